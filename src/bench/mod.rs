//! `rc bench`: measurements of the controller on this machine.
//!
//! `rc bench latency` starts a private controller and measures, per telegram cycle (8, 2,
//! 1 ms) idle and with every CPU busy at nice 19: the PLC's telegram round trips, missed
//! cycles, and the servo's tick lateness. Then, with the controller stopped, the interpreter
//! core's processing time per telegram (in-process) and one iceoryx2 hop against a Unix
//! domain socket. It prints one table and writes the percentile distributions to
//! [`HGRM_FILE`] in the current directory; after the table, the PROFINET row (`profinet`:
//! the period of our input frames on a veth pair, as root). Nothing here judges the numbers.

mod hop;
mod load;
pub mod motion;
mod pipeline;
mod private_controller;
mod processing;
mod profinet;
mod rig;
mod servo_watch;
pub(crate) mod stats;
mod table;
mod workload;

use std::num::NonZero;
use std::path::{Path, PathBuf};
use std::process::Stdio;
use std::time::{Duration, Instant};

use anyhow::Context;
use clap::Subcommand;
use shared_types::config::Config;

use crate::controller::{ChildController, client_options};
use load::CpuLoad;
use pipeline::{RowPlan, RowTiming};
use private_controller::PrivateController;
use stats::Distribution;
use table::{PipelineRow, RatioRow, Row, TimingRow, Unit};

/// The benchmarks.
#[derive(Debug, Subcommand)]
pub enum Benchmark {
    /// Telegram round trips, missed cycles and servo tick lateness at 8, 2 and 1 ms telegram
    /// cycles, idle and under CPU load; interpreter processing time; one iceoryx2 hop against
    /// a Unix domain socket.
    Latency {
        /// Telegram cycles measured per row.
        #[arg(long, default_value_t = 2000, value_parser = cycles_parser())]
        cycles: u32,
        /// Configuration of the controller to measure (default: the embedded
        /// config/default.toml); it runs under a private instance name and port.
        #[arg(long, value_name = "FILE")]
        config: Option<PathBuf>,
    },
    /// Inverse kinematics and planning times, and the planner's move durations against the
    /// time-optimal ones of ruckig (joint moves) and toppra (linear moves).
    Motion {
        #[command(flatten)]
        options: motion::Options,
        /// Configuration of the robot and the planner (default: the embedded
        /// config/default.toml).
        #[arg(long, value_name = "FILE")]
        config: Option<PathBuf>,
    },
}

/// At most this many cycles per row (over two hours at 8 ms), so the sample storage, which
/// is reserved up front, stays within memory.
const MAX_CYCLES: i64 = 1_000_000;

fn cycles_parser() -> clap::builder::RangedI64ValueParser<u32> {
    clap::value_parser!(u32).range(1..=MAX_CYCLES)
}

/// The percentile distributions, written to the current directory.
pub const HGRM_FILE: &str = "bench-latency.hgrm";
/// The telegram cycles measured, in ms.
const CYCLE_TIMES_MS: [u64; 3] = [8, 2, 1];
/// Telegrams timed in-process, and hop round trips, per measured telegram cycle.
const SAMPLES_PER_CYCLE: usize = 10;

/// Nanoseconds since `start` (saturating: no interval here comes near 584 years).
fn elapsed_ns(start: Instant) -> u64 {
    u64::try_from(start.elapsed().as_nanos()).unwrap_or(u64::MAX)
}

/// One row of the pipeline: its label and what was measured.
struct PipelineResult {
    label: String,
    timing: RowTiming,
}

/// Everything `rc bench latency` measured.
struct LatencyResults {
    pipeline: Vec<PipelineResult>,
    processing: processing::Processing,
    hops: hop::Hops,
}

