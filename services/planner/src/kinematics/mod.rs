//! Kinematics of the arm: forward kinematics and the geometric Jacobian of the standard
//! Denavit-Hartenberg chain of the robot configuration, and, for the UR-type 6R family of the
//! JAKA Zu series and the UR5e, singularities, the analytic inverse kinematics, the SRCI
//! configuration bits, turn numbers and the choice of one solution for a Cartesian target.
//!
//! # The UR-type family
//!
//! `T_i = Rz(θ_i)·Tz(d_i)·Tx(a_i)·Rx(α_i)` with `θ_i = q_i + offset_i`, `α = (90°, 0, 0, 90°,
//! −90°, 0)`, `a1 = a4 = a5 = a6 = 0`, `d2 = d3 = 0` (see [`ArmGeometry`]): J1 is vertical, J2,
//! J3 and J4 are parallel (normal `n = (sin θ1, −cos θ1, 0)` of the arm plane), J5 and J6 do not
//! meet in a spherical wrist. JAKA's arm points along +x at zero (`a2, a3 > 0`, `d4 < 0`), the
//! UR5e's along −x (`a2, a3 < 0`, `d4 > 0`); every definition below holds for both signs.
//!
//! - **Reach direction** `e = sign(a2)·(cos θ1, sin θ1, 0)`: where the stretched arm points for
//!   the current J1 angle.
//! - **Wrist point** `p5`: the origin of frame 5, where the J5 and J6 axes meet, i.e. the
//!   flange origin minus `d6` along the flange z axis. Its component along `n` is always `d4`,
//!   so the J1 angle follows from `p5` alone.
//!
//! # Configuration bits (SRCI Position config byte)
//!
//! Each bit is the sign of one of the [`SingularityMeasures`]; each measure is zero exactly on
//! one of the three singular sets, where the two inverse kinematics branches of that bit meet.
//!
//! | bit | 1 | 0 | 1 when |
//! | --- | --- | --- | --- |
//! | 0 Shoulder | BACK | FRONT | the wrist point lies behind the J1 axis: `p5·e < 0` (the arm reaches over its head) |
//! | 1 Elbow | DOWN | UP | the elbow (J3) lies below the line from J2 to J4, seen in the arm plane with `e` pointing forward: `a3·sin θ3 > 0` |
//! | 2 Wrist | FLIP | NON_FLIP | `sin θ5 < 0` (JAKA's "w = sin(axis5)" negative) |
//!
//! The elbow bit is relative to the arm, not to the world: the mirror image of an elbow-up pose
//! through the J1 axis (shoulder BACK) has the elbow bit DOWN. Both homes of the shipped
//! configurations (JAKA `[0, 90, 90, 90, −90, 0]°`, UR5e `[0, −90, 90, −90, −90, 0]°`) have the
//! upper arm vertical and the forearm horizontal; the UR5e's forearm points forward (FRONT, UP,
//! FLIP), JAKA's backward (BACK, DOWN, FLIP). On a singular set the sign is 0 and the bit is 0.
//!
//! # Singularities
//!
//! - **Shoulder:** the wrist point on the line of the J1 axis projected into the arm plane
//!   (`p5·e = 0`, the two J1 roots meet; with `d4 = 0` this is the J1 axis itself).
//! - **Elbow:** the arm stretched or folded, `θ3 = 0` or `π`.
//! - **Wrist:** `θ5 = 0` or `π`: J6 parallel to J2, J3 and J4, four parallel axes for three
//!   planar freedoms, so θ6 is free and θ2..θ4 follow from it.
//!
//! The Jacobian determinant factors into them: `det J = ±a2·a3·(p5·e)·sin θ3·sin θ5`.
//!
//! # Turns
//!
//! Every joint angle is `base + 2π·turn` with `base` in (−π, π]; inverse kinematics yields base
//! angles, [`turns`] the SRCI TurnNumber encoding, [`selection`] the turn the move goes to.

mod arm_config;
mod geometry;
mod inverse;
mod jacobian;
pub mod selection;
mod singularity;
#[cfg(test)]
pub(crate) mod test_robots;
pub mod turns;

