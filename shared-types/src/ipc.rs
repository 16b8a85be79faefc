//! The payloads exchanged between the rc processes over iceoryx2, and the one place that
//! knows every topic's name and quality of service.
//!
//! Every payload is `#[repr(C)]`, fixed size and free of pointers, so it can live in shared
//! memory. Enumerations travel as plain integers (`u8`) so that a corrupted or newer value
//! can never be undefined behaviour in the receiver; the `from_wire` helpers decode them.

use iceoryx2::prelude::*;

/// Largest SRCI telegram a fieldbus module carries (bytes, each direction).
pub const TELEGRAM_CAPACITY: usize = 256;
/// Number of joints of the arm.
pub const AXES: usize = 6;
/// Number of future ticks a planner setpoint window covers: the servo follows the plan through
/// a planner wake-up that comes up to this many ticks late. Scheduling hiccups of a loaded
/// 2-core machine without real-time priorities went past 16 ms in the system tests; a dead
/// planner is still noticed within 32 ms, and stops are planned anew every tick regardless.
pub const SETPOINT_WINDOW: usize = 32;
/// Number of recent per-command events the planner keeps in its status.
pub const JOB_EVENTS: usize = 32;

/// What a [`PlcTelegram`] sample reports.
#[repr(u8)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LinkEvent {
    /// `bytes[..len]` holds a PLC→robot telegram.
    Telegram = 0,
    /// A new fieldbus peer connected (a new TCP client, or a new PROFINET AR).
    Connected = 1,
    /// The fieldbus peer went away; no telegrams will follow until `Connected`.
    Disconnected = 2,
}

impl LinkEvent {
    /// Decodes the wire value; unknown values are treated as a lost link.
    pub fn from_wire(v: u8) -> Self {
        match v {
            0 => Self::Telegram,
            1 => Self::Connected,
            _ => Self::Disconnected,
        }
    }
}

/// fieldbus → interpreter: one raw PLC→robot telegram (topic `srci/p2r`).
#[repr(C)]
#[derive(Debug, Clone, Copy, ZeroCopySend)]
#[type_name("rc::PlcTelegram")]
pub struct PlcTelegram {
    /// Increments with every sample; the answer echoes it.
    pub counter: u64,
    /// CLOCK_MONOTONIC time the last byte arrived, in ns.
    pub received_ns: u64,
    /// Connection number; increments with every new peer.
    pub connection: u32,
    /// [`LinkEvent`] as `u8`.
    pub event: u8,
    pub reserved: u8,
    /// Number of valid bytes in `bytes`.
    pub len: u16,
    pub bytes: [u8; TELEGRAM_CAPACITY],
}

impl PlcTelegram {
    /// An empty sample of the given kind.
    pub fn event(counter: u64, received_ns: u64, connection: u32, event: LinkEvent) -> Self {
        Self {
            counter,
            received_ns,
            connection,
            event: event as u8,
            reserved: 0,
            len: 0,
            bytes: [0; TELEGRAM_CAPACITY],
        }
    }

    /// The telegram bytes (empty for link events).
    pub fn telegram(&self) -> &[u8] {
        &self.bytes[..usize::from(self.len).min(TELEGRAM_CAPACITY)]
    }
}

/// interpreter → fieldbus: the robot→PLC answer to one [`PlcTelegram`] (topic `srci/r2p`).
#[repr(C)]
#[derive(Debug, Clone, Copy, ZeroCopySend)]
#[type_name("rc::RobotTelegram")]
pub struct RobotTelegram {
    /// The `counter` of the PLC telegram this answers.
    pub counter: u64,
    pub connection: u32,
    /// [`RobotTelegram::HANDOVER`], or 0 for an answer.
    pub flags: u16,
    pub len: u16,
    pub bytes: [u8; TELEGRAM_CAPACITY],
}

impl RobotTelegram {
    /// Flag of a sample that answers nothing: the interpreter stops and hands its SRCI
    /// session to the next interpreter process; the fieldbus holds the PLC over until that
    /// one answers. `counter` is the last telegram answered.
    pub const HANDOVER: u16 = 1;

    /// An answer to PLC telegram `counter` (no bytes yet).
    pub fn answer(counter: u64, connection: u32) -> Self {
        Self {
            counter,
            connection,
            flags: 0,
            len: 0,
            bytes: [0; TELEGRAM_CAPACITY],
        }
    }

