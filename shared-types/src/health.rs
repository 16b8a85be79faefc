//! Service health and supervision: what each service process reports about its cyclic loop,
//! what the orchestrator reports about the services, and how others ask it for a restart.
//!
//! # Topics
//!
//! | topic | payload | from → to |
//! | --- | --- | --- |
//! | `health/<service>` (`health/servo`, `health/planner`, `health/interpreter`, `health/fieldbus`) | [`ServiceHealth`] | each service, every [`HEALTH_PUBLISH_INTERVAL_NS`] → orchestrator, `rc status` |
//! | [`topics::SUPERVISION_STATUS`] | [`SupervisionStatus`] | orchestrator, on every change and every [`STATUS_REPUBLISH_INTERVAL_NS`] → interpreter, `rc restart`, `rc status` |
//! | [`topics::SUPERVISION_CONTROL`] | [`SupervisionRequest`] | interpreter (GroupReset), `rc restart` → orchestrator |
//!
//! # Heartbeat and cycle statistics
//! A service loop owns a [`HealthReporter`] and calls [`HealthReporter::beat`] once per pass of
//! its loop (including passes that only waited) and [`HealthReporter::record`] with the time its
//! work was due whenever it did timed work. The heartbeat counter of [`ServiceHealth`] counts
//! the passes: the orchestrator kills a service whose counter stops advancing for longer than
//! `orchestrator.heartbeat_timeout_ms`. Lateness is "when the work was done minus when it was
//! due", per service:
//!
//! | service | due | nominal period (overrun when lateness ≥ it) |
//! | --- | --- | --- |
//! | servo | its tick's absolute deadline | `servo.period_us` |
//! | planner | the servo tick (feedback) it answers | `servo.period_us` |
//! | interpreter | the PLC telegram's arrival at the fieldbus | `fieldbus.reply_timeout_ms` |
//! | fieldbus | the PLC telegram's arrival, until its answer is sent | `fieldbus.reply_timeout_ms` |
//!
//! # Supervision protocol
//! The orchestrator publishes a [`SupervisionStatus`] whenever something changes
//! (`generation` increments) and otherwise every [`STATUS_REPUBLISH_INTERVAL_NS`], so a reader
//! that has seen none for a second knows that the orchestrator is gone. Each service has a
//! [`ServiceState`]; `all_running` is true when all four are [`ServiceState::Running`].
//!
//! When more failures than `orchestrator.max_restarts` happen within
//! `orchestrator.restart_window_s` (all services together), the orchestrator stops restarting the failing service
//! (its state becomes [`ServiceState::Failed`]), keeps the others running and sets
//! `safe_stop`, with `failed_service`, `failure` and the readable `reason` naming the service
//! and the cause. The servo holds the arm on its own once the planner's setpoints stop.
//!
//! Requests ([`SupervisionRequest`]) carry a `request_id` chosen by the requester, unique and
//! non-zero (e.g. `pid << 32 | counter`). The orchestrator answers each request once it is
//! complete, in a status whose `request_id` is that id and whose `request_outcome` says how it
//! ended; the affected services' `pid`s in that status are the new processes. Re-publications
//! carry the same `request_id` until the next request is answered. A requester
//! subscribes to the status *before* it sends, reads every status sample (acknowledgements of
//! other requesters may come in between) and may re-send the same request after a while: a
//! repeated id is not acted upon twice but acknowledged again.
//! - [`RequestKind::Restart`] (`rc restart <service>`): a planned restart of one service:
//!   SIGTERM, SIGKILL after `orchestrator.shutdown_timeout_ms`, respawn, and the
//!   acknowledgement once the new process beats. Not counted against the restart intensity.
//!   A failed service is simply started again; the safe stop ends when no service is failed
//!   any more (the intensity history is kept: only a reset forgets it).
//! - [`RequestKind::Reset`] (GroupReset): every failed service is started again, the restart
//!   intensity starts afresh and `safe_stop` is cleared; acknowledged once all of them run
//!   (at once when none had failed). The interpreter can finish GroupReset when the
//!   acknowledgement says [`RequestOutcome::Done`] and `all_running` is true.

use core::fmt;
use core::str::FromStr;

use iceoryx2::port::publisher::Publisher;
use iceoryx2::prelude::*;

