//! MoveLinearAbsolute: the TCP of a user tool on a straight line to a target given in a user
//! frame, with Progress and RemainingDistance, and the refusals before the arm moves.

use plc_client::Request;
use plc_client::request::{FrameData, ToolData};
use shared_types::srci::message::{code, execution_mode, state};
use shared_types::srci::payload::{PayloadReader, PayloadWriter};
use shared_types::srci::tables::move_linear_absolute as mla;

use super::move_requests::{follow_tcp, initialized_with_cyclic_tcp, tcp};
use crate::common::{
    Controller, HOME, actual_joints, expect_done, expect_error, initialize, max_deviation,
    reset_and_enable,
};

/// A MoveLinearAbsolute to `target` (mm, degrees) in `frame` with `tool`, rates at
/// default, OriMode LINEAR_INTERPOLATED; `edit` changes the request.
fn linear(
    target: [f64; 6],
    tool: u8,
    frame: u8,
    mode: u8,
    edit: impl FnOnce(&mut PayloadWriter),
) -> Request {
    let mut b = vec![0u8; mla::request::LEN];
    let mut w = PayloadWriter::new(&mut b);
    for f in [
        mla::request::VELOCITY_RATE,
        mla::request::ACCELERATION_RATE,
        mla::request::DECELERATION_RATE,
        mla::request::JERK_RATE,
    ] {
        w.set_u16(f, 0xFFFF);
    }
    w.set_u8(mla::request::TOOL_NO, tool);
    w.set_u8(mla::request::FRAME_NO, frame);
    w.set_u8(mla::request::ORI_MODE, 1);
    // Keep the configuration of the start (ConfigMode SAME), turns FREE.
    w.set_u8(mla::request::CONFIG_MODE.element(0), 0x11);
    w.set_u8(mla::request::CONFIG_MODE.element(1), 0x01);
    w.set_u8(mla::request::TURN_MODE, 2);
    for (f, v) in mla::request::POSITION_X_RZ.into_iter().zip(target) {
        w.set_f32(f, v as f32);
    }
    edit(&mut w);
    Request::Raw {
        command_type: mla::TYPE,
        execution_mode: mode,
        payload: b[4..].to_vec(),
    }
}

/// Distance (mm) of `p` from the segment `a`–`b`.
fn distance_from_segment(p: [f64; 3], a: [f64; 3], b: [f64; 3]) -> f64 {
    let ab = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
    let ap = [p[0] - a[0], p[1] - a[1], p[2] - a[2]];
    let len2 = ab.iter().map(|v| v * v).sum::<f64>();
    let t = (ab.iter().zip(ap).map(|(x, y)| x * y).sum::<f64>() / len2).clamp(0.0, 1.0);
    let d = [0, 1, 2].map(|i| ap[i] - t * ab[i]);
    d.iter().map(|v| v * v).sum::<f64>().sqrt()
}

/// Distance (mm) of the pose `p`'s position from the segment of the positions of `a`, `b`.
fn off_line(p: [f64; 6], a: [f64; 6], b: [f64; 6]) -> f64 {
    distance_from_segment([p[0], p[1], p[2]], [a[0], a[1], a[2]], [b[0], b[1], b[2]])
}

