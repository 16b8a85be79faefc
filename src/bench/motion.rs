//! `rc bench motion`: the motion planner's computing times and how close its moves come to
//! the time-optimal ones.
//!
//! A seeded random problem set on the configured robot (joint moves and straight TCP lines,
//! rest to rest, at 100 % of every limit; see [`problems`]) is planned by our planner through
//! its public planning API. The table shows the time per inverse and forward kinematics
//! solve, per plan of each move type, and the durations of our moves over those of open
//! reference planners on the same limits and problems: ruckig for joint moves (time-optimal
//! and jerk-limited), toppra for the lines (time-optimal on the same joint path, without a
//! jerk limit), and for the lines also a jerk-aware lower bound (the larger of toppra's
//! duration and the slowest single coordinate's time-optimal jerk-limited time, by ruckig).
//! The lines are also measured against their jerk-limited optimum on the same joint path and
//! limits, solved as a nonlinear program (bench/optimum.py, CasADi with IPOPT). The
//! references run in Python (in a virtual environment made by bench/setup.sh); without that
//! environment their rows are skipped.

mod exchange;
mod problems;
mod report;
mod stops;
mod timing;

use std::path::PathBuf;

use clap::Args;
use shared_types::config::Config;

use exchange::{Optimum, Reference, ReferenceError};
use problems::{MAX_TURN_RAD, Ours, Problems, Robot};
use report::{OptimalityRow, TimingRow};
use stops::Stops;
use timing::{CallTimes, Timings};

/// The options of `rc bench motion`.
#[derive(Debug, Clone, Args)]
pub struct Options {
    /// Joint moves in the problem set; half as many linear moves are drawn.
    #[arg(long, default_value_t = 200, value_parser = clap::value_parser!(u32).range(2..=100_000))]
    pub problems: u32,
    /// Seed of the problem set.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Python of the reference environment (made by bench/setup.sh).
    #[arg(
        long,
        value_name = "FILE",
        default_value = "target/bench-venv/bin/python"
    )]
    pub python: PathBuf,
    /// Directory for the problem set, the reference scripts and their results.
    #[arg(long, value_name = "DIR", default_value = "target/bench-motion")]
    pub out: PathBuf,
    /// Linear moves (the first ones) timed by the jerk-limited optimum, about 2 s each; 0
    /// skips it.
    #[arg(long, value_name = "N", default_value_t = 100)]
    pub optimum_lines: u32,
}

/// Everything `rc bench motion` found.
struct MotionResults {
    robot: Robot,
    problems: Problems,
    timings: Timings,
    stops: Stops,
    reference: Result<Reference, ReferenceError>,
    /// `None` where it was not asked for.
    optimum: Option<Result<Optimum, ReferenceError>>,
}

/// Runs `rc bench motion` on the robot of `config`; `Ok(false)` if the reference planners
/// were there but failed.
pub fn run(config: &Config, options: &Options) -> anyhow::Result<bool> {
    let results = measure(config, options, true)?;
    print!("{}", render(&results, options));
    let failed = |r: Option<&ReferenceError>| {
        r.is_some_and(|e| !matches!(e, ReferenceError::NoEnvironment(_)))
    };
    let optimum_failed = results.optimum.as_ref().and_then(|o| o.as_ref().err());
    Ok(!failed(results.reference.as_ref().err()) && !failed(optimum_failed))
}

/// Draws and plans the problems, times the planner and, with `with_reference`, asks the
/// reference planners.
fn measure(
    config: &Config,
    options: &Options,
    with_reference: bool,
) -> anyhow::Result<MotionResults> {
    let robot = Robot::from_config(config)?;
    let joints = options.problems as usize;
    let lines = joints / 2;
    super::progress(&format!(
        "drawing and planning {joints} joint and {lines} linear moves (seed {})",
        options.seed
    ));
    let problems = Problems::generate(&robot, options.seed, joints, lines)?;
    super::progress("timing kinematics and planning");
    let timings = timing::measure(
        &robot,
        &problems,
        options.seed,
        joints * timing::KINEMATICS_PER_PROBLEM,
    );
    super::progress("stopping every line at 10 and 50 % of its time");
    let stops = stops::measure(&robot, &problems);
    let reference = if with_reference {
        super::progress(&format!(
            "reference planners ({} in {})",
            options.python.display(),
            options.out.display()
        ));
        exchange::run_reference(&options.python, &options.out, &robot, &problems)
    } else {
        Err(ReferenceError::NoEnvironment(options.python.clone()))
    };
    let optimum_lines = (options.optimum_lines as usize).min(problems.linear.len());
    let optimum = (with_reference && optimum_lines > 0).then(|| {
        super::progress(&format!(
            "jerk-limited optimum of {optimum_lines} linear moves (about 2 s each)"
        ));
        exchange::run_optimum(
            &options.python,
            &options.out,
            &robot,
            &problems,
            optimum_lines,
        )
    });
    Ok(MotionResults {
        robot,
        problems,
        timings,
        stops,
        reference,
        optimum,
    })
}

