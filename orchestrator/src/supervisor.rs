//! The supervision loop: the shell around [`Lifecycle`]. It polls the service processes for
//! exits, feeds the heartbeats and requests from the bus to the lifecycle, carries out its
//! actions (spawn, SIGTERM, SIGKILL), logs its reports, keeps the pid file current and
//! publishes the supervision status; on shutdown it stops all services in reverse order.

use std::os::unix::process::ExitStatusExt;
use std::path::PathBuf;
use std::process::{Command, ExitStatus};
use std::sync::atomic::{AtomicBool, Ordering};
use std::thread;
use std::time::{Duration, Instant};

use shared_types::config::OrchestratorConfig;
use shared_types::health::{SERVICES, STATUS_REPUBLISH_INTERVAL_NS, Service, ServiceHealth};
use shared_types::supervision::HANDOVER_ENV;
use shared_types::time::monotonic_ns;
use tracing::{error, info, warn};

use crate::child_process::Stopped;
use crate::error::OrchestratorError;
use crate::lifecycle::{Action, Exit, Lifecycle, Report};
use crate::link::SupervisionLink;
use crate::pid_file;
use crate::process::ServiceProcess;

/// How often the children are polled for an exit and the shutdown flag is read.
const POLL_PERIOD: Duration = Duration::from_millis(10);

/// Spawns every service with `launcher` and supervises them through `link` until `shutdown`,
/// then stops them all in reverse start order.
pub(crate) struct Supervisor<L, K>
where
    L: FnMut(Service) -> Command,
    K: SupervisionLink,
{
    launcher: L,
    link: K,
    life: Lifecycle,
    processes: [Option<ServiceProcess>; SERVICES],
    /// The successor of a service that hands over, in standby, and whether its predecessor
    /// was asked to stop.
    successor: Option<(ServiceProcess, bool)>,
    config: OrchestratorConfig,
    pid_file: PathBuf,
    /// Generation and time of the last published status.
    published: Option<(u64, u64)>,
}

