//! Runs the real orchestrator with this test binary as its service executable and checks that
//! a crashed service is restarted and that nothing of the instance is left in shared memory.
//!
//! `harness = false`: the orchestrator spawns `current_exe() service <name> --config <file>`,
//! so `main` plays a service when called that way. The fake service opens the controller's
//! topics with real iceoryx2 ports and waits to be signalled, like a real one.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::thread;
use std::time::{Duration, Instant};

use orchestrator::{Service, pid_file};
use shared_types::bus::Bus;
use shared_types::config::{Config, EMBEDDED_DEFAULT};
use shared_types::health::HealthReporter;
use shared_types::ipc::{MotionCommand, PlcTelegram, ServoFeedback, ServoSetpoint, topics};

const TEST: &str = "crashed_service_is_restarted_and_no_shared_memory_is_left";

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if let [command, name, option, config] = args.as_slice()
        && command == "service"
        && option == "--config"
    {
        return fake_service(name, Path::new(config));
    }
    // Honour `cargo test <filter>` and `--list` like the standard harness.
    let filters: Vec<&String> = args.iter().filter(|a| !a.starts_with('-')).collect();
    if args.iter().any(|a| a == "--list") {
        println!("{TEST}: test");
        return;
    }
    if !filters.is_empty() && !filters.iter().any(|f| TEST.contains(f.as_str())) {
        println!("\ntest result: ok. 0 passed; 0 failed; 0 ignored; 0 measured; 1 filtered out");
        return;
    }
    crashed_service_is_restarted_and_no_shared_memory_is_left();
    println!("test {TEST} ... ok");
    println!("\ntest result: ok. 1 passed; 0 failed; 0 ignored; 0 measured; 0 filtered out");
}

fn fake_service(name: &str, config: &Path) {
    let config = Config::load(Some(config)).unwrap();
    let bus = Bus::new(&config.main.instance, name).unwrap();
    // Each subscribes to its real input topic, as a real one does before it beats.
    let _setpoints = (name == "servo").then(|| {
        bus.subscriber::<ServoSetpoint>(topics::SERVO_SETPOINT)
            .unwrap()
    });
    let _commands = (name == "planner").then(|| {
        bus.subscriber::<MotionCommand>(topics::MOTION_COMMAND)
            .unwrap()
    });
    let _telegrams =
        (name == "interpreter").then(|| bus.subscriber::<PlcTelegram>(topics::P2R).unwrap());
    let _feedback = bus
        .publisher::<ServoFeedback>(topics::SERVO_FEEDBACK)
        .unwrap();
    let _wakeup = bus.notifier(topics::SERVO_FEEDBACK).unwrap();
    // The heartbeat tells the orchestrator it is ready and alive.
    let service: Service = name.parse().unwrap();
    let mut health = HealthReporter::new(&bus, service, 0).unwrap();
    // Ended by the orchestrator's SIGTERM (default action) or a test's SIGKILL.
    loop {
        health.beat().unwrap();
        thread::sleep(Duration::from_millis(50));
    }
}

/// Every iceoryx2 file and folder.
fn iceoryx2_entries() -> BTreeSet<PathBuf> {
    fn walk(dir: &Path, into: &mut BTreeSet<PathBuf>) {
        let Ok(entries) = std::fs::read_dir(dir) else {
            return;
        };
        for entry in entries.flatten() {
            let path = entry.path();
            if path.is_dir() {
                walk(&path, into);
            }
            into.insert(path);
        }
    }
    let mut entries = BTreeSet::new();
    walk(Path::new("/tmp/iceoryx2"), &mut entries);
    if let Ok(shm) = std::fs::read_dir("/dev/shm") {
        entries.extend(
            shm.flatten()
                .map(|e| e.path())
                .filter(|p| p.to_string_lossy().contains("iox2")),
        );
    }
    entries
}

fn wait_for<T>(what: &str, mut probe: impl FnMut() -> Option<T>) -> T {
    let deadline = Instant::now() + Duration::from_secs(10);
    loop {
        if let Some(value) = probe() {
            return value;
        }
        assert!(Instant::now() < deadline, "timed out waiting for {what}");
        thread::sleep(Duration::from_millis(10));
    }
}

fn crashed_service_is_restarted_and_no_shared_memory_is_left() {
    let instance = format!("rc-shm-test-{}", std::process::id());
    let dir = std::env::temp_dir().join(&instance);
    std::fs::create_dir_all(&dir).unwrap();
    let config_path = dir.join("controller.toml");
    std::fs::write(
        &config_path,
        EMBEDDED_DEFAULT.replace("instance = \"rc\"", &format!("instance = \"{instance}\"")),
    )
    .unwrap();
    let config = Config::load(Some(&config_path)).unwrap();
    let pid_path = pid_file::pid_file_path(&instance);
    let entries_before = iceoryx2_entries();

    let shutdown = Arc::new(AtomicBool::new(false));
    let controller = {
        let shutdown = shutdown.clone();
        thread::spawn(move || orchestrator::run(&config, &shutdown))
    };
    let pids_of = |path: &Path| {
        let running = pid_file::parse(&std::fs::read_to_string(path).ok()?);
        (running.len() == Service::START_ORDER.len()).then_some(running)
    };
    let first = wait_for("the pid file", || pids_of(&pid_path));
    let planner = first
        .iter()
        .find(|e| e.service == Service::Planner)
        .unwrap()
        .pid;
    // Let the planner open its ports before it "crashes".
    thread::sleep(Duration::from_millis(300));
    // SAFETY: plain syscall on a process of this test.
    unsafe { libc::kill(planner as libc::pid_t, libc::SIGKILL) };
    wait_for("the planner's restart", || {
        pids_of(&pid_path).filter(|running| running.iter().all(|e| e.pid != planner))
    });
    thread::sleep(Duration::from_millis(300));

    shutdown.store(true, Ordering::Relaxed);
    controller.join().unwrap().unwrap();

    assert!(
        !pid_path.exists(),
        "pid file {} left behind",
        pid_path.display()
    );
    let left: Vec<_> = iceoryx2_entries()
        .difference(&entries_before)
        .cloned()
        .collect();
    assert!(left.is_empty(), "stale iceoryx2 resources: {left:#?}");
    std::fs::remove_dir_all(&dir).unwrap();
}