    /// Whether this is the handover notice, not an answer.
    pub fn is_handover(&self) -> bool {
        self.flags & Self::HANDOVER != 0
    }
}

/// Kind of a [`MotionCommand`].
#[repr(u8)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MotionCommandKind {
    /// Joint-space point-to-point move to `joints_rad`.
    MoveAxes = 1,
    /// GroupStop: stop as fast as the limits allow on the path, discard the queue.
    Stop = 2,
    /// ChangeSpeedOverride to `override_fraction`.
    Override = 3,
    /// GroupReset: clear the planner's error state.
    Reset = 4,
    /// The PLC link was lost or reset: stop on the path and discard everything, no error.
    Halt = 5,
    /// GroupInterrupt: stop on the path and hold the primary sequence, keeping its moves.
    Interrupt = 6,
    /// GroupContinue: resume the interrupted primary sequence on its path.
    Continue = 7,
    /// Joint-interpolated move to the Cartesian TCP pose `pose` (MoveDirectAbsolute): the
    /// planner chooses the joint target by inverse kinematics.
    MoveDirect = 8,
    /// Cartesian straight-line move of the TCP to `pose` (MoveLinearAbsolute), orientation
    /// interpolated as `ori_mode` says.
    MoveLinear = 9,
    /// Circular move of the TCP to `pose` (MoveCircularAbsolute/Relative), the arc given by
    /// `aux_pose` and the circle fields, orientation interpolated as `ori_mode` says.
    MoveCircular = 10,
    /// WaitTime: the sequence stands still for `duration_s` before its next move.
    Wait = 11,
}

impl MotionCommandKind {
    /// Decodes the wire value.
    pub fn from_wire(v: u8) -> Option<Self> {
        Some(match v {
            1 => Self::MoveAxes,
            2 => Self::Stop,
            3 => Self::Override,
            4 => Self::Reset,
            5 => Self::Halt,
            6 => Self::Interrupt,
            7 => Self::Continue,
            8 => Self::MoveDirect,
            9 => Self::MoveLinear,
            10 => Self::MoveCircular,
            11 => Self::Wait,
            _ => return None,
        })
    }
}

