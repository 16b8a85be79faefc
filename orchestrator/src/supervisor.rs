//! The supervision loop: spawn the services, restart the ones that exit, stop them all.

use std::os::unix::process::ExitStatusExt;
use std::path::PathBuf;
use std::process::{Command, ExitStatus};
use std::sync::atomic::{AtomicBool, Ordering};
use std::thread;
use std::time::{Duration, Instant};

use shared_types::bus::Bus;
use shared_types::config::OrchestratorConfig;
use tracing::{error, info, warn};

use crate::child_process::Stopped;
use crate::error::OrchestratorError;
use crate::pid_file;
use crate::process::ServiceProcess;
use crate::restart::{RestartDecision, RestartPolicy};
use crate::service::Service;

/// How often the children are polled for an exit and the shutdown flag is read.
const POLL_PERIOD: Duration = Duration::from_millis(10);

/// One service's place in the supervisor.
struct Slot {
    service: Service,
    process: Option<ServiceProcess>,
    restarts: u32,
}

/// Spawns every service with `launcher`, each once the one before it is ready (or did not get
/// ready within the start timeout), supervises them until `shutdown` or until the restart
/// intensity is exceeded, then stops them all in reverse start order.
pub(crate) struct Supervisor<'a, L, R>
where
    L: FnMut(Service) -> Command,
    R: Fn(Service) -> bool,
{
    bus: &'a Bus,
    launcher: L,
    is_ready: R,
    start_timeout: Duration,
    slots: Vec<Slot>,
    /// Slots spawned at least once; the next one starts when the last of them is ready.
    started: usize,
    /// When the next service is started even though the last one is not ready.
    start_deadline: Instant,
    policy: RestartPolicy,
    config: OrchestratorConfig,
    pid_file: PathBuf,
}

