//! The interpreter process: answers every PLC telegram through the [`Server`] core and
//! carries its effects to the planner and the drives.

use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use iceoryx2::port::subscriber::Subscriber;
use shared_types::bus::{self, Bus, BusError, Ipc};
use shared_types::config::Config;
use shared_types::health::{
    HealthReporter, Service, SupervisionRequest, SupervisionStatus, topics as health_topics,
};
use shared_types::ipc::{
    LinkEvent, MotionCommand, MotionStatus, PlcTelegram, RobotTelegram, ServoControl,
    ServoFeedback, topics,
};
use shared_types::supervision::HANDOVER_ENV;

use crate::handover::{self, HandoverError, Snapshot};
use crate::server::{Effects, Now, Server, Settings, write_text};
use crate::user_data::{Saver, UserData};

/// The interpreter process failed.
#[derive(Debug, thiserror::Error)]
pub enum InterpreterError {
    #[error(transparent)]
    Bus(#[from] BusError),
    #[error("user data folder {dir}: {source}")]
    UserData { dir: String, source: std::io::Error },
}

/// Longest wait for a telegram before periodic work runs (lifesign supervision granularity).
const POLL_INTERVAL: Duration = Duration::from_millis(2);
/// Telegrams handled per wake-up at most (bounds the loop; more wait for the next pass).
const TELEGRAMS_PER_PASS: usize = 16;
/// The drive power request is re-published this often, so a restarted servo process (which
/// sees the topic's history only once the publisher sends again) gets it back.
const CONTROL_REPUBLISH_MS: u64 = 100;
/// How often a successor in standby looks for its predecessor's snapshot.
const STANDBY_POLL: Duration = Duration::from_millis(1);
/// How long a successor waits in standby before it starts a new session.
const STANDBY_TIMEOUT: Duration = Duration::from_secs(10);

fn now() -> Now {
    Now {
        mono_ms: shared_types::time::monotonic_ns() / 1_000_000,
        unix_ms: shared_types::time::unix_ms(),
    }
}

/// Runs the interpreter until `shutdown` is set.
pub fn run(config: &Config, shutdown: &AtomicBool) -> Result<(), InterpreterError> {
    let bus = Bus::new(&config.main.instance, "interpreter")?;
    let telegrams = bus.subscriber::<PlcTelegram>(topics::P2R)?;
    let telegram_wakeup = bus.listener(topics::P2R)?;
    let answers = bus.publisher::<RobotTelegram>(topics::R2P)?;
    let answer_wakeup = bus.notifier(topics::R2P)?;
    let commands = bus.publisher::<MotionCommand>(topics::MOTION_COMMAND)?;
    let status = bus.subscriber::<MotionStatus>(topics::MOTION_STATUS)?;
    let feedback = bus.subscriber::<ServoFeedback>(topics::SERVO_FEEDBACK)?;
    let control = bus.publisher::<ServoControl>(topics::SERVO_CONTROL)?;
    let supervision = bus.subscriber::<SupervisionStatus>(health_topics::SUPERVISION_STATUS)?;
    let supervision_requests =
        bus.publisher::<SupervisionRequest>(health_topics::SUPERVISION_CONTROL)?;
    shared_types::supervision::ready();
    let reply_timeout_ns = config.main.fieldbus.reply_timeout_ms * 1_000_000;
    let mut health = HealthReporter::new(&bus, Service::Interpreter, reply_timeout_ns)?;

    let issuer = now().unix_ms ^ (u64::from(std::process::id()) << 40);
    let data_dir = config.main.data_dir();
    let (user_data, warnings) = UserData::load(&data_dir, &config.robot);
    let saver = Saver::spawn(data_dir.clone(), config.robot.name.clone()).map_err(|source| {
        InterpreterError::UserData {
            dir: data_dir.display().to_string(),
            source,
        }
    })?;
    let mut server = Server::new(Settings::from_config(config), issuer, user_data);
    for w in warnings {
        tracing::warn!(%w, "user data");
        let mut text = [0u8; 150];
        let text = write_text(&mut text, format_args!("{w}"));
        server.raise_warning(now(), text);
    }
    // The counter of the last PLC telegram answered, by this process or its predecessor.
    let mut last_counter = 0;
    let standby = std::env::var(HANDOVER_ENV).is_ok_and(|v| v == "standby");
    let taken = if standby {
        let ports = StandbyPorts {
            telegrams: &telegrams,
            status: &status,
            feedback: &feedback,
        };
        match await_handover(
            &data_dir,
            &config.main.instance,
            &ports,
            &mut health,
            shutdown,
        )? {
            Some(taken) => taken,
            None => return Ok(()),
        }
    } else {
        handover::take(&data_dir, &config.main.instance, now().mono_ms)
    };
    match taken {
        Ok(Some(snapshot)) => {
            last_counter = snapshot.last_counter;
            tracing::info!(
                telegram_state = snapshot.telegram_state,
                commands = snapshot.live.len(),
                "continuing the SRCI session of the previous interpreter process"
            );
            server.restore(snapshot, now());
        }
        Ok(None) => {}
        Err(e) => {
            tracing::warn!(%e, "starting a new SRCI session");
            let mut text = [0u8; 150];
            let text = write_text(&mut text, format_args!("{e}"));
            server.raise_warning(now(), text);
        }
    }
    let mut fx = Effects::new();
    let mut answer = RobotTelegram::answer(0, 0);
    tracing::info!(
        instance = %config.main.instance,
        robot = %config.robot.name,
        telegram_state = server.telegram_state(),
        "interpreter ready"
    );
    let mut last_state = server.telegram_state();
    let mut control_published_ms = 0;

    while !shutdown.load(Ordering::Relaxed) {
        shared_types::supervision::beat();
        health.beat()?;
        bus::wait_for_wakeup(&telegram_wakeup, POLL_INTERVAL)?;
        let t = now();
        if let Some(s) = bus::receive_latest(&status)? {
            server.on_motion_status(t, &s, &mut fx);
        }
        if let Some(f) = bus::receive_latest(&feedback)? {
            server.on_servo_feedback(t, &f, &mut fx);
        }
        if let Some(s) = bus::receive_latest(&supervision)? {
            server.on_supervision_status(t, &s, &mut fx);
        }
        for _ in 0..TELEGRAMS_PER_PASS {
            let Some(sample) = telegrams.receive().map_err(|e| BusError {
                action: "receive on",
                service: topics::P2R.into(),
                detail: format!("{e:?}"),
            })?
            else {
                break;
            };
            let request = *sample.payload();
            drop(sample);
            match LinkEvent::from_wire(request.event) {
                // Answered by the predecessor before it handed over.
                LinkEvent::Telegram if request.counter <= last_counter => {}
                LinkEvent::Telegram => {
                    health.record(request.received_ns);
                    let n = server.on_telegram(t, request.telegram(), &mut answer.bytes, &mut fx);
                    answer.counter = request.counter;
                    last_counter = request.counter;
                    answer.connection = request.connection;
                    // At most TELEGRAM_CAPACITY (256).
                    answer.len = n as u16;
                    bus::publish(&answers, answer)?;
                    // A missed wake-up only delays the answer until the fieldbus polls again.
                    let _ = answer_wakeup.notify();
                }
                event => {
                    tracing::info!(?event, connection = request.connection, "fieldbus link");
                    server.on_link(t, event, &mut fx);
                }
            }
        }
        server.poll(t, &mut fx);
        for c in fx.motion.iter() {
            bus::publish(&commands, *c)?;
        }
        // Only once a command has set the power request: a restarted interpreter must not
        // switch the drives off by publishing its initial, all-off request.
        let republish = server.servo_control_set()
            && t.mono_ms.saturating_sub(control_published_ms) >= CONTROL_REPUBLISH_MS;
        if let Some(c) = fx.servo.or(republish.then(|| server.servo_control())) {
            bus::publish(&control, c)?;
            control_published_ms = t.mono_ms;
        }
        if let Some(r) = fx.supervision {
            bus::publish(&supervision_requests, r)?;
        }
        fx.clear();
        // Written by the saver thread, so the telegram loop never waits for the disk.
        if let Some(data) = server.user_data.take_unsaved() {
            saver.submit(data);
        }
        if let Some(e) = saver.take_failure() {
            tracing::error!(%e, "user data not saved");
            let mut text = [0u8; 150];
            let text = write_text(&mut text, format_args!("user data not saved: {e}"));
            server.raise_warning(t, text);
        }
        let state = server.telegram_state();
        if state != last_state {
            tracing::info!(from = last_state, to = state, "TelegramState changed");
            last_state = state;
        }
    }
    if hand_over(&bus, &server, config, &data_dir, last_counter) {
        // The fieldbus holds the PLC over until the next interpreter process answers.
        let mut notice = RobotTelegram::answer(last_counter, answer.connection);
        notice.flags = RobotTelegram::HANDOVER;
        bus::publish(&answers, notice)?;
        let _ = answer_wakeup.notify();
    }
    tracing::info!("interpreter stopped");
    Ok(())
}

/// The inputs a successor in standby keeps drained, so that it starts from fresh samples.
struct StandbyPorts<'a> {
    telegrams: &'a Subscriber<Ipc, PlcTelegram, ()>,
    status: &'a Subscriber<Ipc, MotionStatus, ()>,
    feedback: &'a Subscriber<Ipc, ServoFeedback, ()>,
}