/// interpreter → planner: one decoded, validated motion or group command (topic
/// `motion/command`). The planner acknowledges `seq` in [`MotionStatus::acked_seq`]; the
/// interpreter re-sends until then, so a command is never lost.
#[repr(C)]
#[derive(Debug, Clone, Copy, ZeroCopySend, serde::Serialize, serde::Deserialize)]
#[type_name("rc::MotionCommand")]
pub struct MotionCommand {
    /// Strictly increasing per interpreter instance, starting at 1.
    pub seq: u64,
    /// The interpreter instance that issued it (a restarted interpreter starts a new one).
    pub issuer: u64,
    /// Job number the planner reports state changes under.
    pub job: u32,
    /// [`MotionCommandKind`] as `u8`.
    pub kind: u8,
    /// `true`: abort the running move and discard the queue first (ExecutionMode 1).
    pub aborting: bool,
    pub reserved: u16,
    /// Target joints in rad (MoveAxes).
    pub joints_rad: [f64; AXES],
    /// Fractions of the robot's joint limits (and, for Cartesian moves, of its TCP limits),
    /// in (0, 1].
    pub velocity_scale: f64,
    pub acceleration_scale: f64,
    pub deceleration_scale: f64,
    pub jerk_scale: f64,
    /// The PLC's reference dynamics of the TCP (velocity, acceleration, deceleration, jerk)
    /// as shares of the robot's TCP limits, in (0, 1]: what 100 % of the rates above means
    /// for the TCP of a Cartesian move.
    pub tcp_reference: [f64; 4],
    /// Requested duration in s; 0 = as fast as the scaled limits allow.
    pub duration_s: f64,
    /// Override for `Override`, in [0, 1].
    pub override_fraction: f64,
    /// TCP target of `MoveDirect` and `MoveLinear` in the robot base frame: x, y, z in m,
    /// Rx, Ry, Rz in rad (R = Rz·Ry·Rx).
    pub pose: [f64; 6],
    /// The TCP in the flange frame (the active tool), same units; zero = the flange itself.
    pub tool: [f64; 6],
    /// The SW limits the PLC set (rad), inside which every point of the move must stay; the
    /// planner applies the mechanical limits as well. Infinite = only the mechanical ones.
    pub sw_lower_rad: [f64; AXES],
    pub sw_upper_rad: [f64; AXES],
    /// SRCI configuration bits and TurnNumber bytes sent with the pose.
    pub arm_config: u8,
    pub turn_numbers: [u8; 4],
    /// ConfigMode of shoulder, elbow and wrist, and TurnMode (wire values).
    pub config_modes: [u8; 3],
    pub turn_mode: u8,
    /// OriMode of `MoveLinear` (wire value, 0 = standard: the shortest rotation).
    pub ori_mode: u8,
    /// [`MotionSequence`] as `u8`: the sequence a move belongs to, or the sequences a
    /// Stop, Halt, Interrupt or Continue acts on.
    pub sequence: u8,
    /// StepMode: when this primary move ends, the primary sequence is held (as by
    /// GroupInterrupt) until GroupContinue.
    pub hold_after: bool,
    /// BlendingMode into the next move of the sequence (wire value: 0 exact stop, 2 defined
    /// velocity, 3 corner distance, 4 max corner deviation, 10 and 12 the radius variants,
    /// 11 ramp overlap).
    pub blending_mode: u8,
    /// [`TargetReference`] as `u8`: how `joints_rad` or `pose` give the target.
    pub target_reference: u8,
    /// CircMode of `MoveCircular` (wire value: 0 border, 1 center, 2 center with angle,
    /// 3 radius).
    pub circle_mode: u8,
    /// CircPlane of `MoveCircular` (wire value: 0 XZ, 1 YZ, 2 XY of the frame in `aux_pose`'s
    /// orientation), used by the center modes.
    pub circle_plane: u8,
    /// PathChoice of `MoveCircular` (wire value: 0 clockwise, 1 counter-clockwise; radius
    /// mode: 0 the shorter, 1 the longer arc).
    pub path_choice: u8,
    pub reserved2: [u8; 7],
    /// BlendingParameter[0..1] in SI units: for DEFINED_VELOCITY and RAMP_OVERLAP a fraction
    /// (the PLC's percent / 100), for the distance modes metres.
    pub blending_parameter: [f64; 2],
    /// `MoveCircular`: the AuxPoint in the robot base frame, units as `pose` (border mode: a
    /// point on the arc; the center modes: the centre; its orientation gives the CircPlane
    /// axes; radius mode: the end point displaced along the normal of the arc's plane).
    pub aux_pose: [f64; 6],
    /// `MoveCircular` CENTER_WITH_ANGLE: the angle to travel (rad).
    pub circle_angle_rad: f64,
    /// `MoveCircular` RADIUS: the radius of the arc (m).
    pub circle_radius_m: f64,
    /// `MoveCircular` CENTER: how far (m) the end may lie off the circle the start gives
    /// (the PLC's Tolerance); 0 = the planner's default.
    pub circle_tolerance_m: f64,
}

/// How a move's target is given (`MotionCommand::target_reference`). A relative target is
/// added to where the move starts: the end of the move before it in the sequence.
#[repr(u8)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TargetReference {
    /// `joints_rad` or `pose` is the target itself.
    Absolute = 0,
    /// `joints_rad` is added to the start joints (MoveAxesRelative); for Cartesian moves
    /// `pose` is a displacement in base axes: x, y, z added to the TCP position, the rotation
    /// vector Rx, Ry, Rz applied to its orientation about the TCP (a displacement in a frame,
    /// rotated into base axes).
    RelativeInBase = 1,
    /// `pose` is a displacement in the tool's own axes: `T_target = T_start · pose`.
    RelativeInTool = 2,
}

impl TargetReference {
    /// Decodes the wire value.
    pub fn from_wire(v: u8) -> Option<Self> {
        Some(match v {
            0 => Self::Absolute,
            1 => Self::RelativeInBase,
            2 => Self::RelativeInTool,
            _ => return None,
        })
    }
}

/// The sequence a [`MotionCommand`] belongs to or acts on.
#[repr(u8)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MotionSequence {
    /// Both sequences (GroupStop, a lost PLC); for a move: the primary sequence.
    All = 0,
    /// The primary sequence: the program's moves (ExecutionMode 0/1).
    Primary = 1,
    /// The secondary sequence: jogging and moves with ExecutionMode 7/8, which run while
    /// the primary sequence is held.
    Secondary = 2,
}

impl MotionSequence {
    /// Decodes the wire value; unknown values act on both sequences.
    pub fn from_wire(v: u8) -> Self {
        match v {
            1 => Self::Primary,
            2 => Self::Secondary,
            _ => Self::All,
        }
    }
}

