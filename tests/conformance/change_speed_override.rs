//! ChangeSpeedOverride (2000): the override in the robot header and the pace of moves.

use std::time::Duration;

use plc_client::{MoveAxesAbsolute, Request};
use shared_types::srci::message::{code, state};
use shared_types::srci::tables::change_speed_override as cso;

use crate::common::{
    HOME, Plc, actual_joints, cycles_until, enabled, execute, expect_done, expect_error,
    max_deviation, run_until_state,
};

fn set_override(plc: &mut Plc, percent: f64) {
    expect_done(
        plc,
        &Request::ChangeSpeedOverride { percent },
        cso::response::LEN,
    );
}

/// The duration of a DONE move to `target` (engine time from ACTIVE to DONE).
fn move_time(plc: &mut Plc, target: [f64; 6]) -> Duration {
    let s = execute(
        plc,
        &Request::MoveAxesAbsolute(MoveAxesAbsolute::to(target)),
        Duration::from_secs(20),
    );
    assert_eq!((s.state, s.code), (state::DONE, 0), "{s:?}");
    s.final_at.expect("final") - s.submitted_at
}

#[test]
fn override_is_reported_and_retimes_moves() {
    let (_c, mut plc) = enabled("override");
    set_override(&mut plc, 37.5);
    plc.run_for(Duration::from_millis(30)).expect("cycles");
    assert_eq!(
        plc.task().robot_header().expect("header").override_centi,
        3750,
        "header Override in percent x 100"
    );
    set_override(&mut plc, 100.0);
    let away = [30.0, 90.0, 90.0, 90.0, -90.0, 0.0];
    let full = move_time(&mut plc, away);
    set_override(&mut plc, 50.0);
    let half = move_time(&mut plc, HOME);
    let ratio = half.as_secs_f64() / full.as_secs_f64();
    assert!(
        (1.6..2.4).contains(&ratio),
        "50 % takes about twice as long: {full:?} vs {half:?}"
    );

    // 0 % holds moves: a move waits and runs once the override is raised.
    set_override(&mut plc, 0.0);
    let h = plc
        .task_mut()
        .submit(&Request::MoveAxesAbsolute(MoveAxesAbsolute::to(away)))
        .expect("submit");
    plc.run_for(Duration::from_millis(400)).expect("cycles");
    assert!(!plc.task().is_moving(), "no motion at 0 %");
    assert!(!plc.task().status(h).expect("status").is_final());
    set_override(&mut plc, 100.0);
    let s = run_until_state(&mut plc, h, state::DONE, Duration::from_secs(10));
    assert_eq!((s.state, s.code), (state::DONE, 0), "{s:?}");

    // 0 % during a move holds the arm on its path; the move stays ACTIVE and finishes at
    // its target once the override is back.
    let mut slow = MoveAxesAbsolute::to(HOME);
    slow.velocity_rate = Some(20.0);
    let h = plc
        .task_mut()
        .submit(&Request::MoveAxesAbsolute(slow))
        .expect("submit");
    run_until_state(&mut plc, h, state::ACTIVE, Duration::from_secs(3));
    plc.run_for(Duration::from_millis(200)).expect("moving");
    set_override(&mut plc, 0.0);
    assert!(
        cycles_until(&mut plc, |t| !t.is_moving(), Duration::from_secs(2)),
        "held at 0 %"
    );
    let held = actual_joints(&mut plc);
    plc.run_for(Duration::from_millis(200)).expect("cycles");
    let s = plc.task().status(h).cloned().expect("status");
    assert_eq!(s.state, state::ACTIVE, "still ACTIVE while held: {s:?}");
    assert!(max_deviation(held, actual_joints(&mut plc)) < 1e-3);
    assert!(max_deviation(held, HOME) > 1.0, "held on the way");
    set_override(&mut plc, 100.0);
    let s = run_until_state(&mut plc, h, state::DONE, Duration::from_secs(10));
    assert_eq!((s.state, s.code), (state::DONE, 0), "{s:?}");
    assert!(max_deviation(actual_joints(&mut plc), HOME) < 0.01);

    expect_error(
        &mut plc,
        &Request::ChangeSpeedOverride { percent: 100.01 },
        code::INVALID_OVERRIDE,
    );
    expect_error(
        &mut plc,
        &Request::Raw {
            command_type: cso::TYPE,
            execution_mode: 2,
            payload: vec![0xFF, 0xFF],
        },
        code::INVALID_OVERRIDE,
    );
    expect_error(
        &mut plc,
        &Request::Raw {
            command_type: cso::TYPE,
            execution_mode: 0,
            payload: vec![0x13, 0x88],
        },
        code::INVALID_EXECUTION_MODE,
    );
    assert_eq!(
        plc.task().robot_header().expect("header").override_centi,
        10_000,
        "refused values leave the override"
    );
}