impl<'a, L, R> Supervisor<'a, L, R>
where
    L: FnMut(Service) -> Command,
    R: Fn(Service) -> bool,
{
    pub(crate) fn new(
        bus: &'a Bus,
        config: &OrchestratorConfig,
        pid_file: PathBuf,
        launcher: L,
        is_ready: R,
        start_timeout: Duration,
    ) -> Self {
        Self {
            bus,
            launcher,
            is_ready,
            start_timeout,
            started: 0,
            start_deadline: Instant::now(),
            slots: Service::START_ORDER
                .into_iter()
                .map(|service| Slot {
                    service,
                    process: None,
                    restarts: 0,
                })
                .collect(),
            policy: RestartPolicy::new(
                config.max_restarts,
                Duration::from_secs(config.restart_window_s),
            ),
            config: config.clone(),
            pid_file,
        }
    }

    /// Runs the controller's services until `shutdown` becomes true (`Ok`) or supervision
    /// fails; in every case all services are stopped and the pid file removed on return.
    pub(crate) fn run(mut self, shutdown: &AtomicBool) -> Result<(), OrchestratorError> {
        let supervised = self.supervise(shutdown);
        let stopped = self.stop_all();
        if let Err(e) = pid_file::remove(&self.pid_file) {
            warn!("cannot remove pid file {}: {e}", self.pid_file.display());
        }
        supervised.and(stopped)
    }

    fn supervise(&mut self, shutdown: &AtomicBool) -> Result<(), OrchestratorError> {
        while !shutdown.load(Ordering::Relaxed) {
            self.start_next()?;
            for index in 0..self.started {
                let Some(status) = self.poll_exit(index)? else {
                    continue;
                };
                // An exit caused by the shutdown signal itself is not a crash.
                if shutdown.load(Ordering::Relaxed) {
                    return Ok(());
                }
                self.restart(index, status)?;
            }
            thread::sleep(POLL_PERIOD);
        }
        Ok(())
    }

    /// Spawns the next service of the start order once the one before it is ready.
    fn start_next(&mut self) -> Result<(), OrchestratorError> {
        if self.started == self.slots.len() {
            return Ok(());
        }
        if let Some(previous) = self.started.checked_sub(1).map(|i| self.slots[i].service) {
            if (self.is_ready)(previous) {
                info!("service {previous} ready");
            } else if Instant::now() >= self.start_deadline {
                warn!(
                    "service {previous} not ready (no subscription to its input topic) within \
                     {} s; starting the next service anyway",
                    self.start_timeout.as_secs_f64()
                );
            } else {
                return Ok(());
            }
        }
        self.spawn(self.started)?;
        self.started += 1;
        self.start_deadline = Instant::now() + self.start_timeout;
        Ok(())
    }

    /// The exit status of slot `index`'s process if it has exited; the slot is then empty.
    fn poll_exit(&mut self, index: usize) -> Result<Option<ExitStatus>, OrchestratorError> {
        let slot = &mut self.slots[index];
        let Some(process) = slot.process.as_mut() else {
            return Ok(None);
        };
        let status = process
            .try_wait()
            .map_err(|source| OrchestratorError::Wait {
                service: slot.service,
                source,
            })?;
        if status.is_some() {
            process.join_relays();
            slot.process = None;
        }
        Ok(status)
    }

    fn restart(&mut self, index: usize, status: ExitStatus) -> Result<(), OrchestratorError> {
        let service = self.slots[index].service;
        match self.policy.on_exit(Instant::now()) {
            RestartDecision::GiveUp { restarts_in_window } => {
                error!(
                    "service {service} exited ({status}); {restarts_in_window} restarts within \
                     {} s exceed orchestrator.max_restarts = {}, shutting the controller down",
                    self.config.restart_window_s, self.config.max_restarts
                );
                Err(OrchestratorError::RestartIntensity {
                    service,
                    status,
                    restarts: restarts_in_window,
                    max_restarts: self.config.max_restarts,
                    window_s: self.config.restart_window_s,
                })
            }
            RestartDecision::Restart { restarts_in_window } => {
                let slot = &mut self.slots[index];
                slot.restarts += 1;
                warn!(
                    "service {service} exited ({status}); restarting it (restart {} of this \
                     service, {restarts_in_window} of {} allowed within {} s)",
                    slot.restarts, self.config.max_restarts, self.config.restart_window_s
                );
                // A process killed by a signal left its iceoryx2 node and ports behind.
                if status.signal().is_some() {
                    let removed = self.bus.remove_dead_nodes();
                    info!("removed {removed} dead iceoryx2 node(s) of {service}");
                }
                self.spawn(index)
            }
        }
    }

    fn spawn(&mut self, index: usize) -> Result<(), OrchestratorError> {
        let service = self.slots[index].service;
        let process = ServiceProcess::spawn(service, (self.launcher)(service))
            .map_err(|source| OrchestratorError::Spawn { service, source })?;
        info!("spawned {service} pid={}", process.pid());
        self.slots[index].process = Some(process);
        self.write_pid_file()
    }

    fn write_pid_file(&self) -> Result<(), OrchestratorError> {
        let running = self.slots.iter().filter_map(|slot| {
            Some(pid_file::PidEntry {
                service: slot.service,
                pid: slot.process.as_ref()?.pid(),
                restarts: slot.restarts,
            })
        });
        pid_file::write(&self.pid_file, &pid_file::render(running)).map_err(|source| {
            OrchestratorError::PidFile {
                path: self.pid_file.clone(),
                source,
            }
        })
    }

    /// Stops every running service in reverse start order: `SIGTERM`, up to
    /// `shutdown_timeout_ms` to exit, then `SIGKILL`. Then removes the nodes of killed ones.
    fn stop_all(&mut self) -> Result<(), OrchestratorError> {
        let timeout = Duration::from_millis(self.config.shutdown_timeout_ms);
        let mut unclean = Vec::new();
        for slot in self.slots.iter_mut().rev() {
            let Some(process) = slot.process.take() else {
                continue;
            };
            let service = process.service();
            process.terminate();
            match process.stop(timeout) {
                Ok(Stopped { killed: true, .. }) => {
                    warn!(
                        "service {service} did not exit within {} ms of SIGTERM; killed it",
                        timeout.as_millis()
                    );
                    unclean.push(format!("{service} (killed)"));
                }
                Ok(Stopped { status, .. }) if stopped_cleanly(status) => {
                    info!("service {service} stopped ({status})");
                }
                Ok(Stopped { status, .. }) => {
                    warn!("service {service} stopped with an error ({status})");
                    unclean.push(format!("{service} ({status})"));
                }
                Err(e) => {
                    error!("cannot stop service {service}: {e}");
                    unclean.push(format!("{service} ({e})"));
                }
            }
        }
        let removed = self.bus.remove_dead_nodes();
        if removed > 0 {
            info!("removed {removed} dead iceoryx2 node(s)");
        }
        if unclean.is_empty() {
            Ok(())
        } else {
            Err(OrchestratorError::UncleanStop(unclean.join(", ")))
        }
    }
}

