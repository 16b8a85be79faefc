//! MoveCircularAbsolute and MoveCircularRelative: the TCP on an arc through (or about) the
//! AuxPoint to the EndPoint. Both points go through the tool and FrameNo into the base frame
//! as MoveLinearAbsolute's target does; for the relative move both are distances from where
//! the move starts, in the axes ReferenceType names, made absolute by the planner.
//!
//! In RADIUS mode the AuxPoint's X, Y, Z are a vector, "the spearhead point of the
//! perpendicular" of the circle's plane, its length the radius (the PLCopen MC_MoveCircular
//! definition the CircMode text repeats): it reaches the planner as the radius and as the
//! EndPoint displaced by that vector, so that it turns with the frame or, for the relative
//! move, with the ReferenceType's axes exactly as the EndPoint does. PathChoice then selects
//! the shorter (0) or the longer (1) of the two arcs, as PLCopen's PathChoice does.
//!
//! Table 6-357 (MoveCircularRelative) lists ConfigMode[1] and ReferenceType as bits of byte
//! 111; the generated fields have them corrected (ConfigMode[1] a full byte, ReferenceType
//! the byte before TurnMode: `CORRECTIONS` in shared-types/build.rs). PathChoice and
//! Manipulation share byte 108 (bits 0 and 1).

use shared_types::ipc::{MotionCommand, MotionCommandKind};
use shared_types::srci::message::CommandHeader;
use shared_types::srci::message::code::{
    ANGLE_ONLY_CENTER_WITH_ANGLE, INVALID_CIRC_MODE, INVALID_CIRC_PLANE, TOLERANCE_ONLY_CENTER,
};
use shared_types::srci::payload::{Field, PayloadReader};
use shared_types::srci::tables::{move_circular_absolute as mca, move_circular_relative as mcr};

use super::motion::{self, CartesianLayout, DynamicsLayout, MoveLayout, wire_pose};
use super::relative::{reference_type, relative_target};
use crate::tcp_pose;
use crate::user_data::UserData;

/// CircMode BORDER: the AuxPoint lies on the arc; CircPlane is not used.
const BORDER: i8 = 0;
/// CircMode CENTER: the AuxPoint is the centre; Tolerance applies.
const CENTER: i8 = 1;
/// CircMode CENTER_WITH_ANGLE: the AuxPoint is the centre, Angle gives the end.
const CENTER_WITH_ANGLE: i8 = 2;
/// CircMode RADIUS: the AuxPoint's vector is the normal of the plane, its length the radius;
/// CircPlane is not used.
const RADIUS: i8 = 3;

/// The arc parameters of a request, checked, in the planner's units.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CircleParameters {
    pub mode: u8,
    pub plane: u8,
    pub angle_rad: f64,
    /// How far the end of a CENTER arc may lie off the circle (m); 0 = the planner's default.
    pub tolerance_m: f64,
}

/// Checks CircMode, CircPlane (0..2 where the mode uses it: the center modes), Tolerance
/// (CENTER only, mm ≥ 0) and Angle (CENTER_WITH_ANGLE only, degrees).
pub fn circle_parameters(
    mode: i8,
    plane: i8,
    tolerance: f32,
    angle_deg: f32,
) -> Result<CircleParameters, u16> {
    if !(BORDER..=RADIUS).contains(&mode) {
        return Err(INVALID_CIRC_MODE);
    }
    let plane = match plane {
        _ if mode == BORDER || mode == RADIUS => 0,
        0..=2 => plane,
        _ => return Err(INVALID_CIRC_PLANE),
    };
    if !(tolerance.is_finite() && tolerance >= 0.0) || (tolerance != 0.0 && mode != CENTER) {
        return Err(TOLERANCE_ONLY_CENTER);
    }
    if !angle_deg.is_finite() || (angle_deg != 0.0 && mode != CENTER_WITH_ANGLE) {
        return Err(ANGLE_ONLY_CENTER_WITH_ANGLE);
    }
    // Both checked to lie in 0..=3 and 0..=2.
    Ok(CircleParameters {
        mode: mode as u8,
        plane: plane as u8,
        angle_rad: f64::from(angle_deg).to_radians(),
        tolerance_m: f64::from(tolerance) / 1000.0,
    })
}