impl MotionCommand {
    /// A command of `kind` with neutral parameters.
    pub fn new(kind: MotionCommandKind) -> Self {
        Self {
            seq: 0,
            issuer: 0,
            job: 0,
            kind: kind as u8,
            aborting: false,
            reserved: 0,
            joints_rad: [0.0; AXES],
            velocity_scale: 1.0,
            acceleration_scale: 1.0,
            deceleration_scale: 1.0,
            jerk_scale: 1.0,
            tcp_reference: [1.0; 4],
            duration_s: 0.0,
            override_fraction: 1.0,
            pose: [0.0; 6],
            tool: [0.0; 6],
            sw_lower_rad: [f64::NEG_INFINITY; AXES],
            sw_upper_rad: [f64::INFINITY; AXES],
            arm_config: 0,
            turn_numbers: [0; 4],
            // SAME configuration, FREE turns: the SRCI defaults.
            config_modes: [1; 3],
            turn_mode: 2,
            ori_mode: 0,
            sequence: MotionSequence::All as u8,
            hold_after: false,
            blending_mode: 0,
            target_reference: TargetReference::Absolute as u8,
            circle_mode: 0,
            circle_plane: 0,
            path_choice: 0,
            reserved2: [0; 7],
            blending_parameter: [0.0; 2],
            aux_pose: [0.0; 6],
            circle_angle_rad: 0.0,
            circle_radius_m: 0.0,
            circle_tolerance_m: 0.0,
        }
    }
}

/// A state change of one job, as reported by the planner.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, ZeroCopySend)]
#[type_name("rc::JobEvent")]
pub struct JobEvent {
    /// Event number, strictly increasing per planner instance, starting at 1.
    pub number: u64,
    pub job: u32,
    /// SRCI CmdMessageState (2 BUFFERED, 4 ACTIVE, 10 DONE, 14 ABORTED, 15 ERROR).
    pub state: u8,
    /// [`RefusalReason`] as `u8`: why an ERROR, where its code alone does not tell.
    pub reason: u8,
    /// SRCI message code for ABORTED and ERROR (e.g. 0x6C05), else 0.
    pub code: u16,
}

/// Why the planner refused a move, where its SRCI code (0x6C03, target unreachable, for all of
/// them) does not tell ([`JobEvent::reason`]).
#[repr(u8)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RefusalReason {
    /// The code says all there is.
    None = 0,
    /// The target pose is out of the arm's reach in every configuration.
    OutOfReach = 1,
    /// The target pose is out of reach in the configuration and turns asked for.
    NotInConfiguration = 2,
    /// A line or arc leaves the reach of the configuration it starts in.
    PathOutOfReach = 3,
    /// A line or arc comes within the singularity margins.
    Singular = 4,
    /// A line or arc's target asks for another configuration than the one it starts in.
    ConfigurationChange = 5,
    /// A line or arc ends on other turn numbers than the ones sent with its target.
    TurnMismatch = 6,
}

impl RefusalReason {
    /// Decodes the wire value; unknown values tell nothing.
    pub fn from_wire(v: u8) -> Self {
        match v {
            1 => Self::OutOfReach,
            2 => Self::NotInConfiguration,
            3 => Self::PathOutOfReach,
            4 => Self::Singular,
            5 => Self::ConfigurationChange,
            6 => Self::TurnMismatch,
            _ => Self::None,
        }
    }

    /// The message text of a refusal for this reason (SRCI texts hold 150 bytes).
    pub fn text(self) -> Option<&'static str> {
        Some(match self {
            Self::None => return None,
            Self::OutOfReach => "target unreachable: out of the arm's reach in every configuration",
            Self::NotInConfiguration => {
                "target unreachable in the configuration and turns asked for (ConfigMode, TurnMode)"
            }
            Self::PathOutOfReach => {
                "target unreachable: the path leaves the reach of the configuration it starts in"
            }
            Self::Singular => "target unreachable: the path comes within the singularity margins",
            Self::ConfigurationChange => {
                "target unreachable: the target needs another arm configuration than the path's start"
            }
            Self::TurnMismatch => {
                "target unreachable: the path ends on other turn numbers than the ones sent"
            }
        })
    }
}

