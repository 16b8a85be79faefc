//! The cyclic telegram: PLC→robot and robot→PLC headers and footers, sequences and fragments.
//!
//! Layout (spec tables 5-82..5-85): a fixed header (18 bytes PLC→robot, 10 bytes robot→PLC),
//! optional cyclic blocks, one or two sequences (SEQ_ACK, PayloadLength, then fragments of
//! 8-byte header plus payload), and a 1-byte footer repeating the lifesign. Multi-byte fields
//! are big-endian except StatusRobotArm, which travels little-endian.

/// Bytes of the PLC→robot header.
pub const PLC_HEADER_LEN: usize = 18;
/// Bytes of the robot→PLC header.
pub const ROBOT_HEADER_LEN: usize = 10;
/// Bytes of the footer.
pub const FOOTER_LEN: usize = 1;
/// Bytes of a sequence header (SEQ_ACK, PayloadLength).
pub const SEQUENCE_HEADER_LEN: usize = 4;
/// Bytes of a fragment header (CmdID, reserve, FragmentAction, PayloadPointer, PayloadLength).
pub const FRAGMENT_HEADER_LEN: usize = 8;
/// Smallest and largest telegram this codec accepts.
pub const MIN_TELEGRAM_LEN: usize = 64;
pub const MAX_TELEGRAM_LEN: usize = 256;
/// Bit of TelegramNumber that selects two sequences per telegram.
pub const TELEGRAM_NUMBER_TWO_SEQUENCES: u16 = 1 << 8;

/// A telegram that cannot be decoded.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum TelegramError {
    #[error("telegram of {0} bytes is outside 64..=256")]
    Length(usize),
    #[error("sequence PayloadLength {length} exceeds the {available} bytes of the sequence area")]
    SequenceLength { length: usize, available: usize },
    #[error("fragment of CmdID {cmd_id} with {length} bytes runs past its sequence")]
    FragmentLength { cmd_id: u16, length: usize },
}

/// The SRCI version byte: major in bits 5..7, minor in bits 0..4.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SrciVersion {
    pub major: u8,
    pub minor: u8,
}

impl SrciVersion {
    /// The version this controller speaks (1.5, as the SDK and the open clients).
    pub const CURRENT: Self = Self { major: 1, minor: 5 };

    pub fn from_byte(b: u8) -> Self {
        Self {
            major: b >> 5,
            minor: b & 0x1F,
        }
    }

    pub fn to_byte(self) -> u8 {
        (self.major << 5) | (self.minor & 0x1F)
    }
}

/// Control nibble of the PLC header (ControlHalfByte).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Control {
    None,
    Initialize,
    Resume,
    Reset,
    AckError,
    ClientError,
    /// A value the specification does not define.
    Undefined(u8),
}

impl Control {
    pub fn from_nibble(v: u8) -> Self {
        match v {
            0 => Self::None,
            1 => Self::Initialize,
            2 => Self::Resume,
            3 => Self::Reset,
            4 => Self::AckError,
            5 => Self::ClientError,
            other => Self::Undefined(other),
        }
    }

    pub fn to_nibble(self) -> u8 {
        match self {
            Self::None => 0,
            Self::Initialize => 1,
            Self::Resume => 2,
            Self::Reset => 3,
            Self::AckError => 4,
            Self::ClientError => 5,
            Self::Undefined(v) => v & 0x0F,
        }
    }
}

/// TelegramState values (robot→PLC byte 3, spec table 5-96).
pub mod telegram_state {
    pub const UNDEFINED: u8 = 0;
    pub const CONTROL_MISMATCH: u8 = 161;
    pub const INITIALIZATION_LOST: u8 = 162;
    pub const LENGTH_MISMATCH: u8 = 163;
    pub const MAJOR_VERSION: u8 = 164;
    pub const LIFESIGN_TIMEOUT: u8 = 165;
    pub const OPTIONAL_DATA_TOO_LARGE: u8 = 166;
    pub const RESET_AFTER_INITIALIZED: u8 = 167;
    pub const SEQUENCE_TIMEOUT: u8 = 168;
    pub const TELEGRAM_NUMBER_CHANGED: u8 = 169;
    pub const INVALID_AXES_GROUP: u8 = 170;
    pub const TELEGRAM_NUMBER_INVALID: u8 = 171;
    pub const TELEGRAM_NUMBER_UNSUPPORTED: u8 = 172;
    pub const CONNECTION_LOST: u8 = 173;
    pub const READY_TO_RESUME: u8 = 253;
    pub const READY_FOR_INITIALIZATION: u8 = 254;
    pub const INITIALIZED: u8 = 255;

