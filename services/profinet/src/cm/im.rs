//! I&M1 to I&M4, the identification and maintenance records a controller (or TIA Portal's
//! "Online & diagnostics") writes and reads: plant designation and location, installation
//! date, a descriptor and a signature. One set for the whole device, answered on every
//! submodule as I&M0 is, kept across restarts by the shell in a text record:
//!
//! ```text
//! im1 = <108 hex digits>
//! im2 = <32 hex digits>
//! im3 = <108 hex digits>
//! im4 = <108 hex digits>
//! ```

use std::fmt::Write as _;

use pnio::cm::block::BlockHeader;

use crate::dcp::record::key_values;

/// Index of I&M1 (TagFunction, TagLocation).
pub const INDEX_IM1: u16 = 0xaff1;
/// Index of I&M2 (installation date).
pub const INDEX_IM2: u16 = 0xaff2;
/// Index of I&M3 (descriptor).
pub const INDEX_IM3: u16 = 0xaff3;
/// Index of I&M4 (signature).
pub const INDEX_IM4: u16 = 0xaff4;
/// I&M0's IM_Supported: bits 1 to 4, I&M1 to I&M4.
pub const IM_SUPPORTED: u16 = 0x001e;

/// Lengths of the records' data behind their block header (and version).
const IM1_LEN: usize = 54;
const IM2_LEN: usize = 16;
const IM3_LEN: usize = 54;
const IM4_LEN: usize = 54;
/// BlockType of I&M1; I&M2..4 follow it.
const BLOCK_TYPE_IM1: u16 = 0x0021;

/// A Write of an I&M record this device refuses.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum ImWriteError {
    /// The record's block header is missing or of another block.
    #[error("the record is not an I&M{0} block")]
    Block(u8),
    /// The record's data has another length than the record's.
    #[error("I&M{record} data of {have} bytes (the record has {want})")]
    Length {
        /// Which record (1..=4).
        record: u8,
        /// Bytes written.
        have: usize,
        /// Bytes the record has.
        want: usize,
    },
}

/// A stored I&M text record that cannot be read back.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ImRecordError {
    /// A line is not `imN = hex` for N in 1..=4.
    #[error("line {0}: expected `im1..im4 = hex digits`")]
    Syntax(usize),
    /// A value is not hex or has the wrong length.
    #[error("line {line}: not {want} bytes of hex")]
    Value {
        /// Line number (from 1).
        line: usize,
        /// Bytes the record has.
        want: usize,
    },
}

/// The writable I&M records.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ImRecords {
    im1: [u8; IM1_LEN],
    im2: [u8; IM2_LEN],
    im3: [u8; IM3_LEN],
    im4: [u8; IM4_LEN],
}

impl Default for ImRecords {
    /// What a new device answers: blank visible strings, and a signature of zeros (an
    /// octet string).
    fn default() -> Self {
        Self {
            im1: [b' '; IM1_LEN],
            im2: [b' '; IM2_LEN],
            im3: [b' '; IM3_LEN],
            im4: [0; IM4_LEN],
        }
    }
}

impl ImRecords {
    /// The record at `index` as a Read returns it (block header included); `None` for
    /// an index that is not I&M1..4.
    pub fn read(&self, index: u16) -> Option<Vec<u8>> {
        let (number, data) = self.field(index)?;
        let mut out = Vec::with_capacity(BlockHeader::LEN + data.len());
        BlockHeader::write(&mut out, block_type(number), data_len(data.len()));
        out.extend_from_slice(data);
        Some(out)
    }

    /// Takes the Write of `record` (block header included) to `index`; `Ok(true)` when
    /// a value changed, `None` for an index that is not I&M1..4.
    pub fn write(&mut self, index: u16, record: &[u8]) -> Option<Result<bool, ImWriteError>> {
        let number = number(index)?;
        let Ok((header, data)) = BlockHeader::parse(record) else {
            return Some(Err(ImWriteError::Block(number)));
        };
        if header.block_type != block_type(number) {
            return Some(Err(ImWriteError::Block(number)));
        }
        let field = self.field_mut(number);
        if data.len() != field.len() {
            return Some(Err(ImWriteError::Length {
                record: number,
                have: data.len(),
                want: field.len(),
            }));
        }
        let changed = field != data;
        field.copy_from_slice(data);
        Some(Ok(changed))
    }

    /// The text record of the four values.
    pub fn encode(&self) -> String {
        let mut text = String::new();
        for index in INDEX_IM1..=INDEX_IM4 {
            let Some((number, field)) = self.field(index) else {
                continue;
            };
            let _ = write!(text, "im{number} = ");
            for byte in field {
                // Writing to a String cannot fail.
                let _ = write!(text, "{byte:02x}");
            }
            text.push('\n');
        }
        text
    }

