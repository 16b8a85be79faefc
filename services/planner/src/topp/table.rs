//! The time-parameterised path `s(t)` of a time-optimal path parameterisation: the path
//! speeds the solver found at the grid points `s_k = k/N`, run with a continuous
//! acceleration whose positions follow it exactly.
//!
//! The solver takes the path acceleration constant in every interval (`ṡ²` linear in `s`).
//! Run so, the positions' acceleration would step at every grid point, and from rest by the
//! whole first interval's `s̈` within one tick: a servo that follows position setpoints would
//! see those steps as jerk. The profile therefore runs `s̈` from the table's `a_{k−1}` at the
//! middle of interval `k − 1` to its `a_k` at the middle of interval `k` (a stretch), and
//! `s`, `ṡ` and `s̈` at any time are the exact solution there: the positions' acceleration is
//! the commanded one.
//!
//! - On most of the path `s̈` runs linearly **in `s`** over a stretch: `s̈ = A + B·(s − s_0)`,
//!   hyperbolic or trigonometric in time. `ṡ²` gains what the table gains between the same
//!   middles, so the profile keeps the table's speeds at the middles (at a grid point it
//!   differs by `(a_k − a_{k−1})·Δs/4`), and its jerk `B·ṡ = (a_k − a_{k−1})·ṡ/Δs` is largest
//!   at the stretch's fastest point.
//! - In the [`ZONE`] stretches next to either end `s̈` runs linearly **in time** (a constant
//!   jerk, the change over the stretch's time). Near rest the speed varies much along one
//!   stretch, and linear in `s` the jerk would reach its bound only at the stretch's fast
//!   end: 2.2 % longer lines at the median of `rc bench motion`, all of it within 20 grid
//!   points of the ends. Linear in time the speeds drift from the table's by a little.
//! - From rest to the first middle and from the last to rest, `s̈` ramps at a constant jerk
//!   (from rest it cannot in `s`: `s̈ = B·s` never leaves `s = 0`). Such a ramp reaches the
//!   middle `Δs/2` at `ṡ² = 3/4·α·Δs` for its end acceleration `α`, where the table has
//!   `α·Δs`; its jerk is `α^(3/2)/√(3·Δs)`.
//!
//! The ramp from rest and the stretches of the first zone are run forwards, those of the
//! last zone and the ramp to rest backwards from the end; the middle part in `s` starts at
//! the first zone's speed and must arrive at the last one's. It does with every `s̈` raised
//! by a constant `ε` (the tilt, a fraction of a per mille of the end accelerations), found
//! by the secant method. Without the jerk bound (comparisons with second-order TOPP) the
//! ends keep the table's step of `s̈` from rest, and every stretch runs in `s`.

use super::{INTERVALS, JerkBound};

/// Grid points of a table: both ends included.
pub const POINTS: usize = INTERVALS + 1;
/// Stretches next to either end of a jerk-limited table that run `s̈` linearly in time.
pub const ZONE: usize = 32;
/// Grid step of `s`.
const STEP: f64 = 1.0 / INTERVALS as f64;
/// Newton steps for the time of a stretch at most (three to five reach rounding).
const NEWTON_STEPS: usize = 60;
/// Secant steps for the tilt at most (two or three reach rounding).
const TILT_STEPS: usize = 30;

/// A rest-to-rest profile of `s` from 0 to 1 given by its speeds at the grid points.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TableProfile {
    /// `ṡ` at `s_k` as the solver found it; 0 at both ends.
    speeds: [f64; POINTS],
    /// Time at which the middle of interval `k` is passed; increasing.
    middles: [f64; INTERVALS],
    /// `ṡ` of the profile at the middle of interval `k`.
    middle_speeds: [f64; INTERVALS],
    /// `ε`, added to the table's `s̈` everywhere.
    tilt: f64,
    /// Time of the ramp from rest to the first middle, s.
    ramp_up: f64,
    /// Time of the ramp from the last middle to rest, s.
    ramp_down: f64,
    /// Whether the ramps run at a constant jerk and the zones in time.
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
    #[error("the table's ramps from and to rest cannot be met")]
    Unmatched,
}

