//! The cycle master: runs the RobotTask at a fixed period over a transport.
//!
//! Deadlines are absolute (start + n × period), so the period does not drift with the
//! exchange time; a cycle that overruns its deadline is counted and the schedule restarts
//! from now rather than bursting to catch up. A zero period runs back to back (tests).

use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use crate::ClientError;
use crate::engine::RobotTask;
use crate::transport::Transport;

/// Runs the engine cyclically over a transport.
#[derive(Debug)]
pub struct CycleRunner<T: Transport> {
    task: RobotTask,
    transport: T,
    period: Duration,
    epoch: Instant,
    next_deadline: Instant,
    tx: Vec<u8>,
    rx: Vec<u8>,
    have_rx: bool,
    overruns: u64,
}

impl<T: Transport> CycleRunner<T> {
    /// A runner with the engine's cycle time as its period.
    pub fn new(mut task: RobotTask, transport: T) -> Self {
        let period = task.options().cycle_time;
        let tx = vec![0; task.options().length_plc_to_rob];
        let rx = vec![0; task.options().length_rob_to_plc];
        let epoch = Instant::now();
        let unix_ms = SystemTime::now()
            .duration_since(UNIX_EPOCH)
            .map_or(0, |d| d.as_millis() as u64);
        task.set_wall_clock_origin(unix_ms);
        Self {
            task,
            transport,
            period,
            epoch,
            next_deadline: epoch,
            tx,
            rx,
            have_rx: false,
            overruns: 0,
        }
    }

    /// One cycle: the engine builds the telegram from the last reply, the transport
    /// exchanges it, then the runner sleeps until the next deadline.
    pub fn step(&mut self) -> Result<(), ClientError> {
        let now = self.epoch.elapsed();
        let rx = if self.have_rx { &self.rx[..] } else { &[][..] };
        self.task.cycle(now, rx, &mut self.tx)?;
        self.transport.exchange(&self.tx, &mut self.rx)?;
        self.have_rx = true;
        self.wait_for_deadline();
        Ok(())
    }

    fn wait_for_deadline(&mut self) {
        if self.period.is_zero() {
            return;
        }
        self.next_deadline += self.period;
        let now = Instant::now();
        if now >= self.next_deadline {
            self.overruns += 1;
            self.next_deadline = now;
        } else {
            std::thread::sleep(self.next_deadline - now);
        }
    }

    /// Runs cycles until `done` returns true; fails on an engine fault or after `timeout`.
    pub fn run_until(
        &mut self,
        mut done: impl FnMut(&mut RobotTask) -> bool,
        timeout: Duration,
    ) -> Result<(), ClientError> {
        let start = Instant::now();
        loop {
            self.step()?;
            if done(&mut self.task) {
                return Ok(());
            }
            if let Some(fault) = self.task.fault() {
                return Err(ClientError::Fault(fault));
            }
            if start.elapsed() >= timeout {
                return Err(ClientError::Timeout(timeout));
            }
        }
    }

    /// Runs cycles for `duration` (at least one).
    pub fn run_for(&mut self, duration: Duration) -> Result<(), ClientError> {
        let start = Instant::now();
        loop {
            self.step()?;
            if let Some(fault) = self.task.fault() {
                return Err(ClientError::Fault(fault));
            }
            if start.elapsed() >= duration {
                return Ok(());
            }
        }
    }

    /// Continues over a new connection after the old one was lost: the engine resumes its
    /// session (see [`RobotTask::link_restored`]); the old connection's last reply is
    /// forgotten.
    pub fn reconnect(&mut self, transport: T) {
        self.transport = transport;
        self.have_rx = false;
        self.task.link_restored();
    }

    pub fn task(&self) -> &RobotTask {
        &self.task
    }

    pub fn task_mut(&mut self) -> &mut RobotTask {
        &mut self.task
    }

    pub fn transport(&self) -> &T {
        &self.transport
    }

    pub fn transport_mut(&mut self) -> &mut T {
        &mut self.transport
    }

    /// Cycles whose work ended after their deadline.
    pub fn overruns(&self) -> u64 {
        self.overruns
    }

    /// Time since the runner started (the engine's time base).
    pub fn elapsed(&self) -> Duration {
        self.epoch.elapsed()
    }
}
