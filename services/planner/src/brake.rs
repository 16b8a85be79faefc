//! A jerk-limited stop on the path: the path parameter `s` is brought from any state
//! `(s, ṡ ≥ 0, s̈)` to rest as fast as the path limits allow, without reversing.
//!
//! The jerk is bang-bang: while the speed left exceeds what releasing the deceleration takes
//! (`ṡ > s̈²/(2j)` for `s̈ < 0`), the deceleration grows toward `−a` at rate `j`; once it equals
//! it, the deceleration is released toward 0 at rate `j`, which ends at `ṡ = 0` and `s̈ = 0`
//! together. Phase switches inside a tick are computed exactly, so the sampled acceleration
//! changes by at most `j·dt` per tick.
//!
//! The limits may change from tick to tick, and the jerk range need not be symmetric (a
//! stop on the time scale of a profile, [`scale_brake`](crate::scale_brake), has the
//! profile's own jerk on top of its own): the deceleration builds up at the lowest jerk
//! allowed, is released at the highest, a deceleration beyond a limit that shrank is brought
//! back at the highest, and otherwise the jerk nearest 0 is applied. The speed never turns
//! negative, and the deceleration always ends with it: a state already beyond the release
//! curve (`ṡ < s̈²/(2j)`, where an override ramp's deceleration adds to a move's) is released
//! with the jerk `s̈²/(2ṡ)` above the limit, rather than leaving a step of `s̈` at rest.

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
    /// The jerk range, `jerk_low ≤ jerk_high`.
    jerk_low: f64,
    jerk_high: f64,
    /// The jerk the release plans with, within the range.
    release_jerk: f64,
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
            jerk_low: -j_max,
            jerk_high: j_max,
            release_jerk: j_max,
        }
    }

    /// Whether the path stands still (then `v` and `a` are exactly 0).
    pub fn is_stopped(&self) -> bool {
        self.v == 0.0 && self.a == 0.0
    }

    /// Changes the limits for the following ticks: the largest deceleration `a_max`
    /// (non-negative), the range of the jerk (an empty range counts as its middle) and the
    /// jerk the release plans with (less than `jerk_high` where the range narrows as the
    /// speed falls: a release must be able to end).
    pub fn set_limits(&mut self, a_max: f64, jerk_low: f64, jerk_high: f64, release_jerk: f64) {
        self.a_max = a_max.max(0.0);
        let middle = 0.5 * (jerk_low + jerk_high);
        (self.jerk_low, self.jerk_high) = if jerk_low <= jerk_high {
            (jerk_low, jerk_high)
        } else {
            (middle, middle)
        };
        self.release_jerk = release_jerk.clamp(self.jerk_low, self.jerk_high);
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
            // A phase that ends on the deceleration limit lands on it exactly: a rounding
            // leftover would start another phase of almost no length (with a limit of 0,
            // over and over, never reaching it, the tick's time left unspent).
            if (self.a + self.a_max).abs() <= SWITCH_TOLERANCE * (self.a_max + jerk.abs() * t) {
                self.a = -self.a_max;
            }
            left -= t;
        }
    }

    /// The jerk to apply now and how long until the next switch.
    fn phase(&self) -> (f64, f64) {
        let (v, a, a_max) = (self.v, self.a, self.a_max);
        let (low, high, release) = (self.jerk_low, self.jerk_high, self.release_jerk);
        let release_speed = a * a / (2.0 * release);
        let releasing = release > 0.0 && a < 0.0;
        let (jerk, duration) = if releasing && v <= release_speed * (1.0 + SWITCH_TOLERANCE) {
            // Release: s̈ → 0, ending with the speed. Below the curve (the limits shrank
            // since it began, or it started there: an override ramp's deceleration on top of
            // a move's) the jerk that ends both together, even above `high`: any less ends
            // the speed first and leaves a step of the acceleration at rest.
            let jerk = (a * a / (2.0 * v)).max(release);
            (jerk, -a / jerk)
        } else if a > -a_max && low < 0.0 {
            // Build up deceleration until the limit or the release curve
            // v = s̈²/(2·release), which the jerk `low` meets at s̈ = x with
            // x² = (a²/(2·low) − v)/(1/(2·low) − 1/(2·release)).
            let to_limit = (a + a_max) / -low;
            let to_release = if release > 0.0 {
                let x = -((a * a / (2.0 * low) - v) / (0.5 / low - 0.5 / release)).sqrt();
                (x - a) / low
            } else {
                f64::INFINITY
            };
            (low, to_limit.min(to_release))
        } else if a < -a_max * (1.0 + SWITCH_TOLERANCE) && high > 0.0 {
            // Beyond a limit that shrank: back to it. Under the jerk `high`, v − s̈²/(2·high)
            // stays constant, so the release curve (of a jerk not above `high`) is not
            // crossed on the way.
            (high, (-a_max - a) / high)
        } else {
            // Hold with the jerk nearest 0 (full deceleration until the release curve).
            let hold = 0.0f64.clamp(low, high);
            let until_release = if releasing && (0.0..release).contains(&hold) {
                Self::until_release_curve(v, a, hold, release)
            } else {
                f64::INFINITY
            };
            (hold, until_release)
        };
        (jerk, duration.min(self.time_to_rest(jerk)))
    }

    /// Time until `(v, a)`, decelerating (`a < 0`) above the release curve `v = a²/(2r)`,
    /// meets it under the jerk `hold` (`0 ≤ hold < r`, the range may exclude 0): the
    /// smaller root of `(h·k/2)·t² + a·k·t + (v − a²/(2r)) = 0` with `k = 1 − h/r`, in
    /// the form without cancellation; infinite if it does not.
    fn until_release_curve(v: f64, a: f64, hold: f64, release: f64) -> f64 {
        let k = 1.0 - hold / release;
        let gap = (v - a * a / (2.0 * release)).max(0.0);
        let disc = a * a * k * k - 2.0 * hold * k * gap;
        if disc < 0.0 {
            return f64::INFINITY;
        }
        2.0 * gap / (-a * k + disc.sqrt())
    }

    /// Time until the speed reaches 0 under `jerk`, infinite if it does not.
    fn time_to_rest(&self, jerk: f64) -> f64 {
        let (v, a) = (self.v, self.a);
        if jerk == 0.0 {
            return if a < 0.0 { v / -a } else { f64::INFINITY };
        }
        let disc = a * a - 2.0 * jerk * v;
        if disc < 0.0 {
            return f64::INFINITY;
        }
        let root = disc.sqrt();
        [(-a - root) / jerk, (-a + root) / jerk]
            .into_iter()
            .filter(|t| *t > 0.0)
            .fold(f64::INFINITY, f64::min)
    }

    fn integrate(&mut self, jerk: f64, t: f64) {
        let (v, a) = (self.v, self.a);
        self.s += v * t + a * t * t / 2.0 + jerk * t * t * t / 6.0;
        self.v = v + a * t + jerk * t * t / 2.0;
        self.a = a + jerk * t;
    }
}

