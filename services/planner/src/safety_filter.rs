//! The per-tick safety filter: the last guard between the planned motion and the servo.
//!
//! Every tick the executor hands the filter the acceleration `q̈_ref` its plan wants for the
//! next tick and the arm's commanded state `(q, q̇)`. The filter returns the acceleration
//! closest to `q̈_ref` that keeps every joint inside its limits for this tick **and every
//! tick after it**:
//!
//! - acceleration: `|q̈_i| ≤ a_i`;
//! - velocity after the tick: `|q̇_i + q̈_i·Δt| ≤ v_i`;
//! - position with the braking distance (viability): after the tick the joint can still stop
//!   before its limit with `a_i` in whole ticks: `q_next + q̇_next²/(2·a_i) + |q̇_next|·Δt/2 ≤
//!   q_max` and the mirror, with `q_next = q + (q̇ + q̇_next)·Δt/2` for a constant acceleration
//!   over the tick, which makes it a bound on `q̇_next` and so on `q̈`. Braking at `a_i` keeps
//!   it true from tick to tick, so once inside the arm stays inside.
//!
//! A plan that keeps its limits (every planned move does) passes unchanged without a solve.
//! When the reference leaves the bounds (a jog or an override change that the plan did not
//! foresee, a near-singular configuration where the joints race), the filter solves the
//! small QP
//!
//! ```text
//! min ½ (q̈ − q̈_ref)ᵀ H (q̈ − q̈_ref)   s.t.   lower ≤ q̈ ≤ upper,   H = w·JᵀJ + ε·I
//! ```
//!
//! on clarabel: the weighted `JᵀJ` term changes the TCP acceleration as little as possible,
//! so the TCP keeps its direction while the joints are held back; `ε` keeps `H` positive
//! definite at singularities, where `J` loses rank. The solver is built once with the fixed
//! sparsity of this problem (dense upper triangle of `H`, two identity blocks) and updated
//! in place (`update_P`, `update_q`, `update_b`). Should it fail, the box projection of
//! `q̈_ref` (feasible, though it may bend the TCP path) is used.
//!
//! When the bounds contradict each other (the arm already is beyond what a stop can save:
//! after a fault or with limits changed under it), the filter brakes every joint as hard as
//! its acceleration limit allows.
//!
//! A guard stop ([`SafetyFilter::brake`]) solves a step towards standing still per tick.
//! The executor's window of setpoints runs the same steps again every tick, one further on,
//! so the filter remembers the latest steps and solves each once: about one solve a tick
//! instead of the window's 31 (at some 43 µs each, more than the 1 ms tick).
//!
//! Allocation (`tests/safety_filter_alloc.rs`): a passing tick allocates nothing; a corrected
//! tick (a solve after the in-place updates) allocates once, inside clarabel 0.11.1, whose
//! solve re-creates the sub-timers of its timing statistics.

use clarabel::algebra::CscMatrix;
use clarabel::solver::{
    DefaultSettings, DefaultSettingsBuilder, DefaultSolver, IPSolver, NonnegativeConeT,
    SolverStatus,
};
use nalgebra::Matrix6;
use shared_types::config::JointLimitsRad;
use shared_types::ipc::{AXES, JointPoint, SETPOINT_WINDOW};

/// Weight of the TCP term `JᵀJ` in the cost.
const TCP_WEIGHT: f64 = 1.0;
/// Weight of the joint term, which keeps the cost strictly convex at singularities.
const JOINT_WEIGHT: f64 = 1e-3;
/// Iterations the solver may take; the interior-point method needs 6 to 11 for this size.
const MAX_ITERATIONS: u32 = 50;
/// Relative slack for rounding when judging whether the reference keeps the bounds.
const SLACK: f64 = 1e-9;
/// Position tolerance (rad) of [`SafetyFilter::admits`]: rounding of a plan ending on a limit.
const ADMIT_TOLERANCE_RAD: f64 = 1e-9;
/// Relative tolerance of [`SafetyFilter::admits`] on the velocity and acceleration limits.
const ADMIT_SLACK: f64 = 1e-6;
/// Entries of the upper triangle of the 6×6 cost matrix.
const COST_ENTRIES: usize = AXES * (AXES + 1) / 2;

/// Why the safety filter could not be set up.
#[derive(Debug, thiserror::Error)]
pub enum SafetyFilterError {
    /// The solver refused the problem (not expected for this fixed, valid layout).
    #[error("safety filter: the QP solver could not be set up: {0}")]
    Setup(String),
}

