//! What the benchmarking PLC asks of the robot: GroupReset, EnableRobot, then joint moves back
//! and forth without pause, so that every stage of the pipeline is busy. Pure: it looks at
//! the RobotTask after each cycle and submits the next command.

use plc_client::{CommandHandle, MoveAxesAbsolute, Request, RobotTask, SubmitError};
use shared_types::config::RobotConfig;
use shared_types::srci::message::state;

/// How far (degrees) each joint moves from home, towards the middle of its range.
const STROKE_DEG: f64 = 15.0;

/// The workload cannot go on.
#[derive(Debug, thiserror::Error)]
pub enum WorkloadError {
    #[error(transparent)]
    Submit(#[from] SubmitError),
    #[error("{call} ended {state} (code 0x{code:04X})")]
    Failed {
        call: &'static str,
        state: &'static str,
        code: u16,
    },
}

#[derive(Debug, Clone, Copy)]
enum Stage {
    /// Nothing submitted yet.
    Start,
    Resetting(CommandHandle),
    /// EnableRobot is submitted and stays active; waiting for the drives.
    Enabling,
    /// A move towards `targets[toward]` is running.
    Moving {
        handle: CommandHandle,
        toward: usize,
    },
}

/// The back-and-forth joint move workload of one session.
#[derive(Debug, Clone)]
pub struct Workload {
    targets: [[f64; 6]; 2],
    stage: Stage,
    moves_done: u64,
}

impl Workload {
    /// Moves between the robot's home and a point [`STROKE_DEG`] away on every joint.
    pub fn new(robot: &RobotConfig) -> Self {
        Self {
            targets: shuttle_targets(robot),
            stage: Stage::Start,
            moves_done: 0,
        }
    }

    /// Moves are running (the robot is reset and enabled).
    pub fn moving(&self) -> bool {
        matches!(self.stage, Stage::Moving { .. })
    }

    /// Moves completed so far.
    pub fn moves_done(&self) -> u64 {
        self.moves_done
    }

    /// Submits what comes next, once the interface is initialized; call after every cycle.
    pub fn advance(&mut self, task: &mut RobotTask) -> Result<(), WorkloadError> {
        if !task.initialized() {
            return Ok(());
        }
        self.stage = match self.stage {
            Stage::Start => Stage::Resetting(task.submit(&Request::GroupReset)?),
            Stage::Resetting(handle) => match finished(task, handle, "GroupReset")? {
                true => {
                    task.submit(&Request::EnableRobot { enable: true })?;
                    Stage::Enabling
                }
                false => Stage::Resetting(handle),
            },
            Stage::Enabling if task.is_enabled() => self.move_to(task, 1)?,
            Stage::Enabling => Stage::Enabling,
            Stage::Moving { handle, toward } => match finished(task, handle, "MoveAxesAbsolute")? {
                true => {
                    self.moves_done += 1;
                    self.move_to(task, 1 - toward)?
                }
                false => Stage::Moving { handle, toward },
            },
        };
        Ok(())
    }

    fn move_to(&self, task: &mut RobotTask, toward: usize) -> Result<Stage, WorkloadError> {
        let mut m = MoveAxesAbsolute::to(self.targets[toward]);
        m.velocity_rate = Some(100.0);
        m.acceleration_rate = Some(100.0);
        let handle = task.submit(&Request::MoveAxesAbsolute(m))?;
        Ok(Stage::Moving { handle, toward })
    }
}

/// Whether the command ended DONE (and forgets it); an error if it ended otherwise.
fn finished(
    task: &mut RobotTask,
    handle: CommandHandle,
    call: &'static str,
) -> Result<bool, WorkloadError> {
    let Some(status) = task.status(handle) else {
        return Ok(false);
    };
    if !status.is_final() {
        return Ok(false);
    }
    let (s, code) = (status.state, status.code);
    task.release(handle);
    if s == state::DONE {
        Ok(true)
    } else {
        Err(WorkloadError::Failed {
            call,
            state: state::name(s),
            code,
        })
    }
}

/// Home, and home moved by [`STROKE_DEG`] on every joint towards the middle of its range.
fn shuttle_targets(robot: &RobotConfig) -> [[f64; 6]; 2] {
    let home = robot.home_deg;
    let limits = &robot.joints;
    let away = std::array::from_fn(|i| {
        let middle = (limits.min_deg[i] + limits.max_deg[i]) / 2.0;
        home[i] + STROKE_DEG.copysign(middle - home[i])
    });
    [home, away]
}

#[cfg(test)]
mod tests {
    use super::*;
    use shared_types::config::Config;

    #[test]
    fn shuttle_targets_move_every_joint_towards_the_middle() {
        let mut robot = Config::load(None).unwrap().robot;
        robot.home_deg = [0.0, 90.0, 90.0, 90.0, -90.0, 0.0];
        robot.joints.min_deg = [-360.0, -85.0, -175.0, -85.0, -360.0, -360.0];
        robot.joints.max_deg = [360.0, 265.0, 175.0, 265.0, 360.0, 100.0];
        let [home, away] = shuttle_targets(&robot);
        assert_eq!(home, robot.home_deg);
        assert_eq!(away, [15.0, 105.0, 75.0, 105.0, -75.0, -15.0]);
    }
}
