//! The SRCI reply time inside the PROFINET device, measured on the device's monotonic
//! clock and split in two: our processing (the PLC's output frame received → the
//! interpreter's answer to it at hand in the fieldbus process) and the wait for the cycle
//! (that answer → the next input frame sent, which carries it). A capture on the wire
//! sees only their sum plus the phase between the PLC's cycle and ours.
//!
//! Pure: times come in as arguments. The samples go into buffers allocated at start; a
//! full buffer drops further samples (counted) rather than allocating in data exchange.

/// The message of the log line with a session's [`Summary`] (its fields
/// `requests`, `processing_p50_us` .. `cycle_wait_max_us`); `rc bench latency` reads it.
pub const REPLY_TIMING_LOG: &str = "SRCI reply timing in the device";

/// Samples kept per quantity between two summaries: about two minutes at 8 ms.
const CAPACITY: usize = 16 * 1024;

/// p50, p99 and maximum of one quantity, in ns.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Figures {
    /// Median.
    pub p50: u64,
    /// 99th percentile.
    pub p99: u64,
    /// Maximum.
    pub max: u64,
}

/// What one AR's requests took in the device.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Summary {
    /// Requests whose answer went out in an input frame.
    pub requests: usize,
    /// Output frame received → answer at hand.
    pub processing: Figures,
    /// Answer at hand → the input frame carrying it sent.
    pub cycle_wait: Figures,
    /// Samples not kept because the buffers were full.
    pub dropped: u64,
}

/// The request and answer being timed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Pending {
    /// A request was handed to the interpreter.
    Request { counter: u64, received_ns: u64 },
    /// Its answer is at hand; the next input frame carries it.
    Answer { answered_ns: u64 },
}

/// The reply timing of the device's PLC sessions.
#[derive(Debug)]
pub struct ReplyTiming {
    pending: Option<Pending>,
    processing: Vec<u64>,
    cycle_wait: Vec<u64>,
    dropped: u64,
}

impl Default for ReplyTiming {
    fn default() -> Self {
        Self {
            pending: None,
            processing: Vec::with_capacity(CAPACITY),
            cycle_wait: Vec::with_capacity(CAPACITY),
            dropped: 0,
        }
    }
}

impl ReplyTiming {
    /// The PLC telegram `counter` (an output frame received at `received_ns`) went to the
    /// interpreter. A request still waiting for its answer is no longer timed: the PLC's
    /// cycle is shorter than our processing, and the newest request is the one answered.
    pub fn request(&mut self, counter: u64, received_ns: u64) {
        if matches!(self.pending, None | Some(Pending::Request { .. })) {
            self.pending = Some(Pending::Request {
                counter,
                received_ns,
            });
        }
    }

    /// The interpreter's answer to `counter` is at hand at `now_ns`.
    pub fn answer(&mut self, counter: u64, now_ns: u64) {
        if let Some(Pending::Request {
            counter: waiting,
            received_ns,
        }) = self.pending
            && waiting == counter
        {
            self.keep(Quantity::Processing, now_ns.saturating_sub(received_ns));
            self.pending = Some(Pending::Answer {
                answered_ns: now_ns,
            });
        }
    }

    /// An input frame went out at `now_ns` with the newest answer.
    pub fn input_sent(&mut self, now_ns: u64) {
        if let Some(Pending::Answer { answered_ns }) = self.pending {
            self.keep(Quantity::CycleWait, now_ns.saturating_sub(answered_ns));
            self.pending = None;
        }
    }

    /// The figures since the last summary (none when no request was answered), and a
    /// fresh start; called when an AR ends.
    pub fn summary(&mut self) -> Option<Summary> {
        self.pending = None;
        // A request whose answer never went out counts in neither quantity.
        self.processing.truncate(self.cycle_wait.len());
        let summary = figures(&mut self.processing)
            .zip(figures(&mut self.cycle_wait))
            .map(|(processing, cycle_wait)| Summary {
                requests: self.cycle_wait.len(),
                processing,
                cycle_wait,
                dropped: self.dropped,
            });
        self.processing.clear();
        self.cycle_wait.clear();
        self.dropped = 0;
        summary
    }

    fn keep(&mut self, quantity: Quantity, ns: u64) {
        let samples = match quantity {
            Quantity::Processing => &mut self.processing,
            Quantity::CycleWait => &mut self.cycle_wait,
        };
        if samples.len() < samples.capacity() {
            samples.push(ns);
        } else {
            self.dropped += 1;
        }
    }
}

#[derive(Debug, Clone, Copy)]
enum Quantity {
    Processing,
    CycleWait,
}

