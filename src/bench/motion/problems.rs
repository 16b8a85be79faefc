//! The seeded random problem set of `rc bench motion` and our planner's answers to it.
//!
//! Joint moves go rest to rest from a start drawn uniformly within the joint limits towards
//! another such point, a log-uniform share of the way (1 % to 100 %), so short moves that
//! reach neither the velocity nor the acceleration limit are as common as long ones. Linear
//! moves start from joints drawn within the limits and move the TCP (the flange, no tool) by
//! a log-uniform 1 cm to 60 cm in a random direction while turning it by a random rotation of
//! up to [`MAX_TURN_RAD`] per roll/pitch/yaw angle; draws the planner refuses (out of reach,
//! near a singularity, beyond a joint limit) are replaced by new ones and counted.
//!
//! Everything here is pure: the same seed gives the same problems and the same durations.

use std::collections::BTreeMap;

use planner::joint_move::{JointMove, MoveError, Plan};
use planner::kinematics::{ArmGeometry, GeometryError, Kinematics};
use planner::linear_move::{Arm, LinearError, LinearMove, LinearPlan, SAMPLES, TcpLimits};
use planner::topp::{JerkBound, PathTimer};
use shared_types::config::{Config, JointLimitsRad};
use shared_types::ipc::{AXES, MotionCommand, MotionCommandKind};
use shared_types::pose;

use super::timing::solve_time;

/// Shortest joint move, as a share of the way to the drawn point.
const MIN_JOINT_SHARE: f64 = 0.01;
/// Shortest and longest TCP line, m.
const LINE_LENGTH_M: (f64, f64) = (0.01, 0.6);
/// Largest roll, pitch and yaw of the reorientation of a line, rad.
pub const MAX_TURN_RAD: f64 = 0.4;
/// Draws per linear move asked for before the set is given up as unreachable.
const DRAWS_PER_LINE: usize = 200;

/// Why the problem set cannot be made.
#[derive(Debug, thiserror::Error)]
pub enum ProblemError {
    #[error("the robot's kinematics has no analytic inverse: {0}")]
    NoInverse(#[from] GeometryError),
    #[error("the planner refused a problem it accepted before: {0}")]
    Replan(String),
    #[error("only {found} of {wanted} linear moves found in {draws} draws")]
    TooFewLines {
        found: usize,
        wanted: usize,
        draws: usize,
    },
}

/// SplitMix64 (Steele, Lea & Flood 2014): a small, fast generator, reproducible on every
/// platform; statistical quality far beyond what drawing test problems needs.
#[derive(Debug, Clone)]
pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Self {
        Self(seed)
    }

    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in [lo, hi).
    pub fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        // The top 53 bits: every value exactly representable.
        let unit = (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64;
        lo + (hi - lo) * unit
    }

    /// Log-uniform in [lo, hi) (both positive).
    pub fn log_uniform(&mut self, lo: f64, hi: f64) -> f64 {
        self.uniform(lo.ln(), hi.ln()).exp()
    }

    /// Joints uniformly within `limits`.
    pub fn joints(&mut self, limits: &JointLimitsRad) -> [f64; AXES] {
        core::array::from_fn(|i| self.uniform(limits.min[i], limits.max[i]))
    }
}

/// The robot as the planner sees it.
#[derive(Debug)]
pub struct Robot {
    pub name: String,
    pub limits: JointLimitsRad,
    pub tcp: TcpLimits,
    pub kinematics: Kinematics,
    pub geometry: ArmGeometry,
    /// Share of the acceleration the planner holds back for override changes.
    pub reserve: f64,
    /// The planner's path timer: reachability analysis with the jerk bound.
    pub timer: PathTimer,
    /// Reachability analysis on velocity and acceleration only: the constraints toppra has.
    pub second_order: PathTimer,
}

impl Robot {
    /// The robot and the planner settings of `config`.
    pub fn from_config(config: &Config) -> Result<Self, ProblemError> {
        Ok(Self {
            name: config.robot.name.clone(),
            limits: config.robot.limits_rad(),
            tcp: TcpLimits::from_config(&config.robot.cartesian),
            kinematics: Kinematics::new(&config.robot.kinematics),
            geometry: ArmGeometry::new(&config.robot.kinematics)?,
            reserve: config.main.planner.override_reserve,
            timer: PathTimer::reachability(JerkBound::Joints),
            second_order: PathTimer::reachability(JerkBound::Off),
        })
    }