fn render(results: &MotionResults, options: &Options) -> String {
    let p = &results.problems;
    let refused: usize = p.refused.values().sum();
    let title = vec![format!(
        "rc bench motion: {}, seed {}, {} joint moves, {} linear moves ({refused} more \
         drawn and refused by the planner), override reserve {}",
        results.robot.name,
        p.seed,
        p.joint.len(),
        p.linear.len(),
        results.robot.reserve
    )];
    report::render(
        &title,
        &timing_rows(&results.timings, &results.stops),
        &optimality_rows(results),
        &notes(results, options),
    )
}

fn timing_rows(t: &Timings, stops: &Stops) -> Vec<TimingRow> {
    let measured = |label: &str, micros: bool, calls: &CallTimes| TimingRow::Measured {
        label: label.to_string(),
        micros,
        summary: calls.each.summary(),
        per_second: calls.per_second,
    };
    vec![
        measured(
            "IK, all 8 branches (ArmGeometry::inverse)",
            false,
            &t.ik_all,
        ),
        measured("IK, one branch (ArmGeometry::inverse_in)", false, &t.ik_one),
        measured("FK (Kinematics::flange)", false, &t.fk),
        measured("plan MoveAxes (JointMove::plan)", true, &t.plan_joint),
        measured(
            "plan MoveLinear in the tick (constant bounds)",
            true,
            &t.plan_linear_tick,
        ),
        measured(
            "plan MoveLinear with its table (table thread)",
            true,
            &t.plan_linear,
        ),
        measured(
            "TOPP-RA solve of one MoveLinear (jerk-limited)",
            true,
            &t.topp,
        ),
        measured(
            "conic TOPP of one MoveLinear (clarabel, v/a only)",
            true,
            &t.conic,
        ),
        measured(
            "guard-stop step of the safety filter (SafetyFilter::brake)",
            true,
            &t.guard_step,
        ),
        measured(
            "GroupStop of a MoveLinear on its table (Stop::of)",
            true,
            &stops.decision,
        ),
        measured(
            "a tick of it braking the path parameter (Stop::advance)",
            true,
            &stops.path_tick,
        ),
        measured(
            "a tick braking the table's time scale alone",
            true,
            &stops.time_scale_tick,
        ),
    ]
}

