//! The recorder: a thread of the `rc plc` / `rc demo` process that subscribes to the
//! controller's topics while a program runs and hands what it receives to a [`Capture`].
//!
//! It only reads: it polls its subscribers every millisecond instead of listening to the
//! feedback's wake-up event, so that the servo does not notify one more listener per tick,
//! and a slow recorder only loses samples of its own (the topics overwrite the oldest sample
//! in its buffer, they never wait for it). Missed ticks are counted for the caption.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc;
use std::thread::{self, JoinHandle};
use std::time::Duration;

use planner::kinematics::Kinematics;
use shared_types::bus::{self, Bus, BusError, Ipc};
use shared_types::config::Config;
use shared_types::ipc::{MotionCommand, MotionStatus, ServoFeedback, topics};

use super::capture::{Capture, CaptureCounts};
use super::recording::Recording;
use super::tcp::TcpSpeed;

/// Samples kept at full rate: at a 1 ms servo tick about 65 s; longer runs are decimated.
pub const SAMPLE_CAPACITY: usize = 1 << 16;
/// Job markers kept (a few per move).
const MARKER_CAPACITY: usize = 4096;
/// How often the subscribers are emptied; the feedback buffer (4 samples) covers 4 ticks.
const POLL_PERIOD: Duration = Duration::from_millis(1);
/// Samples taken from one subscriber per poll at most, so that a flood cannot hold the loop.
const MAX_PER_POLL: usize = 64;

/// The recorder could not record.
#[derive(Debug, thiserror::Error)]
pub enum RecorderError {
    #[error("cannot subscribe to the controller's topics: {0}")]
    Bus(#[from] BusError),
    #[error("cannot receive on {topic}: {detail}")]
    Receive { topic: &'static str, detail: String },
    #[error("cannot start the recorder thread: {0}")]
    Spawn(std::io::Error),
    #[error("the recorder thread ended without a result")]
    Lost,
}

/// What a finished recorder hands back.
#[derive(Debug)]
pub struct Recorded {
    pub recording: Recording,
    pub counts: CaptureCounts,
}

/// A running recorder thread.
pub struct Recorder {
    stop: Arc<AtomicBool>,
    thread: JoinHandle<Result<Recorded, RecorderError>>,
}

impl Recorder {
    /// Subscribes to the topics of the controller of `config` and starts recording; returns
    /// once the subscriptions exist, so nothing the program does afterwards is missed.
    pub fn start(config: &Config) -> Result<Self, RecorderError> {
        let instance = config.main.instance.clone();
        let capture = Capture::new(
            Recording::with_capacity(SAMPLE_CAPACITY, MARKER_CAPACITY),
            TcpSpeed::new(Kinematics::new(&config.robot.kinematics)),
        );
        let stop = Arc::new(AtomicBool::new(false));
        let (ready, subscribed) = mpsc::sync_channel(1);
        let thread = thread::Builder::new()
            .name("plot-recorder".into())
            .spawn({
                let stop = Arc::clone(&stop);
                move || record(&instance, capture, &stop, &ready)
            })
            .map_err(RecorderError::Spawn)?;
        if subscribed.recv().is_ok() {
            return Ok(Self { stop, thread });
        }
        // The thread ended before it subscribed: its result says why.
        Err(match thread.join() {
            Ok(Err(e)) => e,
            _ => RecorderError::Lost,
        })
    }

    /// Stops recording (after one last look at the topics) and returns the recording.
    pub fn finish(self) -> Result<Recorded, RecorderError> {
        self.stop.store(true, Ordering::Relaxed);
        self.thread.join().map_err(|_| RecorderError::Lost)?
    }
}

fn record(
    instance: &str,
    mut capture: Capture,
    stop: &AtomicBool,
    ready: &mpsc::SyncSender<()>,
) -> Result<Recorded, RecorderError> {
    let bus = Bus::new(instance, "rcplot")?;
    let feedback = bus.subscriber::<ServoFeedback>(topics::SERVO_FEEDBACK)?;
    let status = bus.subscriber::<MotionStatus>(topics::MOTION_STATUS)?;
    let commands = bus.subscriber::<MotionCommand>(topics::MOTION_COMMAND)?;
    // The receiver waits for this; if it is gone, the recording is simply not used.
    let _ = ready.send(());
    loop {
        // Read once more after the stop request, so that the run's end is in the recording.
        let last_look = stop.load(Ordering::Relaxed);
        drain(&commands, topics::MOTION_COMMAND, |c| capture.on_command(c))?;
        if let Some(s) = bus::receive_latest(&status)? {
            capture.on_status(&s);
        }
        drain(&feedback, topics::SERVO_FEEDBACK, |f| {
            capture.on_feedback(f)
        })?;
        if last_look {
            break;
        }
        thread::sleep(POLL_PERIOD);
    }
    let counts = capture.counts();
    Ok(Recorded {
        recording: capture.finish(),
        counts,
    })
}

/// Hands every waiting sample of `subscriber` (at most [`MAX_PER_POLL`]) to `take`.
fn drain<T: core::fmt::Debug + iceoryx2::prelude::ZeroCopySend>(
    subscriber: &iceoryx2::port::subscriber::Subscriber<Ipc, T, ()>,
    topic: &'static str,
    mut take: impl FnMut(&T),
) -> Result<(), RecorderError> {
    for _ in 0..MAX_PER_POLL {
        match subscriber.receive() {
            Ok(Some(sample)) => take(sample.payload()),
            Ok(None) => break,
            Err(e) => {
                return Err(RecorderError::Receive {
                    topic,
                    detail: format!("{e:?}"),
                });
            }
        }
    }
    Ok(())
}
