//! OriMode 2 JOINT_INTERPOLATED on a TCP path (a straight line or an arc): the TCP position
//! follows the path, the wrist joints J4..J6 move linearly from their start values to the
//! target's, and the arm joints J1..J3 keep the TCP on the path. The orientation is whatever
//! the joints give; it is the start's at `s = 0` and the target's at `s = 1`.
//!
//! # Solving
//!
//! J1..J3 are solved at the grid points `s_k = k/N` ([`INTERVALS`]` = N`) by Newton's method
//! on the TCP position, `q_a ← q_a + J_a⁻¹·(p(s) − p_tcp(q))`, with `J_a` the 3×3 block of the
//! TCP's linear Jacobian for J1..J3 (the flange's linear columns plus `ω × R·t` for the tool
//! offset `t`), seeded from the sample before extrapolated along its slope. Each sample also
//! keeps its slope `dq_a/ds = J_a⁻¹·(p' − J_w·w')`, with `J_w` the block of J4..J6, `w'`
//! the wrist joints' travel and `p'` the path's tangent (a central difference of the path
//! position, exact for a line). A sample that does not converge, or whose Newton step would
//! jump ([`MAX_STEP_RAD`]), leaves the reach of the start branch; a singular `J_a` (shoulder
//! or elbow singularity) cannot hold the TCP on the path: both refuse the move.
//!
//! # Between the samples
//!
//! J1..J3 follow the cubic Hermite interpolation of the samples and their slopes: position
//! and slope are continuous, and the TCP lies off the path by `O(h⁴)` of the fourth
//! derivative (well below a micrometre for the shipped arms). Evaluation is allocation-free
//! and costs no kinematics at all, so it serves the 1 ms tick.

use nalgebra::{Isometry3, Matrix3, Vector3};
use shared_types::ipc::AXES;

use crate::kinematics::Kinematics;
use crate::topp::{INTERVALS, POINTS};

/// Largest TCP position error (m) a converged sample leaves.
pub const POSITION_TOLERANCE_M: f64 = 1e-11;
/// Largest Newton step (rad) of a joint: a bigger one jumps to another branch.
pub const MAX_STEP_RAD: f64 = 0.25;
/// Newton iterations per sample before it counts as not converged.
const MAX_ITERATIONS: usize = 20;
/// Step of `s` for the path's tangent.
const TANGENT_STEP: f64 = 1e-6;
/// Smallest `|det J_a|` (m³) for which J1..J3 can move the TCP in every direction.
const MIN_DETERMINANT: f64 = 1e-9;

/// The arm joints J1..J3 and the wrist joints J4..J6.
const ARM: usize = 3;

/// Why J1..J3 cannot keep the TCP on the path.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum WristPathError {
    /// J1..J3 find no position on the path at `s` in the start branch.
    #[error("J1..J3 find no solution on the path at s = {s}")]
    NotConverged { s: f64 },
    /// J1..J3 cannot move the TCP in every direction at `s`.
    #[error("J1..J3 are singular at s = {s}")]
    Singular { s: f64 },
}

/// A TCP path (line or arc) with linearly interpolated wrist joints, solved for J1..J3.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WristInterpolation {
    /// J4..J6 at `s = 0`.
    wrist_start: [f64; ARM],
    /// J4..J6 at `s = 1` minus at `s = 0`.
    wrist_travel: [f64; ARM],
    /// J1..J3 at the grid points.
    arm: [[f64; ARM]; POINTS],
    /// `dq/ds` of J1..J3 at the grid points.
    arm_slope: [[f64; ARM]; POINTS],
}