pub use arm_config::{ArmConfig, ArmConfigElement, Elbow, Shoulder, Wrist};
pub use geometry::{ArmGeometry, GeometryError};
pub use inverse::{IkError, IkSolutions, REACH_TOLERANCE_M, WRIST_FREE_SIN};
pub use singularity::{
    ELBOW_SINGULARITY_SIN, SHOULDER_SINGULARITY_M, Singularities, SingularityMeasures,
    WRIST_SINGULARITY_SIN,
};

use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};
use shared_types::config::KinematicsConfig;
use shared_types::ipc::AXES;

pub use shared_types::pose::{rotation_from_rpy, rpy_from_matrix};

/// The kinematic chain of the arm from the base to the flange.
#[derive(Debug, Clone)]
pub struct Kinematics {
    /// The joint-independent part of each link, `Tz(d_i)·Tx(a_i)·Rx(alpha_i)`.
    links: [Isometry3<f64>; AXES],
    /// Joint zero offsets, rad.
    offsets: [f64; AXES],
}

impl Kinematics {
    /// The chain of `T_i = Rz(q_i + offset_i)·Tz(d_i)·Tx(a_i)·Rx(alpha_i)`.
    pub fn new(config: &KinematicsConfig) -> Self {
        Self {
            links: core::array::from_fn(|i| {
                Isometry3::from_parts(
                    Translation3::new(config.a_m[i], 0.0, config.d_m[i]),
                    UnitQuaternion::from_axis_angle(
                        &Vector3::x_axis(),
                        config.alpha_deg[i].to_radians(),
                    ),
                )
            }),
            offsets: config.offset_deg.map(f64::to_radians),
        }
    }

    /// The flange frame in the base frame for the joint positions `q` (rad).
    pub fn flange(&self, q: &[f64; AXES]) -> Isometry3<f64> {
        self.frames(q)[AXES]
    }

    /// The flange pose `[x, y, z, Rx, Ry, Rz]` (m, rad) with `R = Rz(Rz)·Ry(Ry)·Rx(Rx)`.
    pub fn flange_pose(&self, q: &[f64; AXES]) -> [f64; 6] {
        shared_types::pose::pose(&self.flange(q))
    }

