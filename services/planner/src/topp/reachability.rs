//! Time-optimal path parameterisation by reachability analysis (TOPP-RA, Pham & Pham 2018)
//! on the grid of [`PathSamples`], with a jerk-limited forward pass.
//!
//! # Stages
//!
//! Stage `k` is the interval `[s_k, s_{k+1}]` with `x = ṡ²` at `s_k` and a constant path
//! acceleration `u = s̈`, so `x_{k+1} = x_k + 2Δs·u`. Its rows are those of the conic
//! problem of [`topp`](super), all linear in `(u, x)`: the joint accelerations
//! `|q'_i·u + q''_i·x_e| ≤ a_i` at both ends `e` of the interval and the TCP's
//! `|p'|·|u| + |p''|·x_e ≤ a_tcp` (within [`GRID_MARGIN`]), the tangential shares of the
//! acceleration and deceleration rates, and `x ≤ x̄` for the speed bounds (joint and TCP
//! velocity, the speed cap). A stage's LP has two variables and is solved exactly: every
//! row bounds `u` from above or from below as a function of `x` (or bounds `x` alone), and
//! every pair of a lower and an upper bound on `u` gives, with `u` eliminated, a row on `x`
//! (Fourier–Motzkin). The `x` of a stage with an admissible `u` therefore form an interval.
//!
//! # Passes
//!
//! The backward pass finds the controllable sets: `K_N = {0}` and `K_k` the `x` at `s_k`
//! from which an admissible `u` leads into `K_{k+1}`. The forward pass starts at `x_0 = 0`
//! and takes the largest admissible `u` into `K_{k+1}` at every stage: the time-optimal
//! timing of the grid (the one the conic problem finds without its jerk rows).
//!
//! # Jerk
//!
//! The [`TableProfile`] runs `s̈` from `u_{m−1}` at the middle of interval `m − 1` to `u_m`
//! at the middle of `m` (`u_{−1} = u_N = 0`) and its positions follow it. In the zones next
//! to the ends it does so linearly in time, at a path jerk of the change over the stretch's
//! time (estimated here from the table's speeds at the middles); between them linearly in
//! `s`, at `(u_m − u_{m−1})·ṡ/Δs`, largest at the stretch's fastest point (a middle, or `m`
//! itself where the speed peaks); from and to rest it ramps at a constant jerk, which
//! reaches `u_0` (or `u_{N−1}`) over `√6·Δs/ṡ` of the speed next to the end. The last pass
//! checks the table as it runs, stretch by stretch. With
//! `q⃛ = q'''·ṡ³ + 3·q''·ṡ·s̈ + q'·s⃛` the joints' jerk budget leaves `s⃛` a window
//! `[−down_m, up_m]`: per joint
//! `(j_i ∓ σ_i·q'''_i·ṡ³ ∓ 3·σ_i·q''_i·ṡ·s̈)/|q'_i|`, `σ_i` the sign of `q'_i`, over the
//! ranges of `ṡ`, `s̈`, `q''` and `q'''` around `m` and the largest `|q'|` there (where
//! `q'_i` changes sign around `m`, the smaller of the two with `σ_i = 1`, as `q'_i·s⃛` takes
//! either sign; for the TCP by the terms' magnitudes either way; see `JerkRows`), so the
//! change of `u` at `m` has a window. To keep the budget positive the
//! speed is capped where `|q'''|·ṡ³` would take more than the share
//! [`ToppLimits::third_share`] of it, and `s̈` is held where the window stays open both ways
//! at every speed up to the stage's speed bound (the largest speed around the stage): per
//! joint `|q'''·ṡ³ + 3·q''·ṡ·s̈| ≤ j` with both terms at the same speed and with their
//! signs, so that braking where `q'''` has the sign of `q'` and `q''`, the one term takes
//! back what the other spends (seed 1 line 74 of `rc bench motion`: the optimum brakes with
//! the curvature term at −1.19 times the jerk limit and the third-derivative term at +0.28;
//! held by magnitude, our table took 1.24 times as long as the optimum, with the signs
//! 1.21). Each pass lowers that bound to the profile of the pass before (the time-optimal
//! one without the jerk window first, the pointwise fastest), and the hold on `s̈` with it:
//! a pass keeps under the profile it runs under. The passes are first run free of the hold
//! and held only where those find no table (`Hold`): free, `q'·s⃛` may answer what the
//! two terms take beyond the limit, as in the jerk-limited optimum near singular sets.
//!
//! The jerk-limited forward pass takes at every stage the largest `u` in that window whose
//! fastest way down (`u` lowered as fast as the window allows, down to the largest braking
//! the rows allow) stays within the controllable sets: a pass that accelerates too long
//! could not brake in time. The end of the path needs `u` back at 0 as the path stops,
//! which no forward look-ahead sees: the same pass on the reversed path (braking seen as
//! speeding up, from the end), under the forward profile as its speed bound, ends at rest
//! with a jerk-limited ramp and meets the forward profile where that one is jerk-limited;
//! a last forward pass runs under it. (A forward profile that comes to rest before the end
//! bounds the reversed pass only up to its peak before that rest.) What is left, where the
//! estimates of a window were too optimistic, is found by checking the jerk of the table
//! made of the result around every grid point: before such a point the speed bound is
//! lowered a little under the profile and the last pass repeated, at most [`MAX_REPAIRS`]
//! times. Every pass runs under the profile of the one before, so each profile's duration
//! is a lower bound of the table's: a candidate that is already no faster than the best
//! table so far stops there. All of it works on fixed-size arrays, without allocation.

use shared_types::ipc::AXES;

