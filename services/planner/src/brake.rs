//! A jerk-limited stop on the path: the path parameter `s` is brought from any state
//! `(s, ṡ ≥ 0, s̈)` to rest as fast as the path limits allow, without reversing.
//!
//! The jerk is bang-bang: while the speed left exceeds what releasing the deceleration takes
//! (`ṡ > s̈²/(2j)` for `s̈ < 0`), the deceleration grows toward `−a` at rate `j`; once it equals
//! it, the deceleration is released toward 0 at rate `j`, which ends at `ṡ = 0` and `s̈ = 0`
//! together. Phase switches inside a tick are computed exactly, so the sampled acceleration
//! changes by at most `j·dt` per tick.

/// Path speed below which the path counts as standing still (1/s).
const REST: f64 = 1e-12;
/// Relative slack of the switching test against rounding.
const SWITCH_TOLERANCE: f64 = 1e-9;
/// Phase switches handled within one tick; more than three only arise from rounding.
const MAX_PHASES: usize = 8;

/// The state of a path being braked.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PathBrake {
    /// Path position, never beyond 1.
    pub s: f64,
    /// Path speed `ṡ`.
    pub v: f64,
    /// Path acceleration `s̈`.
    pub a: f64,
    a_max: f64,
    j_max: f64,
}

impl PathBrake {
    /// Starts braking from `(s, v, a)` with the path acceleration and jerk limits `a_max`,
    /// `j_max` (positive).
    pub fn new(s: f64, v: f64, a: f64, a_max: f64, j_max: f64) -> Self {
        Self {
            s,
            v,
            a,
            a_max,
            j_max,
        }
    }

    /// Whether the path stands still (then `v` and `a` are exactly 0).
    pub fn is_stopped(&self) -> bool {
        self.v == 0.0 && self.a == 0.0
    }

    /// Advances the brake by `dt` seconds.
    pub fn advance(&mut self, dt: f64) {
        let mut left = dt;
        for _ in 0..MAX_PHASES {
            if self.v <= REST || self.s >= 1.0 {
                // At the end of the path the move itself would have stopped: never pass it.
                self.s = self.s.min(1.0);
                self.v = 0.0;
                self.a = 0.0;
                return;
            }
            if left <= 0.0 {
                return;
            }
            let (jerk, duration) = self.phase();
            let t = duration.clamp(0.0, left);
            self.integrate(jerk, t);
            left -= t;
        }
    }

    /// The jerk to apply now and how long until the next switch.
    fn phase(&self) -> (f64, f64) {
        let (v, a, j) = (self.v, self.a, self.j_max);
        let release_speed = a * a / (2.0 * j);
        if a < 0.0 && v <= release_speed * (1.0 + SWITCH_TOLERANCE) {
            // Release: s̈ → 0. If the speed is too low already, it hits 0 first.
            let to_zero_acceleration = -a / j;
            let disc = a * a - 2.0 * j * v;
            let to_zero_speed = if disc >= 0.0 {
                (-a - disc.sqrt()) / j
            } else {
                f64::INFINITY
            };
            (j, to_zero_acceleration.min(to_zero_speed))
        } else if a > -self.a_max {
            // Build up deceleration until the limit or the release curve v = s̈²/(2j).
            let to_limit = (a + self.a_max) / j;
            let to_release = (a + (0.5 * a * a + j * v).sqrt()) / j;
            (-j, to_limit.min(to_release))
        } else {
            // Full deceleration until the release curve.
            (0.0, (v - release_speed) / -a)
        }
    }

    fn integrate(&mut self, jerk: f64, t: f64) {
        let (v, a) = (self.v, self.a);
        self.s += v * t + a * t * t / 2.0 + jerk * t * t * t / 6.0;
        self.v = v + a * t + jerk * t * t / 2.0;
        self.a = a + jerk * t;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// Brakes to rest and checks the limits on the samples; returns (ticks, distance).
    fn brake_to_rest(mut b: PathBrake, dt: f64) -> (usize, f64) {
        let (a_max, j_max) = (b.a_max, b.j_max);
        let start = b.s;
        let start_a = b.a;
        let mut prev = b;
        for tick in 1..1_000_000 {
            b.advance(dt);
            assert!(b.v >= 0.0, "reversed: {b:?}");
            assert!(b.s >= prev.s, "went back: {prev:?} -> {b:?}");
            assert!(b.a >= -a_max * (1.0 + 1e-9) && b.a <= start_a.max(0.0) + 1e-12);
            if !b.is_stopped() {
                let jerk = (b.a - prev.a).abs() / dt;
                assert!(jerk <= j_max * (1.0 + 1e-6), "jerk {jerk} > {j_max}");
            }
            if b.is_stopped() {
                return (tick, b.s - start);
            }
            prev = b;
        }
        panic!("never stopped: {b:?}");
    }

    #[test]
    fn from_cruise_the_stop_reaches_full_deceleration_then_releases() {
        let (v, a, j) = (1.0, 2.0, 10.0);
        let (ticks, distance) = brake_to_rest(PathBrake::new(0.0, v, 0.0, a, j), 1e-4);
        // Time-optimal stop from cruise: ramp a/j, hold, ramp a/j: t = v/a + a/j.
        let t = v / a + a / j;
        assert!(((ticks as f64) * 1e-4 - t).abs() < 2e-4, "{ticks}");
        // Distance = v·t/2 for the symmetric stop.
        assert!((distance - v * t / 2.0).abs() < 1e-6, "{distance}");
    }

    #[test]
    fn the_stop_while_accelerating_first_ramps_the_acceleration_down() {
        let (ticks, _) = brake_to_rest(PathBrake::new(0.2, 0.5, 1.5, 2.0, 10.0), 1e-3);
        assert!(ticks > 100);
    }

    #[test]
    fn standing_path_stops_at_once() {
        let mut b = PathBrake::new(0.4, 0.0, 0.0, 1.0, 1.0);
        b.advance(1e-3);
        assert!(b.is_stopped());
        assert_eq!(b.s, 0.4);
    }

    #[test]
    fn the_brake_never_passes_the_end_of_the_path() {
        let mut b = PathBrake::new(0.999, 1.0, 0.0, 1.0, 10.0);
        for _ in 0..10_000 {
            b.advance(1e-3);
        }
        assert!(b.is_stopped());
        assert_eq!(b.s, 1.0);
    }

    proptest! {
        #[test]
        fn every_stop_keeps_the_limits_and_never_reverses(
            v in 0.0f64..5.0,
            a_frac in -1.0f64..1.0,
            a_max in 0.1f64..20.0,
            j_max in 1.0f64..200.0,
            dt in prop::sample::select(vec![2.5e-4, 1e-3, 8e-3]),
        ) {
            brake_to_rest(PathBrake::new(-1e9, v, a_frac * a_max, a_max, j_max), dt);
        }
    }
}
