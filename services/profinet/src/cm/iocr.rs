//! Whether this device can serve an IOCR as the controller asks for it, and with which
//! FrameID and times.
//!
//! Both connection styles are accepted: RTClass 2 with FrameIDs 0x8000.. (S7-1500) and
//! RTClass 1 with 0xC000.. (legacy controllers, profinet-py). An output CR whose FrameID is
//! 0xFFFF gets one chosen here, from the range of its class.

use std::time::Duration;

use pnio::cm::block::IocrBlockReq;

use super::connect::{IOCR_TYPE_INPUT, IOCR_TYPE_OUTPUT, rt_class};
use crate::ethernet::{ETHER_TYPE_PROFINET, VlanTag};
use crate::frame_id::{DEVICE_CHOOSES, RtClass};
use crate::rt::cycle_counter::CycleTiming;
use crate::rt::frame::{MAX_C_SDU_LEN, MIN_C_SDU_LEN};

/// Shortest cycle this device serves, in 31.25 µs units (1 ms; the GSDML's MinDeviceInterval).
pub const MIN_DEVICE_INTERVAL: u32 = 32;
/// Largest watchdog and data-hold factor.
const MAX_FACTOR: u16 = 0x1e00;
/// Longest data-hold time: 1.92 s.
const MAX_DATA_HOLD: Duration = Duration::from_millis(1920);
/// Largest ReductionRatio of RT classes 1 and 2.
const MAX_REDUCTION_RATIO: u16 = 512;
/// Largest SendClockFactor.
const MAX_SEND_CLOCK_FACTOR: u16 = 128;

/// The field of the IOCRBlockReq that this device cannot serve.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum IocrRefusal {
    /// Neither an input nor an output CR.
    #[error("IOCRType {0} (1 input, 2 output)")]
    IocrType(u16),
    /// Not RT over Ethernet (EtherType 0x8892).
    #[error("LT {0:#06x} (0x8892 expected)")]
    Lt(u16),
    /// An RT class other than 1 or 2.
    #[error("IOCRProperties {0:#010x}: only RTClass 1 and 2 are served")]
    RtClass(u32),
    /// DataLength outside 40..=1440.
    #[error("DataLength {0} (40..=1440)")]
    DataLength(u16),
    /// A FrameID outside the range of its RT class.
    #[error("FrameID {frame_id:#06x} is not in the range of RT class {class:?}")]
    FrameId {
        /// The FrameID.
        frame_id: u16,
        /// The RT class asked for.
        class: RtClass,
    },
    /// A SendClockFactor outside 1..=128.
    #[error("SendClockFactor {0} (1..=128)")]
    SendClockFactor(u16),
    /// A ReductionRatio that is not a power of two up to 512.
    #[error("ReductionRatio {0} (a power of two, 1..=512)")]
    ReductionRatio(u16),
    /// A cycle shorter than this device serves.
    #[error("cycle of {units} × 31.25 µs is shorter than the device's {MIN_DEVICE_INTERVAL}")]
    Cycle {
        /// SendClockFactor × ReductionRatio.
        units: u32,
    },
    /// A WatchdogFactor outside 1..=0x1E00.
    #[error("WatchdogFactor {0} (1..=7680)")]
    WatchdogFactor(u16),
    /// A DataHoldFactor outside 1..=0x1E00, or a data-hold time above 1.92 s.
    #[error("DataHoldFactor {0} (1..=7680, at most 1.92 s)")]
    DataHoldFactor(u16),
    /// A VLAN tag other than priority 6, VLAN 0.
    #[error("IOCRTagHeader {0:#06x} (priority 6, VLAN 0 expected)")]
    TagHeader(u16),
}

/// An IOCR the device serves.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct AcceptedIocr {
    /// The RT class.
    pub rt_class: RtClass,
    /// The FrameID to use (chosen here for an output CR that asked the device to).
    pub frame_id: u16,
    /// Send clock and reduction ratio.
    pub timing: CycleTiming,
    /// The consumer's watchdog time.
    pub watchdog: Duration,
    /// How long a consumer holds the last good data before the AR is aborted.
    pub data_hold: Duration,
}

