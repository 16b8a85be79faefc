//! Restart intensity: how many restarts the supervisor allows before it gives up on a service.
//!
//! Pure bookkeeping without clocks: the caller passes the time of each failure. The intensity
//! is counted over all services together (as in an Erlang supervisor), so services that crash
//! in turn cannot keep the controller cycling forever. Planned restarts are not counted.

use std::collections::VecDeque;
use std::time::{Duration, Instant};

/// What the supervisor does about a service that exited unexpectedly.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RestartDecision {
    /// Restart it; this is restart number `restarts_in_window` within the window.
    Restart { restarts_in_window: u32 },
    /// Too many failures within the window: do not restart it (hold in a safe stop).
    GiveUp { restarts_in_window: u32 },
}

/// Allows at most `max_restarts` restarts within any sliding `window`.
#[derive(Debug, Clone)]
pub struct RestartPolicy {
    max_restarts: u32,
    window: Duration,
    /// Times of the restarts still inside the window, oldest first.
    recent: VecDeque<Instant>,
}

impl RestartPolicy {
    /// A policy allowing `max_restarts` restarts within `window`.
    pub fn new(max_restarts: u32, window: Duration) -> Self {
        Self {
            max_restarts,
            window,
            recent: VecDeque::new(),
        }
    }

    /// Forgets the failures so far (after an operator's reset).
    pub fn reset(&mut self) {
        self.recent.clear();
    }

    /// Records a service failure at `now` and decides whether it may be restarted.
    pub fn on_exit(&mut self, now: Instant) -> RestartDecision {
        while let Some(&oldest) = self.recent.front() {
            if now.saturating_duration_since(oldest) >= self.window {
                self.recent.pop_front();
            } else {
                break;
            }
        }
        self.recent.push_back(now);
        let restarts_in_window = u32::try_from(self.recent.len()).unwrap_or(u32::MAX);
        if restarts_in_window > self.max_restarts {
            RestartDecision::GiveUp { restarts_in_window }
        } else {
            RestartDecision::Restart { restarts_in_window }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const WINDOW: Duration = Duration::from_secs(60);

    #[test]
    fn gives_up_on_the_restart_after_the_allowed_ones() {
        let t0 = Instant::now();
        let mut policy = RestartPolicy::new(3, WINDOW);
        for n in 1..=3 {
            assert_eq!(
                policy.on_exit(t0 + Duration::from_secs(n.into())),
                RestartDecision::Restart {
                    restarts_in_window: n
                }
            );
        }
        assert_eq!(
            policy.on_exit(t0 + Duration::from_secs(4)),
            RestartDecision::GiveUp {
                restarts_in_window: 4
            }
        );
    }

    #[test]
    fn restarts_older_than_the_window_are_forgotten() {
        let t0 = Instant::now();
        let mut policy = RestartPolicy::new(2, WINDOW);
        assert!(matches!(
            policy.on_exit(t0),
            RestartDecision::Restart { .. }
        ));
        assert!(matches!(
            policy.on_exit(t0 + Duration::from_secs(30)),
            RestartDecision::Restart { .. }
        ));
        // The first restart leaves the window exactly at t0 + 60 s.
        assert_eq!(
            policy.on_exit(t0 + WINDOW),
            RestartDecision::Restart {
                restarts_in_window: 2
            }
        );
        assert_eq!(
            policy.on_exit(t0 + WINDOW + Duration::from_secs(1)),
            RestartDecision::GiveUp {
                restarts_in_window: 3
            }
        );
        // Long after, a single crash is fine again.
        assert_eq!(
            policy.on_exit(t0 + Duration::from_secs(600)),
            RestartDecision::Restart {
                restarts_in_window: 1
            }
        );
    }

    #[test]
    fn a_reset_forgets_the_failures() {
        let t0 = Instant::now();
        let mut policy = RestartPolicy::new(1, WINDOW);
        policy.on_exit(t0);
        assert!(matches!(policy.on_exit(t0), RestartDecision::GiveUp { .. }));
        policy.reset();
        assert_eq!(
            policy.on_exit(t0),
            RestartDecision::Restart {
                restarts_in_window: 1
            }
        );
    }

    #[test]
    fn zero_allowed_restarts_gives_up_at_once() {
        let mut policy = RestartPolicy::new(0, WINDOW);
        assert_eq!(
            policy.on_exit(Instant::now()),
            RestartDecision::GiveUp {
                restarts_in_window: 1
            }
        );
    }
}