/// The shortest stop (s) of one coordinate from velocity `velocity` and acceleration
/// `acceleration` within the acceleration and jerk limits `a_max` and `j_max`, path or no
/// path: its acceleration goes to the deceleration limit (or as far as the speed leaves room
/// for) and back to 0 as the speed reaches 0. The slowest joint's is a lower bound of any
/// stop of the arm.
pub fn shortest_stop_time(velocity: f64, acceleration: f64, a_max: f64, j_max: f64) -> f64 {
    let (v, a) = if velocity < 0.0 {
        (-velocity, -acceleration)
    } else {
        (velocity, acceleration)
    };
    let hold = (v + a * a / (2.0 * j_max) - a_max * a_max / j_max) / a_max;
    if hold >= 0.0 {
        (a + a_max) / j_max + hold + a_max / j_max
    } else {
        let peak = (j_max * v + 0.5 * a * a).sqrt();
        (a + 2.0 * peak) / j_max
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// The jerk that releases a deceleration `a < 0` to end with the speed `v`: above the
    /// jerk limit where the start lies beyond the release curve.
    fn release_needs(v: f64, a: f64) -> f64 {
        if a < 0.0 { a * a / (2.0 * v) } else { 0.0 }
    }

    /// Brakes to rest and checks the limits on the samples, up to the last one (no step of
    /// the acceleration at rest); returns (ticks, distance).
    fn brake_to_rest(mut b: PathBrake, dt: f64) -> (usize, f64) {
        let a_max = b.a_max;
        // A start beyond the release curve cannot end within the jerk limit.
        let j_max = b.jerk_high.max(release_needs(b.v, b.a));
        let start = b.s;
        let start_a = b.a;
        let mut prev = b;
        for tick in 1..1_000_000 {
            b.advance(dt);
            assert!(b.v >= 0.0, "reversed: {b:?}");
            assert!(b.s >= prev.s, "went back: {prev:?} -> {b:?}");
            assert!(b.a >= -a_max * (1.0 + 1e-9) && b.a <= start_a.max(0.0) + 1e-12);
            let jerk = (b.a - prev.a).abs() / dt;
            // The speed counts as 0 from REST on: what s̈ has left to release then.
            let rest = if b.is_stopped() {
                (2.0 * j_max * REST).sqrt() / dt
            } else {
                0.0
            };
            // A path standing with s̈ > 0 (as drawn) stays so at once.
            assert!(
                prev.v == 0.0 || jerk <= j_max * (1.0 + 1e-6) + rest,
                "jerk {jerk} > {j_max}: {prev:?} -> {b:?}"
            );
            if b.is_stopped() {
                return (tick, b.s - start);
            }
            prev = b;
        }
        panic!("never stopped: {b:?}");
    }

    /// The brake on constant limits is the time-optimal stop the lower bound describes:
    /// from cruise, speeding up, braking already, and too slow to reach full deceleration.
    #[test]
    fn the_shortest_stop_time_is_the_brakes_on_constant_limits() {
        let (a_max, j_max, dt) = (2.0, 10.0, 1e-4);
        for (v, a) in [
            (0.5, 0.0),
            (0.3, 1.5),
            (0.4, -1.0),
            (0.02, 0.0),
            (0.02, 0.5),
        ] {
            let (ticks, _) = brake_to_rest(PathBrake::new(0.0, v, a, a_max, j_max), dt);
            let bound = shortest_stop_time(v, a, a_max, j_max);
            assert!(
                ((ticks as f64) * dt - bound).abs() < 2.0 * dt,
                "{v} {a}: {ticks} {bound}"
            );
            assert_eq!(bound, shortest_stop_time(-v, -a, a_max, j_max));
        }
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

    #[test]
    fn a_deceleration_beyond_a_shrunk_limit_returns_to_it_at_the_jerk_limit() {
        let mut b = PathBrake::new(-1e9, 10.0, -2.0, 2.0, 10.0);
        b.set_limits(1.0, -10.0, 10.0, 10.0);
        b.advance(0.05);
        assert!((b.a + 1.5).abs() < 1e-12, "{b:?}");
        b.advance(0.1);
        assert!((b.a + 1.0).abs() < 1e-12, "{b:?}");
    }

    #[test]
    fn a_release_below_its_curve_ends_with_the_speed_where_the_range_allows() {
        // v = 0.04 < a²/(2·release) = 0.05: the release needs jerk a²/(2v) = 12.5 ≤ 20.
        let mut b = PathBrake::new(0.0, 0.04, -1.0, 1.0, 10.0);
        b.set_limits(1.0, -10.0, 20.0, 10.0);
        b.advance(1.0);
        assert!(b.is_stopped());
        // s̈ falls linearly to 0 over t = 2v/|a| = 0.08 s, the speed with it: v·t/3.
        assert!((b.s - 0.04 * 0.08 / 3.0).abs() < 1e-12, "{}", b.s);
    }

    #[test]
    fn a_start_beyond_the_release_curve_ends_with_the_speed_without_a_step() {
        // v = 0.04 < a²/(2·j) = 0.05, as an override ramp's deceleration on top of a move's
        // leaves it: the release takes jerk a²/(2v) = 12.5 over the limit 10, where the limit
        // would end the speed at s̈ = -0.45 and leave that as a step.
        let (v, a, dt) = (0.04, -1.0, 1e-3);
        let mut b = PathBrake::new(0.0, v, a, 1.0, 10.0);
        let mut prev = b;
        while !b.is_stopped() {
            b.advance(dt);
            assert!(
                (b.a - prev.a).abs() <= 12.5 * dt * (1.0 + 1e-9),
                "{prev:?} -> {b:?}"
            );
            prev = b;
        }
        assert!((b.s - v * (2.0 * v / -a) / 3.0).abs() < 1e-12, "{}", b.s);
    }

    /// A range of the jerk above 0 (a time-scale stop whose profile's own jerk pushes): the
    /// deceleration eases at the lowest jerk until it meets the release curve, then releases
    /// to end with the speed, never leaving a step of `s̈` at rest. Here the curve
    /// (`v = 3.2e-5`) comes within the tick in which the lowest jerk alone would end the
    /// speed, as a random draw found.
    #[test]
    fn a_hold_above_zero_jerk_switches_to_the_release_on_its_curve() {
        let dt = 1e-3;
        let mut b = PathBrake::new(0.0, 3.3e-5, -0.0331, 0.5, 10.0);
        b.set_limits(0.5, 0.09, 18.4, 17.0);
        let mut prev = b;
        while !b.is_stopped() {
            b.advance(dt);
            assert!(
                (b.a - prev.a) / dt <= 18.4 * (1.0 + 1e-9),
                "{prev:?} -> {b:?}"
            );
            prev = b;
        }
    }

    proptest! {
        /// Limits that change every tick, with a jerk range that need not hold 0: the speed
        /// never turns negative, the path never goes back, and the acceleration changes by
        /// no more than the tick's range allows.
        #[test]
        fn changing_asymmetric_limits_are_kept_every_tick(
            v in 0.0f64..3.0,
            a in -2.0f64..2.0,
            ticks in prop::collection::vec((0.5f64..3.0, -20.0f64..5.0, 5.0f64..20.0, 0.2f64..1.0), 400),
        ) {
            let dt = 1e-3;
            // Far from the path's end, where the move itself would stop.
            let mut b = PathBrake::new(-1e9, v, a, 2.0, 10.0);
            for (a_max, low, high, release) in ticks {
                let before = b;
                b.set_limits(a_max, low, high, release * high);
                b.advance(dt);
                prop_assert!(b.v >= 0.0 && b.s >= before.s);
                if before.v == 0.0 {
                    // Standing (even with s̈ > 0, as drawn): it stays so at once.
                    continue;
                }
                // Beyond the release curve, the release ends with the speed above `high`.
                let high = high.max(release_needs(before.v, before.a));
                let rate = (b.a - before.a) / dt;
                let slack = 1e-9 * (1.0 + low.abs().max(high.abs()));
                prop_assert!(rate <= high + slack, "{rate} above {high}");
                // Coming to rest within the tick ends the jerk there, where the range may
                // exclude 0.
                prop_assert!(b.is_stopped() || rate >= low - slack, "{rate} below {low}");
            }
        }

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
