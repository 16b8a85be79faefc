//! A stop on the time scale of a profile: the path is followed exactly as planned while its
//! time scale σ (the profile advances σ seconds per second) is brought to 0, as fast as the
//! joint and TCP limits at the current point allow.
//!
//! A time-optimal table ([`topp`](crate::topp)) runs at the limits the path allows at every
//! point, so constant path bounds cannot stop it: where it is fast they would brake too
//! weakly, and a stop near the end would have to pass it. Scaling the table's time instead
//! never goes faster than the table at any point of the path (σ ≤ 1), so a stop always ends
//! on the path, at the latest where the table itself ends at rest. A stop that begins while
//! an override ramp raises σ lets σ go on rising while its rate comes down, as gradually as
//! the ramp would have, so σ stays below the ramp's target.
//!
//! With the table's rates `q̇ₜ`, `q̈ₜ`, `q⃛ₜ` of a coordinate (a joint, or the TCP along its
//! path) at the current profile time, the commanded rates are
//!
//! - `q̇ = σ·q̇ₜ`,
//! - `q̈ = σ²·q̈ₜ + σ̇·q̇ₜ`,
//! - `q⃛ = σ³·q⃛ₜ + 3·σ·σ̇·q̈ₜ + σ̈·q̇ₜ` (every profile's `q̈ₜ` is the derivative of its
//!   `q̇ₜ`: a table's positions follow its commanded acceleration).
//!
//! Braking (`σ̇ = −d ≤ 0`), `|q̈| ≤ A` holds for `d ≤ (A + sgn(q̇ₜ)·σ²·q̈ₜ)/|q̇ₜ|` and
//! `|q⃛| ≤ J` for `|σ̈| ≤ (J − |σ³·q⃛ₜ + 3·σ·σ̇·q̈ₜ|)/|q̇ₜ|`. Every tick takes the tightest
//! of these bounds over the coordinates (each limit times [`MARGIN`], for what changes within
//! the tick) as the deceleration and jerk limits of a [`PathBrake`] of σ: its jerk is
//! bang-bang, so σ and σ̇ reach 0 together where the limits allow it.
//!
//! The cross term `3·σ·σ̇·q̈ₜ` is the jerk of taking the table's acceleration away: as
//! σ falls, `σ²·q̈ₜ` falls with it. Where the table slows a coordinate down, that jerk has the
//! sign only a growing deceleration can answer (`σ̈·q̇ₜ` against it), and a larger deceleration
//! makes it larger still: unbounded, a stop could run away into σ = 0 at full deceleration,
//! a step of the acceleration. So the deceleration is bounded as well, by
//! `|3·σ·σ̇·q̈ₜ| ≤` [`CROSS_SHARE`]`·J`: the rest of the jerk is for the table's own
//! `σ³·q⃛ₜ` and for σ̈, which can then bring the deceleration back.
//!
//! Where the table's own jerk and the cross term leave room only for taking the deceleration
//! back (the range above does not hold 0), it is taken back, but not past `σ̇ = 0`: σ does
//! not grow, so the arm is not sped up and never leaves the path, but at that point the jerk
//! may exceed its limit by what the table takes beyond it; and a release that a shrinking
//! range cuts short ends with a step of `σ̇·q̇ₜ` in the acceleration. The table uses its
//! whole jerk budget, so a stop still braking the time scale when the table brakes to its
//! end is the case where this bites: such stops run the table out instead
//! ([`RUN_OUT_FACTOR`]). The executor's tests (stops all along several lines, among them the
//! ones that ran away before the cross term was bounded and before the run-out margin)
//! keep every limit; a stop with a guaranteed jerk would need the table planned with a share
//! of the jerk held back, as the acceleration is held back for the override.

use crate::brake::PathBrake;

