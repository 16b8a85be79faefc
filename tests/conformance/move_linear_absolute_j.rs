//! MoveLinearAbsoluteJ (2109): the TCP on a straight line to a joint target, ending exactly
//! at those joints.

use std::time::Duration;

use plc_client::{CommandHandle, CommandStatus, Request};
use shared_types::srci::message::{code, state};
use shared_types::srci::payload::{PayloadReader, PayloadWriter};
use shared_types::srci::tables::move_linear_absolute_j as mlaj;

use super::move_requests::{expect_move_done, move_request, tcp};
use crate::common::{HOME, Plc, actual_joints, enabled, expect_error, max_deviation};

fn to_joints(joints_deg: [f64; 6], edit: impl FnOnce(&mut PayloadWriter)) -> Request {
    let rates = [
        mlaj::request::VELOCITY_RATE,
        mlaj::request::ACCELERATION_RATE,
        mlaj::request::DECELERATION_RATE,
        mlaj::request::JERK_RATE,
    ];
    move_request(mlaj::TYPE, rates, |w| {
        for (f, v) in mlaj::request::JOINT_POSITION_J1_J6
            .into_iter()
            .zip(joints_deg)
        {
            w.set_f32(f, v as f32);
        }
        w.set_u8(mlaj::request::ORI_MODE, 1);
        edit(w);
    })
}

/// Distance (mm) of `p` from the line through `a` and `b`.
fn distance_from_line(p: [f64; 6], a: [f64; 6], b: [f64; 6]) -> f64 {
    let ab = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
    let ap = [p[0] - a[0], p[1] - a[1], p[2] - a[2]];
    let len2: f64 = ab.iter().map(|v| v * v).sum();
    let t = ab.iter().zip(ap).map(|(x, y)| x * y).sum::<f64>() / len2;
    (0..3)
        .map(|i| (ap[i] - t * ab[i]).powi(2))
        .sum::<f64>()
        .sqrt()
}

/// Runs cycles until `handle` has gone 40 % of its way; false if it ended before.
fn under_way(plc: &mut Plc, handle: CommandHandle) -> bool {
    plc.run_until(
        |t| {
            let s = t.status(handle).expect("status");
            s.is_final()
                || (s.state == state::ACTIVE
                    && PayloadReader::new(&s.response).u16(mlaj::response::PROGRESS) > 4_000)
        },
        Duration::from_secs(20),
    )
    .expect("under way");
    plc.task().status(handle).is_some_and(|s| !s.is_final())
}

/// Runs cycles until `handle` ends; returns its final status.
fn until_final(plc: &mut Plc, handle: CommandHandle) -> CommandStatus {
    plc.run_until(
        |t| t.status(handle).is_some_and(|s| s.is_final()),
        Duration::from_secs(20),
    )
    .expect("the move ends");
    plc.task().status(handle).cloned().expect("status")
}

/// The arm stands at the joints `target`, and the TCP seen `midway` (if the move was
/// caught under way) lay on the line from `start` to where it stands.
fn assert_ended_on_the_line(
    plc: &mut Plc,
    target: [f64; 6],
    start: [f64; 6],
    midway: Option<[f64; 6]>,
) {
    let reached = actual_joints(plc);
    assert!(
        max_deviation(reached, target) < 0.01,
        "{reached:?} vs {target:?}"
    );
    let end = tcp(plc, 0, 0);
    if let Some(p) = midway {
        let off = distance_from_line(p, start, end);
        assert!(off < 0.5, "the TCP left the line by {off:.3} mm");
    }
}

#[test]
fn the_line_ends_exactly_at_the_joints() {
    let (_c, mut plc) = enabled("mlaj");
    let start = tcp(&mut plc, 0, 0);
    let target = [10.0, 80.0, 100.0, 80.0, -95.0, 15.0];
    let handle = plc
        .task_mut()
        .submit(&to_joints(target, |_| {}))
        .expect("submit");
    // Half-way (by time) the TCP is on the line.
    let midway = under_way(&mut plc, handle).then(|| tcp(&mut plc, 0, 0));
    let done = until_final(&mut plc, handle);
    assert_eq!((done.state, done.code), (state::DONE, 0), "{done:?}");
    let r = PayloadReader::new(&done.response);
    assert_eq!(
        (
            r.u16(mlaj::response::PROGRESS),
            r.f32(mlaj::response::REMAINING_DISTANCE)
        ),
        (10_000, 0.0)
    );
    assert_ended_on_the_line(&mut plc, target, start, midway);
}

#[test]
fn joint_interpolated_ends_exactly_at_the_joints_with_the_wrist_joints_on_their_line() {
    let (_c, mut plc) = enabled("mlajori");
    let start_joints = actual_joints(&mut plc);
    let start = tcp(&mut plc, 0, 0);
    let target = [10.0, 80.0, 100.0, 70.0, -80.0, 30.0];
    let handle = plc
        .task_mut()
        .submit(&to_joints(target, |w| w.set_u8(mlaj::request::ORI_MODE, 2)))
        .expect("submit");
    let mut midway = None;
    if under_way(&mut plc, handle) {
        // Midway the wrist joints lie on their straight line in joint space.
        let q = actual_joints(&mut plc);
        let travel: Vec<f64> = (3..6).map(|i| target[i] - start_joints[i]).collect();
        let moved: Vec<f64> = (3..6).map(|i| q[i] - start_joints[i]).collect();
        let norm2: f64 = travel.iter().map(|v| v * v).sum();
        let s = travel.iter().zip(&moved).map(|(a, b)| a * b).sum::<f64>() / norm2;
        let off = (0..3)
            .map(|i| (moved[i] - s * travel[i]).abs())
            .fold(0.0, f64::max);
        // The servo follows a few ticks behind the sampled path: a loose bound.
        assert!(off < 0.5, "the wrist joints left their line by {off:.3}°");
        midway = Some(tcp(&mut plc, 0, 0));
    }
    let done = until_final(&mut plc, handle);
    assert_eq!((done.state, done.code), (state::DONE, 0), "{done:?}");
    assert_ended_on_the_line(&mut plc, target, start, midway);
    // The same joints again by a second move: nothing left to do.
    expect_move_done(
        &mut plc,
        &to_joints(target, |w| w.set_u8(mlaj::request::ORI_MODE, 2)),
    );
}

#[test]
fn refusals_carry_their_codes() {
    let (_c, mut plc) = enabled("mlajerr");
    let cases = [
        (
            to_joints(HOME, |w| w.set_u8(mlaj::request::ORI_MODE, 3)),
            code::ORI_MODE_NOT_SUPPORTED,
        ),
        (
            to_joints(HOME, |w| {
                w.set_f32(mlaj::request::JOINT_POSITION_J2, f32::NAN)
            }),
            code::INVALID_JOINT_POSITION,
        ),
        (
            to_joints([0.0, 90.0, 90.0, 90.0, -90.0, 400.0], |_| {}),
            code::SW_LIMIT_UPPER,
        ),
        (
            to_joints(HOME, |w| w.set_u8(mlaj::request::BLENDING_MODE, 1)),
            code::INVALID_BLENDING_MODE,
        ),
    ];
    for (request, expected) in cases {
        expect_error(&mut plc, &request, expected);
    }
}
