//! GroupJog (2100), Enable type, in joint, frame and tool mode: continuous and incremental
//! jogging, Enabled, MotionActive and DistanceReached, and the refusals.

use std::time::Duration;

use plc_client::response::JogStatus;
use plc_client::{GroupJog, MoveAxesAbsolute, Request};
use shared_types::srci::message::{code, state};
use shared_types::srci::tables::group_jog as gj;

use crate::common::{
    HOME, Plc, actual_joints, cycles_until, expect_error, initialized, max_deviation,
    reset_and_enable, run_until_state,
};

fn jog_status(plc: &Plc, h: plc_client::CommandHandle) -> JogStatus {
    JogStatus::decode(&plc.task().status(h).expect("status").response)
}

#[test]
fn incremental_and_continuous_jogging_in_joint_mode() {
    let (_c, mut plc) = initialized("jog");
    let jog = GroupJog::axes(30.0);
    expect_error(
        &mut plc,
        &jog.pressing(0, 1).request(),
        code::ROBOT_DISABLED,
    );
    reset_and_enable(&mut plc);

    // Enabled, no key: ACTIVE with Enabled, not moving.
    let h = plc.task_mut().submit(&jog.request()).expect("submit");
    let s = run_until_state(&mut plc, h, state::ACTIVE, Duration::from_secs(3));
    assert_eq!((s.state, s.code), (state::ACTIVE, 0), "{s:?}");
    assert_eq!(s.response.len(), gj::response::LEN);
    assert_eq!(
        jog_status(&plc, h),
        JogStatus {
            enabled: true,
            distance_reached: false,
            motion_active: false
        }
    );

    // Incremental: J3 by -5 degrees, then DistanceReached.
    let before = actual_joints(&mut plc);
    let mut step = jog.pressing(2, -1);
    step.incremental_rotation = 5.0;
    plc.task_mut().update(h, &step.request()).expect("update");
    plc.run_until(
        |t| {
            t.status(h)
                .is_some_and(|s| JogStatus::decode(&s.response).distance_reached || s.is_final())
        },
        Duration::from_secs(5),
    )
    .expect("distance reached");
    let st = jog_status(&plc, h);
    assert!(
        st.enabled && st.distance_reached && !st.motion_active,
        "{st:?}"
    );
    let after = actual_joints(&mut plc);
    assert!(
        (after[2] - (before[2] - 5.0)).abs() < 0.01,
        "{before:?} -> {after:?}"
    );

    // Continuous: J1 positive while pressed, MotionActive while moving.
    plc.task_mut()
        .update(h, &jog.pressing(0, 1).request())
        .expect("press");
    plc.run_until(
        |t| {
            t.status(h)
                .is_some_and(|s| JogStatus::decode(&s.response).motion_active)
        },
        Duration::from_secs(2),
    )
    .expect("MotionActive");
    plc.run_for(Duration::from_millis(300)).expect("jogging");
    plc.task_mut().update(h, &jog.request()).expect("release");
    assert!(
        cycles_until(&mut plc, |t| !t.is_moving(), Duration::from_secs(2)),
        "stops when released"
    );
    plc.run_until(
        |t| {
            t.status(h)
                .is_some_and(|s| !JogStatus::decode(&s.response).motion_active)
        },
        Duration::from_secs(2),
    )
    .expect("MotionActive cleared");
    let jogged = actual_joints(&mut plc);
    assert!(jogged[0] > after[0] + 1.0, "J1 moved positive");

    // Enable = FALSE ends the jog DONE.
    let mut off = jog.clone();
    off.enable = false;
    plc.task_mut().update(h, &off.request()).expect("disable");
    let s = run_until_state(&mut plc, h, state::DONE, Duration::from_secs(3));
    assert_eq!((s.state, s.code), (state::DONE, 0), "{s:?}");

    // Refusals.
    let mut both = jog.pressing(1, 1);
    both.negative[1] = true;
    expect_error(&mut plc, &both.request(), code::JOG_BOTH_DIRECTIONS);
    let mut fast = jog.pressing(0, 1);
    fast.override_percent = Some(100.01);
    expect_error(&mut plc, &fast.request(), code::INVALID_OVERRIDE);
    let mut backwards = jog.pressing(0, 1);
    backwards.incremental_rotation = -1.0;
    expect_error(
        &mut plc,
        &backwards.request(),
        code::INVALID_INCREMENTAL_ROTATION,
    );
    let mut undefined = jog.pressing(0, 1);
    undefined.mode = 3;
    expect_error(&mut plc, &undefined.request(), code::INVALID_MODE);
    let mut sequence = jog.clone();
    sequence.execution_mode = 0;
    expect_error(&mut plc, &sequence.request(), code::INVALID_EXECUTION_MODE);

    // No jogging during a move.
    let mut slow = MoveAxesAbsolute::to(HOME);
    slow.velocity_rate = Some(10.0);
    let m = plc
        .task_mut()
        .submit(&Request::MoveAxesAbsolute(slow))
        .expect("submit");
    run_until_state(&mut plc, m, state::ACTIVE, Duration::from_secs(3));
    expect_error(
        &mut plc,
        &jog.pressing(4, 1).request(),
        code::JOG_DURING_MOTION,
    );
    let s = run_until_state(&mut plc, m, state::DONE, Duration::from_secs(30));
    assert_eq!(s.state, state::DONE);
    assert!(max_deviation(actual_joints(&mut plc), HOME) < 0.01);
}

