//! Errors of the orchestrator.

use std::io;
use std::path::PathBuf;

use shared_types::bus::BusError;
use shared_types::health::Service;

/// Why the orchestrator stopped the controller with an error.
#[derive(Debug, thiserror::Error)]
pub enum OrchestratorError {
    #[error(transparent)]
    Bus(#[from] BusError),
    #[error("cannot locate the rc executable to spawn the services: {0}")]
    CurrentExe(io::Error),
    #[error("cannot watch service {service}: {source}")]
    Wait { service: Service, source: io::Error },
    #[error("cannot write pid file {}: {source}", path.display())]
    PidFile { path: PathBuf, source: io::Error },
    #[error("services did not stop cleanly: {0}")]
    UncleanStop(String),
}
