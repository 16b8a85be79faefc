//! The layout of a C_SDU: where each submodule's data, IOPS and IOCS sit.
//!
//! The controller fixes the layout in the Connect's IOCRBlockReq: per IO data object an
//! IODataObjectFrameOffset (its data, then its IOPS byte right behind), per submodule of
//! the other direction an IOCSFrameOffset, and the DataLength (≥ 40, the rest is zero
//! padding). Submodules without data (DAP, interface, port) still have an IOPS byte in the
//! input CR and an IOCS byte in the output CR. The layout lives in fixed arrays: it is
//! used in every cycle and must not allocate.

use super::frame::{MAX_C_SDU_LEN, MIN_C_SDU_LEN};
use super::ioxs::Ioxs;

/// Most IO data objects (and IOCS entries) one IOCR of this device carries: DAP,
/// interface, port and SRCI module, with room to spare.
pub const MAX_ENTRIES: usize = 16;

/// One submodule's data in the C_SDU.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct IoDataObject {
    /// Offset of the data in the C_SDU (IODataObjectFrameOffset).
    pub frame_offset: u16,
    /// Bytes of data; the IOPS follows at `frame_offset + data_length`.
    pub data_length: u16,
}

/// The data lengths of the SRCI module variants (the same in both directions).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SrciModuleSize {
    /// 64 bytes out, 64 in: the shortest telegram SRCI allows.
    Bytes64,
    /// 128 bytes out, 128 in.
    Bytes128,
    /// 256 bytes out, 256 in: the SRCI default.
    Bytes256,
}

impl SrciModuleSize {
    /// Data bytes per direction.
    pub fn data_length(self) -> u16 {
        match self {
            SrciModuleSize::Bytes64 => 64,
            SrciModuleSize::Bytes128 => 128,
            SrciModuleSize::Bytes256 => 256,
        }
    }
}

/// A layout that does not fit its C_SDU.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum LayoutError {
    /// DataLength outside 40..=1440.
    #[error("C_SDU DataLength {0} (40..=1440 allowed)")]
    DataLength(u16),
    /// An entry reaches beyond DataLength.
    #[error("bytes {start}..{end} lie beyond the C_SDU DataLength {data_length}")]
    OutOfRange {
        /// First byte of the entry.
        start: usize,
        /// One past its last byte.
        end: usize,
        /// DataLength.
        data_length: u16,
    },
    /// An entry overlaps another one.
    #[error("bytes {start}..{end} overlap another entry of the C_SDU")]
    Overlap {
        /// First byte of the entry.
        start: usize,
        /// One past its last byte.
        end: usize,
    },
    /// More entries than [`MAX_ENTRIES`].
    #[error("more than {MAX_ENTRIES} entries in one C_SDU")]
    TooManyEntries,
    /// A C_SDU buffer or data slice of the wrong length.
    #[error("{what} of {have} bytes where {need} are needed")]
    Length {
        /// What is too short or too long.
        what: &'static str,
        /// Bytes needed.
        need: usize,
        /// Bytes given.
        have: usize,
    },
}

/// Where the data objects and IOCS bytes of one IOCR sit.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CSduLayout {
    data_length: u16,
    objects: [IoDataObject; MAX_ENTRIES],
    object_count: usize,
    iocs: [u16; MAX_ENTRIES],
    iocs_count: usize,
}

impl CSduLayout {
    /// An empty layout of `data_length` bytes.
    pub fn new(data_length: u16) -> Result<Self, LayoutError> {
        if !(MIN_C_SDU_LEN..=MAX_C_SDU_LEN).contains(&usize::from(data_length)) {
            return Err(LayoutError::DataLength(data_length));
        }
        Ok(Self {
            data_length,
            objects: [IoDataObject::default(); MAX_ENTRIES],
            object_count: 0,
            iocs: [0; MAX_ENTRIES],
            iocs_count: 0,
        })
    }

