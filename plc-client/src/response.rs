//! Typed views of the response payloads the client reads.
//!
//! Decoders take the whole response payload (4-byte header included) and read it through the
//! generated specification tables; missing tail bytes read as zero.

use shared_types::srci::message::Percent;
use shared_types::srci::payload::{Field, Layout, PayloadReader, WireType};
use shared_types::srci::{supported, tables};

use crate::request::{
    DefaultDynamics, FrameData, LoadData, ReferenceDynamics, SW_LIMITS_LOWER, SW_LIMITS_UPPER,
    SwLimits, Timestamp, ToolData,
};

/// A fixed-length CHAR field as text: up to the first NUL, trailing blanks removed.
fn chars(payload: &[u8], f: Field) -> String {
    let start = f.offset.min(payload.len());
    let end = (f.offset + f.size()).min(payload.len());
    let raw = &payload[start..end];
    let text = raw.split(|&b| b == 0).next().unwrap_or(&[]);
    String::from_utf8_lossy(text).trim_end().to_owned()
}

/// ReadRobotData (9002) response: the robot's identity and capabilities.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RobotData {
    pub manufacturer: String,
    pub order_id: String,
    pub serial_number: String,
    pub ra_serial_number: String,
    pub firmware_version: String,
    pub interpreter_version: String,
    pub axis_joint_used: u8,
    pub axis_external_used: u8,
    pub axis_joint_unit: u8,
    pub axis_external_unit: u8,
    /// RCSupportedFunctions bitmap (byte.bit per function).
    pub supported_functions: [u8; 19],
    pub robot_id: String,
    pub interpreter_cycle_time_ms: u16,
}

impl RobotData {
    pub fn decode(payload: &[u8]) -> Self {
        use tables::read_robot_data::response as f;
        let r = PayloadReader::new(payload);
        let mut supported_functions = [0u8; 19];
        for (i, b) in supported_functions.iter_mut().enumerate() {
            *b = r.u8(f::RC_SUPPORTED_FUNCTIONS.element(i));
        }
        Self {
            manufacturer: chars(payload, f::RC_MANUFACTURER),
            order_id: chars(payload, f::RC_ORDER_ID),
            serial_number: chars(payload, f::RC_SERIAL_NUMBER),
            ra_serial_number: chars(payload, f::RA_SERIAL_NUMBER),
            firmware_version: chars(payload, f::RC_FIRMWARE_VERSION),
            interpreter_version: chars(payload, f::RC_INTERPRETER_VERSION),
            axis_joint_used: r.u8(f::AXIS_JOINT_USED),
            axis_external_used: r.u8(f::AXIS_EXTERNAL_USED),
            axis_joint_unit: r.u8(f::AXIS_JOINT_UNIT),
            axis_external_unit: r.u8(f::AXIS_EXTERNAL_UNIT),
            supported_functions,
            robot_id: chars(payload, f::ROBOT_ID),
            interpreter_cycle_time_ms: r.u16(f::INTERPRETER_CYCLE_TIME),
        }
    }

    /// Whether RCSupportedFunctions announces `command_type`.
    pub fn supports(&self, command_type: u16) -> bool {
        supported::announces(&self.supported_functions, command_type)
    }
}

/// ExchangeConfiguration (9000) response: what the robot reports about the session.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Configuration {
    pub enabled: bool,
    /// Entries of the robot's Active Command Register.
    pub length_acr: u16,
    pub highest_tool_index: u8,
    pub highest_frame_index: u8,
    pub highest_load_index: u8,
    pub number_of_server_logs: u16,
}

impl Configuration {
    pub fn decode(payload: &[u8]) -> Self {
        use tables::exchange_configuration::response as f;
        let r = PayloadReader::new(payload);
        Self {
            enabled: r.bit(f::ENABLED),
            length_acr: r.u16(f::LENGTH_ACR),
            highest_tool_index: r.u8(f::HIGHEST_TOOL_INDEX),
            highest_frame_index: r.u8(f::HIGHEST_FRAME_INDEX),
            highest_load_index: r.u8(f::HIGHEST_LOAD_INDEX),
            number_of_server_logs: r.u16(f::NUMBER_OF_SERVER_LOGS),
        }
    }
}

