//! Optional cyclic data (ReadActualPositionCyclic): the blocks a session selects with its
//! TelegramNumber bits, where they sit in the telegrams, and their encoding.
//!
//! Robot→PLC: CartesianPosition (bit 1, 40 bytes: X..RZ, Config WORD, 4 turn bytes, E1,
//! ToolNo, FrameNo, CurrentlyUsedToolNo, CurrentlyUsedFrameNo, 2 reserved) and JointPosition
//! (bit 2, 30 bytes: J1..J6, E1, 2 reserved), in bit order after the header. When the
//! Cartesian block is selected the PLC→robot header is followed by ToolNo and FrameNo, the
//! tool and frame the PLC wants the position in (spec table 5-90). Other optional blocks are
//! not offered.

use shared_types::srci::telegram::{
    FOOTER_LEN, FRAGMENT_HEADER_LEN, PLC_HEADER_LEN, ROBOT_HEADER_LEN, SEQUENCE_HEADER_LEN,
    TELEGRAM_NUMBER_TWO_SEQUENCES, telegram_state as ts,
};

/// TelegramNumberRobToPlc bit of the Cartesian position block.
pub const CARTESIAN_POSITION: u16 = 1 << 1;
/// TelegramNumberRobToPlc bit of the joint position block.
pub const JOINT_POSITION: u16 = 1 << 2;
const CARTESIAN_LEN: usize = 40;
const JOINT_LEN: usize = 30;
/// ToolNo and FrameNo after the PLC→robot header.
const TOOL_FRAME_LEN: usize = 2;
/// Smallest useful sequence: its header and one fragment with a response header.
const MIN_SEQUENCE: usize = SEQUENCE_HEADER_LEN + FRAGMENT_HEADER_LEN + 4;

/// The cyclic blocks of a session.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
pub struct CyclicLayout {
    pub cartesian: bool,
    pub joints: bool,
}

/// The actual position in the units of the wire.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct CyclicPosition {
    /// X, Y, Z in mm, RX, RY, RZ in degrees.
    pub pose: [f64; 6],
    /// J1..J6 in degrees.
    pub joints: [f64; 6],
    /// Tool and frame `pose` is given in.
    pub tool: u8,
    pub frame: u8,
    /// Tool and frame the robot uses now.
    pub current_tool: u8,
    pub current_frame: u8,
    /// Configuration bits (first byte of the Config WORD) and TurnNumber bytes.
    pub arm_config: u8,
    pub turn_numbers: [u8; 4],
}

impl CyclicLayout {
    /// The layout selected by the TelegramNumber bits of an INITIALIZE header, or the
    /// TelegramState that refuses it (172 unsupported blocks, 166 blocks do not fit).
    pub fn select(
        number_plc_to_rob: u16,
        number_rob_to_plc: u16,
        length_plc_to_rob: usize,
        length_rob_to_plc: usize,
    ) -> Result<Self, u8> {
        let offered = CARTESIAN_POSITION | JOINT_POSITION | TELEGRAM_NUMBER_TWO_SEQUENCES;
        if number_plc_to_rob & !TELEGRAM_NUMBER_TWO_SEQUENCES != 0
            || number_rob_to_plc & !offered != 0
        {
            return Err(ts::TELEGRAM_NUMBER_UNSUPPORTED);
        }
        let layout = Self {
            cartesian: number_rob_to_plc & CARTESIAN_POSITION != 0,
            joints: number_rob_to_plc & JOINT_POSITION != 0,
        };
        let fits = |len: usize, header: usize, cyclic: usize| {
            header + cyclic + MIN_SEQUENCE + FOOTER_LEN <= len
        };
        if !fits(length_plc_to_rob, PLC_HEADER_LEN, layout.plc_len())
            || !fits(length_rob_to_plc, ROBOT_HEADER_LEN, layout.robot_len())
        {
            return Err(ts::OPTIONAL_DATA_TOO_LARGE);
        }
        Ok(layout)
    }

    /// Cyclic bytes between the PLC→robot header and the first sequence.
    pub fn plc_len(&self) -> usize {
        if self.cartesian { TOOL_FRAME_LEN } else { 0 }
    }