fn optimality_rows(results: &MotionResults) -> Vec<OptimalityRow> {
    let p = &results.problems;
    let joint: Vec<Ours> = p.joint.iter().map(|c| c.ours).collect();
    let linear: Vec<Ours> = p.linear.iter().map(|c| c.ours).collect();
    let reserve = results.robot.reserve;
    let as_planned = |ours: &[Ours]| ours.iter().map(|o| o.as_planned_s).collect::<Vec<_>>();
    let no_reserve = |ours: &[Ours]| ours.iter().map(|o| o.no_reserve_s).collect::<Vec<_>>();
    let second_order = |ours: &[Ours]| ours.iter().map(|o| o.second_order_s).collect::<Vec<_>>();
    let constant_bounds =
        |ours: &[Ours]| ours.iter().map(|o| o.constant_bounds_s).collect::<Vec<_>>();
    let row = |label: String, ratio: &dyn Fn(&Reference) -> Option<report::RatioStats>| {
        let ratios = reference_ratios(
            &results.reference,
            ratio,
            "the reference planner failed on every problem",
            "the reference planners failed (see below)",
        );
        OptimalityRow { label, ratios }
    };
    let of = report::RatioStats::of;
    let mut rows = vec![
        row(
            format!("MoveAxes / ruckig, as planned (reserve {reserve})"),
            &|r| of(&as_planned(&joint), &r.joint),
        ),
        row("MoveAxes / ruckig, without reserve".into(), &|r| {
            of(&no_reserve(&joint), &r.joint)
        }),
        row(
            format!("MoveLinear / toppra, as planned (reserve {reserve})"),
            &|r| of(&linear_as_planned(p), &r.linear),
        ),
        row("MoveLinear / toppra, without reserve".into(), &|r| {
            of(&no_reserve(&linear), &r.linear)
        }),
        row(
            "MoveLinear / toppra, without reserve and jerk bound".into(),
            &|r| of(&second_order(&linear), &r.linear),
        ),
        row(
            format!("MoveLinear / jerk-aware lower bound, as planned (reserve {reserve})"),
            &|r| of(&linear_as_planned(p), &r.linear_bound),
        ),
        row(
            "MoveLinear / jerk-aware lower bound, without reserve".into(),
            &|r| of(&no_reserve(&linear), &r.linear_bound),
        ),
        OptimalityRow {
            label: format!("MoveLinear / jerk-limited optimum, as planned (reserve {reserve})"),
            ratios: match &results.optimum {
                None => Err("not asked for (--optimum-lines 0)".into()),
                Some(optimum) => reference_ratios(
                    optimum,
                    |o| of(&linear_as_planned(p), &o.linear),
                    "the optimum converged on no line",
                    "bench/optimum.py failed (see below)",
                ),
            },
        },
        row("cross-check: conic TOPP / toppra, the same".into(), &|r| {
            of(&conic(p), &r.linear)
        }),
        row("scale: ruckig / toppra on the MoveAxes".into(), &|r| {
            of(&r.joint, &r.joint_toppra)
        }),
        OptimalityRow {
            label: "scale: MoveLinear on constant bounds / as planned".into(),
            ratios: of(&constant_bounds(&linear), &linear_as_planned(p))
                .ok_or_else(|| "no line planned".to_string()),
        },
    ];
    for (share, set) in stops::STOP_AT.iter().zip(&results.stops.at) {
        let percent = share * 100.0;
        let stop_row = |label: String, ours: &[f64]| OptimalityRow {
            label,
            ratios: of(ours, &set.slowest_joint_s)
                .ok_or_else(|| "no line on its table".to_string()),
        };
        rows.push(stop_row(
            format!("GroupStop at {percent} % of a MoveLinear / slowest joint"),
            &set.ours_s,
        ));
        rows.push(stop_row(
            "the same, braking its time scale alone / slowest joint".to_string(),
            &set.time_scale_s,
        ));
    }
    rows
}

/// The ratios of a row against the answer of a reference script: `ratio` of it, or why there
/// are none (`none` where the reference failed on every problem, `failed` where the script
/// did).
fn reference_ratios<T>(
    answer: &Result<T, ReferenceError>,
    ratio: impl FnOnce(&T) -> Option<report::RatioStats>,
    none: &str,
    failed: &str,
) -> Result<report::RatioStats, String> {
    match answer {
        Ok(a) => ratio(a).ok_or_else(|| none.to_string()),
        Err(ReferenceError::NoEnvironment(_)) => Err("no reference environment".into()),
        Err(_) => Err(failed.to_string()),
    }
}

/// The conic problem's durations of the linear moves (velocity and acceleration only).
fn conic(problems: &Problems) -> Vec<f64> {
    problems.linear.iter().map(|c| c.conic_s).collect()
}

/// Our durations of the linear moves as planned.
fn linear_as_planned(problems: &Problems) -> Vec<f64> {
    problems
        .linear
        .iter()
        .map(|c| c.ours.as_planned_s)
        .collect()
}

