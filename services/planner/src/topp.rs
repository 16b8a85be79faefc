//! Time-optimal path parameterisation (TOPP) of a sampled path: by reachability analysis
//! ([`reachability`], the planner's) and as a second-order-cone problem on clarabel (the
//! cross-check of the tests and `rc bench motion`).
//!
//! # Problem
//!
//! A path `q(s)`, `s` in [0, 1], is given at the grid points `s_k = k/N` ([`INTERVALS`]`= N`)
//! by its joint derivatives `q'`, `q''`, `q'''` and the TCP's `|p'|`, `|p''|`, `|p'''|`
//! ([`PathSamples`]; the TCP's third derivative counts in its jerk budget like the joints').
//! With `b_k = ṡ²` at `s_k` and a constant path acceleration `a_k = (b_{k+1} − b_k)/(2Δs)` in
//! interval `k` (so `b` is linear in `s` there), the joint velocity, joint acceleration and TCP
//! limits are linear in `b`:
//!
//! - `b_k ≤ min_i (v_i/|q'_i|)²` and `b_k ≤ (v_tcp/|p'|)²`, with the largest `|q'|`, `|p'|`
//!   of the neighbouring grid points: `b` is linear between the points, so the bound holds
//!   on the whole interval;
//! - `|q'_i·a_k + q''_i·b_e| ≤ a_i` at both ends `e` of every interval (what changes between
//!   them is second order in `Δs`; [`GRID_MARGIN`] pays for it), and
//!   `|p'|·|a_k| + |p''|·b_e ≤ a_tcp` (exact on a line, conservative on an arc);
//! - with different acceleration and deceleration rates the path acceleration is held to
//!   their shares of what the joints allow tangentially; with equal rates these rows never bind;
//! - `b ≤ V²` for the speed cap of [`ToppLimits::speed_cap`], and with the jerk bound
//!   `|q''_i|·b ≤ curvature_share·a_i` and `|q'''_i|·b^(3/2) ≤ third_share·j_i` at every
//!   point ([`ToppLimits::curvature_share`], [`ToppLimits::third_share`]): they keep the jerk
//!   pass's terms `3·q''·ṡ·s̈` and `q'''·ṡ³` small;
//! - `b_0 = b_N = 0`.
//!
//! [`reachability`] solves it stage by stage (microseconds to a fraction of a millisecond)
//! and bounds the jerk in its forward pass; the conic problem below takes a second or so and
//! serves as the cross-check: without the jerk bound both find the same optimum.
//!
//! # The conic problem
//!
//! The time `Σ 2Δs/(√b_k + √b_{k+1})` is minimised through second-order-cone epigraphs:
//! `c_k² ≤ b_k` and `d_k·(c_k + c_{k+1}) ≥ 1`, minimising `Σ 2Δs·d_k` (variables scaled so
//! that `b` lies in [0, 1]).
//!
//! The table's `s̈` runs from `a_{m−1}` at the middle of interval `m − 1` to `a_m` at the
//! middle of `m` (`a_{−1} = a_N = 0`) and its positions follow it exactly ([`table`]):
//! linearly in `s` on most of the path, at a path jerk of `(a_m − a_{m−1})·ṡ/Δs`, at most
//! `ṡ_hi/Δs` times the change, `ṡ_hi` the largest speed of the points around; linearly in
//! time in the zones next to the ends, where the stretch takes about `Δs/ṡ` or longer; from
//! and to rest a ramp, gentler still. The convex row `|a_m − a_{m−1}| ≤ J_m·Δs/ṡ_hi`
//! therefore bounds the path jerk `|s⃛| ≤ J_m` (up to how the zones' speeds drift from the
//! table's by a little), where `J_m` is what the joints' jerk budget leaves for `q'·s⃛`
//! after `|q'''|·ṡ³ + 3·|q''|·ṡ·|s̈|`. As `ṡ_hi` and `|s̈|` are not known before the solve,
//! the first pass solves without the jerk rows, and each further pass takes them from the
//! pass before; a pass whose own solution keeps the jerk budget at every grid point is taken
//! (at most [`MAX_PASSES`]). The rows are conservative (a slower profile than a true
//! third-order TOPP).
//!
//! One clarabel solver is built on a fixed sparsity (presolve off, zeros kept) and updated
//! in place (`update_A`, `update_b`) for every path. Measured with a counting allocator
//! (test `an_updated_solve_allocates_once`): an updated solve of clarabel 0.11.1 allocates
//! once (one block inside `solve`), and this module's own data none.

pub mod reachability;
pub mod table;

use core::cell::{Cell, RefCell};
use std::time::Instant;

use clarabel::algebra::CscMatrix;
use clarabel::solver::{
    DefaultSettingsBuilder, DefaultSolver, IPSolver, NonnegativeConeT, SecondOrderConeT,
    SolverStatus, SupportedConeT, ZeroConeT,
};
use shared_types::ipc::AXES;

pub use table::{POINTS, TableError, TableProfile};