impl WristInterpolation {
    /// Solves the TCP (tool `tool` on the flange) on the path `position(s)` (base frame, m,
    /// `s` in [0, 1], starting where the TCP is at the joints `start`), the wrist joints
    /// moving linearly to `wrist_target`.
    pub fn solve(
        kinematics: &Kinematics,
        tool: &Isometry3<f64>,
        start: &[f64; AXES],
        position: impl Fn(f64) -> Vector3<f64>,
        wrist_target: [f64; ARM],
    ) -> Result<Self, WristPathError> {
        let wrist_start = [start[3], start[4], start[5]];
        let wrist_travel: [f64; ARM] = core::array::from_fn(|i| wrist_target[i] - wrist_start[i]);
        let mut path = Self {
            wrist_start,
            wrist_travel,
            arm: [[0.0; ARM]; POINTS],
            arm_slope: [[0.0; ARM]; POINTS],
        };
        let h = 1.0 / INTERVALS as f64;
        let mut seed = [start[0], start[1], start[2]];
        let mut seed_slope = [0.0; ARM];
        for k in 0..POINTS {
            let s = k as f64 * h;
            let guess = core::array::from_fn(|i| seed[i] + seed_slope[i] * h);
            let q = path.newton(kinematics, tool, s, &position(s), guess)?;
            let arm_block = ArmBlock::at(kinematics, tool, &q);
            let w = Vector3::from(wrist_travel);
            let (before, after) = ((s - TANGENT_STEP).max(0.0), (s + TANGENT_STEP).min(1.0));
            let tangent = (position(after) - position(before)) / (after - before);
            let slope = arm_block.inverse.ok_or(WristPathError::Singular { s })?
                * (tangent - arm_block.wrist * w);
            path.arm[k] = [q[0], q[1], q[2]];
            path.arm_slope[k] = slope.into();
            seed = path.arm[k];
            seed_slope = path.arm_slope[k];
        }
        Ok(path)
    }

    /// The joints at path position `s` (clamped to [0, 1]).
    pub fn joints(&self, s: f64) -> [f64; AXES] {
        let s = s.clamp(0.0, 1.0);
        let x = s * INTERVALS as f64;
        // `x` lies in [0, N]: the interval is in range after the cast.
        let k = (x.floor() as usize).min(INTERVALS - 1);
        let t = x - k as f64;
        let h = 1.0 / INTERVALS as f64;
        let (t2, t3) = (t * t, t * t * t);
        let (h00, h10, h01, h11) = (
            2.0 * t3 - 3.0 * t2 + 1.0,
            t3 - 2.0 * t2 + t,
            -2.0 * t3 + 3.0 * t2,
            t3 - t2,
        );
        let (a, b) = (&self.arm[k], &self.arm[k + 1]);
        let (da, db) = (&self.arm_slope[k], &self.arm_slope[k + 1]);
        core::array::from_fn(|i| {
            if i < ARM {
                h00 * a[i] + h10 * h * da[i] + h01 * b[i] + h11 * h * db[i]
            } else {
                self.wrist_start[i - ARM] + s * self.wrist_travel[i - ARM]
            }
        })
    }

    /// The joints at `s` with J1..J3 solved from `guess` so that the TCP lies at `target`.
    fn newton(
        &self,
        kinematics: &Kinematics,
        tool: &Isometry3<f64>,
        s: f64,
        target: &Vector3<f64>,
        guess: [f64; ARM],
    ) -> Result<[f64; AXES], WristPathError> {
        let mut q: [f64; AXES] = core::array::from_fn(|i| {
            if i < ARM {
                guess[i]
            } else {
                self.wrist_start[i - ARM] + s * self.wrist_travel[i - ARM]
            }
        });
        for _ in 0..MAX_ITERATIONS {
            let error = target - (kinematics.flange(&q) * tool).translation.vector;
            if error.norm() <= POSITION_TOLERANCE_M {
                return Ok(q);
            }
            let inverse = ArmBlock::at(kinematics, tool, &q)
                .inverse
                .ok_or(WristPathError::Singular { s })?;
            let step = inverse * error;
            if step.amax() > MAX_STEP_RAD {
                return Err(WristPathError::NotConverged { s });
            }
            for (qi, di) in q.iter_mut().zip(step.iter()) {
                *qi += di;
            }
        }
        Err(WristPathError::NotConverged { s })
    }
}

/// The TCP's linear Jacobian at `q`, split into J1..J3 (inverted, if regular) and J4..J6.
struct ArmBlock {
    inverse: Option<Matrix3<f64>>,
    wrist: Matrix3<f64>,
}

