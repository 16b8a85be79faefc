//! Time-optimal tables for buffered Cartesian moves, computed off the tick.
//!
//! The executor plans a MoveLinear or MoveCircular in its tick on constant bounds: the
//! survey finds every error before the arm moves, in about a millisecond. The time-optimal
//! table of the same path ([`topp`](crate::topp)) takes tens of milliseconds, longer than the
//! setpoint window the servo holds, so the executor asks a [`Refiner`] for it. The refined
//! plan replaces the buffered one if the move still starts where both were planned from and
//! has not entered a setpoint window sent to the servo; otherwise the move runs on its
//! constant bounds. Lines buffered behind a running move get their table; a line a standing
//! arm would start waits a bounded time for it (see the executor's
//! [`table_wait`](crate::executor::table_wait)). Every request is answered, with or without
//! a table, so that nothing waits for a table that will not come.
//!
//! [`ThreadRefiner`] plans on a thread of its own (the planner process); [`InlineRefiner`]
//! plans when asked (the executor's unit tests, where the tick has no deadline).

use std::collections::VecDeque;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::mpsc::{self, Receiver, SyncSender, TryRecvError, TrySendError};
use std::time::Duration;

use shared_types::config::{Config, JointLimitsRad};
use shared_types::ipc::{AXES, MotionCommand};

use crate::joint_move::move_limits;
use crate::kinematics::{ArmGeometry, Kinematics};
use crate::linear_move::{Arm, LinearMove, LinearPlan, TcpLimits};
use crate::profile::Profile;
use crate::topp::{JerkBound, PathTimer};

/// A buffered Cartesian move to be timed by its table.
#[derive(Debug, Clone, Copy)]
pub struct TableRequest {
    /// The executor's number of the request: job numbers come from the PLC and recur.
    pub id: u64,
    /// The joints the move was planned from.
    pub start: [f64; AXES],
    /// The move's command.
    pub command: MotionCommand,
}

/// The answer to a [`TableRequest`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Refined {
    /// The request's number.
    pub id: u64,
    /// The plan from the request's start, timed by its table; `None` if the move has none
    /// (the constant bounds are as fast, or the move cannot be planned: the tick reported
    /// that already).
    pub plan: Option<LinearPlan>,
}

/// Plans buffered Cartesian moves with their tables.
pub trait Refiner: Send {
    /// Asks for the table of `request`: whether it will be answered (without room the move
    /// keeps its constant bounds).
    fn request(&mut self, request: &TableRequest) -> bool;
    /// A refined plan, if one is ready.
    fn take(&mut self) -> Option<Refined>;
    /// The requests numbered up to `through` are of no use any more (their moves ended):
    /// they are neither planned nor handed out.
    fn forget(&mut self, through: u64);
}

/// What timing a Cartesian move by its table needs: the robot, its limits and a timer.
struct TablePlanner {
    kinematics: Kinematics,
    geometry: Option<ArmGeometry>,
    limits: JointLimitsRad,
    tcp: TcpLimits,
    reserve: f64,
    timer: PathTimer,
}

impl TablePlanner {
    /// For the robot and planner settings of `config`.
    fn new(config: &Config) -> Self {
        Self {
            kinematics: Kinematics::new(&config.robot.kinematics),
            geometry: ArmGeometry::new(&config.robot.kinematics).ok(),
            limits: config.robot.limits_rad(),
            tcp: TcpLimits::from_config(&config.robot.cartesian),
            reserve: config.main.planner.override_reserve,
            timer: PathTimer::reachability(JerkBound::Joints),
        }
    }

    /// The answer to `request`.
    fn answer(&self, request: &TableRequest) -> Refined {
        Refined {
            id: request.id,
            plan: self.plan(request),
        }
    }

    /// The plan of `request` timed by its table, if it has one.
    fn plan(&self, request: &TableRequest) -> Option<LinearPlan> {
        let limits = move_limits(&self.limits, &request.command);
        let arm = Arm {
            kinematics: &self.kinematics,
            geometry: self.geometry.as_ref()?,
            joints: &limits,
            tcp: &self.tcp,
            timer: Some(&self.timer),
        };
        let plan = LinearMove::plan(request.start, &request.command, &arm, self.reserve).ok()?;
        match plan {
            LinearPlan::Move(m) if matches!(m.timing().profile, Profile::Table(_)) => Some(plan),
            _ => None,
        }
    }
}