/// Where a circular move's fields sit: the EndPoint as the Cartesian target, the AuxPoint,
/// the arc parameters, and the ReferenceType of the relative move.
struct CircularLayout {
    end: CartesianLayout,
    aux: [Field; 6],
    circ_mode: Field,
    circ_plane: Field,
    tolerance: Field,
    angle: Field,
    path_choice: Field,
    ori_mode: Field,
    reference_type: Option<Field>,
}

const MOVE_CIRCULAR_ABSOLUTE: CircularLayout = CircularLayout {
    end: CartesianLayout {
        common: MoveLayout {
            dynamics: DynamicsLayout {
                velocity: mca::request::VELOCITY_RATE,
                acceleration: mca::request::ACCELERATION_RATE,
                deceleration: mca::request::DECELERATION_RATE,
                jerk: mca::request::JERK_RATE,
                time: mca::request::TIME,
            },
            tool: mca::request::TOOL_NO,
            blending_mode: mca::request::BLENDING_MODE,
            blending_parameter: mca::request::BLENDING_PARAMETER,
        },
        frame: mca::request::FRAME_NO,
        position: mca::request::END_POINT_X_RZ,
        shoulder: mca::request::SHOULDER_2,
        elbow: mca::request::ELBOW_2,
        wrist: mca::request::WRIST_2,
        turn_number: mca::request::END_POINT_TURN_NUMBER,
        config_mode: mca::request::CONFIG_MODE,
        turn_mode: mca::request::TURN_MODE,
    },
    aux: mca::request::AUX_POINT_X_RZ,
    circ_mode: mca::request::CIRC_MODE,
    circ_plane: mca::request::CIRC_PLANE,
    tolerance: mca::request::TOLERANCE,
    angle: mca::request::ANGLE,
    path_choice: mca::request::PATH_CHOICE,
    ori_mode: mca::request::ORI_MODE,
    reference_type: None,
};

const MOVE_CIRCULAR_RELATIVE: CircularLayout = CircularLayout {
    end: CartesianLayout {
        common: MoveLayout {
            dynamics: DynamicsLayout {
                velocity: mcr::request::VELOCITY_RATE,
                acceleration: mcr::request::ACCELERATION_RATE,
                deceleration: mcr::request::DECELERATION_RATE,
                jerk: mcr::request::JERK_RATE,
                time: mcr::request::TIME,
            },
            tool: mcr::request::TOOL_NO,
            blending_mode: mcr::request::BLENDING_MODE,
            blending_parameter: mcr::request::BLENDING_PARAMETER,
        },
        frame: mcr::request::FRAME_NO,
        position: mcr::request::END_POINT_X_RZ,
        shoulder: mcr::request::SHOULDER_2,
        elbow: mcr::request::ELBOW_2,
        wrist: mcr::request::WRIST_2,
        turn_number: mcr::request::END_POINT_TURN_NUMBER,
        config_mode: mcr::request::CONFIG_MODE,
        turn_mode: mcr::request::TURN_MODE,
    },
    aux: mcr::request::AUX_POINT_X_RZ,
    circ_mode: mcr::request::CIRC_MODE,
    circ_plane: mcr::request::CIRC_PLANE,
    tolerance: mcr::request::TOLERANCE,
    angle: mcr::request::ANGLE,
    path_choice: mcr::request::PATH_CHOICE,
    ori_mode: mcr::request::ORI_MODE,
    reference_type: Some(mcr::request::REFERENCE_TYPE),
};

