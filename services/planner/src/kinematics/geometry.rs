//! The link parameters of the UR-type 6R family, checked once from the DH table.

use shared_types::config::KinematicsConfig;
use shared_types::ipc::AXES;

/// Link twists (deg) of the family.
const ALPHA_DEG: [f64; AXES] = [90.0, 0.0, 0.0, 90.0, -90.0, 0.0];
/// Links whose `a` must be zero: all but the upper arm (a2) and the forearm (a3).
const ZERO_A: [usize; 4] = [0, 3, 4, 5];
/// Links whose `d` must be zero: J2 and J3 lie in one plane with J4's common normal.
const ZERO_D: [usize; 2] = [1, 2];

/// Why a DH table is not of the UR-type family the closed forms are derived for.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum GeometryError {
    #[error("kinematics.{key}[{index}] = {value}, the UR-type arm needs {expected}")]
    Mismatch {
        key: &'static str,
        index: usize,
        value: f64,
        expected: f64,
    },
    #[error(
        "kinematics.a_m[{index}] = {value}, the UR-type arm needs a non-zero upper arm and forearm"
    )]
    InvalidArmLength { index: usize, value: f64 },
    #[error("kinematics.{key}[{index}] = {value} is not finite")]
    NotFinite {
        key: &'static str,
        index: usize,
        value: f64,
    },
}

/// The parameters of a UR-type arm (see the [module documentation](super)): lengths in m,
/// joint zero offsets in rad.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ArmGeometry {
    pub(super) d1: f64,
    pub(super) a2: f64,
    pub(super) a3: f64,
    pub(super) d4: f64,
    pub(super) d5: f64,
    pub(super) d6: f64,
    pub(super) offsets: [f64; AXES],
}

impl ArmGeometry {
    /// The geometry of `config`, or which entry of the table does not fit the family.
    pub fn new(config: &KinematicsConfig) -> Result<Self, GeometryError> {
        let tables = [
            ("d_m", &config.d_m),
            ("a_m", &config.a_m),
            ("alpha_deg", &config.alpha_deg),
            ("offset_deg", &config.offset_deg),
        ];
        for (key, table) in tables {
            if let Some(index) = table.iter().position(|v| !v.is_finite()) {
                return Err(GeometryError::NotFinite {
                    key,
                    index,
                    value: table[index],
                });
            }
        }
        let expected = ALPHA_DEG
            .iter()
            .enumerate()
            .map(|(i, &alpha)| ("alpha_deg", i, config.alpha_deg[i], alpha))
            .chain(ZERO_A.iter().map(|&i| ("a_m", i, config.a_m[i], 0.0)))
            .chain(ZERO_D.iter().map(|&i| ("d_m", i, config.d_m[i], 0.0)));
        for (key, index, value, expected) in expected {
            if value != expected {
                return Err(GeometryError::Mismatch {
                    key,
                    index,
                    value,
                    expected,
                });
            }
        }
        if let Some(index) = [1, 2].into_iter().find(|&i| config.a_m[i] == 0.0) {
            return Err(GeometryError::InvalidArmLength {
                index,
                value: config.a_m[index],
            });
        }
        Ok(Self {
            d1: config.d_m[0],
            a2: config.a_m[1],
            a3: config.a_m[2],
            d4: config.d_m[3],
            d5: config.d_m[4],
            d6: config.d_m[5],
            offsets: config.offset_deg.map(f64::to_radians),
        })
    }

    /// The DH joint angles `θ_i = q_i + offset_i`.
    pub(super) fn thetas(&self, q: &[f64; AXES]) -> [f64; AXES] {
        core::array::from_fn(|i| q[i] + self.offsets[i])
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kinematics::test_robots;

    #[test]
    fn every_shipped_robot_is_of_the_family_with_its_signs() {
        for robot in test_robots::all() {
            let g = robot.geometry;
            if robot.config.manufacturer == "JAKA" {
                assert!(
                    g.a2 > 0.0 && g.a3 > 0.0 && g.d4 < 0.0,
                    "{}",
                    robot.config.name
                );
            } else {
                assert!(
                    g.a2 < 0.0 && g.a3 < 0.0 && g.d4 > 0.0,
                    "{}",
                    robot.config.name
                );
            }
        }
    }

    #[test]
    fn a_table_outside_the_family_names_the_entry() {
        let good = test_robots::default().config.kinematics;
        let mut twisted = good.clone();
        twisted.alpha_deg[4] = 90.0;
        assert_eq!(
            ArmGeometry::new(&twisted),
            Err(GeometryError::Mismatch {
                key: "alpha_deg",
                index: 4,
                value: 90.0,
                expected: -90.0
            })
        );
        let mut shifted = good.clone();
        shifted.d_m[2] = 0.01;
        assert!(matches!(
            ArmGeometry::new(&shifted),
            Err(GeometryError::Mismatch {
                key: "d_m",
                index: 2,
                ..
            })
        ));
        let mut folded = good.clone();
        folded.a_m[2] = 0.0;
        assert_eq!(
            ArmGeometry::new(&folded),
            Err(GeometryError::InvalidArmLength {
                index: 2,
                value: 0.0
            })
        );
        let mut broken = good;
        broken.offset_deg[5] = f64::NAN;
        assert!(matches!(
            ArmGeometry::new(&broken),
            Err(GeometryError::NotFinite {
                key: "offset_deg",
                index: 5,
                ..
            })
        ));
    }
}