    /// Whether `state` is one of the error states 161..=173.
    pub fn is_error(state: u8) -> bool {
        (CONTROL_MISMATCH..=CONNECTION_LOST).contains(&state)
    }
}

/// The PLC→robot header.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PlcHeader {
    pub version: SrciVersion,
    pub fast_stop: u8,
    pub lifesign: u8,
    pub length_plc_to_rob: u16,
    pub length_rob_to_plc: u16,
    pub axes_group: u8,
    pub control: Control,
    pub telegram_number_plc_to_rob: u16,
    pub telegram_number_rob_to_plc: u16,
    /// Days since 1990-01-01.
    pub client_date: u16,
    /// Milliseconds since midnight.
    pub client_time: u32,
}

fn be16(t: &[u8], i: usize) -> u16 {
    u16::from_be_bytes([t[i], t[i + 1]])
}

fn check_len(t: &[u8]) -> Result<(), TelegramError> {
    if (MIN_TELEGRAM_LEN..=MAX_TELEGRAM_LEN).contains(&t.len()) {
        Ok(())
    } else {
        Err(TelegramError::Length(t.len()))
    }
}

impl PlcHeader {
    /// Decodes the header of a whole PLC→robot telegram.
    pub fn decode(t: &[u8]) -> Result<Self, TelegramError> {
        check_len(t)?;
        Ok(Self {
            version: SrciVersion::from_byte(t[0]),
            fast_stop: t[1] >> 4,
            lifesign: t[1] & 0x0F,
            length_plc_to_rob: be16(t, 2),
            length_rob_to_plc: be16(t, 4),
            axes_group: t[6] >> 4,
            control: Control::from_nibble(t[6] & 0x0F),
            telegram_number_plc_to_rob: be16(t, 8),
            telegram_number_rob_to_plc: be16(t, 10),
            client_date: be16(t, 12),
            client_time: u32::from_be_bytes([t[14], t[15], t[16], t[17]]),
        })
    }

    /// Writes the header and the footer lifesign into a whole telegram buffer.
    pub fn encode(&self, t: &mut [u8]) -> Result<(), TelegramError> {
        check_len(t)?;
        t[0] = self.version.to_byte();
        t[1] = (self.fast_stop << 4) | (self.lifesign & 0x0F);
        t[2..4].copy_from_slice(&self.length_plc_to_rob.to_be_bytes());
        t[4..6].copy_from_slice(&self.length_rob_to_plc.to_be_bytes());
        t[6] = (self.axes_group << 4) | self.control.to_nibble();
        t[7] = 0;
        t[8..10].copy_from_slice(&self.telegram_number_plc_to_rob.to_be_bytes());
        t[10..12].copy_from_slice(&self.telegram_number_rob_to_plc.to_be_bytes());
        t[12..14].copy_from_slice(&self.client_date.to_be_bytes());
        t[14..18].copy_from_slice(&self.client_time.to_be_bytes());
        let last = t.len() - 1;
        t[last] = self.lifesign & 0x0F;
        Ok(())
    }

    /// Whether the whole telegram was written at once: header and footer lifesign agree.
    pub fn is_consistent(t: &[u8]) -> bool {
        t.len() >= MIN_TELEGRAM_LEN && (t[1] & 0x0F) == (t[t.len() - 1] & 0x0F)
    }

    /// Whether both directions select two sequences per telegram.
    pub fn two_sequences(&self) -> bool {
        self.telegram_number_plc_to_rob & TELEGRAM_NUMBER_TWO_SEQUENCES != 0
    }
}

/// StatusRobotArm bits (spec table 5-105).
pub mod status_bit {
    pub const IS_MOVING: u32 = 1 << 0;
    pub const PRIMARY_SEQUENCE_PAUSED: u32 = 1 << 1;
    pub const IN_PRIMARY_POS: u32 = 1 << 2;
    pub const SECONDARY_SEQUENCE_ACTIVE: u32 = 1 << 3;
    pub const IS_BLENDING: u32 = 1 << 4;
    pub const ERROR_PENDING: u32 = 1 << 5;
    pub const RESTART_IN_PROGRESS: u32 = 1 << 6;
    pub const ENABLED: u32 = 1 << 7;
    /// RaSequenceState in bits 8..9 (0 idle, 1 executing, 2 interrupted).
    pub const SEQUENCE_STATE_SHIFT: u32 = 8;
    /// OperationMode in bits 10..12.
    pub const OPERATION_MODE_SHIFT: u32 = 10;
    pub const COLLISION_DETECTED: u32 = 1 << 13;
    pub const RESTART_REQUESTED: u32 = 1 << 14;
    pub const ACCELERATING: u32 = 1 << 15;
    pub const DECELERATING: u32 = 1 << 16;
    pub const CONSTANT_VELOCITY: u32 = 1 << 17;
}

