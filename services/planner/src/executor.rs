//! The per-tick motion state machine: takes the servo feedback and new motion commands,
//! keeps the primary and the secondary sequence, and produces the setpoint window and the
//! planner status.
//!
//! Group commands act on the sequences their command names: GroupInterrupt holds them (the
//! running move of a held sequence brakes on its path and waits at the front of it),
//! GroupContinue releases them, GroupStop and Halt discard them, and an aborting move
//! aborts the moves of its own sequence only. Drives switched off under a move hold it like
//! a GroupInterrupt (0x6F02); a drive fault or a lost servo ends every move with an error.
//!
//! A move with a BlendingMode blends into the next move of its sequence if that one is
//! buffered when the move's blend window begins (the executor decides that once per move,
//! in a committed tick; [`blend`] plans the overlap); a WaitTime is a sequence
//! element that stands still (see [`motion`](crate::motion)).
//!
//! Timeline: the feedback of servo tick `k` arrives, the executor commits the point for tick
//! `k + 1` and looks ahead to `k + SETPOINT_WINDOW`. When wake-ups were missed, the servo
//! used the look-ahead points of the last window; the executor replays those ticks first, so
//! its state is always the one the servo followed.

use shared_types::config::Config;
use shared_types::ipc::{
    AXES, DriveState, JointPoint, MotionCommand, MotionCommandKind, MotionSequence, MotionStatus,
    RefusalReason, SETPOINT_WINDOW, ServoFeedback, ServoSetpoint,
};
use shared_types::pose;
use shared_types::srci::message::{code, state};

use crate::blend::{self, BlendRequest, Blending, PathLeg};
use crate::cartesian_path;
use crate::events::EventLog;
use crate::joint_distance::JointMoveDistance;
use crate::joint_move::{self, JointMove, Plan, move_limits};
use crate::kinematics::selection::{CartesianTarget, ConfigModes, TurnMode, select};
use crate::kinematics::turns::TurnNumbers;
use crate::kinematics::{ArmConfig, ArmGeometry, Kinematics};
use crate::linear_move::{self, Arm, LinearMove, LinearPlan, TcpLimits};
use crate::motion::{
    ActiveMove, Dynamics, Handover, Motion, Path, Phase, PlannedBlend, Running, ServoTick,
};
use crate::queue::QueuedMove;
use crate::refinement::{InlineRefiner, Refiner, TableRequest};
use crate::safety_filter::{Intervention, SafetyFilter};
use crate::sequences::{Cursor, Sequence, Sequences, overlap};
use crate::targets;
use crate::time_scale::TimeScale;

/// Joint speed (rad/s) below which the servo feedback counts as standing still.
const REST_VELOCITY: f64 = 1e-3;
/// Joint speed (rad/s) below which the commanded motion counts as standing.
const MOVING_VELOCITY: f64 = 1e-9;
/// Servo periods accepted from the feedback; outside, the configured period is used.
const PERIOD_RANGE_NS: core::ops::RangeInclusive<u64> = 10_000..=100_000_000;
/// Room for waiting events beyond those of the queued moves.
const EVENT_SLACK: usize = 256;
/// Largest share of a line's duration on constant bounds a standing arm waits for its table.
pub const TABLE_WAIT_SHARE: f64 = 0.25;

/// How long (s) a standing arm waits for the table of a line that takes `duration_s` on
/// constant bounds before it starts on them: `configured_s` (`planner.table_wait_ms`), and
/// no more than [`TABLE_WAIT_SHARE`] of the duration. The table makes most lines far
/// shorter (`rc bench motion`: 1.43 times at the median on constant bounds) but takes tens
/// of milliseconds to plan; the share keeps short moves from waiting longer than they could
/// gain.
pub fn table_wait(configured_s: f64, duration_s: f64) -> f64 {
    configured_s.min(TABLE_WAIT_SHARE * duration_s).max(0.0)
}

/// The motion state machine of one planner process.
pub struct Executor {
    dynamics: Dynamics,
    kinematics: Kinematics,
    /// The UR-type geometry for configuration bits (`None` if the robot does not fit it).
    geometry: Option<ArmGeometry>,
    /// Times buffered Cartesian moves by their tables, off the tick (the tick plans them on
    /// constant bounds).
    refiner: Box<dyn Refiner>,
    /// The jobs that start within the setpoint window sent last: their plans stay.
    window_starts: WindowStarts,
    /// The number of the last table request.
    table_requests: u64,
    /// Longest wait (s) of a standing arm for a line's table ([`table_wait`]).
    table_wait_s: f64,
    /// The last guard before the servo: every point, committed or looked ahead, passes it.
    guard: SafetyFilter,
    /// The guard found a point outside the limits: the moves ended with an error and the
    /// arm brakes under the guard until it stands.
    guard_stop: bool,
    /// Configured interpolation period, s.
    period_s: f64,
    motion: Motion,
    sequences: Sequences,
    /// Whether the executor commands the servo (it publishes setpoints only then).
    synced: bool,
    /// Servo tick of `motion.point`.
    tick: u64,
    servo_instance: u64,
    last_fault: u16,
    /// The servo's count of ticks without a setpoint, as of the last step.
    last_misses: u64,
    override_target: f64,
    /// A GroupStop waiting for the moves of the sequences it acts on to stand still.
    pending_stop: Option<(u32, MotionSequence)>,
    /// A GroupInterrupt waiting for the moves of the sequences it acts on to stand still.
    pending_interrupt: Option<(u32, MotionSequence)>,
    /// The move taken from the queue last (the running one, if any).
    running: Option<QueuedMove>,
    /// The TCP's curve of the running joint move, for its remaining distance.
    joint_distance: JointMoveDistance,
    /// `(issuer, seq)` of the newest accepted command.
    accepted: Option<(u64, u64)>,
    events: EventLog,
    status: MotionStatus,
}