/// A service stopped cleanly if it exited with success, or was ended by the `SIGTERM` itself
/// (which happens when it is stopped before it installed its signal handler).
fn stopped_cleanly(status: ExitStatus) -> bool {
    status.success() || status.signal() == Some(libc::SIGTERM)
}

#[cfg(test)]
mod tests {
    use super::*;

    use std::path::Path;
    use std::sync::Arc;

    const START_TIMEOUT: Duration = Duration::from_secs(10);

    fn config(max_restarts: u32) -> OrchestratorConfig {
        OrchestratorConfig {
            max_restarts,
            restart_window_s: 60,
            shutdown_timeout_ms: 500,
        }
    }

    fn shell(script: &str) -> Command {
        let mut command = Command::new("/bin/sh");
        command.arg("-c").arg(script);
        command
    }

    fn wait_for<T>(what: &str, mut probe: impl FnMut() -> Option<T>) -> T {
        let deadline = Instant::now() + Duration::from_secs(10);
        loop {
            if let Some(value) = probe() {
                return value;
            }
            assert!(Instant::now() < deadline, "timed out waiting for {what}");
            thread::sleep(Duration::from_millis(10));
        }
    }

    fn pids(path: &Path) -> Option<Vec<pid_file::PidEntry>> {
        let running = pid_file::parse(&std::fs::read_to_string(path).ok()?);
        (running.len() == Service::START_ORDER.len()).then_some(running)
    }

    fn pid_of(running: &[pid_file::PidEntry], service: Service) -> u32 {
        running.iter().find(|e| e.service == service).unwrap().pid
    }

    fn alive(pid: u32) -> bool {
        // SAFETY: signal 0 only checks that the process exists.
        unsafe { libc::kill(pid as libc::pid_t, 0) == 0 }
    }

    #[test]
    fn restarts_a_killed_service_and_stops_all_on_shutdown() {
        let instance = format!("rc-test-sup-{}", std::process::id());
        let pid_path = std::env::temp_dir().join(format!("{instance}.pids"));
        let shutdown = Arc::new(AtomicBool::new(false));
        let supervisor = {
            let (shutdown, pid_path) = (shutdown.clone(), pid_path.clone());
            thread::spawn(move || {
                let bus = Bus::new(&instance, "orchestrator").unwrap();
                let launcher = |_| shell("echo started; exec sleep 30");
                Supervisor::new(
                    &bus,
                    &config(3),
                    pid_path,
                    launcher,
                    |_| true,
                    START_TIMEOUT,
                )
                .run(&shutdown)
            })
        };

        let first = wait_for("all services in the pid file", || pids(&pid_path));
        assert_eq!(
            first.iter().map(|e| e.service).collect::<Vec<_>>(),
            Service::START_ORDER
        );
        let planner = pid_of(&first, Service::Planner);
        // SAFETY: plain syscall on a child of the supervisor.
        unsafe { libc::kill(planner as libc::pid_t, libc::SIGKILL) };
        let second = wait_for("the planner's restart", || {
            pids(&pid_path).filter(|running| pid_of(running, Service::Planner) != planner)
        });
        for service in [Service::Servo, Service::Interpreter, Service::Fieldbus] {
            assert_eq!(pid_of(&first, service), pid_of(&second, service));
        }
        let restarts = |service| {
            second
                .iter()
                .find(|e| e.service == service)
                .unwrap()
                .restarts
        };
        assert_eq!(
            restarts(Service::Planner),
            1,
            "the pid file counts restarts"
        );
        assert_eq!(restarts(Service::Servo), 0);

        shutdown.store(true, Ordering::Relaxed);
        supervisor.join().unwrap().unwrap();
        assert!(!pid_path.exists(), "pid file left behind");
        for pid_file::PidEntry { service, pid, .. } in second {
            assert!(!alive(pid), "{service} (pid {pid}) still runs");
        }
    }

