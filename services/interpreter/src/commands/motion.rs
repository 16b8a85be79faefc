//! Commands executed by the planner: MoveAxesAbsolute, ChangeSpeedOverride (and GroupReset's
//! planner part), with their job updates and progress.

use shared_types::ipc::{MotionCommand, MotionCommandKind};
use shared_types::srci::message::{CommandHeader, Percent, code, execution_mode, state};
use shared_types::srci::payload::{Field, PayloadReader, PayloadWriter};
use shared_types::srci::tables::{
    change_speed_override as cso, group_reset as gr, group_stop as gs, move_axes_absolute as maa,
    move_direct_absolute as mda,
};

use super::LiveKind;
use crate::motion_link::JobUpdate;
use crate::server::{Effects, Now, Server};
use crate::user_data::CURRENT_INDEX;
use crate::user_data::{DefaultRates, SwLimitsRad};

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

/// Where the parameters every move command shares sit in its request table.
struct MoveLayout {
    velocity: Field,
    acceleration: Field,
    deceleration: Field,
    jerk: Field,
    tool: Field,
    blending_mode: Field,
    time: Field,
}

const MOVE_AXES: MoveLayout = MoveLayout {
    velocity: maa::request::VELOCITY_RATE,
    acceleration: maa::request::ACCELERATION_RATE,
    deceleration: maa::request::DECELERATION_RATE,
    jerk: maa::request::JERK_RATE,
    tool: maa::request::TOOL_NO,
    blending_mode: maa::request::BLENDING_MODE,
    time: maa::request::TIME,
};

const MOVE_DIRECT: MoveLayout = MoveLayout {
    velocity: mda::request::VELOCITY_RATE,
    acceleration: mda::request::ACCELERATION_RATE,
    deceleration: mda::request::DECELERATION_RATE,
    jerk: mda::request::JERK_RATE,
    tool: mda::request::TOOL_NO,
    blending_mode: mda::request::BLENDING_MODE,
    time: mda::request::TIME,
};

/// Checks what every move shares (rates, tool, blending, time, execution mode) and returns a
/// planner command of `kind` with them; rates left at default take the default dynamics.
fn decode_move(
    r: &PayloadReader<'_>,
    layout: &MoveLayout,
    h: CommandHeader,
    kind: MotionCommandKind,
    defaults: DefaultRates,
) -> Result<MotionCommand, u16> {
    let velocity = rate(
        r.u16(layout.velocity),
        defaults.velocity,
        code::INVALID_VELOCITY_RATE,
    )?;
    let acceleration = rate(
        r.u16(layout.acceleration),
        defaults.acceleration,
        code::INVALID_ACCELERATION_RATE,
    )?;
    if r.u16(layout.deceleration) != 0xFFFF {
        return Err(code::DECELERATION_RATE_NOT_SUPPORTED);
    }
    let jerk = rate(r.u16(layout.jerk), defaults.jerk, code::INVALID_JERK_RATE)?;
    let tool = r.u8(layout.tool);
    if tool != 0 && tool != CURRENT_INDEX {
        return Err(code::TOOL_NOT_EXISTING);
    }
    match r.u8(layout.blending_mode) {
        0 => {}
        2 | 3 | 4 | 10 | 11 | 12 => return Err(code::BLENDING_MODE_NOT_SUPPORTED),
        _ => return Err(code::INVALID_BLENDING_MODE),
    }
    let mut c = MotionCommand::new(kind);
    c.aborting = h.execution_mode == execution_mode::SEQUENCE_ABORT_OTHERS_PRIMARY;
    c.velocity_scale = velocity;
    c.acceleration_scale = acceleration;
    c.jerk_scale = jerk;
    c.duration_s = f64::from(r.u16(layout.time)) / 1000.0;
    Ok(c)
}

/// Checks a MoveAxesAbsolute request and turns it into a planner command; targets must lie
/// within the SW limits.
fn decode_move_axes(
    msg: &[u8],
    h: CommandHeader,
    defaults: DefaultRates,
    limits: SwLimitsRad,
) -> Result<MotionCommand, u16> {
    let r = PayloadReader::new(msg);
    let mut c = decode_move(&r, &MOVE_AXES, h, MotionCommandKind::MoveAxes, defaults)?;
    for (i, (q, f)) in c
        .joints_rad
        .iter_mut()
        .zip(maa::request::JOINT_POSITION_J1_J6)
        .enumerate()
    {
        let deg = r.f32(f);
        if !deg.is_finite() {
            return Err(code::INVALID_JOINT_POSITION);
        }
        *q = f64::from(deg).to_radians();
        // Checked here against the SW limits the PLC may have narrowed; the planner checks
        // the mechanical limits again.
        if *q < limits.lower[i] {
            return Err(code::SW_LIMIT_LOWER);
        }
        if *q > limits.upper[i] {
            return Err(code::SW_LIMIT_UPPER);
        }
    }
    Ok(c)
}