use super::table::{self, ZONE};
use super::{
    GRID_MARGIN, INTERVALS, JerkBound, MOVING, POINTS, PathSamples, TableProfile, ToppError,
    ToppLimits, interval_reach, speed_limits,
};

/// Times the speed bound is lowered before a jerk-limited profile is given up.
pub const MAX_REPAIRS: usize = 8;
/// Factor on the profile's speed² where a repair lowers the speed bound.
const REPAIR_FACTOR: f64 = 0.9;
/// Grid points before a jerk violation whose speed bound a repair lowers.
const REPAIR_SPAN: usize = 16;
/// Regula falsi steps for a jerk window that depends on the `u` it bounds.
const WINDOW_STEPS: usize = 8;
/// Room left in a jerk window (relative to the `u` it is at) that is taken as its edge: the
/// `u` found is always inside the window, this only says how near its edge. From 1e-9 to
/// 1e-5 the jerk-limited passes took 18 % less time and the tables of the 100 lines of
/// `rc bench motion` (seed 1) changed by 0.06 % at most.
const WINDOW_TOLERANCE: f64 = 1e-5;
/// Relative slack of the jerk check for rounding.
const JERK_TOLERANCE: f64 = 1e-6;
/// Absolute slack of the jerk check for rounding, in 1/s³ of the path jerk.
const JERK_FLOOR: f64 = 1e-9;
/// Share of a change's span the windows plan with. The table's speeds between its zones
/// run above the grid's where its zones drift faster than the ramps lose (its stretches'
/// jerk over the window by up to about 0.1 %): with 1 or 0.999, some of 1000 random paths
/// of `random_paths_keep_the_limits` found no jerk-limited table within the repairs, with
/// 0.998 none of 3000 (and the bench's lines take 0.06 % longer at the median).
const DRIFT_SHARE: f64 = 0.998;
/// Slack of the feasibility tests, relative to the largest speed bound.
const FEASIBILITY: f64 = 1e-9;
/// Rows of one stage: joints at both ends with both signs, the TCP at both ends with both
/// signs, the tangential bounds and the controllable set of the next point.
const STAGE_ROWS: usize = 4 * AXES + 4 + 2 + 2;
/// Grid step of `s`.
const STEP: f64 = 1.0 / INTERVALS as f64;
/// The change of `s̈` at an end of the path, over `Δs/ṡ` of the speed next to it, that a
/// table's ramp from or to rest makes at a jerk of 1: the ramp to `s̈ = α` over `Δs/2`
/// takes `√(3·Δs/α) = √6·Δs/ṡ` (`ṡ² = 2·α·Δs` the table's speed² next to the end). Half a
/// per cent of it is left for the tilt of the table's `s̈`, which raises the larger of the
/// two ramps' `α` by `Δs/8` of it at most (its jerk, `∝ α^(3/2)`, by 0.07 %).
const RAMP_SPAN: f64 = 0.995 * 2.449_489_742_783_178;

/// Times `samples` within `limits`: the time-optimal table (with `jerk`, the jerk-limited
/// one) and the passes it took. A jerk-limited table is of use only if it takes less than
/// `longest` (s): when the table without the jerk window or a jerk-limited pass before the
/// last (each a lower bound of its duration) does not, the passes after it are skipped
/// ([`ToppError::NotFaster`]).
pub fn time(
    samples: &PathSamples,
    limits: &ToppLimits,
    jerk: JerkBound,
    longest: f64,
) -> Result<(TableProfile, usize), ToppError> {
    let mut count = 0;
    // A free pass's profile is no lower bound of a held table (the free forward pass may
    // have to brake where the held one did not speed up), so free timings given up as not
    // faster are timed held, too.
    let free = passes(samples, limits, jerk, Hold::Free, longest, &mut count);
    let timed = match free {
        Err(_) if jerk == JerkBound::Joints => {
            passes(samples, limits, jerk, Hold::Held, longest, &mut count)
        }
        _ => free,
    };
    timed.map(|table| (table, count))
}

/// Whether the jerk-limited passes hold `s̈` where the jerk window stays open both ways
/// ([`JerkRows::hold`]).
///
/// Free, the passes may take `s̈` where `q'''·ṡ³ + 3·q''·ṡ·s̈` alone exceeds a joint's
/// jerk limit and `q'·s⃛` has to answer it, as the jerk-limited optimum does near singular
/// sets: the window then no longer holds `s⃛ = 0`, and a pass can run into a point where
/// it holds nothing reachable (a table that comes to rest inside the path, or a jerk the
/// repairs do not settle). Held, it always holds `s⃛ = 0`, which no pass runs out of, but
/// the passes are slower where the two terms would cancel: `rc bench motion` (seed 1), 100
/// lines against their jerk-limited optimum, held always: 30 over 1.02, free first and held
/// where free found no table: 18, 1.05 % less time in sum, 12 lines slower by at most
/// 0.055 %.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Hold {
    Free,
    Held,
}