/// ReadActualPosition (5100) response.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ActualPosition {
    /// Tool and frame the Cartesian position is given in.
    pub tool: u8,
    pub frame: u8,
    /// X, Y, Z in mm and RX, RY, RZ in degrees.
    pub cartesian: [f64; 6],
    /// J1..J6 in degrees.
    pub joints_deg: [f64; 6],
}

impl ActualPosition {
    pub fn decode(payload: &[u8]) -> Self {
        use tables::read_actual_position::response as f;
        let r = PayloadReader::new(payload);
        let read = |fields: [Field; 6]| fields.map(|field| f64::from(r.f32(field)));
        Self {
            tool: r.u8(f::TOOL_NO_RETURN),
            frame: r.u8(f::FRAME_NO_RETURN),
            cartesian: read(f::ACTUAL_CARTESIAN_POSITION_X_RZ),
            joints_deg: read(f::ACTUAL_JOINT_POSITION_J1_J6),
        }
    }
}

/// The optional cyclic position blocks of a robot telegram (ReadActualPositionCyclic).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct CyclicPosition {
    /// X, Y, Z in mm and RX, RY, RZ in degrees (CartesianPosition block).
    pub cartesian: Option<[f64; 6]>,
    /// Tool and frame the Cartesian position is given in.
    pub tool_frame: Option<(u8, u8)>,
    /// J1..J6 in degrees (JointPosition block).
    pub joints_deg: Option<[f64; 6]>,
}

impl CyclicPosition {
    /// Reads the blocks `selection` chose from a whole robot telegram.
    pub fn decode(telegram: &[u8], selection: crate::engine::CyclicSelection) -> Self {
        let real = |at: usize| {
            telegram.get(at..at + 4).map_or(0.0, |b| {
                f64::from(f32::from_be_bytes([b[0], b[1], b[2], b[3]]))
            })
        };
        let six = |at: usize| core::array::from_fn(|i| real(at + 4 * i));
        let mut at = shared_types::srci::telegram::ROBOT_HEADER_LEN;
        let mut p = Self::default();
        if selection.cartesian {
            p.cartesian = Some(six(at));
            p.tool_frame = telegram.get(at + 34..at + 36).map(|b| (b[0], b[1]));
            at += 40;
        }
        if selection.joints {
            p.joints_deg = Some(six(at));
        }
        p
    }
}

/// MoveAxesAbsolute (2101) response: the progress of the move.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MoveProgress {
    pub invocation_counter: u8,
    pub origin_id: i16,
    /// Progress in percent; `None` when the robot sends 0xFFFF (no valid value).
    pub progress_percent: Option<f64>,
}

impl MoveProgress {
    pub fn decode(payload: &[u8]) -> Self {
        use tables::move_axes_absolute::response as f;
        let r = PayloadReader::new(payload);
        Self {
            invocation_counter: r.u8(f::INVOCATION_COUNTER),
            origin_id: r.i16(f::ORIGIN_ID),
            progress_percent: match Percent::from_wire(r.u16(f::PROGRESS)) {
                Percent::Value(p) => Some(p),
                Percent::Default => None,
            },
        }
    }
}

/// The Enabled bit of an EnableRobot (1000) response.
pub fn robot_enabled(payload: &[u8]) -> bool {
    PayloadReader::new(payload).bit(tables::enable_robot::response::ENABLED)
}

/// One robot message delivered by ReadMessages (9001).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RobotMessage {
    /// MsgID the client acknowledged (1..255).
    pub msg_id: u8,
    /// Days since 1990-01-01.
    pub date: u16,
    /// Milliseconds since midnight.
    pub time_ms: u32,
    /// MsgType: 1 RI, 2 RC, 3 RA, 4 CMD.
    pub msg_type: u8,
    pub severity: i8,
    pub code: u32,
    pub text: String,
}

/// The message part of a ReadMessages response.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Messages {
    pub enabled: bool,
    pub active_errors: u8,
    pub active_warnings: u8,
    /// The delivered message, if MsgID > 0.
    pub message: Option<RobotMessage>,
}