/// Intervals of the grid the path is timed on.
pub const INTERVALS: usize = 256;
/// Share of the velocity and acceleration limits the grid rows may use: the rest pays for
/// what changes between the grid points.
pub const GRID_MARGIN: f64 = 0.995;
/// Solves per path at most: one without and the rest with the jerk rows.
pub const MAX_PASSES: usize = 4;
/// Interior-point iterations per solve at most.
const MAX_ITERATIONS: u32 = 200;
/// Relative slack on the jerk budget for the solver's tolerances.
const JERK_TOLERANCE: f64 = 1e-3;
/// Smallest `|q'|` or `|p'|` counted as moving.
const MOVING: f64 = 1e-12;
/// Share of the jerk budget at rest a point keeps when the estimates leave none.
const JERK_FLOOR: f64 = 0.05;
/// Share of a joint's jerk limit the term `q'''·ṡ³` may take at most in the constant stop
/// bounds of [`linear_move`](crate::linear_move) and in its tables by the path position
/// (those on the joints' pace have their own: [`ToppLimits::third_share`]).
pub const THIRD_SHARE: f64 = 0.5;
/// Right-hand side of a jerk row that cannot bind: the scaled `b` lies in [0, 1].
const UNBOUND: f64 = 4.0;

/// The path at the grid points: derivatives by `s` of the joints and of the TCP.
#[derive(Debug, Clone, PartialEq)]
pub struct PathSamples {
    /// `dq/ds`.
    pub slope: [[f64; AXES]; POINTS],
    /// `d²q/ds²`.
    pub curvature: [[f64; AXES]; POINTS],
    /// `d³q/ds³`.
    pub third: [[f64; AXES]; POINTS],
    /// `|dp/ds|` of the TCP position, m: the TCP speed per unit `ṡ`.
    pub tcp_speed: [f64; POINTS],
    /// `|d²p/ds²|` of the TCP position, m.
    pub tcp_curvature: [f64; POINTS],
    /// `|d³p/ds³|` of the TCP position, m (0 on a line run at a constant pace).
    pub tcp_third: [f64; POINTS],
}

impl PathSamples {
    /// A path at rest: every derivative 0.
    pub fn zeros() -> Self {
        Self {
            slope: [[0.0; AXES]; POINTS],
            curvature: [[0.0; AXES]; POINTS],
            third: [[0.0; AXES]; POINTS],
            tcp_speed: [0.0; POINTS],
            tcp_curvature: [0.0; POINTS],
            tcp_third: [0.0; POINTS],
        }
    }
}

/// The limits a path is timed with, rates and override reserve applied.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ToppLimits {
    /// Joint velocities, rad/s.
    pub velocity: [f64; AXES],
    /// Joint accelerations, rad/s².
    pub acceleration: [f64; AXES],
    /// Joint jerks, rad/s³.
    pub jerk: [f64; AXES],
    /// TCP speed, acceleration and jerk, m/s, m/s², m/s³.
    pub tcp_velocity: f64,
    pub tcp_acceleration: f64,
    pub tcp_jerk: f64,
    /// Shares in (0, 1] of the tangential acceleration for speeding up and for braking (the
    /// acceleration and deceleration rates over the larger of the two).
    pub speed_up: f64,
    pub braking: f64,
    /// Largest `ṡ` anywhere, 1/s.
    pub speed_cap: f64,
    /// Share of a joint's acceleration limit the curvature term `|q''|·ṡ²` may take at any
    /// point when the jerk is bounded (infinite: no such bound).
    pub curvature_share: f64,
    /// Share of a joint's jerk limit the term `|q'''|·ṡ³` may take at any point when the
    /// jerk is bounded.
    pub third_share: f64,
}

/// Limits of 1 in every unit.
const UNIT_LIMITS: ToppLimits = ToppLimits {
    velocity: [1.0; AXES],
    acceleration: [1.0; AXES],
    jerk: [1.0; AXES],
    tcp_velocity: 1.0,
    tcp_acceleration: 1.0,
    tcp_jerk: 1.0,
    speed_up: 1.0,
    braking: 1.0,
    speed_cap: 1.0,
    curvature_share: f64::INFINITY,
    third_share: THIRD_SHARE,
};

/// Whether the path jerk is bounded.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum JerkBound {
    /// Bound by the joints' and the TCP's jerk budget (see the module documentation).
    Joints,
    /// Velocity and acceleration only (for comparisons with second-order TOPP).
    Off,
}

