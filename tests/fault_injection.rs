//! Fault injection: `kill -9` of the planner or the servo at random moments while a program of
//! moves runs, many times, and freezing one of them (`SIGSTOP`: alive but stuck, until the
//! orchestrator's heartbeat deadline kills it). Checked on every servo feedback sample and
//! every command:
//! - no joint position, velocity or acceleration limit is exceeded (within one servo process;
//!   across a servo restart the arm may lose at most the position memory's 20 ms of motion);
//! - every move ends exactly once with a final state (DONE, or ERROR/ABORTED with a code);
//! - the arm stands still within a bound after each kill (after a freeze: once the frozen
//!   process has been replaced, as a frozen simulated servo reports nothing);
//! - after GroupReset (and EnableRobot after a servo restart) the moves run again.
//!
//! Iterations: `FAULT_ITERATIONS` (default 6). A longer soak:
//! `FAULT_ITERATIONS=200 cargo test --release --test fault_injection -- --nocapture`.

mod common;

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use common::{Controller, execute, initialize, reset_and_enable};
use iceoryx2::port::subscriber::Subscriber;
use plc_client::{MoveAxesAbsolute, Request};
use shared_types::bus::{self, Bus, Ipc};
use shared_types::config::Config;
use shared_types::health::{self, SupervisionStatus};
use shared_types::ipc::{ServoFeedback, topics};
use shared_types::srci::message::state;

/// What the feedback watcher found.
#[derive(Debug, Default)]
struct Watch {
    samples: u64,
    violations: Vec<String>,
    /// Largest joint speed seen in the last sample (rad/s).
    last_speed: f64,
}

/// Subscribes to the servo feedback of `instance` and checks every sample against the limits.
fn watch_feedback(
    instance: String,
    stop: Arc<AtomicBool>,
    watch: Arc<Mutex<Watch>>,
) -> std::thread::JoinHandle<()> {
    std::thread::spawn(move || {
        let limits = Config::load(None).expect("config").robot.limits_rad();
        let bus = Bus::new(&instance, "faultwatch").expect("bus");
        let feedback = bus
            .subscriber::<ServoFeedback>(topics::SERVO_FEEDBACK)
            .expect("subscriber");
        let wakeup = bus.listener(topics::SERVO_FEEDBACK).expect("listener");
        let mut previous: Option<ServoFeedback> = None;
        while !stop.load(Ordering::Relaxed) {
            let _ = bus::wait_for_wakeup(&wakeup, Duration::from_millis(20));
            while let Ok(Some(sample)) = feedback.receive() {
                let f = *sample.payload();
                let mut w = watch.lock().expect("watch");
                w.samples += 1;
                w.last_speed = f.qd.iter().fold(0.0, |m, v| f64::max(m, v.abs()));
                for j in 0..6 {
                    let tol = 1e-6;
                    if f.q[j] < limits.min[j] - tol || f.q[j] > limits.max[j] + tol {
                        w.violations
                            .push(format!("J{} position {:.4} rad", j + 1, f.q[j]));
                    }
                    if f.qd[j].abs() > limits.velocity[j] * 1.05 + tol {
                        w.violations
                            .push(format!("J{} velocity {:.4} rad/s", j + 1, f.qd[j]));
                    }
                }
                if let Some(p) = previous {
                    let dt = (f.tick.saturating_sub(p.tick)).max(1) as f64 * 1e-3;
                    for j in 0..6 {
                        if f.instance == p.instance {
                            let a = (f.qd[j] - p.qd[j]).abs() / dt;
                            if a > limits.acceleration[j] * 1.1 + 1e-3 {
                                w.violations.push(format!(
                                    "J{} acceleration {a:.2} rad/s² at tick {}",
                                    j + 1,
                                    f.tick
                                ));
                            }
                        } else {
                            // A new servo process: it continues from the position memory.
                            let jump = (f.q[j] - p.q[j]).abs();
                            if jump > limits.velocity[j] * 0.03 + 1e-4 {
                                w.violations
                                    .push(format!("J{} jumped {jump:.4} rad", j + 1));
                            }
                        }
                    }
                }
                previous = Some(f);
            }
        }
    })
}

/// Whether the newest supervision status waiting says that every service runs, `victim` as
/// process `pid`.
fn all_running(
    supervision: &Subscriber<Ipc, SupervisionStatus, ()>,
    victim: &str,
    pid: u32,
) -> bool {
    let victim: health::Service = victim.parse().expect("service");
    bus::receive_latest(supervision)
        .expect("supervision status")
        .is_some_and(|s| s.all_running == 1 && s.service(victim).pid == pid)
}

/// A small xorshift generator: reproducible kill moments without a dependency.
struct Random(u64);

impl Random {
    fn below(&mut self, n: u64) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0 % n
    }
}

