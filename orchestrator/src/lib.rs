//! The orchestrator: creates the controller's iceoryx2 services, spawns the service processes
//! (`rc service <name>`) and supervises them.
//!
//! [`run`] is the body of `rc run`. It
//! - removes the iceoryx2 resources of processes that died earlier without cleaning up, then
//!   creates every service with its full QoS and holds it for the controller's lifetime;
//! - spawns servo, planner, interpreter and fieldbus in that order, each once the one before
//!   it sends heartbeats on its health topic (it creates its health reporter after its other
//!   ports, so it has subscribed to its input topic by then), as a child process that
//!   receives `SIGTERM` if the orchestrator dies, with its output relayed to stderr as
//!   `[<service>] line`;
//! - kills (SIGKILL) a service whose heartbeat stands still for
//!   `orchestrator.heartbeat_timeout_ms`, or that sends none within
//!   `orchestrator.start_timeout_ms`, and handles it like one that exited;
//! - restarts a failed service as its `orchestrator.strategy` says (one_for_one or
//!   rest_for_one) until more than `orchestrator.max_restarts` failures happen within
//!   `orchestrator.restart_window_s`; then it holds the arm in a safe stop: the failed
//!   service is not restarted, the others keep running, and the supervision status names it;
//! - carries out planned restarts (`rc restart <service>`) and resets (GroupReset) requested
//!   on the control topic, and publishes the supervision status (see
//!   [`shared_types::health`] for the payloads and the protocol);
//! - on shutdown stops the services in reverse order (`SIGTERM`, then `SIGKILL` after
//!   `orchestrator.shutdown_timeout_ms`) and leaves no shared memory behind.
//!
//! The decisions are made by the pure `lifecycle` module; `supervisor` is the shell around it.
//!
//! # Finding the service processes
//! Every spawn is logged at info level as `spawned <service> pid=<pid>`, and the pid file
//! `<runtime dir>/<instance>.pids` (runtime dir = `$XDG_RUNTIME_DIR`, else `/tmp`; see
//! [`pid_file`]) lists the running services as `<service> <pid> <restarts>` lines. It is
//! rewritten after every spawn and exit and removed on shutdown.

pub mod child_process;
pub mod control;
mod error;
mod lifecycle;
mod link;
pub mod pid_file;
mod process;
mod restart;
mod supervisor;

use std::process::Command;
use std::sync::atomic::AtomicBool;

use shared_types::bus::Bus;
use shared_types::config::Config;
use tracing::info;

pub use error::OrchestratorError;
pub use restart::{RestartDecision, RestartPolicy};
pub use shared_types::health::{Service, UnknownService};

use link::BusLink;
use supervisor::Supervisor;

/// Runs the controller until `shutdown` becomes true (`Ok`) or supervision fails (a service
/// cannot be watched, the bus fails, a service did not stop cleanly). A service that fails
/// too often does not end it: see [`shared_types::health`] for the safe stop.
pub fn run(config: &Config, shutdown: &AtomicBool) -> Result<(), OrchestratorError> {
    let instance = &config.main.instance;
    let bus = Bus::new(instance, "orchestrator")?;
    let removed = bus.remove_dead_nodes();
    if removed > 0 {
        info!("removed {removed} dead iceoryx2 node(s) left by an earlier run");
    }
    let services = bus.create_all()?;
    let link = BusLink::open(&bus)?;
    let exe = std::env::current_exe().map_err(OrchestratorError::CurrentExe)?;
    let launcher = |service: Service| {
        let mut command = Command::new(&exe);
        command.arg("service").arg(service.name());
        if let Some(path) = &config.path {
            command.arg("--config").arg(path);
        }
        command
    };
    info!("controller '{instance}' starting ({})", config.source);
    let result = Supervisor::new(
        &config.main.orchestrator,
        pid_file::pid_file_path(instance),
        launcher,
        link,
    )
    .run(shutdown);
    // The ports and services go before the node that opened them; all remove their shared
    // memory.
    drop(services);
    drop(bus);
    info!("controller '{instance}' stopped");
    result
}
