//! Commands executed by the planner: the moves (MoveAxesAbsolute, MoveDirectAbsolute,
//! MoveLinearAbsolute here, the Extended moves and WaitTime in their own modules),
//! ChangeSpeedOverride (and GroupReset's planner part), with their job updates and progress.

use shared_types::ipc::{MotionCommand, MotionCommandKind, MotionSequence, TargetReference};
use shared_types::srci::message::{CommandHeader, Percent, code, execution_mode, state};
use shared_types::srci::payload::{Field, PayloadReader, PayloadWriter};
use shared_types::srci::tables::{
    change_speed_override as cso, group_reset as gr, group_stop as gs, move_axes_absolute as maa,
    move_axes_relative as mar, move_circular_absolute as mca, move_circular_relative as mcr,
    move_direct_absolute as mda, move_direct_offset as mdo, move_direct_relative as mdr,
    move_linear_absolute as mla, move_linear_absolute_j as mlaj, move_linear_offset as mlo,
    move_linear_relative as mlr, return_to_primary as rtp, wait_time as wt,
};

use super::sequence::write_primary_pos;
use super::{
    LineTarget, LiveKind, blending, circular, describe, joint_line, offset, relative, wait,
};
use crate::motion_link::JobUpdate;
use crate::server::{Effects, Now, Server};
use crate::tcp_pose::{self, WirePose};
use crate::user_data::UserData;

/// Whether `command_type` queues a move (or a wait) in a motion sequence: the commands
/// [`Server::move_command`] answers.
pub fn is_move(command_type: u16) -> bool {
    matches!(command_type, maa::TYPE | mar::TYPE | wt::TYPE)
        || WITH_REMAINING_DISTANCE.contains(&command_type)
}

/// The moves whose response carries Progress and RemainingDistance, in the layout of
/// MoveDirectAbsolute's.
const WITH_REMAINING_DISTANCE: [u16; 9] = [
    mda::TYPE,
    mla::TYPE,
    mca::TYPE,
    mcr::TYPE,
    mdr::TYPE,
    mlaj::TYPE,
    mlr::TYPE,
    mdo::TYPE,
    mlo::TYPE,
];

/// "0 %: use internal minimal velocity".
const MIN_RATE: f64 = 1.0;
/// Progress refreshes of one move are at most this often.
const PROGRESS_INTERVAL_MS: u64 = 100;

/// A percentage rate as a fraction of the robot's limits, or the code for an invalid value.
fn rate(wire: u16, default: f64, invalid: u16) -> Result<f64, u16> {
    match Percent::from_wire(wire) {
        // A default dynamics rate of 0 % (writable) means the minimal rate as well.
        Percent::Default => Ok(default.clamp(MIN_RATE, 100.0) / 100.0),
        Percent::Value(p) if p <= 100.0 => Ok(p.max(MIN_RATE) / 100.0),
        Percent::Value(_) => Err(invalid),
    }
}

/// Where the rates and Time of a move sit in its request table.
pub(super) struct DynamicsLayout {
    pub(super) velocity: Field,
    pub(super) acceleration: Field,
    pub(super) deceleration: Field,
    pub(super) jerk: Field,
    pub(super) time: Field,
}

/// Where the parameters every move command shares sit in its request table.
pub(super) struct MoveLayout {
    pub(super) dynamics: DynamicsLayout,
    pub(super) tool: Field,
    pub(super) blending_mode: Field,
    pub(super) blending_parameter: Field,
}

const MOVE_AXES: MoveLayout = MoveLayout {
    dynamics: DynamicsLayout {
        velocity: maa::request::VELOCITY_RATE,
        acceleration: maa::request::ACCELERATION_RATE,
        deceleration: maa::request::DECELERATION_RATE,
        jerk: maa::request::JERK_RATE,
        time: maa::request::TIME,
    },
    tool: maa::request::TOOL_NO,
    blending_mode: maa::request::BLENDING_MODE,
    blending_parameter: maa::request::BLENDING_PARAMETER,
};

/// Where the Cartesian target sits in the request table of a Cartesian move.
pub(super) struct CartesianLayout {
    pub(super) common: MoveLayout,
    pub(super) frame: Field,
    pub(super) position: [Field; 6],
    pub(super) shoulder: Field,
    pub(super) elbow: Field,
    pub(super) wrist: Field,
    pub(super) turn_number: Field,
    pub(super) config_mode: Field,
    pub(super) turn_mode: Field,
}