/// The jerk of the stretch of a table around one grid point, with the speeds and
/// accelerations it has there: what the jerk budget of the joints is checked against.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StretchJerk {
    /// `(lowest, highest)` path jerk `s⃛`.
    pub jerk: (f64, f64),
    /// `(lowest, highest)` `ṡ`.
    pub speeds: (f64, f64),
    /// `(lowest, highest)` `s̈`.
    pub accelerations: (f64, f64),
}

/// A stretch with `s̈` linear in `s`, `x = s − s_0` from 0 to `Δs`: `ẍ = A + B·x` from
/// `ẋ² = b_0`.
#[derive(Debug, Clone, Copy)]
struct SpaceStretch {
    /// `ṡ²` at its start.
    start_speed2: f64,
    /// `s̈` at its start (`A`).
    acceleration: f64,
    /// `ds̈/ds` (`B`).
    slope: f64,
}

impl SpaceStretch {
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

    /// Its jerk `B·ṡ` and speeds.
    fn jerk(&self) -> ((f64, f64), (f64, f64)) {
        let (lo, hi) = self.speed2_range();
        let (lo, hi) = (lo.max(0.0).sqrt(), hi.sqrt());
        let (a, b) = (self.slope * lo, self.slope * hi);
        ((a.min(b), a.max(b)), (lo, hi))
    }
}

/// The time of a stretch that runs `s̈` linearly in time from `from` to `to`, from the speed
/// `start_speed`; `None` where the path would stop on it.
pub fn time_through(start_speed: f64, from: f64, to: f64) -> Option<f64> {
    TimeStretch::through(start_speed, from, to).map(|stretch| stretch.time)
}

/// A stretch with `s̈` linear in time, from `from` to `to` over `time`, from the speed
/// `start_speed`.
#[derive(Debug, Clone, Copy)]
struct TimeStretch {
    start_speed: f64,
    from: f64,
    to: f64,
    time: f64,
}

impl TimeStretch {
    /// The stretch over `Δs` from `start_speed` with `s̈` from `from` to `to`: its time
    /// solves `v_0·T + (2·from + to)·T²/6 = Δs`. `None` where the path would stop on it.
    fn through(start_speed: f64, from: f64, to: f64) -> Option<Self> {
        let c = (2.0 * from + to) / 6.0;
        let discriminant = start_speed * start_speed + 4.0 * c * STEP;
        if discriminant.is_nan() || discriminant < 0.0 {
            return None;
        }
        let time = 2.0 * STEP / (start_speed + discriminant.sqrt());
        let stretch = Self {
            start_speed,
            from,
            to,
            time,
        };
        (time.is_finite() && time > 0.0 && stretch.speed_range().0 > 0.0).then_some(stretch)
    }

    /// Its constant jerk `s⃛`.
    fn jerk(&self) -> f64 {
        (self.to - self.from) / self.time
    }

    /// `(x, ẋ, ẍ)` a time `tau` after its start.
    fn state(&self, tau: f64) -> (f64, f64, f64) {
        let jerk = self.jerk();
        (
            tau * (self.start_speed + tau * (0.5 * self.from + tau * jerk / 6.0)),
            self.start_speed + tau * (self.from + 0.5 * jerk * tau),
            self.from + jerk * tau,
        )
    }

    /// `ṡ` at its end.
    fn end_speed(&self) -> f64 {
        self.start_speed + 0.5 * (self.from + self.to) * self.time
    }

    /// The smallest and the largest `ṡ` on it (at an end, or where `s̈` passes 0).
    fn speed_range(&self) -> (f64, f64) {
        let (a, b) = (self.start_speed, self.end_speed());
        let (mut lo, mut hi) = (a.min(b), a.max(b));
        if self.from * self.to < 0.0 {
            let vertex = self.state(self.time * self.from / (self.from - self.to)).1;
            (lo, hi) = (lo.min(vertex), hi.max(vertex));
        }
        (lo, hi)
    }
}

