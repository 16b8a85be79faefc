//! Axes of a plot: a data range made presentable (never empty, never NaN), its tick values,
//! and the linear map from data values to drawing coordinates.

/// A closed data interval that an axis shows, with `low < high` and both finite.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Range {
    pub low: f64,
    pub high: f64,
}

impl Range {
    /// The interval spanned by the finite `values`, widened by `margin` (a fraction of its
    /// width) on both sides. Without finite values it is `fallback`; a single value or a flat
    /// trace gets a width of 2 around it, so that it shows as a line in the middle.
    pub fn of(values: impl IntoIterator<Item = f64>, margin: f64, fallback: Range) -> Range {
        let (low, high) = values
            .into_iter()
            .filter(|v| v.is_finite())
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
                (lo.min(v), hi.max(v))
            });
        if low > high {
            return fallback;
        }
        let width = high - low;
        // Below this width a trace is flat for the eye; also keeps `low < high` for huge values.
        if width <= 1e-9 * low.abs().max(high.abs()).max(1.0) {
            return Range {
                low: low - 1.0,
                high: high + 1.0,
            };
        }
        let pad = width * margin.max(0.0);
        Range {
            low: low - pad,
            high: high + pad,
        }
    }

    /// The range extended to the nearest ticks of [`Range::ticks`] outside it.
    pub fn rounded_to_ticks(self, target_ticks: usize) -> Range {
        let step = tick_step(self.high - self.low, target_ticks);
        Range {
            low: (self.low / step).floor() * step,
            high: (self.high / step).ceil() * step,
        }
    }

    /// Tick values inside the range at a 1-2-5 step giving about `target_ticks` ticks.
    pub fn ticks(self, target_ticks: usize) -> impl Iterator<Item = f64> {
        let step = tick_step(self.high - self.low, target_ticks);
        let first = (self.low / step).ceil() as i64;
        let last = (self.high / step).floor() as i64;
        // `+ 0.0` turns a tick at −0 into 0, so that no label reads "-0".
        (first..=last).map(move |i| i as f64 * step + 0.0)
    }
}

/// The 1, 2 or 5 times a power of ten nearest to `width / target_ticks`.
fn tick_step(width: f64, target_ticks: usize) -> f64 {
    let raw = width / target_ticks.max(1) as f64;
    if !(raw.is_finite() && raw > 0.0) {
        return 1.0;
    }
    let magnitude = 10f64.powf(raw.log10().floor());
    let mantissa = raw / magnitude;
    let nice = if mantissa < 1.5 {
        1.0
    } else if mantissa < 3.5 {
        2.0
    } else if mantissa < 7.5 {
        5.0
    } else {
        10.0
    };
    nice * magnitude
}

/// A linear map from a data range to a drawing interval (which may run backwards, as the y
/// axis of SVG does).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Scale {
    pub range: Range,
    /// Drawing coordinates of `range.low` and `range.high`.
    pub from: f64,
    pub to: f64,
}

impl Scale {
    /// The drawing coordinate of `value`, clamped to the drawing interval.
    pub fn map(&self, value: f64) -> f64 {
        let fraction =
            ((value - self.range.low) / (self.range.high - self.range.low)).clamp(0.0, 1.0);
        self.from + fraction * (self.to - self.from)
    }
}

/// A tick label: integers without decimals, others with as many as the step needs.
pub fn label(value: f64, step_hint: f64) -> String {
    let decimals = if step_hint >= 1.0 || !step_hint.is_finite() || step_hint <= 0.0 {
        0
    } else {
        (-step_hint.log10().floor()) as usize
    };
    format!("{value:.decimals$}")
}

/// The step between consecutive ticks of `range`, for [`label`].
pub fn step_of(range: Range, target_ticks: usize) -> f64 {
    tick_step(range.high - range.low, target_ticks)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    const UNIT: Range = Range {
        low: 0.0,
        high: 1.0,
    };

    #[test]
    fn ranges_of_degenerate_data_are_still_ranges() {
        assert_eq!(Range::of([], 0.1, UNIT), UNIT);
        assert_eq!(Range::of([f64::NAN, f64::INFINITY], 0.1, UNIT), UNIT);
        assert_eq!(
            Range::of([5.0, 5.0, f64::NAN], 0.1, UNIT),
            Range {
                low: 4.0,
                high: 6.0
            }
        );
        assert_eq!(
            Range::of([0.0, 10.0], 0.1, UNIT),
            Range {
                low: -1.0,
                high: 11.0
            }
        );
    }

    #[test]
    fn ticks_step_by_one_two_or_five() {
        let ticks: Vec<f64> = Range {
            low: -1.0,
            high: 11.0,
        }
        .ticks(5)
        .collect();
        assert_eq!(ticks, [0.0, 2.0, 4.0, 6.0, 8.0, 10.0]);
        let rounded = Range {
            low: -93.0,
            high: 181.0,
        }
        .rounded_to_ticks(5);
        assert_eq!(
            rounded,
            Range {
                low: -100.0,
                high: 200.0
            }
        );
        assert_eq!(label(0.25, 0.05), "0.25");
        assert_eq!(label(100.0, 50.0), "100");
        assert_eq!(label(-0.0 + 0.0, 1.0), "0");
    }

    #[test]
    fn the_scale_maps_linearly_and_clamps() {
        let s = Scale {
            range: Range {
                low: 0.0,
                high: 10.0,
            },
            from: 300.0,
            to: 100.0,
        };
        assert_eq!(s.map(0.0), 300.0);
        assert_eq!(s.map(5.0), 200.0);
        assert_eq!(s.map(20.0), 100.0);
        assert_eq!(s.map(-5.0), 300.0);
    }

    proptest! {
        #[test]
        fn ticks_lie_inside_and_are_few(
            low in -1e6f64..1e6,
            width in 1e-6f64..1e6,
            target in 2usize..10,
        ) {
            let range = Range { low, high: low + width };
            let ticks: Vec<f64> = range.ticks(target).collect();
            prop_assert!(ticks.len() <= 3 * target);
            let slack = 1e-9 * low.abs().max(width).max(1.0);
            prop_assert!(ticks.iter().all(|t| *t >= low - slack && *t <= low + width + slack));
            let rounded = range.rounded_to_ticks(target);
            prop_assert!(rounded.low <= low && rounded.high >= low + width);
            prop_assert!(rounded.ticks(target).count() >= 1);
        }
    }
}