use crate::bus::{Bus, BusError, Ipc, publish};
use crate::time::{monotonic_ns, unix_ms};

/// How often a [`HealthReporter`] publishes.
pub const HEALTH_PUBLISH_INTERVAL_NS: u64 = 100_000_000;
/// How often the orchestrator re-publishes an unchanged [`SupervisionStatus`].
pub const STATUS_REPUBLISH_INTERVAL_NS: u64 = 200_000_000;

/// Topic names of supervision (the health topics are [`Service::health_topic`]).
pub mod topics {
    /// orchestrator → all: [`super::SupervisionStatus`].
    pub const SUPERVISION_STATUS: &str = "supervision/status";
    /// requesters → orchestrator: [`super::SupervisionRequest`].
    pub const SUPERVISION_CONTROL: &str = "supervision/control";
}

/// One service process of the controller (`rc service <name>`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[repr(u8)]
pub enum Service {
    /// The interpolation clock and the (simulated) drives.
    Servo = 0,
    /// Kinematics, motion queue and trajectories.
    Planner = 1,
    /// The SRCI server: state machine, commands and responses.
    Interpreter = 2,
    /// The fieldbus transport towards the PLC.
    Fieldbus = 3,
}

/// Number of services; the length of per-service arrays indexed by [`Service::index`].
pub const SERVICES: usize = 4;

/// `failed_service` value when no service failed.
pub const NO_SERVICE: u8 = 0xFF;

impl Service {
    /// Every service in start order: each one's consumers of its topics come up after it, and
    /// the fieldbus comes last so the PLC can only connect to a complete controller.
    /// Shutdown runs in the reverse order.
    pub const START_ORDER: [Service; SERVICES] = [
        Service::Servo,
        Service::Planner,
        Service::Interpreter,
        Service::Fieldbus,
    ];

    /// The name used on the command line (`rc service <name>`), in logs and in the pid file.
    pub const fn name(self) -> &'static str {
        match self {
            Service::Servo => "servo",
            Service::Planner => "planner",
            Service::Interpreter => "interpreter",
            Service::Fieldbus => "fieldbus",
        }
    }

    /// The topic this service publishes its [`ServiceHealth`] on.
    pub const fn health_topic(self) -> &'static str {
        match self {
            Service::Servo => "health/servo",
            Service::Planner => "health/planner",
            Service::Interpreter => "health/interpreter",
            Service::Fieldbus => "health/fieldbus",
        }
    }

    /// Position in [`Service::START_ORDER`] (and in per-service arrays).
    pub const fn index(self) -> usize {
        self as usize
    }

    /// Decodes the wire value (`u8`); `None` for anything else.
    pub fn from_wire(v: u8) -> Option<Self> {
        Self::START_ORDER.get(usize::from(v)).copied()
    }
}

impl fmt::Display for Service {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// A name that is not one of [`Service::START_ORDER`].
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("unknown service '{0}' (known: servo, planner, interpreter, fieldbus)")]
pub struct UnknownService(pub String);

impl FromStr for Service {
    type Err = UnknownService;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Service::START_ORDER
            .into_iter()
            .find(|service| service.name() == s)
            .ok_or_else(|| UnknownService(s.to_string()))
    }
}

/// Cycle statistics of a loop since its start.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, ZeroCopySend)]
#[type_name("rc::CycleSummary")]
pub struct CycleSummary {
    /// Cycles with timed work (lateness samples).
    pub cycles: u64,
    /// Lateness percentiles, ns; at most 1/16 above the true value (histogram resolution),
    /// never above `lateness_max_ns`.
    pub lateness_p50_ns: u64,
    pub lateness_p99_ns: u64,
    /// Exact largest lateness, ns.
    pub lateness_max_ns: u64,
    /// Cycles whose lateness reached the nominal period.
    pub overruns: u64,
}

/// Sub-buckets per power of two: the histogram's relative resolution is 1/16.
const SUB_BUCKETS: u64 = 16;
const SUB_BITS: u32 = SUB_BUCKETS.trailing_zeros();
/// Values from 2^MAX_EXPONENT ns (about 69 s) on share the last bucket.
const MAX_EXPONENT: u32 = 36;
const BUCKETS: usize = (SUB_BUCKETS + (MAX_EXPONENT - SUB_BITS) as u64 * SUB_BUCKETS) as usize;