#[test]
fn the_tcp_moves_on_a_straight_line_to_a_target_in_a_user_frame() {
    let (_c, mut plc) = initialized_with_cyclic_tcp("mla");
    assert!(
        plc.task()
            .robot_data()
            .is_some_and(|d| d.supports(mla::TYPE)),
        "announced in RCSupportedFunctions"
    );
    reset_and_enable(&mut plc);
    // Tool 1: 120 mm along the flange's Z. Frame 1: 200 mm along the world's Y, turned 30°
    // about Z.
    let tool = ToolData {
        pose: [0.0, 0.0, 120.0, 0.0, 0.0, 0.0],
        load_no: 0,
        ..ToolData::default()
    };
    expect_done(
        &mut plc,
        &Request::write_tool_data(1, &tool),
        shared_types::srci::tables::write_tool_data::response::LEN,
    );
    let frame = FrameData {
        pose: [0.0, 200.0, 0.0, 0.0, 0.0, 30.0],
        ..FrameData::default()
    };
    expect_done(
        &mut plc,
        &Request::write_frame_data(1, &frame),
        shared_types::srci::tables::write_frame_data::response::LEN,
    );

    let start = tcp(&mut plc, 1, 1);
    let mut target = start;
    target[0] += 80.0;
    target[1] -= 60.0;
    target[2] -= 50.0;
    // Every telegram's CartesianPosition block (in the tool and frame in use, which the move
    // made tool 1 and frame 1) must lie on the line.
    let mut worst: f64 = 0.0;
    let mut samples = 0;
    let mut remaining_seen = Vec::new();
    let request = linear(target, 1, 1, execution_mode::SEQUENCE_PRIMARY, |_| {});
    let done = follow_tcp(&mut plc, &request, (1, 1), |pose, status| {
        if let Some(pose) = pose {
            worst = worst.max(off_line(pose, start, target));
            samples += 1;
        }
        if status.state == state::ACTIVE && !status.response.is_empty() {
            let r = PayloadReader::new(&status.response);
            remaining_seen.push(r.f32(mla::response::REMAINING_DISTANCE));
        }
    });
    assert_eq!((done.state, done.code), (state::DONE, 0), "{done:?}");
    let r = PayloadReader::new(&done.response);
    assert_eq!(r.u16(mla::response::PROGRESS), 10_000);
    assert_eq!(r.f32(mla::response::REMAINING_DISTANCE), 0.0);
    assert!(samples > 20, "{samples} positions sampled during the move");
    assert!(worst < 0.5, "the TCP left the line by {worst:.3} mm");
    assert!(
        remaining_seen.iter().any(|&d| d > 1.0 && d < 130.0),
        "RemainingDistance while moving: {remaining_seen:?}"
    );
    let reached = tcp(&mut plc, 1, 1);
    assert!(
        max_deviation(reached, target) < 0.05,
        "{reached:?} vs {target:?}"
    );
}

/// The angle (degrees) between two orientations given as Rx, Ry, Rz (degrees).
pub fn orientation_deviation(a: [f64; 6], b: [f64; 6]) -> f64 {
    let rotation = |p: [f64; 6]| {
        shared_types::pose::rotation_from_rpy(
            p[3].to_radians(),
            p[4].to_radians(),
            p[5].to_radians(),
        )
    };
    rotation(a).angle_to(&rotation(b)).to_degrees()
}

/// Runs the line to `target` with `ori_mode` (tool 0, frame 0) to DONE and checks that the
/// TCP of every telegram kept to the line and that it ends at `target`'s position with the
/// orientation of `orientation`; returns where it stands.
fn line_ends_at(
    plc: &mut crate::common::Plc,
    target: [f64; 6],
    ori_mode: u8,
    orientation: [f64; 6],
) -> [f64; 6] {
    let start = tcp(plc, 0, 0);
    let request = linear(target, 0, 0, execution_mode::SEQUENCE_PRIMARY, |w| {
        w.set_u8(mla::request::ORI_MODE, ori_mode)
    });
    let mut worst: f64 = 0.0;
    let done = follow_tcp(plc, &request, (0, 0), |pose, _| {
        if let Some(pose) = pose {
            worst = worst.max(off_line(pose, start, target));
        }
    });
    assert_eq!(
        (done.state, done.code),
        (state::DONE, 0),
        "OriMode {ori_mode}: {done:?}"
    );
    assert!(
        worst < 0.5,
        "OriMode {ori_mode}: {worst:.3} mm off the line"
    );
    let reached = tcp(plc, 0, 0);
    assert!(
        (0..3).all(|i| (reached[i] - target[i]).abs() < 0.05),
        "OriMode {ori_mode}: {reached:?} vs {target:?}"
    );
    assert!(
        orientation_deviation(reached, orientation) < 0.01,
        "OriMode {ori_mode}: {reached:?} vs {orientation:?}"
    );
    reached
}

