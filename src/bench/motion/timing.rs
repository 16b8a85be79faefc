//! Clock measurements of `rc bench motion`: inverse and forward kinematics per solve, and
//! planning per move, each call timed on its own (`Instant`, whose own cost of some tens of
//! ns is included), plus the solve rate of a loop timed as a whole.

use std::hint::black_box;
use std::time::Instant;

use planner::linear_move::LinearMove;
use shared_types::ipc::{AXES, MotionCommand};

use super::problems::{JointCase, LinearCase, Problems, Rng, Robot};
use crate::bench::elapsed_ns;
use crate::bench::stats::Distribution;

/// Kinematics solves timed per joint problem.
pub const KINEMATICS_PER_PROBLEM: usize = 50;
/// Times every problem is planned.
pub const PLAN_REPEATS: usize = 5;

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
    pub plan_linear: CallTimes,
    /// The reachability solve of every linear plan (all its passes).
    pub topp: CallTimes,
    /// The conic problem's solve of every linear move (velocity and acceleration only), as
    /// clarabel measured it.
    pub conic: CallTimes,
}

/// Times `call` on every input: each call alone, then all in one loop.
fn time_calls<I, T>(inputs: &[I], mut call: impl FnMut(&I) -> T) -> CallTimes {
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

    let joint_commands = repeated(&problems.joint, |c| (c.start, JointCase::command(c.target)));
    let plan_joint = time_calls(&joint_commands, |(start, command)| {
        JointCase::plan(robot, *start, command, robot.reserve)
    });
    let linear_commands = repeated(&problems.linear, |c| (c.start, LinearCase::command(c.pose)));
    let plan_linear = time_calls(&linear_commands, |(start, command)| {
        LinearCase::plan(robot, *start, command, robot.reserve)
    });
    let topp = topp_solves(robot, &linear_commands);
    let conic = conic_solves(robot, &problems.linear);
    Timings {
        ik_all,
        ik_one,
        fk,
        plan_joint,
        plan_linear,
        topp,
        conic,
    }
}

/// The solve time of the planner's path timer for every linear plan of `commands`; the
/// rate is solves per second of solve time.
fn topp_solves(robot: &Robot, commands: &[([f64; AXES], MotionCommand)]) -> CallTimes {
    solver_times(commands.iter().filter_map(|(start, command)| {
        LinearCase::plan(robot, *start, command, robot.reserve)
            .ok()
            .map(|_| robot.timer.last_report().solve_s)
    }))
}

/// The solve time of the conic problem for every linear move of `cases`, as clarabel
/// measured it.
fn conic_solves(robot: &Robot, cases: &[LinearCase]) -> CallTimes {
    let arm = robot.arm_timed_by(&robot.conic);
    solver_times(cases.iter().filter_map(|c| {
        LinearMove::plan(c.start, &LinearCase::command(c.pose), &arm, 0.0)
            .ok()
            .map(|_| robot.conic.last_report().solve_s)
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