/// Lateness statistics of a cyclic loop: a log-spaced fixed-bucket histogram (16 buckets per
/// power of two, exact below 16 ns, up to about 69 s), the exact maximum and the overruns.
/// Recording is a few integer operations; nothing allocates after construction.
#[derive(Clone)]
pub struct CycleStats {
    period_ns: u64,
    counts: [u64; BUCKETS],
    cycles: u64,
    max_ns: u64,
    overruns: u64,
}

impl fmt::Debug for CycleStats {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("CycleStats")
            .field("period_ns", &self.period_ns)
            .field("summary", &self.summary())
            .finish()
    }
}

/// The histogram bucket of `v`.
fn bucket_of(v: u64) -> usize {
    if v < SUB_BUCKETS {
        return v as usize;
    }
    let exponent = (63 - v.leading_zeros()).min(MAX_EXPONENT);
    if exponent == MAX_EXPONENT {
        return BUCKETS - 1;
    }
    let mantissa = (v >> (exponent - SUB_BITS)) & (SUB_BUCKETS - 1);
    (SUB_BUCKETS + u64::from(exponent - SUB_BITS) * SUB_BUCKETS + mantissa) as usize
}

/// The largest value that falls into `bucket`.
fn bucket_upper(bucket: usize) -> u64 {
    let b = bucket as u64;
    if b < SUB_BUCKETS {
        return b;
    }
    if bucket == BUCKETS - 1 {
        return u64::MAX;
    }
    let exponent = (b - SUB_BUCKETS) / SUB_BUCKETS + u64::from(SUB_BITS);
    let mantissa = (b - SUB_BUCKETS) % SUB_BUCKETS;
    let width = 1u64 << (exponent - u64::from(SUB_BITS));
    (1u64 << exponent) + (mantissa + 1) * width - 1
}

impl CycleStats {
    /// Empty statistics of a loop whose work is due within `period_ns` (0: no overruns).
    pub fn new(period_ns: u64) -> Self {
        Self {
            period_ns,
            counts: [0; BUCKETS],
            cycles: 0,
            max_ns: 0,
            overruns: 0,
        }
    }

    /// The nominal period.
    pub fn period_ns(&self) -> u64 {
        self.period_ns
    }

    /// Records one cycle's lateness.
    pub fn record(&mut self, lateness_ns: u64) {
        self.counts[bucket_of(lateness_ns)] += 1;
        self.cycles += 1;
        self.max_ns = self.max_ns.max(lateness_ns);
        if self.period_ns > 0 && lateness_ns >= self.period_ns {
            self.overruns += 1;
        }
    }

    /// The lateness at quantile `q` (0..=1): the upper bound of the bucket holding the
    /// `ceil(q·n)`-th smallest sample, capped at the maximum; 0 without samples.
    pub fn quantile(&self, q: f64) -> u64 {
        if self.cycles == 0 {
            return 0;
        }
        let rank = ((q.clamp(0.0, 1.0) * self.cycles as f64).ceil() as u64).clamp(1, self.cycles);
        let mut seen = 0;
        for (bucket, &count) in self.counts.iter().enumerate() {
            seen += count;
            if seen >= rank {
                return bucket_upper(bucket).min(self.max_ns);
            }
        }
        self.max_ns
    }

    /// Cycles, p50, p99, max and overruns.
    pub fn summary(&self) -> CycleSummary {
        CycleSummary {
            cycles: self.cycles,
            lateness_p50_ns: self.quantile(0.5),
            lateness_p99_ns: self.quantile(0.99),
            lateness_max_ns: self.max_ns,
            overruns: self.overruns,
        }
    }
}

/// service → orchestrator, `rc status`: one service process's liveness and cycle statistics
/// (topic [`Service::health_topic`]).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq, ZeroCopySend)]
#[type_name("rc::ServiceHealth")]
pub struct ServiceHealth {
    /// The process id.
    pub pid: u32,
    /// [`Service`] as `u8`.
    pub service: u8,
    pub reserved: [u8; 3],
    /// Wall-clock start of the process, ms since the UNIX epoch.
    pub started_unix_ms: u64,
    /// CLOCK_MONOTONIC time of publication, ns.
    pub published_ns: u64,
    /// Passes of the service loop; stops advancing when the loop is stuck.
    pub heartbeat: u64,
    /// Nominal period: the time within which each cycle's work is due.
    pub period_ns: u64,
    /// Lateness statistics since the process started.
    pub stats: CycleSummary,
}

