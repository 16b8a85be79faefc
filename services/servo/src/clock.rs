//! The interpolation clock: a periodic timer on absolute CLOCK_MONOTONIC deadlines, so the
//! period never drifts with the time spent in a tick.

use std::io;

/// The monotonic clock could not sleep.
#[derive(Debug, thiserror::Error)]
pub enum ClockError {
    #[error("servo period must be > 0 ns")]
    ZeroPeriod,
    #[error("clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME) failed: {0}")]
    Sleep(io::Error),
}

pub use shared_types::time::monotonic_ns;

/// One tick of a [`PeriodicClock`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Tick {
    /// The deadline this tick was due at, CLOCK_MONOTONIC ns.
    pub deadline_ns: u64,
    /// Whole periods skipped because this tick started more than a period late.
    pub skipped: u64,
}

/// A periodic timer with absolute deadlines: `next += period`, and after an overrun the
/// missed periods are skipped (and counted) rather than run back to back.
#[derive(Debug)]
pub struct PeriodicClock {
    period_ns: u64,
    next_ns: u64,
    overruns: u64,
}

impl PeriodicClock {
    /// A clock whose first tick is one period from now.
    pub fn start(period_ns: u64) -> Result<Self, ClockError> {
        if period_ns == 0 {
            return Err(ClockError::ZeroPeriod);
        }
        Ok(Self {
            period_ns,
            next_ns: monotonic_ns().saturating_add(period_ns),
            overruns: 0,
        })
    }

    /// Sleeps until the next deadline and returns that tick.
    pub fn wait(&mut self) -> Result<Tick, ClockError> {
        let deadline_ns = self.next_ns;
        sleep_until(deadline_ns)?;
        let (next_ns, skipped) = next_deadline(deadline_ns, self.period_ns, monotonic_ns());
        self.next_ns = next_ns;
        self.overruns += skipped;
        Ok(Tick {
            deadline_ns,
            skipped,
        })
    }

    /// Periods skipped since the start.
    pub fn overruns(&self) -> u64 {
        self.overruns
    }
}

/// The deadline after `deadline` that still lies ahead of `now`, and how many whole periods
/// had to be skipped to get there.
fn next_deadline(deadline: u64, period: u64, now: u64) -> (u64, u64) {
    let next = deadline.saturating_add(period);
    if now < next {
        return (next, 0);
    }
    let skipped = (now - next) / period + 1;
    (next.saturating_add(skipped.saturating_mul(period)), skipped)
}

fn sleep_until(deadline_ns: u64) -> Result<(), ClockError> {
    let ts = libc::timespec {
        tv_sec: (deadline_ns / 1_000_000_000) as libc::time_t,
        tv_nsec: (deadline_ns % 1_000_000_000) as libc::c_long,
    };
    loop {
        // SAFETY: `ts` is a valid timespec; the remainder pointer may be null with
        // TIMER_ABSTIME.
        let rc = unsafe {
            libc::clock_nanosleep(
                libc::CLOCK_MONOTONIC,
                libc::TIMER_ABSTIME,
                &ts,
                core::ptr::null_mut(),
            )
        };
        match rc {
            0 => return Ok(()),
            // A signal woke us early; the absolute deadline makes the retry exact.
            libc::EINTR => continue,
            err => return Err(ClockError::Sleep(io::Error::from_raw_os_error(err))),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn on_time_ticks_advance_by_one_period() {
        assert_eq!(next_deadline(1_000, 100, 1_000), (1_100, 0));
        assert_eq!(next_deadline(1_000, 100, 1_099), (1_100, 0));
    }

    #[test]
    fn late_ticks_skip_whole_periods() {
        assert_eq!(next_deadline(1_000, 100, 1_100), (1_200, 1));
        assert_eq!(next_deadline(1_000, 100, 1_350), (1_400, 3));
    }

    #[test]
    fn the_clock_ticks_on_absolute_deadlines() {
        let period = 500_000;
        let mut clock = PeriodicClock::start(period).expect("clock");
        let first = clock.wait().expect("tick");
        let mut last = first;
        for _ in 0..20 {
            let t = clock.wait().expect("tick");
            assert_eq!((t.deadline_ns - first.deadline_ns) % period, 0);
            assert!(monotonic_ns() >= t.deadline_ns);
            last = t;
        }
        assert_eq!(
            last.deadline_ns - first.deadline_ns,
            (20 + clock.overruns() - last.skipped) * period
        );
    }

    #[test]
    fn zero_period_is_refused() {
        assert!(matches!(
            PeriodicClock::start(0),
            Err(ClockError::ZeroPeriod)
        ));
    }
}