impl Executor {
    /// An executor for the robot and planner settings of `config`; `instance` identifies
    /// this planner process in its status. Tables of buffered lines are planned when the
    /// lines are accepted ([`InlineRefiner`]): for tests, where the tick has no deadline.
    pub fn new(config: &Config, instance: u64) -> Self {
        let capacity = 2 * usize::from(config.main.planner.queue_length);
        Self::with_refiner(
            config,
            instance,
            Box::new(InlineRefiner::new(config, capacity)),
        )
    }

    /// An executor whose buffered lines get their tables from `refiner`.
    pub fn with_refiner(config: &Config, instance: u64, refiner: Box<dyn Refiner>) -> Self {
        let queue_length = usize::from(config.main.planner.queue_length);
        // The interpreter starts with the same override and sends every change.
        let override_fraction = config.main.interpreter.initial_override_percent / 100.0;
        let status = MotionStatus::initial(instance, override_fraction);
        Self {
            dynamics: Dynamics {
                limits: config.robot.limits_rad(),
                tcp: TcpLimits::from_config(&config.robot.cartesian),
                override_reserve: config.main.planner.override_reserve,
            },
            kinematics: Kinematics::new(&config.robot.kinematics),
            geometry: ArmGeometry::new(&config.robot.kinematics).ok(),
            refiner,
            window_starts: WindowStarts::default(),
            table_requests: 0,
            table_wait_s: config.main.planner.table_wait_ms as f64 * 1e-3,
            guard: SafetyFilter::new(config.robot.limits_rad())
                .expect("the safety filter's fixed problem layout is valid"),
            guard_stop: false,
            period_s: config.main.servo.period_us as f64 * 1e-6,
            motion: Motion::at_rest([0.0; AXES], override_fraction),
            sequences: Sequences::with_capacity(queue_length),
            synced: false,
            tick: 0,
            servo_instance: 0,
            last_fault: 0,
            last_misses: 0,
            override_target: override_fraction,
            pending_stop: None,
            pending_interrupt: None,
            running: None,
            joint_distance: JointMoveDistance::default(),
            accepted: None,
            // Bursts end at most both sequences plus a few commands per move.
            events: EventLog::with_capacity(8 * queue_length + EVENT_SLACK),
            status,
        }
    }

    /// The status after the last [`step`](Self::step).
    pub fn status(&self) -> &MotionStatus {
        &self.status
    }

    /// Whether two moves overlap now (SRCI IsBlending).
    pub fn is_blending(&self) -> bool {
        self.motion.is_blending()
    }

    /// Job events lost because too many waited for the status ring.
    pub fn dropped_events(&self) -> u64 {
        self.events.dropped()
    }

    /// Whether the executor commands the servo (it stays silent until the arm stands still
    /// after a start or a loss of synchronisation).
    pub fn is_commanding(&self) -> bool {
        self.synced
    }

    /// One planner cycle for the servo tick of `feedback`: applies `commands` (in order) and
    /// returns the setpoint window, or `None` while the executor must not command the servo.
    pub fn step(
        &mut self,
        feedback: &ServoFeedback,
        commands: &[MotionCommand],
    ) -> Option<ServoSetpoint> {
        let dt = if PERIOD_RANGE_NS.contains(&feedback.period_ns) {
            feedback.period_ns as f64 * 1e-9
        } else {
            self.period_s
        };
        let drive = DriveState::from_wire(feedback.state);
        self.watch_drives(feedback, drive);
        self.follow_servo_clock(feedback, dt);
        self.track_arm(feedback, drive);
        self.last_misses = feedback.setpoint_misses;
        for command in commands {
            self.accept(command, drive);
        }
        self.take_tables();
        self.finish_stop();
        if self.synced && drive.is_enabled() {
            if self.tick <= feedback.tick {
                if !self.guard_stop {
                    self.prepare_next_move();
                }
                self.prepare_blend(dt);
                self.advance(dt);
                self.finish_stop();
            }
        } else {
            self.tick = feedback.tick.wrapping_add(1);
        }
        self.events.publish(&mut self.status, dt);
        self.update_status(feedback);
        self.synced.then(|| self.window(dt))
    }

    /// Keeps `motion` on the servo's tick: replays the ticks the servo took from the last
    /// window, and gives up control when the servo cannot have followed it.
    fn follow_servo_clock(&mut self, feedback: &ServoFeedback, dt: f64) {
        let restarted = feedback.instance != self.servo_instance;
        self.servo_instance = feedback.instance;
        if !self.synced {
            return;
        }
        let next = feedback.tick.wrapping_add(1);
        if restarted || next < self.tick {
            self.lose_sync();
            return;
        }
        // 1 in the steady state, 0 for the same feedback again.
        let behind = next - self.tick;
        if behind > SETPOINT_WINDOW as u64 {
            // The servo ran past the last window; a standing arm just stayed where it was.
            if self.is_busy() {
                self.lose_sync();
            } else {
                self.tick = feedback.tick;
            }
            return;
        }
        for _ in 1..behind {
            self.advance(dt);
        }
    }