/// Feeds a service loop's heartbeat and cycle statistics and publishes them on the service's
/// health topic at most every [`HEALTH_PUBLISH_INTERVAL_NS`]. Neither call blocks; they
/// allocate nothing except inside iceoryx2's publish (one small allocation per sample, ten
/// times a second).
pub struct HealthReporter {
    publisher: Publisher<Ipc, ServiceHealth, ()>,
    health: ServiceHealth,
    stats: CycleStats,
    next_publish_ns: u64,
}

impl fmt::Debug for HealthReporter {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("HealthReporter")
            .field("health", &self.health)
            .finish()
    }
}

impl HealthReporter {
    /// A reporter for `service` whose cycle work is due within `period_ns`. Create it after
    /// the service's other ports: its first heartbeat tells the orchestrator that the service
    /// is ready.
    pub fn new(bus: &Bus, service: Service, period_ns: u64) -> Result<Self, BusError> {
        Ok(Self {
            publisher: bus.publisher::<ServiceHealth>(service.health_topic())?,
            health: ServiceHealth {
                pid: std::process::id(),
                service: service as u8,
                reserved: [0; 3],
                started_unix_ms: unix_ms(),
                published_ns: 0,
                heartbeat: 0,
                period_ns,
                stats: CycleSummary::default(),
            },
            stats: CycleStats::new(period_ns),
            next_publish_ns: 0,
        })
    }

    /// Records the lateness of work that was due at `due_ns` (CLOCK_MONOTONIC) and is done now.
    pub fn record(&mut self, due_ns: u64) {
        self.stats.record(monotonic_ns().saturating_sub(due_ns));
    }

    /// One pass of the service loop: advances the heartbeat and publishes if it is time.
    pub fn beat(&mut self) -> Result<(), BusError> {
        self.health.heartbeat += 1;
        let now = monotonic_ns();
        if now < self.next_publish_ns {
            return Ok(());
        }
        self.next_publish_ns = now.saturating_add(HEALTH_PUBLISH_INTERVAL_NS);
        self.health.published_ns = now;
        self.health.stats = self.stats.summary();
        publish(&self.publisher, self.health)
    }
}

/// Where a service is in its life cycle, as the orchestrator sees it.
#[repr(u8)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ServiceState {
    /// Not yet running: waiting for its turn to be spawned, or spawned and not yet beating.
    Starting = 0,
    /// Beating.
    Running = 1,
    /// Being stopped and started again (after a failure, a request, or with another service).
    Restarting = 2,
    /// Not restarted any more (restart intensity exceeded): holding in a safe stop.
    Failed = 3,
    /// Stopped with the controller.
    Stopped = 4,
}

impl ServiceState {
    /// Decodes the wire value; unknown values read as `Failed`.
    pub fn from_wire(v: u8) -> Self {
        match v {
            0 => Self::Starting,
            1 => Self::Running,
            2 => Self::Restarting,
            4 => Self::Stopped,
            _ => Self::Failed,
        }
    }
}

/// Why a service process ended without being asked to.
#[repr(u8)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FailureCause {
    None = 0,
    /// It exited by itself (`exit_code`).
    Exited = 1,
    /// It was ended by a signal (`signal`), e.g. a crash or a `kill -9`.
    Signaled = 2,
    /// Its heartbeat stopped advancing for longer than `orchestrator.heartbeat_timeout_ms`;
    /// it was killed.
    MissedHeartbeat = 3,
    /// It did not beat within `orchestrator.start_timeout_ms` of its start; it was killed.
    NotReady = 4,
    /// Its process could not be spawned.
    SpawnFailed = 5,
}

impl FailureCause {
    /// Decodes the wire value; unknown values read as `None`.
    pub fn from_wire(v: u8) -> Self {
        match v {
            1 => Self::Exited,
            2 => Self::Signaled,
            3 => Self::MissedHeartbeat,
            4 => Self::NotReady,
            5 => Self::SpawnFailed,
            _ => Self::None,
        }
    }
}

