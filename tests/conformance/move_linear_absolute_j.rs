//! MoveLinearAbsoluteJ (2109): the TCP on a straight line to a joint target, ending exactly
//! at those joints.

use std::time::Duration;

use plc_client::Request;
use shared_types::srci::message::{code, state};
use shared_types::srci::payload::{PayloadReader, PayloadWriter};
use shared_types::srci::tables::move_linear_absolute_j as mlaj;

use super::move_requests::{move_request, tcp};
use crate::common::{HOME, actual_joints, enabled, expect_error, max_deviation};

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
    let mut midway = None;
    plc.run_until(
        |t| {
            let s = t.status(handle).expect("status");
            if s.state == state::ACTIVE
                && PayloadReader::new(&s.response).u16(mlaj::response::PROGRESS) > 4_000
            {
                return true;
            }
            s.is_final()
        },
        Duration::from_secs(20),
    )
    .expect("under way");
    if plc.task().status(handle).is_some_and(|s| !s.is_final()) {
        midway = Some(tcp(&mut plc, 0, 0));
    }
    plc.run_until(
        |t| t.status(handle).is_some_and(|s| s.is_final()),
        Duration::from_secs(20),
    )
    .expect("the move ends");
    let done = plc.task().status(handle).cloned().expect("status");
    assert_eq!((done.state, done.code), (state::DONE, 0), "{done:?}");
    let r = PayloadReader::new(&done.response);
    assert_eq!(
        (
            r.u16(mlaj::response::PROGRESS),
            r.f32(mlaj::response::REMAINING_DISTANCE)
        ),
        (10_000, 0.0)
    );
    let reached = actual_joints(&mut plc);
    assert!(
        max_deviation(reached, target) < 0.01,
        "{reached:?} vs {target:?}"
    );
    let end = tcp(&mut plc, 0, 0);
    if let Some(p) = midway {
        let off = distance_from_line(p, start, end);
        assert!(off < 0.5, "the TCP left the line by {off:.3} mm");
    }
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
