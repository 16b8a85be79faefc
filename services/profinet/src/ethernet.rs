//! Ethernet II framing of PROFINET frames, with and without an 802.1Q tag.
//!
//! RT, DCP and alarm frames all carry EtherType 0x8892. A PLC sends cyclic frames with a
//! priority tag (TPID 0x8100, PCP 6, VID 0), but on a veth pair (and on NICs with VLAN
//! offload) the kernel strips the tag before an AF_PACKET socket sees the frame, so every
//! parser here accepts both shapes.

use std::fmt;

/// EtherType of PROFINET RT, DCP and RTA frames.
pub const ETHER_TYPE_PROFINET: u16 = 0x8892;
/// Tag protocol identifier of an 802.1Q VLAN tag.
pub const ETHER_TYPE_VLAN: u16 = 0x8100;
/// Length of an untagged Ethernet II header.
pub const UNTAGGED_HEADER_LEN: usize = 14;
/// Length of an Ethernet II header with an 802.1Q tag.
pub const TAGGED_HEADER_LEN: usize = 18;
/// Shortest frame on the wire without the FCS: shorter frames are padded with zeros.
pub const MIN_FRAME_LEN: usize = 60;
/// Longest untagged frame without the FCS.
pub const MAX_FRAME_LEN: usize = 1514;

/// A 48-bit Ethernet MAC address.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct MacAddress(pub [u8; 6]);

impl MacAddress {
    /// DCP Identify multicast address (01:0E:CF:00:00:00).
    pub const DCP_IDENTIFY: MacAddress = MacAddress([0x01, 0x0e, 0xcf, 0x00, 0x00, 0x00]);

    /// True for a group (multicast or broadcast) address.
    pub fn is_multicast(self) -> bool {
        self.0[0] & 0x01 != 0
    }
}

impl fmt::Display for MacAddress {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let [a, b, c, d, e, g] = self.0;
        write!(f, "{a:02x}:{b:02x}:{c:02x}:{d:02x}:{e:02x}:{g:02x}")
    }
}

/// An 802.1Q tag control information (TCI) word.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct VlanTag {
    /// Priority code point (PCP), 0..=7.
    pub priority: u8,
    /// VLAN identifier, 0 for a pure priority tag.
    pub vlan_id: u16,
}

impl VlanTag {
    /// The tag of cyclic RT frames and high-priority alarms: PCP 6, VID 0 (TCI 0xC000).
    pub const RT: VlanTag = VlanTag {
        priority: 6,
        vlan_id: 0,
    };

    /// Decodes a TCI word (the drop-eligible bit is ignored).
    pub fn from_tci(tci: u16) -> Self {
        Self {
            priority: (tci >> 13) as u8,
            vlan_id: tci & 0x0fff,
        }
    }

    /// Encodes the TCI word.
    pub fn tci(self) -> u16 {
        (u16::from(self.priority & 0x07) << 13) | (self.vlan_id & 0x0fff)
    }
}

/// The Ethernet II header of a frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct EthernetHeader {
    /// Destination address.
    pub destination: MacAddress,
    /// Source address.
    pub source: MacAddress,
    /// The 802.1Q tag, if the frame has one.
    pub vlan: Option<VlanTag>,
    /// EtherType of the payload (after the tag, if any).
    pub ether_type: u16,
}

/// A frame too short for its Ethernet header, or an output buffer too small.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum EthernetError {
    /// The frame ends inside the header.
    #[error("Ethernet frame of {have} bytes is shorter than its header ({need} bytes)")]
    Truncated {
        /// Bytes the header needs.
        need: usize,
        /// Bytes present.
        have: usize,
    },
    /// The output buffer cannot hold the frame.
    #[error("output buffer of {have} bytes cannot hold {need} bytes")]
    BufferTooSmall {
        /// Bytes needed.
        need: usize,
        /// Bytes available.
        have: usize,
    },
}

