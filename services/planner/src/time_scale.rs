//! The time scale σ of the running profiles under the override: the profiles' time τ
//! advances σ seconds per second, and σ ramps towards the override with a bounded rate σ̇
//! and a bounded change of it σ̈ (see [`motion`](crate::motion), "Override", for what the
//! bounds keep). A pure law of σ, σ̇ and the bounds, advanced one tick at a time.

/// Distance of σ from its target and rate left, relative to a ramp's change of rate per
/// tick, below which σ stands on the target.
const SETTLED: f64 = 1e-6;

/// The time scale σ and its rate σ̇ over the last tick.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TimeScale {
    /// σ: the running profiles advance σ seconds per second.
    pub sigma: f64,
    /// σ̇ over the last tick (1/s).
    pub rate: f64,
}

impl TimeScale {
    /// σ at rest at `sigma`.
    pub fn at(sigma: f64) -> Self {
        Self { sigma, rate: 0.0 }
    }

    /// The largest `|σ̇|` (1/s) that ramps towards `target` within the bounds `rate` and
    /// `acceleration` (see [`ramp`](Self::ramp)) reach within `horizon` seconds: none where
    /// σ stands on its target.
    pub fn fastest_rate(&self, target: f64, rate: f64, acceleration: f64, horizon: f64) -> f64 {
        if self.rate == 0.0 && self.sigma == target {
            0.0
        } else {
            rate.min(self.rate.abs() + acceleration * horizon)
        }
    }

    /// Where σ comes to rest if its rate brakes now at `acceleration` (1/s²).
    pub fn rest_point(&self, acceleration: f64) -> f64 {
        self.sigma + self.rate * self.rate.abs() / (2.0 * acceleration)
    }

    /// Time (s) a ramp from rest to rest takes to move σ by `distance` within the bounds
    /// `rate` and `acceleration` (see [`ramp`](Self::ramp)), ticks aside: the rate's
    /// trapezoid, or its triangle where the distance is too short to reach the rate.
    pub fn ramp_time(distance: f64, rate: f64, acceleration: f64) -> f64 {
        let distance = distance.abs();
        if distance * acceleration >= rate * rate {
            distance / rate + rate / acceleration
        } else {
            2.0 * (distance / acceleration).sqrt()
        }
    }

