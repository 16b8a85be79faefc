//! MoveCircularRelative (2107): an arc whose AuxPoint and EndPoint are distances from where
//! the move starts, in a frame's axes (ReferenceType FRAME).

use shared_types::srci::message::code;
use shared_types::srci::payload::{Field, Layout, PayloadReader, WireType};
use shared_types::srci::tables::move_circular_relative as mcr;

use super::move_requests::{
    assert_tcp_at, expect_move_done, keep_configuration, move_request, set_pose, shifted, tcp,
};
use crate::common::{enabled, expect_error};

/// ReferenceType: table 6-357 puts it among the bits of ConfigMode[1]; it is the byte before
/// TurnMode (see the interpreter's circular module).
const REFERENCE_TYPE: Field = Field {
    offset: mcr::request::TURN_MODE.offset - 1,
    layout: Layout::Scalar(WireType::U8),
};

fn relative_arc(aux: [f64; 6], end: [f64; 6], reference_type: u8) -> plc_client::Request {
    let rates = [
        mcr::request::VELOCITY_RATE,
        mcr::request::ACCELERATION_RATE,
        mcr::request::DECELERATION_RATE,
        mcr::request::JERK_RATE,
    ];
    let config_mode = Field {
        offset: mcr::request::CONFIG_MODE_ARRAY.offset,
        layout: Layout::Array(WireType::U8, 2),
    };
    move_request(mcr::TYPE, rates, |w| {
        set_pose(w, mcr::request::AUX_POINT_X_RZ, aux);
        set_pose(w, mcr::request::END_POINT_X_RZ, end);
        keep_configuration(w, config_mode, mcr::request::TURN_MODE);
        w.set_u8(mcr::request::ORI_MODE, 1);
        w.set_u8(REFERENCE_TYPE, reference_type);
    })
}

#[test]
fn both_points_are_distances_from_the_start() {
    let (_c, mut plc) = enabled("mcr");
    let start = tcp(&mut plc, 0, 0);
    let aux = [40.0, 0.0, 40.0, 0.0, 0.0, 0.0];
    let end = [80.0, 0.0, 0.0, 0.0, 0.0, 0.0];
    let response = expect_move_done(&mut plc, &relative_arc(aux, end, 1));
    assert_eq!(
        PayloadReader::new(&response).u16(mcr::response::PROGRESS),
        10_000
    );
    assert_tcp_at(&mut plc, shifted(start, [80.0, 0.0, 0.0]));
    expect_error(&mut plc, &relative_arc(aux, end, 4), code::INVALID_MODE);
}