impl fmt::Display for FailureCause {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Self::None => "no failure",
            Self::Exited => "exited",
            Self::Signaled => "killed by a signal",
            Self::MissedHeartbeat => "missed its heartbeat deadline",
            Self::NotReady => "not ready in time",
            Self::SpawnFailed => "could not be spawned",
        })
    }
}

/// The orchestrator's view of one service in a [`SupervisionStatus`].
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq, ZeroCopySend)]
#[type_name("rc::ServiceSupervision")]
pub struct ServiceSupervision {
    /// The running process; 0 when there is none.
    pub pid: u32,
    /// [`ServiceState`] as `u8`.
    pub state: u8,
    /// [`FailureCause`] of its last unrequested end.
    pub last_failure: u8,
    pub reserved: [u8; 2],
    /// Exit code of that end; -1 when it did not exit by itself.
    pub exit_code: i32,
    /// Signal of that end (also the SIGKILL of a missed heartbeat); 0 when none.
    pub signal: i32,
    /// Times this service was started again (requested restarts included).
    pub restarts: u32,
}

impl ServiceSupervision {
    /// A service before its first start.
    pub const fn new() -> Self {
        Self {
            pid: 0,
            state: ServiceState::Starting as u8,
            last_failure: FailureCause::None as u8,
            reserved: [0; 2],
            exit_code: -1,
            signal: 0,
            restarts: 0,
        }
    }
}

impl Default for ServiceSupervision {
    fn default() -> Self {
        Self::new()
    }
}

/// Capacity of [`SupervisionStatus::reason`].
pub const REASON_CAPACITY: usize = 120;

/// orchestrator → interpreter, `rc restart`, `rc status`: the state of supervision (topic
/// [`topics::SUPERVISION_STATUS`]); see the module documentation for the protocol.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq, ZeroCopySend)]
#[type_name("rc::SupervisionStatus")]
pub struct SupervisionStatus {
    /// Increments with every change of the content below (not with a re-publication).
    pub generation: u64,
    /// CLOCK_MONOTONIC time of publication, ns.
    pub published_ns: u64,
    /// The request this status acknowledges (the last completed one); 0 = none yet.
    pub request_id: u64,
    /// The orchestrator's process id.
    pub orchestrator_pid: u32,
    /// [`RequestOutcome`] of `request_id`, as `u8`.
    pub request_outcome: u8,
    /// 1 when every service is [`ServiceState::Running`].
    pub all_running: u8,
    /// 1 when the restart intensity was exceeded and the failed service is not restarted.
    pub safe_stop: u8,
    /// The service whose failure caused the safe stop ([`Service`] as `u8`), or [`NO_SERVICE`].
    pub failed_service: u8,
    /// [`FailureCause`] of that failure, as `u8`.
    pub failure: u8,
    pub reserved: [u8; 3],
    /// Failures within the restart window when the safe stop began.
    pub failures_in_window: u32,
    /// Per service, indexed by [`Service::index`].
    pub services: [ServiceSupervision; SERVICES],
    /// Length of the text in `reason`.
    pub reason_len: u8,
    /// Why the controller is in a safe stop, readable (UTF-8), e.g. "planner killed by signal
    /// 9; 2 failures within 60 s exceed orchestrator.max_restarts = 1".
    pub reason: [u8; REASON_CAPACITY],
    pub reserved2: [u8; 7],
}

impl SupervisionStatus {
    /// Nothing started, no failure, no request.
    pub const fn new(orchestrator_pid: u32) -> Self {
        Self {
            generation: 0,
            published_ns: 0,
            request_id: 0,
            orchestrator_pid,
            request_outcome: RequestOutcome::None as u8,
            all_running: 0,
            safe_stop: 0,
            failed_service: NO_SERVICE,
            failure: FailureCause::None as u8,
            reserved: [0; 3],
            failures_in_window: 0,
            services: [ServiceSupervision::new(); SERVICES],
            reason_len: 0,
            reason: [0; REASON_CAPACITY],
            reserved2: [0; 7],
        }
    }

