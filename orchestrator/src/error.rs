//! Errors of the orchestrator.

use std::io;
use std::path::PathBuf;
use std::process::ExitStatus;

use shared_types::bus::BusError;

use crate::service::Service;

/// Why the orchestrator stopped the controller with an error.
#[derive(Debug, thiserror::Error)]
pub enum OrchestratorError {
    #[error(transparent)]
    Bus(#[from] BusError),
    #[error("cannot locate the rc executable to spawn the services: {0}")]
    CurrentExe(io::Error),
    #[error("cannot spawn service {service}: {source}")]
    Spawn { service: Service, source: io::Error },
    #[error("cannot watch service {service}: {source}")]
    Wait { service: Service, source: io::Error },
    #[error("cannot write pid file {}: {source}", path.display())]
    PidFile { path: PathBuf, source: io::Error },
    #[error(
        "service {service} exited ({status}); {restarts} restarts within {window_s} s exceed \
         orchestrator.max_restarts = {max_restarts}"
    )]
    RestartIntensity {
        service: Service,
        status: ExitStatus,
        restarts: u32,
        max_restarts: u32,
        window_s: u64,
    },
    #[error("services did not stop cleanly: {0}")]
    UncleanStop(String),
}