const MOVE_DIRECT: CartesianLayout = CartesianLayout {
    common: MoveLayout {
        dynamics: DynamicsLayout {
            velocity: mda::request::VELOCITY_RATE,
            acceleration: mda::request::ACCELERATION_RATE,
            deceleration: mda::request::DECELERATION_RATE,
            jerk: mda::request::JERK_RATE,
            time: mda::request::TIME,
        },
        tool: mda::request::TOOL_NO,
        blending_mode: mda::request::BLENDING_MODE,
        blending_parameter: mda::request::BLENDING_PARAMETER,
    },
    frame: mda::request::FRAME_NO,
    position: mda::request::POSITION_X_RZ,
    shoulder: mda::request::SHOULDER,
    elbow: mda::request::ELBOW,
    wrist: mda::request::WRIST,
    turn_number: mda::request::POSITION_TURN_NUMBER,
    config_mode: mda::request::CONFIG_MODE,
    turn_mode: mda::request::TURN_MODE,
};

const MOVE_LINEAR: CartesianLayout = CartesianLayout {
    common: MoveLayout {
        dynamics: DynamicsLayout {
            velocity: mla::request::VELOCITY_RATE,
            acceleration: mla::request::ACCELERATION_RATE,
            deceleration: mla::request::DECELERATION_RATE,
            jerk: mla::request::JERK_RATE,
            time: mla::request::TIME,
        },
        tool: mla::request::TOOL_NO,
        blending_mode: mla::request::BLENDING_MODE,
        blending_parameter: mla::request::BLENDING_PARAMETER,
    },
    frame: mla::request::FRAME_NO,
    position: mla::request::POSITION_X_RZ,
    shoulder: mla::request::SHOULDER,
    elbow: mla::request::ELBOW,
    wrist: mla::request::WRIST,
    turn_number: mla::request::POSITION_TURN_NUMBER,
    config_mode: mla::request::CONFIG_MODE,
    turn_mode: mla::request::TURN_MODE,
};

const RETURN_TO_PRIMARY: DynamicsLayout = DynamicsLayout {
    velocity: rtp::request::VELOCITY_RATE,
    acceleration: rtp::request::ACCELERATION_RATE,
    deceleration: rtp::request::DECELERATION_RATE,
    jerk: rtp::request::JERK_RATE,
    time: rtp::request::TIME,
};

/// Whether `mode` puts a move on the secondary sequence.
fn on_secondary(mode: u8) -> bool {
    matches!(
        mode,
        execution_mode::SEQUENCE_SECONDARY | execution_mode::SEQUENCE_ABORT_OTHERS_SECONDARY
    )
}

/// A planner command of `kind` with the rates (those left at default from the default
/// dynamics) of the reference dynamics, the Time and the PLC's SW limits of the request.
pub(super) fn with_dynamics(
    r: &PayloadReader<'_>,
    layout: &DynamicsLayout,
    kind: MotionCommandKind,
    data: &UserData,
) -> Result<MotionCommand, u16> {
    let defaults = data.default_rates();
    let mut c = MotionCommand::new(kind);
    c.velocity_scale = rate(
        r.u16(layout.velocity),
        defaults.velocity,
        code::INVALID_VELOCITY_RATE,
    )?;
    c.acceleration_scale = rate(
        r.u16(layout.acceleration),
        defaults.acceleration,
        code::INVALID_ACCELERATION_RATE,
    )?;
    c.deceleration_scale = rate(
        r.u16(layout.deceleration),
        defaults.deceleration,
        code::INVALID_DECELERATION_RATE,
    )?;
    c.jerk_scale = rate(r.u16(layout.jerk), defaults.jerk, code::INVALID_JERK_RATE)?;
    c.tcp_reference = data.reference_shares();
    c.duration_s = f64::from(r.u16(layout.time)) / 1000.0;
    let limits = data.sw_limits_rad();
    c.sw_lower_rad = limits.lower;
    c.sw_upper_rad = limits.upper;
    Ok(c)
}

/// Checks what every move shares (rates, tool, blending, time, execution mode) and returns a
/// planner command of `kind` with them, the tool's TCP included.
pub(super) fn decode_move(
    r: &PayloadReader<'_>,
    layout: &MoveLayout,
    h: CommandHeader,
    kind: MotionCommandKind,
    data: &UserData,
) -> Result<MotionCommand, u16> {
    let mut c = with_dynamics(r, &layout.dynamics, kind, data)?;
    c.tool = tcp_pose::tool_offset(data, r.u8(layout.tool))?;
    let parameter = layout.blending_parameter;
    let b = blending::decode(
        r.u8(layout.blending_mode),
        [r.f32(parameter.element(0)), r.f32(parameter.element(1))],
    )?;
    c.blending_mode = b.mode;
    c.blending_parameter = b.parameter;
    c.aborting = matches!(
        h.execution_mode,
        execution_mode::SEQUENCE_ABORT_OTHERS_PRIMARY
            | execution_mode::SEQUENCE_ABORT_OTHERS_SECONDARY
    );
    c.sequence = sequence_of(h.execution_mode) as u8;
    Ok(c)
}

