//! Command and response messages: their 4-byte headers, states, execution modes and the
//! message codes a response carries.

/// The header of every command payload (bytes 0..4).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CommandHeader {
    /// Command type id (e.g. 2101 MoveAxesAbsolute).
    pub command_type: u16,
    pub execution_mode: u8,
    /// Parameter set number of an Enable-type command (4 bits).
    pub par_seq: u8,
    pub priority: u8,
}

impl CommandHeader {
    pub const LEN: usize = 4;

    /// Decodes the header; missing bytes read as zero.
    pub fn decode(p: &[u8]) -> Self {
        let b = |i: usize| p.get(i).copied().unwrap_or(0);
        Self {
            command_type: u16::from_be_bytes([b(0), b(1)]),
            execution_mode: b(2) & 0x0F,
            par_seq: b(3) >> 4,
            priority: b(3) & 0x0F,
        }
    }

    pub fn encode(&self, p: &mut [u8]) {
        p[0..2].copy_from_slice(&self.command_type.to_be_bytes());
        p[2] = self.execution_mode & 0x0F;
        p[3] = (self.par_seq << 4) | (self.priority & 0x0F);
    }
}

/// The header of every response payload (bytes 0..4).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ResponseHeader {
    pub par_seq: u8,
    /// CmdMessageState ([`state`]).
    pub state: u8,
    /// AlarmMessageSeverity ([`severity`]).
    pub severity: i8,
    /// AlarmMessageCode (e.g. 0x8F11).
    pub code: u16,
}

impl ResponseHeader {
    pub const LEN: usize = 4;

    pub fn decode(p: &[u8]) -> Self {
        let b = |i: usize| p.get(i).copied().unwrap_or(0);
        Self {
            par_seq: b(0) >> 4,
            state: b(0) & 0x0F,
            severity: b(1) as i8,
            code: u16::from_be_bytes([b(2), b(3)]),
        }
    }

    pub fn encode(&self, p: &mut [u8]) {
        p[0] = (self.par_seq << 4) | (self.state & 0x0F);
        p[1] = self.severity as u8;
        p[2..4].copy_from_slice(&self.code.to_be_bytes());
    }
}

/// CmdMessageState: the state nibble of a response.
pub mod state {
    pub const EMPTY: u8 = 0;
    pub const CREATED: u8 = 1;
    pub const BUFFERED: u8 = 2;
    pub const BUFFERED_IN_PLANNER: u8 = 3;
    pub const ACTIVE: u8 = 4;
    pub const INTERRUPTED: u8 = 5;
    pub const ABORT_REQUEST: u8 = 6;
    pub const DONE: u8 = 10;
    pub const ABORTED: u8 = 14;
    pub const ERROR: u8 = 15;

    /// States from DONE on end a command; the client frees its ACR slot.
    pub fn is_final(s: u8) -> bool {
        s >= DONE
    }

    /// Name for logs and reports.
    pub fn name(s: u8) -> &'static str {
        match s {
            EMPTY => "EMPTY",
            CREATED => "CREATED",
            BUFFERED => "BUFFERED",
            BUFFERED_IN_PLANNER => "BUFFERED_IN_PLANNER",
            ACTIVE => "ACTIVE",
            INTERRUPTED => "INTERRUPTED",
            ABORT_REQUEST => "ABORT_REQUEST",
            DONE => "DONE",
            ABORTED => "ABORTED",
            ERROR => "ERROR",
            _ => "UNKNOWN",
        }
    }
}

/// AlarmMessageSeverity / message severity.
pub mod severity {
    pub const NONE: i8 = 0;
    pub const DEBUG: i8 = 4;
    pub const INFO: i8 = 5;
    pub const WARNING: i8 = 20;
    pub const ERROR: i8 = 28;
    pub const FATAL_ERROR: i8 = 29;
}

/// ExecutionMode of a command.
pub mod execution_mode {
    pub const SEQUENCE_PRIMARY: u8 = 0;
    pub const SEQUENCE_ABORT_OTHERS_PRIMARY: u8 = 1;
    pub const PARALLEL: u8 = 2;
    pub const CONTINUOUS: u8 = 3;
    pub const TRIGGER_MULTIPLE: u8 = 5;
    pub const SEQUENCE_SECONDARY: u8 = 7;
    pub const SEQUENCE_ABORT_OTHERS_SECONDARY: u8 = 8;
    pub const STOP_PARALLEL_CONTINUOUS_TRIGGER: u8 = 9;