/// Coordinates the limits are kept in: the joints and the TCP along its path.
pub const COORDINATES: usize = shared_types::ipc::AXES + 1;
/// Share of every limit a stop plans with: the rest pays for the change of the table's
/// rates within a tick.
pub const MARGIN: f64 = 0.9;
/// Share of a coordinate's jerk limit (after [`MARGIN`]) the stop's cross term
/// `3·σ·σ̇·q̈ₜ` may take; it bounds the deceleration (see the module documentation).
pub const CROSS_SHARE: f64 = 0.7;
/// Share of the jerk left at `σ = 0` a release of σ̇ plans with: the rest is for what the
/// table's share still takes while σ falls to 0.
pub const RELEASE_SHARE: f64 = 0.9;
/// Largest `−σ̇` (1/s) of a stop. Where the table's speed goes to 0 (at its end) the joint
/// limits no longer bound it, and a σ̇ grown without bound there would have to be released
/// in an instant at the end of the table. A stop from `σ = 1` at this bound and
/// [`MAX_SCALE_JERK`] would take a tenth of a second: every joint limit binds long before.
pub const MAX_SCALE_DECELERATION: f64 = 10.0;
/// Largest `|σ̈|` (1/s²) of a stop, for the same reason.
pub const MAX_SCALE_JERK: f64 = 200.0;
/// A stop runs the table out at its time scale if the table ends within this many times the
/// time a stop of the time scale would take: the table's end then is its own stop, braking
/// at the limits, while a stop of the time scale, with the table's speeds falling to 0 at
/// its end, would have ever less to brake with. More than 1 because the estimate is
/// optimistic (a stop may have to wait until the table's jerk leaves it room), and a stop
/// still braking the time scale when the table brakes to its end adds the two
/// decelerations: where the table brakes at its jerk limit, the jerk of taking its
/// acceleration away then forces the time scale's deceleration ever higher (at 1, 19 of 1179
/// stops on random lines did, with jerks up to 62 times the limit; none of 1728 at 1.25 or
/// at 1.5).
pub const RUN_OUT_FACTOR: f64 = 1.5;
/// Share of a coordinate's jerk limit that the release of σ̇ at the start of a run-out
/// takes at least, where the table's own jerk leaves less (it then adds to it): no less
/// than the share an override ramp changes σ̇ with, so the release is at least as fast as
/// the ramp (`|q̇ₜ|` is at most the velocity limit the ramp's `|σ̈|` is computed with).
pub const RUN_OUT_RELEASE_SHARE: f64 = 0.5;
const _: () = assert!(
    RUN_OUT_RELEASE_SHARE >= crate::motion::OVERRIDE_JERK_SHARE
        && RUN_OUT_RELEASE_SHARE <= RELEASE_SHARE * MARGIN
);
/// Share of a coordinate's jerk limit that the release at the start of a run-out takes at
/// least while σ̇ falls (a stop during an override ramp towards a lower override), where the
/// table's jerk and the ramp's cross term `3·σ·σ̇·q̈ₜ` leave less than
/// [`RUN_OUT_RELEASE_SHARE`] within 1 + that share of the limit: such a release takes at
/// most twice as long as one at that share.
pub const FALLING_RELEASE_FLOOR: f64 = 0.5 * RUN_OUT_RELEASE_SHARE;
/// Table rates below this count as standing.
const MOVING: f64 = 1e-9;

/// The rates of the coordinates on the unscaled profile (`σ = 1`) at one profile time.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TableRates {
    /// `q̇ₜ` (rad/s, m/s).
    pub velocity: [f64; COORDINATES],
    /// `q̈ₜ` (rad/s², m/s²).
    pub acceleration: [f64; COORDINATES],
    /// `q⃛ₜ = d(q̈ₜ)/dτ` (rad/s³, m/s³).
    pub jerk: [f64; COORDINATES],
    /// The acceleration across the path that takes its share of a coordinate's limit (the
    /// TCP's centripetal `|p''|·ṡₜ²` on an arc, 0 for the joints); it scales with σ².
    pub normal: [f64; COORDINATES],
}

/// The acceleration and jerk limits of the coordinates during a stop (rates applied).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ScaleLimits {
    /// rad/s² for the joints, m/s² for the TCP.
    pub acceleration: [f64; COORDINATES],
    /// rad/s³ for the joints, m/s³ for the TCP.
    pub jerk: [f64; COORDINATES],
}

/// The state of a profile's time scale being braked.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ScaleBrake {
    /// σ as a path brake over the profile time normalised by its duration: `s = τ/T`,
    /// `v = σ/T`, `a = σ̇/T`, so the brake never passes the profile's end.
    brake: PathBrake,
    duration: f64,
    limits: ScaleLimits,
    /// Whether the stop runs the table out at its time scale (decided at the first tick).
    run_out: Option<bool>,
}

