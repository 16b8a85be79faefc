//! The supervision decisions, without processes, clocks or I/O: the pure core of the
//! supervisor.
//!
//! [`Lifecycle`] follows each service through its phases (waiting to be spawned, starting,
//! running, stopping, failed) from what the shell tells it (a process was spawned, exited, sent
//! a heartbeat; a request arrived; time passed) and answers with [`Action`]s for the shell to
//! carry out (spawn, SIGTERM, SIGKILL), [`Report`]s worth a log line, and the
//! [`SupervisionStatus`] to publish.
//!
//! - A spawned service is *starting* until its first heartbeat from its own pid, then
//!   *running*; services are spawned one at a time in start order, each once every service
//!   before it runs (or has failed for good), and none while another one is being stopped.
//! - A running service whose heartbeat stands still for `heartbeat_timeout_ms`, or a starting
//!   one that does not beat within `start_timeout_ms`, is killed (SIGKILL) and counts as
//!   failed, like one that exits by itself.
//! - A failure is restarted as the service's [`RestartStrategy`] says while the
//!   [`RestartPolicy`] allows; beyond the intensity limit the service is *failed*: it is not
//!   restarted, the others keep running, and the status reports a safe stop naming it.
//! - Requests (see [`shared_types::health`]): a planned restart (SIGTERM, SIGKILL after
//!   `shutdown_timeout_ms`, respawn; not counted) and a reset (start the failed services
//!   again, forget the intensity history). Each is acknowledged once its services run again.

use std::collections::VecDeque;
use std::fmt;
use std::time::{Duration, Instant};

use shared_types::config::{OrchestratorConfig, RestartStrategy};
use shared_types::health::{
    FailureCause, NO_SERVICE, RequestKind, RequestOutcome, SERVICES, Service, ServiceHealth,
    ServiceState, SupervisionRequest, SupervisionStatus,
};

use crate::restart::{RestartDecision, RestartPolicy};

/// Requests remembered to recognise a re-sent one.
const REMEMBERED_REQUESTS: usize = 32;

/// How a service process ended, from its exit status.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Exit {
    /// It exited with this code.
    Code(i32),
    /// It was ended by this signal.
    Signal(i32),
}

/// Why a service failed, with its exit details.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Failure {
    pub cause: FailureCause,
    /// Exit code, or -1.
    pub exit_code: i32,
    /// Ending signal, or 0.
    pub signal: i32,
}

impl Failure {
    const NONE: Failure = Failure::of(FailureCause::None);

    const fn of(cause: FailureCause) -> Self {
        Self {
            cause,
            exit_code: -1,
            signal: 0,
        }
    }

    fn exited(exit: Exit) -> Self {
        match exit {
            Exit::Code(code) => Self {
                exit_code: code,
                ..Self::of(FailureCause::Exited)
            },
            Exit::Signal(signal) => Self {
                signal,
                ..Self::of(FailureCause::Signaled)
            },
        }
    }

    /// A failure detected by the supervisor, which then killed the process with `exit`.
    fn killed_for(cause: FailureCause, exit: Exit) -> Self {
        match exit {
            Exit::Signal(signal) => Self {
                signal,
                ..Self::of(cause)
            },
            Exit::Code(exit_code) => Self {
                exit_code,
                ..Self::of(cause)
            },
        }
    }
}

impl fmt::Display for Failure {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.cause {
            FailureCause::Exited => write!(f, "exited with code {}", self.exit_code),
            FailureCause::Signaled => write!(f, "killed by signal {}", self.signal),
            cause => write!(f, "{cause}"),
        }
    }
}

/// What the shell is to do now.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Action {
    /// Spawn the service's process, then call [`Lifecycle::spawned`] or
    /// [`Lifecycle::spawn_failed`].
    Spawn(Service),
    /// Ask its process to stop (SIGTERM).
    Terminate(Service),
    /// A planned restart of a service that hands its state over (the interpreter): start
    /// its successor in standby first, and ask the running process to stop (SIGTERM) once
    /// the successor beats. The next [`Action::Spawn`] of the service takes that successor.
    HandOver(Service),
    /// Kill its process (SIGKILL).
    Kill(Service),
}

