//! The cyclic RT frame (RT_CLASS_1/2 over Ethernet):
//!
//! ```text
//! dst(6) src(6) [8100 TCI] 8892 FrameID(2) C_SDU(40..=1440) CycleCounter(2) DataStatus(1) TransferStatus(1)
//! ```
//!
//! The C_SDU has the DataLength the controller set in the IOCR; frames are sent with the
//! RT priority tag and received with or without it (see [`crate::ethernet`]).

use super::data_status::DataStatus;
use crate::ethernet::{ETHER_TYPE_PROFINET, EthernetError, EthernetHeader, MacAddress, VlanTag};

/// Shortest C_SDU (the Ethernet minimum payload is met by the RT layer itself).
pub const MIN_C_SDU_LEN: usize = 40;
/// Longest C_SDU.
pub const MAX_C_SDU_LEN: usize = 1440;
/// CycleCounter, DataStatus and TransferStatus behind the C_SDU.
pub const APDU_STATUS_LEN: usize = 4;

/// A frame that is not a well-formed cyclic frame, or that cannot be written.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum RtFrameError {
    /// The Ethernet header is incomplete, or the output buffer too small for it.
    #[error(transparent)]
    Ethernet(#[from] EthernetError),
    /// Not EtherType 0x8892.
    #[error("EtherType {0:#06x} is not PROFINET")]
    NotProfinet(u16),
    /// The C_SDU is outside 40..=1440 bytes.
    #[error("C_SDU of {0} bytes (40..=1440 allowed)")]
    CSduLength(usize),
    /// The output buffer cannot hold the frame.
    #[error("cyclic frame needs {need} bytes, the buffer has {have}")]
    BufferTooSmall {
        /// Bytes needed.
        need: usize,
        /// Bytes available.
        have: usize,
    },
}

/// A cyclic frame, borrowing its C_SDU.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RtFrame<'a> {
    /// FrameID of the IOCR.
    pub frame_id: u16,
    /// The C_SDU: IO data, IOPS and IOCS at the offsets of the IOCR.
    pub c_sdu: &'a [u8],
    /// Cycle counter (31.25 µs units).
    pub cycle_counter: u16,
    /// DataStatus.
    pub data_status: DataStatus,
    /// TransferStatus; anything but 0 marks a faulty frame.
    pub transfer_status: u8,
}

impl<'a> RtFrame<'a> {
    /// Parses a received frame, tagged or not. The C_SDU is everything between the
    /// FrameID and the 4 status bytes: the caller checks it against the IOCR's DataLength.
    pub fn parse(frame: &'a [u8]) -> Result<(EthernetHeader, RtFrame<'a>), RtFrameError> {
        let (ethernet, payload) = EthernetHeader::parse(frame)?;
        if ethernet.ether_type != ETHER_TYPE_PROFINET {
            return Err(RtFrameError::NotProfinet(ethernet.ether_type));
        }
        let c_sdu_len = payload.len().saturating_sub(2 + APDU_STATUS_LEN);
        if !(MIN_C_SDU_LEN..=MAX_C_SDU_LEN).contains(&c_sdu_len) {
            return Err(RtFrameError::CSduLength(c_sdu_len));
        }
        let status = &payload[2 + c_sdu_len..];
        let rt = RtFrame {
            frame_id: u16::from_be_bytes([payload[0], payload[1]]),
            c_sdu: &payload[2..2 + c_sdu_len],
            cycle_counter: u16::from_be_bytes([status[0], status[1]]),
            data_status: DataStatus(status[2]),
            transfer_status: status[3],
        };
        Ok((ethernet, rt))
    }

