//! MoveAxesRelative, MoveDirectRelative and MoveLinearRelative: a target given as a distance
//! from where the move starts (the end of the move before it in its sequence). The planner
//! adds it when it accepts the move; here it is checked and put into the axes the planner
//! takes (see `TargetReference`).

use shared_types::ipc::{MotionCommand, MotionCommandKind, TargetReference};
use shared_types::srci::message::{CommandHeader, code};
use shared_types::srci::payload::{Field, PayloadReader};
use shared_types::srci::tables::{
    move_axes_relative as mar, move_direct_relative as mdr, move_linear_relative as mlr,
};

use super::motion::{self, CartesianLayout, DynamicsLayout, MoveLayout, decode_move, joint_value};
use crate::displacement::{self, ReferenceType};
use crate::tcp_pose::{self, WirePose};
use crate::user_data::UserData;

const MOVE_AXES_RELATIVE: MoveLayout = MoveLayout {
    dynamics: DynamicsLayout {
        velocity: mar::request::VELOCITY_RATE,
        acceleration: mar::request::ACCELERATION_RATE,
        deceleration: mar::request::DECELERATION_RATE,
        jerk: mar::request::JERK_RATE,
        time: mar::request::TIME,
    },
    tool: mar::request::TOOL_NO,
    blending_mode: mar::request::BLENDING_MODE,
    blending_parameter: mar::request::BLENDING_PARAMETER,
};

/// Where a relative Cartesian move's distance, ReferenceType and OriMode sit.
struct RelativeLayout {
    distance: CartesianLayout,
    reference_type: Field,
    ori_mode: Option<Field>,
}

const MOVE_DIRECT_RELATIVE: RelativeLayout = RelativeLayout {
    distance: CartesianLayout {
        common: MoveLayout {
            dynamics: DynamicsLayout {
                velocity: mdr::request::VELOCITY_RATE,
                acceleration: mdr::request::ACCELERATION_RATE,
                deceleration: mdr::request::DECELERATION_RATE,
                jerk: mdr::request::JERK_RATE,
                time: mdr::request::TIME,
            },
            tool: mdr::request::TOOL_NO,
            blending_mode: mdr::request::BLENDING_MODE,
            blending_parameter: mdr::request::BLENDING_PARAMETER,
        },
        frame: mdr::request::FRAME_NO,
        position: mdr::request::DISTANCE_X_RZ,
        shoulder: mdr::request::SHOULDER,
        elbow: mdr::request::ELBOW,
        wrist: mdr::request::WRIST,
        turn_number: mdr::request::DISTANCE_TURN_NUMBER,
        config_mode: mdr::request::CONFIG_MODE,
        turn_mode: mdr::request::TURN_MODE,
    },
    reference_type: mdr::request::REFERENCE_TYPE,
    ori_mode: None,
};

const MOVE_LINEAR_RELATIVE: RelativeLayout = RelativeLayout {
    distance: CartesianLayout {
        common: MoveLayout {
            dynamics: DynamicsLayout {
                velocity: mlr::request::VELOCITY_RATE,
                acceleration: mlr::request::ACCELERATION_RATE,
                deceleration: mlr::request::DECELERATION_RATE,
                jerk: mlr::request::JERK_RATE,
                time: mlr::request::TIME,
            },
            tool: mlr::request::TOOL_NO,
            blending_mode: mlr::request::BLENDING_MODE,
            blending_parameter: mlr::request::BLENDING_PARAMETER,
        },
        frame: mlr::request::FRAME_NO,
        position: mlr::request::DISTANCE_X_RZ,
        shoulder: mlr::request::SHOULDER,
        elbow: mlr::request::ELBOW,
        wrist: mlr::request::WRIST,
        turn_number: mlr::request::DISTANCE_TURN_NUMBER,
        config_mode: mlr::request::CONFIG_MODE,
        turn_mode: mlr::request::TURN_MODE,
    },
    reference_type: mlr::request::REFERENCE_TYPE,
    ori_mode: Some(mlr::request::ORI_MODE),
};

/// Checks a MoveAxesRelative request: JointDistance (degrees) as joint increments (rad).
/// The SW limits apply to the target, which only the planner knows.
pub(super) fn decode_axes(
    msg: &[u8],
    h: CommandHeader,
    data: &UserData,
) -> Result<MotionCommand, u16> {
    let r = PayloadReader::new(msg);
    let mut c = decode_move(
        &r,
        &MOVE_AXES_RELATIVE,
        h,
        MotionCommandKind::MoveAxes,
        data,
    )?;
    for (q, f) in c
        .joints_rad
        .iter_mut()
        .zip(mar::request::JOINT_DISTANCE_J1_J6)
    {
        *q = f64::from(joint_value(&r, f)?).to_radians();
    }
    c.target_reference = TargetReference::RelativeInBase as u8;
    Ok(c)
}

/// Checks a MoveDirectRelative or MoveLinearRelative request: the Distance in the axes its
/// ReferenceType names (the tool's, or FrameNo's turned into base axes). The configuration
/// and turns sent with the Distance are handed on as they are, for ConfigMode and TurnMode.
pub(super) fn decode_cartesian(
    msg: &[u8],
    h: CommandHeader,
    data: &UserData,
) -> Result<MotionCommand, u16> {
    let (layout, kind) = if h.command_type == mlr::TYPE {
        (&MOVE_LINEAR_RELATIVE, MotionCommandKind::MoveLinear)
    } else {
        (&MOVE_DIRECT_RELATIVE, MotionCommandKind::MoveDirect)
    };
    let (mut c, distance) = motion::decode_cartesian(msg, h, data, &layout.distance, kind)?;
    let r = PayloadReader::new(msg);
    let axes = reference_type(&r, layout.reference_type)?;
    let (pose, reference) = relative_target(data, r.u8(layout.distance.frame), distance, axes)?;
    c.pose = pose;
    c.target_reference = reference as u8;
    if let Some(field) = layout.ori_mode {
        c.ori_mode = motion::ori_mode(msg, field)?;
    }
    Ok(c)
}

