//! Clock measurements of `rc bench motion`: inverse and forward kinematics per solve, and
//! planning per move, each call timed on its own (`Instant`, whose own cost of some tens of
//! ns is included), plus the solve rate of a loop timed as a whole; and the path timers'
//! own solve times, counted only for the plans that called them; and a step of the safety
//! filter's guard stop.

use std::hint::black_box;
use std::time::Instant;

use planner::linear_move::LinearMove;
use planner::safety_filter::SafetyFilter;
use planner::topp::PathTimer;
use shared_types::ipc::{AXES, JointPoint, MotionCommand};

use super::problems::{JointCase, LinearCase, Problems, Rng, Robot};
use crate::bench::elapsed_ns;
use crate::bench::stats::Distribution;

/// Kinematics solves timed per joint problem.
pub const KINEMATICS_PER_PROBLEM: usize = 50;
/// Times every problem is planned.
pub const PLAN_REPEATS: usize = 5;
/// The tick (s) of the timed guard-stop steps.
const GUARD_TICK_S: f64 = 1e-3;

/// One kind of call: the time of each, and the rate of a loop of all of them.
#[derive(Debug, Clone)]
pub struct CallTimes {
    pub each: Distribution,
    /// Calls per second of the untimed loop.
    pub per_second: f64,
}

/// Everything the clock measured.
#[derive(Debug, Clone)]
pub struct Timings {
    /// `ArmGeometry::inverse`: all eight branches of a flange pose.
    pub ik_all: CallTimes,
    /// `ArmGeometry::inverse_in`: one branch, what a line follows every tick.
    pub ik_one: CallTimes,
    /// `Kinematics::flange`.
    pub fk: CallTimes,
    pub plan_joint: CallTimes,
    /// With the table, as the planner's table thread plans.
    pub plan_linear: CallTimes,
    /// On constant bounds, as the executor's tick plans before the table is there.
    pub plan_linear_tick: CallTimes,
    /// The reachability solve of every linear plan that called it (all its passes).
    pub topp: CallTimes,
    /// The conic problem's solve of every linear move (velocity and acceleration only) whose
    /// plan called it, as clarabel measured it when the problem set was planned.
    pub conic: CallTimes,
    /// A step of a guard stop of the safety filter from a new state (its QP solved, unless
    /// the state is beyond saving and brakes at the limits).
    pub guard_step: CallTimes,
}

impl CallTimes {
    /// Calls timed each alone, in ns: their rate is that of their sum.
    pub fn of_samples(samples: Vec<u64>) -> Self {
        let total_s = samples.iter().sum::<u64>() as f64 * 1e-9;
        let per_second = samples.len() as f64 / total_s.max(f64::MIN_POSITIVE);
        Self {
            each: Distribution::new(samples),
            per_second,
        }
    }
}

/// Times `call` on every input: each call alone, then all in one loop.
pub fn time_calls<I, T>(inputs: &[I], mut call: impl FnMut(&I) -> T) -> CallTimes {
    let mut samples = Vec::with_capacity(inputs.len());
    for input in inputs {
        let start = Instant::now();
        black_box(call(black_box(input)));
        samples.push(elapsed_ns(start));
    }
    let start = Instant::now();
    for input in inputs {
        black_box(call(black_box(input)));
    }
    let total_s = start.elapsed().as_secs_f64();
    CallTimes {
        each: Distribution::new(samples),
        per_second: inputs.len() as f64 / total_s.max(f64::MIN_POSITIVE),
    }
}

/// The input of every case, [`PLAN_REPEATS`] times over.
fn repeated<C, T>(cases: &[C], input: impl Fn(&C) -> T) -> Vec<T> {
    (0..PLAN_REPEATS)
        .flat_map(|_| cases.iter().map(&input))
        .collect()
}

