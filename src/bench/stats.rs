//! Latency samples and their distribution: exact percentiles (nearest rank) over every
//! sample, and the HdrHistogram-style percentile ladder for plotting.
//!
//! Samples are kept whole rather than bucketed: a row has at most a few hundred thousand of
//! them, and sorting them once at the end gives exact values at every percentile.

use std::fmt::Write as _;

/// Collects samples (ns) into storage reserved up front, so recording never allocates;
/// samples beyond the capacity are counted, not kept.
#[derive(Debug, Clone)]
pub struct Recorder {
    samples: Vec<u64>,
    dropped: u64,
}

impl Recorder {
    /// A recorder that keeps up to `capacity` samples.
    pub fn with_capacity(capacity: usize) -> Self {
        Self {
            samples: Vec::with_capacity(capacity),
            dropped: 0,
        }
    }

    /// Records one sample in ns.
    pub fn record(&mut self, ns: u64) {
        if self.samples.len() < self.samples.capacity() {
            self.samples.push(ns);
        } else {
            self.dropped += 1;
        }
    }

    /// Samples that did not fit.
    pub fn dropped(&self) -> u64 {
        self.dropped
    }

    /// The distribution of the samples kept.
    pub fn into_distribution(self) -> Distribution {
        Distribution::new(self.samples)
    }
}

/// The main figures of a distribution, in ns; `None` when there were no samples.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Summary {
    pub count: usize,
    pub p50: u64,
    pub p99: u64,
    pub p99_9: u64,
    pub max: u64,
}

/// Sorted samples (ns).
#[derive(Debug, Clone, Default)]
pub struct Distribution {
    sorted: Vec<u64>,
}

/// Percentile steps per halving of the distance to 100 % (HdrHistogram's usual 5).
const TICKS_PER_HALF_DISTANCE: u32 = 5;

impl Distribution {
    /// Sorts `samples`.
    pub fn new(mut samples: Vec<u64>) -> Self {
        samples.sort_unstable();
        Self { sorted: samples }
    }

    pub fn count(&self) -> usize {
        self.sorted.len()
    }

    /// The value at quantile `q` (0..=1) by nearest rank: the smallest sample such that at
    /// least `q` of all samples are at or below it. `None` without samples.
    pub fn quantile(&self, q: f64) -> Option<u64> {
        let n = self.sorted.len();
        if n == 0 {
            return None;
        }
        // Clamped to 1..=n, so the cast cannot truncate.
        let rank = (q.clamp(0.0, 1.0) * n as f64).ceil().clamp(1.0, n as f64) as usize;
        Some(self.sorted[rank - 1])
    }

    /// p50, p99, p99.9 and maximum; `None` without samples.
    pub fn summary(&self) -> Option<Summary> {
        Some(Summary {
            count: self.count(),
            p50: self.quantile(0.5)?,
            p99: self.quantile(0.99)?,
            p99_9: self.quantile(0.999)?,
            max: *self.sorted.last()?,
        })
    }

    /// Number of samples at or below `value`.
    fn count_up_to(&self, value: u64) -> usize {
        self.sorted.partition_point(|&s| s <= value)
    }

    fn mean_and_deviation(&self) -> (f64, f64) {
        let n = self.sorted.len().max(1) as f64;
        let mean = self.sorted.iter().map(|&s| s as f64).sum::<f64>() / n;
        let variance = self
            .sorted
            .iter()
            .map(|&s| (s as f64 - mean).powi(2))
            .sum::<f64>()
            / n;
        (mean, variance.sqrt())
    }

