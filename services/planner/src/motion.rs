//! The commanded motion of the arm, advanced one interpolation tick at a time.
//!
//! A [`Motion`] is small and `Copy`, so the executor can step a copy ahead to fill the
//! setpoint window with exactly the points the real motion will take if nothing changes.

use shared_types::config::JointLimitsRad;
use shared_types::ipc::{AXES, JointPoint, MotionCommandKind};
use shared_types::srci::message::state;

use crate::brake::PathBrake;
use crate::joint_move::{JointMove, Plan, Timing};
use crate::linear_move::{LinearMove, LinearPlan, TcpLimits};
use crate::sequences::{Cursor, Holds, Sequence, Sequences};

/// The path of a running move: a straight line in joint space or of the TCP.
#[derive(Debug, Clone, Copy, PartialEq)]
#[allow(
    clippy::large_enum_variant,
    reason = "the motion is copied ahead every tick, where boxing would allocate"
)]
pub enum Path {
    /// MoveAxes (and MoveDirect, a joint move to a Cartesian target).
    Joint(JointMove),
    /// MoveLinear.
    Linear(LinearMove),
}

impl Path {
    /// The time scaling of the move.
    pub fn timing(&self) -> &Timing {
        match self {
            Self::Joint(m) => m.timing(),
            Self::Linear(m) => m.timing(),
        }
    }

    /// Joint position where the move ends.
    pub fn target(&self) -> [f64; AXES] {
        match self {
            Self::Joint(m) => m.target(),
            Self::Linear(m) => m.target(),
        }
    }

    /// The joint point at `(s, ṡ, s̈)`, next to `previous` (the point of the last tick).
    pub fn point(&self, s: f64, sd: f64, sdd: f64, previous: &[f64; AXES]) -> JointPoint {
        match self {
            Self::Joint(m) => m.point(s, sd, sdd),
            Self::Linear(m) => m.point(s, sd, sdd, previous),
        }
    }
}

/// What the arm is doing.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Phase {
    /// Standing still at the commanded position.
    Idle,
    /// Executing `active`; `tau` is the time along its profile.
    Running {
        active: ActiveMove,
        plan: Path,
        tau: f64,
    },
    /// Stopping on the path of an aborted or interrupted move of `sequence`.
    Braking {
        sequence: Sequence,
        plan: Path,
        brake: PathBrake,
    },
}

/// The running move's job and what its end does.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ActiveMove {
    pub job: u32,
    /// The sequence it was taken from.
    pub sequence: Sequence,
    /// Its end holds the primary sequence (StepMode).
    pub hold_after: bool,
}

/// Limits the moves are planned with.
#[derive(Debug, Clone, Copy)]
pub struct Dynamics {
    /// Joint limits of the robot (rad-based SI units).
    pub limits: JointLimitsRad,
    /// TCP limits of the robot (m-based SI units).
    pub tcp: TcpLimits,
    /// Share of the acceleration limit held back for override changes.
    pub override_reserve: f64,
}

/// The commanded joint motion and the time scaling of the override.
#[derive(Debug, Clone, Copy)]
pub struct Motion {
    /// The point commanded for the current tick.
    pub point: JointPoint,
    /// Path position of the running or braking move, 0..1.
    pub path_position: f64,
    /// Path velocity and acceleration `(ṡ, s̈)` of the running or braking move, as
    /// commanded (override included).
    pub path_rate: (f64, f64),
    /// Time scale σ: the running profile advances σ seconds per second.
    sigma: f64,
    /// σ̇ over the last tick.
    sigma_rate: f64,
    /// What the arm is doing.
    pub phase: Phase,
    /// The held sequences: a standing arm starts none of their moves.
    pub holds: Holds,
}

impl Motion {
    /// Standing still at `q`.
    pub fn at_rest(q: [f64; AXES], sigma: f64) -> Self {
        Self {
            point: JointPoint {
                q,
                ..JointPoint::default()
            },
            path_position: 0.0,
            path_rate: (0.0, 0.0),
            sigma,
            sigma_rate: 0.0,
            phase: Phase::Idle,
            holds: Holds::default(),
        }
    }

    /// The running move, if any.
    pub fn running(&self) -> Option<ActiveMove> {
        match self.phase {
            Phase::Running { active, .. } => Some(active),
            _ => None,
        }
    }

    /// The sequence of the move that runs or brakes, if any.
    pub fn moving_sequence(&self) -> Option<Sequence> {
        match self.phase {
            Phase::Running { active, .. } => Some(active.sequence),
            Phase::Braking { sequence, .. } => Some(sequence),
            Phase::Idle => None,
        }
    }

    /// Switches a running move to braking on its path; returns the job that is thereby
    /// aborted or interrupted. Braking or standing motion is left as it is.
    pub fn brake(&mut self) -> Option<u32> {
        let Phase::Running { active, plan, tau } = self.phase else {
            return None;
        };
        let timing = plan.timing();
        let (s, sd, sdd) = timing.profile.eval(tau);
        let limits = timing.limits;
        // Same (s, ṡ, s̈) as the point last commanded, so the stop is continuous.
        let brake = PathBrake::new(
            s,
            sd * self.sigma,
            sdd * self.sigma * self.sigma + sd * self.sigma_rate,
            limits.braking(),
            limits.jerk,
        );
        self.phase = Phase::Braking {
            sequence: active.sequence,
            plan,
            brake,
        };
        Some(active.job)
    }

