//! Runs a program's steps over an initialized RobotTask and collects their results.
//!
//! Steps are submitted in order; each waits as its `wait` says, and at the end the runner
//! waits for every outstanding command. A step passes when its final state and code match
//! `expect`/`expect_code`; an Enable-type command (EnableRobot, GroupJog, ...) passes (as
//! DONE) once it reports ACTIVE (EnableRobot: with the requested Enabled bit), and a later
//! step of the same command type updates that command under its CmdID instead of sending a
//! new one. Once any step has failed, no further step is submitted (the rest are SKIPPED).
//! A move with an absolute target (joints or a pose, see [`Target`]) is read back by the
//! first ReadActualPosition step submitted after it was DONE and before the next move (of
//! any kind, jogs included); a deviation above the position tolerance fails the move.

use std::time::Duration;

use shared_types::srci::message::state;
use shared_types::srci::tables;

use crate::ClientError;
use crate::acr::CommandHandle;
use crate::cycle::CycleRunner;
use crate::engine::CommandStatus;
use crate::program::{Expect, Program, Step, Wait};
use crate::report::StepReport;
use crate::request::Request;
use crate::response::{ActualPosition, MoveProgress, RobotMessage, fields_by_name, robot_enabled};
use crate::target::{Deviation, Target, Tolerance};
use crate::transport::Transport;

/// What a program run reports while it goes, for live display.
#[derive(Debug, Clone, PartialEq)]
pub enum ProgressEvent {
    /// The start-up chain completed.
    Initialized {
        handshake: Duration,
        manufacturer: String,
    },
    /// A step was submitted (1-based index).
    StepStarted { index: usize, call: String },
    /// A step's command changed state or code.
    StateChanged { index: usize, state: u8, code: u16 },
    /// A move's Progress changed by at least one percent.
    MoveProgress { index: usize, percent: f64 },
    /// A step ended.
    StepFinished {
        index: usize,
        state: String,
        code: u16,
        passed: bool,
    },
    /// The robot sent a message through ReadMessages.
    Message(RobotMessage),
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Outcome {
    Final {
        state: u8,
        code: u16,
    },
    /// Enable-type command reports ACTIVE with the requested Enabled bit.
    Accepted {
        code: u16,
    },
    TimedOut,
    Abandoned,
    NotSent,
    Skipped,
}

#[derive(Debug, Clone, Default)]
struct Tracked {
    handle: Option<CommandHandle>,
    submitted_at: Duration,
    /// Complete responses the command had before this step (non-zero for updates).
    responses_before: u32,
    seen_state: Option<(u8, u16)>,
    seen_progress: Option<i64>,
    outcome: Option<Outcome>,
    ended_at: Option<Duration>,
    /// For a ReadActualPosition step: the move whose reached position it reads.
    position_for: Option<usize>,
    /// For a move, where it was read back; for a ReadActualPosition step, what it read.
    reached: Option<ActualPosition>,
    /// For a move, how far the read lies from its target.
    deviation: Option<Deviation>,
    passed: bool,
    note: String,
}

/// Executes `program`; returns the step results and, if the run was cut short by a
/// transport or RobotTask failure, that error.
pub(crate) fn execute<T: Transport>(
    runner: &mut CycleRunner<T>,
    program: &Program,
    command_timeout: Duration,
    position_tolerance: Tolerance,
    progress: &mut dyn FnMut(&ProgressEvent),
) -> (Vec<StepReport>, Vec<RobotMessage>, Option<ClientError>) {
    let mut ex = Executor {
        runner,
        steps: &program.steps,
        command_timeout,
        position_tolerance,
        progress,
        tracked: vec![Tracked::default(); program.steps.len()],
        targets: program
            .steps
            .iter()
            .map(|s| Target::of(&s.request))
            .collect(),
        last_move: None,
        stopped: false,
        messages: Vec::new(),
    };
    let error = ex.run().err();
    let reports = ex.reports();
    (reports, ex.messages, error)
}

struct Executor<'a, T: Transport> {
    runner: &'a mut CycleRunner<T>,
    steps: &'a [Step],
    command_timeout: Duration,
    position_tolerance: Tolerance,
    progress: &'a mut dyn FnMut(&ProgressEvent),
    tracked: Vec<Tracked>,
    /// The absolute target of each step's move, if it has one.
    targets: Vec<Option<Target>>,
    last_move: Option<usize>,
    stopped: bool,
    messages: Vec<RobotMessage>,
}