/// Why a path could not be timed.
#[derive(Debug, thiserror::Error)]
pub enum ToppError {
    /// The conic solver could not be set up (logged once by [`PathTimer::conic`]). Carries
    /// nothing, so that a fallback in the tick allocates nothing.
    #[error("no TOPP solver")]
    Unavailable,
    #[error("the solver is in use")]
    Busy,
    #[error("the path does not move")]
    NoMotion,
    #[error("no path speed is admissible at grid point {0}")]
    Infeasible(usize),
    #[error("the solver data could not be updated: {0}")]
    Update(#[from] clarabel::solver::DataUpdateError),
    #[error("the solver ended with {0:?}")]
    NotSolved(SolverStatus),
    #[error(transparent)]
    Table(#[from] TableError),
    #[error("the jerk bound did not settle in {0} passes")]
    JerkUnsettled(usize),
    #[error("no table is faster than {0} s")]
    NotFaster(f64),
}

/// What a timer spent.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct SolveReport {
    /// Passes (solves of the conic problem, forward passes of the reachability analysis).
    pub passes: usize,
    /// Their time, s (the conic one as clarabel measured it).
    pub solve_s: f64,
}

/// How a [`PathTimer`] solves.
enum Method {
    Reachability,
    /// One clarabel solver, built when the timer is made, updated for every path.
    Conic(Box<Result<RefCell<Solver>, String>>),
}

/// A path timer: reachability analysis (the planner's) or the conic problem (the
/// cross-check); what it spent is summed up for the benchmark.
pub struct PathTimer {
    method: Method,
    jerk: JerkBound,
    report: Cell<SolveReport>,
}

impl core::fmt::Debug for PathTimer {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        let method = match &self.method {
            Method::Reachability => "reachability",
            Method::Conic(solver) if solver.is_ok() => "conic",
            Method::Conic(_) => "conic (no solver)",
        };
        f.debug_struct("PathTimer")
            .field("method", &method)
            .field("jerk", &self.jerk)
            .finish()
    }
}

impl PathTimer {
    /// Reachability analysis ([`reachability`]).
    pub fn reachability(jerk: JerkBound) -> Self {
        Self {
            method: Method::Reachability,
            jerk,
            report: Cell::default(),
        }
    }

    /// The conic problem on clarabel. If its solver cannot be built, every
    /// [`time`](Self::time) fails; the cause is logged here once.
    pub fn conic(jerk: JerkBound) -> Self {
        let solver = Solver::new().map(RefCell::new);
        if let Err(e) = &solver {
            tracing::error!("TOPP solver not available: {e}");
        }
        Self {
            method: Method::Conic(Box::new(solver)),
            jerk,
            report: Cell::default(),
        }
    }

    /// Whether this timer bounds the path jerk.
    pub fn jerk(&self) -> JerkBound {
        self.jerk
    }

    /// The time-optimal table profile of `samples` within `limits`. The caller has use only
    /// for a table shorter than `longest` (s): reachability analysis may skip its jerk-limited
    /// passes when none can be ([`ToppError::NotFaster`]); the conic problem ignores it.
    pub fn time(
        &self,
        samples: &PathSamples,
        limits: &ToppLimits,
        longest: f64,
    ) -> Result<TableProfile, ToppError> {
        let spent = self.report.get();
        match &self.method {
            Method::Reachability => {
                let started = Instant::now();
                let timed = reachability::time(samples, limits, self.jerk, longest);
                self.report.set(SolveReport {
                    passes: spent.passes + timed.as_ref().map_or(1, |(_, passes)| *passes),
                    solve_s: spent.solve_s + started.elapsed().as_secs_f64(),
                });
                timed.map(|(table, _)| table)
            }
            Method::Conic(solver) => {
                let cell = solver
                    .as_ref()
                    .as_ref()
                    .map_err(|_| ToppError::Unavailable)?;
                let mut solver = cell.try_borrow_mut().map_err(|_| ToppError::Busy)?;
                solver.report = SolveReport::default();
                let table = solver.time(samples, limits, self.jerk);
                self.report.set(SolveReport {
                    passes: spent.passes + solver.report.passes,
                    solve_s: spent.solve_s + solver.report.solve_s,
                });
                table
            }
        }
    }

    /// What the timer spent on all paths since it was made (failed ones too).
    pub fn report(&self) -> SolveReport {
        self.report.get()
    }
}

/// Row and column layout of the problem.
mod layout {
    use super::{AXES, INTERVALS, POINTS};

    /// Variables: `b_k`, `c_k` (points), `d_k` (intervals).
    pub const VARIABLES: usize = 2 * POINTS + INTERVALS;
    pub const fn b(k: usize) -> usize {
        k
    }
    pub const fn c(k: usize) -> usize {
        POINTS + k
    }
    pub const fn d(k: usize) -> usize {
        2 * POINTS + k
    }
    /// Equality rows: `b_0 = 0`, `b_N = 0`, `c_0 = 0`, `c_N = 0`.
    pub const ZERO_ROWS: usize = 4;
    /// Inequality rows: speed per point; per interval and end the joint rows (both signs) and
    /// the TCP rows; two tangential rows per interval; two jerk rows per point.
    pub const NONNEGATIVE_ROWS: usize = POINTS + INTERVALS * (2 * (2 * AXES + 2) + 2) + 2 * POINTS;
    /// Three-dimensional second-order cones: one per inner point and one per interval.
    pub const CONES: usize = (POINTS - 2) + INTERVALS;
    pub const ROWS: usize = ZERO_ROWS + NONNEGATIVE_ROWS + 3 * CONES;
}

