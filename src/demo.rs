//! `rc demo`: start a controller, run the embedded demo program against it, stop it.

use std::path::Path;
use std::process::Stdio;
use std::sync::atomic::AtomicBool;

use plc_client::{DEMO_PROGRAM, Program};
use shared_types::config::Config;

use crate::controller::{ChildController, client_options};

/// Runs the demo; `Ok(true)` if the program succeeded and the controller stopped cleanly.
/// With `plot`, the run is recorded and its plot written there (also when `shutdown` is set).
pub fn run(config: &Config, plot: Option<&Path>, shutdown: &AtomicBool) -> anyhow::Result<bool> {
    let program = Program::parse(DEMO_PROGRAM, "<embedded demo program>")?;
    let mut controller = ChildController::start(config, Stdio::inherit())?;
    let addr = controller.addr();
    println!(
        "controller started (pid {}), waiting for {addr}",
        controller.id()
    );
    let program_succeeded = controller.wait_until_listening().and_then(|()| {
        println!("controller ready; running the demo program\n");
        let addr = addr.to_string();
        let options = client_options(config);
        match plot {
            None => crate::plc::execute(&addr, &program, &options),
            Some(path) => {
                let name = program.name.clone();
                let request = crate::plot::PlotRequest {
                    path,
                    command: "rc demo",
                    program: &name,
                };
                crate::plot::run_recorded(config, request, shutdown, move || {
                    crate::plc::execute(&addr, &program, &options)
                })
            }
        }
    });
    let stopped_cleanly = stop_controller(&mut controller);
    Ok(program_succeeded? && stopped_cleanly?)
}

/// Stops the controller; `Ok(true)` if it exited with success in time.
fn stop_controller(controller: &mut ChildController) -> anyhow::Result<bool> {
    let stopped = controller.stop()?;
    if stopped.killed {
        eprintln!(
            "the controller did not stop within {} ms; killed it",
            controller.stop_timeout().as_millis()
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