impl TableProfile {
    /// The profile of the path speeds `speeds` at the grid points (the ends are taken as 0).
    /// With `jerk` [`JerkBound::Off`] its ramps from and to rest keep the table's `s̈` of
    /// the first and the last interval (a step from rest, as a second-order TOPP has it), and
    /// all its stretches run in `s`.
    pub fn from_speeds(speeds: &[f64; POINTS], jerk: JerkBound) -> Result<Self, TableError> {
        let mut table = Self {
            speeds: *speeds,
            middles: [0.0; INTERVALS],
            middle_speeds: [0.0; INTERVALS],
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
        let mut durations = [0.0; INTERVALS];
        table.match_ends(&mut durations)?;
        let (first, last) = table.middle_part();
        for (k, duration) in durations.iter_mut().enumerate().take(last + 1).skip(first) {
            let stretch = table.space_stretch(k);
            *duration = stretch.duration().ok_or(TableError::Standstill(k))?;
            if k < last {
                table.middle_speeds[k] = stretch.speed2(STEP).sqrt();
            }
        }
        let mut time = table.ramp_up;
        for (middle, duration) in table.middles.iter_mut().zip(&durations) {
            time += duration;
            *middle = time;
        }
        table.peak = (1..INTERVALS)
            .map(|k| table.stretch_speeds(k).1)
            .fold(0.0, f64::max);
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
            return self.ramp_state(self.acceleration(0), self.ramp_up, t);
        }
        if k == INTERVALS {
            // The ramp to rest is the one from rest backwards in time and in `s`.
            let fall = self.acceleration(INTERVALS - 1);
            let (s, sd, sdd) = self.ramp_state(fall, self.ramp_down, duration - t);
            return (1.0 + s, -sd, sdd);
        }
        let tau = t - self.middles[k - 1];
        let (x, xd, xdd) = if self.in_time(k) {
            self.time_stretch(k).state(tau)
        } else {
            self.space_stretch(k).state(tau)
        };
        let s = (k as f64 - 0.5) * STEP + x.clamp(0.0, STEP);
        (s, xd.max(0.0), xdd)
    }

    /// The jerk of a jerk-limited table around grid point `m`: the ramp from rest at 0,
    /// the one to rest at `N`, else the stretch from the middle of interval `m − 1` to that
    /// of `m`.
    pub fn jerk_at(&self, m: usize) -> StretchJerk {
        if m == 0 {
            let rise = self.acceleration(0);
            let jerk = rise / self.ramp_up;
            return StretchJerk {
                jerk: (jerk, jerk),
                speeds: (0.0, self.middle_speeds[0]),
                accelerations: (0.0, rise),
            };
        }
        if m >= INTERVALS {
            let fall = self.acceleration(INTERVALS - 1);
            let jerk = -fall / self.ramp_down;
            return StretchJerk {
                jerk: (jerk, jerk),
                speeds: (0.0, self.middle_speeds[INTERVALS - 1]),
                accelerations: (fall, 0.0),
            };
        }
        let (from, to) = (self.acceleration(m - 1), self.acceleration(m));
        let (jerk, speeds) = if self.in_time(m) {
            let stretch = self.time_stretch(m);
            let jerk = stretch.jerk();
            ((jerk, jerk), stretch.speed_range())
        } else {
            self.space_stretch(m).jerk()
        };
        StretchJerk {
            jerk,
            speeds,
            accelerations: (from.min(to), from.max(to)),
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
            middle_speeds: self.middle_speeds.map(|v| v / k),
            tilt: self.tilt / (k * k),
            ramp_up: self.ramp_up * k,
            ramp_down: self.ramp_down * k,
            jerk_limited: self.jerk_limited,
            peak: self.peak / k,
        }
    }

    /// The table's constant `s̈` of interval `k`.
    fn interval_acceleration(&self, k: usize) -> f64 {
        (self.speeds[k + 1].powi(2) - self.speeds[k].powi(2)) / (2.0 * STEP)
    }

    /// The profile's `s̈` at the middle of interval `k`: the table's, tilted.
    fn acceleration(&self, k: usize) -> f64 {
        self.interval_acceleration(k) + self.tilt
    }

    /// The first and the last stretch that run in `s`.
    fn middle_part(&self) -> (usize, usize) {
        let zone = if self.jerk_limited { ZONE } else { 0 };
        (zone + 1, INTERVALS - 1 - zone)
    }