impl ArmBlock {
    fn at(kinematics: &Kinematics, tool: &Isometry3<f64>, q: &[f64; AXES]) -> Self {
        let flange = kinematics.flange(q);
        let jacobian = kinematics.jacobian(q);
        // The TCP moves with the flange origin plus the turn of the tool offset.
        let offset = flange.rotation * tool.translation.vector;
        let column = |i: usize| {
            let linear: Vector3<f64> = jacobian.fixed_view::<3, 1>(0, i).into();
            let angular: Vector3<f64> = jacobian.fixed_view::<3, 1>(3, i).into();
            linear + angular.cross(&offset)
        };
        let arm = Matrix3::from_columns(&[column(0), column(1), column(2)]);
        let wrist = Matrix3::from_columns(&[column(3), column(4), column(5)]);
        let inverse = if arm.determinant().abs() < MIN_DETERMINANT {
            None
        } else {
            arm.try_inverse()
        };
        Self { inverse, wrist }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kinematics::test_robots;
    use proptest::prelude::*;
    use shared_types::pose;

    /// A regular pose of the Zu 7, far from every singularity.
    const START: [f64; AXES] = [0.3, 0.6, -1.2, 0.9, 1.2, 0.4];

    fn tool() -> Isometry3<f64> {
        pose::isometry([0.02, -0.01, 0.15, 0.3, 0.0, -0.2])
    }

    fn tcp(kinematics: &Kinematics, q: &[f64; AXES]) -> Isometry3<f64> {
        kinematics.flange(q) * tool()
    }

    /// The straight path from `a` to `b`.
    fn line(a: Vector3<f64>, b: Vector3<f64>) -> impl Fn(f64) -> Vector3<f64> {
        move |s| a + (b - a) * s
    }

    fn off_line(p: &Vector3<f64>, a: &Vector3<f64>, b: &Vector3<f64>) -> f64 {
        let dir = (b - a).normalize();
        let d = p - a;
        (d - dir * d.dot(&dir)).norm()
    }

    #[test]
    fn the_tcp_stays_on_the_line_while_the_wrist_joints_move_linearly() {
        let robot = test_robots::default();
        let k = &robot.kinematics;
        let p0 = tcp(k, &START).translation.vector;
        let end = p0 + Vector3::new(0.12, -0.08, 0.1);
        let wrist = [1.3, 0.8, -0.5];
        let path = WristInterpolation::solve(k, &tool(), &START, line(p0, end), wrist).unwrap();
        assert_eq!(path.joints(0.0), START);
        for i in 0..=1000 {
            let s = f64::from(i) / 1000.0;
            let q = path.joints(s);
            let p = tcp(k, &q).translation.vector;
            assert!(off_line(&p, &p0, &end) < 1e-9, "s = {s}");
            // Along the line in proportion to s.
            assert!((p - (p0 + (end - p0) * s)).norm() < 1e-9, "s = {s}");
            for j in 0..3 {
                let expected = START[3 + j] + s * (wrist[j] - START[3 + j]);
                assert!((q[3 + j] - expected).abs() < 1e-12);
            }
        }
        let last = path.joints(1.0);
        assert!((tcp(k, &last).translation.vector - end).norm() < 1e-10);
    }

    #[test]
    fn the_tcp_stays_on_an_arc_while_the_wrist_joints_move_linearly() {
        let robot = test_robots::default();
        let k = &robot.kinematics;
        let p0 = tcp(k, &START).translation.vector;
        // A half circle of 8 cm radius in a tilted plane through the start.
        let (u, v) = (
            Vector3::new(1.0, 0.0, 0.3).normalize(),
            Vector3::new(0.0, 1.0, 0.0),
        );
        let (radius, centre) = (0.08, p0 - u * 0.08);
        let arc = move |s: f64| {
            let angle = s * core::f64::consts::PI;
            centre + (u * angle.cos() + v * angle.sin()) * radius
        };
        let wrist = [1.1, 0.9, -0.3];
        let path = WristInterpolation::solve(k, &tool(), &START, arc, wrist).unwrap();
        for i in 0..=1000 {
            let s = f64::from(i) / 1000.0;
            let q = path.joints(s);
            let p = tcp(k, &q).translation.vector;
            assert!((p - arc(s)).norm() < 1e-8, "s = {s}");
            for j in 0..3 {
                let expected = START[3 + j] + s * (wrist[j] - START[3 + j]);
                assert!((q[3 + j] - expected).abs() < 1e-12);
            }
        }
    }

    #[test]
    fn slopes_are_the_derivatives_of_the_joints() {
        let robot = test_robots::default();
        let k = &robot.kinematics;
        let p0 = tcp(k, &START).translation.vector;
        let end = p0 + Vector3::new(-0.1, 0.15, -0.05);
        let path =
            WristInterpolation::solve(k, &tool(), &START, line(p0, end), [0.6, 1.5, 1.0]).unwrap();
        let h = 1.0 / INTERVALS as f64;
        for n in [1, 40, 128, 200, INTERVALS - 1] {
            // The solved slope is the one of the solved samples either side of it...
            let (before, after) = (&path.arm[n - 1], &path.arm[n + 1]);
            for i in 0..ARM {
                let secant = (after[i] - before[i]) / (2.0 * h);
                let slope = path.arm_slope[n][i];
                assert!(
                    (secant - slope).abs() < 1e-3 * (1.0 + slope.abs()),
                    "{n} {i}"
                );
            }
            // ... and the interpolation's own at the sample.
            let s = n as f64 * h;
            let d = 1e-7;
            let (ahead, behind) = (path.joints(s + d), path.joints(s - d));
            for i in 0..AXES {
                let derivative = (ahead[i] - behind[i]) / (2.0 * d);
                let expected = if i < ARM {
                    path.arm_slope[n][i]
                } else {
                    path.wrist_travel[i - ARM]
                };
                assert!(
                    (derivative - expected).abs() < 1e-5 * (1.0 + expected.abs()),
                    "{n} {i}"
                );
            }
        }
    }

    #[test]
    fn a_line_out_of_reach_or_through_the_stretched_elbow_is_refused() {
        let robot = test_robots::default();
        let k = &robot.kinematics;
        let p0 = tcp(k, &START).translation.vector;
        let far = p0 + Vector3::new(3.0, 0.0, 0.0);
        let e = WristInterpolation::solve(k, &tool(), &START, line(p0, far), [0.9, 1.2, 0.4]);
        assert!(
            matches!(
                e,
                Err(WristPathError::NotConverged { s } | WristPathError::Singular { s }) if s > 0.0 && s < 1.0
            ),
            "{e:?}"
        );
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(24))]

