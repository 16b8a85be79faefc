//! The speed of the tool centre point from the joint positions and velocities.

use planner::kinematics::Kinematics;
use shared_types::ipc::AXES;
use shared_types::pose;

/// Computes TCP speeds of one arm by its geometric Jacobian, so that a single sample gives
/// the speed without differencing (no noise from time stamps, no gap at decimated samples).
#[derive(Debug, Clone)]
pub struct TcpSpeed {
    kinematics: Kinematics,
}

impl TcpSpeed {
    /// For the arm whose chain `kinematics` describes.
    pub fn new(kinematics: Kinematics) -> Self {
        Self { kinematics }
    }

    /// Speed (m/s) of the TCP of `tool` (x, y, z in m and Rx, Ry, Rz in rad in the flange
    /// frame) at joint positions `q` (rad) moving at `qd` (rad/s).
    pub fn speed(&self, q: &[f64; AXES], qd: &[f64; AXES], tool: &[f64; 6]) -> f64 {
        let jacobian = self.kinematics.jacobian(q);
        let twist: [f64; 6] =
            core::array::from_fn(|row| (0..AXES).map(|i| jacobian[(row, i)] * qd[i]).sum());
        let flange = self.kinematics.flange(q);
        let tcp = flange * pose::isometry(*tool);
        // The TCP moves with the flange origin plus ω × (lever from the flange to the TCP).
        let lever = tcp.translation.vector - flange.translation.vector;
        let [vx, vy, vz, wx, wy, wz] = twist;
        let v = [
            vx + wy * lever.z - wz * lever.y,
            vy + wz * lever.x - wx * lever.z,
            vz + wx * lever.y - wy * lever.x,
        ];
        v.iter().map(|c| c * c).sum::<f64>().sqrt()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;
    use shared_types::config::Config;

    fn zu7() -> TcpSpeed {
        let config = Config::load(None).expect("embedded configuration");
        TcpSpeed::new(Kinematics::new(&config.robot.kinematics))
    }

    /// The TCP position of `tool` at `q`, by forward kinematics.
    fn tcp_position(s: &TcpSpeed, q: &[f64; AXES], tool: &[f64; 6]) -> [f64; 3] {
        let t = s.kinematics.flange(q) * pose::isometry(*tool);
        [
            t.translation.vector.x,
            t.translation.vector.y,
            t.translation.vector.z,
        ]
    }

    #[test]
    fn an_arm_at_rest_has_no_tcp_speed() {
        let s = zu7();
        let q = [0.0, 1.5, 1.5, 1.5, -1.5, 0.0];
        assert_eq!(
            s.speed(&q, &[0.0; AXES], &[0.0, 0.0, 0.2, 0.0, 0.0, 0.0]),
            0.0
        );
    }

    #[test]
    fn turning_only_the_last_joint_moves_an_offset_tcp_on_a_circle() {
        let s = zu7();
        let q = [0.0, 1.5, 1.5, 1.5, -1.5, 0.0];
        let mut qd = [0.0; AXES];
        qd[5] = 2.0;
        // J6 turns about the flange z axis: a TCP 0.1 m off that axis moves at 0.1 · 2 m/s.
        let off_axis = [0.1, 0.0, 0.3, 0.0, 0.0, 0.0];
        assert!((s.speed(&q, &qd, &off_axis) - 0.2).abs() < 1e-9);
        let on_axis = [0.0, 0.0, 0.3, 0.0, 0.0, 0.0];
        assert!(s.speed(&q, &qd, &on_axis) < 1e-9);
    }

    proptest! {
        #[test]
        fn the_speed_is_the_rate_of_change_of_the_tcp_position(
            q in prop::array::uniform6(-3.0f64..3.0),
            qd in prop::array::uniform6(-1.0f64..1.0),
            tool in prop::array::uniform6(-0.2f64..0.2),
        ) {
            let s = zu7();
            let h = 1e-6;
            let ahead: [f64; AXES] = core::array::from_fn(|i| q[i] + qd[i] * h);
            let behind: [f64; AXES] = core::array::from_fn(|i| q[i] - qd[i] * h);
            let (a, b) = (tcp_position(&s, &ahead, &tool), tcp_position(&s, &behind, &tool));
            let numeric = (0..3).map(|i| (a[i] - b[i]).powi(2)).sum::<f64>().sqrt() / (2.0 * h);
            prop_assert!((s.speed(&q, &qd, &tool) - numeric).abs() < 1e-6);
        }
    }
}
