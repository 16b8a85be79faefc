//! Reassembly of fixed-length telegrams from a byte stream that arrives in arbitrary pieces.
//!
//! The TCP gateway transport has no framing: a telegram is simply the next
//! `telegram_length_plc_to_rob` bytes. Reading only into [`TelegramAssembler::unfilled`] never
//! takes bytes of the following telegram, so a peer that sends ahead is not misframed.

use shared_types::ipc::TELEGRAM_CAPACITY;

/// The requested telegram length does not fit a telegram buffer.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("telegram length {0} is outside 1..={TELEGRAM_CAPACITY}")]
pub struct TelegramLengthError(pub usize);

/// Collects the bytes of one telegram of fixed length.
#[derive(Debug, Clone)]
pub struct TelegramAssembler {
    buf: [u8; TELEGRAM_CAPACITY],
    length: usize,
    filled: usize,
}

impl TelegramAssembler {
    /// An empty assembler for telegrams of `length` bytes.
    pub fn new(length: usize) -> Result<Self, TelegramLengthError> {
        if length == 0 || length > TELEGRAM_CAPACITY {
            return Err(TelegramLengthError(length));
        }
        Ok(Self {
            buf: [0; TELEGRAM_CAPACITY],
            length,
            filled: 0,
        })
    }

    /// The telegram length.
    pub fn length(&self) -> usize {
        self.length
    }

    /// Bytes of the current telegram received so far.
    pub fn buffered(&self) -> usize {
        self.filled
    }

    /// The part of the buffer still missing; read into it, then call [`Self::fill`].
    /// Empty once the telegram is complete.
    pub fn unfilled(&mut self) -> &mut [u8] {
        &mut self.buf[self.filled..self.length]
    }

    /// Records that `n` more bytes were written into [`Self::unfilled`]; returns whether the
    /// telegram is now complete.
    pub fn fill(&mut self, n: usize) -> bool {
        self.filled = (self.filled + n).min(self.length);
        self.filled == self.length
    }

    /// The complete telegram, if there is one; the next read starts a new telegram.
    pub fn take(&mut self) -> Option<&[u8]> {
        if self.filled < self.length {
            return None;
        }
        self.filled = 0;
        Some(&self.buf[..self.length])
    }

    /// Drops a partial telegram (the peer went away or was replaced).
    pub fn clear(&mut self) {
        self.filled = 0;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// Feeds `stream` in pieces of the given sizes and returns the telegrams completed.
    fn assemble(length: usize, stream: &[u8], pieces: &[usize]) -> Vec<Vec<u8>> {
        let mut a = TelegramAssembler::new(length).unwrap();
        let mut out = Vec::new();
        let mut pos = 0;
        let mut sizes = pieces.iter().copied().cycle();
        while pos < stream.len() {
            let want = sizes.next().unwrap().max(1);
            let room = a.unfilled();
            let n = want.min(room.len()).min(stream.len() - pos);
            room[..n].copy_from_slice(&stream[pos..pos + n]);
            pos += n;
            if a.fill(n) {
                out.push(a.take().unwrap().to_vec());
            }
        }
        out
    }

    #[test]
    fn lengths_outside_the_buffer_are_refused() {
        assert_eq!(
            TelegramAssembler::new(0).unwrap_err(),
            TelegramLengthError(0)
        );
        assert!(TelegramAssembler::new(TELEGRAM_CAPACITY + 1).is_err());
        assert_eq!(TelegramAssembler::new(64).unwrap().length(), 64);
    }

    #[test]
    fn one_read_completes_a_telegram() {
        let stream: Vec<u8> = (0..64).collect();
        assert_eq!(assemble(64, &stream, &[64]), vec![stream]);
    }

    #[test]
    fn partial_reads_are_joined_and_never_cross_telegrams() {
        let stream: Vec<u8> = (0..=255u8).chain(0..=255u8).collect();
        let telegrams = assemble(256, &stream, &[1, 100, 200, 3]);
        assert_eq!(telegrams.len(), 2);
        assert_eq!(telegrams[0], stream[..256]);
        assert_eq!(telegrams[1], stream[256..]);
    }

    #[test]
    fn take_is_empty_until_complete_and_clear_drops_a_partial_telegram() {
        let mut a = TelegramAssembler::new(64).unwrap();
        a.unfilled()[..10].fill(7);
        assert!(!a.fill(10));
        assert_eq!(a.buffered(), 10);
        assert!(a.take().is_none());
        a.clear();
        assert_eq!(a.buffered(), 0);
        assert_eq!(a.unfilled().len(), 64);
    }

    proptest! {
        #[test]
        fn any_split_yields_the_same_telegrams(
            length in 64usize..=256,
            count in 1usize..4,
            pieces in proptest::collection::vec(1usize..300, 1..8),
        ) {
            let stream: Vec<u8> = (0..length * count).map(|i| (i * 7 % 251) as u8).collect();
            let telegrams = assemble(length, &stream, &pieces);
            let expected: Vec<Vec<u8>> = stream.chunks(length).map(<[u8]>::to_vec).collect();
            prop_assert_eq!(telegrams, expected);
        }
    }
}
