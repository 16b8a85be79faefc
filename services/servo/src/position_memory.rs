//! The simulated drives' "absolute encoders": the joint position survives a restart of the
//! servo process (or of the whole controller), as a real arm stays where it stopped.
//!
//! The position lives in `<data_dir>/servo_position.bin`, mapped into the servo's memory
//! (`MAP_SHARED`): the tick loop stores every tick's position with plain memory writes, no
//! system call, and the kernel keeps the page when the process is killed, so a restarted
//! servo continues from the last tick the killed one completed. (A thread that wrote a file
//! every 20 ms lagged by up to 80 ms on a loaded 2-core machine, and the restarted servo's
//! joints jumped by that much of their motion.)
//!
//! The file holds two slots written in turn, each `[sequence, q₁..q₆, check]` as 64-bit
//! words, the check a hash of the other seven written last: a slot the kill interrupted
//! fails its check and the other one, one tick older, is taken.

use std::fs::OpenOptions;
use std::os::fd::AsRawFd;
use std::path::Path;
use std::ptr::NonNull;

use shared_types::ipc::AXES;

const FILE_NAME: &str = "servo_position.bin";
/// 64-bit words per slot: the sequence, the joints and the check.
const WORDS: usize = AXES + 2;
/// Bytes of the file: two slots.
const SIZE: usize = 2 * WORDS * 8;

/// FNV-1a over the words: the check of a slot.
fn check(words: &[u64]) -> u64 {
    words.iter().fold(0xcbf2_9ce4_8422_2325, |h, w| {
        (h ^ w).wrapping_mul(0x0000_0100_0000_01b3)
    })
}

/// The joint position of the slot `words`, with its sequence, if it is complete.
fn slot_position(words: &[u64; WORDS]) -> Option<(u64, [f64; AXES])> {
    let sequence = words[0];
    let q: [f64; AXES] = core::array::from_fn(|i| f64::from_bits(words[1 + i]));
    (sequence != 0
        && words[WORDS - 1] == check(&words[..WORDS - 1])
        && q.iter().all(|v| v.is_finite()))
    .then_some((sequence, q))
}

/// The newer complete slot of the two.
fn newest(slots: &[[u64; WORDS]; 2]) -> Option<(u64, [f64; AXES])> {
    slots
        .iter()
        .filter_map(slot_position)
        .max_by_key(|(sequence, _)| *sequence)
}

/// The position file mapped into memory.
pub struct PositionMemory {
    words: NonNull<u64>,
    sequence: u64,
}

impl PositionMemory {
    /// Opens (or creates) the position file in `dir` and maps it; with it the position it
    /// holds, if it holds one.
    pub fn open(dir: &Path) -> std::io::Result<(Self, Option<[f64; AXES]>)> {
        std::fs::create_dir_all(dir)?;
        let file = OpenOptions::new()
            .read(true)
            .write(true)
            .create(true)
            .truncate(false)
            .open(dir.join(FILE_NAME))?;
        if file.metadata()?.len() != SIZE as u64 {
            // A file of another size holds nothing of ours: both slots fail their checks.
            file.set_len(0)?;
            file.set_len(SIZE as u64)?;
        }
        // SAFETY: a fresh shared mapping of the whole file, which is SIZE bytes long; the
        // descriptor may be closed afterwards (the mapping keeps the file).
        let address = unsafe {
            libc::mmap(
                core::ptr::null_mut(),
                SIZE,
                libc::PROT_READ | libc::PROT_WRITE,
                libc::MAP_SHARED,
                file.as_raw_fd(),
                0,
            )
        };
        if address == libc::MAP_FAILED {
            return Err(std::io::Error::last_os_error());
        }
        let words = NonNull::new(address.cast::<u64>()).ok_or(std::io::ErrorKind::Other)?;
        let mut memory = Self { words, sequence: 0 };
        let stored = newest(&memory.read());
        memory.sequence = stored.map_or(0, |(sequence, _)| sequence);
        Ok((memory, stored.map(|(_, q)| q)))
    }