/// Receives the problem data in a fixed order.
trait Sink {
    /// Coefficient of column `col` in the current row.
    fn entry(&mut self, col: usize, value: f64);
    /// Ends the current row with its right-hand side.
    fn row(&mut self, rhs: f64);
}

/// Collects the structure: `(row, col)` of every entry in emission order.
#[derive(Default)]
struct Structure {
    entries: Vec<(usize, usize)>,
    rows: usize,
}

impl Sink for Structure {
    fn entry(&mut self, col: usize, _: f64) {
        self.entries.push((self.rows, col));
    }
    fn row(&mut self, _: f64) {
        self.rows += 1;
    }
}

/// Writes values into the solver's arrays through the slots of the structure.
struct Values<'a> {
    slots: &'a [usize],
    nzval: &'a mut [f64],
    rhs: &'a mut [f64],
    entry: usize,
    rows: usize,
}

impl Sink for Values<'_> {
    fn entry(&mut self, _: usize, value: f64) {
        self.nzval[self.slots[self.entry]] = value;
        self.entry += 1;
    }
    fn row(&mut self, rhs: f64) {
        self.rhs[self.rows] = rhs;
        self.rows += 1;
    }
}

/// The per-path numbers the rows are made of, in the scaled variables.
struct Rows {
    /// `b = scale·b̂`.
    scale: f64,
    /// Speed bound per point, scaled.
    speed: [f64; POINTS],
    /// Tangential acceleration bound per interval.
    reach: [f64; INTERVALS],
    /// Jerk row bound per point, scaled (`UNBOUND` when off).
    jerk: [f64; POINTS],
}

/// The solver with its fixed structure and preallocated data.
struct Solver {
    solver: DefaultSolver<f64>,
    slots: Vec<usize>,
    nzval: Vec<f64>,
    rhs: Vec<f64>,
    rows: Box<Rows>,
    report: SolveReport,
}

impl Solver {
    fn new() -> Result<Self, String> {
        let rows = Box::new(Rows {
            scale: 1.0,
            speed: [1.0; POINTS],
            reach: [1.0; INTERVALS],
            jerk: [UNBOUND; POINTS],
        });
        // Any values do for the structure: every entry is emitted whatever its value.
        let samples = Box::new(PathSamples::zeros());
        let limits = UNIT_LIMITS;
        let mut structure = Structure::default();
        emit(&samples, &limits, &rows, &mut structure);
        debug_assert_eq!(structure.rows, layout::ROWS);
        // CSC order: by column, then row; `slots` maps emission order to it.
        let mut order: Vec<usize> = (0..structure.entries.len()).collect();
        order.sort_by_key(|&e| (structure.entries[e].1, structure.entries[e].0));
        let mut slots = vec![0; order.len()];
        let mut colptr = vec![0; layout::VARIABLES + 1];
        let mut rowval = Vec::with_capacity(order.len());
        for (slot, &e) in order.iter().enumerate() {
            slots[e] = slot;
            let (row, col) = structure.entries[e];
            rowval.push(row);
            colptr[col + 1] += 1;
        }
        for col in 0..layout::VARIABLES {
            colptr[col + 1] += colptr[col];
        }
        let mut nzval = vec![0.0; order.len()];
        let mut rhs = vec![0.0; layout::ROWS];
        emit(
            &samples,
            &limits,
            &rows,
            &mut Values {
                slots: &slots,
                nzval: &mut nzval,
                rhs: &mut rhs,
                entry: 0,
                rows: 0,
            },
        );
        let a = CscMatrix::new(
            layout::ROWS,
            layout::VARIABLES,
            colptr,
            rowval,
            nzval.clone(),
        );
        let p = CscMatrix::zeros((layout::VARIABLES, layout::VARIABLES));
        let mut q = vec![0.0; layout::VARIABLES];
        for k in 0..INTERVALS {
            q[layout::d(k)] = 2.0 / INTERVALS as f64;
        }
        let mut cones: Vec<SupportedConeT<f64>> = vec![
            ZeroConeT(layout::ZERO_ROWS),
            NonnegativeConeT(layout::NONNEGATIVE_ROWS),
        ];
        cones.extend((0..layout::CONES).map(|_| SecondOrderConeT(3)));
        let settings = DefaultSettingsBuilder::default()
            .verbose(false)
            .presolve_enable(false)
            .input_sparse_dropzeros(false)
            // The rows are scaled here, per path; a scaling fixed at set-up from placeholder
            // data would not fit the paths.
            .equilibrate_enable(false)
            .max_iter(MAX_ITERATIONS)
            .build()
            .map_err(|e| e.to_string())?;
        let solver =
            DefaultSolver::new(&p, &q, &a, &rhs, &cones, settings).map_err(|e| e.to_string())?;
        if !solver.is_data_update_allowed() {
            return Err("clarabel does not allow data updates on this problem".into());
        }
        Ok(Self {
            solver,
            slots,
            nzval,
            rhs,
            rows,
            report: SolveReport::default(),
        })
    }

