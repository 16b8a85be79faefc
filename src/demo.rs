//! `rc demo`: start a controller, run the embedded demo program against it, stop it.

use std::net::{SocketAddr, TcpStream};
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::thread;
use std::time::{Duration, Instant};

use anyhow::{Context, bail};
use orchestrator::{Service, child_process};
use plc_client::{ClientOptions, DEMO_PROGRAM, Program};
use shared_types::config::Config;

/// How long the controller may take until its fieldbus port accepts connections.
const START_TIMEOUT: Duration = Duration::from_secs(10);

/// Runs the demo; `Ok(true)` if the program succeeded and the controller stopped cleanly.
pub fn run(config: &Config) -> anyhow::Result<bool> {
    let program = Program::parse(DEMO_PROGRAM, "<embedded demo program>")?;
    let addr: SocketAddr = config
        .main
        .fieldbus
        .listen
        .parse()
        .with_context(|| format!("fieldbus.listen = {}", config.main.fieldbus.listen))?;
    if TcpStream::connect_timeout(&addr, Duration::from_millis(200)).is_ok() {
        bail!(
            "{addr} is already in use (a controller running?); stop it, or give the demo a \
             --config with another fieldbus.listen"
        );
    }

    let mut controller = start_controller(config.path.as_deref())?;
    println!(
        "controller started (pid {}), waiting for {addr}",
        controller.id()
    );
    let program_succeeded = wait_until_listening(&mut controller, addr).and_then(|()| {
        println!("controller ready; running the demo program\n");
        crate::plc::execute(&addr.to_string(), &program, &client_options(config))
    });
    let stopped_cleanly = stop_controller(&mut controller, config);
    Ok(program_succeeded? && stopped_cleanly?)
}

/// The PLC's settings matching the controller's configuration.
fn client_options(config: &Config) -> ClientOptions {
    let fieldbus = &config.main.fieldbus;
    let mut options = ClientOptions::default();
    options.engine.length_plc_to_rob = usize::from(fieldbus.telegram_length_plc_to_rob);
    options.engine.length_rob_to_plc = usize::from(fieldbus.telegram_length_rob_to_plc);
    options
}

/// Spawns `rc run` with its logs filtered to warnings (unless `RUST_LOG` says otherwise), so
/// the demo's own output stays readable.
fn start_controller(config: Option<&Path>) -> anyhow::Result<Child> {
    let exe = std::env::current_exe().context("cannot locate the rc executable")?;
    let mut command = Command::new(exe);
    command.arg("run");
    if let Some(path) = config {
        command.arg("--config").arg(path);
    }
    if std::env::var_os("RUST_LOG").is_none() {
        command.env("RUST_LOG", "warn");
    }
    command
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::inherit());
    child_process::die_with_parent(&mut command);
    command.spawn().context("cannot start the controller")
}

fn wait_until_listening(controller: &mut Child, addr: SocketAddr) -> anyhow::Result<()> {
    let deadline = Instant::now() + START_TIMEOUT;
    loop {
        if let Some(status) = controller.try_wait()? {
            bail!("the controller exited during start-up ({status})");
        }
        if TcpStream::connect_timeout(&addr, Duration::from_millis(100)).is_ok() {
            return Ok(());
        }
        if Instant::now() >= deadline {
            bail!(
                "the controller did not accept connections on {addr} within {} s",
                START_TIMEOUT.as_secs()
            );
        }
        thread::sleep(Duration::from_millis(50));
    }
}

/// SIGTERMs the controller and waits for it; `Ok(true)` if it exited with success in time.
fn stop_controller(controller: &mut Child, config: &Config) -> anyhow::Result<bool> {
    child_process::terminate(controller);
    // The orchestrator stops its services one after the other, each within the timeout.
    let per_service = Duration::from_millis(config.main.orchestrator.shutdown_timeout_ms);
    let timeout = per_service * Service::START_ORDER.len() as u32 + Duration::from_secs(2);
    let stopped = child_process::stop(controller, timeout).context("cannot stop the controller")?;
    if stopped.killed {
        eprintln!(
            "the controller did not stop within {} ms; killed it",
            timeout.as_millis()
        );
        return Ok(false);
    }
    if !stopped.status.success() {
        eprintln!("the controller stopped with an error ({})", stopped.status);
        return Ok(false);
    }
    println!("controller stopped");
    Ok(true)
}
