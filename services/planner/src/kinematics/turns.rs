//! Turn numbers: a joint angle is `base + 2π·turn` with the base angle in (−π, π]; SRCI
//! carries the turns of J1..J6 and E1 in the 4-byte TurnNumber field.
//!
//! Wire format: byte 0 = J2 (high nibble) | J1 (low nibble), byte 1 = J4 | J3, byte 2 = J6 | J5,
//! byte 3 = E1. A joint nibble is sign-magnitude: bits 0..2 the magnitude, bit 3 the sign
//! (set = negative); E1 uses bits 0..6 and the sign in bit 7. A set sign bit with magnitude 0
//! ("−0") is read as 0 and never written.

use core::f64::consts::{PI, TAU};

use shared_types::ipc::AXES;

/// Largest turn magnitude of a joint nibble.
pub const MAX_JOINT_TURNS: i8 = 7;
/// Largest turn magnitude of the E1 byte.
pub const MAX_E1_TURNS: i8 = 127;

/// A turn number cannot be written into its field.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum TurnError {
    #[error("joint {axis} is {turn} turns away from its base angle, more than the ±7 SRCI encodes")]
    JointOutOfRange { axis: usize, turn: i64 },
    #[error("E1 turn {0} is outside the ±127 SRCI encodes")]
    E1OutOfRange(i8),
}

/// The turns of the six joints and of the external axis E1.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct TurnNumbers {
    pub joints: [i8; AXES],
    pub e1: i8,
}

impl TurnNumbers {
    /// The turns of the joint positions `q` (rad), E1 0.
    pub fn of_joints(q: &[f64; AXES]) -> Result<Self, TurnError> {
        let mut joints = [0; AXES];
        for (axis, (turns, &angle)) in joints.iter_mut().zip(q).enumerate() {
            let turn = split_turn(angle).1;
            *turns = i8::try_from(turn)
                .ok()
                .filter(|t| t.abs() <= MAX_JOINT_TURNS)
                .ok_or(TurnError::JointOutOfRange { axis, turn })?;
        }
        Ok(Self { joints, e1: 0 })
    }

    /// Reads the TurnNumber field; every byte pattern is valid.
    pub fn from_wire(bytes: [u8; 4]) -> Self {
        let [j21, j43, j65, e1] = bytes;
        let joints = [j21, j43, j65].map(|b| [b & 0x0F, b >> 4]);
        Self {
            joints: core::array::from_fn(|axis| decode(joints[axis / 2][axis % 2], 3)),
            e1: decode(e1, 7),
        }
    }

    /// Writes the TurnNumber field.
    pub fn to_wire(&self) -> Result<[u8; 4], TurnError> {
        let mut nibbles = [0u8; AXES];
        for (axis, (nibble, &turn)) in nibbles.iter_mut().zip(&self.joints).enumerate() {
            if turn.unsigned_abs() > MAX_JOINT_TURNS.unsigned_abs() {
                return Err(TurnError::JointOutOfRange {
                    axis,
                    turn: i64::from(turn),
                });
            }
            *nibble = encode(turn, 3);
        }
        if self.e1 == i8::MIN {
            return Err(TurnError::E1OutOfRange(self.e1));
        }
        Ok([
            nibbles[1] << 4 | nibbles[0],
            nibbles[3] << 4 | nibbles[2],
            nibbles[5] << 4 | nibbles[4],
            encode(self.e1, 7),
        ])
    }
}

/// Sign-magnitude `value` with the sign in bit `sign_bit`; the magnitude must fit below it.
fn encode(value: i8, sign_bit: u32) -> u8 {
    let magnitude = value.unsigned_abs();
    if value < 0 {
        1 << sign_bit | magnitude
    } else {
        magnitude
    }
}

/// The value of the sign-magnitude `field` whose sign is bit `sign_bit`.
fn decode(field: u8, sign_bit: u32) -> i8 {
    // The magnitude has at most 7 bits, so it fits an i8.
    let magnitude = (field & ((1 << sign_bit) - 1)) as i8;
    if field & 1 << sign_bit != 0 {
        -magnitude
    } else {
        magnitude
    }
}