impl<T: Transport> Executor<'_, T> {
    fn run(&mut self) -> Result<(), ClientError> {
        for i in 0..self.steps.len() {
            if self.stopped {
                self.tracked[i].outcome = Some(Outcome::Skipped);
                continue;
            }
            let until = self.runner.elapsed() + self.steps[i].delay;
            while self.runner.elapsed() < until {
                self.cycle()?;
            }
            self.submit(i);
            while !self.wait_satisfied(i) {
                self.cycle()?;
            }
        }
        while self
            .tracked
            .iter()
            .any(|t| t.handle.is_some() && t.outcome.is_none())
        {
            self.cycle()?;
        }
        Ok(())
    }

    fn cycle(&mut self) -> Result<(), ClientError> {
        self.runner.step()?;
        if let Some(fault) = self.runner.task().fault() {
            return Err(ClientError::Fault(fault));
        }
        for m in self.runner.task_mut().take_messages() {
            (self.progress)(&ProgressEvent::Message(m.clone()));
            self.messages.push(m);
        }
        for i in 0..self.tracked.len() {
            self.observe(i);
        }
        Ok(())
    }

    fn submit(&mut self, i: usize) {
        let steps = self.steps;
        let step = &steps[i];
        // The move a ReadActualPosition reads back: the last one, if it is already DONE.
        let position_for = self.last_move.filter(|&m| {
            matches!(
                self.tracked[m].outcome,
                Some(Outcome::Final {
                    state: state::DONE,
                    ..
                })
            )
        });
        let live_enable = self.live_enable(&step.request);
        let task = self.runner.task_mut();
        let now = task.now();
        let result = match live_enable {
            Some(h) => {
                let before = task.status(h).map_or(0, |s| s.responses);
                task.update(h, &step.request).map(|()| (h, before))
            }
            None => task.submit(&step.request).map(|h| (h, 0)),
        };
        let (handle, responses_before) = match result {
            Ok(r) => r,
            Err(e) => {
                self.tracked[i].note = e.to_string();
                self.finish(i, Outcome::NotSent);
                return;
            }
        };
        let t = &mut self.tracked[i];
        t.handle = Some(handle);
        t.submitted_at = now;
        t.responses_before = responses_before;
        match step.request {
            Request::ReadActualPosition { .. } => t.position_for = position_for,
            _ if self.targets[i].is_some() => self.last_move = Some(i),
            // A position read after another move no longer tells where this one ended.
            _ if step.request.moves_the_arm() => self.last_move = None,
            _ => {}
        }
        (self.progress)(&ProgressEvent::StepStarted {
            index: i + 1,
            call: step.call.clone(),
        });
    }

    /// The command an Enable-type `request` updates: an earlier step's of the same command
    /// type that has not ended.
    fn live_enable(&self, request: &Request) -> Option<CommandHandle> {
        if !request.is_enable_type() {
            return None;
        }
        let task = self.runner.task();
        self.tracked.iter().filter_map(|t| t.handle).find(|&h| {
            task.status(h).is_some_and(|s| {
                !s.is_final() && !s.abandoned && s.command_type == request.command_type()
            })
        })
    }

    fn wait_satisfied(&self, i: usize) -> bool {
        let t = &self.tracked[i];
        if t.outcome.is_some() || t.handle.is_none() {
            return true;
        }
        match self.steps[i].wait {
            Wait::None => true,
            Wait::Done => false,
            Wait::Active => t
                .handle
                .and_then(|h| self.runner.task().status(h))
                .is_some_and(|s| s.state >= state::ACTIVE),
        }
    }

    fn observe(&mut self, i: usize) {
        let steps = self.steps;
        let step = &steps[i];
        let t = &self.tracked[i];
        let (Some(handle), None) = (t.handle, t.outcome) else {
            return;
        };
        let task = self.runner.task();
        let now = task.now();
        let Some(status) = task.status(handle) else {
            return;
        };
        // For an update of a running command, only responses after the update count.
        let fresh = status.responses > t.responses_before;
        let changed = fresh && t.seen_state != Some((status.state, status.code));
        let percent =
            move_progress(step, status).filter(|p| t.seen_progress != Some(p.floor() as i64));
        let timeout = step.timeout.unwrap_or(self.command_timeout);
        let outcome = if status.abandoned {
            Some(Outcome::Abandoned)
        } else if fresh && status.is_final() {
            Some(Outcome::Final {
                state: status.state,
                code: status.code,
            })
        } else if fresh && accepted(&step.request, status) {
            Some(Outcome::Accepted { code: status.code })
        } else if now.saturating_sub(t.submitted_at) > timeout {
            Some(Outcome::TimedOut)
        } else {
            None
        };
        let position = (matches!(step.request, Request::ReadActualPosition { .. })
            && status.state == state::DONE
            && outcome.is_some())
        .then(|| ActualPosition::decode(&status.response));
        let (state_now, code_now) = (status.state, status.code);

        let t = &mut self.tracked[i];
        if changed {
            t.seen_state = Some((state_now, code_now));
            (self.progress)(&ProgressEvent::StateChanged {
                index: i + 1,
                state: state_now,
                code: code_now,
            });
        }
        if let Some(p) = percent {
            t.seen_progress = Some(p.floor() as i64);
            (self.progress)(&ProgressEvent::MoveProgress {
                index: i + 1,
                percent: p,
            });
        }
        let position_for = t.position_for;
        if let Some(read) = position {
            t.reached = Some(read);
            if let (Some(m), Request::ReadActualPosition { tool, frame }) =
                (position_for, &step.request)
                && self.tracked[m].reached.is_none()
            {
                self.tracked[m].reached = Some(read);
                self.check_position(m, (*tool, *frame));
            }
        }
        if let Some(outcome) = outcome {
            self.tracked[i].ended_at = Some(now);
            self.finish(i, outcome);
        }
    }

    fn finish(&mut self, i: usize, outcome: Outcome) {
        let steps = self.steps;
        let step = &steps[i];
        let t = &mut self.tracked[i];
        t.outcome = Some(outcome);
        let (passed, note) = judge(step, outcome);
        t.passed = passed;
        if !note.is_empty() && t.note.is_empty() {
            t.note = note;
        }
        if !passed {
            self.stopped = true;
        }
        (self.progress)(&ProgressEvent::StepFinished {
            index: i + 1,
            state: outcome_name(outcome).to_owned(),
            code: t.code(),
            passed,
        });
    }

    /// Compares a move with its read-back position (read in the tool and frame `asked`):
    /// fails it when off its target, remarks on one that cannot be compared.
    fn check_position(&mut self, m: usize, asked: (u8, u8)) {
        let t = &mut self.tracked[m];
        let (Some(target), Some(reached)) = (self.targets[m], t.reached) else {
            return;
        };
        let tolerance = self.position_tolerance;
        match target.deviation(&reached, asked) {
            Ok(d) => {
                t.deviation = Some(d);
                if t.passed && !d.within(tolerance) {
                    t.passed = false;
                    t.note = format!(
                        "reached {d} off target (tolerance {} mm, {} deg)",
                        tolerance.mm, tolerance.deg
                    );
                    self.stopped = true;
                }
            }
            Err(reason) if t.note.is_empty() => t.note = reason,
            Err(_) => {}
        }
    }

    fn reports(&self) -> Vec<StepReport> {
        self.steps
            .iter()
            .zip(&self.tracked)
            .enumerate()
            .map(|(i, (step, t))| {
                // Without an outcome the run was cut short: sent or not sent yet.
                let state = match (t.outcome, t.handle) {
                    (Some(outcome), _) => outcome_name(outcome),
                    (None, Some(_)) => "UNFINISHED",
                    (None, None) => outcome_name(Outcome::Skipped),
                };
                StepReport {
                    index: i + 1,
                    call: step.call.clone(),
                    state: state.to_owned(),
                    code: t.code(),
                    duration: t.ended_at.map(|e| e.saturating_sub(t.submitted_at)),
                    target: self.targets[i],
                    reached: t.reached,
                    deviation: t.deviation,
                    passed: t.passed,
                    note: t.note.clone(),
                    response: self.response_fields(step, t),
                }
            })
            .collect()
    }

    /// The response of a table step that reads or writes (not a move) and succeeded, by
    /// field.
    fn response_fields(&self, step: &Step, t: &Tracked) -> Vec<(&'static str, String)> {
        let succeeded = matches!(
            t.outcome,
            Some(
                Outcome::Final {
                    state: state::DONE,
                    ..
                } | Outcome::Accepted { .. }
            )
        );
        if !matches!(step.request, Request::Raw { .. })
            || step.request.moves_the_arm()
            || !succeeded
        {
            return Vec::new();
        }
        t.handle
            .and_then(|h| self.runner.task().status(h))
            .map_or_else(Vec::new, |s| {
                fields_by_name(step.request.command_type(), &s.response)
            })
    }
}