/// The passes of [`time`] with the hold on `s̈` as `hold`, each counted in `count`.
fn passes(
    samples: &PathSamples,
    limits: &ToppLimits,
    jerk: JerkBound,
    hold: Hold,
    longest: f64,
    count: &mut usize,
) -> Result<TableProfile, ToppError> {
    let mut forward = Problem::new(samples, limits, jerk, hold)?;
    let mut sets = Sets::new();
    let mut x = [0.0; POINTS];
    forward.controllable(&mut sets)?;
    forward.greedy(&sets, &mut x);
    *count += 1;
    if jerk == JerkBound::Off {
        return table(&x, jerk);
    }
    // Every pass below only lowers the speeds: each profile's duration is a lower bound of
    // the next one's (the ramps from and to rest of a lower profile take longer, too: its
    // accelerations at the ends are no larger). On steps of `s̈` from and to rest instead,
    // the bound was looser by the ramps, and 30 % more of the candidates of the 100 lines of
    // `rc bench motion` ran their last pass, the same tables won.
    let may_be_faster = |x: &[f64; POINTS]| {
        if table(x, jerk).is_ok_and(|t| t.duration() >= longest) {
            return Err(ToppError::NotFaster(longest));
        }
        Ok(())
    };
    may_be_faster(&x)?;
    // Forward under the controllable sets alone (and that profile, the pointwise fastest):
    // right but for the end of the path.
    forward.lower_bound(&x, INTERVALS);
    forward.controllable(&mut sets)?;
    forward.jerk_greedy(&sets, &mut x);
    *count += 1;
    may_be_faster(&x)?;
    // From the end under that profile (up to where it is of use): right but for the start,
    // and it meets the forward profile where that one is jerk-limited already.
    let trusted = forward.trusted_until(&x);
    let mut problem = forward;
    problem.lower_bound(&x, trusted);
    let reversed = problem.reversed();
    reversed.controllable(&mut sets)?;
    reversed.jerk_greedy(&sets, &mut x);
    *count += 1;
    may_be_faster(&x)?;
    x.reverse();
    problem.lower_bound(&x, INTERVALS);
    for _ in 0..=MAX_REPAIRS {
        problem.controllable(&mut sets)?;
        problem.jerk_greedy(&sets, &mut x);
        *count += 1;
        let table = table(&x, jerk)?;
        let Some(m) = problem.jerk_violation(&table) else {
            return Ok(table);
        };
        let before = m.saturating_sub(REPAIR_SPAN).max(1)..=m.min(INTERVALS - 1);
        for (bound, x) in problem.bound[before.clone()].iter_mut().zip(&x[before]) {
            *bound = bound.min(REPAIR_FACTOR * x);
        }
        problem.rates();
    }
    Err(ToppError::JerkUnsettled(MAX_REPAIRS + 4))
}

/// The speed `ṡ` of the speed² `x` (rounding may leave `x` a hair below 0).
fn speed(x: f64) -> f64 {
    x.max(0.0).sqrt()
}

/// The table of the speeds² `x` at the grid points, its ramps from and to rest as `jerk`.
fn table(x: &[f64; POINTS], jerk: JerkBound) -> Result<TableProfile, ToppError> {
    Ok(TableProfile::from_speeds(&x.map(speed), jerk)?)
}

/// The largest magnitudes of the derivatives of `samples` at grid point `k` and its
/// neighbours (the same either way along the path).
fn envelope(samples: &PathSamples, k: usize) -> Envelope {
    let s = samples;
    let mut e = Envelope {
        slope: [0.0; AXES],
        curvature: [0.0; AXES],
        third: [0.0; AXES],
        tcp_speed: 0.0,
        tcp_curvature: 0.0,
        tcp_third: 0.0,
    };
    for p in k.saturating_sub(1)..=(k + 1).min(INTERVALS) {
        for i in 0..AXES {
            e.slope[i] = e.slope[i].max(s.slope[p][i].abs());
            e.curvature[i] = e.curvature[i].max(s.curvature[p][i].abs());
            e.third[i] = e.third[i].max(s.third[p][i].abs());
        }
        e.tcp_speed = e.tcp_speed.max(s.tcp_speed[p].abs());
        e.tcp_curvature = e.tcp_curvature.max(s.tcp_curvature[p].abs());
        e.tcp_third = e.tcp_third.max(s.tcp_third[p].abs());
    }
    e
}

/// One row `u·u_coefficient + x·x_coefficient ≤ rhs`, scaled to a largest coefficient of 1.
#[derive(Debug, Clone, Copy, Default)]
struct Row {
    u: f64,
    x: f64,
    rhs: f64,
}

/// The rows of one stage.
struct StageRows {
    rows: [Row; STAGE_ROWS],
    len: usize,
}

/// Receives the rows of a stage.
trait RowSink {
    /// The row `u·cu + x·cx ≤ rhs`. Rows without a finite bound are left out: every row's
    /// right-hand side is a limit, so without variables `0 ≤ rhs` holds.
    fn push(&mut self, cu: f64, cx: f64, rhs: f64);
}

impl RowSink for StageRows {
    fn push(&mut self, cu: f64, cx: f64, rhs: f64) {
        let size = cu.abs().max(cx.abs());
        if !(rhs.is_finite() && size > 0.0) || self.len == STAGE_ROWS {
            return;
        }
        self.rows[self.len] = Row {
            u: cu / size,
            x: cx / size,
            rhs: rhs / size,
        };
        self.len += 1;
    }
}

/// The admissible `u` at one `x`, gathered row by row: `(lowest, highest)`, empty
/// (`lowest > highest`) where a row on `x` alone fails by more than `slack`.
struct URange {
    x: f64,
    slack: f64,
    lowest: f64,
    highest: f64,
}

impl URange {
    fn at(x: f64, slack: f64) -> Self {
        Self {
            x,
            slack,
            lowest: f64::NEG_INFINITY,
            highest: f64::INFINITY,
        }
    }
}

impl RowSink for URange {
    fn push(&mut self, cu: f64, cx: f64, rhs: f64) {
        if !rhs.is_finite() {
            return;
        }
        let room = rhs - cx * self.x;
        if cu > 0.0 {
            self.highest = self.highest.min(room / cu);
        } else if cu < 0.0 {
            self.lowest = self.lowest.max(room / cu);
        } else if room < -self.slack {
            (self.lowest, self.highest) = (f64::INFINITY, f64::NEG_INFINITY);
        }
    }
}

