//! The pid file: which process runs which service right now.
//!
//! `<runtime dir>/<instance>.pids`, runtime dir = `$XDG_RUNTIME_DIR`, else `/tmp`. One line per
//! running service, `<name> <pid> <restarts>`, in start order. The orchestrator rewrites it after every
//! (re)spawn, atomically (a temporary file renamed over it, so a reader never sees half a
//! file), and removes it on shutdown. Tools and tests use it to find, signal or watch the
//! services of one controller instance.

use std::fmt::Write as _;
use std::io;
use std::path::{Path, PathBuf};

use shared_types::health::Service;

/// The pid file of controller `instance`, given the value of `$XDG_RUNTIME_DIR` (if set).
pub fn pid_file_path_in(runtime_dir: Option<&Path>, instance: &str) -> PathBuf {
    let dir = match runtime_dir {
        Some(dir) if !dir.as_os_str().is_empty() => dir,
        _ => Path::new("/tmp"),
    };
    dir.join(format!("{instance}.pids"))
}

/// The pid file of controller `instance` in this process's environment.
pub fn pid_file_path(instance: &str) -> PathBuf {
    let runtime_dir = std::env::var_os("XDG_RUNTIME_DIR").map(PathBuf::from);
    pid_file_path_in(runtime_dir.as_deref(), instance)
}

/// One line of the pid file: a running service, its process and how often it was restarted.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PidEntry {
    pub service: Service,
    pub pid: u32,
    pub restarts: u32,
}

/// The text of the pid file for the running services: `<name> <pid> <restarts>` per line.
pub fn render(running: impl IntoIterator<Item = PidEntry>) -> String {
    running.into_iter().fold(String::new(), |mut text, e| {
        // Writing to a String cannot fail.
        let _ = writeln!(text, "{} {} {}", e.service, e.pid, e.restarts);
        text
    })
}

/// Parses a pid file's text; lines that are not of that shape are skipped (a missing restart
/// count reads as 0).
pub fn parse(text: &str) -> Vec<PidEntry> {
    text.lines()
        .filter_map(|line| {
            let mut fields = line.split_whitespace();
            let service = fields.next()?.parse().ok()?;
            let pid = fields.next()?.parse().ok()?;
            let restarts = fields.next().map_or(Some(0), |r| r.parse().ok())?;
            Some(PidEntry {
                service,
                pid,
                restarts,
            })
        })
        .collect()
}

/// Replaces the file at `path` with `text` atomically.
pub fn write(path: &Path, text: &str) -> io::Result<()> {
    let mut temporary = path.as_os_str().to_owned();
    temporary.push(".tmp");
    std::fs::write(&temporary, text)?;
    std::fs::rename(&temporary, path)
}

/// Removes the pid file; a file that is already gone is fine.
pub fn remove(path: &Path) -> io::Result<()> {
    match std::fs::remove_file(path) {
        Err(e) if e.kind() != io::ErrorKind::NotFound => Err(e),
        _ => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn path_uses_the_runtime_dir_or_tmp() {
        assert_eq!(
            pid_file_path_in(Some(Path::new("/run/user/1000")), "rc"),
            PathBuf::from("/run/user/1000/rc.pids")
        );
        assert_eq!(
            pid_file_path_in(None, "cell7"),
            PathBuf::from("/tmp/cell7.pids")
        );
        assert_eq!(
            pid_file_path_in(Some(Path::new("")), "rc"),
            PathBuf::from("/tmp/rc.pids")
        );
    }

    #[test]
    fn render_and_parse_round_trip() {
        let entry = |service, pid, restarts| PidEntry {
            service,
            pid,
            restarts,
        };
        let running = [
            entry(Service::Servo, 101, 0),
            entry(Service::Fieldbus, 4242, 3),
        ];
        let text = render(running);
        assert_eq!(text, "servo 101 0\nfieldbus 4242 3\n");
        assert_eq!(parse(&text), running);
        assert_eq!(
            parse("garbage\nplanner x\nplanner 7\n"),
            [entry(Service::Planner, 7, 0)]
        );
    }

    #[test]
    fn write_replaces_and_remove_tolerates_absence() {
        let path =
            std::env::temp_dir().join(format!("rc-pidfile-test-{}.pids", std::process::id()));
        write(&path, "servo 1\n").unwrap();
        write(&path, "servo 2\n").unwrap();
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "servo 2\n");
        remove(&path).unwrap();
        assert!(!path.exists());
        remove(&path).unwrap();
    }
}
