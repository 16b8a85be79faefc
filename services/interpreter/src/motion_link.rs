//! The interpreter's side of the planner connection: numbered motion commands that are
//! re-sent until the planner acknowledges them, the jobs in flight, and the planner's
//! per-job events turned into updates for the commands they belong to.

use shared_types::ipc::{JOB_EVENTS, MotionCommand, MotionStatus, RefusalReason};

/// Time after which an unacknowledged command is sent again.
const RESEND_MS: u64 = 20;
/// Commands that may wait for acknowledgement at once.
const PENDING_CAPACITY: usize = 64;

/// A job's state changed (from a planner event, or because the planner was lost).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct JobUpdate {
    pub job: u32,
    pub cmd_id: u16,
    pub par_seq: u8,
    pub command_type: u16,
    pub state: u8,
    pub code: u16,
    /// Why an ERROR, where the code does not tell.
    pub reason: RefusalReason,
}

/// A job in flight.
#[derive(Debug, Clone, Copy, serde::Serialize, serde::Deserialize)]
struct Job {
    job: u32,
    cmd_id: u16,
    par_seq: u8,
    command_type: u16,
}

/// A change of the planner that the interpreter must act on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PlannerEvent {
    /// A new planner instance appeared while nothing was in flight (a restart at rest): it
    /// only needs the current override.
    Replaced,
    /// A new planner instance appeared: the old one died with our jobs (a fault).
    Restarted,
    /// No status for longer than the planner timeout while jobs were in flight (a fault).
    Silent,
}

/// Commands to the planner and the jobs they started.
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
pub struct MotionLink {
    issuer: u64,
    next_seq: u64,
    next_job: u32,
    pending: Vec<(MotionCommand, u64)>,
    jobs: Vec<Job>,
    planner_instance: u64,
    last_event: u64,
    last_status_ms: u64,
    timeout_ms: u64,
    silent_reported: bool,
}

impl MotionLink {
    /// `issuer` identifies this interpreter instance; `job_capacity` bounds jobs in flight.
    pub fn new(issuer: u64, job_capacity: usize, timeout_ms: u64) -> Self {
        Self {
            issuer,
            next_seq: 1,
            next_job: 1,
            pending: Vec::with_capacity(PENDING_CAPACITY),
            jobs: Vec::with_capacity(job_capacity),
            planner_instance: 0,
            last_event: 0,
            last_status_ms: 0,
            timeout_ms,
            silent_reported: false,
        }
    }

    /// Gives the pending commands and the jobs their start-up capacity again (after the
    /// link was restored from a snapshot).
    pub fn reserve_capacity(&mut self, job_capacity: usize) {
        self.pending
            .reserve(PENDING_CAPACITY.saturating_sub(self.pending.len()));
        self.jobs
            .reserve(job_capacity.saturating_sub(self.jobs.len()));
    }

    /// This interpreter instance.
    pub fn issuer(&self) -> u64 {
        self.issuer
    }

    /// Numbers `command` and queues it for sending; returns its job number, or `None` when
    /// too many commands or jobs are outstanding. `owner` = (CmdID, ParSeq, command type)
    /// of the SRCI command whose response the job's events update (`None`: no response).
    pub fn submit(
        &mut self,
        mut command: MotionCommand,
        owner: Option<(u16, u8, u16)>,
        now_ms: u64,
        out: &mut Vec<MotionCommand>,
    ) -> Option<u32> {
        if self.pending.len() >= PENDING_CAPACITY
            || (owner.is_some() && self.jobs.len() >= self.jobs.capacity())
        {
            return None;
        }
        let job = self.next_job;
        self.next_job = self.next_job.wrapping_add(1).max(1);
        command.seq = self.next_seq;
        command.issuer = self.issuer;
        command.job = if owner.is_some() { job } else { 0 };
        self.next_seq += 1;
        if let Some((cmd_id, par_seq, command_type)) = owner {
            self.jobs.push(Job {
                job,
                cmd_id,
                par_seq,
                command_type,
            });
        }
        self.pending.push((command, now_ms));
        out.push(command);
        Some(job)
    }

    /// Takes a planner status: acknowledgements and events. A fault ends every job in
    /// flight with ERROR `fault_code` (reported through `updates`).
    pub fn on_status(
        &mut self,
        status: &MotionStatus,
        now_ms: u64,
        fault_code: u16,
        updates: &mut Vec<JobUpdate>,
    ) -> Option<PlannerEvent> {
        self.last_status_ms = now_ms;
        self.silent_reported = false;
        let mut fault = None;
        if status.instance != self.planner_instance {
            if self.planner_instance != 0 {
                let lost = !self.jobs.is_empty() || !self.pending.is_empty();
                fault = Some(if lost {
                    PlannerEvent::Restarted
                } else {
                    PlannerEvent::Replaced
                });
                self.fail_all(fault_code, updates);
                // The new planner must not execute what the old one was given.
                self.pending.clear();
            }
            self.planner_instance = status.instance;
            self.last_event = status.event_head.saturating_sub(JOB_EVENTS as u64);
        }
        if status.acked_issuer == self.issuer {
            self.pending.retain(|(c, _)| c.seq > status.acked_seq);
        }
        let first =
            (self.last_event + 1).max(status.event_head.saturating_sub(JOB_EVENTS as u64 - 1));
        for number in first..=status.event_head {
            let e = status.events[(number % JOB_EVENTS as u64) as usize];
            if e.number != number {
                continue;
            }
            if let Some(i) = self.jobs.iter().position(|j| j.job == e.job) {
                let j = self.jobs[i];
                updates.push(JobUpdate {
                    job: j.job,
                    cmd_id: j.cmd_id,
                    par_seq: j.par_seq,
                    command_type: j.command_type,
                    state: e.state,
                    code: e.code,
                    reason: RefusalReason::from_wire(e.reason),
                });
                if shared_types::srci::message::state::is_final(e.state) {
                    self.jobs.swap_remove(i);
                }
            }
        }
        self.last_event = self.last_event.max(status.event_head);
        fault
    }