impl StageRows {
    fn new() -> Self {
        Self {
            rows: [Row::default(); STAGE_ROWS],
            len: 0,
        }
    }

    fn rows(&self) -> &[Row] {
        &self.rows[..self.len]
    }

    /// The interval of `x` in `[0, bound]` with an admissible `u` (Fourier–Motzkin);
    /// `None` if it is empty.
    fn x_range(&self, bound: f64, slack: f64) -> Option<(f64, f64)> {
        let (mut lo, mut hi) = (0.0f64, bound);
        let mut on_x = |cx: f64, rhs: f64| {
            if cx > 0.0 {
                hi = hi.min(rhs / cx);
            } else if cx < 0.0 {
                lo = lo.max(rhs / cx);
            } else {
                return rhs >= -slack;
            }
            true
        };
        let rows = self.rows();
        for r in rows.iter().filter(|r| r.u == 0.0) {
            if !on_x(r.x, r.rhs) {
                return None;
            }
        }
        for upper in rows.iter().filter(|r| r.u > 0.0) {
            for lower in rows.iter().filter(|r| r.u < 0.0) {
                // upper.u·(lower row) − lower.u·(upper row): u cancels.
                let cx = upper.u * lower.x - lower.u * upper.x;
                let rhs = upper.u * lower.rhs - lower.u * upper.rhs;
                let cx = if cx.abs() < f64::EPSILON { 0.0 } else { cx };
                if !on_x(cx, rhs) {
                    return None;
                }
            }
        }
        if lo > hi + slack {
            return None;
        }
        Some((lo.min(hi), hi))
    }
}

/// The controllable sets `[lo_k, hi_k]` of `x` at the grid points.
struct Sets {
    lo: [f64; POINTS],
    hi: [f64; POINTS],
}

impl Sets {
    fn new() -> Self {
        Self {
            lo: [0.0; POINTS],
            hi: [0.0; POINTS],
        }
    }
}

/// The timing problem of a path, forward or reversed (`s → 1 − s`: `q'` and `q'''` change
/// sign, braking becomes speeding up).
#[derive(Clone, Copy)]
struct Problem<'a> {
    samples: &'a PathSamples,
    limits: &'a ToppLimits,
    jerk: JerkBound,
    hold: Hold,
    reversed: bool,
    /// Largest `x` at every grid point.
    bound: [f64; POINTS],
    /// The tangential reach of every interval at the speed bound of the problem as made
    /// (what the joints allow `|s̈|` at most; the rates' shares of it bound `s̈`).
    reach: [f64; INTERVALS],
    /// Largest `s̈` and `−s̈` in every interval.
    speed_up: [f64; INTERVALS],
    braking: [f64; INTERVALS],
    /// Slack of the feasibility tests.
    slack: f64,
    /// The jerk budgets of every grid point.
    jerk_rows: [JerkRows; POINTS],
}

/// The derivatives of the path at one grid point, in the problem's direction.
struct Point {
    slope: [f64; AXES],
    curvature: [f64; AXES],
    tcp_speed: f64,
    tcp_curvature: f64,
}

/// The jerk budgets of a grid point for `s⃛`, one row per moving joint and the TCP, each
/// limit's terms over its largest `|q'|` (or `|p'|`) around the point once, as the
/// jerk-limited passes ask for a point's window many times at different speeds: with `σ`
/// the sign of `q'`, `|q⃛| ≤ j` is `|σ·q'''/|q'|·ṡ³ + 3·σ·q''/|q'|·ṡ·s̈ + s⃛| ≤ j/|q'|`, so
/// `s⃛` may rise by `budget − max(third·ṡ³) − max(cross·ṡ·s̈)` and fall by
/// `budget + min(third·ṡ³) + min(cross·ṡ·s̈)`, `third` and `cross` the ranges of
/// `σ·q'''/|q'|` and `3·σ·q''/|q'|` around the point. Both terms count with their sign
/// (braking where `q''` and `q'` have the same sign, there is more room to ease off than to
/// brake harder): `q''` as sampled, `q'''` as the differences of `q''` over the intervals
/// around, widened by what the sampled `|q'''|` (which may come from finer steps) exceeds
/// them by. Where `q'` changes sign around the point, `σ = 1` and the window is the room the
/// larger of `±(q'''·ṡ³ + 3·q''·ṡ·s̈)` leaves, both ways (`q'·s⃛` takes either sign there);
/// still with the terms' signs, so braking where `q''` and `q'''` have the same sign the
/// one takes back what the other spends. For the TCP (whose derivatives are norms) by their
/// magnitudes either way.
#[derive(Clone, Copy)]
struct JerkRows {
    budget: [f64; AXES + 1],
    /// `(lowest, highest)` of `σ·q'''/|q'|` around the point.
    third: [(f64, f64); AXES + 1],
    /// `(lowest, highest)` of `3·σ·q''/|q'|` around the point.
    cross: [(f64, f64); AXES + 1],
    /// Rows of a joint whose `q'` changes sign around the point: `σ = 1`, and as `q'·s⃛`
    /// takes either sign there, `s⃛` may rise and fall only by what the larger of the two
    /// leaves.
    symmetric: [bool; AXES + 1],
    len: usize,
}