impl ScaleBrake {
    /// Starts braking the profile of `duration` s at profile time `tau` with time scale
    /// `sigma` changing at `sigma_rate` (1/s), within `limits`.
    pub fn new(tau: f64, sigma: f64, sigma_rate: f64, duration: f64, limits: ScaleLimits) -> Self {
        let t = duration.max(f64::MIN_POSITIVE);
        Self {
            brake: PathBrake::new(tau / t, sigma.max(0.0) / t, sigma_rate / t, 0.0, 0.0),
            duration: t,
            limits,
            run_out: None,
        }
    }

    /// Starts braking as [`new`](Self::new) does, but never runs the profile out: for a
    /// profile that does not end at rest, such as the constant path speed a stop on the
    /// path brakes from (see [`motion`](crate::motion)'s `Stop::OnPath`).
    pub fn without_run_out(
        tau: f64,
        sigma: f64,
        sigma_rate: f64,
        duration: f64,
        limits: ScaleLimits,
    ) -> Self {
        Self {
            run_out: Some(false),
            ..Self::new(tau, sigma, sigma_rate, duration, limits)
        }
    }

    /// The profile time τ (s).
    pub fn tau(&self) -> f64 {
        self.brake.s * self.duration
    }

    /// The time scale σ.
    pub fn sigma(&self) -> f64 {
        self.brake.v * self.duration
    }

    /// σ̇ (1/s).
    pub fn sigma_rate(&self) -> f64 {
        self.brake.a * self.duration
    }

    /// Whether the time scale stands at 0 (or the profile is at its end).
    pub fn is_stopped(&self) -> bool {
        self.brake.is_stopped()
    }

    /// What a stop from here is expected to take (s) at the table's rates `table` now
    /// (`dt` the tick it will advance in): the rest of the profile at the current scale
    /// where it runs the profile out, else the stop at the deceleration and release jerk the
    /// limits allow now. Optimistic where the table's jerk makes the stop wait; pessimistic
    /// where the table slows down, whose deceleration leaves the time scale more room as σ
    /// falls.
    pub fn expected_duration(&self, table: &TableRates, dt: f64) -> f64 {
        let b = bounds(table, &self.limits, self.sigma(), self.sigma_rate(), dt);
        self.estimate(&b).1
    }

    /// How a stop within the bounds `b` is expected to go: whether it runs the profile out
    /// ([`RUN_OUT_FACTOR`]), and how long it takes (s).
    fn estimate(&self, b: &Bounds) -> (bool, f64) {
        let sigma = self.sigma().max(f64::MIN_POSITIVE);
        let braking_s = sigma / b.deceleration + b.deceleration / b.release_jerk;
        let left_s = (self.duration - self.tau()) / sigma;
        // Without any deceleration now (the table at its own limits) the estimate says
        // nothing: the stop brakes as soon as it can.
        let run_out = b.deceleration > 0.0 && left_s <= RUN_OUT_FACTOR * braking_s;
        (run_out, if run_out { left_s } else { braking_s })
    }

    /// Advances `dt` seconds; `table` gives the table's rates at the current profile time,
    /// asked for only while the stop changes σ̇ (a stop that runs the table out holds it
    /// once it has released it).
    pub fn advance(&mut self, dt: f64, table: impl FnOnce() -> TableRates) {
        if self.run_out == Some(true) && self.brake.a == 0.0 {
            self.brake.advance(dt);
            return;
        }
        let b = bounds(&table(), &self.limits, self.sigma(), self.sigma_rate(), dt);
        let run_out = match self.run_out {
            Some(decided) => decided,
            None => *self.run_out.insert(self.estimate(&b).0),
        };
        let t = self.duration;
        if run_out {
            // The time scale is held from here. A stop during an override ramp first
            // brings σ̇ to 0: within the limits where the table's jerk leaves room; a
            // rising σ̇ at least as fast as the ramp changed it, so a ramp towards a higher
            // override ends below it (σ ≤ 1 holds), a falling one at least at the floor.
            let (least, most) = (b.least_release / t, b.release_jerk / t);
            self.brake.set_limits(
                0.0,
                (b.jerk_low / t).clamp(-most, -least),
                (b.jerk_high / t).clamp(least, most),
                most,
            );
        } else {
            self.brake.set_limits(
                b.deceleration / t,
                b.jerk_low / t,
                b.jerk_high / t,
                b.release_jerk / t,
            );
        }
        self.brake.advance(dt);
    }
}

