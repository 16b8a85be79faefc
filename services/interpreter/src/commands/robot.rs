//! Commands about the robot as a whole: EnableRobot, GroupReset, ReadActualPosition.

use shared_types::health::{RequestOutcome, SupervisionRequest};
use shared_types::ipc::{DriveState, MotionCommand, MotionCommandKind};
use shared_types::srci::message::{CommandHeader, code, severity, state};
use shared_types::srci::payload::{PayloadReader, PayloadWriter};
use shared_types::srci::tables::{enable_robot as er, read_actual_position as rap};

use super::LiveKind;
use crate::messages::MessageType;
use crate::server::{Effects, Now, Server, write_text};
use crate::tcp_pose::tcp_pose;

/// A GroupReset that waits this long (ms) for the orchestrator to restart failed services
/// ends in ERROR.
const SERVICES_RESET_TIMEOUT_MS: u64 = 15_000;
/// Meanwhile its request is re-sent this often (ms), in case the orchestrator missed it.
const SERVICES_RESET_RESEND_MS: u64 = 1000;

impl Server {
    pub(crate) fn enable_robot(
        &mut self,
        cmd_id: u16,
        h: CommandHeader,
        msg: &[u8],
        now: Now,
        fx: &mut Effects,
    ) {
        if self
            .live
            .iter()
            .any(|l| matches!(l.kind, LiveKind::Enable { .. }))
        {
            self.respond(
                cmd_id,
                h,
                state::ERROR,
                code::ONLY_ONE_INSTANCE,
                now,
                |_| {},
            );
            return;
        }
        let i = self.keep_live(
            cmd_id,
            h,
            LiveKind::Enable {
                want: false,
                reported: None,
                since_ms: now.mono_ms,
                reached: false,
            },
        );
        self.update_enable_robot(i, msg, now, fx);
    }

    pub(crate) fn update_enable_robot(&mut self, i: usize, msg: &[u8], now: Now, fx: &mut Effects) {
        let r = PayloadReader::new(msg);
        let cmd_id = self.live[i].cmd_id;
        let h = self.live_header(i);
        let want = r.bit(er::request::ENABLE);
        let step_mode = r.u8(er::request::STEP_MODE);
        let error = match step_mode {
            0..=2 => None,
            _ => Some(code::INVALID_STEP_MODE),
        }
        .or((want && self.error_pending).then_some(code::DISABLED_DUE_TO_ERROR))
        .or((want
            && crate::sync::SyncSupervisor::denies_enable(&self.sync_request, self.synchronized()))
        .then_some(code::NOT_SYNCHRONIZED));
        if let Some(c) = error {
            self.respond(cmd_id, h, state::ERROR, c, now, |_| {});
            return;
        }
        self.step_mode = step_mode;
        self.live[i].kind = LiveKind::Enable {
            want,
            reported: None,
            since_ms: now.mono_ms,
            reached: false,
        };
        // Power first, then enable: the drives sequence the two with their own delays.
        self.servo_control.seq += 1;
        self.servo_control.power = want;
        self.servo_control.enable = want;
        fx.servo = Some(self.servo_control);
        self.progress_enable(now, fx);
    }

    /// Reports EnableRobot progress: ACTIVE at once (parameters accepted), ACTIVE with Enabled
    /// when the drives are enabled (and without when they drop out), DONE once switched off,
    /// ERROR if the drives do not enable in time.
    pub(crate) fn progress_enable(&mut self, now: Now, _fx: &mut Effects) {
        let Some(i) = self
            .live
            .iter()
            .position(|l| matches!(l.kind, LiveKind::Enable { .. }))
        else {
            return;
        };
        let LiveKind::Enable {
            want,
            reported,
            since_ms,
            reached,
        } = self.live[i].kind
        else {
            return;
        };
        let drive = self.feedback.map(|f| DriveState::from_wire(f.state));
        let enabled = drive.is_some_and(DriveState::is_enabled);
        let cmd_id = self.live[i].cmd_id;
        let h = self.live_header(i);
        if !want {
            if reported.is_none() {
                self.set_enable_reported(i, enabled);
                self.respond(cmd_id, h, state::ACTIVE, 0, now, |b| {
                    PayloadWriter::new(b).set_bit(er::response::ENABLED, enabled);
                });
            }
            if matches!(drive, Some(DriveState::Off)) {
                self.respond(cmd_id, h, state::DONE, 0, now, |_| {});
            }
            return;
        }
        if !enabled
            && !reached
            && now.mono_ms.saturating_sub(since_ms) > self.settings.enable_timeout_ms
        {
            self.respond(cmd_id, h, state::ERROR, code::INTERNAL_ERROR, now, |_| {});
            return;
        }
        if reported != Some(enabled) {
            self.set_enable_reported(i, enabled);
            self.respond(cmd_id, h, state::ACTIVE, 0, now, |b| {
                PayloadWriter::new(b).set_bit(er::response::ENABLED, enabled);
            });
        }
    }

    /// Ends a live EnableRobot with ERROR `code`: the drives were switched off by a fault.
    pub(crate) fn end_enable_robot(&mut self, now: Now, code: u16) {
        if let Some(i) = self
            .live
            .iter()
            .position(|l| matches!(l.kind, LiveKind::Enable { .. }))
        {
            let cmd_id = self.live[i].cmd_id;
            let h = self.live_header(i);
            self.respond(cmd_id, h, state::ERROR, code, now, |_| {});
        }
    }

    fn set_enable_reported(&mut self, i: usize, value: bool) {
        if let LiveKind::Enable {
            reported, reached, ..
        } = &mut self.live[i].kind
        {
            *reported = Some(value);
            *reached |= value;
        }
    }