    /// Ends the moves in flight on a new drive fault, holds them when the drives are not
    /// enabled.
    fn watch_drives(&mut self, feedback: &ServoFeedback, drive: DriveState) {
        let fault = feedback.fault_code;
        if fault != 0 && fault != self.last_fault {
            // The drives stop the arm themselves; take over again once it stands.
            self.end_all(state::ERROR, fault);
            self.status.error_code = fault;
            self.synced = false;
        }
        self.last_fault = fault;
        if !drive.is_enabled() {
            self.hold_for_disabled_drives();
        }
    }

    /// Follows the arm while the executor does not command it, and takes over once the arm
    /// stands still.
    fn track_arm(&mut self, feedback: &ServoFeedback, drive: DriveState) {
        if drive == DriveState::Stopping && self.synced {
            if feedback.setpoint_misses == self.last_misses {
                // The servo brakes with setpoints at hand: the drives are being switched off.
                self.hold_for_disabled_drives();
                self.synced = false;
            } else {
                // The servo brakes by itself: our setpoints did not reach it in time.
                self.lose_sync();
            }
        }
        if !drive.is_enabled() || !self.synced {
            // Track the arm so that taking over (or enabling) never jumps.
            let at_rest = feedback.q.iter().all(|q| q.is_finite())
                && feedback.qd.iter().all(|v| v.abs() <= REST_VELOCITY);
            // The held sequences stay held.
            let holds = self.motion.holds;
            self.motion = Motion::at_rest(feedback.q, self.override_target);
            self.motion.holds = holds;
            self.tick = feedback.tick;
            self.synced = at_rest && drive != DriveState::Stopping;
        }
    }

    fn accept(&mut self, command: &MotionCommand, drive: DriveState) {
        if let Some((issuer, seq)) = self.accepted
            && issuer == command.issuer
            && command.seq <= seq
        {
            return;
        }
        self.accepted = Some((command.issuer, command.seq));
        self.status.acked_issuer = command.issuer;
        self.status.acked_seq = command.seq;
        let start = self.start_of(command);
        let command = &match targets::absolute(command, &start, &self.kinematics) {
            Ok(absolute) => absolute,
            Err(e) => return self.report(command.job, state::ERROR, e.code()),
        };
        let job = command.job;
        let scope = MotionSequence::from_wire(command.sequence);
        match MotionCommandKind::from_wire(command.kind) {
            Some(
                MotionCommandKind::MoveAxes
                | MotionCommandKind::MoveLinear
                | MotionCommandKind::MoveCircular,
            ) => self.accept_move(command, drive),
            Some(MotionCommandKind::MoveDirect) => self.accept_move_direct(command, drive),
            Some(MotionCommandKind::Stop) => {
                self.stop(scope, code::ABORTED_BY_GROUP_STOP);
                if let Some((previous, _)) = self.pending_stop.replace((job, scope)) {
                    self.report(previous, state::ABORTED, code::ABORTED_BY_GROUP_STOP);
                }
            }
            Some(MotionCommandKind::Halt) => self.stop(scope, code::ABORTED_BY_GROUP_STOP),
            Some(MotionCommandKind::Interrupt) => self.interrupt(job, scope),
            Some(MotionCommandKind::Continue) => self.resume(job, scope),
            Some(MotionCommandKind::Override) => {
                let fraction = command.override_fraction;
                if (0.0..=1.0).contains(&fraction) {
                    self.override_target = fraction;
                    self.report(job, state::DONE, 0);
                } else {
                    self.report(job, state::ERROR, code::INVALID_OVERRIDE);
                }
            }
            Some(MotionCommandKind::Reset) => {
                self.status.error_code = 0;
                self.report(job, state::DONE, 0);
            }
            Some(MotionCommandKind::Wait) => self.accept_wait(command, drive),
            None => self.report(job, state::ERROR, code::NOT_IMPLEMENTED),
        }
    }

    /// MoveAxesAbsolute and MoveLinearAbsolute: checked and planned from where the move
    /// will most likely start, so that every error is reported before the arm moves, then
    /// buffered. A joint move is planned again when it starts; a linear move keeps its plan
    /// if it starts there (see [`prepare_next_move`](Self::prepare_next_move)).
    fn accept_move(&mut self, command: &MotionCommand, drive: DriveState) {
        let job = command.job;
        let linear = cartesian_path::is_cartesian(command);
        let limits = move_limits(&self.dynamics.limits, command);
        let valid = if linear {
            linear_move::validate(command).map_err(|e| e.code())
        } else {
            joint_move::validate(command, &limits).map_err(|e| e.code())
        };
        if let Err(code) = valid.and(Blending::of(command).map(|_| ()).map_err(|e| e.code())) {
            return self.report(job, state::ERROR, code);
        }
        if let Some(code) = self.refusal(drive) {
            return self.report(job, state::ERROR, code);
        }
        let start = self.start_of(command);
        let planned = if linear {
            self.plan_linear(start, command).map(|plan| {
                let mut command = *command;
                command.joints_rad = plan.target();
                QueuedMove {
                    linear: Some(plan),
                    ..QueuedMove::joint(command)
                }
            })
        } else {
            let reserve = self.dynamics.override_reserve;
            JointMove::plan(start, command, &limits, reserve)
                .map(|_| QueuedMove::joint(*command))
                .map_err(|e| Refusal::of(e.code()))
        };
        match planned {
            Ok(mut queued) => {
                if let Some(LinearPlan::Move(line)) = queued.linear {
                    self.table_requests += 1;
                    let asked = self.refiner.request(&TableRequest {
                        id: self.table_requests,
                        start,
                        command: queued.command,
                    });
                    if asked {
                        let wait = table_wait(self.table_wait_s, line.timing().profile.duration());
                        queued.table_request = self.table_requests;
                        // Ticks of the wait, rounded down: never longer than the wait.
                        let ticks = (wait / self.period_s) as u64;
                        queued.earliest_start_tick = self.tick.wrapping_add(1 + ticks);
                    }
                }
                self.buffer(queued);
            }
            Err(refusal) => self.refuse(job, refusal),
        }
    }

