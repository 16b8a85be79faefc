//! Displacements of the relative and offset moves (ReferenceType): given along and about the
//! axes of the tool (the TCP's own axes) or of a frame, and what they make of a pose.
//!
//! Poses are isometries in metres (see [`crate::tcp_pose::from_wire`]); a displacement is one
//! too: its translation is the shift, its rotation (`R = Rz·Ry·Rx` of the wire angles) the turn.

use nalgebra::{Isometry3, Translation3, UnitQuaternion};
use shared_types::pose;

/// ReferenceType of the relative and offset moves: the axes a displacement is given in.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ReferenceType {
    /// 0: along and about the axes of the TCP.
    Tool,
    /// 1: along and about the axes of the move's frame, the turn about the TCP.
    Frame,
}

impl ReferenceType {
    /// The type of a wire value, `None` for values the specification does not define.
    pub fn from_wire(v: u8) -> Option<Self> {
        match v {
            0 => Some(Self::Tool),
            1 => Some(Self::Frame),
            _ => None,
        }
    }
}

/// A displacement given in the axes of a frame whose orientation in the base frame is
/// `frame`, in base axes as the planner's `RelativeInBase` takes it: the shift rotated into
/// base axes (m), the turn as a rotation vector in base axes (rad).
pub fn in_base_axes(frame: &UnitQuaternion<f64>, displacement: &Isometry3<f64>) -> [f64; 6] {
    let shift = frame * displacement.translation.vector;
    let turn = (frame * displacement.rotation * frame.inverse()).scaled_axis();
    [shift.x, shift.y, shift.z, turn.x, turn.y, turn.z]
}

/// `reference` displaced by `offset` (both in the same frame): along and about the axes of
/// the reference pose itself (TOOL), or along the frame's axes and turned about the
/// reference's origin (FRAME).
pub fn offset(
    reference: &Isometry3<f64>,
    offset: &Isometry3<f64>,
    axes: ReferenceType,
) -> Isometry3<f64> {
    match axes {
        ReferenceType::Tool => reference * offset,
        ReferenceType::Frame => Isometry3::from_parts(
            Translation3::from(reference.translation.vector + offset.translation.vector),
            offset.rotation * reference.rotation,
        ),
    }
}

/// The tool-axes displacement as the planner's `RelativeInTool` takes it (m, rad).
pub fn in_tool_axes(displacement: &Isometry3<f64>) -> [f64; 6] {
    pose::pose(displacement)
}

#[cfg(test)]
mod tests {
    use super::*;
    use core::f64::consts::FRAC_PI_2;
    use nalgebra::Vector3;
    use proptest::prelude::*;

    fn iso(p: [f64; 6]) -> Isometry3<f64> {
        pose::isometry(p)
    }

    #[test]
    fn reference_types_are_tool_and_frame() {
        assert_eq!(ReferenceType::from_wire(0), Some(ReferenceType::Tool));
        assert_eq!(ReferenceType::from_wire(1), Some(ReferenceType::Frame));
        assert_eq!(ReferenceType::from_wire(2), None);
    }

    #[test]
    fn a_frame_displacement_is_rotated_into_base_axes() {
        // A frame turned 90° about Z: its X is the base Y.
        let frame = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), FRAC_PI_2);
        let d = in_base_axes(&frame, &iso([0.1, 0.0, 0.0, 0.2, 0.0, 0.0]));
        let expected = [0.0, 0.1, 0.0, 0.0, 0.2, 0.0];
        for (a, b) in d.iter().zip(expected) {
            assert!((a - b).abs() < 1e-12, "{d:?}");
        }
    }

    #[test]
    fn offsets_follow_the_reference_or_the_frame_axes() {
        // The reference's X axis points along the frame's Y.
        let reference = iso([0.5, 0.0, 0.3, 0.0, 0.0, FRAC_PI_2]);
        let shift = iso([0.1, 0.0, 0.0, 0.0, 0.0, 0.0]);
        let tool = offset(&reference, &shift, ReferenceType::Tool);
        assert!((tool.translation.vector - Vector3::new(0.5, 0.1, 0.3)).norm() < 1e-12);
        let frame = offset(&reference, &shift, ReferenceType::Frame);
        assert!((frame.translation.vector - Vector3::new(0.6, 0.0, 0.3)).norm() < 1e-12);
        let turn = iso([0.0, 0.0, 0.0, FRAC_PI_2, 0.0, 0.0]);
        let turned = offset(&reference, &turn, ReferenceType::Frame);
        assert_eq!(turned.translation, reference.translation);
        let expected = turn.rotation * reference.rotation;
        assert!(turned.rotation.angle_to(&expected) < 1e-12);
    }

    proptest! {
        #[test]
        fn a_base_displacement_of_a_frame_turn_is_the_conjugated_turn(
            f in prop::array::uniform3(-3.0f64..3.0),
            d in prop::array::uniform6(-1.0f64..1.0),
        ) {
            let frame = iso([0.0, 0.0, 0.0, f[0], f[1], f[2]]).rotation;
            let b = in_base_axes(&frame, &iso(d));
            let turn = UnitQuaternion::from_scaled_axis(Vector3::new(b[3], b[4], b[5]));
            let expected = frame * iso(d).rotation * frame.inverse();
            prop_assert!(turn.angle_to(&expected) < 1e-9);
            let shift = Vector3::new(b[0], b[1], b[2]).norm();
            prop_assert!((shift - Vector3::new(d[0], d[1], d[2]).norm()).abs() < 1e-12);
        }
    }
}
