//! The SRCI server core: one call per PLC telegram, pure (no I/O, no clock).
//!
//! It runs the robot-interface state machine (254 → INITIALIZE → 255, RESET, the telegram
//! error states), supervises the PLC lifesign, acknowledges sequences exactly once, feeds
//! fragments into the Active Command Register, starts commands and answers with responses on
//! every state change. What it wants done outside (motion commands, drive power) it returns
//! in [`Effects`]; what happens outside reaches it through `on_motion_status` and
//! `on_servo_feedback`.

use shared_types::config::{JointLimitsRad, KinematicsConfig};
use shared_types::ipc::{
    DriveState, LinkEvent, MotionCommand, MotionCommandKind, MotionSequence, MotionStatus,
    ServoControl, ServoFeedback,
};
use shared_types::srci::message::{ResponseHeader, code, severity, state};
use shared_types::srci::tables;
use shared_types::srci::telegram::{
    Control, PLC_HEADER_LEN, PlcHeader, ROBOT_HEADER_LEN, RobotHeader, Sequence, SequenceWriter,
    SrciVersion, TELEGRAM_NUMBER_TWO_SEQUENCES, next_lifesign, sequence_areas, status_bit,
    telegram_state as ts,
};

use crate::acr::{Acr, FragmentOutcome, MESSAGE_CAPACITY};
use crate::arm::ArmModel;
use crate::commands::LiveCommand;
use crate::cyclic::{CyclicLayout, CyclicPosition};
use crate::handover::{self, Snapshot};
use crate::messages::{MessageLog, MessageType};
use crate::motion_link::{JobUpdate, MotionLink, PlannerEvent};
use crate::responses::ResponseQueue;
use crate::sequences::Sequences;
use crate::server_log::{JOURNAL_LINES, ServerLog};
use crate::sync::{SyncAction, SyncRequest, SyncSupervisor};
use crate::tcp_pose::tcp_pose;
use crate::user_data::{CURRENT_INDEX as CURRENT, UserData};
use shared_types::health::{RequestOutcome, SupervisionRequest, SupervisionStatus};

/// Settings of the server core, taken from the configuration at start-up.
#[derive(Debug, Clone)]
pub struct Settings {
    pub length_plc_to_rob: usize,
    pub length_rob_to_plc: usize,
    pub acr_length: usize,
    pub lifesign_timeout_ms: u16,
    pub message_capacity: usize,
    pub initial_override_percent: f64,
    pub planner_timeout_ms: u64,
    pub manufacturer: String,
    pub serial_number: String,
    pub robot_name: String,
    pub limits: JointLimitsRad,
    /// Interpolation period in ms, reported as InterpreterCycleTime.
    pub cycle_time_ms: u16,
    /// Time EnableRobot may take before it ends with an error.
    pub enable_timeout_ms: u64,
    /// The arm's Denavit-Hartenberg chain (Cartesian targets of joint positions).
    pub kinematics: KinematicsConfig,
}

impl Settings {
    /// The settings of `config` (validated at load time).
    pub fn from_config(config: &shared_types::config::Config) -> Self {
        let m = &config.main;
        Self {
            length_plc_to_rob: usize::from(m.fieldbus.telegram_length_plc_to_rob),
            length_rob_to_plc: usize::from(m.fieldbus.telegram_length_rob_to_plc),
            acr_length: usize::from(m.interpreter.acr_length),
            lifesign_timeout_ms: m.interpreter.lifesign_timeout_ms,
            message_capacity: usize::from(m.interpreter.message_capacity),
            initial_override_percent: m.interpreter.initial_override_percent,
            planner_timeout_ms: m.interpreter.planner_timeout_ms,
            manufacturer: m.interpreter.manufacturer.clone(),
            serial_number: m.interpreter.serial_number.clone(),
            robot_name: config.robot.name.clone(),
            limits: config.robot.limits_rad(),
            // At least 1 ms; config keeps the period at or below 8 ms.
            cycle_time_ms: m.servo.period_us.div_ceil(1000).max(1) as u16,
            enable_timeout_ms: m.servo.power_on_delay_ms + m.servo.enable_delay_ms + 5_000,
            kinematics: config.robot.kinematics.clone(),
        }
    }
}

/// The time of a call: monotonic for supervision, wall clock for message stamps.
#[derive(Debug, Clone, Copy, Default)]
pub struct Now {
    pub mono_ms: u64,
    pub unix_ms: u64,
}

/// What the server wants done after a call.
#[derive(Debug)]
pub struct Effects {
    /// Motion commands to publish, in order.
    pub motion: Vec<MotionCommand>,
    /// A new drive power request to publish.
    pub servo: Option<ServoControl>,
    /// A request to the orchestrator (GroupReset of a failed service).
    pub supervision: Option<SupervisionRequest>,
}

impl Effects {
    /// Pre-allocated, so that steady-state calls do not allocate.
    pub fn new() -> Self {
        Self {
            motion: Vec::with_capacity(128),
            servo: None,
            supervision: None,
        }
    }

    pub fn clear(&mut self) {
        self.motion.clear();
        self.servo = None;
        self.supervision = None;
    }
}

impl Default for Effects {
    fn default() -> Self {
        Self::new()
    }
}

/// Values fixed at INITIALIZE that every later telegram must repeat.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub(crate) struct Session {
    cyclic: CyclicLayout,
    length_plc_to_rob: u16,
    length_rob_to_plc: u16,
    telegram_number_plc_to_rob: u16,
    telegram_number_rob_to_plc: u16,
    axes_group: u8,
}