/// Something that happened, for the log.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Report {
    /// The process beat for the first time.
    Ready { service: Service, pid: u32 },
    /// It failed and is restarted, with `also` (rest_for_one).
    Restarting {
        service: Service,
        failure: Failure,
        restarts_in_window: u32,
        also: Vec<Service>,
    },
    /// It failed once too often: held in a safe stop.
    Held {
        service: Service,
        failure: Failure,
        restarts_in_window: u32,
    },
    /// Its heartbeat stood still or never came: killed.
    Hung {
        service: Service,
        pid: u32,
        cause: FailureCause,
    },
    /// It did not stop within the grace period after SIGTERM: killed.
    StopOverdue { service: Service, pid: u32 },
    /// A planned restart was requested.
    RestartRequested { service: Service, request_id: u64 },
    /// A reset was requested; these failed services are started again.
    ResetRequested {
        request_id: u64,
        services: Vec<Service>,
    },
    /// A request was answered.
    Acknowledged {
        request_id: u64,
        outcome: RequestOutcome,
    },
}

/// What happens once a stopping process has exited.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum AfterStop {
    /// Spawn it again (planned restart, or restarted along with another service).
    Respawn,
    /// Handle it as failed for this reason (it was killed for missing its heartbeat).
    Fail(FailureCause),
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Phase {
    /// Waiting to be spawned.
    Down,
    /// Spawned at `since`, no heartbeat yet.
    Starting { since: Instant },
    /// Beating; the counter last advanced at `advanced_at`.
    Running {
        heartbeat: u64,
        advanced_at: Instant,
    },
    /// Asked to stop (or killed) at `since`.
    Stopping {
        since: Instant,
        killed: bool,
        then: AfterStop,
    },
    /// Not restarted any more.
    Failed,
    /// Stopped with the controller.
    Stopped,
}

#[derive(Debug, Clone, Copy)]
struct Slot {
    service: Service,
    phase: Phase,
    /// The running process, 0 when none.
    pid: u32,
    restarts: u32,
    /// It has been spawned before (a new spawn is a restart).
    ever_spawned: bool,
    last_failure: Failure,
}

/// The safe stop: who failed once too often, and why.
#[derive(Debug, Clone, Copy)]
struct SafeStop {
    service: Service,
    failure: Failure,
    restarts_in_window: u32,
}

/// A request waiting for its services to run again.
#[derive(Debug, Clone)]
struct Pending {
    request_id: u64,
    /// The services concerned and their pids when the request came.
    services: Vec<(Service, u32)>,
}

/// The supervision state of all services; see the module documentation.
#[derive(Debug)]
pub struct Lifecycle {
    slots: [Slot; SERVICES],
    strategies: [RestartStrategy; SERVICES],
    heartbeat_timeout: Duration,
    start_timeout: Duration,
    stop_timeout: Duration,
    max_restarts: u32,
    window_s: u64,
    policy: RestartPolicy,
    safe_stop: Option<SafeStop>,
    pending: Vec<Pending>,
    /// Recent request ids and their outcome (`None` while pending), oldest first.
    recent: VecDeque<(u64, Option<RequestOutcome>)>,
    last_ack: (u64, RequestOutcome),
    generation: u64,
    orchestrator_pid: u32,
    actions: VecDeque<Action>,
    reports: Vec<Report>,
}

impl Lifecycle {
    /// Every service waiting for its first start.
    pub fn new(config: &OrchestratorConfig, orchestrator_pid: u32) -> Self {
        let slot = |service| Slot {
            service,
            phase: Phase::Down,
            pid: 0,
            restarts: 0,
            ever_spawned: false,
            last_failure: Failure::NONE,
        };
        Self {
            slots: Service::START_ORDER.map(slot),
            strategies: Service::START_ORDER.map(|s| config.strategy.of(s)),
            heartbeat_timeout: Duration::from_millis(config.heartbeat_timeout_ms),
            start_timeout: Duration::from_millis(config.start_timeout_ms),
            stop_timeout: Duration::from_millis(config.shutdown_timeout_ms),
            max_restarts: config.max_restarts,
            window_s: config.restart_window_s,
            policy: RestartPolicy::new(
                config.max_restarts,
                Duration::from_secs(config.restart_window_s),
            ),
            safe_stop: None,
            pending: Vec::new(),
            recent: VecDeque::with_capacity(REMEMBERED_REQUESTS),
            last_ack: (0, RequestOutcome::None),
            generation: 0,
            orchestrator_pid,
            actions: VecDeque::new(),
            reports: Vec::new(),
        }
    }

    /// The next action to carry out.
    pub fn next_action(&mut self) -> Option<Action> {
        self.actions.pop_front()
    }

    /// The reports since the last call.
    pub fn take_reports(&mut self) -> Vec<Report> {
        std::mem::take(&mut self.reports)
    }

    /// Increments with every change of the status.
    pub fn generation(&self) -> u64 {
        self.generation
    }