/// The sequence a move with ExecutionMode `mode` belongs to.
pub(super) fn sequence_of(mode: u8) -> MotionSequence {
    if on_secondary(mode) {
        MotionSequence::Secondary
    } else {
        MotionSequence::Primary
    }
}

/// The rates and Time of a ReturnToPrimary request as a planner command (kind and target
/// are set by the caller).
pub(crate) fn decode_return(r: &PayloadReader<'_>, data: &UserData) -> Result<MotionCommand, u16> {
    with_dynamics(r, &RETURN_TO_PRIMARY, MotionCommandKind::MoveAxes, data)
}

/// Checks a MoveAxesAbsolute request and turns it into a planner command; targets must lie
/// within the SW limits.
fn decode_move_axes(msg: &[u8], h: CommandHeader, data: &UserData) -> Result<MotionCommand, u16> {
    let r = PayloadReader::new(msg);
    let mut c = decode_move(&r, &MOVE_AXES, h, MotionCommandKind::MoveAxes, data)?;
    c.joints_rad = joint_target(&r, maa::request::JOINT_POSITION_J1_J6, data)?;
    Ok(c)
}

/// The joint target in `fields` (degrees on the wire) in rad, within the SW limits.
pub(super) fn joint_target(
    r: &PayloadReader<'_>,
    fields: [Field; 6],
    data: &UserData,
) -> Result<[f64; 6], u16> {
    let limits = data.sw_limits_rad();
    let mut joints = [0.0; 6];
    for (i, (q, f)) in joints.iter_mut().zip(fields).enumerate() {
        *q = f64::from(joint_value(r, f)?).to_radians();
        // Checked here against the SW limits the PLC may have narrowed; the planner checks
        // the mechanical limits again.
        if *q < limits.lower[i] {
            return Err(code::SW_LIMIT_LOWER);
        }
        if *q > limits.upper[i] {
            return Err(code::SW_LIMIT_UPPER);
        }
    }
    Ok(joints)
}

/// A joint value (or joint distance) of a request, if it is a number.
pub(super) fn joint_value(r: &PayloadReader<'_>, f: Field) -> Result<f32, u16> {
    Some(r.f32(f))
        .filter(|v| v.is_finite())
        .ok_or(code::INVALID_JOINT_POSITION)
}

/// A Cartesian pose of a request (mm and degrees), if every value is a number.
pub(super) fn wire_pose(r: &PayloadReader<'_>, fields: [Field; 6]) -> Result<WirePose, u16> {
    let mut pose = [0.0; 6];
    for (v, f) in pose.iter_mut().zip(fields) {
        let wire = r.f32(f);
        if !wire.is_finite() {
            return Err(code::INVALID_POSITION);
        }
        *v = f64::from(wire);
    }
    Ok(pose)
}

/// Checks a MoveDirectAbsolute or MoveLinearAbsolute request and turns it into a planner
/// command: the TCP target in the world frame (m and rad) through the chain of the given
/// frame, the tool, the configuration, turns and their modes (the planner solves the IK).
fn decode_cartesian_move(
    msg: &[u8],
    h: CommandHeader,
    data: &UserData,
    layout: &CartesianLayout,
    kind: MotionCommandKind,
) -> Result<MotionCommand, u16> {
    let (mut c, target) = decode_cartesian(msg, h, data, layout, kind)?;
    c.pose = tcp_pose::world_target(data, PayloadReader::new(msg).u8(layout.frame), target)?;
    Ok(c)
}

/// Checks a Cartesian move's request: what every move shares, the configuration, turns and
/// their modes; returns the planner command without its pose, and the pose of `layout`
/// as the PLC sent it (mm and degrees), for the caller to place.
pub(super) fn decode_cartesian(
    msg: &[u8],
    h: CommandHeader,
    data: &UserData,
    layout: &CartesianLayout,
    kind: MotionCommandKind,
) -> Result<(MotionCommand, WirePose), u16> {
    let r = PayloadReader::new(msg);
    let mut c = decode_move(&r, &layout.common, h, kind, data)?;
    let target = wire_pose(&r, layout.position)?;
    // The frame is checked here for every Cartesian move; its use is the caller's.
    tcp_pose::world_frame(data, r.u8(layout.frame))?;
    c.arm_config = r.u8(layout.shoulder) | r.u8(layout.elbow) << 1 | r.u8(layout.wrist) << 2;
    c.turn_numbers = core::array::from_fn(|i| r.u8(layout.turn_number.element(i)));
    let modes = [
        r.u8(layout.config_mode.element(0)),
        r.u8(layout.config_mode.element(1)),
    ];
    // [0] low nibble shoulder, high nibble elbow; [1] low nibble wrist. The planner rejects
    // undefined values with their codes.
    c.config_modes = [modes[0] & 0x0F, modes[0] >> 4, modes[1] & 0x0F];
    c.turn_mode = r.u8(layout.turn_mode);
    Ok((c, target))
}