/// A GroupReset asks the orchestrator to restart failed services only while its status is
/// fresher than this (ms); without one, the services are not supervised by it.
const SUPERVISION_SILENCE_MS: u64 = 1000;

/// The SRCI server of one axes group.
#[derive(Debug)]
pub struct Server {
    pub(crate) settings: Settings,
    telegram_state: u8,
    session: Option<Session>,
    robot_lifesign: u8,
    plc_lifesign: Option<u8>,
    lifesign_changed_ms: u64,
    pub(crate) lifesign_timeout_ms: u16,
    /// Last processed SEQ per sequence (0 = none yet).
    last_seq: [u16; 2],
    /// The sequence areas of the last answer, re-sent while the PLC repeats its SEQ.
    reply_areas: [[u8; 256]; 2],
    pub(crate) invalid_frames: u64,
    pub(crate) acr: Acr,
    pub(crate) responses: ResponseQueue,
    pub(crate) messages: MessageLog,
    pub(crate) server_log: ServerLog,
    /// The data synchronisation of the session's last ExchangeConfiguration.
    pub(crate) sync_request: SyncRequest,
    sync_supervisor: SyncSupervisor,
    /// The primary and secondary sequence.
    pub(crate) sequences: Sequences,
    /// The orchestrator's last status and when it came (ms); none without an orchestrator
    /// (services run by systemd, tests).
    pub(crate) supervision: Option<(SupervisionStatus, u64)>,
    /// Requests to the orchestrator sent so far.
    supervision_requests: u64,
    /// The continuous read being answered now (its DONE becomes ACTIVE).
    pub(crate) continuous_answer: Option<u16>,
    /// StepMode of EnableRobot: 0 off, 1 BLENDING, 2 EXACT_STOP (both hold after each move,
    /// as this controller stops exactly anyway).
    pub(crate) step_mode: u8,
    pub(crate) live: Vec<LiveCommand>,
    pub(crate) motion: MotionLink,
    pub(crate) updates: Vec<JobUpdate>,
    pub(crate) servo_control: ServoControl,
    pub(crate) feedback: Option<ServoFeedback>,
    pub(crate) status: Option<MotionStatus>,
    pub(crate) override_percent: f64,
    pub(crate) error_pending: bool,
    /// Tools, frames, loads, dynamics and SW limits (persisted by the service shell).
    pub user_data: UserData,
    /// The arm's kinematics, for moves to joint targets on a TCP line.
    pub(crate) arm: ArmModel,
    last_drive_fault: u16,
    last_planner_error: u16,
    /// The session lost its PLC (link or lifesign) with the primary sequence held and the
    /// ACR kept: a PLC may RESUME it (TelegramState 253) or RESET it.
    suspended: bool,
}

impl Server {
    /// A server in READY_FOR_INITIALIZATION; `issuer` identifies this process instance.
    pub fn new(settings: Settings, issuer: u64, user_data: UserData) -> Self {
        let acr_length = settings.acr_length;
        Self {
            telegram_state: ts::READY_FOR_INITIALIZATION,
            session: None,
            robot_lifesign: 0,
            plc_lifesign: None,
            lifesign_changed_ms: 0,
            lifesign_timeout_ms: settings.lifesign_timeout_ms,
            last_seq: [0; 2],
            reply_areas: [[0; 256]; 2],
            invalid_frames: 0,
            acr: Acr::new(acr_length),
            responses: ResponseQueue::new(acr_length * 4 + 16),
            messages: MessageLog::new(settings.message_capacity),
            server_log: ServerLog::new(JOURNAL_LINES),
            sync_request: SyncRequest::default(),
            sync_supervisor: SyncSupervisor::default(),
            sequences: Sequences::default(),
            supervision: None,
            supervision_requests: 0,
            continuous_answer: None,
            step_mode: 0,
            live: Vec::with_capacity(acr_length),
            motion: MotionLink::new(issuer, acr_length + 8, settings.planner_timeout_ms),
            updates: Vec::with_capacity(acr_length * 2 + 8),
            servo_control: ServoControl::default(),
            feedback: None,
            status: None,
            override_percent: settings.initial_override_percent,
            error_pending: false,
            user_data,
            arm: ArmModel::new(&settings.kinematics),
            last_drive_fault: 0,
            last_planner_error: 0,
            suspended: false,
            settings,
        }
    }

    /// The state a successor process continues from (see [`crate::handover`]);
    /// `last_counter` is the counter of the last PLC telegram answered.
    pub fn snapshot(&self, instance: &str, now: Now, last_counter: u64) -> Snapshot {
        Snapshot {
            version: handover::VERSION,
            instance: instance.to_owned(),
            written_mono_ms: now.mono_ms,
            last_counter,
            telegram_state: self.telegram_state,
            session: self.session,
            robot_lifesign: self.robot_lifesign,
            plc_lifesign: self.plc_lifesign,
            lifesign_timeout_ms: self.lifesign_timeout_ms,
            last_seq: self.last_seq,
            reply_areas: [self.reply_areas[0].to_vec(), self.reply_areas[1].to_vec()],
            invalid_frames: self.invalid_frames,
            acr: self.acr.clone(),
            responses: self.responses.clone(),
            messages: self.messages.clone(),
            live: self.live.clone(),
            motion: self.motion.clone(),
            servo_control: self.servo_control,
            override_percent: self.override_percent,
            error_pending: self.error_pending,
            current_tool: self.user_data.current_tool(),
            current_frame: self.user_data.current_frame(),
            last_drive_fault: self.last_drive_fault,
            last_planner_error: self.last_planner_error,
            suspended: self.suspended,
            server_log: self.server_log.clone(),
            sync_request: self.sync_request,
            sync_supervisor: self.sync_supervisor,
            sequences: self.sequences,
            supervision_requests: self.supervision_requests,
            step_mode: self.step_mode,
        }
    }

