//! `rc`: the SRCI robot controller. One executable, several processes:
//! - `rc run` starts the orchestrator, which spawns and supervises the services;
//! - `rc service <name>` is one service process (spawned by `rc run`, or by systemd);
//! - `rc restart <name>` replaces one service process of a running controller;
//! - `rc status` shows a running controller's services, their cycles and supervision;
//! - `rc plc PROGRAM.toml` plays the PLC: runs an SRCI program against a running controller;
//! - `rc demo` starts a controller, runs the embedded demo program against it and stops it;
//! - `rc bench latency` measures the controller's latencies on this machine;
//! - `rc bench motion` measures the planner's computing times and move durations.

mod bench;
mod controller;
mod demo;
mod plc;
mod plot;
mod status;

use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use anyhow::Context;
use clap::builder::{PossibleValuesParser, TypedValueParser};
use clap::{Parser, Subcommand};
use orchestrator::Service;
use shared_types::config::Config;
use shared_types::realtime::{self, SchedulingPlan};
use shared_types::supervision;
use tracing_subscriber::EnvFilter;

/// Exit code for a configuration that cannot be loaded.
const EXIT_CONFIG: u8 = 2;

#[derive(Debug, Parser)]
#[command(name = "rc", version, about = "SRCI robot controller")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Runs the controller: the orchestrator and every service process.
    Run {
        /// Configuration file (default: the embedded config/default.toml).
        #[arg(long, value_name = "FILE")]
        config: Option<PathBuf>,
    },
    /// Runs one service process (normally spawned by `rc run`).
    Service {
        #[arg(value_parser = service_parser())]
        service: Service,
        /// Configuration file (default: the embedded config/default.toml).
        #[arg(long, value_name = "FILE")]
        config: Option<PathBuf>,
    },
    /// Plays the PLC: runs an SRCI program against a running controller.
    Plc {
        /// The program (TOML): `[[step]]`s of SRCI calls, any request of the specification
        /// by its table's field names (README.md, "Driving it"; examples in
        /// plc-client/programs/).
        program: PathBuf,
        /// Address of the controller's TCP gateway transport.
        #[arg(long, default_value = "127.0.0.1:5000")]
        addr: String,
        /// Telegram cycle time.
        #[arg(long, default_value_t = 8)]
        cycle_ms: u64,
        /// Lifesign timeout the PLC sets with ExchangeConfiguration.
        #[arg(long, default_value_t = 50)]
        lifesign_ms: u16,
        /// The controller's configuration, for --plot: its instance and robot (default: the
        /// embedded config/default.toml).
        #[arg(long, value_name = "FILE")]
        config: Option<PathBuf>,
        /// Records the run and writes its motion plot (SVG) to FILE when it ends.
        #[arg(long, value_name = "FILE.svg")]
        plot: Option<PathBuf>,
    },
    /// Starts a controller, runs the demo program against it, prints a summary and stops it.
    Demo {
        /// Configuration file for the controller (default: the embedded config/default.toml).
        #[arg(long, value_name = "FILE")]
        config: Option<PathBuf>,
        /// Records the run and writes its motion plot (SVG) to FILE when it ends.
        #[arg(long, value_name = "FILE.svg")]
        plot: Option<PathBuf>,
    },
    /// Replaces one service process of the running controller now (a planned restart:
    /// SIGTERM, a new process once the old one is gone) and prints the new pid. The other
    /// services keep running; not counted against the restart limit.
    Restart {
        #[arg(value_parser = service_parser())]
        service: Service,
        /// The controller's configuration (default: the embedded config/default.toml).
        #[arg(long, value_name = "FILE")]
        config: Option<PathBuf>,
    },
    /// Shows a running controller: pid, uptime, restarts and cycle statistics of each
    /// service, the supervision state, and a one-second sample of the servo tick and the
    /// planner.
    Status {
        /// The controller's configuration (default: the embedded config/default.toml).
        #[arg(long, value_name = "FILE")]
        config: Option<PathBuf>,
    },
    /// Measures the controller on this machine (starts and stops one of its own).
    Bench {
        #[command(subcommand)]
        benchmark: bench::Benchmark,
    },
}

fn service_parser() -> impl TypedValueParser<Value = Service> {
    PossibleValuesParser::new(Service::START_ORDER.map(Service::name))
        .try_map(|name| name.parse::<Service>())
}

/// Set by SIGINT, SIGTERM and SIGHUP; every long-running subcommand watches it.
static SHUTDOWN: AtomicBool = AtomicBool::new(false);