impl EthernetHeader {
    /// Parses the header of `frame`; returns it and the payload behind it.
    pub fn parse(frame: &[u8]) -> Result<(Self, &[u8]), EthernetError> {
        let truncated = |need| EthernetError::Truncated {
            need,
            have: frame.len(),
        };
        let (Some(destination), Some(source), Some(first)) =
            (mac_at(frame, 0), mac_at(frame, 6), be16_at(frame, 12))
        else {
            return Err(truncated(UNTAGGED_HEADER_LEN));
        };
        let (vlan, ether_type, header_len) = if first == ETHER_TYPE_VLAN {
            let (Some(tci), Some(ether_type)) = (be16_at(frame, 14), be16_at(frame, 16)) else {
                return Err(truncated(TAGGED_HEADER_LEN));
            };
            (Some(VlanTag::from_tci(tci)), ether_type, TAGGED_HEADER_LEN)
        } else {
            (None, first, UNTAGGED_HEADER_LEN)
        };
        let header = Self {
            destination,
            source,
            vlan,
            ether_type,
        };
        Ok((header, &frame[header_len..]))
    }

    /// Length of this header on the wire.
    pub fn len(&self) -> usize {
        if self.vlan.is_some() {
            TAGGED_HEADER_LEN
        } else {
            UNTAGGED_HEADER_LEN
        }
    }

    /// Always false: a header is never empty (here for clippy's `len_without_is_empty`).
    pub fn is_empty(&self) -> bool {
        false
    }

    /// Writes the header to the start of `out`; returns its length.
    pub fn write(&self, out: &mut [u8]) -> Result<usize, EthernetError> {
        let len = self.len();
        let Some(header) = out.get_mut(..len) else {
            return Err(EthernetError::BufferTooSmall {
                need: len,
                have: out.len(),
            });
        };
        header[0..6].copy_from_slice(&self.destination.0);
        header[6..12].copy_from_slice(&self.source.0);
        if let Some(tag) = self.vlan {
            header[12..14].copy_from_slice(&ETHER_TYPE_VLAN.to_be_bytes());
            header[14..16].copy_from_slice(&tag.tci().to_be_bytes());
        }
        header[len - 2..len].copy_from_slice(&self.ether_type.to_be_bytes());
        Ok(len)
    }
}

/// Pads a frame of `len` bytes in `out` with zeros up to [`MIN_FRAME_LEN`]; returns the
/// padded length (raw sockets send what they are given, and short frames are malformed).
pub fn pad_to_minimum(out: &mut [u8], len: usize) -> usize {
    let padded = len.max(MIN_FRAME_LEN).min(out.len());
    out[len.min(padded)..padded].fill(0);
    padded
}

/// The big-endian u16 at `offset`, if the slice holds it.
pub(crate) fn be16_at(bytes: &[u8], offset: usize) -> Option<u16> {
    let pair = bytes.get(offset..offset.checked_add(2)?)?;
    Some(u16::from_be_bytes([pair[0], pair[1]]))
}

/// The big-endian u32 at `offset`, if the slice holds it.
pub(crate) fn be32_at(bytes: &[u8], offset: usize) -> Option<u32> {
    let quad = bytes.get(offset..offset.checked_add(4)?)?;
    Some(u32::from_be_bytes([quad[0], quad[1], quad[2], quad[3]]))
}

