//! ExchangeConfiguration (9000), Enable type: LifeSignTimeOut, LengthACR, highest indices and
//! change indices.

use std::time::Duration;

use plc_client::response::Configuration;
use plc_client::{EngineOptions, Request};
use shared_types::srci::message::{code, severity, state};
use shared_types::srci::payload::PayloadReader;
use shared_types::srci::tables::exchange_configuration as xc;

use crate::common::{
    Controller, exchange_configuration, execute, expect_error, initialize, plc_options,
    run_until_state, wait_for_message,
};

#[test]
fn configuration_is_reported_and_lifesign_timeout_is_raised_to_10_ms() {
    let c = Controller::start("xconf");
    // A 2 ms cycle keeps the PLC lifesign well inside the 10 ms the robot will supervise.
    let mut plc = c.client_with(EngineOptions {
        cycle_time: Duration::from_millis(2),
        message_level: severity::INFO as u8,
        ..plc_options()
    });
    initialize(&mut plc);
    let start_up = *plc.task().configuration().expect("start-up configuration");
    assert!(start_up.enabled);
    assert_eq!(start_up.length_acr, 50, "acr_length of the configuration");
    assert_eq!(
        (
            start_up.highest_tool_index,
            start_up.highest_frame_index,
            start_up.highest_load_index
        ),
        (15, 15, 15)
    );

    // A second instance with 5 ms: ACTIVE with info 0x6001, raised to 10 ms.
    let handle = plc
        .task_mut()
        .submit(&exchange_configuration(true, 5))
        .expect("submit");
    let s = run_until_state(&mut plc, handle, state::ACTIVE, Duration::from_secs(5));
    assert_eq!(
        (s.state, s.severity, s.code),
        (state::ACTIVE, severity::INFO, code::LIFESIGN_RAISED),
        "{s:?}"
    );
    assert_eq!(s.response.len(), xc::response::LEN);
    let r = PayloadReader::new(&s.response);
    assert!(r.bit(xc::response::ENABLED));
    assert_eq!(r.u16(xc::response::LENGTH_ACR), 50);
    assert_eq!(
        r.u8(xc::response::HIGHEST_WORK_AREA_INDEX),
        0,
        "no work areas"
    );
    assert_eq!(Configuration::decode(&s.response), start_up);
    let m = wait_for_message(&mut plc, code::LIFESIGN_RAISED);
    assert_eq!(m.severity, severity::INFO);

    // An update with 200 ms is accepted without a code; Enable = FALSE ends it DONE.
    plc.task_mut()
        .update(handle, &exchange_configuration(true, 200))
        .expect("update");
    plc.run_until(
        |t| t.status(handle).is_some_and(|s| s.par_seq == 2),
        Duration::from_secs(2),
    )
    .expect("update answered");
    let s = plc.task().status(handle).cloned().expect("status");
    assert_eq!((s.state, s.code), (state::ACTIVE, 0), "{s:?}");
    plc.task_mut()
        .update(handle, &exchange_configuration(false, 200))
        .expect("disable");
    let s = run_until_state(&mut plc, handle, state::DONE, Duration::from_secs(2));
    assert_eq!((s.state, s.code, s.par_seq), (state::DONE, 0, 3), "{s:?}");

    // With 200 ms the robot tolerates a PLC pause of 100 ms.
    let handle = plc
        .task_mut()
        .submit(&exchange_configuration(true, 200))
        .expect("submit");
    run_until_state(&mut plc, handle, state::ACTIVE, Duration::from_secs(5));
    plc.task_mut().set_lifesign_frozen(true);
    plc.run_for(Duration::from_millis(100)).expect("cycles");
    plc.task_mut().set_lifesign_frozen(false);
    plc.run_for(Duration::from_millis(50)).expect("cycles");
    assert_eq!(
        plc.task().telegram_state(),
        shared_types::srci::telegram::telegram_state::INITIALIZED,
        "no lifesign timeout within LifeSignTimeOut"
    );

    expect_error(
        &mut plc,
        &Request::Raw {
            command_type: xc::TYPE,
            execution_mode: 0,
            payload: Vec::new(),
        },
        code::INVALID_EXECUTION_MODE,
    );
    let s = execute(&mut plc, &Request::ReadRobotData, Duration::from_secs(5));
    assert_eq!(s.state, state::DONE, "the session still runs");
}

/// StatusRobotArm bits 15..17 (Accelerating, Decelerating, ConstantVelocity) are reported
/// "if supported, see ExchangeConfiguration": a robot that sets them must announce them.
#[test]
fn status_bits_in_use_are_announced_as_supported() {
    use crate::common::{HOME, enabled, move_to};
    use shared_types::srci::telegram::status_bit;
    let (_c, mut plc) = enabled("xsupp");
    let h = plc
        .task_mut()
        .submit(&plc_client::Request::MoveAxesAbsolute(
            plc_client::MoveAxesAbsolute::to([40.0, 90.0, 90.0, 90.0, -90.0, 0.0]),
        ))
        .expect("submit");
    let mut seen = 0u32;
    plc.run_until(
        |t| {
            seen |= t.status_word();
            t.status(h).is_some_and(|s| s.is_final())
        },
        Duration::from_secs(10),
    )
    .expect("move ends");
    assert!(move_to(&mut plc, HOME, 100.0) < 0.01);
    let handle = plc
        .task_mut()
        .submit(&exchange_configuration(true, 50))
        .expect("submit");
    let s = run_until_state(&mut plc, handle, state::ACTIVE, Duration::from_secs(3));
    let r = PayloadReader::new(&s.response);
    for (bit, announced, name) in [
        (
            status_bit::ACCELERATING,
            xc::response::ACCELERATING_SUPPORTED,
            "AcceleratingSupported",
        ),
        (
            status_bit::DECELERATING,
            xc::response::DECCELERATING_SUPPORTED,
            "DeceleratingSupported",
        ),
        (
            status_bit::CONSTANT_VELOCITY,
            xc::response::CONSTANT_VELOCITY_SUPPORTED,
            "ConstantVelocitySupported",
        ),
    ] {
        if seen & bit != 0 {
            // StatusRobotArm reports the bit during moves, so the ExchangeConfiguration
            // response (table 6-87, bytes 22/23) must announce it.
            assert!(
                r.bit(announced),
                "StatusRobotArm uses bit 0x{bit:X}, so {name} must be set"
            );
        }
    }
    assert_ne!(seen & status_bit::ACCELERATING, 0, "a move accelerates");
}