    /// The quantiles of the HdrHistogram percentile ladder: steps of 10 % up to 50 %, then
    /// each halving of the remaining distance to 100 % in five steps, until the last sample
    /// is reached; then 1.0.
    pub fn ladder(&self) -> Vec<f64> {
        let n = self.sorted.len();
        let mut ladder = Vec::new();
        if n == 0 {
            return ladder;
        }
        let last_below_max = (n as f64 - 1.0) / n as f64;
        // Level k covers [1 - 2^-k, 1 - 2^-(k+1)); each point is computed afresh rather than
        // accumulated, so rounding never skips a step. 2^-60 is far below any sample count.
        'levels: for k in 0..60 {
            let start = 1.0 - 0.5f64.powi(k);
            let step = 0.5f64.powi(k + 1) / f64::from(TICKS_PER_HALF_DISTANCE);
            for i in 0..TICKS_PER_HALF_DISTANCE {
                let q = start + f64::from(i) * step;
                if q > last_below_max {
                    break 'levels;
                }
                ladder.push(q);
            }
        }
        ladder.push(1.0);
        ladder
    }

    /// Appends the distribution in the `.hgrm` percentile format of HdrHistogram
    /// (`Value Percentile TotalCount 1/(1-Percentile)`), values in µs, after a `#` title line.
    pub fn write_hgrm(&self, title: &str, out: &mut String) {
        // Writing to a String cannot fail.
        let _ = writeln!(out, "# {title} (values in µs)");
        let _ = writeln!(
            out,
            "{:>12} {:>14} {:>10} {:>14}\n",
            "Value", "Percentile", "TotalCount", "1/(1-Percentile)"
        );
        for q in self.ladder() {
            let Some(value) = self.quantile(q) else {
                break;
            };
            let us = value as f64 / 1e3;
            let total = self.count_up_to(value);
            if q < 1.0 {
                let _ = writeln!(
                    out,
                    "{us:12.3} {q:2.12} {total:10} {:14.2}",
                    1.0 / (1.0 - q)
                );
            } else {
                let _ = writeln!(out, "{us:12.3} {q:2.12} {total:10}");
            }
        }
        let (mean, deviation) = self.mean_and_deviation();
        let max = self.sorted.last().copied().unwrap_or(0) as f64 / 1e3;
        let _ = writeln!(
            out,
            "#[Mean    = {:12.3}, StdDeviation   = {:12.3}]",
            mean / 1e3,
            deviation / 1e3
        );
        let _ = writeln!(
            out,
            "#[Max     = {max:12.3}, Total count    = {:12}]\n",
            self.count()
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn one_to(n: u64) -> Distribution {
        // Shuffled on purpose: the distribution must sort.
        Distribution::new((1..=n).rev().collect())
    }

    #[test]
    fn nearest_rank_percentiles_of_known_samples() {
        let d = one_to(1000);
        let s = d.summary().unwrap();
        assert_eq!(
            (s.count, s.p50, s.p99, s.p99_9, s.max),
            (1000, 500, 990, 999, 1000)
        );
        assert_eq!(d.quantile(0.0), Some(1));
        assert_eq!(d.quantile(1.0), Some(1000));
        let d = one_to(10);
        assert_eq!(d.quantile(0.5), Some(5));
        assert_eq!(d.quantile(0.51), Some(6));
        assert_eq!(d.quantile(0.999), Some(10));
    }

    #[test]
    fn no_samples_have_no_summary() {
        assert_eq!(Distribution::default().summary(), None);
        assert!(Distribution::default().ladder().is_empty());
    }

    #[test]
    fn a_full_recorder_counts_what_it_drops() {
        let mut r = Recorder::with_capacity(2);
        for v in [3, 1, 2] {
            r.record(v);
        }
        assert_eq!(r.dropped(), 1);
        assert_eq!(r.into_distribution().summary().unwrap().max, 3);
    }

    #[test]
    fn ladder_follows_the_hdrhistogram_steps() {
        let ladder = one_to(100_000).ladder();
        let percent: Vec<f64> = ladder.iter().take(13).map(|q| q * 100.0).collect();
        let expected = [
            0.0, 10.0, 20.0, 30.0, 40.0, 50.0, 55.0, 60.0, 65.0, 70.0, 75.0, 77.5, 80.0,
        ];
        for (got, want) in percent.iter().zip(expected) {
            assert!((got - want).abs() < 1e-9, "{percent:?}");
        }
        assert_eq!(ladder.last(), Some(&1.0));
    }

    #[test]
    fn hgrm_lines_hold_value_percentile_and_count() {
        let mut text = String::new();
        one_to(1000).write_hgrm("synthetic", &mut text);
        let rows: Vec<Vec<f64>> = text
            .lines()
            .filter(|l| !l.starts_with('#') && !l.trim().is_empty())
            .skip(1)
            .map(|l| l.split_whitespace().map(|v| v.parse().unwrap()).collect())
            .collect();
        // Values are 1..=1000 ns, printed in µs.
        assert_eq!(rows[0][..3], [0.001, 0.0, 1.0]);
        let median = rows.iter().find(|r| r[1] == 0.5).unwrap();
        assert_eq!(median[..4], [0.5, 0.5, 500.0, 2.0]);
        assert_eq!(rows.last().unwrap()[..], [1.0, 1.0, 1000.0]);
        assert!(text.contains("Total count    =         1000]"));
    }

    proptest! {
        #[test]
        fn percentiles_are_ordered_samples(samples in proptest::collection::vec(0u64..1_000_000, 1..500)) {
            let d = Distribution::new(samples.clone());
            let s = d.summary().unwrap();
            prop_assert!(s.p50 <= s.p99 && s.p99 <= s.p99_9 && s.p99_9 <= s.max);
            prop_assert_eq!(s.max, *samples.iter().max().unwrap());
            for q in d.ladder() {
                let v = d.quantile(q).unwrap();
                prop_assert!(samples.contains(&v));
                // At least q of the samples are at or below the value.
                prop_assert!(d.count_up_to(v) as f64 >= q * samples.len() as f64 - 1e-9);
            }
        }
    }
}
