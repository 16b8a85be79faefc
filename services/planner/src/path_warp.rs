//! The timing parameter of a Cartesian path: `s = σ(r)`, `r` in [0, 1], where the path
//! position `s` (the share of the TCP's path) advances slowly where the joints move fast
//! per unit `s`.
//!
//! # Why
//!
//! The jerk of joint `i` along a timed path is `q'''·ṙ³ + 3·q''·ṙ·r̈ + q'·r⃛` (derivatives by
//! the timing parameter). The time-optimal timing of [`topp`](crate::topp) bounds it with
//! the magnitude of every term, which is exact only where the terms do not cancel. Near a
//! singular set the joints turn fast over a short piece of the TCP's path: by `s`, `q''`
//! and `q'''` are large there and their terms cancel in a good timing, which the magnitudes
//! cannot see. By a parameter that runs at the same pace as the joints (`dr/ds` the
//! joints' speed per unit `s` over their velocity limits, with the TCP's), the path has no
//! such spikes and the bounds by magnitude lose little: a scratch study of the lines of
//! `rc bench motion` (seed 1, a jerk-limited direct collocation on ipopt) found the jerk-
//! limited optimum of the magnitude bounds 1.51 s by `s` and 0.97 s by `r` on its worst
//! line, against 0.95 s for the exact jerk rows.
//!
//! The grid the path is timed on ([`INTERVALS`] equal steps of the parameter) follows the
//! joints too. By `s` such a stretch lies within a few intervals, over which the grid rows
//! hold the velocity limit with the largest `|q'|` around and the acceleration limit at both
//! ends of each, so the timing loses to the grid's coarseness even without the jerk bound:
//! on toppra's constraints alone the bench's lines (seed 1) took up to 1.043 times toppra's
//! duration on 4000 grid points by `s`, at most 1.009 times with the table on the joints'
//! pace.
//!
//! # Shape
//!
//! The density `g = dr/ds` (up to a constant) is given at the grid points `s_k = k/N` of
//! [`POINTS`], smoothed (a few passes of a `(1, 2, 1)/4` filter) and interpolated by the
//! natural cubic spline, so it is twice continuously differentiable; a spline that dips
//! towards 0 between the samples gives no warp. `r(s) = ∫g/∫g` is then a piecewise quartic
//! and `σ` its inverse, found per call by a safeguarded Newton iteration; `σ' = T/g(σ)`,
//! `σ'' = −g'(σ)·σ'³/T` (`T = ∫g`) and `σ'''` are continuous, so the joints' positions,
//! velocities, accelerations and jerks by `r` have no jumps. (Without the smoothing and
//! with a spline only once differentiable, the third derivatives between the grid points
//! were up to 3.7 times those the samples gave on the worst line of the bench.)

use crate::topp::{INTERVALS, POINTS};

/// Newton steps for `σ(r)` at most (each keeps a bracket, so it always ends inside it).
const NEWTON_STEPS: usize = 40;
/// Points per interval at which the interpolated density is checked to stay away from 0.
const CHECKS_PER_INTERVAL: usize = 8;
/// Passes of the smoothing filter over the density.
const SMOOTHING_PASSES: usize = 8;
/// Tolerance of `σ(r)` in `s`.
const POSITION_TOLERANCE: f64 = 1e-13;

/// `s = σ(r)`, the inverse of `r(s) = ∫₀ˢ g / ∫₀¹ g`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PathWarp {
    /// `g(s_k)`.
    density: [f64; POINTS],
    /// `g'(s_k)` of the interpolant.
    slope: [f64; POINTS],
    /// `∫₀^{s_k} g`.
    integral: [f64; POINTS],
}

impl PathWarp {
    /// The warp whose `dr/ds` is proportional to `density` (given at `s_k = k/N`); `None`
    /// if a density is not finite and positive.
    pub fn from_density(density: &[f64; POINTS]) -> Option<Self> {
        if density.iter().any(|g| !(g.is_finite() && *g > 0.0)) {
            return None;
        }
        let density = &smoothed(density);
        let h = 1.0 / INTERVALS as f64;
        // The slopes of the natural cubic spline: the interpolant is twice continuously
        // differentiable, so the joints' third derivative by `r` has no jumps.
        let bends = natural_spline_bends(density, h);
        let slope: [f64; POINTS] = core::array::from_fn(|k| {
            if k < INTERVALS {
                (density[k + 1] - density[k]) / h - h * (2.0 * bends[k] + bends[k + 1]) / 6.0
            } else {
                (density[k] - density[k - 1]) / h + h * (bends[k - 1] + 2.0 * bends[k]) / 6.0
            }
        });
        let mut warp = Self {
            density: *density,
            slope,
            integral: [0.0; POINTS],
        };
        for k in 0..INTERVALS {
            warp.integral[k + 1] = warp.integral[k] + warp.piece_integral(k, 1.0);
        }
        let total = warp.integral[INTERVALS];
        // The spline of smoothed positive samples stays near them; a density that still
        // dips below half its smallest sample anywhere is not used.
        let least = 0.5 * density.iter().copied().fold(f64::INFINITY, f64::min);
        let positive = (0..INTERVALS).all(|k| {
            (1..CHECKS_PER_INTERVAL)
                .all(|c| warp.density_at(k, c as f64 / CHECKS_PER_INTERVAL as f64).0 > least)
        });
        (total.is_finite() && total > 0.0 && positive).then_some(warp)
    }

