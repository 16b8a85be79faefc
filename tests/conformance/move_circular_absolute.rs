//! MoveCircularAbsolute (2106): the TCP on an arc through the AuxPoint (CircMode BORDER) to
//! the EndPoint, and the checks of the arc parameters.

use std::time::Duration;

use plc_client::Request;
use shared_types::srci::message::code;
use shared_types::srci::payload::{PayloadReader, PayloadWriter};
use shared_types::srci::tables::move_circular_absolute as mca;

use super::move_requests::{
    assert_tcp_at, initialized_with_cyclic_tcp, keep_configuration, move_request, set_pose,
    shifted, tcp,
};
use crate::common::{Controller, expect_error, initialize, reset_and_enable};

/// A BORDER arc through `aux` to `end` (mm, degrees, frame 0, tool 0).
pub fn arc(aux: [f64; 6], end: [f64; 6], edit: impl FnOnce(&mut PayloadWriter)) -> Request {
    let rates = [
        mca::request::VELOCITY_RATE,
        mca::request::ACCELERATION_RATE,
        mca::request::DECELERATION_RATE,
        mca::request::JERK_RATE,
    ];
    move_request(mca::TYPE, rates, |w| {
        set_pose(w, mca::request::AUX_POINT_X_RZ, aux);
        set_pose(w, mca::request::END_POINT_X_RZ, end);
        keep_configuration(w, mca::request::CONFIG_MODE, mca::request::TURN_MODE);
        w.set_u8(mca::request::ORI_MODE, 1);
        edit(w);
    })
}

#[test]
fn the_tcp_follows_the_arc_through_the_aux_point() {
    let (_c, mut plc) = initialized_with_cyclic_tcp("mca");
    reset_and_enable(&mut plc);
    let start = tcp(&mut plc, 0, 0);
    // A half circle of radius 50 mm about start + 50 mm X, in the world's XY plane.
    let centre = shifted(start, [50.0, 0.0, 0.0]);
    let aux = shifted(start, [50.0, 50.0, 0.0]);
    let end = shifted(start, [100.0, 0.0, 0.0]);
    let handle = plc
        .task_mut()
        .submit(&arc(aux, end, |_| {}))
        .expect("submit");
    let mut worst: f64 = 0.0;
    let mut samples = 0;
    plc.run_until(
        |t| {
            if let Some(p) = t.cyclic_position()
                && p.tool_frame == Some((0, 0))
                && let Some(pose) = p.cartesian
            {
                let r = ((pose[0] - centre[0]).powi(2) + (pose[1] - centre[1]).powi(2)).sqrt();
                worst = worst.max((r - 50.0).abs()).max((pose[2] - centre[2]).abs());
                samples += 1;
            }
            t.status(handle).is_some_and(|s| s.is_final())
        },
        Duration::from_secs(20),
    )
    .expect("the arc ends");
    let done = plc.task().status(handle).cloned().expect("status");
    assert_eq!(
        (done.state, done.code),
        (shared_types::srci::message::state::DONE, 0),
        "{done:?}"
    );
    let r = PayloadReader::new(&done.response);
    assert_eq!(r.u16(mca::response::PROGRESS), 10_000);
    assert_eq!(r.f32(mca::response::REMAINING_DISTANCE), 0.0);
    assert!(samples > 20, "{samples} positions sampled");
    assert!(worst < 0.5, "the TCP left the arc by {worst:.3} mm");
    assert_tcp_at(&mut plc, end);
}

#[test]
fn arc_parameters_are_checked() {
    let c = Controller::start("mcaerr");
    let mut plc = c.client();
    initialize(&mut plc);
    reset_and_enable(&mut plc);
    let start = tcp(&mut plc, 0, 0);
    let aux = shifted(start, [50.0, 50.0, 0.0]);
    let end = shifted(start, [100.0, 0.0, 0.0]);
    expect_error(
        &mut plc,
        &arc(aux, end, |w| w.set_i8(mca::request::CIRC_MODE, 5)),
        code::INVALID_CIRC_MODE,
    );
    expect_error(
        &mut plc,
        &arc(aux, end, |w| w.set_f32(mca::request::ANGLE, 90.0)),
        code::ANGLE_ONLY_CENTER_WITH_ANGLE,
    );
    expect_error(
        &mut plc,
        &arc(aux, end, |w| w.set_f32(mca::request::AUX_POINT_Z, f32::NAN)),
        code::INVALID_POSITION,
    );
}