impl Tracked {
    fn code(&self) -> u16 {
        match self.outcome {
            Some(Outcome::Final { code, .. } | Outcome::Accepted { code }) => code,
            _ => self.seen_state.map_or(0, |(_, c)| c),
        }
    }
}

/// Progress of an ACTIVE move, in percent.
fn move_progress(step: &Step, status: &CommandStatus) -> Option<f64> {
    let is_move = status.command_type == tables::move_axes_absolute::TYPE
        && matches!(step.request, Request::MoveAxesAbsolute(_));
    if !is_move || status.state != state::ACTIVE {
        return None;
    }
    MoveProgress::decode(&status.response).progress_percent
}

/// Whether an Enable-type command's step is done while the command stays ACTIVE: an
/// EnableRobot once it reports the Enabled bit it asked for, any other once it reports ACTIVE
/// to the parameters last sent, except ReturnToPrimary, which is ACTIVE while it moves back
/// and DONE there.
fn accepted(request: &Request, status: &CommandStatus) -> bool {
    match request {
        Request::EnableRobot { enable } => {
            status.state == state::ACTIVE && robot_enabled(&status.response) == *enable
        }
        // ACTIVE with the parameters last sent (the robot echoes their ParSeq).
        r => {
            r.is_enable_type()
                && r.command_type() != tables::return_to_primary::TYPE
                && status.state == state::ACTIVE
                && status.par_seq == status.par_seq_sent
        }
    }
}

