//! The interpreter's SRCI server in-process, in a realistic session: the real PLC engine
//! ([`RobotTask`]) on one side, a stand-in planner and drives on the other, and a simulated
//! clock of one millisecond per telegram. Pure: the shell times [`Rig::answer`] alone.

use interpreter::server::{Effects, Now, Server, Settings};
use interpreter::user_data::{RobotBounds, UserData};
use plc_client::{EngineOptions, OptionsError, RobotTask};
use shared_types::config::Config;
use shared_types::ipc::{
    DriveState, JOB_EVENTS, JobEvent, MotionCommand, MotionCommandKind, MotionStatus, ServoControl,
    ServoFeedback, TELEGRAM_CAPACITY,
};
use shared_types::srci::message::state;

use super::workload::{Workload, WorkloadError};

/// Simulated time of the first telegram (a monotonic clock is far from zero).
const START_MS: u64 = 1_000_000;
/// Wall-clock time of the first telegram, for message stamps.
const START_UNIX_MS: u64 = 1_750_000_000_000;
/// How long the stand-in planner takes for a move.
const MOVE_MS: u64 = 200;
const PLANNER_INSTANCE: u64 = 1;
const SERVO_INSTANCE: u64 = 1;

/// A planner that acknowledges every command at once, starts a move's job at once and ends
/// it DONE after [`MOVE_MS`], and ends every other job DONE at once.
#[derive(Debug)]
struct StandInPlanner {
    status: MotionStatus,
    /// The running move's job and when it ends.
    running: Option<(u32, u64)>,
}

impl StandInPlanner {
    fn new() -> Self {
        Self {
            status: MotionStatus::initial(PLANNER_INSTANCE, 1.0),
            running: None,
        }
    }

    fn event(&mut self, job: u32, state: u8) {
        let s = &mut self.status;
        s.event_head += 1;
        s.events[(s.event_head % JOB_EVENTS as u64) as usize] = JobEvent {
            number: s.event_head,
            job,
            state,
            reason: 0,
            code: 0,
        };
    }

    fn accept(&mut self, commands: &[MotionCommand], now_ms: u64) {
        for c in commands {
            // Re-sends of what was already taken are ignored, as the real planner does.
            if c.issuer == self.status.acked_issuer && c.seq <= self.status.acked_seq {
                continue;
            }
            self.status.acked_issuer = c.issuer;
            self.status.acked_seq = c.seq;
            if c.job == 0 {
                continue;
            }
            if MotionCommandKind::from_wire(c.kind) == Some(MotionCommandKind::MoveAxes) {
                self.event(c.job, state::ACTIVE);
                self.running = Some((c.job, now_ms + MOVE_MS));
            } else {
                self.event(c.job, state::DONE);
            }
        }
    }

    fn tick(&mut self, now_ms: u64) {
        self.status.tick += 1;
        if let Some((job, end_ms)) = self.running {
            let left = end_ms.saturating_sub(now_ms) as f64 / MOVE_MS as f64;
            self.status.active_job = job;
            self.status.active_progress = 1.0 - left;
            if now_ms >= end_ms {
                self.event(job, state::DONE);
                self.running = None;
                self.status.active_job = 0;
            }
        }
        self.status.moving = self.running.is_some();
    }
}

/// Drives that follow the power request at once.
fn drive_state(control: &ServoControl) -> DriveState {
    match (control.power, control.enable) {
        (true, true) => DriveState::Following,
        (true, false) => DriveState::Powered,
        _ => DriveState::Off,
    }
}

/// The server, a PLC session against it, and its stand-in surroundings.
pub struct Rig {
    server: Server,
    fx: Effects,
    task: RobotTask,
    workload: Workload,
    planner: StandInPlanner,
    feedback: ServoFeedback,
    now_ms: u64,
    plc_telegram: Vec<u8>,
    robot_telegram: [u8; TELEGRAM_CAPACITY],
    robot_len: usize,
}

