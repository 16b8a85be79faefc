//! Turning the controller's topics into a [`Recording`]: every servo feedback sample becomes
//! a plot sample (with the TCP speed of the tool in use, the override and the interrupt state
//! the planner reported last), every new job event of the planner a marker. Pure: the
//! recorder hands it the payloads it receives.

use shared_types::ipc::{
    AXES, JOB_EVENTS, MotionCommand, MotionCommandKind, MotionStatus, ServoFeedback,
};

use super::recording::{JobMarker, JobState, Recording, Sample};
use super::tcp::TcpSpeed;

/// Move jobs whose tool is remembered; the active job is always among the newest.
const REMEMBERED_TOOLS: usize = 64;

/// The tool (TCP in the flange frame) of the flange itself.
const FLANGE: [f64; 6] = [0.0; 6];

/// What the planner reported last that samples carry.
#[derive(Debug, Clone, Copy)]
struct PlannerView {
    instance: u64,
    /// The newest job event turned into a marker.
    last_event: u64,
    override_fraction: f64,
    interrupted: bool,
    blending: bool,
}

/// Builds a [`Recording`] from servo feedback, planner status and motion commands.
#[derive(Debug)]
pub struct Capture {
    recording: Recording,
    tcp: TcpSpeed,
    /// (job, tool) of recent move commands, a ring; job 0 = empty.
    tools: [(u32, [f64; 6]); REMEMBERED_TOOLS],
    next_tool: usize,
    tool_in_use: [f64; 6],
    planner: Option<PlannerView>,
    /// Servo instance and tick of the last feedback, and its time.
    last_tick: Option<(u64, u64)>,
    last_time_ns: Option<u64>,
    feedback_samples: u64,
    missed_ticks: u64,
}

/// Counts of what a capture saw, for the plot's caption.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CaptureCounts {
    /// Feedback samples received.
    pub feedback_samples: u64,
    /// Servo ticks whose feedback never arrived (the recorder late, or a servo overrun).
    pub missed_ticks: u64,
}

impl Capture {
    /// Fills `recording`, computing TCP speeds with `tcp`.
    pub fn new(recording: Recording, tcp: TcpSpeed) -> Self {
        Self {
            recording,
            tcp,
            tools: [(0, FLANGE); REMEMBERED_TOOLS],
            next_tool: 0,
            tool_in_use: FLANGE,
            planner: None,
            last_tick: None,
            last_time_ns: None,
            feedback_samples: 0,
            missed_ticks: 0,
        }
    }

    /// Remembers the tool of a move command (re-sent commands are remembered once).
    pub fn on_command(&mut self, command: &MotionCommand) {
        let is_move = matches!(
            MotionCommandKind::from_wire(command.kind),
            Some(
                MotionCommandKind::MoveAxes
                    | MotionCommandKind::MoveDirect
                    | MotionCommandKind::MoveLinear
                    | MotionCommandKind::MoveCircular
            )
        );
        if !is_move || command.job == 0 || self.tool_of(command.job).is_some() {
            return;
        }
        self.tools[self.next_tool] = (command.job, command.tool);
        self.next_tool = (self.next_tool + 1) % REMEMBERED_TOOLS;
    }

    fn tool_of(&self, job: u32) -> Option<[f64; 6]> {
        self.tools
            .iter()
            .find(|(j, _)| *j == job)
            .map(|(_, tool)| *tool)
    }

    /// Takes the planner's override, interrupt state and active job, and marks the job
    /// events it reports for the first time. The events a planner had reported before the
    /// recording began are not marked.
    pub fn on_status(&mut self, status: &MotionStatus) {
        let last_event = match self.planner {
            Some(view) if view.instance == status.instance => view.last_event,
            // A restarted planner: all its events are new.
            Some(_) => 0,
            None => status.event_head,
        };
        let t_s = self.now_s();
        let oldest = status
            .event_head
            .saturating_sub(JOB_EVENTS as u64 - 1)
            .max(1);
        for number in (last_event + 1).max(oldest)..=status.event_head {
            let event = status.events[(number % JOB_EVENTS as u64) as usize];
            // Job 0 stands for no command of the PLC.
            if event.number != number || event.job == 0 {
                continue;
            }
            if let Some(state) = JobState::from_cmd_state(event.state) {
                self.recording.push_marker(JobMarker {
                    t_s,
                    job: event.job,
                    state,
                });
            }
        }
        self.planner = Some(PlannerView {
            instance: status.instance,
            last_event: status.event_head,
            override_fraction: status.override_fraction,
            interrupted: status.sequence_paused,
            blending: status.blending,
        });
        if let Some(tool) = self.tool_of(status.active_job) {
            self.tool_in_use = tool;
        }
    }

    /// The time of the newest feedback in the recording's seconds (0 before any).
    fn now_s(&mut self) -> f64 {
        match self.last_time_ns {
            Some(time_ns) => self.recording.seconds_at(time_ns),
            None => 0.0,
        }
    }

    /// Records a servo tick.
    pub fn on_feedback(&mut self, feedback: &ServoFeedback) {
        if let Some((instance, tick)) = self.last_tick
            && instance == feedback.instance
            && feedback.tick > tick
        {
            self.missed_ticks += feedback.tick - tick - 1;
        }
        self.last_tick = Some((feedback.instance, feedback.tick));
        self.last_time_ns = Some(feedback.time_ns);
        self.feedback_samples += 1;
        let t_s = self.recording.seconds_at(feedback.time_ns);
        let (override_fraction, interrupted, blending) =
            self.planner.map_or((f64::NAN, false, false), |p| {
                (p.override_fraction, p.interrupted, p.blending)
            });
        let q: [f64; AXES] = feedback.q;
        let qd: [f64; AXES] = feedback.qd;
        self.recording.push_sample(Sample {
            t_s,
            q,
            qd,
            tcp_speed: self.tcp.speed(&q, &qd, &self.tool_in_use),
            override_fraction,
            interrupted,
            blending,
        });
    }