/// The largest deceleration `d = −σ̇` of the time scale and the range of its jerk `σ̈` that
/// keep every coordinate within `limits` (times [`MARGIN`]) at the table rates `table`, at
/// the start of a tick of `dt` s and (to first order) at its end: where the table's speed
/// is small its acceleration still changes the coefficients within the tick. The range is
/// empty where the table's own jerk leaves none.
fn bounds(
    table: &TableRates,
    limits: &ScaleLimits,
    sigma: f64,
    sigma_rate: f64,
    dt: f64,
) -> Bounds {
    let mut bounds = Bounds {
        deceleration: MAX_SCALE_DECELERATION,
        jerk_low: -MAX_SCALE_JERK,
        jerk_high: MAX_SCALE_JERK,
        release_jerk: MAX_SCALE_JERK,
        least_release: MAX_SCALE_JERK,
    };
    for i in 0..COORDINATES {
        let (v, a) = (table.velocity[i], table.acceleration[i]);
        let used = sigma.powi(3) * table.jerk[i] + 3.0 * sigma * sigma_rate * a;
        // To first order over the tick: σ̈'s coefficient q̇ₜ grows by 2·σ·dt·q̈ₜ (its own
        // change and that of the cross term), and the cross term by 3·σ̇²·dt·q̈ₜ.
        let end = (
            v + 2.0 * dt * sigma * a,
            used + 3.0 * dt * sigma_rate * sigma_rate * a,
        );
        let acceleration_limit = MARGIN * limits.acceleration[i] - sigma * sigma * table.normal[i];
        let j = MARGIN * limits.jerk[i];
        for (coefficient, used) in [(v, used), end] {
            bounds.keep(coefficient, a, used, sigma, acceleration_limit, j);
        }
        let cross = 3.0 * sigma * a.abs();
        if cross > MOVING {
            bounds.deceleration = bounds.deceleration.min(CROSS_SHARE * j / cross);
        }
        if v.abs() > MOVING {
            // As σ → 0 the table's share `used` vanishes: what is left for σ̈ then.
            bounds.release_jerk = bounds.release_jerk.min(RELEASE_SHARE * j / v.abs());
            // Releasing a falling σ̇ more slowly only lowers σ further: there the release
            // keeps the table's jerk and its own within 1 + RUN_OUT_RELEASE_SHARE of the
            // limit, down to the floor's share.
            let share = if sigma_rate < 0.0 {
                let used = used.abs().max(end.1.abs()) / limits.jerk[i];
                (1.0 + RUN_OUT_RELEASE_SHARE - used)
                    .clamp(FALLING_RELEASE_FLOOR, RUN_OUT_RELEASE_SHARE)
            } else {
                RUN_OUT_RELEASE_SHARE
            };
            bounds.least_release = bounds.least_release.min(share * limits.jerk[i] / v.abs());
        }
    }
    // Where the table's own jerk leaves room only for taking the deceleration back, it is
    // taken back, but never so far that σ would grow again: the arm is never sped up.
    if sigma_rate >= 0.0 {
        bounds.jerk_low = bounds.jerk_low.min(0.0);
        bounds.jerk_high = bounds.jerk_high.max(0.0);
    }
    bounds
}

/// The limits of the time scale in one tick.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Bounds {
    /// Largest `−σ̇` (1/s).
    deceleration: f64,
    /// Range of `σ̈` (1/s²).
    jerk_low: f64,
    jerk_high: f64,
    /// The jerk a release of σ̇ can count on until σ = 0.
    release_jerk: f64,
    /// The `|σ̈|` with which a run-out releases σ̇ at least.
    least_release: f64,
}

