//! The planner process: one executor step per servo tick.
//!
//! Wakes on the servo's feedback event, takes the newest feedback and the new motion
//! commands, steps the [`Executor`] and publishes the setpoint window and the status. The
//! servo is the clock: without fresh feedback nothing is stepped or published.

use core::sync::atomic::{AtomicBool, Ordering};
use core::time::Duration;

use shared_types::bus::{Bus, BusError, publish, receive_latest, wait_for_wakeup};
use shared_types::config::Config;
use shared_types::health::{HealthReporter, Service};
use shared_types::ipc::{
    JOB_EVENTS, MotionCommand, MotionCommandKind, MotionStatus, RefusalReason, ServoFeedback,
    ServoSetpoint, topics,
};
use shared_types::srci::message::state;
use tracing::{debug, info, warn};

use crate::executor::Executor;
use crate::refinement::ThreadRefiner;

/// Longest wait for a servo tick before the shutdown flag is checked again.
const WAKEUP_TIMEOUT: Duration = Duration::from_millis(20);
/// Commands taken per tick (the depth of the command topic's buffer).
const COMMAND_BATCH: usize = 64;

/// The planner process could not run.
#[derive(Debug, thiserror::Error)]
pub enum PlannerError {
    #[error(transparent)]
    Bus(#[from] BusError),
    #[error("the table planning thread could not be started: {0}")]
    TableThread(std::io::Error),
}

/// Runs the planner until `shutdown` becomes true.
pub fn run(config: &Config, shutdown: &AtomicBool) -> Result<(), PlannerError> {
    let bus = Bus::new(&config.main.instance, "planner")?;
    let feedback_subscriber = bus.subscriber::<ServoFeedback>(topics::SERVO_FEEDBACK)?;
    let feedback_wakeup = bus.listener(topics::SERVO_FEEDBACK)?;
    let command_subscriber = bus.subscriber::<MotionCommand>(topics::MOTION_COMMAND)?;
    let setpoint_publisher = bus.publisher::<ServoSetpoint>(topics::SERVO_SETPOINT)?;
    let status_publisher = bus.publisher::<MotionStatus>(topics::MOTION_STATUS)?;
    shared_types::supervision::ready();
    let period_ns = config.main.servo.period_us.saturating_mul(1000);
    let mut health = HealthReporter::new(&bus, Service::Planner, period_ns)?;

    let instance = process_instance();
    // Tables of buffered lines take longer than the setpoint window: planned off the tick.
    let capacity = 2 * usize::from(config.main.planner.queue_length);
    let refiner = ThreadRefiner::spawn(config, capacity).map_err(PlannerError::TableThread)?;
    let mut executor = Executor::with_refiner(config, instance, Box::new(refiner));
    let mut commands = [MotionCommand::new(MotionCommandKind::Reset); COMMAND_BATCH];
    let mut log = ChangeLog::default();
    info!(
        instance,
        robot = %config.robot.name,
        queue_length = config.main.planner.queue_length,
        "planner started"
    );
    if let Err(e) = crate::kinematics::ArmGeometry::new(&config.robot.kinematics) {
        // Joint moves work with any DH table; Cartesian targets need the UR-type solver.
        tracing::warn!(%e, "no inverse kinematics for this robot: Cartesian moves are refused");
    }

    while !shutdown.load(Ordering::Relaxed) {
        shared_types::supervision::beat();
        health.beat()?;
        if let Err(e) = wait_for_wakeup(&feedback_wakeup, WAKEUP_TIMEOUT) {
            // The signal that requests the shutdown may interrupt the wait.
            if shutdown.load(Ordering::Relaxed) {
                break;
            }
            return Err(e.into());
        }
        let Some(feedback) = receive_latest(&feedback_subscriber)? else {
            continue;
        };
        health.record(feedback.time_ns);
        let mut count = 0;
        while count < COMMAND_BATCH {
            match command_subscriber.receive() {
                Ok(Some(sample)) => {
                    commands[count] = *sample.payload();
                    count += 1;
                }
                Ok(None) => break,
                Err(e) => {
                    return Err(BusError {
                        action: "receive on",
                        service: topics::MOTION_COMMAND.to_string(),
                        detail: format!("{e:?}"),
                    }
                    .into());
                }
            }
        }
        let window = executor.step(&feedback, &commands[..count]);
        if let Some(window) = window {
            publish(&setpoint_publisher, window)?;
        }
        publish(&status_publisher, *executor.status())?;
        log.record(&feedback, &executor);
    }
    info!("planner stopped");
    Ok(())
}

/// Remembers what was logged last, so only changes are logged.
#[derive(Default)]
struct ChangeLog {
    feedback_seen: bool,
    commanding: bool,
    error_code: u16,
    event_head: u64,
    dropped_events: u64,
}

impl ChangeLog {
    fn record(&mut self, feedback: &ServoFeedback, executor: &Executor) {
        if !self.feedback_seen {
            self.feedback_seen = true;
            info!(
                servo = feedback.instance,
                tick = feedback.tick,
                state = feedback.state,
                "first servo feedback"
            );
        }
        if executor.is_commanding() != self.commanding {
            self.commanding = executor.is_commanding();
            if self.commanding {
                info!(
                    tick = feedback.tick,
                    "commanding the servo from the arm's position"
                );
            } else {
                warn!(
                    tick = feedback.tick,
                    state = feedback.state,
                    "servo not following: waiting for the arm to stand still"
                );
            }
        }
        let status = executor.status();
        if status.error_code != self.error_code {
            self.error_code = status.error_code;
            if status.error_code == 0 {
                info!("planner error cleared");
            } else {
                warn!(
                    code = format_args!("{:#06X}", status.error_code),
                    drive_fault = feedback.fault_code,
                    "planner error"
                );
            }
        }
        if executor.dropped_events() != self.dropped_events {
            self.dropped_events = executor.dropped_events();
            warn!(
                total = self.dropped_events,
                "job events lost: too many waiting"
            );
        }
        // Only the last JOB_EVENTS events are still in the ring.
        let first =
            (self.event_head + 1).max((status.event_head + 1).saturating_sub(JOB_EVENTS as u64));
        for number in first..=status.event_head {
            let event = &status.events[(number % JOB_EVENTS as u64) as usize];
            let name = state::name(event.state);
            if event.state == state::ERROR {
                let why = RefusalReason::from_wire(event.reason).text().unwrap_or("");
                warn!(
                    job = event.job,
                    code = format_args!("{:#06X}", event.code),
                    "job {name} {why}"
                );
            } else {
                debug!(
                    job = event.job,
                    code = format_args!("{:#06X}", event.code),
                    "job {name}"
                );
            }
        }
        self.event_head = status.event_head;
    }
}

/// A number that differs between planner process starts: CLOCK_REALTIME and the pid, mixed.
fn process_instance() -> u64 {
    let mut now = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: `now` is a valid timespec for the call to write.
    unsafe { libc::clock_gettime(libc::CLOCK_REALTIME, &mut now) };
    let seed = (now.tv_sec as u64)
        .wrapping_mul(1_000_000_000)
        .wrapping_add(now.tv_nsec as u64)
        ^ (u64::from(std::process::id()) << 32);
    // SplitMix64 finalizer: nearby seeds give unrelated values.
    let mut z = seed.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    (z ^ (z >> 31)).max(1)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn process_instances_are_nonzero_and_differ() {
        let a = process_instance();
        std::thread::sleep(Duration::from_millis(1));
        let b = process_instance();
        assert!(a != 0 && b != 0 && a != b);
    }
}