    /// The arm as the planner plans with it.
    pub fn arm(&self) -> Arm<'_> {
        self.arm_timed_by(&self.timer)
    }

    /// The arm with the path timer `timer`.
    pub fn arm_timed_by<'a>(&'a self, timer: &'a PathTimer) -> Arm<'a> {
        Arm {
            timer: Some(timer),
            ..self.arm_in_the_tick()
        }
    }

    /// The arm as the executor's tick plans with it: constant bounds, the table comes
    /// later from the planner's table thread.
    pub fn arm_in_the_tick(&self) -> Arm<'_> {
        Arm {
            kinematics: &self.kinematics,
            geometry: &self.geometry,
            joints: &self.limits,
            tcp: &self.tcp,
            timer: None,
        }
    }
}

/// Durations (s) of our plan of one problem.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ours {
    /// As the planner runs it: with the configured override reserve.
    pub as_planned_s: f64,
    /// With no override reserve: the limits alone.
    pub no_reserve_s: f64,
    /// Linear moves only: with no override reserve and no jerk bound, the constraints toppra
    /// has (joint moves: as `no_reserve_s`).
    pub second_order_s: f64,
    /// Linear moves only: on constant bounds, as the executor's tick plans them, so as a
    /// standing arm runs a line whose table is late (joint moves: as `as_planned_s`).
    pub constant_bounds_s: f64,
}

/// One rest-to-rest joint move (MoveAxes at 100 % of every limit).
#[derive(Debug, Clone, PartialEq)]
pub struct JointCase {
    pub start: [f64; AXES],
    pub target: [f64; AXES],
    pub ours: Ours,
}

impl JointCase {
    pub fn command(target: [f64; AXES]) -> MotionCommand {
        let mut command = MotionCommand::new(MotionCommandKind::MoveAxes);
        command.joints_rad = target;
        command
    }

    /// Our plan with the override reserve `reserve`; `None` if the arm is already there.
    pub fn plan(
        robot: &Robot,
        start: [f64; AXES],
        command: &MotionCommand,
        reserve: f64,
    ) -> Result<Option<JointMove>, MoveError> {
        Ok(
            match JointMove::plan(start, command, &robot.limits, reserve)? {
                Plan::Move(m) => Some(m),
                Plan::Stationary => None,
            },
        )
    }
}

/// One rest-to-rest straight line of the TCP (MoveLinear at 100 % of every limit).
#[derive(Debug, Clone, PartialEq)]
pub struct LinearCase {
    pub start: [f64; AXES],
    /// Target TCP pose `[x, y, z, Rx, Ry, Rz]` (m, rad) in the base frame.
    pub pose: [f64; 6],
    pub length_m: f64,
    /// The joints of our path at `s = k / SAMPLES`, `k = 0..=SAMPLES`.
    pub path: Vec<[f64; AXES]>,
    pub ours: Ours,
    /// The conic problem's duration (s) on the constraints of `ours.second_order_s` (the
    /// cross-check of the reachability analysis).
    pub conic_s: f64,
}

impl LinearCase {
    pub fn command(pose: [f64; 6]) -> MotionCommand {
        let mut command = MotionCommand::new(MotionCommandKind::MoveLinear);
        command.pose = pose;
        command
    }

    /// Our plan with the override reserve `reserve`, as the table thread makes it; `None`
    /// if the TCP is already there.
    pub fn plan(
        robot: &Robot,
        start: [f64; AXES],
        command: &MotionCommand,
        reserve: f64,
    ) -> Result<Option<LinearMove>, LinearError> {
        Self::plan_with(&robot.arm(), start, command, reserve)
    }

    /// Our plan on `arm`; `None` if the TCP is already there.
    pub fn plan_with(
        arm: &Arm<'_>,
        start: [f64; AXES],
        command: &MotionCommand,
        reserve: f64,
    ) -> Result<Option<LinearMove>, LinearError> {
        Ok(match LinearMove::plan(start, command, arm, reserve)? {
            LinearPlan::Move(m) => Some(m),
            LinearPlan::Stationary(_) => None,
        })
    }
}