impl<L, K> Supervisor<L, K>
where
    L: FnMut(Service) -> Command,
    K: SupervisionLink,
{
    pub(crate) fn new(
        config: &OrchestratorConfig,
        pid_file: PathBuf,
        launcher: L,
        link: K,
    ) -> Self {
        Self {
            launcher,
            link,
            life: Lifecycle::new(config, std::process::id()),
            processes: Default::default(),
            successor: None,
            config: config.clone(),
            pid_file,
            published: None,
        }
    }

    /// Runs the controller's services until `shutdown` becomes true (`Ok`) or supervision
    /// fails (a process cannot be watched, the bus fails); in every case all services are
    /// stopped and the pid file removed on return.
    pub(crate) fn run(mut self, shutdown: &AtomicBool) -> Result<(), OrchestratorError> {
        let supervised = self.supervise(shutdown);
        self.life.shut_down();
        if let Err(e) = self.publish_status() {
            warn!("cannot publish the final supervision status: {e}");
        }
        let stopped = self.stop_all();
        if let Err(e) = pid_file::remove(&self.pid_file) {
            warn!("cannot remove pid file {}: {e}", self.pid_file.display());
        }
        supervised.and(stopped)
    }

    fn supervise(&mut self, shutdown: &AtomicBool) -> Result<(), OrchestratorError> {
        let mut health = Vec::with_capacity(SERVICES);
        let mut requests = Vec::new();
        while !shutdown.load(Ordering::Relaxed) {
            let now = Instant::now();
            self.link.receive_health(&mut health)?;
            for sample in health.drain(..) {
                self.successor_beats(&sample);
                self.life.health(&sample, now);
            }
            self.link.receive_requests(&mut requests)?;
            for request in requests.drain(..) {
                self.life.request(&request, now);
            }
            for service in Service::START_ORDER {
                let Some(exit) = self.poll_exit(service)? else {
                    continue;
                };
                // An exit caused by the shutdown signal itself is not a crash.
                if shutdown.load(Ordering::Relaxed) {
                    return Ok(());
                }
                self.life.exited(service, exit, now);
            }
            self.life.tick(now);
            // Reports first, so a failure is logged before the spawn that follows it.
            self.log_reports();
            self.carry_out(now)?;
            self.log_reports();
            self.publish_status()?;
            thread::sleep(POLL_PERIOD);
        }
        Ok(())
    }

    /// How `service`'s process ended, if it has; the slot is then empty.
    fn poll_exit(&mut self, service: Service) -> Result<Option<Exit>, OrchestratorError> {
        let Some(process) = self.processes[service.index()].as_mut() else {
            return Ok(None);
        };
        let pid = process.pid();
        let Some(status) = process
            .try_wait()
            .map_err(|source| OrchestratorError::Wait { service, source })?
        else {
            return Ok(None);
        };
        process.join_relays();
        self.processes[service.index()] = None;
        info!("service {service} (pid {pid}) ended ({status})");
        // A process ended by a signal left its iceoryx2 node and ports behind.
        if status.signal().is_some() {
            let removed = self.link.remove_dead_nodes();
            info!("removed {removed} dead iceoryx2 node(s) of {service}");
        }
        self.write_pid_file()?;
        Ok(Some(exit_of(status)))
    }

    fn carry_out(&mut self, now: Instant) -> Result<(), OrchestratorError> {
        while let Some(action) = self.life.next_action() {
            match action {
                Action::Spawn(service) => {
                    if let Some(process) = self.successor_of(service) {
                        info!("{service} pid={} takes over", process.pid());
                        self.life.spawned(service, process.pid(), now);
                        self.processes[service.index()] = Some(process);
                        self.write_pid_file()?;
                        continue;
                    }
                    match ServiceProcess::spawn(service, (self.launcher)(service)) {
                        Ok(process) => {
                            info!("spawned {service} pid={}", process.pid());
                            self.life.spawned(service, process.pid(), now);
                            self.processes[service.index()] = Some(process);
                            self.write_pid_file()?;
                        }
                        Err(e) => {
                            error!("cannot spawn service {service}: {e}");
                            self.life.spawn_failed(service, now);
                        }
                    }
                }
                Action::Terminate(service) => {
                    if let Some(process) = &self.processes[service.index()] {
                        process.terminate();
                    }
                }
                Action::HandOver(service) => self.start_successor(service),
                Action::Kill(service) => {
                    if let Some(process) = self.processes[service.index()].as_mut()
                        && let Err(e) = process.kill()
                    {
                        warn!("cannot kill service {service} (pid {}): {e}", process.pid());
                    }
                }
            }
        }
        Ok(())
    }

    /// Starts the successor of `service` in standby (it waits for its predecessor's state);
    /// the predecessor is asked to stop once the successor beats. Without a successor the
    /// predecessor stops at once and the service restarts the usual way.
    fn start_successor(&mut self, service: Service) {
        let mut command = (self.launcher)(service);
        command.env(HANDOVER_ENV, "standby");
        match ServiceProcess::spawn(service, command) {
            Ok(process) => {
                info!("spawned {service} pid={} in standby", process.pid());
                self.successor = Some((process, false));
            }
            Err(e) => {
                warn!("cannot spawn a successor of {service}, restarting it instead: {e}");
                if let Some(process) = &self.processes[service.index()] {
                    process.terminate();
                }
            }
        }
    }

    /// A heartbeat of the successor in standby: it is ready, its predecessor may stop now.
    fn successor_beats(&mut self, health: &ServiceHealth) {
        let Some((successor, asked)) = self.successor.as_mut() else {
            return;
        };
        if *asked || successor.pid() != health.pid {
            return;
        }
        *asked = true;
        let service = successor.service();
        if let Some(process) = &self.processes[service.index()] {
            info!(
                "{service} successor pid={} ready: asking pid={} to hand over",
                health.pid,
                process.pid()
            );
            process.terminate();
        }
    }

    /// The successor in standby of `service`, taken, if it is still alive.
    fn successor_of(&mut self, service: Service) -> Option<ServiceProcess> {
        let (mut process, _) = self.successor.take_if(|(p, _)| p.service() == service)?;
        match process.try_wait() {
            Ok(None) => Some(process),
            Ok(Some(status)) => {
                warn!("the successor of {service} ended in standby ({status})");
                process.join_relays();
                None
            }
            Err(e) => {
                warn!("cannot watch the successor of {service}: {e}");
                None
            }
        }
    }

    fn log_reports(&mut self) {
        for report in self.life.take_reports() {
            self.log(&report);
        }
    }

    fn log(&self, report: &Report) {
        let window_s = self.config.restart_window_s;
        let max = self.config.max_restarts;
        match report {
            Report::Ready { service, pid } => info!("service {service} ready (pid {pid})"),
            Report::Restarting {
                service,
                failure,
                restarts_in_window,
                also,
            } => {
                let also = if also.is_empty() {
                    String::new()
                } else {
                    let names: Vec<&str> = also.iter().map(|s| s.name()).collect();
                    format!(" with {} (rest_for_one)", names.join(", "))
                };
                warn!(
                    "service {service} {failure}; restarting it{also} ({restarts_in_window} of \
                     {max} restarts allowed within {window_s} s)"
                );
            }
            Report::Held {
                service,
                failure,
                restarts_in_window,
            } => error!(
                "service {service} {failure}; {restarts_in_window} failures within {window_s} s \
                 exceed orchestrator.max_restarts = {max}: not restarting it, the arm is held \
                 in a safe stop (GroupReset or `rc restart {service}` starts it again)"
            ),
            Report::Hung {
                service,
                pid,
                cause,
            } => error!("service {service} (pid {pid}) {cause}: killing it"),
            Report::StopOverdue { service, pid } => warn!(
                "service {service} (pid {pid}) did not exit within {} ms of SIGTERM; killing it",
                self.config.shutdown_timeout_ms
            ),
            Report::RestartRequested {
                service,
                request_id,
            } => info!("restart of {service} requested (request {request_id:#x})"),
            Report::ResetRequested {
                request_id,
                services,
            } => info!("reset requested (request {request_id:#x}); starting again: {services:?}"),
            Report::Acknowledged {
                request_id,
                outcome,
            } => info!("request {request_id:#x}: {outcome:?}"),
        }
    }

    /// Publishes the status when it changed, or when the last one is getting old.
    fn publish_status(&mut self) -> Result<(), OrchestratorError> {
        let now_ns = monotonic_ns();
        let generation = self.life.generation();
        let due = self.published.is_none_or(|(published, at_ns)| {
            published != generation || now_ns.saturating_sub(at_ns) >= STATUS_REPUBLISH_INTERVAL_NS
        });
        if due {
            let mut status = self.life.status();
            status.published_ns = now_ns;
            self.link.publish_status(status)?;
            self.published = Some((generation, now_ns));
        }
        Ok(())
    }

    fn write_pid_file(&self) -> Result<(), OrchestratorError> {
        let status = self.life.status();
        let running = Service::START_ORDER.into_iter().filter_map(|service| {
            Some(pid_file::PidEntry {
                service,
                pid: self.processes[service.index()].as_ref()?.pid(),
                restarts: status.service(service).restarts,
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
        if let Some((successor, _)) = self.successor.take() {
            successor.terminate();
            if let Err(e) = successor.stop(timeout) {
                warn!("cannot stop the successor in standby: {e}");
            }
        }
        for slot in self.processes.iter_mut().rev() {
            let Some(process) = slot.take() else {
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
        let removed = self.link.remove_dead_nodes();
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

/// How a process ended, from its exit status.
fn exit_of(status: ExitStatus) -> Exit {
    match (status.code(), status.signal()) {
        (Some(code), _) => Exit::Code(code),
        (None, Some(signal)) => Exit::Signal(signal),
        // Neither code nor signal is not possible for a reaped process on Linux.
        (None, None) => Exit::Code(-1),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    use std::path::Path;
    use std::sync::{Arc, Mutex};

    use shared_types::bus::BusError;
    use shared_types::config::Config;
    use shared_types::health::{
        FailureCause, RequestOutcome, ServiceHealth, SupervisionRequest, SupervisionStatus,
    };

    /// A simulated bus: every process the last published status names beats, except the
    /// services in `silent`; requests are handed over from the test.
    #[derive(Default)]
    struct FakeBus {
        silent: Vec<Service>,
        requests: Vec<SupervisionRequest>,
        status: Option<SupervisionStatus>,
        beats: u64,
    }

    #[derive(Clone, Default)]
    struct FakeLink(Arc<Mutex<FakeBus>>);

    impl FakeLink {
        fn status(&self) -> Option<SupervisionStatus> {
            self.0.lock().unwrap().status
        }
    }

    impl SupervisionLink for FakeLink {
        fn receive_health(&mut self, into: &mut Vec<ServiceHealth>) -> Result<(), BusError> {
            let mut bus = self.0.lock().unwrap();
            bus.beats += 1;
            let Some(status) = bus.status else {
                return Ok(());
            };
            for service in Service::START_ORDER {
                let pid = status.service(service).pid;
                if pid != 0 && !bus.silent.contains(&service) {
                    into.push(ServiceHealth {
                        pid,
                        service: service as u8,
                        reserved: [0; 3],
                        started_unix_ms: 0,
                        published_ns: 0,
                        heartbeat: bus.beats,
                        period_ns: 0,
                        stats: Default::default(),
                    });
                }
            }
            Ok(())
        }

        fn receive_requests(&mut self, into: &mut Vec<SupervisionRequest>) -> Result<(), BusError> {
            into.append(&mut self.0.lock().unwrap().requests);
            Ok(())
        }

        fn publish_status(&mut self, status: SupervisionStatus) -> Result<(), BusError> {
            self.0.lock().unwrap().status = Some(status);
            Ok(())
        }

        fn remove_dead_nodes(&mut self) -> u64 {
            0
        }
    }

    fn config(max_restarts: u32) -> OrchestratorConfig {
        let mut config = Config::load(None).unwrap().main.orchestrator;
        config.max_restarts = max_restarts;
        config.restart_window_s = 60;
        config.shutdown_timeout_ms = 500;
        config.heartbeat_timeout_ms = 300;
        config.start_timeout_ms = 10_000;
        config
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

    /// A supervisor in a thread, with `launcher`, a simulated bus and its own pid file.
    struct Running {
        link: FakeLink,
        pid_path: PathBuf,
        shutdown: Arc<AtomicBool>,
        thread: thread::JoinHandle<Result<(), OrchestratorError>>,
    }

    impl Running {
        fn start(
            tag: &str,
            config: OrchestratorConfig,
            launcher: impl FnMut(Service) -> Command + Send + 'static,
        ) -> Self {
            let pid_path =
                std::env::temp_dir().join(format!("rc-test-{tag}-{}.pids", std::process::id()));
            let link = FakeLink::default();
            let shutdown = Arc::new(AtomicBool::new(false));
            let thread = {
                let (shutdown, pid_path, link) = (shutdown.clone(), pid_path.clone(), link.clone());
                thread::spawn(move || {
                    Supervisor::new(&config, pid_path, launcher, link).run(&shutdown)
                })
            };
            Self {
                link,
                pid_path,
                shutdown,
                thread,
            }
        }

        fn status_where(
            &self,
            what: &str,
            condition: impl Fn(&SupervisionStatus) -> bool,
        ) -> SupervisionStatus {
            wait_for(what, || self.link.status().filter(|s| condition(s)))
        }

        fn stop(self) -> Result<(), OrchestratorError> {
            self.shutdown.store(true, Ordering::Relaxed);
            let result = self.thread.join().unwrap();
            assert!(!self.pid_path.exists(), "pid file left behind");
            result
        }
    }

    #[test]
    fn restarts_a_killed_service_and_stops_all_on_shutdown() {
        let sup = Running::start("sup", config(3), |_| shell("echo started; exec sleep 30"));
        let first = wait_for("all services in the pid file", || pids(&sup.pid_path));
        assert_eq!(
            first.iter().map(|e| e.service).collect::<Vec<_>>(),
            Service::START_ORDER
        );
        let planner = pid_of(&first, Service::Planner);
        // SAFETY: plain syscall on a child of the supervisor.
        unsafe { libc::kill(planner as libc::pid_t, libc::SIGKILL) };
        let second = wait_for("the planner's restart", || {
            pids(&sup.pid_path).filter(|running| pid_of(running, Service::Planner) != planner)
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
        let status = sup.status_where("all running again", |s| s.all_running == 1);
        assert_eq!(status.service(Service::Planner).signal, libc::SIGKILL);

        sup.stop().unwrap();
        for pid_file::PidEntry { service, pid, .. } in second {
            assert!(!alive(pid), "{service} (pid {pid}) still runs");
        }
    }

    #[test]
    fn beyond_the_intensity_the_failing_service_is_held_and_the_others_keep_running() {
        let sup = Running::start("hold", config(2), |service| {
            if service == Service::Interpreter {
                shell("exit 3")
            } else {
                shell("exec sleep 30")
            }
        });
        let status = sup.status_where("the safe stop", |s| s.safe_stop == 1);
        assert_eq!(status.failed_service(), Some(Service::Interpreter));
        assert_eq!(
            FailureCause::from_wire(status.failure),
            FailureCause::Exited
        );
        assert_eq!(status.service(Service::Interpreter).exit_code, 3);
        assert!(status.reason().contains("interpreter exited with code 3"));
        // The fieldbus still starts, and the others keep running.
        let status = sup.status_where("the fieldbus running", |s| {
            s.service(Service::Fieldbus).pid != 0
        });
        thread::sleep(Duration::from_millis(200));
        for service in [Service::Servo, Service::Planner, Service::Fieldbus] {
            let pid = status.service(service).pid;
            assert!(pid != 0 && alive(pid), "{service} runs");
        }
        sup.stop().unwrap();
    }

    #[test]
    fn a_service_ignoring_sigterm_is_killed_and_reported() {
        let sup = Running::start("stubborn", config(3), |service| {
            if service == Service::Servo {
                shell("trap '' TERM; echo ready; while :; do sleep 0.01; done")
            } else {
                shell("exec sleep 30")
            }
        });
        wait_for("all services in the pid file", || pids(&sup.pid_path));
        // Give the shell time to install its trap.
        thread::sleep(Duration::from_millis(200));
        let err = sup.stop().unwrap_err().to_string();
        assert!(err.contains("servo (killed)"), "{err}");
    }

    #[test]
    fn a_service_starts_only_once_the_one_before_it_beats() {
        let sup = Running::start("order", config(3), |_| shell("exec sleep 30"));
        sup.link.0.lock().unwrap().silent = vec![Service::Interpreter];
        let started = |count: usize| {
            let path = sup.pid_path.clone();
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
            "fieldbus started before the interpreter beat"
        );
        sup.link.0.lock().unwrap().silent.clear();
        wait_for("the fieldbus", started(4));
        sup.stop().unwrap();
    }

    #[test]
    fn a_frozen_service_is_killed_by_its_heartbeat_deadline_and_restarted() {
        let sup = Running::start("frozen", config(3), |_| shell("exec sleep 30"));
        let first = sup.status_where("all running", |s| s.all_running == 1);
        let planner = first.service(Service::Planner).pid;
        sup.link.0.lock().unwrap().silent = vec![Service::Planner];
        let status = sup.status_where("the planner replaced", |s| {
            let p = s.service(Service::Planner).pid;
            p != 0 && p != planner
        });
        sup.link.0.lock().unwrap().silent.clear();
        assert!(!alive(planner), "the frozen process was killed");
        let entry = status.service(Service::Planner);
        assert_eq!(
            FailureCause::from_wire(entry.last_failure),
            FailureCause::MissedHeartbeat
        );
        assert_eq!(entry.signal, libc::SIGKILL);
        assert_eq!(
            status.service(Service::Servo).pid,
            first.service(Service::Servo).pid
        );
        sup.stop().unwrap();
    }

    #[test]
    fn a_requested_restart_replaces_the_process_and_is_acknowledged() {
        let sup = Running::start("request", config(0), |_| shell("exec sleep 30"));
        let first = sup.status_where("all running", |s| s.all_running == 1);
        let planner = first.service(Service::Planner).pid;
        sup.link
            .0
            .lock()
            .unwrap()
            .requests
            .push(SupervisionRequest::restart(42, Service::Planner));
        let status = sup.status_where("the acknowledgement", |s| s.request_id == 42);
        assert_eq!(
            RequestOutcome::from_wire(status.request_outcome),
            RequestOutcome::Done
        );
        let new = status.service(Service::Planner).pid;
        assert!(new != planner && alive(new));
        assert!(!alive(planner));
        assert_eq!(
            status.safe_stop, 0,
            "planned: not counted although max_restarts = 0"
        );
        assert_eq!(status.all_running, 1);
        sup.stop().unwrap();
    }
}