    /// What was received so far.
    pub fn counts(&self) -> CaptureCounts {
        CaptureCounts {
            feedback_samples: self.feedback_samples,
            missed_ticks: self.missed_ticks,
        }
    }

    /// The recording, its last sample kept.
    pub fn finish(mut self) -> Recording {
        self.recording.finish();
        self.recording
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use planner::kinematics::Kinematics;
    use shared_types::config::Config;
    use shared_types::ipc::{DriveState, JobEvent};
    use shared_types::srci::message::state;

    fn capture() -> Capture {
        let config = Config::load(None).expect("embedded configuration");
        Capture::new(
            Recording::with_capacity(100, 100),
            TcpSpeed::new(Kinematics::new(&config.robot.kinematics)),
        )
    }

    fn feedback(tick: u64, qd5: f64) -> ServoFeedback {
        let mut f = ServoFeedback::at_rest(
            1,
            [0.0, 1.5, 1.5, 1.5, -1.5, 0.0],
            DriveState::Following,
            1_000_000,
        );
        f.tick = tick;
        f.time_ns = 7_000_000_000 + tick * 1_000_000;
        f.qd[5] = qd5;
        f
    }

    /// A status of planner `instance` whose newest event is `head` (job `head`, state
    /// `states[n % len]`).
    fn status(instance: u64, head: u64, active_job: u32) -> MotionStatus {
        let mut s = MotionStatus::initial(instance, 0.5);
        s.event_head = head;
        for number in head.saturating_sub(JOB_EVENTS as u64 - 1).max(1)..=head {
            s.events[(number % JOB_EVENTS as u64) as usize] = JobEvent {
                number,
                job: number as u32,
                state: if number % 2 == 0 {
                    state::DONE
                } else {
                    state::ACTIVE
                },
                reason: 0,
                code: 0,
            };
        }
        s.active_job = active_job;
        s
    }

    fn move_with_tool(job: u32, tool: [f64; 6]) -> MotionCommand {
        let mut c = MotionCommand::new(MotionCommandKind::MoveAxes);
        c.job = job;
        c.tool = tool;
        c
    }

    #[test]
    fn events_before_the_recording_are_not_marked_later_ones_are() {
        let mut c = capture();
        c.on_feedback(&feedback(0, 0.0));
        c.on_status(&status(9, 5, 0));
        c.on_feedback(&feedback(1, 0.0));
        c.on_status(&status(9, 7, 0));
        let r = c.finish();
        let marked: Vec<(u32, JobState)> = r.markers().iter().map(|m| (m.job, m.state)).collect();
        assert_eq!(marked, [(6, JobState::Done), (7, JobState::Active)]);
        assert_eq!(r.markers()[0].t_s, 1e-3);
    }

    #[test]
    fn events_of_no_job_are_not_marked() {
        let mut c = capture();
        c.on_status(&status(9, 0, 0));
        let mut s = status(9, 2, 0);
        s.events[2].job = 0;
        c.on_status(&s);
        let jobs: Vec<u32> = c.finish().markers().iter().map(|m| m.job).collect();
        assert_eq!(jobs, [1]);
    }

    #[test]
    fn a_restarted_planner_has_all_its_events_marked() {
        let mut c = capture();
        c.on_status(&status(9, 40, 0));
        c.on_status(&status(10, 2, 0));
        assert_eq!(c.finish().markers().len(), 2);
    }

    #[test]
    fn more_events_than_the_ring_holds_mark_only_those_still_in_it() {
        let mut c = capture();
        c.on_status(&status(9, 1, 0));
        c.on_status(&status(9, 1 + 2 * JOB_EVENTS as u64, 0));
        assert_eq!(c.finish().markers().len(), JOB_EVENTS);
    }

    #[test]
    fn samples_carry_the_tool_of_the_active_job_override_and_gaps() {
        let mut c = capture();
        c.on_command(&move_with_tool(3, [0.1, 0.0, 0.0, 0.0, 0.0, 0.0]));
        c.on_feedback(&feedback(10, 2.0));
        c.on_status(&status(9, 0, 3));
        c.on_feedback(&feedback(11, 2.0));
        c.on_feedback(&feedback(14, 2.0));
        assert_eq!(
            c.counts(),
            CaptureCounts {
                feedback_samples: 3,
                missed_ticks: 2
            }
        );
        let r = c.finish();
        let s = r.samples();
        // J6 alone turns: the flange origin stands, a TCP 0.1 m off the axis moves.
        assert!(s[0].tcp_speed < 1e-9);
        assert!(s[0].override_fraction.is_nan());
        assert!((s[1].tcp_speed - 0.2).abs() < 1e-9);
        assert_eq!(s[1].override_fraction, 0.5);
        assert_eq!(s[2].t_s, 4e-3);
    }

    #[test]
    fn re_sent_commands_and_non_moves_take_no_place() {
        let mut c = capture();
        for _ in 0..3 * REMEMBERED_TOOLS {
            c.on_command(&move_with_tool(1, [0.2; 6]));
            c.on_command(&MotionCommand::new(MotionCommandKind::Override));
        }
        assert_eq!(c.tools.iter().filter(|(job, _)| *job != 0).count(), 1);
    }
}
