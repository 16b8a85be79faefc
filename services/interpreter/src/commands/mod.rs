//! Command semantics: dispatch of complete command messages, the commands that live beyond
//! one telegram (Enable-type commands and motion jobs), and the responses they send.

mod blending;
mod circular;
mod jog;
mod joint_line;
mod motion;
mod offset;
mod relative;
mod robot;
mod sequence;
mod server_log;
mod session;
#[cfg(test)]
mod test_support;
mod user_data;
mod wait;

use shared_types::srci::message::{
    CommandHeader, ResponseHeader, code, execution_mode, severity, state,
};
use shared_types::srci::tables as t;

use shared_types::ipc::MotionCommandKind;

use crate::acr::MESSAGE_CAPACITY;
use crate::messages::MessageType;
use crate::server::{Effects, Now, Server};

/// Command types this interpreter implements; RCSupportedFunctions announces exactly these.
/// ReadActualPositionCyclic has no command type and is not offered yet.
pub const IMPLEMENTED: [u16; 39] = [
    t::read_robot_data::TYPE,
    t::exchange_configuration::TYPE,
    t::read_messages::TYPE,
    t::enable_robot::TYPE,
    t::group_reset::TYPE,
    t::set_sequence::TYPE,
    t::move_axes_absolute::TYPE,
    t::move_direct_absolute::TYPE,
    t::move_linear_absolute::TYPE,
    t::move_axes_relative::TYPE,
    t::move_direct_relative::TYPE,
    t::move_linear_relative::TYPE,
    t::move_linear_absolute_j::TYPE,
    t::move_circular_absolute::TYPE,
    t::move_circular_relative::TYPE,
    t::move_direct_offset::TYPE,
    t::move_linear_offset::TYPE,
    t::wait_time::TYPE,
    t::return_to_primary::TYPE,
    t::read_actual_position::TYPE,
    t::change_speed_override::TYPE,
    t::group_stop::TYPE,
    t::group_interrupt::TYPE,
    t::group_continue::TYPE,
    t::group_jog::TYPE,
    t::read_tool_data::TYPE,
    t::write_tool_data::TYPE,
    t::read_frame_data::TYPE,
    t::write_frame_data::TYPE,
    t::read_load_data::TYPE,
    t::write_load_data::TYPE,
    t::read_robot_default_dynamics::TYPE,
    t::write_robot_default_dynamics::TYPE,
    t::read_robot_reference_dynamics::TYPE,
    t::write_robot_reference_dynamics::TYPE,
    t::read_robot_sw_limits::TYPE,
    t::write_robot_sw_limits::TYPE,
    t::create_server_log::TYPE,
    t::read_server_log::TYPE,
];

/// A command that stays in the register after its first response.
#[derive(Debug, Clone, Copy, serde::Serialize, serde::Deserialize)]
pub struct LiveCommand {
    pub cmd_id: u16,
    pub command_type: u16,
    /// ParSeq of the parameter set the next response belongs to.
    pub par_seq: u8,
    pub kind: LiveKind,
}

