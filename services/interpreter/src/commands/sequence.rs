//! SetSequence and ReturnToPrimary: the secondary sequence's excursion and the way back to
//! where the primary sequence was left (see [`crate::sequences`]).

use shared_types::ipc::{MotionCommand, MotionCommandKind, MotionSequence};
use shared_types::srci::message::{CommandHeader, code, state};
use shared_types::srci::payload::{PayloadReader, PayloadWriter};
use shared_types::srci::tables::{return_to_primary as rtp, set_sequence as ss};

use super::{LineTarget, LiveKind};
use crate::sequences::{PrimaryPosition, SwitchRefused};
use crate::server::{Effects, Now, Server};

/// Writes PrimaryPosToolNo and PrimaryPosFrameNo of a ReturnToPrimary response.
pub(crate) fn write_primary_pos(w: &mut PayloadWriter<'_>, numbers: (u8, u8)) {
    w.set_u8(rtp::response::PRIMARY_POS_TOOL_NO, numbers.0);
    w.set_u8(rtp::response::PRIMARY_POS_FRAME_NO, numbers.1);
}

impl Server {
    /// The tool and frame the primary sequence was left with (the ones in use if it was
    /// not left).
    pub(crate) fn primary_pos_numbers(&self) -> (u8, u8) {
        self.sequences.primary_position().map_or(
            (
                self.user_data.current_tool(),
                self.user_data.current_frame(),
            ),
            |p| (p.tool_no, p.frame_no),
        )
    }

    /// Where the arm stands now, as a position to return the primary sequence to; `None`
    /// before the planner's first status.
    pub(crate) fn primary_position_here(&self) -> Option<PrimaryPosition> {
        self.status.map(|s| PrimaryPosition {
            joints: s.joints_rad,
            flange: s.flange_pose,
            tool_no: self.user_data.current_tool(),
            frame_no: self.user_data.current_frame(),
        })
    }

    /// Whether the primary sequence is held with moves to continue.
    pub(crate) fn primary_held(&self) -> bool {
        self.status
            .is_some_and(|s| s.sequence_paused && (s.active_job != 0 || s.queued_jobs != 0))
    }

    /// Whether a primary move runs or waits without the sequence being held.
    fn primary_running(&self) -> bool {
        self.status
            .is_some_and(|s| !s.sequence_paused && (s.active_job != 0 || s.queued_jobs != 0))
    }

    /// Whether a jog or ReturnToPrimary occupies the secondary sequence (0x8F15 for more).
    pub(crate) fn secondary_blocked(&self) -> bool {
        self.live.iter().any(|l| {
            matches!(l.kind, LiveKind::Jog { job, .. } if job != 0)
                || (l.command_type == rtp::TYPE && matches!(l.kind, LiveKind::Job { .. }))
        })
    }

    /// Whether anything still runs or waits on the secondary sequence.
    fn secondary_busy(&self) -> bool {
        self.secondary_blocked()
            || self.live.iter().any(|l| {
                matches!(
                    l.kind,
                    LiveKind::Job {
                        secondary: true,
                        ..
                    }
                )
            })
    }

    /// SetSequence: TargetSequence 1 (primary) or 2 (secondary).
    pub(crate) fn set_sequence(
        &mut self,
        cmd_id: u16,
        h: CommandHeader,
        msg: &[u8],
        now: Now,
        fx: &mut Effects,
    ) {
        let outcome = match PayloadReader::new(msg).u8(ss::request::TARGET_SEQUENCE) {
            1 => self.sequences.activate_primary(self.secondary_busy()),
            2 => {
                let was_held = self.status.is_some_and(|s| s.sequence_paused);
                let switched = match self.primary_position_here() {
                    Some(here) => self
                        .sequences
                        .activate_secondary(self.primary_running(), here),
                    // No planner status yet: nothing can run, but the position is unknown.
                    None => Err(SwitchRefused::PrimaryRunning),
                };
                if switched.is_ok() && !was_held {
                    // Primary moves sent from now on wait for the way back.
                    let mut hold = MotionCommand::new(MotionCommandKind::Interrupt);
                    hold.sequence = MotionSequence::Primary as u8;
                    let _ = self.motion.submit(hold, None, now.mono_ms, &mut fx.motion);
                }
                switched
            }
            _ => {
                let c = code::INVALID_TARGET_SEQUENCE;
                return self.respond(cmd_id, h, state::ERROR, c, now, |_| {});
            }
        };
        let (st, c) = match outcome {
            Ok(()) => (state::DONE, 0),
            Err(SwitchRefused::PrimaryRunning) => (state::ERROR, code::REQUIRES_INTERRUPT_OR_IDLE),
            Err(SwitchRefused::SecondaryNotEmpty) => (state::ERROR, code::SECONDARY_NOT_EMPTY),
        };
        self.respond(cmd_id, h, st, c, now, |_| {});
    }

