//! `rc status`: what a running controller is doing, read from outside — each service's pid,
//! uptime and restarts (the orchestrator's pid file) with its cycle statistics (its health
//! topic), the supervision state (the orchestrator's status topic), and a one-second sample of
//! the servo tick (period, lateness of the feedback, overruns, setpoint misses, drive state)
//! and of the planner (active job, queue, override, error).

use std::time::{Duration, Instant};

use anyhow::Context;
use orchestrator::pid_file::{self, PidEntry};
use shared_types::bus::{self, Bus};
use shared_types::config::Config;
use shared_types::health::{
    FailureCause, SERVICES, Service, ServiceHealth, ServiceState, SupervisionStatus,
    topics as health_topics,
};
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

/// The topics over [`SAMPLE_TIME`].
struct Sample {
    feedback: Vec<(u64, ServoFeedback)>,
    status: Option<MotionStatus>,
    /// The newest health sample of each service, by [`Service::index`].
    health: [Option<ServiceHealth>; SERVICES],
    supervision: Option<SupervisionStatus>,
}

fn sample(instance: &str) -> anyhow::Result<Sample> {
    let bus = Bus::new(instance, "rcstatus")?;
    let feedback = bus.subscriber::<ServoFeedback>(topics::SERVO_FEEDBACK)?;
    let wakeup = bus.listener(topics::SERVO_FEEDBACK)?;
    let status = bus.subscriber::<MotionStatus>(topics::MOTION_STATUS)?;
    let health = Service::START_ORDER
        .map(|service| bus.subscriber::<ServiceHealth>(service.health_topic()))
        .into_iter()
        .collect::<Result<Vec<_>, _>>()?;
    let supervision = bus.subscriber::<SupervisionStatus>(health_topics::SUPERVISION_STATUS)?;
    let mut s = Sample {
        feedback: Vec::with_capacity(4096),
        status: None,
        health: [None; SERVICES],
        supervision: None,
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
        for (latest, subscriber) in s.health.iter_mut().zip(&health) {
            if let Some(h) = bus::receive_latest(subscriber)? {
                *latest = Some(h);
            }
        }
        if let Some(st) = bus::receive_latest(&supervision)? {
            s.supervision = Some(st);
        }
    }
    Ok(s)
}

/// The header of the services table.
fn services_header() -> String {
    format!(
        "{:<12} {:>8} {:>9} {:>10} {:>9} {:>8} {:>8} {:>9} {:>9} {:>9}",
        "service",
        "pid",
        "uptime s",
        "period µs",
        "cycles",
        "p50 µs",
        "p99 µs",
        "max µs",
        "overruns",
        "restarts"
    )
}

/// One service's row: pid, uptime and restarts from the pid file, the cycle statistics from
/// its health sample if that came from the same process (lateness in µs), restarts last.
fn service_row(entry: &PidEntry, uptime_s: Option<f64>, health: Option<&ServiceHealth>) -> String {
    let uptime = uptime_s.map_or("-".to_string(), |u| format!("{u:.1}"));
    let us = |ns: u64| format!("{:.1}", ns as f64 / 1e3);
    let stats = match health.filter(|h| h.pid == entry.pid) {
        Some(h) => format!(
            "{:>10} {:>9} {:>8} {:>8} {:>9} {:>9}",
            h.period_ns / 1000,
            h.stats.cycles,
            us(h.stats.lateness_p50_ns),
            us(h.stats.lateness_p99_ns),
            us(h.stats.lateness_max_ns),
            h.stats.overruns
        ),
        None => format!(
            "{:>10} {:>9} {:>8} {:>8} {:>9} {:>9}",
            "-", "-", "-", "-", "-", "-"
        ),
    };
    format!(
        "{:<12} {:>8} {:>9} {stats} {:>9}",
        entry.service.name(),
        entry.pid,
        uptime,
        entry.restarts
    )
}