/// Checks a MoveDirectAbsolute request and turns it into a planner command: the flange pose
/// in m and rad, with the configuration, turns and their modes (the planner solves the IK).
fn decode_move_direct(
    msg: &[u8],
    h: CommandHeader,
    defaults: DefaultRates,
) -> Result<MotionCommand, u16> {
    let r = PayloadReader::new(msg);
    let mut c = decode_move(&r, &MOVE_DIRECT, h, MotionCommandKind::MoveDirect, defaults)?;
    let frame = r.u8(mda::request::FRAME_NO);
    if frame != 0 && frame != CURRENT_INDEX {
        return Err(code::FRAME_NOT_EXISTING);
    }
    for (i, (v, f)) in c
        .pose
        .iter_mut()
        .zip(mda::request::POSITION_X_RZ)
        .enumerate()
    {
        let wire = f64::from(r.f32(f));
        if !wire.is_finite() {
            return Err(code::INVALID_POSITION);
        }
        *v = if i < 3 {
            wire / 1000.0
        } else {
            wire.to_radians()
        };
    }
    c.arm_config = r.u8(mda::request::SHOULDER)
        | r.u8(mda::request::ELBOW) << 1
        | r.u8(mda::request::WRIST) << 2;
    c.turn_numbers = core::array::from_fn(|i| r.u8(mda::request::POSITION_TURN_NUMBER.element(i)));
    let modes = [
        r.u8(mda::request::CONFIG_MODE.element(0)),
        r.u8(mda::request::CONFIG_MODE.element(1)),
    ];
    // [0] low nibble shoulder, high nibble elbow; [1] low nibble wrist. The planner rejects
    // undefined values with their codes.
    c.config_modes = [modes[0] & 0x0F, modes[0] >> 4, modes[1] & 0x0F];
    c.turn_mode = r.u8(mda::request::TURN_MODE);
    Ok(c)
}

/// Progress (percent × 100) of a MoveAxesAbsolute or MoveDirectAbsolute response; the
/// latter also carries RemainingDistance, which joint-interpolated moves do not track:
/// -1 means "no valid value", 0 "target reached".
fn write_progress(w: &mut PayloadWriter<'_>, command_type: u16, progress: u16) {
    if command_type == mda::TYPE {
        w.set_u16(mda::response::PROGRESS, progress);
        let remaining = if progress == 10_000 { 0.0 } else { -1.0 };
        w.set_f32(mda::response::REMAINING_DISTANCE, remaining);
    } else {
        w.set_u16(maa::response::PROGRESS, progress);
    }
}