/// What the filter did to one tick.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Intervention {
    /// The reference kept every bound and was passed on unchanged.
    None,
    /// The reference was moved into the bounds by the QP.
    Corrected,
    /// The QP failed and the reference was clipped joint by joint into the bounds.
    Clipped,
    /// No acceleration keeps every bound: every joint brakes at its limit.
    Braking,
}

/// Steps of guard stops remembered: those of a whole window of setpoints and the next one's.
const REMEMBERED_BRAKES: usize = 2 * SETPOINT_WINDOW;

/// A step of a guard stop: from `from` over a tick of `dt` s to `to`.
#[derive(Debug, Clone, Copy, PartialEq)]
struct BrakeStep {
    dt: f64,
    from: JointPoint,
    to: Filtered,
}

/// The filtered next point and what the filter did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Filtered {
    /// Position, velocity and acceleration commanded for the end of the tick.
    pub point: JointPoint,
    pub intervention: Intervention,
}

/// Lower and upper bounds of each joint's acceleration for the next tick.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AccelerationBounds {
    pub lower: [f64; AXES],
    pub upper: [f64; AXES],
}

impl AccelerationBounds {
    /// The bounds of the module documentation for the state `(q, qd)`, a tick of `dt` s and
    /// the limits `limits`. `None` when some joint has no admissible acceleration.
    pub fn new(
        q: &[f64; AXES],
        qd: &[f64; AXES],
        limits: &JointLimitsRad,
        dt: f64,
    ) -> Option<Self> {
        let mut bounds = Self {
            lower: [0.0; AXES],
            upper: [0.0; AXES],
        };
        for i in 0..AXES {
            let a = limits.acceleration[i];
            // With a constant acceleration over the tick the joint ends at
            // `q + (q̇ + w)·Δt/2` with the velocity `w`; braking from there in whole ticks
            // takes at most `w²/(2a) + w·Δt/2` (the last tick cannot stop in its middle).
            // Both must fit before the limit: `w²/(2a) + w·Δt ≤ room`.
            let fastest = |room: f64| {
                (room >= 0.0).then(|| -a * dt + (a * a * dt * dt + 2.0 * a * room).sqrt())
            };
            let half_step = 0.5 * qd[i] * dt;
            let (Some(up), Some(down)) = (
                fastest(limits.max[i] - q[i] - half_step),
                fastest(q[i] + half_step - limits.min[i]),
            ) else {
                return None;
            };
            let v = limits.velocity[i];
            let upper = a.min((up.min(v) - qd[i]) / dt);
            let lower = (-a).max((-down.min(v) - qd[i]) / dt);
            if lower > upper {
                return None;
            }
            bounds.lower[i] = lower;
            bounds.upper[i] = upper;
        }
        Some(bounds)
    }

    /// Whether `qdd` keeps every bound (up to rounding).
    pub fn contain(&self, qdd: &[f64; AXES]) -> bool {
        (0..AXES).all(|i| {
            let slack = SLACK * (1.0 + self.upper[i].abs().max(self.lower[i].abs()));
            qdd[i] >= self.lower[i] - slack && qdd[i] <= self.upper[i] + slack
        })
    }

    /// `qdd` clipped joint by joint into the bounds.
    pub fn clip(&self, qdd: &[f64; AXES]) -> [f64; AXES] {
        core::array::from_fn(|i| qdd[i].clamp(self.lower[i], self.upper[i]))
    }
}

/// The per-tick safety filter of one robot (see the module documentation).
pub struct SafetyFilter {
    limits: JointLimitsRad,
    /// The latest steps of guard stops ([`brake`](Self::brake)), oldest overwritten first.
    brakes: [Option<BrakeStep>; REMEMBERED_BRAKES],
    /// Where the next step of [`brakes`](Self::brakes) goes.
    next_brake: usize,
    /// QP solves so far.
    solves: u64,
    solver: DefaultSolver<f64>,
    /// Values of the upper triangle of `H`, in the column order of the solver's matrix.
    cost: Vec<f64>,
    /// Linear cost `−H·q̈_ref`.
    linear: Vec<f64>,
    /// Right-hand sides: the upper bounds, then the negated lower bounds.
    sides: Vec<f64>,
}