    fn time(
        &mut self,
        samples: &PathSamples,
        limits: &ToppLimits,
        jerk: JerkBound,
    ) -> Result<TableProfile, ToppError> {
        speed_bounds(samples, limits, jerk, &mut self.rows)?;
        self.rows.jerk = [UNBOUND; POINTS];
        let mut profile = self.solve(samples, limits, jerk)?;
        if jerk == JerkBound::Off {
            return Ok(profile);
        }
        // Estimates of ṡ around every point, growing from pass to pass.
        let mut speed = [0.0; POINTS];
        for _ in 1..MAX_PASSES {
            if jerk_rows(samples, limits, &profile, &mut speed, &mut self.rows) {
                return Ok(profile);
            }
            profile = self.solve(samples, limits, jerk)?;
        }
        jerk_rows(samples, limits, &profile, &mut speed, &mut self.rows)
            .then_some(profile)
            .ok_or(ToppError::JerkUnsettled(MAX_PASSES))
    }

    /// One solve with the current rows; the table's ramps from and to rest as `jerk`.
    fn solve(
        &mut self,
        samples: &PathSamples,
        limits: &ToppLimits,
        jerk: JerkBound,
    ) -> Result<TableProfile, ToppError> {
        emit(
            samples,
            limits,
            &self.rows,
            &mut Values {
                slots: &self.slots,
                nzval: &mut self.nzval,
                rhs: &mut self.rhs,
                entry: 0,
                rows: 0,
            },
        );
        self.solver.update_A(&self.nzval)?;
        self.solver.update_b(&self.rhs)?;
        self.solver.solve();
        self.report.passes += 1;
        self.report.solve_s += self.solver.solution.solve_time;
        let status = self.solver.solution.status;
        if !matches!(status, SolverStatus::Solved | SolverStatus::AlmostSolved) {
            return Err(ToppError::NotSolved(status));
        }
        let x = &self.solver.solution.x;
        let scale = self.rows.scale;
        // Rounding of the solver may leave b a hair above its bounds or below 0.
        let speeds = core::array::from_fn(|k| {
            (x[layout::b(k)].clamp(0.0, self.rows.speed[k]) * scale).sqrt()
        });
        Ok(TableProfile::from_speeds(&speeds, jerk)?)
    }
}

/// The largest `ṡ²` at every grid point: the joint and TCP velocities with the largest
/// `|q'|`, `|p'|` of the point and its neighbours (`ṡ²` is linear between the points, so the
/// bound holds on the whole interval), the speed cap and, with the jerk bound, also
/// `|q'''|·ṡ³ ≤ third_share·j`.
fn speed_limits(
    samples: &PathSamples,
    limits: &ToppLimits,
    jerk: JerkBound,
) -> Result<[f64; POINTS], ToppError> {
    let mut bound = [0.0; POINTS];
    for (k, b) in bound.iter_mut().enumerate() {
        let around = k.saturating_sub(1)..=(k + 1).min(INTERVALS);
        let largest =
            |f: &dyn Fn(usize) -> f64| around.clone().fold(0.0f64, |m, e| m.max(f(e).abs()));
        let mut v = limits.speed_cap;
        let tcp = largest(&|e| samples.tcp_speed[e]);
        if tcp > MOVING {
            v = v.min(GRID_MARGIN * limits.tcp_velocity / tcp);
        }
        let tcp_third = largest(&|e| samples.tcp_third[e]);
        if jerk == JerkBound::Joints && tcp_third > MOVING {
            v = v.min((limits.third_share * limits.tcp_jerk / tcp_third).cbrt());
        }
        for i in 0..AXES {
            let slope = largest(&|e| samples.slope[e][i]);
            if slope > MOVING {
                v = v.min(GRID_MARGIN * limits.velocity[i] / slope);
            }
            let third = largest(&|e| samples.third[e][i]);
            if jerk == JerkBound::Joints && third > MOVING {
                v = v.min((limits.third_share * limits.jerk[i] / third).cbrt());
            }
            let curvature = largest(&|e| samples.curvature[e][i]);
            if jerk == JerkBound::Joints && curvature > MOVING {
                v = v.min((limits.curvature_share * limits.acceleration[i] / curvature).sqrt());
            }
        }
        *b = v * v;
    }
    let scale = bound.iter().copied().fold(0.0, f64::max);
    if !(scale.is_finite() && scale > 0.0) {
        return Err(ToppError::NoMotion);
    }
    Ok(bound)
}