impl JerkRows {
    fn new(samples: &PathSamples, k: usize, e: &Envelope, l: &ToppLimits) -> Self {
        let mut rows = Self {
            budget: [0.0; AXES + 1],
            third: [(0.0, 0.0); AXES + 1],
            cross: [(0.0, 0.0); AXES + 1],
            symmetric: [false; AXES + 1],
            len: 0,
        };
        let mut push =
            |jerk: f64, slope: f64, third: (f64, f64), cross: (f64, f64), symmetric: bool| {
                if slope > MOVING {
                    rows.budget[rows.len] = GRID_MARGIN * jerk / slope;
                    rows.third[rows.len] = (third.0 / slope, third.1 / slope);
                    rows.cross[rows.len] = (cross.0 / slope, cross.1 / slope);
                    rows.symmetric[rows.len] = symmetric;
                    rows.len += 1;
                }
            };
        let magnitude = |curvature: f64| (-3.0 * curvature, 3.0 * curvature);
        push(
            l.tcp_jerk,
            e.tcp_speed,
            (-e.tcp_third, e.tcp_third),
            magnitude(e.tcp_curvature),
            false,
        );
        let intervals = k.saturating_sub(2)..=(k + 1).min(INTERVALS - 1);
        let around = k.saturating_sub(1)..=(k + 1).min(INTERVALS);
        for i in 0..AXES {
            let slopes = samples.slope[around.clone()].iter().map(|q| q[i]);
            let (sign, symmetric) = if slopes.clone().all(|q| q > MOVING) {
                (1.0, false)
            } else if slopes.clone().all(|q| q < -MOVING) {
                (-1.0, false)
            } else {
                (1.0, true)
            };
            let cross = samples.curvature[around.clone()]
                .iter()
                .map(|q| 3.0 * sign * q[i])
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), c| {
                    (lo.min(c), hi.max(c))
                });
            let third = {
                let (lo, hi, most) = intervals.clone().fold(
                    (f64::INFINITY, f64::NEG_INFINITY, 0.0f64),
                    |(lo, hi, most), j| {
                        let d =
                            sign * (samples.curvature[j + 1][i] - samples.curvature[j][i]) / STEP;
                        (lo.min(d), hi.max(d), most.max(d.abs()))
                    },
                );
                let widen = (e.third[i] - most).max(0.0);
                ((lo - widen).max(-e.third[i]), (hi + widen).min(e.third[i]))
            };
            push(l.jerk[i], e.slope[i], third, cross, symmetric);
        }
        rows
    }

    /// The rows of the same point on the reversed path: `σ` changes sign, `q''` does not
    /// (`q'''` changes with `σ`, so its term stays).
    fn reversed(mut self) -> Self {
        for c in &mut self.cross[..self.len] {
            *c = (-c.1, -c.0);
        }
        self
    }

    /// The largest `s̈` and `−s̈` `(up, down)` at which the window of `s⃛` stays open both ways
    /// at every speed `ṡ` up to `v`: per row `|t·ṡ³ + c·ṡ·s̈| ≤ budget` for `t` and `c` in
    /// their ranges, with both terms at the same speed, so that where they have opposite
    /// signs the one takes back what the other spends.
    fn hold(&self, v: f64) -> (f64, f64) {
        let (mut up, mut down) = (f64::INFINITY, f64::INFINITY);
        for r in 0..self.len {
            let budget = self.budget[r];
            let ((t_lo, t_hi), (c_lo, c_hi)) = (self.third[r], self.cross[r]);
            // Speeding up by s̈: c_hi·s̈ adds to the rise of q⃛/|q'|, c_lo to its fall.
            // Braking by w = −s̈: −c_lo·w adds to the rise, c_hi·w to the fall.
            let rising = slope_room(t_hi, budget, v);
            let falling = slope_room(-t_lo, budget, v);
            if c_hi > 0.0 {
                up = smaller(up, rising / c_hi);
                down = smaller(down, falling / c_hi);
            }
            if c_lo < 0.0 {
                up = smaller(up, falling / -c_lo);
                down = smaller(down, rising / -c_lo);
            }
        }
        (up.max(0.0), down.max(0.0))
    }

    /// The largest rise and fall `(up, down)` of `s⃛` at speeds `ṡ` within `speeds` and path
    /// accelerations `s̈` within `accelerations` (both `(lowest, highest)`) around the point
    /// (negative where the budget is spent).
    fn jerk(&self, speeds: (f64, f64), accelerations: (f64, f64)) -> (f64, f64) {
        let (v3_lo, v3_hi) = (speeds.0.powi(3), speeds.1.powi(3));
        let corners = [
            speeds.0 * accelerations.0,
            speeds.0 * accelerations.1,
            speeds.1 * accelerations.0,
            speeds.1 * accelerations.1,
        ];
        let (va_lo, va_hi) = (least(corners), most(corners));
        let (mut up, mut down) = (f64::INFINITY, f64::INFINITY);
        for r in 0..self.len {
            let (c_lo, c_hi) = self.cross[r];
            let cross = [c_lo * va_lo, c_lo * va_hi, c_hi * va_lo, c_hi * va_hi];
            let (t_lo, t_hi) = self.third[r];
            let third_most = larger(t_hi * v3_hi, t_hi * v3_lo);
            let third_least = smaller(t_lo * v3_hi, t_lo * v3_lo);
            let budget = self.budget[r];
            let (rise, fall) = (
                budget - third_most - most(cross),
                budget + third_least + least(cross),
            );
            if self.symmetric[r] {
                let both = smaller(rise, fall);
                up = smaller(up, both);
                down = smaller(down, both);
            } else {
                up = smaller(up, rise);
                down = smaller(down, fall);
            }
        }
        (up, down)
    }
}