impl SafetyFilter {
    /// Builds the filter and its solver for the limits `limits` (the only allocation).
    pub fn new(limits: JointLimitsRad) -> Result<Self, SafetyFilterError> {
        let identity = Matrix6::identity();
        let cost = upper_triangle(&identity);
        let linear = vec![0.0; AXES];
        let sides = vec![1.0; 2 * AXES];
        let solver = DefaultSolver::new(
            &cost_matrix(&cost),
            &linear,
            &bound_matrix(),
            &sides,
            &[NonnegativeConeT(2 * AXES)],
            settings()?,
        )
        .map_err(|e| SafetyFilterError::Setup(e.to_string()))?;
        if !solver.is_data_update_allowed() {
            return Err(SafetyFilterError::Setup(
                "the solver does not allow in-place updates".into(),
            ));
        }
        Ok(Self {
            limits,
            brakes: [None; REMEMBERED_BRAKES],
            next_brake: 0,
            solves: 0,
            solver,
            cost,
            linear,
            sides,
        })
    }

    /// The limits the filter holds.
    pub fn limits(&self) -> &JointLimitsRad {
        &self.limits
    }

    /// Replaces the limits (for instance when the PLC writes new SW limits); no allocation.
    pub fn set_limits(&mut self, limits: JointLimitsRad) {
        self.limits = limits;
        self.brakes = [None; REMEMBERED_BRAKES];
    }

    /// The QP solves so far: a guard stop solves each of its steps once.
    pub fn solves(&self) -> u64 {
        self.solves
    }

    /// The next point from the commanded state `current` for a tick of `dt` s, with the
    /// acceleration closest to `reference_qdd` inside the bounds; `jacobian` is the arm's
    /// Jacobian at `current.q` (it weights the correction so that the TCP keeps its
    /// direction).
    pub fn filter(
        &mut self,
        current: &JointPoint,
        reference_qdd: &[f64; AXES],
        jacobian: &Matrix6<f64>,
        dt: f64,
    ) -> Filtered {
        let Some(bounds) = AccelerationBounds::new(&current.q, &current.qd, &self.limits, dt)
        else {
            let braking: [f64; AXES] = core::array::from_fn(|i| {
                let a = self.limits.acceleration[i];
                (-current.qd[i] / dt).clamp(-a, a)
            });
            return step(current, &braking, dt, Intervention::Braking);
        };
        if bounds.contain(reference_qdd) {
            return step(current, reference_qdd, dt, Intervention::None);
        }
        match self.solve(&bounds, reference_qdd, jacobian) {
            Some(qdd) => step(current, &bounds.clip(&qdd), dt, Intervention::Corrected),
            None => step(
                current,
                &bounds.clip(reference_qdd),
                dt,
                Intervention::Clipped,
            ),
        }
    }

    /// Whether the planned point `next` keeps the limits by itself: position, velocity and
    /// acceleration within the limits, and every joint able to stop before its position
    /// limits with its acceleration limit (`q + q̇·|q̇|/(2a)` inside them). Every planned
    /// move, stop and blend does; the test uses the plan's own values, so that it does not
    /// depend on how the plan's acceleration varies within the tick.
    pub fn admits(&self, next: &JointPoint) -> bool {
        let l = &self.limits;
        (0..AXES).all(|i| {
            let (q, qd, qdd) = (next.q[i], next.qd[i], next.qdd[i]);
            let stop = q + qd * qd.abs() / (2.0 * l.acceleration[i]);
            let tolerance = ADMIT_TOLERANCE_RAD;
            q.min(stop) >= l.min[i] - tolerance
                && q.max(stop) <= l.max[i] + tolerance
                && qd.abs() <= l.velocity[i] * (1.0 + ADMIT_SLACK)
                && qdd.abs() <= l.acceleration[i] * (1.0 + ADMIT_SLACK)
        })
    }

    /// The point commanded for the tick after `previous`: `planned` itself when it keeps
    /// the limits ([`admits`](Self::admits)), else the filtered point closest to the plan's
    /// acceleration. `jacobian` gives the Jacobian at a joint position; it is only
    /// evaluated when the filter acts.
    pub fn guard(
        &mut self,
        previous: &JointPoint,
        planned: &JointPoint,
        dt: f64,
        jacobian: impl FnOnce(&[f64; AXES]) -> Matrix6<f64>,
    ) -> Filtered {
        if self.admits(planned) {
            return Filtered {
                point: *planned,
                intervention: Intervention::None,
            };
        }
        let filtered = self.filter(previous, &planned.qdd, &jacobian(&previous.q), dt);
        Filtered {
            // The plan asked for nothing the limits allow: stop instead.
            intervention: match filtered.intervention {
                Intervention::None => Intervention::Corrected,
                other => other,
            },
            ..filtered
        }
    }

