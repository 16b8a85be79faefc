//! GroupJog: an Enable-type command whose direction bits move the arm while they are set
//! (continuous) or by a distance (incremental), at the jog override, on the secondary
//! sequence.
//!
//! Each change of the direction bits halts the jog motion on its path and, if bits remain,
//! starts a new move. In joint mode it is a joint move: continuous jogging heads for the
//! joint limit, incremental jogging moves by IncrementalRotation degrees. In frame and tool
//! mode it is a straight TCP line along (or a turn about) the axes of FrameNo or of the tool
//! ToolNo: incremental by IncrementalTranslation mm / IncrementalRotation degrees; continuous
//! towards a point 400 mm (90°) away, which the planner checks before the arm moves; where
//! that is out of reach or beyond a limit, the step is halved (up to six times) so that the
//! arm still jogs up to near the edge. The response stays ACTIVE with Enabled, MotionActive
//! and DistanceReached; Enable = FALSE ends the command DONE.

use shared_types::ipc::{AXES, MotionCommand, MotionCommandKind, MotionSequence};
use shared_types::srci::message::{CommandHeader, Percent, code, state};
use shared_types::srci::payload::{Field, PayloadReader, PayloadWriter};
use shared_types::srci::tables::group_jog as gj;

use shared_types::pose;

use super::LiveKind;
use crate::cartesian_jog::{self, JogStep};
use crate::motion_link::JobUpdate;
use crate::server::{Effects, Now, Server};
use crate::tcp_pose;

/// JogMode: frame, tool, joint (axis) jogging.
const JOG_FRAME: u8 = 0;
const JOG_TOOL: u8 = 1;
const JOG_AXES: u8 = 2;
/// How far a continuous frame or tool jog heads for (m, rad) before it is halved.
const CONTINUOUS_DISTANCE_M: f64 = 0.4;
const CONTINUOUS_ANGLE_RAD: f64 = core::f64::consts::FRAC_PI_2;
/// How often a continuous frame or tool jog halves its step before it gives up.
const HALVINGS: u8 = 6;
/// Continuous jogging stops this far inside the joint limit (rad).
const LIMIT_MARGIN: f64 = 0.5 * core::f64::consts::PI / 180.0;
/// Acceleration share of the joint limits while jogging.
const JOG_ACCELERATION: f64 = 0.5;

/// The positive and negative direction bit of each joint.
const DIRECTIONS: [(Field, Field); AXES] = [
    (gj::request::X_J1_POS, gj::request::X_J1_NEG),
    (gj::request::Y_J2_POS, gj::request::Y_J2_NEG),
    (gj::request::Z_J3_POS, gj::request::Z_J3_NEG),
    (gj::request::RX_J4_POS, gj::request::RX_J4_NEG),
    (gj::request::RY_J5_POS, gj::request::RY_J5_NEG),
    (gj::request::RZ_J6_POS, gj::request::RZ_J6_NEG),
];

/// A frame or tool jog in progress: its step, tool, frame and speed, and how often it may
/// still halve the step.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct CartesianJog {
    pub step: JogStep,
    pub tool_no: u8,
    pub frame_no: u8,
    pub velocity_scale: f64,
    pub halvings_left: u8,
}

/// A decoded GroupJog request.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct JogRequest {
    pub enable: bool,
    /// JogMode: [`JOG_FRAME`], [`JOG_TOOL`] or [`JOG_AXES`].
    pub mode: u8,
    pub tool_no: u8,
    pub frame_no: u8,
    /// Incremental translation in m (frame and tool mode); 0 = continuous.
    pub translation: f64,
    /// Per joint: +1, -1 or 0.
    pub directions: [i8; AXES],
    /// Fraction of the joint velocity limits, (0, 1].
    pub velocity_scale: f64,
    /// Incremental distance in rad; 0 = continuous.
    pub increment: f64,
}

