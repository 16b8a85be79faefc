//! GroupStops on the problem set's lines, braked as the executor brakes them
//! ([`Stop::of`] and [`Stop::advance`] in 1 ms ticks), against the shortest stop the slowest
//! joint could make alone from the same point ([`shortest_stop_time`], a lower bound of any
//! stop), and the same stops braking the table's time scale alone (as every stop on a table
//! did before its path parameter could be braked): side by side in one run.

use std::time::Instant;

use planner::brake::shortest_stop_time;
use planner::linear_move::LinearMove;
use planner::motion::{Path, Stop};
use planner::profile::Profile;
use planner::scale_brake::ScaleBrake;
use planner::time_scale::TimeScale;
use shared_types::config::JointLimitsRad;
use shared_types::ipc::{AXES, JointPoint};

use super::problems::{LinearCase, Problems, Robot};
use super::timing::{CallTimes, time_calls};
use crate::bench::elapsed_ns;

/// Shares of a line's duration after which it is stopped.
pub const STOP_AT: [f64; 2] = [0.1, 0.5];
/// The executor's tick (s).
const TICK_S: f64 = 1e-3;
/// Ticks a stop may take at most (20 s; none takes a second).
const MAX_TICKS: usize = 20_000;
/// Points at which the joints are followed from the start of a line to where it is stopped
/// (each on the turn nearest the one before).
const FOLLOW_STEPS: usize = 64;

/// The stops at one share of every line's duration, in s; NaN for a line on constant
/// bounds (no table to brake).
#[derive(Debug, Clone, Default)]
pub struct StopSet {
    /// As the executor stops.
    pub ours_s: Vec<f64>,
    /// Braking the table's time scale alone.
    pub time_scale_s: Vec<f64>,
    /// The slowest joint alone, from the point commanded when the stop comes.
    pub slowest_joint_s: Vec<f64>,
    /// The highest the stops as the executor stops commanded, over the joint limits.
    pub ours_peaks: Peaks,
    /// The same, braking the time scale alone.
    pub time_scale_peaks: Peaks,
    /// Stops that braked the path parameter, and of those, handed over to the time scale.
    pub path_stops: usize,
    pub handovers: usize,
}

/// The highest joint velocity, acceleration and jerk some stops commanded, each over its
/// limit, the jerk from the accelerations of consecutive ticks (the first against the point
/// commanded before the stop).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Peaks {
    pub velocity: f64,
    pub acceleration: f64,
    pub jerk: f64,
}

impl Peaks {
    /// Takes in the step from `before` to `after`, a tick apart.
    fn take(&mut self, limits: &JointLimitsRad, before: &JointPoint, after: &JointPoint) {
        for i in 0..AXES {
            let jerk = (after.qdd[i] - before.qdd[i]).abs() / TICK_S;
            self.velocity = self.velocity.max(after.qd[i].abs() / limits.velocity[i]);
            self.acceleration = self
                .acceleration
                .max(after.qdd[i].abs() / limits.acceleration[i]);
            self.jerk = self.jerk.max(jerk / limits.jerk[i]);
        }
    }
}

/// Every stop measured.
#[derive(Debug, Clone)]
pub struct Stops {
    /// One set per share of [`STOP_AT`].
    pub at: Vec<StopSet>,
    /// [`Stop::of`] at every share of every line on its table: the decision in the tick
    /// that brakes.
    pub decision: CallTimes,
    /// [`Stop::advance`]: every tick of those stops that braked the path parameter.
    pub path_tick: CallTimes,
    /// [`Stop::advance`]: every tick that braked a table's time scale, in the stops braking
    /// it alone.
    pub time_scale_tick: CallTimes,
}

/// Whether a tick of `stop` brakes the path parameter.
fn on_path(stop: &Stop) -> bool {
    matches!(stop, Stop::OnPath(_))
}

/// Whether a tick of `stop` brakes the table's time scale.
fn on_time_scale(stop: &Stop) -> bool {
    matches!(stop, Stop::TimeScale(_))
}

/// A line stopped after `share` of its duration: the plan, the profile time and the joints
/// commanded there.
struct Stopped {
    plan: Path,
    tau: f64,
    joints: [f64; AXES],
}