/// What a live command is waiting for.
#[derive(Debug, Clone, Copy, serde::Serialize, serde::Deserialize)]
pub enum LiveKind {
    /// ReadMessages: `shown` is the MsgID in the last response, with the counts sent then;
    /// `enable_seen` if the PLC sets the (library) Enable flag, so clearing it disables.
    Messages {
        level: i8,
        shown: u8,
        counts: (u8, u8),
        enable_seen: bool,
    },
    /// ExchangeConfiguration, enabled; `sent` is what its last response reported.
    Configuration { sent: session::ConfigurationReport },
    /// ReadServerLog, enabled.
    ServerLog,
    /// EnableRobot: the requested drive state, the Enabled bit last reported, the request
    /// time, and whether the drives were enabled since the request.
    Enable {
        want: bool,
        reported: Option<bool>,
        since_ms: u64,
        reached: bool,
    },
    /// GroupJog: the job of the jog motion (0 = none), whether it is incremental, and for
    /// frame and tool jogging the step it takes.
    Jog {
        job: u32,
        end: jog::JogEnd,
        cartesian: Option<jog::CartesianJog>,
    },
    /// A read executed continuously (ExecutionMode CONTINUOUS): answered ACTIVE again every
    /// [`CONTINUOUS_INTERVAL_MS`] until ExecutionMode STOP_PARALLEL_CONTINUOUS_TRIGGER.
    Continuous { sent_ms: u64 },
    /// GroupReset waiting for the orchestrator to restart failed services (request
    /// `request_id`, last sent at `sent_ms`, first at `since_ms`); the planner's reset
    /// follows.
    ServicesReset {
        request_id: u64,
        sent_ms: u64,
        since_ms: u64,
    },
    /// A command executed by the planner as `job`; `progress` last sent (percent × 100);
    /// `aborts_moves` for a GroupStop issued while moves were in flight (AbortedSequence).
    Job {
        job: u32,
        progress: u16,
        sent_ms: u64,
        aborts_moves: bool,
        /// Where a MoveLinearAbsolute goes, for its RemainingDistance.
        line: Option<LineTarget>,
        /// A move of the secondary sequence (ExecutionMode 7/8, ReturnToPrimary).
        secondary: bool,
        /// WaitTime: how long it waits (ms), for its ElapsedTime.
        #[serde(default)]
        wait_ms: u32,
    },
}

/// The end of a straight-line move: the TCP target position in the world (m) and the tool
/// (TCP in the flange frame, m and rad), so that the distance left can be measured from the
/// flange pose the planner reports.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct LineTarget {
    pub position: [f64; 3],
    pub tool: [f64; 6],
}

