//! The time-parameterised path `s(t)` of a time-optimal path parameterisation: the path
//! speeds the solver found at the grid points `s_k = k/N`, run with a continuous
//! acceleration whose positions follow it exactly.
//!
//! The solver takes the path acceleration constant in every interval (`ṡ²` linear in `s`).
//! Run so, the positions' acceleration would step at every grid point, and from rest by the
//! whole first interval's `s̈` within one tick: a servo that follows position setpoints would
//! see those steps as jerk. The profile therefore runs `s̈` linearly **in `s`** from the
//! middle of one interval to the middle of the next (a stretch), and `s`, `ṡ` and `s̈` at any
//! time are the exact solution of `s̈ = A + B·(s − s_0)` there (hyperbolic or trigonometric
//! in time): the positions' acceleration is the commanded one, and their jerk
//! `s⃛ = B·ṡ = (a_k − a_{k−1})·ṡ/Δs` is what the solver's jerk rows bound. Over a stretch
//! `ṡ²` gains what the table gains between the same middles, so at the middles the profile
//! keeps the table's speed (at a grid point it differs from it by `(a_k − a_{k−1})·Δs/4`,
//! lower where the table brakes into or speeds out of a peak).
//!
//! From rest to the first middle and from the last to rest, `s̈` ramps at a constant jerk
//! in time (from rest it cannot in `s`: `s̈ = B·s` never leaves `s = 0`). Such a ramp reaches
//! the middle `Δs/2` at `ṡ² = 3/4·α·Δs` for its end acceleration `α` where the table has
//! `α·Δs`: the profile's `ṡ²` is the table's lowered by a constant `δ` (the shift) and its
//! `s̈` raised by a constant `ε` (the tilt, a fraction of a per mille of the end
//! accelerations), the two chosen so that both ramps meet their middles exactly. A ramp's
//! jerk is `α^(3/2)/√(3·Δs)`, which the solver bounds as the change of `s̈` over `√6·Δs/ṡ_1`.

use super::{INTERVALS, JerkBound};

/// Grid points of a table: both ends included.
pub const POINTS: usize = INTERVALS + 1;
/// Grid step of `s`.
const STEP: f64 = 1.0 / INTERVALS as f64;
/// Newton steps for the time of a stretch at most (three to five reach rounding).
const NEWTON_STEPS: usize = 60;

/// A rest-to-rest profile of `s` from 0 to 1 given by its speeds at the grid points.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TableProfile {
    /// `ṡ` at `s_k` as the solver found it; 0 at both ends.
    speeds: [f64; POINTS],
    /// Time at which the middle of interval `k` is passed; increasing.
    middles: [f64; INTERVALS],
    /// `δ`, added to the table's `ṡ²` at the middles.
    shift: f64,
    /// `ε`, added to the table's `s̈` everywhere.
    tilt: f64,
    /// Time of the ramp from rest to the first middle, s.
    ramp_up: f64,
    /// Time of the ramp from the last middle to rest, s.
    ramp_down: f64,
    /// Whether the ramps run at a constant jerk (else at the table's constant `s̈`).
    jerk_limited: bool,
    /// Largest `ṡ` of the profile.
    peak: f64,
}

/// Why a table cannot be made of the path speeds.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum TableError {
    #[error("the path speed at grid point {0} is not finite or negative")]
    InvalidSpeed(usize),
    #[error("the path stands still inside interval {0}")]
    Standstill(usize),
}

/// One stretch from the middle of an interval to the middle of the next, `x = s − s_0` from
/// 0 to `Δs`: `ẍ = A + B·x` from `ẋ² = b_0`.
#[derive(Debug, Clone, Copy)]
struct Stretch {
    /// `ṡ²` at its start.
    start_speed2: f64,
    /// `s̈` at its start (`A`).
    acceleration: f64,
    /// `ds̈/ds` (`B`).
    slope: f64,
}

impl Stretch {
    /// `ṡ²` at `x`.
    fn speed2(&self, x: f64) -> f64 {
        self.start_speed2 + x * (2.0 * self.acceleration + self.slope * x)
    }

