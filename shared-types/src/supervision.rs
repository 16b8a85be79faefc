//! systemd integration of a service process: the start-up notification and the watchdog.
//!
//! Under a `Type=notify` unit the service calls [`ready`] once its ports exist. With
//! `WatchdogSec=`, [`Watchdog::start`] runs a normal-priority thread that pings systemd at half
//! the interval, but only while the service loop's heartbeat ([`beat`], once per cycle)
//! advances: a stuck loop stops the pings and systemd restarts the unit. Without systemd
//! (`rc run`, tests) both do nothing.
//!
//! The notifications allocate and make system calls, so they are sent only from start-up code
//! and from the watchdog thread; the loop itself only bumps an atomic counter.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use sd_notify::NotifyState;

/// Environment variable the orchestrator sets (to `standby`) on the successor of a service
/// that hands its state over (the interpreter): the process starts, beats, and waits for
/// its predecessor's state before it serves.
pub const HANDOVER_ENV: &str = "RC_HANDOVER";

/// Cycles of the process's service loop. One per process, as the systemd watchdog it feeds
/// supervises the process; a global lets each loop beat without passing a handle through
/// every service's `run`.
static HEARTBEAT: AtomicU64 = AtomicU64::new(0);

/// Marks one cycle of the service loop: a relaxed atomic add, real-time safe.
#[inline]
pub fn beat() {
    HEARTBEAT.fetch_add(1, Ordering::Relaxed);
}

/// Tells systemd that the service has started (READY=1), if it runs under a `Type=notify` unit
/// (NOTIFY_SOCKET set); otherwise does nothing. Call once, after the ports exist.
///
/// A failure is logged, not returned: the service works without it, and systemd, which then
/// never hears READY=1, fails the start after TimeoutStartSec= and restarts the unit.
pub fn ready() {
    if let Err(e) = sd_notify::notify(&[NotifyState::Ready]) {
        tracing::warn!(error = %e, "cannot tell systemd that the service is ready (READY=1)");
    }
}

/// The watchdog thread could not be started.
#[derive(Debug, thiserror::Error)]
#[error("cannot start the systemd watchdog thread: {0}")]
pub struct WatchdogError(#[from] std::io::Error);

/// Whether the service loop made progress between two watchdog checks.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Verdict {
    /// The loop has not beaten yet (still starting up): no ping. systemd enforces the
    /// watchdog only after READY=1, and TimeoutStartSec= covers the start-up.
    NotStarted,
    /// Progress since the last check: ping.
    Alive,
    /// Progress again after a stall: ping, and say so.
    Recovered,
    /// The first check without progress: withhold the ping, and say so.
    Stalled,
    /// Still no progress: withhold the ping.
    StillStalled,
}

impl Verdict {
    /// True when systemd is to be pinged.
    pub fn pings(self) -> bool {
        matches!(self, Verdict::Alive | Verdict::Recovered)
    }
}

/// Compares each heartbeat count with the previous one: the pure core of the watchdog thread.
#[derive(Debug, Clone)]
pub struct ProgressCheck {
    last_beats: u64,
    started: bool,
    stalled: bool,
}

impl ProgressCheck {
    /// Starts from the heartbeat count `beats` as it is now.
    pub fn new(beats: u64) -> Self {
        Self {
            last_beats: beats,
            started: false,
            stalled: false,
        }
    }

    /// One check with the heartbeat count `beats` as it is now.
    pub fn check(&mut self, beats: u64) -> Verdict {
        let advanced = beats != self.last_beats;
        self.last_beats = beats;
        let verdict = match (advanced, self.started, self.stalled) {
            (true, _, true) => Verdict::Recovered,
            (true, _, false) => Verdict::Alive,
            (false, false, _) => Verdict::NotStarted,
            (false, true, false) => Verdict::Stalled,
            (false, true, true) => Verdict::StillStalled,
        };
        self.started |= advanced;
        self.stalled = self.started && !advanced;
        verdict
    }
}

/// The running watchdog thread; dropping it stops the pings.
#[derive(Debug)]
pub struct Watchdog {
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
}