#[test]
fn group_stop_ends_a_running_jog_motion() {
    use crate::common::{enabled, expect_done};
    let (_c, mut plc) = enabled("jogstop");
    let jog = GroupJog::axes(20.0);
    let h = plc
        .task_mut()
        .submit(&jog.pressing(5, 1).request())
        .expect("submit");
    plc.run_until(
        |t| {
            t.status(h)
                .is_some_and(|s| JogStatus::decode(&s.response).motion_active)
        },
        Duration::from_secs(3),
    )
    .expect("jogging");
    expect_done(
        &mut plc,
        &Request::GroupStop,
        shared_types::srci::tables::group_stop::response::LEN,
    );
    assert!(
        cycles_until(&mut plc, |t| !t.is_moving(), Duration::from_secs(1)),
        "GroupStop stops the jog motion"
    );
    plc.run_for(Duration::from_millis(100)).expect("cycles");
    let s = plc.task().status(h).cloned().expect("status");
    assert!(
        s.is_final() || !JogStatus::decode(&s.response).motion_active,
        "the jog reports no motion any more: {s:?}"
    );
}

/// GroupInterrupt holds the primary sequence so that the secondary one can move the arm:
/// jogging is allowed while a move is interrupted.
#[test]
fn jogging_while_the_primary_sequence_is_interrupted() {
    use crate::common::{enabled, expect_done, start_slow_move};
    use shared_types::srci::tables::group_interrupt as gi;
    let (_c, mut plc) = enabled("jogint");
    let m = start_slow_move(&mut plc, [50.0, 110.0, 60.0, 80.0, -70.0, 30.0]);
    expect_done(&mut plc, &Request::GroupInterrupt, gi::response::LEN);
    run_until_state(&mut plc, m, state::INTERRUPTED, Duration::from_secs(2));
    assert!(cycles_until(
        &mut plc,
        |t| !t.is_moving(),
        Duration::from_secs(1)
    ));
    let before = actual_joints(&mut plc);
    let mut step = GroupJog::axes(30.0).pressing(5, 1);
    step.incremental_rotation = 3.0;
    let h = plc.task_mut().submit(&step.request()).expect("submit");
    plc.run_until(
        |t| {
            t.status(h)
                .is_some_and(|s| s.is_final() || JogStatus::decode(&s.response).distance_reached)
        },
        Duration::from_secs(5),
    )
    .expect("jog answered");
    let s = plc.task().status(h).cloned().expect("status");
    // The interrupted move is held, not in progress: jogging (the secondary sequence)
    // moves the arm meanwhile.
    assert_eq!(
        (s.state, s.code),
        (state::ACTIVE, 0),
        "jogging must be possible while the primary sequence is interrupted: {s:?}"
    );
    let after = actual_joints(&mut plc);
    assert!(
        (after[5] - before[5] - 3.0).abs() < 0.01,
        "{before:?} -> {after:?}"
    );
}

/// The TCP (tool 0, world frame): X, Y, Z in mm, RX, RY, RZ in degrees.
fn flange(plc: &mut crate::common::Plc) -> [f64; 6] {
    let s = crate::common::expect_done(
        plc,
        &Request::ReadActualPosition { tool: 0, frame: 0 },
        shared_types::srci::tables::read_actual_position::response::LEN,
    );
    plc_client::response::ActualPosition::decode(&s.response).cartesian
}

