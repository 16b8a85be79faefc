//! `rc status`: what a running controller is doing, read from outside — each service's pid,
//! uptime and restarts (the orchestrator's pid file), and a one-second sample of the servo
//! tick (period, lateness of the feedback, overruns, setpoint misses, drive state) and of the
//! planner (active job, queue, override, error).

use std::time::{Duration, Instant};

use anyhow::Context;
use orchestrator::pid_file;
use shared_types::bus::{self, Bus};
use shared_types::config::Config;
use shared_types::ipc::{DriveState, MotionStatus, ServoFeedback, topics};
use shared_types::time::monotonic_ns;

use crate::bench::stats::Distribution;

/// How long the servo and planner topics are sampled.
const SAMPLE_TIME: Duration = Duration::from_secs(1);

/// Seconds a process has been running, from `/proc`.
fn uptime_s(pid: u32) -> Option<f64> {
    let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).ok()?;
    // Field 22 (starttime, clock ticks since boot) counts from after the `(comm)` field.
    let after_comm = &stat[stat.rfind(')')? + 2..];
    let start_ticks: f64 = after_comm.split_whitespace().nth(19)?.parse().ok()?;
    let boot_uptime: f64 = std::fs::read_to_string("/proc/uptime")
        .ok()?
        .split_whitespace()
        .next()?
        .parse()
        .ok()?;
    // SAFETY: sysconf has no preconditions.
    let ticks_per_s = unsafe { libc::sysconf(libc::_SC_CLK_TCK) } as f64;
    (ticks_per_s > 0.0).then(|| boot_uptime - start_ticks / ticks_per_s)
}

/// The servo and planner topics over [`SAMPLE_TIME`].
struct Sample {
    feedback: Vec<(u64, ServoFeedback)>,
    status: Option<MotionStatus>,
}

fn sample(instance: &str) -> anyhow::Result<Sample> {
    let bus = Bus::new(instance, "rcstatus")?;
    let feedback = bus.subscriber::<ServoFeedback>(topics::SERVO_FEEDBACK)?;
    let wakeup = bus.listener(topics::SERVO_FEEDBACK)?;
    let status = bus.subscriber::<MotionStatus>(topics::MOTION_STATUS)?;
    let mut s = Sample {
        feedback: Vec::with_capacity(4096),
        status: None,
    };
    let start = Instant::now();
    while start.elapsed() < SAMPLE_TIME {
        bus::wait_for_wakeup(&wakeup, Duration::from_millis(20))?;
        let now = monotonic_ns();
        while let Some(f) = feedback.receive().context("servo/feedback")? {
            s.feedback.push((now, *f.payload()));
        }
        if let Some(st) = bus::receive_latest(&status)? {
            s.status = Some(st);
        }
    }
    Ok(s)
}

/// Prints the status of the controller of `config`; false if it does not run.
pub fn run(config: &Config) -> anyhow::Result<bool> {
    let instance = &config.main.instance;
    let path = pid_file::pid_file_path(instance);
    let Ok(text) = std::fs::read_to_string(&path) else {
        println!(
            "controller '{instance}' is not running (no {})",
            path.display()
        );
        return Ok(false);
    };
    println!("controller '{instance}' ({})", config.robot.name);
    println!(
        "{:<12} {:>8} {:>10} {:>9}",
        "service", "pid", "uptime s", "restarts"
    );
    for e in pid_file::parse(&text) {
        let uptime = uptime_s(e.pid).map_or("-".to_string(), |u| format!("{u:.1}"));
        println!(
            "{:<12} {:>8} {:>10} {:>9}",
            e.service.name(),
            e.pid,
            uptime,
            e.restarts
        );
    }
    let s = sample(instance)?;
    match (s.feedback.first(), s.feedback.last()) {
        (Some((_, first)), Some((_, last))) => {
            // Overruns skip whole periods, so the time per executed tick exceeds the period.
            let ticks = last.tick.saturating_sub(first.tick).max(1);
            let per_tick_us =
                (last.time_ns.saturating_sub(first.time_ns)) as f64 / ticks as f64 / 1e3;
            let period_us = last.period_ns / 1000;
            let lateness = Distribution::new(
                s.feedback
                    .iter()
                    .map(|(arrival, f)| arrival.saturating_sub(f.time_ns))
                    .collect(),
            );
            let us = |q: f64| lateness.quantile(q).map_or(0.0, |v| v as f64 / 1e3);
            println!(
                "servo: {} ticks in {:.1} s, period {period_us} µs ({per_tick_us:.1} µs per executed tick), \
                 feedback lateness p50 {:.0} µs \
                 p99 {:.0} µs max {:.0} µs (includes one iceoryx2 hop), overruns {} (+{}), \
                 setpoint misses {} (+{}), drives {:?}, fault 0x{:04X}",
                s.feedback.len(),
                SAMPLE_TIME.as_secs_f64(),
                us(0.5),
                us(0.99),
                us(1.0),
                last.overruns,
                last.overruns.saturating_sub(first.overruns),
                last.setpoint_misses,
                last.setpoint_misses.saturating_sub(first.setpoint_misses),
                DriveState::from_wire(last.state),
                last.fault_code,
            );
        }
        _ => println!("servo: no feedback within {SAMPLE_TIME:?}"),
    }
    match s.status {
        Some(st) => println!(
            "planner: active job {}, {} queued, {:.0} % progress, override {:.0} %, {}{}, error 0x{:04X}",
            st.active_job,
            st.queued_jobs,
            st.active_progress,
            st.override_fraction * 100.0,
            if st.moving { "moving" } else { "standing" },
            if st.sequence_paused {
                ", sequence interrupted"
            } else {
                ""
            },
            st.error_code,
        ),
        None => println!("planner: no status within {SAMPLE_TIME:?}"),
    }
    Ok(true)
}