    /// The process of `service` was spawned as `pid`.
    pub fn spawned(&mut self, service: Service, pid: u32, now: Instant) {
        let slot = &mut self.slots[service.index()];
        if slot.ever_spawned {
            slot.restarts += 1;
        }
        slot.ever_spawned = true;
        slot.pid = pid;
        slot.phase = Phase::Starting { since: now };
        self.changed();
    }

    /// The process of `service` could not be spawned.
    pub fn spawn_failed(&mut self, service: Service, now: Instant) {
        self.slots[service.index()].ever_spawned = true;
        self.fail(service, Failure::of(FailureCause::SpawnFailed), now);
    }

    /// A heartbeat sample arrived.
    pub fn health(&mut self, health: &ServiceHealth, now: Instant) {
        let Some(service) = Service::from_wire(health.service) else {
            return;
        };
        let slot = &mut self.slots[service.index()];
        // Samples of an earlier process of the service may still be queued.
        if slot.pid == 0 || slot.pid != health.pid {
            return;
        }
        match slot.phase {
            Phase::Starting { .. } => {
                slot.phase = Phase::Running {
                    heartbeat: health.heartbeat,
                    advanced_at: now,
                };
                self.reports.push(Report::Ready {
                    service,
                    pid: health.pid,
                });
                self.changed();
            }
            Phase::Running { heartbeat, .. } if heartbeat != health.heartbeat => {
                slot.phase = Phase::Running {
                    heartbeat: health.heartbeat,
                    advanced_at: now,
                };
            }
            _ => {}
        }
    }

    /// The process of `service` ended.
    pub fn exited(&mut self, service: Service, exit: Exit, now: Instant) {
        let slot = &mut self.slots[service.index()];
        slot.pid = 0;
        let phase = slot.phase;
        self.changed();
        match phase {
            Phase::Starting { .. } | Phase::Running { .. } => {
                self.fail(service, Failure::exited(exit), now)
            }
            Phase::Stopping {
                then: AfterStop::Respawn,
                ..
            } => self.slots[service.index()].phase = Phase::Down,
            Phase::Stopping {
                then: AfterStop::Fail(cause),
                ..
            } => self.fail(service, Failure::killed_for(cause, exit), now),
            Phase::Down | Phase::Failed | Phase::Stopped => {}
        }
    }

    /// A request arrived on the control topic.
    pub fn request(&mut self, request: &SupervisionRequest, now: Instant) {
        let id = request.request_id;
        if let Some(&(_, outcome)) = self.recent.iter().find(|(r, _)| *r == id) {
            // Re-sent: answer again if it is complete, else it is being worked on.
            if let Some(outcome) = outcome {
                self.acknowledge(id, outcome);
            }
            return;
        }
        if self.recent.len() == REMEMBERED_REQUESTS {
            self.recent.pop_front();
        }
        self.recent.push_back((id, None));
        let kind = RequestKind::from_wire(request.kind);
        let service = Service::from_wire(request.service);
        match (kind, service) {
            (Some(RequestKind::Restart), Some(service)) => {
                self.reports.push(Report::RestartRequested {
                    service,
                    request_id: id,
                });
                let pid = self.slots[service.index()].pid;
                self.replace(service, now);
                self.pending.push(Pending {
                    request_id: id,
                    services: vec![(service, pid)],
                });
            }
            (Some(RequestKind::Reset), _) => {
                let failed: Vec<Service> = self
                    .slots
                    .iter()
                    .filter(|s| s.phase == Phase::Failed)
                    .map(|s| s.service)
                    .collect();
                for &service in &failed {
                    self.slots[service.index()].phase = Phase::Down;
                }
                self.policy.reset();
                self.safe_stop = None;
                self.reports.push(Report::ResetRequested {
                    request_id: id,
                    services: failed.clone(),
                });
                self.pending.push(Pending {
                    request_id: id,
                    services: failed.into_iter().map(|s| (s, 0)).collect(),
                });
                self.changed();
            }
            _ => self.acknowledge(id, RequestOutcome::Rejected),
        }
    }

    /// Time passed: deadlines, the next spawn, acknowledgements.
    pub fn tick(&mut self, now: Instant) {
        self.check_deadlines(now);
        self.start_next();
        self.resolve_one_request();
    }

    /// The controller shuts down: every service counts as stopped.
    pub fn shut_down(&mut self) {
        for slot in &mut self.slots {
            slot.phase = Phase::Stopped;
        }
        self.changed();
    }