    /// DataLength: the C_SDU's length.
    pub fn data_length(&self) -> usize {
        usize::from(self.data_length)
    }

    /// Adds an IO data object (data and IOPS); returns its index.
    pub fn add_data_object(&mut self, object: IoDataObject) -> Result<usize, LayoutError> {
        let start = usize::from(object.frame_offset);
        self.check_free(start, start + usize::from(object.data_length) + 1)?;
        if self.object_count == MAX_ENTRIES {
            return Err(LayoutError::TooManyEntries);
        }
        self.objects[self.object_count] = object;
        self.object_count += 1;
        Ok(self.object_count - 1)
    }

    /// Adds an IOCS byte at `frame_offset`; returns its index.
    pub fn add_iocs(&mut self, frame_offset: u16) -> Result<usize, LayoutError> {
        let start = usize::from(frame_offset);
        self.check_free(start, start + 1)?;
        if self.iocs_count == MAX_ENTRIES {
            return Err(LayoutError::TooManyEntries);
        }
        self.iocs[self.iocs_count] = frame_offset;
        self.iocs_count += 1;
        Ok(self.iocs_count - 1)
    }

    /// The IO data objects, in the order added.
    pub fn data_objects(&self) -> &[IoDataObject] {
        &self.objects[..self.object_count]
    }

    /// The IOCS offsets, in the order added.
    pub fn iocs_offsets(&self) -> &[u16] {
        &self.iocs[..self.iocs_count]
    }

