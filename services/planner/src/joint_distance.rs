//! The distance the TCP has left on a joint move (MoveAxes, and MoveDirect, a joint move to a
//! Cartesian target), for the RemainingDistance of the SRCI responses.
//!
//! A joint move's TCP follows a curve. Its length from path position `s` to the end is that
//! of [`CHORDS`] chords between equally spaced points of the joint line, measured once per
//! move (one forward kinematics per point) and interpolated along `s` every tick.

use nalgebra::Isometry3;
use shared_types::ipc::AXES;
use shared_types::pose;

use crate::joint_move::JointMove;
use crate::kinematics::Kinematics;

/// Chords the TCP's curve is measured by.
pub const CHORDS: usize = 32;

/// The measured curve of the TCP of the latest joint move asked about.
#[derive(Debug, Clone, Copy)]
pub struct JointMoveDistance {
    /// The move's start and target joints and its tool, as measured.
    measured: Option<([f64; AXES], [f64; AXES], [f64; 6])>,
    /// The TCP's path length (m) from the start to each point.
    travelled: [f64; CHORDS + 1],
}

impl Default for JointMoveDistance {
    fn default() -> Self {
        Self {
            measured: None,
            travelled: [0.0; CHORDS + 1],
        }
    }
}

impl JointMoveDistance {
    /// The TCP's (of `tool`, the pose of the TCP in the flange frame) path length (m) left on
    /// `joint_move` from its path position `s`; the move's curve is measured when it is not
    /// the one measured last.
    pub fn remaining(
        &mut self,
        joint_move: &JointMove,
        tool: [f64; 6],
        s: f64,
        kinematics: &Kinematics,
    ) -> f64 {
        let key = (joint_move.start(), joint_move.target(), tool);
        if self.measured != Some(key) {
            self.measure(joint_move, &pose::isometry(tool), kinematics);
            self.measured = Some(key);
        }
        let at = s.clamp(0.0, 1.0) * CHORDS as f64;
        // Saturating float-to-int conversion: `at` lies in [0, CHORDS].
        let k = (at.floor() as usize).min(CHORDS - 1);
        let (before, after) = (self.travelled[k], self.travelled[k + 1]);
        let travelled = before + (at - k as f64) * (after - before);
        (self.travelled[CHORDS] - travelled).max(0.0)
    }

    fn measure(&mut self, joint_move: &JointMove, tool: &Isometry3<f64>, kinematics: &Kinematics) {
        let tcp = |k: usize| {
            let q = joint_move.point(k as f64 / CHORDS as f64, 0.0, 0.0).q;
            (kinematics.flange(&q) * tool).translation.vector
        };
        let mut last = tcp(0);
        self.travelled[0] = 0.0;
        for k in 1..=CHORDS {
            let next = tcp(k);
            self.travelled[k] = self.travelled[k - 1] + (next - last).norm();
            last = next;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use shared_types::config::Config;
    use shared_types::ipc::{MotionCommand, MotionCommandKind};

    use crate::joint_move::Plan;

    /// A turn of J1 alone moves the TCP on a circle about the base axis: the distance left
    /// is the arc's, to within the chords' shortfall.
    #[test]
    fn a_turn_of_the_base_leaves_the_arc_of_its_tcp() {
        let config = Config::load(None).expect("embedded configuration");
        let kinematics = Kinematics::new(&config.robot.kinematics);
        let start = config.robot.home_deg.map(f64::to_radians);
        let mut command = MotionCommand::new(MotionCommandKind::MoveAxes);
        command.joints_rad = start;
        command.joints_rad[0] += 1.0;
        let Ok(Plan::Move(m)) = JointMove::plan(start, &command, &config.robot.limits_rad(), 0.2)
        else {
            panic!("a joint move");
        };
        let radius = |tool| {
            let tcp = (kinematics.flange(&start) * pose::isometry(tool))
                .translation
                .vector;
            tcp.x.hypot(tcp.y)
        };
        // 15 cm out along the flange's x: another radius about the base axis than the
        // flange's, so another curve.
        let tool = [0.15, 0.0, 0.1, 0.0, 0.0, 0.0];
        assert!((radius(tool) - radius([0.0; 6])).abs() > 0.05);
        let mut distance = JointMoveDistance::default();
        for tool in [tool, [0.0; 6], tool] {
            for s in [0.0, 0.25, 0.6, 1.0] {
                let left = distance.remaining(&m, tool, s, &kinematics);
                let arc = radius(tool) * (1.0 - s);
                assert!(
                    (left - arc).abs() < 1e-4 * radius(tool),
                    "{left} {arc} at s = {s}"
                );
            }
        }
    }
}
