//! DCP blocks: `Option(1) Suboption(1) DCPBlockLength(2) value`, padded to an even length.
//!
//! Blocks of Identify requests (filters) carry the bare value; blocks of Set requests begin
//! with a BlockQualifier, blocks of responses with a BlockInfo (2 bytes each, counted in
//! DCPBlockLength). Get requests carry bare `Option Suboption` pairs, no length.

use super::DcpError;
use crate::ethernet::be16_at;

/// The Option/Suboption pair that names a block.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BlockType {
    /// Option.
    pub option: u8,
    /// Suboption.
    pub suboption: u8,
}

const fn block_type(option: u8, suboption: u8) -> BlockType {
    BlockType { option, suboption }
}

/// IP/MAC address.
pub const MAC_ADDRESS: BlockType = block_type(1, 1);
/// IP/IP parameter: address, subnet mask, gateway.
pub const IP_PARAMETER: BlockType = block_type(1, 2);
/// Device properties/TypeOfStation (DeviceVendorValue).
pub const TYPE_OF_STATION: BlockType = block_type(2, 1);
/// Device properties/NameOfStation.
pub const NAME_OF_STATION: BlockType = block_type(2, 2);
/// Device properties/DeviceID: VendorID and DeviceID.
pub const DEVICE_ID: BlockType = block_type(2, 3);
/// Device properties/DeviceRole.
pub const DEVICE_ROLE: BlockType = block_type(2, 4);
/// Device properties/DeviceOptions: the blocks the device supports.
pub const DEVICE_OPTIONS: BlockType = block_type(2, 5);
/// Device properties/DeviceInstance.
pub const DEVICE_INSTANCE: BlockType = block_type(2, 7);
/// Control/Start of a Set transaction.
pub const CONTROL_START: BlockType = block_type(5, 1);
/// Control/Stop of a Set transaction.
pub const CONTROL_STOP: BlockType = block_type(5, 2);
/// Control/Signal: flash the identification LED.
pub const CONTROL_SIGNAL: BlockType = block_type(5, 3);
/// Control/Response: the outcome of one block of a Set (or Get) request.
pub const CONTROL_RESPONSE: BlockType = block_type(5, 4);
/// Control/FactoryReset (the older form of reset to factory).
pub const CONTROL_FACTORY_RESET: BlockType = block_type(5, 5);
/// Control/ResetToFactory with the reset mode in the BlockQualifier.
pub const CONTROL_RESET_TO_FACTORY: BlockType = block_type(5, 6);
/// All selector: an Identify filter that matches every device.
pub const ALL_SELECTOR: BlockType = block_type(0xff, 0xff);

/// DeviceRole value of an IO-device.
pub const DEVICE_ROLE_IO_DEVICE: u8 = 0x01;
/// Signal value "flash once", the only one defined.
pub const SIGNAL_FLASH_ONCE: u16 = 0x0100;

/// BlockError of a Control/Response block.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BlockError {
    /// Done.
    NoError,
    /// The option is not supported.
    OptionNotSupported,
    /// The suboption is not supported (or no data set is available).
    SuboptionNotSupported,
    /// The suboption is not set.
    SuboptionNotSet,
    /// A resource (here the permanent store) failed.
    ResourceError,
    /// The value cannot be set for local reasons (for example it is invalid).
    SetNotPossible,
}

impl BlockError {
    /// The code on the wire.
    pub fn code(self) -> u8 {
        match self {
            BlockError::NoError => 0,
            BlockError::OptionNotSupported => 1,
            BlockError::SuboptionNotSupported => 2,
            BlockError::SuboptionNotSet => 3,
            BlockError::ResourceError => 4,
            BlockError::SetNotPossible => 5,
        }
    }
}

/// One block of a request.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Block<'a> {
    /// Option and suboption.
    pub block_type: BlockType,
    /// The DCPBlockLength bytes behind the block header (qualifier or info included).
    pub value: &'a [u8],
}

impl<'a> Block<'a> {
    /// Splits a Set block's value into its BlockQualifier and the rest.
    pub fn qualified(&self) -> Option<(u16, &'a [u8])> {
        Some((be16_at(self.value, 0)?, &self.value[2..]))
    }
}