/// The robot→PLC header.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RobotHeader {
    pub version: SrciVersion,
    pub lifesign: u8,
    pub telegram_state: u8,
    /// StatusRobotArm bit field ([`status_bit`]).
    pub status: u32,
    /// Override in percent × 100.
    pub override_centi: u16,
}

impl RobotHeader {
    /// Decodes the header of a whole robot→PLC telegram.
    pub fn decode(t: &[u8]) -> Result<Self, TelegramError> {
        check_len(t)?;
        Ok(Self {
            version: SrciVersion::from_byte(t[0]),
            lifesign: t[1] >> 4,
            telegram_state: t[3],
            status: u32::from_le_bytes([t[4], t[5], t[6], t[7]]),
            override_centi: be16(t, 8),
        })
    }

    /// Writes the header and the footer lifesign into a whole telegram buffer.
    pub fn encode(&self, t: &mut [u8]) -> Result<(), TelegramError> {
        check_len(t)?;
        t[0] = self.version.to_byte();
        t[1] = self.lifesign << 4;
        t[2] = 0;
        t[3] = self.telegram_state;
        t[4..8].copy_from_slice(&self.status.to_le_bytes());
        t[8..10].copy_from_slice(&self.override_centi.to_be_bytes());
        let last = t.len() - 1;
        t[last] = self.lifesign << 4;
        Ok(())
    }

    /// Whether header and footer lifesign agree.
    pub fn is_consistent(t: &[u8]) -> bool {
        t.len() >= MIN_TELEGRAM_LEN && (t[1] >> 4) == (t[t.len() - 1] >> 4)
    }
}

/// The next 4-bit lifesign after `v`: 1..=15, wrapping to 1 (0 only before the first cycle).
pub fn next_lifesign(v: u8) -> u8 {
    if v >= 15 { 1 } else { v + 1 }
}

/// Where the sequences of a telegram are: `(start, length)` of each sequence area.
///
/// With one sequence it fills everything between the header (plus `cyclic_len` bytes of
/// optional cyclic data) and the footer; with two, the first gets half (rounded down).
pub fn sequence_areas(
    telegram_len: usize,
    header_len: usize,
    cyclic_len: usize,
    two_sequences: bool,
) -> ([(usize, usize); 2], usize) {
    let start = header_len + cyclic_len;
    let area = telegram_len.saturating_sub(start + FOOTER_LEN);
    if two_sequences {
        let first = area / 2;
        ([(start, first), (start + first, area - first)], 2)
    } else {
        ([(start, area), (0, 0)], 1)
    }
}

/// FragmentAction bits.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct FragmentAction(pub u8);

impl FragmentAction {
    /// The message is complete with this fragment: process it.
    pub const COMPLETE: u8 = 0x01;
    /// First fragment of a new command: reset the ACR entry of this CmdID.
    pub const RESET: u8 = 0x02;
    /// First fragment of a parameter update: zero the receive buffer first.
    pub const CLEAR: u8 = 0x04;

    pub fn complete(self) -> bool {
        self.0 & Self::COMPLETE != 0
    }
    pub fn reset(self) -> bool {
        self.0 & Self::RESET != 0
    }
    pub fn clear(self) -> bool {
        self.0 & Self::CLEAR != 0
    }
}

/// The header of one fragment.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FragmentHeader {
    pub cmd_id: u16,
    pub action: FragmentAction,
    /// Offset of this piece inside the whole message.
    pub pointer: u16,
    pub length: u16,
}

/// One decoded sequence of a telegram.
#[derive(Debug, Clone, Copy)]
pub struct Sequence<'a> {
    pub seq_ack: u16,
    /// The fragment bytes (`PayloadLength` of them).
    pub body: &'a [u8],
}

impl<'a> Sequence<'a> {
    /// Decodes the sequence in `area` (the sequence area of a telegram).
    pub fn decode(area: &'a [u8]) -> Result<Self, TelegramError> {
        if area.len() < SEQUENCE_HEADER_LEN {
            return Err(TelegramError::SequenceLength {
                length: 0,
                available: area.len(),
            });
        }
        let seq_ack = be16(area, 0);
        let length = usize::from(be16(area, 2));
        let available = area.len() - SEQUENCE_HEADER_LEN;
        if length > available {
            return Err(TelegramError::SequenceLength { length, available });
        }
        Ok(Self {
            seq_ack,
            body: &area[SEQUENCE_HEADER_LEN..SEQUENCE_HEADER_LEN + length],
        })
    }

