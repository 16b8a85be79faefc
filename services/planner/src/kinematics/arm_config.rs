//! The SRCI arm configuration (Position config byte): Shoulder, Elbow and Wrist, one bit each.
//! The geometric meaning of the bits is in the [module documentation](super).

use shared_types::ipc::AXES;

use super::ArmGeometry;

/// One element of the arm configuration: a choice between the two branches of one binary
/// choice of the inverse kinematics, carried as one bit of the config byte.
pub trait ArmConfigElement: Copy + Eq + core::fmt::Debug {
    /// The element whose config bit is `bit`.
    fn from_bit(bit: bool) -> Self;
    /// Its config bit.
    fn bit(self) -> bool;
}

/// Defines an element with its two values, the second one being the set bit.
macro_rules! arm_config_element {
    ($(#[$doc:meta])* $name:ident { $clear:ident, $set:ident }) => {
        $(#[$doc])*
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
        pub enum $name {
            $clear,
            $set,
        }

        impl ArmConfigElement for $name {
            fn from_bit(bit: bool) -> Self {
                if bit { Self::$set } else { Self::$clear }
            }

            fn bit(self) -> bool {
                self == Self::$set
            }
        }
    };
}

arm_config_element!(
    /// Bit 0: where the wrist point lies relative to the J1 axis.
    Shoulder { Front, Back }
);
arm_config_element!(
    /// Bit 1: where the elbow lies relative to the line from J2 to J4.
    Elbow { Up, Down }
);
arm_config_element!(
    /// Bit 2: the sign of `sin θ5`.
    Wrist { NonFlip, Flip }
);

/// The arm configuration: which of the (up to) eight inverse kinematics branches a joint
/// vector belongs to. Its [`bits`](Self::bits) index [`IkSolutions`](super::IkSolutions).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct ArmConfig {
    pub shoulder: Shoulder,
    pub elbow: Elbow,
    pub wrist: Wrist,
}

impl ArmConfig {
    /// The configuration of a config byte (bit 0 Shoulder BACK, bit 1 Elbow DOWN, bit 2
    /// Wrist FLIP); the higher bits are reserved and ignored.
    pub fn from_bits(bits: u8) -> Self {
        Self {
            shoulder: Shoulder::from_bit(bits & 0b001 != 0),
            elbow: Elbow::from_bit(bits & 0b010 != 0),
            wrist: Wrist::from_bit(bits & 0b100 != 0),
        }
    }

    /// The config byte.
    pub fn bits(self) -> u8 {
        u8::from(self.shoulder.bit())
            | u8::from(self.elbow.bit()) << 1
            | u8::from(self.wrist.bit()) << 2
    }
}

impl ArmGeometry {
    /// The arm configuration of the joint positions `q` (rad): the signs of the
    /// [`singularity_measures`](Self::singularity_measures), a zero counting as positive.
    pub fn arm_config(&self, q: &[f64; AXES]) -> ArmConfig {
        let m = self.singularity_measures(q);
        ArmConfig {
            shoulder: Shoulder::from_bit(m.shoulder_m < 0.0),
            elbow: Elbow::from_bit(m.elbow < 0.0),
            wrist: Wrist::from_bit(m.wrist < 0.0),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kinematics::test_robots;

    #[test]
    fn bits_round_trip_and_follow_the_srci_polarity() {
        for bits in 0..8 {
            assert_eq!(ArmConfig::from_bits(bits).bits(), bits);
        }
        let c = ArmConfig::from_bits(0b1111_1101);
        assert_eq!(
            c,
            ArmConfig {
                shoulder: Shoulder::Back,
                elbow: Elbow::Up,
                wrist: Wrist::Flip,
            }
        );
        assert_eq!(c.bits(), 0b101);
    }

    #[test]
    fn home_positions_have_the_documented_configuration() {
        for robot in test_robots::all() {
            let home = robot.config.home_deg.map(f64::to_radians);
            let expected = if robot.config.manufacturer == "JAKA" {
                ArmConfig {
                    shoulder: Shoulder::Back,
                    elbow: Elbow::Down,
                    wrist: Wrist::Flip,
                }
            } else {
                ArmConfig {
                    shoulder: Shoulder::Front,
                    elbow: Elbow::Up,
                    wrist: Wrist::Flip,
                }
            };
            assert_eq!(
                robot.geometry.arm_config(&home),
                expected,
                "{}",
                robot.config.name
            );
        }
    }

    #[test]
    fn elbow_up_means_the_elbow_above_the_shoulder_wrist_line() {
        for robot in test_robots::all() {
            // Shoulder FRONT with the arm reaching forward and level: the elbow (origin of
            // frame 2) must lie above the straight line from J2 (frame 1) to J4 (frame 3).
            let g = robot.geometry;
            for q3 in [-1.0, 1.0] {
                let q2 = if g.a2 > 0.0 { 0.5 } else { -0.5 };
                let q = [0.0, q2, q3, 0.0, 1.0, 0.0];
                let frames = robot.kinematics.frames(&q);
                let [shoulder, elbow, wrist] = [1, 2, 3].map(|i| frames[i].translation.vector.xz());
                let (a, b) = (wrist - shoulder, elbow - shoulder);
                let t = b.x / a.x;
                let above = elbow.y > shoulder.y + t * a.y;
                let config = g.arm_config(&q);
                assert_eq!(config.shoulder, Shoulder::Front, "{}", robot.config.name);
                assert_eq!(
                    config.elbow == Elbow::Up,
                    above,
                    "{} q3 = {q3}",
                    robot.config.name
                );
            }
        }
    }
}