    /// Continues from a predecessor's snapshot. The PLC's lifesign is timed from `now`, as the
    /// gap was the controller's, not the PLC's; storage gets its start-up capacity back, so
    /// that the steady state still does not allocate.
    pub fn restore(&mut self, s: Snapshot, now: Now) {
        let acr_length = self.settings.acr_length;
        self.telegram_state = s.telegram_state;
        self.session = s.session;
        self.robot_lifesign = s.robot_lifesign;
        self.plc_lifesign = s.plc_lifesign;
        self.lifesign_changed_ms = now.mono_ms;
        self.lifesign_timeout_ms = s.lifesign_timeout_ms;
        self.last_seq = s.last_seq;
        for (area, saved) in self.reply_areas.iter_mut().zip(&s.reply_areas) {
            let n = saved.len().min(area.len());
            area[..n].copy_from_slice(&saved[..n]);
        }
        self.invalid_frames = s.invalid_frames;
        self.acr = s.acr;
        self.responses = s.responses;
        self.responses.reserve_capacity();
        self.messages = s.messages;
        self.messages.reserve_capacity();
        self.live = s.live;
        self.live
            .reserve(acr_length.saturating_sub(self.live.len()));
        self.motion = s.motion;
        self.motion.reserve_capacity(acr_length + 8);
        self.servo_control = s.servo_control;
        self.override_percent = s.override_percent;
        self.error_pending = s.error_pending;
        let _ = self.user_data.select_tool(s.current_tool);
        let _ = self.user_data.select_frame(s.current_frame);
        self.last_drive_fault = s.last_drive_fault;
        self.last_planner_error = s.last_planner_error;
        self.suspended = s.suspended;
        self.server_log = s.server_log;
        self.server_log.reserve_capacity();
        self.sync_request = s.sync_request;
        self.sync_supervisor = s.sync_supervisor;
        self.sequences = s.sequences;
        self.supervision_requests = s.supervision_requests;
        self.step_mode = s.step_mode;
    }

    /// The current TelegramState.
    pub fn telegram_state(&self) -> u8 {
        self.telegram_state
    }

    /// The current drive power request.
    pub fn servo_control(&self) -> ServoControl {
        self.servo_control
    }

    /// Whether a command has set the drive power request since start.
    pub fn servo_control_set(&self) -> bool {
        self.servo_control.seq != 0
    }

    /// Telegrams dropped because header and footer lifesign differed.
    pub fn invalid_frames(&self) -> u64 {
        self.invalid_frames
    }

    /// Handles one PLC→robot telegram and writes the robot→PLC answer into `out`; returns
    /// the number of bytes of the answer.
    pub fn on_telegram(&mut self, now: Now, rx: &[u8], out: &mut [u8], fx: &mut Effects) -> usize {
        let len = self.settings.length_rob_to_plc.min(out.len());
        let out = &mut out[..len];
        out.fill(0);
        let consistent =
            rx.len() == self.settings.length_plc_to_rob && PlcHeader::is_consistent(rx);
        match PlcHeader::decode(rx) {
            Ok(header) if consistent => {
                self.track_lifesign(header.lifesign, now);
                self.handle_control(&header, now, fx);
                if self.telegram_state == ts::INITIALIZED {
                    self.check_lifesign(now, fx);
                }
                if self.telegram_state == ts::INITIALIZED {
                    self.exchange_sequences(rx, now, out, fx);
                }
            }
            // A torn or short frame is not interpreted; the PLC gets the last sequences again.
            _ => {
                self.invalid_frames += 1;
                if self.telegram_state == ts::INITIALIZED {
                    self.copy_reply_areas(out);
                }
            }
        }
        if self.telegram_state == ts::INITIALIZED {
            self.write_cyclic(rx, out);
        }
        self.write_header(out);
        len
    }

    /// The optional cyclic position blocks (ReadActualPositionCyclic), fresh every telegram,
    /// the Cartesian one in the tool and frame the PLC header asks for (an index that does
    /// not exist falls back to the ones in use; the block says which it used).
    fn write_cyclic(&self, rx: &[u8], out: &mut [u8]) {
        let layout = self.cyclic();
        if layout.robot_len() == 0 {
            return;
        }
        let (Some(f), Some(s)) = (self.feedback, self.status) else {
            return;
        };
        let (tool, frame) = layout
            .requested_tool_frame(rx)
            .unwrap_or((CURRENT, CURRENT));
        let in_use = |data: &UserData| tcp_pose(data, s.flange_pose, CURRENT, CURRENT);
        let Ok((tool, frame, pose)) = tcp_pose(&self.user_data, s.flange_pose, tool, frame)
            .or_else(|_| in_use(&self.user_data))
        else {
            return;
        };
        let position = CyclicPosition {
            pose,
            joints: f.q.map(f64::to_degrees),
            tool,
            frame,
            current_tool: self.user_data.current_tool(),
            current_frame: self.user_data.current_frame(),
            arm_config: s.arm_config,
            turn_numbers: s.turn_numbers,
        };
        layout.write(out, &position);
    }