    /// The entry of `service`.
    pub fn service(&self, service: Service) -> &ServiceSupervision {
        &self.services[service.index()]
    }

    /// The service that caused the safe stop, if any.
    pub fn failed_service(&self) -> Option<Service> {
        Service::from_wire(self.failed_service)
    }

    /// Why the safe stop began ("" when there is none).
    pub fn reason(&self) -> &str {
        let len = usize::from(self.reason_len).min(REASON_CAPACITY);
        core::str::from_utf8(&self.reason[..len]).unwrap_or("")
    }

    /// Sets `reason` to `text`, cut at a character boundary to fit.
    pub fn set_reason(&mut self, text: &str) {
        let mut len = text.len().min(REASON_CAPACITY);
        while !text.is_char_boundary(len) {
            len -= 1;
        }
        self.reason = [0; REASON_CAPACITY];
        self.reason[..len].copy_from_slice(&text.as_bytes()[..len]);
        // At most REASON_CAPACITY (120).
        self.reason_len = len as u8;
    }
}

/// What a [`SupervisionRequest`] asks for.
#[repr(u8)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RequestKind {
    /// Replace the process of `service` now (planned; not counted as a failure).
    Restart = 1,
    /// Start every failed service again and leave the safe stop (GroupReset).
    Reset = 2,
}

impl RequestKind {
    /// Decodes the wire value; `None` for anything else.
    pub fn from_wire(v: u8) -> Option<Self> {
        match v {
            1 => Some(Self::Restart),
            2 => Some(Self::Reset),
            _ => None,
        }
    }
}

/// How a request ended.
#[repr(u8)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RequestOutcome {
    /// No request acknowledged yet.
    None = 0,
    /// Done: the services it concerned run (new processes).
    Done = 1,
    /// Not understood (unknown kind or service); nothing was done.
    Rejected = 2,
    /// A service it concerned failed again instead of running.
    Failed = 3,
}

impl RequestOutcome {
    /// Decodes the wire value; unknown values read as `Rejected`.
    pub fn from_wire(v: u8) -> Self {
        match v {
            0 => Self::None,
            1 => Self::Done,
            3 => Self::Failed,
            _ => Self::Rejected,
        }
    }
}

/// requester → orchestrator: a restart or reset (topic [`topics::SUPERVISION_CONTROL`]).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq, ZeroCopySend)]
#[type_name("rc::SupervisionRequest")]
pub struct SupervisionRequest {
    /// Chosen by the requester: non-zero and unique (e.g. `pid << 32 | counter`).
    pub request_id: u64,
    /// [`RequestKind`] as `u8`.
    pub kind: u8,
    /// For [`RequestKind::Restart`]: the [`Service`] as `u8`.
    pub service: u8,
    pub reserved: [u8; 6],
}

impl SupervisionRequest {
    /// A planned restart of `service`.
    pub const fn restart(request_id: u64, service: Service) -> Self {
        Self {
            request_id,
            kind: RequestKind::Restart as u8,
            service: service as u8,
            reserved: [0; 6],
        }
    }

