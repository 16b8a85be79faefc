//! The jerk-limited rest-to-rest "double-S" profile of a normalized path parameter.
//!
//! The path parameter `s` goes from 0 to 1 with `|ṡ| ≤ v`, `s̈ ≤ a` while speeding up,
//! `−s̈ ≤ d` while slowing down and `|s⃛| ≤ j`, starting and ending at rest with zero
//! acceleration, in the shortest time those limits allow. It is the rest-to-rest double-S
//! trajectory of Biagiotti & Melchiorri, "Trajectory Planning for Automatic Machines and
//! Robots" (2008), §3.4, with separate acceleration and deceleration limits and the cases where
//! the velocity limit, or also the acceleration limits, are not reached.
//!
//! Each ramp (rest to the peak speed `V`, and back) is the shortest one for its limit: with
//! `V·j ≥ a²` it reaches `a` (jerk `a/j`, hold, jerk `a/j`: `T = a/j + V/a`), otherwise it is
//! two jerk phases of `√(V/j)` each. The speed of a ramp is point-symmetric about its middle,
//! so it covers `V·T/2`. The peak speed is `v` if both ramps fit into the path, else the `V`
//! with `V·(T_a(V) + T_d(V))/2 = 1`: closed form when both or neither ramp reach their limit,
//! bisection in the mixed case (only with `a ≠ d`).

use crate::topp::TableProfile;

/// Bisection steps for the peak speed of the mixed case: the bracket shrinks below one ulp.
const BISECTION_STEPS: usize = 80;

/// One jerk-limited ramp of the path speed from rest to the peak speed (or, mirrored in time,
/// from the peak speed to rest).
#[derive(Debug, Clone, Copy, PartialEq)]
struct Ramp {
    /// Duration of each constant-jerk part.
    t_jerk: f64,
    /// Duration of the whole ramp.
    duration: f64,
    /// Acceleration reached (`jerk·t_jerk`).
    peak: f64,
}

impl Ramp {
    /// The shortest ramp from rest to `v` with the acceleration limit `a` and the jerk `j`.
    fn new(v: f64, a: f64, j: f64) -> Self {
        let (t_jerk, duration) = Self::phases(v, a, j);
        Self {
            t_jerk,
            duration,
            peak: j * t_jerk,
        }
    }

    /// `(t_jerk, duration)` of the ramp to `v`.
    fn phases(v: f64, a: f64, j: f64) -> (f64, f64) {
        if v * j >= a * a {
            (a / j, a / j + v / a)
        } else {
            let t_jerk = (v / j).sqrt();
            (t_jerk, 2.0 * t_jerk)
        }
    }

    /// Path length the ramp to `v` covers.
    fn distance(v: f64, a: f64, j: f64) -> f64 {
        0.5 * v * Self::phases(v, a, j).1
    }

    /// `(s, ṡ, s̈)` at `0 ≤ t ≤ duration` of the ramp from rest to `v` with jerk `j`.
    fn eval(&self, t: f64, v: f64, j: f64) -> (f64, f64, f64) {
        let (tj, ta) = (self.t_jerk, self.duration);
        if t < tj {
            (j * t * t * t / 6.0, 0.5 * j * t * t, j * t)
        } else if t < ta - tj {
            let a = self.peak;
            (
                a / 6.0 * (3.0 * t * t - 3.0 * tj * t + tj * tj),
                a * (t - 0.5 * tj),
                a,
            )
        } else {
            let r = ta - t;
            (
                0.5 * v * ta - v * r + j * r * r * r / 6.0,
                v - 0.5 * j * r * r,
                j * r,
            )
        }
    }

    fn scaled(&self, k: f64) -> Self {
        Self {
            t_jerk: self.t_jerk * k,
            duration: self.duration * k,
            peak: self.peak / (k * k),
        }
    }
}

/// A rest-to-rest double-S profile of `s` from 0 to 1: the acceleration ramp, a cruise at
/// the peak speed, and the deceleration ramp (mirrored in time).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DoubleS {
    accel: Ramp,
    decel: Ramp,
    /// Duration of the cruise phase.
    t_cruise: f64,
    jerk: f64,
    /// Speed reached.
    v_peak: f64,
}

