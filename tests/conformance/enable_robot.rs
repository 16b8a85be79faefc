//! EnableRobot (1000), Enable type: power and enable with the simulated delays, Enabled in the
//! response and in StatusRobotArm, disable by update, one instance only, StepMode.

use std::time::{Duration, Instant};

use plc_client::Request;
use plc_client::response::robot_enabled;
use shared_types::srci::message::{code, state};
use shared_types::srci::tables::enable_robot as er;

use crate::common::{execute, expect_error, initialized, run_until_state};

#[test]
fn enable_reports_enabled_then_disable_ends_done() {
    let (_c, mut plc) = initialized("enable");
    assert_eq!(
        execute(&mut plc, &Request::GroupReset, Duration::from_secs(5)).state,
        state::DONE
    );
    let asked = Instant::now();
    let h = plc
        .task_mut()
        .submit(&Request::EnableRobot { enable: true })
        .expect("submit");
    // ACTIVE without Enabled (parameters accepted), then ACTIVE with Enabled.
    let mut seen = Vec::new();
    plc.run_until(
        |t| {
            let s = t.status(h).expect("status");
            let e = (s.state, robot_enabled(&s.response));
            if s.responses > 0 && seen.last() != Some(&e) {
                seen.push(e);
            }
            e == (state::ACTIVE, true) || s.is_final()
        },
        Duration::from_secs(10),
    )
    .expect("enabled");
    let took = asked.elapsed();
    assert_eq!(
        seen,
        [(state::ACTIVE, false), (state::ACTIVE, true)],
        "state sequence"
    );
    assert!(
        took >= Duration::from_millis(450),
        "power-on 300 ms + enable 200 ms: {took:?}"
    );
    let s = plc.task().status(h).cloned().expect("status");
    assert_eq!((s.code, s.response.len()), (0, er::response::LEN));
    assert!(plc.task().is_enabled(), "StatusRobotArm.Enabled");

    // Only one EnableRobot at a time.
    expect_error(
        &mut plc,
        &Request::EnableRobot { enable: true },
        code::ONLY_ONE_INSTANCE,
    );

    // Enable = FALSE by update: ACTIVE, then DONE once the drives are off.
    plc.task_mut()
        .update(h, &Request::EnableRobot { enable: false })
        .expect("disable");
    let s = run_until_state(&mut plc, h, state::DONE, Duration::from_secs(5));
    assert_eq!((s.state, s.code, s.par_seq), (state::DONE, 0, 2), "{s:?}");
    plc.run_for(Duration::from_millis(50)).expect("cycles");
    assert!(!plc.task().is_enabled(), "StatusRobotArm.Enabled cleared");

    // StepMode: 0 DEACTIVATE, 1 BLENDING, 2 EXACT_STOP; others are undefined.
    expect_error(
        &mut plc,
        &Request::enable_robot_step_mode(true, 3),
        code::INVALID_STEP_MODE,
    );
    expect_error(
        &mut plc,
        &Request::Raw {
            command_type: er::TYPE,
            execution_mode: 0,
            payload: vec![1, 0, 0, 0],
        },
        code::INVALID_EXECUTION_MODE,
    );
    // StepMode 0 with Enable TRUE works again after the refusals.
    let h = plc
        .task_mut()
        .submit(&Request::enable_robot_step_mode(true, 0))
        .expect("submit");
    plc.run_until(|t| t.is_enabled(), Duration::from_secs(10))
        .expect("enabled again");
    let s = plc.task().status(h).cloned().expect("status");
    assert_eq!(s.state, state::ACTIVE, "{s:?}");
}

#[test]
fn disabling_during_a_move_holds_it_until_enable_and_group_continue() {
    use crate::common::{actual_joints, cycles_until, expect_done, max_deviation, start_slow_move};
    let (_c, mut plc) = initialized("enmove");
    expect_done(&mut plc, &Request::GroupReset, 4);
    let enable = plc
        .task_mut()
        .submit(&Request::EnableRobot { enable: true })
        .expect("submit");
    plc.run_until(|t| t.is_enabled(), Duration::from_secs(10))
        .expect("enabled");
    let target = [60.0, 120.0, 40.0, 60.0, -40.0, 90.0];
    let m = start_slow_move(&mut plc, target);
    plc.task_mut()
        .update(enable, &Request::EnableRobot { enable: false })
        .expect("switch off");
    let s = run_until_state(&mut plc, enable, state::DONE, Duration::from_secs(5));
    assert_eq!((s.state, s.code), (state::DONE, 0), "switched off: {s:?}");
    // The move is held, not ended: INTERRUPTED with 0x6F02 (interrupted by RA state
    // NOT_ENABLED), no error; after EnableRobot it needs GroupContinue (the SDK's
    // behaviour too).
    let s = run_until_state(&mut plc, m, state::INTERRUPTED, Duration::from_secs(3));
    assert_eq!(
        (s.state, s.code),
        (state::INTERRUPTED, code::INTERRUPTED_NOT_ENABLED),
        "{s:?}"
    );
    assert!(
        cycles_until(&mut plc, |t| !t.is_moving(), Duration::from_secs(2)),
        "the arm stands"
    );
    let here = actual_joints(&mut plc);
    assert!(max_deviation(here, target) > 1.0, "short of the target");
    assert_eq!(
        plc.task().status_word() & shared_types::srci::telegram::status_bit::ERROR_PENDING,
        0,
        "switching off is no error"
    );
    plc.task_mut()
        .submit(&Request::EnableRobot { enable: true })
        .expect("submit");
    plc.run_until(|t| t.is_enabled(), Duration::from_secs(10))
        .expect("enabled again");
    expect_done(&mut plc, &Request::GroupContinue, 4);
    let s = run_until_state(&mut plc, m, state::DONE, Duration::from_secs(30));
    assert_eq!(
        (s.state, s.code),
        (state::DONE, 0),
        "the held move finishes: {s:?}"
    );
    assert!(max_deviation(actual_joints(&mut plc), target) < 0.01);
}
