//! Holding the PLC over while the interpreter process is replaced.
//!
//! `rc restart interpreter` (or a systemd restart of that unit alone) stops the interpreter,
//! which leaves its SRCI session to the next process. Until that one listens, no one could
//! answer the PLC, whose lifesign supervision would end the session. The gateway answers
//! instead, as a PROFINET device keeps providing its last input data: the last reply again,
//! with the robot lifesign advanced in header and footer and nothing else changed (the same
//! ACK, so the PLC repeats its sequence until the new interpreter processes it). The hold-over
//! is bounded: beyond it the PLC is left unanswered and notices.

use shared_types::ipc::TELEGRAM_CAPACITY;
use shared_types::srci::telegram::{MIN_TELEGRAM_LEN, next_lifesign};

/// The last real reply and the hold-over in progress.
#[derive(Debug)]
pub struct HoldOver {
    last: [u8; TELEGRAM_CAPACITY],
    len: usize,
    /// When the hold-over began (CLOCK_MONOTONIC ns), if one runs.
    since_ns: Option<u64>,
    limit_ns: u64,
}

impl HoldOver {
    /// Hold-overs of at most `limit_ms` (0: never).
    pub fn new(limit_ms: u64) -> Self {
        Self {
            last: [0; TELEGRAM_CAPACITY],
            len: 0,
            since_ns: None,
            limit_ns: limit_ms.saturating_mul(1_000_000),
        }
    }

    /// A reply of the interpreter went to the PLC: the one to repeat, and any hold-over ends.
    pub fn remember(&mut self, reply: &[u8]) {
        let n = reply.len().min(TELEGRAM_CAPACITY);
        self.last[..n].copy_from_slice(&reply[..n]);
        self.len = n;
        self.since_ns = None;
    }

    /// The PLC connection changed, or the hold-over ran out: nothing to repeat any more.
    pub fn forget(&mut self) {
        self.len = 0;
        self.since_ns = None;
    }

    /// The interpreter announced its handover at `now_ns`: the hold-over begins.
    pub fn begin(&mut self, now_ns: u64) {
        self.since_ns = Some(now_ns);
    }

    /// Whether a hold-over runs.
    pub fn active(&self) -> bool {
        self.since_ns.is_some()
    }

    /// Whether the hold-over answers at `now_ns`: it runs, within its limit, with a reply to
    /// repeat.
    pub fn can_answer(&self, now_ns: u64) -> bool {
        self.len >= MIN_TELEGRAM_LEN
            && self
                .since_ns
                .is_some_and(|since| now_ns.saturating_sub(since) <= self.limit_ns)
    }

    /// The last reply with the lifesign advanced (header and footer), or `None` without a
    /// reply to repeat.
    pub fn answer(&mut self) -> Option<&[u8]> {
        if self.len < MIN_TELEGRAM_LEN {
            return None;
        }
        let last = self.len - 1;
        let lifesign = next_lifesign(self.last[1] >> 4);
        self.last[1] = (self.last[1] & 0x0F) | lifesign << 4;
        self.last[last] = (self.last[last] & 0x0F) | lifesign << 4;
        Some(&self.last[..self.len])
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use shared_types::srci::telegram::RobotHeader;

    fn reply(lifesign: u8) -> Vec<u8> {
        let mut t = vec![0u8; 64];
        t[1] = lifesign << 4 | 0x05;
        t[2] = 0xAB;
        t[63] = lifesign << 4;
        t
    }

    #[test]
    fn repeats_the_last_reply_with_a_live_lifesign_within_the_limit() {
        let mut h = HoldOver::new(100);
        h.remember(&reply(14));
        assert!(
            !h.can_answer(0),
            "only after the interpreter announced its handover"
        );
        h.begin(1_000);
        assert!(h.can_answer(1_000));
        let a = h.answer().unwrap().to_vec();
        assert_eq!(a[1] >> 4, 15);
        assert!(RobotHeader::is_consistent(&a));
        assert_eq!((a[1] & 0x0F, a[2]), (0x05, 0xAB), "the rest unchanged");
        let b = h.answer().unwrap().to_vec();
        assert_eq!(b[1] >> 4, 1, "15 wraps to 1");
        assert!(h.can_answer(1_000 + 100_000_000));
        assert!(!h.can_answer(1_000 + 100_000_001), "beyond the limit");
        // A real reply ends the hold-over.
        h.remember(&reply(3));
        assert!(!h.active());
        assert!(!h.can_answer(2_000));
    }

    #[test]
    fn off_with_a_zero_limit_and_after_the_link_changed() {
        let mut off = HoldOver::new(0);
        off.remember(&reply(1));
        off.begin(0);
        assert!(
            off.can_answer(0),
            "a zero limit still answers at the instant it began"
        );
        assert!(!off.can_answer(1));
        let mut h = HoldOver::new(100);
        h.remember(&reply(1));
        h.begin(0);
        h.forget();
        assert!(!h.can_answer(0));
        assert_eq!(h.answer(), None);
    }
}
