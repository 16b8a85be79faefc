//! A stop of a time-optimal table on its path that brakes the path parameter itself.
//!
//! Braking a table's time scale ([`scale_brake`](crate::scale_brake)) keeps the table's own
//! acceleration and jerk in every joint while σ falls: where the table speeds up at its
//! limits, as it does early in every line, the stop has to wait until taking that
//! acceleration away leaves it room. A GroupStop 20 to 120 ms into the executor tests'
//! lines took 1.5 to 4.9 times as long as the joint that needs longest could stop alone
//! (0.30 s instead of 0.07 s at 20 ms). Braking the path parameter `s` instead starts
//! braking at once: it is the same brake on the time scale of a profile that passes `s` at
//! a constant reference speed `V` (`ṡ = σ·V`, `s̈ = σ̇·V`, `s⃛ = σ̈·V`), whose rates at `s`
//! are `q'·V`, `q''·V²` and `q'''·V³`, with the same limits, margins and release; those
//! stops take 1.11 to 1.13 times as long as the slowest joint alone. That profile does not
//! end at rest, so it is never run out.
//!
//! What the time scale guarantees by construction, never being faster than the table at any
//! point of the path, this brake has to check:
//! - it is taken only where a prediction in steps of [`PREDICTION_STEP_S`]
//!   ([`PathStop::predicted_duration`]) finds it standing before it gains on the table ahead
//!   (towards its end or a point near a singular set) within [`PREDICTION_MARGIN`] of its
//!   speed, and sooner than the time-scale brake is expected to stand
//!   ([`ScaleBrake::expected_duration`]); otherwise the stop brakes the time scale as
//!   before. While the table speeds up, the time scale has little to brake with and is
//!   expected late; where the table brakes towards its end at its limits, running it out is
//!   the sooner (and its deceleration, built up at the whole jerk limit, is more than this
//!   brake's share could release). On the 100 lines of `rc bench motion` (seed 1), at 10 %
//!   of the table's time all 100 stops took it, 1.11 instead of 2.17 times as long as the
//!   slowest joint alone (median); at 50 %, 8 of 100, among them 3 that had run the table
//!   out (0.49 instead of 0.52 to 0.73 s) and one that took 11 ms longer than the time scale
//!   (0.348 s, expected 0.39 s);
//! - should it still gain on the table where the table slows down, it hands over to the
//!   table's time-scale brake from the same `(s, ṡ, s̈)` ([`PathStop::handover`]; none of
//!   those 200 stops did).
//!
//! The prediction runs in the tick that brakes, once per stop: with the rest of the decision
//! 61 µs at the median and 0.22 ms at most on those lines (`rc bench motion`, release), within
//! the setpoint window the servo holds. Every tick after it compares the stop with the table
//! at the same path position, whose time it finds by Newton steps from the last tick's: a
//! tick took 4.6 µs at the median, as much as one braking the time scale (4.0 µs); with a
//! bisection every tick it took 7.3 µs.

use crate::profile::Profile;
use crate::scale_brake::{ScaleBrake, ScaleLimits, TableRates};

/// How close the search for the profile time of a path position `s ∈ [0, 1]` brings the
/// profile's position to `s`: a few rounding steps. The hand-over starts the table's
/// time-scale brake there, whose position setpoints must go on from the stop's without a
/// step.
const POSITION_RESOLUTION: f64 = 4.0 * f64::EPSILON;
/// The search also ends at a step shorter than this share of the profile's duration (2⁻⁴⁸),
/// where the profile passes the position too slowly to resolve it further.
const TIME_RESOLUTION: f64 = 1.0 / (1u64 << 48) as f64;
/// Steps that search takes at most: more than the 48 halvings that reach the time
/// resolution alone. Newton steps from the last tick's time took 2 to 6 (3.9 on average)
/// over the 36994 searches of `rc bench motion`'s stops (seed 1).
const TIME_SEARCH_STEPS: usize = 64;
/// Step (s) of the prediction that decides whether a stop brakes the path parameter
/// ([`PathStop::predicted_duration`]): a tenth of the shortest stop from full speed.
pub const PREDICTION_STEP_S: f64 = 0.01;
/// Steps the prediction takes at most (2 s: longer than any stop within the limits).
const PREDICTION_STEPS: usize = 200;
/// Largest ratio of the predicted stop's speed to the table's at the same path position:
/// while the table still speeds up and the stop has begun to brake, the table's `s̈` may
/// fall faster for a few milliseconds (it takes it back at its whole jerk limit, the stop
/// at its share), by a fraction of a per cent; more, the stop is not taken.
const PREDICTION_CEILING: f64 = 1.01;
/// Share of the table's speed at the same path position from which a predicted stop that
/// gains on the table counts as handing over: below [`HANDOVER_SCALE`], for what the steps
/// of the prediction miss.
pub const PREDICTION_MARGIN: f64 = 0.9;
/// Share of the table's speed at the same point from which a brake that gains on the table
/// hands over to the table's time scale.
pub const HANDOVER_SCALE: f64 = 0.995;

