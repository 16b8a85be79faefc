//! The analytic inverse kinematics of the UR-type family: every branch of a flange pose.
//!
//! Derivation, with `x6, y6, z6` the flange axes and `p6` its origin in the base frame,
//! `u = (c1, s1, 0)` and `n = (s1, −c1, 0)` the in-plane and normal directions of the arm plane:
//!
//! 1. **θ1.** The wrist point `p5 = p6 − d6·z6` has `p5·n = d4`: with `p5 = r·(cos φ, sin φ)`
//!    in the xy-plane, `r·sin(θ1 − φ) = d4`, so `θ1 = φ + atan2(d4, ±√(r² − d4²))`; the sign is
//!    that of `p5·u`, which with `sign(a2)` is the shoulder bit. `r < |d4|` is unreachable.
//! 2. **θ5.** `z6 = −s5·x4 + c5·n` with `x4` in the arm plane, so `c5 = z6·n` and
//!    `|s5| = |(z6·u, z6_z)|`; the sign of `s5` is the wrist bit.
//! 3. **θ6.** `x6·n = c6·s5` and `y6·n = −s6·s5`. For `|s5|` below [`WRIST_FREE_SIN`] J6 is
//!    parallel to J2, J3 and J4 and θ6 is free: it takes the reference value if the two-link arm
//!    reaches J4 with it, else the nearest value with which it does (step 5 below).
//! 4. **θ2 + θ3 + θ4.** Undoing J6 gives `x5 = c6·x6 − s6·y6`, `y5 = s6·x6 + c6·y6`, then
//!    `x4 = c5·x5 − s5·z6 = (c1·c234, s1·c234, s234)` and `z4 = −y5`.
//! 5. **θ2, θ3.** J4's axis point `o4 = p5 − d5·z4` lies, from J2 at height `d1`, at
//!    `(X, Y) = (o4·u, o4_z − d1) = (a2·c2 + a3·c23, a2·s2 + a3·s23)`: the planar two-link arm,
//!    `c3 = (X² + Y² − a2² − a3²)/(2·a2·a3)`, the sign of `s3` from the elbow bit, and
//!    `θ2 = atan2(Y, X) − atan2(a3·s3, a2 + a3·c3)`; `θ4 = θ234 − θ2 − θ3`.

use nalgebra::{Isometry3, Vector3};
use shared_types::ipc::AXES;

use super::turns::base_angle;
use super::{ArmConfig, ArmConfigElement, ArmGeometry, Elbow, Shoulder, Wrist};

/// `|sin θ5|` below which θ6 is free (step 3 of the derivation) and chosen from the reference.
/// At this size the pose the result reaches differs from the target by less than
/// `WRIST_FREE_SIN·π`.
pub const WRIST_FREE_SIN: f64 = 1e-12;
/// How far (m) a target may lie beyond the reach of the shoulder or of the two-link arm and
/// still be solved, as the closest stretched or folded pose: rounding of a pose on the
/// boundary.
pub const REACH_TOLERANCE_M: f64 = 1e-10;

/// Why a flange pose has no inverse kinematics solution.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum IkError {
    #[error("the flange pose is not finite")]
    NotFinite,
    #[error("the flange pose is out of reach in every configuration")]
    Unreachable,
}

/// The inverse kinematics branches of one flange pose, indexed by the configuration bits.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct IkSolutions {
    /// Joint angles (rad) in (−π, π] of branch `ArmConfig::bits()`, `None` where that branch
    /// cannot reach the pose.
    pub branches: [Option<[f64; AXES]>; 8],
    /// Branches at a wrist singularity, whose θ6 is the reference or the angle nearest to it
    /// with which the arm reaches the pose.
    pub wrist_free: [bool; 8],
}

impl IkSolutions {
    /// The solution in `config`, if it reaches the pose.
    pub fn get(&self, config: ArmConfig) -> Option<&[f64; AXES]> {
        self.branches[usize::from(config.bits())].as_ref()
    }

    /// The reachable branches with their configurations.
    pub fn iter(&self) -> impl Iterator<Item = (ArmConfig, &[f64; AXES])> {
        (0u8..)
            .zip(&self.branches)
            .filter_map(|(bits, q)| Some((ArmConfig::from_bits(bits), q.as_ref()?)))
    }
}

