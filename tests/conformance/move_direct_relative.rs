//! MoveDirectRelative (2108): a joint-interpolated move of the TCP by a distance in a frame's
//! axes (ReferenceType FRAME) or the tool's (TOOL).

use plc_client::Request;
use shared_types::srci::message::code;
use shared_types::srci::payload::{PayloadReader, PayloadWriter};
use shared_types::srci::tables::move_direct_relative as mdr;

use super::move_requests::{
    along_own_z, assert_tcp_at, expect_move_done, keep_configuration, move_request, set_pose,
    shifted, tcp,
};
use crate::common::{enabled, expect_error};

fn relative(
    distance: [f64; 6],
    reference_type: u8,
    edit: impl FnOnce(&mut PayloadWriter),
) -> Request {
    let rates = [
        mdr::request::VELOCITY_RATE,
        mdr::request::ACCELERATION_RATE,
        mdr::request::DECELERATION_RATE,
        mdr::request::JERK_RATE,
    ];
    move_request(mdr::TYPE, rates, |w| {
        set_pose(w, mdr::request::DISTANCE_X_RZ, distance);
        keep_configuration(w, mdr::request::CONFIG_MODE, mdr::request::TURN_MODE);
        w.set_u8(mdr::request::REFERENCE_TYPE, reference_type);
        edit(w);
    })
}

#[test]
fn the_tcp_moves_by_the_distance() {
    let (_c, mut plc) = enabled("mdr");
    let start = tcp(&mut plc, 0, 0);
    let response = expect_move_done(
        &mut plc,
        &relative([-30.0, 20.0, 25.0, 0.0, 0.0, 0.0], 1, |_| {}),
    );
    assert_eq!(response.len(), mdr::response::LEN);
    let r = PayloadReader::new(&response);
    assert_eq!(
        (
            r.u16(mdr::response::PROGRESS),
            r.f32(mdr::response::REMAINING_DISTANCE)
        ),
        (10_000, 0.0)
    );
    assert_tcp_at(&mut plc, shifted(start, [-30.0, 20.0, 25.0]));

    let before = tcp(&mut plc, 0, 0);
    expect_move_done(
        &mut plc,
        &relative([0.0, 0.0, -20.0, 0.0, 0.0, 0.0], 0, |_| {}),
    );
    let expected = along_own_z(before, -20.0);
    assert_tcp_at(&mut plc, expected);
}

#[test]
fn bad_parameters_are_refused() {
    let (_c, mut plc) = enabled("mdrerr");
    let zero = [0.0; 6];
    expect_error(&mut plc, &relative(zero, 7, |_| {}), code::INVALID_MODE);
    expect_error(
        &mut plc,
        &relative(zero, 1, |w| w.set_u8(mdr::request::TOOL_NO, 16)),
        code::INVALID_TOOL_NO,
    );
    expect_error(
        &mut plc,
        &relative(zero, 1, |w| {
            w.set_u8(mdr::request::BLENDING_MODE, 11);
            w.set_f32(mdr::request::BLENDING_PARAMETER.element(0), 150.0);
        }),
        code::INVALID_BLENDING_PARAMETER,
    );
}