/// Checks a MoveLinearAbsolute request: a Cartesian move with its OriMode (0 is taken as
/// the standard, LINEAR_INTERPOLATED).
fn decode_move_linear(msg: &[u8], h: CommandHeader, data: &UserData) -> Result<MotionCommand, u16> {
    let mut c = decode_cartesian_move(msg, h, data, &MOVE_LINEAR, MotionCommandKind::MoveLinear)?;
    c.ori_mode = ori_mode(msg, mla::request::ORI_MODE)?;
    Ok(c)
}

/// The OriMode of a request: 0 (taken as the standard, LINEAR_INTERPOLATED) to 4.
pub(super) fn ori_mode(msg: &[u8], field: Field) -> Result<u8, u16> {
    match PayloadReader::new(msg).u8(field) {
        m @ 0..=4 => Ok(m),
        _ => Err(code::INVALID_ORI_MODE),
    }
}

/// Progress (percent × 100) of a move response; the moves with RemainingDistance (mm) carry
/// it too: the TCP's path length left of the running move (a line, an arc, or the curve of
/// a joint move), "no valid value" (-1) while none is known, 0 at the target. WaitTime
/// reports its ElapsedTime (ms) of `wait_ms` instead.
fn write_progress(
    w: &mut PayloadWriter<'_>,
    command_type: u16,
    progress: u16,
    remaining_mm: Option<f64>,
    wait_ms: u32,
) {
    // The Extended moves answer in the layout of MoveDirectAbsolute or MoveAxesAbsolute.
    const _: () = {
        let layouts = [
            (mla::response::PROGRESS, mla::response::REMAINING_DISTANCE),
            (mca::response::PROGRESS, mca::response::REMAINING_DISTANCE),
            (mcr::response::PROGRESS, mcr::response::REMAINING_DISTANCE),
            (mdr::response::PROGRESS, mdr::response::REMAINING_DISTANCE),
            (mlaj::response::PROGRESS, mlaj::response::REMAINING_DISTANCE),
            (mlr::response::PROGRESS, mlr::response::REMAINING_DISTANCE),
            (mdo::response::PROGRESS, mdo::response::REMAINING_DISTANCE),
            (mlo::response::PROGRESS, mlo::response::REMAINING_DISTANCE),
        ];
        let mut i = 0;
        while i < layouts.len() {
            assert!(
                layouts[i].0.offset == mda::response::PROGRESS.offset
                    && layouts[i].1.offset == mda::response::REMAINING_DISTANCE.offset
            );
            i += 1;
        }
        assert!(mar::response::PROGRESS.offset == maa::response::PROGRESS.offset);
    };
    let remaining = match remaining_mm {
        _ if progress == 10_000 => 0.0,
        Some(mm) => mm as f32,
        None => -1.0,
    };
    if command_type == rtp::TYPE {
        w.set_u16(rtp::response::PROGRESS, progress);
        w.set_f32(rtp::response::REMAINING_DISTANCE, remaining);
    } else if command_type == wt::TYPE {
        let elapsed = u64::from(wait_ms) * u64::from(progress.min(10_000)) / 10_000;
        // At most `wait_ms`, so it fits.
        w.set_u32(wt::response::ELAPSED_TIME, elapsed as u32);
    } else if WITH_REMAINING_DISTANCE.contains(&command_type) {
        w.set_u16(mda::response::PROGRESS, progress);
        w.set_f32(mda::response::REMAINING_DISTANCE, remaining);
    } else {
        w.set_u16(maa::response::PROGRESS, progress);
    }
}

