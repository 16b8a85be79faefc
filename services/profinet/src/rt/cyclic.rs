//! The cyclic exchange of one IO AR, pure (time comes in as an argument, frames in and
//! out as byte slices, no allocation): the provider of the input CR (robot → PLC) and the
//! consumer of the output CR (PLC → robot) with its watchdog and data-hold time.
//!
//! The provider sends on absolute deadlines, `start + n × cycle`; a late shell skips the
//! slots it missed and the cycle counter still tells the time of each frame. The consumer
//! takes a frame only from the controller, with the CR's FrameID and DataLength, a cycle
//! counter newer than the last one taken and TransferStatus 0; its SRCI data goes up only
//! when it is valid (DataStatus primary, valid, run, and IOPS good). Its supervision arms
//! with the first frame taken: no frame within the watchdog time, or no valid data within
//! the data-hold time, ends the exchange once, as an [`Expiry`].

use std::time::Duration;

use super::c_sdu::{CSduLayout, LayoutError};
use super::cycle_counter::{CycleCounter, CycleTiming, is_newer};
use super::data_status::DataStatus;
use super::frame::{MAX_C_SDU_LEN, RtFrame, RtFrameError};
use super::ioxs::Ioxs;
use crate::ethernet::{MacAddress, VlanTag};

/// A CR the cyclic engine cannot serve.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum CyclicError {
    /// The cycle does not fit the cycle counter.
    #[error("cycle {0:?} does not fit the cycle counter")]
    Cycle(CycleTiming),
    /// The layout does not fit.
    #[error("C_SDU layout: {0}")]
    Layout(#[from] LayoutError),
    /// The frame cannot be written.
    #[error("cyclic frame: {0}")]
    Frame(#[from] RtFrameError),
}

/// One IOCR as the cyclic engine runs it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CrConfig {
    /// FrameID.
    pub frame_id: u16,
    /// Send clock and reduction ratio.
    pub timing: CycleTiming,
    /// Where the objects sit.
    pub layout: CSduLayout,
    /// The SRCI submodule's data object, when the controller exchanges it.
    pub srci_object: Option<usize>,
}

/// The provider of the input CR.
#[derive(Debug, Clone)]
pub struct Provider {
    frame_id: u16,
    layout: CSduLayout,
    srci_object: Option<usize>,
    destination: MacAddress,
    source: MacAddress,
    counter: CycleCounter,
    cycle: Duration,
    due: Duration,
    c_sdu: [u8; MAX_C_SDU_LEN],
}

impl Provider {
    /// A provider sending from `source` to `destination`, its first frame due at `start`.
    /// Every IOPS and IOCS is GOOD: the device's submodules are all there and it consumes
    /// every output of the controller.
    pub fn new(
        cr: &CrConfig,
        destination: MacAddress,
        source: MacAddress,
        start: Duration,
    ) -> Result<Self, CyclicError> {
        let step = cr.timing.step().ok_or(CyclicError::Cycle(cr.timing))?;
        let mut c_sdu = [0; MAX_C_SDU_LEN];
        let used = &mut c_sdu[..cr.layout.data_length()];
        for (index, object) in cr.layout.data_objects().iter().enumerate() {
            let start = usize::from(object.frame_offset);
            let end = start + usize::from(object.data_length);
            // Zeros until the application gives data; the IOPS follows the data.
            let data = [0; MAX_C_SDU_LEN];
            cr.layout
                .write_data(used, index, &data[..end - start], Ioxs::GOOD)?;
        }
        for index in 0..cr.layout.iocs_offsets().len() {
            cr.layout.write_iocs(used, index, Ioxs::GOOD)?;
        }
        Ok(Self {
            frame_id: cr.frame_id,
            layout: cr.layout,
            srci_object: cr.srci_object,
            destination,
            source,
            counter: CycleCounter::new(0, step),
            cycle: cr.timing.cycle(),
            due: start,
            c_sdu,
        })
    }

    /// When the next frame is due.
    pub fn due(&self) -> Duration {
        self.due
    }

