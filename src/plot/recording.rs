//! What a run leaves for its plot: the arm's samples over time and the job state changes,
//! in memory reserved up front.
//!
//! Memory is bounded by decimation: the sample store is allocated once for `capacity`
//! samples (at the servo's 1 ms tick, [`super::recorder::SAMPLE_CAPACITY`] holds about a
//! minute at full rate). When it is full, every second sample is dropped and from then on a
//! sample is only kept when at least the new, doubled interval has passed since the last kept
//! one; a long run thus ends up with between half and all of the store, evenly spaced. Job
//! markers are few (two or three per move); beyond their capacity further ones are counted,
//! not kept.

use shared_types::ipc::AXES;

/// One kept sample of the arm.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sample {
    /// Seconds since the first sample of the run.
    pub t_s: f64,
    /// Actual joint positions (rad).
    pub q: [f64; AXES],
    /// Actual joint velocities (rad/s).
    pub qd: [f64; AXES],
    /// Speed of the TCP of the tool in use (m/s).
    pub tcp_speed: f64,
    /// Speed override in [0, 1].
    pub override_fraction: f64,
    /// The primary sequence is interrupted (GroupInterrupt, a lost PLC).
    pub interrupted: bool,
    /// Two moves are being blended.
    pub blending: bool,
}

/// The job states a plot marks.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum JobState {
    Active,
    Interrupted,
    Done,
    Aborted,
    Error,
}

impl JobState {
    /// The state of an SRCI CmdMessageState value, if the plot marks it.
    pub fn from_cmd_state(state: u8) -> Option<Self> {
        use shared_types::srci::message::state;
        match state {
            state::ACTIVE => Some(Self::Active),
            state::INTERRUPTED => Some(Self::Interrupted),
            state::DONE => Some(Self::Done),
            state::ABORTED => Some(Self::Aborted),
            state::ERROR => Some(Self::Error),
            _ => None,
        }
    }

    /// The SRCI name.
    pub fn name(self) -> &'static str {
        match self {
            Self::Active => "ACTIVE",
            Self::Interrupted => "INTERRUPTED",
            Self::Done => "DONE",
            Self::Aborted => "ABORTED",
            Self::Error => "ERROR",
        }
    }
}

/// A job reaching a state at a time.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JobMarker {
    /// Seconds since the first sample of the run.
    pub t_s: f64,
    pub job: u32,
    pub state: JobState,
}

/// The samples and job markers of one run, in storage reserved at creation.
#[derive(Debug, Clone)]
pub struct Recording {
    samples: Vec<Sample>,
    sample_capacity: usize,
    /// The newest sample offered if decimation did not keep it.
    pending: Option<Sample>,
    markers: Vec<JobMarker>,
    marker_capacity: usize,
    dropped_markers: u64,
    /// CLOCK_MONOTONIC time of the first sample, ns: the time origin.
    origin_ns: Option<u64>,
    /// Least time between two kept samples, s (0 until the store first filled).
    interval_s: f64,
}

impl Recording {
    /// An empty recording that keeps up to `samples` samples and `markers` markers.
    pub fn with_capacity(samples: usize, markers: usize) -> Self {
        // Room for at least two samples, so that halving always leaves a trace.
        let sample_capacity = samples.max(2);
        Self {
            samples: Vec::with_capacity(sample_capacity + 1),
            sample_capacity,
            pending: None,
            markers: Vec::with_capacity(markers),
            marker_capacity: markers,
            dropped_markers: 0,
            origin_ns: None,
            interval_s: 0.0,
        }
    }

    /// Seconds since the first sample for the monotonic time `time_ns`; the first call sets
    /// the origin.
    pub fn seconds_at(&mut self, time_ns: u64) -> f64 {
        let origin = *self.origin_ns.get_or_insert(time_ns);
        // Signed: a marker may carry a time a little before the first sample.
        (time_ns as i128 - origin as i128) as f64 / 1e9
    }

    /// Offers a sample; it is kept unless it follows the last kept one by less than the
    /// current decimation interval. Samples must come in time order.
    pub fn push_sample(&mut self, sample: Sample) {
        if self.samples.len() >= self.sample_capacity {
            self.halve();
        }
        let due = self.samples.last().is_none_or(|last| {
            // A little slack: tick times jitter around their nominal spacing.
            sample.t_s - last.t_s >= self.interval_s * 0.9
        });
        if due {
            self.samples.push(sample);
            self.pending = None;
        } else {
            self.pending = Some(sample);
        }
    }

    /// Keeps the newest sample offered if decimation left it out, so that the traces end
    /// where the run ended. Call once, when the run is over.
    pub fn finish(&mut self) {
        if let Some(sample) = self.pending.take() {
            // The store reserves one place beyond its capacity for this.
            self.samples.push(sample);
        }
    }