    #[test]
    fn gives_up_when_services_keep_exiting() {
        let instance = format!("rc-test-giveup-{}", std::process::id());
        let pid_path = std::env::temp_dir().join(format!("{instance}.pids"));
        let bus = Bus::new(&instance, "orchestrator").unwrap();
        let shutdown = AtomicBool::new(false);
        let launcher = |service| {
            if service == Service::Interpreter {
                shell("exit 3")
            } else {
                shell("exec sleep 30")
            }
        };
        let err = Supervisor::new(
            &bus,
            &config(2),
            pid_path.clone(),
            launcher,
            |_| true,
            START_TIMEOUT,
        )
        .run(&shutdown)
        .unwrap_err();
        match &err {
            OrchestratorError::RestartIntensity {
                service, restarts, ..
            } => {
                assert_eq!(*service, Service::Interpreter);
                assert_eq!(*restarts, 3);
            }
            other => panic!("unexpected error {other}"),
        }
        let message = err.to_string();
        assert!(
            message.contains("interpreter") && message.contains("exit status: 3"),
            "{message}"
        );
        assert!(!pid_path.exists(), "pid file left behind");
    }

    #[test]
    fn a_service_ignoring_sigterm_is_killed_and_reported() {
        let instance = format!("rc-test-stubborn-{}", std::process::id());
        let pid_path = std::env::temp_dir().join(format!("{instance}.pids"));
        let shutdown = Arc::new(AtomicBool::new(false));
        let supervisor = {
            let (shutdown, pid_path) = (shutdown.clone(), pid_path.clone());
            thread::spawn(move || {
                let bus = Bus::new(&instance, "orchestrator").unwrap();
                let launcher = |service| {
                    if service == Service::Servo {
                        shell("trap '' TERM; echo ready; while :; do sleep 0.01; done")
                    } else {
                        shell("exec sleep 30")
                    }
                };
                Supervisor::new(
                    &bus,
                    &config(3),
                    pid_path,
                    launcher,
                    |_| true,
                    START_TIMEOUT,
                )
                .run(&shutdown)
            })
        };
        wait_for("all services in the pid file", || pids(&pid_path));
        // Give the shell time to install its trap.
        thread::sleep(Duration::from_millis(200));
        shutdown.store(true, Ordering::Relaxed);
        let err = supervisor.join().unwrap().unwrap_err().to_string();
        assert!(err.contains("servo (killed)"), "{err}");
    }

    #[test]
    fn a_service_starts_only_once_the_one_before_it_is_ready() {
        let instance = format!("rc-test-order-{}", std::process::id());
        let pid_path = std::env::temp_dir().join(format!("{instance}.pids"));
        let shutdown = Arc::new(AtomicBool::new(false));
        let interpreter_ready = Arc::new(AtomicBool::new(false));
        let supervisor = {
            let (shutdown, pid_path) = (shutdown.clone(), pid_path.clone());
            let interpreter_ready = interpreter_ready.clone();
            thread::spawn(move || {
                let bus = Bus::new(&instance, "orchestrator").unwrap();
                let launcher = |_| shell("exec sleep 30");
                let is_ready = |service| {
                    service != Service::Interpreter || interpreter_ready.load(Ordering::Relaxed)
                };
                Supervisor::new(
                    &bus,
                    &config(3),
                    pid_path,
                    launcher,
                    is_ready,
                    START_TIMEOUT,
                )
                .run(&shutdown)
            })
        };
        let started = |count: usize| {
            let path = pid_path.clone();
            move || {
                let running = pid_file::parse(&std::fs::read_to_string(&path).ok()?);
                (running.len() == count).then_some(running)
            }
        };
        let first = wait_for("servo, planner and interpreter", started(3));
        assert_eq!(first.last().unwrap().service, Service::Interpreter);
        thread::sleep(Duration::from_millis(200));
        assert!(
            started(3)().is_some(),
            "fieldbus started before the interpreter was ready"
        );
        interpreter_ready.store(true, Ordering::Relaxed);
        wait_for("the fieldbus", started(4));
        shutdown.store(true, Ordering::Relaxed);
        supervisor.join().unwrap().unwrap();
    }
}
