//! How far a joint vector is from the three singularities of the UR-type family, and the
//! manipulability that combines them.

use shared_types::ipc::AXES;

use super::ArmGeometry;

/// Distance (m) of the wrist point from the shoulder-singular line below which the shoulder
/// counts as singular: a flange moving at 1 m/s across the line would need J1 at 50 rad/s.
pub const SHOULDER_SINGULARITY_M: f64 = 0.02;
/// `|sin θ3|` below which the elbow counts as singular (the arm within 1° of stretched or
/// folded).
pub const ELBOW_SINGULARITY_SIN: f64 = 0.017_452_406_437_283_51;
/// `|sin θ5|` below which the wrist counts as singular (J4 and J6 within 1° of parallel).
pub const WRIST_SINGULARITY_SIN: f64 = 0.017_452_406_437_283_51;

/// Signed distances of a joint vector from the three singular sets. Each is zero on its set,
/// and its sign is the configuration bit (see the [module documentation](super)):
/// non-negative means FRONT, UP and NON_FLIP.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SingularityMeasures {
    /// `p5·e`, m: the wrist point ahead of (+) or behind (−) the J1 axis along the reach
    /// direction.
    pub shoulder_m: f64,
    /// `−sign(a3)·sin θ3`: the elbow above (+) or below (−) the line from J2 to J4.
    pub elbow: f64,
    /// `sin θ5`.
    pub wrist: f64,
}

/// Which singularities a joint vector is near, by the thresholds of this module.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Singularities {
    pub shoulder: bool,
    pub elbow: bool,
    pub wrist: bool,
}

impl Singularities {
    /// Whether any of the three is near.
    pub fn any(&self) -> bool {
        self.shoulder || self.elbow || self.wrist
    }
}

impl SingularityMeasures {
    /// The singularities within their thresholds.
    pub fn singularities(&self) -> Singularities {
        Singularities {
            shoulder: self.shoulder_m.abs() < SHOULDER_SINGULARITY_M,
            elbow: self.elbow.abs() < ELBOW_SINGULARITY_SIN,
            wrist: self.wrist.abs() < WRIST_SINGULARITY_SIN,
        }
    }
}

impl ArmGeometry {
    /// The singularity measures of the joint positions `q` (rad).
    pub fn singularity_measures(&self, q: &[f64; AXES]) -> SingularityMeasures {
        let [_, t2, t3, t4, t5, _] = self.thetas(q);
        // In the arm plane the wrist point lies a2·c2 + a3·c23 + d5·s234 along (cos θ1, sin θ1).
        let along_arm =
            self.a2 * t2.cos() + self.a3 * (t2 + t3).cos() + self.d5 * (t2 + t3 + t4).sin();
        SingularityMeasures {
            shoulder_m: self.a2.signum() * along_arm,
            elbow: -self.a3.signum() * t3.sin(),
            wrist: t5.sin(),
        }
    }

    /// Yoshikawa's manipulability of the square Jacobian, `|det J|` (m³), in closed form
    /// `|a2·a3·(p5·e)·sin θ3·sin θ5|`: zero exactly on the singular sets.
    pub fn manipulability(&self, q: &[f64; AXES]) -> f64 {
        let m = self.singularity_measures(q);
        (self.a2 * self.a3 * m.shoulder_m * m.elbow * m.wrist).abs()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kinematics::test_robots;
    use core::f64::consts::PI;
    use proptest::prelude::*;

    #[test]
    fn stretched_folded_and_parallel_wrist_are_detected() {
        for robot in test_robots::all() {
            let g = robot.geometry;
            let regular = [0.3, 0.7, 1.2, 0.6, 1.1, 0.2];
            assert!(!g.singularity_measures(&regular).singularities().any());
            for (axis, value, expected) in [
                (
                    2,
                    0.0,
                    Singularities {
                        elbow: true,
                        ..Default::default()
                    },
                ),
                (
                    2,
                    PI,
                    Singularities {
                        elbow: true,
                        ..Default::default()
                    },
                ),
                (
                    4,
                    0.0,
                    Singularities {
                        wrist: true,
                        ..Default::default()
                    },
                ),
                (
                    4,
                    -PI,
                    Singularities {
                        wrist: true,
                        ..Default::default()
                    },
                ),
            ] {
                let mut q = regular;
                q[axis] = value;
                let found = g.singularity_measures(&q).singularities();
                assert_eq!(found, expected, "{} {q:?}", robot.config.name);
                assert!(g.manipulability(&q) < 1e-12);
            }
        }
    }

    #[test]
    fn wrist_point_over_the_j1_axis_is_a_shoulder_singularity() {
        for robot in test_robots::all() {
            let g = robot.geometry;
            let q = test_robots::shoulder_singular(&g);
            let p5 = robot.kinematics.frames(&q)[5].translation.vector;
            assert!(
                (p5.xy().norm() - g.d4.abs()).abs() < 1e-12,
                "{}",
                robot.config.name
            );
            let m = g.singularity_measures(&q);
            assert!(m.shoulder_m.abs() < 1e-12, "{}", robot.config.name);
            let expected = Singularities {
                shoulder: true,
                ..Default::default()
            };
            assert_eq!(m.singularities(), expected);
            assert!(g.manipulability(&q) < 1e-12);
        }
    }

    proptest! {
        #[test]
        fn shoulder_measure_is_the_wrist_point_along_the_reach_direction(
            q in prop::array::uniform6(-PI..PI),
        ) {
            for robot in test_robots::all() {
                let g = robot.geometry;
                let p5 = robot.kinematics.frames(&q)[5].translation.vector;
                let reach = g.a2.signum() * (p5.x * q[0].cos() + p5.y * q[0].sin());
                prop_assert!((g.singularity_measures(&q).shoulder_m - reach).abs() < 1e-12);
            }
        }

        #[test]
        fn manipulability_is_the_jacobian_determinant(q in prop::array::uniform6(-PI..PI)) {
            for robot in test_robots::all() {
                let det = robot.kinematics.jacobian(&q).determinant().abs();
                let closed = robot.geometry.manipulability(&q);
                prop_assert!((det - closed).abs() < 1e-12, "{} {det} {closed}", robot.config.name);
            }
        }
    }
}