impl Bounds {
    /// Narrows the bounds to keep a coordinate within the acceleration limit `a_limit` and
    /// the jerk limit `j` where σ̇ and σ̈ act on it with `coefficient` (`q̇ₜ`), the table's
    /// acceleration is `acceleration` and the jerk without σ̈ is `used`:
    /// `|σ²·q̈ₜ − d·q̇ₜ| ≤ a_limit` and `|used + σ̈·q̇ₜ| ≤ j`.
    fn keep(
        &mut self,
        coefficient: f64,
        acceleration: f64,
        used: f64,
        sigma: f64,
        a_limit: f64,
        j: f64,
    ) {
        let v = coefficient;
        if v.abs() <= MOVING {
            return;
        }
        let left = a_limit + v.signum() * sigma * sigma * acceleration;
        self.deceleration = self.deceleration.min(left.max(0.0) / v.abs());
        let (x, y) = ((-j - used) / v, (j - used) / v);
        self.jerk_low = self.jerk_low.max(x.min(y));
        self.jerk_high = self.jerk_high.min(x.max(y));
    }
}

#[cfg(test)]
impl ScaleLimits {
    /// The same acceleration and jerk limit for every coordinate.
    pub(crate) fn uniform(acceleration: f64, jerk: f64) -> Self {
        Self {
            acceleration: [acceleration; COORDINATES],
            jerk: [jerk; COORDINATES],
        }
    }
}