impl Messages {
    pub fn decode(payload: &[u8]) -> Self {
        use tables::read_messages::response as f;
        let r = PayloadReader::new(payload);
        let msg_id = r.u8(f::MSG_ID);
        Self {
            enabled: r.bit(f::ENABLED),
            active_errors: r.u8(f::NUMBER_OF_ACTIVE_ERRORS),
            active_warnings: r.u8(f::NUMBER_OF_ACTIVE_WARNINGS),
            message: (msg_id > 0).then(|| RobotMessage {
                msg_id,
                date: r.u16(f::DATE),
                time_ms: r.u32(f::TIME),
                msg_type: r.u8(f::MSG_TYPE),
                severity: r.i8(f::SEVERITY),
                code: r.u32(f::ERROR_CODE),
                text: chars(payload, f::TEXT),
            }),
        }
    }
}

/// A user-data set read back, with DataChanged (the robot changed it since the last write).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DataEntry<T> {
    pub data: T,
    pub data_changed: bool,
}

fn timestamp(r: &PayloadReader, date: Field, time: Field) -> Timestamp {
    Timestamp {
        date: r.u16(date),
        time_of_day_ms: r.u32(time),
    }
}

fn reals<const N: usize>(r: &PayloadReader, fields: [Field; N]) -> [f32; N] {
    fields.map(|f| r.f32(f))
}

fn percent(r: &PayloadReader, f: Field) -> Option<f64> {
    match Percent::from_wire(r.u16(f)) {
        Percent::Value(p) => Some(p),
        Percent::Default => None,
    }
}

/// ReadToolData (5107) response: ToolNo and the tool.
pub fn tool_data(payload: &[u8]) -> (u8, DataEntry<ToolData>) {
    use tables::read_tool_data::response as f;
    let r = PayloadReader::new(payload);
    let data = ToolData {
        timestamp: timestamp(&r, f::TOOL_DATA_DATE, f::TOOL_DATA_TIME),
        pose: reals(&r, f::TOOL_DATA_X_RZ),
        id: r.u8(f::TOOL_DATA_ID),
        load_no: r.u8(f::TOOL_DATA_LOAD_NO),
        external_tcp: r.bit(f::TOOL_DATA_EXTERNAL_TCP),
    };
    let changed = r.bit(f::DATA_CHANGED);
    (r.u8(f::TOOL_NO), entry(data, changed))
}

/// ReadFrameData (5102) response: FrameNo and the frame.
pub fn frame_data(payload: &[u8]) -> (u8, DataEntry<FrameData>) {
    use tables::read_frame_data::response as f;
    let r = PayloadReader::new(payload);
    let data = FrameData {
        timestamp: timestamp(&r, f::FRAME_DATA_DATE, f::FRAME_DATA_TIME),
        reference_frame: r.u8(f::FRAME_DATA_REFERENCE_FRAME),
        pose: reals(&r, f::FRAME_DATA_X_RZ),
    };
    let changed = r.bit(f::DATA_CHANGED);
    (r.u8(f::FRAME_NO), entry(data, changed))
}

/// ReadLoadData (5103) response: LoadNo and the load.
pub fn load_data(payload: &[u8]) -> (u8, DataEntry<LoadData>) {
    use tables::read_load_data::response as f;
    let r = PayloadReader::new(payload);
    let data = LoadData {
        timestamp: timestamp(&r, f::LOAD_DATA_DATE, f::LOAD_DATA_TIME),
        centre_of_gravity: reals(&r, f::LOAD_DATA_X_RZ),
        mass_kg: r.f32(f::LOAD_DATA_MASS),
        inertia: reals(&r, [f::LOAD_DATA_IX, f::LOAD_DATA_IY, f::LOAD_DATA_IZ]),
    };
    let changed = r.bit(f::DATA_CHANGED);
    (r.u8(f::LOAD_NO), entry(data, changed))
}

fn entry<T>(data: T, data_changed: bool) -> DataEntry<T> {
    DataEntry { data, data_changed }
}