    /// The status to publish.
    pub fn status(&self) -> SupervisionStatus {
        let mut status = SupervisionStatus::new(self.orchestrator_pid);
        status.generation = self.generation;
        status.request_id = self.last_ack.0;
        status.request_outcome = self.last_ack.1 as u8;
        status.all_running = u8::from(
            self.slots
                .iter()
                .all(|s| matches!(s.phase, Phase::Running { .. })),
        );
        for (entry, slot) in status.services.iter_mut().zip(&self.slots) {
            entry.pid = slot.pid;
            entry.state = wire_state(slot) as u8;
            entry.last_failure = slot.last_failure.cause as u8;
            entry.exit_code = slot.last_failure.exit_code;
            entry.signal = slot.last_failure.signal;
            entry.restarts = slot.restarts;
        }
        if let Some(stop) = self.safe_stop {
            status.safe_stop = 1;
            status.failed_service = stop.service as u8;
            status.failure = stop.failure.cause as u8;
            status.failures_in_window = stop.restarts_in_window;
            status.set_reason(&format!(
                "{} {}; {} failures within {} s exceed orchestrator.max_restarts = {}",
                stop.service,
                stop.failure,
                stop.restarts_in_window,
                self.window_s,
                self.max_restarts
            ));
        } else {
            status.failed_service = NO_SERVICE;
        }
        status
    }

    fn changed(&mut self) {
        self.generation += 1;
    }

    /// Starts a planned replacement of `service`'s process.
    fn replace(&mut self, service: Service, now: Instant) {
        let slot = &mut self.slots[service.index()];
        match slot.phase {
            Phase::Starting { .. } | Phase::Running { .. } => {
                slot.phase = Phase::Stopping {
                    since: now,
                    killed: false,
                    then: AfterStop::Respawn,
                };
                // The interpreter hands its SRCI session to its successor.
                self.actions.push_back(if service == Service::Interpreter {
                    Action::HandOver(service)
                } else {
                    Action::Terminate(service)
                });
            }
            Phase::Failed | Phase::Stopped => slot.phase = Phase::Down,
            // Already on its way to a new process.
            Phase::Down | Phase::Stopping { .. } => {}
        }
        // Started again by hand: the safe stop ends with the last failed service.
        if !self.slots.iter().any(|s| s.phase == Phase::Failed) {
            self.safe_stop = None;
        }
        self.changed();
    }

    fn fail(&mut self, service: Service, failure: Failure, now: Instant) {
        let index = service.index();
        self.slots[index].last_failure = failure;
        self.changed();
        match self.policy.on_exit(now) {
            RestartDecision::Restart { restarts_in_window } => {
                self.slots[index].phase = Phase::Down;
                let mut also = Vec::new();
                if self.strategies[index] == RestartStrategy::RestForOne {
                    for later in index + 1..SERVICES {
                        if matches!(
                            self.slots[later].phase,
                            Phase::Starting { .. } | Phase::Running { .. }
                        ) {
                            self.slots[later].phase = Phase::Stopping {
                                since: now,
                                killed: false,
                                then: AfterStop::Respawn,
                            };
                            let sibling = self.slots[later].service;
                            self.actions.push_back(Action::Terminate(sibling));
                            also.push(sibling);
                        }
                    }
                }
                self.reports.push(Report::Restarting {
                    service,
                    failure,
                    restarts_in_window,
                    also,
                });
            }
            RestartDecision::GiveUp { restarts_in_window } => {
                self.slots[index].phase = Phase::Failed;
                // The first failure that caused the safe stop names it.
                self.safe_stop.get_or_insert(SafeStop {
                    service,
                    failure,
                    restarts_in_window,
                });
                self.reports.push(Report::Held {
                    service,
                    failure,
                    restarts_in_window,
                });
            }
        }
    }

    fn check_deadlines(&mut self, now: Instant) {
        for index in 0..SERVICES {
            let Slot {
                service,
                pid,
                phase,
                ..
            } = self.slots[index];
            let cause = match phase {
                Phase::Starting { since } if now.duration_since(since) > self.start_timeout => {
                    FailureCause::NotReady
                }
                Phase::Running { advanced_at, .. }
                    if now.duration_since(advanced_at) > self.heartbeat_timeout =>
                {
                    FailureCause::MissedHeartbeat
                }
                Phase::Stopping {
                    since,
                    killed: false,
                    then,
                } if now.duration_since(since) > self.stop_timeout => {
                    self.slots[index].phase = Phase::Stopping {
                        since,
                        killed: true,
                        then,
                    };
                    self.actions.push_back(Action::Kill(service));
                    self.reports.push(Report::StopOverdue { service, pid });
                    continue;
                }
                _ => continue,
            };
            self.slots[index].phase = Phase::Stopping {
                since: now,
                killed: true,
                then: AfterStop::Fail(cause),
            };
            self.actions.push_back(Action::Kill(service));
            self.reports.push(Report::Hung {
                service,
                pid,
                cause,
            });
            self.changed();
        }
    }

