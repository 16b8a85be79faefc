//! `--plot FILE.svg` of `rc plc` and `rc demo`: record while the PLC program runs, and write
//! the plot when it ends, also when Ctrl-C (or SIGTERM) ends it early.

use std::fs::File;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::thread;
use std::time::Duration;

use anyhow::{Context, anyhow};
use interpreter::messages::{MessageText, MessageType};
use interpreter::server_log::LogLine;
use shared_types::config::Config;
use shared_types::time::unix_ms;

use super::recorder::{Recorded, Recorder};
use super::svg::{self, PlotLabels};

/// How often the run and the shutdown flag are looked at.
const WATCH_PERIOD: Duration = Duration::from_millis(20);

/// The plot could not be written.
#[derive(Debug, thiserror::Error)]
#[error("cannot write the plot {}: {source}", path.display())]
pub struct PlotFileError {
    pub path: PathBuf,
    pub source: std::io::Error,
}

/// What the plot is of.
#[derive(Debug, Clone, Copy)]
pub struct PlotRequest<'a> {
    /// The SVG file to write.
    pub path: &'a Path,
    /// The command that ran (`rc plc`, `rc demo`) and the program's name, for the title.
    pub command: &'a str,
    pub program: &'a str,
}

/// Runs `run` (the PLC program; `Ok(true)` if it passed) while recording the controller of
/// `config`, then writes the plot. When `shutdown` is set first, the plot is written at once
/// and the run, left behind, ends with the process.
pub fn run_recorded(
    config: &Config,
    request: PlotRequest<'_>,
    shutdown: &AtomicBool,
    run: impl FnOnce() -> anyhow::Result<bool> + Send + 'static,
) -> anyhow::Result<bool> {
    // Created now, so that an unwritable path fails before the run rather than after it.
    let file = File::create(request.path).map_err(|source| PlotFileError {
        path: request.path.to_path_buf(),
        source,
    })?;
    let started_unix_ms = unix_ms();
    let recorder = Recorder::start(config).context("cannot record the run for the plot")?;
    let worker = thread::Builder::new()
        .name("plc-program".into())
        .spawn(run)
        .context("cannot start the PLC program thread")?;
    let outcome = loop {
        if worker.is_finished() {
            break worker
                .join()
                .unwrap_or_else(|_| Err(anyhow!("the PLC program thread panicked")));
        }
        if shutdown.load(Ordering::Relaxed) {
            break Err(anyhow!("interrupted"));
        }
        thread::sleep(WATCH_PERIOD);
    };
    let written = recorder
        .finish()
        .context("the plot's recording failed")
        .and_then(|recorded| {
            write(file, request, config, started_unix_ms, &recorded)?;
            Ok(recorded)
        });
    match (outcome, written) {
        (outcome, Ok(recorded)) => {
            if recorded.counts.feedback_samples == 0 {
                tracing::warn!(
                    "no servo feedback of controller instance '{}' arrived: is --config the \
                     running controller's?",
                    config.main.instance
                );
            }
            println!(
                "plot written to {} ({} samples)",
                request.path.display(),
                recorded.recording.samples().len()
            );
            outcome
        }
        (Ok(_), Err(e)) => Err(e),
        (Err(e), Err(plot)) => {
            eprintln!("error: {plot:#}");
            Err(e)
        }
    }
}

fn write(
    mut file: File,
    request: PlotRequest<'_>,
    config: &Config,
    started_unix_ms: u64,
    recorded: &Recorded,
) -> Result<(), PlotFileError> {
    let title = format!(
        "{} {}: {}, {} UTC",
        request.command,
        request.program,
        config.robot.name,
        utc_date_time(started_unix_ms)
    );
    let caption = caption(recorded);
    let svg = svg::render(
        &recorded.recording,
        &PlotLabels {
            title: &title,
            caption: &caption,
            velocity_limits_deg_s: config.robot.joints.max_velocity_deg_s,
        },
    );
    file.write_all(svg.as_bytes())
        .and_then(|()| file.sync_all())
        .map_err(|source| PlotFileError {
            path: request.path.to_path_buf(),
            source,
        })
}

/// Where the data came from and how much of it there is.
fn caption(recorded: &Recorded) -> Vec<String> {
    let r = &recorded.recording;
    let thinning = if r.interval_s() > 0.0 {
        format!(
            "decimated to one sample per {:.0} ms to fit memory",
            r.interval_s() * 1e3
        )
    } else {
        "every tick kept".to_string()
    };
    let mut lines = vec![
        "Positions and velocities: actual joints of servo/feedback. TCP speed: Jacobian of \
         those, with the tool of the active move (flange before the first). Override, \
         interruptions and job markers: motion/status."
            .to_string(),
        format!(
            "{} feedback samples, {} ticks not received; {} kept ({thinning}); traces thinned \
             to the first, lowest, highest and last point per pixel column.",
            recorded.counts.feedback_samples,
            recorded.counts.missed_ticks,
            r.samples().len()
        ),
    ];
    if r.dropped_markers() > 0 {
        lines.push(format!("{} job markers not shown.", r.dropped_markers()));
    }
    lines
}

/// `YYYY-MM-DD hh:mm:ss` of a UNIX time in ms, UTC.
fn utc_date_time(unix_ms: u64) -> String {
    // The server log's line format begins with exactly this; reusing it keeps one calendar
    // conversion in the code base.
    let line = LogLine {
        unix_ms,
        kind: MessageType::Controller,
        severity: 0,
        code: 0,
        text: MessageText::new(""),
    };
    let mut buf = [0u8; 64];
    let len = line.format(&mut buf);
    let text = String::from_utf8_lossy(&buf[..len]);
    text.get(..19).unwrap_or(&text).to_string()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_date_is_utc() {
        assert_eq!(utc_date_time(0), "1970-01-01 00:00:00");
        // 2026-11-22 04:40:12.345 UTC
        assert_eq!(utc_date_time(1_795_322_412_345), "2026-11-22 04:40:12");
    }
}
