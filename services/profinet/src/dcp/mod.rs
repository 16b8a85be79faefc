//! DCP, the Discovery and basic Configuration Protocol, on the device side.
//!
//! A DCP PDU follows the FrameID: `ServiceID(1) ServiceType(1) Xid(4) ResponseDelay(2)
//! DCPDataLength(2)` and then `DCPDataLength` bytes of blocks. Identify requests go to the
//! multicast address 01:0E:CF:00:00:00 (FrameID 0xFEFE) and are answered unicast (0xFEFF);
//! Get and Set are unicast both ways (0xFEFD).

pub mod block;
pub mod delay;
pub mod record;
pub mod responder;
pub mod station;

use crate::ethernet::be16_at;
use crate::ethernet::be32_at;

/// Length of the DCP header after the FrameID.
pub const HEADER_LEN: usize = 10;

/// The DCP service of a PDU.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ServiceId {
    /// Read parameters of one device.
    Get,
    /// Write parameters of one device (also Signal and reset to factory).
    Set,
    /// Find devices, all or by a filter.
    Identify,
    /// A device announces itself.
    Hello,
}

impl ServiceId {
    fn from_u8(value: u8) -> Option<Self> {
        match value {
            3 => Some(ServiceId::Get),
            4 => Some(ServiceId::Set),
            5 => Some(ServiceId::Identify),
            6 => Some(ServiceId::Hello),
            _ => None,
        }
    }

    fn to_u8(self) -> u8 {
        match self {
            ServiceId::Get => 3,
            ServiceId::Set => 4,
            ServiceId::Identify => 5,
            ServiceId::Hello => 6,
        }
    }
}

/// ServiceType: a request, or a response and its outcome.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ServiceType {
    /// A request.
    Request,
    /// A successful response (per-block errors travel in Control/Response blocks).
    ResponseSuccess,
    /// A response: the service is not supported.
    ResponseNotSupported,
    /// Any other value (a response with an error).
    Other(u8),
}

impl ServiceType {
    fn from_u8(value: u8) -> Self {
        match value {
            0 => ServiceType::Request,
            1 => ServiceType::ResponseSuccess,
            5 => ServiceType::ResponseNotSupported,
            other => ServiceType::Other(other),
        }
    }

    fn to_u8(self) -> u8 {
        match self {
            ServiceType::Request => 0,
            ServiceType::ResponseSuccess => 1,
            ServiceType::ResponseNotSupported => 5,
            ServiceType::Other(value) => value,
        }
    }
}

/// The DCP header after the FrameID.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct DcpHeader {
    /// The service.
    pub service_id: ServiceId,
    /// Request or response.
    pub service_type: ServiceType,
    /// Transaction id; a response echoes the request's.
    pub xid: u32,
    /// In an Identify request the ResponseDelayFactor (units of 10 ms); 0 elsewhere.
    pub response_delay: u16,
    /// Length of the blocks behind the header.
    pub data_length: u16,
}

/// A DCP PDU that cannot be decoded.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum DcpError {
    /// The PDU ends inside its header.
    #[error("DCP PDU of {have} bytes is shorter than its {HEADER_LEN}-byte header")]
    TruncatedHeader {
        /// Bytes present.
        have: usize,
    },
    /// The header names a service DCP does not define.
    #[error("unknown DCP ServiceID {0}")]
    UnknownService(u8),
    /// DCPDataLength points past the end of the frame.
    #[error("DCPDataLength {declared} exceeds the {available} bytes behind the header")]
    DataLength {
        /// DCPDataLength of the header.
        declared: u16,
        /// Bytes present behind the header.
        available: usize,
    },
    /// A block's length points past the end of the DCP data.
    #[error(
        "DCP block {option}/{suboption} of {declared} bytes exceeds the {available} bytes left"
    )]
    BlockLength {
        /// Option of the block.
        option: u8,
        /// Suboption of the block.
        suboption: u8,
        /// DCPBlockLength of the block.
        declared: u16,
        /// Bytes left in the DCP data.
        available: usize,
    },
    /// A block ends inside its 4-byte block header.
    #[error("DCP data ends inside a block header")]
    TruncatedBlock,
    /// The response does not fit the output buffer.
    #[error("DCP response needs {need} bytes, the buffer has {have}")]
    BufferTooSmall {
        /// Bytes needed.
        need: usize,
        /// Bytes available.
        have: usize,
    },
}

