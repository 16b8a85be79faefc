//! Commands the client sends: typed requests and their encoding into SRCI command payloads.
//!
//! Every offset comes from the generated specification tables (`srci::tables`); the only
//! exception is the Enable bit of ReadMessages, which the table leaves reserved.

use shared_types::srci::message::{CommandHeader, Percent, execution_mode};
use shared_types::srci::payload::{Field, Layout, PayloadWriter};
use shared_types::srci::tables;

/// PriorityLevel NORMAL: the priority of every command this client sends, as the RobotTask's
/// internal blocks and the open client's function blocks use by default.
pub const PRIORITY_NORMAL: u8 = 3;

/// Byte 5 bit 0 of the ReadMessages request. Spec table 6-107 marks byte 5 reserved; the ST
/// library sets its Enable flag there, and so does this client.
const READ_MESSAGES_ENABLE: Field = Field {
    offset: 5,
    layout: Layout::Bit(0),
};

/// A MoveAxesAbsolute (2101) request: a joint-interpolated move to an absolute joint target.
#[derive(Debug, Clone, PartialEq)]
pub struct MoveAxesAbsolute {
    /// Target J1..J6 in degrees.
    pub joints_deg: [f64; 6],
    /// Percent of the reference dynamics; `None` sends 0xFFFF ("use the robot default").
    pub velocity_rate: Option<f64>,
    pub acceleration_rate: Option<f64>,
    pub deceleration_rate: Option<f64>,
    pub jerk_rate: Option<f64>,
    /// AbortingMode ABORT: ExecutionMode 1 (abort the running and buffered moves) instead of 0.
    pub aborting: bool,
    /// Duration of the move in ms (0 = defined by the dynamics).
    pub time_ms: u16,
    /// BlendingMode (0 = exact stop).
    pub blending_mode: u8,
    /// BlendingParameter[0..1] (e.g. blending radius).
    pub blending_parameter: [f64; 2],
    /// ToolNo of the move.
    pub tool: u8,
}

impl MoveAxesAbsolute {
    /// An exact-stop, buffered move to `joints_deg` with the robot's default dynamics.
    pub fn to(joints_deg: [f64; 6]) -> Self {
        Self {
            joints_deg,
            velocity_rate: None,
            acceleration_rate: None,
            deceleration_rate: None,
            jerk_rate: None,
            aborting: false,
            time_ms: 0,
            blending_mode: 0,
            blending_parameter: [0.0; 2],
            tool: 0,
        }
    }
}

/// A command the client can send.
#[derive(Debug, Clone, PartialEq)]
pub enum Request {
    /// ReadRobotData (9002), Execute type.
    ReadRobotData,
    /// ExchangeConfiguration (9000), Enable type; the RobotTask keeps it enabled.
    ExchangeConfiguration {
        /// LogLevel (a severity).
        log_level: u8,
        /// LifeSignTimeOut in ms.
        lifesign_timeout_ms: u16,
    },
    /// ReadMessages (9001), Enable type; `msg_id` acknowledges a received message.
    ReadMessages { msg_id: u8, message_level: u8 },
    /// EnableRobot (1000), Enable type: switch the arm's power on or off.
    EnableRobot { enable: bool },
    /// GroupReset (1001): acknowledge pending errors.
    GroupReset,
    /// GroupStop (2003): stop and discard every move.
    GroupStop,
    /// GroupInterrupt (2002): stop on the path and hold the primary sequence.
    GroupInterrupt,
    /// GroupContinue (2001): resume the interrupted primary sequence.
    GroupContinue,
    /// ChangeSpeedOverride (2000), override in percent.
    ChangeSpeedOverride { percent: f64 },
    /// MoveAxesAbsolute (2101).
    MoveAxesAbsolute(MoveAxesAbsolute),
    /// ReadActualPosition (5100) in the given tool and frame (255 = the one in use).
    ReadActualPosition { tool: u8, frame: u8 },
    /// Any command type with the given parameter bytes (everything after the 4-byte header).
    Raw {
        command_type: u16,
        execution_mode: u8,
        payload: Vec<u8>,
    },
}

