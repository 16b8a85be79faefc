//! Jogging in frame or tool coordinates: where a jog step takes the TCP.
//!
//! Translations follow the axes of the jog frame (FrameNo's axes in frame mode, the tool's
//! own axes in tool mode); rotations turn the TCP about those axes through the TCP itself.
//! Several direction bits at once combine into one direction (one axis of rotation).

use nalgebra::{Isometry3, Translation3, Unit, UnitQuaternion, Vector3};

/// A jog step: per axis X, Y, Z, RX, RY, RZ a direction (+1, -1, 0), the distance of the
/// translation (m) and the angle of the rotation (rad).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct JogStep {
    /// Axes of the tool (true) or of the frame (false).
    pub in_tool: bool,
    pub directions: [i8; 6],
    pub distance_m: f64,
    pub angle_rad: f64,
}

impl JogStep {
    /// The same step, half as far (continuous jogging backs off from an unreachable end).
    pub fn halved(self) -> Self {
        Self {
            distance_m: self.distance_m / 2.0,
            angle_rad: self.angle_rad / 2.0,
            ..self
        }
    }
}

/// The TCP pose (world) after `step` from `tcp` (world), with the jog frame `frame` (world)
/// in frame mode.
pub fn target(tcp: &Isometry3<f64>, frame: &Isometry3<f64>, step: &JogStep) -> Isometry3<f64> {
    let axes = if step.in_tool {
        tcp.rotation
    } else {
        frame.rotation
    };
    let d = step.directions.map(f64::from);
    let mut result = *tcp;
    if let Some(direction) = Unit::try_new(Vector3::new(d[0], d[1], d[2]), 1e-9) {
        let shift = axes * (direction.into_inner() * step.distance_m);
        result.translation = Translation3::from(tcp.translation.vector + shift);
    }
    if let Some(axis) = Unit::try_new(axes * Vector3::new(d[3], d[4], d[5]), 1e-9) {
        result.rotation = UnitQuaternion::from_axis_angle(&axis, step.angle_rad) * tcp.rotation;
    }
    result
}

#[cfg(test)]
mod tests {
    use super::*;
    use core::f64::consts::FRAC_PI_2;
    use shared_types::pose::isometry;

    fn step(in_tool: bool, directions: [i8; 6]) -> JogStep {
        JogStep {
            in_tool,
            directions,
            distance_m: 0.01,
            angle_rad: FRAC_PI_2,
        }
    }

    #[test]
    fn frame_mode_moves_along_and_turns_about_the_frame_axes() {
        // TCP pointing down (turned 180° about X); frame turned 90° about Z.
        let tcp = isometry([0.4, 0.0, 0.3, core::f64::consts::PI, 0.0, 0.0]);
        let frame = isometry([0.0, 0.2, 0.0, 0.0, 0.0, FRAC_PI_2]);
        // +X of the frame is +Y of the world.
        let t = target(&tcp, &frame, &step(false, [1, 0, 0, 0, 0, 0]));
        assert!((t.translation.vector - Vector3::new(0.4, 0.01, 0.3)).norm() < 1e-12);
        assert!(t.rotation.angle_to(&tcp.rotation) < 1e-12);
        // +RZ of the frame turns about the world's Z through the TCP: position stays.
        let t = target(&tcp, &frame, &step(false, [0, 0, 0, 0, 0, 1]));
        assert!((t.translation.vector - tcp.translation.vector).norm() < 1e-12);
        let expected =
            UnitQuaternion::from_axis_angle(&Vector3::z_axis(), FRAC_PI_2) * tcp.rotation;
        assert!(t.rotation.angle_to(&expected) < 1e-12);
    }

    #[test]
    fn tool_mode_moves_along_the_tool_axes() {
        // TCP pointing down: the tool's +Z is the world's -Z.
        let tcp = isometry([0.4, 0.0, 0.3, core::f64::consts::PI, 0.0, 0.0]);
        let t = target(
            &tcp,
            &Isometry3::identity(),
            &step(true, [0, 0, 1, 0, 0, 0]),
        );
        assert!((t.translation.vector - Vector3::new(0.4, 0.0, 0.29)).norm() < 1e-12);
        // Two bits at once: one diagonal direction of the same length.
        let t = target(
            &tcp,
            &Isometry3::identity(),
            &step(true, [1, 1, 0, 0, 0, 0]),
        );
        assert!(((t.translation.vector - tcp.translation.vector).norm() - 0.01).abs() < 1e-12);
        let half = step(true, [1, 0, 0, 0, 0, 0]).halved();
        assert_eq!((half.distance_m, half.angle_rad), (0.005, FRAC_PI_2 / 2.0));
    }
}
