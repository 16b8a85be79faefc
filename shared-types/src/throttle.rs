//! Rate limiting of a recurring warning, so a stalled interpreter costs one log line per
//! interval instead of one per telegram cycle.

/// Lets a warning through at most once per interval and counts the ones held back.
#[derive(Debug, Clone)]
pub struct WarnThrottle {
    interval_ns: u64,
    last_ns: Option<u64>,
    suppressed: u64,
}

impl WarnThrottle {
    pub fn new(interval_ns: u64) -> Self {
        Self {
            interval_ns,
            last_ns: None,
            suppressed: 0,
        }
    }

    /// Called for every occurrence at time `now_ns`: `Some(n)` means log now, `n` occurrences
    /// were held back since the last line; `None` means stay quiet.
    pub fn admit(&mut self, now_ns: u64) -> Option<u64> {
        match self.last_ns {
            Some(last) if now_ns.saturating_sub(last) < self.interval_ns => {
                self.suppressed += 1;
                None
            }
            _ => {
                self.last_ns = Some(now_ns);
                Some(core::mem::take(&mut self.suppressed))
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_line_per_interval_with_the_count_held_back() {
        let mut t = WarnThrottle::new(1_000);
        assert_eq!(t.admit(10), Some(0));
        assert_eq!(t.admit(20), None);
        assert_eq!(t.admit(1_009), None);
        assert_eq!(t.admit(1_010), Some(2));
        assert_eq!(t.admit(5_000), Some(0));
    }
}