    /// One tick of a stop from `previous` (a guard stop): as close to standing still after
    /// this tick as the bounds allow, weighted so that the TCP keeps its direction while it
    /// slows down; a joint that the weighting would speed up brakes on its own instead, so
    /// every joint slows down every tick and the arm stands after at most
    /// `max(v_i/a_i)/Δt + 1` ticks.
    ///
    /// A window of setpoints runs the same steps again every tick, one further on: a step
    /// from the same point over the same tick is remembered, not solved again.
    pub fn brake(
        &mut self,
        previous: &JointPoint,
        dt: f64,
        jacobian: impl FnOnce(&[f64; AXES]) -> Matrix6<f64>,
    ) -> Filtered {
        let remembered = self
            .brakes
            .iter()
            .flatten()
            .find(|b| b.dt == dt && b.from == *previous);
        if let Some(step) = remembered {
            return step.to;
        }
        let to = self.braked(previous, dt, jacobian);
        self.brakes[self.next_brake] = Some(BrakeStep {
            dt,
            from: *previous,
            to,
        });
        self.next_brake = (self.next_brake + 1) % REMEMBERED_BRAKES;
        to
    }

    /// One step of [`brake`](Self::brake), solved.
    fn braked(
        &mut self,
        previous: &JointPoint,
        dt: f64,
        jacobian: impl FnOnce(&[f64; AXES]) -> Matrix6<f64>,
    ) -> Filtered {
        let stop_now: [f64; AXES] = core::array::from_fn(|i| -previous.qd[i] / dt);
        let filtered = self.filter(previous, &stop_now, &jacobian(&previous.q), dt);
        let slows_down = (0..AXES).all(|i| filtered.point.qd[i].abs() <= previous.qd[i].abs());
        if slows_down {
            return filtered;
        }
        let braking: [f64; AXES] = core::array::from_fn(|i| {
            let a = self.limits.acceleration[i];
            stop_now[i].clamp(-a, a)
        });
        step(previous, &braking, dt, Intervention::Braking)
    }

    /// The QP of the module documentation; `None` if the solver does not converge.
    fn solve(
        &mut self,
        bounds: &AccelerationBounds,
        reference_qdd: &[f64; AXES],
        jacobian: &Matrix6<f64>,
    ) -> Option<[f64; AXES]> {
        let hessian =
            TCP_WEIGHT * jacobian.transpose() * jacobian + JOINT_WEIGHT * Matrix6::identity();
        write_upper_triangle(&hessian, &mut self.cost);
        for i in 0..AXES {
            self.linear[i] = -(0..AXES)
                .map(|j| hessian[(i, j)] * reference_qdd[j])
                .sum::<f64>();
            self.sides[i] = bounds.upper[i];
            self.sides[AXES + i] = -bounds.lower[i];
        }
        self.solver.update_P(&self.cost).ok()?;
        self.solver.update_q(&self.linear).ok()?;
        self.solver.update_b(&self.sides).ok()?;
        self.solves += 1;
        self.solver.solve();
        let solved = matches!(
            self.solver.solution.status,
            SolverStatus::Solved | SolverStatus::AlmostSolved
        );
        let x = &self.solver.solution.x;
        (solved && x.iter().all(|v| v.is_finite())).then(|| core::array::from_fn(|i| x[i]))
    }
}

/// The point one tick of `dt` s after `current` under the constant acceleration `qdd`.
fn step(current: &JointPoint, qdd: &[f64; AXES], dt: f64, intervention: Intervention) -> Filtered {
    Filtered {
        point: JointPoint {
            q: core::array::from_fn(|i| current.q[i] + current.qd[i] * dt + 0.5 * qdd[i] * dt * dt),
            qd: core::array::from_fn(|i| current.qd[i] + qdd[i] * dt),
            qdd: *qdd,
        },
        intervention,
    }
}