    /// Periodic work: re-sends unacknowledged commands and detects a silent planner.
    pub fn poll(
        &mut self,
        now_ms: u64,
        fault_code: u16,
        out: &mut Vec<MotionCommand>,
        updates: &mut Vec<JobUpdate>,
    ) -> Option<PlannerEvent> {
        for (command, sent) in &mut self.pending {
            if now_ms.saturating_sub(*sent) >= RESEND_MS {
                *sent = now_ms;
                out.push(*command);
            }
        }
        let silent = now_ms.saturating_sub(self.last_status_ms) > self.timeout_ms;
        if silent && !self.silent_reported && (!self.jobs.is_empty() || !self.pending.is_empty()) {
            self.silent_reported = true;
            self.fail_all(fault_code, updates);
            self.pending.clear();
            return Some(PlannerEvent::Silent);
        }
        None
    }

    fn fail_all(&mut self, code: u16, updates: &mut Vec<JobUpdate>) {
        for j in self.jobs.drain(..) {
            updates.push(JobUpdate {
                job: j.job,
                cmd_id: j.cmd_id,
                par_seq: j.par_seq,
                command_type: j.command_type,
                state: shared_types::srci::message::state::ERROR,
                code,
                reason: RefusalReason::None,
            });
        }
    }

    /// Forgets the jobs of the SRCI session (interface reset); the planner is told to halt
    /// separately, and its events for these jobs are ignored from now on.
    pub fn forget_jobs(&mut self) {
        self.jobs.clear();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use shared_types::ipc::{JobEvent, MotionCommandKind};
    use shared_types::srci::message::state;

    fn status(instance: u64, acked: u64, events: &[(u64, u32, u8)]) -> MotionStatus {
        let mut s = MotionStatus::initial(instance, 1.0);
        s.acked_seq = acked;
        s.acked_issuer = 7;
        for &(n, job, st) in events {
            s.events[(n % JOB_EVENTS as u64) as usize] = JobEvent {
                number: n,
                job,
                state: st,
                reason: 0,
                code: 0,
            };
            s.event_head = n;
        }
        s
    }

    #[test]
    fn resends_until_acknowledged_and_maps_events_to_commands() {
        let mut link = MotionLink::new(7, 4, 100);
        let mut out = Vec::new();
        let mut updates = Vec::new();
        link.on_status(&status(1, 0, &[]), 0, 0x6C02, &mut updates);
        let job = link
            .submit(
                MotionCommand::new(MotionCommandKind::MoveAxes),
                Some((3, 1, 2101)),
                0,
                &mut out,
            )
            .unwrap();
        assert_eq!(out.len(), 1);
        link.poll(25, 0x6C02, &mut out, &mut updates);
        assert_eq!(out.len(), 2, "re-sent after 20 ms");
        link.on_status(
            &status(1, 1, &[(1, job, state::ACTIVE), (2, job, state::DONE)]),
            30,
            0x6C02,
            &mut updates,
        );
        assert_eq!(updates.len(), 2);
        assert_eq!((updates[1].cmd_id, updates[1].state), (3, state::DONE));
        out.clear();
        link.poll(100, 0x6C02, &mut out, &mut updates);
        assert!(out.is_empty(), "acknowledged commands are not re-sent");
    }

    /// A link to planner instance 1 with one move (CmdID 3) sent.
    fn one_move_in_flight() -> (MotionLink, Vec<MotionCommand>, Vec<JobUpdate>) {
        let mut link = MotionLink::new(7, 4, 100);
        let (mut out, mut updates) = (Vec::new(), Vec::new());
        link.on_status(&status(1, 0, &[]), 0, 0x6C02, &mut updates);
        link.submit(
            MotionCommand::new(MotionCommandKind::MoveAxes),
            Some((3, 1, 2101)),
            0,
            &mut out,
        );
        (link, out, updates)
    }

    #[test]
    fn planner_restart_fails_jobs_in_flight() {
        let (mut link, _, mut updates) = one_move_in_flight();
        let fault = link.on_status(&status(2, 0, &[]), 10, 0x6C02, &mut updates);
        assert_eq!(fault, Some(PlannerEvent::Restarted));
        assert_eq!((updates[0].state, updates[0].code), (state::ERROR, 0x6C02));
    }

    #[test]
    fn a_planner_restart_at_rest_loses_nothing() {
        let mut link = MotionLink::new(1, 4, 100);
        let mut updates = Vec::new();
        assert_eq!(
            link.on_status(&status(1, 0, &[]), 0, 0x6C02, &mut updates),
            None
        );
        let event = link.on_status(&status(2, 0, &[]), 10, 0x6C02, &mut updates);
        assert_eq!(event, Some(PlannerEvent::Replaced));
        assert!(updates.is_empty());
    }

    #[test]
    fn silent_planner_fails_jobs_once() {
        let (mut link, mut out, mut updates) = one_move_in_flight();
        assert_eq!(
            link.poll(150, 0x6C02, &mut out, &mut updates),
            Some(PlannerEvent::Silent)
        );
        assert_eq!(link.poll(160, 0x6C02, &mut out, &mut updates), None);
        assert_eq!(updates.len(), 1);
    }
}