/// What every branch needs of a flange pose: its axes and the wrist point (steps 1 and 2).
struct Wrist5 {
    x6: Vector3<f64>,
    y6: Vector3<f64>,
    z6: Vector3<f64>,
    p5: Vector3<f64>,
    /// `√(r² − d4²)`: the wrist point's distance from the J1 axis within the arm plane.
    radial: f64,
    /// Azimuth `φ` of the wrist point.
    azimuth: f64,
}

impl ArmGeometry {
    /// Every branch reaching the flange pose `flange` (base frame). `q6_reference` (rad) is
    /// J6's angle where the wrist is singular, usually the current one.
    pub fn inverse(
        &self,
        flange: &Isometry3<f64>,
        q6_reference: f64,
    ) -> Result<IkSolutions, IkError> {
        let wrist5 = self.wrist_point(flange)?;
        let mut solutions = IkSolutions::default();
        for shoulder in [Shoulder::Front, Shoulder::Back] {
            for wrist in [Wrist::NonFlip, Wrist::Flip] {
                let Some((arms, free)) = self.branch_pair(&wrist5, shoulder, wrist, q6_reference)
                else {
                    continue;
                };
                for (elbow, q) in [Elbow::Up, Elbow::Down].into_iter().zip(arms) {
                    let k = usize::from(
                        ArmConfig {
                            shoulder,
                            elbow,
                            wrist,
                        }
                        .bits(),
                    );
                    solutions.branches[k] = Some(q);
                    solutions.wrist_free[k] = free;
                }
            }
        }
        if solutions.branches.iter().all(Option::is_none) {
            return Err(IkError::Unreachable);
        }
        Ok(solutions)
    }

    /// The one branch `config` of the flange pose, if it reaches it: what
    /// [`inverse`](Self::inverse) gives for `config`, at an eighth of the work (for following
    /// a path in one configuration every interpolation tick).
    pub fn inverse_in(
        &self,
        flange: &Isometry3<f64>,
        config: ArmConfig,
        q6_reference: f64,
    ) -> Option<[f64; AXES]> {
        let wrist5 = self.wrist_point(flange).ok()?;
        let (arms, _) = self.branch_pair(&wrist5, config.shoulder, config.wrist, q6_reference)?;
        Some(arms[usize::from(config.elbow.bit())])
    }

    /// Steps 1 and 2 common to every branch.
    fn wrist_point(&self, flange: &Isometry3<f64>) -> Result<Wrist5, IkError> {
        let rotation = flange.rotation.to_rotation_matrix();
        let m = rotation.matrix();
        let p6 = flange.translation.vector;
        if !(m.iter().all(|v| v.is_finite()) && p6.iter().all(|v| v.is_finite())) {
            return Err(IkError::NotFinite);
        }
        let (x6, y6, z6) = (
            m.column(0).into_owned(),
            m.column(1).into_owned(),
            m.column(2).into_owned(),
        );
        let p5 = p6 - self.d6 * z6;
        let radial_sq = p5.x * p5.x + p5.y * p5.y - self.d4 * self.d4;
        if radial_sq < -2.0 * self.d4.abs() * REACH_TOLERANCE_M {
            return Err(IkError::Unreachable);
        }
        Ok(Wrist5 {
            x6,
            y6,
            z6,
            p5,
            radial: radial_sq.max(0.0).sqrt(),
            azimuth: p5.y.atan2(p5.x),
        })
    }