/// The problem set with our planner's answers.
#[derive(Debug, Clone)]
pub struct Problems {
    pub seed: u64,
    pub joint: Vec<JointCase>,
    pub linear: Vec<LinearCase>,
    /// Linear draws the planner refused, by reason.
    pub refused: BTreeMap<&'static str, usize>,
    /// The conic problem's solve time (s), as clarabel measured it, of every linear move
    /// whose plan solved it: clock readings, the one part a seed does not reproduce.
    pub conic_solve_s: Vec<f64>,
}

impl Problems {
    /// `joints` joint moves and `lines` linear moves drawn with `seed`, planned by our
    /// planner for `robot`.
    pub fn generate(
        robot: &Robot,
        seed: u64,
        joints: usize,
        lines: usize,
    ) -> Result<Self, ProblemError> {
        let mut rng = Rng::new(seed);
        let mut problems = Self {
            seed,
            joint: Vec::with_capacity(joints),
            linear: Vec::with_capacity(lines),
            refused: BTreeMap::new(),
            conic_solve_s: Vec::with_capacity(lines),
        };
        while problems.joint.len() < joints {
            if let Some(case) = draw_joint_case(robot, &mut rng)? {
                problems.joint.push(case);
            }
        }
        let draws = lines * DRAWS_PER_LINE;
        for _ in 0..draws {
            if problems.linear.len() == lines {
                break;
            }
            match draw_linear_case(robot, &mut rng)? {
                Ok((case, conic_solve_s)) => {
                    problems.linear.push(case);
                    problems.conic_solve_s.extend(conic_solve_s);
                }
                Err(reason) => *problems.refused.entry(reason).or_default() += 1,
            }
        }
        if problems.linear.len() < lines {
            return Err(ProblemError::TooFewLines {
                found: problems.linear.len(),
                wanted: lines,
                draws,
            });
        }
        Ok(problems)
    }
}

/// One joint move, `None` for a draw too short to move.
fn draw_joint_case(robot: &Robot, rng: &mut Rng) -> Result<Option<JointCase>, ProblemError> {
    let start = rng.joints(&robot.limits);
    let towards = rng.joints(&robot.limits);
    let share = rng.log_uniform(MIN_JOINT_SHARE, 1.0);
    let target = core::array::from_fn(|i| start[i] + share * (towards[i] - start[i]));
    let command = JointCase::command(target);
    let replan = |e: MoveError| ProblemError::Replan(e.to_string());
    let Some(planned) = JointCase::plan(robot, start, &command, robot.reserve).map_err(replan)?
    else {
        return Ok(None);
    };
    let no_reserve = JointCase::plan(robot, start, &command, 0.0)
        .map_err(replan)?
        .ok_or_else(|| ProblemError::Replan("stationary without reserve".into()))?;
    Ok(Some(JointCase {
        start,
        target,
        ours: Ours {
            as_planned_s: planned.timing().profile.duration(),
            no_reserve_s: no_reserve.timing().profile.duration(),
            second_order_s: no_reserve.timing().profile.duration(),
            constant_bounds_s: planned.timing().profile.duration(),
        },
    }))
}