/// What the jerk-aware bound says about the lines: which part of it binds, the slowest line
/// against it, and every line faster than it (a planner bug).
fn bound_notes(p: &Problems, r: &Reference) -> Vec<String> {
    let mut notes = Vec::new();
    let jerk_binds = r
        .linear_bound
        .iter()
        .zip(&r.linear)
        .filter(|(bound, toppra)| bound > toppra)
        .count();
    notes.push(format!(
        "the jerk-aware bound is a single coordinate's jerk-limited time on {jerk_binds} of {} \
         lines, toppra's duration on the rest",
        r.linear_bound.len()
    ));
    let line = |k: usize, ours_s: f64| {
        p.linear.get(k).map(|case| {
            format!(
                "[[linear]] {k} of {}, {:.1} mm, ours {ours_s:.3} s, bound {:.3} s, toppra \
                 {:.3} s",
                exchange::PROBLEMS_FILE,
                case.length_m * 1e3,
                r.linear_bound[k],
                r.linear[k],
            )
        })
    };
    let as_planned = linear_as_planned(p);
    if let Some(stats) = report::RatioStats::of(&as_planned, &r.linear_bound)
        && let Some(worst) = line(stats.worst, as_planned[stats.worst])
    {
        notes.push(format!("slowest MoveLinear against the bound: {worst}"));
    }
    let no_reserve: Vec<f64> = p.linear.iter().map(|c| c.ours.no_reserve_s).collect();
    for (what, ours) in [
        ("as planned", &as_planned),
        ("without reserve", &no_reserve),
    ] {
        if let Some(stats) = report::RatioStats::of(ours, &r.linear_bound)
            && stats.below_one > 0
            && let Some(fastest) = line(stats.best, ours[stats.best])
        {
            notes.push(format!(
                "BUG: {} MoveLinear {what} faster than the jerk-aware bound, the fastest: \
                 {fastest}",
                stats.below_one
            ));
        }
    }
    notes
}

