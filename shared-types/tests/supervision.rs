//! The systemd notifications against a fake NOTIFY_SOCKET. A test binary of its own with one
//! test, because the environment variables it sets are process-global.

use std::os::unix::net::UnixDatagram;
use std::path::PathBuf;
use std::time::{Duration, Instant};

use shared_types::supervision::{Watchdog, beat, ready};

/// WatchdogSec= of the fake unit: pings are due every 100 ms.
const WATCHDOG_USEC: u64 = 200_000;

/// A datagram socket standing in for systemd's notify socket.
struct FakeSystemd {
    socket: UnixDatagram,
    dir: PathBuf,
}

impl FakeSystemd {
    fn bind() -> Self {
        let dir = std::env::temp_dir().join(format!("rc-supervision-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("notify");
        let _ = std::fs::remove_file(&path);
        let socket = UnixDatagram::bind(&path).unwrap();
        // SAFETY: this binary's only test sets it before starting any thread of its own.
        unsafe { std::env::set_var("NOTIFY_SOCKET", &path) };
        Self { socket, dir }
    }

    /// The next notification within `timeout`, if any.
    fn receive(&self, timeout: Duration) -> Option<String> {
        self.socket.set_read_timeout(Some(timeout)).unwrap();
        let mut buf = [0u8; 256];
        let n = self.socket.recv(&mut buf).ok()?;
        Some(String::from_utf8_lossy(&buf[..n]).into_owned())
    }

    /// Discards what has arrived so far.
    fn drain(&self) {
        while self.receive(Duration::from_millis(1)).is_some() {}
    }
}

impl Drop for FakeSystemd {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.dir);
    }
}

/// Beats every 2 ms for `duration`, as a running service loop does.
fn run_loop_for(duration: Duration) {
    let end = Instant::now() + duration;
    while Instant::now() < end {
        beat();
        std::thread::sleep(Duration::from_millis(2));
    }
}

#[test]
fn ready_and_watchdog_pings_follow_the_service_loop() {
    // Without systemd both do nothing (even when this test itself runs under a unit).
    // SAFETY: this binary's only test, before it starts any thread.
    unsafe {
        for variable in ["NOTIFY_SOCKET", "WATCHDOG_USEC", "WATCHDOG_PID"] {
            std::env::remove_var(variable);
        }
    }
    ready();
    assert!(Watchdog::start().unwrap().is_none());

    let systemd = FakeSystemd::bind();
    ready();
    assert_eq!(
        systemd.receive(Duration::from_secs(2)).as_deref(),
        Some("READY=1\n")
    );

    // SAFETY: see FakeSystemd::bind; no thread of this test runs yet.
    unsafe {
        std::env::set_var("WATCHDOG_USEC", WATCHDOG_USEC.to_string());
        std::env::set_var("WATCHDOG_PID", "1");
    }
    assert!(
        Watchdog::start().unwrap().is_none(),
        "the watchdog of another process (WATCHDOG_PID) is not ours"
    );
    // SAFETY: as above.
    unsafe { std::env::set_var("WATCHDOG_PID", std::process::id().to_string()) };
    let watchdog = Watchdog::start().unwrap().expect("WATCHDOG_USEC is set");

    // Before the loop's first beat: no ping.
    assert_eq!(systemd.receive(Duration::from_millis(350)), None);

    run_loop_for(Duration::from_millis(250));
    assert_eq!(
        systemd.receive(Duration::from_millis(200)).as_deref(),
        Some("WATCHDOG=1\n")
    );

    // The loop stalls: after the check that still saw its last beats, the pings stop.
    std::thread::sleep(Duration::from_millis(250));
    systemd.drain();
    assert_eq!(systemd.receive(Duration::from_millis(350)), None);

    // It runs again: the pings resume.
    run_loop_for(Duration::from_millis(250));
    assert_eq!(
        systemd.receive(Duration::from_millis(200)).as_deref(),
        Some("WATCHDOG=1\n")
    );

    drop(watchdog);
    systemd.drain();
    run_loop_for(Duration::from_millis(250));
    assert_eq!(
        systemd.receive(Duration::from_millis(100)),
        None,
        "dropping the watchdog stops the pings"
    );
}