/// Stops every line of `problems` at the shares of [`STOP_AT`].
pub fn measure(robot: &Robot, problems: &Problems) -> Stops {
    let plans: Vec<Option<LinearMove>> = problems
        .linear
        .iter()
        .map(|c| {
            LinearCase::plan(robot, c.start, &LinearCase::command(c.pose), robot.reserve)
                .ok()
                .flatten()
                .filter(|m| matches!(m.timing().profile, Profile::Table(_)))
        })
        .collect();
    let mut decisions = Vec::new();
    let (mut path_ticks, mut time_scale_ticks) = (Vec::new(), Vec::new());
    let at = STOP_AT
        .iter()
        .map(|&share| {
            let mut set = StopSet::default();
            for (plan, case) in plans.iter().zip(&problems.linear) {
                let Some(m) = plan else {
                    set.ours_s.push(f64::NAN);
                    set.time_scale_s.push(f64::NAN);
                    set.slowest_joint_s.push(f64::NAN);
                    continue;
                };
                let stopped = stopped(m, case.start, share);
                set.slowest_joint_s.push(slowest_joint(robot, &stopped));
                let ours = Stop::of(
                    &stopped.plan,
                    stopped.tau,
                    TimeScale::at(1.0),
                    &stopped.joints,
                );
                let limits = &robot.limits;
                set.path_stops += usize::from(on_path(&ours));
                let (took, handed_over) = run(
                    ours,
                    &stopped,
                    limits,
                    (&mut path_ticks, on_path),
                    &mut set.ours_peaks,
                );
                set.ours_s.push(took);
                set.handovers += usize::from(handed_over);
                let time_scale = Stop::TimeScale(ScaleBrake::new(
                    stopped.tau,
                    1.0,
                    0.0,
                    m.timing().profile.duration(),
                    *m.scale_limits(),
                ));
                let (took, _) = run(
                    time_scale,
                    &stopped,
                    limits,
                    (&mut time_scale_ticks, on_time_scale),
                    &mut set.time_scale_peaks,
                );
                set.time_scale_s.push(took);
                decisions.push(stopped);
            }
            set
        })
        .collect();
    let decision = time_calls(&decisions, |s| {
        Stop::of(&s.plan, s.tau, TimeScale::at(1.0), &s.joints)
    });
    Stops {
        at,
        decision,
        path_tick: CallTimes::of_samples(path_ticks),
        time_scale_tick: CallTimes::of_samples(time_scale_ticks),
    }
}

/// `m` after `share` of its duration, its joints followed there from `start`.
fn stopped(m: &LinearMove, start: [f64; AXES], share: f64) -> Stopped {
    let profile = &m.timing().profile;
    let tau = share * profile.duration();
    let (r, _, _) = profile.eval(tau);
    let mut joints = start;
    for k in 1..=FOLLOW_STEPS {
        let (s, _, _) = m.travel(r * k as f64 / FOLLOW_STEPS as f64, 0.0, 0.0);
        joints = m.joints_at(s, &joints).unwrap_or(joints);
    }
    Stopped {
        plan: Path::Linear(*m),
        tau,
        joints,
    }
}

impl Stopped {
    /// The point commanded when the stop comes.
    fn point(&self) -> JointPoint {
        let (r, rd, rdd) = self.plan.timing().profile.eval(self.tau);
        self.plan.point(r, rd, rdd, &self.joints)
    }
}

/// The longest of the joints' shortest stops from the point commanded at the stop.
fn slowest_joint(robot: &Robot, stopped: &Stopped) -> f64 {
    let point = stopped.point();
    let limits = &robot.limits;
    (0..AXES)
        .map(|i| {
            shortest_stop_time(
                point.qd[i],
                point.qdd[i],
                limits.acceleration[i],
                limits.jerk[i],
            )
        })
        .fold(0.0, f64::max)
}

/// Runs `stop` to rest in ticks, the clock time of each tick that `times.1` selects to
/// `times.0` and what every tick commanded (over `limits`) to `peaks`: the time it takes
/// (NaN if it never stands) and whether a stop of the path parameter handed over to the
/// time scale.
fn run(
    mut stop: Stop,
    stopped: &Stopped,
    limits: &JointLimitsRad,
    times: (&mut Vec<u64>, fn(&Stop) -> bool),
    peaks: &mut Peaks,
) -> (f64, bool) {
    let (times, timed) = times;
    let mut scale = TimeScale::at(1.0);
    let mut before = stopped.point();
    let mut handed_over = false;
    for tick in 1..=MAX_TICKS {
        let braking = stop;
        let start = Instant::now();
        let next = stop.advance(&stopped.plan, TICK_S, &mut scale, &before.q);
        let ns = elapsed_ns(start);
        if timed(&braking) {
            times.push(ns);
        }
        peaks.take(limits, &before, &next.point);
        handed_over |= on_path(&braking) && on_time_scale(&stop);
        before = next.point;
        if next.stopped {
            return (tick as f64 * TICK_S, handed_over);
        }
    }
    (f64::NAN, handed_over)
}