impl Server {
    /// MoveAxesAbsolute and MoveDirectAbsolute: checked, then handed to the planner.
    pub(crate) fn move_command(
        &mut self,
        cmd_id: u16,
        h: CommandHeader,
        msg: &[u8],
        now: Now,
        fx: &mut Effects,
    ) {
        let defaults = self.user_data.default_rates();
        let checked = if self.error_pending {
            Err(code::DISABLED_DUE_TO_ERROR)
        } else if !self.drives_enabled() {
            Err(code::ROBOT_DISABLED)
        } else if h.command_type == mda::TYPE {
            decode_move_direct(msg, h, defaults)
        } else {
            decode_move_axes(msg, h, defaults, self.user_data.sw_limits_rad())
        };
        match checked {
            Ok(command) => self.submit_job(cmd_id, h, command, now, fx),
            Err(c) => self.respond(cmd_id, h, state::ERROR, c, now, |_| {}),
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
        if kind == MotionCommandKind::Continue {
            let refused = if self.error_pending {
                Some(code::DISABLED_DUE_TO_ERROR)
            } else if !self.drives_enabled() {
                Some(code::CONTINUE_NOT_ENABLED)
            } else {
                None
            };
            if let Some(c) = refused {
                self.respond(cmd_id, h, state::ERROR, c, now, |_| {});
                return;
            }
        }
        self.submit_job(cmd_id, h, MotionCommand::new(kind), now, fx);
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
                            && self.live.iter().any(|l| l.command_type == maa::TYPE),
                    },
                );
            }
            None => self.respond(cmd_id, h, state::ERROR, code::INTERNAL_ERROR, now, |_| {}),
        }
    }

    /// A planner event (or a lost planner) changed the state of a job.
    pub(crate) fn on_job_update(&mut self, u: JobUpdate, now: Now, _fx: &mut Effects) {
        let Some(i) = self.live.iter().position(|l| l.cmd_id == u.cmd_id) else {
            return;
        };
        if matches!(self.live[i].kind, LiveKind::Jog { .. }) {
            self.on_jog_update(i, u, now);
            return;
        }
        let h = self.live_header(i);
        let (progress, aborts_moves) = match self.live[i].kind {
            LiveKind::Job {
                progress,
                aborts_moves,
                ..
            } => (progress, aborts_moves),
            _ => (0, false),
        };
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
        self.respond(u.cmd_id, h, u.state, u.code, now, |b| {
            let mut w = PayloadWriter::new(b);
            match command_type {
                maa::TYPE | mda::TYPE => write_progress(&mut w, command_type, progress),
                gs::TYPE => w.set_i8(gs::response::ABORTED_SEQUENCE, aborted_sequence),
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
            job,
            progress,
            sent_ms,
            aborts_moves,
        } = self.live[i].kind
        else {
            return;
        };
        // Clamped to 0..=100 %, so the product fits a u16.
        let now_progress = (status.active_progress.clamp(0.0, 100.0) * 100.0) as u16;
        if now_progress == progress || now.mono_ms.saturating_sub(sent_ms) < PROGRESS_INTERVAL_MS {
            return;
        }
        self.live[i].kind = LiveKind::Job {
            job,
            progress: now_progress,
            sent_ms: now.mono_ms,
            aborts_moves,
        };
        let cmd_id = self.live[i].cmd_id;
        let h = self.live_header(i);
        let command_type = self.live[i].command_type;
        if matches!(command_type, maa::TYPE | mda::TYPE) {
            self.respond(cmd_id, h, state::ACTIVE, 0, now, |b| {
                write_progress(&mut PayloadWriter::new(b), command_type, now_progress);
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

    fn decode(msg: &[u8], h: CommandHeader) -> Result<MotionCommand, u16> {
        let defaults = DefaultRates {
            velocity: 50.0,
            acceleration: 50.0,
            deceleration: 50.0,
            jerk: 100.0,
        };
        let limits = SwLimitsRad {
            lower: [-3.0; 6],
            upper: [3.0; 6],
        };
        decode_move_axes(msg, h, defaults, limits)
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
        assert!(!c.aborting);
        assert!(decode(&request(|_| {}), header(1)).unwrap().aborting);
    }

    #[test]
    fn rejects_out_of_range_parameters_with_their_codes() {
        type Edit = fn(&mut PayloadWriter);
        let cases: [(Edit, u16); 8] = [
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
                |w| w.set_u16(maa::request::DECELERATION_RATE, 5_000),
                code::DECELERATION_RATE_NOT_SUPPORTED,
            ),
            (
                |w| w.set_u8(maa::request::BLENDING_MODE, 3),
                code::BLENDING_MODE_NOT_SUPPORTED,
            ),
            (
                |w| w.set_u8(maa::request::BLENDING_MODE, 7),
                code::INVALID_BLENDING_MODE,
            ),
            (
                |w| w.set_f32(maa::request::JOINT_POSITION_J1, f32::NAN),
                code::INVALID_JOINT_POSITION,
            ),
        ];
        for (edit, expected) in cases {
            assert_eq!(decode(&request(edit), header(0)).unwrap_err(), expected);
        }
    }

    #[test]
    fn a_zero_default_rate_means_minimal_velocity_too() {
        // Found by fuzzing: WriteRobotDefaultDynamics with 0 % made default-rate moves
        // reach the planner with a velocity scale of 0.
        let defaults = DefaultRates {
            velocity: 0.0,
            acceleration: 0.0,
            deceleration: 0.0,
            jerk: 0.0,
        };
        let limits = SwLimitsRad {
            lower: [-3.0; 6],
            upper: [3.0; 6],
        };
        let c = decode_move_axes(&request(|_| {}), header(0), defaults, limits).unwrap();
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