/// Splits a joint angle (rad) into its base angle in (−π, π] and its turn:
/// `angle = base + 2π·turn`. 200° gives (−160°, 1), −180° gives (180°, −1).
pub fn split_turn(angle: f64) -> (f64, i64) {
    // `angle` lies in (−π + 2πt, π + 2πt] for t = ⌈(angle − π)/2π⌉.
    let turn = ((angle - PI) / TAU).ceil();
    let base = angle - TAU * turn;
    // Rounding can put the base a hair outside (−π, π]; move it to the other end then.
    let (base, turn) = if base <= -PI {
        (base + TAU, turn - 1.0)
    } else if base > PI {
        (base - TAU, turn + 1.0)
    } else {
        (base, turn)
    };
    // `as` saturates; a joint angle is never 2^63 turns away.
    (base, turn as i64)
}

/// The base angle of `angle` in (−π, π].
pub fn base_angle(angle: f64) -> f64 {
    split_turn(angle).0
}

/// The joint positions `base + 2π·turns` (rad).
pub fn with_turns(base: &[f64; AXES], turns: &[i8; AXES]) -> [f64; AXES] {
    core::array::from_fn(|i| base[i] + TAU * f64::from(turns[i]))
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn angles_split_into_base_and_turn() {
        let deg = |d: f64| d.to_radians();
        for (angle, base, turn) in [
            (200.0, -160.0, 1),
            (-200.0, 160.0, -1),
            (180.0, 180.0, 0),
            (-180.0, 180.0, -1),
            (540.0, 180.0, 1),
            (0.0, 0.0, 0),
            (-359.0, 1.0, -1),
            (1000.0, -80.0, 3),
        ] {
            let (b, t) = split_turn(deg(angle));
            assert_eq!(t, turn, "{angle}°");
            assert!(
                (b - deg(base)).abs() < 1e-12,
                "{angle}°: {}°",
                b.to_degrees()
            );
        }
    }

    #[test]
    fn wire_layout_packs_j1_low_and_signs_in_bit_3() {
        let turns = TurnNumbers {
            joints: [-3, 2, 0, -1, 7, -7],
            e1: -100,
        };
        let wire = turns.to_wire().unwrap();
        assert_eq!(wire, [0x2B, 0x90, 0xF7, 0x80 | 100]);
        assert_eq!(TurnNumbers::from_wire(wire), turns);
    }

    #[test]
    fn minus_zero_reads_as_zero_and_is_written_as_zero() {
        let turns = TurnNumbers::from_wire([0x88, 0x88, 0x88, 0x80]);
        assert_eq!(turns, TurnNumbers::default());
        assert_eq!(turns.to_wire().unwrap(), [0; 4]);
    }

    #[test]
    fn unencodable_turns_are_refused() {
        let mut turns = TurnNumbers::default();
        turns.joints[4] = -8;
        assert_eq!(
            turns.to_wire(),
            Err(TurnError::JointOutOfRange { axis: 4, turn: -8 })
        );
        turns.joints[4] = 0;
        turns.e1 = i8::MIN;
        assert_eq!(turns.to_wire(), Err(TurnError::E1OutOfRange(i8::MIN)));
        let far = [0.0, 0.0, 16.0 * PI, 0.0, 0.0, 0.0];
        assert_eq!(
            TurnNumbers::of_joints(&far),
            Err(TurnError::JointOutOfRange { axis: 2, turn: 8 })
        );
    }

    proptest! {
        #[test]
        fn every_field_round_trips(bytes in any::<[u8; 4]>()) {
            let turns = TurnNumbers::from_wire(bytes);
            let again = TurnNumbers::from_wire(turns.to_wire().unwrap());
            prop_assert_eq!(again, turns);
            // Only "−0" fields change on the way back.
            let wire = turns.to_wire().unwrap();
            let nibbles = |w: [u8; 4]| [w[0] & 15, w[0] >> 4, w[1] & 15, w[1] >> 4, w[2] & 15, w[2] >> 4];
            for (written, read) in nibbles(wire).into_iter().zip(nibbles(bytes)) {
                prop_assert!(written == read || (read == 8 && written == 0));
            }
            prop_assert!(wire[3] == bytes[3] || (bytes[3] == 0x80 && wire[3] == 0));
        }

        #[test]
        fn turns_of_joints_rebuild_the_joints(q in prop::array::uniform6(-7.0 * TAU..7.0 * TAU)) {
            let turns = TurnNumbers::of_joints(&q).unwrap();
            let base = q.map(base_angle);
            prop_assert!(base.iter().all(|b| *b > -PI && *b <= PI));
            let again = with_turns(&base, &turns.joints);
            for (a, b) in again.iter().zip(&q) {
                prop_assert!((a - b).abs() < 1e-12);
            }
            prop_assert_eq!(TurnNumbers::from_wire(turns.to_wire().unwrap()), turns);
        }
    }
}