impl LineTarget {
    /// Distance in mm from the TCP of `flange` (world, m and rad) to the target.
    pub fn remaining_mm(&self, flange: [f64; 6]) -> f64 {
        let tcp = shared_types::pose::isometry(flange) * shared_types::pose::isometry(self.tool);
        let t = tcp.translation.vector;
        let d = [
            self.position[0] - t.x,
            self.position[1] - t.y,
            self.position[2] - t.z,
        ];
        (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt() * 1000.0
    }
}

/// How often a continuous read is answered again (ms).
pub const CONTINUOUS_INTERVAL_MS: u64 = 100;

/// The reads that run in the parallel buffer, once (PARALLEL) or continuously.
const CONTINUOUS_READS: [u16; 7] = [
    t::read_actual_position::TYPE,
    t::read_tool_data::TYPE,
    t::read_frame_data::TYPE,
    t::read_load_data::TYPE,
    t::read_robot_default_dynamics::TYPE,
    t::read_robot_reference_dynamics::TYPE,
    t::read_robot_sw_limits::TYPE,
];

/// Text for the message log of a command that ended with `code`.
pub fn describe(code: u16) -> &'static str {
    match code {
        code::NOT_IMPLEMENTED => "command not implemented by this robot controller",
        code::COMMAND_TYPE_OUT_OF_RANGE => "command type not defined by the specification",
        code::INVALID_EXECUTION_MODE => "execution mode not valid for this command",
        code::ROBOT_DISABLED => "robot not enabled: EnableRobot first",
        code::CONTINUE_NOT_ENABLED => "GroupContinue not possible: robot not enabled",
        code::DISABLED_DUE_TO_ERROR => "robot in error: GroupReset first",
        // A line or an arc is checked all along: a point of the path may be the one.
        code::SW_LIMIT_LOWER => "target or path below the lower joint limit",
        code::SW_LIMIT_UPPER => "target or path above the upper joint limit",
        code::INVALID_ACCELERATION_RATE => "AccelerationRate out of range 0..100 %",
        code::INVALID_VELOCITY_RATE => "VelocityRate out of range 0..100 %",
        code::INVALID_JERK_RATE => "JerkRate out of range 0..100 %",
        code::INVALID_DECELERATION_RATE => "DecelerationRate out of range 0..100 %",
        code::INVALID_ORI_MODE => "OriMode is not a defined value (1..4)",
        code::ORI_MODE_NOT_SUPPORTED => "OriMode not supported for this move",
        code::INVALID_BLENDING_MODE => "BlendingMode is not a defined value",
        code::INVALID_BLENDING_PARAMETER => {
            "BlendingParameter negative, not a number, or a percentage above 100"
        }
        code::INVALID_CIRC_PLANE => "CircPlane is not a defined value for this CircMode",
        code::INVALID_CIRC_MODE => "CircMode outside of the allowed range 0..3",
        code::TOLERANCE_ONLY_CENTER => {
            "Tolerance must be a number >= 0 and is only used with CircMode 1 (CENTER)"
        }
        code::ANGLE_ONLY_CENTER_WITH_ANGLE => {
            "Angle must be a number and is only used with CircMode 2 (CENTER_WITH_ANGLE)"
        }
        code::INVALID_JOINT_POSITION => "joint position is not a finite number",
        code::INVALID_POSITION => {
            "Cartesian position not a finite number, or no arc through the points (on one \
             line, off the circle's plane, radius or angle out of range)"
        }
        code::TARGET_UNREACHABLE => "target unreachable in the requested configuration",
        code::INVALID_TURN_MODE => "TurnMode is not a defined value",
        code::INVALID_CONFIG_MODE_SHOULDER
        | code::INVALID_CONFIG_MODE_ELBOW
        | code::INVALID_CONFIG_MODE_WRIST => "ConfigMode is not a defined value",
        code::INVALID_OVERRIDE => "Override out of range 0..100 %",
        code::JOG_DURING_MOTION => "jog not possible during an active movement",
        code::JOG_BOTH_DIRECTIONS => "positive and negative jog direction at the same time",
        code::INVALID_INCREMENTAL_ROTATION => "IncrementalRotation must be a number >= 0",
        code::INVALID_INCREMENTAL_TRANSLATION => "IncrementalTranslation must be a number >= 0",
        code::INVALID_TIME => "move cannot be done in the requested time",
        code::TOOL_NOT_EXISTING => "ToolNo does not exist",
        code::FRAME_NOT_EXISTING => "FrameNo does not exist",
        code::INVALID_STEP_MODE => "StepMode is not a defined value",
        code::NOT_IN_PRIMARY_POSITION => {
            "GroupContinue not possible: the arm is not where the primary sequence was left (ReturnToPrimary)"
        }
        code::REQUIRES_INTERRUPT_OR_IDLE => {
            "only while the primary sequence is interrupted or idle"
        }
        code::SECONDARY_BLOCKED => "secondary sequence blocked by GroupJog or ReturnToPrimary",
        code::SECONDARY_NOT_ACTIVE => "secondary sequence not active: SetSequence 2 first",
        code::SECONDARY_NOT_EMPTY => "secondary sequence not empty",
        code::INVALID_TARGET_SEQUENCE => "TargetSequence must be 1 (primary) or 2 (secondary)",
        code::INVALID_RETURN_MODE => {
            "ReturnMode 1 (end position of the interrupted move) is not supported"
        }
        code::MOTION_ERROR => "motion error: the move was stopped",
        code::INVALID_MODE => "MessageLevel, LogLevel or ReferenceType is not a defined value",
        code::INVALID_SYNC_REACTION => "SyncReaction is not a defined value (0..3)",
        code::NOT_SYNCHRONIZED => {
            "user data not synchronized and SyncReaction denies enabling the robot"
        }
        code::INTERNAL_ERROR => "internal error (Active Command Register full or message too long)",
        _ => crate::user_data::codes::describe(code).unwrap_or("command ended with an error"),
    }
}

/// Severity a response in state `st` carries with `code`: a command that ends in ERROR is
/// an error whatever the class of its code (0x6C03 target unreachable ends a move, the PLC
/// must see an ErrorID); otherwise infos (0x6xxx), warnings (0x7xxx), errors.
fn severity_of(st: u8, code: u16) -> i8 {
    match code >> 12 {
        0 => severity::NONE,
        _ if st == state::ERROR => severity::ERROR,
        6 => severity::INFO,
        7 => severity::WARNING,
        _ => severity::ERROR,
    }
}