impl Server {
    /// The moves and WaitTime: checked, then handed to the planner.
    pub(crate) fn move_command(
        &mut self,
        cmd_id: u16,
        h: CommandHeader,
        msg: &[u8],
        now: Now,
        fx: &mut Effects,
    ) {
        let data = &self.user_data;
        let secondary = on_secondary(h.execution_mode);
        let checked = if self.error_pending {
            Err(code::DISABLED_DUE_TO_ERROR)
        } else if !self.drives_enabled() && h.command_type != wt::TYPE {
            // A wait moves nothing: it may be queued with the drives off.
            Err(code::ROBOT_DISABLED)
        } else if secondary && !self.sequences.secondary_active() {
            Err(code::SECONDARY_NOT_ACTIVE)
        } else if secondary && self.secondary_blocked() {
            Err(code::SECONDARY_BLOCKED)
        } else {
            match h.command_type {
                mda::TYPE => {
                    decode_cartesian_move(msg, h, data, &MOVE_DIRECT, MotionCommandKind::MoveDirect)
                }
                mla::TYPE => decode_move_linear(msg, h, data),
                mar::TYPE => relative::decode_axes(msg, h, data),
                mdr::TYPE | mlr::TYPE => relative::decode_cartesian(msg, h, data),
                mlaj::TYPE => joint_line::decode(msg, h, data, &self.arm),
                mca::TYPE | mcr::TYPE => circular::decode(msg, h, data),
                mdo::TYPE | mlo::TYPE => offset::decode(msg, h, data),
                wt::TYPE => Ok(wait::decode(msg, h)),
                _ => decode_move_axes(msg, h, data),
            }
        };
        match checked {
            Ok(mut command) => {
                let wait = command.kind == MotionCommandKind::Wait as u8;
                // StepMode: every primary move holds the sequence when it ends.
                command.hold_after = !secondary && !wait && self.step_mode != 0;
                self.select_tool_and_frame(h.command_type, msg);
                self.submit_job(cmd_id, h, command, now, fx);
                // What its responses report beyond Progress: the time a wait takes, the
                // end of a line whose target is known here.
                let straight_to_target = command.kind == MotionCommandKind::MoveLinear as u8
                    && command.target_reference == TargetReference::Absolute as u8;
                if let Some(LiveKind::Job { wait_ms, line, .. }) = self
                    .live
                    .iter_mut()
                    .find(|l| l.cmd_id == cmd_id)
                    .map(|l| &mut l.kind)
                {
                    if wait {
                        *wait_ms = wait::milliseconds(msg);
                    } else if straight_to_target {
                        *line = Some(LineTarget {
                            position: [command.pose[0], command.pose[1], command.pose[2]],
                            tool: command.tool,
                        });
                    }
                }
            }
            Err(c) => self.respond(cmd_id, h, state::ERROR, c, now, |_| {}),
        }
    }

    /// The tool and frame of an accepted move become the ones in use (what -1 means to the
    /// next command and to the cyclic position); the move's decoding validated them.
    fn select_tool_and_frame(&mut self, command_type: u16, msg: &[u8]) {
        let r = PayloadReader::new(msg);
        let (tool, frame) = match command_type {
            maa::TYPE => (maa::request::TOOL_NO, None),
            mar::TYPE => (mar::request::TOOL_NO, None),
            mlaj::TYPE => (mlaj::request::TOOL_NO, None),
            mda::TYPE => (mda::request::TOOL_NO, Some(mda::request::FRAME_NO)),
            mla::TYPE => (mla::request::TOOL_NO, Some(mla::request::FRAME_NO)),
            mdr::TYPE => (mdr::request::TOOL_NO, Some(mdr::request::FRAME_NO)),
            mlr::TYPE => (mlr::request::TOOL_NO, Some(mlr::request::FRAME_NO)),
            mca::TYPE => (mca::request::TOOL_NO, Some(mca::request::FRAME_NO)),
            mcr::TYPE => (mcr::request::TOOL_NO, Some(mcr::request::FRAME_NO)),
            mdo::TYPE => (mdo::request::TOOL_NO, Some(mdo::request::FRAME_NO)),
            mlo::TYPE => (mlo::request::TOOL_NO, Some(mlo::request::FRAME_NO)),
            // WaitTime has neither.
            _ => return,
        };
        let _ = self.user_data.select_tool(r.u8(tool));
        if let Some(frame) = frame {
            let _ = self.user_data.select_frame(r.u8(frame));
        }
    }

    pub(crate) fn change_speed_override(
        &mut self,
        cmd_id: u16,
        h: CommandHeader,
        msg: &[u8],
        now: Now,
        fx: &mut Effects,
    ) {
        let wire = PayloadReader::new(msg).u16(cso::request::OVERRIDE);
        let percent = match Percent::from_wire(wire) {
            Percent::Value(p) if p <= 100.0 => p,
            _ => {
                self.respond(cmd_id, h, state::ERROR, code::INVALID_OVERRIDE, now, |_| {});
                return;
            }
        };
        self.override_percent = percent;
        let mut c = MotionCommand::new(MotionCommandKind::Override);
        c.override_fraction = percent / 100.0;
        self.submit_job(cmd_id, h, c, now, fx);
    }

    /// GroupStop, GroupInterrupt and GroupContinue: executed by the planner, DONE when it has
    /// stopped the arm (stop, interrupt) or resumed the sequence (continue).
    pub(crate) fn group_motion(
        &mut self,
        cmd_id: u16,
        h: CommandHeader,
        kind: MotionCommandKind,
        now: Now,
        fx: &mut Effects,
    ) {
        let on_secondary = self.sequences.secondary_active();
        if kind == MotionCommandKind::Continue {
            let refused = if self.error_pending {
                Some(code::DISABLED_DUE_TO_ERROR)
            } else if !self.drives_enabled() {
                Some(code::CONTINUE_NOT_ENABLED)
            } else if !on_secondary
                && !self
                    .status
                    .is_none_or(|s| self.sequences.in_primary_position(&s.joints_rad))
            {
                Some(code::NOT_IN_PRIMARY_POSITION)
            } else {
                None
            };
            if let Some(c) = refused {
                self.respond(cmd_id, h, state::ERROR, c, now, |_| {});
                return;
            }
        }
        let mut command = MotionCommand::new(kind);
        command.sequence = match kind {
            // GroupStop ends both sequences.
            MotionCommandKind::Stop => {
                self.sequences.reset();
                MotionSequence::All
            }
            _ if on_secondary => MotionSequence::Secondary,
            _ => {
                if kind == MotionCommandKind::Continue {
                    self.sequences.primary_resumed();
                }
                MotionSequence::Primary
            }
        } as u8;
        self.submit_job(cmd_id, h, command, now, fx);
    }