    /// WaitTime: buffered in its sequence like a move that stands where the moves before it
    /// end, for `duration_s` (see [`motion`](crate::motion)).
    fn accept_wait(&mut self, command: &MotionCommand, drive: DriveState) {
        let job = command.job;
        if !(command.duration_s.is_finite() && command.duration_s >= 0.0) {
            return self.report(job, state::ERROR, code::INVALID_TIME);
        }
        if let Some(code) = self.refusal(drive) {
            return self.report(job, state::ERROR, code);
        }
        let mut wait = *command;
        wait.joints_rad = self.start_of(command);
        self.buffer(QueuedMove::joint(wait));
    }

    /// Why no move may be buffered now, if it may not: a pending error or disabled drives.
    fn refusal(&self, drive: DriveState) -> Option<u16> {
        if self.status.error_code != 0 {
            Some(code::DISABLED_DUE_TO_ERROR)
        } else if !drive.is_enabled() {
            Some(code::ROBOT_DISABLED)
        } else {
            None
        }
    }

    /// Appends an accepted move (or wait) to its sequence, after stopping that sequence if
    /// the move aborts, and reports it BUFFERED.
    fn buffer(&mut self, queued: QueuedMove) {
        let command = &queued.command;
        let sequence = Sequence::of_move(command);
        if command.aborting {
            self.stop(sequence.scope(), code::ABORTED_BY_MOTION_COMMAND);
        }
        let job = command.job;
        match self.sequences.queue_mut(sequence).push(queued) {
            Ok(()) => self.report(job, state::BUFFERED, 0),
            Err(_) => self.report(job, state::ERROR, code::INTERNAL_ERROR),
        }
    }

    /// Decides, once per running move, whether it blends into the next move of its
    /// sequence. The decision falls when the move's blend window begins: halfway through
    /// it (the earliest overlap start) less the look-ahead of the setpoint window, since
    /// what the servo has been sent must not change. A move whose next one is not buffered
    /// by then (the CODESYS rule: both commanded in time), or whose StepMode holds after
    /// it, ends with an exact stop. Runs before the committed tick of a step only.
    ///
    /// An override ramp under way then moves the overlap's earliest start on by the time
    /// its rate takes to come down to 0: the blend's rate, often lower than the move's,
    /// holds from the overlap's start, and the rate comes down to it on the way (see
    /// [`Motion`]) without changing what the servo has been sent. Held at once instead, it
    /// stepped the acceleration by up to 9 times the jerk limit in one tick.
    ///
    /// An overlap that must run slower than the override (its
    /// [`max_scale`](blend::Overlap::max_scale)) needs the time of that slow-down ahead of
    /// it, after the setpoint window: a next move that is buffered and final (not a line
    /// waiting for its table) is decided earlier by the longest slow-down; where the time
    /// left is still too short, the overlap runs at the lowest scale it can reach.
    fn prepare_blend(&mut self, dt: f64) {
        let Phase::Running(running) = self.motion.phase else {
            return;
        };
        if !matches!(running.handover, Handover::Undecided) {
            return;
        }
        let lookahead = SETPOINT_WINDOW as f64 * dt;
        let half = 0.5 * running.plan.timing().profile.duration();
        let blending = self
            .running
            .filter(|queued| queued.command.job == running.active.job)
            .and_then(|queued| Blending::of(&queued.command).ok());
        let ramp = self.dynamics.override_ramp(running.plan.timing());
        let anticipation = self.final_next_rate(&running, ramp.0).map_or(0.0, |rate| {
            TimeScale::ramp_time(1.0 - blend::SLOWEST_SCALE, rate, ramp.1) + 2.0 * dt
        });
        let handover = match blending {
            None | Some(Blending::ExactStop) => Handover::ExactStop,
            Some(_) if running.active.hold_after => Handover::ExactStop,
            Some(_) if running.tau + lookahead + anticipation < half => return,
            Some(blending) => {
                let (rate, acceleration) = ramp;
                let scale = self.motion.time_scale();
                // The fastest rate within the setpoint window, with the override as it is.
                let fastest =
                    scale.fastest_rate(self.override_target, rate, acceleration, lookahead);
                let window_end = running.tau + lookahead;
                // σ is at rest by then, unless the override changes after the decision.
                let settled = window_end + fastest / acceleration;
                self.plan_blend(&running, blending, settled).map_or(
                    Handover::ExactStop,
                    |mut blend| {
                        blend.schedule_slow_down(scale, running.tau, window_end, ramp, dt);
                        Handover::Blend(blend)
                    },
                )
            }
        };
        if let Phase::Running(running) = &mut self.motion.phase {
            running.handover = handover;
        }
    }