/// Times the kinematics on `count` random joint vectors (seeded by `seed`) and the planning
/// of every problem.
pub fn measure(robot: &Robot, problems: &Problems, seed: u64, count: usize) -> Timings {
    let mut rng = Rng::new(seed);
    let joints: Vec<_> = (0..count).map(|_| rng.joints(&robot.limits)).collect();
    let flanges: Vec<_> = joints
        .iter()
        .map(|q| {
            (
                robot.kinematics.flange(q),
                robot.geometry.arm_config(q),
                q[5],
            )
        })
        .collect();
    let geometry = &robot.geometry;
    let ik_all = time_calls(&flanges, |(f, _, q6)| geometry.inverse(f, *q6));
    let ik_one = time_calls(&flanges, |(f, c, q6)| geometry.inverse_in(f, *c, *q6));
    let fk = time_calls(&joints, |q| robot.kinematics.flange(q));
    let moving: Vec<_> = joints
        .iter()
        .map(|q| JointPoint {
            q: *q,
            qd: core::array::from_fn(|i| rng.uniform(-0.8, 0.8) * robot.limits.velocity[i]),
            ..JointPoint::default()
        })
        .collect();
    let mut guard = SafetyFilter::new(robot.limits).expect("the filter's fixed problem");
    let guard_step = time_calls(&moving, |p| {
        guard.brake(p, GUARD_TICK_S, |q| robot.kinematics.jacobian(q))
    });

    let joint_commands = repeated(&problems.joint, |c| (c.start, JointCase::command(c.target)));
    let plan_joint = time_calls(&joint_commands, |(start, command)| {
        JointCase::plan(robot, *start, command, robot.reserve)
    });
    let linear_commands = repeated(&problems.linear, |c| (c.start, LinearCase::command(c.pose)));
    let plan_linear = time_calls(&linear_commands, |(start, command)| {
        LinearCase::plan(robot, *start, command, robot.reserve)
    });
    let tick_arm = robot.arm_in_the_tick();
    let plan_linear_tick = time_calls(&linear_commands, |(start, command)| {
        LinearCase::plan_with(&tick_arm, *start, command, robot.reserve)
    });
    let topp = topp_solves(robot, &linear_commands);
    let conic = solver_times(problems.conic_solve_s.iter().copied());
    Timings {
        ik_all,
        ik_one,
        fk,
        plan_joint,
        plan_linear,
        plan_linear_tick,
        topp,
        conic,
        guard_step,
    }
}

/// The solve time (s) `timer` spent; `None` if it has made no pass.
///
/// A plan may decide without its timer (a stationary path) or call it more than once (one
/// table per candidate speed bound), and the timer sums up all it spent. So each measured
/// plan gets a timer of its own, whose report is empty until the plan calls it.
pub fn solve_time(timer: &PathTimer) -> Option<f64> {
    let report = timer.report();
    (report.passes > 0).then_some(report.solve_s)
}

/// The solve time of the planner's path timer in every linear plan of `commands` that
/// called it; the rate is solves per second of solve time.
fn topp_solves(robot: &Robot, commands: &[([f64; AXES], MotionCommand)]) -> CallTimes {
    solver_times(commands.iter().filter_map(|(start, command)| {
        // Reachability analysis keeps no state but the report: a new timer costs nothing.
        let timer = PathTimer::reachability(robot.timer.jerk());
        LinearMove::plan(*start, command, &robot.arm_timed_by(&timer), robot.reserve).ok()?;
        solve_time(&timer)
    }))
}

/// The distribution of solve times (s); the rate is solves per second of solve time.
fn solver_times(times: impl Iterator<Item = f64>) -> CallTimes {
    let times: Vec<f64> = times.collect();
    let total_s: f64 = times.iter().sum();
    CallTimes {
        per_second: times.len() as f64 / total_s.max(f64::MIN_POSITIVE),
        each: Distribution::new(times.iter().map(|t| (t * 1e9).round() as u64).collect()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use planner::linear_move::LinearPlan;
    use shared_types::config::Config;
    use shared_types::pose;

    #[test]
    fn only_plans_that_called_the_timer_count_as_solves() {
        let robot = Robot::from_config(&Config::load(None).unwrap()).unwrap();
        let problems = Problems::generate(&robot, 5, 1, 1).unwrap();
        let case = &problems.linear[0];
        let moving = LinearCase::command(case.pose);
        let here = LinearCase::command(pose::pose(&robot.kinematics.flange(&case.start)));

        let timer = PathTimer::reachability(robot.timer.jerk());
        assert_eq!(solve_time(&timer), None);
        let arm = robot.arm_timed_by(&timer);
        LinearMove::plan(case.start, &moving, &arm, robot.reserve).unwrap();
        assert!(solve_time(&timer).is_some_and(|t| t > 0.0));
        let still = LinearMove::plan(case.start, &here, &arm, robot.reserve).unwrap();
        assert!(matches!(still, LinearPlan::Stationary(_)));
        // The shared timer still reports the moving plan's solve.
        assert!(solve_time(&timer).is_some());

        let commands = [
            (case.start, moving),
            (case.start, here),
            (case.start, moving),
        ];
        assert_eq!(topp_solves(&robot, &commands).each.count(), 2);
    }
}
