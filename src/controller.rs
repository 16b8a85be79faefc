//! A controller (`rc run`) started as a child process of this one, for `rc demo` and
//! `rc bench`, and the PLC settings that match its configuration.

use std::net::{SocketAddr, TcpStream};
use std::process::{Child, Command, Stdio};
use std::thread;
use std::time::{Duration, Instant};

use anyhow::{Context, bail};
use orchestrator::{Service, child_process};
use plc_client::ClientOptions;
use shared_types::config::Config;

/// How long the controller may take until its fieldbus port accepts connections.
const START_TIMEOUT: Duration = Duration::from_secs(10);

/// A running `rc run` child; stopped (SIGTERM, then SIGKILL) at the latest when dropped.
pub struct ChildController {
    child: Child,
    addr: SocketAddr,
    stop_timeout: Duration,
}

impl ChildController {
    /// Spawns `rc run` with `config`, its logs filtered to warnings (unless `RUST_LOG` says
    /// otherwise) and written to `stderr`. Fails if the fieldbus address is already in use.
    pub fn start(config: &Config, stderr: Stdio) -> anyhow::Result<Self> {
        let addr: SocketAddr = config
            .main
            .fieldbus
            .listen
            .parse()
            .with_context(|| format!("fieldbus.listen = {}", config.main.fieldbus.listen))?;
        if TcpStream::connect_timeout(&addr, Duration::from_millis(200)).is_ok() {
            bail!(
                "{addr} is already in use (a controller running?); stop it, or give a \
                 --config with another fieldbus.listen"
            );
        }
        let exe = std::env::current_exe().context("cannot locate the rc executable")?;
        let mut command = Command::new(exe);
        command.arg("run");
        if let Some(path) = &config.path {
            command.arg("--config").arg(path);
        }
        if std::env::var_os("RUST_LOG").is_none() {
            command.env("RUST_LOG", "warn");
        }
        command
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(stderr);
        child_process::die_with_parent(&mut command);
        let child = command.spawn().context("cannot start the controller")?;
        // The orchestrator stops its services one after the other, each within the timeout.
        let per_service = Duration::from_millis(config.main.orchestrator.shutdown_timeout_ms);
        let stop_timeout = per_service * Service::START_ORDER.len() as u32 + Duration::from_secs(2);
        Ok(Self {
            child,
            addr,
            stop_timeout,
        })
    }

    /// The controller's process id.
    pub fn id(&self) -> u32 {
        self.child.id()
    }

    /// The fieldbus (TCP gateway) address.
    pub fn addr(&self) -> SocketAddr {
        self.addr
    }

    /// How long [`Self::stop`] waits before it kills.
    pub fn stop_timeout(&self) -> Duration {
        self.stop_timeout
    }

    /// Waits until the fieldbus port accepts connections.
    pub fn wait_until_listening(&mut self) -> anyhow::Result<()> {
        let deadline = Instant::now() + START_TIMEOUT;
        loop {
            if let Some(status) = self.child.try_wait()? {
                bail!("the controller exited during start-up ({status})");
            }
            if TcpStream::connect_timeout(&self.addr, Duration::from_millis(100)).is_ok() {
                return Ok(());
            }
            if Instant::now() >= deadline {
                bail!(
                    "the controller did not accept connections on {} within {} s",
                    self.addr,
                    START_TIMEOUT.as_secs()
                );
            }
            thread::sleep(Duration::from_millis(50));
        }
    }

    /// SIGTERMs the controller and waits for it (killing it after the stop timeout).
    pub fn stop(&mut self) -> anyhow::Result<child_process::Stopped> {
        child_process::terminate(&self.child);
        child_process::stop(&mut self.child, self.stop_timeout)
            .context("cannot stop the controller")
    }
}

impl Drop for ChildController {
    fn drop(&mut self) {
        if matches!(self.child.try_wait(), Ok(None)) {
            // Leaving anyway (an error on the way): nothing to report the outcome to.
            let _ = self.stop();
        }
    }
}

/// The PLC's settings matching the controller's configuration.
pub fn client_options(config: &Config) -> ClientOptions {
    let fieldbus = &config.main.fieldbus;
    let mut options = ClientOptions::default();
    options.engine.length_plc_to_rob = usize::from(fieldbus.telegram_length_plc_to_rob);
    options.engine.length_rob_to_plc = usize::from(fieldbus.telegram_length_rob_to_plc);
    options
}
