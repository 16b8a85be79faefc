//! Relative targets made absolute (MoveAxesRelative, MoveDirectRelative, MoveLinearRelative,
//! MoveCircularRelative): a move whose [`TargetReference`] is relative is turned into the same
//! move with an absolute target once, when the planner accepts it, from the joints where it
//! starts. The rest of the planner only ever sees absolute targets.
//!
//! - Joint moves: `joints_rad` holds increments, added to the start joints.
//! - [`TargetReference::RelativeInBase`]: `pose` is a displacement in base axes; its x, y, z
//!   are added to the TCP position, its rotation vector turns the TCP orientation about the
//!   TCP itself (`R_target = Rot(r)·R_start`).
//! - [`TargetReference::RelativeInTool`]: `pose` is a displacement in the TCP's own axes,
//!   `T_target = T_start·T(pose)` (angles as everywhere, `R = Rz·Ry·Rx`).
//!
//! A circular move's `aux_pose` is relative to the same start as its `pose`.

use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};
use shared_types::ipc::{AXES, MotionCommand, MotionCommandKind, TargetReference};
use shared_types::pose;
use shared_types::srci::message::code;

use crate::kinematics::Kinematics;

/// A move's target reference cannot be resolved.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum TargetError {
    #[error("target reference {0} is not defined")]
    UndefinedReference(u8),
    #[error("a joint move cannot be relative to the tool")]
    JointMoveInTool,
}

impl TargetError {
    /// The SRCI message code reported for this error.
    pub fn code(&self) -> u16 {
        match self {
            Self::UndefinedReference(_) => code::INVALID_POSITION,
            Self::JointMoveInTool => code::INVALID_JOINT_POSITION,
        }
    }
}

/// `command` with an absolute target, for a move that starts at the joints `start` (rad);
/// commands that are not moves and absolute moves come back unchanged.
pub fn absolute(
    command: &MotionCommand,
    start: &[f64; AXES],
    kinematics: &Kinematics,
) -> Result<MotionCommand, TargetError> {
    let reference = TargetReference::from_wire(command.target_reference)
        .ok_or(TargetError::UndefinedReference(command.target_reference))?;
    let mut resolved = *command;
    resolved.target_reference = TargetReference::Absolute as u8;
    match (MotionCommandKind::from_wire(command.kind), reference) {
        (_, TargetReference::Absolute) => return Ok(*command),
        (Some(MotionCommandKind::MoveAxes), TargetReference::RelativeInBase) => {
            for (q, s) in resolved.joints_rad.iter_mut().zip(start) {
                *q += s;
            }
        }
        (Some(MotionCommandKind::MoveAxes), TargetReference::RelativeInTool) => {
            return Err(TargetError::JointMoveInTool);
        }
        (
            Some(
                MotionCommandKind::MoveDirect
                | MotionCommandKind::MoveLinear
                | MotionCommandKind::MoveCircular,
            ),
            _,
        ) => {
            let tcp = kinematics.flange(start) * pose::isometry(command.tool);
            resolved.pose = displaced(&tcp, command.pose, reference);
            if command.kind == MotionCommandKind::MoveCircular as u8 {
                resolved.aux_pose = displaced(&tcp, command.aux_pose, reference);
            }
        }
        // Group commands and waits have no target.
        _ => return Ok(*command),
    }
    Ok(resolved)
}

/// The pose `displacement` leads to from the TCP pose `tcp` (base frame, m and rad).
fn displaced(tcp: &Isometry3<f64>, displacement: [f64; 6], reference: TargetReference) -> [f64; 6] {
    let target = match reference {
        TargetReference::RelativeInTool => tcp * pose::isometry(displacement),
        TargetReference::RelativeInBase | TargetReference::Absolute => {
            let [x, y, z, rx, ry, rz] = displacement;
            Isometry3::from_parts(
                Translation3::from(tcp.translation.vector + Vector3::new(x, y, z)),
                UnitQuaternion::from_scaled_axis(Vector3::new(rx, ry, rz)) * tcp.rotation,
            )
        }
    };
    pose::pose(&target)
}

#[cfg(test)]
mod tests {
    use super::*;
    use core::f64::consts::FRAC_PI_2;
    use proptest::prelude::*;

    fn kinematics() -> Kinematics {
        let config = shared_types::config::Config::load(None).unwrap();
        Kinematics::new(&config.robot.kinematics)
    }

    /// A pose of the arm away from its singularities (rad).
    const START: [f64; AXES] = [0.3, 1.2, 1.4, 1.6, -1.4, 0.2];

    fn relative(kind: MotionCommandKind, reference: TargetReference) -> MotionCommand {
        let mut c = MotionCommand::new(kind);
        c.target_reference = reference as u8;
        c.tool = [0.0, 0.0, 0.1, 0.0, 0.0, 0.0];
        c
    }

    fn tcp(k: &Kinematics, c: &MotionCommand) -> Isometry3<f64> {
        k.flange(&START) * pose::isometry(c.tool)
    }

    fn assert_close(a: &Isometry3<f64>, b: &Isometry3<f64>) {
        let d = a.inverse() * b;
        assert!(
            d.translation.vector.norm() < 1e-9 && d.rotation.angle() < 1e-9,
            "{a:?} vs {b:?}"
        );
    }