    /// The override rate (1/s) of a blend of `running` (whose own is `rate`) into the next
    /// move of its sequence, as far as the moves tell, if that move is buffered and final:
    /// not a line whose table is still being planned (a decided blend takes no table).
    fn final_next_rate(&self, running: &Running, rate: f64) -> Option<f64> {
        let (sequence, next) = self.sequences.next(&Cursor::default(), self.motion.holds)?;
        let waiting = next.table_request != 0 && next.earliest_start_tick != 0;
        if sequence != running.active.sequence || waiting {
            return None;
        }
        Some(match next.linear {
            Some(LinearPlan::Move(line)) => rate.min(line.timing().override_rate),
            _ => rate,
        })
    }

    /// The blend of `running` into the next move of its sequence, if that is a joint or
    /// Cartesian move planned from where `running` ends and the blend keeps the limits.
    fn plan_blend(
        &self,
        running: &Running,
        blending: Blending,
        earliest_start: f64,
    ) -> Option<PlannedBlend> {
        let outgoing = self.running?;
        let (sequence, next) = self.sequences.next(&Cursor::default(), self.motion.holds)?;
        if sequence != running.active.sequence {
            return None;
        }
        let corner = running.plan.target();
        let reserve = self.dynamics.override_reserve;
        let plan = if cartesian_path::is_cartesian(&next.command) {
            match next.linear? {
                LinearPlan::Move(m) if next.linear?.start() == &corner => Path::Linear(m),
                _ => return None,
            }
        } else if next.command.kind == MotionCommandKind::MoveAxes as u8 {
            match JointMove::plan(corner, &next.command, &self.dynamics.limits, reserve).ok()? {
                Plan::Move(m) => Path::Joint(m),
                Plan::Stationary => return None,
            }
        } else {
            return None;
        };
        // Both moves' SW limits hold on the overlap.
        let limits = move_limits(
            &move_limits(&self.dynamics.limits, &outgoing.command),
            &next.command,
        );
        let leg = |path, command: &MotionCommand| PathLeg {
            path,
            kinematics: &self.kinematics,
            tool: pose::isometry(command.tool),
        };
        let overlap = blend::plan(&BlendRequest {
            outgoing: &leg(&running.plan, &outgoing.command),
            incoming: &leg(&plan, &next.command),
            blending,
            corner,
            earliest_start,
            limits: &limits,
        })?;
        Some(PlannedBlend {
            next: ActiveMove::of(&next.command, sequence),
            plan,
            overlap,
            slow_down_at: overlap.start,
        })
    }

    /// Puts the tables the refiner has ready into the buffered moves they were requested for:
    /// only into a move that still starts where the table was planned from, has not entered
    /// the setpoint window sent last (what the servo holds must not change) and is not the
    /// decided blend of the running move. Such a move waits for its table no longer, with or
    /// without one.
    fn take_tables(&mut self) {
        let blended = match self.motion.phase {
            Phase::Running(Running {
                handover: Handover::Blend(blend),
                ..
            }) => Some(blend.next.job),
            _ => None,
        };
        while let Some(refined) = self.refiner.take() {
            for sequence in Sequence::BOTH {
                let queue = self.sequences.queue_mut(sequence);
                for index in 0..queue.len() {
                    if let Some(queued) = queue.get_mut(index)
                        && queued.table_request == refined.id
                        && !self.window_starts.contains(queued.command.job)
                        && blended != Some(queued.command.job)
                    {
                        queued.earliest_start_tick = 0;
                        if let Some(table) = refined.plan
                            && queued
                                .linear
                                .is_some_and(|plan| plan.start() == table.start())
                        {
                            queued.linear = Some(table);
                        }
                    }
                }
            }
        }
    }

    /// The linear move of `command` from `start`, or the SRCI code why there is none.
    fn plan_linear(
        &self,
        start: [f64; AXES],
        command: &MotionCommand,
    ) -> Result<LinearPlan, Refusal> {
        let geometry = self
            .geometry
            .as_ref()
            .ok_or(Refusal::of(code::TARGET_UNREACHABLE))?;
        let limits = move_limits(&self.dynamics.limits, command);
        let arm = Arm {
            kinematics: &self.kinematics,
            geometry,
            joints: &limits,
            tcp: &self.dynamics.tcp,
            timer: None,
        };
        LinearMove::plan(start, command, &arm, self.dynamics.override_reserve).map_err(|e| {
            Refusal {
                code: e.code(),
                reason: e.reason(),
            }
        })
    }

    /// Plans the linear move a standing arm starts next again from where the arm stands, if
    /// it was planned from elsewhere (after an aborting move's stop or an interrupt); a move
    /// that cannot start from there ends with its error. Until then the motion (and a copy
    /// of it in the window) waits. Runs before the committed tick of a step only, never in a
    /// replayed one: the servo used a window in which the move waited, and the replay must
    /// wait too.
    fn prepare_next_move(&mut self) {
        while self.motion.phase == Phase::Idle {
            let start = self.motion.point.q;
            let Some((sequence, front)) =
                self.sequences.next(&Cursor::default(), self.motion.holds)
            else {
                return;
            };
            let stale = cartesian_path::is_cartesian(&front.command)
                && front.linear.is_none_or(|plan| plan.start() != &start);
            if !stale {
                return;
            }
            let command = front.command;
            match self.plan_linear(start, &command) {
                Ok(plan) => {
                    if let Some(front) = self.sequences.queue_mut(sequence).front_mut() {
                        front.command.joints_rad = plan.target();
                        front.linear = Some(plan);
                        // It starts now, within the window: a table would come too late.
                        front.table_request = 0;
                        front.earliest_start_tick = 0;
                    }
                    return;
                }
                Err(refusal) => {
                    self.sequences.queue_mut(sequence).pop_front();
                    self.refuse(command.job, refusal);
                }
            }
        }
    }