    /// The joint angles (rad, in (−π, π]) of the elbow UP and DOWN branches of one shoulder
    /// and wrist, and whether θ6 was free, if the two-link arm reaches.
    fn branch_pair(
        &self,
        w: &Wrist5,
        shoulder: Shoulder,
        wrist: Wrist,
        q6_reference: f64,
    ) -> Option<([[f64; AXES]; 2], bool)> {
        // FRONT puts p5 on the side of sign(a2)·u, i.e. p5·u has the sign of a2 (step 1).
        let along = if shoulder == Shoulder::Front {
            self.a2.signum() * w.radial
        } else {
            -self.a2.signum() * w.radial
        };
        let theta1 = w.azimuth + self.d4.atan2(along);
        let (s1, c1) = theta1.sin_cos();
        let u = Vector3::new(c1, s1, 0.0);
        let n = Vector3::new(s1, -c1, 0.0);
        let c5 = w.z6.dot(&n);
        let s5_magnitude = w.z6.dot(&u).hypot(w.z6.z);
        let s5 = if wrist.bit() {
            -s5_magnitude
        } else {
            s5_magnitude
        };
        let free = s5_magnitude < WRIST_FREE_SIN;
        let theta6 = if free {
            self.free_theta6(&w.p5, &w.x6, &w.y6, q6_reference + self.offsets[5])
        } else {
            let (x6n, y6n) = (w.x6.dot(&n), w.y6.dot(&n));
            (-y6n * s5.signum()).atan2(x6n * s5.signum())
        };
        let (s6, c6) = theta6.sin_cos();
        let x5 = c6 * w.x6 - s6 * w.y6;
        let z4 = -(s6 * w.x6 + c6 * w.y6);
        let x4 = c5 * x5 - s5 * w.z6;
        let theta234 = x4.z.atan2(x4.dot(&u));
        let o4 = w.p5 - self.d5 * z4;
        let arms = self.planar_arm(o4.dot(&u), o4.z - self.d1)?;
        let theta5 = s5.atan2(c5);
        let joints = arms.map(|(theta2, theta3)| {
            let thetas = [
                theta1,
                theta2,
                theta3,
                theta234 - theta2 - theta3,
                theta5,
                theta6,
            ];
            core::array::from_fn(|i| base_angle(thetas[i] - self.offsets[i]))
        });
        Some((joints, free))
    }

    /// θ6 at a wrist singularity: `reference` if J4 is then within reach of the two-link arm,
    /// else the nearest angle with which it is.
    fn free_theta6(
        &self,
        p5: &Vector3<f64>,
        x6: &Vector3<f64>,
        y6: &Vector3<f64>,
        reference: f64,
    ) -> f64 {
        // With z6 = ±n the flange x6, y6 span the arm plane, and z4 = −(s6·x6 + c6·y6) there:
        // o4 − J2 = (px + d5·s6, py + d5·c6), so |o4 − J2|² = a + k·cos(θ6 − β).
        let p = p5 - Vector3::new(0.0, 0.0, self.d1);
        let (px, py) = (p.dot(x6), p.dot(y6));
        let a = px * px + py * py + self.d5 * self.d5;
        let k = 2.0 * self.d5 * px.hypot(py);
        if k == 0.0 {
            return reference;
        }
        let beta = px.atan2(py);
        let (inner, outer) = self.reach_range();
        let (to_inner, to_outer) = ((inner * inner - a) / k, (outer * outer - a) / k);
        let (lowest, highest) = if k > 0.0 {
            (to_inner, to_outer)
        } else {
            (to_outer, to_inner)
        };
        // cos(θ6 − β) in [lowest, highest] is |θ6 − β| in [acos(highest), acos(lowest)] on
        // either side of β; clamping |δ| keeps the reference's side, which holds the nearest.
        let near = highest.clamp(-1.0, 1.0).acos();
        let far = lowest.clamp(-1.0, 1.0).acos();
        let delta = base_angle(reference - beta);
        beta + delta.abs().clamp(near, far).copysign(delta)
    }

    /// The smallest and the largest distance of J4 from J2.
    fn reach_range(&self) -> (f64, f64) {
        let (a2, a3) = (self.a2.abs(), self.a3.abs());
        ((a2 - a3).abs(), a2 + a3)
    }