/// The four rates at `fields` (VelocityRate, AccelerationRate, DecelerationRate, JerkRate).
fn rates(r: &PayloadReader, fields: [Field; 4], timestamp: Timestamp) -> DefaultDynamics {
    let [
        velocity_rate,
        acceleration_rate,
        deceleration_rate,
        jerk_rate,
    ] = fields.map(|f| percent(r, f));
    DefaultDynamics {
        timestamp,
        velocity_rate,
        acceleration_rate,
        deceleration_rate,
        jerk_rate,
    }
}

/// The four reference values at `fields` (velocity, acceleration, deceleration, jerk).
fn references(r: &PayloadReader, fields: [Field; 4], timestamp: Timestamp) -> ReferenceDynamics {
    let [velocity, acceleration, deceleration, jerk] = reals(r, fields);
    ReferenceDynamics {
        timestamp,
        velocity,
        acceleration,
        deceleration,
        jerk,
    }
}

/// ReadRobotDefaultDynamics (5104) response.
pub fn default_dynamics(payload: &[u8]) -> DataEntry<DefaultDynamics> {
    use tables::read_robot_default_dynamics::response as f;
    let r = PayloadReader::new(payload);
    let fields = [
        f::VELOCITY_RATE,
        f::ACCELERATION_RATE,
        f::DECELERATION_RATE,
        f::JERK_RATE,
    ];
    let data = rates(&r, fields, timestamp(&r, f::DATE, f::TIME));
    entry(data, r.bit(f::DATA_CHANGED))
}

/// WriteRobotDefaultDynamics (5202) response: the rates now in effect (no timestamp).
pub fn default_dynamics_written(payload: &[u8]) -> DefaultDynamics {
    use tables::write_robot_default_dynamics::response as f;
    let fields = [
        f::VELOCITY_RATE,
        f::ACCELERATION_RATE,
        f::DECELERATION_RATE,
        f::JERK_RATE,
    ];
    rates(&PayloadReader::new(payload), fields, Timestamp::default())
}

/// ReadRobotReferenceDynamics (5105) response.
pub fn reference_dynamics(payload: &[u8]) -> DataEntry<ReferenceDynamics> {
    use tables::read_robot_reference_dynamics::response as f;
    let r = PayloadReader::new(payload);
    let fields = [
        f::VELOCITY_REFERENCE,
        f::ACCELERATION_REFERENCE,
        f::DECELERATION_REFERENCE,
        f::JERK_REFERENCE,
    ];
    let data = references(&r, fields, timestamp(&r, f::DATE, f::TIME));
    entry(data, r.bit(f::DATA_CHANGED))
}

/// WriteRobotReferenceDynamics (5203) response: the values now in effect (no timestamp).
pub fn reference_dynamics_written(payload: &[u8]) -> ReferenceDynamics {
    use tables::write_robot_reference_dynamics::response as f;
    let fields = [
        f::VELOCITY_REFERENCE,
        f::ACCELERATION_REFERENCE,
        f::DECELERATION_REFERENCE,
        f::JERK_REFERENCE,
    ];
    references(&PayloadReader::new(payload), fields, Timestamp::default())
}

/// ReadRobotSWLimits (5106) response: the limits of J1..J6.
pub fn sw_limits(payload: &[u8]) -> DataEntry<SwLimits> {
    use tables::read_robot_sw_limits::response as f;
    let r = PayloadReader::new(payload);
    let data = SwLimits {
        timestamp: timestamp(&r, f::DATE, f::TIME),
        lower_deg: reals(&r, SW_LIMITS_LOWER),
        upper_deg: reals(&r, SW_LIMITS_UPPER),
    };
    entry(data, r.bit(f::DATA_CHANGED))
}

/// The arm configuration of a ReadActualPosition (5100) response.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ArmConfiguration {
    /// Shoulder BACK (else FRONT).
    pub shoulder: bool,
    /// Elbow DOWN (else UP).
    pub elbow: bool,
    /// Wrist FLIP (else NON_FLIP).
    pub wrist: bool,
    /// TurnNumber bytes (sign-magnitude nibbles J1..J6, then E1).
    pub turn_numbers: [u8; 4],
}