    /// Reads a text record written by [`Self::encode`]; records it lacks stay blank.
    pub fn decode(text: &str) -> Result<Self, ImRecordError> {
        let mut records = Self::default();
        for entry in key_values(text) {
            let (line, key, value) = entry.map_err(ImRecordError::Syntax)?;
            let number = match key {
                "im1" => 1,
                "im2" => 2,
                "im3" => 3,
                "im4" => 4,
                _ => return Err(ImRecordError::Syntax(line)),
            };
            let field = records.field_mut(number);
            let want = field.len();
            let bytes = hex(value).filter(|b| b.len() == want);
            let bytes = bytes.ok_or(ImRecordError::Value { line, want })?;
            field.copy_from_slice(&bytes);
        }
        Ok(records)
    }

    fn field(&self, index: u16) -> Option<(u8, &[u8])> {
        let number = number(index)?;
        let field: &[u8] = match number {
            1 => &self.im1,
            2 => &self.im2,
            3 => &self.im3,
            _ => &self.im4,
        };
        Some((number, field))
    }

    fn field_mut(&mut self, number: u8) -> &mut [u8] {
        match number {
            1 => &mut self.im1,
            2 => &mut self.im2,
            3 => &mut self.im3,
            _ => &mut self.im4,
        }
    }
}

/// 1..=4 for the indices of I&M1..4.
fn number(index: u16) -> Option<u8> {
    match index {
        INDEX_IM1 => Some(1),
        INDEX_IM2 => Some(2),
        INDEX_IM3 => Some(3),
        INDEX_IM4 => Some(4),
        _ => None,
    }
}

fn block_type(number: u8) -> u16 {
    BLOCK_TYPE_IM1 + u16::from(number) - 1
}

/// The records are at most 54 bytes long.
fn data_len(len: usize) -> u16 {
    u16::try_from(len).unwrap_or(u16::MAX)
}

fn hex(text: &str) -> Option<Vec<u8>> {
    if !text.len().is_multiple_of(2) {
        return None;
    }
    (0..text.len())
        .step_by(2)
        .map(|at| u8::from_str_radix(text.get(at..at + 2)?, 16).ok())
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// An I&M1 record as a controller writes it.
    fn im1(function: &str, location: &str) -> Vec<u8> {
        let mut record = vec![0x00, 0x21, 0x00, 56, 1, 0];
        record.extend(format!("{function:<32}{location:<22}").bytes());
        record
    }

    #[test]
    fn a_new_device_answers_blank_records_with_their_block_headers() {
        let records = ImRecords::default();
        let read = records.read(INDEX_IM2).unwrap();
        assert_eq!(read[..6], [0x00, 0x22, 0x00, 18, 1, 0]);
        assert_eq!(read[6..], [b' '; 16]);
        let signature = records.read(INDEX_IM4).unwrap();
        assert_eq!(signature[..6], [0x00, 0x24, 0x00, 56, 1, 0]);
        assert!(signature[6..].iter().all(|&b| b == 0));
        assert_eq!(records.read(0xaff0), None);
        assert_eq!(records.read(0xaff5), None);
    }

    #[test]
    fn a_written_record_is_read_back_and_checked() {
        let mut records = ImRecords::default();
        let record = im1("robot cell 1", "hall 3");
        assert_eq!(records.write(INDEX_IM1, &record), Some(Ok(true)));
        assert_eq!(records.read(INDEX_IM1), Some(record.clone()));
        assert_eq!(records.write(INDEX_IM1, &record), Some(Ok(false)));
        assert_eq!(
            records.write(INDEX_IM2, &record),
            Some(Err(ImWriteError::Block(2)))
        );
        let mut short = record.clone();
        short.truncate(20);
        short[3] = 16;
        assert_eq!(
            records.write(INDEX_IM1, &short),
            Some(Err(ImWriteError::Length {
                record: 1,
                have: 14,
                want: 54
            }))
        );
        assert_eq!(records.write(0x8071, &record), None);
    }

    #[test]
    fn the_text_record_reads_back_and_refuses_damage() {
        let mut records = ImRecords::default();
        records.write(INDEX_IM1, &im1("robot cell 1", "hall 3"));
        assert_eq!(ImRecords::decode(&records.encode()), Ok(records));
        assert_eq!(ImRecords::decode(""), Ok(ImRecords::default()));
        assert_eq!(
            ImRecords::decode("im2 = 2020\n"),
            Err(ImRecordError::Value { line: 1, want: 16 })
        );
        assert_eq!(
            ImRecords::decode("\nim5 = 00\n"),
            Err(ImRecordError::Syntax(2))
        );
    }

    proptest! {
        #[test]
        fn any_write_of_the_right_length_reads_back(number in 1u8..=4, byte in any::<u8>()) {
            let index = INDEX_IM1 + u16::from(number) - 1;
            let mut records = ImRecords::default();
            let mut record = records.read(index).unwrap();
            record[6..].fill(byte);
            prop_assert!(records.write(index, &record).unwrap().is_ok());
            prop_assert_eq!(records.read(index).unwrap(), record);
            prop_assert_eq!(ImRecords::decode(&records.encode()).unwrap(), records);
        }
    }
}