fn notes(results: &MotionResults, options: &Options) -> Vec<String> {
    let p = &results.problems;
    let mut notes = vec![
        format!(
            "timing: each call timed alone (the clock's own tens of ns included), on {} random \
             joint vectors and {} repeats of every plan; calls/s from one untimed loop of the \
             same calls",
            p.joint.len() * timing::KINEMATICS_PER_PROBLEM,
            timing::PLAN_REPEATS
        ),
        format!(
            "solver rows: the path timer's own solve time (clarabel's for the conic problem) \
             in the plans that called it (both candidate speed bounds of a line), n counting \
             those; TOPP-RA in {} repeats of every line as the table thread plans it, the conic \
             problem once per line as the set was planned; calls/s = plans per second of solve \
             time",
            timing::PLAN_REPEATS
        ),
        "guard-stop step: one tick (1 ms) of the safety filter's stop from each of the random \
         joint vectors at random speeds of up to 80 % of every joint's limit: its QP solved \
         (a state beyond saving brakes at the limits without it); a guard stop solves about \
         one step a tick, the rest of its setpoint window is remembered"
            .to_string(),
        format!(
            "problems: joint moves from a point within the joint limits a log-uniform 1-100 % \
             of the way to another; lines of 1-60 cm in a random direction with a turn of up \
             to {MAX_TURN_RAD} rad per roll/pitch/yaw angle, from joints within the limits; \
             all rest to rest at 100 % of every limit"
        ),
        "ratio = our duration / reference duration; >1.02: misses the 2 % target; <1.0: \
         faster than the reference"
            .to_string(),
        "MoveAxes: ruckig is time-optimal for the same per-joint v/a/j limits (time-\
         synchronised, free to leave the straight joint line we keep), so <1.0 would mean \
         our limits are broken; the override reserve (acceleration held back so the override \
         may change mid-move) makes ours slower by design"
            .to_string(),
        "MoveLinear: toppra times the same joint path (our samples, cubic spline) under the \
         same joint v/a and TCP v/a limits but has no jerk limit: a lower bound, so ours is \
         expected slower; <1.0 would mean ours breaks a v/a limit. As planned: the faster of \
         the jerk-limited TOPP-RA table (with its speed cap) and the double S on constant \
         bounds, as the planner's table thread plans a line (a standing arm waits for it up \
         to planner.table_wait_ms, a buffered line gets it meanwhile); without jerk bound: \
         TOPP-RA on toppra's constraints alone (no cap), with the conic problem as its \
         cross-check"
            .to_string(),
        "jerk-aware lower bound: the larger of toppra's duration and the time-optimal \
         jerk-limited rest-to-rest time of the slowest single coordinate alone (ruckig, not \
         synchronised): each joint over its net displacement on our path, the TCP over the \
         line's length, under the robot's v/a/j limits without reserve. No timing within \
         those limits can be faster, so <1.0 there means our planner breaks a limit; it is \
         not an optimum (a joint that moves back and forth travels more than its net \
         displacement, and the coordinates are not held to one path)"
            .to_string(),
        "jerk-limited optimum: the shortest timing of the same joint path (our samples, \
         quintic spline) under the same joint and TCP v/a/j limits as planned (acceleration \
         held back by the reserve, as ours), by direct collocation (150 time steps of constant \
         path jerk, the limits at every step boundary; CasADi with IPOPT, a local optimum of \
         a nonconvex program started from ours): the 2 % target's reference for the lines; \
         as the limits hold at the step boundaries only it may be a little shorter than a \
         timing that keeps them everywhere"
            .to_string(),
        "GroupStop: every line on its table stopped after 10 and 50 % of its duration at \
         full override, in 1 ms ticks as the executor brakes (the path parameter where that \
         is predicted to stand sooner, else the table's time scale), against the shortest \
         stop of the slowest joint alone from the point commanded then (its acceleration to \
         the limit and back, without the path: a lower bound); braking the time scale alone: \
         how every stop on a table braked before, side by side"
            .to_string(),
    ];
    for (share, set) in stops::STOP_AT.iter().zip(&results.stops.at) {
        let peaks = |p: &stops::Peaks| {
            format!(
                "velocity {:.3}, acceleration {:.3}, jerk {:.3}",
                p.velocity, p.acceleration, p.jerk
            )
        };
        notes.push(format!(
            "GroupStop at {} %, the highest any joint was commanded over its limit: as the \
             executor stops {} ({} of the stops braked the path parameter, {} of those handed \
             over to the time scale); braking the time scale alone {}",
            share * 100.0,
            peaks(&set.ours_peaks),
            set.path_stops,
            set.handovers,
            peaks(&set.time_scale_peaks),
        ));
    }
    notes.extend([
        "scale: ruckig's jerk-limited optimum over toppra's v/a-only optimum of the same \
         joint moves (straight joint lines): what the jerk limit alone costs on such moves, \
         so the part of the MoveLinear ratio beyond it comes from our planner; constant \
         bounds / as planned: what a line gains by its table (a line runs on constant bounds \
         when its table comes too late)"
            .to_string(),
    ]);
    if !p.refused.is_empty() {
        let reasons: Vec<String> = p.refused.iter().map(|(r, n)| format!("{r} {n}")).collect();
        notes.push(format!(
            "line draws refused by the planner: {}",
            reasons.join(", ")
        ));
    }
    if let Ok(r) = &results.reference {
        notes.extend(bound_notes(p, r));
    }
    match &results.reference {
        Ok(r) => {
            let failed = |d: &[f64]| d.iter().filter(|x| !x.is_finite()).count();
            notes.push(format!(
                "reference: ruckig {} ({:.3} s for all), toppra {} ({:.2} s for the lines); failed: \
                 ruckig {}, toppra {}, bound {}; files in {}",
                r.ruckig_version,
                r.ruckig_s,
                r.toppra_version,
                r.toppra_s,
                failed(&r.joint),
                failed(&r.linear),
                failed(&r.linear_bound),
                options.out.display()
            ));
        }
        Err(ReferenceError::NoEnvironment(python)) => notes.push(format!(
            "optimality skipped: no Python at {}; create the reference environment with \
             `bash bench/setup.sh` in the repository (pip install of ruckig and toppra into \
             target/bench-venv), or point --python at one",
            python.display()
        )),
        Err(e) => notes.push(format!("optimality skipped: {e}")),
    }
    match &results.optimum {
        Some(Ok(o)) => notes.extend(optimum_notes(p, o, options.optimum_lines as usize)),
        Some(Err(ReferenceError::NoEnvironment(_))) | None => {}
        Some(Err(e)) => notes.push(format!(
            "jerk-limited optimum skipped: {e}; `bash bench/setup.sh` installs CasADi"
        )),
    }
    notes
}

