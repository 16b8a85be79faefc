//! The PLC side of SRCI: a client that plays the PLC (SRCI client and cycle master) against
//! the controller over the TCP gateway transport. Used by `rc plc <program>`, `rc demo`, the
//! system tests and the benchmarks.
//!
//! - [`engine::RobotTask`]: the pure cycle engine (SEQ/ACK, fragments, Active Command
//!   Register, lifesign, start-up chain), modelled on the open Python client.
//! - [`transport::TcpTransport`]: raw telegrams in lockstep with a 100 ms reply timeout.
//! - [`cycle::CycleRunner`]: runs the engine at a fixed period over a transport.
//! - [`program::Program`] and [`run_program`]: TOML programs of SRCI calls and their
//!   [`report::Report`].

mod acr;
pub mod cycle;
pub mod engine;
mod executor;
pub mod program;
pub mod report;
pub mod request;
pub mod response;
pub mod table_step;
pub mod target;
#[cfg(test)]
mod testing;
pub mod transport;

use std::time::Duration;

pub use acr::CommandHandle;
pub use cycle::CycleRunner;
pub use engine::{
    CommandStatus, CycleError, CyclicSelection, EngineFault, EngineOptions, OptionsError, Phase,
    RobotTask, SubmitError, telegram_state_name,
};
pub use executor::ProgressEvent;
pub use program::{Program, ProgramError};
pub use report::{Report, StepReport};
pub use request::{
    DefaultDynamics, FrameData, GroupJog, LoadData, MoveAxesAbsolute, MoveDirectAbsolute,
    ReferenceDynamics, Request, SwLimits, Timestamp, ToolData,
};
pub use target::{Deviation, Target, Tolerance};
pub use transport::{TcpTransport, Transport, TransportError};

/// The built-in demo program (`rc demo`).
pub const DEMO_PROGRAM: &str = include_str!("../programs/demo.toml");

/// Settings of a client session.
#[derive(Debug, Clone, PartialEq)]
pub struct ClientOptions {
    pub engine: EngineOptions,
    pub connect_timeout: Duration,
    /// A reply later than this closes the connection.
    pub response_timeout: Duration,
    /// From the first telegram to the end of the start-up chain.
    pub handshake_timeout: Duration,
    /// Per command, from submission to its final state (a step's `timeout_ms` overrides it).
    pub command_timeout: Duration,
    /// Largest deviation between a DONE move's target and the position read back after it.
    pub position_tolerance: Tolerance,
}

impl Default for ClientOptions {
    fn default() -> Self {
        Self {
            engine: EngineOptions::default(),
            connect_timeout: Duration::from_secs(2),
            response_timeout: transport::DEFAULT_RESPONSE_TIMEOUT,
            handshake_timeout: Duration::from_secs(10),
            command_timeout: Duration::from_secs(30),
            position_tolerance: Tolerance { deg: 0.05, mm: 0.1 },
        }
    }
}

/// A failed client session.
#[derive(Debug, thiserror::Error)]
pub enum ClientError {
    #[error(transparent)]
    Options(#[from] OptionsError),
    #[error(transparent)]
    Transport(#[from] TransportError),
    #[error(transparent)]
    Cycle(#[from] CycleError),
    #[error(transparent)]
    Submit(#[from] SubmitError),
    #[error("RobotTask fault: {0}")]
    Fault(EngineFault),
    #[error("no result within {0:?}")]
    Timeout(Duration),
    #[error(
        "SRCI start-up failed after {elapsed:?} ({}): robot TelegramState {telegram_state} ({}){}",
        phase.describe(),
        telegram_state_name(*telegram_state),
        fault.map(|f| format!(": {f}")).unwrap_or_default()
    )]
    Handshake {
        telegram_state: u8,
        phase: Phase,
        fault: Option<EngineFault>,
        elapsed: Duration,
    },
    /// The program stopped early; the report holds the steps up to then.
    #[error("program stopped: {cause}")]
    Interrupted {
        report: Box<Report>,
        cause: Box<ClientError>,
    },
}

/// Connects to the controller at `addr`, runs the SRCI start-up and then `program`, and
/// reports every step. The robot is left as the program leaves it (no disable at the end).
pub fn run_program(
    addr: &str,
    program: &Program,
    options: &ClientOptions,
    progress: &mut dyn FnMut(&ProgressEvent),
) -> Result<Report, ClientError> {
    let transport = TcpTransport::connect(addr, options.connect_timeout, options.response_timeout)?;
    run_program_over(transport, program, options, progress)
}

/// [`run_program`] over any transport.
pub fn run_program_over<T: Transport>(
    transport: T,
    program: &Program,
    options: &ClientOptions,
    progress: &mut dyn FnMut(&ProgressEvent),
) -> Result<Report, ClientError> {
    let mut runner = CycleRunner::new(RobotTask::new(options.engine.clone())?, transport);
    let handshake = start_up(&mut runner, options.handshake_timeout)?;
    progress(&ProgressEvent::Initialized {
        handshake,
        manufacturer: runner
            .task()
            .robot_data()
            .map(|d| d.manufacturer.clone())
            .unwrap_or_default(),
    });
    let (steps, messages, error) = executor::execute(
        &mut runner,
        program,
        options.command_timeout,
        options.position_tolerance,
        progress,
    );
    let task = runner.task();
    let report = Report {
        program: program.name.clone(),
        handshake,
        steps,
        round_trips: runner.transport().round_trips(),
        cycles: task.cycles(),
        overruns: runner.overruns(),
        invalid_frames: task.invalid_frames(),
        messages,
        robot: task.robot_data().cloned(),
    };
    match error {
        None => Ok(report),
        Some(cause) => Err(ClientError::Interrupted {
            report: Box::new(report),
            cause: Box::new(cause),
        }),
    }
}

/// Runs cycles until the interface is initialized; returns how long that took.
pub fn start_up<T: Transport>(
    runner: &mut CycleRunner<T>,
    timeout: Duration,
) -> Result<Duration, ClientError> {
    let start = runner.elapsed();
    match runner.run_until(|t| t.initialized(), timeout) {
        Ok(()) => Ok(runner
            .task()
            .initialized_at()
            .unwrap_or_else(|| runner.elapsed())
            .saturating_sub(start)),
        Err(ClientError::Timeout(_) | ClientError::Fault(_)) => {
            let task = runner.task();
            Err(ClientError::Handshake {
                telegram_state: task.telegram_state(),
                phase: task.faulted_in().unwrap_or(task.phase()),
                fault: task.fault(),
                elapsed: runner.elapsed().saturating_sub(start),
            })
        }
        Err(e) => Err(e),
    }
}