impl Watchdog {
    /// Starts pinging systemd if its unit has `WatchdogSec=` (WATCHDOG_USEC set for this
    /// process); `None` otherwise.
    ///
    /// Start it before the real-time settings are applied: a thread inherits its creator's
    /// scheduling policy and CPU, and this one must stay at normal priority.
    pub fn start() -> Result<Option<Watchdog>, WatchdogError> {
        let Some(interval) = sd_notify::watchdog_enabled() else {
            return Ok(None);
        };
        let period = interval / 2;
        let stop = Arc::new(AtomicBool::new(false));
        let thread = {
            let stop = Arc::clone(&stop);
            std::thread::Builder::new()
                .name("watchdog".into())
                .spawn(move || ping_while_alive(period, &stop))?
        };
        tracing::info!(
            interval_ms = interval.as_millis() as u64,
            "systemd watchdog: pinging while the service loop makes progress"
        );
        Ok(Some(Watchdog {
            stop,
            thread: Some(thread),
        }))
    }
}

impl Drop for Watchdog {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(thread) = self.thread.take() {
            thread.thread().unpark();
            // A panic in the thread has already been reported by the panic hook.
            let _ = thread.join();
        }
    }
}

/// The watchdog thread: every `period`, pings systemd if the heartbeat advanced.
fn ping_while_alive(period: Duration, stop: &AtomicBool) {
    let mut progress = ProgressCheck::new(HEARTBEAT.load(Ordering::Relaxed));
    while sleep_unless_stopped(period, stop) {
        let verdict = progress.check(HEARTBEAT.load(Ordering::Relaxed));
        match verdict {
            Verdict::Stalled => tracing::error!(
                period_ms = period.as_millis() as u64,
                "service loop made no progress: withholding the watchdog ping, systemd will \
                 restart the service"
            ),
            Verdict::Recovered => {
                tracing::warn!("service loop progressing again: watchdog pings resumed")
            }
            Verdict::NotStarted | Verdict::Alive | Verdict::StillStalled => {}
        }
        if verdict.pings()
            && let Err(e) = sd_notify::notify(&[NotifyState::Watchdog])
        {
            tracing::warn!(error = %e, "cannot ping the systemd watchdog (WATCHDOG=1)");
        }
    }
}

/// Sleeps for `period`; false as soon as `stop` is set (the owner unparks the thread).
fn sleep_unless_stopped(period: Duration, stop: &AtomicBool) -> bool {
    let deadline = Instant::now() + period;
    loop {
        if stop.load(Ordering::Relaxed) {
            return false;
        }
        let now = Instant::now();
        if now >= deadline {
            return true;
        }
        // Spurious wake-ups only loop once more.
        std::thread::park_timeout(deadline - now);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn no_pings_before_the_first_beat_then_only_while_beating() {
        let mut check = ProgressCheck::new(7);
        assert_eq!(check.check(7), Verdict::NotStarted);
        assert_eq!(check.check(7), Verdict::NotStarted);
        assert_eq!(check.check(9), Verdict::Alive);
        assert_eq!(check.check(12), Verdict::Alive);
        assert_eq!(check.check(12), Verdict::Stalled);
        assert_eq!(check.check(12), Verdict::StillStalled);
        assert_eq!(check.check(13), Verdict::Recovered);
        assert_eq!(check.check(14), Verdict::Alive);
        assert_eq!(check.check(14), Verdict::Stalled);
    }

    #[test]
    fn only_alive_and_recovered_ping() {
        assert!(Verdict::Alive.pings() && Verdict::Recovered.pings());
        assert!(!Verdict::NotStarted.pings());
        assert!(!Verdict::Stalled.pings() && !Verdict::StillStalled.pings());
    }

    proptest! {
        /// A ping is sent exactly when the count changed since the previous check, and a
        /// stall is reported once per stall.
        #[test]
        fn pings_exactly_when_the_heartbeat_advanced(
            start in any::<u64>(),
            steps in proptest::collection::vec(0u64..3, 0..64),
        ) {
            let mut check = ProgressCheck::new(start);
            let mut beats = start;
            let mut ever_advanced = false;
            let mut previous = Verdict::NotStarted;
            for step in steps {
                beats = beats.wrapping_add(step);
                let verdict = check.check(beats);
                ever_advanced |= step > 0;
                prop_assert_eq!(verdict.pings(), step > 0);
                prop_assert_eq!(verdict == Verdict::NotStarted, !ever_advanced);
                if verdict == Verdict::Stalled {
                    prop_assert!(previous.pings());
                }
                previous = verdict;
            }
        }
    }
}