/// One linear move with the conic problem's solve time (s; `None` if its plan did not solve
/// it), or the reason the planner refused the draw.
fn draw_linear_case(
    robot: &Robot,
    rng: &mut Rng,
) -> Result<Result<(LinearCase, Option<f64>), &'static str>, ProblemError> {
    let start = rng.joints(&robot.limits);
    let tcp = robot.kinematics.flange(&start);
    let direction = unit_vector(rng);
    let length_m = rng.log_uniform(LINE_LENGTH_M.0, LINE_LENGTH_M.1);
    let turn = pose::isometry([
        0.0,
        0.0,
        0.0,
        rng.uniform(-MAX_TURN_RAD, MAX_TURN_RAD),
        rng.uniform(-MAX_TURN_RAD, MAX_TURN_RAD),
        rng.uniform(-MAX_TURN_RAD, MAX_TURN_RAD),
    ]);
    let at = pose::pose(&tcp);
    let turned = pose::pose(&(turn * tcp));
    let target = [
        at[0] + length_m * direction[0],
        at[1] + length_m * direction[1],
        at[2] + length_m * direction[2],
        turned[3],
        turned[4],
        turned[5],
    ];
    let command = LinearCase::command(target);
    let planned = match LinearCase::plan(robot, start, &command, robot.reserve) {
        Ok(Some(m)) => m,
        Ok(None) => return Ok(Err("no motion")),
        Err(e) => return Ok(Err(refusal(&e))),
    };
    let replan = |e: LinearError| ProblemError::Replan(e.to_string());
    let no_reserve = LinearCase::plan(robot, start, &command, 0.0)
        .map_err(replan)?
        .ok_or_else(|| ProblemError::Replan("stationary without reserve".into()))?;
    let second_order = LinearMove::plan(
        start,
        &command,
        &robot.arm_timed_by(&robot.second_order),
        0.0,
    )
    .map_err(replan)?;
    let constant_bounds =
        LinearCase::plan_with(&robot.arm_in_the_tick(), start, &command, robot.reserve)
            .map_err(replan)?
            .ok_or_else(|| ProblemError::Replan("stationary on constant bounds".into()))?;
    let LinearPlan::Move(second_order) = second_order else {
        return Err(ProblemError::Replan("stationary without jerk bound".into()));
    };
    // A conic timer of its own: its report stays empty unless this plan solves (see
    // `timing::solve_time`).
    let conic_timer = PathTimer::conic(JerkBound::Off);
    let conic = LinearMove::plan(start, &command, &robot.arm_timed_by(&conic_timer), 0.0)
        .map_err(replan)?;
    let LinearPlan::Move(conic) = conic else {
        return Err(ProblemError::Replan(
            "stationary for the conic timer".into(),
        ));
    };
    let mut path = Vec::with_capacity(SAMPLES + 1);
    let mut previous = start;
    for k in 0..=SAMPLES {
        // By the path position: a table on the joints' pace runs on another parameter.
        previous = planned
            .joints_at(k as f64 / SAMPLES as f64, &previous)
            .ok_or_else(|| ProblemError::Replan("a surveyed point without joints".into()))?;
        path.push(previous);
    }
    let case = LinearCase {
        start,
        pose: target,
        length_m,
        path,
        ours: Ours {
            as_planned_s: planned.timing().profile.duration(),
            no_reserve_s: no_reserve.timing().profile.duration(),
            second_order_s: second_order.timing().profile.duration(),
            constant_bounds_s: constant_bounds.timing().profile.duration(),
        },
        conic_s: conic.timing().profile.duration(),
    };
    Ok(Ok((case, solve_time(&conic_timer))))
}

/// A direction uniformly on the unit sphere (rejection sampling in the cube).
fn unit_vector(rng: &mut Rng) -> [f64; 3] {
    loop {
        let v = [(); 3].map(|()| rng.uniform(-1.0, 1.0));
        let norm = v.iter().map(|x| x * x).sum::<f64>().sqrt();
        // Inside the ball, and away from the centre, where rounding would bias the direction.
        if (0.1..=1.0).contains(&norm) {
            return v.map(|x| x / norm);
        }
    }
}