    pub(crate) fn group_reset(
        &mut self,
        cmd_id: u16,
        h: CommandHeader,
        now: Now,
        fx: &mut Effects,
    ) {
        self.messages.reset();
        self.servo_control.seq += 1;
        self.servo_control.fault_reset += 1;
        fx.servo = Some(self.servo_control);
        if self.services_down(now) {
            // First the orchestrator starts the failed services again.
            let request_id = self.next_supervision_request();
            fx.supervision = Some(SupervisionRequest::reset(request_id));
            self.keep_live(
                cmd_id,
                h,
                LiveKind::ServicesReset {
                    request_id,
                    sent_ms: now.mono_ms,
                    since_ms: now.mono_ms,
                },
            );
            return;
        }
        self.reset_planner(cmd_id, h, now, fx);
    }

    /// DONE comes from the planner once it has cleared its error: then every service is
    /// back in a consistent state.
    fn reset_planner(&mut self, cmd_id: u16, h: CommandHeader, now: Now, fx: &mut Effects) {
        self.submit_job(
            cmd_id,
            h,
            MotionCommand::new(MotionCommandKind::Reset),
            now,
            fx,
        );
    }

    /// Moves a GroupReset that waits for the orchestrator on: to the planner's reset once
    /// every service runs again, to ERROR if the orchestrator could not restart them or
    /// does not answer; the request is re-sent every second meanwhile.
    pub(crate) fn continue_group_reset(&mut self, now: Now, fx: &mut Effects) {
        let Some(i) = self
            .live
            .iter()
            .position(|l| matches!(l.kind, LiveKind::ServicesReset { .. }))
        else {
            return;
        };
        let LiveKind::ServicesReset {
            request_id,
            sent_ms,
            since_ms,
        } = self.live[i].kind
        else {
            return;
        };
        let (cmd_id, h) = (self.live[i].cmd_id, self.live_header(i));
        match self.supervision_outcome(request_id) {
            Some((RequestOutcome::Done, true)) => {
                self.live.swap_remove(i);
                self.reset_planner(cmd_id, h, now, fx);
            }
            Some((RequestOutcome::Rejected | RequestOutcome::Failed, _)) => {
                self.fail_services_reset(
                    i,
                    "the orchestrator could not restart the failed service",
                    now,
                );
            }
            _ if now.mono_ms.saturating_sub(since_ms) > SERVICES_RESET_TIMEOUT_MS => {
                self.fail_services_reset(i, "the orchestrator did not answer within 15 s", now);
            }
            _ if now.mono_ms.saturating_sub(sent_ms) >= SERVICES_RESET_RESEND_MS => {
                fx.supervision = Some(SupervisionRequest::reset(request_id));
                self.live[i].kind = LiveKind::ServicesReset {
                    request_id,
                    sent_ms: now.mono_ms,
                    since_ms,
                };
            }
            _ => {}
        }
    }

    /// Ends the GroupReset `i` that waited for the orchestrator with an error and its cause.
    fn fail_services_reset(&mut self, i: usize, cause: &str, now: Now) {
        let (cmd_id, h) = (self.live[i].cmd_id, self.live_header(i));
        let mut text = [0u8; 150];
        let text = write_text(&mut text, format_args!("GroupReset: {cause}"));
        self.raise(
            now,
            MessageType::Controller,
            severity::ERROR,
            code::INTERNAL_ERROR,
            text,
        );
        self.respond(cmd_id, h, state::ERROR, code::INTERNAL_ERROR, now, |_| {});
    }

    pub(crate) fn read_actual_position(
        &mut self,
        cmd_id: u16,
        h: CommandHeader,
        msg: &[u8],
        now: Now,
    ) {
        let r = PayloadReader::new(msg);
        let tool = r.u8(rap::request::TOOL_NO);
        let frame = r.u8(rap::request::FRAME_NO);
        let (Some(feedback), Some(status)) = (self.feedback, self.status) else {
            // Without drive feedback and planner status there is no position to report.
            self.respond(cmd_id, h, state::ERROR, code::MOTION_ERROR, now, |_| {});
            return;
        };
        let (tool_no, frame_no, pose) =
            match tcp_pose(&self.user_data, status.flange_pose, tool, frame) {
                Ok(p) => p,
                Err(c) => {
                    self.respond(cmd_id, h, state::ERROR, c, now, |_| {});
                    return;
                }
            };
        self.respond(cmd_id, h, state::DONE, 0, now, |b| {
            let mut w = PayloadWriter::new(b);
            w.set_u8(rap::response::TOOL_NO_RETURN, tool_no);
            w.set_u8(rap::response::FRAME_NO_RETURN, frame_no);
            let cart = rap::response::ACTUAL_CARTESIAN_POSITION_X_RZ;
            for (f, v) in cart.into_iter().zip(pose) {
                w.set_f32(f, v as f32);
            }
            // The configuration bits share byte 34 and follow the Shoulder/Elbow/Wrist fields.
            w.set_bit(rap::response::SHOULDER, status.arm_config & 1 != 0);
            w.set_bit(rap::response::ELBOW, status.arm_config & 2 != 0);
            w.set_bit(rap::response::WRIST, status.arm_config & 4 != 0);
            w.set_bytes(
                rap::response::ACTUAL_CARTESIAN_POSITION_TURN_NUMBER,
                &status.turn_numbers,
            );
            let joints = rap::response::ACTUAL_JOINT_POSITION_J1_J6;
            for (f, q) in joints.into_iter().zip(feedback.q) {
                w.set_f32(f, q.to_degrees() as f32);
            }
        });
    }
}
