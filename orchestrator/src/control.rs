//! Asking a running orchestrator for a planned restart of one service (`rc restart`): the
//! requester's side of the protocol in [`shared_types::health`].

use std::thread;
use std::time::{Duration, Instant};

use iceoryx2::port::subscriber::Subscriber;
use shared_types::bus::{self, Bus, BusError, Ipc};
use shared_types::health::{
    RequestOutcome, STATUS_REPUBLISH_INTERVAL_NS, Service, SupervisionRequest, SupervisionStatus,
    topics,
};
use shared_types::time::monotonic_ns;

/// How long without any status before the orchestrator counts as not running: several
/// re-publication intervals.
const SILENCE_LIMIT: Duration = Duration::from_nanos(5 * STATUS_REPUBLISH_INTERVAL_NS);
/// How often an unanswered request is sent again (the orchestrator ignores repeats).
const RESEND_INTERVAL: Duration = Duration::from_secs(1);
const POLL_PERIOD: Duration = Duration::from_millis(10);

/// A restart request did not succeed.
#[derive(Debug, thiserror::Error)]
pub enum ControlError {
    #[error(transparent)]
    Bus(#[from] BusError),
    #[error(
        "controller '{instance}' is not running (no supervision status within {} ms)",
        SILENCE_LIMIT.as_millis()
    )]
    NotRunning { instance: String },
    #[error("the orchestrator of controller '{instance}' stopped answering")]
    Vanished { instance: String },
    #[error("{service} was not running again within {} s", timeout.as_secs_f64())]
    Timeout { service: Service, timeout: Duration },
    #[error("the orchestrator rejected the restart of {service}")]
    Rejected { service: Service },
    #[error("{service} failed again instead of running{}", reason_suffix(reason))]
    Failed { service: Service, reason: String },
}

fn reason_suffix(reason: &str) -> String {
    if reason.is_empty() {
        String::new()
    } else {
        format!(": {reason}")
    }
}

/// A completed restart.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Restarted {
    /// The process replaced (0 if the service had none, e.g. it had failed).
    pub old_pid: u32,
    /// The new process, running.
    pub new_pid: u32,
}

/// Asks the orchestrator of controller `instance` to replace `service`'s process and waits up
/// to `timeout` for the new process to run.
pub fn restart(
    instance: &str,
    service: Service,
    timeout: Duration,
) -> Result<Restarted, ControlError> {
    let bus = Bus::new(instance, "rcrestart")?;
    // Subscribed before the request goes out, so the acknowledgement cannot be missed.
    let statuses = bus.subscriber::<SupervisionStatus>(topics::SUPERVISION_STATUS)?;
    let control = bus.publisher::<SupervisionRequest>(topics::SUPERVISION_CONTROL)?;
    let start = Instant::now();
    let first = loop {
        if let Some(status) = next_status(&statuses)? {
            break status;
        }
        if start.elapsed() > SILENCE_LIMIT {
            return Err(ControlError::NotRunning {
                instance: instance.to_string(),
            });
        }
        thread::sleep(POLL_PERIOD);
    };
    let old_pid = first.service(service).pid;
    let request = SupervisionRequest::restart(request_id(), service);
    let deadline = Instant::now() + timeout;
    let mut sent_at: Option<Instant> = None;
    let mut heard_at = Instant::now();
    loop {
        let now = Instant::now();
        if sent_at.is_none_or(|at| now.duration_since(at) >= RESEND_INTERVAL) {
            bus::publish(&control, request)?;
            sent_at = Some(now);
        }
        while let Some(status) = next_status(&statuses)? {
            heard_at = now;
            if status.request_id == request.request_id {
                return answer(service, old_pid, &status);
            }
        }
        if now.duration_since(heard_at) > SILENCE_LIMIT {
            return Err(ControlError::Vanished {
                instance: instance.to_string(),
            });
        }
        if now >= deadline {
            return Err(ControlError::Timeout { service, timeout });
        }
        thread::sleep(POLL_PERIOD);
    }
}

/// The outcome of the restart of `service` from its acknowledgement.
fn answer(
    service: Service,
    old_pid: u32,
    status: &SupervisionStatus,
) -> Result<Restarted, ControlError> {
    match RequestOutcome::from_wire(status.request_outcome) {
        RequestOutcome::Done => Ok(Restarted {
            old_pid,
            new_pid: status.service(service).pid,
        }),
        RequestOutcome::Failed => Err(ControlError::Failed {
            service,
            reason: status.reason().to_string(),
        }),
        RequestOutcome::None | RequestOutcome::Rejected => Err(ControlError::Rejected { service }),
    }
}

/// The next status sample waiting, if any.
fn next_status(
    statuses: &Subscriber<Ipc, SupervisionStatus, ()>,
) -> Result<Option<SupervisionStatus>, BusError> {
    let sample = statuses.receive().map_err(|e| BusError {
        action: "receive on",
        service: topics::SUPERVISION_STATUS.to_string(),
        detail: format!("{e:?}"),
    })?;
    Ok(sample.map(|s| *s.payload()))
}

/// A request id unique to this process and moment: the pid in the upper half, never 0.
fn request_id() -> u64 {
    (u64::from(std::process::id()) << 32) | (monotonic_ns() & 0xFFFF_FFFF) | 1
}