    /// The fieldbus link changed. A lost or replaced peer suspends the session: motion stops
    /// on its path and the commands stay in the ACR. The next PLC finds READY_TO_RESUME and
    /// may RESUME the session, or RESET it.
    pub fn on_link(&mut self, now: Now, event: LinkEvent, fx: &mut Effects) {
        if !matches!(event, LinkEvent::Connected | LinkEvent::Disconnected) {
            return;
        }
        if self.telegram_state == ts::INITIALIZED {
            self.fail_session(
                ts::CONNECTION_LOST,
                now,
                fx,
                "fieldbus connection to the PLC lost",
            );
        }
        if event == LinkEvent::Connected && self.suspended {
            self.offer_resume(now, fx);
        }
    }

    /// A suspended session waits for a PLC: READY_TO_RESUME while commands are registered,
    /// otherwise there is nothing to resume and the session ends.
    fn offer_resume(&mut self, now: Now, fx: &mut Effects) {
        if self.acr.live() > 0 {
            self.telegram_state = ts::READY_TO_RESUME;
        } else {
            self.halt_session(now, fx);
            self.telegram_state = ts::READY_FOR_INITIALIZATION;
        }
    }

    /// Periodic work between telegrams (call every few ms): lifesign supervision, command
    /// re-sending, planner supervision, EnableRobot progress.
    pub fn poll(&mut self, now: Now, fx: &mut Effects) {
        if self.telegram_state == ts::INITIALIZED {
            self.check_lifesign(now, fx);
        }
        let fault = self.motion.poll(
            now.mono_ms,
            code::MOTION_ERROR,
            &mut fx.motion,
            &mut self.updates,
        );
        if let Some(f) = fault {
            self.on_planner_fault(f, now, fx);
        }
        self.apply_job_updates(now, fx);
        self.progress_enable(now, fx);
        self.continue_group_reset(now, fx);
        if self.telegram_state == ts::INITIALIZED {
            self.refresh_continuous(now, fx);
            self.supervise_sync(now, fx);
            self.refresh_configuration(now);
        }
        self.refresh_messages();
    }

    /// Whether the interface is SYNCHRONIZED (every data set the PLC synchronises in sync).
    pub(crate) fn synchronized(&self) -> bool {
        crate::sync::synchronized(&self.sync_request, &self.user_data)
    }

    /// SyncReaction: interrupts the primary sequence once while the data is out of sync.
    fn supervise_sync(&mut self, now: Now, fx: &mut Effects) {
        let empty = self
            .status
            .is_none_or(|s| s.active_job == 0 && s.queued_jobs == 0);
        let synchronized = self.synchronized();
        let action =
            self.sync_supervisor
                .check(&self.sync_request, synchronized, empty, now.mono_ms);
        if action == SyncAction::Interrupt {
            // The primary sequence only: jogging stays possible to fix the data.
            let mut interrupt = MotionCommand::new(MotionCommandKind::Interrupt);
            interrupt.sequence = MotionSequence::Primary as u8;
            let _ = self
                .motion
                .submit(interrupt, None, now.mono_ms, &mut fx.motion);
            self.raise(
                now,
                MessageType::Interface,
                severity::WARNING,
                code::NOT_SYNCHRONIZED,
                "user data not synchronized: primary sequence interrupted (SyncReaction)",
            );
        }
    }

    /// A new planner status.
    pub fn on_motion_status(&mut self, now: Now, status: &MotionStatus, fx: &mut Effects) {
        let fault =
            self.motion
                .on_status(status, now.mono_ms, code::MOTION_ERROR, &mut self.updates);
        if let Some(f) = fault {
            self.on_planner_fault(f, now, fx);
        }
        if status.error_code != 0 && status.error_code != self.last_planner_error {
            self.error_pending = true;
            self.raise(
                now,
                MessageType::Arm,
                severity::ERROR,
                status.error_code,
                "motion stopped by a planner error",
            );
        }
        self.last_planner_error = status.error_code;
        self.status = Some(*status);
        self.apply_job_updates(now, fx);
        self.refresh_motion_progress(now);
    }

    /// A new status of the orchestrator: a safe stop is an error the PLC sees (with its
    /// cause); a GroupReset waiting for the services goes on once they run again.
    pub fn on_supervision_status(
        &mut self,
        now: Now,
        status: &SupervisionStatus,
        fx: &mut Effects,
    ) {
        let was_stopped = self.supervision.is_some_and(|(s, _)| s.safe_stop != 0);
        self.supervision = Some((*status, now.mono_ms));
        if status.safe_stop != 0 && !was_stopped {
            self.error_pending = true;
            let mut text = [0u8; 150];
            let text = write_text(
                &mut text,
                format_args!("safe stop: {}; GroupReset restarts it", status.reason()),
            );
            self.raise(
                now,
                MessageType::Controller,
                severity::ERROR,
                code::INTERNAL_ERROR,
                text,
            );
        }
        self.continue_group_reset(now, fx);
    }

    /// Whether the orchestrator reports a service down (and is there to restart it).
    pub(crate) fn services_down(&self, now: Now) -> bool {
        self.supervision.is_some_and(|(s, at)| {
            now.mono_ms.saturating_sub(at) <= SUPERVISION_SILENCE_MS
                && (s.safe_stop != 0 || s.all_running == 0)
        })
    }

    /// A request id no other requester uses: this interpreter instance and a count.
    pub(crate) fn next_supervision_request(&mut self) -> u64 {
        self.supervision_requests += 1;
        (self.motion.issuer() << 24) ^ self.supervision_requests
    }

