//! The servo process: the clock of motion. Every period it takes the latest power request and
//! setpoint window, advances the simulated drives by one tick and publishes their feedback,
//! which wakes the planner for the next setpoints.

pub mod clock;
pub mod drives;
pub mod position_memory;

use std::sync::atomic::{AtomicBool, Ordering};

use shared_types::bus::{Bus, BusError, publish, receive_latest};
use shared_types::config::Config;
use shared_types::health::{HealthReporter, Service};
use shared_types::ipc::{DriveState, ServoControl, ServoFeedback, ServoSetpoint, topics};
use shared_types::throttle::WarnThrottle;

use clock::{ClockError, PeriodicClock, monotonic_ns};
use drives::{Cause, DriveParams, DriveStatus, SimulatedDrives, Transition};
use position_memory::PositionMemory;

/// At most one overrun log line per this interval (each overrun is counted in the feedback).
const OVERRUN_LOG_INTERVAL_NS: u64 = 10_000_000_000;

/// The servo process failed.
#[derive(Debug, thiserror::Error)]
pub enum ServoError {
    #[error(transparent)]
    Bus(#[from] BusError),
    #[error(transparent)]
    Clock(#[from] ClockError),
    #[error("wake-up notification on '{topic}' failed: {detail}")]
    Notify { topic: &'static str, detail: String },
    #[error("servo position memory in {dir}: {source}")]
    PositionMemory { dir: String, source: std::io::Error },
}

/// Runs the servo loop until `shutdown` becomes true (returns within one period).
pub fn run(config: &Config, shutdown: &AtomicBool) -> Result<(), ServoError> {
    let bus = Bus::new(&config.main.instance, "servo")?;
    let control_sub = bus.subscriber::<ServoControl>(topics::SERVO_CONTROL)?;
    let setpoint_sub = bus.subscriber::<ServoSetpoint>(topics::SERVO_SETPOINT)?;
    let feedback_pub = bus.publisher::<ServoFeedback>(topics::SERVO_FEEDBACK)?;
    let feedback_wake = bus.notifier(topics::SERVO_FEEDBACK)?;
    shared_types::supervision::ready();

    let instance = process_instance();
    let period_ns = config.main.servo.period_us.saturating_mul(1000);
    let mut health = HealthReporter::new(&bus, Service::Servo, period_ns)?;
    // The arm stays where it stopped: a restarted servo process (or controller) continues
    // from the stored position, never from home, so the simulated joints never jump.
    let data_dir = config.main.data_dir();
    let (mut position, previous) =
        PositionMemory::open(&data_dir).map_err(|source| ServoError::PositionMemory {
            dir: data_dir.display().to_string(),
            source,
        })?;
    let start = previous.unwrap_or_else(|| config.robot.home_deg.map(f64::to_radians));
    position.store(&start);
    let mut drives = SimulatedDrives::new(DriveParams::from_config(config), start);
    let mut control = ServoControl::default();
    let mut setpoint: Option<ServoSetpoint> = None;
    let mut clock = PeriodicClock::start(period_ns)?;
    tracing::info!(
        instance,
        period_us = config.main.servo.period_us,
        robot = %config.robot.name,
        restored = previous.is_some(),
        "servo started, drives off"
    );

    let mut tick: u64 = 0;
    let mut overrun_log = WarnThrottle::new(OVERRUN_LOG_INTERVAL_NS);
    while !shutdown.load(Ordering::Relaxed) {
        let timing = clock.wait()?;
        shared_types::supervision::beat();
        health.record(timing.deadline_ns);
        health.beat()?;
        // Overruns are counted in every feedback sample; the log gets one line per interval
        // at most, so a loaded machine does not flood it.
        if timing.skipped > 0 && overrun_log.admit(timing.deadline_ns).is_some() {
            tracing::info!(
                tick,
                overruns = clock.overruns(),
                "servo ticks overran; periods skipped"
            );
        }
        if let Some(c) = receive_latest(&control_sub)? {
            control = c;
        }
        if let Some(s) = receive_latest(&setpoint_sub)? {
            setpoint = Some(s);
        }
        let report = drives.tick(tick, &control, setpoint.as_ref());
        for t in report.transitions.iter() {
            log_transition(tick, t, &report.status);
        }
        let s = &report.status;
        position.store(&s.q);
        let feedback = ServoFeedback {
            instance,
            tick,
            time_ns: timing.deadline_ns,
            period_ns,
            q: s.q,
            qd: s.qd,
            state: s.state as u8,
            reserved: 0,
            fault_code: s.fault_code,
            reserved2: 0,
            control_seq: s.control_seq,
            setpoint_misses: s.setpoint_misses,
            overruns: clock.overruns(),
        };
        publish(&feedback_pub, feedback)?;
        feedback_wake.notify().map_err(|e| ServoError::Notify {
            topic: topics::SERVO_FEEDBACK,
            detail: format!("{e:?}"),
        })?;
        tick += 1;
    }
    tracing::info!(tick, overruns = clock.overruns(), "servo stopped");
    Ok(())
}

fn log_transition(tick: u64, t: &Transition, s: &DriveStatus) {
    let (from, to, cause) = (t.from, t.to, t.cause);
    match cause {
        Cause::Fault(fault) => tracing::error!(
            tick,
            ?fault,
            code = format_args!("{:#06X}", s.fault_code),
            "drive fault: implausible setpoint, stopping the arm"
        ),
        Cause::SetpointTimeout if to == DriveState::Stopping => tracing::warn!(
            tick,
            misses = s.setpoint_misses,
            "setpoints stopped; stopping the arm"
        ),
        // Every move starts and ends this way; not worth a line each.
        Cause::SetpointAccepted | Cause::SetpointTimeout => {
            tracing::debug!(tick, ?from, ?to, ?cause, "drive state")
        }
        _ => tracing::info!(tick, ?from, ?to, ?cause, "drive state"),
    }
}

/// A number that differs between process starts, so readers notice a restarted servo.
fn process_instance() -> u64 {
    let wall_ns = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_nanos() as u64);
    let seed = wall_ns ^ monotonic_ns().rotate_left(32) ^ u64::from(std::process::id());
    // SplitMix64 finaliser: spreads the few changing bits over the whole word.
    let mut z = seed.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    (z ^ (z >> 31)).max(1)
}
