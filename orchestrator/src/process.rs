//! One running service process: spawning it, relaying its output, signalling and reaping it.

use std::io::{self, BufRead, BufReader, Read, Write};
use std::process::{Child, Command, ExitStatus, Stdio};
use std::thread::{self, JoinHandle};
use std::time::Duration;

use crate::child_process::{self, Stopped};
use shared_types::health::Service;

/// A spawned service process and the threads relaying its output.
pub struct ServiceProcess {
    service: Service,
    child: Child,
    relays: Vec<JoinHandle<()>>,
}

impl ServiceProcess {
    /// Spawns `command` as the process of `service`.
    ///
    /// The child gets `SIGTERM` when the spawning thread ends (`PR_SET_PDEATHSIG`), so services
    /// never outlive a crashed orchestrator. Its stdout and stderr lines are relayed to this
    /// process's stderr, prefixed with `[<service>]`.
    pub fn spawn(service: Service, mut command: Command) -> io::Result<Self> {
        child_process::die_with_parent(&mut command);
        let mut child = command
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()?;
        let mut relays = Vec::with_capacity(2);
        let pipes: [Option<Box<dyn Read + Send>>; 2] = [
            child
                .stdout
                .take()
                .map(|p| Box::new(p) as Box<dyn Read + Send>),
            child
                .stderr
                .take()
                .map(|p| Box::new(p) as Box<dyn Read + Send>),
        ];
        for pipe in pipes.into_iter().flatten() {
            let relay = thread::Builder::new()
                .name(format!("relay-{service}"))
                .spawn(move || relay_lines(service, pipe));
            match relay {
                Ok(handle) => relays.push(handle),
                Err(e) => {
                    // A process whose output nobody reads would block on a full pipe.
                    let _ = child.kill();
                    let _ = child.wait();
                    return Err(e);
                }
            }
        }
        Ok(Self {
            service,
            child,
            relays,
        })
    }

    /// The service this process runs.
    pub fn service(&self) -> Service {
        self.service
    }

    /// The process id.
    pub fn pid(&self) -> u32 {
        self.child.id()
    }

    /// The exit status if the process has exited (it is then reaped), without blocking.
    pub fn try_wait(&mut self) -> io::Result<Option<ExitStatus>> {
        self.child.try_wait()
    }

    /// Asks the process to shut down (`SIGTERM`).
    pub fn terminate(&self) {
        child_process::terminate(&self.child);
    }

    /// Kills the process (`SIGKILL`); it still has to be reaped with
    /// [`try_wait`](Self::try_wait).
    pub fn kill(&mut self) -> io::Result<()> {
        self.child.kill()
    }

    /// Waits up to `timeout` for the process to exit after [`terminate`](Self::terminate),
    /// kills it if it does not, reaps it and waits for its output to be relayed.
    pub fn stop(mut self, timeout: Duration) -> io::Result<Stopped> {
        let stopped = child_process::stop(&mut self.child, timeout)?;
        self.join_relays();
        Ok(stopped)
    }

    /// Waits for the relay threads of an exited process to reach the end of its output.
    pub fn join_relays(&mut self) {
        for relay in self.relays.drain(..) {
            // A relay thread never panics on purpose; nothing to add if one did.
            let _ = relay.join();
        }
    }
}

/// Copies each line of `pipe` to stderr as `[<service>] line`. The service formats its own log
/// lines (time, level, target), so they are relayed verbatim rather than wrapped into another
/// log event.
fn relay_lines(service: Service, pipe: Box<dyn Read + Send>) {
    let mut reader = BufReader::new(pipe);
    let mut line = Vec::with_capacity(256);
    loop {
        line.clear();
        match reader.read_until(b'\n', &mut line) {
            Ok(0) | Err(_) => break,
            Ok(_) => {
                let text = String::from_utf8_lossy(&line);
                let mut stderr = io::stderr().lock();
                let _ = writeln!(
                    stderr,
                    "[{service}] {}",
                    text.trim_end_matches(['\n', '\r'])
                );
            }
        }
    }
}