impl DoubleS {
    /// The time-optimal profile for the path limits: speed `v`, acceleration `a`, deceleration
    /// `d`, jerk `j` (all positive and finite). With `d = a` the profile is symmetric.
    pub fn new(v: f64, a: f64, d: f64, j: f64) -> Self {
        let both = |v: f64| Ramp::distance(v, a, j) + Ramp::distance(v, d, j);
        let reached = both(v);
        if reached <= 1.0 {
            return Self::with_peak(v, a, d, j, (1.0 - reached) / v);
        }
        let (low, high) = (a.min(d), a.max(d));
        let v_peak = if both(low * low / j) >= 1.0 {
            // Neither ramp reaches its limit: two pure jerk ramps, s = 2·j·t_jerk³ = 1.
            let t_jerk = (0.5 / j).cbrt();
            j * t_jerk * t_jerk
        } else if both(high * high / j) <= 1.0 {
            // Both reach their limits: V²·(1/a + 1/d)/2 + V·(a + d)/(2j) − 1 = 0.
            let qa = 0.5 * (1.0 / a + 1.0 / d);
            let qb = 0.5 * (a + d) / j;
            2.0 / (qb + (qb * qb + 4.0 * qa).sqrt())
        } else {
            // Only the ramp with the lower limit reaches it; the distance grows with V.
            let (mut lo, mut hi) = (low * low / j, high * high / j);
            for _ in 0..BISECTION_STEPS {
                let mid = 0.5 * (lo + hi);
                if both(mid) > 1.0 {
                    hi = mid;
                } else {
                    lo = mid;
                }
            }
            lo
        };
        Self::with_peak(v_peak, a, d, j, 0.0)
    }

    fn with_peak(v_peak: f64, a: f64, d: f64, j: f64, t_cruise: f64) -> Self {
        Self {
            accel: Ramp::new(v_peak, a, j),
            decel: Ramp::new(v_peak, d, j),
            t_cruise,
            jerk: j,
            v_peak,
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
        Self {
            accel: self.accel.scaled(k),
            decel: self.decel.scaled(k),
            t_cruise: self.t_cruise * k,
            jerk: self.jerk / (k * k * k),
            v_peak: self.v_peak / k,
        }
    }

    /// Total time from rest at `s = 0` to rest at `s = 1`, in s.
    pub fn duration(&self) -> f64 {
        self.accel.duration + self.t_cruise + self.decel.duration
    }

    /// Largest `ṡ` of the profile.
    pub fn peak_velocity(&self) -> f64 {
        self.v_peak
    }

    /// Largest `s̈` of the profile (while speeding up).
    pub fn peak_acceleration(&self) -> f64 {
        self.accel.peak
    }

    /// Largest `−s̈` of the profile (while slowing down).
    pub fn peak_deceleration(&self) -> f64 {
        self.decel.peak
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
        let (v, j) = (self.v_peak, self.jerk);
        let cruise_end = self.accel.duration + self.t_cruise;
        if t < self.accel.duration {
            self.accel.eval(t, v, j)
        } else if t <= cruise_end {
            let t = t - self.accel.duration;
            (0.5 * v * self.accel.duration + v * t, v, 0.0)
        } else {
            // The deceleration is its ramp mirrored in time and space.
            let (s, sd, sdd) = self.decel.eval(total - t, v, j);
            (1.0 - s, sd, -sdd)
        }
    }
}

/// The time scaling of a move's path: a double-S on constant bounds, or the table of a
/// time-optimal path parameterisation ([`TableProfile`]).
#[derive(Debug, Clone, Copy, PartialEq)]
#[allow(
    clippy::large_enum_variant,
    reason = "profiles are copied ahead in the tick path, where boxing would allocate"
)]
pub enum Profile {
    DoubleS(DoubleS),
    Table(TableProfile),
}

impl Profile {
    /// Total time from rest at `s = 0` to rest at `s = 1`, in s.
    pub fn duration(&self) -> f64 {
        match self {
            Self::DoubleS(p) => p.duration(),
            Self::Table(p) => p.duration(),
        }
    }

    /// `(s, ṡ, s̈)` at time `t`; before 0 at rest at 0, after the end at rest at 1.
    pub fn eval(&self, t: f64) -> (f64, f64, f64) {
        match self {
            Self::DoubleS(p) => p.eval(t),
            Self::Table(p) => p.eval(t),
        }
    }