/// How the optimum of the first `asked` lines was had and the slowest line against it.
fn optimum_notes(p: &Problems, o: &Optimum, asked: usize) -> Vec<String> {
    let asked = asked.min(p.linear.len());
    let solved = o.linear.iter().filter(|x| x.is_finite()).count();
    let mut notes = vec![format!(
        "optimum: CasADi {}, {solved} of the first {asked} lines converged ({:.0} s)",
        o.casadi_version, o.seconds
    )];
    let as_planned = linear_as_planned(p);
    if let Some(stats) = report::RatioStats::of(&as_planned, &o.linear)
        && let Some(case) = p.linear.get(stats.worst)
    {
        notes.push(format!(
            "slowest MoveLinear against the optimum: [[linear]] {} of {}, {:.1} mm, ours \
             {:.3} s, optimum {:.3} s",
            stats.worst,
            exchange::PROBLEMS_FILE,
            case.length_m * 1e3,
            as_planned[stats.worst],
            o.linear[stats.worst]
        ));
    }
    notes.extend(cancelling_note(&as_planned, o));
    notes
}

/// Share of its limit above which a single term of a joint's acceleration or jerk in the
/// optimum counts as cancelled by the others (in the lines of seed 1 the largest term lies
/// between 1.0 and 8.4 times its limit, continuously; our planner keeps the terms of the
/// jerk other than `q'·s⃛` within the limit together).
const CANCELLING_TERM: f64 = 1.5;

