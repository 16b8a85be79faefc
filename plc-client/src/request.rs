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

    /// Whether the command moves the arm: a move, a jog or ReturnToPrimary, typed or not.
    pub fn moves_the_arm(&self) -> bool {
        let name = self.name();
        is_move(name) || name == "GroupJog" || name == "ReturnToPrimary"
    }

    /// Whether the command is of Enable type: it stays ACTIVE with parameters that can be
    /// updated under the same CmdID, instead of running to DONE.
    pub fn is_enable_type(&self) -> bool {
        match self {
            Self::ExchangeConfiguration { .. }
            | Self::ReadMessages { .. }
            | Self::EnableRobot { .. } => true,
            Self::Raw { command_type, .. } => tables::REQUESTS
                .iter()
                .find(|t| t.command_type == *command_type)
                .is_some_and(crate::table_step::is_enable_type),
            _ => false,
        }
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

/// VelocityRate, AccelerationRate, DecelerationRate and JerkRate, in this order.
fn encode_rates(w: &mut PayloadWriter<'_>, fields: [Field; 4], rates: [Option<f64>; 4]) {
    for (f, rate) in fields.into_iter().zip(rates) {
        w.set_u16(f, percent_or_default(rate));
    }
}

fn encode_move_axes_absolute(m: &MoveAxesAbsolute, w: &mut PayloadWriter<'_>) {
    use tables::move_axes_absolute::request as f;
    encode_rates(
        w,
        [
            f::VELOCITY_RATE,
            f::ACCELERATION_RATE,
            f::DECELERATION_RATE,
            f::JERK_RATE,
        ],
        [
            m.velocity_rate,
            m.acceleration_rate,
            m.deceleration_rate,
            m.jerk_rate,
        ],
    );
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

/// IEC DATE and TIME_OF_DAY of a user-data set: days since 1990-01-01, ms since midnight.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Timestamp {
    pub date: u16,
    pub time_of_day_ms: u32,
}

/// ToolData: the TCP in the flange frame (REAL values as on the wire).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ToolData {
    pub timestamp: Timestamp,
    /// X, Y, Z in mm and RX, RY, RZ in degrees.
    pub pose: [f32; 6],
    pub id: u8,
    /// The load the tool carries (0 = none).
    pub load_no: u8,
    /// A stationary tool (the robot carries the workpiece).
    pub external_tcp: bool,
}

/// FrameData: a user frame relative to its reference frame.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct FrameData {
    pub timestamp: Timestamp,
    /// The frame this one is given in (0 = world).
    pub reference_frame: u8,
    /// X, Y, Z in mm and RX, RY, RZ in degrees.
    pub pose: [f32; 6],
}

/// LoadData: a payload carried by the flange or a tool.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct LoadData {
    pub timestamp: Timestamp,
    /// Centre of gravity (X, Y, Z in mm) and principal inertia axes (RX, RY, RZ in degrees).
    pub centre_of_gravity: [f32; 6],
    pub mass_kg: f32,
    /// IX, IY, IZ.
    pub inertia: [f32; 3],
}

/// RobotDefaultDynamics: the rates of moves that leave a rate at default, in percent;
/// `None` is 0xFFFF (in a write: keep the value).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct DefaultDynamics {
    pub timestamp: Timestamp,
    pub velocity_rate: Option<f64>,
    pub acceleration_rate: Option<f64>,
    pub deceleration_rate: Option<f64>,
    pub jerk_rate: Option<f64>,
}

/// RobotReferenceDynamics: the 100 % values of the rates (mm/s, mm/s², mm/s³); a value
/// below 0 in a write keeps the value.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ReferenceDynamics {
    pub timestamp: Timestamp,
    pub velocity: f32,
    pub acceleration: f32,
    pub deceleration: f32,
    pub jerk: f32,
}

/// RobotSWLimits of J1..J6 in degrees (the external axes are left 0).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct SwLimits {
    pub timestamp: Timestamp,
    pub lower_deg: [f32; 6],
    pub upper_deg: [f32; 6],
}

