//! Typed access to command and response payloads through the generated field tables.
//!
//! A [`Field`] is one entry of a specification table (offset plus layout). Reading past the
//! end of a received payload yields zero, because clients trim trailing zero parameters.

/// Encoding of one value on the wire (big-endian for multi-byte values).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum WireType {
    U8,
    I8,
    U16,
    I16,
    U32,
    F32,
    Char,
}

impl WireType {
    /// Size in bytes.
    pub const fn size(self) -> usize {
        match self {
            Self::U8 | Self::I8 | Self::Char => 1,
            Self::U16 | Self::I16 => 2,
            Self::U32 | Self::F32 => 4,
        }
    }
}

/// Where in its byte(s) a field sits.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Layout {
    Scalar(WireType),
    /// Upper four bits of a byte.
    HighNibble,
    /// Lower four bits of a byte.
    LowNibble,
    /// One bit of a byte (0 = least significant).
    Bit(u8),
    /// `n` consecutive values (a string for `Char`).
    Array(WireType, usize),
}

/// One field of a payload table.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Field {
    pub offset: usize,
    pub layout: Layout,
}

impl Field {
    /// The `i`-th element of an array field as a scalar field.
    pub const fn element(self, i: usize) -> Field {
        match self.layout {
            Layout::Array(t, _) => Field {
                offset: self.offset + i * t.size(),
                layout: Layout::Scalar(t),
            },
            _ => self,
        }
    }

    /// Bytes this field spans.
    pub const fn size(self) -> usize {
        match self.layout {
            Layout::Scalar(t) => t.size(),
            Layout::Array(t, n) => t.size() * n,
            _ => 1,
        }
    }
}

/// The request or the response table of one command type, for building requests and
/// reading responses by field name ([`tables::REQUESTS`](super::tables::REQUESTS),
/// [`tables::RESPONSES`](super::tables::RESPONSES)).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FieldTable {
    /// The specification's function name, e.g. `MoveLinearAbsolute`.
    pub function: &'static str,
    pub command_type: u16,
    /// Full payload length in bytes, header included.
    pub len: usize,
    /// Every field by its snake_case name (`position_x`, `blending_parameter`, ...).
    pub fields: &'static [(&'static str, Field)],
    /// The six-value groups by name (`position` for `Position.X` .. `Position.RZ`).
    pub groups: &'static [(&'static str, [Field; 6])],
}

/// Reads fields of a received payload; bytes past its end read as zero.
#[derive(Debug, Clone, Copy)]
pub struct PayloadReader<'a> {
    bytes: &'a [u8],
}

impl<'a> PayloadReader<'a> {
    pub fn new(bytes: &'a [u8]) -> Self {
        Self { bytes }
    }

    fn byte(&self, i: usize) -> u8 {
        self.bytes.get(i).copied().unwrap_or(0)
    }

    fn be<const N: usize>(&self, offset: usize) -> [u8; N] {
        core::array::from_fn(|i| self.byte(offset + i))
    }

    /// An unsigned byte, a nibble or a bit (as 0/1).
    pub fn u8(&self, f: Field) -> u8 {
        let b = self.byte(f.offset);
        match f.layout {
            Layout::HighNibble => b >> 4,
            Layout::LowNibble => b & 0x0F,
            Layout::Bit(n) => (b >> n) & 1,
            _ => b,
        }
    }

    pub fn i8(&self, f: Field) -> i8 {
        self.byte(f.offset) as i8
    }

    pub fn bit(&self, f: Field) -> bool {
        self.u8(f) != 0
    }

    pub fn u16(&self, f: Field) -> u16 {
        u16::from_be_bytes(self.be(f.offset))
    }

    pub fn i16(&self, f: Field) -> i16 {
        i16::from_be_bytes(self.be(f.offset))
    }

    pub fn u32(&self, f: Field) -> u32 {
        u32::from_be_bytes(self.be(f.offset))
    }

    pub fn f32(&self, f: Field) -> f32 {
        f32::from_be_bytes(self.be(f.offset))
    }
}

/// Writes fields into a payload buffer that is at least as long as the table's `LEN`.
#[derive(Debug)]
pub struct PayloadWriter<'a> {
    bytes: &'a mut [u8],
}

impl<'a> PayloadWriter<'a> {
    pub fn new(bytes: &'a mut [u8]) -> Self {
        Self { bytes }
    }

    fn put(&mut self, offset: usize, src: &[u8]) {
        if let Some(dst) = self.bytes.get_mut(offset..offset + src.len()) {
            dst.copy_from_slice(src);
        }
    }

    /// An unsigned byte, a nibble or a bit (any non-zero value sets it).
    pub fn set_u8(&mut self, f: Field, v: u8) {
        let Some(b) = self.bytes.get_mut(f.offset) else {
            return;
        };
        *b = match f.layout {
            Layout::HighNibble => (*b & 0x0F) | (v << 4),
            Layout::LowNibble => (*b & 0xF0) | (v & 0x0F),
            Layout::Bit(n) if v != 0 => *b | (1 << n),
            Layout::Bit(n) => *b & !(1 << n),
            _ => v,
        };
    }

    pub fn set_bit(&mut self, f: Field, v: bool) {
        self.set_u8(f, u8::from(v));
    }

    pub fn set_i8(&mut self, f: Field, v: i8) {
        self.put(f.offset, &v.to_be_bytes());
    }

    pub fn set_u16(&mut self, f: Field, v: u16) {
        self.put(f.offset, &v.to_be_bytes());
    }

    pub fn set_i16(&mut self, f: Field, v: i16) {
        self.put(f.offset, &v.to_be_bytes());
    }

    pub fn set_u32(&mut self, f: Field, v: u32) {
        self.put(f.offset, &v.to_be_bytes());
    }

    pub fn set_f32(&mut self, f: Field, v: f32) {
        self.put(f.offset, &v.to_be_bytes());
    }

    /// A fixed-length string field: truncated to fit, padded with zeros.
    pub fn set_chars(&mut self, f: Field, s: &str) {
        let n = f.size();
        for i in 0..n {
            let c = s.as_bytes().get(i).copied().unwrap_or(0);
            self.put(f.offset + i, &[c]);
        }
    }

    /// Raw bytes of an array field (truncated or zero-padded to its size).
    pub fn set_bytes(&mut self, f: Field, src: &[u8]) {
        for i in 0..f.size() {
            self.put(f.offset + i, &[src.get(i).copied().unwrap_or(0)]);
        }
    }
}