/// The largest `β` with `α·ṡ³ + β·ṡ ≤ budget` for every `ṡ` in `[0, v]` (negative where
/// `α·v³` alone exceeds the budget). With `α < 0` the cubic peaks inside at
/// `ṡ = √(β/(3|α|))`, where it is `(2/3)·β·ṡ`.
fn slope_room(alpha: f64, budget: f64, v: f64) -> f64 {
    let at_end = (budget - alpha * v * v * v) / v;
    if alpha >= 0.0 || at_end >= -3.0 * alpha * v * v {
        return at_end;
    }
    (1.5 * budget * (-3.0 * alpha).sqrt()).powf(2.0 / 3.0)
}

/// The larger of two numbers that are not NaN (a plain comparison: `f64::max` also orders
/// NaN, which costs in the windows the jerk-limited passes ask for most often).
fn larger(a: f64, b: f64) -> f64 {
    if a > b { a } else { b }
}

/// The smaller of two numbers that are not NaN (see [`larger`]).
fn smaller(a: f64, b: f64) -> f64 {
    if a < b { a } else { b }
}

/// The largest of four numbers that are not NaN.
fn most(x: [f64; 4]) -> f64 {
    larger(larger(x[0], x[1]), larger(x[2], x[3]))
}

/// The smallest of four numbers that are not NaN.
fn least(x: [f64; 4]) -> f64 {
    smaller(smaller(x[0], x[1]), smaller(x[2], x[3]))
}

/// The largest magnitudes of the derivatives at a grid point and its neighbours.
#[derive(Clone, Copy)]
struct Envelope {
    slope: [f64; AXES],
    curvature: [f64; AXES],
    third: [f64; AXES],
    tcp_speed: f64,
    tcp_curvature: f64,
    tcp_third: f64,
}

impl<'a> Problem<'a> {
    fn new(
        samples: &'a PathSamples,
        limits: &'a ToppLimits,
        jerk: JerkBound,
        hold: Hold,
    ) -> Result<Self, ToppError> {
        let bound = speed_limits(samples, limits, jerk)?;
        let mut problem = Self {
            samples,
            limits,
            jerk,
            hold,
            reversed: false,
            bound,
            reach: core::array::from_fn(|k| interval_reach(samples, limits, &bound, k)),
            speed_up: [f64::INFINITY; INTERVALS],
            braking: [f64::INFINITY; INTERVALS],
            slack: FEASIBILITY * bound.iter().copied().fold(0.0, f64::max),
            jerk_rows: core::array::from_fn(|k| {
                JerkRows::new(samples, k, &envelope(samples, k), limits)
            }),
        };
        problem.rates();
        Ok(problem)
    }

    /// The largest `s̈` and `−s̈` of every interval: the rates' shares of the tangential
    /// reach, and with the jerk bound the hold on `s̈` at the speed bound
    /// ([`hold`](Self::hold)). Forward problems only (the reversed one takes
    /// them reversed).
    fn rates(&mut self) {
        debug_assert!(!self.reversed);
        let holds: [(f64, f64); POINTS] = core::array::from_fn(|k| self.hold(k));
        for k in 0..INTERVALS {
            let (up, down) = (
                holds[k].0.min(holds[k + 1].0),
                holds[k].1.min(holds[k + 1].1),
            );
            self.speed_up[k] = (self.limits.speed_up * self.reach[k]).min(up);
            self.braking[k] = (self.limits.braking * self.reach[k]).min(down);
        }
    }

    /// Lowers the speed bound to the speeds² `x` up to grid point `until`, and the rates
    /// with it: a pass under the profile of the one before keeps its speeds, so the
    /// curvature term's share of the jerk budget is found at those instead of the speed
    /// limits (where a profile brakes well below them, to the end of the path, that held the
    /// braking to a fraction of what the jerk budget allows).
    fn lower_bound(&mut self, x: &[f64; POINTS], until: usize) {
        for (bound, x) in self.bound.iter_mut().zip(x).take(until + 1) {
            *bound = bound.min(*x);
        }
        self.rates();
    }

    /// The same problem on the reversed path.
    fn reversed(&self) -> Self {
        let mut bound = self.bound;
        bound.reverse();
        let mut jerk_rows = self.jerk_rows.map(JerkRows::reversed);
        jerk_rows.reverse();
        let (mut speed_up, mut braking) = (self.braking, self.speed_up);
        speed_up.reverse();
        braking.reverse();
        Self {
            reversed: !self.reversed,
            bound,
            speed_up,
            braking,
            jerk_rows,
            ..*self
        }
    }

    /// The index into the samples of grid point `k`.
    fn index(&self, k: usize) -> usize {
        if self.reversed { INTERVALS - k } else { k }
    }

    fn point(&self, k: usize) -> Point {
        let i = self.index(k);
        let sign = if self.reversed { -1.0 } else { 1.0 };
        Point {
            slope: self.samples.slope[i].map(|v| sign * v),
            curvature: self.samples.curvature[i],
            tcp_speed: self.samples.tcp_speed[i],
            tcp_curvature: self.samples.tcp_curvature[i],
        }
    }

    /// With the jerk bound, the largest `s̈` and `−s̈` at grid point `k` that leave its jerk
    /// window open both ways at every speed up to the largest bound around `k`
    /// ([`JerkRows::hold`]); unbounded without.
    fn hold(&self, k: usize) -> (f64, f64) {
        if self.jerk == JerkBound::Off || self.hold == Hold::Free {
            return (f64::INFINITY, f64::INFINITY);
        }
        let around = k.saturating_sub(1)..=(k + 1).min(INTERVALS);
        let v = self.bound[around]
            .iter()
            .fold(0.0f64, |m, b| m.max(*b))
            .sqrt();
        if !(v.is_finite() && v > 0.0) {
            return (f64::INFINITY, f64::INFINITY);
        }
        self.jerk_rows[k].hold(v)
    }