/// Plans each request when it is made.
pub struct InlineRefiner {
    planner: TablePlanner,
    ready: VecDeque<Refined>,
}

impl InlineRefiner {
    /// Keeps up to `capacity` refined plans until they are taken.
    pub fn new(config: &Config, capacity: usize) -> Self {
        Self {
            planner: TablePlanner::new(config),
            ready: VecDeque::with_capacity(capacity),
        }
    }
}

impl Refiner for InlineRefiner {
    fn request(&mut self, request: &TableRequest) -> bool {
        // Beyond the capacity the move keeps its constant bounds: no allocation here.
        let room = self.ready.len() < self.ready.capacity();
        if room {
            self.ready.push_back(self.planner.answer(request));
        }
        room
    }

    fn take(&mut self) -> Option<Refined> {
        self.ready.pop_front()
    }

    fn forget(&mut self, through: u64) {
        self.ready.retain(|refined| refined.id > through);
    }
}

/// Plans on a thread of its own, fed and drained through bounded channels (their slots
/// are allocated when they are made; sending and receiving in the tick never block).
pub struct ThreadRefiner {
    requests: SyncSender<TableRequest>,
    results: Receiver<Refined>,
    /// Requests up to this number are skipped (shared with the thread).
    forgotten: Arc<AtomicU64>,
    /// Room of each channel.
    capacity: usize,
    /// The thread ended (logged once).
    ended: bool,
}

impl ThreadRefiner {
    /// Starts the planning thread with room for `capacity` requests and as many results.
    /// It ends when the refiner is dropped.
    pub fn spawn(config: &Config, capacity: usize) -> std::io::Result<Self> {
        let (requests, inbox) = mpsc::sync_channel::<TableRequest>(capacity);
        let (outbox, results) = mpsc::sync_channel::<Refined>(capacity);
        let planner = TablePlanner::new(config);
        let forgotten = Arc::new(AtomicU64::new(0));
        let skip = Arc::clone(&forgotten);
        std::thread::Builder::new()
            .name("planner-tables".into())
            .spawn(move || {
                // Inherited from the tick's thread: planning must never compete with it.
                if let Err(errno) = shared_types::realtime::make_background() {
                    tracing::warn!(%errno, "the table planning thread keeps the tick's scheduling");
                }
                serve(&planner, &inbox, &outbox, &skip);
            })?;
        Ok(Self {
            requests,
            results,
            forgotten,
            capacity,
            ended: false,
        })
    }
}

/// How long the planning thread sleeps when it has nothing to do or no room for a result.
const IDLE_WAIT: Duration = Duration::from_millis(2);

/// The planning thread's loop. It never blocks on a channel: a thread blocked in `recv` or
/// `send` registers with the channel under a lock, which the tick's `try_send`/`try_recv`
/// would then take too, and a preempted background thread holding it would stall the tick.
fn serve(
    planner: &TablePlanner,
    inbox: &Receiver<TableRequest>,
    outbox: &SyncSender<Refined>,
    forgotten: &AtomicU64,
) {
    loop {
        let request = match inbox.try_recv() {
            Ok(request) => request,
            Err(TryRecvError::Empty) => {
                std::thread::sleep(IDLE_WAIT);
                continue;
            }
            Err(TryRecvError::Disconnected) => return,
        };
        if request.id <= forgotten.load(Ordering::Relaxed) {
            continue;
        }
        let mut refined = planner.answer(&request);
        loop {
            match outbox.try_send(refined) {
                Ok(()) => break,
                Err(TrySendError::Full(back)) => {
                    refined = back;
                    std::thread::sleep(IDLE_WAIT);
                }
                Err(TrySendError::Disconnected(_)) => return,
            }
        }
    }
}

impl Refiner for ThreadRefiner {
    fn request(&mut self, request: &TableRequest) -> bool {
        match self.requests.try_send(*request) {
            Ok(()) => true,
            // Busy with as many lines as a sequence holds: this one keeps constant bounds.
            Err(TrySendError::Full(_)) => false,
            Err(TrySendError::Disconnected(_)) => {
                if !self.ended {
                    self.ended = true;
                    tracing::error!("the table planning thread ended; lines keep constant bounds");
                }
                false
            }
        }
    }

