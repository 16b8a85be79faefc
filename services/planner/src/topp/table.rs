//! The time-parameterised path `s(t)` of a time-optimal path parameterisation: the path
//! speed at the grid points `s_k = k/N` and the times they are passed.
//!
//! Between two grid points the path acceleration is constant (`ṡ²` is linear in `s`, as
//! the solver assumed), so `s` and `ṡ` are exact and the constraints checked at the grid
//! points hold in between. The reported `s̈` is that constant blended linearly in time from
//! the middle of one interval to the middle of the next (and from 0 at both ends): the
//! commanded acceleration then changes continuously, at the rate the path-jerk bound of the
//! solver limits, instead of stepping at every grid point.

use super::INTERVALS;

/// Grid points of a table: both ends included.
pub const POINTS: usize = INTERVALS + 1;

/// A rest-to-rest profile of `s` from 0 to 1 given at the grid points.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TableProfile {
    /// Time at which `s_k` is passed; `times[0] = 0`, increasing.
    times: [f64; POINTS],
    /// `ṡ` at `s_k`; 0 at both ends.
    speeds: [f64; POINTS],
}

/// Why a table cannot be made of the path speeds.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum TableError {
    #[error("the path speed at grid point {0} is not finite or negative")]
    InvalidSpeed(usize),
    #[error("the path stands still inside interval {0}")]
    Standstill(usize),
}

impl TableProfile {
    /// The profile of the path speeds `speeds` at the grid points (the ends are taken as 0).
    pub fn from_speeds(speeds: &[f64; POINTS]) -> Result<Self, TableError> {
        let step = 1.0 / INTERVALS as f64;
        let mut table = Self {
            times: [0.0; POINTS],
            speeds: *speeds,
        };
        table.speeds[0] = 0.0;
        table.speeds[INTERVALS] = 0.0;
        for (k, v) in table.speeds.iter().enumerate() {
            if !(v.is_finite() && *v >= 0.0) {
                return Err(TableError::InvalidSpeed(k));
            }
        }
        for k in 0..INTERVALS {
            // Constant acceleration: the mean speed of the interval is the mean of its ends.
            let mean = 0.5 * (table.speeds[k] + table.speeds[k + 1]);
            let dt = step / mean;
            if !(dt.is_finite() && dt > 0.0) {
                return Err(TableError::Standstill(k));
            }
            table.times[k + 1] = table.times[k] + dt;
        }
        Ok(table)
    }

    /// Total time from rest at `s = 0` to rest at `s = 1`, in s.
    pub fn duration(&self) -> f64 {
        self.times[INTERVALS]
    }

    /// Largest `ṡ` at the grid points (and so anywhere).
    pub fn peak_velocity(&self) -> f64 {
        self.speeds.iter().copied().fold(0.0, f64::max)
    }

    /// `ṡ` at the grid points.
    pub fn speeds(&self) -> &[f64; POINTS] {
        &self.speeds
    }

    /// The constant `s̈` of interval `k`.
    fn acceleration(&self, k: usize) -> f64 {
        (self.speeds[k + 1] - self.speeds[k]) / (self.times[k + 1] - self.times[k])
    }

    /// `(time, s̈)` of the middle of interval `k`; outside the grid the ends at rest.
    fn knot(&self, k: isize) -> (f64, f64) {
        match usize::try_from(k) {
            Err(_) => (0.0, 0.0),
            Ok(k) if k >= INTERVALS => (self.duration(), 0.0),
            Ok(k) => (
                0.5 * (self.times[k] + self.times[k + 1]),
                self.acceleration(k),
            ),
        }
    }