    /// The DH frames 0 (base) to 6 (flange) in the base frame; joint `i + 1` turns about the
    /// z axis of frame `i`.
    fn frames(&self, q: &[f64; AXES]) -> [Isometry3<f64>; AXES + 1] {
        let mut frames = [Isometry3::identity(); AXES + 1];
        for (i, (link, (qi, offset))) in self
            .links
            .iter()
            .zip(q.iter().zip(&self.offsets))
            .enumerate()
        {
            let joint = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), qi + offset);
            frames[i + 1] =
                frames[i] * Isometry3::from_parts(Translation3::identity(), joint) * link;
        }
        frames
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use core::f64::consts::FRAC_PI_2;
    use nalgebra::Matrix3;
    use proptest::prelude::*;
    use shared_types::config::Config;

    fn zu7() -> Kinematics {
        let cfg = Config::load(None).expect("embedded configuration");
        assert_eq!(cfg.robot.name, "JAKA Zu 7");
        Kinematics::new(&cfg.robot.kinematics)
    }

    // JAKA Zu 7 table: d1 = 0.12015, a2 = 0.360, a3 = 0.30353, d4 = −0.11501, d5 = 0.1135,
    // d6 = 0.107; alpha = (90°, 0, 0, 90°, −90°, 0).
    const D1: f64 = 0.12015;
    const A2: f64 = 0.360;
    const A3: f64 = 0.30353;
    const D4: f64 = -0.11501;
    const D5: f64 = 0.1135;
    const D6: f64 = 0.107;

    fn assert_pose(kin: &Kinematics, q: [f64; 6], position: [f64; 3], rotation: Matrix3<f64>) {
        let f = kin.flange(&q);
        for i in 0..3 {
            assert!(
                (f.translation.vector[i] - position[i]).abs() < 1e-12,
                "{q:?}: {:?} != {position:?}",
                f.translation.vector
            );
        }
        let r = f.rotation.to_rotation_matrix();
        assert!((r.matrix() - rotation).abs().max() < 1e-12, "{q:?}: {r}");
    }

    #[test]
    fn zero_pose_matches_the_hand_computed_chain() {
        // At q = 0, link 1 turns the frame to (x, y, z) = (X, Z, −Y); a2 and a3 run along X,
        // d4 along −Y, link 4 turns to (X, −Y, −Z), d5 along −Z, link 5 turns back to
        // (X, Z, −Y), d6 along −Y.
        let rotation = Matrix3::new(1.0, 0.0, 0.0, 0.0, 0.0, -1.0, 0.0, 1.0, 0.0);
        assert_pose(&zu7(), [0.0; 6], [A2 + A3, -D4 - D6, D1 - D5], rotation);
        // (0.66353, 0.00801, 0.00665) m, the flange position of JAKA's URDF at zero.
        let p = zu7().flange_pose(&[0.0; 6]);
        assert!((p[0] - 0.66353).abs() < 1e-12 && (p[1] - 0.00801).abs() < 1e-12);
        assert!((p[2] - 0.00665).abs() < 1e-12);
        assert!((p[3] - FRAC_PI_2).abs() < 1e-12 && p[4].abs() < 1e-12 && p[5].abs() < 1e-12);
    }

    #[test]
    fn base_joint_turns_the_zero_pose_about_z() {
        // Rz(90°) maps (x, y) to (−y, x) and the frame (X, Z, −Y) to (Y, Z, X).
        let rotation = Matrix3::new(0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0);
        assert_pose(
            &zu7(),
            [FRAC_PI_2, 0.0, 0.0, 0.0, 0.0, 0.0],
            [D4 + D6, A2 + A3, D1 - D5],
            rotation,
        );
    }

    #[test]
    fn shoulder_up_pose_matches_the_hand_computed_chain() {
        // q2 = 90°: the upper arm points up (frame (Z, −X, −Y)); d4 along −Y, link 4 turns to
        // (Z, −Y, X), d5 along X, link 5 to (Z, −X, −Y), d6 along −Y.
        let rotation = Matrix3::new(0.0, -1.0, 0.0, 0.0, 0.0, -1.0, 1.0, 0.0, 0.0);
        assert_pose(
            &zu7(),
            [0.0, FRAC_PI_2, 0.0, 0.0, 0.0, 0.0],
            [D5, -D4 - D6, D1 + A2 + A3],
            rotation,
        );
    }

    #[test]
    fn flange_joint_turns_only_the_orientation() {
        // Rz(90°) about the flange z (= −Y): x goes to Z, y to −X.
        let rotation = Matrix3::new(0.0, -1.0, 0.0, 0.0, 0.0, -1.0, 1.0, 0.0, 0.0);
        assert_pose(
            &zu7(),
            [0.0, 0.0, 0.0, 0.0, 0.0, FRAC_PI_2],
            [A2 + A3, -D4 - D6, D1 - D5],
            rotation,
        );
    }

    #[test]
    fn gimbal_lock_angles_rebuild_the_rotation() {
        for ry in [FRAC_PI_2, -FRAC_PI_2] {
            let r = rotation_from_rpy(0.7, ry, -0.4);
            let [a, b, c] = rpy_from_matrix(r.matrix());
            assert_eq!(c, 0.0);
            assert!((b - ry).abs() < 1e-7);
            let back = rotation_from_rpy(a, b, c);
            assert!((back.matrix() - r.matrix()).abs().max() < 1e-7, "{ry}");
        }
    }

    proptest! {
        #[test]
        fn angles_round_trip_through_the_rotation_matrix(
            rx in -3.1f64..3.1,
            ry in -1.57f64..1.57,
            rz in -3.1f64..3.1,
        ) {
            let r = rotation_from_rpy(rx, ry, rz);
            let [a, b, c] = rpy_from_matrix(r.matrix());
            prop_assert!((a - rx).abs() < 1e-9 && (b - ry).abs() < 1e-9 && (c - rz).abs() < 1e-9);
            let back = rotation_from_rpy(a, b, c);
            prop_assert!((back.matrix() - r.matrix()).abs().max() < 1e-12);
        }

        #[test]
        fn reported_pose_rebuilds_the_flange_frame(q in prop::array::uniform6(-3.0f64..3.0)) {
            let kin = zu7();
            let f = kin.flange(&q);
            let p = kin.flange_pose(&q);
            let r = rotation_from_rpy(p[3], p[4], p[5]);
            prop_assert!((r.matrix() - f.rotation.to_rotation_matrix().matrix()).abs().max() < 1e-9);
            prop_assert_eq!(&p[..3], f.translation.vector.as_slice());
        }
    }
}
