//! The spread of Identify responses over the ResponseDelay a controller allows.
//!
//! A controller that identifies all devices at once asks them to spread their answers over
//! `ResponseDelayFactor × 10 ms`, so that its switch port is not flooded. Each device waits
//! `(random mod factor) × 10 ms`; factor 0 or 1, or one above 6400, means "answer at once".

use std::time::Duration;

use crate::ethernet::MacAddress;

/// Unit of the ResponseDelayFactor.
const DELAY_UNIT: Duration = Duration::from_millis(10);
/// Largest factor that spreads (64 s).
const MAX_SPREAD_FACTOR: u16 = 6400;

/// A small pseudo-random sequence for the spread: devices must differ, not be secret, so a
/// xorshift seeded from the MAC address serves.
#[derive(Debug, Clone)]
pub struct ResponseSpread {
    state: u32,
}

impl ResponseSpread {
    /// A sequence seeded from the device's MAC address (never the zero state).
    pub fn new(mac: MacAddress) -> Self {
        let [a, b, c, d, e, f] = mac.0;
        let seed =
            u32::from_be_bytes([c, d, e, f]) ^ u32::from_be_bytes([0, 0, a, b]).rotate_left(16);
        Self {
            state: if seed == 0 { 0x9e37_79b9 } else { seed },
        }
    }

    /// How long to wait before answering an Identify with this ResponseDelayFactor.
    pub fn delay(&mut self, factor: u16) -> Duration {
        if factor <= 1 || factor > MAX_SPREAD_FACTOR {
            return Duration::ZERO;
        }
        DELAY_UNIT * (self.next() % u32::from(factor))
    }

    fn next(&mut self) -> u32 {
        let mut x = self.state;
        x ^= x << 13;
        x ^= x >> 17;
        x ^= x << 5;
        self.state = x;
        x
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn factors_that_do_not_spread_answer_at_once() {
        let mut spread = ResponseSpread::new(MacAddress([2, 0, 0, 0, 0, 1]));
        for factor in [0, 1, 6401, u16::MAX] {
            assert_eq!(spread.delay(factor), Duration::ZERO);
        }
    }

    #[test]
    fn devices_with_different_macs_spread_differently() {
        let mut a = ResponseSpread::new(MacAddress([2, 0, 0, 0, 0, 1]));
        let mut b = ResponseSpread::new(MacAddress([2, 0, 0, 0, 0, 2]));
        let first: Vec<Duration> = (0..8).map(|_| a.delay(128)).collect();
        let second: Vec<Duration> = (0..8).map(|_| b.delay(128)).collect();
        assert_ne!(first, second);
        assert!(first.iter().any(|d| !d.is_zero()));
    }

    proptest! {
        #[test]
        fn the_delay_stays_below_the_factor(mac in any::<[u8; 6]>(), factor in 2u16..=6400) {
            let mut spread = ResponseSpread::new(MacAddress(mac));
            for _ in 0..4 {
                let delay = spread.delay(factor);
                prop_assert!(delay <= DELAY_UNIT * u32::from(factor - 1));
                prop_assert_eq!(delay.as_nanos() % DELAY_UNIT.as_nanos(), 0);
            }
        }
    }
}
