//! MoveLinearRelative (2110): a straight TCP line by a distance in the tool's axes
//! (ReferenceType TOOL) or in a frame's (FRAME), from where the move starts.

use plc_client::Request;
use plc_client::request::FrameData;
use shared_types::srci::message::code;
use shared_types::srci::payload::{PayloadReader, PayloadWriter};
use shared_types::srci::tables::{move_linear_relative as mlr, write_frame_data};

use super::move_requests::{
    along_own_z, assert_tcp_at, expect_move_done, keep_configuration, move_request, set_pose,
    shifted, tcp,
};
use crate::common::{enabled, expect_done, expect_error};

/// ReferenceType TOOL.
const TOOL: u8 = 0;
/// ReferenceType FRAME.
const FRAME: u8 = 1;

fn relative(
    distance: [f64; 6],
    reference_type: u8,
    frame: u8,
    edit: impl FnOnce(&mut PayloadWriter),
) -> Request {
    let rates = [
        mlr::request::VELOCITY_RATE,
        mlr::request::ACCELERATION_RATE,
        mlr::request::DECELERATION_RATE,
        mlr::request::JERK_RATE,
    ];
    move_request(mlr::TYPE, rates, |w| {
        set_pose(w, mlr::request::DISTANCE_X_RZ, distance);
        keep_configuration(w, mlr::request::CONFIG_MODE, mlr::request::TURN_MODE);
        w.set_u8(mlr::request::ORI_MODE, 1);
        w.set_u8(mlr::request::REFERENCE_TYPE, reference_type);
        w.set_u8(mlr::request::FRAME_NO, frame);
        edit(w);
    })
}

#[test]
fn distances_in_tool_and_frame_axes() {
    let (_c, mut plc) = enabled("mlr");
    // Frame 1 turned 90° about Z: its X is the world's Y.
    let frame = FrameData {
        pose: [0.0, 0.0, 0.0, 0.0, 0.0, 90.0],
        ..FrameData::default()
    };
    expect_done(
        &mut plc,
        &Request::write_frame_data(1, &frame),
        write_frame_data::response::LEN,
    );
    let start = tcp(&mut plc, 0, 0);
    let response = expect_move_done(
        &mut plc,
        &relative([40.0, 0.0, 0.0, 0.0, 0.0, 0.0], FRAME, 1, |_| {}),
    );
    let r = PayloadReader::new(&response);
    assert_eq!(response.len(), mlr::response::LEN);
    assert_eq!(
        (
            r.u16(mlr::response::PROGRESS),
            r.f32(mlr::response::REMAINING_DISTANCE)
        ),
        (10_000, 0.0)
    );
    assert_tcp_at(&mut plc, shifted(start, [0.0, 40.0, 0.0]));

    // 30 mm along the TCP's own Z.
    let before = tcp(&mut plc, 0, 0);
    expect_move_done(
        &mut plc,
        &relative([0.0, 0.0, 30.0, 0.0, 0.0, 0.0], TOOL, 0, |_| {}),
    );
    let expected = along_own_z(before, 30.0);
    assert_tcp_at(&mut plc, expected);
}

#[test]
fn undefined_reference_types_and_frames_are_refused() {
    let (_c, mut plc) = enabled("mlrerr");
    let zero = [0.0; 6];
    expect_error(&mut plc, &relative(zero, 2, 0, |_| {}), code::INVALID_MODE);
    expect_error(
        &mut plc,
        &relative(zero, FRAME, 16, |_| {}),
        code::INVALID_FRAME_NO,
    );
    expect_error(
        &mut plc,
        &relative(zero, TOOL, 0, |w| {
            w.set_f32(mlr::request::DISTANCE_RZ, f32::NAN)
        }),
        code::INVALID_POSITION,
    );
}
