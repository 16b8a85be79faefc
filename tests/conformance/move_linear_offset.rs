//! MoveLinearOffset (2112): a straight line to a reference position displaced by an offset,
//! along the reference's own axes (ReferenceType TOOL) or the frame's (FRAME).

use plc_client::Request;
use shared_types::srci::message::code;
use shared_types::srci::payload::{PayloadReader, PayloadWriter};
use shared_types::srci::tables::move_linear_offset as mlo;

use super::move_requests::{
    along_own_z, assert_tcp_at, expect_move_done, keep_configuration, move_request, set_pose,
    shifted, tcp,
};
use crate::common::{enabled, expect_error};

fn offset_move(
    reference: [f64; 6],
    offset: [f64; 6],
    reference_type: u8,
    edit: impl FnOnce(&mut PayloadWriter),
) -> Request {
    let rates = [
        mlo::request::VELOCITY_RATE,
        mlo::request::ACCELERATION_RATE,
        mlo::request::DECELERATION_RATE,
        mlo::request::JERK_RATE,
    ];
    move_request(mlo::TYPE, rates, |w| {
        set_pose(w, mlo::request::REFERENCE_POSITION_X_RZ, reference);
        set_pose(w, mlo::request::OFFSET_X_RZ, offset);
        keep_configuration(w, mlo::request::CONFIG_MODE, mlo::request::TURN_MODE);
        w.set_u8(mlo::request::ORI_MODE, 1);
        w.set_u8(mlo::request::REFERENCE_TYPE, reference_type);
        edit(w);
    })
}

#[test]
fn the_target_is_the_reference_displaced_by_the_offset() {
    let (_c, mut plc) = enabled("mlo");
    let reference = tcp(&mut plc, 0, 0);
    // FRAME: 40 mm down the world's Z from the reference.
    let response = expect_move_done(
        &mut plc,
        &offset_move(reference, [0.0, 0.0, -40.0, 0.0, 0.0, 0.0], 1, |_| {}),
    );
    let r = PayloadReader::new(&response);
    assert_eq!(
        (
            r.u16(mlo::response::PROGRESS),
            r.f32(mlo::response::REMAINING_DISTANCE)
        ),
        (10_000, 0.0)
    );
    assert_tcp_at(&mut plc, shifted(reference, [0.0, 0.0, -40.0]));
    // TOOL: 25 mm along the reference's own Z, from the same reference.
    expect_move_done(
        &mut plc,
        &offset_move(reference, [0.0, 0.0, 25.0, 0.0, 0.0, 0.0], 0, |_| {}),
    );
    let expected = along_own_z(reference, 25.0);
    assert_tcp_at(&mut plc, expected);
    expect_error(
        &mut plc,
        &offset_move(reference, [0.0; 6], 2, |_| {}),
        code::INVALID_MODE,
    );
    expect_error(
        &mut plc,
        &offset_move(reference, [0.0; 6], 1, |w| {
            w.set_f32(mlo::request::OFFSET_X, f32::NAN)
        }),
        code::INVALID_POSITION,
    );
}