    /// The fragments, in order; stops at the first malformed one with an error.
    pub fn fragments(&self) -> Fragments<'a> {
        Fragments {
            rest: self.body,
            failed: false,
        }
    }
}

/// Iterator over the fragments of a sequence.
#[derive(Debug)]
pub struct Fragments<'a> {
    rest: &'a [u8],
    failed: bool,
}

impl<'a> Iterator for Fragments<'a> {
    type Item = Result<(FragmentHeader, &'a [u8]), TelegramError>;

    fn next(&mut self) -> Option<Self::Item> {
        if self.failed || self.rest.len() < FRAGMENT_HEADER_LEN {
            return None;
        }
        let r = self.rest;
        let header = FragmentHeader {
            cmd_id: be16(r, 0),
            action: FragmentAction(r[3]),
            pointer: be16(r, 4),
            length: be16(r, 6),
        };
        let len = usize::from(header.length);
        if FRAGMENT_HEADER_LEN + len > r.len() {
            self.failed = true;
            return Some(Err(TelegramError::FragmentLength {
                cmd_id: header.cmd_id,
                length: len,
            }));
        }
        let data = &r[FRAGMENT_HEADER_LEN..FRAGMENT_HEADER_LEN + len];
        self.rest = &r[FRAGMENT_HEADER_LEN + len..];
        Some(Ok((header, data)))
    }
}

/// Writes one sequence (header plus fragments) into a sequence area.
#[derive(Debug)]
pub struct SequenceWriter<'a> {
    area: &'a mut [u8],
    used: usize,
}

impl<'a> SequenceWriter<'a> {
    /// Starts an empty sequence with `seq_ack` in `area`.
    pub fn new(area: &'a mut [u8], seq_ack: u16) -> Self {
        area.fill(0);
        if area.len() >= SEQUENCE_HEADER_LEN {
            area[0..2].copy_from_slice(&seq_ack.to_be_bytes());
        }
        Self { area, used: 0 }
    }

    /// Payload bytes a further fragment could carry (0 if not even a header fits).
    pub fn room(&self) -> usize {
        self.area
            .len()
            .saturating_sub(SEQUENCE_HEADER_LEN + self.used + FRAGMENT_HEADER_LEN)
    }

    /// Appends a fragment carrying `data`; returns false (writing nothing) if it does not fit.
    pub fn push(&mut self, cmd_id: u16, action: u8, pointer: u16, data: &[u8]) -> bool {
        if data.len() > self.room()
            || (data.is_empty()
                && self.area.len() < SEQUENCE_HEADER_LEN + self.used + FRAGMENT_HEADER_LEN)
        {
            return false;
        }
        let at = SEQUENCE_HEADER_LEN + self.used;
        let h = &mut self.area[at..at + FRAGMENT_HEADER_LEN];
        h[0..2].copy_from_slice(&cmd_id.to_be_bytes());
        h[2] = 0;
        h[3] = action;
        h[4..6].copy_from_slice(&pointer.to_be_bytes());
        // `data.len()` is at most a sequence area (< 256), so it fits a u16.
        h[6..8].copy_from_slice(&(data.len() as u16).to_be_bytes());
        self.area[at + FRAGMENT_HEADER_LEN..at + FRAGMENT_HEADER_LEN + data.len()]
            .copy_from_slice(data);
        self.used += FRAGMENT_HEADER_LEN + data.len();
        // Likewise bounded by the area length.
        self.area[2..4].copy_from_slice(&(self.used as u16).to_be_bytes());
        true
    }