    /// Drops every second sample and doubles the interval between kept ones.
    fn halve(&mut self) {
        let n = self.samples.len();
        let span = match (self.samples.first(), self.samples.last()) {
            (Some(first), Some(last)) => last.t_s - first.t_s,
            _ => 0.0,
        };
        let mean_spacing = span / n.saturating_sub(1).max(1) as f64;
        self.interval_s = (2.0 * self.interval_s).max(2.0 * mean_spacing);
        let mut index = 0;
        self.samples.retain(|_| {
            index += 1;
            index % 2 == 1
        });
    }

    /// Records a job state change; beyond the capacity it is only counted.
    pub fn push_marker(&mut self, marker: JobMarker) {
        if self.markers.len() < self.marker_capacity {
            self.markers.push(marker);
        } else {
            self.dropped_markers += 1;
        }
    }

    /// The kept samples, in time order.
    pub fn samples(&self) -> &[Sample] {
        &self.samples
    }

    /// The kept job markers, in the order they happened.
    pub fn markers(&self) -> &[JobMarker] {
        &self.markers
    }

    /// Job markers beyond the capacity, not kept.
    pub fn dropped_markers(&self) -> u64 {
        self.dropped_markers
    }

    /// Least time between kept samples (0: every sample offered was kept).
    pub fn interval_s(&self) -> f64 {
        self.interval_s
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use proptest::prelude::*;

    /// A sample at `t_s` with every joint at `value` rad.
    pub(crate) fn sample(t_s: f64, value: f64) -> Sample {
        Sample {
            t_s,
            q: [value; AXES],
            qd: [0.0; AXES],
            tcp_speed: 0.0,
            override_fraction: 1.0,
            interrupted: false,
            blending: false,
        }
    }

    #[test]
    fn the_first_time_is_the_origin() {
        let mut r = Recording::with_capacity(4, 4);
        assert_eq!(r.seconds_at(5_000_000_000), 0.0);
        assert_eq!(r.seconds_at(5_500_000_000), 0.5);
        assert_eq!(r.seconds_at(4_000_000_000), -1.0);
    }

    #[test]
    fn a_full_store_halves_and_then_keeps_every_second_tick() {
        let mut r = Recording::with_capacity(8, 0);
        for i in 0..8 {
            r.push_sample(sample(f64::from(i) * 1e-3, 0.0));
        }
        assert_eq!(r.samples().len(), 8);
        assert_eq!(r.interval_s(), 0.0);
        r.push_sample(sample(8e-3, 0.0));
        let millis = |r: &Recording| -> Vec<f64> {
            r.samples().iter().map(|s| (s.t_s * 1e3).round()).collect()
        };
        assert_eq!(millis(&r), [0.0, 2.0, 4.0, 6.0, 8.0]);
        assert!((r.interval_s() - 2e-3).abs() < 1e-12);
        r.push_sample(sample(9e-3, 0.0));
        r.push_sample(sample(10e-3, 0.0));
        r.push_sample(sample(11e-3, 0.0));
        assert_eq!(millis(&r), [0.0, 2.0, 4.0, 6.0, 8.0, 10.0]);
        r.finish();
        assert_eq!(millis(&r), [0.0, 2.0, 4.0, 6.0, 8.0, 10.0, 11.0]);
    }

    #[test]
    fn markers_beyond_the_capacity_are_counted() {
        let mut r = Recording::with_capacity(2, 1);
        let marker = JobMarker {
            t_s: 0.0,
            job: 1,
            state: JobState::Active,
        };
        r.push_marker(marker);
        r.push_marker(marker);
        assert_eq!(r.markers().len(), 1);
        assert_eq!(r.dropped_markers(), 1);
    }

    #[test]
    fn job_states_follow_srci() {
        use shared_types::srci::message::state;
        assert_eq!(
            JobState::from_cmd_state(state::ACTIVE),
            Some(JobState::Active)
        );
        assert_eq!(JobState::from_cmd_state(state::DONE), Some(JobState::Done));
        assert_eq!(JobState::from_cmd_state(state::BUFFERED), None);
        assert_eq!(JobState::Aborted.name(), "ABORTED");
    }

    proptest! {
        #[test]
        fn storage_stays_bounded_ordered_and_keeps_the_newest(
            capacity in 2usize..64,
            count in 0usize..2000,
        ) {
            let mut r = Recording::with_capacity(capacity, 0);
            let reserved = r.samples.capacity();
            for i in 0..count {
                r.push_sample(sample(i as f64 * 1e-3, 0.0));
            }
            prop_assert!(r.samples().len() <= capacity);
            prop_assert_eq!(r.samples.capacity(), reserved, "no reallocation");
            prop_assert!(r.samples().windows(2).all(|w| w[0].t_s < w[1].t_s));
            if count >= capacity {
                prop_assert!(r.samples().len() >= capacity / 2);
            }
            r.finish();
            prop_assert!(r.samples().len() <= capacity + 1);
            prop_assert_eq!(r.samples.capacity(), reserved, "no reallocation");
            if count > 0 {
                prop_assert_eq!(r.samples()[0].t_s, 0.0);
                let newest = (count - 1) as f64 * 1e-3;
                prop_assert_eq!(r.samples().last().map(|s| s.t_s), Some(newest));
            }
        }
    }
}
