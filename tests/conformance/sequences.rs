//! SetSequence, ReturnToPrimary and StepMode: an excursion on the secondary sequence while
//! the primary one is held, the way back, and a primary sequence that holds after every
//! move.

use std::time::Duration;

use plc_client::{MoveAxesAbsolute, Request};
use shared_types::srci::message::{code, execution_mode, state};
use shared_types::srci::payload::{PayloadReader, PayloadWriter};
use shared_types::srci::tables::{
    move_axes_absolute as maa, return_to_primary as rtp, set_sequence as ss,
};
use shared_types::srci::telegram::status_bit;

use crate::common::{
    HOME, Plc, actual_joints, enabled, execute, expect_done, expect_error, initialized,
    max_deviation, run_until_state, start_slow_move,
};

fn set_sequence(target: u8) -> Request {
    let mut b = vec![0u8; ss::request::LEN];
    PayloadWriter::new(&mut b).set_u8(ss::request::TARGET_SEQUENCE, target);
    Request::Raw {
        command_type: ss::TYPE,
        execution_mode: execution_mode::PARALLEL,
        payload: b.split_off(4),
    }
}

/// A MoveAxesAbsolute to `target` at 50 % on the secondary sequence.
fn secondary_move(target: [f64; 6]) -> Request {
    let mut m = MoveAxesAbsolute::to(target);
    m.velocity_rate = Some(50.0);
    let mut b = Vec::new();
    Request::MoveAxesAbsolute(m).encode(1, &mut b);
    Request::Raw {
        command_type: maa::TYPE,
        execution_mode: execution_mode::SEQUENCE_SECONDARY,
        payload: b.split_off(4),
    }
}

/// ReturnToPrimary, joint-interpolated, rates at default.
fn return_to_primary(enable: bool) -> Request {
    let mut b = vec![0u8; rtp::request::LEN];
    let mut w = PayloadWriter::new(&mut b);
    for f in [
        rtp::request::VELOCITY_RATE,
        rtp::request::ACCELERATION_RATE,
        rtp::request::DECELERATION_RATE,
        rtp::request::JERK_RATE,
    ] {
        w.set_u16(f, 0xFFFF);
    }
    w.set_bit(rtp::request::ENABLE, enable);
    Request::Raw {
        command_type: rtp::TYPE,
        execution_mode: execution_mode::SEQUENCE_PRIMARY,
        payload: b.split_off(4),
    }
}

fn status(plc: &Plc) -> u32 {
    plc.task().status_word()
}

#[test]
fn an_excursion_on_the_secondary_sequence_and_back_to_the_primary_path() {
    let (_c, mut plc) = enabled("seq");
    let target = [50.0, 110.0, 60.0, 70.0, -60.0, 60.0];
    let primary = start_slow_move(&mut plc, target);
    expect_error(&mut plc, &set_sequence(2), code::REQUIRES_INTERRUPT_OR_IDLE);
    expect_error(&mut plc, &secondary_move(HOME), code::SECONDARY_NOT_ACTIVE);
    expect_done(&mut plc, &Request::GroupInterrupt, 4);
    plc.run_until(|t| !t.is_moving(), Duration::from_secs(3))
        .expect("held");
    let left_at = actual_joints(&mut plc);

    expect_done(&mut plc, &set_sequence(2), ss::response::LEN);
    assert_ne!(status(&plc) & status_bit::SECONDARY_SEQUENCE_ACTIVE, 0);
    let mut away = left_at;
    away[0] -= 20.0;
    let s = execute(&mut plc, &secondary_move(away), Duration::from_secs(20));
    assert_eq!((s.state, s.code), (state::DONE, 0), "{s:?}");
    assert!(max_deviation(actual_joints(&mut plc), away) < 0.01);
    plc.run_for(Duration::from_millis(50)).expect("cycles");
    assert_eq!(
        status(&plc) & status_bit::IN_PRIMARY_POS,
        0,
        "away from the primary path"
    );
    expect_done(&mut plc, &set_sequence(1), ss::response::LEN);
    expect_error(
        &mut plc,
        &Request::GroupContinue,
        code::NOT_IN_PRIMARY_POSITION,
    );

    // The way back.
    let h = plc
        .task_mut()
        .submit(&return_to_primary(true))
        .expect("submit");
    let back = run_until_state(&mut plc, h, state::DONE, Duration::from_secs(20));
    assert_eq!((back.state, back.code), (state::DONE, 0), "{back:?}");
    assert_eq!(back.response.len(), rtp::response::LEN);
    let r = PayloadReader::new(&back.response);
    assert_eq!(r.u16(rtp::response::PROGRESS), 10_000);
    assert_eq!(r.u8(rtp::response::PRIMARY_POS_TOOL_NO), 0);
    assert!(max_deviation(actual_joints(&mut plc), left_at) < 0.01);
    plc.run_for(Duration::from_millis(50)).expect("cycles");
    assert_ne!(status(&plc) & status_bit::IN_PRIMARY_POS, 0);

    // The primary sequence continues its move on its own path.
    expect_done(&mut plc, &Request::GroupContinue, 4);
    let done = run_until_state(&mut plc, primary, state::DONE, Duration::from_secs(30));
    assert_eq!((done.state, done.code), (state::DONE, 0), "{done:?}");
    assert!(max_deviation(actual_joints(&mut plc), target) < 0.01);
}