    /// The outcome of supervision request `id`, once the orchestrator has answered it.
    pub(crate) fn supervision_outcome(&self, id: u64) -> Option<(RequestOutcome, bool)> {
        self.supervision
            .filter(|(s, _)| s.request_id == id)
            .map(|(s, _)| {
                (
                    RequestOutcome::from_wire(s.request_outcome),
                    s.all_running != 0,
                )
            })
    }

    /// A new drive feedback.
    pub fn on_servo_feedback(&mut self, now: Now, feedback: &ServoFeedback, fx: &mut Effects) {
        let restarted = self
            .feedback
            .is_some_and(|f| f.instance != feedback.instance);
        if restarted {
            // Like a drive fault: the restarted drives stay off until the PLC resets the
            // error and enables again; the standing power request is withdrawn at once.
            self.error_pending = true;
            self.servo_control.seq += 1;
            self.servo_control.power = false;
            self.servo_control.enable = false;
            fx.servo = Some(self.servo_control);
            self.raise(
                now,
                MessageType::Arm,
                severity::ERROR,
                code::MOTION_ERROR,
                "drive process restarted: drives off, GroupReset and EnableRobot required",
            );
            self.end_enable_robot(now, code::DISABLED_DUE_TO_ERROR);
        }
        if feedback.fault_code != 0 && feedback.fault_code != self.last_drive_fault {
            self.error_pending = true;
            self.raise(
                now,
                MessageType::Arm,
                severity::ERROR,
                feedback.fault_code,
                "drive fault: the arm was stopped",
            );
        }
        self.last_drive_fault = feedback.fault_code;
        let was_enabled = self.drives_enabled();
        self.feedback = Some(*feedback);
        if was_enabled && !self.drives_enabled() {
            self.on_drives_off(now, fx);
        }
        self.progress_enable(now, fx);
    }

    fn on_planner_fault(&mut self, event: PlannerEvent, now: Now, fx: &mut Effects) {
        if event != PlannerEvent::Silent {
            // A new planner starts with the configured override; give it the current one.
            let mut o = MotionCommand::new(MotionCommandKind::Override);
            o.override_fraction = self.override_percent / 100.0;
            let _ = self.motion.submit(o, None, now.mono_ms, &mut fx.motion);
        }
        let text = match event {
            PlannerEvent::Replaced => {
                // Nothing was in flight: a restart at rest is invisible to the PLC.
                self.raise(
                    now,
                    MessageType::Controller,
                    severity::INFO,
                    0,
                    "motion planner restarted at rest; nothing was lost",
                );
                return;
            }
            PlannerEvent::Restarted => {
                "motion planner restarted: its commands ended with an error, GroupReset required"
            }
            PlannerEvent::Silent => {
                "motion planner not responding: its commands ended with an error, GroupReset required"
            }
        };
        self.error_pending = true;
        self.raise(
            now,
            MessageType::Controller,
            severity::ERROR,
            code::MOTION_ERROR,
            text,
        );
    }

    fn track_lifesign(&mut self, lifesign: u8, now: Now) {
        if self.plc_lifesign != Some(lifesign) {
            self.plc_lifesign = Some(lifesign);
            self.lifesign_changed_ms = now.mono_ms;
        }
    }

    fn check_lifesign(&mut self, now: Now, fx: &mut Effects) {
        let frozen = now.mono_ms.saturating_sub(self.lifesign_changed_ms);
        if frozen > u64::from(self.lifesign_timeout_ms) {
            self.fail_session(
                ts::LIFESIGN_TIMEOUT,
                now,
                fx,
                "PLC lifesign timeout: motion stopped",
            );
        }
    }

    /// Leaves INITIALIZED for an error state. A lost PLC (link or lifesign) suspends the
    /// session so that it can be resumed; any other fault ends it: motion halts, the
    /// commands of the session end.
    fn fail_session(&mut self, error_state: u8, now: Now, fx: &mut Effects, text: &str) {
        self.telegram_state = error_state;
        if matches!(error_state, ts::CONNECTION_LOST | ts::LIFESIGN_TIMEOUT) {
            self.suspend_session(error_state, now, fx);
        } else {
            self.halt_session(now, fx);
        }
        self.raise(
            now,
            MessageType::Interface,
            severity::ERROR,
            0x8000 | u16::from(error_state),
            text,
        );
    }

    /// Holds the session without a PLC: a running jog ends (nobody holds its button), the
    /// primary sequence is interrupted on its path (its running move reports INTERRUPTED),
    /// and the ACR, the pending responses and the sequence numbers are kept for RESUME.
    fn suspend_session(&mut self, error_state: u8, now: Now, fx: &mut Effects) {
        // Both sequences are held first; then the jogs end, whose Halt(Secondary) releases the
        // secondary sequence again, empty.
        let interrupt = MotionCommand::new(MotionCommandKind::Interrupt);
        if self
            .motion
            .submit(interrupt, None, now.mono_ms, &mut fx.motion)
            .is_none()
        {
            self.raise(
                now,
                MessageType::Controller,
                severity::WARNING,
                code::INTERNAL_ERROR,
                "interrupt not queued: the planner is not taking commands",
            );
        }
        self.end_jogs(0x8000 | u16::from(error_state), now, fx);
        self.suspended = true;
    }