    /// `(θ2, θ3)` of the two-link arm J2–J3–J4 reaching `(x, y)` in the arm plane (from J2,
    /// along `u` and up), elbow UP first, if it is within reach.
    fn planar_arm(&self, x: f64, y: f64) -> Option<[(f64, f64); 2]> {
        let (a2, a3) = (self.a2, self.a3);
        let reach = x.hypot(y);
        let (inner, outer) = self.reach_range();
        if reach > outer + REACH_TOLERANCE_M || reach < inner - REACH_TOLERANCE_M {
            return None;
        }
        let c3 = ((reach * reach - a2 * a2 - a3 * a3) / (2.0 * a2 * a3)).clamp(-1.0, 1.0);
        // UP is a3·s3 < 0 (see the module documentation of `kinematics`).
        let up_s3 = -a3.signum() * (1.0 - c3 * c3).sqrt();
        let towards = y.atan2(x);
        Some([up_s3, -up_s3].map(|s3| {
            let theta2 = towards - (a3 * s3).atan2(a2 + a3 * c3);
            (theta2, s3.atan2(c3))
        }))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kinematics::test_robots::{self, Robot};
    use core::f64::consts::PI;
    use nalgebra::{Translation3, UnitQuaternion};
    use proptest::prelude::*;

    /// Largest position (m) and rotation (rad) error of a reproduced pose.
    const POSE_TOLERANCE: f64 = 1e-9;

    fn pose_error(a: &Isometry3<f64>, b: &Isometry3<f64>) -> (f64, f64) {
        (
            (a.translation.vector - b.translation.vector).norm(),
            a.rotation.angle_to(&b.rotation),
        )
    }

    /// Every branch of `target` reaches it; returns how many branches there are.
    fn assert_branches_reach(robot: &Robot, target: &Isometry3<f64>, q6_ref: f64) -> usize {
        let solutions = robot.geometry.inverse(target, q6_ref).expect("reachable");
        for (config, q) in solutions.iter() {
            assert!(q.iter().all(|a| *a > -PI && *a <= PI), "{q:?}");
            let (dp, dr) = pose_error(&robot.kinematics.flange(q), target);
            assert!(
                dp < POSE_TOLERANCE && dr < POSE_TOLERANCE,
                "{} {config:?} {q:?}: {dp} m, {dr} rad",
                robot.config.name
            );
        }
        solutions.iter().count()
    }

    fn angle_difference(a: f64, b: f64) -> f64 {
        base_angle(a - b).abs()
    }

    #[test]
    fn a_regular_pose_has_eight_distinct_branches_with_their_bits() {
        for robot in test_robots::all() {
            let g = robot.geometry;
            let q = test_robots::regular(&g);
            let target = robot.kinematics.flange(&q);
            assert_eq!(
                assert_branches_reach(&robot, &target, 0.0),
                8,
                "{}",
                robot.config.name
            );
            let solutions = g.inverse(&target, 0.0).unwrap();
            for (config, q) in solutions.iter() {
                assert_eq!(g.arm_config(q), config, "{} {q:?}", robot.config.name);
                assert!(!g.singularity_measures(q).singularities().any());
            }
        }
    }

    #[test]
    fn wrist_singular_pose_takes_q6_from_the_reference_where_it_reaches() {
        let mut out_of_reach = 0;
        for robot in test_robots::all() {
            let g = robot.geometry;
            let q = [0.3, 0.7, 1.2, 0.6, 0.0, 0.2];
            let target = robot.kinematics.flange(&q);
            let own = g.arm_config(&q);
            for reference in [0.2, -2.5, 1.7] {
                assert_branches_reach(&robot, &target, reference);
                let solutions = g.inverse(&target, reference).unwrap();
                // Only the J1 angle of `q` aligns J6 with J4; the other shoulder's does not.
                for (config, _) in solutions.iter() {
                    let free = solutions.wrist_free[usize::from(config.bits())];
                    assert_eq!(
                        free,
                        config.shoulder == own.shoulder,
                        "{} {config:?}",
                        robot.config.name
                    );
                }
                let solved = solutions.get(own).expect("the own branch");
                if reference == 0.2 {
                    assert!(angle_difference(solved[5], reference) < 1e-12);
                } else if angle_difference(solved[5], reference) > 1e-12 {
                    // The reference puts J4 out of reach: the nearest q6 stretches or folds the arm.
                    let elbow = g.singularity_measures(solved).elbow;
                    assert!(
                        elbow.abs() < 1e-6,
                        "{} {reference}: {solved:?}",
                        robot.config.name
                    );
                    out_of_reach += 1;
                }
            }
        }
        assert!(out_of_reach > 0, "no reference was out of reach");
    }

    #[test]
    fn shoulder_singular_pose_has_coinciding_shoulder_branches() {
        for robot in test_robots::all() {
            let g = robot.geometry;
            let q = test_robots::shoulder_singular(&g);
            let target = robot.kinematics.flange(&q);
            assert_branches_reach(&robot, &target, 0.0);
            let solutions = g.inverse(&target, 0.0).unwrap();
            for bits in 0..4u8 {
                let front = solutions.get(ArmConfig::from_bits(bits << 1)).unwrap();
                let back = solutions.get(ArmConfig::from_bits(bits << 1 | 1)).unwrap();
                assert!(
                    angle_difference(front[0], back[0]) < 1e-6,
                    "{}",
                    robot.config.name
                );
            }
        }
    }

    #[test]
    fn stretched_arm_is_on_the_border_of_reach() {
        for robot in test_robots::all() {
            let q = [0.3, 0.7, 0.0, 0.6, 1.1, 0.2];
            let target = robot.kinematics.flange(&q);
            assert_branches_reach(&robot, &target, 0.0);
            // 1 mm further along the stretched arm is out of reach for that shoulder and wrist.
            let t = robot.kinematics.frames(&q);
            let arm = (t[3].translation.vector - t[1].translation.vector).normalize();
            let beyond = Translation3::from(1e-3 * arm) * target;
            let solutions = robot.geometry.inverse(&beyond, 0.0);
            let original = robot.geometry.arm_config(&q);
            assert!(
                solutions.map_or(true, |s| s.get(original).is_none()),
                "{}",
                robot.config.name
            );
        }
    }

    #[test]
    fn poses_out_of_reach_are_refused() {
        for robot in test_robots::all() {
            let g = robot.geometry;
            let far = Isometry3::translation(2.0, 0.0, 0.5);
            assert_eq!(g.inverse(&far, 0.0), Err(IkError::Unreachable));
            // The wrist point on the J1 axis: no J1 angle puts it d4 off the arm plane.
            let above = Isometry3::from_parts(
                Translation3::new(0.0, 0.0, 0.3 + g.d6),
                UnitQuaternion::identity(),
            );
            assert_eq!(g.inverse(&above, 0.0), Err(IkError::Unreachable));
            let broken = Isometry3::translation(f64::NAN, 0.0, 0.0);
            assert_eq!(g.inverse(&broken, 0.0), Err(IkError::NotFinite));
        }
    }

    #[test]
    fn one_inverse_takes_a_few_microseconds() {
        // Not a timing assertion: prints the mean time (see with `--release -- --nocapture`)
        // and checks every solution of the run.
        let robot = test_robots::default();
        let targets: Vec<_> = (0..200)
            .map(|i| {
                let x = f64::from(i) * 0.37;
                robot.kinematics.flange(&[
                    x.sin() * 3.0,
                    x.cos() * 1.5,
                    1.0 + x.sin(),
                    x,
                    0.5 + x.cos(),
                    -x,
                ])
            })
            .collect();
        let rounds = 50;
        let start = std::time::Instant::now();
        let mut found = 0;
        for _ in 0..rounds {
            for target in &targets {
                let solutions = robot.geometry.inverse(core::hint::black_box(target), 0.0);
                found += solutions.map_or(0, |s| s.iter().count());
            }
        }
        let elapsed = start.elapsed();
        let calls = rounds * targets.len();
        println!(
            "inverse kinematics: {:.3} µs per call, {:.2} branches per pose",
            elapsed.as_secs_f64() * 1e6 / calls as f64,
            found as f64 / calls as f64
        );
        for target in &targets {
            assert!(assert_branches_reach(&robot, target, 0.0) >= 1);
        }
    }

    proptest! {
        #[test]
        fn one_branch_is_the_same_as_that_branch_of_all(
            q in prop::array::uniform6(-PI..PI),
            q6_ref in -PI..PI,
            bits in 0u8..8,
        ) {
            for robot in test_robots::all() {
                let g = robot.geometry;
                let target = robot.kinematics.flange(&q);
                let config = ArmConfig::from_bits(bits);
                let all = g.inverse(&target, q6_ref).unwrap();
                let one = g.inverse_in(&target, config, q6_ref);
                prop_assert_eq!(one.as_ref(), all.get(config));
            }
        }

        #[test]
        fn every_branch_reproduces_the_pose_and_the_own_branch_the_joints(
            q in prop::array::uniform6(-PI..PI),
            q6_ref in -PI..PI,
        ) {
            for robot in test_robots::all() {
                let g = robot.geometry;
                let target = robot.kinematics.flange(&q);
                assert_branches_reach(&robot, &target, q6_ref);
                if g.singularity_measures(&q).singularities().any() {
                    continue;
                }
                let solutions = g.inverse(&target, q6_ref).unwrap();
                let own = solutions.get(g.arm_config(&q));
                prop_assert!(own.is_some(), "{} {q:?}", robot.config.name);
                for (a, b) in own.unwrap().iter().zip(&q) {
                    prop_assert!(angle_difference(*a, *b) < 1e-9, "{} {q:?}", robot.config.name);
                }
                for (config, q) in solutions.iter() {
                    prop_assert_eq!(g.arm_config(q), config);
                }
            }
        }
    }
}
