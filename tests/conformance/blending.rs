//! BlendingMode and BlendingParameter of the moves: a blended pair runs and ends at the
//! second target; undefined modes and parameters are refused.

use std::time::Duration;

use plc_client::{MoveAxesAbsolute, Request};
use shared_types::srci::message::{code, state};
use shared_types::srci::tables::move_linear_absolute as mla;
use shared_types::srci::telegram::status_bit;

use super::move_requests::{assert_tcp_at, keep_configuration, move_request, set_pose, tcp};
use crate::common::{HOME, actual_joints, enabled, expect_error, max_deviation};

fn blended_axes(target: [f64; 6], mode: u8, parameter: f64) -> Request {
    let mut m = MoveAxesAbsolute::to(target);
    m.blending_mode = mode;
    m.blending_parameter = [parameter, 0.0];
    Request::MoveAxesAbsolute(m)
}

fn blended_line(target: [f64; 6], mode: u8, parameter: f32) -> Request {
    let rates = [
        mla::request::VELOCITY_RATE,
        mla::request::ACCELERATION_RATE,
        mla::request::DECELERATION_RATE,
        mla::request::JERK_RATE,
    ];
    move_request(mla::TYPE, rates, |w| {
        set_pose(w, mla::request::POSITION_X_RZ, target);
        keep_configuration(w, mla::request::CONFIG_MODE, mla::request::TURN_MODE);
        w.set_u8(mla::request::ORI_MODE, 1);
        w.set_u8(mla::request::BLENDING_MODE, mode);
        w.set_f32(mla::request::BLENDING_PARAMETER.element(0), parameter);
    })
}

/// Submits both, runs until both end, and expects both DONE and the robot to have reported
/// IsBlending (StatusRobotArm bit 4) in between: the pair really blended.
fn run_pair(plc: &mut crate::common::Plc, first: &Request, second: &Request) {
    let a = plc.task_mut().submit(first).expect("submit");
    let b = plc.task_mut().submit(second).expect("submit");
    let mut seen = 0u32;
    plc.run_until(
        |t| {
            seen |= t.status_word();
            [a, b]
                .iter()
                .all(|&h| t.status(h).is_some_and(|s| s.is_final()))
        },
        Duration::from_secs(30),
    )
    .expect("both end");
    for h in [a, b] {
        let s = plc.task().status(h).cloned().expect("status");
        assert_eq!((s.state, s.code), (state::DONE, 0), "{s:?}");
    }
    assert_ne!(
        seen & status_bit::IS_BLENDING,
        0,
        "IsBlending never reported"
    );
}

#[test]
fn blended_pairs_end_at_the_second_target() {
    let (_c, mut plc) = enabled("blend");
    // RAMP_OVERLAP 50 % between two joint moves.
    let mut via = HOME;
    via[0] += 20.0;
    let mut end = via;
    end[1] += 10.0;
    run_pair(
        &mut plc,
        &blended_axes(via, 11, 50.0),
        &blended_axes(end, 0, 0.0),
    );
    let reached = actual_joints(&mut plc);
    assert!(max_deviation(reached, end) < 0.01, "{reached:?} vs {end:?}");

    // CORNER_DISTANCE 20 mm between two lines.
    let start = tcp(&mut plc, 0, 0);
    let corner = [
        start[0] + 60.0,
        start[1],
        start[2],
        start[3],
        start[4],
        start[5],
    ];
    let target = [
        corner[0],
        corner[1] + 60.0,
        corner[2],
        start[3],
        start[4],
        start[5],
    ];
    run_pair(
        &mut plc,
        &blended_line(corner, 3, 20.0),
        &blended_line(target, 0, 0.0),
    );
    assert_tcp_at(&mut plc, target);
}

#[test]
fn undefined_modes_and_parameters_are_refused() {
    let (_c, mut plc) = enabled("blenderr");
    expect_error(
        &mut plc,
        &blended_axes(HOME, 7, 0.0),
        code::INVALID_BLENDING_MODE,
    );
    expect_error(
        &mut plc,
        &blended_axes(HOME, 2, 150.0),
        code::INVALID_BLENDING_PARAMETER,
    );
    expect_error(
        &mut plc,
        &blended_axes(HOME, 12, -1.0),
        code::INVALID_BLENDING_PARAMETER,
    );
    let here = tcp(&mut plc, 0, 0);
    expect_error(
        &mut plc,
        &blended_line(here, 4, f32::NAN),
        code::INVALID_BLENDING_PARAMETER,
    );
}