    /// ReturnToPrimary (Enable type): moves the arm on the secondary sequence back to where
    /// the primary sequence was left: joint-interpolated (TrajectoryMode bit clear) or on a
    /// straight line of the flange (set). ACTIVE with Progress and RemainingDistance while
    /// it moves, DONE there; Enable = FALSE by an update stops it.
    pub(crate) fn return_to_primary(
        &mut self,
        cmd_id: u16,
        h: CommandHeader,
        msg: &[u8],
        now: Now,
        fx: &mut Effects,
    ) {
        let r = PayloadReader::new(msg);
        let primary = self.primary_pos_numbers();
        let target = self.sequences.primary_position();
        let refused = if !r.bit(rtp::request::ENABLE) {
            Some((state::DONE, 0))
        } else if r.bit(rtp::request::RETURN_MODE) {
            // ReturnMode 1 (the end position of the interrupted move) is not offered.
            Some((state::ERROR, code::INVALID_RETURN_MODE))
        } else if self.error_pending {
            Some((state::ERROR, code::DISABLED_DUE_TO_ERROR))
        } else if !self.drives_enabled() {
            Some((state::ERROR, code::ROBOT_DISABLED))
        } else if self.primary_running() {
            Some((state::ERROR, code::REQUIRES_INTERRUPT_OR_IDLE))
        } else if self.secondary_blocked() {
            Some((state::ERROR, code::SECONDARY_BLOCKED))
        } else {
            None
        };
        if let Some((st, c)) = refused {
            return self.respond(cmd_id, h, st, c, now, |b| {
                write_primary_pos(&mut PayloadWriter::new(b), primary);
            });
        }
        let Some(target) = target.filter(|p| {
            !self
                .status
                .is_none_or(|s| self.sequences.in_primary_position(&s.joints_rad))
                || p.joints.iter().any(|v| !v.is_finite())
        }) else {
            // Already on the primary path.
            return self.respond(cmd_id, h, state::DONE, 0, now, |b| {
                let mut w = PayloadWriter::new(b);
                w.set_u16(rtp::response::PROGRESS, 10_000);
                write_primary_pos(&mut w, primary);
            });
        };
        let mut c = match super::motion::decode_return(&r, &self.user_data) {
            Ok(c) => c,
            Err(e) => return self.respond(cmd_id, h, state::ERROR, e, now, |_| {}),
        };
        let linear = r.bit(rtp::request::TRAJECTORY_MODE);
        if linear {
            c.kind = MotionCommandKind::MoveLinear as u8;
            c.pose = target.flange;
        } else {
            c.kind = MotionCommandKind::MoveAxes as u8;
            c.joints_rad = target.joints;
        }
        c.sequence = MotionSequence::Secondary as u8;
        self.submit_job(cmd_id, h, c, now, fx);
        if linear
            && let Some(LiveKind::Job { line, .. }) = self
                .live
                .iter_mut()
                .find(|l| l.cmd_id == cmd_id)
                .map(|l| &mut l.kind)
        {
            *line = Some(LineTarget {
                position: [target.flange[0], target.flange[1], target.flange[2]],
                tool: [0.0; 6],
            });
        }
    }

    /// An update of a running ReturnToPrimary: Enable = FALSE stops the way back on its path
    /// (the job ends ABORTED).
    pub(crate) fn update_return_to_primary(&mut self, msg: &[u8], now: Now, fx: &mut Effects) {
        if !PayloadReader::new(msg).bit(rtp::request::ENABLE) {
            let mut stop = MotionCommand::new(MotionCommandKind::Halt);
            stop.sequence = MotionSequence::Secondary as u8;
            let _ = self.motion.submit(stop, None, now.mono_ms, &mut fx.motion);
        }
    }
}
