//! Servo tick lateness as seen from outside: a thread subscribed to the controller's
//! `servo/feedback`, woken by its event, notes for each sample its arrival time minus the
//! tick's deadline (`time_ns`). That includes one iceoryx2 hop and this thread's own wake-up.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc;
use std::thread::{self, JoinHandle};
use std::time::Duration;

use anyhow::Context;
use shared_types::bus::{self, Bus, BusError};
use shared_types::ipc::{ServoFeedback, topics};
use shared_types::time::monotonic_ns;

use super::stats::{Distribution, Recorder};

/// How long the watcher sleeps at most before it looks whether it should stop.
const STOP_POLL: Duration = Duration::from_millis(50);

/// What the watcher saw.
pub struct ServoTiming {
    /// Arrival minus deadline per tick (ns).
    pub lateness: Distribution,
    /// Growth of the servo's overrun counter while watched; `None` without samples.
    pub overruns: Option<u64>,
    /// Ticks seen but not kept (more than the capacity).
    pub dropped: u64,
}

/// A running watcher.
pub struct ServoWatch {
    stop: Arc<AtomicBool>,
    thread: JoinHandle<Result<ServoTiming, BusError>>,
}

impl ServoWatch {
    /// Subscribes to the feedback of controller `instance` and starts recording (up to
    /// `capacity` ticks); returns once the subscription exists.
    pub fn start(instance: &str, capacity: usize) -> anyhow::Result<Self> {
        let stop = Arc::new(AtomicBool::new(false));
        let (ready_tx, ready_rx) = mpsc::channel();
        let instance = instance.to_string();
        let stopping = Arc::clone(&stop);
        let thread = thread::Builder::new()
            .name("bench-servo-watch".into())
            .spawn(move || watch(&instance, capacity, &stopping, &ready_tx))
            .context("cannot start the servo watcher")?;
        match ready_rx.recv() {
            Ok(()) => Ok(Self { stop, thread }),
            // The thread ended before it was ready: its result says why.
            Err(_) => match thread.join() {
                Ok(Err(e)) => Err(e).context("servo watcher"),
                _ => anyhow::bail!("the servo watcher stopped during start-up"),
            },
        }
    }

    /// Stops recording and returns what was seen.
    pub fn finish(self) -> anyhow::Result<ServoTiming> {
        self.stop.store(true, Ordering::Relaxed);
        match self.thread.join() {
            Ok(result) => result.context("servo watcher"),
            Err(_) => anyhow::bail!("the servo watcher panicked"),
        }
    }
}

fn watch(
    instance: &str,
    capacity: usize,
    stop: &AtomicBool,
    ready: &mpsc::Sender<()>,
) -> Result<ServoTiming, BusError> {
    // The ports are created in this thread: iceoryx2's `ipc::Service` ports are not `Send`.
    let bus = Bus::new(instance, "bench-servo-watch")?;
    let feedback = bus.subscriber::<ServoFeedback>(topics::SERVO_FEEDBACK)?;
    let wakeup = bus.listener(topics::SERVO_FEEDBACK)?;
    // The history sample is old: not an arrival.
    bus::receive_latest(&feedback)?;
    // The caller may have given up waiting; then nobody reads the result either.
    let _ = ready.send(());
    let mut lateness = Recorder::with_capacity(capacity);
    let mut counters: Option<(u64, u64)> = None;
    while !stop.load(Ordering::Relaxed) {
        bus::wait_for_wakeup(&wakeup, STOP_POLL)?;
        let arrival = monotonic_ns();
        while let Some(sample) = feedback.receive().map_err(|e| BusError {
            action: "receive on",
            service: bus.service_name(topics::SERVO_FEEDBACK),
            detail: format!("{e:?}"),
        })? {
            let f = sample.payload();
            lateness.record(arrival.saturating_sub(f.time_ns));
            let first = counters.map_or(f.overruns, |(first, _)| first);
            counters = Some((first, f.overruns));
        }
    }
    Ok(ServoTiming {
        dropped: lateness.dropped(),
        lateness: lateness.into_distribution(),
        overruns: counters.map(|(first, last)| last.saturating_sub(first)),
    })
}