/// The ReferenceType in `field`, or 0x8D21 (invalid Mode) for an undefined value.
pub(super) fn reference_type(r: &PayloadReader<'_>, field: Field) -> Result<ReferenceType, u16> {
    ReferenceType::from_wire(r.u8(field)).ok_or(code::INVALID_MODE)
}

/// A distance (mm, degrees) along and about the tool's axes or those of frame `frame`, as
/// the planner's relative target (m, rad), or the code that refuses the frame.
pub(super) fn relative_target(
    data: &UserData,
    frame: u8,
    distance: WirePose,
    axes: ReferenceType,
) -> Result<([f64; 6], TargetReference), u16> {
    let d = tcp_pose::from_wire(distance);
    Ok(match axes {
        ReferenceType::Tool => (
            displacement::in_tool_axes(&d),
            TargetReference::RelativeInTool,
        ),
        ReferenceType::Frame => {
            let frame = tcp_pose::world_frame(data, frame)?;
            (
                displacement::in_base_axes(&frame.rotation, &d),
                TargetReference::RelativeInBase,
            )
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::commands::test_support::{cartesian_request, default_rates, factory_data, header};
    use crate::user_data::FrameData;
    use shared_types::srci::payload::PayloadWriter;

    /// Factory user data with frame 2 turned 90° about Z.
    fn data() -> UserData {
        let mut data = factory_data();
        let frame = FrameData {
            pose: [100.0, 0.0, 0.0, 0.0, 0.0, 90.0],
            ..Default::default()
        };
        data.write_frame(2, Default::default(), frame).unwrap();
        data
    }

    fn request(
        layout: &RelativeLayout,
        len: usize,
        edit: impl FnOnce(&mut PayloadWriter),
    ) -> Vec<u8> {
        cartesian_request(
            &layout.distance,
            len,
            [50.0, 0.0, -20.0, 0.0, 0.0, 10.0],
            edit,
        )
    }

    #[test]
    fn joint_distances_become_increments() {
        let mut b = vec![0u8; mar::request::LEN];
        let mut w = PayloadWriter::new(&mut b);
        default_rates(&mut w, &MOVE_AXES_RELATIVE.dynamics);
        w.set_f32(mar::request::JOINT_DISTANCE_J6, -90.0);
        let c = decode_axes(&b, header(mar::TYPE), &data()).unwrap();
        assert_eq!(c.target_reference, TargetReference::RelativeInBase as u8);
        assert!((c.joints_rad[5] + core::f64::consts::FRAC_PI_2).abs() < 1e-6);
        PayloadWriter::new(&mut b).set_f32(mar::request::JOINT_DISTANCE_J1, f32::NAN);
        assert_eq!(
            decode_axes(&b, header(mar::TYPE), &data()).unwrap_err(),
            code::INVALID_JOINT_POSITION
        );
    }
    #[test]
    fn a_tool_distance_stays_in_tool_axes() {
        let msg = request(&MOVE_LINEAR_RELATIVE, mlr::request::LEN, |w| {
            w.set_u8(mlr::request::ORI_MODE, 1);
        });
        let c = decode_cartesian(&msg, header(mlr::TYPE), &data()).unwrap();
        assert_eq!(
            (c.kind, c.target_reference, c.ori_mode),
            (
                MotionCommandKind::MoveLinear as u8,
                TargetReference::RelativeInTool as u8,
                1
            )
        );
        assert!((c.pose[0] - 0.05).abs() < 1e-9 && (c.pose[2] + 0.02).abs() < 1e-9);
        assert!((c.pose[5] - 10f64.to_radians()).abs() < 1e-9);
    }

    #[test]
    fn a_frame_distance_is_turned_into_base_axes() {
        let msg = request(&MOVE_DIRECT_RELATIVE, mdr::request::LEN, |w| {
            w.set_u8(mdr::request::REFERENCE_TYPE, 1);
            w.set_u8(mdr::request::FRAME_NO, 2);
        });
        let c = decode_cartesian(&msg, header(mdr::TYPE), &data()).unwrap();
        assert_eq!(c.kind, MotionCommandKind::MoveDirect as u8);
        assert_eq!(c.target_reference, TargetReference::RelativeInBase as u8);
        // 50 mm along the frame's X is 50 mm along the world's Y.
        let expected = [0.0, 0.05, -0.02, 0.0, 0.0, 10f64.to_radians()];
        for (a, b) in c.pose.iter().zip(expected) {
            assert!((a - b).abs() < 1e-9, "{:?}", c.pose);
        }
    }

    #[test]
    fn undefined_reference_types_and_frames_are_refused() {
        let undefined = request(&MOVE_LINEAR_RELATIVE, mlr::request::LEN, |w| {
            w.set_u8(mlr::request::REFERENCE_TYPE, 2);
        });
        assert_eq!(
            decode_cartesian(&undefined, header(mlr::TYPE), &data()).unwrap_err(),
            code::INVALID_MODE
        );
        let no_frame = request(&MOVE_LINEAR_RELATIVE, mlr::request::LEN, |w| {
            w.set_u8(mlr::request::REFERENCE_TYPE, 1);
            w.set_u8(mlr::request::FRAME_NO, 40);
        });
        assert_eq!(
            decode_cartesian(&no_frame, header(mlr::TYPE), &data()).unwrap_err(),
            code::INVALID_FRAME_NO
        );
    }
}