fn main() -> ExitCode {
    let cli = Cli::parse();
    let outcome = match cli.command {
        Command::Run { config } => {
            init_logging("info");
            with_config(config.as_deref(), |config| {
                install_shutdown_handler()?;
                orchestrator::run(config, &SHUTDOWN)?;
                Ok(true)
            })
        }
        Command::Service { service, config } => {
            init_logging("info");
            with_config(config.as_deref(), |config| {
                install_shutdown_handler()?;
                run_service(service, config)?;
                Ok(true)
            })
        }
        Command::Plc {
            program,
            addr,
            cycle_ms,
            lifesign_ms,
            config,
            plot: svg_path,
        } => {
            init_logging("warn");
            let cycle_time = Duration::from_millis(cycle_ms);
            with_config(config.as_deref(), |config| {
                let Some(svg_path) = svg_path else {
                    return plc::run_file(&program, &addr, cycle_time, lifesign_ms);
                };
                install_shutdown_handler()?;
                // Loaded here for the plot's title (and to fail before recording); the run
                // loads it again, as without --plot.
                let name = plc_client::Program::load(&program)?.name;
                let request = plot::PlotRequest {
                    path: &svg_path,
                    command: "rc plc",
                    program: &name,
                };
                plot::run_recorded(config, request, &SHUTDOWN, move || {
                    plc::run_file(&program, &addr, cycle_time, lifesign_ms)
                })
            })
        }
        Command::Demo {
            config,
            plot: svg_path,
        } => {
            init_logging("warn");
            with_config(config.as_deref(), |config| {
                if svg_path.is_some() {
                    install_shutdown_handler()?;
                }
                demo::run(config, svg_path.as_deref(), &SHUTDOWN)
            })
        }
        Command::Restart { service, config } => {
            init_logging("warn");
            with_config(config.as_deref(), |config| restart(service, config))
        }
        Command::Status { config } => {
            init_logging("warn");
            with_config(config.as_deref(), status::run)
        }
        Command::Bench {
            benchmark: bench::Benchmark::Latency { cycles, config },
        } => {
            init_logging("warn");
            with_config(config.as_deref(), |config| bench::latency(config, cycles))
        }
        Command::Bench {
            benchmark: bench::Benchmark::Motion { options, config },
        } => {
            init_logging("warn");
            with_config(config.as_deref(), |config| {
                bench::motion::run(config, &options)
            })
        }
    };
    match outcome {
        Ok(Ok(true)) => ExitCode::SUCCESS,
        Ok(Ok(false)) => ExitCode::FAILURE,
        Ok(Err(e)) => {
            eprintln!("error: {}", describe(&e));
            ExitCode::FAILURE
        }
        Err(config_error) => {
            eprintln!("error: {config_error}");
            ExitCode::from(EXIT_CONFIG)
        }
    }
}

/// Loads the configuration and runs `body` with it. The outer error is the configuration's
/// (exit code 2), the inner result the body's (`Ok(false)`: completed but failed).
fn with_config(
    path: Option<&Path>,
    body: impl FnOnce(&Config) -> anyhow::Result<bool>,
) -> Result<anyhow::Result<bool>, shared_types::config::ConfigError> {
    Config::load(path).map(|config| body(&config))
}

fn run_service(service: Service, config: &Config) -> anyhow::Result<()> {
    // Started before the real-time settings, as threads inherit them: the watchdog thread
    // must keep normal scheduling and may run on any CPU.
    let _watchdog = supervision::Watchdog::start()?;
    let rt = &config.main.realtime;
    let scheduling = match service {
        Service::Fieldbus => &rt.fieldbus,
        Service::Interpreter => &rt.interpreter,
        Service::Planner => &rt.planner,
        Service::Servo => &rt.servo,
    };
    realtime::apply(service.name(), &SchedulingPlan::from_settings(scheduling))?;
    match service {
        Service::Fieldbus => fieldbus::run(config, &SHUTDOWN)?,
        Service::Interpreter => interpreter::run(config, &SHUTDOWN)?,
        Service::Planner => planner::run(config, &SHUTDOWN)?,
        Service::Servo => servo::run(config, &SHUTDOWN)?,
    }
    Ok(())
}

/// `rc restart`: asks the running orchestrator for a planned restart of `service`.
fn restart(service: Service, config: &Config) -> anyhow::Result<bool> {
    let o = &config.main.orchestrator;
    // The old process's grace period, the new one's start, and some slack.
    let timeout =
        Duration::from_millis(o.shutdown_timeout_ms + o.start_timeout_ms) + Duration::from_secs(2);
    let restarted = orchestrator::control::restart(&config.main.instance, service, timeout)?;
    println!(
        "{service} restarted: pid {} -> {}",
        restarted.old_pid, restarted.new_pid
    );
    Ok(true)
}

/// The error and its causes on one line. Causes whose text the message already includes (as
/// many error types print their source) are not repeated.
fn describe(error: &anyhow::Error) -> String {
    error
        .chain()
        .skip(1)
        .fold(error.to_string(), |mut text, cause| {
            let cause = cause.to_string();
            if !text.contains(&cause) {
                text.push_str(": ");
                text.push_str(&cause);
            }
            text
        })
}

/// Logs to stderr, filtered by `RUST_LOG` (else `default_level`). iceoryx2 logs on its own
/// console only errors unless `IOX2_LOG_LEVEL` says otherwise: its start-up notes (e.g. that it
/// uses its built-in configuration) would repeat in every process.
fn init_logging(default_level: &str) {
    iceoryx2::prelude::set_log_level_from_env_or(iceoryx2::prelude::LogLevel::Error);
    let filter =
        EnvFilter::try_from_default_env().unwrap_or_else(|_| EnvFilter::new(default_level));
    tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr)
        .with_ansi(std::io::stderr().is_terminal())
        .init();
}

fn install_shutdown_handler() -> anyhow::Result<()> {
    ctrlc::set_handler(|| SHUTDOWN.store(true, Ordering::Relaxed))
        .context("cannot install the SIGINT/SIGTERM/SIGHUP handler")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn describe_does_not_repeat_causes_the_message_contains() {
        let io = std::io::Error::other("connection refused");
        let error = anyhow::Error::new(io).context("cannot connect: connection refused");
        assert_eq!(describe(&error), "cannot connect: connection refused");
        let error = anyhow::anyhow!("connection refused").context("program 'demo'");
        assert_eq!(describe(&error), "program 'demo': connection refused");
    }
}