/// A MoveDirectAbsolute (2102) request: a joint-interpolated move to a Cartesian target.
#[derive(Debug, Clone, PartialEq)]
pub struct MoveDirectAbsolute {
    /// X, Y, Z in mm and RX, RY, RZ in degrees.
    pub pose: [f64; 6],
    /// Configuration bits: bit 0 Shoulder, bit 1 Elbow, bit 2 Wrist.
    pub config: u8,
    /// TurnNumber bytes (sign-magnitude nibbles J1..J6, then E1).
    pub turn_numbers: [u8; 4],
    /// ConfigMode of shoulder, elbow and wrist (0 USE_CONFIG, 1 SAME, 2 FREE, 3/4 explicit).
    pub config_mode: [u8; 3],
    /// TurnMode (0 USE_TURN_NUMBER, 1 SAME, 2 FREE).
    pub turn_mode: u8,
    /// Percent of the reference dynamics; `None` sends 0xFFFF ("use the robot default").
    pub velocity_rate: Option<f64>,
    pub acceleration_rate: Option<f64>,
    pub deceleration_rate: Option<f64>,
    pub jerk_rate: Option<f64>,
    pub tool: u8,
    pub frame: u8,
    /// BlendingMode (0 = exact stop).
    pub blending_mode: u8,
    /// Duration of the move in ms (0 = defined by the dynamics).
    pub time_ms: u16,
    /// ExecutionMode 1 (abort the running and buffered moves) instead of 0.
    pub aborting: bool,
}

impl MoveDirectAbsolute {
    /// An exact-stop, buffered move to `pose` in configuration `config` with `turn_numbers`
    /// (ConfigMode USE_CONFIG, TurnMode USE_TURN_NUMBER), default dynamics, tool and frame 0.
    pub fn to(pose: [f64; 6], config: u8, turn_numbers: [u8; 4]) -> Self {
        Self {
            pose,
            config,
            turn_numbers,
            config_mode: [0; 3],
            turn_mode: 0,
            velocity_rate: None,
            acceleration_rate: None,
            deceleration_rate: None,
            jerk_rate: None,
            tool: 0,
            frame: 0,
            blending_mode: 0,
            time_ms: 0,
            aborting: false,
        }
    }

    /// The request (sent with its parameter bytes as [`Request::Raw`]).
    pub fn request(&self) -> Request {
        use tables::move_direct_absolute::request as f;
        let mode = if self.aborting {
            execution_mode::SEQUENCE_ABORT_OTHERS_PRIMARY
        } else {
            execution_mode::SEQUENCE_PRIMARY
        };
        parameters(tables::move_direct_absolute::TYPE, mode, f::LEN, |w| {
            encode_rates(
                w,
                [
                    f::VELOCITY_RATE,
                    f::ACCELERATION_RATE,
                    f::DECELERATION_RATE,
                    f::JERK_RATE,
                ],
                [
                    self.velocity_rate,
                    self.acceleration_rate,
                    self.deceleration_rate,
                    self.jerk_rate,
                ],
            );
            w.set_u8(f::TOOL_NO, self.tool);
            w.set_u8(f::FRAME_NO, self.frame);
            w.set_u8(f::BLENDING_MODE, self.blending_mode);
            for (field, v) in f::POSITION_X_RZ.into_iter().zip(self.pose) {
                w.set_f32(field, v as f32);
            }
            w.set_u8(f::SHOULDER, self.config & 1);
            w.set_u8(f::ELBOW, self.config & 2);
            w.set_u8(f::WRIST, self.config & 4);
            w.set_bytes(f::POSITION_TURN_NUMBER, &self.turn_numbers);
            w.set_u8(f::TURN_MODE, self.turn_mode);
            let [shoulder, elbow, wrist] = self.config_mode;
            w.set_bytes(
                f::CONFIG_MODE,
                &[(shoulder & 0x0F) | (elbow << 4), wrist & 0x0F],
            );
            w.set_u16(f::TIME, self.time_ms);
        })
    }
}

/// JogMode JOG_AXES: each direction pair moves one joint.
pub const JOG_AXES: u8 = 2;

/// A GroupJog (2100) request, Enable type: the direction "keys" move while they are set.
#[derive(Debug, Clone, PartialEq)]
pub struct GroupJog {
    pub enable: bool,
    /// JogMode: 0 frame, 1 tool, 2 axes.
    pub mode: u8,
    pub tool: u8,
    pub frame: u8,
    /// Jog override in percent; `None` sends 0xFFFF (the robot's default).
    pub override_percent: Option<f64>,
    /// Incremental distances (mm, degrees); 0 = continuous.
    pub incremental_translation: f32,
    pub incremental_rotation: f32,
    /// Keys X/J1 .. RZ/J6 in the positive and the negative direction.
    pub positive: [bool; 6],
    pub negative: [bool; 6],
    /// SEQUENCE_SECONDARY (the default of the PLC libraries) or PARALLEL.
    pub execution_mode: u8,
}

