//! Controlling a child process: tying its life to ours, asking it to stop, killing it.
//!
//! Used for the service processes and by `rc demo` for the controller it starts.

use std::io;
use std::os::unix::process::CommandExt;
use std::process::{Child, Command, ExitStatus};
use std::thread;
use std::time::{Duration, Instant};

/// How often a stopping process is polled.
const POLL_PERIOD: Duration = Duration::from_millis(10);

/// Makes the process spawned from `command` receive `SIGTERM` when the thread that spawns it
/// ends (`PR_SET_PDEATHSIG`), so it never outlives a crashed parent. Spawn from a thread that
/// lives as long as the child should.
pub fn die_with_parent(command: &mut Command) {
    let parent = std::process::id();
    // SAFETY: the closure runs between fork and exec and only calls the async-signal-safe
    // `prctl` and `getppid`.
    unsafe {
        command.pre_exec(move || {
            if libc::prctl(libc::PR_SET_PDEATHSIG, libc::SIGTERM) != 0 {
                return Err(io::Error::last_os_error());
            }
            // The parent may have died before the death signal was armed.
            if u32::try_from(libc::getppid()).ok() != Some(parent) {
                return Err(io::Error::other("parent exited during spawn"));
            }
            Ok(())
        });
    }
}

/// Asks `child` to shut down (`SIGTERM`).
pub fn terminate(child: &Child) {
    if let Ok(pid) = libc::pid_t::try_from(child.id()) {
        // SAFETY: plain syscall; the pid is our unreaped child, so it cannot have been reused.
        unsafe {
            libc::kill(pid, libc::SIGTERM);
        }
    }
}

/// How a child process ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Stopped {
    pub status: ExitStatus,
    /// It did not exit in time and was killed with `SIGKILL`.
    pub killed: bool,
}

/// Waits up to `timeout` for `child` to exit (after [`terminate`]), kills it if it does not,
/// and reaps it.
pub fn stop(child: &mut Child, timeout: Duration) -> io::Result<Stopped> {
    let deadline = Instant::now() + timeout;
    loop {
        if let Some(status) = child.try_wait()? {
            return Ok(Stopped {
                status,
                killed: false,
            });
        }
        if Instant::now() >= deadline {
            child.kill()?;
            return Ok(Stopped {
                status: child.wait()?,
                killed: true,
            });
        }
        thread::sleep(POLL_PERIOD);
    }
}