    /// The admissible `u` of stage `k` at `x` into `sets` at `k + 1`: `(lowest, highest)`.
    fn u_range(&self, sets: &Sets, k: usize, x: f64) -> (f64, f64) {
        let mut range = URange::at(x, self.slack);
        self.stage(k, (sets.lo[k + 1], sets.hi[k + 1]), &mut range);
        (range.lowest, range.highest)
    }

    /// The rows of stage `k` in `(u, x_k)`, with the controllable set `[lo, hi]` of `k + 1`.
    fn stage(&self, k: usize, next: (f64, f64), rows: &mut impl RowSink) {
        let (a, b) = (self.point(k), self.point(k + 1));
        let two_step = 2.0 * STEP;
        for i in 0..AXES {
            let limit = GRID_MARGIN * self.limits.acceleration[i];
            // At s_k: q'·u + q''·x; at s_{k+1}: q'·u + q''·(x + 2Δs·u).
            let at_end = b.slope[i] + two_step * b.curvature[i];
            for sign in [1.0, -1.0] {
                rows.push(sign * a.slope[i], sign * a.curvature[i], limit);
                rows.push(sign * at_end, sign * b.curvature[i], limit);
            }
        }
        let limit = GRID_MARGIN * self.limits.tcp_acceleration;
        for sign in [1.0, -1.0] {
            rows.push(sign * a.tcp_speed, a.tcp_curvature, limit);
            rows.push(
                sign * b.tcp_speed + two_step * b.tcp_curvature,
                b.tcp_curvature,
                limit,
            );
        }
        rows.push(1.0, 0.0, self.speed_up[k]);
        rows.push(-1.0, 0.0, self.braking[k]);
        rows.push(two_step, 1.0, next.1);
        rows.push(-two_step, -1.0, -next.0);
    }

    /// The backward pass: the controllable sets of every grid point.
    fn controllable(&self, sets: &mut Sets) -> Result<(), ToppError> {
        sets.lo[INTERVALS] = 0.0;
        sets.hi[INTERVALS] = 0.0;
        let mut rows = StageRows::new();
        for k in (0..INTERVALS).rev() {
            rows.len = 0;
            self.stage(k, (sets.lo[k + 1], sets.hi[k + 1]), &mut rows);
            let (lo, hi) = rows
                .x_range(self.bound[k], self.slack)
                .ok_or(ToppError::Infeasible(self.index(k)))?;
            sets.lo[k] = lo;
            sets.hi[k] = hi;
        }
        if sets.lo[0] > self.slack {
            return Err(ToppError::Infeasible(self.index(0)));
        }
        Ok(())
    }

    /// The forward pass without the jerk bound: the largest admissible `u` at every stage.
    fn greedy(&self, sets: &Sets, x: &mut [f64; POINTS]) {
        x[0] = 0.0;
        for k in 0..INTERVALS {
            let (_, highest) = self.u_range(sets, k, x[k]);
            x[k + 1] = (x[k] + 2.0 * STEP * highest)
                .max(sets.lo[k + 1])
                .min(sets.hi[k + 1]);
        }
    }

    /// The largest rise and fall `(up, down)` of `s̈` around grid point `m` the jerk budget
    /// allows, for the speeds `ṡ` around it (`before` at `m − 1`, `next` at `m + 1`, ignored
    /// at the ends) and the path accelerations `before_u` of interval `m − 1` and `after_u`
    /// of `m`.
    fn window_at_speeds(
        &self,
        m: usize,
        speeds: [f64; 3],
        before_u: f64,
        after_u: f64,
    ) -> (f64, f64) {
        let [before, at, next] = speeds;
        let (mut slowest, mut fastest) = (at, at);
        if m > 0 {
            (slowest, fastest) = (slowest.min(before), fastest.max(before));
        }
        if m < INTERVALS {
            (slowest, fastest) = (slowest.min(next), fastest.max(next));
        }
        // The table ramps `s̈` at a constant jerk from and to rest, runs it linearly in time
        // over the stretches of its zones (the change over the stretch's time, estimated
        // from the table's speeds) and linearly in `s` between them (the change over `Δs`
        // at the stretch's fastest point: one of the middles, or `m` where the speed peaks);
        // see `TableProfile`. The table as it runs is checked (`jerk_violation`).
        let middle = |a: f64, b: f64| (0.5 * (a * a + b * b)).sqrt();
        let (early, late) = (middle(before, at), middle(at, next));
        let span = if m == 0 || m == INTERVALS {
            RAMP_SPAN * STEP / fastest
        } else if m <= ZONE || m >= INTERVALS - ZONE {
            table::time_through(early, before_u, after_u)
                .unwrap_or_else(|| 2.0 * STEP / (early + late))
        } else {
            STEP / at.max(early).max(late)
        } * DRIFT_SHARE;
        let accelerations = (before_u.min(after_u), before_u.max(after_u));
        let (up, down) = self.jerk_rows[m].jerk((slowest, fastest), accelerations);
        (up.max(0.0) * span, down.max(0.0) * span)
    }

    /// The largest `u` of stage `k` up to `highest` that the jerk window around `k` allows
    /// after `before_u` (speeds² `before` at `k − 1` and `at` at `k`).
    fn ramp_up(&self, k: usize, before: f64, at: f64, before_u: f64, highest: f64) -> f64 {
        self.ramp(k, [before, at], before_u, highest, 1.0)
    }

    /// The smallest `u` of stage `k` down to `lowest` that the jerk window allows (as
    /// [`ramp_up`](Self::ramp_up)).
    fn ramp_down(&self, k: usize, before: f64, at: f64, before_u: f64, lowest: f64) -> f64 {
        self.ramp(k, [before, at], before_u, lowest, -1.0)
    }