    /// Whether the specification defines `m`.
    pub fn is_defined(m: u8) -> bool {
        matches!(m, 0 | 1 | 2 | 3 | 5 | 7 | 8 | 9)
    }
}

/// Message codes of responses and of ReadMessages (spec tables 7-1, 7-3, 7-5).
pub mod code {
    /// Lifesign below the lower limit, raised to 10 ms (info).
    pub const LIFESIGN_RAISED: u16 = 0x6001;
    pub const MOTION_ERROR: u16 = 0x6C02;
    pub const TARGET_UNREACHABLE: u16 = 0x6C03;
    pub const SW_LIMIT_REACHED: u16 = 0x6C04;
    pub const ABORTED_BY_GROUP_STOP: u16 = 0x6C05;
    pub const ABORTED_BY_MOTION_COMMAND: u16 = 0x6C06;
    /// Command interrupted by the RA state INTERRUPTED (GroupInterrupt).
    pub const INTERRUPTED_BY_GROUP_INTERRUPT: u16 = 0x6F01;
    pub const INTERRUPTED_NOT_ENABLED: u16 = 0x6F02;
    /// GroupContinue not possible: robot not enabled.
    pub const CONTINUE_NOT_ENABLED: u16 = 0x8C01;
    /// GroupContinue not possible: the arm is not where the primary sequence was left.
    pub const NOT_IN_PRIMARY_POSITION: u16 = 0x8C02;
    pub const SERVER_STATE_RESET: u16 = 0x6A03;
    pub const ROBOT_DISABLED: u16 = 0x8C03;
    pub const DISABLED_DUE_TO_ERROR: u16 = 0x8C04;
    /// The interface is not synchronized and SyncReaction denies enabling.
    pub const NOT_SYNCHRONIZED: u16 = 0x8C06;
    /// Jog not possible during an active movement.
    pub const JOG_DURING_MOTION: u16 = 0x8C33;
    pub const SW_LIMIT_LOWER: u16 = 0x8C53;
    pub const SW_LIMIT_UPPER: u16 = 0x8C54;
    pub const INVALID_ACCELERATION_RATE: u16 = 0x8D01;
    /// ConfigMode of the elbow invalid.
    pub const INVALID_CONFIG_MODE_ELBOW: u16 = 0x8D05;
    pub const INVALID_BLENDING_MODE: u16 = 0x8D03;
    pub const INVALID_BLENDING_PARAMETER: u16 = 0x8D04;
    pub const INVALID_DECELERATION_RATE: u16 = 0x8D06;
    pub const INVALID_FRAME_NO: u16 = 0x8D08;
    /// Incremental rotation invalid.
    pub const INVALID_INCREMENTAL_ROTATION: u16 = 0x8D09;
    /// Incremental translation invalid.
    pub const INVALID_INCREMENTAL_TRANSLATION: u16 = 0x8D10;
    pub const INVALID_JERK_RATE: u16 = 0x8D11;
    /// Positive and negative jog direction at the same time.
    pub const JOG_BOTH_DIRECTIONS: u16 = 0x8D12;
    pub const INVALID_JOINT_POSITION: u16 = 0x8D13;
    pub const INVALID_LIFESIGN_TIMEOUT: u16 = 0x8D14;
    pub const INVALID_MODE: u16 = 0x8D21;
    pub const INVALID_ORI_MODE: u16 = 0x8D22;
    pub const INVALID_OVERRIDE: u16 = 0x8D23;
    /// Cartesian position invalid (not a number).
    pub const INVALID_POSITION: u16 = 0x8D24;
    pub const INVALID_SYNC_REACTION: u16 = 0x8D33;
    pub const INVALID_TIME: u16 = 0x8D34;
    pub const INVALID_RETURN_MODE: u16 = 0x8D30;
    pub const INVALID_TARGET_SEQUENCE: u16 = 0x8D31;
    pub const INVALID_TURN_MODE: u16 = 0x8D37;
    pub const INVALID_TOOL_NO: u16 = 0x8D35;
    pub const INVALID_VELOCITY_RATE: u16 = 0x8D38;
    /// ConfigMode of the shoulder / wrist invalid.
    pub const INVALID_CONFIG_MODE_SHOULDER: u16 = 0x8D40;
    pub const INVALID_CONFIG_MODE_WRIST: u16 = 0x8D41;
    pub const INVALID_STEP_MODE: u16 = 0x8D42;
    pub const TOOL_NOT_EXISTING: u16 = 0x8D69;
    /// CircPlane undefined.
    pub const INVALID_CIRC_PLANE: u16 = 0x8D61;
    /// CircMode undefined.
    pub const INVALID_CIRC_MODE: u16 = 0x8D62;
    /// A Tolerance given outside the CENTER mode.
    pub const TOLERANCE_ONLY_CENTER: u16 = 0x8D63;
    /// An Angle given outside the CENTER_WITH_ANGLE mode.
    pub const ANGLE_ONLY_CENTER_WITH_ANGLE: u16 = 0x8D64;
    pub const FRAME_NOT_EXISTING: u16 = 0x8D70;
    pub const BLENDING_MODE_NOT_SUPPORTED: u16 = 0x8E05;
    pub const ORI_MODE_NOT_SUPPORTED: u16 = 0x8E08;
    pub const INVALID_EXECUTION_MODE: u16 = 0x8F10;
    pub const NOT_IMPLEMENTED: u16 = 0x8F11;
    pub const ONLY_ONE_INSTANCE: u16 = 0x8F12;
    /// Only from an interrupted or idle primary sequence.
    pub const REQUIRES_INTERRUPT_OR_IDLE: u16 = 0x8F13;
    /// The secondary sequence is blocked by a command (GroupJog, ReturnToPrimary).
    pub const SECONDARY_BLOCKED: u16 = 0x8F15;
    pub const SECONDARY_NOT_ACTIVE: u16 = 0x8F16;
    pub const SECONDARY_NOT_EMPTY: u16 = 0x8F17;
    pub const TRANSITION_NOT_POSSIBLE: u16 = 0x8F18;
    /// The command type is not one the specification defines.
    pub const COMMAND_TYPE_OUT_OF_RANGE: u16 = 0x8F20;
    pub const INTERNAL_ERROR: u16 = 0x8FFF;
}