impl GroupJog {
    /// Joint jogging, enabled, at `override_percent`, continuous, no key pressed.
    pub fn axes(override_percent: f64) -> Self {
        Self {
            enable: true,
            mode: JOG_AXES,
            tool: 0,
            frame: 0,
            override_percent: Some(override_percent),
            incremental_translation: 0.0,
            incremental_rotation: 0.0,
            positive: [false; 6],
            negative: [false; 6],
            execution_mode: execution_mode::SEQUENCE_SECONDARY,
        }
    }

    /// The same jog with key `axis` (0 = J1) pressed in `direction` (> 0 positive) and every
    /// other key released.
    pub fn pressing(&self, axis: usize, direction: i8) -> Self {
        let mut j = self.clone();
        j.positive = [false; 6];
        j.negative = [false; 6];
        if direction > 0 {
            j.positive[axis] = true;
        } else {
            j.negative[axis] = true;
        }
        j
    }

    /// The request (sent with its parameter bytes as [`Request::Raw`]).
    pub fn request(&self) -> Request {
        use tables::group_jog::request as f;
        const KEYS: [(Field, Field); 6] = [
            (f::X_J1_POS, f::X_J1_NEG),
            (f::Y_J2_POS, f::Y_J2_NEG),
            (f::Z_J3_POS, f::Z_J3_NEG),
            (f::RX_J4_POS, f::RX_J4_NEG),
            (f::RY_J5_POS, f::RY_J5_NEG),
            (f::RZ_J6_POS, f::RZ_J6_NEG),
        ];
        parameters(tables::group_jog::TYPE, self.execution_mode, f::LEN, |w| {
            w.set_bit(f::ENABLE, self.enable);
            w.set_u8(f::TOOL_NO, self.tool);
            w.set_u8(f::FRAME_NO, self.frame);
            w.set_u8(f::MODE, self.mode);
            w.set_f32(f::INCREMENTAL_TRANSLATION, self.incremental_translation);
            w.set_f32(f::INCREMENTAL_ROTATION, self.incremental_rotation);
            w.set_u16(f::OVERRIDE, percent_or_default(self.override_percent));
            for (i, (pos, neg)) in KEYS.into_iter().enumerate() {
                w.set_bit(pos, self.positive[i]);
                w.set_bit(neg, self.negative[i]);
            }
        })
    }
}