    /// The `u` nearest `limit` in the direction `sign` (+1 up, −1 down) from `before_u`
    /// within the jerk window, which itself depends on `u` (through the time of the
    /// interval and the size of `s̈`): `sign·(u − before_u) ≤ window(u)`, solved by the
    /// Illinois variant of regula falsi between `before_u` (inside) and `limit`, until the
    /// room left is within [`WINDOW_TOLERANCE`] (stopping there made the jerk-limited passes
    /// 1.5 to 2 times faster on the lines of `rc bench motion`).
    #[allow(
        clippy::float_cmp,
        reason = "Some(true) and Some(false) are compared, not floats"
    )]
    fn ramp(&self, k: usize, x: [f64; 2], before_u: f64, limit: f64, sign: f64) -> f64 {
        let [before, at] = x.map(speed);
        let room = |u: f64| {
            let next = speed(x[1] + 2.0 * STEP * u);
            let (up, down) = self.window_at_speeds(k, [before, at, next], before_u, u);
            (if sign > 0.0 { up } else { down }) - sign * (u - before_u)
        };
        let mut outer = (limit, room(limit));
        if outer.1 >= 0.0 {
            return limit;
        }
        let mut inner = (before_u, room(before_u));
        let mut last_inner = None;
        for _ in 0..WINDOW_STEPS {
            let secant = (inner.0 * outer.1 - outer.0 * inner.1) / (outer.1 - inner.1);
            // An unbounded window (at rest: the interval's time has no bound) bisects.
            let u = if secant.is_finite() {
                secant
            } else {
                0.5 * (inner.0 + outer.0)
            };
            let r = room(u);
            if r >= 0.0 {
                inner = (u, r);
                if r <= WINDOW_TOLERANCE * (1.0 + u.abs()) {
                    break;
                }
                if last_inner == Some(true) {
                    outer.1 *= 0.5;
                }
                last_inner = Some(true);
            } else {
                outer = (u, r);
                if last_inner == Some(false) {
                    inner.1 *= 0.5;
                }
                last_inner = Some(false);
            }
        }
        inner.0
    }

    /// Whether `u` at stage `k` (speeds² `before` at `k − 1`, `at` at `k`) leaves a way
    /// down: `u` lowered as fast as the jerk windows allow until it reaches the largest
    /// braking of the rows (from where the controllable sets guarantee the rest) or the
    /// path stops, within the controllable sets all along.
    fn can_brake(&self, sets: &Sets, k: usize, at: f64, u: f64) -> bool {
        let (mut before, mut at, mut before_u) = (at, at + 2.0 * STEP * u, u);
        for j in k + 1..INTERVALS {
            if at <= self.slack {
                return true;
            }
            let (lowest, highest) = self.u_range(sets, j, at);
            let u = self.ramp_down(j, before, at, before_u, lowest).max(lowest);
            if u > highest + self.slack {
                return false;
            }
            if u <= lowest {
                return true;
            }
            (before, at, before_u) = (at, at + 2.0 * STEP * u, u);
        }
        at <= self.slack
    }

    /// The jerk-limited forward pass (see the module documentation): speeds² `x`.
    fn jerk_greedy(&self, sets: &Sets, x: &mut [f64; POINTS]) {
        x[0] = 0.0;
        let (mut before, mut before_u) = (0.0, 0.0);
        for k in 0..INTERVALS {
            let (lowest, highest) = self.u_range(sets, k, x[k]);
            let top = self.ramp_up(k, before, x[k], before_u, highest);
            let safe = self
                .ramp_down(k, before, x[k], before_u, lowest)
                .max(lowest)
                .min(highest);
            let chosen = if top <= safe {
                safe
            } else if self.can_brake(sets, k, x[k], top) {
                top
            } else {
                // One step between: the transition starts within half an interval.
                let middle = 0.5 * (safe + top);
                if self.can_brake(sets, k, x[k], middle) {
                    middle
                } else {
                    safe
                }
            };
            x[k + 1] = (x[k] + 2.0 * STEP * chosen)
                .max(sets.lo[k + 1])
                .min(sets.hi[k + 1]);
            (before, before_u) = (x[k], (x[k + 1] - x[k]) / (2.0 * STEP));
        }
    }

    /// The last grid point up to which the profile `x` of the first jerk-limited pass bounds
    /// the reversed one: the end, unless the pass came to rest before it (braking at the
    /// largest rate where the curvature term leaves its jerk window no room to ease off, it
    /// overshoots the controllable set's edge into a stop); then its peak before that rest.
    /// A rest inside the bound would hold every later pass to a standstill there.
    fn trusted_until(&self, x: &[f64; POINTS]) -> usize {
        let Some(rest) = (1..INTERVALS).find(|&k| x[k] <= self.slack) else {
            return INTERVALS;
        };
        (0..rest).fold(0, |best, k| if x[k] > x[best] { k } else { best })
    }

    /// The first grid point around which the table's jerk (its ramps and stretches as they
    /// run, see [`TableProfile`]) exceeds the window its speeds and accelerations leave
    /// there, if any.
    fn jerk_violation(&self, table: &TableProfile) -> Option<usize> {
        (0..POINTS).find(|&m| {
            let stretch = table.jerk_at(m);
            let (up, down) = self.jerk_rows[m].jerk(stretch.speeds, stretch.accelerations);
            let (lowest, highest) = stretch.jerk;
            highest > up * (1.0 + JERK_TOLERANCE) + JERK_FLOOR
                || -lowest > down * (1.0 + JERK_TOLERANCE) + JERK_FLOOR
        })
    }
}

#[cfg(test)]
mod tests;