    fn take(&mut self) -> Option<Refined> {
        let forgotten = self.forgotten.load(Ordering::Relaxed);
        // Bounded by the channel's capacity: it holds no more results.
        for _ in 0..=self.capacity {
            match self.results.try_recv() {
                Ok(refined) if refined.id <= forgotten => {}
                Ok(refined) => return Some(refined),
                Err(_) => return None,
            }
        }
        None
    }

    fn forget(&mut self, through: u64) {
        self.forgotten.fetch_max(through, Ordering::Relaxed);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Translation3, UnitQuaternion};
    use shared_types::ipc::MotionCommandKind;
    use shared_types::pose;
    use std::time::{Duration, Instant};

    fn test_config() -> Config {
        Config::load(None).expect("embedded configuration")
    }

    /// A line of 0.19 m from the robot's home position.
    fn request(config: &Config) -> TableRequest {
        let start = config.robot.home_deg.map(f64::to_radians);
        let kinematics = Kinematics::new(&config.robot.kinematics);
        let here = kinematics.flange(&start);
        let there = Translation3::new(0.1, -0.15, -0.05) * here * UnitQuaternion::identity();
        let mut command = MotionCommand::new(MotionCommandKind::MoveLinear);
        command.job = 7;
        command.pose = pose::pose(&there);
        TableRequest {
            id: 3,
            start,
            command,
        }
    }

    #[test]
    fn the_thread_returns_the_plan_the_inline_refiner_makes() {
        let config = test_config();
        let r = request(&config);
        let mut inline = InlineRefiner::new(&config, 4);
        inline.request(&r);
        let expected = inline.take().expect("a table for a 0.2 m line");
        assert!(inline.take().is_none());
        let mut threaded = ThreadRefiner::spawn(&config, 4).expect("thread");
        threaded.request(&r);
        let deadline = Instant::now() + Duration::from_secs(60);
        let refined = loop {
            if let Some(refined) = threaded.take() {
                break refined;
            }
            assert!(Instant::now() < deadline, "no refined plan in 60 s");
            std::thread::sleep(Duration::from_millis(5));
        };
        assert_eq!(refined, expected);
        assert_eq!(refined.id, 3);
        assert_eq!(refined.plan.map(|p| *p.start()), Some(r.start));
    }

    #[test]
    fn asking_and_taking_in_the_tick_allocates_nothing() {
        let config = test_config();
        let r = request(&config);
        let mut threaded = ThreadRefiner::spawn(&config, 4).expect("thread");
        let deadline = Instant::now() + Duration::from_secs(60);
        let before = crate::topp::tests::allocations();
        let mut taken = 0;
        for _ in 0..3 {
            threaded.request(&r);
        }
        while taken < 3 {
            if threaded.take().is_some() {
                taken += 1;
            }
            assert!(
                Instant::now() < deadline,
                "only {taken} refined plans in 60 s"
            );
        }
        // The counter is this thread's: the planning thread's own work is not in it.
        assert_eq!(crate::topp::tests::allocations(), before);
    }

    #[test]
    fn forgotten_requests_are_neither_planned_nor_handed_out() {
        let config = test_config();
        let r = request(&config);
        let mut inline = InlineRefiner::new(&config, 4);
        let mut threaded = ThreadRefiner::spawn(&config, 4).expect("thread");
        for id in 1..=3 {
            let numbered = TableRequest { id, ..r };
            inline.request(&numbered);
            threaded.request(&numbered);
        }
        inline.forget(2);
        threaded.forget(2);
        assert_eq!(inline.take().map(|t| t.id), Some(3));
        assert!(inline.take().is_none());
        let deadline = Instant::now() + Duration::from_secs(60);
        loop {
            if let Some(refined) = threaded.take() {
                assert_eq!(refined.id, 3);
                break;
            }
            assert!(Instant::now() < deadline, "no refined plan in 60 s");
            std::thread::sleep(Duration::from_millis(5));
        }
    }

    #[test]
    fn a_move_without_a_table_is_answered_without_one() {
        let config = test_config();
        let mut r = request(&config);
        // Where it stands: nothing to time.
        r.command.pose = pose::pose(&Kinematics::new(&config.robot.kinematics).flange(&r.start));
        let mut inline = InlineRefiner::new(&config, 4);
        inline.request(&r);
        assert_eq!(inline.take(), Some(Refined { id: 3, plan: None }));
        assert!(inline.take().is_none());
    }
}