/// A request of `command_type` whose parameters `fill` writes at their table offsets into a
/// payload of `len` bytes; sent as [`Request::Raw`].
fn parameters(
    command_type: u16,
    execution_mode: u8,
    len: usize,
    fill: impl FnOnce(&mut PayloadWriter<'_>),
) -> Request {
    let mut b = vec![0u8; len.max(CommandHeader::LEN)];
    fill(&mut PayloadWriter::new(&mut b));
    Request::Raw {
        command_type,
        execution_mode,
        payload: b.split_off(CommandHeader::LEN),
    }
}

fn set_timestamp(w: &mut PayloadWriter<'_>, t: Timestamp, date: Field, time: Field) {
    w.set_u16(date, t.date);
    w.set_u32(time, t.time_of_day_ms);
}

fn set_reals<const N: usize>(w: &mut PayloadWriter<'_>, fields: [Field; N], values: [f32; N]) {
    for (f, v) in fields.into_iter().zip(values) {
        w.set_f32(f, v);
    }
}

/// The user-data function blocks: Read/Write ToolData, FrameData, LoadData,
/// RobotDefaultDynamics, RobotReferenceDynamics and RobotSWLimits, and EnableRobot with a
/// StepMode. All run in parallel (ExecutionMode 2), as the PLC libraries send them.
impl Request {
    /// EnableRobot with StepMode (0 DEACTIVATE, 1 BLENDING, 2 EXACT_STOP).
    pub fn enable_robot_step_mode(enable: bool, step_mode: u8) -> Self {
        use tables::enable_robot::request as f;
        parameters(
            tables::enable_robot::TYPE,
            execution_mode::PARALLEL,
            f::LEN,
            |w| {
                w.set_bit(f::ENABLE, enable);
                w.set_u8(f::STEP_MODE, step_mode);
            },
        )
    }

    /// ReadToolData of `tool_no` (255 = the one in use).
    pub fn read_tool_data(tool_no: u8) -> Self {
        use tables::read_tool_data as t;
        parameters(t::TYPE, execution_mode::PARALLEL, t::request::LEN, |w| {
            w.set_u8(t::request::TOOL_NO, tool_no)
        })
    }

    /// WriteToolData of `tool_no` (1..15).
    pub fn write_tool_data(tool_no: u8, d: &ToolData) -> Self {
        use tables::write_tool_data::request as f;
        parameters(
            tables::write_tool_data::TYPE,
            execution_mode::PARALLEL,
            f::LEN,
            |w| {
                set_timestamp(w, d.timestamp, f::TOOL_DATA_DATE, f::TOOL_DATA_TIME);
                set_reals(w, f::TOOL_DATA_X_RZ, d.pose);
                w.set_u8(f::TOOL_DATA_ID, d.id);
                w.set_u8(f::TOOL_DATA_LOAD_NO, d.load_no);
                w.set_bit(f::TOOL_DATA_EXTERNAL_TCP, d.external_tcp);
                w.set_u8(f::TOOL_NO, tool_no);
            },
        )
    }

    /// ReadFrameData of `frame_no` (255 = the one in use).
    pub fn read_frame_data(frame_no: u8) -> Self {
        use tables::read_frame_data as t;
        parameters(t::TYPE, execution_mode::PARALLEL, t::request::LEN, |w| {
            w.set_u8(t::request::FRAME_NO, frame_no)
        })
    }

    /// WriteFrameData of `frame_no` (1..15).
    pub fn write_frame_data(frame_no: u8, d: &FrameData) -> Self {
        use tables::write_frame_data::request as f;
        parameters(
            tables::write_frame_data::TYPE,
            execution_mode::PARALLEL,
            f::LEN,
            |w| {
                set_timestamp(w, d.timestamp, f::FRAME_DATA_DATE, f::FRAME_DATA_TIME);
                w.set_u8(f::FRAME_DATA_REFERENCE_FRAME, d.reference_frame);
                set_reals(w, f::FRAME_DATA_X_RZ, d.pose);
                w.set_u8(f::FRAME_NO, frame_no);
            },
        )
    }

    /// ReadLoadData of `load_no` (255 = the one in use).
    pub fn read_load_data(load_no: u8) -> Self {
        use tables::read_load_data as t;
        parameters(t::TYPE, execution_mode::PARALLEL, t::request::LEN, |w| {
            w.set_u8(t::request::LOAD_NO, load_no)
        })
    }

    /// WriteLoadData of `load_no` (1..15).
    pub fn write_load_data(load_no: u8, d: &LoadData) -> Self {
        use tables::write_load_data::request as f;
        parameters(
            tables::write_load_data::TYPE,
            execution_mode::PARALLEL,
            f::LEN,
            |w| {
                set_timestamp(w, d.timestamp, f::LOAD_DATA_DATE, f::LOAD_DATA_TIME);
                set_reals(w, f::LOAD_DATA_X_RZ, d.centre_of_gravity);
                w.set_f32(f::LOAD_DATA_MASS, d.mass_kg);
                set_reals(
                    w,
                    [f::LOAD_DATA_IX, f::LOAD_DATA_IY, f::LOAD_DATA_IZ],
                    d.inertia,
                );
                w.set_u8(f::LOAD_NO, load_no);
            },
        )
    }

    /// ReadRobotDefaultDynamics.
    pub fn read_default_dynamics() -> Self {
        use tables::read_robot_default_dynamics as t;
        parameters(t::TYPE, execution_mode::PARALLEL, t::request::LEN, |_| {})
    }

    /// WriteRobotDefaultDynamics.
    pub fn write_default_dynamics(d: &DefaultDynamics) -> Self {
        use tables::write_robot_default_dynamics::request as f;
        parameters(
            tables::write_robot_default_dynamics::TYPE,
            execution_mode::PARALLEL,
            f::LEN,
            |w| {
                set_timestamp(w, d.timestamp, f::DATE, f::TIME);
                encode_rates(
                    w,
                    [
                        f::VELOCITY_RATE,
                        f::ACCELERATION_RATE,
                        f::DECELERATION_RATE,
                        f::JERK_RATE,
                    ],
                    [
                        d.velocity_rate,
                        d.acceleration_rate,
                        d.deceleration_rate,
                        d.jerk_rate,
                    ],
                );
            },
        )
    }

    /// ReadRobotReferenceDynamics.
    pub fn read_reference_dynamics() -> Self {
        use tables::read_robot_reference_dynamics as t;
        parameters(t::TYPE, execution_mode::PARALLEL, t::request::LEN, |_| {})
    }

    /// WriteRobotReferenceDynamics.
    pub fn write_reference_dynamics(d: &ReferenceDynamics) -> Self {
        use tables::write_robot_reference_dynamics::request as f;
        parameters(
            tables::write_robot_reference_dynamics::TYPE,
            execution_mode::PARALLEL,
            f::LEN,
            |w| {
                set_timestamp(w, d.timestamp, f::DATE, f::TIME);
                set_reals(
                    w,
                    [
                        f::VELOCITY_REFERENCE,
                        f::ACCELERATION_REFERENCE,
                        f::DECELERATION_REFERENCE,
                        f::JERK_REFERENCE,
                    ],
                    [d.velocity, d.acceleration, d.deceleration, d.jerk],
                );
            },
        )
    }

    /// ReadRobotSWLimits.
    pub fn read_sw_limits() -> Self {
        use tables::read_robot_sw_limits as t;
        parameters(t::TYPE, execution_mode::PARALLEL, t::request::LEN, |_| {})
    }

    /// WriteRobotSWLimits of J1..J6; `reset_to_factory` sets ResetToFactoryDefault instead.
    pub fn write_sw_limits(d: &SwLimits, reset_to_factory: bool) -> Self {
        use tables::write_robot_sw_limits::request as f;
        parameters(
            tables::write_robot_sw_limits::TYPE,
            execution_mode::PARALLEL,
            f::LEN,
            |w| {
                set_timestamp(w, d.timestamp, f::DATE, f::TIME);
                set_reals(w, SW_LIMITS_LOWER, d.lower_deg);
                set_reals(w, SW_LIMITS_UPPER, d.upper_deg);
                w.set_bit(f::RESET_TO_FACTORY_DEFAULT, reset_to_factory);
            },
        )
    }
}

/// J1..J6 lower limits of WriteRobotSWLimits; the ReadRobotSWLimits response has them at the
/// same offsets (checked below), so its decoder reads them with these.
pub(crate) const SW_LIMITS_LOWER: [Field; 6] = {
    use tables::write_robot_sw_limits::request as f;
    [
        f::J1_LOWER_LIMIT,
        f::J2_LOWER_LIMIT,
        f::J3_LOWER_LIMIT,
        f::J4_LOWER_LIMIT,
        f::J5_LOWER_LIMIT,
        f::J6_LOWER_LIMIT,
    ]
};
pub(crate) const SW_LIMITS_UPPER: [Field; 6] = {
    use tables::write_robot_sw_limits::request as f;
    [
        f::J1_UPPER_LIMIT,
        f::J2_UPPER_LIMIT,
        f::J3_UPPER_LIMIT,
        f::J4_UPPER_LIMIT,
        f::J5_UPPER_LIMIT,
        f::J6_UPPER_LIMIT,
    ]
};
const _: () = {
    use tables::read_robot_sw_limits::response as r;
    assert!(SW_LIMITS_LOWER[0].offset == r::J1_LOWER_LIMIT.offset);
    assert!(SW_LIMITS_LOWER[5].offset == r::J6_LOWER_LIMIT.offset);
    assert!(SW_LIMITS_UPPER[0].offset == r::J1_UPPER_LIMIT.offset);
    assert!(SW_LIMITS_UPPER[5].offset == r::J6_UPPER_LIMIT.offset);
};

/// Whether the specification's function `function` is a move (MoveLinearAbsolute, ...).
pub fn is_move(function: &str) -> bool {
    function.starts_with("Move")
}

/// The specification's function name of a command type, or "Unknown".
pub fn command_name(command_type: u16) -> &'static str {
    tables::COMMAND_TYPES
        .iter()
        .find(|(_, t)| *t == command_type)
        .map_or("Unknown", |(name, _)| name)
}