#[test]
fn joint_interpolated_and_path_reach_the_target_orientation() {
    let (_c, mut plc) = initialized_with_cyclic_tcp("mlaori");
    reset_and_enable(&mut plc);
    // JOINT_INTERPOLATED: on the line to the target's position and orientation.
    let mut target = tcp(&mut plc, 0, 0);
    target[0] += 60.0;
    target[1] -= 40.0;
    target[2] += 30.0;
    target[4] += 15.0;
    target[5] += 20.0;
    let reached = line_ends_at(&mut plc, target, 2, target);
    // PATH: the tangent of a line does not turn, so the whole turn to the target's
    // orientation is spread over the line.
    let mut back = reached;
    back[0] -= 60.0;
    back[2] -= 30.0;
    back[3] += 10.0;
    line_ends_at(&mut plc, back, 4, back);
}

#[test]
fn refusals_come_before_the_arm_moves() {
    let c = Controller::start("mlaerr");
    let mut plc = c.client();
    initialize(&mut plc);
    let home_tcp = tcp(&mut plc, 0, 0);
    expect_error(
        &mut plc,
        &linear(home_tcp, 0, 0, 0, |_| {}),
        code::ROBOT_DISABLED,
    );
    reset_and_enable(&mut plc);
    let before = actual_joints(&mut plc);
    let mut far = home_tcp;
    far[0] = 5000.0;
    let cases = [
        (
            linear(home_tcp, 0, 0, 0, |w| w.set_u8(mla::request::ORI_MODE, 5)),
            code::INVALID_ORI_MODE,
        ),
        (linear(far, 0, 0, 0, |_| {}), code::TARGET_UNREACHABLE),
        (
            linear(home_tcp, 0, 0, 0, |w| {
                w.set_u16(mla::request::VELOCITY_RATE, 10_001)
            }),
            code::INVALID_VELOCITY_RATE,
        ),
        (
            linear(home_tcp, 0, 0, 0, |w| {
                w.set_f32(mla::request::POSITION_Y, f32::NAN)
            }),
            code::INVALID_POSITION,
        ),
        (linear(home_tcp, 0, 16, 0, |_| {}), code::INVALID_FRAME_NO),
        (
            linear(home_tcp, 0, 0, execution_mode::PARALLEL, |_| {}),
            code::INVALID_EXECUTION_MODE,
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

/// A line from home across the J1 axis to the mirrored pose: the wrist centre passes the
/// shoulder singularity halfway. It is refused with 0x6C03 before the arm moves, its message
/// says why (it said "target unreachable in the requested configuration"), and the next line
/// runs from home.
#[test]
fn a_line_through_the_shoulder_singularity_is_refused_before_the_arm_moves() {
    let report = crate::common::run_passing(
        "mla-singular",
        &(crate::common::FROM_HOME.to_owned()
            + r#"
        [[step]]
        call = "MoveLinearAbsolute"
        position = [417.03, 115.01, 373.15, -180.0, 0.0, 90.0]
        ori_mode = 1
        config_mode = [0x11, 0x01]
        turn_mode = 1
        expect = "ERROR"
        expect_code = 0x6C03
        [[step]]
        call = "ReadActualPosition"
        [[step]]
        call = "MoveLinearAbsolute"
        position = [-417.03, 165.01, 373.15, -180.0, 0.0, 90.0]
        ori_mode = 1
        config_mode = [0x11, 0x01]
        turn_mode = 1
        "#),
    );
    let stood = report.steps[4]
        .reached
        .expect("the position read")
        .joints_deg;
    assert!(max_deviation(stood, HOME) < 1e-3, "{stood:?}");
    assert!(
        report.messages.iter().any(
            |m| m.code == u32::from(code::TARGET_UNREACHABLE) && m.text.contains("singularity")
        ),
        "{:?}",
        report.messages
    );
}