    /// σ approaches `target` over a tick of `dt` with `|σ̇| ≤ rate` (1/s) and `|σ̈| ≤
    /// acceleration` (1/s²), braking its rate in time to arrive at rest; returns how far the
    /// profiles' time τ advances in it. σ stays within [0, 1] and passes a target only where
    /// it was set too late to brake for.
    pub fn ramp(&mut self, target: f64, rate: f64, acceleration: f64, dt: f64) -> f64 {
        let change = acceleration * dt;
        // A rate lower than σ̇ by up to one tick's change (a blend's, approached gradually)
        // is reached within this tick's change; one lower still (a blend's, entered while
        // the override ramps faster) holds at once: the rate is what keeps the
        // acceleration within its limit.
        let sigma_rate = if self.rate.abs() - rate <= change {
            self.rate
        } else {
            self.rate.clamp(-rate, rate)
        };
        let sigma = self.sigma;
        let gap = target - sigma;
        let toward = if gap < 0.0 { -1.0 } else { 1.0 };
        // The fastest rate towards the target at the end of the tick from which braking at
        // `acceleration` (in the same trapezoid steps) still stops on it:
        // `(σ̇ + v)/2·dt + v²/(2·acceleration) ≤ |gap|`; none where even that overshoots.
        let half = 0.5 * dt;
        let room = half * half + 2.0 * (gap.abs() - toward * sigma_rate * half) / acceleration;
        let arriving = if room >= 0.0 {
            acceleration * (room.sqrt() - half)
        } else {
            f64::NEG_INFINITY
        };
        // Near the target: this tick's rate, then 0 in the next, ends on it (braking on the
        // bound alone, the rate would flip about it without getting there).
        let finishing = gap.abs() / dt - 0.5 * toward * sigma_rate;
        let wanted = if (finishing - toward * sigma_rate).abs() <= change
            && finishing.abs() <= change.min(rate)
        {
            toward * finishing
        } else {
            toward * rate.min(arriving)
        };
        let mut next_rate =
            (sigma_rate + (wanted - sigma_rate).clamp(-change, change)).clamp(-rate, rate);
        // σ̈ is constant within the tick.
        let mut step = dt * (sigma + dt * (2.0 * sigma_rate + next_rate) / 6.0);
        let mut next = sigma + 0.5 * (sigma_rate + next_rate) * dt;
        // The last step may end a little past the target or, by rounding, short of rest on
        // it: it stops on the target instead, within one tick's change of σ̇. (Faster, it
        // passes the target only where a new one came too late to brake for: it then turns
        // back as it can.)
        let passed = (next - target) * gap > 0.0 && sigma_rate.abs() <= change;
        let settled =
            (next - target).abs() <= SETTLED * change && next_rate.abs() <= SETTLED * change;
        let highest = 1.0f64.max(target);
        let held = if passed || settled {
            Some(target)
        } else {
            (!(0.0..=highest).contains(&next)).then(|| next.clamp(0.0, highest))
        };
        if let Some(at) = held {
            (next, next_rate) = (at, 0.0);
            step = 0.5 * (sigma + next) * dt;
        }
        self.sigma = next;
        self.rate = next_rate;
        step
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const DT: f64 = 1e-3;

    /// An override ramp changes σ̇ by at most its acceleration per second, never faster
    /// than its rate, never past the target it heads for and never out of [0, 1]; it
    /// arrives on the target at rest, as soon as the rate and the acceleration allow. Down
    /// to 0.3, back up to 1 before arriving, down to 0 and up to 1 again. (A step of σ̇
    /// moved the joints' acceleration by up to the override reserve's share of its limit in
    /// one tick: 80 times the jerk limit of the JAKA Zu 7.)
    #[test]
    fn override_ramps_change_their_rate_gradually_and_stop_on_the_target() {
        let (rate, acceleration) = (0.8, 10.0);
        let mut m = TimeScale::at(1.0);
        for (target, ticks) in [(0.3, 400), (1.0, 2000), (0.0, 2000), (1.0, 2000)] {
            let (from, from_rest) = (m.sigma, m.rate == 0.0);
            let mut arrived = None;
            for tick in 0..ticks {
                let (sigma, sigma_rate) = (m.sigma, m.rate);
                let step = m.ramp(target, rate, acceleration, DT);
                assert!(m.rate.abs() <= rate * (1.0 + 1e-12), "{m:?}");
                let change = (m.rate - sigma_rate).abs();
                assert!(
                    change <= acceleration * DT * (1.0 + 1e-9),
                    "{change} at {m:?}"
                );
                assert!((0.0..=1.0).contains(&m.sigma), "{m:?}");
                assert!(
                    (m.sigma - target) * (from - target) >= 0.0,
                    "past {target}: {m:?}"
                );
                let (low, high) = (sigma.min(m.sigma), sigma.max(m.sigma));
                assert!(step >= low * DT - 1e-15 && step <= high * DT + 1e-15);
                if arrived.is_none() && m.sigma == target && m.rate == 0.0 {
                    arrived = Some(tick + 1);
                }
            }
            if target == 0.3 {
                assert!(arrived.is_none(), "turned back before 0.3");
                continue;
            }
            let arrived = arrived.unwrap_or_else(|| panic!("not at {target}: {m:?}"));
            if from_rest {
                // From rest: `|Δσ|/rate + rate/acceleration`, within a few ticks.
                let shortest = TimeScale::ramp_time(target - from, rate, acceleration);
                assert!(
                    arrived as f64 * DT <= shortest + 3.0 * DT,
                    "{arrived} ticks"
                );
            }
        }
    }

    /// The time of a ramp from rest, short of the rate or reaching it, is what the ramp takes
    /// to arrive on its target, within a few ticks.
    #[test]
    fn the_ramp_time_is_that_of_a_ramp_from_rest() {
        let (rate, acceleration) = (0.4, 5.0);
        // Triangles below 0.032, trapezoids above.
        for distance in [0.001, 0.01, 0.03, 0.05, 0.2, 0.6] {
            let mut m = TimeScale::at(1.0);
            let target = 1.0 - distance;
            let mut ticks = 0;
            while (m.sigma, m.rate) != (target, 0.0) {
                m.ramp(target, rate, acceleration, DT);
                ticks += 1;
                assert!(ticks < 10_000, "{distance}");
            }
            let time = TimeScale::ramp_time(-distance, rate, acceleration);
            let took = ticks as f64 * DT;
            assert!((took - time).abs() <= 3.0 * DT, "{distance}: {took} {time}");
        }
    }

    /// A target set too late to brake for (σ falling at the full rate just above it) is
    /// passed and reached from the other side, the rate changing as gradually as ever.
    #[test]
    fn a_target_too_near_to_brake_for_is_passed_and_reached_from_the_other_side() {
        let (rate, acceleration) = (0.8, 10.0);
        let mut m = TimeScale::at(1.0);
        while m.sigma > 0.5 {
            m.ramp(0.0, rate, acceleration, DT);
        }
        assert_eq!(m.rate, -rate);
        let target = m.sigma - 0.001;
        let mut lowest = m.sigma;
        for _ in 0..1000 {
            let before = m.rate;
            m.ramp(target, rate, acceleration, DT);
            assert!((m.rate - before).abs() <= acceleration * DT * (1.0 + 1e-9));
            lowest = lowest.min(m.sigma);
        }
        assert!(lowest < target - 0.02, "{lowest}");
        assert_eq!((m.sigma, m.rate), (target, 0.0));
    }

    /// A lower rate (a blend's, entered while the override ramps at the move's own) holds
    /// from the first tick: the rate is what keeps the acceleration within its limit.
    #[test]
    fn a_lower_rate_holds_at_once() {
        let mut m = TimeScale::at(1.0);
        while m.rate > -0.8 {
            m.ramp(0.0, 0.8, 10.0, DT);
        }
        m.ramp(0.0, 0.3, 10.0, DT);
        assert!(m.rate >= -0.3, "{m:?}");
    }

    /// A rate that comes down a little every tick (towards a blend's, ahead of its overlap)
    /// while the override turns back: σ̇ still changes by at most one tick's step. (Held
    /// at the lower rate first and then changed by a step, it changed by up to 1.86 steps;
    /// found by a review.)
    #[test]
    fn a_rate_coming_down_gradually_changes_sigma_rate_by_one_step_at_most() {
        let acceleration = 10.0;
        let change = acceleration * DT;
        for turn_after in [1, 5, 20] {
            let mut m = TimeScale::at(0.9);
            while m.rate > -0.5 {
                m.ramp(0.0, 0.5, acceleration, DT);
            }
            let mut rate = 0.5;
            for tick in 0..200 {
                rate = (rate - 0.9 * change).max(0.05);
                let target = if tick < turn_after { 0.0 } else { 1.0 };
                let before = m.rate;
                m.ramp(target, rate, acceleration, DT);
                let step = (m.rate - before).abs();
                assert!(step <= change * (1.0 + 1e-9), "{turn_after} {tick}: {step}");
                assert!(m.rate.abs() <= rate, "{m:?}");
            }
        }
    }

    /// From rates and distances around a target of every sign and size near one tick's
    /// change, σ settles exactly on it at rest, its rate changing by at most one tick's step
    /// and never beyond the rate, also where the rate is below one tick's change.
    #[test]
    fn near_the_target_the_ramp_settles_within_its_bounds() {
        let acceleration = 10.0;
        let change = acceleration * DT;
        for rate in [0.8, 0.004] {
            for gap in [-1e-4, -3.9e-6, -1e-7, 0.0, 1e-7, 3.9e-6, 1e-4] {
                for start_rate in [-0.03, -0.02, -0.004, 0.0, 0.004, 0.02, 0.03] {
                    let start_rate = f64::clamp(start_rate, -rate, rate);
                    let target = 0.6271476;
                    let mut m = TimeScale::at(target - gap);
                    m.rate = start_rate;
                    for _ in 0..2000 {
                        let before = m.rate;
                        m.ramp(target, rate, acceleration, DT);
                        let step = (m.rate - before).abs();
                        assert!(step <= change * (1.0 + 1e-9), "{gap} {start_rate}: {step}");
                        assert!(m.rate.abs() <= rate, "{gap} {start_rate}: {m:?}");
                    }
                    assert_eq!((m.sigma, m.rate), (target, 0.0), "{gap} {start_rate}");
                }
            }
        }
    }
}