#[cfg(test)]
pub(crate) mod tests {
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

    /// The whole encoded payload of a function block's request.
    pub(crate) fn encoded(r: &Request) -> Vec<u8> {
        let mut out = Vec::new();
        r.encode(1, &mut out);
        out
    }

    #[test]
    fn move_direct_absolute_places_pose_configuration_and_modes() {
        use tables::move_direct_absolute::request as f;
        let mut m = MoveDirectAbsolute::to(
            [400.0, -50.0, 300.0, 180.0, 0.0, 90.0],
            0b101,
            [1, 0, 0x9, 0],
        );
        m.config_mode = [2, 1, 4];
        m.turn_mode = 1;
        m.velocity_rate = Some(25.0);
        m.aborting = true;
        let out = encoded(&m.request());
        assert_eq!(out.len(), f::LEN);
        let h = CommandHeader::decode(&out);
        assert_eq!((h.command_type, h.execution_mode), (2102, 1));
        let r = PayloadReader::new(&out);
        assert_eq!(r.f32(f::POSITION_Y), -50.0);
        assert_eq!(r.f32(f::POSITION_RZ), 90.0);
        assert_eq!(out[54], 0b101, "Shoulder and Wrist bits");
        assert_eq!(&out[56..60], &[1, 0, 0x9, 0]);
        assert_eq!((out[66], out[67]), (0x12, 0x04));
        assert_eq!(r.u8(f::TURN_MODE), 1);
        assert_eq!(r.u16(f::VELOCITY_RATE), 2500);
        assert_eq!(r.u16(f::DECELERATION_RATE), 0xFFFF);
    }