    /// `∫` of the density over the first share `t` of interval `k`.
    fn piece_integral(&self, k: usize, t: f64) -> f64 {
        let h = 1.0 / INTERVALS as f64;
        let (t2, t3, t4) = (t * t, t * t * t, t * t * t * t);
        h * ((0.5 * t4 - t3 + t) * self.density[k]
            + (0.25 * t4 - 2.0 / 3.0 * t3 + 0.5 * t2) * h * self.slope[k]
            + (-0.5 * t4 + t3) * self.density[k + 1]
            + (0.25 * t4 - t3 / 3.0) * h * self.slope[k + 1])
    }

    /// The density and its derivative by `s` at share `t` of interval `k`.
    fn density_at(&self, k: usize, t: f64) -> (f64, f64) {
        let h = 1.0 / INTERVALS as f64;
        let (g0, g1, d0, d1) = (
            self.density[k],
            self.density[k + 1],
            h * self.slope[k],
            h * self.slope[k + 1],
        );
        let t2 = t * t;
        let t3 = t2 * t;
        let value = (2.0 * t3 - 3.0 * t2 + 1.0) * g0
            + (t3 - 2.0 * t2 + t) * d0
            + (-2.0 * t3 + 3.0 * t2) * g1
            + (t3 - t2) * d1;
        let rate = (6.0 * t2 - 6.0 * t) * g0
            + (3.0 * t2 - 4.0 * t + 1.0) * d0
            + (-6.0 * t2 + 6.0 * t) * g1
            + (3.0 * t2 - 2.0 * t) * d1;
        (value, rate / h)
    }

    /// `(σ, dσ/dr, d²σ/dr²)` at `r` (clamped to [0, 1]).
    pub fn eval(&self, r: f64) -> (f64, f64, f64) {
        let total = self.integral[INTERVALS];
        let wanted = r.clamp(0.0, 1.0) * total;
        // The interval holding `wanted`: the last k with integral[k] ≤ wanted.
        let k = self
            .integral
            .partition_point(|&i| i <= wanted)
            .saturating_sub(1)
            .min(INTERVALS - 1);
        let rest = wanted - self.integral[k];
        let h = 1.0 / INTERVALS as f64;
        let (mut lo, mut hi) = (0.0f64, 1.0f64);
        let mut t = (rest / (self.integral[k + 1] - self.integral[k])).clamp(0.0, 1.0);
        for _ in 0..NEWTON_STEPS {
            let miss = self.piece_integral(k, t) - rest;
            if miss > 0.0 {
                hi = t;
            } else {
                lo = t;
            }
            let (g, _) = self.density_at(k, t);
            let step = miss / (g * h);
            if (step * h).abs() < POSITION_TOLERANCE || (hi - lo) * h < POSITION_TOLERANCE {
                break;
            }
            let next = t - step;
            t = if next > lo && next < hi {
                next
            } else {
                0.5 * (lo + hi)
            };
        }
        let (g, rate) = self.density_at(k, t);
        let speed = total / g;
        (
            (k as f64 + t) * h,
            speed,
            -rate * speed * speed * speed / total,
        )
    }
}

/// `density` after [`SMOOTHING_PASSES`] passes of the filter `(1, 2, 1)/4` (the ends
/// kept): the interpolant's second derivative, and with it the third derivative of the
/// joints by the timing parameter, stays small where the samples turn sharply. Weighted
/// means of positive values stay positive.
fn smoothed(density: &[f64; POINTS]) -> [f64; POINTS] {
    let mut g = *density;
    for _ in 0..SMOOTHING_PASSES {
        let before = g;
        for k in 1..INTERVALS {
            g[k] = 0.25 * (before[k - 1] + 2.0 * before[k] + before[k + 1]);
        }
    }
    g
}