    /// MoveDirectAbsolute: chooses the joint target of the Cartesian pose from where the move
    /// will start (ConfigMode and TurnMode decide among the solutions), then it is a joint
    /// move like MoveAxesAbsolute.
    fn accept_move_direct(&mut self, command: &MotionCommand, drive: DriveState) {
        let start = self.start_of(command);
        match self.joint_target(command, &start) {
            Ok(joints) => {
                let mut joint_move = *command;
                joint_move.kind = MotionCommandKind::MoveAxes as u8;
                joint_move.joints_rad = joints;
                self.accept_move(&joint_move, drive);
            }
            Err(refusal) => self.refuse(command.job, refusal),
        }
    }

    /// The joint target (rad) of the Cartesian target of `command` within its limits, or why
    /// there is none.
    fn joint_target(
        &self,
        command: &MotionCommand,
        start: &[f64; AXES],
    ) -> Result<[f64; AXES], Refusal> {
        let geometry = self.geometry.ok_or(Refusal::of(code::TARGET_UNREACHABLE))?;
        let target = CartesianTarget {
            // The TCP target and the tool give the flange: pose · tool⁻¹.
            flange: pose::isometry(command.pose) * pose::isometry(command.tool).inverse(),
            config: ArmConfig::from_bits(command.arm_config),
            turns: TurnNumbers::from_wire(command.turn_numbers),
            config_modes: ConfigModes::from_wire(command.config_modes)
                .map_err(|e| Refusal::of(e.code()))?,
            turn_mode: TurnMode::parse(command.turn_mode).map_err(|e| Refusal::of(e.code()))?,
        };
        select(
            &geometry,
            &target,
            start,
            &move_limits(&self.dynamics.limits, command),
        )
        .map_err(|e| Refusal {
            code: e.code(),
            reason: e.reason(),
        })
    }

    /// Where the move of `command` is expected to start: where the arm stands for an
    /// aborting move, else where its sequence ends.
    fn start_of(&self, command: &MotionCommand) -> [f64; AXES] {
        if command.aborting {
            return self.motion.point.q;
        }
        // Secondary moves go first: a primary move starts after both sequences' moves.
        let last = match Sequence::of_move(command) {
            Sequence::Primary => self
                .sequences
                .queue(Sequence::Primary)
                .back()
                .or(self.sequences.queue(Sequence::Secondary).back()),
            Sequence::Secondary => self.sequences.queue(Sequence::Secondary).back(),
        };
        match (last, self.motion.phase) {
            (Some(last), _) => last.command.joints_rad,
            (None, Phase::Running(Running { plan, .. })) => plan.target(),
            (None, Phase::Blending(blend)) => blend.plan.target(),
            (None, _) => self.motion.point.q,
        }
    }

    /// GroupInterrupt: holds the sequences of `scope` until GroupContinue; their running
    /// move brakes on its path and waits at the front of its sequence. Done once it stands.
    fn interrupt(&mut self, job: u32, scope: MotionSequence) {
        for sequence in Sequence::within(scope) {
            self.motion.holds.set(sequence, true);
        }
        if self
            .motion
            .running()
            .is_some_and(|active| active.sequence.is_in(scope))
        {
            self.interrupt_running(code::INTERRUPTED_BY_GROUP_INTERRUPT);
        }
        if let Some((previous, _)) = self.pending_interrupt.replace((job, scope)) {
            self.report(previous, state::DONE, 0);
        }
    }

    /// GroupContinue: releases the sequences of `scope`; a GroupInterrupt of them that is
    /// still braking ends ABORTED.
    fn resume(&mut self, job: u32, scope: MotionSequence) {
        for sequence in Sequence::within(scope) {
            self.motion.holds.set(sequence, false);
        }
        if let Some((previous, interrupted)) = self.pending_interrupt
            && overlap(interrupted, scope)
        {
            self.pending_interrupt = None;
            self.report(previous, state::ABORTED, code::ABORTED_BY_MOTION_COMMAND);
        }
        self.report(job, state::DONE, 0);
    }

    /// Brakes the running move on its path and puts it back at the front of its sequence,
    /// reported INTERRUPTED with `reason`; continuing plans it again from where it stops.
    fn interrupt_running(&mut self, reason: u16) {
        let Some(active) = self.motion.running() else {
            return;
        };
        let wait_left = match self.motion.phase {
            Phase::Waiting { left_s, .. } => Some(left_s),
            _ => None,
        };
        self.motion.brake();
        if let Some(mut queued) = self.running.filter(|c| c.command.job == active.job) {
            // An interrupted wait goes on with the time it had left.
            if let Some(left_s) = wait_left {
                queued.command.duration_s = left_s;
            }
            // Room is kept for exactly this move.
            let _ = self.sequences.queue_mut(active.sequence).push_front(queued);
        }
        self.report(active.job, state::INTERRUPTED, reason);
    }