fn settings() -> Result<DefaultSettings<f64>, SafetyFilterError> {
    DefaultSettingsBuilder::default()
        .verbose(false)
        .presolve_enable(false)
        .input_sparse_dropzeros(false)
        .max_iter(MAX_ITERATIONS)
        .build()
        .map_err(|e| SafetyFilterError::Setup(e.to_string()))
}

/// The upper triangle of `m` in column order (the order of [`cost_matrix`]'s values).
fn upper_triangle(m: &Matrix6<f64>) -> Vec<f64> {
    let mut values = vec![0.0; COST_ENTRIES];
    write_upper_triangle(m, &mut values);
    values
}

fn write_upper_triangle(m: &Matrix6<f64>, values: &mut [f64]) {
    let mut k = 0;
    for column in 0..AXES {
        for row in 0..=column {
            values[k] = m[(row, column)];
            k += 1;
        }
    }
}

/// The dense upper triangle of a 6×6 matrix in compressed columns, with `values`.
fn cost_matrix(values: &[f64]) -> CscMatrix<f64> {
    let mut colptr = Vec::with_capacity(AXES + 1);
    let mut rowval = Vec::with_capacity(COST_ENTRIES);
    colptr.push(0);
    for column in 0..AXES {
        rowval.extend(0..=column);
        colptr.push(rowval.len());
    }
    CscMatrix::new(AXES, AXES, colptr, rowval, values.to_vec())
}