/// A stop braking the path parameter of a table's path.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PathStop {
    /// The brake of the time scale of the constant-speed profile from `from`.
    brake: ScaleBrake,
    /// The path parameter at which the stop began.
    from: f64,
    /// The reference speed `V` (1/s).
    speed: f64,
    /// `ṡ` over the table's speed at the same path position, in the last tick.
    table_scale: f64,
    /// The table's time at the stop's position, in the last tick: where the next search
    /// for it starts.
    table_time: f64,
}

/// The stop against its table at the stop's position.
struct Comparison {
    /// The table's time there and its `ṡₜ`, `s̈ₜ`.
    time: f64,
    speed: f64,
    acceleration: f64,
    /// `ṡ / ṡₜ`.
    scale: f64,
    /// Whether the stop gains on a table that slows down.
    gaining: bool,
}

impl PathStop {
    /// A stop from `(s, ṡ, s̈)` on a table whose highest speed is `peak` (1/s), which
    /// passes `s` at its time `table_time`, `ṡ` being `table_scale` times the table's speed
    /// there; `None` for a path that stands.
    pub fn new(
        state: (f64, f64, f64),
        table_time: f64,
        table_scale: f64,
        peak: f64,
        limits: ScaleLimits,
    ) -> Option<Self> {
        let (s, sd, sdd) = state;
        // The table's highest speed as the reference keeps σ ≤ 1, and σ̇ and σ̈ of the size
        // the time-scale brake's own bounds on them are made for.
        let speed = peak.max(sd);
        (sd > 0.0 && speed.is_finite()).then(|| Self {
            brake: ScaleBrake::without_run_out(
                0.0,
                sd / speed,
                sdd / speed,
                (1.0 - s).max(0.0) / speed,
                limits,
            ),
            from: s,
            speed,
            table_scale,
            table_time,
        })
    }

    /// How long (s, to a step) this stop takes, advanced in steps of [`PREDICTION_STEP_S`]
    /// with `cruise` (as [`advance`](Self::advance) takes it), if it stands before it gains
    /// on `table` within [`PREDICTION_MARGIN`] of its speed at the same path position: then
    /// it will not have to hand over to the table's time scale. `None` if it gains, or
    /// stands only after [`PREDICTION_STEPS`] steps.
    pub fn predicted_duration(
        &self,
        table: &Profile,
        mut cruise: impl FnMut(f64, f64) -> TableRates,
    ) -> Option<f64> {
        let mut ahead = *self;
        for step in 1..=PREDICTION_STEPS {
            ahead.advance(PREDICTION_STEP_S, &mut cruise);
            if ahead.is_stopped() {
                return Some(step as f64 * PREDICTION_STEP_S);
            }
            let c = ahead.compare(table);
            if c.scale > PREDICTION_CEILING || (c.gaining && c.scale >= PREDICTION_MARGIN) {
                return None;
            }
        }
        None
    }