    /// The drives are switched off: the running move is interrupted (0x6F02), and every
    /// sequence with a move in flight is held until the drives are enabled again and a
    /// GroupContinue releases it.
    fn hold_for_disabled_drives(&mut self) {
        for sequence in Sequence::BOTH {
            let running = self
                .motion
                .running()
                .is_some_and(|active| active.sequence == sequence);
            if running || !self.sequences.queue(sequence).is_empty() {
                self.motion.holds.set(sequence, true);
            }
        }
        self.interrupt_running(code::INTERRUPTED_NOT_ENABLED);
        // The drives stop the arm; the executor follows it until it stands.
        self.motion.phase = Phase::Idle;
    }

    /// Brakes the running move of the sequences of `scope` on its path and ends it and
    /// their buffered moves ABORTED; moves of the other sequence stay as they are.
    fn stop(&mut self, scope: MotionSequence, reason: u16) {
        if let Some(active) = self
            .motion
            .running()
            .filter(|active| active.sequence.is_in(scope))
        {
            self.motion.brake();
            self.report(active.job, state::ABORTED, reason);
        }
        for sequence in Sequence::within(scope) {
            while let Some(queued) = self.sequences.queue_mut(sequence).pop_front() {
                self.report(queued.command.job, state::ABORTED, reason);
            }
            // Nothing is left to continue.
            if reason == code::ABORTED_BY_GROUP_STOP {
                self.motion.holds.set(sequence, false);
            }
        }
        if scope == MotionSequence::All && reason == code::ABORTED_BY_GROUP_STOP {
            // A GroupStop of both sequences leaves no buffered move: the tables asked for
            // are of no use.
            self.refiner.forget(self.table_requests);
        }
    }

    /// Ends the running and every buffered move of both sequences with `state` and
    /// `reason`, leaving the arm where it is commanded now; nothing is left to continue.
    fn end_all(&mut self, state: u8, reason: u16) {
        if let Some(active) = self.motion.running() {
            self.report(active.job, state, reason);
        }
        self.motion.phase = Phase::Idle;
        for sequence in Sequence::BOTH {
            while let Some(queued) = self.sequences.queue_mut(sequence).pop_front() {
                self.report(queued.command.job, state, reason);
            }
            self.motion.holds.set(sequence, false);
        }
        self.refiner.forget(self.table_requests);
    }

    /// Gives up commanding the servo until the arm stands still again. Moves in flight
    /// cannot continue: they end with a motion error that only a reset clears.
    fn lose_sync(&mut self) {
        self.synced = false;
        if self.motion.running().is_some() || !self.sequences.is_empty() {
            self.end_all(state::ERROR, code::MOTION_ERROR);
            self.status.error_code = code::MOTION_ERROR;
        }
        self.motion.phase = Phase::Idle;
    }

    /// Whether the arm moves or would start a move.
    fn is_busy(&self) -> bool {
        self.motion.phase != Phase::Idle
            || self
                .sequences
                .next(&Cursor::default(), self.motion.holds)
                .is_some()
    }

    /// A pending GroupStop or GroupInterrupt is done once the commanded moves of the
    /// sequences it acts on stand.
    fn finish_stop(&mut self) {
        if !self.synced {
            return;
        }
        let moving = self.motion.moving_sequence();
        let stands = |scope: MotionSequence| moving.is_none_or(|s| !s.is_in(scope));
        if let Some((job, _)) = self.pending_stop.filter(|&(_, scope)| stands(scope)) {
            self.pending_stop = None;
            self.report(job, state::DONE, 0);
        }
        if let Some((job, _)) = self.pending_interrupt.filter(|&(_, scope)| stands(scope)) {
            self.pending_interrupt = None;
            self.report(job, state::DONE, 0);
        }
    }

    /// Commits the next tick of the real motion: events are reported, started moves leave
    /// the queue.
    fn advance(&mut self, dt: f64) {
        let previous = self.motion.point;
        let kinematics = &self.kinematics;
        if self.guard_stop {
            let braked = self.guard.brake(&previous, dt, |q| kinematics.jacobian(q));
            self.motion.point = braked.point;
            if braked.point.qd.iter().all(|v| *v == 0.0) {
                self.guard_stop = false;
                self.motion.point.qdd = [0.0; AXES];
            }
        } else {
            let mut cursor = Cursor::default();
            let events = &mut self.events;
            self.motion.advance(
                &self.dynamics,
                &self.sequences,
                &mut cursor,
                ServoTick {
                    number: self.tick.wrapping_add(1),
                    dt,
                },
                self.override_target,
                &mut |job, state, code| events.push(job, state, code),
            );
            for sequence in Sequence::BOTH {
                for _ in 0..cursor.passed(sequence) {
                    self.running = self.sequences.queue_mut(sequence).pop_front();
                }
            }
            let guarded = self.guard.guard(&previous, &self.motion.point, dt, |q| {
                kinematics.jacobian(q)
            });
            if guarded.intervention != Intervention::None {
                tracing::error!(
                    planned = ?self.motion.point,
                    "safety filter: the planned point leaves the joint limits; stopping"
                );
                self.end_all(state::ERROR, code::MOTION_ERROR);
                self.status.error_code = code::MOTION_ERROR;
                self.motion.point = guarded.point;
                self.guard_stop = true;
            }
        }
        self.tick = self.tick.wrapping_add(1);
    }