    /// Whether stretch `k` runs `s̈` linearly in time.
    fn in_time(&self, k: usize) -> bool {
        let (first, last) = self.middle_part();
        k < first || k > last
    }

    /// Stretch `k`, from the middle of interval `k − 1` to that of `k`, in `s`.
    fn space_stretch(&self, k: usize) -> SpaceStretch {
        SpaceStretch {
            start_speed2: self.middle_speeds[k - 1].powi(2),
            acceleration: self.acceleration(k - 1),
            slope: (self.interval_acceleration(k) - self.interval_acceleration(k - 1)) / STEP,
        }
    }

    /// Stretch `k` in time (its time from the middles: the table must be complete).
    fn time_stretch(&self, k: usize) -> TimeStretch {
        TimeStretch {
            start_speed: self.middle_speeds[k - 1],
            from: self.acceleration(k - 1),
            to: self.acceleration(k),
            time: self.middles[k] - self.middles[k - 1],
        }
    }

    /// The smallest and the largest `ṡ` on stretch `k`.
    fn stretch_speeds(&self, k: usize) -> (f64, f64) {
        if self.in_time(k) {
            self.time_stretch(k).speed_range()
        } else {
            let (lo, hi) = self.space_stretch(k).speed2_range();
            (lo.max(0.0).sqrt(), hi.sqrt())
        }
    }

    /// Finds the tilt with which the part in `s`, from the first zone's speed at its end,
    /// arrives at the last zone's speed at its start (the secant method: the arrival moves
    /// with the tilt nearly linearly), and leaves the ramps and the zones run with it.
    fn match_ends(&mut self, durations: &mut [f64; INTERVALS]) -> Result<(), TableError> {
        let (first, last) = self.middle_part();
        // What `ṡ²` gains over the part in `s` without the tilt, and per unit of tilt.
        let gain = (first..=last)
            .map(|k| (self.interval_acceleration(k - 1) + self.interval_acceleration(k)) * STEP)
            .sum::<f64>();
        let per_tilt = 2.0 * (last + 1 - first) as f64 * STEP;
        let fastest = self.speeds.iter().copied().fold(0.0, f64::max);
        let tolerance = 1e-12 * (1.0 + fastest * fastest);
        let mut mismatch = |table: &mut Self, tilt: f64| -> Result<f64, TableError> {
            table.tilt = tilt;
            table.run_zones(durations)?;
            let arrival = table.middle_speeds[first - 1].powi(2) + gain + per_tilt * tilt;
            Ok(arrival - table.middle_speeds[last].powi(2))
        };
        let (mut before, mut before_miss) = (0.0, mismatch(self, 0.0)?);
        if before_miss.abs() <= tolerance {
            return Ok(());
        }
        let mut tilt = -before_miss / per_tilt;
        for _ in 0..TILT_STEPS {
            let miss = mismatch(self, tilt)?;
            if miss.abs() <= tolerance {
                return Ok(());
            }
            if miss == before_miss {
                break;
            }
            let next = tilt - miss * (tilt - before) / (miss - before_miss);
            (before, before_miss, tilt) = (tilt, miss, next);
        }
        Err(TableError::Unmatched)
    }