    /// Cyclic bytes between the robot→PLC header and the first sequence.
    pub fn robot_len(&self) -> usize {
        usize::from(self.cartesian) * CARTESIAN_LEN + usize::from(self.joints) * JOINT_LEN
    }

    /// ToolNo and FrameNo the PLC asks the Cartesian position in (255 = the one in use).
    pub fn requested_tool_frame(&self, plc_telegram: &[u8]) -> Option<(u8, u8)> {
        let at = PLC_HEADER_LEN;
        (self.cartesian && plc_telegram.len() >= at + TOOL_FRAME_LEN)
            .then(|| (plc_telegram[at], plc_telegram[at + 1]))
    }

    /// Writes the selected blocks after the robot→PLC header.
    pub fn write(&self, out: &mut [u8], p: &CyclicPosition) {
        let mut at = ROBOT_HEADER_LEN;
        let put = |out: &mut [u8], at: &mut usize, bytes: &[u8]| {
            out[*at..*at + bytes.len()].copy_from_slice(bytes);
            *at += bytes.len();
        };
        if self.cartesian && out.len() >= at + CARTESIAN_LEN {
            let start = at;
            for v in p.pose {
                put(out, &mut at, &(v as f32).to_be_bytes());
            }
            // Config WORD (bits in its first byte, as in the move commands), turn numbers;
            // E1 stays 0: no external axis.
            put(out, &mut at, &[p.arm_config, 0]);
            put(out, &mut at, &p.turn_numbers);
            at = start + 34;
            put(
                out,
                &mut at,
                &[p.tool, p.frame, p.current_tool, p.current_frame],
            );
            at = start + CARTESIAN_LEN;
        }
        if self.joints && out.len() >= at + JOINT_LEN {
            for v in p.joints {
                put(out, &mut at, &(v as f32).to_be_bytes());
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn selects_the_offered_blocks_and_refuses_the_rest() {
        let l = CyclicLayout::select(0, CARTESIAN_POSITION | JOINT_POSITION, 256, 256).unwrap();
        assert_eq!((l.plc_len(), l.robot_len()), (2, 70));
        assert_eq!(
            CyclicLayout::select(1 << 1, 0, 256, 256),
            Err(ts::TELEGRAM_NUMBER_UNSUPPORTED)
        );
        assert_eq!(
            CyclicLayout::select(0, 1 << 4, 256, 256),
            Err(ts::TELEGRAM_NUMBER_UNSUPPORTED)
        );
        // 10 + 70 + 16 + 1 = 97 bytes do not fit a 64-byte robot→PLC telegram.
        assert_eq!(
            CyclicLayout::select(0, CARTESIAN_POSITION | JOINT_POSITION, 256, 64),
            Err(ts::OPTIONAL_DATA_TOO_LARGE)
        );
        assert!(CyclicLayout::select(0, JOINT_POSITION, 64, 64).is_ok());
    }

    #[test]
    fn writes_cartesian_then_joint_block_big_endian() {
        let l = CyclicLayout {
            cartesian: true,
            joints: true,
        };
        let mut out = [0u8; 128];
        let p = CyclicPosition {
            pose: [500.0, -20.0, 300.0, 180.0, 0.0, 90.0],
            joints: [0.0, 90.0, 90.0, 90.0, -90.0, 45.0],
            arm_config: 0b101,
            turn_numbers: [0x2B, 0, 0, 0],
            ..CyclicPosition::default()
        };
        l.write(&mut out, &p);
        assert_eq!(
            &out[34..40],
            &[0b101, 0, 0x2B, 0, 0, 0],
            "Config WORD and turns"
        );
        let f = |at: usize| f32::from_be_bytes([out[at], out[at + 1], out[at + 2], out[at + 3]]);
        assert_eq!(f(10), 500.0);
        assert_eq!(f(10 + 20), 90.0);
        assert_eq!(
            f(50 + 4),
            90.0,
            "J2 of the joint block after 40 Cartesian bytes"
        );
        assert_eq!(f(50 + 20), 45.0);
    }
}
