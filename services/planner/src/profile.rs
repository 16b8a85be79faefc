//! The jerk-limited rest-to-rest "double-S" profile of a normalized path parameter.
//!
//! The path parameter `s` goes from 0 to 1 with `|ṡ| ≤ v`, `|s̈| ≤ a`, `|s⃛| ≤ j`, starting
//! and ending at rest with zero acceleration, in the shortest time those limits allow. The
//! closed form is the symmetric rest-to-rest case of the double-S trajectory in Biagiotti &
//! Melchiorri, "Trajectory Planning for Automatic Machines and Robots" (2008), §3.4, with the
//! cases where the velocity limit, or also the acceleration limit, is not reached.

/// A rest-to-rest double-S profile of `s` from 0 to 1.
///
/// The profile is symmetric: acceleration phase (jerk `+j`, constant `a_peak`, jerk `-j`),
/// cruise at `v_peak`, and the mirror image of the acceleration phase to stop.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DoubleS {
    /// Duration of each constant-jerk ramp.
    t_jerk: f64,
    /// Duration of the whole acceleration (and of the deceleration) phase.
    t_accel: f64,
    /// Duration of the cruise phase.
    t_cruise: f64,
    jerk: f64,
    /// Acceleration reached (`jerk·t_jerk`).
    a_peak: f64,
    /// Velocity reached (`a_peak·(t_accel − t_jerk)`).
    v_peak: f64,
}

impl DoubleS {
    /// The time-optimal profile for the path limits `v`, `a`, `j` (all positive and finite).
    pub fn new(v: f64, a: f64, j: f64) -> Self {
        // Velocity limit reached: a trapezoidal (or triangular) acceleration up to `v`.
        let (t_jerk, t_accel) = if v * j >= a * a {
            (a / j, a / j + v / a)
        } else {
            let t_jerk = (v / j).sqrt();
            (t_jerk, 2.0 * t_jerk)
        };
        let t_cruise = 1.0 / v - t_accel;
        if t_cruise >= 0.0 {
            return Self::from_phases(t_jerk, t_accel, t_cruise, j);
        }
        // No cruise. With the acceleration limit reached, v_peak·t_accel = 1 and
        // v_peak = a·(t_accel − a/j) give t_accel² − (a/j)·t_accel − 1/a = 0.
        let t_jerk = a / j;
        let t_accel = 0.5 * (t_jerk + (t_jerk * t_jerk + 4.0 / a).sqrt());
        if t_accel >= 2.0 * t_jerk {
            return Self::from_phases(t_jerk, t_accel, 0.0, j);
        }
        // Neither limit reached: pure jerk ramps, s(T) = 2·j·t_jerk³ = 1.
        let t_jerk = (0.5 / j).cbrt();
        Self::from_phases(t_jerk, 2.0 * t_jerk, 0.0, j)
    }

    fn from_phases(t_jerk: f64, t_accel: f64, t_cruise: f64, jerk: f64) -> Self {
        let a_peak = jerk * t_jerk;
        Self {
            t_jerk,
            t_accel,
            t_cruise,
            jerk,
            a_peak,
            v_peak: a_peak * (t_accel - t_jerk),
        }
    }

    /// The same path in `duration` instead of [`duration`](Self::duration), by time scaling
    /// `t' = k·t` with `k = duration / self.duration()`: velocity, acceleration and jerk drop
    /// by `k`, `k²`, `k³`. A `duration` not longer than the profile returns it unchanged.
    pub fn stretched(&self, duration: f64) -> Self {
        let k = duration / self.duration();
        if k.is_nan() || k <= 1.0 {
            return *self;
        }
        Self::from_phases(
            self.t_jerk * k,
            self.t_accel * k,
            self.t_cruise * k,
            self.jerk / (k * k * k),
        )
    }

    /// Total time from rest at `s = 0` to rest at `s = 1`, in s.
    pub fn duration(&self) -> f64 {
        2.0 * self.t_accel + self.t_cruise
    }

