//! The arm's kinematics as the interpreter needs them: where the TCP of a tool is, in which
//! configuration and with which turns, for a joint target (MoveLinearAbsoluteJ, a straight
//! TCP line to joints). The kinematics themselves are the planner's.

use planner::kinematics::turns::TurnNumbers;
use planner::kinematics::{ArmGeometry, Kinematics};
use shared_types::config::KinematicsConfig;
use shared_types::ipc::AXES;
use shared_types::pose;

/// A Cartesian target of the TCP that ends exactly at given joints.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointTarget {
    /// TCP pose in the robot base frame: m, rad (R = Rz·Ry·Rx).
    pub pose: [f64; 6],
    /// SRCI configuration bits of the joints.
    pub arm_config: u8,
    /// SRCI TurnNumber bytes of the joints.
    pub turn_numbers: [u8; 4],
}

/// The kinematic model of the configured arm.
#[derive(Debug, Clone)]
pub struct ArmModel {
    kinematics: Kinematics,
    /// `None` for an arm outside the UR-type family: no configuration bits, no lines to joints.
    geometry: Option<ArmGeometry>,
}

impl ArmModel {
    /// The model of the arm described by `config`.
    pub fn new(config: &KinematicsConfig) -> Self {
        Self {
            kinematics: Kinematics::new(config),
            geometry: ArmGeometry::new(config).ok(),
        }
    }

    /// The TCP of `tool` (flange frame, m and rad) at the joints `q` (rad), with their
    /// configuration and turns; `None` when the arm has no configuration bits or a joint is
    /// more turns away than SRCI encodes.
    pub fn joint_target(&self, q: &[f64; AXES], tool: [f64; 6]) -> Option<JointTarget> {
        let geometry = self.geometry.as_ref()?;
        let tcp = self.kinematics.flange(q) * pose::isometry(tool);
        Some(JointTarget {
            pose: pose::pose(&tcp),
            arm_config: geometry.arm_config(q).bits(),
            turn_numbers: TurnNumbers::of_joints(q).ok()?.to_wire().ok()?,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_home_position_has_its_documented_configuration_and_no_turns() {
        let cfg = shared_types::config::Config::load(None).unwrap();
        let arm = ArmModel::new(&cfg.robot.kinematics);
        let home = cfg.robot.home_deg.map(f64::to_radians);
        let flange = arm.joint_target(&home, [0.0; 6]).unwrap();
        // JAKA's home: shoulder BACK, elbow DOWN, wrist FLIP.
        assert_eq!((flange.arm_config, flange.turn_numbers), (0b111, [0; 4]));
        let tool = arm
            .joint_target(&home, [0.0, 0.0, 0.2, 0.0, 0.0, 0.0])
            .unwrap();
        let offset: f64 = (0..3)
            .map(|i| (tool.pose[i] - flange.pose[i]).powi(2))
            .sum::<f64>()
            .sqrt();
        assert!((offset - 0.2).abs() < 1e-9, "{offset}");
        let mut turned = home;
        turned[5] += 2.0 * core::f64::consts::TAU;
        assert_eq!(
            arm.joint_target(&turned, [0.0; 6]).unwrap().turn_numbers[2] >> 4,
            2
        );
    }
}