    /// Bytes of fragments written so far (the sequence's PayloadLength).
    pub fn payload_length(&self) -> usize {
        self.used
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn hex(s: &str) -> Vec<u8> {
        (0..s.len())
            .step_by(2)
            .map(|i| u8::from_str_radix(&s[i..i + 2], 16).unwrap())
            .collect()
    }

    /// The PLC→robot vector of the open Python client's telegram test (64 bytes).
    const PLC_VECTOR: &str = "2503004000800100000200062B670036EE800007000C010100010000000403E81000000000000000000000000000000000000000000000000000000000000003";

    #[test]
    fn decodes_the_reference_plc_telegram() {
        let t = hex(PLC_VECTOR);
        assert_eq!(t.len(), 64);
        let h = PlcHeader::decode(&t).unwrap();
        assert_eq!(h.version, SrciVersion { major: 1, minor: 5 });
        assert_eq!(h.lifesign, 3);
        assert_eq!(h.length_plc_to_rob, 0x40);
        assert_eq!(h.length_rob_to_plc, 0x80);
        assert_eq!(h.control, Control::Initialize);
        assert_eq!(h.axes_group, 0);
        assert_eq!(h.telegram_number_plc_to_rob, 2);
        assert_eq!(h.telegram_number_rob_to_plc, 6);
        assert_eq!(h.client_date, 0x2B67);
        assert_eq!(h.client_time, 3_600_000);
        assert!(PlcHeader::is_consistent(&t));
        let (areas, n) = sequence_areas(64, PLC_HEADER_LEN, 0, false);
        assert_eq!((n, areas[0]), (1, (18, 45)));
        let seq = Sequence::decode(&t[18..63]).unwrap();
        assert_eq!(seq.seq_ack, 7);
        let frags: Vec<_> = seq.fragments().collect::<Result<_, _>>().unwrap();
        assert_eq!(frags.len(), 1);
        let (fh, data) = frags[0];
        assert_eq!(fh.cmd_id, 0x0101);
        assert!(fh.action.complete() && !fh.action.reset());
        assert_eq!((fh.pointer, fh.length), (0, 4));
        assert_eq!(data, &[0x03, 0xE8, 0x10, 0x00]);
    }

    #[test]
    fn encodes_the_reference_plc_telegram_byte_for_byte() {
        let expected = hex(PLC_VECTOR);
        let mut t = vec![0u8; 64];
        let h = PlcHeader::decode(&expected).unwrap();
        h.encode(&mut t).unwrap();
        let mut w = SequenceWriter::new(&mut t[18..63], 7);
        assert!(w.push(
            0x0101,
            FragmentAction::COMPLETE,
            0,
            &[0x03, 0xE8, 0x10, 0x00]
        ));
        assert_eq!(t, expected);
    }

    /// The robot→PLC vector of the same test (128 bytes).
    #[test]
    fn encodes_the_reference_robot_telegram_byte_for_byte() {
        let mut expected = hex("253000FF8100000013880005000D010100010000000521FE1234AA");
        expected.resize(128, 0);
        expected[127] = 0x30;
        let mut t = vec![0u8; 128];
        RobotHeader {
            version: SrciVersion::CURRENT,
            lifesign: 3,
            telegram_state: telegram_state::INITIALIZED,
            status: 0x81,
            override_centi: 5000,
        }
        .encode(&mut t)
        .unwrap();
        let mut w = SequenceWriter::new(&mut t[10..127], 5);
        assert!(w.push(
            0x0101,
            FragmentAction::COMPLETE,
            0,
            &[0x21, 0xFE, 0x12, 0x34, 0xAA]
        ));
        assert_eq!(t, expected);
        let h = RobotHeader::decode(&t).unwrap();
        assert_eq!(h.status, 0x81, "StatusRobotArm is little-endian");
        assert!(RobotHeader::is_consistent(&t));
    }

    #[test]
    fn torn_frames_and_bad_lengths_are_detected() {
        let mut t = hex(PLC_VECTOR);
        t[63] = 0x04;
        assert!(!PlcHeader::is_consistent(&t));
        assert_eq!(PlcHeader::decode(&t[..63]), Err(TelegramError::Length(63)));
        let mut area = [0u8; 20];
        area[3] = 17; // PayloadLength 17 > 16 available
        assert!(matches!(
            Sequence::decode(&area),
            Err(TelegramError::SequenceLength {
                length: 17,
                available: 16
            })
        ));
        area[3] = 12; // one fragment header claiming 10 bytes but only 4 follow
        area[11] = 10;
        let seq = Sequence::decode(&area).unwrap();
        let r: Vec<_> = seq.fragments().collect();
        assert!(matches!(r[0], Err(TelegramError::FragmentLength { .. })));
    }

    #[test]
    fn lifesign_wraps_from_15_to_1() {
        assert_eq!(next_lifesign(0), 1);
        assert_eq!(next_lifesign(14), 15);
        assert_eq!(next_lifesign(15), 1);
    }

    #[test]
    fn two_sequences_split_the_area() {
        let (a, n) = sequence_areas(256, PLC_HEADER_LEN, 0, true);
        assert_eq!(n, 2);
        assert_eq!(a[0], (18, 118));
        assert_eq!(a[1], (136, 119));
    }

    proptest::proptest! {
        #[test]
        fn sequence_parser_never_panics(bytes in proptest::collection::vec(proptest::num::u8::ANY, 0..300)) {
            if let Ok(seq) = Sequence::decode(&bytes) {
                for f in seq.fragments() { let _ = f; }
            }
            let _ = PlcHeader::decode(&bytes);
            let _ = RobotHeader::decode(&bytes);
        }
    }
}