impl Server {
    /// A command message is complete in the register.
    pub(crate) fn on_command_message(
        &mut self,
        cmd_id: u16,
        msg: &[u8],
        new_command: bool,
        now: Now,
        fx: &mut Effects,
    ) {
        let h = CommandHeader::decode(msg);
        if !new_command {
            self.on_parameter_update(cmd_id, h, msg, now, fx);
            return;
        }
        self.live.retain(|l| l.cmd_id != cmd_id);
        let mode_ok = match h.command_type {
            // A wait belongs to a sequence; aborting the others with it has no use.
            t::wait_time::TYPE => matches!(
                h.execution_mode,
                execution_mode::SEQUENCE_PRIMARY | execution_mode::SEQUENCE_SECONDARY
            ),
            ty if motion::is_move(ty) => matches!(
                h.execution_mode,
                execution_mode::SEQUENCE_PRIMARY
                    | execution_mode::SEQUENCE_ABORT_OTHERS_PRIMARY
                    | execution_mode::SEQUENCE_SECONDARY
                    | execution_mode::SEQUENCE_ABORT_OTHERS_SECONDARY
            ),
            // The PLC libraries send it on the primary sequence; it moves on the secondary.
            t::return_to_primary::TYPE => matches!(
                h.execution_mode,
                execution_mode::SEQUENCE_PRIMARY | execution_mode::SEQUENCE_SECONDARY
            ),
            // Jogging belongs to the secondary sequence (its default) or runs in parallel.
            t::group_jog::TYPE => matches!(
                h.execution_mode,
                execution_mode::SEQUENCE_SECONDARY | execution_mode::PARALLEL
            ),
            ty if CONTINUOUS_READS.contains(&ty) => matches!(
                h.execution_mode,
                execution_mode::PARALLEL
                    | execution_mode::CONTINUOUS
                    | execution_mode::STOP_PARALLEL_CONTINUOUS_TRIGGER
            ),
            _ => h.execution_mode == execution_mode::PARALLEL,
        };
        let known = IMPLEMENTED.contains(&h.command_type);
        if known && !mode_ok {
            self.respond(
                cmd_id,
                h,
                state::ERROR,
                code::INVALID_EXECUTION_MODE,
                now,
                |_| {},
            );
            return;
        }
        if known && h.execution_mode == execution_mode::STOP_PARALLEL_CONTINUOUS_TRIGGER {
            self.stop_continuous(h.command_type, now);
            self.respond(cmd_id, h, state::DONE, 0, now, |_| {});
            return;
        }
        if known && h.execution_mode == execution_mode::CONTINUOUS {
            self.start_continuous(cmd_id, h, msg, now, fx);
            return;
        }
        self.execute(cmd_id, h, msg, now, fx);
    }