fn outcome_name(outcome: Outcome) -> &'static str {
    match outcome {
        Outcome::Final { state: s, .. } => state::name(s),
        Outcome::Accepted { .. } => "ACTIVE",
        Outcome::TimedOut => "TIMEOUT",
        Outcome::Abandoned => "ABANDONED",
        Outcome::NotSent => "NOT SENT",
        Outcome::Skipped => "SKIPPED",
    }
}

/// Whether the outcome is the expected one, and what differs if not.
fn judge(step: &Step, outcome: Outcome) -> (bool, String) {
    let (reached, code) = match outcome {
        Outcome::Final { state: s, code } => (s == step.expect.state(), code),
        Outcome::Accepted { code } => (step.expect == Expect::Done, code),
        _ => return (false, String::new()),
    };
    let code_ok = step.expect_code.is_none_or(|c| c == code);
    if reached && code_ok {
        return (true, String::new());
    }
    let expected_code = step
        .expect_code
        .map(|c| format!(" 0x{c:04X}"))
        .unwrap_or_default();
    (
        false,
        format!(
            "expected {}{expected_code}",
            state::name(step.expect.state())
        ),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::FakeRobot;
    use crate::{ClientOptions, run_program_over};

    /// Runs the program `text` against a fake robot.
    fn run_on_fake_robot(text: &str) -> crate::Report {
        let program = Program::parse(text, "t").unwrap();
        run_program_over(FakeRobot::new(256), &program, &options(), &mut |_| {}).unwrap()
    }

    fn options() -> ClientOptions {
        let mut o = ClientOptions::default();
        // Back to back: the fake robot counts exchanges, not time.
        o.engine.cycle_time = Duration::ZERO;
        o.handshake_timeout = Duration::from_secs(5);
        o.command_timeout = Duration::from_secs(5);
        o
    }

    const PROGRAM: &str = r#"
        name = "fake demo"
        [[step]]
        call = "GroupReset"
        [[step]]
        call = "EnableRobot"
        [[step]]
        call = "ChangeSpeedOverride"
        override = 100.0
        [[step]]
        call = "MoveAxesAbsolute"
        joints = [10.0, 90.0, 90.0, 90.0, -90.0, 10.0]
        wait = "active"
        expect = "ABORTED"
        expect_code = 0x6C06
        [[step]]
        call = "MoveAxesAbsolute"
        joints = [-10.0, 80.0, 100.0, 90.0, -90.0, -10.0]
        aborting = true
        [[step]]
        call = "MoveAxesAbsolute"
        joints = [0.0, 90.0, 90.0, 90.0, -90.0, 0.0]
        [[step]]
        call = "ReadActualPosition"
        [[step]]
        call = "EnableRobot"
        enable = false
    "#;

    #[test]
    fn program_runs_to_a_successful_report() {
        let program = Program::parse(PROGRAM, "fake.toml").unwrap();
        let mut robot = FakeRobot::new(256);
        let mut events = Vec::new();
        let report = run_program_over(&mut robot, &program, &options(), &mut |e| {
            events.push(e.clone())
        })
        .unwrap();
        let mut table = Vec::new();
        report.print_table(&mut table).unwrap();
        let table = String::from_utf8(table).unwrap();
        assert!(report.success(), "{table}");

        let s = &report.steps;
        assert_eq!((s[3].state.as_str(), s[3].code), ("ABORTED", 0x6C06));
        assert_eq!(s[4].state, "DONE");
        assert_eq!(s[4].reached, None, "no read between move B and move C");
        assert!(
            matches!(s[5].deviation, Some(Deviation::Joints { deg }) if deg < 1e-4),
            "{table}"
        );
        assert_eq!(s[7].state, "ACTIVE");
        assert!(s.iter().all(|s| s.duration.is_some()));

        assert!(matches!(events[0], ProgressEvent::Initialized { .. }));
        let started = events
            .iter()
            .filter(|e| matches!(e, ProgressEvent::StepStarted { .. }))
            .count();
        assert_eq!(started, program.steps.len());
        assert!(
            events
                .iter()
                .any(|e| matches!(e, ProgressEvent::MoveProgress { index: 6, .. }))
        );

        let enables = robot.received_of(tables::enable_robot::TYPE);
        assert_eq!(enables.len(), 2);
        assert_eq!(enables[0].cmd_id, enables[1].cmd_id, "disable is an update");
        assert!(!robot.enabled);
    }

    #[test]
    fn unexpected_outcome_fails_the_step_and_skips_the_rest() {
        let report = run_on_fake_robot(
            r#"
            [[step]]
            call = "Raw"
            command_type = 2103
            expect = "ERROR"
            expect_code = 0x8F11
            [[step]]
            call = "Raw"
            command_type = 2103
            [[step]]
            call = "GroupReset"
            "#,
        );
        let s = &report.steps;
        assert!(s[0].passed);
        assert!(!s[1].passed);
        assert_eq!((s[1].state.as_str(), s[1].code), ("ERROR", 0x8F11));
        assert_eq!(s[1].note, "expected DONE");
        assert_eq!(s[2].state, "SKIPPED");
        assert!(!report.success());
    }

    /// A move sent by its table's field names between a MoveAxesAbsolute and the read-back
    /// leaves the MoveAxesAbsolute without a reached position (it used to be compared with
    /// where the later move ended).
    #[test]
    fn a_position_read_after_another_move_is_not_the_first_moves() {
        let report = run_on_fake_robot(
            r#"
            [[step]]
            call = "MoveAxesAbsolute"
            joints = [10.0, 90.0, 90.0, 90.0, -90.0, 10.0]
            [[step]]
            call = "MoveLinearRelative"
            distance = [0.0, 0.0, 50.0, 0.0, 0.0, 0.0]
            expect = "ERROR"
            [[step]]
            call = "ReadActualPosition"
            "#,
        );
        let s = &report.steps;
        assert_eq!(s[0].state, "DONE");
        assert_eq!(s[0].reached, None);
        assert!(s[2].reached.is_some(), "the read itself shows the joints");
        assert!(report.success());
    }

    #[test]
    fn handshake_failure_names_the_telegram_state() {
        let mut robot = FakeRobot::new(256);
        robot.version = 0x45;
        let program = Program::parse("[[step]]\ncall = \"GroupReset\"\n", "t").unwrap();
        let e = run_program_over(&mut robot, &program, &options(), &mut |_| {}).unwrap_err();
        let text = e.to_string();
        assert!(text.contains("TelegramState 255 (INITIALIZED)"), "{text}");
        assert!(text.contains("major version 2"), "{text}");
    }
}