    /// The ramps and the zones run with the current tilt: the ramps' times, the zones'
    /// speeds at the middles and their stretches' times into `durations`.
    fn run_zones(&mut self, durations: &mut [f64; INTERVALS]) -> Result<(), TableError> {
        let (rise, fall) = (self.acceleration(0), self.acceleration(INTERVALS - 1));
        if rise <= 0.0 {
            return Err(TableError::Standstill(0));
        }
        if fall >= 0.0 {
            return Err(TableError::Standstill(INTERVALS - 1));
        }
        // Over Δs/2 from rest: α·r²/6 at a constant jerk to ṡ² = 3/4·α·Δs, α·r²/2 at a
        // constant s̈ to ṡ² = α·Δs.
        let (reach, speed2) = if self.jerk_limited {
            (3.0, 0.75)
        } else {
            (1.0, 1.0)
        };
        self.ramp_up = (reach * STEP / rise).sqrt();
        self.ramp_down = (-reach * STEP / fall).sqrt();
        self.middle_speeds[0] = (speed2 * rise * STEP).sqrt();
        self.middle_speeds[INTERVALS - 1] = (-speed2 * fall * STEP).sqrt();
        let (first, last) = self.middle_part();
        for (k, duration) in durations.iter_mut().enumerate().take(first).skip(1) {
            let (from, to) = (self.acceleration(k - 1), self.acceleration(k));
            let stretch = TimeStretch::through(self.middle_speeds[k - 1], from, to)
                .ok_or(TableError::Standstill(k))?;
            *duration = stretch.time;
            self.middle_speeds[k] = stretch.end_speed();
        }
        // Backwards in time: the same stretch from its end, `s̈` negated.
        for k in (last + 1..INTERVALS).rev() {
            let (from, to) = (self.acceleration(k - 1), self.acceleration(k));
            let stretch = TimeStretch::through(self.middle_speeds[k], -to, -from)
                .ok_or(TableError::Standstill(k))?;
            durations[k] = stretch.time;
            self.middle_speeds[k - 1] = stretch.end_speed();
        }
        Ok(())
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

    /// `(s, ṡ, s̈)` every `dt` from 0 to a little after the end.
    fn sampled(p: &TableProfile, dt: f64) -> Vec<(f64, f64, f64)> {
        let ticks = (p.duration() / dt) as usize + 4;
        (0..ticks).map(|n| p.eval(n as f64 * dt)).collect()
    }

    #[test]
    fn a_constant_acceleration_table_runs_its_speeds_between_jerk_limited_ramps() {
        let p = triangle();
        // Symmetric ends: no tilt.
        assert!(p.tilt.abs() < 1e-12, "{}", p.tilt);
        // From rest at a constant jerk for √(3·Δs) to s̈ = 1 at the first middle.
        let ramp = (3.0 * STEP).sqrt();
        assert!((p.ramp_up - ramp).abs() < 1e-15);
        let (s, sd, sdd) = p.eval(0.5 * ramp);
        let jerk = 1.0 / ramp;
        assert!((sdd - 0.5).abs() < 1e-12 && (sd - 0.125 * jerk * ramp * ramp).abs() < 1e-12);
        assert!((s - jerk * (0.5 * ramp).powi(3) / 6.0).abs() < 1e-15);
        // Then at s̈ = 1 with ṡ² = 2·s − Δs/4 (in the zone and in the part in `s`).
        for t in [0.15, 0.2, 0.5, 0.9] {
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
        assert!(p.tilt != 0.0);
        // The largest change of s̈ on a fine sampling: the profile's jerk.
        let fine = sampled(&p, 1e-5);
        let jerk = fine
            .windows(2)
            .map(|w| (w[1].2 - w[0].2).abs() / 1e-5)
            .fold(0.0, f64::max);
        assert!(jerk.is_finite() && jerk > 1.0);
        let dt = 1e-3;
        let s = sampled(&p, dt);
        for n in 1..s.len() - 2 {
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
        assert_eq!(s[s.len() - 1], (1.0, 0.0, 0.0));
    }

    #[test]
    fn the_zones_run_at_a_constant_jerk_and_the_middle_linearly_in_s() {
        let p = wavy();
        let at =
            |k: usize, share: f64| p.middles[k - 1] + share * (p.middles[k] - p.middles[k - 1]);
        for k in [1, 5, ZONE, INTERVALS - ZONE, INTERVALS - 1] {
            // s̈ linear in time: its middle is the mean of its ends.
            let [a, b, c] = [0.0, 0.5, 1.0].map(|share| p.eval(at(k, share)).2);
            assert!((b - 0.5 * (a + c)).abs() < 1e-9 * (1.0 + a.abs()), "{k}");
            assert!((a - p.acceleration(k - 1)).abs() < 1e-9, "{k}");
        }
        for k in [ZONE + 1, 128, INTERVALS - ZONE - 1] {
            // s̈ linear in s.
            let [(s0, _, a), (s1, _, b), (s2, _, c)] =
                [0.0, 0.4, 1.0].map(|share| p.eval(at(k, share)));
            let share = (s1 - s0) / (s2 - s0);
            assert!(
                (b - (a + share * (c - a))).abs() < 1e-9 * (1.0 + a.abs()),
                "{k}"
            );
        }
        // The jerk reported around the points is the one sampled.
        for m in [0, 3, ZONE, 100, INTERVALS - 2, INTERVALS] {
            let reported = p.jerk_at(m);
            let (from, to) = match m {
                0 => (0.0, p.middles[0]),
                INTERVALS => (p.middles[INTERVALS - 1], p.duration()),
                _ => (p.middles[m - 1], p.middles[m]),
            };
            let h = 1e-7;
            for share in [0.1, 0.5, 0.9] {
                let t = from + share * (to - from);
                let sampled = (p.eval(t + h).2 - p.eval(t - h).2) / (2.0 * h);
                let (lo, hi) = reported.jerk;
                let slack = 1e-5 * (1.0 + hi.abs());
                assert!(
                    sampled >= lo - slack && sampled <= hi + slack,
                    "{m}: {sampled} {reported:?}"
                );
                let (_, sd, sdd) = p.eval(t);
                assert!(sd >= reported.speeds.0 - 1e-12 && sd <= reported.speeds.1 + 1e-12);
                let (a, b) = reported.accelerations;
                assert!(sdd >= a - 1e-12 && sdd <= b + 1e-12, "{m}");
            }
        }
    }

    #[test]
    fn the_profile_keeps_near_the_tables_speeds_and_under_its_peak() {
        let p = wavy();
        // Lowered from the ramps on by about a quarter of the end accelerations' gain over
        // one interval, a little more or less where the zones drift.
        let (first, last) = (
            p.interval_acceleration(0),
            -p.interval_acceleration(INTERVALS - 1),
        );
        for k in [0, 1, 17, ZONE, 128, 200, INTERVALS - 1] {
            let (s, sd, _) = p.eval(p.middles[k]);
            assert!((s - (k as f64 + 0.5) * STEP).abs() < 1e-12, "{k}: {s}");
            assert!((sd - p.middle_speeds[k]).abs() < 1e-12, "{k}");
            let table = 0.5 * (p.speeds[k].powi(2) + p.speeds[k + 1].powi(2));
            let lower = table - sd * sd;
            assert!(
                lower > 0.0 && lower < 0.5 * first.max(last) * STEP,
                "{k}: {lower}"
            );
        }
        let mut t = 0.0;
        while t < p.duration() {
            assert!(p.eval(t).1 <= p.peak_velocity() + 1e-12);
            t += 1e-4;
        }
        let fastest = p.speeds.iter().copied().fold(0.0, f64::max);
        assert!(p.peak_velocity() <= fastest && p.peak_velocity() > 0.99 * fastest);
    }

    #[test]
    fn without_the_jerk_bound_the_ends_step_and_the_speeds_are_the_tables() {
        let speeds = *wavy().speeds();
        let p = TableProfile::from_speeds(&speeds, JerkBound::Off).unwrap();
        assert_eq!(p.tilt, 0.0);
        let a0 = p.interval_acceleration(0);
        assert_eq!(p.eval(1e-6).2, a0);
        for k in [0, 1, ZONE, 128, INTERVALS - 1] {
            let table = 0.5 * (speeds[k].powi(2) + speeds[k + 1].powi(2));
            assert!((p.middle_speeds[k].powi(2) - table).abs() < 1e-9, "{k}");
        }
    }

    #[test]
    fn stretching_scales_time_uniformly() {
        let p = wavy();
        let q = p.stretched(2.0 * p.duration());
        assert!((q.duration() - 2.0 * p.duration()).abs() < 1e-12);
        for t in [0.001, 0.05, 0.3, 0.5 * p.duration(), p.duration() - 0.001] {
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
        speeds[100] = 0.0;
        speeds[101] = 0.0;
        assert_eq!(
            TableProfile::from_speeds(&speeds, JerkBound::Joints),
            Err(TableError::Standstill(100))
        );
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