    /// Advances one tick of `dt` seconds. A standing arm starts the next move of `sequences`
    /// past `cursor` (see [`Sequences::next`]) and moves the cursor past it; a linear move
    /// only if it was planned from exactly where the arm stands, else the arm waits for the
    /// executor to plan it from there. A primary move with `hold_after` holds the primary
    /// sequence when it is done.
    /// State changes of jobs go to `report(job, state, code)`. A finished stop leaves the
    /// arm standing for this tick, so a stop's end is observable before the next move starts.
    pub fn advance(
        &mut self,
        dynamics: &Dynamics,
        sequences: &Sequences,
        cursor: &mut Cursor,
        dt: f64,
        override_target: f64,
        report: &mut impl FnMut(u32, u8, u16),
    ) {
        match self.phase {
            Phase::Idle => {
                self.stand(override_target);
                let Some((sequence, queued)) = sequences.next(cursor, self.holds) else {
                    return;
                };
                let command = &queued.command;
                let hold_after = command.hold_after && sequence == Sequence::Primary;
                let planned = if command.kind == MotionCommandKind::MoveLinear as u8 {
                    match queued.linear {
                        Some(plan) if plan.start() == &self.point.q => match plan {
                            LinearPlan::Move(m) => Ok(Some(Path::Linear(m))),
                            LinearPlan::Stationary(_) => Ok(None),
                        },
                        _ => return,
                    }
                } else {
                    match JointMove::plan(
                        self.point.q,
                        command,
                        &dynamics.limits,
                        dynamics.override_reserve,
                    ) {
                        Ok(Plan::Move(m)) => Ok(Some(Path::Joint(m))),
                        Ok(Plan::Stationary) => Ok(None),
                        Err(e) => Err(e.code()),
                    }
                };
                cursor.pass(sequence);
                let active = ActiveMove {
                    job: command.job,
                    sequence,
                    hold_after,
                };
                match planned {
                    Err(code) => report(command.job, state::ERROR, code),
                    Ok(None) => {
                        self.point.q = command.joints_rad;
                        report(command.job, state::ACTIVE, 0);
                        self.finish(active, report);
                    }
                    Ok(Some(plan)) => {
                        report(command.job, state::ACTIVE, 0);
                        self.run(active, plan, 0.0, dt, override_target, report);
                    }
                }
            }
            Phase::Running { active, plan, tau } => {
                self.run(active, plan, tau, dt, override_target, report)
            }
            Phase::Braking {
                sequence,
                plan,
                mut brake,
            } => {
                brake.advance(dt);
                self.point = plan.point(brake.s, brake.v, brake.a, &self.point.q);
                self.path_position = brake.s;
                self.path_rate = (brake.v, brake.a);
                self.phase = if brake.is_stopped() {
                    Phase::Idle
                } else {
                    Phase::Braking {
                        sequence,
                        plan,
                        brake,
                    }
                };
            }
        }
    }

    fn stand(&mut self, override_target: f64) {
        // Without motion the time scale has no inertia.
        self.sigma = override_target;
        self.sigma_rate = 0.0;
        self.point.qd = [0.0; AXES];
        self.point.qdd = [0.0; AXES];
        self.path_position = 0.0;
        self.path_rate = (0.0, 0.0);
    }

    /// One tick of a running move under the override: τ advances at the rate σ, and σ
    /// approaches the target no faster than the move's override rate.
    fn run(
        &mut self,
        active: ActiveMove,
        plan: Path,
        tau: f64,
        dt: f64,
        override_target: f64,
        report: &mut impl FnMut(u32, u8, u16),
    ) {
        let timing = *plan.timing();
        let max_change = timing.override_rate * dt;
        let sigma = self.sigma + (override_target - self.sigma).clamp(-max_change, max_change);
        self.sigma_rate = (sigma - self.sigma) / dt;
        // σ is linear within the tick, so the trapezoid is the exact integral.
        let tau = tau + 0.5 * (self.sigma + sigma) * dt;
        self.sigma = sigma;
        let profile = timing.profile;
        if tau >= profile.duration() {
            self.point = plan.point(1.0, 0.0, 0.0, &self.point.q);
            self.path_position = 1.0;
            self.path_rate = (0.0, 0.0);
            self.phase = Phase::Idle;
            self.finish(active, report);
            return;
        }
        let (s, sd, sdd) = profile.eval(tau);
        let rate = (sd * sigma, sdd * sigma * sigma + sd * self.sigma_rate);
        self.point = plan.point(s, rate.0, rate.1, &self.point.q);
        self.path_position = s;
        self.path_rate = rate;
        self.phase = Phase::Running { active, plan, tau };
    }

    /// Reports a move done; StepMode holds the primary sequence after it.
    fn finish(&mut self, active: ActiveMove, report: &mut impl FnMut(u32, u8, u16)) {
        if active.hold_after {
            self.holds.primary = true;
        }
        report(active.job, state::DONE, 0);
    }
}
