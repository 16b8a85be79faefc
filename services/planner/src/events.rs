//! The job events of the planner status, paced for a reader that samples the status.
//!
//! The status carries only the last [`JOB_EVENTS`] events, and the interpreter reads the
//! newest status once per telegram cycle. A burst larger than the ring (a GroupStop with a
//! full queue ends every buffered move at once) would overwrite events before they are read.
//! So events wait in a FIFO and enter the ring through a token bucket: at most
//! [`BURST`] at once and [`RATE_PER_S`] on average, so a reader that looks at least every
//! `(JOB_EVENTS − BURST) / RATE_PER_S` (16 ms) sees every event.

use shared_types::ipc::{JOB_EVENTS, JobEvent, MotionStatus, RefusalReason};
use shared_types::srci::message::state;

/// Events that may enter the status ring in one go.
pub const BURST: usize = JOB_EVENTS / 2;
/// Events per second that may enter the status ring on average.
pub const RATE_PER_S: f64 = 1000.0;

/// Job events waiting for the status ring.
#[derive(Debug)]
pub struct EventLog {
    pending: Box<[JobEvent]>,
    head: usize,
    len: usize,
    tokens: f64,
    dropped: u64,
}

impl EventLog {
    /// Room for `capacity` waiting events (at least one).
    pub fn with_capacity(capacity: usize) -> Self {
        Self {
            pending: vec![JobEvent::default(); capacity.max(1)].into_boxed_slice(),
            head: 0,
            len: 0,
            tokens: BURST as f64,
            dropped: 0,
        }
    }

    /// Queues a state change of `job`; it gets its number when it enters the ring.
    pub fn push(&mut self, job: u32, state: u8, code: u16) {
        self.queue(job, state, code, RefusalReason::None);
    }

    /// Queues the refusal of `job` with `code` (ERROR) and why.
    pub fn refuse(&mut self, job: u32, code: u16, reason: RefusalReason) {
        self.queue(job, state::ERROR, code, reason);
    }

    fn queue(&mut self, job: u32, state: u8, code: u16, reason: RefusalReason) {
        if self.len == self.pending.len() {
            self.dropped += 1;
            return;
        }
        let tail = (self.head + self.len) % self.pending.len();
        self.pending[tail] = JobEvent {
            number: 0,
            job,
            state,
            reason: reason as u8,
            code,
        };
        self.len += 1;
    }

    /// Events lost because more were waiting than there was room for.
    pub fn dropped(&self) -> u64 {
        self.dropped
    }

    /// Moves the waiting events that the pacing allows after `dt` seconds into `status`,
    /// numbered on from `status.event_head`.
    pub fn publish(&mut self, status: &mut MotionStatus, dt: f64) {
        self.tokens = (self.tokens + RATE_PER_S * dt).min(BURST as f64);
        while self.len > 0 && self.tokens >= 1.0 {
            let mut event = self.pending[self.head];
            self.head = (self.head + 1) % self.pending.len();
            self.len -= 1;
            self.tokens -= 1.0;
            event.number = status.event_head + 1;
            status.events[(event.number % JOB_EVENTS as u64) as usize] = event;
            status.event_head = event.number;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_burst_is_paced_and_a_slow_reader_still_sees_every_event() {
        let mut log = EventLog::with_capacity(300);
        let mut s = MotionStatus::initial(1, 1.0);
        for job in 1..=200 {
            log.push(job, 14, 0x6C05);
        }
        // A reader that looks every 16 ticks of 1 ms.
        let mut seen = 0;
        let mut jobs = Vec::new();
        for tick in 1..=400 {
            log.publish(&mut s, 1e-3);
            if tick % 16 == 0 {
                assert!(s.event_head - seen <= JOB_EVENTS as u64, "overwritten");
                for n in seen + 1..=s.event_head {
                    let e = s.events[(n % JOB_EVENTS as u64) as usize];
                    assert_eq!(e.number, n);
                    jobs.push(e.job);
                }
                seen = s.event_head;
            }
        }
        assert_eq!(jobs, (1..=200).collect::<Vec<_>>());
        assert_eq!(log.dropped(), 0);
    }

    #[test]
    fn small_bursts_enter_the_ring_at_once_and_overflow_is_counted() {
        let mut log = EventLog::with_capacity(2);
        let mut s = MotionStatus::initial(1, 1.0);
        log.push(1, 2, 0);
        log.push(1, 4, 0);
        log.push(1, 10, 0);
        assert_eq!(log.dropped(), 1);
        log.publish(&mut s, 1e-3);
        assert_eq!(s.event_head, 2);
        assert_eq!((s.events[1].state, s.events[2].state), (2, 4));
    }
}