    /// Writes the frame due at or before `now` into `out` and returns its length:
    /// `srci_input` (the robot→PLC telegram, the module's length) in the SRCI object,
    /// the StationProblemIndicator cleared when `station_problem`.
    pub fn frame(
        &mut self,
        now: Duration,
        srci_input: &[u8],
        station_problem: bool,
        out: &mut [u8],
    ) -> Result<usize, CyclicError> {
        let c_sdu = &mut self.c_sdu[..self.layout.data_length()];
        if let Some(index) = self.srci_object {
            self.layout
                .write_data(c_sdu, index, srci_input, Ioxs::GOOD)?;
        }
        let frame = RtFrame {
            frame_id: self.frame_id,
            c_sdu,
            cycle_counter: self.counter.value(),
            data_status: DataStatus::provider(true, station_problem),
            transfer_status: 0,
        };
        let len = frame.write(self.destination, self.source, Some(VlanTag::RT), out)?;
        // The next slot after `now`: slots a late caller missed are skipped, and the
        // counter still advances for them, so that it tells the time.
        loop {
            self.due += self.cycle;
            self.counter.advance();
            if self.due > now {
                break;
            }
        }
        Ok(len)
    }
}

/// Why the consumer gave up.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Expiry {
    /// No frame within the watchdog time.
    Watchdog,
    /// No valid data within the data-hold time.
    DataHold,
}

/// What a received frame was.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Consumed<'a> {
    /// Valid data of the SRCI module (the PLC→robot telegram).
    Data(&'a [u8]),
    /// A frame of this CR whose data is not valid (provider stopped, DataValid clear,
    /// IOPS bad) or that carries no SRCI module: it feeds the watchdog only.
    Invalid,
    /// Not a frame for this consumer (another FrameID, another source, a stale counter,
    /// a wrong length or TransferStatus): ignored.
    Ignored,
}

/// The consumer of the output CR.
#[derive(Debug, Clone)]
pub struct Consumer {
    frame_id: u16,
    layout: CSduLayout,
    srci_object: Option<usize>,
    controller: MacAddress,
    watchdog: Duration,
    data_hold: Duration,
    last_counter: Option<u16>,
    last_frame: Duration,
    last_valid: Duration,
    expired: Option<Expiry>,
}

impl Consumer {
    /// A consumer of frames from `controller`, supervised by `watchdog` and `data_hold`.
    pub fn new(
        cr: &CrConfig,
        controller: MacAddress,
        watchdog: Duration,
        data_hold: Duration,
    ) -> Self {
        Self {
            frame_id: cr.frame_id,
            layout: cr.layout,
            srci_object: cr.srci_object,
            controller,
            watchdog,
            data_hold,
            last_counter: None,
            last_frame: Duration::ZERO,
            last_valid: Duration::ZERO,
            expired: None,
        }
    }