    /// The smallest and the largest `ṡ²` on the stretch.
    fn speed2_range(&self) -> (f64, f64) {
        let (a, b) = (self.speed2(0.0), self.speed2(STEP));
        let (mut lo, mut hi) = (a.min(b), a.max(b));
        if self.slope != 0.0 {
            let vertex = -self.acceleration / self.slope;
            if vertex > 0.0 && vertex < STEP {
                let extreme = self.speed2(vertex);
                (lo, hi) = (lo.min(extreme), hi.max(extreme));
            }
        }
        (lo, hi)
    }

    /// `(x, ẋ, ẍ)` a time `tau` after its start: with `ω² = |B|`, `x = √b_0·S + A·C` where
    /// `S = sinh(ωτ)/ω` and `C = (cosh(ωτ) − 1)/ω²` (sin and 1 − cos for `B < 0`, `τ` and
    /// `τ²/2` for `B = 0`), written so that a small `ω` loses no digits.
    fn state(&self, tau: f64) -> (f64, f64, f64) {
        let (sine, versine, cosine) = if self.slope > 0.0 {
            let w = self.slope.sqrt();
            let half = (0.5 * w * tau).sinh();
            (
                (w * tau).sinh() / w,
                2.0 * half * half / (w * w),
                (w * tau).cosh(),
            )
        } else if self.slope < 0.0 {
            let w = (-self.slope).sqrt();
            let half = (0.5 * w * tau).sin();
            (
                (w * tau).sin() / w,
                2.0 * half * half / (w * w),
                (w * tau).cos(),
            )
        } else {
            (tau, 0.5 * tau * tau, 1.0)
        };
        let v0 = self.start_speed2.sqrt();
        let x = v0 * sine + self.acceleration * versine;
        let xd = v0 * cosine + self.acceleration * sine;
        (x, xd, self.acceleration + self.slope * x)
    }

    /// Time to its end, or `None` where the path would stand still on it. Newton's method
    /// on `x(τ) = Δs`, kept inside a bracket: from 0 (before) to the time at the slowest
    /// speed of the stretch (after); a point past the end or turned back counts as after.
    fn duration(&self) -> Option<f64> {
        let (slowest, fastest) = self.speed2_range();
        if !(slowest > 0.0 && fastest.is_finite()) {
            return None;
        }
        let (mut before, mut after) = (0.0, STEP / slowest.sqrt());
        let mut tau = 2.0 * STEP / (self.start_speed2.sqrt() + self.speed2(STEP).sqrt());
        for _ in 0..NEWTON_STEPS {
            let (x, xd, _) = self.state(tau);
            if x >= STEP || xd <= 0.0 {
                after = tau;
            } else {
                before = tau;
            }
            let newton = tau - (x - STEP) / xd;
            let next = if newton > before && newton < after {
                newton
            } else {
                0.5 * (before + after)
            };
            let converged = (next - tau).abs() <= 4.0 * f64::EPSILON * tau;
            tau = next;
            if converged {
                break;
            }
        }
        let (x, xd, _) = self.state(tau);
        ((x - STEP).abs() <= 1e-9 * STEP && xd > 0.0).then_some(tau)
    }
}

impl TableProfile {
    /// The profile of the path speeds `speeds` at the grid points (the ends are taken as 0).
    /// With `jerk` [`JerkBound::Off`] its ramps from and to rest keep the table's `s̈` of
    /// the first and the last interval (a step from rest, as a second-order TOPP has it),
    /// without shift or tilt.
    pub fn from_speeds(speeds: &[f64; POINTS], jerk: JerkBound) -> Result<Self, TableError> {
        let mut table = Self {
            speeds: *speeds,
            middles: [0.0; INTERVALS],
            shift: 0.0,
            tilt: 0.0,
            ramp_up: 0.0,
            ramp_down: 0.0,
            jerk_limited: jerk == JerkBound::Joints,
            peak: 0.0,
        };
        table.speeds[0] = 0.0;
        table.speeds[INTERVALS] = 0.0;
        for (k, v) in table.speeds.iter().enumerate() {
            if !(v.is_finite() && *v >= 0.0) {
                return Err(TableError::InvalidSpeed(k));
            }
        }
        let (first, last) = (
            table.interval_acceleration(0),
            table.interval_acceleration(INTERVALS - 1),
        );
        if table.jerk_limited {
            // Both ramps meet their middles: 3/4·(a + ε)·Δs = b_mid + δ at both ends, with
            // b_mid = a_0·Δs at the first and −a_{N−1}·Δs + 2·ε·(1 − Δs) at the last.
            table.tilt = (first + last) * STEP / (8.0 - 2.0 * STEP);
            table.shift = (3.0 * table.tilt - first) * STEP / 4.0;
        }
        let (rise, fall) = (first + table.tilt, last + table.tilt);
        if rise <= 0.0 {
            return Err(TableError::Standstill(0));
        }
        if fall >= 0.0 {
            return Err(TableError::Standstill(INTERVALS - 1));
        }
        // Over Δs/2 from rest: α·r²/6 at a constant jerk, α·r²/2 at a constant s̈.
        let reach = if table.jerk_limited { 3.0 } else { 1.0 };
        table.ramp_up = (reach * STEP / rise).sqrt();
        table.ramp_down = (-reach * STEP / fall).sqrt();
        table.middles[0] = table.ramp_up;
        let mut peak = table.middle_speed2(0);
        for k in 1..INTERVALS {
            let stretch = table.stretch(k);
            let time = stretch.duration().ok_or(TableError::Standstill(k))?;
            table.middles[k] = table.middles[k - 1] + time;
            peak = peak.max(stretch.speed2_range().1);
        }
        table.peak = peak.sqrt();
        Ok(table)
    }