    /// Spawns the first waiting service once every one before it runs or has failed, and
    /// none is being stopped.
    fn start_next(&mut self) {
        if self
            .slots
            .iter()
            .any(|s| matches!(s.phase, Phase::Stopping { .. }))
        {
            return;
        }
        for slot in &self.slots {
            match slot.phase {
                Phase::Running { .. } | Phase::Failed | Phase::Stopped => {}
                Phase::Down => {
                    self.actions.push_back(Action::Spawn(slot.service));
                    return;
                }
                Phase::Starting { .. } | Phase::Stopping { .. } => return,
            }
        }
    }

    /// Answers the first pending request that is complete (one per tick, so each answer gets
    /// a status of its own).
    fn resolve_one_request(&mut self) {
        let outcome = |p: &Pending| {
            let failed = p
                .services
                .iter()
                .any(|(s, _)| self.slots[s.index()].phase == Phase::Failed);
            let replaced = p.services.iter().all(|&(s, old_pid)| {
                let slot = &self.slots[s.index()];
                matches!(slot.phase, Phase::Running { .. }) && slot.pid != old_pid
            });
            if failed {
                Some(RequestOutcome::Failed)
            } else if replaced {
                Some(RequestOutcome::Done)
            } else {
                None
            }
        };
        let Some((index, outcome)) = self
            .pending
            .iter()
            .enumerate()
            .find_map(|(i, p)| outcome(p).map(|o| (i, o)))
        else {
            return;
        };
        let request = self.pending.remove(index);
        self.acknowledge(request.request_id, outcome);
    }

    fn acknowledge(&mut self, request_id: u64, outcome: RequestOutcome) {
        if let Some(entry) = self.recent.iter_mut().find(|(r, _)| *r == request_id) {
            entry.1 = Some(outcome);
        }
        self.last_ack = (request_id, outcome);
        self.reports.push(Report::Acknowledged {
            request_id,
            outcome,
        });
        self.changed();
    }
}