/// The kind of a refusal, for the count per reason.
fn refusal(error: &LinearError) -> &'static str {
    match error {
        LinearError::Unreachable { .. } => "out of reach",
        LinearError::Singular { .. } => "singular",
        LinearError::Move(
            MoveError::BelowLowerLimit { .. } | MoveError::AboveUpperLimit { .. },
        ) => "joint limit",
        _ => "other",
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn robot() -> Robot {
        Robot::from_config(&Config::load(None).unwrap()).unwrap()
    }

    #[test]
    fn the_generator_is_reproducible_and_in_range() {
        let (mut a, mut b) = (Rng::new(7), Rng::new(7));
        for _ in 0..1000 {
            let x = a.uniform(-2.0, 3.0);
            assert_eq!(x, b.uniform(-2.0, 3.0));
            assert!((-2.0..3.0).contains(&x));
            let y = a.log_uniform(0.01, 0.6);
            b.log_uniform(0.01, 0.6);
            assert!((0.01..=0.6).contains(&y), "{y}");
        }
        assert_ne!(Rng::new(1).next_u64(), Rng::new(2).next_u64());
    }

    #[test]
    fn unit_vectors_have_unit_length() {
        let mut rng = Rng::new(3);
        for _ in 0..100 {
            let v = unit_vector(&mut rng);
            assert!((v.iter().map(|x| x * x).sum::<f64>() - 1.0).abs() < 1e-12);
        }
    }

    #[test]
    fn a_seed_gives_the_same_problems_and_the_planner_accepts_them() {
        let robot = robot();
        let a = Problems::generate(&robot, 11, 4, 2).unwrap();
        let b = Problems::generate(&robot, 11, 4, 2).unwrap();
        assert_eq!(
            (&a.joint, &a.linear, &a.refused),
            (&b.joint, &b.linear, &b.refused)
        );
        // Every line of the set is long enough for its plan to solve the conic problem.
        assert_eq!(a.conic_solve_s.len(), 2);
        assert!(
            a.conic_solve_s.iter().all(|&t| t > 0.0),
            "{:?}",
            a.conic_solve_s
        );
        assert_ne!(a.joint, Problems::generate(&robot, 12, 4, 2).unwrap().joint);
        assert_eq!((a.joint.len(), a.linear.len()), (4, 2));
        for case in &a.joint {
            for i in 0..AXES {
                assert!(robot.limits.min[i] <= case.target[i]);
                assert!(case.target[i] <= robot.limits.max[i]);
            }
            // The override reserve only ever slows a move down.
            // The reserve only tightens the limits, but the jerk-limited pass is not an
            // exact optimum: with tighter limits it may find a table a little faster.
            assert!(
                case.ours.as_planned_s >= 0.98 * case.ours.no_reserve_s,
                "{:?}",
                case.ours
            );
        }
        for case in &a.linear {
            assert_eq!(case.path.len(), SAMPLES + 1);
            for (q, start) in case.path[0].iter().zip(&case.start) {
                assert!(
                    (q - start).abs() < 1e-9,
                    "{:?} {:?}",
                    case.path[0],
                    case.start
                );
            }
            // The path ends where the TCP reaches the target pose.
            let end = pose::pose(&robot.kinematics.flange(case.path.last().unwrap()));
            for (reached, wanted) in end.iter().zip(&case.pose).take(3) {
                assert!((reached - wanted).abs() < 1e-9, "{end:?} {:?}", case.pose);
            }
            // The reserve only tightens the limits, but the jerk-limited pass is not an
            // exact optimum: with tighter limits it may find a table faster. Where the bend
            // term 3·|q''|·ṡ·|s̈| may take the whole jerk budget, a smaller |s̈| leaves more
            // of it to change s̈ with (7 % faster on one of these lines).
            assert!(
                case.ours.as_planned_s >= 0.9 * case.ours.no_reserve_s,
                "{:?}",
                case.ours
            );
        }
    }

    /// The joint path of every line goes to the reference planners at equal shares of the
    /// line (toppra's virtual TCP coordinate is linear in them), also where our table runs
    /// on the joints' pace: seed 1's fifth line does (its planned points at equal steps of
    /// the table's parameter bunch up where the joints turn fast).
    #[test]
    fn the_reference_gets_the_line_at_equal_shares() {
        let robot = robot();
        let problems = Problems::generate(&robot, 1, 200, 5).unwrap();
        for (n, case) in problems.linear.iter().enumerate() {
            let from = robot.kinematics.flange(&case.start).translation.vector;
            for (k, q) in case.path.iter().enumerate() {
                let travelled = (robot.kinematics.flange(q).translation.vector - from).norm();
                let share = k as f64 / SAMPLES as f64;
                assert!(
                    (travelled - share * case.length_m).abs() < 1e-9,
                    "line {n}, sample {k}: {travelled} m"
                );
            }
        }
    }

    #[test]
    fn refusals_are_counted_by_reason() {
        let e = LinearError::Move(MoveError::AboveUpperLimit {
            axis: 1,
            target_rad: 5.0,
            limit_rad: 4.0,
        });
        assert_eq!(refusal(&e), "joint limit");
        assert_eq!(refusal(&LinearError::Singular { s: 0.5 }), "singular");
        assert_eq!(
            refusal(&LinearError::Unreachable { s: 0.5 }),
            "out of reach"
        );
        assert_eq!(refusal(&LinearError::TurnMismatch), "other");
    }
}
