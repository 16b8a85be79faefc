//! GroupReset (1001): acknowledges errors in every service; DONE once the planner confirms.

use std::time::Duration;

use plc_client::Request;
use shared_types::srci::message::{code, state};
use shared_types::srci::tables::group_reset as gr;
use shared_types::srci::telegram::status_bit;

use crate::common::{expect_done, expect_error, initialized, reset_and_enable, state_trace};

#[test]
fn group_reset_runs_to_done_and_keeps_the_robot_enabled() {
    let (_c, mut plc) = initialized("greset");
    let (states, s) = state_trace(&mut plc, &Request::GroupReset, Duration::from_secs(5));
    assert_eq!((s.state, s.code), (state::DONE, 0), "{s:?}");
    assert_eq!(s.response.len(), gr::response::LEN, "header only");
    assert!(
        states
            .iter()
            .all(|&st| st == state::ACTIVE || st == state::BUFFERED || st == state::DONE),
        "{states:?}"
    );
    assert_eq!(states.last(), Some(&state::DONE));
    reset_and_enable(&mut plc);
    expect_done(&mut plc, &Request::GroupReset, gr::response::LEN);
    plc.run_for(Duration::from_millis(50)).expect("cycles");
    let status = plc.task().status_word();
    assert_ne!(status & status_bit::ENABLED, 0, "still enabled");
    assert_eq!(status & status_bit::ERROR_PENDING, 0, "no error pending");
    expect_error(
        &mut plc,
        &Request::Raw {
            command_type: gr::TYPE,
            execution_mode: 0,
            payload: Vec::new(),
        },
        code::INVALID_EXECUTION_MODE,
    );
}

#[test]
fn errors_block_enable_and_moves_until_group_reset() {
    use crate::common::{HOME, cycles_until, move_to};
    use plc_client::MoveAxesAbsolute;
    let (c, mut plc) = initialized("gresete");
    reset_and_enable(&mut plc);
    // A restarted drive process is an arm error: drives off, ErrorPending.
    let servo = c.pid_of("servo").expect("servo pid");
    // SAFETY: kill(2) on the servo process of our own controller.
    assert_eq!(unsafe { libc::kill(servo as i32, libc::SIGKILL) }, 0);
    assert!(
        cycles_until(
            &mut plc,
            |t| t.status_word() & status_bit::ERROR_PENDING != 0,
            Duration::from_secs(10)
        ),
        "StatusRobotArm.ErrorPending after the drive error"
    );
    plc.run_for(Duration::from_millis(300)).expect("cycles");
    assert!(!plc.task().is_enabled(), "drives off");
    expect_error(
        &mut plc,
        &Request::EnableRobot { enable: true },
        code::DISABLED_DUE_TO_ERROR,
    );
    expect_error(
        &mut plc,
        &Request::MoveAxesAbsolute(MoveAxesAbsolute::to(HOME)),
        code::DISABLED_DUE_TO_ERROR,
    );
    expect_error(
        &mut plc,
        &Request::GroupContinue,
        code::DISABLED_DUE_TO_ERROR,
    );
    expect_done(&mut plc, &Request::GroupReset, gr::response::LEN);
    plc.run_for(Duration::from_millis(30)).expect("cycles");
    assert_eq!(
        plc.task().status_word() & status_bit::ERROR_PENDING,
        0,
        "ErrorPending cleared by GroupReset"
    );
    reset_and_enable(&mut plc);
    assert!(move_to(&mut plc, [5.0, 90.0, 90.0, 90.0, -90.0, 0.0], 100.0) < 0.01);
}
