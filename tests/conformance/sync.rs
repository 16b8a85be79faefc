//! Data synchronisation (SYNC) in ExchangeConfiguration: DataInSync follows the PLC's bits
//! and the controller's DataChanged, and SyncReaction keeps the robot from being enabled
//! while the data is not synchronized.

use std::time::Duration;

use plc_client::Request;
use plc_client::request::SwLimits;
use shared_types::srci::message::{code, execution_mode, severity, state};
use shared_types::srci::payload::{PayloadReader, PayloadWriter};
use shared_types::srci::tables::{exchange_configuration as xc, write_robot_sw_limits as wsl};

use crate::common::{Plc, expect_done, expect_error, initialized, run_until_state};

/// ExchangeConfiguration synchronising the SW limits, held in sync by the PLC, with
/// SyncReaction `reaction`.
fn syncing_sw_limits(reaction: u8) -> Request {
    let mut b = vec![0u8; xc::request::LEN];
    let mut w = PayloadWriter::new(&mut b);
    w.set_bit(xc::request::ENABLE, true);
    w.set_u8(xc::request::LOG_LEVEL, severity::INFO as u8);
    w.set_u16(xc::request::LIFE_SIGN_TIME_OUT, 1000);
    w.set_bit(xc::request::ENABLE_SYNC_SW_LIMITS, true);
    w.set_bit(xc::request::SW_LIMITS_IN_SYNC_CLIENT, true);
    w.set_u8(xc::request::SYNC_REACTION, reaction);
    Request::Raw {
        command_type: xc::TYPE,
        execution_mode: execution_mode::PARALLEL,
        payload: b.split_off(4),
    }
}

/// Runs until the live ExchangeConfiguration `h` reports SW limits in sync as `wanted`.
fn until_sw_limits_in_sync(plc: &mut Plc, h: plc_client::CommandHandle, wanted: bool) {
    plc.run_until(
        |t| {
            t.status(h).is_some_and(|s| {
                !s.response.is_empty()
                    && PayloadReader::new(&s.response).bit(xc::response::SW_LIMITS) == wanted
            })
        },
        Duration::from_secs(3),
    )
    .unwrap_or_else(|e| panic!("SW limits DataInSync = {wanted}: {e}"));
}

#[test]
fn data_in_sync_follows_data_changed_and_sync_reaction_denies_enabling() {
    let (_c, mut plc) = initialized("sync");
    let h = plc
        .task_mut()
        .submit(&syncing_sw_limits(1))
        .expect("submit");
    let s = run_until_state(&mut plc, h, state::ACTIVE, Duration::from_secs(3));
    let r = PayloadReader::new(&s.response);
    assert!(r.bit(xc::response::SW_LIMITS), "SW limits in sync");
    assert!(!r.bit(xc::response::TOOL), "tools are not synchronised");

    // The limits go back to the factory values: the PLC did not write those (DataChanged),
    // and the live ExchangeConfiguration says so by itself.
    let read = expect_done(
        &mut plc,
        &Request::read_sw_limits(),
        shared_types::srci::tables::read_robot_sw_limits::response::LEN,
    );
    let limits = plc_client::response::sw_limits(&read.response).data;
    expect_done(
        &mut plc,
        &Request::write_sw_limits(&limits, true),
        wsl::response::LEN,
    );
    until_sw_limits_in_sync(&mut plc, h, false);
    expect_error(
        &mut plc,
        &Request::EnableRobot { enable: true },
        code::NOT_SYNCHRONIZED,
    );

    // The PLC writes its limits: in sync again, and the robot can be enabled.
    let narrowed = SwLimits {
        lower_deg: limits.lower_deg.map(|v| v + 1.0),
        ..limits
    };
    expect_done(
        &mut plc,
        &Request::write_sw_limits(&narrowed, false),
        wsl::response::LEN,
    );
    until_sw_limits_in_sync(&mut plc, h, true);
    let enable = plc
        .task_mut()
        .submit(&Request::EnableRobot { enable: true })
        .expect("submit");
    plc.run_until(|t| t.is_enabled(), Duration::from_secs(10))
        .expect("enabled once synchronized");
    assert_eq!(
        plc.task().status(enable).map(|s| s.state),
        Some(state::ACTIVE)
    );

    // An undefined SyncReaction.
    expect_error(&mut plc, &syncing_sw_limits(9), code::INVALID_SYNC_REACTION);
}