#[test]
fn killing_or_freezing_planner_or_servo_never_breaks_a_limit_or_loses_a_command() {
    let iterations: u32 = std::env::var("FAULT_ITERATIONS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(6);
    // Many kills on purpose: lift the restart-intensity limit that would otherwise (rightly)
    // stop restarting the victim and hold the arm in a safe stop.
    let c = Controller::start_with("fault", |text| {
        text.replace("max_restarts = 5", "max_restarts = 100")
            .replace("restart_window_s = 60", "restart_window_s = 1")
    });
    let stop = Arc::new(AtomicBool::new(false));
    let watch = Arc::new(Mutex::new(Watch::default()));
    let watcher = watch_feedback(c.instance.clone(), stop.clone(), watch.clone());
    let bus = Bus::new(&c.instance, "faultsup").expect("bus");
    let supervision = bus
        .subscriber::<SupervisionStatus>(health::topics::SUPERVISION_STATUS)
        .expect("subscriber");
    let mut plc = c.client();
    initialize(&mut plc);
    reset_and_enable(&mut plc);
    let mut random = Random(0x9E37_79B9_7F4A_7C15);
    let targets = [
        [40.0, 110.0, 60.0, 100.0, -60.0, 90.0],
        [-40.0, 80.0, 110.0, 70.0, -110.0, -90.0],
    ];
    let (mut moves, mut ended, mut errors, mut worst_stop) = (0, 0, 0, Duration::ZERO);
    let mut freezes = 0;
    for i in 0..iterations {
        let (victim, fault) = match random.below(4) {
            0 => ("planner", libc::SIGKILL),
            1 => ("servo", libc::SIGKILL),
            2 => ("planner", libc::SIGSTOP),
            _ => ("servo", libc::SIGSTOP),
        };
        let mut m = MoveAxesAbsolute::to(targets[i as usize % 2]);
        m.velocity_rate = Some(60.0);
        let handle = plc
            .task_mut()
            .submit(&Request::MoveAxesAbsolute(m))
            .expect("submit");
        moves += 1;
        plc.run_for(Duration::from_millis(100 + random.below(600)))
            .expect("cycles");
        let pid = c.pid_of(victim).expect("pid");
        // SAFETY: kill(2) on a service process of our own controller.
        assert_eq!(unsafe { libc::kill(pid as i32, fault) }, 0);
        let killed = Instant::now();
        // The move ends exactly once (a final state is final in the client).
        let s = plc
            .run_until(
                |t| t.status(handle).is_some_and(|s| s.is_final()),
                Duration::from_secs(10),
            )
            .map(|()| plc.task().status(handle).cloned().expect("status"));
        let s = s.unwrap_or_else(|e| panic!("iteration {i} ({victim}): move not ended: {e}"));
        ended += 1;
        if s.state != state::DONE {
            assert_ne!(s.code, 0, "an error or abort carries a code: {s:?}");
            errors += 1;
        }
        // The arm stands within a bound; a frozen process has to be found and replaced first.
        let bound = if fault == libc::SIGSTOP {
            freezes += 1;
            Duration::from_secs(5)
        } else {
            Duration::from_secs(3)
        };
        loop {
            plc.run_for(Duration::from_millis(10)).expect("cycles");
            let standing = watch.lock().expect("watch").last_speed < 1e-3;
            if standing {
                break;
            }
            assert!(killed.elapsed() < bound, "arm still moving");
        }
        if fault == libc::SIGKILL {
            worst_stop = worst_stop.max(killed.elapsed());
        }
        // Wait for the restart, then recover.
        let restarted = Instant::now();
        let new_pid = loop {
            if let Some(new) = c.pid_of(victim).filter(|&p| p != pid) {
                break new;
            }
            assert!(
                restarted.elapsed() < Duration::from_secs(10),
                "{victim} restarted"
            );
            plc.run_for(Duration::from_millis(20)).expect("cycles");
        };
        // GroupReset only once the new process runs and the interpreter has heard from it: a
        // new planner instance fails the commands in flight, a GroupReset among them.
        while !all_running(&supervision, victim, new_pid) {
            assert!(
                restarted.elapsed() < Duration::from_secs(10),
                "{victim} running again"
            );
            plc.run_for(Duration::from_millis(20)).expect("cycles");
        }
        plc.run_for(Duration::from_millis(100)).expect("cycles");
        let reset = execute(&mut plc, &Request::GroupReset, Duration::from_secs(10));
        assert_eq!(reset.state, state::DONE, "GroupReset: {reset:?}");
        if !plc.task().is_enabled() {
            reset_and_enable(&mut plc);
        }
    }
    // After all that, a full move still runs.
    let mut m = MoveAxesAbsolute::to(targets[0]);
    m.velocity_rate = Some(100.0);
    let s = execute(
        &mut plc,
        &Request::MoveAxesAbsolute(m),
        Duration::from_secs(15),
    );
    assert_eq!((s.state, s.code), (state::DONE, 0), "{s:?}");
    stop.store(true, Ordering::Relaxed);
    watcher.join().expect("watcher");
    let w = watch.lock().expect("watch");
    println!(
        "fault injection: {iterations} faults ({freezes} freezes), {moves} moves, {ended} ended once \
         ({errors} with an error code), {} feedback samples, {} limit violations, worst stop \
         after a kill {worst_stop:?}",
        w.samples,
        w.violations.len()
    );
    assert!(w.samples > 1000, "the watcher saw the feedback");
    assert!(
        w.violations.is_empty(),
        "{:?}",
        &w.violations[..w.violations.len().min(10)]
    );
}