impl Request {
    /// The command type id.
    pub fn command_type(&self) -> u16 {
        match self {
            Self::ReadRobotData => tables::read_robot_data::TYPE,
            Self::ExchangeConfiguration { .. } => tables::exchange_configuration::TYPE,
            Self::ReadMessages { .. } => tables::read_messages::TYPE,
            Self::EnableRobot { .. } => tables::enable_robot::TYPE,
            Self::GroupReset => tables::group_reset::TYPE,
            Self::GroupStop => tables::group_stop::TYPE,
            Self::GroupInterrupt => tables::group_interrupt::TYPE,
            Self::GroupContinue => tables::group_continue::TYPE,
            Self::ChangeSpeedOverride { .. } => tables::change_speed_override::TYPE,
            Self::MoveAxesAbsolute(_) => tables::move_axes_absolute::TYPE,
            Self::ReadActualPosition { .. } => tables::read_actual_position::TYPE,
            Self::Raw { command_type, .. } => *command_type,
        }
    }

    /// The ExecutionMode nibble: moves go to the primary sequence, everything else runs in
    /// parallel (the default of the open client's function blocks).
    pub fn execution_mode(&self) -> u8 {
        match self {
            Self::MoveAxesAbsolute(m) if m.aborting => {
                execution_mode::SEQUENCE_ABORT_OTHERS_PRIMARY
            }
            Self::MoveAxesAbsolute(_) => execution_mode::SEQUENCE_PRIMARY,
            Self::Raw { execution_mode, .. } => *execution_mode,
            _ => execution_mode::PARALLEL,
        }
    }

    /// Whether the command is of Enable type: it stays ACTIVE with parameters that can be
    /// updated under the same CmdID, instead of running to DONE.
    pub fn is_enable_type(&self) -> bool {
        matches!(
            self,
            Self::ExchangeConfiguration { .. }
                | Self::ReadMessages { .. }
                | Self::EnableRobot { .. }
        )
    }

    /// The specification's function name of the command type ("Raw" commands included).
    pub fn name(&self) -> &'static str {
        command_name(self.command_type())
    }

    /// Writes the full command payload (header and every parameter) into `out`.
    pub fn encode(&self, par_seq: u8, out: &mut Vec<u8>) {
        out.clear();
        out.resize(self.payload_len(), 0);
        CommandHeader {
            command_type: self.command_type(),
            execution_mode: self.execution_mode(),
            par_seq,
            priority: PRIORITY_NORMAL,
        }
        .encode(out);
        let mut w = PayloadWriter::new(out);
        match self {
            Self::ReadRobotData
            | Self::GroupReset
            | Self::GroupStop
            | Self::GroupInterrupt
            | Self::GroupContinue => {}
            Self::ExchangeConfiguration {
                log_level,
                lifesign_timeout_ms,
            } => {
                use tables::exchange_configuration::request as f;
                w.set_u8(f::LOG_LEVEL, *log_level);
                w.set_bit(f::ENABLE, true);
                w.set_u16(f::LIFE_SIGN_TIME_OUT, *lifesign_timeout_ms);
            }
            Self::ReadMessages {
                msg_id,
                message_level,
            } => {
                use tables::read_messages::request as f;
                w.set_u8(f::MSG_ID, *msg_id);
                w.set_bit(READ_MESSAGES_ENABLE, true);
                w.set_u8(f::MESSAGE_LEVEL, *message_level);
            }
            Self::EnableRobot { enable } => {
                w.set_bit(tables::enable_robot::request::ENABLE, *enable);
            }
            Self::ChangeSpeedOverride { percent } => {
                w.set_u16(
                    tables::change_speed_override::request::OVERRIDE,
                    Percent::Value(*percent).to_wire(),
                );
            }
            Self::MoveAxesAbsolute(m) => encode_move_axes_absolute(m, &mut w),
            Self::ReadActualPosition { tool, frame } => {
                use tables::read_actual_position::request as f;
                w.set_u8(f::TOOL_NO, *tool);
                w.set_u8(f::FRAME_NO, *frame);
            }
            Self::Raw { payload, .. } => {
                out[CommandHeader::LEN..].copy_from_slice(payload);
            }
        }
    }

    /// Length of the encoded payload.
    pub fn payload_len(&self) -> usize {
        match self {
            Self::ReadRobotData => tables::read_robot_data::request::LEN,
            Self::ExchangeConfiguration { .. } => tables::exchange_configuration::request::LEN,
            Self::ReadMessages { .. } => tables::read_messages::request::LEN,
            Self::EnableRobot { .. } => tables::enable_robot::request::LEN,
            Self::GroupReset => tables::group_reset::request::LEN,
            Self::GroupStop => tables::group_stop::request::LEN,
            Self::GroupInterrupt => tables::group_interrupt::request::LEN,
            Self::GroupContinue => tables::group_continue::request::LEN,
            Self::ChangeSpeedOverride { .. } => tables::change_speed_override::request::LEN,
            Self::MoveAxesAbsolute(_) => tables::move_axes_absolute::request::LEN,
            Self::ReadActualPosition { .. } => tables::read_actual_position::request::LEN,
            Self::Raw { payload, .. } => CommandHeader::LEN + payload.len(),
        }
    }
}