        /// Random short lines from random regular starts: where a solution exists, every
        /// point lies on the line (within the micrometre the module promises between the
        /// samples: a line whose arm joints speed up near its end left 0.14 µm) and the
        /// wrist joints on their straight line.
        #[test]
        fn random_lines_stay_on_the_line(
            q in prop::array::uniform6(-0.4f64..0.4),
            shift in prop::array::uniform3(-0.1f64..0.1),
            wrist in prop::array::uniform3(-0.5f64..0.5),
        ) {
            let robot = test_robots::default();
            let k = &robot.kinematics;
            let start: [f64; AXES] = core::array::from_fn(|i| START[i] + q[i]);
            let p0 = tcp(k, &start).translation.vector;
            let end = p0 + Vector3::from(shift);
            prop_assume!(shift.iter().map(|v| v * v).sum::<f64>() > 1e-6);
            let target = [start[3] + wrist[0], start[4] + wrist[1], start[5] + wrist[2]];
            let Ok(path) = WristInterpolation::solve(k, &tool(), &start, line(p0, end), target) else {
                return Err(TestCaseError::reject("no solution"));
            };
            for i in 0..=200 {
                let s = f64::from(i) / 200.0;
                let p = tcp(k, &path.joints(s)).translation.vector;
                prop_assert!((p - (p0 + (end - p0) * s)).norm() < 1e-6, "s = {}", s);
            }
        }
    }
}
