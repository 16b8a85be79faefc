//! The cycle counter of cyclic frames and the cycle time it counts.
//!
//! The counter is in units of 31.25 µs and advances by SendClockFactor × ReductionRatio per
//! frame (8 ms = 32 × 8 → +256). A consumer takes a frame only if the counter moved
//! forward by 1..=61440 units since the last one taken (older or repeated frames are stale).

use std::time::Duration;

/// Unit of the cycle counter and of the send clock.
pub const CYCLE_UNIT: Duration = Duration::from_nanos(31_250);
/// Largest forward step a consumer accepts (1.92 s).
const MAX_ADVANCE: u16 = 61_440;

/// SendClockFactor × ReductionRatio: the cycle of one IOCR.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CycleTiming {
    /// SendClockFactor (32 = 1 ms send clock).
    pub send_clock_factor: u16,
    /// ReductionRatio.
    pub reduction_ratio: u16,
}

impl CycleTiming {
    /// Counter units per frame, if the product fits the 16-bit counter's accepted window.
    pub fn step(self) -> Option<u16> {
        let units = u32::from(self.send_clock_factor) * u32::from(self.reduction_ratio);
        u16::try_from(units)
            .ok()
            .filter(|units| (1..=MAX_ADVANCE).contains(units))
    }

    /// The cycle time.
    pub fn cycle(self) -> Duration {
        CYCLE_UNIT * (u32::from(self.send_clock_factor) * u32::from(self.reduction_ratio))
    }
}

/// The cycle counter a provider sends.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CycleCounter {
    value: u16,
    step: u16,
}

impl CycleCounter {
    /// A counter starting at `start`, advancing by `step` units per frame.
    pub fn new(start: u16, step: u16) -> Self {
        Self { value: start, step }
    }

    /// The value of the current frame.
    pub fn value(self) -> u16 {
        self.value
    }

    /// Advances to the next frame (wrapping at 2^16).
    pub fn advance(&mut self) {
        self.value = self.value.wrapping_add(self.step);
    }
}

/// True when a consumer may take a frame with counter `now` after one with `previous`.
pub fn is_newer(previous: u16, now: u16) -> bool {
    (1..=MAX_ADVANCE).contains(&now.wrapping_sub(previous))
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn eight_ms_is_32_times_8_and_steps_256() {
        let timing = CycleTiming {
            send_clock_factor: 32,
            reduction_ratio: 8,
        };
        assert_eq!(timing.cycle(), Duration::from_millis(8));
        assert_eq!(timing.step(), Some(256));
        let s7 = CycleTiming {
            send_clock_factor: 32,
            reduction_ratio: 32,
        };
        assert_eq!(s7.cycle(), Duration::from_millis(32));
        let too_long = CycleTiming {
            send_clock_factor: 32,
            reduction_ratio: 2048,
        };
        assert_eq!(too_long.step(), None);
    }

    #[test]
    fn the_counter_wraps() {
        let mut counter = CycleCounter::new(0xff00, 256);
        counter.advance();
        assert_eq!(counter.value(), 0);
        counter.advance();
        assert_eq!(counter.value(), 0x0100);
    }

    #[test]
    fn stale_and_repeated_frames_are_not_newer() {
        assert!(is_newer(0x1c00, 0x1d00));
        assert!(is_newer(0xff00, 0x0000));
        assert!(!is_newer(0x1c00, 0x1c00));
        assert!(!is_newer(0x1d00, 0x1c00));
        assert!(is_newer(0, 61_440));
        assert!(!is_newer(0, 61_441));
    }

    proptest! {
        #[test]
        fn every_next_frame_is_newer(start in any::<u16>(), step in 1u16..=61_440) {
            let mut counter = CycleCounter::new(start, step);
            let previous = counter.value();
            counter.advance();
            prop_assert!(is_newer(previous, counter.value()));
            // Going back is stale unless the step is so large that the way back looks short.
            prop_assert_eq!(is_newer(counter.value(), previous), step >= 4096);
        }
    }
}