    #[test]
    fn absolute_targets_and_group_commands_are_left_alone() {
        let k = kinematics();
        let mut c = MotionCommand::new(MotionCommandKind::MoveLinear);
        c.pose = [0.4, 0.1, 0.3, 0.1, 0.2, 0.3];
        assert_eq!(absolute(&c, &START, &k).unwrap().pose, c.pose);
        let mut stop = MotionCommand::new(MotionCommandKind::Stop);
        stop.target_reference = TargetReference::RelativeInBase as u8;
        assert_eq!(absolute(&stop, &START, &k).unwrap().joints_rad, [0.0; AXES]);
    }

    #[test]
    fn joint_increments_are_added_to_the_start() {
        let k = kinematics();
        let mut c = relative(MotionCommandKind::MoveAxes, TargetReference::RelativeInBase);
        c.joints_rad = [0.1, -0.2, 0.0, 0.0, 0.5, -1.0];
        let r = absolute(&c, &START, &k).unwrap();
        assert_eq!(r.target_reference, TargetReference::Absolute as u8);
        for ((q, s), d) in r.joints_rad.iter().zip(START).zip(c.joints_rad) {
            assert!((q - s - d).abs() < 1e-12);
        }
        let in_tool = relative(MotionCommandKind::MoveAxes, TargetReference::RelativeInTool);
        assert_eq!(
            absolute(&in_tool, &START, &k).unwrap_err(),
            TargetError::JointMoveInTool
        );
    }

    #[test]
    fn a_displacement_in_base_axes_shifts_the_tcp_and_turns_it_about_itself() {
        let k = kinematics();
        let mut c = relative(
            MotionCommandKind::MoveLinear,
            TargetReference::RelativeInBase,
        );
        c.pose = [0.05, -0.02, 0.1, 0.0, 0.0, FRAC_PI_2];
        let start = tcp(&k, &c);
        let target = pose::isometry(absolute(&c, &START, &k).unwrap().pose);
        let shift = target.translation.vector - start.translation.vector;
        assert!(
            (shift - Vector3::new(0.05, -0.02, 0.1)).norm() < 1e-9,
            "{shift}"
        );
        let turn = target.rotation * start.rotation.inverse();
        let expected = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), FRAC_PI_2);
        assert!(turn.angle_to(&expected) < 1e-9);
    }

    #[test]
    fn a_displacement_in_tool_axes_follows_the_tcp_axes() {
        let k = kinematics();
        let mut c = relative(
            MotionCommandKind::MoveDirect,
            TargetReference::RelativeInTool,
        );
        c.pose = [0.0, 0.0, 0.05, 0.0, 0.0, 0.0];
        let start = tcp(&k, &c);
        let target = pose::isometry(absolute(&c, &START, &k).unwrap().pose);
        let along_z = start.rotation * Vector3::new(0.0, 0.0, 0.05);
        assert!((target.translation.vector - start.translation.vector - along_z).norm() < 1e-9);
        assert!(target.rotation.angle_to(&start.rotation) < 1e-9);
    }

    #[test]
    fn a_relative_circle_resolves_its_aux_point_from_the_same_start() {
        let k = kinematics();
        let mut c = relative(
            MotionCommandKind::MoveCircular,
            TargetReference::RelativeInBase,
        );
        c.aux_pose = [0.05, 0.05, 0.0, 0.0, 0.0, 0.0];
        c.pose = [0.1, 0.0, 0.0, 0.0, 0.0, 0.0];
        let start = tcp(&k, &c);
        let r = absolute(&c, &START, &k).unwrap();
        for (p, d) in [(r.aux_pose, c.aux_pose), (r.pose, c.pose)] {
            let shift = pose::isometry(p).translation.vector - start.translation.vector;
            assert!((shift - Vector3::new(d[0], d[1], d[2])).norm() < 1e-9);
        }
    }

    #[test]
    fn an_undefined_reference_is_refused() {
        let mut c = MotionCommand::new(MotionCommandKind::MoveLinear);
        c.target_reference = 7;
        let e = absolute(&c, &START, &kinematics()).unwrap_err();
        assert_eq!(
            (e, e.code()),
            (TargetError::UndefinedReference(7), code::INVALID_POSITION)
        );
    }

    proptest! {
        #[test]
        fn a_tool_displacement_is_what_separates_start_and_target(
            d in prop::array::uniform6(-0.3f64..0.3),
        ) {
            let k = kinematics();
            let mut c = relative(MotionCommandKind::MoveLinear, TargetReference::RelativeInTool);
            c.pose = d;
            let start = tcp(&k, &c);
            let target = pose::isometry(absolute(&c, &START, &k).unwrap().pose);
            assert_close(&(start.inverse() * target), &pose::isometry(d));
        }

        #[test]
        fn a_base_displacement_keeps_the_rotation_vector(
            d in prop::array::uniform6(-0.5f64..0.5),
        ) {
            let k = kinematics();
            let mut c = relative(MotionCommandKind::MoveLinear, TargetReference::RelativeInBase);
            c.pose = d;
            let start = tcp(&k, &c);
            let target = pose::isometry(absolute(&c, &START, &k).unwrap().pose);
            let turn = (target.rotation * start.rotation.inverse()).scaled_axis();
            prop_assert!((turn - Vector3::new(d[3], d[4], d[5])).norm() < 1e-9);
        }
    }
}
