//! The commanded motion of the arm, advanced one interpolation tick at a time.
//!
//! A [`Motion`] is small and `Copy`, so the executor can step a copy ahead to fill the
//! setpoint window with exactly the points the real motion will take if nothing changes.

use shared_types::config::JointLimitsRad;
use shared_types::ipc::{AXES, JointPoint};
use shared_types::srci::message::state;

use crate::brake::PathBrake;
use crate::joint_move::{JointMove, Plan};
use crate::queue::MoveQueue;

/// What the arm is doing.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Phase {
    /// Standing still at the commanded position.
    Idle,
    /// Executing the move of `job`; `tau` is the time along its profile.
    Running { job: u32, plan: JointMove, tau: f64 },
    /// Stopping on the path of an aborted move.
    Braking { plan: JointMove, brake: PathBrake },
}

/// Limits the moves are planned with.
#[derive(Debug, Clone, Copy)]
pub struct Dynamics {
    /// Joint limits of the robot (rad-based SI units).
    pub limits: JointLimitsRad,
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
    /// Time scale σ: the running profile advances σ seconds per second.
    sigma: f64,
    /// σ̇ over the last tick.
    sigma_rate: f64,
    /// What the arm is doing.
    pub phase: Phase,
    /// GroupInterrupt holds the primary sequence: a standing arm starts no queued move.
    pub sequence_paused: bool,
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
            sigma,
            sigma_rate: 0.0,
            phase: Phase::Idle,
            sequence_paused: false,
        }
    }

    /// The job of the running move, if any.
    pub fn running_job(&self) -> Option<u32> {
        match self.phase {
            Phase::Running { job, .. } => Some(job),
            _ => None,
        }
    }

    /// Switches a running move to braking on its path; returns the job that is thereby
    /// aborted. Braking or standing motion is left as it is.
    pub fn brake(&mut self) -> Option<u32> {
        let Phase::Running { job, plan, tau } = self.phase else {
            return None;
        };
        let (s, sd, sdd) = plan.profile().eval(tau);
        let limits = plan.limits();
        // Same (s, ṡ, s̈) as the point last commanded, so the stop is continuous.
        let brake = PathBrake::new(
            s,
            sd * self.sigma,
            sdd * self.sigma * self.sigma + sd * self.sigma_rate,
            limits.acceleration,
            limits.jerk,
        );
        self.phase = Phase::Braking { plan, brake };
        Some(job)
    }

    /// Advances one tick of `dt` seconds. A standing arm starts the move at `queue[*cursor]`
    /// (and moves the cursor past it). State changes of jobs go to `report(job, state, code)`.
    /// A finished stop leaves the arm standing for this tick, so a stop's end is observable
    /// before the next move starts.
    pub fn advance(
        &mut self,
        dynamics: &Dynamics,
        queue: &MoveQueue,
        cursor: &mut usize,
        dt: f64,
        override_target: f64,
        report: &mut impl FnMut(u32, u8, u16),
    ) {
        match self.phase {
            Phase::Idle => {
                self.stand(override_target);
                if self.sequence_paused {
                    return;
                }
                let Some(command) = queue.get(*cursor) else {
                    return;
                };
                *cursor += 1;
                let planned = JointMove::plan(
                    self.point.q,
                    command,
                    &dynamics.limits,
                    dynamics.override_reserve,
                );
                match planned {
                    Err(e) => report(command.job, state::ERROR, e.code()),
                    Ok(Plan::Stationary) => {
                        self.point.q = command.joints_rad;
                        report(command.job, state::ACTIVE, 0);
                        report(command.job, state::DONE, 0);
                    }
                    Ok(Plan::Move(plan)) => {
                        report(command.job, state::ACTIVE, 0);
                        self.run(command.job, plan, 0.0, dt, override_target, report);
                    }
                }
            }
            Phase::Running { job, plan, tau } => {
                self.run(job, plan, tau, dt, override_target, report)
            }
            Phase::Braking { plan, mut brake } => {
                brake.advance(dt);
                self.point = plan.point(brake.s, brake.v, brake.a);
                self.path_position = brake.s;
                self.phase = if brake.is_stopped() {
                    Phase::Idle
                } else {
                    Phase::Braking { plan, brake }
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
    }

    /// One tick of a running move under the override: τ advances at the rate σ, and σ
    /// approaches the target no faster than the move's override rate.
    fn run(
        &mut self,
        job: u32,
        plan: JointMove,
        tau: f64,
        dt: f64,
        override_target: f64,
        report: &mut impl FnMut(u32, u8, u16),
    ) {
        let max_change = plan.override_rate() * dt;
        let sigma = self.sigma + (override_target - self.sigma).clamp(-max_change, max_change);
        self.sigma_rate = (sigma - self.sigma) / dt;
        // σ is linear within the tick, so the trapezoid is the exact integral.
        let tau = tau + 0.5 * (self.sigma + sigma) * dt;
        self.sigma = sigma;
        let profile = plan.profile();
        if tau >= profile.duration() {
            self.point = plan.point(1.0, 0.0, 0.0);
            self.path_position = 1.0;
            self.phase = Phase::Idle;
            report(job, state::DONE, 0);
            return;
        }
        let (s, sd, sdd) = profile.eval(tau);
        self.point = plan.point(s, sd * sigma, sdd * sigma * sigma + sd * self.sigma_rate);
        self.path_position = s;
        self.phase = Phase::Running { job, plan, tau };
    }
}
