//! RobotTask: the interface start-up (254 → INITIALIZE → 255) and the header checks of
//! INITIALIZE.

use std::time::Duration;

use plc_client::EngineOptions;
use shared_types::srci::telegram::{status_bit, telegram_state as ts};

use crate::common::{Controller, cycles_until, initialize, plc_options};

/// A client with `options` runs until the robot reports `wanted`.
fn refused_with(c: &Controller, options: EngineOptions, wanted: u8) {
    let mut plc = c.client_with(options.clone());
    assert!(
        cycles_until(
            &mut plc,
            |t| t.telegram_state() == wanted,
            Duration::from_secs(2)
        ),
        "TelegramState {wanted} for {options:?}"
    );
    assert!(
        !cycles_until(
            &mut plc,
            |t| t.telegram_state() == ts::INITIALIZED,
            Duration::from_millis(300)
        ),
        "never INITIALIZED"
    );
}

#[test]
fn start_up_initializes_and_initialize_checks_the_header() {
    let c = Controller::start("rtask");
    let defaults = plc_options();
    refused_with(
        &c,
        EngineOptions {
            axes_group: 2,
            ..defaults.clone()
        },
        ts::INVALID_AXES_GROUP,
    );
    refused_with(
        &c,
        EngineOptions {
            version: 0x45, // 2.5
            ..defaults.clone()
        },
        ts::MAJOR_VERSION,
    );
    refused_with(
        &c,
        EngineOptions {
            header_lengths: Some((256, 128)),
            ..defaults.clone()
        },
        ts::LENGTH_MISMATCH,
    );

    // A single arm answers to AxesGroupID 1 (the specification) and 0 (what clients send).
    let mut plc = c.client_with(EngineOptions {
        axes_group: 1,
        ..defaults.clone()
    });
    initialize(&mut plc);
    drop(plc);

    let mut plc = c.client();
    initialize(&mut plc);
    let task = plc.task();
    assert_eq!(task.telegram_state(), ts::INITIALIZED);
    let header = *task.robot_header().expect("robot header");
    assert_eq!(header.version.major, 1, "SRCI major version 1");
    assert_eq!(header.override_centi, 10_000, "initial override 100 %");
    let mode = (header.status >> status_bit::OPERATION_MODE_SHIFT) & 0b111;
    assert_eq!(mode, 4, "OperationMode AUTO_EXT");
    assert_eq!(header.status & status_bit::ENABLED, 0, "not enabled yet");
    assert_eq!(header.status & status_bit::ERROR_PENDING, 0, "no error");
    assert!(task.configuration().is_some_and(|c| c.enabled));
    assert!(task.robot_data().is_some());

    // The robot lifesign counts on with every telegram.
    let mut seen = Vec::new();
    for _ in 0..6 {
        plc.step().expect("cycle");
        seen.push(plc.task().robot_header().expect("header").lifesign);
    }
    assert!(
        seen.windows(2).all(|w| w[0] != w[1]),
        "robot lifesign changes every telegram: {seen:?}"
    );
}