    /// Carries out a new command.
    fn execute(&mut self, cmd_id: u16, h: CommandHeader, msg: &[u8], now: Now, fx: &mut Effects) {
        match h.command_type {
            t::read_robot_data::TYPE => self.read_robot_data(cmd_id, h, now),
            t::exchange_configuration::TYPE => self.exchange_configuration(cmd_id, h, msg, now),
            t::read_messages::TYPE => self.read_messages(cmd_id, h, msg, now),
            t::enable_robot::TYPE => self.enable_robot(cmd_id, h, msg, now, fx),
            t::group_reset::TYPE => self.group_reset(cmd_id, h, now, fx),
            t::set_sequence::TYPE => self.set_sequence(cmd_id, h, msg, now, fx),
            t::return_to_primary::TYPE => self.return_to_primary(cmd_id, h, msg, now, fx),
            t::read_actual_position::TYPE => self.read_actual_position(cmd_id, h, msg, now),
            ty if motion::is_move(ty) => self.move_command(cmd_id, h, msg, now, fx),
            t::change_speed_override::TYPE => self.change_speed_override(cmd_id, h, msg, now, fx),
            t::group_stop::TYPE => self.group_motion(cmd_id, h, MotionCommandKind::Stop, now, fx),
            t::group_interrupt::TYPE => {
                self.group_motion(cmd_id, h, MotionCommandKind::Interrupt, now, fx)
            }
            t::group_continue::TYPE => {
                self.group_motion(cmd_id, h, MotionCommandKind::Continue, now, fx)
            }
            t::group_jog::TYPE => self.group_jog(cmd_id, h, msg, now, fx),
            t::create_server_log::TYPE => self.create_server_log(cmd_id, h, now),
            t::read_server_log::TYPE => self.read_server_log(cmd_id, h, msg, now),
            _ if self.user_data_command(cmd_id, h, msg, now) => {}
            ty if !t::COMMAND_TYPES.iter().any(|&(_, id)| id == ty) => self.respond(
                cmd_id,
                h,
                state::ERROR,
                code::COMMAND_TYPE_OUT_OF_RANGE,
                now,
                |_| {},
            ),
            _ => self.respond(cmd_id, h, state::ERROR, code::NOT_IMPLEMENTED, now, |_| {}),
        }
    }

    /// A parameter update (FragmentAction Clear) of a live Enable-type command.
    fn on_parameter_update(
        &mut self,
        cmd_id: u16,
        h: CommandHeader,
        msg: &[u8],
        now: Now,
        fx: &mut Effects,
    ) {
        let Some(i) = self.live.iter().position(|l| l.cmd_id == cmd_id) else {
            // An update of a command that already ended: nothing runs under this CmdID.
            self.respond(
                cmd_id,
                h,
                state::ERROR,
                code::TRANSITION_NOT_POSSIBLE,
                now,
                |_| {},
            );
            return;
        };
        self.live[i].par_seq = h.par_seq;
        match self.live[i].kind {
            LiveKind::Continuous { .. }
                if h.execution_mode == execution_mode::STOP_PARALLEL_CONTINUOUS_TRIGGER =>
            {
                self.respond(cmd_id, h, state::DONE, 0, now, |_| {});
            }
            // New parameters: answered at once, then continuously as before.
            LiveKind::Continuous { .. } => self.answer_continuous(i, msg, now, fx),
            LiveKind::Messages { .. } => self.update_read_messages(i, msg, now),
            LiveKind::Configuration { .. } => self.update_exchange_configuration(i, msg, now),
            LiveKind::ServerLog => self.update_read_server_log(i, msg, now),
            LiveKind::Enable { .. } => self.update_enable_robot(i, msg, now, fx),
            LiveKind::Jog { .. } => self.update_group_jog(i, msg, now, fx),
            LiveKind::ServicesReset { .. } => {}
            // ReturnToPrimary is disabled by an update with Enable = FALSE.
            LiveKind::Job { .. } if self.live[i].command_type == t::return_to_primary::TYPE => {
                self.update_return_to_primary(msg, now, fx)
            }
            // Execute-type commands take no updates; the new ParSeq is simply acknowledged
            // with the next response.
            LiveKind::Job { .. } => {}
        }
    }

    /// ExecutionMode CONTINUOUS: the read is answered now and then again every
    /// [`CONTINUOUS_INTERVAL_MS`], ACTIVE, until it is stopped.
    fn start_continuous(
        &mut self,
        cmd_id: u16,
        h: CommandHeader,
        msg: &[u8],
        now: Now,
        fx: &mut Effects,
    ) {
        let i = self.keep_live(
            cmd_id,
            h,
            LiveKind::Continuous {
                sent_ms: now.mono_ms,
            },
        );
        self.answer_continuous(i, msg, now, fx);
    }