/// The blocks of DCP data, in order.
#[derive(Debug, Clone)]
pub struct Blocks<'a> {
    rest: &'a [u8],
}

/// Iterates over the blocks of `data`; a malformed block ends the iteration with an error.
pub fn blocks(data: &[u8]) -> Blocks<'_> {
    Blocks { rest: data }
}

impl<'a> Iterator for Blocks<'a> {
    type Item = Result<Block<'a>, DcpError>;

    fn next(&mut self) -> Option<Self::Item> {
        if self.rest.is_empty() {
            return None;
        }
        let Some(length) = be16_at(self.rest, 2) else {
            self.rest = &[];
            return Some(Err(DcpError::TruncatedBlock));
        };
        let block_type = block_type(self.rest[0], self.rest[1]);
        let end = 4 + usize::from(length);
        let Some(value) = self.rest.get(4..end) else {
            let available = self.rest.len() - 4;
            self.rest = &[];
            return Some(Err(DcpError::BlockLength {
                option: block_type.option,
                suboption: block_type.suboption,
                declared: length,
                available,
            }));
        };
        // The pad byte of an odd block may be missing behind the last one.
        let next = (end + (end & 1)).min(self.rest.len());
        self.rest = &self.rest[next..];
        Some(Ok(Block { block_type, value }))
    }
}

/// Writes blocks, each with its BlockInfo and pad byte, into a byte buffer.
#[derive(Debug)]
pub struct BlockWriter<'a> {
    out: &'a mut [u8],
    len: usize,
}

impl<'a> BlockWriter<'a> {
    /// A writer that fills `out` from its start.
    pub fn new(out: &'a mut [u8]) -> Self {
        Self { out, len: 0 }
    }

    /// Bytes written so far.
    pub fn len(&self) -> usize {
        self.len
    }

    /// True while nothing is written.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Appends a block of `block_type` with `block_info` and the concatenated `parts`.
    pub fn block(
        &mut self,
        block_type: BlockType,
        block_info: u16,
        parts: &[&[u8]],
    ) -> Result<(), DcpError> {
        let value_len = 2 + parts.iter().map(|part| part.len()).sum::<usize>();
        let padded = 4 + value_len + (value_len & 1);
        let need = self.len + padded;
        let too_small = DcpError::BufferTooSmall {
            need,
            have: self.out.len(),
        };
        let length = u16::try_from(value_len).map_err(|_| too_small)?;
        let Some(block) = self.out.get_mut(self.len..need) else {
            return Err(too_small);
        };
        block[0] = block_type.option;
        block[1] = block_type.suboption;
        block[2..4].copy_from_slice(&length.to_be_bytes());
        block[4..6].copy_from_slice(&block_info.to_be_bytes());
        let mut at = 6;
        for part in parts {
            block[at..at + part.len()].copy_from_slice(part);
            at += part.len();
        }
        block[at..].fill(0);
        self.len = need;
        Ok(())
    }