fn wire_state(slot: &Slot) -> ServiceState {
    match slot.phase {
        Phase::Running { .. } => ServiceState::Running,
        Phase::Failed => ServiceState::Failed,
        Phase::Stopped => ServiceState::Stopped,
        Phase::Stopping { .. } => ServiceState::Restarting,
        Phase::Down if slot.ever_spawned => ServiceState::Restarting,
        Phase::Starting { .. } if slot.restarts > 0 => ServiceState::Restarting,
        Phase::Down | Phase::Starting { .. } => ServiceState::Starting,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use shared_types::config::{Config, RestartStrategies};

    const MS: Duration = Duration::from_millis(1);

    /// A lifecycle with the default configuration but `max_restarts`, and a clock.
    struct Harness {
        life: Lifecycle,
        now: Instant,
        next_pid: u32,
        beats: u64,
    }

    fn config(max_restarts: u32) -> OrchestratorConfig {
        let mut config = Config::load(None).unwrap().main.orchestrator;
        config.max_restarts = max_restarts;
        config.heartbeat_timeout_ms = 1000;
        config.start_timeout_ms = 5000;
        config.shutdown_timeout_ms = 2000;
        config.strategy = RestartStrategies {
            servo: RestartStrategy::OneForOne,
            planner: RestartStrategy::OneForOne,
            interpreter: RestartStrategy::RestForOne,
            fieldbus: RestartStrategy::OneForOne,
        };
        config
    }

    impl Harness {
        fn new(max_restarts: u32) -> Self {
            Self {
                life: Lifecycle::new(&config(max_restarts), 1),
                now: Instant::now(),
                next_pid: 100,
                beats: 0,
            }
        }

        /// Advances the clock, ticks, and carries out the spawns; returns the other actions.
        fn tick(&mut self, by: Duration) -> Vec<Action> {
            self.now += by;
            self.life.tick(self.now);
            let mut others = Vec::new();
            while let Some(action) = self.life.next_action() {
                match action {
                    Action::Spawn(service) => {
                        self.next_pid += 1;
                        self.life.spawned(service, self.next_pid, self.now);
                    }
                    other => others.push(other),
                }
            }
            others
        }

        fn pid(&self, service: Service) -> u32 {
            self.life.status().service(service).pid
        }

        fn state(&self, service: Service) -> ServiceState {
            ServiceState::from_wire(self.life.status().service(service).state)
        }

        /// Every service with a process sends a heartbeat, except `silent`.
        fn beat_all_but(&mut self, silent: &[Service]) {
            self.beats += 1;
            for service in Service::START_ORDER {
                let pid = self.pid(service);
                if pid != 0 && !silent.contains(&service) {
                    let mut health = beat(service, pid);
                    health.heartbeat = self.beats;
                    self.life.health(&health, self.now);
                }
            }
        }

        /// Ticks and beats until all four run.
        fn start_all(&mut self) {
            for _ in 0..8 {
                self.tick(MS);
                self.beat_all_but(&[]);
            }
            assert_eq!(self.life.status().all_running, 1, "{:?}", self.life);
        }
    }

    fn beat(service: Service, pid: u32) -> ServiceHealth {
        ServiceHealth {
            pid,
            service: service as u8,
            reserved: [0; 3],
            started_unix_ms: 0,
            published_ns: 0,
            heartbeat: 1,
            period_ns: 1_000_000,
            stats: Default::default(),
        }
    }

    #[test]
    fn starts_one_service_at_a_time_in_order_once_the_previous_beats() {
        let mut h = Harness::new(5);
        h.tick(MS);
        assert_ne!(h.pid(Service::Servo), 0);
        assert_eq!(h.pid(Service::Planner), 0);
        h.tick(MS);
        assert_eq!(h.pid(Service::Planner), 0, "servo has not beaten yet");
        assert_eq!(h.state(Service::Servo), ServiceState::Starting);
        h.beat_all_but(&[]);
        h.tick(MS);
        assert_ne!(h.pid(Service::Planner), 0);
        assert_eq!(h.state(Service::Servo), ServiceState::Running);
        assert!(h.life.take_reports().contains(&Report::Ready {
            service: Service::Servo,
            pid: h.pid(Service::Servo)
        }));
        h.start_all();
    }

    #[test]
    fn a_crash_restarts_only_that_service_under_one_for_one() {
        let mut h = Harness::new(5);
        h.start_all();
        let before = Service::START_ORDER.map(|s| h.pid(s));
        h.life.exited(Service::Planner, Exit::Signal(9), h.now);
        assert_eq!(h.state(Service::Planner), ServiceState::Restarting);
        assert!(h.tick(MS).is_empty());
        h.beat_all_but(&[]);
        h.tick(MS);
        let after = Service::START_ORDER.map(|s| h.pid(s));
        assert_ne!(after[1], before[1]);
        assert_eq!(
            [after[0], after[2], after[3]],
            [before[0], before[2], before[3]]
        );
        let status = h.life.status();
        assert_eq!(status.service(Service::Planner).restarts, 1);
        assert_eq!(status.service(Service::Planner).signal, 9);
        assert_eq!(status.all_running, 1);
        assert_eq!(status.safe_stop, 0);
    }

    #[test]
    fn rest_for_one_stops_the_later_services_and_starts_them_again_in_order() {
        let mut h = Harness::new(5);
        h.start_all();
        let fieldbus = h.pid(Service::Fieldbus);
        h.life.exited(Service::Interpreter, Exit::Code(101), h.now);
        assert_eq!(
            h.tick(MS),
            vec![Action::Terminate(Service::Fieldbus)],
            "nothing spawned while the fieldbus stops"
        );
        assert_eq!(h.pid(Service::Interpreter), 0);
        h.life.exited(Service::Fieldbus, Exit::Code(0), h.now);
        h.tick(MS);
        assert_ne!(h.pid(Service::Interpreter), 0);
        assert_eq!(
            h.pid(Service::Fieldbus),
            0,
            "fieldbus waits for the interpreter"
        );
        h.start_all();
        assert_ne!(h.pid(Service::Fieldbus), fieldbus);
        // The sibling's restart is not a failure of its own.
        let status = h.life.status();
        assert_eq!(status.service(Service::Fieldbus).last_failure, 0);
        assert_eq!(status.service(Service::Fieldbus).restarts, 1);
        assert_eq!(status.service(Service::Interpreter).exit_code, 101);
    }

    #[test]
    fn a_stalled_heartbeat_is_killed_and_handled_as_a_failure() {
        let mut h = Harness::new(5);
        h.start_all();
        let servo = h.pid(Service::Servo);
        // 900 ms of silence is within the deadline.
        for _ in 0..9 {
            assert!(h.tick(100 * MS).is_empty());
            h.beat_all_but(&[Service::Servo]);
        }
        assert_eq!(h.tick(200 * MS), vec![Action::Kill(Service::Servo)]);
        assert!(h.life.take_reports().contains(&Report::Hung {
            service: Service::Servo,
            pid: servo,
            cause: FailureCause::MissedHeartbeat
        }));
        assert!(h.tick(MS).is_empty(), "killed once");
        h.life.exited(Service::Servo, Exit::Signal(9), h.now);
        h.tick(MS);
        assert_ne!(h.pid(Service::Servo), servo);
        let entry = *h.life.status().service(Service::Servo);
        assert_eq!(
            FailureCause::from_wire(entry.last_failure),
            FailureCause::MissedHeartbeat
        );
        assert_eq!(entry.signal, 9);
    }

    #[test]
    fn a_service_that_never_beats_is_killed_after_the_start_timeout() {
        let mut h = Harness::new(5);
        h.tick(MS);
        assert!(h.tick(4999 * MS).is_empty());
        assert_eq!(h.tick(2 * MS), vec![Action::Kill(Service::Servo)]);
        h.life.exited(Service::Servo, Exit::Signal(9), h.now);
        assert_eq!(
            h.life.status().service(Service::Servo).last_failure,
            FailureCause::NotReady as u8
        );
    }

    #[test]
    fn beyond_the_intensity_the_failed_service_is_held_and_the_others_keep_running() {
        let mut h = Harness::new(1);
        h.start_all();
        h.life.exited(Service::Planner, Exit::Signal(9), h.now);
        h.tick(MS);
        h.beat_all_but(&[]);
        h.tick(MS);
        let planner = h.pid(Service::Planner);
        h.life.exited(Service::Planner, Exit::Signal(11), h.now);
        for _ in 0..5 {
            assert!(h.tick(MS).is_empty(), "nothing restarted or stopped");
            h.beat_all_but(&[]);
        }
        assert_eq!(h.pid(Service::Planner), 0, "{planner} not replaced");
        let status = h.life.status();
        assert_eq!(status.safe_stop, 1);
        assert_eq!(status.failed_service(), Some(Service::Planner));
        assert_eq!(
            FailureCause::from_wire(status.failure),
            FailureCause::Signaled
        );
        assert_eq!(status.all_running, 0);
        assert_eq!(status.failures_in_window, 2);
        assert_eq!(
            status.reason(),
            "planner killed by signal 11; 2 failures within 60 s exceed \
             orchestrator.max_restarts = 1"
        );
        assert_eq!(
            ServiceState::from_wire(status.service(Service::Planner).state),
            ServiceState::Failed
        );
        for service in [Service::Servo, Service::Interpreter, Service::Fieldbus] {
            assert_eq!(h.state(service), ServiceState::Running);
        }
        // A later crash of another service is held too (the window is still full).
        h.life.exited(Service::Fieldbus, Exit::Code(1), h.now);
        h.tick(MS);
        assert_eq!(h.state(Service::Fieldbus), ServiceState::Failed);
        assert_eq!(h.life.status().failed_service(), Some(Service::Planner));
    }

    #[test]
    fn a_reset_starts_the_failed_services_and_is_acknowledged_once_they_run() {
        let mut h = Harness::new(0);
        h.start_all();
        h.life.exited(Service::Planner, Exit::Code(3), h.now);
        h.tick(MS);
        assert_eq!(h.life.status().safe_stop, 1);
        h.life.request(&SupervisionRequest::reset(77), h.now);
        assert_eq!(h.life.status().safe_stop, 0);
        h.tick(MS);
        assert_ne!(h.pid(Service::Planner), 0);
        assert_eq!(h.life.status().request_id, 0, "not before it runs");
        h.beat_all_but(&[]);
        h.tick(MS);
        let status = h.life.status();
        assert_eq!(
            (
                status.request_id,
                status.request_outcome,
                status.all_running
            ),
            (77, RequestOutcome::Done as u8, 1)
        );
        // A reset with nothing failed is done at once.
        h.life.request(&SupervisionRequest::reset(78), h.now);
        h.tick(MS);
        assert_eq!(h.life.status().request_id, 78);
    }

    #[test]
    fn a_planned_restart_terminates_respawns_and_acknowledges_without_counting() {
        let mut h = Harness::new(0);
        h.start_all();
        let planner = h.pid(Service::Planner);
        h.life
            .request(&SupervisionRequest::restart(5, Service::Planner), h.now);
        assert_eq!(h.tick(MS), vec![Action::Terminate(Service::Planner)]);
        h.life.exited(Service::Planner, Exit::Code(0), h.now);
        h.tick(MS);
        let new = h.pid(Service::Planner);
        assert!(new != 0 && new != planner);
        assert_eq!(h.life.status().request_id, 0);
        h.beat_all_but(&[]);
        h.tick(MS);
        let status = h.life.status();
        assert_eq!(status.request_id, 5);
        assert_eq!(status.request_outcome, RequestOutcome::Done as u8);
        assert_eq!(status.service(Service::Planner).pid, new);
        assert_eq!(status.service(Service::Planner).restarts, 1);
        assert_eq!(status.service(Service::Planner).last_failure, 0);
        assert_eq!(
            status.safe_stop, 0,
            "max_restarts = 0 and still not a failure"
        );
        // The same request again is answered again, not carried out again.
        h.life
            .request(&SupervisionRequest::restart(5, Service::Planner), h.now);
        assert!(h.tick(MS).is_empty());
        assert_eq!(h.pid(Service::Planner), new);
    }

    #[test]
    fn a_planned_restart_of_the_interpreter_hands_over_to_a_successor() {
        let mut h = Harness::new(0);
        h.start_all();
        let old = h.pid(Service::Interpreter);
        h.life
            .request(&SupervisionRequest::restart(6, Service::Interpreter), h.now);
        assert_eq!(h.tick(MS), vec![Action::HandOver(Service::Interpreter)]);
        assert_eq!(
            h.state(Service::Interpreter),
            ServiceState::Restarting,
            "the old process runs until the successor beats"
        );
        h.life.exited(Service::Interpreter, Exit::Code(0), h.now);
        h.tick(MS);
        let new = h.pid(Service::Interpreter);
        assert!(
            new != 0 && new != old,
            "the successor is the service's process"
        );
        h.beat_all_but(&[]);
        h.tick(MS);
        let status = h.life.status();
        assert_eq!(
            (status.request_id, status.request_outcome),
            (6, RequestOutcome::Done as u8)
        );
        assert_eq!(
            status.service(Service::Fieldbus).restarts,
            0,
            "not rest_for_one"
        );
    }

    #[test]
    fn restarting_the_failed_service_by_hand_ends_the_safe_stop() {
        let mut h = Harness::new(0);
        h.start_all();
        h.life.exited(Service::Servo, Exit::Signal(6), h.now);
        h.tick(MS);
        assert_eq!(h.life.status().safe_stop, 1);
        h.life
            .request(&SupervisionRequest::restart(8, Service::Servo), h.now);
        assert_eq!(h.life.status().safe_stop, 0);
        h.tick(MS);
        h.beat_all_but(&[]);
        h.tick(MS);
        let status = h.life.status();
        assert_eq!((status.request_id, status.all_running), (8, 1));
    }

    #[test]
    fn a_process_ignoring_sigterm_is_killed_after_the_grace_period() {
        let mut h = Harness::new(5);
        h.start_all();
        h.life
            .request(&SupervisionRequest::restart(9, Service::Servo), h.now);
        assert_eq!(h.tick(MS), vec![Action::Terminate(Service::Servo)]);
        for _ in 0..19 {
            assert!(h.tick(100 * MS).is_empty());
            h.beat_all_but(&[]);
        }
        assert!(h.tick(99 * MS).is_empty());
        assert_eq!(h.tick(2 * MS), vec![Action::Kill(Service::Servo)]);
        h.life.exited(Service::Servo, Exit::Signal(9), h.now);
        h.tick(MS);
        assert_eq!(h.state(Service::Servo), ServiceState::Restarting);
        assert_eq!(h.life.status().service(Service::Servo).last_failure, 0);
    }

    #[test]
    fn malformed_requests_are_rejected() {
        let mut h = Harness::new(5);
        let mut request = SupervisionRequest::restart(3, Service::Servo);
        request.service = 9;
        h.life.request(&request, h.now);
        let status = h.life.status();
        assert_eq!(
            (status.request_id, status.request_outcome),
            (3, RequestOutcome::Rejected as u8)
        );
        request.kind = 0;
        request.request_id = 4;
        h.life.request(&request, h.now);
        assert_eq!(h.life.status().request_id, 4);
    }

    #[test]
    fn samples_of_an_earlier_process_are_ignored() {
        let mut h = Harness::new(5);
        h.tick(MS);
        let servo = h.pid(Service::Servo);
        h.life.health(&beat(Service::Servo, servo + 1000), h.now);
        assert_eq!(h.state(Service::Servo), ServiceState::Starting);
        h.life.health(&beat(Service::Servo, servo), h.now);
        assert_eq!(h.state(Service::Servo), ServiceState::Running);
    }
}