    /// Largest `ṡ` of the profile.
    pub fn peak_velocity(&self) -> f64 {
        self.v_peak
    }

    /// Largest `|s̈|` of the profile.
    pub fn peak_acceleration(&self) -> f64 {
        self.a_peak
    }

    /// Largest `|s⃛|` of the profile.
    pub fn peak_jerk(&self) -> f64 {
        self.jerk
    }

    /// `(s, ṡ, s̈)` at time `t`; before 0 the profile is at rest at 0, after the end at rest
    /// at 1.
    pub fn eval(&self, t: f64) -> (f64, f64, f64) {
        let total = self.duration();
        if t.is_nan() || t <= 0.0 {
            return (0.0, 0.0, 0.0);
        }
        if t >= total {
            return (1.0, 0.0, 0.0);
        }
        let half = self.t_accel + 0.5 * self.t_cruise;
        if t <= half {
            self.first_half(t)
        } else {
            // The deceleration is the acceleration mirrored in time and space.
            let (s, sd, sdd) = self.first_half(total - t);
            (1.0 - s, sd, -sdd)
        }
    }

    /// Acceleration and cruise phases, for `0 ≤ t ≤ t_accel + t_cruise`.
    fn first_half(&self, t: f64) -> (f64, f64, f64) {
        let (tj, ta, j) = (self.t_jerk, self.t_accel, self.jerk);
        if t < tj {
            (j * t * t * t / 6.0, 0.5 * j * t * t, j * t)
        } else if t < ta - tj {
            let a = self.a_peak;
            (
                a / 6.0 * (3.0 * t * t - 3.0 * tj * t + tj * tj),
                a * (t - 0.5 * tj),
                a,
            )
        } else if t < ta {
            let r = ta - t;
            let v = self.v_peak;
            (
                0.5 * v * ta - v * r + j * r * r * r / 6.0,
                v - 0.5 * j * r * r,
                j * r,
            )
        } else {
            let v = self.v_peak;
            (0.5 * v * ta + v * (t - ta), v, 0.0)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    const EPS: f64 = 1e-9;

    /// Samples the profile and checks every promised property.
    fn check(p: &DoubleS, v: f64, a: f64, j: f64) {
        let total = p.duration();
        assert!(total.is_finite() && total > 0.0, "{p:?}");
        assert_eq!(p.eval(0.0), (0.0, 0.0, 0.0));
        let (s_end, sd_end, sdd_end) = p.eval(total);
        assert_eq!((s_end, sd_end, sdd_end), (1.0, 0.0, 0.0));
        // Just inside both ends the profile must already be close to its end values.
        let (s, sd, sdd) = p.eval(total * (1.0 - 1e-12));
        assert!((s - 1.0).abs() < 1e-9 && sd.abs() < 1e-6 && sdd.abs() < 1e-3);

        let n = 4000;
        let dt = total / n as f64;
        let mut prev = p.eval(0.0);
        for i in 1..=n {
            let t = i as f64 * dt;
            let (s, sd, sdd) = p.eval(t);
            assert!(
                s >= prev.0 - EPS,
                "not monotone at t={t}: {} -> {s}",
                prev.0
            );
            assert!(sd >= -EPS && sd <= v * (1.0 + EPS), "sd={sd} v={v}");
            assert!(sdd.abs() <= a * (1.0 + EPS), "sdd={sdd} a={a}");
            // Continuity: the derivatives bound the change over one sample.
            assert!((s - prev.0).abs() <= v * dt * (1.0 + 1e-6) + EPS);
            assert!((sd - prev.1).abs() <= a * dt * (1.0 + 1e-6) + EPS);
            let jerk = (sdd - prev.2).abs() / dt;
            assert!(jerk <= j * (1.0 + 1e-6) + EPS, "jerk {jerk} > {j}");
            prev = (s, sd, sdd);
        }
    }

    #[test]
    fn velocity_limit_reached_has_a_cruise_phase() {
        let p = DoubleS::new(0.5, 2.0, 20.0);
        assert!(p.t_cruise > 0.0);
        assert!((p.peak_velocity() - 0.5).abs() < 1e-12);
        assert!((p.peak_acceleration() - 2.0).abs() < 1e-12);
        // Distance = v·(t_accel + t_cruise) for the symmetric profile.
        assert!((p.duration() - (1.0 / 0.5 + 0.5 / 2.0 + 2.0 / 20.0)).abs() < 1e-12);
        check(&p, 0.5, 2.0, 20.0);
    }

    #[test]
    fn acceleration_limit_reached_without_cruise() {
        let p = DoubleS::new(10.0, 2.0, 20.0);
        assert_eq!(p.t_cruise, 0.0);
        assert!((p.peak_acceleration() - 2.0).abs() < 1e-12);
        assert!(p.peak_velocity() < 10.0);
        check(&p, 10.0, 2.0, 20.0);
    }

    #[test]
    fn neither_velocity_nor_acceleration_limit_reached() {
        let p = DoubleS::new(10.0, 10.0, 2.0);
        assert_eq!(p.t_cruise, 0.0);
        assert_eq!(p.t_accel, 2.0 * p.t_jerk);
        assert!((p.duration() - 4.0 * 0.25f64.cbrt()).abs() < 1e-12);
        check(&p, 10.0, 10.0, 2.0);
    }

    #[test]
    fn velocity_limit_below_acceleration_ramp() {
        // v·j < a²: the acceleration limit cannot be reached before the velocity limit.
        let p = DoubleS::new(0.2, 5.0, 10.0);
        assert!(p.t_cruise > 0.0);
        assert!(p.peak_acceleration() < 5.0);
        check(&p, 0.2, 5.0, 10.0);
    }

    #[test]
    fn outside_the_profile_time_the_parameter_rests() {
        let p = DoubleS::new(1.0, 1.0, 1.0);
        assert_eq!(p.eval(-1.0), (0.0, 0.0, 0.0));
        assert_eq!(p.eval(f64::NAN), (0.0, 0.0, 0.0));
        assert_eq!(p.eval(p.duration() + 5.0), (1.0, 0.0, 0.0));
    }

    #[test]
    fn stretched_profile_takes_the_requested_time_with_lower_limits() {
        let p = DoubleS::new(1.0, 4.0, 40.0);
        let t = 3.0 * p.duration();
        let q = p.stretched(t);
        assert!((q.duration() - t).abs() < 1e-12);
        assert!((q.peak_velocity() - p.peak_velocity() / 3.0).abs() < 1e-12);
        assert!((q.peak_acceleration() - p.peak_acceleration() / 9.0).abs() < 1e-12);
        assert!((q.peak_jerk() - p.peak_jerk() / 27.0).abs() < 1e-12);
        check(&q, 1.0 / 3.0, 4.0 / 9.0, 40.0 / 27.0);
        assert_eq!(p.stretched(0.5 * p.duration()), p);
    }

    proptest! {
        #[test]
        fn every_profile_keeps_its_limits(
            v in 1e-2f64..1e2,
            a in 1e-2f64..1e3,
            j in 1e-1f64..1e4,
        ) {
            let p = DoubleS::new(v, a, j);
            check(&p, v, a, j);
        }

        #[test]
        fn every_stretched_profile_keeps_its_scaled_limits(
            v in 1e-1f64..1e1,
            a in 1e-1f64..1e2,
            j in 1.0f64..1e3,
            k in 1.0f64..10.0,
        ) {
            let p = DoubleS::new(v, a, j).stretched(k * DoubleS::new(v, a, j).duration());
            check(&p, v / k, a / (k * k), j / (k * k * k));
        }
    }
}