/// Runs `rc bench latency` against a controller configured like `config`; `Ok(true)` if the
/// controller also stopped cleanly.
pub fn latency(config: &Config, cycles: u32) -> anyhow::Result<bool> {
    let cycles = cycles as usize;
    let cpus = std::thread::available_parallelism().map_or(1, NonZero::get);
    let instance = format!("bench{}", std::process::id());
    let mut private = PrivateController::create(config, &instance)?;
    let log_path = private.log_path();
    let log = std::fs::File::create(&log_path)
        .with_context(|| format!("cannot create {}", log_path.display()))?;
    let mut controller = ChildController::start(&private.config, Stdio::from(log))?;
    let pipeline = run_pipeline_rows(&mut controller, &private.config, cycles, cpus);
    let stopped = controller.stop();
    let pipeline = match pipeline {
        Ok(p) => p,
        Err(e) => {
            private.keep();
            return Err(e.context(format!("controller log: {}", log_path.display())));
        }
    };
    // The controller's 1 kHz loops are stopped: they would disturb these short timings.
    progress(&format!(
        "interpreter on_telegram in-process ({} telegrams)",
        cycles * SAMPLES_PER_CYCLE
    ));
    let processing = processing::measure(&private.config, cycles * SAMPLES_PER_CYCLE)?;
    progress(&format!(
        "iceoryx2 and Unix socket hops ({} round trips each)",
        cycles * SAMPLES_PER_CYCLE
    ));
    let hops = hop::measure(&format!("{instance}hop"), cycles * SAMPLES_PER_CYCLE)?;
    let results = LatencyResults {
        pipeline,
        processing,
        hops,
    };

    let hgrm_path = std::env::current_dir()
        .map(|d| d.join(HGRM_FILE))
        .unwrap_or_else(|_| PathBuf::from(HGRM_FILE));
    let title = title(&private.config, cycles, cpus);
    let notes = notes(&results, cycles, &hgrm_path);
    std::fs::write(&hgrm_path, hgrm(&results))
        .with_context(|| format!("cannot write {}", hgrm_path.display()))?;
    print!("{}", table::render(&title, &rows(&results), &notes));
    print!("{}", profinet::report(&private.config));

    let stopped = stopped?;
    if stopped.killed || !stopped.status.success() {
        private.keep();
        eprintln!(
            "the controller did not stop cleanly ({}{}); its log: {}",
            stopped.status,
            if stopped.killed { ", killed" } else { "" },
            log_path.display()
        );
        return Ok(false);
    }
    Ok(true)
}

/// Progress goes to stderr, so that stdout holds the table alone.
fn progress(what: &str) {
    eprintln!("bench: {what}");
}

fn row_label(cycle_ms: u64, loaded: bool) -> String {
    format!("{cycle_ms} ms {}", if loaded { "load" } else { "idle" })
}

fn run_pipeline_rows(
    controller: &mut ChildController,
    config: &Config,
    cycles: usize,
    cpus: usize,
) -> anyhow::Result<Vec<PipelineResult>> {
    controller.wait_until_listening()?;
    let addr = controller.addr().to_string();
    let base = client_options(config).engine;
    let servo_period_ns = config.main.servo.period_us.max(1) * 1000;
    let mut results = Vec::new();
    for cycle_ms in CYCLE_TIMES_MS {
        for loaded in [false, true] {
            let label = row_label(cycle_ms, loaded);
            progress(&format!("{label} ({cycles} telegram cycles)"));
            let _load = loaded.then(|| CpuLoad::start(cpus)).transpose()?;
            let cycle_time = Duration::from_millis(cycle_ms);
            // Room for twice the ticks of the planned time, for restarts and slow cycles.
            let ticks = cycle_time.as_nanos() * cycles as u128 / u128::from(servo_period_ns);
            let plan = RowPlan {
                addr: &addr,
                options: plc_client::EngineOptions {
                    cycle_time,
                    ..base.clone()
                },
                robot: &config.robot,
                instance: &config.main.instance,
                cycles,
                servo_ticks: usize::try_from(ticks * 2).unwrap_or(usize::MAX).max(1000),
            };
            let timing = pipeline::run_row(&plan).with_context(|| label.clone())?;
            results.push(PipelineResult { label, timing });
        }
    }
    Ok(results)
}

fn title(config: &Config, cycles: usize, cpus: usize) -> Vec<String> {
    vec![
        format!(
            "rc bench latency: {}, servo period {} µs, {cpus} CPUs, {cycles} telegram cycles per row",
            config.robot.name, config.main.servo.period_us
        ),
        format!(
            "load rows: {cpus} busy threads at nice {} (one per CPU); idle rows: no load added",
            load::NICE
        ),
    ]
}