/// A percentage field (VelocityRate, Override, ...): percent × 100, 0xFFFF = "use the default".
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Percent {
    Default,
    /// Percent (0.0 ..= 655.34).
    Value(f64),
}

impl Percent {
    pub fn from_wire(v: u16) -> Self {
        if v == 0xFFFF {
            Self::Default
        } else {
            Self::Value(f64::from(v) / 100.0)
        }
    }

    /// Whether a table field named `name` (in snake_case, as `tables::REQUESTS` and
    /// `tables::RESPONSES` name them) carries a percentage: a UINT rate (`velocity_rate`,
    /// `jerk_rate`, ...) or `override`.
    pub fn is_field(name: &str, field: crate::srci::payload::Field) -> bool {
        use crate::srci::payload::{Layout, WireType};
        field.layout == Layout::Scalar(WireType::U16)
            && (name.ends_with("_rate") || name == "override")
    }

    pub fn to_wire(self) -> u16 {
        match self {
            Self::Default => 0xFFFF,
            // Clamped to the wire range first, so the cast cannot overflow.
            Self::Value(p) => (p * 100.0).round().clamp(0.0, 65534.0) as u16,
        }
    }
}

/// IEC DATE and TIME_OF_DAY of a UNIX time in ms: (days since 1990-01-01, ms since midnight).
pub fn iec_date_time(unix_ms: u64) -> (u16, u32) {
    const DAYS_1970_TO_1990: u64 = 7305;
    let days = unix_ms / 86_400_000;
    let ms = (unix_ms % 86_400_000) as u32;
    (
        days.saturating_sub(DAYS_1970_TO_1990).min(65_535) as u16,
        ms,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn headers_round_trip() {
        let h = CommandHeader {
            command_type: 2101,
            execution_mode: 1,
            par_seq: 3,
            priority: 3,
        };
        let mut b = [0u8; 4];
        h.encode(&mut b);
        assert_eq!(b, [0x08, 0x35, 0x01, 0x33]);
        assert_eq!(CommandHeader::decode(&b), h);
        let r = ResponseHeader {
            par_seq: 2,
            state: 1,
            severity: -2,
            code: 0x1234,
        };
        r.encode(&mut b);
        assert_eq!(b, [0x21, 0xFE, 0x12, 0x34]);
        assert_eq!(ResponseHeader::decode(&b), r);
    }

    #[test]
    fn percent_uses_0xffff_for_default() {
        assert_eq!(Percent::from_wire(0xFFFF), Percent::Default);
        assert_eq!(Percent::from_wire(5000), Percent::Value(50.0));
        assert_eq!(Percent::Value(12.34).to_wire(), 1234);
    }

    #[test]
    fn iec_date_of_the_reference_vector() {
        // 2020-06-03 01:00:00 UTC
        let (d, t) = iec_date_time(1_591_146_000_000);
        assert_eq!((d, t), (0x2B67, 3_600_000));
    }
}