/// Checks a GroupJog request and returns it, or the code that refuses it.
pub(crate) fn decode_jog(msg: &[u8]) -> Result<JogRequest, u16> {
    let r = PayloadReader::new(msg);
    let enable = r.bit(gj::request::ENABLE);
    let mode = r.u8(gj::request::MODE);
    if !matches!(mode, JOG_FRAME | JOG_TOOL | JOG_AXES) {
        return Err(code::INVALID_MODE);
    }
    let translation = f64::from(r.f32(gj::request::INCREMENTAL_TRANSLATION));
    if !translation.is_finite() || translation < 0.0 {
        return Err(code::INVALID_INCREMENTAL_TRANSLATION);
    }
    let mut directions = [0i8; AXES];
    for (d, (pos, neg)) in directions.iter_mut().zip(DIRECTIONS) {
        *d = match (r.bit(pos), r.bit(neg)) {
            (true, true) => return Err(code::JOG_BOTH_DIRECTIONS),
            (true, false) => 1,
            (false, true) => -1,
            (false, false) => 0,
        };
    }
    let override_percent = match Percent::from_wire(r.u16(gj::request::OVERRIDE)) {
        Percent::Default => 10.0,
        Percent::Value(p) if p <= 100.0 => p,
        Percent::Value(_) => return Err(code::INVALID_OVERRIDE),
    };
    let increment = f64::from(r.f32(gj::request::INCREMENTAL_ROTATION));
    if !increment.is_finite() || increment < 0.0 {
        return Err(code::INVALID_INCREMENTAL_ROTATION);
    }
    Ok(JogRequest {
        enable,
        mode,
        tool_no: r.u8(gj::request::TOOL_NO),
        frame_no: r.u8(gj::request::FRAME_NO),
        translation: translation / 1000.0,
        directions,
        // 0 % means no movement: the move is simply not started.
        velocity_scale: override_percent / 100.0,
        increment: increment.to_radians(),
    })
}

/// What ends a jog motion by itself, and what its GroupJog reports when it does.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum JogEnd {
    /// A continuous frame or tool jog's step: ends quietly (the keys are still pressed).
    Step,
    /// An incremental jog's distance: DistanceReached.
    Distance,
    /// A joint jog at the SW limit (continuous, or an increment the limit cuts short):
    /// 0x6C04, SW limit reached.
    SwLimit,
}

impl JogRequest {
    fn moves(&self) -> bool {
        self.enable && self.velocity_scale > 0.0 && self.directions.iter().any(|d| *d != 0)
    }

    /// Whether it moves by a given distance rather than while the bits are set.
    fn incremental(&self) -> bool {
        self.increment > 0.0 || (self.mode != JOG_AXES && self.translation > 0.0)
    }

    /// The frame or tool jog it asks for (`None` in joint mode).
    fn cartesian(&self) -> Option<CartesianJog> {
        if self.mode == JOG_AXES {
            return None;
        }
        let (distance_m, angle_rad, halvings_left) = if self.incremental() {
            (self.translation, self.increment, 0)
        } else {
            (CONTINUOUS_DISTANCE_M, CONTINUOUS_ANGLE_RAD, HALVINGS)
        };
        Some(CartesianJog {
            step: JogStep {
                in_tool: self.mode == JOG_TOOL,
                directions: self.directions,
                distance_m,
                angle_rad,
            },
            tool_no: self.tool_no,
            frame_no: self.frame_no,
            velocity_scale: self.velocity_scale,
            halvings_left,
        })
    }

    /// The joint target of this jog from `q` within `[min, max]`, and what ends it there.
    fn target(&self, q: [f64; AXES], min: [f64; AXES], max: [f64; AXES]) -> ([f64; AXES], JogEnd) {
        let mut end = JogEnd::Distance;
        let target = core::array::from_fn(|i| {
            let (lo, hi) = (min[i] + LIMIT_MARGIN, max[i] - LIMIT_MARGIN);
            let goal = match self.directions[i] {
                0 => return q[i],
                d if self.increment > 0.0 => q[i] + f64::from(d) * self.increment,
                1 => hi,
                _ => lo,
            };
            let kept = goal.clamp(lo.min(q[i]), hi.max(q[i]));
            if self.increment <= 0.0 || kept != goal {
                end = JogEnd::SwLimit;
            }
            kept
        });
        (target, end)
    }

    /// What ends a frame or tool jog by itself.
    fn cartesian_end(&self) -> JogEnd {
        if self.incremental() {
            JogEnd::Distance
        } else {
            JogEnd::Step
        }
    }
}