    /// Compares the stop with `table` at its position, and keeps the scale for the next
    /// comparison.
    fn compare(&mut self, table: &Profile) -> Comparison {
        let (s, sd, _) = self.state();
        let time = time_at(table, s, self.table_time);
        self.table_time = time;
        let (_, speed, acceleration) = table.eval(time);
        let scale = if speed > 0.0 {
            sd / speed
        } else {
            f64::INFINITY
        };
        let gaining = scale > self.table_scale && acceleration < 0.0;
        self.table_scale = scale;
        Comparison {
            time,
            speed,
            acceleration,
            scale,
            gaining,
        }
    }

    /// `(s, ṡ, s̈)` now.
    pub fn state(&self) -> (f64, f64, f64) {
        (
            self.from + self.speed * self.brake.tau(),
            self.speed * self.brake.sigma(),
            self.speed * self.brake.sigma_rate(),
        )
    }

    /// Whether it stands.
    pub fn is_stopped(&self) -> bool {
        self.brake.is_stopped()
    }

    /// Advances `dt` seconds; `cruise` gives the rates of the path at `s` passed at the
    /// constant speed `V` (`(s, V)` its arguments).
    pub fn advance(&mut self, dt: f64, cruise: impl FnOnce(f64, f64) -> TableRates) {
        let (s, _, _) = self.state();
        let speed = self.speed;
        self.brake.advance(dt, || cruise(s, speed));
    }

    /// The time-scale brake of `table` (its limits `limits`) that goes on from here, once
    /// this brake gains on the table and has come within [`HANDOVER_SCALE`] of its speed at
    /// the same point; `None` while it stays below.
    pub fn handover(&mut self, table: &Profile, limits: ScaleLimits) -> Option<ScaleBrake> {
        let c = self.compare(table);
        if self.is_stopped() || !(c.gaining && c.scale >= HANDOVER_SCALE) {
            return None;
        }
        let (_, _, sdd) = self.state();
        // Same (s, ṡ, s̈) on the table's time scale: ṡ = σ·ṡₜ, s̈ = σ²·s̈ₜ + σ̇·ṡₜ. σ may
        // exceed 1 by what the stop ran above the table while the table still sped up (the
        // prediction takes no stop that runs more than PREDICTION_CEILING above it).
        let sigma = c.scale;
        let rate = if c.speed > 0.0 {
            (sdd - sigma * sigma * c.acceleration) / c.speed
        } else {
            0.0
        };
        Some(ScaleBrake::new(
            c.time,
            sigma,
            rate,
            table.duration(),
            limits,
        ))
    }
}