fn percent_or_default(p: Option<f64>) -> u16 {
    p.map_or(Percent::Default, Percent::Value).to_wire()
}

fn encode_move_axes_absolute(m: &MoveAxesAbsolute, w: &mut PayloadWriter<'_>) {
    use tables::move_axes_absolute::request as f;
    w.set_u16(f::VELOCITY_RATE, percent_or_default(m.velocity_rate));
    w.set_u16(
        f::ACCELERATION_RATE,
        percent_or_default(m.acceleration_rate),
    );
    w.set_u16(
        f::DECELERATION_RATE,
        percent_or_default(m.deceleration_rate),
    );
    w.set_u16(f::JERK_RATE, percent_or_default(m.jerk_rate));
    w.set_u8(f::TOOL_NO, m.tool);
    w.set_u8(f::BLENDING_MODE, m.blending_mode);
    for (i, p) in m.blending_parameter.iter().enumerate() {
        // REAL on the wire.
        w.set_f32(f::BLENDING_PARAMETER.element(i), *p as f32);
    }
    let joints = f::JOINT_POSITION_J1_J6;
    for (field, q) in joints.into_iter().zip(m.joints_deg) {
        w.set_f32(field, q as f32);
    }
    w.set_u16(f::TIME, m.time_ms);
}

/// The specification's function name of a command type, or "Unknown".
pub fn command_name(command_type: u16) -> &'static str {
    tables::COMMAND_TYPES
        .iter()
        .find(|(_, t)| *t == command_type)
        .map_or("Unknown", |(name, _)| name)
}

#[cfg(test)]
mod tests {
    use super::*;
    use shared_types::srci::payload::PayloadReader;

    #[test]
    fn read_messages_sets_enable_and_level() {
        let mut out = Vec::new();
        Request::ReadMessages {
            msg_id: 7,
            message_level: 20,
        }
        .encode(2, &mut out);
        assert_eq!(out, [0x23, 0x29, 0x02, 0x23, 7, 0x01, 20]);
    }

    #[test]
    fn move_axes_absolute_uses_the_table_offsets() {
        let mut m = MoveAxesAbsolute::to([10.0, 90.0, 90.0, 90.0, -90.0, 0.0]);
        m.velocity_rate = Some(50.0);
        m.aborting = true;
        let mut out = Vec::new();
        Request::MoveAxesAbsolute(m).encode(1, &mut out);
        assert_eq!(out.len(), 80);
        let r = PayloadReader::new(&out);
        use tables::move_axes_absolute::request as f;
        assert_eq!(CommandHeader::decode(&out).execution_mode, 1);
        assert_eq!(r.u16(f::VELOCITY_RATE), 5000);
        assert_eq!(r.u16(f::ACCELERATION_RATE), 0xFFFF);
        assert_eq!(r.f32(f::JOINT_POSITION_J1), 10.0);
        assert_eq!(r.f32(f::JOINT_POSITION_J5), -90.0);
    }

    #[test]
    fn raw_keeps_its_bytes_after_the_header() {
        let mut out = Vec::new();
        let raw = Request::Raw {
            command_type: 2103,
            execution_mode: 0,
            payload: vec![1, 2, 3],
        };
        raw.encode(1, &mut out);
        assert_eq!(out, [0x08, 0x37, 0x00, 0x13, 1, 2, 3]);
        assert_eq!(raw.name(), "MoveLinearAbsolute");
    }
}