/// A PLC program interrupts a joint move, jogs J2 away without SetSequence(2), and may
/// continue only after ReturnToPrimary brought the arm back: the held move then ends at its
/// target. (A jog used not to count as leaving the primary path: ReturnToPrimary answered
/// DONE where it stood and GroupContinue went on from the jogged position.)
#[test]
fn a_jog_away_from_a_held_move_needs_the_way_back_before_it_continues() {
    let s = &crate::common::run_passing_program(
        "jogaway",
        &(crate::common::FROM_HOME.to_owned()
            + r#"
        [[step]]
        call = "MoveAxesAbsolute"
        joints = [40.0, 90.0, 90.0, 90.0, -90.0, 0.0]
        velocity_rate = 20.0
        wait = "active"
        [[step]]
        call = "GroupInterrupt"
        delay_ms = 300
        [[step]]
        call = "ReadActualPosition"
        [[step]]
        call = "GroupJog"
        enable = true
        mode = 2
        override = 20.0
        y_j2_pos = true
        [[step]]
        call = "GroupJog"
        delay_ms = 300
        enable = false
        [[step]]
        call = "ReadActualPosition"
        delay_ms = 500
        [[step]]
        call = "GroupContinue"
        expect = "ERROR"
        expect_code = 0x8C02
        [[step]]
        call = "ReturnToPrimary"
        enable = true
        [[step]]
        call = "ReadActualPosition"
        [[step]]
        call = "GroupContinue"
        [[step]]
        call = "ReadActualPosition"
        delay_ms = 3000
        "#),
    );
    assert_eq!(s[9].code, code::NOT_IN_PRIMARY_POSITION);
    let left_at = s[5].reached.expect("where the move was held").joints_deg;
    let jogged = s[8].reached.expect("where the jog ended").joints_deg;
    assert!(jogged[1] > left_at[1] + 1.0, "{left_at:?} -> {jogged:?}");
    let back = s[11].reached.expect("after ReturnToPrimary").joints_deg;
    assert!(
        max_deviation(back, left_at) < 0.01,
        "{left_at:?} vs {back:?}"
    );
    assert_eq!(s[3].state, "DONE", "the held move ended");
    let end = s[13].reached.expect("where the move ended").joints_deg;
    assert!(
        max_deviation(end, [40.0, 90.0, 90.0, 90.0, -90.0, 0.0]) < 0.01,
        "{end:?}"
    );
}

#[test]
fn step_mode_holds_the_primary_sequence_after_every_move() {
    let (_c, mut plc) = initialized("step");
    expect_done(&mut plc, &Request::GroupReset, 4);
    plc.task_mut()
        .submit(&Request::enable_robot_step_mode(true, 2))
        .expect("submit");
    plc.run_until(|t| t.is_enabled(), Duration::from_secs(10))
        .expect("enabled in step mode");
    expect_done(
        &mut plc,
        &Request::ChangeSpeedOverride { percent: 100.0 },
        4,
    );
    let first = [10.0, 90.0, 90.0, 90.0, -90.0, 0.0];
    let second = [20.0, 90.0, 90.0, 90.0, -90.0, 0.0];
    let a = plc
        .task_mut()
        .submit(&Request::MoveAxesAbsolute(MoveAxesAbsolute::to(first)))
        .expect("submit");
    let b = plc
        .task_mut()
        .submit(&Request::MoveAxesAbsolute(MoveAxesAbsolute::to(second)))
        .expect("submit");
    let s = run_until_state(&mut plc, a, state::DONE, Duration::from_secs(20));
    assert_eq!(s.state, state::DONE, "{s:?}");
    plc.run_for(Duration::from_millis(300)).expect("cycles");
    assert_ne!(
        status(&plc) & status_bit::PRIMARY_SEQUENCE_PAUSED,
        0,
        "held after the move"
    );
    assert_ne!(
        plc.task().status(b).map(|s| s.state),
        Some(state::DONE),
        "the next move waits"
    );
    assert!(max_deviation(actual_joints(&mut plc), first) < 0.01);
    expect_done(&mut plc, &Request::GroupContinue, 4);
    let s = run_until_state(&mut plc, b, state::DONE, Duration::from_secs(20));
    assert_eq!((s.state, s.code), (state::DONE, 0), "{s:?}");
    assert!(max_deviation(actual_joints(&mut plc), second) < 0.01);
}