    /// Hands `command` to the planner as a job whose events answer command `cmd_id`.
    pub(crate) fn submit_job(
        &mut self,
        cmd_id: u16,
        h: CommandHeader,
        command: MotionCommand,
        now: Now,
        fx: &mut Effects,
    ) {
        match self.motion.submit(
            command,
            Some((cmd_id, h.par_seq, h.command_type)),
            now.mono_ms,
            &mut fx.motion,
        ) {
            Some(job) => {
                self.keep_live(
                    cmd_id,
                    h,
                    LiveKind::Job {
                        job,
                        progress: 0,
                        sent_ms: now.mono_ms,
                        aborts_moves: h.command_type == gs::TYPE
                            && self.live.iter().any(|l| is_move(l.command_type)),
                        line: None,
                        wait_ms: 0,
                        secondary: command.sequence == MotionSequence::Secondary as u8,
                    },
                );
            }
            None => self.respond(cmd_id, h, state::ERROR, code::INTERNAL_ERROR, now, |_| {}),
        }
    }

    /// A planner event (or a lost planner) changed the state of a job.
    pub(crate) fn on_job_update(&mut self, u: JobUpdate, now: Now, fx: &mut Effects) {
        let Some(i) = self.live.iter().position(|l| l.cmd_id == u.cmd_id) else {
            return;
        };
        if matches!(self.live[i].kind, LiveKind::Jog { .. }) {
            self.on_jog_update(i, u, now, fx);
            return;
        }
        let h = self.live_header(i);
        let (progress, aborts_moves, line, wait_ms) = match self.live[i].kind {
            LiveKind::Job {
                progress,
                aborts_moves,
                line,
                wait_ms,
                ..
            } => (progress, aborts_moves, line, wait_ms),
            _ => (0, false, None, 0),
        };
        let remaining = line
            .zip(self.status)
            .map(|(l, s)| l.remaining_mm(s.flange_pose));
        let primary = self.primary_pos_numbers();
        let progress = if u.state == state::DONE {
            10_000
        } else {
            progress
        };
        if u.command_type == gr::TYPE && u.state == state::DONE {
            self.error_pending = false;
        }
        // GroupStop reports whether it aborted moves of the primary sequence (1) or none (0).
        let aborted_sequence = i8::from(aborts_moves);
        let command_type = u.command_type;
        let text = u.reason.text().unwrap_or(describe(u.code));
        self.respond_telling(u.cmd_id, h, u.state, u.code, text, now, |b| {
            let mut w = PayloadWriter::new(b);
            match command_type {
                rtp::TYPE => {
                    write_progress(&mut w, command_type, progress, remaining, wait_ms);
                    write_primary_pos(&mut w, primary);
                }
                gs::TYPE => w.set_i8(gs::response::ABORTED_SEQUENCE, aborted_sequence),
                ty if is_move(ty) => {
                    write_progress(&mut w, command_type, progress, remaining, wait_ms)
                }
                _ => {}
            }
        });
    }