impl DcpHeader {
    /// Parses the header of `pdu` (the bytes after the FrameID); returns it and the
    /// DCP data (exactly DCPDataLength bytes, Ethernet padding cut off).
    pub fn parse(pdu: &[u8]) -> Result<(Self, &[u8]), DcpError> {
        let (Some(service_xid), Some(response_delay), Some(data_length)) =
            (be32_at(pdu, 2), be16_at(pdu, 6), be16_at(pdu, 8))
        else {
            return Err(DcpError::TruncatedHeader { have: pdu.len() });
        };
        let service_id = ServiceId::from_u8(pdu[0]).ok_or(DcpError::UnknownService(pdu[0]))?;
        let behind = &pdu[HEADER_LEN..];
        let data = behind
            .get(..usize::from(data_length))
            .ok_or(DcpError::DataLength {
                declared: data_length,
                available: behind.len(),
            })?;
        let header = Self {
            service_id,
            service_type: ServiceType::from_u8(pdu[1]),
            xid: service_xid,
            response_delay,
            data_length,
        };
        Ok((header, data))
    }

    /// Writes the header to the start of `out` (which must hold [`HEADER_LEN`] bytes).
    pub fn write(&self, out: &mut [u8]) -> Result<usize, DcpError> {
        let have = out.len();
        let header = out.get_mut(..HEADER_LEN).ok_or(DcpError::BufferTooSmall {
            need: HEADER_LEN,
            have,
        })?;
        header[0] = self.service_id.to_u8();
        header[1] = self.service_type.to_u8();
        header[2..6].copy_from_slice(&self.xid.to_be_bytes());
        header[6..8].copy_from_slice(&self.response_delay.to_be_bytes());
        header[8..10].copy_from_slice(&self.data_length.to_be_bytes());
        Ok(HEADER_LEN)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ethernet::EthernetHeader;
    use crate::testdata;
    use proptest::prelude::*;

    fn pdu_of(name: &str) -> Vec<u8> {
        let frame = testdata::frame(name);
        let (_, payload) = EthernetHeader::parse(&frame).unwrap();
        payload[2..].to_vec()
    }

    #[test]
    fn the_golden_identify_request_header_decodes() {
        let pdu = pdu_of("identify_req_s7");
        let (header, data) = DcpHeader::parse(&pdu).unwrap();
        assert_eq!(header.service_id, ServiceId::Identify);
        assert_eq!(header.service_type, ServiceType::Request);
        assert_eq!(header.xid, 0x0300_0152);
        assert_eq!(header.response_delay, 1);
        assert_eq!(header.data_length, 12);
        // The Ethernet padding behind the blocks is not part of the data.
        assert_eq!(data.len(), 12);
    }

    #[test]
    fn the_golden_set_response_header_decodes() {
        let pdu = pdu_of("dcp_set_res");
        let (header, data) = DcpHeader::parse(&pdu).unwrap();
        assert_eq!(header.service_id, ServiceId::Set);
        assert_eq!(header.service_type, ServiceType::ResponseSuccess);
        assert_eq!(header.xid, 0x0300_012d);
        assert_eq!(data, &[0x05, 0x04, 0x00, 0x03, 0x01, 0x02, 0x00, 0x00]);
    }

    #[test]
    fn a_data_length_beyond_the_frame_is_refused() {
        let pdu = [5, 0, 0, 0, 0, 1, 0, 0, 0, 8, 0xff, 0xff, 0, 0];
        assert_eq!(
            DcpHeader::parse(&pdu),
            Err(DcpError::DataLength {
                declared: 8,
                available: 4
            })
        );
    }

    #[test]
    fn an_unknown_service_is_refused() {
        let pdu = [9, 0, 0, 0, 0, 1, 0, 0, 0, 0];
        assert_eq!(DcpHeader::parse(&pdu), Err(DcpError::UnknownService(9)));
        assert_eq!(
            DcpHeader::parse(&pdu[..9]),
            Err(DcpError::TruncatedHeader { have: 9 })
        );
    }

    proptest! {
        #[test]
        fn write_then_parse_is_the_identity(
            service in 3u8..=6,
            service_type in any::<u8>(),
            xid in any::<u32>(),
            response_delay in any::<u16>(),
            data in proptest::collection::vec(any::<u8>(), 0..32),
        ) {
            let header = DcpHeader {
                service_id: ServiceId::from_u8(service).unwrap(),
                service_type: ServiceType::from_u8(service_type),
                xid,
                response_delay,
                data_length: data.len() as u16,
            };
            let mut pdu = vec![0; HEADER_LEN];
            header.write(&mut pdu).unwrap();
            pdu.extend_from_slice(&data);
            let (parsed, parsed_data) = DcpHeader::parse(&pdu).unwrap();
            prop_assert_eq!(parsed, header);
            prop_assert_eq!(parsed_data, &data[..]);
        }

        #[test]
        fn parse_never_panics(bytes in proptest::collection::vec(any::<u8>(), 0..24)) {
            let _ = DcpHeader::parse(&bytes);
        }
    }
}