/// The time at which `profile` reaches path position `s` (its position only grows), to
/// [`POSITION_RESOLUTION`] or [`TIME_RESOLUTION`]: Newton steps from `guess`, the time of a
/// position a tick or a prediction step before; a step that would leave the times known to
/// lie before and after `s` (or a profile standing there) halves them instead.
fn time_at(profile: &Profile, s: f64, guess: f64) -> f64 {
    let duration = profile.duration();
    let resolution = TIME_RESOLUTION * duration;
    let (mut early, mut late) = (0.0, duration);
    let mut t = guess.clamp(early, late);
    for _ in 0..TIME_SEARCH_STEPS {
        let (at, speed, _) = profile.eval(t);
        if (s - at).abs() <= POSITION_RESOLUTION {
            return t;
        }
        if at < s {
            early = t;
        } else {
            late = t;
        }
        let newton = t + (s - at) / speed;
        let next = if newton > early && newton < late {
            newton
        } else {
            0.5 * (early + late)
        };
        if (next - t).abs() <= resolution {
            return next;
        }
        t = next;
    }
    t
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::topp::{JerkBound, POINTS, TableProfile};

    const DT: f64 = 1e-3;

    fn limits(a: f64, j: f64) -> ScaleLimits {
        ScaleLimits::uniform(a, j)
    }

    /// A path every coordinate follows at `dq/ds = 1`: passed at `speed` its rates are
    /// `speed` and nothing else.
    fn straight(_: f64, speed: f64) -> TableRates {
        TableRates::cruise(speed)
    }

    /// A table of `ṡ` rising like `√s` to `peak` by `s = top`, falling the same way to
    /// its end.
    fn table(peak: f64, top: f64) -> Profile {
        let speeds: [f64; POINTS] = core::array::from_fn(|k| {
            let s = k as f64 / (POINTS - 1) as f64;
            let rising = (s / top).sqrt();
            let falling = ((1.0 - s) / (1.0 - top)).sqrt();
            peak * rising.min(falling).min(1.0)
        });
        Profile::Table(TableProfile::from_speeds(&speeds, JerkBound::Joints).expect("a table"))
    }

    /// From any guess, near or far, before or after, and at the ends where the table
    /// stands.
    #[test]
    fn the_time_of_a_position_is_where_the_profile_passes_it() {
        let table = table(2.0, 0.3);
        let duration = table.duration();
        for s in [1e-6, 0.01, 0.2, 0.3, 0.5, 0.99, 1.0 - 1e-9] {
            for guess in [0.0, 0.3 * duration, duration, 2.0 * duration] {
                let time = time_at(&table, s, guess);
                let (at, _, _) = table.eval(time);
                assert!((at - s).abs() < 1e-12, "{s} from {guess}: {at}");
            }
        }
    }

    #[test]
    fn a_standing_path_has_no_stop_on_the_path() {
        assert!(PathStop::new((0.5, 0.0, 0.0), 0.5, 1.0, 2.0, limits(10.0, 50.0)).is_none());
        assert!(PathStop::new((0.5, 1.0, -0.1), 0.5, 1.0, 2.0, limits(10.0, 50.0)).is_some());
    }

    /// From a path speeding up, `s̈` comes down from the first tick at the jerk limit (with
    /// the margin of the time-scale brake) and the stop ends at rest, never passing the
    /// table.
    #[test]
    fn a_stop_while_the_path_speeds_up_brakes_at_once_and_ends_at_rest() {
        let table = table(2.0, 0.6);
        let (s, sd, sdd) = (0.1, 0.8, 3.0);
        let tau = time_at(&table, s, 0.0);
        let mut stop =
            PathStop::new((s, sd, sdd), tau, 1.0, 2.0, limits(10.0, 50.0)).expect("a stop");
        assert!(stop.predicted_duration(&table, straight).is_some());
        stop.advance(DT, straight);
        let (_, _, after) = stop.state();
        assert!(after < sdd - 0.5 * 50.0 * DT, "{after}");
        let mut ticks = 0;
        while !stop.is_stopped() {
            stop.advance(DT, straight);
            assert!(stop.handover(&table, limits(10.0, 50.0)).is_none());
            ticks += 1;
            assert!(ticks < 2000);
        }
        let (end, speed, acceleration) = stop.state();
        assert_eq!((speed, acceleration), (0.0, 0.0));
        assert!(end > s && end < 0.6, "{end}");
    }

    /// A stop whose jerk limit lets it bring `s̈` down more slowly than the table ahead
    /// slows down is refused by the prediction; run anyway, it hands over to the table's
    /// time scale from the same `(s, ṡ, s̈)`.
    #[test]
    fn a_stop_that_gains_on_the_table_hands_over_to_its_time_scale() {
        let table = table(2.0, 0.2);
        let tau = time_at(&table, 0.15, 0.0);
        let state = table.eval(tau);
        let weak = limits(10.0, 0.5);
        let mut stop = PathStop::new(state, tau, 1.0, 2.0, weak).expect("a stop");
        assert!(stop.predicted_duration(&table, straight).is_none());
        let mut ticks = 0;
        let handover = loop {
            stop.advance(DT, straight);
            if let Some(brake) = stop.handover(&table, weak) {
                break brake;
            }
            ticks += 1;
            assert!(ticks < 2000, "never handed over");
        };
        let (s, sd, sdd) = stop.state();
        let (at, td, tdd) = table.eval(handover.tau());
        let sigma = handover.sigma();
        assert!((at - s).abs() < 1e-9);
        // Above the table it went while the table still sped up (by less than the
        // prediction tolerates), never far.
        assert!(
            (HANDOVER_SCALE..PREDICTION_CEILING).contains(&sigma),
            "{sigma}"
        );
        assert!((sigma * td - sd).abs() < 1e-9);
        assert!((sigma * sigma * tdd + handover.sigma_rate() * td - sdd).abs() < 1e-9);
    }
}