    /// Stops motion and forgets everything of the SRCI session (ACR, responses, sequences).
    fn halt_session(&mut self, now: Now, fx: &mut Effects) {
        self.suspended = false;
        if self
            .motion
            .submit(
                MotionCommand::new(MotionCommandKind::Halt),
                None,
                now.mono_ms,
                &mut fx.motion,
            )
            .is_none()
        {
            // 64 commands the planner has not taken yet: it is not running, and a restarted
            // planner starts standing still anyway.
            self.raise(
                now,
                MessageType::Controller,
                severity::WARNING,
                code::INTERNAL_ERROR,
                "halt not queued: the planner is not taking commands",
            );
        }
        self.motion.forget_jobs();
        self.acr.clear();
        self.responses.clear();
        self.live.clear();
        self.last_seq = [0; 2];
        self.reply_areas = [[0; 256]; 2];
        self.session = None;
        self.lifesign_timeout_ms = self.settings.lifesign_timeout_ms;
        self.sync_request = SyncRequest::default();
        self.sync_supervisor = SyncSupervisor::default();
        self.sequences.reset();
    }

    fn handle_control(&mut self, h: &PlcHeader, now: Now, fx: &mut Effects) {
        match h.control {
            Control::Reset | Control::ClientError
                if self.telegram_state != ts::READY_FOR_INITIALIZATION =>
            {
                if self.telegram_state == ts::INITIALIZED || self.suspended {
                    self.halt_session(now, fx);
                }
                self.telegram_state = ts::READY_FOR_INITIALIZATION;
                self.raise(
                    now,
                    MessageType::Interface,
                    severity::INFO,
                    code::SERVER_STATE_RESET,
                    "interface reset by the PLC",
                );
            }
            Control::AckError if ts::is_error(self.telegram_state) => {
                if self.suspended {
                    self.offer_resume(now, fx);
                } else {
                    self.telegram_state = ts::READY_FOR_INITIALIZATION;
                }
            }
            Control::Resume if self.telegram_state == ts::READY_TO_RESUME => self.resume(h, now),
            Control::Initialize
                if matches!(
                    self.telegram_state,
                    ts::READY_FOR_INITIALIZATION | ts::READY_TO_RESUME
                ) =>
            {
                // A PLC that initializes instead of resuming starts a new session.
                if self.suspended {
                    self.halt_session(now, fx);
                }
                self.telegram_state = self.initialize(h);
                if self.telegram_state == ts::INITIALIZED {
                    self.lifesign_changed_ms = now.mono_ms;
                } else {
                    let state = self.telegram_state;
                    self.raise(
                        now,
                        MessageType::Interface,
                        severity::ERROR,
                        0x8000 | u16::from(state),
                        "initialization refused: telegram header does not match the robot interface",
                    );
                }
            }
            _ if self.telegram_state == ts::INITIALIZED => {
                if let Some(error) = self.session_violation(h) {
                    self.fail_session(
                        error,
                        now,
                        fx,
                        "telegram header changed after initialization",
                    );
                }
            }
            _ => {}
        }
    }

    /// RESUME of a suspended session: the header must be the one it was initialized with;
    /// the ACR, its responses and the sequence numbers continue. The primary sequence stays
    /// interrupted until the PLC sends GroupContinue, so the arm does not start by itself.
    fn resume(&mut self, h: &PlcHeader, now: Now) {
        if let Some(error) = self.session_violation(h) {
            self.telegram_state = error;
            self.raise(
                now,
                MessageType::Interface,
                severity::ERROR,
                0x8000 | u16::from(error),
                "resume refused: telegram header differs from the suspended session's",
            );
            return;
        }
        self.telegram_state = ts::INITIALIZED;
        self.suspended = false;
        self.plc_lifesign = Some(h.lifesign);
        self.lifesign_changed_ms = now.mono_ms;
        self.raise(
            now,
            MessageType::Interface,
            severity::INFO,
            0,
            "session resumed: commands continue after GroupContinue",
        );
    }

    /// Checks an INITIALIZE header; returns the new TelegramState.
    fn initialize(&mut self, h: &PlcHeader) -> u8 {
        if h.version.major != SrciVersion::CURRENT.major {
            return ts::MAJOR_VERSION;
        }
        if usize::from(h.length_plc_to_rob) != self.settings.length_plc_to_rob
            || usize::from(h.length_rob_to_plc) != self.settings.length_rob_to_plc
        {
            return ts::LENGTH_MISMATCH;
        }
        // A single arm answers to AxesGroupID 0 (what clients send) and 1 (what the spec asks).
        if h.axes_group > 1 {
            return ts::INVALID_AXES_GROUP;
        }
        let two_p2r = h.telegram_number_plc_to_rob & TELEGRAM_NUMBER_TWO_SEQUENCES != 0;
        let two_r2p = h.telegram_number_rob_to_plc & TELEGRAM_NUMBER_TWO_SEQUENCES != 0;
        if two_p2r != two_r2p {
            return ts::TELEGRAM_NUMBER_INVALID;
        }
        let cyclic = match CyclicLayout::select(
            h.telegram_number_plc_to_rob,
            h.telegram_number_rob_to_plc,
            self.settings.length_plc_to_rob,
            self.settings.length_rob_to_plc,
        ) {
            Ok(layout) => layout,
            Err(state) => return state,
        };
        self.session = Some(Session {
            cyclic,
            length_plc_to_rob: h.length_plc_to_rob,
            length_rob_to_plc: h.length_rob_to_plc,
            telegram_number_plc_to_rob: h.telegram_number_plc_to_rob,
            telegram_number_rob_to_plc: h.telegram_number_rob_to_plc,
            axes_group: h.axes_group,
        });
        self.last_seq = [0; 2];
        self.reply_areas = [[0; 256]; 2];
        ts::INITIALIZED
    }