    /// Both slots as they are in the file.
    fn read(&self) -> [[u64; WORDS]; 2] {
        core::array::from_fn(|s| {
            core::array::from_fn(|w| {
                // SAFETY: inside the mapping of 2·WORDS words.
                unsafe { self.words.as_ptr().add(s * WORDS + w).read_volatile() }
            })
        })
    }

    /// Stores `q` (for the tick loop: plain memory writes into the older slot, the check
    /// last, so that a kill in between leaves the other slot as it was).
    pub fn store(&mut self, q: &[f64; AXES]) {
        self.sequence += 1;
        let mut words = [0u64; WORDS];
        words[0] = self.sequence;
        for (w, v) in words[1..=AXES].iter_mut().zip(q) {
            *w = v.to_bits();
        }
        words[WORDS - 1] = check(&words[..WORDS - 1]);
        let slot = (self.sequence % 2) as usize * WORDS;
        for (i, w) in words.iter().enumerate() {
            // SAFETY: inside the mapping; volatile keeps the check the last write.
            unsafe { self.words.as_ptr().add(slot + i).write_volatile(*w) };
        }
    }
}

impl Drop for PositionMemory {
    fn drop(&mut self) {
        // SAFETY: the mapping made in `open`, unmapped once. Synchronously written first so
        // that a controller switched off after a clean stop keeps the position too.
        unsafe {
            libc::msync(self.words.as_ptr().cast(), SIZE, libc::MS_SYNC);
            libc::munmap(self.words.as_ptr().cast(), SIZE);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn temp_dir(name: &str) -> std::path::PathBuf {
        let dir = std::env::temp_dir().join(format!("rc-posmem-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        dir
    }

    #[test]
    fn the_last_stored_position_is_found_by_the_next_process() {
        let dir = temp_dir("last");
        let (mut memory, stored) = PositionMemory::open(&dir).unwrap();
        assert_eq!(stored, None);
        let q = [0.5, 1.0, -1.0, 0.25, 2.0, -3.0];
        memory.store(&[0.0; AXES]);
        memory.store(&q);
        // Not dropped (no msync): as a killed process leaves it.
        std::mem::forget(memory);
        let (mut again, stored) = PositionMemory::open(&dir).unwrap();
        assert_eq!(stored, Some(q));
        let r = [0.1, -2.5, 3.0, 1e-9, -0.0, 6.2];
        again.store(&r);
        drop(again);
        assert_eq!(PositionMemory::open(&dir).unwrap().1, Some(r));
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn a_slot_cut_short_leaves_the_one_before() {
        let q: [f64; AXES] = [0.5, 1.0, -1.0, 0.25, 2.0, -3.0];
        let mut words = [0u64; WORDS];
        words[0] = 7;
        for (w, v) in words[1..=AXES].iter_mut().zip(q) {
            *w = v.to_bits();
        }
        words[WORDS - 1] = check(&words[..WORDS - 1]);
        let mut newer = words;
        newer[0] = 8;
        newer[3] = 0.75f64.to_bits();
        // The kill came before the newer slot's check: it still holds the older one's.
        assert_eq!(newest(&[words, newer]), Some((7, q)));
        newer[WORDS - 1] = check(&newer[..WORDS - 1]);
        assert_eq!(newest(&[words, newer]).map(|(s, _)| s), Some(8));
        assert_eq!(newest(&[[0; WORDS], [0; WORDS]]), None);
    }

    #[test]
    fn a_file_of_another_size_holds_no_position() {
        let dir = temp_dir("size");
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(dir.join(FILE_NAME), "0.1 0.2 0.3 0.4 0.5 0.6\n").unwrap();
        assert_eq!(PositionMemory::open(&dir).unwrap().1, None);
        let _ = std::fs::remove_dir_all(&dir);
    }
}
