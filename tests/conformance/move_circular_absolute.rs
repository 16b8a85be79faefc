//! MoveCircularAbsolute (2106): the TCP on an arc through the AuxPoint (CircMode BORDER) to
//! the EndPoint, the longer arc of a radius (RADIUS, PathChoice set), the PLC's Tolerance
//! (CENTER), and the checks of the arc parameters.

use plc_client::Request;
use shared_types::srci::message::{code, state};
use shared_types::srci::payload::{PayloadReader, PayloadWriter};
use shared_types::srci::tables::move_circular_absolute as mca;

use super::move_linear_absolute::orientation_deviation;
use super::move_requests::{
    assert_tcp_at, expect_move_done, follow_tcp, initialized_with_cyclic_tcp, keep_configuration,
    move_request, set_pose, shifted, tcp,
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
    let response = follow_arc(&mut plc, &arc(aux, end, |_| {}), centre, 50.0, |_| {});
    let r = PayloadReader::new(&response);
    assert_eq!(r.u16(mca::response::PROGRESS), 10_000);
    assert_eq!(r.f32(mca::response::REMAINING_DISTANCE), 0.0);
    assert_tcp_at(&mut plc, end);
}

#[test]
fn joint_interpolated_keeps_the_tcp_on_the_arc_and_ends_at_the_target_orientation() {
    let (_c, mut plc) = initialized_with_cyclic_tcp("mcaj");
    reset_and_enable(&mut plc);
    let start = tcp(&mut plc, 0, 0);
    let centre = shifted(start, [50.0, 0.0, 0.0]);
    let aux = shifted(start, [50.0, 50.0, 0.0]);
    let mut end = shifted(start, [100.0, 0.0, 0.0]);
    end[3] += 10.0;
    end[5] -= 15.0;
    let request = arc(aux, end, |w| w.set_u8(mca::request::ORI_MODE, 2));
    follow_arc(&mut plc, &request, centre, 50.0, |_| {});
    let reached = tcp(&mut plc, 0, 0);
    assert_tcp_at(&mut plc, end);
    assert!(
        orientation_deviation(reached, end) < 0.01,
        "{reached:?} vs {end:?}"
    );
}

/// Runs the arc of `request` to DONE and checks that the TCP (tool 0, frame 0) of every
/// telegram kept `radius` (mm) from `centre` in the world's XY plane through it; `sample`
/// sees each position. Returns the final response.
fn follow_arc(
    plc: &mut crate::common::Plc,
    request: &Request,
    centre: [f64; 6],
    radius: f64,
    mut sample: impl FnMut([f64; 6]),
) -> Vec<u8> {
    let mut worst: f64 = 0.0;
    let mut samples = 0;
    let done = follow_tcp(plc, request, (0, 0), |pose, _| {
        if let Some(pose) = pose {
            let r = ((pose[0] - centre[0]).powi(2) + (pose[1] - centre[1]).powi(2)).sqrt();
            worst = worst
                .max((r - radius).abs())
                .max((pose[2] - centre[2]).abs());
            samples += 1;
            sample(pose);
        }
    });
    assert_eq!((done.state, done.code), (state::DONE, 0), "{done:?}");
    assert!(samples > 20, "{samples} positions sampled");
    assert!(worst < 0.5, "the TCP left the arc by {worst:.3} mm");
    done.response
}

#[test]
fn radius_with_path_choice_set_takes_the_longer_arc_about_the_aux_vector() {
    let (_c, mut plc) = initialized_with_cyclic_tcp("mcarad");
    reset_and_enable(&mut plc);
    let start = tcp(&mut plc, 0, 0);
    // Radius 50 mm, chord 80 mm along X, the vector +Z: counter-clockwise seen from above.
    // The short arc's centre lies 30 mm to the left of the chord (+Y), the long one's 30 mm
    // to the right, and the long arc passes 80 mm below the start in Y.
    let end = shifted(start, [80.0, 0.0, 0.0]);
    let vector = [0.0, 0.0, 50.0, 0.0, 0.0, 0.0];
    let centre = shifted(start, [40.0, -30.0, 0.0]);
    let mut lowest = f64::INFINITY;
    let request = arc(vector, end, |w| {
        w.set_i8(mca::request::CIRC_MODE, 3);
        w.set_bit(mca::request::PATH_CHOICE, true);
    });
    follow_arc(&mut plc, &request, centre, 50.0, |pose| {
        lowest = lowest.min(pose[1] - start[1]);
    });
    assert!(lowest < -79.0, "the short way round: {lowest:.1} mm");
    assert_tcp_at(&mut plc, end);
}

#[test]
fn center_takes_the_plcs_tolerance_for_the_end() {
    let c = Controller::start("mcatol");
    let mut plc = c.client();
    initialize(&mut plc);
    reset_and_enable(&mut plc);
    let start = tcp(&mut plc, 0, 0);
    // About start + 50 mm X in the world's XY plane, the end 52 mm from the centre.
    let mut centre = shifted(start, [50.0, 0.0, 0.0]);
    centre[3..].copy_from_slice(&[0.0, 0.0, 0.0]);
    let end = shifted(start, [50.0, 52.0, 0.0]);
    let center = |tolerance: f32| {
        arc(centre, end, move |w| {
            w.set_i8(mca::request::CIRC_MODE, 1);
            w.set_i8(mca::request::CIRC_PLANE, 2);
            // Clockwise seen from above: the quarter from the start to the end.
            w.set_bit(mca::request::PATH_CHOICE, false);
            w.set_f32(mca::request::TOLERANCE, tolerance);
        })
    };
    // The default (Tolerance 0: 1 mm) and 1.5 mm refuse a 2 mm difference, 3 mm takes it.
    expect_error(&mut plc, &center(0.0), code::INVALID_POSITION);
    expect_error(&mut plc, &center(1.5), code::INVALID_POSITION);
    let response = expect_move_done(&mut plc, &center(3.0));
    assert_eq!(
        PayloadReader::new(&response).u16(mca::response::PROGRESS),
        10_000
    );
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