impl Server {
    pub(crate) fn group_jog(
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
            LiveKind::Jog {
                job: 0,
                end: JogEnd::Step,
                cartesian: None,
            },
        );
        self.update_group_jog(i, msg, now, fx);
    }

    pub(crate) fn update_group_jog(&mut self, i: usize, msg: &[u8], now: Now, fx: &mut Effects) {
        let cmd_id = self.live[i].cmd_id;
        let h = self.live_header(i);
        let LiveKind::Jog { job: running, .. } = self.live[i].kind else {
            return;
        };
        let request = match decode_jog(msg) {
            Ok(r) => r,
            Err(c) => return self.respond(cmd_id, h, state::ERROR, c, now, |_| {}),
        };
        // Moves held by GroupInterrupt do not count: jogging is the secondary sequence's
        // way to move the arm while the primary one is held.
        let busy = self.status.is_some_and(|s| {
            (s.active_job != 0 && s.active_job != running)
                || (s.queued_jobs > 0 && !s.sequence_paused)
        });
        if request.moves() && busy {
            return self.respond(
                cmd_id,
                h,
                state::ERROR,
                code::JOG_DURING_MOTION,
                now,
                |_| {},
            );
        }
        if request.moves() && !self.drives_enabled() {
            return self.respond(cmd_id, h, state::ERROR, code::ROBOT_DISABLED, now, |_| {});
        }
        if running != 0 {
            // The previous jog motion stops on its path; its job ends ABORTED quietly.
            self.halt_secondary(now, fx);
        }
        if !request.enable {
            self.respond(cmd_id, h, state::DONE, 0, now, |_| {});
            return;
        }
        let cartesian = request.cartesian();
        let (mut job, mut end) = (0, request.cartesian_end());
        if request.moves() {
            let submitted = match cartesian {
                Some(jog) => self
                    .submit_cartesian_jog(cmd_id, h, &jog, now, fx)
                    .map(|job| (job, end)),
                None => self.submit_joint_jog(cmd_id, h, &request, now, fx),
            };
            match submitted {
                Ok(started) => (job, end) = started,
                Err(c) => return self.respond(cmd_id, h, state::ERROR, c, now, |_| {}),
            }
            // Jogging away from held primary moves is an excursion: they continue only from
            // where they were left (InPrimaryPos, ReturnToPrimary), not from wherever the jog
            // ended.
            if self.primary_held()
                && let Some(here) = self.primary_position_here()
            {
                self.sequences.left_primary(here);
            }
        }
        self.live[i].kind = LiveKind::Jog {
            job,
            end,
            cartesian,
        };
        self.respond(cmd_id, h, state::ACTIVE, 0, now, |b| {
            let mut w = PayloadWriter::new(b);
            w.set_bit(gj::response::ENABLED, true);
            w.set_bit(gj::response::MOTION_ACTIVE, job != 0);
        });
    }

    /// A joint jog move; returns its job and what ends it, or the code that refuses it.
    fn submit_joint_jog(
        &mut self,
        cmd_id: u16,
        h: CommandHeader,
        request: &JogRequest,
        now: Now,
        fx: &mut Effects,
    ) -> Result<(u32, JogEnd), u16> {
        let status = self.status.ok_or(code::INTERNAL_ERROR)?;
        let limits = self.user_data.sw_limits_rad();
        let mut c = MotionCommand::new(MotionCommandKind::MoveAxes);
        let (target, end) = request.target(status.joints_rad, limits.lower, limits.upper);
        c.joints_rad = target;
        c.velocity_scale = request.velocity_scale;
        Ok((self.submit_jog_move(cmd_id, h, c, now, fx)?, end))
    }

    /// A frame or tool jog step: a straight TCP line from where the TCP is; returns its job
    /// or the code that refuses it (a tool or frame that does not exist).
    fn submit_cartesian_jog(
        &mut self,
        cmd_id: u16,
        h: CommandHeader,
        jog: &CartesianJog,
        now: Now,
        fx: &mut Effects,
    ) -> Result<u32, u16> {
        let status = self.status.ok_or(code::INTERNAL_ERROR)?;
        let tool = tcp_pose::tool_offset(&self.user_data, jog.tool_no)?;
        let frame = tcp_pose::world_frame(&self.user_data, jog.frame_no)?;
        let tcp = pose::isometry(status.flange_pose) * pose::isometry(tool);
        let mut c = MotionCommand::new(MotionCommandKind::MoveLinear);
        c.pose = pose::pose(&cartesian_jog::target(&tcp, &frame, &jog.step));
        c.tool = tool;
        c.ori_mode = 1;
        c.velocity_scale = jog.velocity_scale;
        c.tcp_reference = self.user_data.reference_shares();
        self.submit_jog_move(cmd_id, h, c, now, fx)
    }

    /// Hands a jog move to the planner on the secondary sequence, within the SW limits.
    fn submit_jog_move(
        &mut self,
        cmd_id: u16,
        h: CommandHeader,
        mut c: MotionCommand,
        now: Now,
        fx: &mut Effects,
    ) -> Result<u32, u16> {
        let limits = self.user_data.sw_limits_rad();
        c.sequence = MotionSequence::Secondary as u8;
        c.acceleration_scale = JOG_ACCELERATION;
        c.deceleration_scale = JOG_ACCELERATION;
        c.sw_lower_rad = limits.lower;
        c.sw_upper_rad = limits.upper;
        self.motion
            .submit(
                c,
                Some((cmd_id, h.par_seq, gj::TYPE)),
                now.mono_ms,
                &mut fx.motion,
            )
            .ok_or(code::INTERNAL_ERROR)
    }

    /// Stops the secondary sequence's motion on its path (a jog, ReturnToPrimary, secondary
    /// moves), so that moves the primary sequence holds stay.
    pub(crate) fn halt_secondary(&mut self, now: Now, fx: &mut Effects) {
        let mut halt = MotionCommand::new(MotionCommandKind::Halt);
        halt.sequence = MotionSequence::Secondary as u8;
        let _ = self.motion.submit(halt, None, now.mono_ms, &mut fx.motion);
    }

    /// The drives went off: a jog ends (0x8C03) and the secondary sequence stops, as the
    /// planner holds whatever ran and a held secondary move would block the primary one.
    pub(crate) fn on_drives_off(&mut self, now: Now, fx: &mut Effects) {
        self.end_jogs(code::ROBOT_DISABLED, now, fx);
        if self.live.iter().any(|l| {
            matches!(
                l.kind,
                LiveKind::Job {
                    secondary: true,
                    ..
                }
            )
        }) {
            self.halt_secondary(now, fx);
        }
    }

    /// Ends every running GroupJog with `code` and stops its motion on the path (the PLC that
    /// held the jog buttons is gone).
    pub(crate) fn end_jogs(&mut self, code: u16, now: Now, fx: &mut Effects) {
        while let Some(i) = self
            .live
            .iter()
            .position(|l| matches!(l.kind, LiveKind::Jog { .. }))
        {
            if let LiveKind::Jog { job, .. } = self.live[i].kind
                && job != 0
            {
                self.halt_secondary(now, fx);
            }
            let (cmd_id, h) = (self.live[i].cmd_id, self.live_header(i));
            self.respond(cmd_id, h, state::ERROR, code, now, |_| {});
        }
    }

    /// A state change of the jog motion: the GroupJog command stays ACTIVE and reports
    /// whether the arm moves and whether an incremental distance was reached.
    pub(crate) fn on_jog_update(&mut self, i: usize, u: JobUpdate, now: Now, fx: &mut Effects) {
        let LiveKind::Jog {
            job,
            end,
            cartesian,
        } = self.live[i].kind
        else {
            return;
        };
        if u.job != job {
            return;
        }
        let h = self.live_header(i);
        let too_far = matches!(
            u.code,
            code::TARGET_UNREACHABLE | code::SW_LIMIT_LOWER | code::SW_LIMIT_UPPER
        );
        if u.state == state::ERROR
            && too_far
            && let Some(jog) = cartesian.filter(|j| j.halvings_left > 0)
        {
            // The planner refused before moving: a shorter continuous step, from here.
            let shorter = CartesianJog {
                step: jog.step.halved(),
                halvings_left: jog.halvings_left - 1,
                ..jog
            };
            let job = match self.submit_cartesian_jog(u.cmd_id, h, &shorter, now, fx) {
                Ok(job) => job,
                Err(c) => return self.respond(u.cmd_id, h, state::ERROR, c, now, |_| {}),
            };
            self.live[i].kind = LiveKind::Jog {
                job,
                end,
                cartesian: Some(shorter),
            };
            return;
        }
        if u.state == state::ERROR {
            self.respond(u.cmd_id, h, state::ERROR, u.code, now, |_| {});
            return;
        }
        let active = !state::is_final(u.state);
        if !active {
            self.live[i].kind = LiveKind::Jog {
                job: 0,
                end,
                cartesian,
            };
        }
        let done = u.state == state::DONE;
        let reached = done && end == JogEnd::Distance;
        let code = if done && end == JogEnd::SwLimit {
            code::SW_LIMIT_REACHED
        } else {
            0
        };
        self.respond(u.cmd_id, h, state::ACTIVE, code, now, |b| {
            let mut w = PayloadWriter::new(b);
            w.set_bit(gj::response::ENABLED, true);
            w.set_bit(gj::response::MOTION_ACTIVE, active);
            w.set_bit(gj::response::DISTANCE_REACHED, reached);
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn request(edit: impl FnOnce(&mut PayloadWriter)) -> Vec<u8> {
        let mut b = vec![0u8; gj::request::LEN];
        let mut w = PayloadWriter::new(&mut b);
        w.set_bit(gj::request::ENABLE, true);
        w.set_u8(gj::request::MODE, JOG_AXES);
        w.set_u16(gj::request::OVERRIDE, 5000);
        edit(&mut w);
        b
    }

    #[test]
    fn decodes_directions_override_and_increment() {
        let r = decode_jog(&request(|w| {
            w.set_bit(gj::request::Y_J2_POS, true);
            w.set_bit(gj::request::RZ_J6_NEG, true);
            w.set_f32(gj::request::INCREMENTAL_ROTATION, 5.0);
        }))
        .unwrap();
        assert_eq!(r.directions, [0, 1, 0, 0, 0, -1]);
        assert_eq!(r.velocity_scale, 0.5);
        assert!((r.increment - 5f64.to_radians()).abs() < 1e-12);
        assert!(r.moves());
    }

    #[test]
    fn refuses_with_the_reference_codes() {
        let both = request(|w| {
            w.set_bit(gj::request::X_J1_POS, true);
            w.set_bit(gj::request::X_J1_NEG, true);
        });
        assert_eq!(decode_jog(&both), Err(code::JOG_BOTH_DIRECTIONS));
        let undefined = request(|w| w.set_u8(gj::request::MODE, 3));
        assert_eq!(decode_jog(&undefined), Err(code::INVALID_MODE));
        let backwards = request(|w| w.set_f32(gj::request::INCREMENTAL_TRANSLATION, -1.0));
        assert_eq!(
            decode_jog(&backwards),
            Err(code::INVALID_INCREMENTAL_TRANSLATION)
        );
        let fast = request(|w| w.set_u16(gj::request::OVERRIDE, 10_001));
        assert_eq!(decode_jog(&fast), Err(code::INVALID_OVERRIDE));
    }

    #[test]
    fn frame_and_tool_jogs_step_by_their_increments_or_head_far_and_may_halve() {
        let incremental = decode_jog(&request(|w| {
            w.set_u8(gj::request::MODE, JOG_TOOL);
            w.set_u8(gj::request::TOOL_NO, 3);
            w.set_bit(gj::request::Z_J3_NEG, true);
            w.set_f32(gj::request::INCREMENTAL_TRANSLATION, 2.5);
        }))
        .unwrap();
        let jog = incremental.cartesian().unwrap();
        assert!(jog.step.in_tool && jog.tool_no == 3);
        assert_eq!(jog.step.directions, [0, 0, -1, 0, 0, 0]);
        assert_eq!((jog.step.distance_m, jog.halvings_left), (0.0025, 0));
        let continuous = decode_jog(&request(|w| {
            w.set_u8(gj::request::MODE, JOG_FRAME);
            w.set_bit(gj::request::X_J1_POS, true);
        }))
        .unwrap();
        let jog = continuous.cartesian().unwrap();
        assert!(!jog.step.in_tool && !continuous.incremental());
        assert_eq!(
            (jog.step.distance_m, jog.halvings_left),
            (CONTINUOUS_DISTANCE_M, HALVINGS)
        );
        let joints = decode_jog(&request(|_| {})).unwrap();
        assert_eq!(joints.cartesian(), None);
    }

    #[test]
    fn continuous_jog_heads_for_the_limit_and_incremental_moves_by_the_distance() {
        let min = [-1.0; AXES];
        let max = [1.0; AXES];
        let q = [0.0, 0.2, 0.0, 0.0, 0.0, 0.0];
        let mut r = decode_jog(&request(|w| w.set_bit(gj::request::Y_J2_POS, true))).unwrap();
        let (t, end) = r.target(q, min, max);
        assert!((t[1] - (1.0 - LIMIT_MARGIN)).abs() < 1e-12);
        assert_eq!((t[0], end), (0.0, JogEnd::SwLimit));
        r.increment = 0.1;
        let (t, end) = r.target(q, min, max);
        assert!((t[1] - 0.3).abs() < 1e-12);
        assert_eq!(end, JogEnd::Distance);
        // Never beyond the limit margin, even in increments: the limit ends it.
        r.increment = 5.0;
        let (t, end) = r.target(q, min, max);
        assert!((t[1] - (1.0 - LIMIT_MARGIN)).abs() < 1e-12);
        assert_eq!(end, JogEnd::SwLimit);
    }
}