    /// The committed point and the points a copy of the motion takes in the following ticks.
    fn window(&mut self, dt: f64) -> ServoSetpoint {
        let mut ahead = self.motion;
        let mut starts = WindowStarts::default();
        let mut cursor = Cursor::default();
        let mut guard_stop = self.guard_stop;
        let kinematics = &self.kinematics;
        let mut points = [JointPoint::default(); SETPOINT_WINDOW];
        points[0] = ahead.point;
        for k in 1..SETPOINT_WINDOW {
            let previous = points[k - 1];
            points[k] = if guard_stop {
                self.guard
                    .brake(&previous, dt, |q| kinematics.jacobian(q))
                    .point
            } else {
                ahead.advance(
                    &self.dynamics,
                    &self.sequences,
                    &mut cursor,
                    ServoTick {
                        number: self.tick.wrapping_add(k as u64),
                        dt,
                    },
                    self.override_target,
                    &mut |job, state, _| {
                        if state == state::ACTIVE {
                            starts.add(job);
                        }
                    },
                );
                let guarded = self
                    .guard
                    .guard(&previous, &ahead.point, dt, |q| kinematics.jacobian(q));
                guard_stop = guarded.intervention != Intervention::None;
                guarded.point
            };
        }
        self.window_starts = starts;
        ServoSetpoint {
            planner_instance: self.status.instance,
            first_tick: self.tick,
            points,
        }
    }

    fn report(&mut self, job: u32, state: u8, code: u16) {
        self.events.push(job, state, code);
    }

    fn refuse(&mut self, job: u32, refusal: Refusal) {
        self.events.refuse(job, refusal.code, refusal.reason);
    }

    fn update_status(&mut self, feedback: &ServoFeedback) {
        let point = &self.motion.point;
        let s = &mut self.status;
        s.tick = feedback.tick;
        let active = self.motion.running();
        // Along the TCP's path, whatever parameter the move is timed by.
        let (travelled, _, path_acceleration) = self.motion.travel();
        s.active_job = active.map_or(0, |active| active.job);
        s.active_progress = match self.motion.phase {
            Phase::Waiting {
                left_s, duration_s, ..
            } => 100.0 * (1.0 - left_s / duration_s),
            _ if active.is_some() => 100.0 * travelled,
            _ => 0.0,
        };
        // The interpreter counts the primary moves waiting, held ones included.
        let primary = self.sequences.queue(Sequence::Primary).len();
        s.queued_jobs = u32::try_from(primary).unwrap_or(u32::MAX);
        s.joints_rad = point.q;
        s.joint_velocities = point.qd;
        s.flange_pose = self.kinematics.flange_pose(&point.q);
        s.arm_config = self.geometry.map_or(0, |g| g.arm_config(&point.q).bits());
        // Joints within ±720° always fit the turn nibbles; keep the last value otherwise.
        if let Some(wire) = TurnNumbers::of_joints(&point.q)
            .ok()
            .and_then(|t| t.to_wire().ok())
        {
            s.turn_numbers = wire;
        }
        s.override_fraction = self.override_target;
        s.sequence_paused = self.motion.holds.primary;
        s.blending = self.motion.is_blending();
        let active_plan = match &self.motion.phase {
            Phase::Running(running) => Some(&running.plan),
            Phase::Blending(blend) => Some(&blend.plan),
            _ => None,
        };
        // Lines and arcs are parameterised by their length: s is the share travelled. A joint
        // move's TCP (of the running command's tool) follows a curve, measured once.
        s.active_remaining_m = match active_plan {
            Some(Path::Linear(m)) => (1.0 - travelled).max(0.0) * m.length(),
            Some(Path::Joint(m)) => {
                let tool = self
                    .running
                    .filter(|r| r.command.job == s.active_job)
                    .map_or([0.0; 6], |r| r.command.tool);
                self.joint_distance
                    .remaining(m, tool, travelled, &self.kinematics)
            }
            None => f64::NAN,
        };
        // The path acceleration tells speeding up from slowing down, on any path.
        s.moving = point.qd.iter().any(|v| v.abs() > MOVING_VELOCITY);
        s.accelerating = s.moving && path_acceleration > 1e-9;
        s.decelerating = s.moving && path_acceleration < -1e-9;
        s.constant_velocity = s.moving && !s.accelerating && !s.decelerating;
    }
}

/// Why a move is refused: its SRCI code, and what the code does not tell.
#[derive(Debug, Clone, Copy)]
struct Refusal {
    code: u16,
    reason: RefusalReason,
}

impl Refusal {
    /// A refusal its code explains.
    fn of(code: u16) -> Self {
        Self {
            code,
            reason: RefusalReason::None,
        }
    }
}

/// The jobs that start within one setpoint window (a window holds few: past that many,
/// every job counts as started).
#[derive(Debug, Clone, Copy, Default)]
struct WindowStarts {
    jobs: [u32; WindowStarts::CAPACITY],
    len: usize,
    overflowed: bool,
}

impl WindowStarts {
    const CAPACITY: usize = 8;

    fn add(&mut self, job: u32) {
        match self.jobs.get_mut(self.len) {
            Some(slot) => {
                *slot = job;
                self.len += 1;
            }
            None => self.overflowed = true,
        }
    }

    fn contains(&self, job: u32) -> bool {
        self.overflowed || self.jobs[..self.len].contains(&job)
    }
}

#[cfg(test)]
mod tests;
