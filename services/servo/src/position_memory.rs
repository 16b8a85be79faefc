//! The simulated drives' "absolute encoders": the joint position survives a restart of the
//! servo process (or of the whole controller), as a real arm stays where it stopped.
//!
//! The tick loop only stores the position into atomics; a background thread writes it to
//! `<data_dir>/servo_position.txt` (temporary file, rename) when it changed, so the loop never
//! touches the disk.

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::Duration;

use shared_types::ipc::AXES;

const FILE_NAME: &str = "servo_position.txt";
/// How often the writer looks for a changed position: a killed servo process loses at most
/// this much of the simulated arm's motion.
const WRITE_INTERVAL: Duration = Duration::from_millis(20);

/// The last joint position (rad) shared between the tick loop and the writer thread.
#[derive(Debug, Default)]
pub struct SharedPosition {
    joints: [AtomicU64; AXES],
}

impl SharedPosition {
    /// Stores `q` (lock-free, for the tick loop).
    pub fn store(&self, q: &[f64; AXES]) {
        for (a, v) in self.joints.iter().zip(q) {
            a.store(v.to_bits(), Ordering::Relaxed);
        }
    }

    fn load(&self) -> [f64; AXES] {
        core::array::from_fn(|i| f64::from_bits(self.joints[i].load(Ordering::Relaxed)))
    }
}

/// The text of the file for `q`: six numbers in radians.
pub fn format(q: &[f64; AXES]) -> String {
    q.iter()
        .map(|v| format!("{v:e}"))
        .collect::<Vec<_>>()
        .join(" ")
        + "\n"
}

/// The position in a file's text; `None` unless it holds exactly six finite numbers.
pub fn parse(text: &str) -> Option<[f64; AXES]> {
    let mut q = [0.0; AXES];
    let mut values = text.split_whitespace();
    for v in &mut q {
        *v = values
            .next()?
            .parse()
            .ok()
            .filter(|x: &f64| x.is_finite())?;
    }
    values.next().is_none().then_some(q)
}

/// The position stored in `dir`, if there is a valid one.
pub fn load(dir: &Path) -> Option<[f64; AXES]> {
    parse(&std::fs::read_to_string(dir.join(FILE_NAME)).ok()?)
}

/// Writes `shared` to `dir` whenever it changed, until `stop` is set (then unpark the
/// thread so it writes the final position at once).
pub fn spawn_writer(
    dir: PathBuf,
    shared: Arc<SharedPosition>,
    stop: Arc<AtomicBool>,
) -> std::io::Result<std::thread::JoinHandle<()>> {
    std::fs::create_dir_all(&dir)?;
    std::thread::Builder::new()
        .name("position-memory".into())
        .spawn(move || {
            let mut written: Option<[f64; AXES]> = None;
            loop {
                let stopping = stop.load(Ordering::Relaxed);
                let q = shared.load();
                if written != Some(q) {
                    match write_atomically(&dir, &q) {
                        Ok(()) => written = Some(q),
                        Err(e) => tracing::warn!(%e, "servo position not stored"),
                    }
                }
                if stopping {
                    return;
                }
                // Woken early by `unpark` when the servo stops.
                std::thread::park_timeout(WRITE_INTERVAL);
            }
        })
}

fn write_atomically(dir: &Path, q: &[f64; AXES]) -> std::io::Result<()> {
    let tmp = dir.join(format!("{FILE_NAME}.tmp"));
    std::fs::write(&tmp, format(q))?;
    std::fs::rename(&tmp, dir.join(FILE_NAME))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn position_round_trips_and_garbage_is_refused() {
        let q = [0.1, -2.5, 3.0, 1e-9, -0.0, 6.2];
        assert_eq!(parse(&format(&q)), Some(q));
        assert_eq!(parse("1 2 3 4 5"), None);
        assert_eq!(parse("1 2 3 4 5 6 7"), None);
        assert_eq!(parse("1 2 3 4 5 NaN"), None);
        assert_eq!(parse("a b c d e f"), None);
    }

    #[test]
    fn the_writer_stores_the_last_position() {
        let dir = std::env::temp_dir().join(format!("rc-posmem-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let shared = Arc::new(SharedPosition::default());
        let stop = Arc::new(AtomicBool::new(false));
        let q = [0.5, 1.0, -1.0, 0.25, 2.0, -3.0];
        shared.store(&q);
        let writer = spawn_writer(dir.clone(), shared.clone(), stop.clone()).unwrap();
        stop.store(true, Ordering::Relaxed);
        writer.thread().unpark();
        writer.join().unwrap();
        assert_eq!(load(&dir), Some(q));
        let _ = std::fs::remove_dir_all(&dir);
    }
}
