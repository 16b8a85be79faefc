//! MoveAxesRelative (2105): joint distances added to where the move starts (the end of the
//! move before it), Progress, and the parameter checks.

use plc_client::Request;
use shared_types::srci::message::code;
use shared_types::srci::payload::{PayloadReader, PayloadWriter};
use shared_types::srci::tables::move_axes_relative as mar;

use super::move_requests::{expect_move_done, move_request};
use crate::common::{actual_joints, enabled, expect_error, max_deviation};

fn relative(distance_deg: [f64; 6], edit: impl FnOnce(&mut PayloadWriter)) -> Request {
    let r = &mar::request::JOINT_DISTANCE_J1_J6;
    let rates = [
        mar::request::VELOCITY_RATE,
        mar::request::ACCELERATION_RATE,
        mar::request::DECELERATION_RATE,
        mar::request::JERK_RATE,
    ];
    move_request(mar::TYPE, rates, |w| {
        for (f, v) in r.iter().zip(distance_deg) {
            w.set_f32(*f, v as f32);
        }
        edit(w);
    })
}

#[test]
fn distances_add_to_the_end_of_the_move_before() {
    let (_c, mut plc) = enabled("mar");
    let start = actual_joints(&mut plc);
    let d = [10.0, -5.0, 5.0, 0.0, 0.0, -20.0];
    let response = expect_move_done(&mut plc, &relative(d, |_| {}));
    assert_eq!(response.len(), mar::response::LEN);
    assert_eq!(
        PayloadReader::new(&response).u16(mar::response::PROGRESS),
        10_000
    );
    let first: [f64; 6] = core::array::from_fn(|i| start[i] + d[i]);
    let reached = actual_joints(&mut plc);
    assert!(
        max_deviation(reached, first) < 0.01,
        "{reached:?} vs {first:?}"
    );

    // Two buffered relative moves: the second starts where the first ends.
    let step = [0.0, 0.0, 0.0, 0.0, 0.0, 15.0];
    let a = plc
        .task_mut()
        .submit(&relative(step, |_| {}))
        .expect("submit");
    let b = plc
        .task_mut()
        .submit(&relative(step, |_| {}))
        .expect("submit");
    plc.run_until(
        |t| {
            [a, b]
                .iter()
                .all(|&h| t.status(h).is_some_and(|s| s.is_final()))
        },
        std::time::Duration::from_secs(20),
    )
    .expect("both end");
    let mut second = first;
    second[5] += 30.0;
    let reached = actual_joints(&mut plc);
    assert!(
        max_deviation(reached, second) < 0.01,
        "{reached:?} vs {second:?}"
    );
}

#[test]
fn bad_parameters_are_refused() {
    let (_c, mut plc) = enabled("marerr");
    let before = actual_joints(&mut plc);
    let cases = [
        (
            relative([0.0; 6], |w| {
                w.set_f32(mar::request::JOINT_DISTANCE_J3, f32::NAN)
            }),
            code::INVALID_JOINT_POSITION,
        ),
        (
            relative([0.0; 6], |w| w.set_u8(mar::request::BLENDING_MODE, 7)),
            code::INVALID_BLENDING_MODE,
        ),
        (
            relative([0.0; 6], |w| {
                w.set_u8(mar::request::BLENDING_MODE, 3);
                w.set_f32(mar::request::BLENDING_PARAMETER.element(0), -5.0);
            }),
            code::INVALID_BLENDING_PARAMETER,
        ),
        (
            relative([0.0; 6], |w| w.set_u16(mar::request::VELOCITY_RATE, 10_001)),
            code::INVALID_VELOCITY_RATE,
        ),
    ];
    for (request, expected) in cases {
        expect_error(&mut plc, &request, expected);
    }
    assert!(
        max_deviation(before, actual_joints(&mut plc)) < 1e-6,
        "nothing moved"
    );
}