/// Checks a MoveCircularAbsolute or MoveCircularRelative request and turns it into a
/// MoveCircular: the EndPoint with its configuration and turns, the AuxPoint (its own
/// configuration and turns are not used: the arc passes it, the arm does not stop there),
/// the arc parameters, PathChoice and OriMode. In RADIUS mode the AuxPoint's vector (mm) is
/// the normal of the plane, its length the radius (see the module documentation).
pub(super) fn decode(msg: &[u8], h: CommandHeader, data: &UserData) -> Result<MotionCommand, u16> {
    let layout = if h.command_type == mcr::TYPE {
        &MOVE_CIRCULAR_RELATIVE
    } else {
        &MOVE_CIRCULAR_ABSOLUTE
    };
    let (mut c, end) =
        motion::decode_cartesian(msg, h, data, &layout.end, MotionCommandKind::MoveCircular)?;
    let r = PayloadReader::new(msg);
    let mut aux = wire_pose(&r, layout.aux)?;
    let circle = circle_parameters(
        r.i8(layout.circ_mode),
        r.i8(layout.circ_plane),
        r.f32(layout.tolerance),
        r.f32(layout.angle),
    )?;
    c.circle_mode = circle.mode;
    c.circle_plane = circle.plane;
    c.circle_angle_rad = circle.angle_rad;
    c.circle_tolerance_m = circle.tolerance_m;
    if circle.mode == RADIUS as u8 {
        c.circle_radius_m = (aux[0] * aux[0] + aux[1] * aux[1] + aux[2] * aux[2]).sqrt() / 1000.0;
        // The vector from the EndPoint: turned into the base frame as the EndPoint is.
        aux = [
            end[0] + aux[0],
            end[1] + aux[1],
            end[2] + aux[2],
            end[3],
            end[4],
            end[5],
        ];
    }
    c.path_choice = u8::from(r.bit(layout.path_choice));
    c.ori_mode = motion::ori_mode(msg, layout.ori_mode)?;
    let frame = r.u8(layout.end.frame);
    match layout.reference_type {
        None => {
            c.pose = tcp_pose::world_target(data, frame, end)?;
            c.aux_pose = tcp_pose::world_target(data, frame, aux)?;
        }
        Some(field) => {
            let axes = reference_type(&r, field)?;
            let (pose, reference) = relative_target(data, frame, end, axes)?;
            c.pose = pose;
            c.target_reference = reference as u8;
            (c.aux_pose, _) = relative_target(data, frame, aux, axes)?;
        }
    }
    Ok(c)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::commands::test_support::{cartesian_request, factory_data, header};
    use shared_types::ipc::TargetReference;
    use shared_types::srci::message::code;
    use shared_types::srci::payload::PayloadWriter;

    /// A circle the planner refuses for its points (on one line, off its plane) ends with
    /// 0x8D24, whose message used to say only "not a finite number".
    #[test]
    fn the_message_of_an_invalid_position_names_the_arc_too() {
        let text = crate::commands::describe(code::INVALID_POSITION);
        assert!(
            text.contains("not a finite number") && text.contains("no arc"),
            "{text}"
        );
    }

    #[test]
    fn arc_parameters_are_checked_with_the_codes_of_the_specification() {
        assert_eq!(
            circle_parameters(0, 7, 0.0, 0.0),
            Ok(CircleParameters {
                mode: 0,
                plane: 0,
                angle_rad: 0.0,
                tolerance_m: 0.0,
            })
        );
        let center = circle_parameters(1, 2, 0.5, 0.0).unwrap();
        assert_eq!(center.plane, 2);
        assert!((center.tolerance_m - 5e-4).abs() < 1e-12);
        // RADIUS takes its plane from the AuxPoint's vector: CircPlane is not checked.
        assert_eq!(circle_parameters(3, 9, 0.0, 0.0).unwrap().plane, 0);
        let angle = circle_parameters(2, 1, 0.0, -90.0).unwrap();
        assert!((angle.angle_rad + core::f64::consts::FRAC_PI_2).abs() < 1e-12);
        assert_eq!(circle_parameters(3, 0, 0.0, 0.0).unwrap().mode, 3);
        let refusals = [
            ((4, 0, 0.0, 0.0), INVALID_CIRC_MODE),
            ((-1, 0, 0.0, 0.0), INVALID_CIRC_MODE),
            ((2, 3, 0.0, 10.0), INVALID_CIRC_PLANE),
            ((0, 0, 1.0, 0.0), TOLERANCE_ONLY_CENTER),
            ((1, 0, -1.0, 0.0), TOLERANCE_ONLY_CENTER),
            ((1, 0, f32::NAN, 0.0), TOLERANCE_ONLY_CENTER),
            ((1, 0, 0.0, 30.0), ANGLE_ONLY_CENTER_WITH_ANGLE),
            ((2, 0, 0.0, f32::INFINITY), ANGLE_ONLY_CENTER_WITH_ANGLE),
        ];
        for ((mode, plane, tolerance, angle), expected) in refusals {
            assert_eq!(
                circle_parameters(mode, plane, tolerance, angle),
                Err(expected),
                "{mode} {plane} {tolerance} {angle}"
            );
        }
    }

    fn request(layout: &CircularLayout, edit: impl FnOnce(&mut PayloadWriter)) -> Vec<u8> {
        let end = [400.0, 100.0, 300.0, 180.0, 0.0, 0.0];
        cartesian_request(&layout.end, mca::request::LEN, end, |w| {
            for (f, v) in layout
                .aux
                .into_iter()
                .zip([450.0, 50.0, 300.0, 180.0, 0.0, 0.0])
            {
                w.set_f32(f, v);
            }
            edit(w);
        })
    }

    #[test]
    fn an_absolute_arc_reaches_the_planner_in_the_base_frame() {
        let msg = request(&MOVE_CIRCULAR_ABSOLUTE, |w| {
            w.set_bit(mca::request::PATH_CHOICE, true);
            w.set_u8(mca::request::ORI_MODE, 4);
        });
        let c = decode(&msg, header(mca::TYPE), &factory_data()).unwrap();
        assert_eq!(c.kind, MotionCommandKind::MoveCircular as u8);
        assert_eq!((c.path_choice, c.ori_mode, c.circle_mode), (1, 4, 0));
        assert_eq!(c.target_reference, TargetReference::Absolute as u8);
        for (a, b) in c.aux_pose.iter().zip([0.45, 0.05, 0.3]) {
            assert!((a - b).abs() < 1e-9, "{:?}", c.aux_pose);
        }
        for (a, b) in c.pose.iter().zip([0.4, 0.1, 0.3]) {
            assert!((a - b).abs() < 1e-9, "{:?}", c.pose);
        }
    }

    #[test]
    fn a_radius_arc_takes_the_aux_vector_as_the_normal_and_its_length_as_the_radius() {
        let radius = |layout: &CircularLayout, reference_type: u8| {
            request(layout, |w| {
                w.set_i8(layout.circ_mode, 3);
                w.set_bit(layout.path_choice, true);
                for (f, v) in layout.aux.into_iter().zip([0.0, 30.0, 40.0]) {
                    w.set_f32(f, v);
                }
                if let Some(field) = layout.reference_type {
                    w.set_u8(field, reference_type);
                }
            })
        };
        let msg = radius(&MOVE_CIRCULAR_ABSOLUTE, 0);
        let c = decode(&msg, header(mca::TYPE), &factory_data()).unwrap();
        assert!((c.circle_radius_m - 0.05).abs() < 1e-9);
        assert_eq!((c.circle_mode, c.path_choice), (3, 1));
        // The EndPoint (400, 100, 300) displaced by the vector, with the EndPoint's turn.
        for (a, b) in c.aux_pose.iter().zip([0.4, 0.13, 0.34]) {
            assert!((a - b).abs() < 1e-9, "{:?}", c.aux_pose);
        }
        assert_eq!(c.aux_pose[3..], c.pose[3..]);
        // Relative, in the tool's axes: the same offset from the EndPoint's distance.
        let msg = radius(&MOVE_CIRCULAR_RELATIVE, 0);
        let c = decode(&msg, header(mcr::TYPE), &factory_data()).unwrap();
        assert_eq!(c.target_reference, TargetReference::RelativeInTool as u8);
        for i in 0..3 {
            let offset = c.aux_pose[i] - c.pose[i];
            assert!(
                (offset - [0.0, 0.03, 0.04][i]).abs() < 1e-9,
                "{:?}",
                c.aux_pose
            );
        }
    }

    #[test]
    fn a_relative_arc_carries_both_points_as_distances() {
        let msg = request(&MOVE_CIRCULAR_RELATIVE, |w| {
            let reference_type = MOVE_CIRCULAR_RELATIVE.reference_type.unwrap();
            w.set_u8(reference_type, 1);
        });
        let c = decode(&msg, header(mcr::TYPE), &factory_data()).unwrap();
        assert_eq!(c.target_reference, TargetReference::RelativeInBase as u8);
        assert!((c.aux_pose[0] - 0.45).abs() < 1e-9 && (c.pose[1] - 0.1).abs() < 1e-9);
        let undefined = request(&MOVE_CIRCULAR_RELATIVE, |w| {
            w.set_u8(MOVE_CIRCULAR_RELATIVE.reference_type.unwrap(), 5);
        });
        assert_eq!(
            decode(&undefined, header(mcr::TYPE), &factory_data()).unwrap_err(),
            code::INVALID_MODE
        );
    }
}