/// Fills the speed bounds ([`speed_limits`]), the scale and the tangential reach of `rows`.
fn speed_bounds(
    samples: &PathSamples,
    limits: &ToppLimits,
    jerk: JerkBound,
    rows: &mut Rows,
) -> Result<(), ToppError> {
    let bound = speed_limits(samples, limits, jerk)?;
    let scale = bound.iter().copied().fold(0.0, f64::max);
    rows.scale = scale;
    rows.speed = bound.map(|b| b / scale);
    for k in 0..INTERVALS {
        let reach = interval_reach(samples, limits, &bound, k);
        rows.reach[k] = if reach.is_finite() { reach } else { scale };
    }
    Ok(())
}

/// The largest `|s̈|` the acceleration rows allow in interval `k` at the speed bounds
/// `bound` (`ṡ²`) of its ends.
fn interval_reach(
    samples: &PathSamples,
    limits: &ToppLimits,
    bound: &[f64; POINTS],
    k: usize,
) -> f64 {
    tangential_reach(samples, limits, k, bound[k]).min(tangential_reach(
        samples,
        limits,
        k + 1,
        bound[k + 1],
    ))
}

/// The largest `|s̈|` the acceleration rows allow at point `e` at `ṡ² = b`.
fn tangential_reach(samples: &PathSamples, limits: &ToppLimits, e: usize, b: f64) -> f64 {
    let mut reach = f64::INFINITY;
    let tcp = samples.tcp_speed[e];
    if tcp > MOVING {
        reach = reach.min((limits.tcp_acceleration + samples.tcp_curvature[e] * b) / tcp);
    }
    for i in 0..AXES {
        let slope = samples.slope[e][i].abs();
        if slope > MOVING {
            let curvature = samples.curvature[e][i].abs();
            reach = reach.min((limits.acceleration[i] + curvature * b) / slope);
        }
    }
    reach
}

/// Returns whether `profile` keeps the jerk budget at its own speeds and accelerations; raises
/// the speed estimates to it and sets the jerk rows from them and from the largest path
/// acceleration the rows allow at those speeds (for the next pass).
fn jerk_rows(
    samples: &PathSamples,
    limits: &ToppLimits,
    profile: &TableProfile,
    speed: &mut [f64; POINTS],
    rows: &mut Rows,
) -> bool {
    let step = 1.0 / INTERVALS as f64;
    let speeds = profile.speeds();
    let interval_acceleration =
        |k: usize| (speeds[k + 1] * speeds[k + 1] - speeds[k] * speeds[k]) / (2.0 * step);
    let mut keeps = true;
    for (m, estimate) in speed.iter_mut().enumerate() {
        let around = m.saturating_sub(1)..=(m + 1).min(INTERVALS);
        let fast = speeds[around].iter().copied().fold(0.0, f64::max);
        let before = if m == 0 {
            0.0
        } else {
            interval_acceleration(m - 1)
        };
        let after = if m == INTERVALS {
            0.0
        } else {
            interval_acceleration(m)
        };
        let steep = before.abs().max(after.abs());
        // |a_m − a_{m−1}| ≤ J·Δs/ṡ_hi.
        let own = path_jerk(samples, limits, m, fast, steep) * step / fast.max(f64::MIN_POSITIVE);
        if (after - before).abs() > own * (1.0 + JERK_TOLERANCE) {
            keeps = false;
        }
        *estimate = estimate.max(fast);
        // What any pass may accelerate with at that speed, not only this one.
        let reach = tangential_reach(samples, limits, m, *estimate * *estimate);
        let acceleration = steep.max(if reach.is_finite() { reach } else { 0.0 });
        // Estimates above what the next pass needs may leave no budget: a small one then,
        // and that pass's own check decides.
        let floor = JERK_FLOOR * path_jerk(samples, limits, m, 0.0, 0.0);
        let path_jerk = path_jerk(samples, limits, m, *estimate, acceleration).max(floor);
        let allowed = path_jerk * step / estimate.max(f64::MIN_POSITIVE);
        // In units of the scaled b: scale/(2Δs).
        rows.jerk[m] = (allowed * 2.0 * step / rows.scale).min(UNBOUND);
    }
    keeps
}

/// The path jerk the joints' and the TCP's jerk budget leaves at point `m` for speed `v` and
/// path acceleration `a`.
fn path_jerk(samples: &PathSamples, limits: &ToppLimits, m: usize, v: f64, a: f64) -> f64 {
    let mut jerk = f64::INFINITY;
    let tcp = samples.tcp_speed[m];
    if tcp > MOVING {
        let left = limits.tcp_jerk
            - samples.tcp_third[m] * v * v * v
            - 3.0 * samples.tcp_curvature[m] * v * a;
        jerk = jerk.min(left / tcp);
    }
    for i in 0..AXES {
        let slope = samples.slope[m][i].abs();
        if slope > MOVING {
            let left = limits.jerk[i]
                - samples.third[m][i].abs() * v * v * v
                - 3.0 * samples.curvature[m][i].abs() * v * a;
            jerk = jerk.min(left / slope);
        }
    }
    jerk
}

