//! One pipeline row: a PLC session at one telegram cycle against the running controller,
//! keeping joint moves going, with every telegram round trip timed and the servo's ticks
//! watched. A reply that times out, an engine fault or a failed move restarts the session
//! (counted and reported); the measurement goes on until the requested cycles are done.

use std::time::{Duration, Instant};

use anyhow::{Context, bail};
use plc_client::transport::{DEFAULT_RESPONSE_TIMEOUT, RoundTripSummary};
use plc_client::{
    ClientError, CycleRunner, EngineOptions, RobotTask, TcpTransport, Transport, TransportError,
};
use shared_types::config::RobotConfig;

use super::elapsed_ns;
use super::servo_watch::{ServoTiming, ServoWatch};
use super::stats::{Distribution, Recorder};
use super::workload::Workload;

const CONNECT_TIMEOUT: Duration = Duration::from_secs(2);
/// Start-up chain, GroupReset and EnableRobot (with the drives' simulated power-on delays).
const SETUP_TIMEOUT: Duration = Duration::from_secs(20);
/// Session restarts a row may need before the benchmark gives up.
const MAX_RESTARTS: usize = 5;

/// What one row is run with.
pub struct RowPlan<'a> {
    pub addr: &'a str,
    /// The PLC engine's options; `cycle_time` is the row's telegram cycle.
    pub options: EngineOptions,
    pub robot: &'a RobotConfig,
    /// The controller's instance name (for its `servo/feedback`).
    pub instance: &'a str,
    /// Telegram cycles to measure.
    pub cycles: usize,
    /// Servo ticks the watcher keeps at most.
    pub servo_ticks: usize,
}

/// What one row measured.
pub struct RowTiming {
    /// Telegram round trips (ns).
    pub round_trip: Distribution,
    /// PLC cycles that ended after their deadline.
    pub overruns: u64,
    /// Replies later than the response timeout.
    pub timeouts: u64,
    /// Watched from the first measured cycle to the last (session restarts included).
    pub servo: ServoTiming,
    /// Why sessions were restarted.
    pub restarts: Vec<String>,
    /// Moves completed while measuring.
    pub moves: u64,
}

/// The TCP gateway transport, timing each exchange while `recording`.
struct TimedTransport {
    inner: TcpTransport,
    round_trips: Recorder,
    recording: bool,
}

impl Transport for TimedTransport {
    fn exchange(&mut self, tx: &[u8], rx: &mut [u8]) -> Result<(), TransportError> {
        let start = Instant::now();
        let result = self.inner.exchange(tx, rx);
        if self.recording && result.is_ok() {
            self.round_trips.record(elapsed_ns(start));
        }
        result
    }

    fn round_trips(&self) -> RoundTripSummary {
        self.inner.round_trips()
    }
}

fn connect(addr: &str) -> Result<TcpTransport, TransportError> {
    TcpTransport::connect(addr, CONNECT_TIMEOUT, DEFAULT_RESPONSE_TIMEOUT)
}

/// Counters of the measured part of a row, across session restarts.
#[derive(Default)]
struct Progress {
    measured: usize,
    overruns: u64,
    timeouts: u64,
    moves: u64,
}

/// Runs one row.
pub fn run_row(plan: &RowPlan<'_>) -> anyhow::Result<RowTiming> {
    let mut link = TimedTransport {
        inner: connect(plan.addr)?,
        round_trips: Recorder::with_capacity(plan.cycles),
        recording: false,
    };
    let mut progress = Progress::default();
    let mut restarts = Vec::new();
    let mut watch = None;
    loop {
        let mut runner = CycleRunner::new(RobotTask::new(plan.options.clone())?, &mut link);
        let mut workload = Workload::new(plan.robot);
        set_up(&mut runner, &mut workload)?;
        if watch.is_none() {
            watch = Some(ServoWatch::start(plan.instance, plan.servo_ticks)?);
        }
        let interruption = measure(&mut runner, &mut workload, plan.cycles, &mut progress)?;
        drop(runner);
        let Some(why) = interruption else {
            break;
        };
        restarts.push(why);
        if restarts.len() > MAX_RESTARTS {
            bail!(
                "the PLC session had to be restarted too often: {}",
                restarts.join("; ")
            );
        }
        link.inner = connect(plan.addr)?;
    }
    let servo = match watch {
        Some(w) => w.finish()?,
        None => bail!("the servo was never watched"),
    };
    Ok(RowTiming {
        round_trip: link.round_trips.into_distribution(),
        overruns: progress.overruns,
        timeouts: progress.timeouts,
        servo,
        restarts,
        moves: progress.moves,
    })
}

/// Initializes the interface, resets and enables the robot and starts the first move.
fn set_up(
    runner: &mut CycleRunner<&mut TimedTransport>,
    workload: &mut Workload,
) -> anyhow::Result<()> {
    plc_client::start_up(runner, SETUP_TIMEOUT).context("SRCI start-up")?;
    let start = Instant::now();
    while !workload.moving() {
        runner.step()?;
        if let Some(fault) = runner.task().fault() {
            bail!("RobotTask fault while resetting and enabling: {fault}");
        }
        workload.advance(runner.task_mut())?;
        if start.elapsed() > SETUP_TIMEOUT {
            bail!(
                "the robot was not reset, enabled and moving within {} s",
                SETUP_TIMEOUT.as_secs()
            );
        }
    }
    Ok(())
}

/// Runs and times cycles until `cycles` are measured in all, or the session must restart
/// (returns why).
fn measure(
    runner: &mut CycleRunner<&mut TimedTransport>,
    workload: &mut Workload,
    cycles: usize,
    progress: &mut Progress,
) -> anyhow::Result<Option<String>> {
    let overruns_before = runner.overruns();
    let moves_before = workload.moves_done();
    runner.transport_mut().recording = true;
    let interruption = loop {
        if progress.measured >= cycles {
            break None;
        }
        match runner.step() {
            Ok(()) => progress.measured += 1,
            Err(ClientError::Transport(e @ TransportError::Timeout(_))) => {
                progress.timeouts += 1;
                break Some(e.to_string());
            }
            Err(e) => return Err(e.into()),
        }
        if let Some(fault) = runner.task().fault() {
            break Some(format!("RobotTask fault: {fault}"));
        }
        if let Err(e) = workload.advance(runner.task_mut()) {
            break Some(e.to_string());
        }
    };
    runner.transport_mut().recording = false;
    progress.overruns += runner.overruns() - overruns_before;
    progress.moves += workload.moves_done() - moves_before;
    Ok(interruption)
}