    /// Total time from rest at `s = 0` to rest at `s = 1`, in s.
    pub fn duration(&self) -> f64 {
        self.middles[INTERVALS - 1] + self.ramp_down
    }

    /// Largest `ṡ` anywhere.
    pub fn peak_velocity(&self) -> f64 {
        self.peak
    }

    /// `ṡ` at the grid points as the solver found them (the profile's own differ by a
    /// fraction of one interval's change, see the module documentation).
    pub fn speeds(&self) -> &[f64; POINTS] {
        &self.speeds
    }

    /// The table's constant `s̈` of interval `k`.
    fn interval_acceleration(&self, k: usize) -> f64 {
        (self.speeds[k + 1].powi(2) - self.speeds[k].powi(2)) / (2.0 * STEP)
    }

    /// The profile's `ṡ²` at the middle of interval `k`.
    fn middle_speed2(&self, k: usize) -> f64 {
        0.5 * (self.speeds[k].powi(2) + self.speeds[k + 1].powi(2))
            + self.shift
            + 2.0 * self.tilt * k as f64 * STEP
    }

    /// The stretch from the middle of interval `k − 1` to that of `k`, `k` in `1..N`.
    fn stretch(&self, k: usize) -> Stretch {
        let before = self.interval_acceleration(k - 1);
        Stretch {
            start_speed2: self.middle_speed2(k - 1),
            acceleration: before + self.tilt,
            slope: (self.interval_acceleration(k) - before) / STEP,
        }
    }

    /// `(s, ṡ, s̈)` at time `t`; before 0 at rest at 0, after the end at rest at 1. A binary
    /// search of the middles (at most `log2(N) + 1` steps) and a closed form: no allocation.
    pub fn eval(&self, t: f64) -> (f64, f64, f64) {
        if t.is_nan() || t <= 0.0 {
            return (0.0, 0.0, 0.0);
        }
        let duration = self.duration();
        if t >= duration {
            return (1.0, 0.0, 0.0);
        }
        let k = self.middles.partition_point(|&middle| middle <= t);
        if k == 0 {
            let rise = self.interval_acceleration(0) + self.tilt;
            return self.ramp_state(rise, self.ramp_up, t);
        }
        if k == INTERVALS {
            let fall = self.interval_acceleration(INTERVALS - 1) + self.tilt;
            // The ramp to rest is the one from rest backwards in time and in `s`.
            let (s, sd, sdd) = self.ramp_state(fall, self.ramp_down, duration - t);
            return (1.0 + s, -sd, sdd);
        }
        let (x, xd, xdd) = self.stretch(k).state(t - self.middles[k - 1]);
        let s = (k as f64 - 0.5) * STEP + x.clamp(0.0, STEP);
        (s, xd.max(0.0), xdd)
    }

    /// `(s, ṡ, s̈)` a time `t` into a ramp from rest to `s̈ = alpha` that takes `ramp`.
    fn ramp_state(&self, alpha: f64, ramp: f64, t: f64) -> (f64, f64, f64) {
        if self.jerk_limited {
            let jerk = alpha / ramp;
            (jerk * t.powi(3) / 6.0, 0.5 * jerk * t * t, jerk * t)
        } else {
            (0.5 * alpha * t * t, alpha * t, alpha)
        }
    }