/// planner → interpreter: the planner's state, published every tick (topic `motion/status`).
#[repr(C)]
#[derive(Debug, Clone, Copy, ZeroCopySend)]
#[type_name("rc::MotionStatus")]
pub struct MotionStatus {
    /// Random per planner process start; a change means the planner restarted.
    pub instance: u64,
    /// Servo tick the status belongs to.
    pub tick: u64,
    /// Highest [`MotionCommand::seq`] taken over from `acked_issuer`.
    pub acked_seq: u64,
    pub acked_issuer: u64,
    /// Number of the newest event in `events` (0 = none yet).
    pub event_head: u64,
    /// Ring of the last [`JOB_EVENTS`] events; event `n` is at `n % JOB_EVENTS`.
    pub events: [JobEvent; JOB_EVENTS],
    /// The job being executed (0 = none) and its progress.
    pub active_job: u32,
    pub queued_jobs: u32,
    pub active_progress: f64,
    /// TCP path length (m) the active move still has to go: along a line or arc, or the
    /// TCP's curve of a joint move (with the tool of its command); NaN when none is active.
    pub active_remaining_m: f64,
    /// Commanded joint positions and velocities (rad, rad/s).
    pub joints_rad: [f64; AXES],
    pub joint_velocities: [f64; AXES],
    /// Flange pose in the world frame: x, y, z in m, then Rx, Ry, Rz in rad (R = Rz·Ry·Rx).
    pub flange_pose: [f64; 6],
    /// SRCI configuration bits of `joints_rad` (bit 0 Shoulder BACK, 1 Elbow DOWN, 2 Wrist
    /// FLIP) and its TurnNumber bytes (sign-magnitude nibbles, [J2|J1, J4|J3, J6|J5, E1]).
    pub arm_config: u8,
    pub turn_numbers: [u8; 4],
    /// Current override in [0, 1] (target of the ramp).
    pub override_fraction: f64,
    pub moving: bool,
    pub accelerating: bool,
    pub decelerating: bool,
    pub constant_velocity: bool,
    /// The primary sequence is interrupted (GroupInterrupt) until GroupContinue.
    pub sequence_paused: bool,
    /// Two moves are being blended (StatusRobotArm IsBlending).
    pub blending: bool,
    /// Pending planner error (SRCI code), 0 = none. Cleared by `Reset`.
    pub error_code: u16,
    pub reserved: u16,
}

impl MotionStatus {
    /// The status of planner `instance` before anything happened: no events, no jobs, at
    /// rest at zero, the given override.
    pub fn initial(instance: u64, override_fraction: f64) -> Self {
        Self {
            instance,
            tick: 0,
            acked_seq: 0,
            acked_issuer: 0,
            event_head: 0,
            events: [JobEvent::default(); JOB_EVENTS],
            active_job: 0,
            queued_jobs: 0,
            active_progress: 0.0,
            active_remaining_m: f64::NAN,
            joints_rad: [0.0; AXES],
            joint_velocities: [0.0; AXES],
            flange_pose: [0.0; 6],
            arm_config: 0,
            turn_numbers: [0; 4],
            override_fraction,
            moving: false,
            accelerating: false,
            decelerating: false,
            constant_velocity: false,
            sequence_paused: false,
            blending: false,
            error_code: 0,
            reserved: 0,
        }
    }
}

/// One point of a joint trajectory.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq, ZeroCopySend)]
#[type_name("rc::JointPoint")]
pub struct JointPoint {
    pub q: [f64; AXES],
    pub qd: [f64; AXES],
    pub qdd: [f64; AXES],
}

/// planner → servo: setpoints for the next ticks (topic `servo/setpoint`). Sending a window
/// lets the servo ride out a planner wake-up that comes a tick or two late.
#[repr(C)]
#[derive(Debug, Clone, Copy, ZeroCopySend)]
#[type_name("rc::ServoSetpoint")]
pub struct ServoSetpoint {
    pub planner_instance: u64,
    /// Tick of `points[0]`; `points[i]` is for tick `first_tick + i`.
    pub first_tick: u64,
    pub points: [JointPoint; SETPOINT_WINDOW],
}

/// State of the (simulated) drives.
#[repr(u8)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DriveState {
    /// No power; brakes closed.
    Off = 0,
    PoweringOn = 1,
    /// Powered, not yet enabled; brakes closed.
    Powered = 2,
    Enabling = 3,
    /// Enabled and following fresh setpoints.
    Following = 4,
    /// Enabled, setpoints stale: bringing the arm to a controlled stop.
    Stopping = 5,
    /// Enabled and standing still, waiting for setpoints that continue from here.
    Holding = 6,
    /// A fault stopped the arm; it holds until the fault is reset.
    Fault = 7,
}