/// The rig cannot go on.
#[derive(Debug, thiserror::Error)]
pub enum RigError {
    #[error(transparent)]
    Options(#[from] OptionsError),
    #[error("the PLC engine stopped: {0}")]
    Cycle(#[from] plc_client::CycleError),
    #[error("PLC workload: {0}")]
    Workload(#[from] WorkloadError),
    #[error("the PLC's moves did not start within {0} telegrams")]
    NotMoving(usize),
}

impl Rig {
    /// A server configured from `config` and a PLC about to initialize the interface.
    pub fn new(config: &Config) -> Result<Self, RigError> {
        let settings = Settings::from_config(config);
        let options = EngineOptions {
            length_plc_to_rob: settings.length_plc_to_rob,
            length_rob_to_plc: settings.length_rob_to_plc,
            cycle_time: std::time::Duration::from_millis(1),
            ..EngineOptions::default()
        };
        let plc_telegram = vec![0; options.length_plc_to_rob];
        let home = config.robot.home_deg.map(f64::to_radians);
        let period_ns = config.main.servo.period_us.saturating_mul(1000);
        let mut task = RobotTask::new(options)?;
        task.set_wall_clock_origin(START_UNIX_MS);
        Ok(Self {
            // Factory user data: nothing is read from or written to disk.
            server: Server::new(
                settings,
                0x5EED,
                UserData::factory(RobotBounds::of(&config.robot).0),
            ),
            fx: Effects::new(),
            task,
            workload: Workload::new(&config.robot),
            planner: StandInPlanner::new(),
            feedback: ServoFeedback::at_rest(SERVO_INSTANCE, home, DriveState::Off, period_ns),
            now_ms: START_MS,
            plc_telegram,
            robot_telegram: [0; TELEGRAM_CAPACITY],
            robot_len: 0,
        })
    }

    fn now(&self) -> Now {
        Now {
            mono_ms: self.now_ms,
            unix_ms: START_UNIX_MS + (self.now_ms - START_MS),
        }
    }

    /// Moves completed by the PLC's workload.
    pub fn moves_done(&self) -> u64 {
        self.workload.moves_done()
    }

    /// The PLC's moves are running.
    pub fn moving(&self) -> bool {
        self.workload.moving()
    }

    /// Advances the clock by a millisecond: the planner and drives tick and report, the
    /// server does its periodic work, the PLC builds its next telegram.
    pub fn prepare(&mut self) -> Result<(), RigError> {
        self.now_ms += 1;
        let now = self.now();
        self.planner.tick(self.now_ms);
        self.feedback.tick += 1;
        self.feedback.time_ns = self.now_ms * 1_000_000;
        self.server
            .on_motion_status(now, &self.planner.status, &mut self.fx);
        self.server
            .on_servo_feedback(now, &self.feedback, &mut self.fx);
        self.server.poll(now, &mut self.fx);
        self.apply_effects();
        let since_start = std::time::Duration::from_millis(self.now_ms - START_MS);
        let rx = &self.robot_telegram[..self.robot_len];
        self.task.cycle(since_start, rx, &mut self.plc_telegram)?;
        Ok(())
    }

    /// The server answers the PLC telegram: the call the benchmark times.
    pub fn answer(&mut self) {
        let now = self.now();
        self.robot_len = self.server.on_telegram(
            now,
            &self.plc_telegram,
            &mut self.robot_telegram,
            &mut self.fx,
        );
    }

    /// The surroundings carry out the server's effects; the PLC's workload goes on.
    pub fn absorb(&mut self) -> Result<(), RigError> {
        self.apply_effects();
        self.workload.advance(&mut self.task)?;
        Ok(())
    }

    /// One whole telegram cycle.
    pub fn cycle(&mut self) -> Result<(), RigError> {
        self.prepare()?;
        self.answer();
        self.absorb()
    }

    /// Runs cycles until the PLC's moves run: start-up, GroupReset and EnableRobot done.
    pub fn run_until_moving(&mut self, max_cycles: usize) -> Result<(), RigError> {
        for _ in 0..max_cycles {
            if self.moving() {
                return Ok(());
            }
            self.cycle()?;
        }
        Err(RigError::NotMoving(max_cycles))
    }

    fn apply_effects(&mut self) {
        self.planner.accept(&self.fx.motion, self.now_ms);
        if let Some(control) = self.fx.servo {
            self.feedback.state = drive_state(&control) as u8;
            self.feedback.control_seq = control.seq;
        }
        self.fx.clear();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_plc_initializes_enables_and_keeps_moving() {
        let config = Config::load(None).unwrap();
        let mut rig = Rig::new(&config).unwrap();
        rig.run_until_moving(1_000).unwrap();
        for _ in 0..3_000 {
            rig.cycle().unwrap();
        }
        assert!(rig.moving());
        // 3 s of 200 ms moves, after the start-up.
        assert!(rig.moves_done() >= 10, "{} moves", rig.moves_done());
    }
}