/// Our lines against the optimum apart where the optimum lets single terms far beyond their
/// limit cancel each other (`q'''·ṡ³` against `3·q''·ṡ·s̈` near singular sets, several times
/// the jerk limit each) and where it does not.
fn cancelling_note(as_planned: &[f64], o: &Optimum) -> Option<String> {
    let part = |cancelling: bool| {
        let (ours, optimum): (Vec<f64>, Vec<f64>) = as_planned
            .iter()
            .zip(&o.linear)
            .zip(&o.largest_term)
            .filter(|(_, term)| term.is_finite() && (**term > CANCELLING_TERM) == cancelling)
            .map(|((ours, optimum), _)| (*ours, *optimum))
            .unzip();
        report::RatioStats::of(&ours, &optimum)
    };
    let describe = |s: Option<report::RatioStats>| {
        s.map_or("0 lines".to_string(), |s| {
            format!(
                "{} lines, p50 {:.3}, max {:.3}, {} over {}",
                s.count,
                s.p50,
                s.max,
                s.over_target,
                report::TARGET_RATIO
            )
        })
    };
    let (cancelling, within) = (part(true), part(false));
    cancelling.is_some().then(|| {
        format!(
            "the optimum lets one term of a joint's acceleration or jerk go beyond \
             {CANCELLING_TERM} times its limit, cancelled by the others, on {}; on the rest, \
             {}",
            describe(cancelling),
            describe(within)
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_lines_whose_optimum_cancels_terms_beyond_their_limit_are_counted_apart() {
        let optimum = |largest_term: Vec<f64>| Optimum {
            casadi_version: "3.7.2".into(),
            seconds: 1.0,
            linear: vec![1.0, 1.0, 1.0, f64::NAN],
            largest_term,
        };
        let ours = [1.1, 1.0, 1.01, 2.0];
        let note = cancelling_note(&ours, &optimum(vec![3.0, 1.2, 1.4, f64::NAN])).unwrap();
        assert!(
            note.contains("on 1 lines, p50 1.100, max 1.100, 1 over 1.02; on the rest, 2 lines"),
            "{note}"
        );
        assert_eq!(
            cancelling_note(&ours, &optimum(vec![1.0, 1.2, 1.4, f64::NAN])),
            None
        );
    }

    #[test]
    fn the_rust_side_runs_and_renders_without_python() {
        let config = Config::load(None).unwrap();
        let options = Options {
            problems: 5,
            seed: 3,
            python: PathBuf::from("/nonexistent/python"),
            out: std::env::temp_dir().join("rc-bench-motion-smoke"),
            optimum_lines: 1,
        };
        let results = measure(&config, &options, false).unwrap();
        let p = &results.problems;
        assert_eq!((p.joint.len(), p.linear.len()), (5, 2));
        for ours in p
            .joint
            .iter()
            .map(|c| c.ours)
            .chain(p.linear.iter().map(|c| c.ours))
        {
            for d in [
                ours.as_planned_s,
                ours.no_reserve_s,
                ours.second_order_s,
                ours.constant_bounds_s,
            ] {
                assert!(d.is_finite() && d > 0.0, "{ours:?}");
            }
        }
        let t = &results.timings;
        assert_eq!(t.ik_all.each.count(), 5 * timing::KINEMATICS_PER_PROBLEM);
        assert_eq!(t.plan_linear.each.count(), 2 * timing::PLAN_REPEATS);
        assert_eq!(t.plan_linear_tick.each.count(), 2 * timing::PLAN_REPEATS);
        assert_eq!(t.topp.each.count(), 2 * timing::PLAN_REPEATS);
        assert_eq!(t.conic.each.count(), 2);
        // Both lines stopped at both shares; no stop beats the slowest joint alone.
        assert_eq!(results.stops.at.len(), stops::STOP_AT.len());
        for set in &results.stops.at {
            assert_eq!(set.ours_s.len(), 2);
            let stops = set.ours_s.iter().chain(&set.time_scale_s);
            for (took, slowest) in stops.zip(set.slowest_joint_s.iter().cycle()) {
                assert!(took.is_nan() || took >= slowest, "{took} {slowest}");
            }
            // Every stop within the joint limits, the jerk of its first tick included.
            for p in [set.ours_peaks, set.time_scale_peaks] {
                assert!(
                    p.velocity <= 1.0 + 1e-6 && p.acceleration <= 1.0 + 1e-6,
                    "{p:?}"
                );
                assert!(p.jerk > 0.0 && p.jerk <= 1.0 + 1e-6, "{p:?}");
            }
        }
        let text = render(&results, &options);
        for expected in [
            "IK, all 8 branches",
            "plan MoveLinear",
            "TOPP-RA solve of one MoveLinear",
            "conic TOPP of one MoveLinear",
            "cross-check: conic TOPP / toppra",
            "without reserve and jerk bound",
            "MoveLinear / jerk-aware lower bound, as planned",
            "MoveLinear / jerk-aware lower bound, without reserve",
            "MoveAxes / ruckig, as planned",
            "GroupStop at 10 % of a MoveLinear / slowest joint",
            "braking its time scale alone",
            "GroupStop of a MoveLinear on its table",
            "skipped: no reference environment",
            "bash bench/setup.sh",
        ] {
            assert!(text.contains(expected), "{expected} missing in\n{text}");
        }
    }

    /// A reference for the lines of `p`: toppra at half our durations, the bound at `share`
    /// of ours as planned per line.
    fn reference(p: &Problems, share: &[f64]) -> Reference {
        let ours = linear_as_planned(p);
        Reference {
            ruckig_version: "0".into(),
            toppra_version: "0".into(),
            ruckig_s: 0.0,
            toppra_s: 0.0,
            joint: vec![1.0; p.joint.len()],
            linear: ours.iter().map(|o| 0.5 * o).collect(),
            joint_toppra: vec![1.0; p.joint.len()],
            linear_bound: ours.iter().zip(share).map(|(o, s)| s * o).collect(),
        }
    }

    #[test]
    fn a_line_faster_than_the_jerk_aware_bound_is_named_as_a_bug() {
        let robot = Robot::from_config(&Config::load(None).unwrap()).unwrap();
        let p = Problems::generate(&robot, 3, 2, 2).unwrap();
        let sound = bound_notes(&p, &reference(&p, &[0.9, 0.4]));
        assert!(sound.iter().all(|n| !n.contains("BUG")), "{sound:?}");
        assert!(sound[0].contains("on 1 of 2 lines"), "{sound:?}");
        assert!(
            sound[1].contains("against the bound: [[linear]] 1 of"),
            "{sound:?}"
        );

        let broken = bound_notes(&p, &reference(&p, &[0.9, 1.1]));
        let bug = broken
            .iter()
            .find(|n| n.starts_with("BUG: 1 MoveLinear as planned"))
            .unwrap_or_else(|| panic!("{broken:?}"));
        assert!(bug.contains("the fastest: [[linear]] 1 of"), "{bug}");
    }
}