    #[test]
    fn group_jog_sets_the_key_bits_of_the_table() {
        use tables::group_jog::request as f;
        let jog = GroupJog::axes(20.0).pressing(1, -1);
        let out = encoded(&jog.request());
        assert_eq!(out.len(), f::LEN);
        assert_eq!(CommandHeader::decode(&out).execution_mode, 7);
        let r = PayloadReader::new(&out);
        assert!(r.bit(f::ENABLE));
        assert_eq!(r.u8(f::MODE), JOG_AXES);
        assert_eq!(r.u16(f::OVERRIDE), 2000);
        assert!(r.bit(f::Y_J2_NEG));
        assert_eq!((out[20], out[21], out[22]), (0b1000_0000, 0, 0));
        let positive = encoded(&jog.pressing(5, 1).request());
        assert_eq!(positive[20], 0b0010_0000, "RZ_J6_Pos");
    }

    #[test]
    fn user_data_blocks_use_the_table_offsets() {
        let tool = ToolData {
            timestamp: Timestamp {
                date: 0x2B67,
                time_of_day_ms: 3_600_000,
            },
            pose: [1.5, 0.0, 100.0, 0.0, 0.0, 45.0],
            id: 9,
            load_no: 2,
            external_tcp: false,
        };
        let out = encoded(&Request::write_tool_data(7, &tool));
        assert_eq!(out.len(), tables::write_tool_data::request::LEN);
        assert_eq!(&out[0..4], &[0x14, 0x55, 2, 0x13]);
        assert_eq!(&out[4..6], &[0x2B, 0x67]);
        assert_eq!(&out[10..14], &1.5f32.to_be_bytes());
        assert_eq!((out[34], out[35], out[38]), (9, 2, 7));
        assert_eq!(
            encoded(&Request::read_tool_data(255)),
            [0x13, 0xF3, 2, 0x13, 255]
        );

        let limits = SwLimits {
            timestamp: Timestamp::default(),
            lower_deg: [-10.0; 6],
            upper_deg: [20.0; 6],
        };
        let out = encoded(&Request::write_sw_limits(&limits, true));
        assert_eq!(out.len(), 107);
        assert_eq!(&out[10..14], &(-10f32).to_be_bytes(), "J1 lower");
        assert_eq!(&out[58..62], &20f32.to_be_bytes(), "J6 upper");
        assert_eq!(out[106], 1, "ResetToFactoryDefault");

        let dynamics = DefaultDynamics {
            velocity_rate: Some(75.0),
            ..DefaultDynamics::default()
        };
        let out = encoded(&Request::write_default_dynamics(&dynamics));
        assert_eq!(
            &out[10..18],
            &[0x1D, 0x4C, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF]
        );
        let out = encoded(&Request::enable_robot_step_mode(true, 2));
        assert_eq!(out, [0x03, 0xE8, 2, 0x13, 1, 2, 0, 0]);
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