    /// The same path in `duration` instead of [`duration`](Self::duration), by uniform time
    /// scaling `t' = k·t`: velocity and acceleration drop by `k` and `k²`. A `duration` not
    /// longer than the profile returns it unchanged.
    pub fn stretched(&self, duration: f64) -> Self {
        let k = duration / self.duration();
        if k.is_nan() || k <= 1.0 {
            return *self;
        }
        Self {
            speeds: self.speeds.map(|v| v / k),
            middles: self.middles.map(|t| t * k),
            shift: self.shift / (k * k),
            tilt: self.tilt / (k * k),
            ramp_up: self.ramp_up * k,
            ramp_down: self.ramp_down * k,
            jerk_limited: self.jerk_limited,
            peak: self.peak / k,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A triangular speed profile: constant acceleration 1 to the middle, then braking.
    fn triangle() -> TableProfile {
        // ṡ² = 2·s up to 0.5, mirrored: ṡ = √(2·min(s, 1 − s)).
        let speeds = core::array::from_fn(|k| {
            let s = k as f64 * STEP;
            (2.0 * s.min(1.0 - s)).sqrt()
        });
        TableProfile::from_speeds(&speeds, JerkBound::Joints).unwrap()
    }

    /// Speeds that rise and fall several times, slower to the end than from the start.
    fn wavy() -> TableProfile {
        let speeds = core::array::from_fn(|k| {
            let s = k as f64 * STEP;
            let pi = core::f64::consts::PI;
            (pi * s).sin().sqrt() * (1.3 + 0.3 * (7.0 * pi * s).sin()) * (1.5 - s)
        });
        TableProfile::from_speeds(&speeds, JerkBound::Joints).unwrap()
    }

    #[test]
    fn a_constant_acceleration_table_runs_its_speeds_between_jerk_limited_ramps() {
        let p = triangle();
        // Equal ends: no tilt, and ṡ² a quarter of the first interval's gain lower.
        assert_eq!(p.tilt, 0.0);
        assert!((p.shift + 0.25 * STEP).abs() < 1e-15);
        // From rest at a constant jerk for √(3·Δs) to s̈ = 1 at the first middle.
        let ramp = (3.0 * STEP).sqrt();
        assert!((p.ramp_up - ramp).abs() < 1e-15);
        let (s, sd, sdd) = p.eval(0.5 * ramp);
        let jerk = 1.0 / ramp;
        assert!((sdd - 0.5).abs() < 1e-12 && (sd - 0.125 * jerk * ramp * ramp).abs() < 1e-12);
        assert!((s - jerk * (0.5 * ramp).powi(3) / 6.0).abs() < 1e-15);
        // Then at s̈ = 1 with ṡ² = 2·s − Δs/4 up to the middle's stretch.
        for t in [0.2, 0.5, 0.9] {
            let (s, sd, sdd) = p.eval(t);
            assert!((sdd - 1.0).abs() < 1e-9, "{t}: {sdd}");
            assert!((sd * sd - (2.0 * s - 0.25 * STEP)).abs() < 1e-9, "{t}");
        }
        // At each end the ramp from rest takes (√3 − 1)·√Δs longer than a step to s̈ = 1
        // would, and the lower speed about √Δs/8 more.
        let late = 2.0 * (3f64.sqrt() - 1.0 + 0.125) * STEP.sqrt();
        assert!(
            (p.duration() - 2.0 - late).abs() < 0.01 * STEP.sqrt(),
            "{}",
            p.duration()
        );
        // Symmetric: braking mirrors speeding up.
        let (s, sd, sdd) = p.eval(p.duration() - 0.3);
        let (s1, sd1, sdd1) = p.eval(0.3);
        assert!((1.0 - s - s1).abs() < 1e-9 && (sd - sd1).abs() < 1e-9);
        assert!((sdd + sdd1).abs() < 1e-9);
        assert_eq!(p.eval(-1.0), (0.0, 0.0, 0.0));
        assert_eq!(p.eval(f64::NAN), (0.0, 0.0, 0.0));
        assert_eq!(p.eval(3.0), (1.0, 0.0, 0.0));
    }

    #[test]
    fn positions_follow_the_commanded_speed_and_acceleration() {
        let p = wavy();
        assert!(p.tilt != 0.0 && p.shift < 0.0);
        // The largest change of s̈ on a fine sampling: the profile's jerk.
        let fine = 1e-5;
        let samples = (p.duration() / fine) as usize + 2;
        let jerk = (0..samples)
            .map(|n| (p.eval((n + 1) as f64 * fine).2 - p.eval(n as f64 * fine).2).abs() / fine)
            .fold(0.0, f64::max);
        assert!(jerk.is_finite() && jerk > 1.0);
        let dt = 1e-3;
        let ticks = (p.duration() / dt) as usize + 4;
        let s: Vec<(f64, f64, f64)> = (0..ticks).map(|n| p.eval(n as f64 * dt)).collect();
        for n in 1..ticks - 2 {
            let velocity = (s[n + 1].0 - s[n - 1].0) / (2.0 * dt);
            let acceleration = (s[n + 1].0 - 2.0 * s[n].0 + s[n - 1].0) / (dt * dt);
            let third = (s[n + 2].0 - 3.0 * s[n + 1].0 + 3.0 * s[n].0 - s[n - 1].0) / dt.powi(3);
            assert!(
                (velocity - s[n].1).abs() < jerk * dt * dt,
                "{n}: {velocity} {:?}",
                s[n]
            );
            assert!(
                (acceleration - s[n].2).abs() < jerk * dt,
                "{n}: {acceleration} {:?}",
                s[n]
            );
            assert!(third.abs() <= jerk * 1.001 + 1e-6, "{n}: {third} > {jerk}");
        }
        assert!(s.windows(2).all(|w| w[1].0 >= w[0].0));
        assert_eq!(s[ticks - 1], (1.0, 0.0, 0.0));
    }

    #[test]
    fn the_middles_keep_the_tables_speed_and_nothing_runs_faster() {
        let p = wavy();
        // At the middles the table's ṡ² with the shift (and the tilt's share).
        for k in [0, 1, 17, 128, 200, INTERVALS - 1] {
            let (s, sd, _) = p.eval(p.middles[k]);
            assert!((s - (k as f64 + 0.5) * STEP).abs() < 1e-12, "{k}: {s}");
            assert!((sd * sd - p.middle_speed2(k)).abs() < 1e-9, "{k}");
            let table = 0.5 * (p.speeds[k].powi(2) + p.speeds[k + 1].powi(2)) + p.shift;
            assert!((sd * sd - table).abs() <= 2.0 * p.tilt.abs(), "{k}");
        }
        let fastest = p.speeds.iter().copied().fold(0.0, f64::max);
        let mut t = 0.0;
        while t < p.duration() {
            assert!(p.eval(t).1 <= p.peak_velocity() + 1e-12);
            t += 1e-4;
        }
        assert!(p.peak_velocity() <= fastest && p.peak_velocity() > 0.99 * fastest);
    }

    #[test]
    fn stretching_scales_time_uniformly() {
        let p = wavy();
        let q = p.stretched(2.0 * p.duration());
        assert!((q.duration() - 2.0 * p.duration()).abs() < 1e-12);
        for t in [0.001, 0.3, 0.5 * p.duration(), p.duration() - 0.001] {
            let (s, sd, sdd) = q.eval(2.0 * t);
            let (s1, sd1, sdd1) = p.eval(t);
            assert!(
                (s - s1).abs() < 1e-12 && (sd - 0.5 * sd1).abs() < 1e-12,
                "{t}"
            );
            assert!((sdd - 0.25 * sdd1).abs() < 1e-9, "{t}");
        }
        assert_eq!(p.stretched(p.duration()), p);
    }

    #[test]
    fn a_standing_interior_point_is_refused() {
        let mut speeds = [1.0; POINTS];
        speeds[3] = 0.0;
        speeds[4] = 0.0;
        assert_eq!(
            TableProfile::from_speeds(&speeds, JerkBound::Joints),
            Err(TableError::Standstill(3))
        );
        speeds[4] = f64::NAN;
        assert_eq!(
            TableProfile::from_speeds(&speeds, JerkBound::Joints),
            Err(TableError::InvalidSpeed(4))
        );
    }
}