    /// Sends the progress of the running move, at most every 100 ms.
    pub(crate) fn refresh_motion_progress(&mut self, now: Now) {
        let Some(status) = self.status else {
            return;
        };
        if status.active_job == 0 {
            return;
        }
        let Some(i) = self
            .live
            .iter()
            .position(|l| matches!(l.kind, LiveKind::Job { job, .. } if job == status.active_job))
        else {
            return;
        };
        let LiveKind::Job {
            progress,
            sent_ms,
            line,
            wait_ms,
            ..
        } = &mut self.live[i].kind
        else {
            return;
        };
        let wait_ms = *wait_ms;
        // Clamped to 0..=100 %, so the product fits a u16.
        let now_progress = (status.active_progress.clamp(0.0, 100.0) * 100.0) as u16;
        if now_progress == *progress || now.mono_ms.saturating_sub(*sent_ms) < PROGRESS_INTERVAL_MS
        {
            return;
        }
        *progress = now_progress;
        *sent_ms = now.mono_ms;
        let line = *line;
        // The planner knows the path length left of lines and arcs; the distance to a known
        // line target serves a planner that does not report it.
        let remaining = if status.active_remaining_m.is_finite() {
            Some(status.active_remaining_m * 1000.0)
        } else {
            line.map(|l| l.remaining_mm(status.flange_pose))
        };
        let primary = self.primary_pos_numbers();
        let cmd_id = self.live[i].cmd_id;
        let h = self.live_header(i);
        let command_type = self.live[i].command_type;
        if command_type == rtp::TYPE || is_move(command_type) {
            self.respond(cmd_id, h, state::ACTIVE, 0, now, |b| {
                let mut w = PayloadWriter::new(b);
                write_progress(&mut w, command_type, now_progress, remaining, wait_ms);
                if command_type == rtp::TYPE {
                    write_primary_pos(&mut w, primary);
                }
            });
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn request(edit: impl FnOnce(&mut PayloadWriter)) -> Vec<u8> {
        let mut b = vec![0u8; maa::request::LEN];
        let mut w = PayloadWriter::new(&mut b);
        w.set_u16(maa::request::VELOCITY_RATE, 0xFFFF);
        w.set_u16(maa::request::ACCELERATION_RATE, 0xFFFF);
        w.set_u16(maa::request::DECELERATION_RATE, 0xFFFF);
        w.set_u16(maa::request::JERK_RATE, 0xFFFF);
        w.set_f32(maa::request::JOINT_POSITION_J2, 90.0);
        edit(&mut w);
        b
    }

    /// Factory user data with SW limits of at most ±3 rad and `rates` as the default
    /// dynamics.
    fn user_data(rates: u16) -> UserData {
        use crate::user_data::{DefaultDynamicsRequest, RobotBounds, SwLimits};
        let cfg = shared_types::config::Config::load(None).unwrap();
        let bounds = RobotBounds::of(&cfg.robot).0;
        let limit = 3f64.to_degrees();
        let limits = SwLimits {
            lower_deg: bounds.joint_min_deg.map(|m| m.max(-limit) as f32),
            upper_deg: bounds.joint_max_deg.map(|m| m.min(limit) as f32),
        };
        let mut data = UserData::factory(bounds);
        data.write_sw_limits(Default::default(), Some(limits))
            .unwrap();
        let rates = DefaultDynamicsRequest {
            velocity_rate: rates,
            acceleration_rate: rates,
            deceleration_rate: rates,
            jerk_rate: rates,
        };
        data.write_default_dynamics(Default::default(), rates)
            .unwrap();
        data
    }

    fn decode(msg: &[u8], h: CommandHeader) -> Result<MotionCommand, u16> {
        decode_move_axes(msg, h, &user_data(5_000))
    }

    fn header(mode: u8) -> CommandHeader {
        CommandHeader {
            command_type: maa::TYPE,
            execution_mode: mode,
            par_seq: 1,
            priority: 3,
        }
    }

    #[test]
    fn decodes_defaults_and_degrees() {
        let c = decode(&request(|_| {}), header(0)).unwrap();
        assert!((c.joints_rad[1] - core::f64::consts::FRAC_PI_2).abs() < 1e-6);
        assert_eq!(c.velocity_scale, 0.5);
        assert_eq!(c.deceleration_scale, 0.5);
        assert!(!c.aborting);
        let decelerating = decode(
            &request(|w| w.set_u16(maa::request::DECELERATION_RATE, 2_500)),
            header(0),
        )
        .unwrap();
        assert_eq!(
            (
                decelerating.acceleration_scale,
                decelerating.deceleration_scale
            ),
            (0.5, 0.25)
        );
        assert!(decode(&request(|_| {}), header(1)).unwrap().aborting);
    }

    #[test]
    fn rejects_out_of_range_parameters_with_their_codes() {
        type Edit = fn(&mut PayloadWriter);
        let cases: [(Edit, u16); 9] = [
            (
                |w| w.set_f32(maa::request::JOINT_POSITION_J1, 200.0),
                code::SW_LIMIT_UPPER,
            ),
            (
                |w| w.set_f32(maa::request::JOINT_POSITION_J6, -200.0),
                code::SW_LIMIT_LOWER,
            ),
            (
                |w| w.set_u16(maa::request::VELOCITY_RATE, 10_001),
                code::INVALID_VELOCITY_RATE,
            ),
            (
                |w| w.set_u16(maa::request::ACCELERATION_RATE, 20_000),
                code::INVALID_ACCELERATION_RATE,
            ),
            (
                |w| w.set_u16(maa::request::DECELERATION_RATE, 10_001),
                code::INVALID_DECELERATION_RATE,
            ),
            (
                |w| {
                    w.set_u8(maa::request::BLENDING_MODE, 3);
                    w.set_f32(maa::request::BLENDING_PARAMETER.element(1), -1.0);
                },
                code::INVALID_BLENDING_PARAMETER,
            ),
            (
                |w| w.set_u8(maa::request::BLENDING_MODE, 7),
                code::INVALID_BLENDING_MODE,
            ),
            (
                |w| w.set_f32(maa::request::JOINT_POSITION_J1, f32::NAN),
                code::INVALID_JOINT_POSITION,
            ),
            (
                |w| w.set_u8(maa::request::TOOL_NO, 16),
                code::INVALID_TOOL_NO,
            ),
        ];
        for (edit, expected) in cases {
            assert_eq!(decode(&request(edit), header(0)).unwrap_err(), expected);
        }
    }

    #[test]
    fn blending_reaches_the_planner_in_si_units() {
        let c = decode(
            &request(|w| {
                w.set_u8(maa::request::BLENDING_MODE, 11);
                w.set_f32(maa::request::BLENDING_PARAMETER.element(0), 40.0);
            }),
            header(0),
        )
        .unwrap();
        assert_eq!((c.blending_mode, c.blending_parameter), (11, [0.4, 0.0]));
    }

    #[test]
    fn a_zero_default_rate_means_minimal_velocity_too() {
        // Found by fuzzing: WriteRobotDefaultDynamics with 0 % made default-rate moves
        // reach the planner with a velocity scale of 0.
        let c = decode_move_axes(&request(|_| {}), header(0), &user_data(0)).unwrap();
        assert_eq!(
            (c.velocity_scale, c.acceleration_scale, c.jerk_scale),
            (0.01, 0.01, 0.01)
        );
    }

    #[test]
    fn zero_rate_means_minimal_velocity() {
        let c = decode(
            &request(|w| w.set_u16(maa::request::VELOCITY_RATE, 0)),
            header(0),
        )
        .unwrap();
        assert_eq!(c.velocity_scale, 0.01);
    }
}

#[cfg(test)]
mod cartesian_tests {
    use super::*;
    use crate::user_data::{FrameData, RobotBounds, ToolData};

    fn header() -> CommandHeader {
        CommandHeader {
            command_type: mla::TYPE,
            execution_mode: 0,
            par_seq: 1,
            priority: 3,
        }
    }

    fn linear(edit: impl FnOnce(&mut PayloadWriter)) -> Vec<u8> {
        let mut b = vec![0u8; mla::request::LEN];
        let mut w = PayloadWriter::new(&mut b);
        for f in [
            mla::request::VELOCITY_RATE,
            mla::request::ACCELERATION_RATE,
            mla::request::DECELERATION_RATE,
            mla::request::JERK_RATE,
        ] {
            w.set_u16(f, 0xFFFF);
        }
        w.set_u8(mla::request::ORI_MODE, 1);
        for (f, v) in mla::request::POSITION_X_RZ
            .into_iter()
            .zip([400.0, 0.0, 300.0, 180.0, 0.0, 0.0])
        {
            w.set_f32(f, v);
        }
        edit(&mut w);
        b
    }

    #[test]
    fn a_target_in_a_user_frame_reaches_the_planner_in_the_world_with_the_tool() {
        let cfg = shared_types::config::Config::load(None).unwrap();
        let mut data = UserData::factory(RobotBounds::of(&cfg.robot).0);
        // Frame 2: 100 mm along world X, turned 90° about Z. Tool 3: 150 mm along flange Z.
        let frame = FrameData {
            pose: [100.0, 0.0, 0.0, 0.0, 0.0, 90.0],
            ..Default::default()
        };
        data.write_frame(2, Default::default(), frame).unwrap();
        let tool = ToolData {
            pose: [0.0, 0.0, 150.0, 0.0, 0.0, 0.0],
            ..Default::default()
        };
        data.write_tool(3, Default::default(), tool, false).unwrap();
        let msg = linear(|w| {
            w.set_u8(mla::request::FRAME_NO, 2);
            w.set_u8(mla::request::TOOL_NO, 3);
        });
        let c = decode_move_linear(&msg, header(), &data).unwrap();
        assert_eq!(c.kind, MotionCommandKind::MoveLinear as u8);
        assert_eq!(c.ori_mode, 1);
        // (400, 0) in the frame is (100, 400) in the world.
        let expected = [0.1, 0.4, 0.3];
        for (a, b) in c.pose.iter().zip(expected) {
            assert!((a - b).abs() < 1e-6, "{:?}", c.pose);
        }
        assert!((c.tool[2] - 0.15).abs() < 1e-9, "{:?}", c.tool);

        let undefined = linear(|w| w.set_u8(mla::request::ORI_MODE, 5));
        assert_eq!(
            decode_move_linear(&undefined, header(), &data).unwrap_err(),
            code::INVALID_ORI_MODE
        );
        let no_frame = linear(|w| w.set_u8(mla::request::FRAME_NO, 40));
        assert_eq!(
            decode_move_linear(&no_frame, header(), &data).unwrap_err(),
            code::INVALID_FRAME_NO
        );
    }
}
