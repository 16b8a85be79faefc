//! The orchestrator: creates the controller's iceoryx2 services, spawns the service processes
//! (`rc service <name>`) and supervises them.
//!
//! [`run`] is the body of `rc run`. It
//! - removes the iceoryx2 resources of processes that died earlier without cleaning up, then
//!   creates every service with its full QoS and holds it for the controller's lifetime;
//! - spawns servo, planner, interpreter and fieldbus in that order, each once the one before
//!   it has subscribed to its input topic (see `readiness`), as a child process that
//!   receives `SIGTERM` if the orchestrator dies, with its output relayed to stderr as
//!   `[<service>] line`;
//! - restarts a service that exits (one-for-one) until more than
//!   `orchestrator.max_restarts` restarts happen within `orchestrator.restart_window_s`;
//! - on shutdown stops the services in reverse order (`SIGTERM`, then `SIGKILL` after
//!   `orchestrator.shutdown_timeout_ms`) and leaves no shared memory behind.
//!
//! # Finding the service processes
//! Every spawn is logged at info level as `spawned <service> pid=<pid>`, and the pid file
//! `<runtime dir>/<instance>.pids` (runtime dir = `$XDG_RUNTIME_DIR`, else `/tmp`; see
//! [`pid_file`]) lists the running services as `<service> <pid>` lines. It is rewritten after
//! every (re)spawn and removed on shutdown.

pub mod child_process;
mod error;
pub mod pid_file;
mod process;
mod readiness;
mod restart;
mod service;
mod supervisor;

use std::process::Command;
use std::sync::atomic::AtomicBool;
use std::time::Duration;

use shared_types::bus::Bus;
use shared_types::config::Config;
use tracing::info;

pub use error::OrchestratorError;
pub use restart::{RestartDecision, RestartPolicy};
pub use service::{Service, UnknownService};

use readiness::ReadinessProbe;
use supervisor::Supervisor;

/// How long a service may take to subscribe to its input topic before the next one is started
/// anyway (see [`readiness`]).
const START_TIMEOUT: Duration = Duration::from_secs(10);

/// Runs the controller until `shutdown` becomes true (`Ok`) or supervision fails (restart
/// intensity exceeded, a service cannot be spawned, a service did not stop cleanly).
pub fn run(config: &Config, shutdown: &AtomicBool) -> Result<(), OrchestratorError> {
    let instance = &config.main.instance;
    let bus = Bus::new(instance, "orchestrator")?;
    let removed = bus.remove_dead_nodes();
    if removed > 0 {
        info!("removed {removed} dead iceoryx2 node(s) left by an earlier run");
    }
    let services = bus.create_all()?;
    let probe = ReadinessProbe::new(&bus)?;
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
        &bus,
        &config.main.orchestrator,
        pid_file::pid_file_path(instance),
        launcher,
        |service| probe.is_ready(service),
        START_TIMEOUT,
    )
    .run(shutdown);
    // The services go before the node that opened them; both remove their shared memory.
    drop(probe);
    drop(services);
    drop(bus);
    info!("controller '{instance}' stopped");
    result
}
