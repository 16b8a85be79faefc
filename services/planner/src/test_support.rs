//! Checks shared by the unit tests.

use shared_types::config::JointLimitsRad;
use shared_types::ipc::{AXES, JointPoint, MotionCommand, MotionCommandKind};

use crate::queue::QueuedMove;

/// Relative slack on the limits for rounding.
const SLACK: f64 = 1e-6;

/// Every point of a trajectory sampled every `dt` s keeps the joint position, velocity and
/// acceleration limits, in its commanded values and in the finite differences of its
/// positions.
pub fn assert_within_limits(points: &[JointPoint], limits: &JointLimitsRad, dt: f64) {
    let l = limits;
    for p in points {
        for i in 0..AXES {
            assert!(p.q[i] >= l.min[i] && p.q[i] <= l.max[i], "q {i} {p:?}");
            assert!(
                p.qd[i].abs() <= l.velocity[i] * (1.0 + SLACK),
                "qd {i} {p:?}"
            );
            assert!(
                p.qdd[i].abs() <= l.acceleration[i] * (1.0 + SLACK),
                "qdd {i} {p:?}"
            );
        }
    }
    for w in points.windows(3) {
        for i in 0..AXES {
            let v = (w[2].q[i] - w[1].q[i]) / dt;
            let a = (w[2].q[i] - 2.0 * w[1].q[i] + w[0].q[i]) / (dt * dt);
            assert!(
                v.abs() <= l.velocity[i] * (1.0 + SLACK) + 1e-9,
                "v {v} joint {i}"
            );
            assert!(
                a.abs() <= l.acceleration[i] * (1.0 + SLACK) + 1e-6,
                "a {a} joint {i}"
            );
        }
    }
}

/// The jerk of the commanded accelerations (their change over one tick of `dt` s) and of the
/// positions (their third differences: what a servo that follows position setpoints sees)
/// keeps the joint jerk limits: true for moves and stops; override ramps add to it (see
/// [`assert_jerk_within`]).
pub fn assert_jerk_within_limits(points: &[JointPoint], limits: &JointLimitsRad, dt: f64) {
    assert_jerk_within(points, limits, dt, 1.0);
}

/// The jerk of the commanded accelerations and of the positions (as
/// [`assert_jerk_within_limits`]) stays within `factor` times the joint jerk limits.
pub fn assert_jerk_within(points: &[JointPoint], limits: &JointLimitsRad, dt: f64, factor: f64) {
    for w in points.windows(2) {
        for i in 0..AXES {
            let jerk = (w[1].qdd[i] - w[0].qdd[i]).abs() / dt;
            assert!(
                jerk <= factor * limits.jerk[i] * (1.0 + SLACK),
                "jerk {jerk} joint {i}"
            );
        }
    }
    for (n, w) in points.windows(4).enumerate() {
        for i in 0..AXES {
            let third = w[3].q[i] - 3.0 * w[2].q[i] + 3.0 * w[1].q[i] - w[0].q[i];
            let jerk = third.abs() / dt.powi(3);
            // Rounding of positions near 1 rad and of their path: a few 1e-16 rad over dt³
            // (1e-9 s³ at 1 ms), with room to spare.
            assert!(
                jerk <= factor * limits.jerk[i] * (1.0 + SLACK) + 1e-3,
                "jerk of the positions {jerk} joint {i} at point {n}"
            );
        }
    }
}

/// A buffered MoveAxes of job `job`.
pub fn queued(job: u32) -> QueuedMove {
    let mut c = MotionCommand::new(MotionCommandKind::MoveAxes);
    c.job = job;
    QueuedMove::joint(c)
}