/// `[I; −I]`: the upper bounds, then the lower bounds as `−q̈ ≤ −lower`.
fn bound_matrix() -> CscMatrix<f64> {
    let colptr = (0..=AXES).map(|c| 2 * c).collect();
    let rowval = (0..AXES).flat_map(|c| [c, AXES + c]).collect();
    let values = (0..AXES).flat_map(|_| [1.0, -1.0]).collect();
    CscMatrix::new(2 * AXES, AXES, colptr, rowval, values)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kinematics::{Kinematics, test_robots};
    use proptest::prelude::*;

    const DT: f64 = 0.001;

    fn limits() -> JointLimitsRad {
        test_robots::default().config.limits_rad()
    }

    fn filter() -> SafetyFilter {
        SafetyFilter::new(limits()).expect("filter")
    }

    fn kinematics() -> Kinematics {
        test_robots::default().kinematics
    }

    fn at(q: [f64; AXES], qd: [f64; AXES]) -> JointPoint {
        JointPoint {
            q,
            qd,
            ..JointPoint::default()
        }
    }

    #[test]
    fn a_reference_within_the_bounds_passes_unchanged() {
        let mut f = filter();
        let q = test_robots::regular(&test_robots::default().geometry);
        let current = at(q, [0.1; AXES]);
        let reference = [0.5, -0.5, 0.2, 0.0, 0.3, -0.1];
        let out = f.filter(&current, &reference, &kinematics().jacobian(&q), DT);
        assert_eq!(out.intervention, Intervention::None);
        assert_eq!(out.point.qdd, reference);
    }

    #[test]
    fn an_excessive_reference_is_corrected_into_the_bounds() {
        let mut f = filter();
        let l = limits();
        let q = test_robots::regular(&test_robots::default().geometry);
        let current = at(q, [0.0; AXES]);
        let reference: [f64; AXES] = core::array::from_fn(|i| 3.0 * l.acceleration[i]);
        let out = f.filter(&current, &reference, &kinematics().jacobian(&q), DT);
        assert_eq!(out.intervention, Intervention::Corrected);
        for i in 0..AXES {
            assert!(
                out.point.qdd[i] <= l.acceleration[i] * (1.0 + 1e-9),
                "{out:?}"
            );
            assert!(out.point.qdd[i] > 0.0, "keeps the direction: {out:?}");
        }
    }

    #[test]
    fn the_correction_keeps_the_tcp_direction_better_than_clipping() {
        let mut f = filter();
        let l = limits();
        let q = test_robots::regular(&test_robots::default().geometry);
        let jacobian = kinematics().jacobian(&q);
        let current = at(q, [0.0; AXES]);
        // One joint far over its limit, the others within.
        let mut reference = [0.2; AXES];
        reference[1] = 4.0 * l.acceleration[1];
        let out = f.filter(&current, &reference, &jacobian, DT);
        let bounds = AccelerationBounds::new(&q, &[0.0; AXES], &l, DT).expect("bounds");
        let clipped = bounds.clip(&reference);
        // The filter minimises the error of the TCP acceleration the reference asked for.
        let tcp_error = |qdd: &[f64; AXES]| {
            (jacobian * nalgebra::Vector6::from(*qdd)
                - jacobian * nalgebra::Vector6::from(reference))
            .norm()
        };
        assert!(bounds.contain(&out.point.qdd));
        assert!(
            tcp_error(&out.point.qdd) < 0.9 * tcp_error(&clipped),
            "{} vs clipped {}",
            tcp_error(&out.point.qdd),
            tcp_error(&clipped)
        );
    }

    #[test]
    fn an_arm_already_beyond_saving_brakes_at_its_limits() {
        let mut f = filter();
        let l = limits();
        let mut q = [0.0; AXES];
        q[0] = l.max[0] - 1e-4;
        let mut qd = [0.0; AXES];
        qd[0] = l.velocity[0];
        let out = f.filter(&at(q, qd), &[0.0; AXES], &kinematics().jacobian(&q), DT);
        assert_eq!(out.intervention, Intervention::Braking);
        assert!((out.point.qdd[0] + l.acceleration[0]).abs() < 1e-9);
    }

    #[test]
    fn near_a_singularity_the_filter_still_solves() {
        let mut f = filter();
        let l = limits();
        let geometry = test_robots::default().geometry;
        // The wrist 1 mrad from its singular stretch.
        let mut q = test_robots::regular(&geometry);
        q[4] = 1e-3;
        let reference: [f64; AXES] = core::array::from_fn(|i| -2.5 * l.acceleration[i]);
        let out = f.filter(
            &at(q, [0.0; AXES]),
            &reference,
            &kinematics().jacobian(&q),
            DT,
        );
        assert_eq!(out.intervention, Intervention::Corrected);
        let bounds = AccelerationBounds::new(&q, &[0.0; AXES], &l, DT).expect("bounds");
        assert!(bounds.contain(&out.point.qdd));
    }

    /// A window of setpoints runs a guard stop's steps again every tick, one further on:
    /// each step is solved once (the window solved all 31 of its steps every tick: about
    /// 1.3 ms of a 1 ms tick).
    #[test]
    fn a_guard_stop_solves_each_of_its_steps_once() {
        let mut f = filter();
        let k = kinematics();
        let l = limits();
        let geometry = test_robots::default().geometry;
        let start = at(
            test_robots::regular(&geometry),
            core::array::from_fn(|i| 0.8 * l.velocity[i]),
        );
        let mut window = |from: JointPoint| {
            let mut point = from;
            let steps: [JointPoint; SETPOINT_WINDOW] = core::array::from_fn(|_| {
                point = f.brake(&point, DT, |q| k.jacobian(q)).point;
                point
            });
            (steps, f.solves())
        };
        let (first, solved) = window(start);
        assert!(solved >= SETPOINT_WINDOW as u64 / 2, "{solved} solves");
        let (next, solved_again) = window(first[0]);
        assert_eq!(next[..SETPOINT_WINDOW - 1], first[1..]);
        assert!(
            solved_again - solved <= 1,
            "{} solves",
            solved_again - solved
        );
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(48))]

        /// A jog that pushes every joint towards a limit at any acceleration for 3 s: the
        /// filtered motion never leaves the position, velocity or acceleration limits.
        #[test]
        fn a_runaway_reference_never_leaves_the_limits(
            start in prop::array::uniform6(-0.8f64..0.8),
            push in prop::array::uniform6(-4.0f64..4.0),
        ) {
            let mut f = filter();
            let l = limits();
            let k = kinematics();
            let mut point = at(start, [0.0; AXES]);
            for _ in 0..3000 {
                let reference: [f64; AXES] = core::array::from_fn(|i| push[i] * l.acceleration[i]);
                let out = f.filter(&point, &reference, &k.jacobian(&point.q), DT);
                point = out.point;
                for i in 0..AXES {
                    // At rest on a limit, rounding may put it a few ulp beyond.
                    prop_assert!(point.q[i] >= l.min[i] - 1e-12 && point.q[i] <= l.max[i] + 1e-12, "q {i} {point:?}");
                    prop_assert!(point.qd[i].abs() <= l.velocity[i] * (1.0 + 1e-9), "qd {i} {point:?}");
                    prop_assert!(point.qdd[i].abs() <= l.acceleration[i] * (1.0 + 1e-9), "qdd {i} {point:?}");
                }
            }
        }
    }
}