const PROCESSING_LABEL: &str = "interpreter on_telegram";
const ICEORYX2_LABEL: &str = "iceoryx2 hop one-way";
const UDS_LABEL: &str = "UDS hop one-way";

fn rows(results: &LatencyResults) -> Vec<Row> {
    let mut rows: Vec<Row> = results
        .pipeline
        .iter()
        .map(|r| {
            Row::Pipeline(PipelineRow {
                label: r.label.clone(),
                round_trip: r.timing.round_trip.summary(),
                overruns: r.timing.overruns,
                timeouts: r.timing.timeouts,
                servo: r.timing.servo.lateness.summary(),
                servo_overruns: r.timing.servo.overruns,
            })
        })
        .collect();
    let timing = |label: &str, unit, d: &Distribution| {
        Row::Timing(TimingRow {
            label: label.into(),
            unit,
            summary: d.summary(),
        })
    };
    let hops = &results.hops;
    rows.push(timing(
        PROCESSING_LABEL,
        Unit::Nanos,
        &results.processing.times,
    ));
    rows.push(timing(ICEORYX2_LABEL, Unit::Micros, &hops.iceoryx2));
    rows.push(timing(UDS_LABEL, Unit::Micros, &hops.unix_socket));
    rows.extend(
        RatioRow::of(
            "UDS / iceoryx2",
            hops.unix_socket.summary(),
            hops.iceoryx2.summary(),
        )
        .map(Row::Ratio),
    );
    rows
}

fn notes(results: &LatencyResults, cycles: usize, hgrm: &Path) -> Vec<String> {
    let samples = cycles * SAMPLES_PER_CYCLE;
    let mut notes = vec![
        "latency: telegram round trip, PLC send -> complete reply over the TCP gateway \
         (fieldbus -> interpreter -> fieldbus: two iceoryx2 hops)"
            .to_string(),
        format!(
            "missed cycles: overrun = PLC cycles that ended after their deadline; timeout = \
             replies later than {} ms (the session is then restarted)",
            plc_client::transport::DEFAULT_RESPONSE_TIMEOUT.as_millis()
        ),
        "servo tick lateness: feedback arrival in this process - the tick's deadline \
         (time_ns); includes one iceoryx2 hop and this process's wake-up; overrun = growth of \
         the servo's own overrun counter"
            .to_string(),
        format!(
            "{PROCESSING_LABEL}: Server::on_telegram in-process, {samples} telegrams of an \
             initialized session (ReadMessages active, {} joint moves, planner and drive \
             status updates every 1 ms), controller stopped",
            results.processing.moves
        ),
        format!(
            "hops: one-way = round trip / 2 of a 256-byte message ping-ponged between two \
             threads, {samples} round trips each, woken by events (no spinning), controller \
             stopped; ratio = UDS / iceoryx2"
        ),
    ];
    let moves: Vec<String> = results
        .pipeline
        .iter()
        .map(|r| format!("{} {}", r.label, r.timing.moves))
        .collect();
    notes.push(format!(
        "moves completed while measuring: {}",
        moves.join(", ")
    ));
    for r in &results.pipeline {
        for why in &r.timing.restarts {
            notes.push(format!("{}: PLC session restarted: {why}", r.label));
        }
        if r.timing.servo.dropped > 0 {
            notes.push(format!(
                "{}: {} servo ticks not kept (more than expected)",
                r.label, r.timing.servo.dropped
            ));
        }
    }
    notes.push(format!("percentile distributions: {}", hgrm.display()));
    notes
}

/// The `.hgrm` text: one section per distribution.
fn hgrm(results: &LatencyResults) -> String {
    let mut text = String::new();
    for r in &results.pipeline {
        r.timing
            .round_trip
            .write_hgrm(&format!("telegram round trip, {}", r.label), &mut text);
        r.timing.servo.lateness.write_hgrm(
            &format!("servo tick lateness (incl. one iceoryx2 hop), {}", r.label),
            &mut text,
        );
    }
    results
        .processing
        .times
        .write_hgrm(PROCESSING_LABEL, &mut text);
    results.hops.iceoryx2.write_hgrm(ICEORYX2_LABEL, &mut text);
    results.hops.unix_socket.write_hgrm(UDS_LABEL, &mut text);
    text
}