    /// Appends a Control/Response block: the outcome of the request block `answered`.
    /// Its three bytes (option, suboption, BlockError) take the place of BlockInfo + value.
    pub fn control_response(
        &mut self,
        answered: BlockType,
        error: BlockError,
    ) -> Result<(), DcpError> {
        let need = self.len + 8;
        let Some(block) = self.out.get_mut(self.len..need) else {
            return Err(DcpError::BufferTooSmall {
                need,
                have: self.out.len(),
            });
        };
        block.copy_from_slice(&[
            CONTROL_RESPONSE.option,
            CONTROL_RESPONSE.suboption,
            0,
            3,
            answered.option,
            answered.suboption,
            error.code(),
            0,
        ]);
        self.len = need;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dcp::DcpHeader;
    use crate::ethernet::EthernetHeader;
    use crate::testdata;
    use proptest::prelude::*;

    fn data_of(name: &str) -> Vec<u8> {
        let frame = testdata::frame(name);
        let (_, payload) = EthernetHeader::parse(&frame).unwrap();
        let (_, data) = DcpHeader::parse(&payload[2..]).unwrap();
        data.to_vec()
    }

    #[test]
    fn the_golden_identify_response_has_the_p_net_blocks_in_order() {
        let data = data_of("ident_ok_pnet");
        let parsed: Vec<Block> = blocks(&data).collect::<Result<_, _>>().unwrap();
        let types: Vec<BlockType> = parsed.iter().map(|b| b.block_type).collect();
        assert_eq!(
            types,
            [
                IP_PARAMETER,
                TYPE_OF_STATION,
                NAME_OF_STATION,
                DEVICE_ID,
                DEVICE_ROLE,
                DEVICE_OPTIONS
            ]
        );
        // NameOfStation "rt-labs-dev" is odd with its BlockInfo: the pad byte is skipped.
        assert_eq!(&parsed[2].value[2..], b"rt-labs-dev");
        assert_eq!(parsed[3].value, &[0, 0, 0x04, 0x93, 0x00, 0x02]);
    }

    #[test]
    fn the_golden_set_request_carries_a_temporary_ip() {
        let data = data_of("dcp_set_req");
        let parsed: Vec<Block> = blocks(&data).collect::<Result<_, _>>().unwrap();
        assert_eq!(parsed.len(), 1);
        assert_eq!(parsed[0].block_type, IP_PARAMETER);
        let (qualifier, value) = parsed[0].qualified().unwrap();
        assert_eq!(qualifier, 0);
        assert_eq!(value, &[172, 16, 2, 10, 255, 255, 255, 0, 172, 16, 2, 10]);
    }

    #[test]
    fn the_control_response_matches_the_golden_set_response() {
        let mut out = [0xaa; 8];
        let mut writer = BlockWriter::new(&mut out);
        writer
            .control_response(IP_PARAMETER, BlockError::NoError)
            .unwrap();
        assert_eq!(writer.len(), 8);
        assert_eq!(out.to_vec(), data_of("dcp_set_res"));
    }

    #[test]
    fn a_block_longer_than_the_data_is_refused() {
        let data = [2, 2, 0, 9, b'a', b'b'];
        let mut iter = blocks(&data);
        assert_eq!(
            iter.next(),
            Some(Err(DcpError::BlockLength {
                option: 2,
                suboption: 2,
                declared: 9,
                available: 2
            }))
        );
        assert_eq!(iter.next(), None);
        assert_eq!(
            blocks(&[2, 2, 0]).next(),
            Some(Err(DcpError::TruncatedBlock))
        );
    }

    #[test]
    fn a_full_buffer_is_reported() {
        let mut out = [0; 9];
        let mut writer = BlockWriter::new(&mut out);
        assert_eq!(
            writer.block(NAME_OF_STATION, 0, &[b"abcd"]),
            Err(DcpError::BufferTooSmall { need: 10, have: 9 })
        );
        assert!(writer.is_empty());
    }

    proptest! {
        #[test]
        fn written_blocks_read_back(
            values in proptest::collection::vec(
                (any::<u8>(), any::<u8>(), any::<u16>(), proptest::collection::vec(any::<u8>(), 0..20)),
                0..6,
            ),
        ) {
            let mut out = [0u8; 512];
            let mut writer = BlockWriter::new(&mut out);
            for (option, suboption, info, value) in &values {
                writer.block(block_type(*option, *suboption), *info, &[value]).unwrap();
            }
            let len = writer.len();
            prop_assert_eq!(len % 2, 0);
            let read: Vec<Block> = blocks(&out[..len]).collect::<Result<_, _>>().unwrap();
            prop_assert_eq!(read.len(), values.len());
            for (block, (option, suboption, info, value)) in read.iter().zip(&values) {
                prop_assert_eq!(block.block_type, block_type(*option, *suboption));
                prop_assert_eq!(block.qualified(), Some((*info, &value[..])));
            }
        }

        #[test]
        fn reading_never_panics(bytes in proptest::collection::vec(any::<u8>(), 0..40)) {
            for block in blocks(&bytes) {
                let _ = block.map(|b| b.qualified());
            }
        }
    }
}