    fn session_violation(&self, h: &PlcHeader) -> Option<u8> {
        let s = self.session?;
        if h.length_plc_to_rob != s.length_plc_to_rob || h.length_rob_to_plc != s.length_rob_to_plc
        {
            Some(ts::LENGTH_MISMATCH)
        } else if h.axes_group != s.axes_group {
            Some(ts::INVALID_AXES_GROUP)
        } else if h.telegram_number_plc_to_rob != s.telegram_number_plc_to_rob
            || h.telegram_number_rob_to_plc != s.telegram_number_rob_to_plc
        {
            Some(ts::TELEGRAM_NUMBER_CHANGED)
        } else if h.version.major != SrciVersion::CURRENT.major {
            Some(ts::MAJOR_VERSION)
        } else {
            None
        }
    }

    fn cyclic(&self) -> CyclicLayout {
        self.session.map(|s| s.cyclic).unwrap_or_default()
    }

    fn two_sequences(&self) -> bool {
        self.session
            .is_some_and(|s| s.telegram_number_plc_to_rob & TELEGRAM_NUMBER_TWO_SEQUENCES != 0)
    }

    /// Processes new sequences exactly once and writes the answering sequences.
    fn exchange_sequences(&mut self, rx: &[u8], now: Now, out: &mut [u8], fx: &mut Effects) {
        let two = self.two_sequences();
        let cyclic = self.cyclic();
        let (in_areas, n) = sequence_areas(rx.len(), PLC_HEADER_LEN, cyclic.plc_len(), two);
        let (out_areas, _) = sequence_areas(out.len(), ROBOT_HEADER_LEN, cyclic.robot_len(), two);
        let mut seqs = [0u16; 2];
        for i in 0..n {
            let (start, len) = in_areas[i];
            seqs[i] = match Sequence::decode(&rx[start..start + len]) {
                Ok(seq) => seq.seq_ack,
                Err(_) => 0,
            };
        }
        // The older of two new sequences goes first (numbers wrap from 254 to 1).
        let order: [usize; 2] = if n == 2 && newer(seqs[0], seqs[1]) {
            [1, 0]
        } else {
            [0, 1]
        };
        for &i in order.iter().take(n) {
            let seq = seqs[i];
            if seq == 0 || seq == self.last_seq[i] {
                continue;
            }
            let (start, len) = in_areas[i];
            self.process_sequence(&rx[start..start + len], now, fx);
            self.last_seq[i] = seq;
            self.apply_job_updates(now, fx);
            self.refresh_messages();
            let (_, olen) = out_areas[i];
            let mut w = SequenceWriter::new(&mut self.reply_areas[i][..olen], seq);
            self.responses.fill(&mut w);
        }
        self.copy_reply_areas(out);
    }

    fn copy_reply_areas(&self, out: &mut [u8]) {
        let robot_len = self.cyclic().robot_len();
        let (areas, n) =
            sequence_areas(out.len(), ROBOT_HEADER_LEN, robot_len, self.two_sequences());
        for (i, &(start, len)) in areas.iter().enumerate().take(n) {
            out[start..start + len].copy_from_slice(&self.reply_areas[i][..len]);
        }
    }

    fn process_sequence(&mut self, area: &[u8], now: Now, fx: &mut Effects) {
        let seq = match Sequence::decode(area) {
            Ok(seq) => seq,
            Err(e) => {
                self.raise_malformed(now, e);
                return;
            }
        };
        for fragment in seq.fragments() {
            let (header, data) = match fragment {
                Ok(f) => f,
                Err(e) => {
                    self.raise_malformed(now, e);
                    return;
                }
            };
            match self.acr.on_fragment(&header, data) {
                FragmentOutcome::Partial => {}
                FragmentOutcome::Complete {
                    slot,
                    len,
                    new_command,
                } => {
                    let mut message = [0u8; MESSAGE_CAPACITY];
                    message[..len].copy_from_slice(self.acr.message(slot));
                    let cmd_id = self.acr.cmd_id(slot);
                    self.on_command_message(cmd_id, &message[..len], new_command, now, fx);
                }
                FragmentOutcome::UnknownCommand => self.raise(
                    now,
                    MessageType::Interface,
                    severity::WARNING,
                    code::TRANSITION_NOT_POSSIBLE,
                    "fragment ignored: its CmdID has no message being received (a new command starts with Reset, an update with Clear)",
                ),
                FragmentOutcome::RegisterFull | FragmentOutcome::OutOfBounds => {
                    self.respond_error_unregistered(header.cmd_id, code::INTERNAL_ERROR, now)
                }
            }
        }
    }

    fn raise_malformed(&mut self, now: Now, e: shared_types::srci::telegram::TelegramError) {
        let mut text = [0u8; 150];
        let s = write_text(&mut text, format_args!("malformed sequence ignored: {e}"));
        self.raise(
            now,
            MessageType::Interface,
            severity::WARNING,
            code::INTERNAL_ERROR,
            s,
        );
    }

    /// Sends the answer to a command whose fragments could not be registered.
    fn respond_error_unregistered(&mut self, cmd_id: u16, code: u16, now: Now) {
        self.responses.push(
            cmd_id,
            ResponseHeader {
                par_seq: 0,
                state: state::ERROR,
                severity: severity::ERROR,
                code,
            },
            ResponseHeader::LEN,
            |_| {},
        );
        self.raise(
            now,
            MessageType::Command,
            severity::ERROR,
            code,
            crate::commands::describe(code),
        );
    }