    /// `(s, ṡ, s̈)` at time `t`; before 0 at rest at 0, after the end at rest at 1. A binary
    /// search of the grid: at most `log2(N) + 1` steps, no allocation.
    pub fn eval(&self, t: f64) -> (f64, f64, f64) {
        if t.is_nan() || t <= 0.0 {
            return (0.0, 0.0, 0.0);
        }
        if t >= self.duration() {
            return (1.0, 0.0, 0.0);
        }
        let k = (self.times.partition_point(|&time| time <= t) - 1).min(INTERVALS - 1);
        let tau = t - self.times[k];
        let a = self.acceleration(k);
        let s = (k as f64 + tau * (self.speeds[k] + 0.5 * a * tau) * INTERVALS as f64)
            / INTERVALS as f64;
        let sd = self.speeds[k] + a * tau;
        let (t0, a0) = self.knot(k as isize);
        let neighbour = if t < t0 {
            k as isize - 1
        } else {
            k as isize + 1
        };
        let (t1, a1) = self.knot(neighbour);
        let share = if t1 == t0 { 0.0 } else { (t - t0) / (t1 - t0) };
        (s.min(1.0), sd.max(0.0), a0 + (a1 - a0) * share)
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
            times: self.times.map(|t| t * k),
            speeds: self.speeds.map(|v| v / k),
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
            let s = k as f64 / INTERVALS as f64;
            (2.0 * s.min(1.0 - s)).sqrt()
        });
        TableProfile::from_speeds(&speeds).unwrap()
    }

    #[test]
    fn a_constant_acceleration_table_is_the_analytic_profile() {
        let p = triangle();
        // Accelerate at 1 over s = 0.5: t = 1, twice.
        assert!((p.duration() - 2.0).abs() < 1e-12, "{}", p.duration());
        for t in [0.1, 0.4, 0.77] {
            let (s, sd, _) = p.eval(t);
            assert!((s - 0.5 * t * t).abs() < 1e-12);
            assert!((sd - t).abs() < 1e-12);
        }
        let (s, sd, sdd) = p.eval(1.5);
        assert!((s - (1.0 - 0.5 * 0.25)).abs() < 1e-12);
        assert!((sd - 0.5).abs() < 1e-12);
        assert!((sdd + 1.0).abs() < 1e-9);
        assert_eq!(p.eval(-1.0), (0.0, 0.0, 0.0));
        assert_eq!(p.eval(f64::NAN), (0.0, 0.0, 0.0));
        assert_eq!(p.eval(3.0), (1.0, 0.0, 0.0));
    }

    #[test]
    fn the_acceleration_is_continuous() {
        let p = triangle();
        let dt = 1e-4;
        let mut previous = p.eval(0.0);
        let mut t = dt;
        while t < p.duration() + dt {
            let now = p.eval(t);
            assert!(now.0 >= previous.0 - 1e-15);
            // The largest change is the switch from +1 to −1 over one interval's time.
            assert!(
                (now.2 - previous.2).abs() < 0.25,
                "{t}: {previous:?} -> {now:?}"
            );
            previous = now;
            t += dt;
        }
    }

    #[test]
    fn stretching_scales_time_uniformly() {
        let p = triangle();
        let q = p.stretched(4.0);
        assert!((q.duration() - 4.0).abs() < 1e-12);
        let (s, sd, sdd) = q.eval(2.0);
        let (s1, sd1, sdd1) = p.eval(1.0);
        assert!((s - s1).abs() < 1e-12 && (sd - 0.5 * sd1).abs() < 1e-12);
        assert!((sdd - 0.25 * sdd1).abs() < 1e-9);
        assert_eq!(p.stretched(1.0), p);
    }

    #[test]
    fn a_standing_interior_point_is_refused() {
        let mut speeds = [1.0; POINTS];
        speeds[3] = 0.0;
        speeds[4] = 0.0;
        assert_eq!(
            TableProfile::from_speeds(&speeds),
            Err(TableError::Standstill(3))
        );
        speeds[4] = f64::NAN;
        assert_eq!(
            TableProfile::from_speeds(&speeds),
            Err(TableError::InvalidSpeed(4))
        );
    }
}