    /// Writes the frame from `source` to `destination` into `out`, with the RT priority
    /// tag when `vlan` is given; returns its length. No allocation: the cyclic path.
    pub fn write(
        &self,
        destination: MacAddress,
        source: MacAddress,
        vlan: Option<VlanTag>,
        out: &mut [u8],
    ) -> Result<usize, RtFrameError> {
        let len = self.c_sdu.len();
        if !(MIN_C_SDU_LEN..=MAX_C_SDU_LEN).contains(&len) {
            return Err(RtFrameError::CSduLength(len));
        }
        let ethernet = EthernetHeader {
            destination,
            source,
            vlan,
            ether_type: ETHER_TYPE_PROFINET,
        };
        let need = ethernet.len() + 2 + len + APDU_STATUS_LEN;
        let Some(frame) = out.get_mut(..need) else {
            return Err(RtFrameError::BufferTooSmall {
                need,
                have: out.len(),
            });
        };
        let at = ethernet.write(frame)?;
        frame[at..at + 2].copy_from_slice(&self.frame_id.to_be_bytes());
        frame[at + 2..at + 2 + len].copy_from_slice(self.c_sdu);
        let status = &mut frame[at + 2 + len..];
        status[0..2].copy_from_slice(&self.cycle_counter.to_be_bytes());
        status[2] = self.data_status.0;
        status[3] = self.transfer_status;
        Ok(need)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ethernet::TAGGED_HEADER_LEN;
    use crate::testdata;
    use proptest::prelude::*;

    #[test]
    fn the_golden_frames_of_both_directions_parse() {
        let frame = testdata::frame("rtc_cpu_8001");
        let (ethernet, rt) = RtFrame::parse(&frame).unwrap();
        assert_eq!(ethernet.vlan, Some(VlanTag::RT));
        assert_eq!(rt.frame_id, 0x8001);
        assert_eq!(rt.c_sdu.len(), 40);
        assert_eq!(rt.cycle_counter, 0xb800);
        assert_eq!(rt.transfer_status, 0);
        let frame = testdata::frame("rtc_dev_8000");
        let (_, rt) = RtFrame::parse(&frame).unwrap();
        assert_eq!(rt.frame_id, 0x8000);
        assert_eq!(rt.cycle_counter, 0x1c00);
    }

    #[test]
    fn writing_reproduces_the_golden_frame_byte_for_byte() {
        let golden = testdata::frame("rtc_dev_8000");
        let (ethernet, rt) = RtFrame::parse(&golden).unwrap();
        let mut out = [0u8; 128];
        let len = rt
            .write(
                ethernet.destination,
                ethernet.source,
                ethernet.vlan,
                &mut out,
            )
            .unwrap();
        assert_eq!(out[..len], golden[..]);
    }

    #[test]
    fn a_frame_untagged_by_the_kernel_parses_the_same() {
        // On veth the kernel strips the tag: the same frame arrives 4 bytes shorter.
        let golden = testdata::frame("rtc_cpu_8001");
        let mut stripped = golden[..12].to_vec();
        stripped.extend_from_slice(&golden[16..]);
        let (ethernet, rt) = RtFrame::parse(&stripped).unwrap();
        assert_eq!(ethernet.vlan, None);
        let (_, tagged) = RtFrame::parse(&golden).unwrap();
        assert_eq!(rt, tagged);
    }

    #[test]
    fn bad_frames_are_refused() {
        let golden = testdata::frame("rtc_cpu_8001");
        assert_eq!(
            RtFrame::parse(&golden[..golden.len() - 1]),
            Err(RtFrameError::CSduLength(39))
        );
        let mut ipv4 = golden.clone();
        ipv4[16..18].copy_from_slice(&[0x08, 0x00]);
        assert_eq!(
            RtFrame::parse(&ipv4),
            Err(RtFrameError::NotProfinet(0x0800))
        );
        let rt = RtFrame {
            frame_id: 0x8000,
            c_sdu: &[0; 39],
            cycle_counter: 0,
            data_status: DataStatus::NORMAL,
            transfer_status: 0,
        };
        let mut out = [0u8; 128];
        let mac = MacAddress::default();
        assert_eq!(
            rt.write(mac, mac, None, &mut out),
            Err(RtFrameError::CSduLength(39))
        );
        let rt = RtFrame {
            c_sdu: &[0; 40],
            ..rt
        };
        assert_eq!(
            rt.write(mac, mac, Some(VlanTag::RT), &mut out[..63]),
            Err(RtFrameError::BufferTooSmall { need: 64, have: 63 })
        );
    }

    proptest! {
        #[test]
        fn write_then_parse_is_the_identity(
            frame_id in any::<u16>(),
            c_sdu in proptest::collection::vec(any::<u8>(), MIN_C_SDU_LEN..300),
            cycle_counter in any::<u16>(),
            data_status in any::<u8>(),
            transfer_status in any::<u8>(),
            tagged in any::<bool>(),
        ) {
            let rt = RtFrame { frame_id, c_sdu: &c_sdu, cycle_counter, data_status: DataStatus(data_status), transfer_status };
            let mut out = [0u8; 400];
            let vlan = tagged.then_some(VlanTag::RT);
            let len = rt.write(MacAddress([2; 6]), MacAddress([4; 6]), vlan, &mut out).unwrap();
            prop_assert_eq!(len, c_sdu.len() + 6 + if tagged { TAGGED_HEADER_LEN } else { 14 });
            let (_, parsed) = RtFrame::parse(&out[..len]).unwrap();
            prop_assert_eq!(parsed, rt);
        }

        #[test]
        fn parse_never_panics(bytes in proptest::collection::vec(any::<u8>(), 0..100)) {
            let _ = RtFrame::parse(&bytes);
        }
    }
}
