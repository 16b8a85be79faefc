//! MoveCircularRelative (2107): an arc whose AuxPoint and EndPoint are distances from where
//! the move starts, in a frame's axes (ReferenceType FRAME) or the tool's (TOOL); in RADIUS
//! mode the AuxPoint's vector turns with those axes.

use shared_types::srci::message::{code, state};
use shared_types::srci::payload::{PayloadReader, PayloadWriter};
use shared_types::srci::tables::move_circular_relative as mcr;

use super::move_requests::{
    assert_tcp_at, expect_move_done, follow_tcp, initialized_with_cyclic_tcp, keep_configuration,
    move_request, set_pose, shifted, tcp,
};
use crate::common::{enabled, expect_error, reset_and_enable};

fn relative_arc(
    aux: [f64; 6],
    end: [f64; 6],
    reference_type: u8,
    edit: impl FnOnce(&mut PayloadWriter),
) -> plc_client::Request {
    let rates = [
        mcr::request::VELOCITY_RATE,
        mcr::request::ACCELERATION_RATE,
        mcr::request::DECELERATION_RATE,
        mcr::request::JERK_RATE,
    ];
    move_request(mcr::TYPE, rates, |w| {
        set_pose(w, mcr::request::AUX_POINT_X_RZ, aux);
        set_pose(w, mcr::request::END_POINT_X_RZ, end);
        keep_configuration(w, mcr::request::CONFIG_MODE, mcr::request::TURN_MODE);
        w.set_u8(mcr::request::ORI_MODE, 1);
        w.set_u8(mcr::request::REFERENCE_TYPE, reference_type);
        edit(w);
    })
}

#[test]
fn both_points_are_distances_from_the_start() {
    let (_c, mut plc) = enabled("mcr");
    let start = tcp(&mut plc, 0, 0);
    let aux = [40.0, 0.0, 40.0, 0.0, 0.0, 0.0];
    let end = [80.0, 0.0, 0.0, 0.0, 0.0, 0.0];
    let response = expect_move_done(&mut plc, &relative_arc(aux, end, 1, |_| {}));
    assert_eq!(
        PayloadReader::new(&response).u16(mcr::response::PROGRESS),
        10_000
    );
    assert_tcp_at(&mut plc, shifted(start, [80.0, 0.0, 0.0]));
    expect_error(
        &mut plc,
        &relative_arc(aux, end, 4, |_| {}),
        code::INVALID_MODE,
    );
}

#[test]
fn a_radius_vector_turns_with_the_frame_or_the_tool_axes() {
    let (_c, mut plc) = initialized_with_cyclic_tcp("mcrrad");
    reset_and_enable(&mut plc);
    // In the world: 80 mm along X, radius 50 mm about +Z, the longer arc, which passes 80 mm
    // below the start in Y. Sent in the world's axes (FRAME, frame 0), then in the tool's.
    for reference_type in [1, 0] {
        let start = tcp(&mut plc, 0, 0);
        // A world vector in the axes the request uses: the tool's are the TCP's orientation.
        let tool_axes = shared_types::pose::rotation_from_rpy(
            start[3].to_radians(),
            start[4].to_radians(),
            start[5].to_radians(),
        );
        let in_axes = |world: [f64; 3]| -> [f64; 6] {
            let m = tool_axes.matrix();
            let local: [f64; 3] = if reference_type == 0 {
                core::array::from_fn(|i| (0..3).map(|j| m[(j, i)] * world[j]).sum())
            } else {
                world
            };
            [local[0], local[1], local[2], 0.0, 0.0, 0.0]
        };
        let request = relative_arc(
            in_axes([0.0, 0.0, 50.0]),
            in_axes([80.0, 0.0, 0.0]),
            reference_type,
            |w| {
                w.set_i8(mcr::request::CIRC_MODE, 3);
                w.set_bit(mcr::request::PATH_CHOICE, true);
            },
        );
        let mut lowest = f64::INFINITY;
        let done = follow_tcp(&mut plc, &request, (0, 0), |pose, _| {
            if let Some(pose) = pose {
                lowest = lowest.min(pose[1] - start[1]);
            }
        });
        assert_eq!((done.state, done.code), (state::DONE, 0), "{done:?}");
        assert!(
            lowest < -79.0,
            "ReferenceType {reference_type}: the short way round, {lowest:.1} mm"
        );
        assert_tcp_at(&mut plc, shifted(start, [80.0, 0.0, 0.0]));
    }
}