/// Checks `iocr`; `taken` are the FrameIDs already in use (the other CRs of the AR), from
/// which a FrameID chosen here must differ.
pub fn accept_iocr(iocr: &IocrBlockReq, taken: &[u16]) -> Result<AcceptedIocr, IocrRefusal> {
    if iocr.iocr_type != IOCR_TYPE_INPUT && iocr.iocr_type != IOCR_TYPE_OUTPUT {
        return Err(IocrRefusal::IocrType(iocr.iocr_type));
    }
    if iocr.lt != ETHER_TYPE_PROFINET {
        return Err(IocrRefusal::Lt(iocr.lt));
    }
    let class = rt_class(iocr).ok_or(IocrRefusal::RtClass(iocr.properties))?;
    if !(MIN_C_SDU_LEN..=MAX_C_SDU_LEN).contains(&usize::from(iocr.data_length)) {
        return Err(IocrRefusal::DataLength(iocr.data_length));
    }
    let frame_id = if iocr.iocr_type == IOCR_TYPE_OUTPUT && iocr.frame_id == DEVICE_CHOOSES {
        class
            .unicast_frame_ids()
            .find(|id| !taken.contains(id))
            .ok_or(IocrRefusal::FrameId {
                frame_id: iocr.frame_id,
                class,
            })?
    } else if class.accepts(iocr.frame_id) {
        iocr.frame_id
    } else {
        return Err(IocrRefusal::FrameId {
            frame_id: iocr.frame_id,
            class,
        });
    };
    if !(1..=MAX_SEND_CLOCK_FACTOR).contains(&iocr.send_clock_factor) {
        return Err(IocrRefusal::SendClockFactor(iocr.send_clock_factor));
    }
    let ratio = iocr.reduction_ratio;
    if !ratio.is_power_of_two() || ratio > MAX_REDUCTION_RATIO {
        return Err(IocrRefusal::ReductionRatio(ratio));
    }
    let timing = CycleTiming {
        send_clock_factor: iocr.send_clock_factor,
        reduction_ratio: ratio,
    };
    let units = u32::from(iocr.send_clock_factor) * u32::from(ratio);
    if units < MIN_DEVICE_INTERVAL {
        return Err(IocrRefusal::Cycle { units });
    }
    if !(1..=MAX_FACTOR).contains(&iocr.watchdog_factor) {
        return Err(IocrRefusal::WatchdogFactor(iocr.watchdog_factor));
    }
    let data_hold = timing.cycle() * u32::from(iocr.data_hold_factor);
    if !(1..=MAX_FACTOR).contains(&iocr.data_hold_factor) || data_hold > MAX_DATA_HOLD {
        return Err(IocrRefusal::DataHoldFactor(iocr.data_hold_factor));
    }
    if VlanTag::from_tci(iocr.tag_header) != VlanTag::RT {
        return Err(IocrRefusal::TagHeader(iocr.tag_header));
    }
    Ok(AcceptedIocr {
        rt_class: class,
        frame_id,
        timing,
        watchdog: timing.cycle() * u32::from(iocr.watchdog_factor),
        data_hold,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cm::connect::ConnectRequest;
    use crate::testdata;
    use proptest::prelude::*;

    fn golden() -> ConnectRequest {
        ConnectRequest::parse(&testdata::frame("connect_req")[42..]).unwrap()
    }

    /// An output CR as profinet-py asks for it at 8 ms: RTClass 1, FrameID 0xFFFF,
    /// watchdog and data-hold factor 6.
    fn legacy_output() -> IocrBlockReq {
        let mut iocr = golden().iocr(IOCR_TYPE_OUTPUT).unwrap().clone();
        iocr.properties = 1;
        iocr.frame_id = DEVICE_CHOOSES;
        iocr.reduction_ratio = 8;
        iocr.watchdog_factor = 6;
        iocr.data_hold_factor = 6;
        iocr
    }

    #[test]
    fn the_golden_s7_iocrs_are_served_as_asked() {
        let connect = golden();
        let input = accept_iocr(connect.iocr(IOCR_TYPE_INPUT).unwrap(), &[]).unwrap();
        let output = accept_iocr(connect.iocr(IOCR_TYPE_OUTPUT).unwrap(), &[0x8000]).unwrap();
        assert_eq!((input.rt_class, input.frame_id), (RtClass::Two, 0x8000));
        assert_eq!((output.rt_class, output.frame_id), (RtClass::Two, 0x8001));
        assert_eq!(input.timing.cycle(), Duration::from_millis(32));
        assert_eq!(input.watchdog, Duration::from_millis(96));
        assert_eq!(input.data_hold, Duration::from_millis(96));
    }

    #[test]
    fn a_legacy_output_cr_gets_a_free_rt_class_1_frame_id() {
        let accepted = accept_iocr(&legacy_output(), &[0xc001]).unwrap();
        assert_eq!(accepted.rt_class, RtClass::One);
        assert_eq!(accepted.frame_id, 0xc000);
        let accepted = accept_iocr(&legacy_output(), &[0xc000, 0xc001]).unwrap();
        assert_eq!(accepted.frame_id, 0xc002);
        assert_eq!(accepted.timing.cycle(), Duration::from_millis(8));
        assert_eq!(accepted.data_hold, Duration::from_millis(48));
    }

    #[test]
    fn each_unserviceable_field_is_named() {
        let base = legacy_output();
        let refused = |change: &dyn Fn(&mut IocrBlockReq)| {
            let mut iocr = base.clone();
            change(&mut iocr);
            accept_iocr(&iocr, &[]).unwrap_err()
        };
        assert_eq!(refused(&|i| i.iocr_type = 3), IocrRefusal::IocrType(3));
        assert_eq!(refused(&|i| i.lt = 0x0800), IocrRefusal::Lt(0x0800));
        assert_eq!(refused(&|i| i.properties = 3), IocrRefusal::RtClass(3));
        assert_eq!(
            refused(&|i| i.data_length = 39),
            IocrRefusal::DataLength(39)
        );
        assert_eq!(
            refused(&|i| i.frame_id = 0x8001),
            IocrRefusal::FrameId {
                frame_id: 0x8001,
                class: RtClass::One
            }
        );
        assert_eq!(
            refused(&|i| {
                i.iocr_type = IOCR_TYPE_INPUT;
            }),
            IocrRefusal::FrameId {
                frame_id: DEVICE_CHOOSES,
                class: RtClass::One
            }
        );
        assert_eq!(
            refused(&|i| i.send_clock_factor = 0),
            IocrRefusal::SendClockFactor(0)
        );
        assert_eq!(
            refused(&|i| i.reduction_ratio = 3),
            IocrRefusal::ReductionRatio(3)
        );
        assert_eq!(
            refused(&|i| i.reduction_ratio = 1024),
            IocrRefusal::ReductionRatio(1024)
        );
        assert_eq!(
            refused(&|i| {
                i.send_clock_factor = 8;
                i.reduction_ratio = 2;
            }),
            IocrRefusal::Cycle { units: 16 }
        );
        assert_eq!(
            refused(&|i| i.watchdog_factor = 0),
            IocrRefusal::WatchdogFactor(0)
        );
        assert_eq!(
            refused(&|i| i.data_hold_factor = 241),
            IocrRefusal::DataHoldFactor(241)
        );
        assert_eq!(
            refused(&|i| i.tag_header = 0xa000),
            IocrRefusal::TagHeader(0xa000)
        );
        assert_eq!(
            refused(&|i| i.tag_header = 0xc001),
            IocrRefusal::TagHeader(0xc001)
        );
    }

    proptest! {
        #[test]
        fn what_is_accepted_fits_its_class_and_the_time_limits(
            class in 1u32..=2,
            output in any::<bool>(),
            frame_id in any::<u16>(),
            send_clock_factor in 0u16..=160,
            ratio_exponent in 0u32..=10,
            watchdog_factor in 0u16..=8000,
            data_hold_factor in 0u16..=8000,
            taken in proptest::collection::vec(any::<u16>(), 0..4),
        ) {
            let mut iocr = legacy_output();
            iocr.properties = class;
            iocr.iocr_type = if output { IOCR_TYPE_OUTPUT } else { IOCR_TYPE_INPUT };
            iocr.frame_id = frame_id;
            iocr.send_clock_factor = send_clock_factor;
            iocr.reduction_ratio = 1 << ratio_exponent;
            iocr.watchdog_factor = watchdog_factor;
            iocr.data_hold_factor = data_hold_factor;
            if let Ok(accepted) = accept_iocr(&iocr, &taken) {
                prop_assert!(accepted.rt_class.accepts(accepted.frame_id));
                prop_assert!(accepted.frame_id == frame_id || (output && frame_id == DEVICE_CHOOSES));
                prop_assert!(frame_id != DEVICE_CHOOSES || !taken.contains(&accepted.frame_id));
                prop_assert!(accepted.data_hold <= MAX_DATA_HOLD);
                prop_assert!(accepted.timing.cycle() >= Duration::from_millis(1));
                prop_assert!(accepted.timing.step().is_some());
            }
        }
    }
}