impl DriveState {
    /// Decodes the wire value.
    pub fn from_wire(v: u8) -> Self {
        match v {
            0 => Self::Off,
            1 => Self::PoweringOn,
            2 => Self::Powered,
            3 => Self::Enabling,
            4 => Self::Following,
            5 => Self::Stopping,
            6 => Self::Holding,
            _ => Self::Fault,
        }
    }

    /// Drives are enabled and hold or move the arm under control.
    pub fn is_enabled(self) -> bool {
        matches!(self, Self::Following | Self::Stopping | Self::Holding)
    }
}

/// servo → planner, interpreter: actual drive state every tick (topic `servo/feedback`).
#[repr(C)]
#[derive(Debug, Clone, Copy, ZeroCopySend)]
#[type_name("rc::ServoFeedback")]
pub struct ServoFeedback {
    pub instance: u64,
    pub tick: u64,
    /// CLOCK_MONOTONIC time of the tick, ns.
    pub time_ns: u64,
    pub period_ns: u64,
    pub q: [f64; AXES],
    pub qd: [f64; AXES],
    /// [`DriveState`] as `u8`.
    pub state: u8,
    pub reserved: u8,
    /// Drive fault code (SRCI message code), 0 = none.
    pub fault_code: u16,
    pub reserved2: u32,
    /// The last [`ServoControl::seq`] applied.
    pub control_seq: u64,
    /// Ticks with no setpoint for them, and ticks that started late.
    pub setpoint_misses: u64,
    pub overruns: u64,
}

impl ServoFeedback {
    /// Drives of servo `instance` standing still at `q` in `state`, no fault, tick 0.
    pub fn at_rest(instance: u64, q: [f64; AXES], state: DriveState, period_ns: u64) -> Self {
        Self {
            instance,
            tick: 0,
            time_ns: 0,
            period_ns,
            q,
            qd: [0.0; AXES],
            state: state as u8,
            reserved: 0,
            fault_code: 0,
            reserved2: 0,
            control_seq: 0,
            setpoint_misses: 0,
            overruns: 0,
        }
    }
}

/// interpreter → servo: requested power state (topic `servo/control`); latest value wins.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, ZeroCopySend, serde::Serialize, serde::Deserialize)]
#[type_name("rc::ServoControl")]
pub struct ServoControl {
    pub seq: u64,
    pub power: bool,
    pub enable: bool,
    pub reserved: [u8; 6],
    /// Incremented to acknowledge (clear) a drive fault.
    pub fault_reset: u64,
}

/// The topics of the controller, with their payload and QoS.
pub mod topics {
    /// PLC→robot telegrams.
    pub const P2R: &str = "srci/p2r";
    /// Robot→PLC telegrams.
    pub const R2P: &str = "srci/r2p";
    /// Motion commands.
    pub const MOTION_COMMAND: &str = "motion/command";
    /// Planner status.
    pub const MOTION_STATUS: &str = "motion/status";
    /// Servo setpoints.
    pub const SERVO_SETPOINT: &str = "servo/setpoint";
    /// Servo feedback.
    pub const SERVO_FEEDBACK: &str = "servo/feedback";
    /// Power requests.
    pub const SERVO_CONTROL: &str = "servo/control";

    /// Every publish-subscribe topic, for creation and clean-up.
    pub const ALL: [&str; 7] = [
        P2R,
        R2P,
        MOTION_COMMAND,
        MOTION_STATUS,
        SERVO_SETPOINT,
        SERVO_FEEDBACK,
        SERVO_CONTROL,
    ];
    /// Topics whose publisher wakes the subscriber through a companion event service of the
    /// same name.
    pub const WITH_WAKEUP: [&str; 3] = [P2R, R2P, SERVO_FEEDBACK];
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every reason survives the wire, and its text fits an SRCI message (150 bytes).
    #[test]
    fn refusal_reasons_round_trip_and_their_texts_fit_a_message() {
        for v in 0..=7u8 {
            let reason = RefusalReason::from_wire(v);
            if v <= 6 {
                assert_eq!(reason as u8, v);
            } else {
                assert_eq!(reason, RefusalReason::None);
            }
            assert_eq!(reason.text().is_none(), reason == RefusalReason::None);
            assert!(reason.text().is_none_or(|t| t.len() <= 150));
        }
    }
}