/// Emits the problem rows in their fixed order (see [`layout`]).
fn emit(samples: &PathSamples, limits: &ToppLimits, rows: &Rows, sink: &mut impl Sink) {
    use layout::{b, c, d};
    let step = 1.0 / INTERVALS as f64;
    // a_k = scale·(b̂_{k+1} − b̂_k)/(2Δs); a row divided by its limit.
    let per_acceleration = rows.scale / (2.0 * step);
    // At rest at both ends. `c = 0` there is set, not derived from `c² ≤ b = 0`: that cone
    // would have no interior, which stalls the interior-point method.
    for column in [b(0), b(INTERVALS), c(0), c(INTERVALS)] {
        sink.entry(column, 1.0);
        sink.row(0.0);
    }
    for k in 0..POINTS {
        sink.entry(b(k), 1.0);
        sink.row(rows.speed[k]);
    }
    for k in 0..INTERVALS {
        for e in [k, k + 1] {
            let at_end = if e == k { 0.0 } else { 1.0 };
            for i in 0..AXES {
                let limit = GRID_MARGIN * limits.acceleration[i];
                let tangential = samples.slope[e][i] * per_acceleration / limit;
                let normal = samples.curvature[e][i] * rows.scale / limit;
                for sign in [1.0, -1.0] {
                    sink.entry(b(k), sign * (-tangential + (1.0 - at_end) * normal));
                    sink.entry(b(k + 1), sign * (tangential + at_end * normal));
                    sink.row(1.0);
                }
            }
            let limit = GRID_MARGIN * limits.tcp_acceleration;
            let tangential = samples.tcp_speed[e] * per_acceleration / limit;
            let normal = samples.tcp_curvature[e] * rows.scale / limit;
            for sign in [1.0, -1.0] {
                sink.entry(b(k), -sign * tangential + (1.0 - at_end) * normal);
                sink.entry(b(k + 1), sign * tangential + at_end * normal);
                sink.row(1.0);
            }
        }
        let reach = per_acceleration / rows.reach[k];
        for (sign, share) in [(1.0, limits.speed_up), (-1.0, limits.braking)] {
            sink.entry(b(k), -sign * reach);
            sink.entry(b(k + 1), sign * reach);
            sink.row(share);
        }
    }
    // a_m − a_{m−1} ∝ b̂_{m+1} − 2·b̂_m + b̂_{m−1}, with a_{−1} = a_N = 0.
    for m in 0..POINTS {
        let middle = if m == 0 || m == INTERVALS { -1.0 } else { -2.0 };
        for sign in [1.0, -1.0] {
            if m > 0 {
                sink.entry(b(m - 1), sign);
            }
            sink.entry(b(m), sign * middle);
            if m < INTERVALS {
                sink.entry(b(m + 1), sign);
            }
            sink.row(rows.jerk[m]);
        }
    }
    // c_k² ≤ b̂_k: (1 + b̂, b̂ − 1, 2c) in the cone.
    for k in 1..INTERVALS {
        sink.entry(b(k), -1.0);
        sink.row(1.0);
        sink.entry(b(k), -1.0);
        sink.row(-1.0);
        sink.entry(c(k), -2.0);
        sink.row(0.0);
    }
    // d_k·(c_k + c_{k+1}) ≥ 1: (d + c_k + c_{k+1}, d − c_k − c_{k+1}, 2) in the cone.
    for k in 0..INTERVALS {
        for sign in [1.0, -1.0] {
            sink.entry(d(k), -1.0);
            sink.entry(c(k), -sign);
            sink.entry(c(k + 1), -sign);
            sink.row(0.0);
        }
        sink.row(2.0);
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use core::cell::Cell;
    use std::alloc::{GlobalAlloc, Layout, System};

    /// Counts the allocations of the current thread (tests run in parallel threads).
    struct Counting;

    thread_local! {
        static ALLOCATIONS: Cell<usize> = const { Cell::new(0) };
    }

    // SAFETY: forwards to the system allocator unchanged; the counter is a const-initialised
    // thread-local `Cell`, which neither allocates nor re-enters the allocator.
    unsafe impl GlobalAlloc for Counting {
        unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
            ALLOCATIONS.with(|n| n.set(n.get() + 1));
            // SAFETY: the caller's contract is passed on.
            unsafe { System.alloc(layout) }
        }
        unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
            // SAFETY: the caller's contract is passed on.
            unsafe { System.dealloc(ptr, layout) }
        }
        unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, size: usize) -> *mut u8 {
            ALLOCATIONS.with(|n| n.set(n.get() + 1));
            // SAFETY: the caller's contract is passed on.
            unsafe { System.realloc(ptr, layout, size) }
        }
    }

    #[global_allocator]
    static ALLOCATOR: Counting = Counting;

    pub(crate) fn allocations() -> usize {
        ALLOCATIONS.with(Cell::get)
    }

    pub(super) const SLOPE: [f64; AXES] = [1.0, -0.5, 0.25, 0.0, 0.8, -0.2];

    /// A straight joint-space path `q(s) = q0 + s·Δ` with `Δ = SLOPE`.
    pub(super) fn straight() -> Box<PathSamples> {
        let mut samples = Box::new(PathSamples::zeros());
        samples.slope = [SLOPE; POINTS];
        samples
    }

    pub(super) fn limits() -> ToppLimits {
        ToppLimits {
            velocity: [2.0; AXES],
            acceleration: [8.0; AXES],
            jerk: [400.0; AXES],
            speed_cap: 100.0,
            ..UNIT_LIMITS
        }
    }

    /// Shortest rest-to-rest time over `s` in [0, 1] with `ṡ ≤ v`, `|s̈| ≤ a`.
    pub(super) fn trapezoid(v: f64, a: f64) -> f64 {
        if v * v / a >= 1.0 {
            2.0 / a.sqrt()
        } else {
            1.0 / v + v / a
        }
    }

    #[test]
    fn a_straight_joint_path_takes_the_trapezoid_time() {
        let timer = PathTimer::conic(JerkBound::Off);
        for (velocity, acceleration) in [(2.0, 8.0), (0.5, 8.0), (20.0, 2.0)] {
            let mut l = limits();
            l.velocity = [velocity; AXES];
            l.acceleration = [acceleration; AXES];
            let table = timer.time(&straight(), &l, f64::INFINITY).unwrap();
            // Joint 0 (|q'| = 1) decides both limits.
            let expected = trapezoid(GRID_MARGIN * velocity, GRID_MARGIN * acceleration);
            let ratio = table.duration() / expected;
            // Faster only by the solver's tolerance.
            assert!(
                (1.0 - 1e-5..1.002).contains(&ratio),
                "{velocity} {acceleration}: {ratio}"
            );
        }
    }

    #[test]
    fn a_curved_middle_slows_the_path_there_only() {
        let timer = PathTimer::conic(JerkBound::Off);
        let l = limits();
        let plain = timer.time(&straight(), &l, f64::INFINITY).unwrap();
        let mut bent = straight();
        for k in 120..=136 {
            bent.curvature[k][1] = 200.0;
        }
        let slowed = timer.time(&bent, &l, f64::INFINITY).unwrap();
        assert!(slowed.duration() > plain.duration() * 1.01);
        // Where the curvature is, at most √(a/|q''|) (plus what the slope term may add).
        assert!(slowed.speeds()[128] <= (8.0f64 / 200.0).sqrt() * 1.01);
        // Far from it, the same speed as on the straight path.
        for k in [16, 32, 224, 240] {
            let (a, b) = (plain.speeds()[k], slowed.speeds()[k]);
            assert!((a - b).abs() <= 1e-3 * a, "{k}: {a} {b}");
        }
    }

    /// Samples `table` densely; returns the largest `|q'_0·Δs̈/Δt|`.
    pub(super) fn largest_tangential_jerk(table: &TableProfile, slope: f64) -> f64 {
        let dt = 1e-4;
        let mut previous = table.eval(0.0);
        let mut jerk: f64 = 0.0;
        let mut t = dt;
        while t <= table.duration() + dt {
            let now = table.eval(t);
            jerk = jerk.max(slope * (now.2 - previous.2).abs() / dt);
            previous = now;
            t += dt;
        }
        jerk
    }

    #[test]
    fn the_jerk_rows_keep_the_joint_jerk() {
        let l = limits();
        let free = PathTimer::conic(JerkBound::Off)
            .time(&straight(), &l, f64::INFINITY)
            .unwrap();
        let bounded = PathTimer::conic(JerkBound::Joints)
            .time(&straight(), &l, f64::INFINITY)
            .unwrap();
        // A straight path: q⃛ = q'·s⃛, joint 0 decides.
        let jerk = largest_tangential_jerk(&bounded, 1.0);
        assert!(jerk <= 400.0 * 1.01, "{jerk}");
        assert!(largest_tangential_jerk(&free, 1.0) > 400.0);
        assert!(bounded.duration() > free.duration());
        // Slower than the jerk-free optimum, but not absurdly.
        assert!(bounded.duration() < 2.0 * free.duration());
    }

    #[test]
    fn a_path_without_motion_is_refused() {
        let timer = PathTimer::conic(JerkBound::Joints);
        let samples = PathSamples::zeros();
        let mut l = limits();
        l.speed_cap = f64::INFINITY;
        assert!(matches!(
            timer.time(&samples, &l, f64::INFINITY),
            Err(ToppError::NoMotion)
        ));
    }

    #[test]
    fn an_updated_solve_allocates_once() {
        let timer = PathTimer::conic(JerkBound::Off);
        let samples = straight();
        let l = limits();
        timer.time(&samples, &l, f64::INFINITY).unwrap();
        let before = allocations();
        timer.time(&samples, &l, f64::INFINITY).unwrap();
        let per_solve = allocations() - before;
        // clarabel 0.11.1 allocates one block inside `solve` (see the module documentation).
        assert!(per_solve <= 1, "{per_solve} allocations per solve");
    }
}
