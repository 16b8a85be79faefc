//! The geometric Jacobian of the DH chain.

use nalgebra::{Matrix6, Vector3};
use shared_types::ipc::AXES;

use super::Kinematics;

impl Kinematics {
    /// The geometric Jacobian in the base frame at the joint positions `q` (rad): column `i`
    /// maps `q̇_i` (rad/s) to the flange twist, rows 0..3 the linear velocity of the flange
    /// origin (m/s), rows 3..6 the angular velocity (rad/s).
    pub fn jacobian(&self, q: &[f64; AXES]) -> Matrix6<f64> {
        let frames = self.frames(q);
        let flange = frames[AXES].translation.vector;
        let mut jacobian = Matrix6::zeros();
        for (i, frame) in frames[..AXES].iter().enumerate() {
            // A revolute joint about the unit axis z through o moves the flange by z × (p − o).
            let axis = frame.rotation * Vector3::z();
            let linear = axis.cross(&(flange - frame.translation.vector));
            jacobian.fixed_view_mut::<3, 1>(0, i).copy_from(&linear);
            jacobian.fixed_view_mut::<3, 1>(3, i).copy_from(&axis);
        }
        jacobian
    }
}

#[cfg(test)]
mod tests {
    use crate::kinematics::test_robots;
    use core::f64::consts::PI;
    use nalgebra::Vector6;
    use proptest::prelude::*;

    /// Step of the central differences, rad.
    const STEP: f64 = 1e-6;

    proptest! {
        #[test]
        fn columns_are_the_flange_twist_per_joint_velocity(q in prop::array::uniform6(-PI..PI)) {
            for robot in test_robots::all() {
                let kin = &robot.kinematics;
                let jacobian = kin.jacobian(&q);
                for i in 0..6 {
                    let (mut ahead, mut behind) = (q, q);
                    ahead[i] += STEP;
                    behind[i] -= STEP;
                    let (a, b) = (kin.flange(&ahead), kin.flange(&behind));
                    let linear = (a.translation.vector - b.translation.vector) / (2.0 * STEP);
                    let angular = (a.rotation * b.rotation.inverse()).scaled_axis() / (2.0 * STEP);
                    let twist = Vector6::new(
                        linear.x, linear.y, linear.z, angular.x, angular.y, angular.z,
                    );
                    let error = (jacobian.column(i) - twist).abs().max();
                    prop_assert!(error < 1e-8, "{} joint {i}: {error}", robot.config.name);
                }
            }
        }
    }
}