    /// Answers continuous read `i` again (ACTIVE); an error ends it.
    fn answer_continuous(&mut self, i: usize, msg: &[u8], now: Now, fx: &mut Effects) {
        let cmd_id = self.live[i].cmd_id;
        let h = CommandHeader {
            execution_mode: execution_mode::CONTINUOUS,
            ..self.live_header(i)
        };
        self.live[i].kind = LiveKind::Continuous {
            sent_ms: now.mono_ms,
        };
        self.continuous_answer = Some(cmd_id);
        self.execute(cmd_id, h, msg, now, fx);
        self.continuous_answer = None;
    }

    /// Answers the continuous reads that are due again (from `poll`).
    pub(crate) fn refresh_continuous(&mut self, now: Now, fx: &mut Effects) {
        for i in 0..self.live.len() {
            let LiveKind::Continuous { sent_ms } = self.live[i].kind else {
                continue;
            };
            if now.mono_ms.saturating_sub(sent_ms) < CONTINUOUS_INTERVAL_MS {
                continue;
            }
            let mut message = [0u8; MESSAGE_CAPACITY];
            let Some(stored) = self.acr.message_of(self.live[i].cmd_id) else {
                continue;
            };
            let len = stored.len();
            message[..len].copy_from_slice(stored);
            self.answer_continuous(i, &message[..len], now, fx);
        }
    }

    /// ExecutionMode STOP_PARALLEL_CONTINUOUS_TRIGGER as a new command: every continuous
    /// read of `command_type` ends DONE.
    fn stop_continuous(&mut self, command_type: u16, now: Now) {
        while let Some(i) = self.live.iter().position(|l| {
            l.command_type == command_type && matches!(l.kind, LiveKind::Continuous { .. })
        }) {
            let (cmd_id, h) = (self.live[i].cmd_id, self.live_header(i));
            self.respond(cmd_id, h, state::DONE, 0, now, |_| {});
        }
    }

    /// Queues a response to the command `cmd_id` (header `h`) and ends it if `st` is final;
    /// an ERROR raises a message with the text of its code.
    pub(crate) fn respond(
        &mut self,
        cmd_id: u16,
        h: CommandHeader,
        st: u8,
        code: u16,
        now: Now,
        fill: impl FnOnce(&mut [u8]),
    ) {
        self.respond_telling(cmd_id, h, st, code, describe(code), now, fill);
    }

    /// [`respond`](Self::respond), an ERROR raising its message with `text`.
    #[allow(
        clippy::too_many_arguments,
        reason = "respond's arguments and the message text of an ERROR"
    )]
    pub(crate) fn respond_telling(
        &mut self,
        cmd_id: u16,
        h: CommandHeader,
        st: u8,
        code: u16,
        text: &str,
        now: Now,
        fill: impl FnOnce(&mut [u8]),
    ) {
        // A continuous read answers ACTIVE where a single one is DONE.
        let st = if st == state::DONE && self.continuous_answer == Some(cmd_id) {
            state::ACTIVE
        } else {
            st
        };
        let header = ResponseHeader {
            par_seq: h.par_seq,
            state: st,
            severity: severity_of(st, code),
            code,
        };
        self.responses
            .push(cmd_id, header, Server::response_len(h.command_type), fill);
        if state::is_final(st) {
            self.acr.release(cmd_id);
            self.live.retain(|l| l.cmd_id != cmd_id);
            if st == state::ERROR {
                self.raise(now, MessageType::Command, severity::ERROR, code, text);
            }
        }
    }

    /// The header the next response of live command `i` carries.
    pub(crate) fn live_header(&self, i: usize) -> CommandHeader {
        let l = &self.live[i];
        CommandHeader {
            command_type: l.command_type,
            execution_mode: 0,
            par_seq: l.par_seq,
            priority: 0,
        }
    }

    /// Registers a command that stays live after its first response.
    pub(crate) fn keep_live(&mut self, cmd_id: u16, h: CommandHeader, kind: LiveKind) -> usize {
        self.live.push(LiveCommand {
            cmd_id,
            command_type: h.command_type,
            par_seq: h.par_seq,
            kind,
        });
        self.live.len() - 1
    }
}