/// The supervision state in one line.
fn supervision_line(status: &SupervisionStatus) -> String {
    if status.safe_stop != 0 {
        return format!("supervision: SAFE STOP: {}", status.reason());
    }
    if status.all_running != 0 {
        return format!(
            "supervision: all running (generation {})",
            status.generation
        );
    }
    let others: Vec<String> = Service::START_ORDER
        .into_iter()
        .filter_map(|service| {
            let entry = status.service(service);
            let state = ServiceState::from_wire(entry.state);
            (state != ServiceState::Running).then(|| {
                let failure = FailureCause::from_wire(entry.last_failure);
                if failure == FailureCause::None {
                    format!("{service} {state:?}")
                } else {
                    format!("{service} {state:?} (last: {failure})")
                }
            })
        })
        .collect();
    format!(
        "supervision: {} (generation {})",
        others.join(", "),
        status.generation
    )
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
    let s = sample(instance)?;
    println!("controller '{instance}' ({})", config.robot.name);
    println!("{}", services_header());
    for e in pid_file::parse(&text) {
        let health = s.health[e.service.index()].as_ref();
        println!("{}", service_row(&e, uptime_s(e.pid), health));
    }
    match &s.supervision {
        Some(status) => println!("{}", supervision_line(status)),
        None => println!("supervision: no status within {SAMPLE_TIME:?}"),
    }
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

#[cfg(test)]
mod tests {
    use super::*;
    use shared_types::health::CycleSummary;

    fn health(pid: u32) -> ServiceHealth {
        ServiceHealth {
            pid,
            service: Service::Servo as u8,
            reserved: [0; 3],
            started_unix_ms: 0,
            published_ns: 0,
            heartbeat: 9,
            period_ns: 1_000_000,
            stats: CycleSummary {
                cycles: 5000,
                lateness_p50_ns: 45_100,
                lateness_p99_ns: 210_000,
                lateness_max_ns: 3_421_900,
                overruns: 13,
            },
        }
    }

    #[test]
    fn a_row_shows_the_cycle_statistics_of_the_same_process_and_ends_with_the_restarts() {
        let entry = PidEntry {
            service: Service::Servo,
            pid: 4242,
            restarts: 2,
        };
        let row = service_row(&entry, Some(12.34), Some(&health(4242)));
        let fields: Vec<&str> = row.split_whitespace().collect();
        assert_eq!(
            fields,
            [
                "servo", "4242", "12.3", "1000", "5000", "45.1", "210.0", "3421.9", "13", "2"
            ]
        );
        assert_eq!(
            services_header().chars().count(),
            row.chars().count(),
            "columns line up"
        );
        // A sample of the process before a restart is not shown for the new one.
        let row = service_row(&entry, None, Some(&health(1)));
        assert_eq!(
            row.split_whitespace().collect::<Vec<_>>(),
            ["servo", "4242", "-", "-", "-", "-", "-", "-", "-", "2"]
        );
    }

    #[test]
    fn the_supervision_line_names_the_safe_stop_or_what_is_not_running() {
        let mut status = SupervisionStatus::new(1);
        status.all_running = 1;
        status.generation = 7;
        assert_eq!(
            supervision_line(&status),
            "supervision: all running (generation 7)"
        );
        status.all_running = 0;
        for entry in &mut status.services {
            entry.state = ServiceState::Running as u8;
        }
        status.services[Service::Planner.index()].state = ServiceState::Restarting as u8;
        status.services[Service::Planner.index()].last_failure =
            FailureCause::MissedHeartbeat as u8;
        assert_eq!(
            supervision_line(&status),
            "supervision: planner Restarting (last: missed its heartbeat deadline) \
             (generation 7)"
        );
        status.safe_stop = 1;
        status.set_reason("planner exited with code 3; 2 failures within 60 s exceed x");
        assert_eq!(
            supervision_line(&status),
            "supervision: SAFE STOP: planner exited with code 3; 2 failures within 60 s exceed x"
        );
    }
}