    /// Records a warning of the robot controller (e.g. about its stored data) for
    /// ReadMessages.
    pub fn raise_warning(&mut self, now: Now, text: &str) {
        self.raise(
            now,
            MessageType::Controller,
            severity::WARNING,
            code::INTERNAL_ERROR,
            text,
        );
    }

    /// Records a message for ReadMessages.
    pub(crate) fn raise(&mut self, now: Now, kind: MessageType, sev: i8, code: u16, text: &str) {
        self.messages
            .raise(now.unix_ms, kind, sev, u32::from(code), text);
        self.server_log
            .record(now.unix_ms, kind, sev, u32::from(code), text);
    }

    /// Whether the drives are enabled (moves possible).
    pub(crate) fn drives_enabled(&self) -> bool {
        self.feedback
            .is_some_and(|f| DriveState::from_wire(f.state).is_enabled())
    }

    fn status_word(&self) -> u32 {
        let mut w = 4u32 << status_bit::OPERATION_MODE_SHIFT; // AUTO_EXT: the PLC drives the robot
        if self.sequences.secondary_active() {
            w |= status_bit::SECONDARY_SEQUENCE_ACTIVE;
        }
        if self
            .status
            .is_none_or(|s| self.sequences.in_primary_position(&s.joints_rad))
        {
            w |= status_bit::IN_PRIMARY_POS;
        }
        if let Some(f) = self.feedback {
            if DriveState::from_wire(f.state).is_enabled() {
                w |= status_bit::ENABLED;
            }
            if f.qd.iter().any(|v| v.abs() > 1e-6) {
                w |= status_bit::IS_MOVING;
            }
        }
        if let Some(s) = self.status {
            if s.moving {
                w |= status_bit::IS_MOVING;
            }
            if s.sequence_paused {
                w |= status_bit::PRIMARY_SEQUENCE_PAUSED | (2 << status_bit::SEQUENCE_STATE_SHIFT);
            } else if s.active_job != 0 || s.queued_jobs != 0 {
                w |= 1 << status_bit::SEQUENCE_STATE_SHIFT;
            }
            if s.accelerating {
                w |= status_bit::ACCELERATING;
            }
            if s.decelerating {
                w |= status_bit::DECELERATING;
            }
            if s.constant_velocity {
                w |= status_bit::CONSTANT_VELOCITY;
            }
            if s.blending {
                w |= status_bit::IS_BLENDING;
            }
        }
        if self.error_pending {
            w |= status_bit::ERROR_PENDING;
        }
        w
    }

    fn write_header(&mut self, out: &mut [u8]) {
        self.robot_lifesign = next_lifesign(self.robot_lifesign);
        let header = RobotHeader {
            version: SrciVersion::CURRENT,
            lifesign: self.robot_lifesign,
            telegram_state: self.telegram_state,
            status: self.status_word(),
            // Within 0..=100 %, so the product fits a u16.
            override_centi: (self.override_percent * 100.0).round() as u16,
        };
        // `out` has the configured length, which config validation keeps in 64..=256.
        let _ = header.encode(out);
    }

    /// Turns collected job updates into responses.
    pub(crate) fn apply_job_updates(&mut self, now: Now, fx: &mut Effects) {
        let mut i = 0;
        while i < self.updates.len() {
            let u = self.updates[i];
            i += 1;
            self.on_job_update(u, now, fx);
        }
        self.updates.clear();
    }

    /// The default lengths of request/response tables, by command type.
    pub(crate) fn response_len(command_type: u16) -> usize {
        tables::payload_lengths(command_type).map_or(ResponseHeader::LEN, |(_, _, rsp)| rsp)
    }
}

/// Whether sequence number `a` is newer than `b` (numbers run 1..=254 and wrap to 1).
fn newer(a: u16, b: u16) -> bool {
    let d = (i32::from(a) - i32::from(b)).rem_euclid(254);
    d != 0 && d < 127
}

/// Formats into a fixed buffer without allocating; text that does not fit is cut.
pub fn write_text<'a>(buf: &'a mut [u8], args: core::fmt::Arguments<'_>) -> &'a str {
    struct Cursor<'b> {
        buf: &'b mut [u8],
        len: usize,
    }
    impl core::fmt::Write for Cursor<'_> {
        fn write_str(&mut self, s: &str) -> core::fmt::Result {
            for ch in s.chars() {
                let mut tmp = [0u8; 4];
                let enc = ch.encode_utf8(&mut tmp);
                if self.len + enc.len() > self.buf.len() {
                    return Err(core::fmt::Error);
                }
                self.buf[self.len..self.len + enc.len()].copy_from_slice(enc.as_bytes());
                self.len += enc.len();
            }
            Ok(())
        }
    }
    let mut c = Cursor { buf, len: 0 };
    let _ = core::fmt::write(&mut c, args);
    let len = c.len;
    core::str::from_utf8(&c.buf[..len]).unwrap_or("")
}

#[cfg(test)]
mod tests {
    use super::newer;

    #[test]
    fn sequence_numbers_wrap_from_254_to_1() {
        assert!(newer(2, 1));
        assert!(newer(1, 254));
        assert!(!newer(254, 1));
        assert!(!newer(5, 5));
    }
}

#[cfg(test)]
#[path = "server_tests.rs"]
mod server_tests;