/// The successor of a handing-over interpreter: beats (its beat tells the orchestrator to
/// stop the predecessor) and drains its inputs, which the predecessor still serves, until
/// the predecessor's snapshot appears. `None` on shutdown; a new session after
/// [`STANDBY_TIMEOUT`] without a snapshot.
fn await_handover(
    data_dir: &Path,
    instance: &str,
    ports: &StandbyPorts<'_>,
    health: &mut HealthReporter,
    shutdown: &AtomicBool,
) -> Result<Option<Result<Option<Snapshot>, HandoverError>>, InterpreterError> {
    tracing::info!("in standby: waiting for the running interpreter to hand over");
    let start = now().mono_ms;
    while !shutdown.load(Ordering::Relaxed) {
        shared_types::supervision::beat();
        health.beat()?;
        while ports
            .telegrams
            .receive()
            .map_err(|e| BusError {
                action: "receive on",
                service: topics::P2R.into(),
                detail: format!("{e:?}"),
            })?
            .is_some()
        {}
        bus::receive_latest(ports.status)?;
        bus::receive_latest(ports.feedback)?;
        let t = now().mono_ms;
        match handover::take(data_dir, instance, t) {
            Ok(None) if t.saturating_sub(start) < STANDBY_TIMEOUT.as_millis() as u64 => {
                std::thread::sleep(STANDBY_POLL);
            }
            Ok(None) => {
                tracing::warn!("no interpreter handed over: starting a new SRCI session");
                return Ok(Some(Ok(None)));
            }
            taken => return Ok(Some(taken)),
        }
    }
    Ok(None)
}

/// On a stop while a fieldbus still carries the PLC link (a restart of this service alone),
/// leaves the session to the next interpreter process; when the whole controller stops, the
/// fieldbus has gone first and there is no session to continue. Returns whether it did.
fn hand_over(
    bus: &Bus,
    server: &Server,
    config: &Config,
    data_dir: &Path,
    last_counter: u64,
) -> bool {
    let fieldbus_listening = bus
        .subscriber_count::<RobotTelegram>(topics::R2P)
        .is_ok_and(|n| n > 0);
    if !fieldbus_listening {
        return false;
    }
    let t = now();
    let snapshot = server.snapshot(&config.main.instance, t, last_counter);
    match handover::write(data_dir, &snapshot) {
        Ok(()) => {
            tracing::info!(
                telegram_state = server.telegram_state(),
                last_counter,
                "SRCI session handed over to the next interpreter process"
            );
            true
        }
        Err(e) => {
            tracing::error!(%e, "the SRCI session cannot be handed over");
            false
        }
    }
}