/// The second derivatives of the natural cubic spline through `y` on a uniform grid of
/// step `h` (Thomas algorithm on `m_{k−1} + 4·m_k + m_{k+1} = 6·(y_{k+1} − 2y_k + y_{k−1})/h²`,
/// 0 at both ends).
fn natural_spline_bends(y: &[f64; POINTS], h: f64) -> [f64; POINTS] {
    let mut diagonal = [4.0; POINTS];
    let mut rhs = [0.0; POINTS];
    for k in 1..INTERVALS {
        rhs[k] = 6.0 * (y[k + 1] - 2.0 * y[k] + y[k - 1]) / (h * h);
        if k > 1 {
            let factor = 1.0 / diagonal[k - 1];
            diagonal[k] -= factor;
            rhs[k] -= factor * rhs[k - 1];
        }
    }
    let mut bends = [0.0; POINTS];
    for k in (1..INTERVALS).rev() {
        bends[k] = (rhs[k] - bends[k + 1]) / diagonal[k];
    }
    bends
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_constant_density_is_the_identity() {
        let warp = PathWarp::from_density(&[2.5; POINTS]).unwrap();
        for k in 0..=100 {
            let r = k as f64 / 100.0;
            let (s, slope, bend) = warp.eval(r);
            assert!((s - r).abs() < 1e-12, "σ({r}) = {s}");
            assert!((slope - 1.0).abs() < 1e-9 && bend.abs() < 1e-6);
        }
    }

    #[test]
    fn the_path_advances_slowly_where_the_density_is_high() {
        // dr/ds ten times higher in the middle fifth of the path.
        let density = core::array::from_fn(|k| {
            let s = k as f64 / INTERVALS as f64;
            1.0 + 9.0 * (-((s - 0.5) / 0.1).powi(2)).exp()
        });
        let warp = PathWarp::from_density(&density).unwrap();
        let (s_mid, slope_mid, _) = warp.eval(0.5);
        assert!((s_mid - 0.5).abs() < 1e-9, "symmetric: σ(0.5) = {s_mid}");
        let (_, slope_end, _) = warp.eval(0.02);
        assert!(
            slope_end > 5.0 * slope_mid,
            "σ' {slope_end} at the start, {slope_mid} in the middle"
        );
        assert_eq!(warp.eval(0.0).0, 0.0);
        assert_eq!(warp.eval(1.0).0, 1.0);
    }

    #[test]
    fn derivatives_match_differences_and_are_continuous() {
        let density = core::array::from_fn(|k| 1.0 + (k as f64 * 0.05).sin().powi(2) * 4.0);
        let warp = PathWarp::from_density(&density).unwrap();
        let h = 1e-6;
        for k in 1..400 {
            let r = k as f64 / 400.0 + 1e-4;
            let (_, slope, bend) = warp.eval(r);
            let numeric = (warp.eval(r + h).0 - warp.eval(r - h).0) / (2.0 * h);
            let numeric_bend = (warp.eval(r + h).1 - warp.eval(r - h).1) / (2.0 * h);
            assert!((slope - numeric).abs() < 1e-6, "σ' at {r}");
            assert!(
                (bend - numeric_bend).abs() < 1e-3 * (1.0 + bend.abs()),
                "σ'' at {r}"
            );
        }
        // Continuous across a knot.
        let knot = 100.0 / INTERVALS as f64;
        let (a, b) = (warp.eval(knot - 1e-12), warp.eval(knot + 1e-12));
        assert!((a.1 - b.1).abs() < 1e-6 && (a.2 - b.2).abs() < 1e-3);
    }

    #[test]
    fn the_warp_inverts_the_integral_of_the_density() {
        let density = core::array::from_fn(|k| 1.0 + 3.0 * (k as f64 / 40.0).cos().powi(2));
        let warp = PathWarp::from_density(&density).unwrap();
        for k in 0..=200 {
            let r = k as f64 / 200.0;
            let (s, _, _) = warp.eval(r);
            let j = ((s * INTERVALS as f64) as usize).min(INTERVALS - 1);
            let t = s * INTERVALS as f64 - j as f64;
            let back = (warp.integral[j] + warp.piece_integral(j, t)) / warp.integral[INTERVALS];
            assert!((back - r).abs() < 1e-12, "r({s}) = {back}, not {r}");
        }
    }

    #[test]
    fn a_density_that_is_not_positive_gives_no_warp() {
        let mut density = [1.0; POINTS];
        density[7] = 0.0;
        assert!(PathWarp::from_density(&density).is_none());
        density[7] = f64::NAN;
        assert!(PathWarp::from_density(&density).is_none());
    }
}