    /// Largest `ṡ` of the profile.
    pub fn peak_velocity(&self) -> f64 {
        match self {
            Self::DoubleS(p) => p.peak_velocity(),
            Self::Table(p) => p.peak_velocity(),
        }
    }

    /// The same path in `duration` by uniform time scaling; not shorter than it is.
    pub fn stretched(&self, duration: f64) -> Self {
        match self {
            Self::DoubleS(p) => Self::DoubleS(p.stretched(duration)),
            Self::Table(p) => Self::Table(p.stretched(duration)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    const EPS: f64 = 1e-9;

    /// Samples the profile and checks every promised property for the limits `v`, `a`, `d`,
    /// `j`.
    fn check(p: &DoubleS, v: f64, a: f64, d: f64, j: f64) {
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
            assert!(sdd <= a * (1.0 + EPS), "sdd={sdd} a={a}");
            assert!(-sdd <= d * (1.0 + EPS), "sdd={sdd} d={d}");
            // Continuity: the derivatives bound the change over one sample.
            assert!((s - prev.0).abs() <= v * dt * (1.0 + 1e-6) + EPS);
            assert!((sd - prev.1).abs() <= a.max(d) * dt * (1.0 + 1e-6) + EPS);
            let jerk = (sdd - prev.2).abs() / dt;
            assert!(jerk <= j * (1.0 + 1e-6) + EPS, "jerk {jerk} > {j}");
            prev = (s, sd, sdd);
        }
    }

    /// The duration of the symmetric profile in the closed form of Biagiotti & Melchiorri.
    fn symmetric_duration(v: f64, a: f64, j: f64) -> f64 {
        let t_accel = if v * j >= a * a {
            a / j + v / a
        } else {
            2.0 * (v / j).sqrt()
        };
        if 1.0 / v >= t_accel {
            return 1.0 / v + t_accel;
        }
        let t_jerk = a / j;
        let t_accel = 0.5 * (t_jerk + (t_jerk * t_jerk + 4.0 / a).sqrt());
        if t_accel >= 2.0 * t_jerk {
            2.0 * t_accel
        } else {
            4.0 * (0.5 / j).cbrt()
        }
    }

    #[test]
    fn velocity_limit_reached_has_a_cruise_phase() {
        let p = DoubleS::new(0.5, 2.0, 2.0, 20.0);
        assert!(p.t_cruise > 0.0);
        assert!((p.peak_velocity() - 0.5).abs() < 1e-12);
        assert!((p.peak_acceleration() - 2.0).abs() < 1e-12);
        // Distance = v·(t_accel + t_cruise) for the symmetric profile.
        assert!((p.duration() - (1.0 / 0.5 + 0.5 / 2.0 + 2.0 / 20.0)).abs() < 1e-12);
        check(&p, 0.5, 2.0, 2.0, 20.0);
    }

    #[test]
    fn acceleration_limit_reached_without_cruise() {
        let p = DoubleS::new(10.0, 2.0, 2.0, 20.0);
        assert_eq!(p.t_cruise, 0.0);
        assert!((p.peak_acceleration() - 2.0).abs() < 1e-12);
        assert!(p.peak_velocity() < 10.0);
        check(&p, 10.0, 2.0, 2.0, 20.0);
    }

    #[test]
    fn neither_velocity_nor_acceleration_limit_reached() {
        let p = DoubleS::new(10.0, 10.0, 10.0, 2.0);
        assert_eq!(p.t_cruise, 0.0);
        assert_eq!(p.accel.duration, 2.0 * p.accel.t_jerk);
        assert!((p.duration() - 4.0 * 0.25f64.cbrt()).abs() < 1e-12);
        check(&p, 10.0, 10.0, 10.0, 2.0);
    }

    #[test]
    fn velocity_limit_below_acceleration_ramp() {
        // v·j < a²: the acceleration limit cannot be reached before the velocity limit.
        let p = DoubleS::new(0.2, 5.0, 5.0, 10.0);
        assert!(p.t_cruise > 0.0);
        assert!(p.peak_acceleration() < 5.0);
        check(&p, 0.2, 5.0, 5.0, 10.0);
    }

    #[test]
    fn a_lower_deceleration_lengthens_only_the_braking_ramp() {
        // Cruise reached: accelerate in a/j + v/a, brake in d/j + v/d.
        let (v, a, d, j) = (0.5, 2.0, 0.5, 20.0);
        let p = DoubleS::new(v, a, d, j);
        assert!((p.accel.duration - (a / j + v / a)).abs() < 1e-12);
        assert!((p.decel.duration - (d / j + v / d)).abs() < 1e-12);
        let ramps = 0.5 * v * (p.accel.duration + p.decel.duration);
        assert!((p.t_cruise - (1.0 - ramps) / v).abs() < 1e-12);
        assert!((p.peak_acceleration() - a).abs() < 1e-12);
        assert!((p.peak_deceleration() - d).abs() < 1e-12);
        check(&p, v, a, d, j);
        // The mirror image takes the same time.
        let q = DoubleS::new(v, d, a, j);
        assert!((q.duration() - p.duration()).abs() < 1e-12);
        check(&q, v, d, a, j);
    }

    #[test]
    fn asymmetric_profiles_without_cruise_cover_every_case() {
        // Both limits reached, only the lower one, neither.
        for (a, d, j) in [(2.0, 1.0, 100.0), (4.0, 0.5, 8.0), (10.0, 8.0, 2.0)] {
            let p = DoubleS::new(100.0, a, d, j);
            assert_eq!(p.t_cruise, 0.0);
            assert!(p.peak_velocity() < 100.0);
            check(&p, 100.0, a, d, j);
        }
    }

    #[test]
    fn outside_the_profile_time_the_parameter_rests() {
        let p = DoubleS::new(1.0, 1.0, 1.0, 1.0);
        assert_eq!(p.eval(-1.0), (0.0, 0.0, 0.0));
        assert_eq!(p.eval(f64::NAN), (0.0, 0.0, 0.0));
        assert_eq!(p.eval(p.duration() + 5.0), (1.0, 0.0, 0.0));
    }

    #[test]
    fn stretched_profile_takes_the_requested_time_with_lower_limits() {
        let p = DoubleS::new(1.0, 4.0, 2.0, 40.0);
        let t = 3.0 * p.duration();
        let q = p.stretched(t);
        assert!((q.duration() - t).abs() < 1e-12);
        assert!((q.peak_velocity() - p.peak_velocity() / 3.0).abs() < 1e-12);
        assert!((q.peak_acceleration() - p.peak_acceleration() / 9.0).abs() < 1e-12);
        assert!((q.peak_deceleration() - p.peak_deceleration() / 9.0).abs() < 1e-12);
        assert!((q.peak_jerk() - p.peak_jerk() / 27.0).abs() < 1e-12);
        check(&q, 1.0 / 3.0, 4.0 / 9.0, 2.0 / 9.0, 40.0 / 27.0);
        assert_eq!(p.stretched(0.5 * p.duration()), p);
    }

    proptest! {
        #[test]
        fn every_profile_keeps_its_limits(
            v in 1e-2f64..1e2,
            a in 1e-2f64..1e3,
            d_frac in 0.05f64..1.0,
            j in 1e-1f64..1e4,
            decelerate_slower in any::<bool>(),
        ) {
            let d = a * d_frac;
            let (a, d) = if decelerate_slower { (a, d) } else { (d, a) };
            let p = DoubleS::new(v, a, d, j);
            check(&p, v, a, d, j);
        }

        #[test]
        fn equal_limits_give_the_symmetric_closed_form(
            v in 1e-2f64..1e2,
            a in 1e-2f64..1e3,
            j in 1e-1f64..1e4,
        ) {
            let p = DoubleS::new(v, a, a, j);
            let expected = symmetric_duration(v, a, j);
            prop_assert!((p.duration() - expected).abs() <= 1e-12 * expected, "{p:?}");
            prop_assert_eq!(p.accel, p.decel);
            let half = 0.5 * p.duration();
            let (s, _, sdd) = p.eval(half);
            prop_assert!((s - 0.5).abs() < 1e-12 && sdd.abs() < 1e-9 * a);
        }

        #[test]
        fn every_stretched_profile_keeps_its_scaled_limits(
            v in 1e-1f64..1e1,
            a in 1e-1f64..1e2,
            d in 1e-1f64..1e2,
            j in 1.0f64..1e3,
            k in 1.0f64..10.0,
        ) {
            let p = DoubleS::new(v, a, d, j);
            let p = p.stretched(k * p.duration());
            check(&p, v / k, a / (k * k), d / (k * k), j / (k * k * k));
        }
    }
}