    /// The data and IOPS of data object `index` in a received C_SDU.
    pub fn data<'a>(&self, c_sdu: &'a [u8], index: usize) -> Option<(&'a [u8], Ioxs)> {
        let object = self.data_objects().get(index)?;
        let start = usize::from(object.frame_offset);
        let end = start + usize::from(object.data_length);
        Some((c_sdu.get(start..end)?, Ioxs(*c_sdu.get(end)?)))
    }

    /// The IOCS `index` in a received C_SDU.
    pub fn iocs(&self, c_sdu: &[u8], index: usize) -> Option<Ioxs> {
        let offset = *self.iocs_offsets().get(index)?;
        c_sdu.get(usize::from(offset)).copied().map(Ioxs)
    }

    /// Writes data object `index` (exactly its length) and its IOPS into `c_sdu`.
    pub fn write_data(
        &self,
        c_sdu: &mut [u8],
        index: usize,
        data: &[u8],
        iops: Ioxs,
    ) -> Result<(), LayoutError> {
        self.check_buffer(c_sdu)?;
        let object = self.data_objects().get(index).ok_or(LayoutError::Length {
            what: "data object index",
            need: self.object_count,
            have: index,
        })?;
        let start = usize::from(object.frame_offset);
        let length = usize::from(object.data_length);
        if data.len() != length {
            return Err(LayoutError::Length {
                what: "IO data",
                need: length,
                have: data.len(),
            });
        }
        c_sdu[start..start + length].copy_from_slice(data);
        c_sdu[start + length] = iops.0;
        Ok(())
    }

    /// Writes IOCS `index` into `c_sdu`.
    pub fn write_iocs(
        &self,
        c_sdu: &mut [u8],
        index: usize,
        iocs: Ioxs,
    ) -> Result<(), LayoutError> {
        self.check_buffer(c_sdu)?;
        let offset = self.iocs_offsets().get(index).ok_or(LayoutError::Length {
            what: "IOCS index",
            need: self.iocs_count,
            have: index,
        })?;
        c_sdu[usize::from(*offset)] = iocs.0;
        Ok(())
    }

    fn check_buffer(&self, c_sdu: &[u8]) -> Result<(), LayoutError> {
        if c_sdu.len() == self.data_length() {
            Ok(())
        } else {
            Err(LayoutError::Length {
                what: "C_SDU",
                need: self.data_length(),
                have: c_sdu.len(),
            })
        }
    }

    /// Checks that `start..end` lies in the C_SDU and touches no entry yet.
    fn check_free(&self, start: usize, end: usize) -> Result<(), LayoutError> {
        if end > self.data_length() {
            return Err(LayoutError::OutOfRange {
                start,
                end,
                data_length: self.data_length,
            });
        }
        let objects = self.data_objects().iter().map(|o| {
            let s = usize::from(o.frame_offset);
            (s, s + usize::from(o.data_length) + 1)
        });
        let iocs = self
            .iocs_offsets()
            .iter()
            .map(|&o| (usize::from(o), usize::from(o) + 1));
        if objects.chain(iocs).any(|(s, e)| start < e && s < end) {
            return Err(LayoutError::Overlap { start, end });
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rt::frame::RtFrame;
    use crate::testdata;
    use proptest::prelude::*;

    fn object(frame_offset: u16, data_length: u16) -> IoDataObject {
        IoDataObject {
            frame_offset,
            data_length,
        }
    }

    /// The layouts of the golden S7-1515 Connect (decoded with tshark): input CR 0x8000
    /// and output CR 0x8001, DataLength 40 each.
    fn golden_layouts() -> (CSduLayout, CSduLayout) {
        let mut input = CSduLayout::new(40).unwrap();
        for (offset, length) in [(0, 0), (1, 0), (2, 0), (3, 1), (6, 1), (9, 8)] {
            input.add_data_object(object(offset, length)).unwrap();
        }
        for offset in [5, 8, 18] {
            input.add_iocs(offset).unwrap();
        }
        let mut output = CSduLayout::new(40).unwrap();
        for (offset, length) in [(4, 1), (7, 1), (10, 8)] {
            output.add_data_object(object(offset, length)).unwrap();
        }
        for offset in [0, 1, 2, 3, 6, 9] {
            output.add_iocs(offset).unwrap();
        }
        (input, output)
    }

    #[test]
    fn the_golden_input_frame_decodes_with_the_connect_s_layout() {
        let (input, _) = golden_layouts();
        let frame = testdata::frame("rtc_dev_8000");
        let (_, rt) = RtFrame::parse(&frame).unwrap();
        assert_eq!(input.data(rt.c_sdu, 0), Some((&[][..], Ioxs::GOOD)));
        assert_eq!(input.data(rt.c_sdu, 3), Some((&[0x2c][..], Ioxs::GOOD)));
        assert_eq!(input.data(rt.c_sdu, 4), Some((&[0x2d][..], Ioxs::GOOD)));
        assert_eq!(input.data(rt.c_sdu, 5), Some((&[0; 8][..], Ioxs::GOOD)));
        for index in 0..3 {
            assert_eq!(input.iocs(rt.c_sdu, index), Some(Ioxs::GOOD));
        }
        assert_eq!(input.data(rt.c_sdu, 6), None);
    }

    #[test]
    fn writing_with_the_layout_reproduces_the_golden_output_c_sdu() {
        let (_, output) = golden_layouts();
        let frame = testdata::frame("echo_cpu_8001");
        let (_, rt) = RtFrame::parse(&frame).unwrap();
        let mut c_sdu = [0u8; 40];
        output
            .write_data(&mut c_sdu, 0, &[0x01], Ioxs::GOOD)
            .unwrap();
        output
            .write_data(&mut c_sdu, 1, &[0x00], Ioxs::GOOD)
            .unwrap();
        output
            .write_data(
                &mut c_sdu,
                2,
                &[0x12, 0x34, 0x56, 0x78, 0x3f, 0xc0, 0, 0],
                Ioxs::GOOD,
            )
            .unwrap();
        for index in 0..6 {
            output.write_iocs(&mut c_sdu, index, Ioxs::GOOD).unwrap();
        }
        assert_eq!(c_sdu[..], rt.c_sdu[..]);
    }

    #[test]
    fn the_srci_input_cr_of_256_bytes_fits() {
        // DAP, interface, port (IOPS only), the SRCI module's 256 bytes + IOPS, and the
        // IOCS of the SRCI output submodule.
        let size = SrciModuleSize::Bytes256;
        let mut input = CSduLayout::new(3 + size.data_length() + 1 + 1).unwrap();
        for offset in 0..3 {
            input.add_data_object(object(offset, 0)).unwrap();
        }
        let srci = input
            .add_data_object(object(3, size.data_length()))
            .unwrap();
        let iocs = input.add_iocs(260).unwrap();
        let mut c_sdu = [0u8; 261];
        let telegram: Vec<u8> = (0..=255).collect();
        input
            .write_data(&mut c_sdu, srci, &telegram, Ioxs::GOOD)
            .unwrap();
        input.write_iocs(&mut c_sdu, iocs, Ioxs::GOOD).unwrap();
        assert_eq!(input.data(&c_sdu, srci), Some((&telegram[..], Ioxs::GOOD)));
        assert_eq!(c_sdu[259], 0x80);
        assert_eq!(
            input.write_data(&mut c_sdu, srci, &telegram[..128], Ioxs::GOOD),
            Err(LayoutError::Length {
                what: "IO data",
                need: 256,
                have: 128
            })
        );
        assert_eq!(SrciModuleSize::Bytes64.data_length(), 64);
        assert_eq!(SrciModuleSize::Bytes128.data_length(), 128);
    }

    #[test]
    fn inconsistent_layouts_are_refused() {
        assert_eq!(CSduLayout::new(39), Err(LayoutError::DataLength(39)));
        assert_eq!(CSduLayout::new(1441), Err(LayoutError::DataLength(1441)));
        let mut layout = CSduLayout::new(40).unwrap();
        layout.add_data_object(object(0, 4)).unwrap();
        assert_eq!(
            layout.add_iocs(4),
            Err(LayoutError::Overlap { start: 4, end: 5 })
        );
        assert_eq!(
            layout.add_data_object(object(30, 10)),
            Err(LayoutError::OutOfRange {
                start: 30,
                end: 41,
                data_length: 40
            })
        );
        for offset in 5..5 + MAX_ENTRIES as u16 {
            layout.add_iocs(offset).unwrap();
        }
        assert_eq!(layout.add_iocs(30), Err(LayoutError::TooManyEntries));
        assert!(matches!(
            layout.write_iocs(&mut [0; 39], 0, Ioxs::GOOD),
            Err(LayoutError::Length { what: "C_SDU", .. })
        ));
    }

    proptest! {
        #[test]
        fn written_data_reads_back_and_touches_only_its_bytes(
            lengths in proptest::collection::vec(0u16..40, 1..6),
            fill in any::<u8>(),
        ) {
            let mut layout = CSduLayout::new(300).unwrap();
            let mut offset = 0u16;
            for length in &lengths {
                layout.add_data_object(object(offset, *length)).unwrap();
                offset += length + 1;
            }
            let iocs = layout.add_iocs(offset).unwrap();
            let mut c_sdu = [0u8; 300];
            for (index, length) in lengths.iter().enumerate() {
                let data = vec![fill; usize::from(*length)];
                layout.write_data(&mut c_sdu, index, &data, Ioxs::GOOD).unwrap();
            }
            layout.write_iocs(&mut c_sdu, iocs, Ioxs(0x81)).unwrap();
            for (index, length) in lengths.iter().enumerate() {
                let (data, iops) = layout.data(&c_sdu, index).unwrap();
                prop_assert_eq!(data.len(), usize::from(*length));
                prop_assert!(data.iter().all(|&b| b == fill));
                prop_assert_eq!(iops, Ioxs::GOOD);
            }
            prop_assert_eq!(layout.iocs(&c_sdu, iocs), Some(Ioxs(0x81)));
            prop_assert!(c_sdu[usize::from(offset) + 1..].iter().all(|&b| b == 0));
        }
    }
}