fn mac_at(bytes: &[u8], offset: usize) -> Option<MacAddress> {
    let six = bytes.get(offset..offset + 6)?;
    let mut mac = [0; 6];
    mac.copy_from_slice(six);
    Some(MacAddress(mac))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testdata;
    use proptest::prelude::*;

    #[test]
    fn the_golden_tagged_set_request_parses_with_its_priority_tag() {
        let frame = testdata::frame("dcp_set_req");
        let (header, payload) = EthernetHeader::parse(&frame).unwrap();
        assert_eq!(header.destination.to_string(), "8c:f3:19:cd:19:f8");
        assert_eq!(header.source.to_string(), "ec:1c:5d:61:e7:3f");
        assert_eq!(
            header.vlan,
            Some(VlanTag {
                priority: 0,
                vlan_id: 0
            })
        );
        assert_eq!(header.ether_type, ETHER_TYPE_PROFINET);
        assert_eq!(payload.len(), frame.len() - TAGGED_HEADER_LEN);
        assert_eq!(&payload[..2], &[0xfe, 0xfd]);
    }

    #[test]
    fn the_golden_cyclic_frame_carries_the_rt_tag() {
        let frame = testdata::frame("rtc_cpu_8001");
        let (header, _) = EthernetHeader::parse(&frame).unwrap();
        assert_eq!(header.vlan, Some(VlanTag::RT));
        assert_eq!(VlanTag::RT.tci(), 0xc000);
    }

    #[test]
    fn an_untagged_frame_has_its_payload_at_14() {
        let frame = testdata::frame("dcp_set_res");
        let (header, payload) = EthernetHeader::parse(&frame).unwrap();
        assert_eq!(header.vlan, None);
        assert_eq!(header.len(), UNTAGGED_HEADER_LEN);
        assert_eq!(payload, &frame[14..]);
    }

    #[test]
    fn truncated_headers_are_refused() {
        assert_eq!(
            EthernetHeader::parse(&[0; 13]),
            Err(EthernetError::Truncated { need: 14, have: 13 })
        );
        let mut tagged = [0u8; 17];
        tagged[12..14].copy_from_slice(&ETHER_TYPE_VLAN.to_be_bytes());
        assert_eq!(
            EthernetHeader::parse(&tagged),
            Err(EthernetError::Truncated { need: 18, have: 17 })
        );
    }

    #[test]
    fn a_short_frame_is_padded_with_zeros() {
        let mut out = [0xaa; 80];
        assert_eq!(pad_to_minimum(&mut out, 34), 60);
        assert!(out[34..60].iter().all(|&b| b == 0));
        assert_eq!(out[60], 0xaa);
        assert_eq!(pad_to_minimum(&mut out, 70), 70);
    }

    #[test]
    fn writing_into_a_short_buffer_fails() {
        let header = EthernetHeader {
            destination: MacAddress::DCP_IDENTIFY,
            source: MacAddress::default(),
            vlan: Some(VlanTag::RT),
            ether_type: ETHER_TYPE_PROFINET,
        };
        assert_eq!(
            header.write(&mut [0; 17]),
            Err(EthernetError::BufferTooSmall { need: 18, have: 17 })
        );
    }

    proptest! {
        #[test]
        fn write_then_parse_is_the_identity(
            destination in any::<[u8; 6]>(),
            source in any::<[u8; 6]>(),
            tag in proptest::option::of((0u8..8, 0u16..4096)),
            ether_type in any::<u16>().prop_filter("not a tag", |t| *t != ETHER_TYPE_VLAN),
            payload in proptest::collection::vec(any::<u8>(), 0..64),
        ) {
            let header = EthernetHeader {
                destination: MacAddress(destination),
                source: MacAddress(source),
                vlan: tag.map(|(priority, vlan_id)| VlanTag { priority, vlan_id }),
                ether_type,
            };
            let mut out = [0u8; 100];
            let len = header.write(&mut out).unwrap();
            out[len..len + payload.len()].copy_from_slice(&payload);
            let (parsed, rest) = EthernetHeader::parse(&out[..len + payload.len()]).unwrap();
            prop_assert_eq!(parsed, header);
            prop_assert_eq!(rest, &payload[..]);
        }

        #[test]
        fn parse_never_panics(bytes in proptest::collection::vec(any::<u8>(), 0..40)) {
            let _ = EthernetHeader::parse(&bytes);
        }
    }
}
