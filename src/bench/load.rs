//! A CPU load for the "load" rows: one busy thread per CPU at nice 19, so the controller
//! competes for every core with work of the lowest normal priority.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::thread::{self, JoinHandle};

/// Nice value of the load threads (the lowest priority of normal scheduling).
pub const NICE: i32 = 19;

/// Busy threads that run until dropped.
pub struct CpuLoad {
    stop: Arc<AtomicBool>,
    threads: Vec<JoinHandle<()>>,
}

impl CpuLoad {
    /// Starts `threads` busy threads.
    pub fn start(threads: usize) -> std::io::Result<Self> {
        let stop = Arc::new(AtomicBool::new(false));
        let mut load = Self {
            stop: Arc::clone(&stop),
            threads: Vec::with_capacity(threads),
        };
        for i in 0..threads {
            let stop = Arc::clone(&stop);
            let handle = thread::Builder::new()
                .name(format!("bench-load-{i}"))
                .spawn(move || spin(&stop))?;
            load.threads.push(handle);
        }
        Ok(load)
    }
}

impl Drop for CpuLoad {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        for t in self.threads.drain(..) {
            // A load thread only spins; a panic there has nothing to report.
            let _ = t.join();
        }
    }
}

/// Lowers this thread's priority to [`NICE`] (on Linux, nice is per thread), then keeps
/// its CPU busy until `stop`.
fn spin(stop: &AtomicBool) {
    // SAFETY: plain syscalls on this thread's own id.
    let niced = unsafe {
        let tid = libc::gettid();
        libc::setpriority(libc::PRIO_PROCESS, tid as libc::id_t, NICE)
    };
    if niced != 0 {
        tracing::warn!(
            error = %std::io::Error::last_os_error(),
            "cannot lower the load thread's priority; it runs at the bench's own"
        );
    }
    let mut x = 1u64;
    while !stop.load(Ordering::Relaxed) {
        for _ in 0..10_000 {
            x = std::hint::black_box(x.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1));
        }
    }
}