impl ArmConfiguration {
    pub fn decode(payload: &[u8]) -> Self {
        use tables::read_actual_position::response as f;
        let r = PayloadReader::new(payload);
        Self {
            shoulder: r.bit(f::SHOULDER),
            elbow: r.bit(f::ELBOW),
            wrist: r.bit(f::WRIST),
            turn_numbers: core::array::from_fn(|i| {
                r.u8(f::ACTUAL_CARTESIAN_POSITION_TURN_NUMBER.element(i))
            }),
        }
    }

    /// The configuration bits as a move request takes them (bit 0 Shoulder, 1 Elbow, 2 Wrist).
    pub fn bits(&self) -> u8 {
        u8::from(self.shoulder) | u8::from(self.elbow) << 1 | u8::from(self.wrist) << 2
    }
}

/// MoveDirectAbsolute (2102) response: progress and remaining distance of the move.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CartesianMoveProgress {
    pub invocation_counter: u8,
    pub origin_id: i16,
    /// Progress in percent; `None` when the robot sends 0xFFFF (no valid value).
    pub progress_percent: Option<f64>,
    /// Remaining distance in mm: -1 no valid value, 0 target reached.
    pub remaining_distance: f32,
}

impl CartesianMoveProgress {
    pub fn decode(payload: &[u8]) -> Self {
        use tables::move_direct_absolute::response as f;
        let r = PayloadReader::new(payload);
        Self {
            invocation_counter: r.u8(f::INVOCATION_COUNTER),
            origin_id: r.i16(f::ORIGIN_ID),
            progress_percent: percent(&r, f::PROGRESS),
            remaining_distance: r.f32(f::REMAINING_DISTANCE),
        }
    }
}

/// GroupJog (2100) response bits.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct JogStatus {
    pub enabled: bool,
    /// An incremental jog reached its distance.
    pub distance_reached: bool,
    /// The arm moves by this jog.
    pub motion_active: bool,
}

impl JogStatus {
    pub fn decode(payload: &[u8]) -> Self {
        use tables::group_jog::response as f;
        let r = PayloadReader::new(payload);
        Self {
            enabled: r.bit(f::ENABLED),
            distance_reached: r.bit(f::DISTANCE_REACHED),
            motion_active: r.bit(f::MOTION_ACTIVE),
        }
    }
}

/// AbortedSequence of a GroupStop (2003) response: 1 if it aborted moves of the primary
/// sequence, 0 if none.
pub fn aborted_sequence(payload: &[u8]) -> i8 {
    PayloadReader::new(payload).i8(tables::group_stop::response::ABORTED_SEQUENCE)
}

/// Fields of every response header, which the report shows in its own columns.
const RESPONSE_HEADER: [&str; 4] = [
    "par_seq",
    "state",
    "alarm_message_severity",
    "alarm_message_code",
];

/// The response `payload` of a `command_type` field by field, named as its table names them,
/// each value as text: REAL and integers as numbers, the UINT percentages (`*_rate`,
/// `override`) in percent or "default", bits as true/false, CHAR arrays as text, arrays and
/// the six-value groups (`position`, ...) as lists. Empty for a command without a response
/// table; the header (state, message code) is left out.
pub fn fields_by_name(command_type: u16, payload: &[u8]) -> Vec<(&'static str, String)> {
    let Some(table) = tables::RESPONSES
        .iter()
        .find(|t| t.command_type == command_type)
    else {
        return Vec::new();
    };
    let r = PayloadReader::new(payload);
    let grouped = |f: &Field| table.groups.iter().any(|(_, g)| g.contains(f));
    let groups = table.groups.iter().map(|(name, group)| {
        let values: Vec<String> = group
            .iter()
            .map(|f| value_text(&r, payload, name, *f))
            .collect();
        (*name, format!("[{}]", values.join(", ")), group[0].offset)
    });
    let fields = table
        .fields
        .iter()
        .filter(|(name, f)| !RESPONSE_HEADER.contains(name) && !grouped(f))
        .map(|(name, f)| (*name, value_text(&r, payload, name, *f), f.offset));
    let mut all: Vec<_> = groups.chain(fields).collect();
    all.sort_by_key(|(_, _, offset)| *offset);
    all.into_iter()
        .map(|(name, text, _)| (name, text))
        .collect()
}