#[cfg(test)]
impl TableRates {
    /// A table cruising with `velocity` in every coordinate.
    pub(crate) fn cruise(velocity: f64) -> Self {
        Self {
            velocity: [velocity; COORDINATES],
            acceleration: [0.0; COORDINATES],
            jerk: [0.0; COORDINATES],
            normal: [0.0; COORDINATES],
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const DT: f64 = 1e-3;

    fn limits(a: f64, j: f64) -> ScaleLimits {
        ScaleLimits::uniform(a, j)
    }

    fn cruise(velocity: f64) -> TableRates {
        TableRates::cruise(velocity)
    }

    /// Brakes a cruising table and checks the commanded rates every tick; returns the
    /// stop's time.
    fn stop_from_cruise(v: f64, a: f64, j: f64) -> f64 {
        let table = cruise(v);
        let mut b = ScaleBrake::new(0.0, 1.0, 0.0, 100.0, limits(a, j));
        let mut last_acceleration = 0.0;
        for tick in 1..100_000 {
            b.advance(DT, || table);
            let acceleration = b.sigma_rate() * v;
            assert!(acceleration.abs() <= a * (1.0 + 1e-9), "{acceleration}");
            let jerk = (acceleration - last_acceleration).abs() / DT;
            assert!(jerk <= j * (1.0 + 1e-6), "{jerk}");
            last_acceleration = acceleration;
            assert!(b.sigma() >= 0.0);
            if b.is_stopped() {
                return tick as f64 * DT;
            }
        }
        panic!("never stopped");
    }

    #[test]
    fn from_cruise_it_stops_as_a_jerk_limited_brake_at_the_margin() {
        let (v, a, j) = (3.0, 12.0, 60.0);
        let t = stop_from_cruise(v, a, j);
        // The joint brakes from v at MARGIN·a, building it up at MARGIN·j and releasing it
        // at RELEASE_SHARE·MARGIN·j: v/a' plus half of both ramps.
        let expected = v / (MARGIN * a) + 0.5 * (a / j + a / (RELEASE_SHARE * j));
        assert!((t - expected).abs() < 3.0 * DT, "{t} vs {expected}");
    }

    /// From cruise the expected stop is close to the stop itself (its ramps counted at the
    /// release's jerk); near the table's end it is the rest of the table, which is what a
    /// stop there takes (the next test).
    #[test]
    fn the_expected_stop_is_the_stop_from_cruise_or_the_rest_of_the_table() {
        let (v, a, j) = (3.0, 12.0, 60.0);
        let far = ScaleBrake::new(0.0, 1.0, 0.0, 100.0, limits(a, j));
        let expected = far.expected_duration(&cruise(v), DT);
        let took = stop_from_cruise(v, a, j);
        assert!(
            (expected - took).abs() < 0.05 * took,
            "{expected} vs {took}"
        );
        let near = ScaleBrake::new(0.95, 1.0, 0.0, 1.0, limits(0.1, 1.0));
        let expected = near.expected_duration(&cruise(1.0), DT);
        assert!((expected - 0.05).abs() < 1e-12, "{expected}");
    }

    #[test]
    fn the_time_scale_never_exceeds_the_table_and_stops_at_its_end() {
        // A table too short for the stop: the profile's end stops it.
        let mut b = ScaleBrake::new(0.95, 1.0, 0.0, 1.0, limits(0.1, 1.0));
        let table = cruise(1.0);
        for _ in 0..10_000 {
            b.advance(DT, || table);
            assert!(b.sigma() <= 1.0 && b.tau() <= 1.0);
        }
        assert!(b.is_stopped());
        assert_eq!(b.tau(), 1.0);
    }

    #[test]
    fn a_run_out_during_an_override_ramp_releases_the_rate_gradually() {
        let (j, table) = (5.0, cruise(1.0));
        for rate in [-0.5, 0.5] {
            // Near the table's end: the stop runs it out.
            let mut b = ScaleBrake::new(0.9, 0.6, rate, 1.0, limits(2.0, j));
            let mut highest = b.sigma();
            for tick in 0.. {
                if b.sigma_rate() == 0.0 {
                    break;
                }
                assert!(tick < 10_000, "never released: {b:?}");
                let before = b.sigma_rate();
                b.advance(DT, || table);
                let change = (b.sigma_rate() - before).abs() / DT;
                assert!(
                    change <= RELEASE_SHARE * MARGIN * j * (1.0 + 1e-9),
                    "{change}"
                );
                highest = highest.max(b.sigma());
                assert!(b.tau() < 1.0, "not released before the end");
            }
            assert_eq!(b.run_out, Some(true));
            let held = b.sigma();
            for _ in 0..10 {
                b.advance(DT, || table);
                assert_eq!(b.sigma(), held);
            }
            // Ramping up, σ goes on at most as far as a release at the least jerk takes it.
            let farthest = 0.6 + rate.max(0.0).powi(2) / (2.0 * RUN_OUT_RELEASE_SHARE * j);
            assert!(highest <= farthest + 1e-9, "{highest} > {farthest}");
        }
    }

    /// A stop during a ramp towards a lower override, where the table brakes at its full
    /// jerk: the release of the falling σ̇ keeps the table's jerk, the ramp's cross term
    /// `3·σ·σ̇·q̈ₜ` and its own within 1 + [`RUN_OUT_RELEASE_SHARE`] of the limit (at
    /// that share of its own it took 1.63 times the limit), and still ends with σ above 0.
    #[test]
    fn a_run_out_of_a_falling_rate_keeps_the_jerk_the_table_and_the_ramp_leave() {
        let j = 5.0;
        let table = TableRates {
            velocity: [1.0; COORDINATES],
            acceleration: [-1.5; COORDINATES],
            jerk: [j; COORDINATES],
            normal: [0.0; COORDINATES],
        };
        let (sigma, rate) = (0.9, -0.5);
        let mut b = ScaleBrake::new(0.5, sigma, rate, 1.0, limits(2.0, j));
        let used = sigma.powi(3) * j + 3.0 * sigma * rate * -1.5;
        assert!(
            used > j,
            "{used}: the case needs the table and the ramp beyond the limit"
        );
        b.advance(DT, || table);
        assert_eq!(b.run_out, Some(true));
        let release = (b.sigma_rate() - rate) / DT;
        assert!(release > 0.0);
        let jerk = used + release * table.velocity[0];
        assert!(
            jerk <= (1.0 + RUN_OUT_RELEASE_SHARE) * j * (1.0 + 1e-9),
            "{} times the limit",
            jerk / j
        );
        for tick in 0..10_000 {
            if b.sigma_rate() == 0.0 {
                break;
            }
            assert!(tick < 9_999, "never released: {b:?}");
            b.advance(DT, || table);
        }
        assert!(
            b.sigma() > 0.0 && b.tau() < 1.0,
            "not released before the end"
        );
    }

    proptest::proptest! {
        /// Run-outs from any state of an override ramp, on uneven numbers: the release of
        /// σ̇ ends exactly at 0 within a bounded time, and from then on the profile's time
        /// advances σ seconds per second until the table's end stops it. (With a rounding
        /// leftover of the release, σ̇ never reached 0 exactly: the time stood still on some
        /// ticks and some stops never ended.)
        #[test]
        fn a_run_out_releases_its_rate_exactly_and_then_runs_the_table_out(
            tau in 0.5f64..0.99,
            sigma in 0.05f64..1.0,
            rate in -0.8f64..0.8,
            duration in 0.3f64..3.0,
            velocity in 0.1f64..3.0,
            a in 1.0f64..20.0,
            j in 5.0f64..100.0,
        ) {
            let table = cruise(velocity);
            let mut b = ScaleBrake::new(tau * duration, sigma, rate, duration, limits(a, j));
            let mut ticks = 0;
            while b.sigma_rate() != 0.0 && !b.is_stopped() {
                b.advance(DT, || table);
                ticks += 1;
                proptest::prop_assert!(ticks < 10_000, "never released: {b:?}");
            }
            if b.run_out == Some(true) {
                while !b.is_stopped() {
                    let (before, held) = (b.tau(), b.sigma());
                    b.advance(DT, || table);
                    let advanced = b.tau() - before;
                    proptest::prop_assert!(
                        b.is_stopped() || (advanced - held * DT).abs() <= 1e-9 * DT.max(held * DT),
                        "{advanced} instead of {} at {b:?}", held * DT
                    );
                    ticks += 1;
                    proptest::prop_assert!(ticks < 1_000_000, "never stopped: {b:?}");
                }
            }
        }
    }

    #[test]
    fn while_the_table_uses_the_full_jerk_the_time_scale_may_only_ease_it() {
        let table = TableRates {
            jerk: [MARGIN * 5.0; COORDINATES],
            ..cruise(1.0)
        };
        let b = bounds(&table, &limits(2.0, 5.0), 1.0, 0.0, DT);
        // The table's jerk is MARGIN·J: σ̈ may only take it back.
        assert_eq!(b.jerk_high, 0.0);
        assert!((b.jerk_low + 2.0 * MARGIN * 5.0).abs() < 1e-12);
        assert!((b.deceleration - MARGIN * 2.0).abs() < 1e-12);
    }

    #[test]
    fn the_centripetal_acceleration_on_an_arc_leaves_the_tcp_less_to_brake_with() {
        let mut table = cruise(1.0);
        table.normal[COORDINATES - 1] = 0.5;
        let mut l = limits(2.0, 5.0);
        // Only the TCP's limit binds.
        l.acceleration[..COORDINATES - 1].fill(100.0);
        let at = |sigma: f64| bounds(&table, &l, sigma, 0.0, DT).deceleration;
        assert!((at(1.0) - (MARGIN * 2.0 - 0.5)).abs() < 1e-12);
        // The centripetal part falls with σ².
        assert!((at(0.5) - (MARGIN * 2.0 - 0.125)).abs() < 1e-12);
    }

    #[test]
    fn a_table_taking_its_acceleration_back_at_full_jerk_is_never_sped_up() {
        // The table's jerk leaves only σ̈ > 0: taken, it would make σ grow beyond 1.
        let table = TableRates {
            jerk: [-2.0 * MARGIN * 5.0; COORDINATES],
            ..cruise(1.0)
        };
        let mut b = ScaleBrake::new(0.0, 1.0, 0.0, 100.0, limits(2.0, 5.0));
        for _ in 0..100 {
            b.advance(DT, || table);
            assert!(b.sigma() <= 1.0 && b.sigma_rate() <= 0.0, "{b:?}");
        }
    }

    #[test]
    fn the_jerk_of_taking_the_tables_acceleration_away_bounds_the_deceleration() {
        let mut table = cruise(1.0);
        table.acceleration = [2.0; COORDINATES];
        // The acceleration limit leaves 90 + 2 per unit of q̇ₜ: the cross term binds.
        let l = limits(100.0, 5.0);
        let at = |sigma: f64| bounds(&table, &l, sigma, 0.0, DT).deceleration;
        let expected = CROSS_SHARE * MARGIN * 5.0 / (3.0 * 2.0);
        assert!((at(1.0) - expected).abs() < 1e-12, "{}", at(1.0));
        // σ·σ̇ is what is bounded: at half the time scale, twice the deceleration.
        assert!((at(0.5) - 2.0 * expected).abs() < 1e-12, "{}", at(0.5));
    }

    #[test]
    fn a_table_already_slowing_a_joint_leaves_less_deceleration() {
        let mut table = cruise(1.0);
        table.acceleration[0] = -1.0;
        let b = bounds(&table, &limits(2.0, 5.0), 1.0, 0.0, DT);
        // q̈ = q̈ₜ − d·q̇ₜ ≥ −A: d ≤ A·MARGIN − 1.
        assert!((b.deceleration - (2.0 * MARGIN - 1.0)).abs() < 1e-12);
    }
}