    /// Takes a received frame (from `source`) at `now`.
    pub fn on_frame<'a>(
        &mut self,
        source: MacAddress,
        frame: &RtFrame<'a>,
        now: Duration,
    ) -> Consumed<'a> {
        let fresh = self
            .last_counter
            .is_none_or(|last| is_newer(last, frame.cycle_counter));
        if self.expired.is_some()
            || source != self.controller
            || frame.frame_id != self.frame_id
            || frame.c_sdu.len() != self.layout.data_length()
            || frame.transfer_status != 0
            || !fresh
        {
            return Consumed::Ignored;
        }
        if self.last_counter.is_none() {
            // Supervision arms with the first frame.
            self.last_valid = now;
        }
        self.last_counter = Some(frame.cycle_counter);
        self.last_frame = now;
        let data = self
            .srci_object
            .and_then(|index| self.layout.data(frame.c_sdu, index))
            .filter(|(_, iops)| iops.is_good() && frame.data_status.usable());
        match data {
            Some((data, _)) => {
                self.last_valid = now;
                Consumed::Data(data)
            }
            None => Consumed::Invalid,
        }
    }

    /// The expiry at `now`, reported once; `None` while the exchange is healthy or before
    /// the first frame.
    pub fn check(&mut self, now: Duration) -> Option<Expiry> {
        if self.expired.is_some() || self.last_counter.is_none() {
            return None;
        }
        let expiry = if now.saturating_sub(self.last_frame) > self.watchdog {
            Expiry::Watchdog
        } else if now.saturating_sub(self.last_valid) > self.data_hold {
            Expiry::DataHold
        } else {
            return None;
        };
        self.expired = Some(expiry);
        Some(expiry)
    }

    /// The earliest time at which [`Consumer::check`] can report an expiry.
    pub fn deadline(&self) -> Option<Duration> {
        (self.expired.is_none() && self.last_counter.is_some())
            .then(|| (self.last_frame + self.watchdog).min(self.last_valid + self.data_hold))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rt::c_sdu::IoDataObject;
    use proptest::prelude::*;

    const DEVICE: MacAddress = MacAddress([2, 0, 0, 0, 0, 1]);
    const PLC: MacAddress = MacAddress([2, 0, 0, 0, 0, 2]);
    const MS: Duration = Duration::from_millis(1);

    /// An SRCI 64 CR: DAP object (no data) at 0, SRCI data at 1..65 with its IOPS at 65,
    /// one IOCS at 66.
    fn cr(frame_id: u16, reduction_ratio: u16) -> CrConfig {
        let mut layout = CSduLayout::new(80).unwrap();
        layout
            .add_data_object(IoDataObject {
                frame_offset: 0,
                data_length: 0,
            })
            .unwrap();
        let srci = layout
            .add_data_object(IoDataObject {
                frame_offset: 1,
                data_length: 64,
            })
            .unwrap();
        layout.add_iocs(66).unwrap();
        CrConfig {
            frame_id,
            timing: CycleTiming {
                send_clock_factor: 32,
                reduction_ratio,
            },
            layout,
            srci_object: Some(srci),
        }
    }

    fn telegram(seed: u8) -> [u8; 64] {
        std::array::from_fn(|i| seed.wrapping_add(i as u8))
    }

    #[test]
    fn provider_frames_carry_the_telegram_good_ioxs_and_the_status() {
        let mut provider = Provider::new(&cr(0xc001, 8), PLC, DEVICE, MS).unwrap();
        let mut out = [0; 1600];
        let len = provider.frame(MS, &telegram(7), false, &mut out).unwrap();
        let (ethernet, rt) = RtFrame::parse(&out[..len]).unwrap();
        assert_eq!((ethernet.destination, ethernet.source), (PLC, DEVICE));
        assert_eq!(ethernet.vlan, Some(VlanTag::RT));
        assert_eq!(rt.frame_id, 0xc001);
        assert_eq!(rt.data_status, DataStatus::NORMAL);
        let layout = cr(0xc001, 8).layout;
        assert_eq!(layout.data(rt.c_sdu, 0), Some((&[][..], Ioxs::GOOD)));
        assert_eq!(
            layout.data(rt.c_sdu, 1),
            Some((&telegram(7)[..], Ioxs::GOOD))
        );
        assert_eq!(layout.iocs(rt.c_sdu, 0), Some(Ioxs::GOOD));
        assert_eq!(provider.due(), MS * 9);
        let len = provider
            .frame(MS * 9, &telegram(8), true, &mut out)
            .unwrap();
        let (_, rt) = RtFrame::parse(&out[..len]).unwrap();
        assert_eq!(rt.cycle_counter, 256);
        assert!(!rt.data_status.station_ok());
        assert!(rt.data_status.usable());
    }

    #[test]
    fn a_late_provider_skips_the_missed_slots_and_its_counter_tells_the_time() {
        let mut provider = Provider::new(&cr(0x8000, 2), PLC, DEVICE, Duration::ZERO).unwrap();
        let mut out = [0; 1600];
        provider
            .frame(Duration::ZERO, &telegram(0), false, &mut out)
            .unwrap();
        // 5.5 ms late for the slot at 2 ms: the slots at 2, 4 and 6 ms are gone.
        let len = provider
            .frame(MS * 7, &telegram(0), false, &mut out)
            .unwrap();
        let (_, rt) = RtFrame::parse(&out[..len]).unwrap();
        assert_eq!(rt.cycle_counter, 64);
        assert_eq!(provider.due(), MS * 8);
    }

    /// A controller frame of `cr` with `counter`, DataStatus `status` and the SRCI IOPS.
    fn plc_frame(counter: u16, status: DataStatus, iops: Ioxs, seed: u8) -> Vec<u8> {
        let config = cr(0xc000, 8);
        let mut c_sdu = [0; 80];
        config
            .layout
            .write_data(&mut c_sdu, 0, &[], Ioxs::GOOD)
            .unwrap();
        config
            .layout
            .write_data(&mut c_sdu, 1, &telegram(seed), iops)
            .unwrap();
        let frame = RtFrame {
            frame_id: 0xc000,
            c_sdu: &c_sdu,
            cycle_counter: counter,
            data_status: status,
            transfer_status: 0,
        };
        let mut out = vec![0; 200];
        let len = frame.write(DEVICE, PLC, None, &mut out).unwrap();
        out.truncate(len);
        out
    }

    fn consumer() -> Consumer {
        Consumer::new(&cr(0xc000, 8), PLC, MS * 24, MS * 24)
    }

    #[test]
    fn valid_data_goes_up_and_invalid_or_foreign_frames_do_not() {
        let mut consumer = consumer();
        let good = plc_frame(256, DataStatus::NORMAL, Ioxs::GOOD, 3);
        let (_, rt) = RtFrame::parse(&good).unwrap();
        assert_eq!(
            consumer.on_frame(PLC, &rt, MS),
            Consumed::Data(&telegram(3))
        );
        // The same counter again is stale; another source is not the controller.
        assert_eq!(consumer.on_frame(PLC, &rt, MS * 2), Consumed::Ignored);
        let next = plc_frame(512, DataStatus::NORMAL, Ioxs::GOOD, 4);
        let (_, rt) = RtFrame::parse(&next).unwrap();
        assert_eq!(consumer.on_frame(DEVICE, &rt, MS * 2), Consumed::Ignored);
        let stopped = plc_frame(512, DataStatus::provider(false, false), Ioxs::GOOD, 4);
        let (_, rt) = RtFrame::parse(&stopped).unwrap();
        assert_eq!(consumer.on_frame(PLC, &rt, MS * 9), Consumed::Invalid);
        let bad_iops = plc_frame(768, DataStatus::NORMAL, Ioxs::BAD, 5);
        let (_, rt) = RtFrame::parse(&bad_iops).unwrap();
        assert_eq!(consumer.on_frame(PLC, &rt, MS * 17), Consumed::Invalid);
    }

    #[test]
    fn the_watchdog_expires_once_when_frames_stop() {
        let mut consumer = consumer();
        assert_eq!(consumer.check(MS * 1000), None, "not armed before a frame");
        let good = plc_frame(256, DataStatus::NORMAL, Ioxs::GOOD, 3);
        let (_, rt) = RtFrame::parse(&good).unwrap();
        consumer.on_frame(PLC, &rt, MS * 100);
        assert_eq!(consumer.deadline(), Some(MS * 124));
        assert_eq!(consumer.check(MS * 124), None);
        assert_eq!(consumer.check(MS * 125), Some(Expiry::Watchdog));
        assert_eq!(consumer.check(MS * 200), None);
        assert_eq!(consumer.on_frame(PLC, &rt, MS * 200), Consumed::Ignored);
    }

    #[test]
    fn invalid_data_for_longer_than_the_data_hold_time_expires() {
        let mut consumer = Consumer::new(&cr(0xc000, 8), PLC, MS * 24, MS * 40);
        let stopped =
            |counter| plc_frame(counter, DataStatus::provider(false, false), Ioxs::GOOD, 0);
        for n in 1..=5u16 {
            let frame = stopped(n * 256);
            let (_, rt) = RtFrame::parse(&frame).unwrap();
            consumer.on_frame(PLC, &rt, MS * 8 * u32::from(n));
            assert_eq!(consumer.check(MS * 8 * u32::from(n)), None);
        }
        let frame = stopped(6 * 256);
        let (_, rt) = RtFrame::parse(&frame).unwrap();
        consumer.on_frame(PLC, &rt, MS * 49);
        assert_eq!(consumer.check(MS * 49), Some(Expiry::DataHold));
    }

    proptest! {
        #[test]
        fn what_the_provider_sends_a_consumer_of_the_same_cr_takes(
            seeds in proptest::collection::vec(any::<u8>(), 1..20),
            ratio in prop::sample::select(vec![1u16, 2, 8, 32]),
        ) {
            let config = cr(0x8001, ratio);
            let mut provider = Provider::new(&config, PLC, DEVICE, Duration::ZERO).unwrap();
            let mut consumer = Consumer::new(&config, DEVICE, MS * 1000, MS * 1000);
            let mut out = [0; 1600];
            for seed in seeds {
                let now = provider.due();
                let len = provider.frame(now, &telegram(seed), false, &mut out).unwrap();
                let (ethernet, rt) = RtFrame::parse(&out[..len]).unwrap();
                prop_assert_eq!(
                    consumer.on_frame(ethernet.source, &rt, now),
                    Consumed::Data(&telegram(seed))
                );
                prop_assert_eq!(consumer.check(now), None);
            }
        }
    }
}