    /// A reset: start every failed service again.
    pub const fn reset(request_id: u64) -> Self {
        Self {
            request_id,
            kind: RequestKind::Reset as u8,
            service: NO_SERVICE,
            reserved: [0; 6],
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::alloc_count::{CountingAllocator, count};
    use proptest::prelude::*;

    #[global_allocator]
    static ALLOCATOR: CountingAllocator = CountingAllocator;

    #[test]
    fn names_and_wire_values_round_trip() {
        for service in Service::START_ORDER {
            assert_eq!(service.name().parse::<Service>(), Ok(service));
            assert_eq!(Service::from_wire(service as u8), Some(service));
            assert_eq!(Service::START_ORDER[service.index()], service);
            assert!(service.health_topic().ends_with(service.name()));
        }
        assert!("robot".parse::<Service>().is_err());
        assert_eq!(Service::from_wire(NO_SERVICE), None);
    }

    #[test]
    fn buckets_are_contiguous_and_cover_their_values() {
        for bucket in 1..BUCKETS - 1 {
            assert_eq!(bucket_upper(bucket - 1) + 1, lowest_of(bucket), "{bucket}");
            assert_eq!(bucket_of(bucket_upper(bucket)), bucket);
            assert_eq!(bucket_of(lowest_of(bucket)), bucket);
        }
        assert_eq!(bucket_of(u64::MAX), BUCKETS - 1);
        assert_eq!(bucket_of(1 << MAX_EXPONENT), BUCKETS - 1);
    }

    fn lowest_of(bucket: usize) -> u64 {
        if bucket == 0 {
            0
        } else {
            bucket_upper(bucket - 1) + 1
        }
    }

    #[test]
    fn constant_lateness_is_reported_exactly() {
        let mut stats = CycleStats::new(1_000_000);
        for _ in 0..1000 {
            stats.record(123_456);
        }
        let s = stats.summary();
        assert_eq!(
            (
                s.cycles,
                s.lateness_p50_ns,
                s.lateness_p99_ns,
                s.lateness_max_ns
            ),
            (1000, 123_456, 123_456, 123_456)
        );
        assert_eq!(s.overruns, 0);
    }

    #[test]
    fn uniform_lateness_percentiles() {
        let mut stats = CycleStats::new(0);
        // 1..=10000 µs, each once.
        for us in 1..=10_000u64 {
            stats.record(us * 1000);
        }
        let within = |value: u64, exact: u64| {
            value >= exact && value as f64 <= exact as f64 * (1.0 + 1.0 / 16.0)
        };
        let s = stats.summary();
        assert!(within(s.lateness_p50_ns, 5_000_000), "{s:?}");
        assert!(within(s.lateness_p99_ns, 9_900_000), "{s:?}");
        assert_eq!(s.lateness_max_ns, 10_000_000);
        assert_eq!(s.overruns, 0, "period 0: no overruns");
    }

    #[test]
    fn a_rare_outlier_shows_in_max_and_overruns_not_in_p99() {
        let mut stats = CycleStats::new(1_000_000);
        for _ in 0..999 {
            stats.record(50_000);
        }
        stats.record(30_000_000);
        stats.record(1_000_000);
        let s = stats.summary();
        assert!(
            (50_000..=53_125).contains(&s.lateness_p99_ns),
            "p99 is the bulk's bucket: {s:?}"
        );
        assert_eq!(s.lateness_max_ns, 30_000_000);
        assert_eq!(s.overruns, 2, "lateness ≥ period is an overrun");
        assert_eq!(stats.quantile(1.0), 30_000_000);
    }

    #[test]
    fn empty_statistics_are_zero() {
        assert_eq!(CycleStats::new(1).summary(), CycleSummary::default());
    }

    #[test]
    fn recording_and_summarising_allocate_nothing() {
        let mut stats = CycleStats::new(1_000_000);
        let (summary, allocations) = count(|| {
            for i in 0..10_000u64 {
                stats.record(i * 7919 % 3_000_000);
            }
            stats.summary()
        });
        assert_eq!(allocations, 0);
        assert_eq!(summary.cycles, 10_000);
    }

    #[test]
    fn reason_is_cut_at_a_character_boundary() {
        let mut status = SupervisionStatus::new(1);
        status.set_reason(&"ä".repeat(100));
        assert_eq!(status.reason(), "ä".repeat(60));
        status.set_reason("planner exited");
        assert_eq!(status.reason(), "planner exited");
    }

    proptest! {
        /// Every percentile lies at or above the exact one and at most 1/16 above it (or is
        /// the maximum).
        #[test]
        fn quantiles_are_within_the_resolution(
            values in proptest::collection::vec(0u64..60_000_000_000, 1..400),
            q in 0.0f64..=1.0,
        ) {
            let mut stats = CycleStats::new(0);
            for &v in &values {
                stats.record(v);
            }
            let mut sorted = values.clone();
            sorted.sort_unstable();
            let rank = ((q * sorted.len() as f64).ceil() as usize).clamp(1, sorted.len());
            let exact = sorted[rank - 1];
            let reported = stats.quantile(q);
            prop_assert!(reported >= exact, "{reported} < {exact}");
            prop_assert!(
                reported <= *sorted.last().unwrap()
                    && reported as f64 <= exact as f64 * (1.0 + 1.0 / 16.0) + 1.0,
                "{reported} vs {exact}"
            );
        }
    }
}