/// The figures of `samples` (sorted in place); `None` when there are none.
fn figures(samples: &mut [u64]) -> Option<Figures> {
    samples.sort_unstable();
    Some(Figures {
        p50: nearest_rank(samples, 0.5)?,
        p99: nearest_rank(samples, 0.99)?,
        max: *samples.last()?,
    })
}

/// The value at quantile `q` (0..=1) of `sorted` by nearest rank: the smallest sample such
/// that at least `q` of all samples are at or below it; `None` without samples. The rule
/// of `rc bench` (`Distribution::quantile` in `src/bench/stats.rs`), so that the device's
/// figures and the benchmark's compare.
fn nearest_rank(sorted: &[u64], q: f64) -> Option<u64> {
    let n = sorted.len();
    if n == 0 {
        return None;
    }
    // Clamped to 1..=n, so the cast cannot truncate.
    let rank = (q.clamp(0.0, 1.0) * n as f64).ceil().clamp(1.0, n as f64) as usize;
    Some(sorted[rank - 1])
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn processing_and_the_wait_for_the_cycle_are_timed_apart() {
        let mut timing = ReplyTiming::default();
        timing.request(1, 1_000);
        timing.answer(1, 1_300);
        timing.input_sent(5_000);
        timing.request(2, 9_000);
        timing.answer(2, 9_200);
        timing.input_sent(13_000);
        let summary = timing.summary().unwrap();
        assert_eq!(summary.requests, 2);
        assert_eq!(summary.processing.max, 300);
        // Nearest rank: the median of two samples is the smaller one.
        assert_eq!(summary.processing.p50, 200);
        assert_eq!(summary.cycle_wait.p50, 3_700);
        assert_eq!(summary.cycle_wait.max, 3_800);
        assert_eq!(timing.summary(), None);
    }

    #[test]
    fn only_the_answer_to_the_newest_request_counts() {
        let mut timing = ReplyTiming::default();
        timing.request(1, 1_000);
        timing.input_sent(2_000);
        timing.request(2, 3_000);
        // The answer to the older request, then one never sent before the AR ended.
        timing.answer(1, 3_100);
        timing.answer(2, 3_500);
        timing.input_sent(4_000);
        timing.request(3, 5_000);
        timing.answer(3, 5_100);
        let summary = timing.summary().unwrap();
        assert_eq!(summary.requests, 1);
        assert_eq!(summary.processing.max, 500);
        assert_eq!(summary.cycle_wait.max, 500);
    }

    #[test]
    fn a_full_buffer_drops_samples_without_growing() {
        let mut timing = ReplyTiming::default();
        for counter in 0..(CAPACITY as u64 + 10) {
            timing.request(counter, counter * 10);
            timing.answer(counter, counter * 10 + 1);
            timing.input_sent(counter * 10 + 2);
        }
        assert_eq!(timing.processing.capacity(), CAPACITY);
        let summary = timing.summary().unwrap();
        assert_eq!((summary.requests, summary.dropped), (CAPACITY, 20));
    }

    #[test]
    fn the_percentiles_are_by_nearest_rank() {
        // Rounding the index (samples[round((n - 1) q)]) would give 501 as p50 of 1..=1000
        // and the larger of two samples as their p50.
        let mut samples: Vec<u64> = (1..=1000).rev().collect();
        let figures = figures(&mut samples).unwrap();
        assert_eq!((figures.p50, figures.p99, figures.max), (500, 990, 1000));
        let figures = super::figures(&mut [7, 3]).unwrap();
        assert_eq!((figures.p50, figures.p99, figures.max), (3, 7, 7));
        let figures = super::figures(&mut [4]).unwrap();
        assert_eq!((figures.p50, figures.p99, figures.max), (4, 4, 4));
        assert_eq!(super::figures(&mut []), None);
    }

    proptest! {
        #[test]
        fn the_figures_are_ordered_nearest_ranks(
            samples in proptest::collection::vec(0u64..1_000_000, 1..200),
        ) {
            let mut sorted = samples.clone();
            let figures = figures(&mut sorted).unwrap();
            prop_assert!(figures.p50 <= figures.p99 && figures.p99 <= figures.max);
            prop_assert_eq!(figures.max, *samples.iter().max().unwrap());
            // At least q of the samples are at or below the value, fewer below it.
            let n = samples.len() as f64;
            for (q, value) in [(0.5, figures.p50), (0.99, figures.p99)] {
                let at_or_below = samples.iter().filter(|&&s| s <= value).count() as f64;
                let below = samples.iter().filter(|&&s| s < value).count() as f64;
                prop_assert!(at_or_below >= q * n && below < q * n);
            }
        }
    }
}