#[test]
fn frame_and_tool_jogging_move_the_tcp_along_their_axes() {
    let (_c, mut plc) = initialized("jogcart");
    reset_and_enable(&mut plc);
    let mut jog = GroupJog::axes(20.0);
    jog.mode = 0;
    let h = plc.task_mut().submit(&jog.request()).expect("submit");
    run_until_state(&mut plc, h, state::ACTIVE, Duration::from_secs(3));

    // Frame mode (world frame), incremental: +X by 20 mm, the orientation unchanged.
    let before = flange(&mut plc);
    let mut step = jog.pressing(0, 1);
    step.incremental_translation = 20.0;
    plc.task_mut().update(h, &step.request()).expect("update");
    plc.run_until(
        |t| {
            t.status(h)
                .is_some_and(|s| JogStatus::decode(&s.response).distance_reached || s.is_final())
        },
        Duration::from_secs(10),
    )
    .expect("distance reached");
    assert_eq!(plc.task().status(h).map(|s| s.state), Some(state::ACTIVE));
    let after = flange(&mut plc);
    let moved: Vec<f64> = (0..6).map(|k| after[k] - before[k]).collect();
    assert!((moved[0] - 20.0).abs() < 0.05, "moved {moved:?}");
    assert!(
        moved[1..].iter().all(|d| d.abs() < 0.05),
        "only along X: {moved:?}"
    );

    // Tool mode, continuous -Z while the key is held: the TCP moves along the tool's Z axis
    // (the home pose points the flange's Z elsewhere than the world's), orientation kept.
    let mut tool = jog.pressing(2, -1);
    tool.mode = 1;
    let before = flange(&mut plc);
    plc.task_mut().update(h, &tool.request()).expect("press");
    plc.run_for(Duration::from_millis(600)).expect("jogging");
    plc.task_mut().update(h, &jog.request()).expect("release");
    plc.run_until(
        |t| {
            t.status(h)
                .is_some_and(|s| !JogStatus::decode(&s.response).motion_active)
        },
        Duration::from_secs(5),
    )
    .expect("stopped");
    let after = flange(&mut plc);
    let shift = [
        after[0] - before[0],
        after[1] - before[1],
        after[2] - before[2],
    ];
    let length = shift.iter().map(|v| v * v).sum::<f64>().sqrt();
    assert!(length > 1.0, "the TCP moved: {shift:?}");
    // The tool's Z axis in the world: the third column of Rz·Ry·Rx.
    let [a, b, c] = [before[3], before[4], before[5]].map(f64::to_radians);
    let z = [
        c.cos() * b.sin() * a.cos() + c.sin() * a.sin(),
        c.sin() * b.sin() * a.cos() - c.cos() * a.sin(),
        b.cos() * a.cos(),
    ];
    let off_axis = (0..3)
        .map(|k| (shift[k] / length + z[k]).powi(2))
        .sum::<f64>()
        .sqrt();
    assert!(off_axis < 0.01, "along the tool's -Z: {shift:?} vs {z:?}");
    assert!(
        (3..6).all(|k| (after[k] - before[k]).abs() < 0.05),
        "orientation kept: {before:?} -> {after:?}"
    );
    plc.task_mut()
        .update(
            h,
            &GroupJog {
                enable: false,
                ..jog
            }
            .request(),
        )
        .expect("disable");
    let s = run_until_state(&mut plc, h, state::DONE, Duration::from_secs(3));
    assert_eq!(s.state, state::DONE);
}

/// A continuous joint jog stops at the SW limit, half a degree inside it: the GroupJog stays
/// ACTIVE and says why the arm stopped with 0x6C04 (SW limit reached), MotionActive cleared.
/// (It said nothing: code 0, as if the key had been released.)
#[test]
fn a_joint_jog_at_the_sw_limit_reports_it() {
    use super::sw_limits::{MECHANICAL_LOWER, MECHANICAL_UPPER};
    use crate::common::{enabled, expect_done};
    use plc_client::{SwLimits, Timestamp};
    let (_c, mut plc) = enabled("joglimit");
    let mut narrow = SwLimits {
        timestamp: Timestamp::default(),
        lower_deg: MECHANICAL_LOWER,
        upper_deg: MECHANICAL_UPPER,
    };
    narrow.upper_deg[0] = 5.0;
    expect_done(
        &mut plc,
        &Request::write_sw_limits(&narrow, false),
        shared_types::srci::tables::write_robot_sw_limits::response::LEN,
    );
    let h = plc
        .task_mut()
        .submit(&GroupJog::axes(50.0).pressing(0, 1).request())
        .expect("submit");
    plc.run_until(
        |t| t.status(h).is_some_and(|s| s.code != 0 || s.is_final()),
        Duration::from_secs(5),
    )
    .expect("the jog ends at the limit");
    let s = plc.task().status(h).cloned().expect("status");
    assert_eq!(
        (s.state, s.code),
        (state::ACTIVE, code::SW_LIMIT_REACHED),
        "{s:?}"
    );
    assert!(!JogStatus::decode(&s.response).motion_active);
    let j1 = actual_joints(&mut plc)[0];
    assert!((j1 - 4.5).abs() < 0.01, "J1 at {j1}");
}
