//! ReadMessages (9001), Enable type: one message at a time, acknowledged by MsgID, filtered by
//! MessageLevel, with the active error and warning counts.

use std::time::{Duration, SystemTime, UNIX_EPOCH};

use plc_client::{CommandHandle, EngineOptions, Request};
use shared_types::srci::message::{code, iec_date_time, severity, state};
use shared_types::srci::payload::PayloadReader;
use shared_types::srci::tables::read_messages as rm;

use crate::common::{Controller, Plc, execute, initialize, plc_options, run_until_state};

/// The last response of `handle` once `done` holds for it.
fn response_when(
    plc: &mut Plc,
    handle: CommandHandle,
    done: impl Fn(&PayloadReader) -> bool,
) -> Vec<u8> {
    plc.run_until(
        |t| {
            t.status(handle)
                .is_some_and(|s| done(&PayloadReader::new(&s.response)))
        },
        Duration::from_secs(3),
    )
    .unwrap_or_else(|e| {
        panic!(
            "no such ReadMessages response: {e}; last {:?}",
            plc.task().status(handle)
        )
    });
    plc.task().status(handle).expect("status").response.clone()
}

/// Raises a command error with `code` by sending a request the robot refuses.
fn raise(plc: &mut Plc, request: &Request, expected: u16) {
    let s = execute(plc, request, Duration::from_secs(5));
    assert_eq!((s.state, s.code), (state::ERROR, expected), "{s:?}");
}

#[test]
fn messages_are_delivered_one_at_a_time_and_acknowledged_by_msg_id() {
    let c = Controller::start("rmsg");
    // The RobotTask's own ReadMessages asks for FATAL_ERROR only, so it acknowledges nothing
    // this test looks at.
    let mut plc = c.client_with(EngineOptions {
        message_level: severity::FATAL_ERROR as u8,
        ..plc_options()
    });
    initialize(&mut plc);
    let level = severity::ERROR as u8;
    let h = plc
        .task_mut()
        .submit(&Request::ReadMessages {
            msg_id: 0,
            message_level: level,
        })
        .expect("submit");
    let s = run_until_state(&mut plc, h, state::ACTIVE, Duration::from_secs(3));
    assert_eq!((s.state, s.code), (state::ACTIVE, 0));
    assert_eq!(s.response.len(), rm::response::LEN);
    let r = PayloadReader::new(&s.response);
    assert!(r.bit(rm::response::ENABLED));
    assert_eq!(r.u8(rm::response::MSG_ID), 0, "no error yet");
    assert_eq!(r.u8(rm::response::NUMBER_OF_ACTIVE_ERRORS), 0);

    let unsupported = crate::common::unimplemented_request();
    raise(&mut plc, &unsupported, code::NOT_IMPLEMENTED);
    let b = response_when(&mut plc, h, |r| r.u8(rm::response::MSG_ID) != 0);
    let r = PayloadReader::new(&b);
    let first = r.u8(rm::response::MSG_ID);
    assert_eq!(r.u32(rm::response::ERROR_CODE), 0x8F11, "DWORD ErrorCode");
    assert_eq!(r.i8(rm::response::SEVERITY), severity::ERROR);
    assert_eq!(r.u8(rm::response::MSG_TYPE), 4, "MsgType CMD");
    assert_eq!(r.u8(rm::response::NUMBER_OF_ACTIVE_ERRORS), 1);
    let unix_ms = SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .expect("clock")
        .as_millis() as u64;
    let (date, time) = iec_date_time(unix_ms);
    assert_eq!(r.u16(rm::response::DATE), date, "IEC DATE of today");
    let stamped = r.u32(rm::response::TIME);
    assert!(
        time.abs_diff(stamped) < 10_000 || time < 10_000,
        "TIME_OF_DAY {stamped} vs now {time}"
    );
    let text = &b[rm::response::TEXT.offset..rm::response::TEXT.offset + 150];
    assert!(text[0] != 0, "a text");

    // A second error waits behind the first until that is acknowledged.
    let too_fast = Request::ChangeSpeedOverride { percent: 100.01 };
    raise(&mut plc, &too_fast, code::INVALID_OVERRIDE);
    let b = response_when(&mut plc, h, |r| {
        r.u8(rm::response::NUMBER_OF_ACTIVE_ERRORS) == 2
    });
    assert_eq!(
        PayloadReader::new(&b).u8(rm::response::MSG_ID),
        first,
        "one at a time"
    );
    plc.task_mut()
        .update(
            h,
            &Request::ReadMessages {
                msg_id: first,
                message_level: level,
            },
        )
        .expect("acknowledge");
    let b = response_when(&mut plc, h, |r| {
        let id = r.u8(rm::response::MSG_ID);
        id != 0 && id != first
    });
    let r = PayloadReader::new(&b);
    let second = r.u8(rm::response::MSG_ID);
    assert_eq!(
        r.u32(rm::response::ERROR_CODE),
        u32::from(code::INVALID_OVERRIDE)
    );
    assert_eq!(b[0] >> 4, 2, "the response echoes ParSeq 2");
    plc.task_mut()
        .update(
            h,
            &Request::ReadMessages {
                msg_id: second,
                message_level: level,
            },
        )
        .expect("acknowledge");
    let b = response_when(&mut plc, h, |r| r.u8(rm::response::MSG_ID) == 0);
    assert_eq!(
        PayloadReader::new(&b).u8(rm::response::NUMBER_OF_ACTIVE_ERRORS),
        2,
        "errors stay active until GroupReset"
    );

    // GroupReset clears the active counts.
    let reset = execute(&mut plc, &Request::GroupReset, Duration::from_secs(5));
    assert_eq!(reset.state, state::DONE);
    let b = response_when(&mut plc, h, |r| {
        r.u8(rm::response::NUMBER_OF_ACTIVE_ERRORS) == 0
    });
    assert_eq!(PayloadReader::new(&b).u8(rm::response::MSG_ID), 0);

    // Enable = FALSE (byte 5 bit 0, as the PLC libraries send it) ends the command DONE.
    plc.task_mut()
        .update(
            h,
            &Request::Raw {
                command_type: rm::TYPE,
                execution_mode: 2,
                payload: vec![0, 0, level],
            },
        )
        .expect("disable");
    let s = run_until_state(&mut plc, h, state::DONE, Duration::from_secs(3));
    assert_eq!((s.state, s.code), (state::DONE, 0), "{s:?}");

    // MessageLevel must be a severity.
    let s = execute(
        &mut plc,
        &Request::ReadMessages {
            msg_id: 0,
            message_level: 7,
        },
        Duration::from_secs(3),
    );
    assert_eq!(
        (s.state, s.code),
        (state::ERROR, code::INVALID_MODE),
        "{s:?}"
    );
}