/// One field's value as text (see [`fields_by_name`]).
fn value_text(r: &PayloadReader, payload: &[u8], name: &str, f: Field) -> String {
    let scalar = |f: Field, t: WireType| match t {
        WireType::F32 => format!("{}", r.f32(f)),
        WireType::U8 => r.u8(f).to_string(),
        WireType::I8 => r.i8(f).to_string(),
        WireType::U16 => r.u16(f).to_string(),
        WireType::I16 => r.i16(f).to_string(),
        WireType::U32 => r.u32(f).to_string(),
        WireType::Char => char::from(r.u8(f)).to_string(),
    };
    match f.layout {
        Layout::Scalar(_) if Percent::is_field(name, f) => {
            percent(r, f).map_or_else(|| "default".to_owned(), |p| format!("{p} %"))
        }
        Layout::Scalar(t) => scalar(f, t),
        Layout::Bit(_) => r.bit(f).to_string(),
        Layout::HighNibble | Layout::LowNibble => r.u8(f).to_string(),
        Layout::Array(WireType::Char, _) => format!("{:?}", chars(payload, f)),
        Layout::Array(t, n) => {
            let values: Vec<String> = (0..n).map(|i| scalar(f.element(i), t)).collect();
            format!("[{}]", values.join(", "))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use shared_types::srci::payload::PayloadWriter;

    #[test]
    fn robot_data_reads_strings_and_cycle_time() {
        use tables::read_robot_data::response as f;
        let mut p = vec![0u8; f::LEN];
        let mut w = PayloadWriter::new(&mut p);
        w.set_chars(f::RC_MANUFACTURER, "rc SRCI controller");
        w.set_u16(f::INTERPRETER_CYCLE_TIME, 8);
        w.set_bytes(f::RC_SUPPORTED_FUNCTIONS, &[0b0000_0110]);
        let d = RobotData::decode(&p);
        assert_eq!(d.manufacturer, "rc SRCI controller");
        assert_eq!(d.interpreter_cycle_time_ms, 8);
        assert!(d.supports(tables::enable_robot::TYPE));
        assert!(!d.supports(tables::group_reset::TYPE));
        // A truncated response reads as zeros, not a panic.
        assert_eq!(RobotData::decode(&p[..30]).interpreter_cycle_time_ms, 0);
    }

    #[test]
    fn user_data_responses_read_index_data_and_data_changed() {
        use tables::read_tool_data::response as f;
        let mut p = vec![0u8; f::LEN];
        let mut w = PayloadWriter::new(&mut p);
        w.set_f32(f::TOOL_DATA_Z, 150.0);
        w.set_u8(f::TOOL_DATA_LOAD_NO, 3);
        w.set_u8(f::TOOL_NO, 4);
        w.set_bit(f::DATA_CHANGED, true);
        let (index, tool) = tool_data(&p);
        assert_eq!(index, 4);
        assert_eq!(tool.data.pose[2], 150.0);
        assert_eq!(tool.data.load_no, 3);
        assert!(tool.data_changed);

        use tables::read_robot_default_dynamics::response as d;
        let mut p = vec![0u8; d::LEN];
        let mut w = PayloadWriter::new(&mut p);
        w.set_u16(d::VELOCITY_RATE, 5000);
        w.set_u16(d::JERK_RATE, 0xFFFF);
        let dd = default_dynamics(&p);
        assert_eq!(dd.data.velocity_rate, Some(50.0));
        assert_eq!(dd.data.jerk_rate, None);
        assert!(!dd.data_changed);
    }

    #[test]
    fn arm_configuration_and_jog_bits() {
        let mut p = vec![0u8; tables::read_actual_position::response::LEN];
        p[34] = 0b110;
        p[36..40].copy_from_slice(&[0x10, 0, 0x08, 0]);
        let c = ArmConfiguration::decode(&p);
        assert!(!c.shoulder && c.elbow && c.wrist);
        assert_eq!(c.bits(), 0b110);
        assert_eq!(c.turn_numbers, [0x10, 0, 0x08, 0]);
        let jog = JogStatus::decode(&[0, 0, 0, 0, 0b101]);
        assert!(jog.enabled && !jog.distance_reached && jog.motion_active);
        assert_eq!(aborted_sequence(&[0, 0, 0, 0, 1]), 1);
    }

    #[test]
    fn actual_position_reads_joints() {
        use tables::read_actual_position::response as f;
        let mut p = vec![0u8; f::LEN];
        let mut w = PayloadWriter::new(&mut p);
        w.set_f32(f::ACTUAL_JOINT_POSITION_J2, 90.0);
        w.set_f32(f::ACTUAL_CARTESIAN_POSITION_Z, 500.5);
        let a = ActualPosition::decode(&p);
        assert_eq!(a.joints_deg[1], 90.0);
        assert_eq!(a.cartesian[2], 500.5);
    }
}

#[cfg(test)]
mod field_tests {
    use super::*;
    use shared_types::srci::payload::PayloadWriter;

    /// A ReadToolData response reads as its fields, the tool's six values as one list, the
    /// header left out; a ReadRobotDefaultDynamics response shows its rates in percent.
    #[test]
    fn a_response_reads_field_by_field_as_its_table_names_them() {
        use tables::read_tool_data::response as rtd;
        let mut b = vec![0u8; rtd::LEN];
        let mut w = PayloadWriter::new(&mut b);
        w.set_u8(rtd::STATE, 3);
        for (f, v) in rtd::TOOL_DATA_X_RZ
            .into_iter()
            .zip([0.0, 0.0, 100.5, 0.0, 0.0, 90.0])
        {
            w.set_f32(f, v);
        }
        w.set_u8(rtd::TOOL_NO, 2);
        w.set_bit(rtd::TOOL_DATA_EXTERNAL_TCP, true);
        let fields = fields_by_name(tables::read_tool_data::TYPE, &b);
        let get = |name: &str| {
            fields
                .iter()
                .find(|(n, _)| *n == name)
                .map(|(_, v)| v.as_str())
        };
        assert_eq!(get("tool_data"), Some("[0, 0, 100.5, 0, 0, 90]"));
        assert_eq!(get("tool_data_z"), None, "inside the list");
        assert_eq!(get("tool_no"), Some("2"));
        assert_eq!(get("tool_data_external_tcp"), Some("true"));
        assert_eq!(get("state"), None, "the header has its own columns");

        use tables::read_robot_default_dynamics::response as rdd;
        let mut b = vec![0u8; rdd::LEN];
        let mut w = PayloadWriter::new(&mut b);
        w.set_u16(rdd::VELOCITY_RATE, 5000);
        w.set_u16(rdd::JERK_RATE, 0xFFFF);
        let fields = fields_by_name(tables::read_robot_default_dynamics::TYPE, &b);
        assert!(
            fields.contains(&("velocity_rate", "50 %".to_owned())),
            "{fields:?}"
        );
        assert!(
            fields.contains(&("jerk_rate", "default".to_owned())),
            "{fields:?}"
        );
        assert!(fields_by_name(0xFFFF, &b).is_empty(), "no table, no fields");
    }

    /// Table 6-203 names byte 62 of ReadRobotSWLimits "E1LowerLimit" a second time; the
    /// generated fields call it E1's upper limit (the correction in shared-types/build.rs).
    #[test]
    fn the_sw_limits_response_names_e1s_upper_limit() {
        use tables::read_robot_sw_limits::response as rsl;
        assert_eq!(rsl::E1_UPPER_LIMIT.offset, 62);
        let b = vec![0u8; rsl::LEN];
        let names: Vec<&str> = fields_by_name(tables::read_robot_sw_limits::TYPE, &b)
            .into_iter()
            .map(|(n, _)| n)
            .collect();
        assert!(names.contains(&"e1_upper_limit"), "{names:?}");
        assert!(!names.contains(&"e1_lower_limit_2"), "{names:?}");
    }
}
