//! The executor against a simulated servo that follows every setpoint exactly.

use super::*;
use shared_types::config::JointLimitsRad;
use shared_types::ipc::{JOB_EVENTS, JobEvent};

use crate::test_support::{assert_jerk_within, assert_jerk_within_limits, assert_within_limits};

const DT: f64 = 1e-3;
const ISSUER: u64 = 77;

fn config() -> Config {
    Config::load(None).expect("embedded configuration")
}

/// A servo that applies the first point of each window, and the commands it was sent.
struct Rig {
    executor: Executor,
    feedback: ServoFeedback,
    limits: JointLimitsRad,
    /// The latest setpoint window, if any.
    window: Option<ServoSetpoint>,
    /// Every point the servo applied.
    trace: Vec<JointPoint>,
    events: Vec<JobEvent>,
    seen: u64,
    seq: u64,
}

impl Rig {
    fn new() -> Self {
        Self::with(Executor::new(&config(), 0xABCD))
    }

    /// A rig around `executor`.
    fn with(executor: Executor) -> Self {
        let cfg = config();
        let home = cfg.robot.home_deg.map(f64::to_radians);
        let mut rig = Self {
            executor,
            feedback: ServoFeedback {
                tick: 100,
                ..ServoFeedback::at_rest(5, home, DriveState::Holding, 1_000_000)
            },
            limits: cfg.robot.limits_rad(),
            window: None,
            trace: Vec::new(),
            events: Vec::new(),
            seen: 0,
            seq: 0,
        };
        rig.step(&[]);
        assert!(
            rig.window.is_some(),
            "an enabled arm at rest is commanded at once"
        );
        rig
    }

    fn command(&mut self, kind: MotionCommandKind, job: u32) -> MotionCommand {
        self.seq += 1;
        let mut c = MotionCommand::new(kind);
        c.seq = self.seq;
        c.issuer = ISSUER;
        c.job = job;
        c
    }

    /// A rig with job 1 (to [`target_a`]) and job 2 (home) sent, job 1 run past `progress` %.
    fn running(progress: f64) -> Self {
        let mut rig = Self::new();
        let a = rig.move_to(1, target_a());
        let b = rig.move_to(2, home());
        rig.step(&[a, b]);
        rig.run_until(10_000, |r| r.executor.status().active_progress > progress);
        rig
    }

    /// Sends ChangeSpeedOverride `fraction` as job `job` and steps once.
    fn set_override(&mut self, job: u32, fraction: f64) {
        let mut c = self.command(MotionCommandKind::Override, job);
        c.override_fraction = fraction;
        self.step(&[c]);
    }

    fn move_to(&mut self, job: u32, target: [f64; AXES]) -> MotionCommand {
        let mut c = self.command(MotionCommandKind::MoveAxes, job);
        c.joints_rad = target;
        c
    }

    /// A MoveLinear of the TCP (with [`tool`]) from where the arm stands now, shifted by
    /// `shift` (m) and turned by `turn` (rotation vector, rad).
    fn line_by(&mut self, job: u32, shift: [f64; 3], turn: [f64; 3]) -> MotionCommand {
        let mut c = self.command(MotionCommandKind::MoveLinear, job);
        c.tool = tool();
        c.pose = shifted(&tcp_of(&self.feedback.q), shift, turn);
        c
    }

    /// Every applied point since `from` puts the TCP (with [`tool`]) on the segment from
    /// `start` to `target`, within 0.01 mm.
    fn check_on_tcp_line(&self, from: usize, start: [f64; 6], target: [f64; 6]) {
        let (a, b) = (pose::isometry(start), pose::isometry(target));
        let (pa, pb) = (a.translation.vector, b.translation.vector);
        let length = (pb - pa).norm();
        for p in &self.trace[from..] {
            let d = tcp_of(&p.q).translation.vector - pa;
            let along = d.dot(&(pb - pa)) / length;
            let off = (d - (pb - pa) * (along / length)).norm();
            assert!(off < 1e-5, "{off} m off the line");
            assert!(
                along > -1e-9 && along < length + 1e-9,
                "off the segment: {along}"
            );
        }
    }

    /// One planner step for the current feedback, then the servo executes the next tick.
    fn step(&mut self, commands: &[MotionCommand]) {
        self.window = self.executor.step(&self.feedback, commands);
        self.collect_events();
        self.feedback.tick += 1;
        if let Some(w) = &self.window {
            assert_eq!(w.first_tick, self.feedback.tick);
            assert_eq!(w.planner_instance, 0xABCD);
            self.apply(w.points[0]);
        }
    }

    /// One step without commands: the new window goes on with what the last one held for
    /// the ticks ahead (what the servo has been sent never changes by itself).
    fn step_keeping_the_window(&mut self) {
        let sent = self.window.expect("a window");
        self.step(&[]);
        let window = self.window.expect("a window");
        let shift = usize::try_from(window.first_tick - sent.first_tick).unwrap();
        let kept = SETPOINT_WINDOW - shift;
        assert!(
            window.points[..kept] == sent.points[shift..],
            "the window of tick {} changed what was sent",
            window.first_tick
        );
    }

    /// The servo executes the next tick from the last window, without a planner step.
    fn step_without_planner(&mut self) {
        let w = self.window.expect("a window");
        self.feedback.tick += 1;
        let i = usize::try_from(self.feedback.tick - w.first_tick).unwrap();
        self.apply(w.points[i]);
    }

    fn apply(&mut self, p: JointPoint) {
        self.feedback.q = p.q;
        self.feedback.qd = p.qd;
        self.feedback.state = DriveState::Following as u8;
        self.trace.push(p);
    }

    fn collect_events(&mut self) {
        let s = self.executor.status();
        assert!(s.event_head - self.seen <= JOB_EVENTS as u64, "events lost");
        for n in self.seen + 1..=s.event_head {
            let e = s.events[(n % JOB_EVENTS as u64) as usize];
            assert_eq!(e.number, n);
            self.events.push(e);
        }
        self.seen = s.event_head;
    }

    /// Sends GroupInterrupt as job `job`, which interrupts the running job `running`, and
    /// checks that the arm then stands for 100 ticks.
    fn interrupt_and_stand(&mut self, job: u32, running: u32) {
        let interrupt = self.command(MotionCommandKind::Interrupt, job);
        self.step(&[interrupt]);
        assert_eq!(
            self.states_of(running).last(),
            Some(&(state::INTERRUPTED, code::INTERRUPTED_BY_GROUP_INTERRUPT))
        );
        self.run_until(20_000, |r| r.is_final(job));
        let stood = self.feedback.q;
        for _ in 0..100 {
            self.step(&[]);
        }
        assert_eq!(self.feedback.q, stood);
    }

    fn run_until(&mut self, ticks: usize, done: impl Fn(&Self) -> bool) {
        for _ in 0..ticks {
            if done(self) {
                return;
            }
            self.step(&[]);
        }
        panic!("condition not reached in {ticks} ticks");
    }

    fn final_state(&self, job: u32) -> Option<(u8, u16)> {
        self.events
            .iter()
            .filter(|e| e.job == job)
            .map(|e| (e.state, e.code))
            .find(|(s, _)| state::is_final(*s))
    }

    fn states_of(&self, job: u32) -> Vec<(u8, u16)> {
        self.events
            .iter()
            .filter(|e| e.job == job)
            .map(|e| (e.state, e.code))
            .collect()
    }

    /// Every job of `jobs` ended DONE.
    fn assert_done(&self, jobs: &[u32]) {
        for &job in jobs {
            assert_eq!(self.final_state(job), Some((state::DONE, 0)), "job {job}");
        }
    }

    fn is_final(&self, job: u32) -> bool {
        self.final_state(job).is_some()
    }

    /// Joint position, velocity and acceleration limits on the reported values and on the
    /// finite differences of the applied positions.
    fn check_limits(&self) {
        assert_within_limits(&self.trace, &self.limits, DT);
    }

    /// A stop on a line: the arm stands on the TCP's segment from `start` to `target`,
    /// came there within the limits and `jerk_factor` times the jerk limits.
    fn check_stood_on_tcp_line(&self, start: [f64; 6], target: [f64; 6], jerk_factor: f64) {
        self.check_on_tcp_line(0, start, target);
        self.check_limits();
        assert_jerk_within(&self.trace, &self.limits, DT, jerk_factor);
        assert_eq!(self.trace.last().map(|p| p.qd), Some([0.0; AXES]));
    }

    /// Every applied point since `from` lies on the segment from `start` to `target`.
    fn check_on_line(&self, from: usize, start: [f64; AXES], target: [f64; AXES]) {
        let lead = (0..AXES)
            .max_by(|&a, &b| {
                (target[a] - start[a])
                    .abs()
                    .total_cmp(&(target[b] - start[b]).abs())
            })
            .unwrap();
        for p in &self.trace[from..] {
            let s = (p.q[lead] - start[lead]) / (target[lead] - start[lead]);
            assert!((-1e-12..=1.0 + 1e-12).contains(&s), "off the segment: {s}");
            for i in 0..AXES {
                let expected = start[i] + s * (target[i] - start[i]);
                assert!((p.q[i] - expected).abs() < 1e-9, "joint {i} off the line");
            }
        }
    }
}

/// Whether the running move of `rig` is timed by a table.
fn runs_on_table(rig: &Rig) -> bool {
    match rig.executor.motion.phase {
        Phase::Running(Running { plan, .. }) => {
            matches!(plan.timing().profile, crate::profile::Profile::Table(_))
        }
        phase => panic!("not running: {phase:?}"),
    }
}

fn home() -> [f64; AXES] {
    config().robot.home_deg.map(f64::to_radians)
}

/// The tool of the linear-move tests: 12 cm out along the flange z, tilted.
fn tool() -> [f64; 6] {
    [0.01, 0.0, 0.12, 0.2, -0.1, 0.0]
}

/// The pose (base frame) of the TCP of [`tool`] at the joints `q`.
fn tcp_of(q: &[f64; AXES]) -> nalgebra::Isometry3<f64> {
    Kinematics::new(&config().robot.kinematics).flange(q) * pose::isometry(tool())
}

/// `pose` shifted by `shift` (m) and turned by `turn` (rotation vector in the base frame, rad).
fn shifted(pose: &nalgebra::Isometry3<f64>, shift: [f64; 3], turn: [f64; 3]) -> [f64; 6] {
    use nalgebra::{Translation3, UnitQuaternion, Vector3};
    let rotation = UnitQuaternion::from_scaled_axis(Vector3::from(turn)) * pose.rotation;
    let position = pose.translation.vector + Vector3::from(shift);
    pose::pose(&nalgebra::Isometry3::from_parts(
        Translation3::from(position),
        rotation,
    ))
}

/// A shift and turn of the TCP from home that the arm reaches on a line.
const SHIFT: [f64; 3] = [0.12, -0.15, -0.1];
const TURN: [f64; 3] = [0.2, 0.3, -0.4];

fn target_a() -> [f64; AXES] {
    let h = home();
    [
        h[0] + 1.0,
        h[1] - 0.5,
        h[2] + 0.3,
        h[3],
        h[4] + 0.8,
        h[5] - 2.0,
    ]
}

#[test]
fn a_move_reaches_its_target_exactly_within_the_limits() {
    let mut rig = Rig::new();
    let start = rig.feedback.q;
    let target = target_a();
    let c = rig.move_to(1, target);
    rig.step(&[c]);
    rig.run_until(10_000, |r| r.is_final(1));
    assert_eq!(
        rig.states_of(1),
        vec![(state::BUFFERED, 0), (state::ACTIVE, 0), (state::DONE, 0)]
    );
    assert_eq!(rig.feedback.q, target);
    assert_eq!(rig.trace.last().map(|p| p.qd), Some([0.0; AXES]));
    rig.check_limits();
    rig.check_on_line(0, start, target);
    assert_jerk_within_limits(&rig.trace, &rig.limits, DT);
    let s = rig.executor.status();
    assert_eq!((s.active_job, s.queued_jobs, s.moving), (0, 0, false));
    assert_eq!(s.acked_seq, c.seq);
    assert_eq!(s.acked_issuer, ISSUER);
    assert_eq!(s.instance, 0xABCD);
    assert_eq!(
        s.flange_pose,
        Kinematics::new(&config().robot.kinematics).flange_pose(&target)
    );
}

#[test]
fn all_joints_start_and_arrive_together() {
    let mut rig = Rig::new();
    let target = target_a();
    let c = rig.move_to(1, target);
    rig.step(&[c]);
    rig.run_until(10_000, |r| r.is_final(1));
    let moving: Vec<usize> = (0..AXES).filter(|&i| target[i] != home()[i]).collect();
    let first = |i: usize| rig.trace.iter().position(|p| p.qd[i] != 0.0).unwrap();
    let last = |i: usize| rig.trace.iter().rposition(|p| p.qd[i] != 0.0).unwrap();
    for &i in &moving {
        assert_eq!(first(i), first(moving[0]));
        assert_eq!(last(i), last(moving[0]));
    }
    // The slowest joint sets the pace: some joint reaches its velocity limit.
    let peak = (0..AXES)
        .map(|i| {
            rig.trace.iter().map(|p| p.qd[i].abs()).fold(0.0, f64::max) / rig.limits.velocity[i]
        })
        .fold(0.0, f64::max);
    assert!(peak > 0.999, "{peak}");
}

#[test]
fn moves_run_in_order_with_an_exact_stop_between() {
    let mut rig = Rig::new();
    let mut second = home();
    second[0] -= 0.2;
    let a = rig.move_to(1, target_a());
    let b = rig.move_to(2, second);
    rig.step(&[a, b]);
    assert_eq!(rig.executor.status().queued_jobs, 1);
    rig.run_until(10_000, |r| r.is_final(1));
    assert_eq!(rig.feedback.q, target_a());
    assert!(!rig.is_final(2));
    rig.run_until(10_000, |r| r.is_final(2));
    assert_eq!(rig.feedback.q, second);
    assert_eq!(rig.final_state(2), Some((state::DONE, 0)));
    rig.check_limits();
}

#[test]
fn override_changes_keep_the_path_and_the_limits() {
    let mut rig = Rig::new();
    let start = rig.feedback.q;
    let target = target_a();
    let c = rig.move_to(1, target);
    rig.step(&[c]);
    rig.run_until(10_000, |r| r.executor.status().active_progress > 30.0);
    rig.set_override(2, 0.3);
    assert_eq!(rig.final_state(2), Some((state::DONE, 0)));
    assert_eq!(rig.executor.status().override_fraction, 0.3);
    rig.run_until(10_000, |r| r.executor.status().active_progress > 60.0);
    rig.set_override(3, 1.0);
    rig.run_until(10_000, |r| r.is_final(1));
    assert_eq!(rig.final_state(1), Some((state::DONE, 0)));
    assert_eq!(rig.feedback.q, target);
    rig.check_limits();
    rig.check_on_line(0, start, target);
}

#[test]
fn override_zero_halts_on_the_path_and_the_move_stays_active() {
    let mut rig = Rig::new();
    let start = rig.feedback.q;
    // Long enough for the override ramp (only the reserve decelerates it) to halt it.
    let mut target = target_a();
    target[0] = start[0] + 5.0;
    let c = rig.move_to(1, target);
    rig.step(&[c]);
    rig.run_until(10_000, |r| r.executor.status().active_progress > 5.0);
    rig.set_override(2, 0.0);
    rig.run_until(10_000, |r| !r.executor.status().moving);
    let held = rig.feedback.q;
    for _ in 0..500 {
        rig.step(&[]);
    }
    assert_eq!(rig.feedback.q, held);
    let s = rig.executor.status();
    assert_eq!(s.active_job, 1);
    assert!(s.active_progress > 5.0 && s.active_progress < 100.0);
    assert_eq!(
        rig.states_of(1),
        vec![(state::BUFFERED, 0), (state::ACTIVE, 0)]
    );
    rig.set_override(3, 1.0);
    rig.run_until(10_000, |r| r.is_final(1));
    assert_eq!(rig.feedback.q, target);
    rig.check_limits();
    rig.check_on_line(0, start, target);
}

#[test]
fn stop_brakes_on_the_path_within_the_limits_and_aborts_everything() {
    let mut rig = Rig::new();
    let start = rig.feedback.q;
    let target = target_a();
    let a = rig.move_to(1, target);
    let b = rig.move_to(2, home());
    rig.step(&[a, b]);
    rig.run_until(10_000, |r| r.executor.status().active_progress > 50.0);
    assert!(rig.executor.status().constant_velocity || rig.executor.status().decelerating);
    let stop = rig.command(MotionCommandKind::Stop, 3);
    rig.step(&[stop]);
    let abort = (state::ABORTED, code::ABORTED_BY_GROUP_STOP);
    assert_eq!(rig.final_state(1), Some(abort));
    assert_eq!(rig.final_state(2), Some(abort));
    assert!(!rig.is_final(3), "the stop ends only when the arm stands");
    assert!(rig.executor.status().decelerating);
    rig.run_until(10_000, |r| r.is_final(3));
    assert_eq!(rig.final_state(3), Some((state::DONE, 0)));
    assert!(!rig.executor.status().moving);
    assert_ne!(rig.feedback.q, target);
    rig.check_limits();
    rig.check_on_line(0, start, target);
    // Standing: the same position from now on.
    let stood = rig.feedback.q;
    rig.step(&[]);
    assert_eq!(rig.feedback.q, stood);
}

/// GroupStop brakes as fast as the limits allow, whatever the move's rates: a joint move
/// cruising at 30 % of the joint speed and a line at 5 % of the TCP's, with
/// AccelerationRate, DecelerationRate and JerkRate at 10 %, stand as soon as at 100 %,
/// within the limits (they braked at their own rates: the joint move took 950 ticks
/// against 245).
#[test]
fn a_stop_brakes_as_fast_as_the_limits_allow_whatever_the_rates() {
    let stop_ticks = |rate: f64, line: bool| {
        let mut rig = Rig::new();
        let mut c = if line {
            let mut c = rig.line_by(1, SHIFT, [0.0; 3]);
            c.velocity_scale = 0.05;
            c
        } else {
            let mut target = home();
            target[0] += 2.5;
            let mut c = rig.move_to(1, target);
            c.velocity_scale = 0.3;
            c
        };
        (c.acceleration_scale, c.deceleration_scale, c.jerk_scale) = (rate, rate, rate);
        rig.step(&[c]);
        // Halfway: cruising.
        rig.run_until(20_000, |r| r.executor.status().active_progress > 50.0);
        let stop = rig.command(MotionCommandKind::Stop, 2);
        let from = rig.trace.len();
        rig.step(&[stop]);
        rig.run_until(10_000, |r| r.is_final(2));
        rig.check_limits();
        assert_jerk_within_limits(&rig.trace, &rig.limits, DT);
        rig.trace.len() - from
    };
    for line in [false, true] {
        let (gentle, full) = (stop_ticks(0.1, line), stop_ticks(1.0, line));
        assert!(
            gentle <= full + 1,
            "line {line}: {gentle} ticks at 10 %, {full} at 100 %"
        );
    }
}

#[test]
fn interrupt_stops_on_the_path_and_continue_finishes_the_same_moves() {
    let mut rig = Rig::new();
    let start = rig.feedback.q;
    let target = target_a();
    let a = rig.move_to(1, target);
    let b = rig.move_to(2, home());
    rig.step(&[a, b]);
    rig.run_until(10_000, |r| r.executor.status().active_progress > 40.0);
    let interrupt = rig.command(MotionCommandKind::Interrupt, 3);
    rig.step(&[interrupt]);
    assert_eq!(
        rig.states_of(1).last(),
        Some(&(state::INTERRUPTED, code::INTERRUPTED_BY_GROUP_INTERRUPT))
    );
    assert!(!rig.is_final(3), "done only when the arm stands");
    rig.run_until(10_000, |r| r.is_final(3));
    assert_eq!(rig.final_state(3), Some((state::DONE, 0)));
    assert!(rig.executor.status().sequence_paused);
    // Interrupted: the arm stands, short of the target, and the queue waits.
    let stood = rig.feedback.q;
    for _ in 0..200 {
        rig.step(&[]);
    }
    assert_eq!(rig.feedback.q, stood);
    assert_ne!(stood, target);
    assert!(!rig.is_final(1) && !rig.is_final(2));

    let resume = rig.command(MotionCommandKind::Continue, 4);
    rig.step(&[resume]);
    assert_eq!(rig.final_state(4), Some((state::DONE, 0)));
    rig.run_until(20_000, |r| r.is_final(2));
    assert_eq!(rig.final_state(1), Some((state::DONE, 0)));
    assert_eq!(rig.final_state(2), Some((state::DONE, 0)));
    assert_eq!(
        rig.states_of(1)
            .iter()
            .filter(|(s, _)| *s == state::ACTIVE)
            .count(),
        2
    );
    assert!(!rig.executor.status().sequence_paused);
    rig.check_limits();
    rig.check_on_line(0, start, target);
}

#[test]
fn stop_of_an_interrupted_sequence_aborts_its_moves() {
    let mut rig = Rig::new();
    let a = rig.move_to(1, target_a());
    rig.step(&[a]);
    rig.run_until(10_000, |r| r.executor.status().active_progress > 20.0);
    let interrupt = rig.command(MotionCommandKind::Interrupt, 2);
    rig.step(&[interrupt]);
    rig.run_until(10_000, |r| r.is_final(2));
    let stop = rig.command(MotionCommandKind::Stop, 3);
    rig.step(&[stop]);
    assert_eq!(
        rig.final_state(1),
        Some((state::ABORTED, code::ABORTED_BY_GROUP_STOP))
    );
    assert_eq!(rig.final_state(3), Some((state::DONE, 0)));
    assert!(!rig.executor.status().sequence_paused);
}

#[test]
fn the_status_carries_configuration_bits_and_turn_numbers() {
    let mut rig = Rig::new();
    rig.step(&[]);
    // The JAKA Zu 7 home [0, 90, 90, 90, -90, 0]: shoulder BACK, elbow DOWN, wrist FLIP.
    assert_eq!(rig.executor.status().arm_config, 0b111);
    assert_eq!(rig.executor.status().turn_numbers, [0; 4]);
    let mut target = home();
    target[0] = 200f64.to_radians();
    let c = rig.move_to(1, target);
    rig.step(&[c]);
    rig.run_until(20_000, |r| r.is_final(1));
    // J1 at 200 deg is turn +1 of -160 deg: low nibble of byte 0.
    assert_eq!(rig.executor.status().turn_numbers[0] & 0x0F, 1);
}

#[test]
fn a_direct_move_goes_to_the_joints_of_its_cartesian_target() {
    use crate::kinematics::turns::TurnNumbers;
    use crate::kinematics::{ArmGeometry, Kinematics};
    let cfg = config();
    let target = target_a();
    let geometry = ArmGeometry::new(&cfg.robot.kinematics).unwrap();
    let mut rig = Rig::new();
    let mut c = rig.command(MotionCommandKind::MoveDirect, 1);
    c.pose = Kinematics::new(&cfg.robot.kinematics).flange_pose(&target);
    // USE_CONFIG with the target's configuration bits and turn numbers.
    c.arm_config = geometry.arm_config(&target).bits();
    c.turn_numbers = TurnNumbers::of_joints(&target).unwrap().to_wire().unwrap();
    c.config_modes = [0; 3];
    c.turn_mode = 0;
    rig.step(&[c]);
    rig.run_until(20_000, |r| r.is_final(1));
    assert_eq!(rig.final_state(1), Some((state::DONE, 0)));
    for (q, t) in rig.feedback.q.iter().zip(target) {
        assert!((q - t).abs() < 1e-6, "{:?} vs {target:?}", rig.feedback.q);
    }
    rig.check_limits();

    let mut far = rig.command(MotionCommandKind::MoveDirect, 2);
    far.pose = [5.0, 0.0, 0.5, 0.0, 0.0, 0.0];
    rig.step(&[far]);
    assert_eq!(
        rig.final_state(2),
        Some((state::ERROR, code::TARGET_UNREACHABLE))
    );
    let mut bad = rig.command(MotionCommandKind::MoveDirect, 3);
    bad.pose = c.pose;
    bad.config_modes = [9, 1, 1];
    rig.step(&[bad]);
    assert_eq!(
        rig.final_state(3),
        Some((state::ERROR, code::INVALID_CONFIG_MODE_SHOULDER))
    );
}

#[test]
fn stop_of_a_standing_arm_is_done_at_once() {
    let mut rig = Rig::new();
    let stop = rig.command(MotionCommandKind::Stop, 9);
    rig.step(&[stop]);
    assert_eq!(rig.final_state(9), Some((state::DONE, 0)));
}

#[test]
fn halt_stops_like_a_stop_without_an_event_of_its_own() {
    let mut rig = Rig::new();
    let c = rig.move_to(1, target_a());
    rig.step(&[c]);
    rig.run_until(10_000, |r| r.executor.status().active_progress > 20.0);
    let halt = rig.command(MotionCommandKind::Halt, 0);
    rig.step(&[halt]);
    assert_eq!(
        rig.final_state(1),
        Some((state::ABORTED, code::ABORTED_BY_GROUP_STOP))
    );
    rig.run_until(10_000, |r| !r.executor.status().moving);
    assert!(rig.events.iter().all(|e| e.job != 0));
    rig.check_limits();
}

#[test]
fn an_aborting_move_stops_the_running_one_and_starts_from_rest() {
    let mut rig = Rig::new();
    let a = rig.move_to(1, target_a());
    let queued = rig.move_to(2, home());
    rig.step(&[a, queued]);
    rig.run_until(10_000, |r| r.executor.status().active_progress > 50.0);
    let mut other = home();
    other[1] += 0.4;
    let mut b = rig.move_to(3, other);
    b.aborting = true;
    rig.step(&[b]);
    let abort = (state::ABORTED, code::ABORTED_BY_MOTION_COMMAND);
    assert_eq!(rig.final_state(1), Some(abort));
    assert_eq!(rig.final_state(2), Some(abort));
    assert_eq!(rig.states_of(3), vec![(state::BUFFERED, 0)]);
    rig.run_until(10_000, |r| r.states_of(3).len() > 1);
    // Started only once the arm stood.
    let start = rig.trace.len() - 1;
    assert_eq!(rig.trace[start - 1].qd, [0.0; AXES]);
    let stood = rig.trace[start - 1].q;
    rig.run_until(10_000, |r| r.is_final(3));
    assert_eq!(
        rig.states_of(3),
        vec![(state::BUFFERED, 0), (state::ACTIVE, 0), (state::DONE, 0)]
    );
    assert_eq!(rig.feedback.q, other);
    rig.check_limits();
    rig.check_on_line(start, stood, other);
}

#[test]
fn targets_outside_the_limits_are_rejected_before_any_motion() {
    let mut rig = Rig::new();
    let limits = rig.limits;
    let mut low = home();
    low[1] = limits.min[1] - 0.01;
    let mut high = home();
    high[2] = limits.max[2] + 0.01;
    let a = rig.move_to(1, low);
    let b = rig.move_to(2, high);
    rig.step(&[a, b]);
    assert_eq!(
        rig.final_state(1),
        Some((state::ERROR, code::SW_LIMIT_LOWER))
    );
    assert_eq!(
        rig.final_state(2),
        Some((state::ERROR, code::SW_LIMIT_UPPER))
    );
    assert_eq!(rig.states_of(1).len(), 1);
    for _ in 0..10 {
        rig.step(&[]);
    }
    assert!(
        rig.trace
            .iter()
            .all(|p| p.q == home() && p.qd == [0.0; AXES])
    );
    assert_eq!(rig.executor.status().error_code, 0);
}

#[test]
fn a_duplicate_sequence_number_is_ignored_and_a_new_issuer_starts_over() {
    let mut rig = Rig::new();
    let c = rig.move_to(1, target_a());
    rig.step(&[c]);
    rig.step(&[c]);
    let mut old = c;
    old.seq -= 1;
    old.job = 5;
    rig.step(&[old]);
    assert_eq!(
        rig.events
            .iter()
            .filter(|e| e.state == state::BUFFERED)
            .count(),
        1
    );
    assert!(rig.states_of(5).is_empty());
    let mut fresh = rig.command(MotionCommandKind::Override, 6);
    fresh.issuer = ISSUER + 1;
    fresh.seq = 1;
    rig.step(&[fresh]);
    assert_eq!(rig.final_state(6), Some((state::DONE, 0)));
    let s = rig.executor.status();
    assert_eq!((s.acked_issuer, s.acked_seq), (ISSUER + 1, 1));
}

#[test]
fn moves_for_disabled_drives_are_refused() {
    let mut rig = Rig::new();
    rig.feedback.state = DriveState::Powered as u8;
    let c = rig.move_to(1, target_a());
    rig.window = rig.executor.step(&rig.feedback, &[c]);
    rig.collect_events();
    assert_eq!(
        rig.final_state(1),
        Some((state::ERROR, code::ROBOT_DISABLED))
    );
}

#[test]
fn drives_switched_off_hold_the_move_and_continue_resumes_it() {
    let mut rig = Rig::running(10.0);
    // The drives brake the arm to a standstill somewhere and drop out.
    let mut elsewhere = rig.feedback.q;
    elsewhere[0] += 0.01;
    rig.feedback.q = elsewhere;
    rig.feedback.qd = [0.0; AXES];
    rig.feedback.state = DriveState::Off as u8;
    let window = rig.executor.step(&rig.feedback, &[]);
    rig.collect_events();
    let from = rig.trace.len();
    assert_eq!(
        rig.states_of(1).last(),
        Some(&(state::INTERRUPTED, code::INTERRUPTED_NOT_ENABLED))
    );
    assert!(!rig.is_final(1) && !rig.is_final(2));
    let w = window.expect("a standing arm is tracked");
    assert!(
        w.points
            .iter()
            .all(|p| p.q == elsewhere && p.qd == [0.0; AXES])
    );
    let s = rig.executor.status();
    assert_eq!(s.joints_rad, elsewhere);
    assert_eq!(s.error_code, 0);
    assert!(s.sequence_paused);
    assert_eq!(s.queued_jobs, 2);
    // Enabled again, the sequence waits for GroupContinue.
    rig.feedback.state = DriveState::Holding as u8;
    for _ in 0..100 {
        rig.step(&[]);
    }
    assert_eq!(rig.feedback.q, elsewhere);
    let resume = rig.command(MotionCommandKind::Continue, 3);
    rig.step(&[resume]);
    rig.run_until(20_000, |r| r.is_final(2));
    assert_eq!(rig.final_state(1), Some((state::DONE, 0)));
    assert_eq!(rig.final_state(2), Some((state::DONE, 0)));
    assert_eq!(rig.feedback.q, home());
    assert_within_limits(&rig.trace[from..], &rig.limits, DT);
}

/// Rig with job 1 (to [`target_a`]) running; then the servo reports that it brakes the arm by
/// itself, with `misses` more ticks without a setpoint than before.
fn servo_stops_by_itself(misses: u64) -> Rig {
    let mut rig = Rig::new();
    let c = rig.move_to(1, target_a());
    rig.step(&[c]);
    rig.run_until(10_000, |r| r.executor.status().active_progress > 10.0);
    rig.feedback.state = DriveState::Stopping as u8;
    rig.feedback.setpoint_misses += misses;
    assert!(rig.executor.step(&rig.feedback, &[]).is_none());
    rig.collect_events();
    rig
}

#[test]
fn a_servo_stopping_with_setpoints_at_hand_is_being_switched_off() {
    let rig = servo_stops_by_itself(0);
    assert_eq!(
        rig.states_of(1).last(),
        Some(&(state::INTERRUPTED, code::INTERRUPTED_NOT_ENABLED))
    );
    let s = rig.executor.status();
    assert_eq!((s.error_code, s.queued_jobs), (0, 1));
    assert!(s.sequence_paused);
}

#[test]
fn a_servo_stopping_for_want_of_setpoints_ends_the_move_with_an_error() {
    let rig = servo_stops_by_itself(5);
    assert_eq!(rig.final_state(1), Some((state::ERROR, code::MOTION_ERROR)));
    let s = rig.executor.status();
    assert_eq!((s.error_code, s.queued_jobs), (code::MOTION_ERROR, 0));
    assert!(!s.sequence_paused);
}

#[test]
fn a_drive_fault_ends_everything_until_reset() {
    let mut rig = Rig::new();
    let a = rig.move_to(1, target_a());
    let b = rig.move_to(2, home());
    rig.step(&[a, b]);
    rig.run_until(10_000, |r| r.executor.status().active_progress > 10.0);
    rig.feedback.fault_code = 0x7001;
    rig.feedback.state = DriveState::Fault as u8;
    rig.feedback.qd = [0.0; AXES];
    rig.step(&[]);
    assert_eq!(rig.final_state(1), Some((state::ERROR, 0x7001)));
    assert_eq!(rig.final_state(2), Some((state::ERROR, 0x7001)));
    assert_eq!(rig.executor.status().error_code, 0x7001);
    // The fault is acknowledged at the drives; the planner error stays until Reset.
    rig.feedback.fault_code = 0;
    rig.feedback.state = DriveState::Holding as u8;
    let c = rig.move_to(3, home());
    rig.step(&[c]);
    assert_eq!(
        rig.final_state(3),
        Some((state::ERROR, code::DISABLED_DUE_TO_ERROR))
    );
    let reset = rig.command(MotionCommandKind::Reset, 4);
    let d = rig.move_to(5, home());
    rig.step(&[reset, d]);
    assert_eq!(rig.final_state(4), Some((state::DONE, 0)));
    assert_eq!(rig.executor.status().error_code, 0);
    rig.run_until(10_000, |r| r.is_final(5));
    assert_eq!(rig.final_state(5), Some((state::DONE, 0)));
    assert_eq!(rig.feedback.q, home());
}

#[test]
fn a_restarted_planner_waits_until_the_arm_stands() {
    let cfg = config();
    let mut executor = Executor::new(&cfg, 1);
    let mut feedback = Rig::new().feedback;
    feedback.state = DriveState::Stopping as u8;
    feedback.qd = [0.0, 0.3, 0.0, 0.0, 0.0, 0.0];
    assert!(executor.step(&feedback, &[]).is_none());
    assert!(!executor.is_commanding());
    // Still braking; a move sent now waits.
    let mut c = MotionCommand::new(MotionCommandKind::MoveAxes);
    c.seq = 1;
    c.job = 1;
    c.joints_rad = target_a();
    feedback.tick += 1;
    feedback.q[1] += 0.0003;
    feedback.qd[1] = 0.1;
    assert!(executor.step(&feedback, &[c]).is_none());
    assert_eq!(executor.status().joints_rad, feedback.q);
    // Standing, but the servo has not switched to Holding yet.
    feedback.tick += 1;
    feedback.qd = [0.0; AXES];
    assert!(executor.step(&feedback, &[]).is_none());
    feedback.tick += 1;
    feedback.state = DriveState::Holding as u8;
    let w = executor
        .step(&feedback, &[])
        .expect("commanding from the standing arm");
    assert_eq!(w.first_tick, feedback.tick + 1);
    // The queued move starts from exactly where the arm stands.
    let p = w.points[0];
    for i in 0..AXES {
        assert!((p.q[i] - feedback.q[i]).abs() < 1e-6);
        assert!(p.qd[i].abs() < 1e-3);
    }
}

#[test]
fn a_late_planner_continues_the_window_the_servo_followed() {
    let mut smooth = Rig::new();
    let mut late = Rig::new();
    for rig in [&mut smooth, &mut late] {
        let c = rig.move_to(1, target_a());
        rig.step(&[c]);
    }
    for n in 0..3000 {
        if n % 7 == 3 {
            // Two wake-ups missed: the servo takes ticks from the last window.
            late.step_without_planner();
            late.step_without_planner();
            smooth.step(&[]);
            smooth.step(&[]);
        } else {
            late.step(&[]);
            smooth.step(&[]);
        }
    }
    assert_eq!(smooth.trace.len(), late.trace.len());
    let differ = smooth
        .trace
        .iter()
        .zip(&late.trace)
        .position(|(a, b)| a != b);
    assert_eq!(
        differ, None,
        "the servo would have seen a different trajectory"
    );
    assert_eq!(late.final_state(1), Some((state::DONE, 0)));
    assert_eq!(late.feedback.q, target_a());
}

#[test]
fn a_servo_that_ran_out_of_setpoints_ends_the_move_with_an_error() {
    let mut rig = Rig::new();
    let c = rig.move_to(1, target_a());
    rig.step(&[c]);
    rig.run_until(10_000, |r| r.executor.status().active_progress > 10.0);
    rig.feedback.tick += SETPOINT_WINDOW as u64 + 1;
    rig.feedback.qd = [0.1; AXES];
    assert!(rig.executor.step(&rig.feedback, &[]).is_none());
    rig.collect_events();
    assert_eq!(rig.final_state(1), Some((state::ERROR, code::MOTION_ERROR)));
    assert_eq!(rig.executor.status().error_code, code::MOTION_ERROR);
}

#[test]
fn a_full_queue_refuses_the_move() {
    let mut rig = Rig::new();
    let length = config().main.planner.queue_length;
    let mut batch = Vec::new();
    for job in 1..=u32::from(length) + 2 {
        let mut t = home();
        t[0] += 0.001 * f64::from(job);
        batch.push(rig.move_to(job, t));
    }
    rig.step(&batch);
    let last = u32::from(length) + 2;
    // The burst of events reaches the status ring paced over a few ticks.
    rig.run_until(100, |r| r.is_final(last));
    // Queue full with `length` moves; the first of them has not started yet.
    assert_eq!(
        rig.final_state(last - 1),
        Some((state::ERROR, code::INTERNAL_ERROR))
    );
    assert_eq!(
        rig.final_state(last),
        Some((state::ERROR, code::INTERNAL_ERROR))
    );
}

#[test]
fn a_requested_duration_is_kept_or_refused() {
    let mut rig = Rig::new();
    let mut c = rig.move_to(1, target_a());
    c.duration_s = 6.0;
    rig.step(&[c]);
    let begin = rig.trace.len();
    rig.run_until(10_000, |r| r.is_final(1));
    let ticks = rig.trace.len() - begin + 1;
    assert!((ticks as f64 * DT - 6.0).abs() < 2.0 * DT, "{ticks}");
    let mut quick = rig.move_to(2, home());
    quick.duration_s = 0.1;
    rig.step(&[quick]);
    assert_eq!(rig.final_state(2), Some((state::ERROR, code::INVALID_TIME)));
}

#[test]
fn a_zero_length_move_is_done_at_once() {
    let mut rig = Rig::new();
    let c = rig.move_to(1, home());
    rig.step(&[c]);
    assert_eq!(
        rig.states_of(1),
        vec![(state::BUFFERED, 0), (state::ACTIVE, 0), (state::DONE, 0)]
    );
}

#[test]
fn the_same_feedback_twice_does_not_advance_the_motion() {
    let mut rig = Rig::new();
    let c = rig.move_to(1, target_a());
    rig.step(&[c]);
    rig.run_until(10_000, |r| r.executor.status().active_progress > 20.0);
    let first = rig.executor.step(&rig.feedback, &[]);
    let again = rig.executor.step(&rig.feedback, &[]);
    assert_eq!(first.map(|w| w.points), again.map(|w| w.points));
    assert_eq!(first.map(|w| w.first_tick), again.map(|w| w.first_tick));
}

mod random {
    use super::*;
    use proptest::prelude::*;

    #[derive(Debug, Clone)]
    enum Action {
        Override(f64),
        Stop,
        Abort([f64; AXES]),
        /// An aborting linear move of the TCP by a shift (m) from home's.
        AbortLinear([f64; 3]),
        Interrupt(MotionSequence),
        Continue(MotionSequence),
        /// A secondary move turning the last joint from home's by an angle, aborting or not.
        Jog(f64, bool),
        /// The jog button released: Halt of the secondary sequence.
        HaltSecondary,
    }

    fn scope() -> impl Strategy<Value = MotionSequence> {
        prop_oneof![
            Just(MotionSequence::All),
            Just(MotionSequence::Primary),
            Just(MotionSequence::Secondary),
        ]
    }

    fn action() -> impl Strategy<Value = Action> {
        prop_oneof![
            3 => (0.0f64..=1.0).prop_map(Action::Override),
            1 => Just(Action::Stop),
            1 => prop::array::uniform6(-1.0f64..1.0).prop_map(Action::Abort),
            2 => prop::array::uniform3(-0.15f64..0.15).prop_map(Action::AbortLinear),
            2 => scope().prop_map(Action::Interrupt),
            2 => scope().prop_map(Action::Continue),
            2 => (-1.0f64..1.0, any::<bool>()).prop_map(|(t, a)| Action::Jog(t, a)),
            1 => Just(Action::HaltSecondary),
        ]
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(24))]

        /// Whatever happens when, to joint and linear moves of both sequences, the joints
        /// never leave their velocity and acceleration limits nor the jerk limit by more
        /// than an override ramp adds, and every job ends with a final state once both
        /// sequences are continued.
        #[test]
        fn any_sequence_of_overrides_stops_and_aborts_keeps_the_limits(
            offset in prop::array::uniform6(-1.0f64..1.0),
            actions in prop::collection::vec((1usize..400, action()), 1..6),
        ) {
            let mut rig = Rig::new();
            let base = home();
            let first: [f64; AXES] = core::array::from_fn(|i| base[i] + offset[i]);
            let c = rig.move_to(1, first);
            rig.step(&[c]);
            let mut job = 1;
            let mut jobs = vec![1];
            for (wait, action) in actions {
                for _ in 0..wait {
                    rig.step(&[]);
                }
                job += 1;
                jobs.push(job);
                let c = match action {
                    Action::Override(f) => {
                        let mut c = rig.command(MotionCommandKind::Override, job);
                        c.override_fraction = f;
                        c
                    }
                    Action::Stop => rig.command(MotionCommandKind::Stop, job),
                    Action::Abort(t) => {
                        let mut c = rig.move_to(job, core::array::from_fn(|i| base[i] + t[i]));
                        c.aborting = true;
                        c
                    }
                    Action::AbortLinear(shift) => {
                        let mut c = rig.line_by(job, [0.0; 3], [0.0; 3]);
                        c.pose = shifted(&tcp_of(&base), shift, [0.0; 3]);
                        c.aborting = true;
                        c
                    }
                    Action::Interrupt(scope) => {
                        let mut c = rig.command(MotionCommandKind::Interrupt, job);
                        c.sequence = scope as u8;
                        c
                    }
                    Action::Continue(scope) => {
                        let mut c = rig.command(MotionCommandKind::Continue, job);
                        c.sequence = scope as u8;
                        c
                    }
                    Action::Jog(turn, aborting) => {
                        let mut target = base;
                        target[5] += turn;
                        let mut c = rig.move_to(job, target);
                        c.sequence = MotionSequence::Secondary as u8;
                        c.aborting = aborting;
                        c
                    }
                    Action::HaltSecondary => {
                        // Halt reports nothing under its own job.
                        jobs.pop();
                        let mut c = rig.command(MotionCommandKind::Halt, 0);
                        c.sequence = MotionSequence::Secondary as u8;
                        c
                    }
                };
                rig.step(&[c]);
            }
            let mut resume = rig.command(MotionCommandKind::Override, job + 1);
            resume.override_fraction = 1.0;
            let go_on = rig.command(MotionCommandKind::Continue, job + 2);
            jobs.extend([job + 1, job + 2]);
            rig.step(&[resume, go_on]);
            rig.run_until(60_000, |r| {
                jobs.iter().all(|&j| r.is_final(j)) && !r.executor.status().moving
            });
            let s = rig.executor.status();
            prop_assert!(!s.sequence_paused);
            prop_assert_eq!((s.active_job, s.queued_jobs), (0, 0));
            rig.check_limits();
            let within = 1.0 + crate::motion::OVERRIDE_JERK_SHARE;
            assert_jerk_within(&rig.trace, &rig.limits, DT, within);
        }
    }
}

mod linear {
    use super::*;

    /// Rig with a linear move by [`SHIFT`] and [`TURN`] from home sent as job 1; returns
    /// the start and target TCP poses.
    fn started(rig: &mut Rig) -> ([f64; 6], [f64; 6]) {
        let c = rig.line_by(1, SHIFT, TURN);
        let start = pose::pose(&tcp_of(&rig.feedback.q));
        rig.step(&[c]);
        (start, c.pose)
    }

    /// Runs job 1 to its end and checks that it was done on the line within the limits.
    fn finish(rig: &mut Rig, start: [f64; 6], target: [f64; 6]) {
        rig.run_until(20_000, |r| r.is_final(1));
        assert_eq!(rig.final_state(1), Some((state::DONE, 0)));
        assert_tcp_at(&rig.feedback.q, target);
        rig.check_on_tcp_line(0, start, target);
        rig.check_limits();
    }

    pub(super) fn assert_tcp_at(q: &[f64; AXES], pose: [f64; 6]) {
        let (reached, target) = (tcp_of(q), pose::isometry(pose));
        assert!((reached.translation.vector - target.translation.vector).norm() < 1e-9);
        assert!(reached.rotation.angle_to(&target.rotation) < 1e-9);
    }

    #[test]
    fn a_linear_move_keeps_the_tcp_on_the_line_and_reaches_the_target() {
        let mut rig = Rig::new();
        let (start, target) = started(&mut rig);
        let mut progress = Vec::new();
        rig.run_until(20_000, |r| r.is_final(1));
        for _ in 0..3 {
            progress.push(rig.executor.status().active_progress);
            rig.step(&[]);
        }
        assert_eq!(
            rig.states_of(1),
            vec![(state::BUFFERED, 0), (state::ACTIVE, 0), (state::DONE, 0)]
        );
        assert_tcp_at(&rig.feedback.q, target);
        assert_eq!(rig.trace.last().map(|p| p.qd), Some([0.0; AXES]));
        rig.check_on_tcp_line(0, start, target);
        rig.check_limits();
        assert_jerk_within_limits(&rig.trace, &rig.limits, DT);
        let s = rig.executor.status();
        assert_eq!((s.active_job, s.moving), (0, false));
        assert_eq!(
            s.flange_pose,
            Kinematics::new(&config().robot.kinematics).flange_pose(&rig.feedback.q)
        );
    }

    #[test]
    fn progress_is_reported_along_the_line() {
        let mut rig = Rig::new();
        started(&mut rig);
        let mut seen = Vec::new();
        while !rig.is_final(1) {
            let s = rig.executor.status();
            if s.active_job == 1 {
                seen.push(s.active_progress);
            }
            rig.step(&[]);
        }
        assert!(seen.len() > 100);
        assert!(seen.windows(2).all(|w| w[1] >= w[0]));
        assert!(seen[0] < 1.0 && *seen.last().unwrap() > 99.0);
    }

    #[test]
    fn stop_brakes_on_the_line_within_the_limits() {
        let mut rig = Rig::new();
        let (start, target) = started(&mut rig);
        let queued = rig.move_to(2, home());
        rig.step(&[queued]);
        rig.run_until(20_000, |r| r.executor.status().active_progress > 50.0);
        let stop = rig.command(MotionCommandKind::Stop, 3);
        rig.step(&[stop]);
        let abort = (state::ABORTED, code::ABORTED_BY_GROUP_STOP);
        assert_eq!(rig.final_state(1), Some(abort));
        assert_eq!(rig.final_state(2), Some(abort));
        assert!(rig.executor.status().decelerating);
        rig.run_until(20_000, |r| r.is_final(3));
        assert_eq!(rig.final_state(3), Some((state::DONE, 0)));
        let stood = rig.feedback.q;
        rig.step(&[]);
        assert_eq!(rig.feedback.q, stood);
        rig.check_on_tcp_line(0, start, target);
        rig.check_limits();
        assert_jerk_within_limits(&rig.trace, &rig.limits, DT);
        let progress =
            (tcp_of(&stood).translation.vector - pose::isometry(start).translation.vector).norm()
                / (pose::isometry(target).translation.vector
                    - pose::isometry(start).translation.vector)
                    .norm();
        assert!(progress > 0.5 && progress < 1.0, "{progress}");
    }

    /// GroupStop at several points of a line timed by its time-optimal table: every stop
    /// keeps the limits, jerk included, and stays on the line; none takes longer than the
    /// rest of the table, and a stop early on the line (1.4 s, where a stop from full speed
    /// takes about 0.5 s) brakes far sooner.
    #[test]
    fn stops_anywhere_on_a_time_optimal_line_keep_the_limits_and_the_line() {
        for at in [10.0, 30.0, 50.0, 80.0, 90.0, 95.0, 99.0] {
            let mut rig = Rig::new();
            let start = pose::pose(&tcp_of(&rig.feedback.q));
            let line = rig.line_by(1, [0.3, -0.3, -0.2], TURN);
            let target = line.pose;
            rig.step(&[line]);
            assert!(runs_on_table(&rig), "the line is not timed by its table");
            rig.run_until(20_000, |r| r.executor.status().active_progress > at);
            let (stopped_at, left) = match rig.executor.motion.phase {
                Phase::Running(Running { tau, plan, .. }) => {
                    (rig.trace.len(), plan.timing().profile.duration() - tau)
                }
                phase => panic!("not running: {phase:?}"),
            };
            let stop = rig.command(MotionCommandKind::Stop, 3);
            rig.step(&[stop]);
            rig.run_until(20_000, |r| r.is_final(3));
            let took = (rig.trace.len() - stopped_at) as f64 * DT;
            rig.check_stood_on_tcp_line(start, target, 1.0);
            // Never longer than running the table out; early on, far shorter.
            assert!(
                took <= left + 2.0 * DT,
                "stop at {at} %: {took} s of {left} s left"
            );
            if at <= 30.0 {
                assert!(
                    took < 0.7 * left,
                    "stop at {at} %: {took} s of {left} s left"
                );
            }
        }
    }

    /// GroupStop `ticks` into the line by `shift` (and [`TURN`]): the time the stop took,
    /// the longest any joint alone needs from the point commanded when it was sent, and
    /// the line's target.
    fn stop_against_the_slowest_joint(
        rig: &mut Rig,
        shift: [f64; 3],
        ticks: usize,
    ) -> (f64, f64, [f64; 6]) {
        let line = rig.line_by(1, shift, TURN);
        rig.step(&[line]);
        assert!(runs_on_table(rig), "the line is not timed by its table");
        for _ in 0..ticks {
            rig.step(&[]);
        }
        let from = *rig.trace.last().expect("the line moved");
        let stopped_at = rig.trace.len();
        let stop = rig.command(MotionCommandKind::Stop, 3);
        rig.step(&[stop]);
        rig.run_until(20_000, |r| r.is_final(3));
        let took = (rig.trace.len() - stopped_at) as f64 * DT;
        let slowest = (0..AXES)
            .map(|i| {
                crate::brake::shortest_stop_time(
                    from.qd[i],
                    from.qdd[i],
                    rig.limits.acceleration[i],
                    rig.limits.jerk[i],
                )
            })
            .fold(0.0, f64::max);
        (took, slowest, line.pose)
    }

    /// A GroupStop while the table still speeds the line up brakes its path parameter at
    /// once: it takes little longer than the slowest joint would need alone (1.11 to 1.13
    /// times). Braking the table's time scale, it had to wait until taking the table's
    /// acceleration away left it room: 1.49 to 4.86 times as long on these lines, 0.30 s
    /// instead of 0.07 s 20 ms into a line.
    #[test]
    fn a_stop_while_the_table_speeds_up_takes_little_longer_than_the_slowest_joint() {
        let shifts = [
            [0.3, -0.3, -0.2],
            [0.1, -0.1, 0.05],
            [0.05, 0.1, -0.05],
            [-0.15, 0.0, 0.1],
        ];
        for shift in shifts {
            for ticks in [20, 50, 80, 120] {
                let mut rig = Rig::new();
                let start = pose::pose(&tcp_of(&rig.feedback.q));
                let (took, slowest, target) =
                    stop_against_the_slowest_joint(&mut rig, shift, ticks);
                rig.check_stood_on_tcp_line(start, target, 1.0);
                assert!(
                    took <= 1.2 * slowest,
                    "{shift:?}, {ticks} ticks: {took} s, the slowest joint alone {slowest} s"
                );
            }
        }
    }

    /// A GroupStop half-way through a long line whose table already slows down (towards its
    /// end) brakes the path parameter where the prediction finds that sooner than braking
    /// the time scale, which would run the table out: here 0.49 s instead of the 0.68 s
    /// left of the table. Before, a stop there always braked the time scale.
    #[test]
    fn a_stop_while_the_table_slows_down_brakes_the_path_where_that_is_sooner() {
        let mut rig = Rig::new();
        let start = pose::pose(&tcp_of(&rig.feedback.q));
        let line = rig.line_by(1, [0.38, -0.26, -0.07], [0.03, 0.03, -0.03]);
        rig.step(&[line]);
        let table = |rig: &Rig| match rig.executor.motion.phase {
            Phase::Running(Running { plan, tau, .. }) => (plan.timing().profile, tau),
            phase => panic!("not running: {phase:?}"),
        };
        assert!(runs_on_table(&rig), "the line is not timed by its table");
        let half = 0.5 * table(&rig).0.duration();
        rig.run_until(20_000, |r| table(r).1 >= half);
        let (profile, tau) = table(&rig);
        let (_, _, slowing) = profile.eval(tau);
        assert!(slowing < 0.0, "{slowing}");
        let stopped_at = rig.trace.len();
        let stop = rig.command(MotionCommandKind::Stop, 3);
        rig.step(&[stop]);
        assert!(matches!(
            rig.executor.motion.phase,
            Phase::Braking {
                stop: crate::motion::Stop::OnPath(_),
                ..
            }
        ));
        rig.run_until(20_000, |r| r.is_final(3));
        let took = (rig.trace.len() - stopped_at) as f64 * DT;
        let left = profile.duration() - tau;
        assert!(took < 0.8 * left, "{took} s, the table's {left} s left");
        rig.check_stood_on_tcp_line(start, line.pose, 1.0);
    }

    /// GroupStops at random times of random lines from home keep the limits, jerk
    /// included, and the line, whether they brake the path parameter, hand over to the
    /// table's time scale or brake that alone.
    #[test]
    fn stops_at_random_times_of_random_lines_keep_the_limits() {
        let mut state: u64 = 0x2545_F491_4F6C_DD1D;
        let mut next = move || {
            state = state
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let mut timed = 0;
        for _ in 0..12 {
            let shift = [0.5 * next() - 0.25, 0.5 * next() - 0.25, 0.4 * next() - 0.2];
            let turn = [0.6 * next() - 0.3, 0.6 * next() - 0.3, 0.6 * next() - 0.3];
            let ticks = (20.0 + 600.0 * next()) as usize;
            let mut rig = Rig::new();
            let start = pose::pose(&tcp_of(&rig.feedback.q));
            let line = rig.line_by(1, shift, turn);
            rig.step(&[line]);
            // A line out of reach or through a singular set is refused: nothing to stop.
            if !matches!(rig.executor.motion.phase, Phase::Running(_)) || !runs_on_table(&rig) {
                continue;
            }
            timed += 1;
            for _ in 0..ticks {
                rig.step(&[]);
            }
            stop_on_the_line(&mut rig, 3, (start, line.pose), 1.0);
        }
        assert!(timed >= 8, "{timed} of 12 lines timed by their tables");
    }

    /// GroupStop as job `job`, run until it is done: the arm stands on the TCP's line from
    /// `start` to `target`, within the limits and `jerk_factor` times the jerk limits.
    fn stop_on_the_line(rig: &mut Rig, job: u32, line: ([f64; 6], [f64; 6]), jerk_factor: f64) {
        let stop = rig.command(MotionCommandKind::Stop, job);
        rig.step(&[stop]);
        rig.run_until(20_000, |r| r.is_final(job));
        rig.check_stood_on_tcp_line(line.0, line.1, jerk_factor);
    }

    /// GroupStop at `at` % of the line from home by `shift` and `turn` of the TCP, timed by
    /// its table: the stop keeps the limits, jerk included, and the line.
    fn stop_on_table_keeps_the_limits(shift: [f64; 3], turn: [f64; 3], at: f64) {
        let mut rig = Rig::new();
        let start = pose::pose(&tcp_of(&rig.feedback.q));
        let line = rig.line_by(1, shift, turn);
        rig.step(&[line]);
        assert!(
            runs_on_table(&rig),
            "{shift:?} {turn:?}: the line is not timed by its table"
        );
        rig.run_until(20_000, |r| r.executor.status().active_progress > at);
        stop_on_the_line(&mut rig, 3, (start, line.pose), 1.0);
    }

    /// GroupStops during override ramps on a line timed by its table, towards a lower and a
    /// higher override: where the stop runs the table out, the time scale's rate is
    /// released gradually. A step of it took the acceleration by `σ̇·q̇ₜ` in one tick, up to
    /// 12.9 times the jerk limit; now the jerk stays within the ramp's own bound.
    #[test]
    fn stops_during_override_ramps_release_the_rate_gradually() {
        let within = 1.0 + crate::motion::OVERRIDE_JERK_SHARE;
        // (at progress %, ticks into the ramp, ramping up to 100 % from 30 %)
        let cases = [
            (50.0, 60, false),
            (80.0, 20, false),
            (96.0, 60, false),
            (50.0, 30, true),
            (85.0, 30, true),
            // A release whose rounding leftover kept σ̇ from reaching 0: the stop never
            // ended, or the time stood still for ticks (third differences of the positions
            // 8850 and 21396 times the jerk limit); found by a review.
            (70.0, 40, true),
            (90.0, 68, false),
        ];
        for (at, into_ramp, up) in cases {
            let mut rig = Rig::new();
            let start = pose::pose(&tcp_of(&rig.feedback.q));
            let line = rig.line_by(1, [0.3, -0.3, -0.2], TURN);
            rig.step(&[line]);
            assert!(runs_on_table(&rig), "the line is not timed by its table");
            rig.run_until(20_000, |r| r.executor.status().active_progress > at);
            rig.set_override(2, 0.3);
            if up {
                for _ in 0..300 {
                    rig.step(&[]);
                }
                rig.set_override(3, 1.0);
            }
            for _ in 0..into_ramp {
                rig.step(&[]);
            }
            stop_on_the_line(&mut rig, 4, (start, line.pose), within);
        }
    }

    /// Override changes (to 30 % and back) at several points of a joint move and of a line
    /// timed by its table: the time scale's rate changes gradually, so the jerk stays within
    /// the move's own plus [`OVERRIDE_JERK_SHARE`](crate::motion::OVERRIDE_JERK_SHARE) of the
    /// limit (measured: at most 1.35 times the limit, the cross term `3·σ·σ̇·q̈ₜ` included).
    /// With a step of the rate it was up to 80 times the limit (40 in the positions).
    #[test]
    fn override_changes_keep_the_jerk_near_its_limit() {
        let within = 1.0 + crate::motion::OVERRIDE_JERK_SHARE;
        // (a line, at progress %, JerkRate): a lower JerkRate slows the ramps down with it.
        let cases = [
            (false, 5.0, 1.0),
            (false, 30.0, 1.0),
            (false, 80.0, 1.0),
            (true, 15.0, 1.0),
            (false, 30.0, 0.1),
            (true, 15.0, 0.1),
        ];
        for (line, at, jerk_rate) in cases {
            let mut rig = Rig::new();
            let mut c = if line {
                rig.line_by(1, [0.3, -0.3, -0.2], TURN)
            } else {
                rig.move_to(1, target_a())
            };
            c.jerk_scale = jerk_rate;
            rig.step(&[c]);
            assert!(
                !line || runs_on_table(&rig),
                "the line is not timed by its table"
            );
            rig.run_until(20_000, |r| r.executor.status().active_progress > at);
            rig.set_override(2, 0.3);
            for _ in 0..300 {
                rig.step(&[]);
            }
            rig.set_override(3, 1.0);
            rig.run_until(20_000, |r| r.is_final(1));
            rig.check_limits();
            let mut limits = rig.limits;
            limits.jerk = limits.jerk.map(|j| jerk_rate * j);
            assert_jerk_within(&rig.trace, &limits, DT, within);
        }
    }

    /// GroupStop all along lines on which the stop of the time scale, unbounded by its
    /// cross term, ran away into σ = 0 at full deceleration (a jerk of 78 to 125 times the
    /// limit).
    #[test]
    fn stops_where_the_table_slows_a_joint_down_keep_the_jerk() {
        let lines = [
            ([0.291, 0.109, 0.162], [0.223, -0.219, 0.282]),
            ([-0.077, -0.196, 0.094], [-0.322, -0.336, -0.314]),
            ([0.173, 0.056, -0.036], [0.106, 0.316, 0.309]),
            ([-0.170, 0.051, 0.082], [0.398, 0.260, 0.011]),
        ];
        for (shift, turn) in lines {
            for at in (1..10).map(|k| f64::from(k) * 10.0) {
                stop_on_table_keeps_the_limits(shift, turn, at);
            }
        }
    }

    /// GroupStops that braked the time scale while the table was about to brake at its jerk
    /// limit to its end: the two decelerations added up, and the jerk of taking the table's
    /// acceleration away forced the deceleration ever higher (the first of them to 20 times
    /// the jerk limit) until such stops ran the table out instead.
    #[test]
    fn stops_shortly_before_the_table_brakes_to_its_end_keep_the_jerk() {
        let stops = [
            (
                [0.0159, 0.04488, -0.14836],
                [0.08936, -0.38936, 0.38096],
                40.0,
            ),
            (
                [0.12216, 0.08382, 0.06008],
                [0.2232, -0.00016, -0.38664],
                40.0,
            ),
            (
                [0.19374, 0.0018, 0.01176],
                [0.15304, -0.34784, -0.08112],
                40.0,
            ),
            (
                [0.27078, 0.03912, 0.1474],
                [-0.14856, -0.37088, -0.07736],
                40.0,
            ),
            (
                [0.02016, 0.19638, -0.03764],
                [0.29704, 0.2192, 0.01624],
                50.0,
            ),
        ];
        for (shift, turn, at) in stops {
            stop_on_table_keeps_the_limits(shift, turn, at);
        }
    }

    #[test]
    fn interrupt_and_continue_stay_on_the_line() {
        let mut rig = Rig::new();
        let (start, target) = started(&mut rig);
        rig.run_until(20_000, |r| r.executor.status().active_progress > 40.0);
        rig.interrupt_and_stand(2, 1);
        let resume = rig.command(MotionCommandKind::Continue, 3);
        rig.step(&[resume]);
        finish(&mut rig, start, target);
    }

    #[test]
    fn override_changes_retime_the_line_without_leaving_it() {
        let mut rig = Rig::new();
        let start = pose::pose(&tcp_of(&rig.feedback.q));
        // Slow enough for the override ramp to halt it on the way.
        let mut c = rig.line_by(1, SHIFT, TURN);
        c.velocity_scale = 0.2;
        let target = c.pose;
        rig.step(&[c]);
        rig.run_until(20_000, |r| r.executor.status().active_progress > 20.0);
        rig.set_override(2, 0.2);
        rig.run_until(20_000, |r| r.executor.status().active_progress > 50.0);
        rig.set_override(3, 0.0);
        rig.run_until(20_000, |r| !r.executor.status().moving);
        assert_eq!(rig.executor.status().active_job, 1);
        rig.set_override(4, 1.0);
        finish(&mut rig, start, target);
    }

    #[test]
    fn an_aborting_linear_move_runs_from_where_the_arm_stopped() {
        let mut rig = Rig::new();
        let a = rig.move_to(1, target_a());
        rig.step(&[a]);
        rig.run_until(10_000, |r| r.executor.status().active_progress > 20.0);
        let mut c = rig.line_by(2, [0.0; 3], [0.0; 3]);
        c.pose = shifted(&tcp_of(&home()), SHIFT, TURN);
        c.aborting = true;
        rig.step(&[c]);
        assert_eq!(
            rig.final_state(1),
            Some((state::ABORTED, code::ABORTED_BY_MOTION_COMMAND))
        );
        rig.run_until(20_000, |r| r.states_of(2).len() > 1);
        let from = rig.trace.len() - 1;
        let stood = rig.trace[from - 1].q;
        assert_eq!(rig.trace[from - 1].qd, [0.0; AXES]);
        rig.run_until(20_000, |r| r.is_final(2));
        assert_eq!(rig.final_state(2), Some((state::DONE, 0)));
        assert_tcp_at(&rig.feedback.q, c.pose);
        rig.check_on_tcp_line(from, pose::pose(&tcp_of(&stood)), c.pose);
        rig.check_limits();
    }

    #[test]
    fn queued_moves_chain_joint_and_linear_moves() {
        let mut rig = Rig::new();
        let mut first = home();
        first[0] += 0.3;
        let a = rig.move_to(1, first);
        let mut b = rig.line_by(2, [0.0; 3], [0.0; 3]);
        b.pose = shifted(&tcp_of(&first), SHIFT, [0.0; 3]);
        let mut c = rig.line_by(3, [0.0; 3], [0.0; 3]);
        c.pose = shifted(&tcp_of(&first), [0.0; 3], TURN);
        let d = rig.move_to(4, home());
        rig.step(&[a, b, c, d]);
        assert_eq!(rig.executor.status().queued_jobs, 3);
        rig.run_until(20_000, |r| r.is_final(1));
        let from = rig.trace.len();
        rig.run_until(20_000, |r| r.is_final(2));
        assert_tcp_at(&rig.feedback.q, b.pose);
        rig.check_on_tcp_line(from, pose::pose(&tcp_of(&first)), b.pose);
        rig.run_until(20_000, |r| r.is_final(4));
        for job in 1..=4 {
            assert_eq!(rig.final_state(job), Some((state::DONE, 0)), "job {job}");
        }
        assert_eq!(rig.feedback.q, home());
        rig.check_limits();
    }

    #[test]
    fn errors_are_reported_before_the_arm_moves() {
        let mut rig = Rig::new();
        let far = rig.line_by(1, [2.0, 0.0, 0.0], [0.0; 3]);
        let mut undefined_ori_mode = rig.line_by(2, SHIFT, [0.0; 3]);
        undefined_ori_mode.ori_mode = 5;
        let mut other_config = rig.line_by(3, SHIFT, [0.0; 3]);
        // Shoulder FRONT: home is BACK.
        other_config.config_modes = [4, 1, 1];
        let mut slow_decel = rig.line_by(4, SHIFT, [0.0; 3]);
        slow_decel.deceleration_scale = 1.5;
        rig.step(&[far, undefined_ori_mode, other_config, slow_decel]);
        assert_eq!(
            rig.states_of(1),
            vec![(state::ERROR, code::TARGET_UNREACHABLE)]
        );
        assert_eq!(rig.states_of(2), vec![(state::ERROR, 0x8D22)]);
        assert_eq!(
            rig.states_of(3),
            vec![(state::ERROR, code::TARGET_UNREACHABLE)]
        );
        assert_eq!(
            rig.states_of(4),
            vec![(state::ERROR, code::INVALID_DECELERATION_RATE)]
        );
        // 0x6C03 says why in the event (2 m away, the arm stretches into the elbow's
        // singularity margin first); the other codes tell by themselves.
        let reason = |job| {
            let e = rig.events.iter().find(|e| e.job == job).expect("an event");
            RefusalReason::from_wire(e.reason)
        };
        assert_eq!(
            [1, 2, 3, 4].map(reason),
            [
                RefusalReason::Singular,
                RefusalReason::None,
                RefusalReason::ConfigurationChange,
                RefusalReason::None
            ]
        );
        assert_eq!(rig.executor.status().queued_jobs, 0);
        for _ in 0..10 {
            rig.step(&[]);
        }
        assert!(rig.trace.iter().all(|p| p.q == home()));
    }

    #[test]
    fn a_late_planner_follows_the_same_line() {
        let mut smooth = Rig::new();
        let mut late = Rig::new();
        for rig in [&mut smooth, &mut late] {
            started(rig);
        }
        for n in 0..4000 {
            if n % 5 == 2 {
                late.step_without_planner();
                late.step_without_planner();
                late.step_without_planner();
                smooth.step(&[]);
                smooth.step(&[]);
                smooth.step(&[]);
            } else {
                late.step(&[]);
                smooth.step(&[]);
            }
        }
        assert_eq!(smooth.trace, late.trace);
        assert_eq!(late.final_state(1), Some((state::DONE, 0)));
    }

    #[test]
    fn a_direct_move_takes_its_target_for_the_tcp_of_the_tool() {
        let mut rig = Rig::new();
        let mut c = rig.command(MotionCommandKind::MoveDirect, 1);
        c.tool = tool();
        c.pose = shifted(&tcp_of(&home()), SHIFT, TURN);
        rig.step(&[c]);
        rig.run_until(20_000, |r| r.is_final(1));
        assert_eq!(rig.final_state(1), Some((state::DONE, 0)));
        let (reached, target) = (tcp_of(&rig.feedback.q), pose::isometry(c.pose));
        assert!((reached.translation.vector - target.translation.vector).norm() < 1e-6);
        assert!(reached.rotation.angle_to(&target.rotation) < 1e-6);
    }
}

#[test]
fn a_lower_deceleration_rate_slows_only_the_end_of_the_move() {
    let mut target = home();
    target[0] += 4.0;
    let run = |deceleration: f64| {
        let mut rig = Rig::new();
        let mut c = rig.move_to(1, target);
        c.acceleration_scale = 0.8;
        c.deceleration_scale = deceleration;
        rig.step(&[c]);
        rig.run_until(20_000, |r| r.is_final(1));
        assert_eq!(rig.feedback.q, target);
        rig.check_limits();
        rig.trace
    };
    let (equal, low) = (run(0.8), run(0.4));
    // The same acceleration ramp (0.5 s) and the start of the cruise, bit for bit.
    assert_eq!(equal[..600], low[..600]);
    // Braking ramp 0.85 s instead of 0.52 s, half of the difference won back in the cruise.
    assert!(
        low.len() > equal.len() + 150,
        "{} vs {}",
        low.len(),
        equal.len()
    );
    // Braking uses at most 40 % of the acceleration limit, less the part of the override
    // reserve the braking ramp's speeds need (from full speed nearly all of it).
    let limit = config().robot.limits_rad().acceleration[0];
    let braking = |trace: &[JointPoint]| {
        trace[trace.len() / 2..]
            .iter()
            .map(|p| -p.qdd[0])
            .fold(0.0, f64::max)
            / limit
    };
    let kept = 1.0 - config().main.planner.override_reserve;
    for (trace, rate) in [(&low, 0.4), (&equal, 0.8)] {
        let used = braking(trace) / rate;
        assert!(used > kept - 1e-9 && used < 1.0, "{used}");
    }
}

/// The tables of buffered lines, planned off the tick, replace the constant bounds only
/// where the servo has not been sent the move yet.
mod tables {
    use super::*;
    use crate::refinement::{InlineRefiner, Refined, Refiner, TableRequest};
    use std::sync::Arc;
    use std::sync::atomic::{AtomicBool, Ordering};

    /// Plans at once but hands the tables out only once released, and no more than
    /// `left` of them: a slow planning thread.
    struct HeldRefiner {
        inner: InlineRefiner,
        released: Arc<AtomicBool>,
        left: usize,
    }

    impl Refiner for HeldRefiner {
        fn request(&mut self, request: &TableRequest) -> bool {
            self.inner.request(request)
        }

        fn take(&mut self) -> Option<Refined> {
            if self.released.load(Ordering::Relaxed) && self.left > 0 {
                self.left -= 1;
                self.inner.take()
            } else {
                None
            }
        }

        fn forget(&mut self, through: u64) {
            self.inner.forget(through);
        }
    }

    fn held() -> (Rig, Arc<AtomicBool>) {
        held_for(usize::MAX)
    }

    /// A rig whose refiner hands out `tables` tables at most.
    fn held_for(tables: usize) -> (Rig, Arc<AtomicBool>) {
        let released = Arc::new(AtomicBool::new(false));
        let refiner = HeldRefiner {
            inner: InlineRefiner::new(&config(), 8),
            released: released.clone(),
            left: tables,
        };
        let executor = Executor::with_refiner(&config(), 0xABCD, Box::new(refiner));
        (Rig::with(executor), released)
    }

    /// Job 1 to [`target_a`], then a line (job 2) from there.
    fn joint_move_then_line(rig: &mut Rig) -> MotionCommand {
        let a = rig.move_to(1, target_a());
        let mut line = rig.command(MotionCommandKind::MoveLinear, 2);
        line.tool = tool();
        line.pose = shifted(&tcp_of(&target_a()), SHIFT, TURN);
        rig.step(&[a, line]);
        line
    }

    /// Answers every request at once without a table, or (`accepts` false) takes none: a
    /// line the constant bounds time as fast, or a planning thread without room.
    struct NoTables {
        accepts: bool,
        asked: Option<u64>,
    }

    impl Refiner for NoTables {
        fn request(&mut self, request: &TableRequest) -> bool {
            self.asked = self.accepts.then_some(request.id);
            self.accepts
        }

        fn take(&mut self) -> Option<Refined> {
            self.asked.take().map(|id| Refined { id, plan: None })
        }

        fn forget(&mut self, _through: u64) {}
    }

    /// The ticks a standing arm waits for the table of the line at the front of the primary
    /// sequence.
    fn table_wait_ticks(rig: &Rig) -> u64 {
        let front = rig.executor.sequences.queue(Sequence::Primary).get(0);
        let Some(Some(LinearPlan::Move(line))) = front.map(|q| q.linear) else {
            panic!("no line buffered");
        };
        let configured = config().main.planner.table_wait_ms as f64 * 1e-3;
        (table_wait(configured, line.timing().profile.duration()) / DT) as u64
    }

    #[test]
    fn a_line_sent_to_a_standing_arm_waits_for_its_table() {
        let (mut rig, released) = held();
        let c = rig.line_by(1, SHIFT, TURN);
        let start = pose::pose(&tcp_of(&rig.feedback.q));
        rig.step(&[c]);
        let wait = table_wait_ticks(&rig);
        assert!(wait > 100, "{wait} ticks");
        // The table is being planned: the line waits in the queue, the arm stands.
        for _ in 0..wait / 2 {
            rig.step(&[]);
        }
        let s = rig.executor.status();
        assert_eq!((s.active_job, s.queued_jobs, s.moving), (0, 1, false));
        assert_eq!(rig.states_of(1), [(state::BUFFERED, 0)]);
        released.store(true, Ordering::Relaxed);
        rig.step(&[]);
        assert_eq!(rig.executor.status().active_job, 1);
        assert!(runs_on_table(&rig));
        rig.run_until(20_000, |r| r.is_final(1));
        assert_eq!(rig.final_state(1), Some((state::DONE, 0)));
        rig.check_on_tcp_line(0, start, c.pose);
        rig.check_limits();
        assert_jerk_within_limits(&rig.trace, &rig.limits, DT);
    }

    #[test]
    fn a_line_whose_table_is_late_starts_on_constant_bounds_after_the_wait_and_keeps_them() {
        let (mut rig, released) = held();
        let c = rig.line_by(1, SHIFT, TURN);
        rig.step(&[c]);
        let wait = table_wait_ticks(&rig);
        let waited_from = rig.trace.len();
        rig.run_until(10_000, |r| r.executor.status().active_job == 1);
        assert_eq!((rig.trace.len() - waited_from) as u64, wait);
        assert!(!runs_on_table(&rig));
        released.store(true, Ordering::Relaxed);
        rig.run_until(20_000, |r| r.is_final(1) || runs_on_table(r));
        assert_eq!(rig.final_state(1), Some((state::DONE, 0)));
        rig.check_limits();
        assert_jerk_within_limits(&rig.trace, &rig.limits, DT);
    }

    #[test]
    fn a_line_without_a_table_to_wait_for_starts_at_once() {
        for accepts in [true, false] {
            let refiner = NoTables {
                accepts,
                asked: None,
            };
            let executor = Executor::with_refiner(&config(), 0xABCD, Box::new(refiner));
            let mut rig = Rig::with(executor);
            let c = rig.line_by(1, SHIFT, TURN);
            rig.step(&[c]);
            assert_eq!(rig.executor.status().active_job, 1, "accepts: {accepts}");
            assert!(!runs_on_table(&rig));
            rig.run_until(20_000, |r| r.is_final(1));
            assert_eq!(rig.final_state(1), Some((state::DONE, 0)));
        }
    }

    #[test]
    fn the_wait_for_a_table_is_the_configured_one_and_at_most_a_quarter_of_the_line() {
        assert_eq!(table_wait(0.15, 2.0), 0.15);
        assert_eq!(table_wait(0.15, 0.2), 0.05);
        assert_eq!(table_wait(0.0, 2.0), 0.0);
    }

    #[test]
    fn a_line_buffered_behind_a_running_move_gets_its_table() {
        let (mut rig, released) = held();
        let line = joint_move_then_line(&mut rig);
        released.store(true, Ordering::Relaxed);
        rig.run_until(20_000, |r| r.executor.status().active_job == 2);
        assert!(runs_on_table(&rig));
        rig.run_until(20_000, |r| r.is_final(2));
        assert_eq!(rig.final_state(2), Some((state::DONE, 0)));
        super::linear::assert_tcp_at(&rig.feedback.q, line.pose);
        rig.check_limits();
        assert_jerk_within_limits(&rig.trace, &rig.limits, DT);
    }

    #[test]
    fn a_late_table_of_an_aborted_line_never_goes_into_a_new_one_of_the_same_job() {
        let (mut rig, released) = held_for(1);
        joint_move_then_line(&mut rig);
        rig.run_until(20_000, |r| r.executor.status().active_progress > 20.0);
        // A stop of the primary sequence alone: the requests of the other one stay wanted.
        let mut stop = rig.command(MotionCommandKind::Stop, 3);
        stop.sequence = MotionSequence::Primary as u8;
        rig.step(&[stop]);
        rig.run_until(20_000, |r| r.is_final(3));
        // The PLC sends job numbers again: the same job, the same start, another target.
        let back = rig.move_to(4, target_a());
        let mut line = rig.command(MotionCommandKind::MoveLinear, 2);
        line.tool = tool();
        line.pose = shifted(&tcp_of(&target_a()), [-0.1, 0.05, 0.05], [0.0; 3]);
        rig.step(&[back, line]);
        // Only the aborted line's table is ready when the refiner gives out.
        released.store(true, Ordering::Relaxed);
        rig.run_until(20_000, |r| {
            r.events
                .iter()
                .filter(|e| e.job == 2 && e.state == state::DONE)
                .count()
                > 0
        });
        super::linear::assert_tcp_at(&rig.feedback.q, line.pose);
    }

    #[test]
    fn a_table_ready_once_the_line_is_in_the_window_is_left_out() {
        let (mut rig, released) = held();
        joint_move_then_line(&mut rig);
        // Job 1 ends within the window: job 2 starts in it.
        rig.run_until(20_000, |r| match r.executor.motion.phase {
            Phase::Running(Running { plan, tau, .. }) => {
                plan.timing().profile.duration() - tau < 10.0 * DT
            }
            _ => false,
        });
        released.store(true, Ordering::Relaxed);
        rig.run_until(20_000, |r| r.executor.status().active_job == 2);
        assert!(!runs_on_table(&rig));
        rig.run_until(20_000, |r| r.is_final(2));
        assert_eq!(rig.final_state(2), Some((state::DONE, 0)));
        rig.check_limits();
    }
}

mod sequences {
    use super::*;

    /// `command` acting on (or belonging to) `scope`.
    fn on(scope: MotionSequence, mut command: MotionCommand) -> MotionCommand {
        command.sequence = scope as u8;
        command
    }

    /// A secondary move (a jog) from `from`, turning the last joint by `turn`.
    fn jog(rig: &mut Rig, job: u32, from: [f64; AXES], turn: f64) -> MotionCommand {
        let mut target = from;
        target[5] += turn;
        let c = rig.move_to(job, target);
        on(MotionSequence::Secondary, c)
    }

    impl Rig {
        /// Sends the group command `kind` acting on `scope` as job `job` and steps once.
        fn group(&mut self, kind: MotionCommandKind, job: u32, scope: MotionSequence) {
            let c = self.command(kind, job);
            self.step(&[on(scope, c)]);
        }
    }

    fn active_before(rig: &Rig, first: u32, second: u32) -> bool {
        let at = |job| {
            rig.events
                .iter()
                .position(|e| e.job == job && e.state == state::ACTIVE)
                .unwrap()
        };
        at(first) < at(second)
    }

    /// Rig with primary jobs 1 (to [`target_a`]) and 2 (home), interrupted on the way by
    /// job 3: the arm stands, the primary sequence is held.
    fn interrupted_primary() -> Rig {
        let mut rig = Rig::running(30.0);
        rig.group(MotionCommandKind::Interrupt, 3, MotionSequence::Primary);
        rig.run_until(10_000, |r| r.is_final(3));
        assert_eq!(
            rig.states_of(1).last(),
            Some(&(state::INTERRUPTED, code::INTERRUPTED_BY_GROUP_INTERRUPT))
        );
        rig
    }

    /// [`interrupted_primary`] with jog job 4 run past 20 %.
    fn jogging() -> Rig {
        let mut rig = interrupted_primary();
        let stood = rig.feedback.q;
        let j = jog(&mut rig, 4, stood, 1.0);
        rig.step(&[j]);
        rig.run_until(10_000, |r| r.executor.status().active_progress > 20.0);
        rig
    }

    #[test]
    fn jogging_while_the_primary_sequence_is_held_leaves_its_moves_alone() {
        let mut rig = interrupted_primary();
        let stood = rig.feedback.q;
        let j = jog(&mut rig, 4, stood, 0.3);
        rig.step(&[j]);
        rig.run_until(10_000, |r| r.is_final(4));
        rig.assert_done(&[4]);
        assert_eq!(rig.feedback.q, j.joints_rad);
        let s = rig.executor.status();
        assert!(s.sequence_paused);
        assert_eq!((s.queued_jobs, s.active_job), (2, 0));

        // A jog button released: Halt of the secondary sequence, the held moves stay.
        let k = jog(&mut rig, 5, j.joints_rad, -0.6);
        rig.step(&[k]);
        rig.run_until(10_000, |r| r.executor.status().active_progress > 20.0);
        assert_eq!(rig.executor.status().active_job, 5);
        rig.group(MotionCommandKind::Halt, 0, MotionSequence::Secondary);
        assert_eq!(
            rig.final_state(5),
            Some((state::ABORTED, code::ABORTED_BY_GROUP_STOP))
        );
        rig.run_until(10_000, |r| !r.executor.status().moving);
        assert!(!rig.is_final(1) && !rig.is_final(2));
        assert_eq!(rig.executor.status().queued_jobs, 2);
        assert!(rig.executor.status().sequence_paused);

        rig.group(MotionCommandKind::Continue, 6, MotionSequence::Primary);
        rig.run_until(20_000, |r| r.is_final(2));
        rig.assert_done(&[1, 2]);
        assert_eq!(rig.feedback.q, home());
        rig.check_limits();
    }

    #[test]
    fn a_secondary_move_waits_for_the_running_primary_move_and_goes_before_the_next() {
        let mut rig = Rig::running(10.0);
        let j = jog(&mut rig, 3, target_a(), 0.5);
        rig.step(&[j]);
        assert_eq!(rig.states_of(3), vec![(state::BUFFERED, 0)]);
        // Only primary moves count as queued.
        assert_eq!(rig.executor.status().queued_jobs, 1);
        rig.run_until(20_000, |r| r.is_final(2));
        assert!(active_before(&rig, 1, 3) && active_before(&rig, 3, 2));
        rig.assert_done(&[1, 2, 3]);
        assert_eq!(rig.feedback.q, home());
        rig.check_limits();
    }

    #[test]
    fn interrupting_the_secondary_sequence_keeps_its_move_and_blocks_the_primary_one() {
        let mut rig = Rig::new();
        let start = rig.feedback.q;
        let j = jog(&mut rig, 1, start, 1.5);
        rig.step(&[j]);
        rig.run_until(10_000, |r| r.executor.status().active_progress > 30.0);
        rig.group(MotionCommandKind::Interrupt, 2, MotionSequence::Secondary);
        assert_eq!(
            rig.states_of(1).last(),
            Some(&(state::INTERRUPTED, code::INTERRUPTED_BY_GROUP_INTERRUPT))
        );
        rig.run_until(10_000, |r| r.is_final(2));
        rig.assert_done(&[2]);
        assert!(!rig.executor.status().sequence_paused);
        // A primary move waits behind the held secondary one.
        let c = rig.move_to(3, home());
        rig.step(&[c]);
        let stood = rig.feedback.q;
        for _ in 0..200 {
            rig.step(&[]);
        }
        assert_eq!(rig.feedback.q, stood);
        assert_eq!(rig.states_of(3), vec![(state::BUFFERED, 0)]);
        rig.group(MotionCommandKind::Continue, 4, MotionSequence::Secondary);
        rig.run_until(20_000, |r| r.is_final(3));
        rig.assert_done(&[1, 3]);
        assert!(active_before(&rig, 1, 3));
        assert_eq!(rig.feedback.q, home());
        rig.check_limits();
        rig.check_on_line(0, start, j.joints_rad);
    }

    #[test]
    fn interrupting_both_sequences_holds_each_until_its_own_continue() {
        let mut rig = Rig::new();
        let a = rig.move_to(1, target_a());
        rig.step(&[a]);
        rig.run_until(10_000, |r| r.executor.status().active_progress > 30.0);
        rig.group(MotionCommandKind::Interrupt, 2, MotionSequence::All);
        rig.run_until(10_000, |r| r.is_final(2));
        assert!(rig.executor.status().sequence_paused);
        let stood = rig.feedback.q;
        let j = jog(&mut rig, 3, stood, 0.2);
        rig.step(&[j]);
        for _ in 0..100 {
            rig.step(&[]);
        }
        assert_eq!(rig.states_of(3), vec![(state::BUFFERED, 0)]);
        rig.group(MotionCommandKind::Continue, 4, MotionSequence::Secondary);
        rig.run_until(10_000, |r| r.is_final(3));
        rig.assert_done(&[3]);
        for _ in 0..100 {
            rig.step(&[]);
        }
        assert!(!rig.is_final(1));
        rig.group(MotionCommandKind::Continue, 5, MotionSequence::Primary);
        rig.run_until(20_000, |r| r.is_final(1));
        rig.assert_done(&[1]);
        assert_eq!(rig.feedback.q, target_a());
        rig.check_limits();
    }

    #[test]
    fn an_aborting_secondary_move_aborts_only_secondary_moves() {
        let mut rig = interrupted_primary();
        let stood = rig.feedback.q;
        let j = jog(&mut rig, 4, stood, 1.0);
        let k = jog(&mut rig, 5, j.joints_rad, 0.2);
        rig.step(&[j, k]);
        rig.run_until(10_000, |r| r.executor.status().active_progress > 20.0);
        let mut l = jog(&mut rig, 6, stood, -0.3);
        l.aborting = true;
        rig.step(&[l]);
        let abort = (state::ABORTED, code::ABORTED_BY_MOTION_COMMAND);
        assert_eq!(rig.final_state(4), Some(abort));
        assert_eq!(rig.final_state(5), Some(abort));
        rig.run_until(10_000, |r| r.is_final(6));
        rig.assert_done(&[6]);
        assert_eq!(rig.feedback.q, l.joints_rad);
        assert!(!rig.is_final(1) && !rig.is_final(2));
        assert_eq!(rig.executor.status().queued_jobs, 2);
        rig.check_limits();
    }

    #[test]
    fn a_halt_of_the_secondary_sequence_leaves_a_running_primary_move_alone() {
        let mut rig = Rig::new();
        let a = rig.move_to(1, target_a());
        rig.step(&[a]);
        rig.run_until(10_000, |r| r.executor.status().active_progress > 30.0);
        let j = jog(&mut rig, 2, target_a(), 0.3);
        rig.step(&[j]);
        rig.group(MotionCommandKind::Halt, 0, MotionSequence::Secondary);
        assert_eq!(
            rig.final_state(2),
            Some((state::ABORTED, code::ABORTED_BY_GROUP_STOP))
        );
        assert!(!rig.executor.status().decelerating);
        rig.run_until(10_000, |r| r.is_final(1));
        rig.assert_done(&[1]);
        assert_eq!(rig.feedback.q, target_a());
    }

    #[test]
    fn a_group_stop_ends_both_sequences() {
        let mut rig = jogging();
        rig.group(MotionCommandKind::Stop, 5, MotionSequence::All);
        let abort = (state::ABORTED, code::ABORTED_BY_GROUP_STOP);
        for job in [1, 2, 4] {
            assert_eq!(rig.final_state(job), Some(abort), "job {job}");
        }
        rig.run_until(10_000, |r| r.is_final(5));
        rig.assert_done(&[5]);
        let s = rig.executor.status();
        assert!(!s.sequence_paused && !s.moving);
        assert_eq!(s.queued_jobs, 0);
    }

    #[test]
    fn step_mode_holds_the_primary_sequence_after_each_move() {
        let mut rig = Rig::new();
        let mut a = rig.move_to(1, target_a());
        a.hold_after = true;
        let b = rig.move_to(2, home());
        rig.step(&[a, b]);
        rig.run_until(10_000, |r| r.is_final(1));
        rig.assert_done(&[1]);
        for _ in 0..200 {
            rig.step(&[]);
        }
        assert_eq!(rig.states_of(2), vec![(state::BUFFERED, 0)]);
        let s = rig.executor.status();
        assert!(s.sequence_paused);
        assert_eq!(s.queued_jobs, 1);
        // A secondary move still runs; its own StepMode flag holds nothing.
        let mut j = jog(&mut rig, 3, target_a(), 0.2);
        j.hold_after = true;
        rig.step(&[j]);
        rig.run_until(10_000, |r| r.is_final(3));
        let k = jog(&mut rig, 4, j.joints_rad, -0.2);
        rig.step(&[k]);
        rig.run_until(10_000, |r| r.is_final(4));
        rig.assert_done(&[4]);
        rig.group(MotionCommandKind::Continue, 5, MotionSequence::Primary);
        rig.run_until(20_000, |r| r.is_final(2));
        rig.assert_done(&[2]);
        assert!(!rig.executor.status().sequence_paused);
        // A move done at once holds as well.
        let mut c = rig.move_to(6, home());
        c.hold_after = true;
        rig.step(&[c]);
        rig.assert_done(&[6]);
        assert!(rig.executor.status().sequence_paused);
    }

    #[test]
    fn targets_outside_the_plc_sw_limits_are_refused() {
        let mut rig = Rig::new();
        let target = target_a();
        let mut low = rig.move_to(1, target);
        low.sw_lower_rad[1] = target[1] + 0.1;
        let mut high = rig.move_to(2, target);
        high.sw_upper_rad[4] = target[4] - 0.1;
        let mut inside = rig.move_to(3, target);
        inside.sw_lower_rad = target.map(|q| q - 0.01);
        inside.sw_upper_rad = target.map(|q| q + 0.01);
        rig.step(&[low, high, inside]);
        assert_eq!(
            rig.final_state(1),
            Some((state::ERROR, code::SW_LIMIT_LOWER))
        );
        assert_eq!(
            rig.final_state(2),
            Some((state::ERROR, code::SW_LIMIT_UPPER))
        );
        rig.run_until(10_000, |r| r.is_final(3));
        rig.assert_done(&[3]);
    }

    #[test]
    fn a_direct_move_chooses_a_solution_within_the_sw_limits() {
        let mut rig = Rig::new();
        let target = target_a();
        let pose = Kinematics::new(&config().robot.kinematics).flange_pose(&target);
        // Joint 6 ends at -2 rad on the nearest turn; the SW limits only allow the next one.
        let mut c = rig.command(MotionCommandKind::MoveDirect, 1);
        c.pose = pose;
        c.sw_lower_rad[5] = -1.0;
        let mut none = c;
        none.sw_upper_rad[5] = 1.0;
        (none.job, none.seq) = (2, c.seq);
        c.seq = rig.command(MotionCommandKind::MoveDirect, 1).seq;
        rig.step(&[none]);
        assert_eq!(
            rig.final_state(2),
            Some((state::ERROR, code::SW_LIMIT_LOWER))
        );
        rig.step(&[c]);
        rig.run_until(20_000, |r| r.is_final(1));
        rig.assert_done(&[1]);
        let turned = target[5] + core::f64::consts::TAU;
        assert!(
            (rig.feedback.q[5] - turned).abs() < 1e-6,
            "{:?}",
            rig.feedback.q
        );
    }

    #[test]
    fn a_line_through_the_plc_sw_limits_is_refused() {
        // Where the joints go on the line, from a free run of it.
        let mut free = Rig::new();
        let c = free.line_by(1, SHIFT, TURN);
        free.step(&[c]);
        free.run_until(20_000, |r| r.is_final(1));
        let (start, end) = (home(), free.feedback.q);
        let axis = (0..AXES)
            .max_by(|&a, &b| {
                (end[a] - start[a])
                    .abs()
                    .total_cmp(&(end[b] - start[b]).abs())
            })
            .unwrap();
        let middle = 0.5 * (start[axis] + end[axis]);
        let mut rig = Rig::new();
        let mut c = rig.line_by(1, SHIFT, TURN);
        if end[axis] > start[axis] {
            c.sw_upper_rad[axis] = middle;
        } else {
            c.sw_lower_rad[axis] = middle;
        }
        let expected = if end[axis] > start[axis] {
            code::SW_LIMIT_UPPER
        } else {
            code::SW_LIMIT_LOWER
        };
        rig.step(&[c]);
        assert_eq!(rig.states_of(1), vec![(state::ERROR, expected)]);
    }

    #[test]
    fn drives_switched_off_under_a_jog_hold_it_on_its_own_sequence() {
        let mut rig = jogging();
        rig.feedback.qd = [0.0; AXES];
        rig.feedback.state = DriveState::Off as u8;
        rig.window = rig.executor.step(&rig.feedback, &[]);
        rig.collect_events();
        assert_eq!(
            rig.states_of(4).last(),
            Some(&(state::INTERRUPTED, code::INTERRUPTED_NOT_ENABLED))
        );
        assert_eq!(rig.executor.status().queued_jobs, 2);
        // The PLC lets go of the jog: the secondary sequence is discarded, and released.
        rig.feedback.state = DriveState::Holding as u8;
        rig.group(MotionCommandKind::Halt, 0, MotionSequence::Secondary);
        assert_eq!(
            rig.final_state(4),
            Some((state::ABORTED, code::ABORTED_BY_GROUP_STOP))
        );
        let here = rig.feedback.q;
        let k = jog(&mut rig, 5, here, 0.1);
        rig.step(&[k]);
        rig.run_until(10_000, |r| r.is_final(5));
        rig.assert_done(&[5]);
        assert!(!rig.is_final(1) && rig.executor.status().sequence_paused);
    }
}

mod blending {
    use super::*;
    use crate::joint_move::Plan;

    const EXACT_STOP: u8 = 0;
    const DEFINED_VELOCITY: u8 = 2;
    const CORNER_DISTANCE: u8 = 3;
    const MAX_CORNER_DEVIATION: u8 = 4;
    const CORNER_DISTANCE_2R: u8 = 10;
    const RAMP_OVERLAP: u8 = 11;
    const CORNER_DISTANCE_1R: u8 = 12;

    fn shifted_joints(q: [f64; AXES], delta: [f64; AXES]) -> [f64; AXES] {
        core::array::from_fn(|i| q[i] + delta[i])
    }

    /// The corner of the pair: where A ends and B starts.
    fn corner() -> [f64; AXES] {
        shifted_joints(home(), [0.8, 0.0, 0.0, 0.0, 0.0, 0.3])
    }

    /// Where B ends, moving other joints than A.
    fn b_end() -> [f64; AXES] {
        shifted_joints(corner(), [0.0, 0.6, 0.9, 0.4, 0.0, 0.0])
    }

    impl Rig {
        /// A move to `target` that blends into the next one by `mode` and `parameter`.
        fn blending_to(
            &mut self,
            job: u32,
            target: [f64; AXES],
            mode: u8,
            parameter: [f64; 2],
        ) -> MotionCommand {
            let c = self.move_to(job, target);
            with_blending(c, mode, parameter)
        }

        /// Every job of `jobs` ended DONE, the arm at `target`, every point within the
        /// limits.
        fn assert_done_at(&self, jobs: &[u32], target: [f64; AXES]) {
            self.assert_done(jobs);
            assert_eq!(self.feedback.q, target);
            self.check_limits();
        }

        /// A line of the TCP to [`corner`]'s shifted by `shift` (m), blending by `mode`.
        fn blending_line(
            &mut self,
            job: u32,
            shift: [f64; 3],
            mode: u8,
            parameter: [f64; 2],
        ) -> MotionCommand {
            let mut c = self.line_by(job, [0.0; 3], [0.0; 3]);
            c.pose = shifted(&tcp_of(&corner()), shift, [0.0; 3]);
            with_blending(c, mode, parameter)
        }
    }

    fn with_blending(mut command: MotionCommand, mode: u8, parameter: [f64; 2]) -> MotionCommand {
        command.blending_mode = mode;
        command.blending_parameter = parameter;
        command
    }

    /// Rig with A (job 1, to [`corner`], blending by `mode`) and B (job 2, to [`b_end`])
    /// sent together.
    fn pair(mode: u8, parameter: [f64; 2]) -> Rig {
        let mut rig = Rig::new();
        let a = rig.blending_to(1, corner(), mode, parameter);
        let b = rig.move_to(2, b_end());
        rig.step(&[a, b]);
        rig
    }

    /// Override changes under way when a joint move's blend into a line is decided: the
    /// overlap starts late enough for the rate to come down to the line's on the way, and
    /// the windows already sent stay as they were. Held at once when the overlap began, the
    /// lower rate stepped the acceleration in one tick by at least 3.6 times the jerk limit
    /// (up to 9 times in the random blended sequences, which found it); brought down from
    /// the earliest start the window allows, it changed points the servo had been sent.
    #[test]
    fn a_blend_entered_during_an_override_ramp_keeps_the_jerk_near_its_limit() {
        let within = 1.0 + crate::motion::OVERRIDE_JERK_SHARE;
        // A move of several joints blending at a corner distance, and a turn of the wrist
        // blending at a full ramp overlap, where the overlap starts as early as it may.
        let long = (
            shifted_joints(home(), [-0.05, -0.46, 0.5, 0.6, 0.22, -0.05]),
            (CORNER_DISTANCE_2R, [0.19, 0.17]),
            shifted(&tcp_of(&home()), [-0.057, 0.096, -0.086], [0.0; 3]),
        );
        let wrist = shifted_joints(home(), [0.0, 0.0, 0.0, 0.0, 0.0, 0.2]);
        let short = (
            wrist,
            (RAMP_OVERLAP, [1.0, 0.0]),
            shifted(&tcp_of(&wrist), [-0.2, 0.05, 0.0], [0.0; 3]),
        );
        // (move, line, at progress %, override from 100 % or 20 % to)
        let cases = [
            (long, 20.0, (1.0, 0.3)),
            (long, 40.0, (1.0, 0.1)),
            (long, 48.0, (1.0, 0.6)),
            (short, 10.0, (1.0, 0.1)),
            (short, 25.0, (0.2, 1.0)),
        ];
        for ((target, (mode, parameter), pose), at, (from, to)) in cases {
            let mut rig = Rig::new();
            rig.set_override(9, from);
            let joint = with_blending(rig.move_to(1, target), mode, parameter);
            let mut line = rig.command(MotionCommandKind::MoveLinear, 2);
            line.tool = tool();
            line.pose = pose;
            rig.step(&[joint, line]);
            rig.run_until(20_000, |r| r.executor.status().active_progress > at);
            rig.set_override(3, to);
            let mut blended = false;
            for _ in 0..20_000 {
                if rig.is_final(2) {
                    break;
                }
                rig.step_keeping_the_window();
                blended |= rig.executor.status().blending;
            }
            assert!(blended, "no blend");
            rig.assert_done(&[1, 2, 3, 9]);
            assert_jerk_within(&rig.trace, &rig.limits, DT, within);
        }
    }

    /// Ticks the pair of `mode` takes from sending to B's end, within the limits.
    fn pair_ticks(mode: u8, parameter: [f64; 2]) -> usize {
        let mut rig = pair(mode, parameter);
        rig.run_until(20_000, |r| r.is_final(2));
        rig.assert_done_at(&[1, 2], b_end());
        rig.trace.len()
    }

    /// A's deceleration ramp at 100 % override, s.
    fn braking_ramp_of_a() -> f64 {
        let mut c = MotionCommand::new(MotionCommandKind::MoveAxes);
        c.joints_rad = corner();
        let cfg = config();
        let Ok(Plan::Move(m)) = JointMove::plan(
            home(),
            &c,
            &cfg.robot.limits_rad(),
            cfg.main.planner.override_reserve,
        ) else {
            panic!("A moves");
        };
        let profile = m.timing().profile;
        let total = profile.duration();
        let braking = (0..=100_000)
            .map(|k| total * k as f64 / 100_000.0)
            .find(|&t| profile.eval(t).2 < 0.0)
            .unwrap();
        total - braking
    }

    #[test]
    fn a_full_ramp_overlap_shortens_the_pair_by_the_braking_ramp() {
        let exact = pair_ticks(EXACT_STOP, [0.0; 2]);
        let ramp = pair_ticks(RAMP_OVERLAP, [1.0, 0.0]);
        let saved = (exact - ramp) as f64 * DT;
        assert!((saved - braking_ramp_of_a()).abs() <= 3.0 * DT, "{saved}");
        // Half the overlap saves half the time.
        let half = pair_ticks(RAMP_OVERLAP, [0.5, 0.0]);
        let saved_half = (exact - half) as f64 * DT;
        assert!((saved_half - 0.5 * braking_ramp_of_a()).abs() <= 3.0 * DT);
    }

    #[test]
    fn every_mode_blends_as_its_parameter_says() {
        let exact = pair_ticks(EXACT_STOP, [0.0; 2]);
        let ramp = pair_ticks(RAMP_OVERLAP, [1.0, 0.0]);
        // Slowing down to the full speed is the start of the braking ramp.
        let velocity = pair_ticks(DEFINED_VELOCITY, [1.0, 0.0]);
        assert!(velocity.abs_diff(ramp) <= 2, "{velocity} {ramp}");
        assert!(pair_ticks(DEFINED_VELOCITY, [0.2, 0.0]) > velocity);
        // Larger radii and deviations blend earlier.
        let radius = |r: f64| pair_ticks(CORNER_DISTANCE, [r, 0.0]);
        let (near, far) = (radius(0.01), radius(0.05));
        assert!(exact > near && near > far, "{exact} {near} {far}");
        let deviation = |d: f64| pair_ticks(MAX_CORNER_DEVIATION, [d, 0.0]);
        assert!(exact > deviation(0.002) && deviation(0.002) > deviation(0.01));
        // Joining closer to the corner than leaving: the join radius decides.
        let two = pair_ticks(CORNER_DISTANCE_2R, [0.05, 0.01]);
        assert!(two > far && two < exact);
        let one = pair_ticks(CORNER_DISTANCE_1R, [0.05, 0.0]);
        assert!(one >= far && one < exact);
    }

    #[test]
    fn a_parameter_asking_for_too_much_is_clipped_to_half_of_each_move() {
        // A's braking ramp is half of it, and B is the longer move: both clip there.
        let ramp = pair_ticks(RAMP_OVERLAP, [1.0, 0.0]);
        let huge = pair_ticks(CORNER_DISTANCE, [10.0, 0.0]);
        assert!(huge.abs_diff(ramp) <= 2, "{huge} {ramp}");
        let fraction = pair_ticks(RAMP_OVERLAP, [7.0, 0.0]);
        assert_eq!(fraction, ramp);
    }

    #[test]
    fn a_is_done_when_b_becomes_active_and_the_status_shows_the_blend() {
        let mut rig = pair(RAMP_OVERLAP, [1.0, 0.0]);
        rig.run_until(10_000, |r| r.is_final(1));
        assert!(rig.executor.is_blending());
        let s = rig.executor.status();
        assert!(s.moving);
        assert_eq!((s.active_job, s.queued_jobs), (2, 0));
        let order: Vec<(u32, u8)> = rig.events.iter().map(|e| (e.job, e.state)).collect();
        assert_eq!(
            order,
            [
                (1, state::BUFFERED),
                (2, state::BUFFERED),
                (1, state::ACTIVE),
                (1, state::DONE),
                (2, state::ACTIVE),
            ]
        );
        // The arm never stood at the corner.
        assert!(!rig.trace.iter().any(|p| p.q == corner()));
        rig.run_until(10_000, |r| r.is_final(2));
        assert!(!rig.executor.is_blending());
        rig.assert_done(&[2]);
        rig.check_limits();
    }

    #[test]
    fn a_late_next_move_or_a_step_mode_hold_means_an_exact_stop() {
        let mut rig = Rig::new();
        let a = rig.blending_to(1, corner(), RAMP_OVERLAP, [1.0, 0.0]);
        rig.step(&[a]);
        rig.run_until(10_000, |r| r.executor.status().active_progress > 60.0);
        let b = rig.move_to(2, b_end());
        rig.step(&[b]);
        rig.run_until(10_000, |r| r.is_final(2));
        assert!(
            rig.trace
                .iter()
                .any(|p| p.q == corner() && p.qd == [0.0; AXES])
        );

        let mut rig = Rig::new();
        let mut a = rig.blending_to(1, corner(), RAMP_OVERLAP, [1.0, 0.0]);
        a.hold_after = true;
        a.sequence = MotionSequence::Primary as u8;
        let b = rig.move_to(2, b_end());
        rig.step(&[a, b]);
        rig.run_until(10_000, |r| r.is_final(1));
        assert_eq!(rig.feedback.q, corner());
        assert!(rig.executor.status().sequence_paused && !rig.is_final(2));
    }

    #[test]
    fn a_stop_during_the_blend_brakes_on_the_blended_path_and_discards_b() {
        let mut rig = pair(RAMP_OVERLAP, [1.0, 0.0]);
        rig.run_until(10_000, |r| r.executor.is_blending());
        for _ in 0..50 {
            rig.step(&[]);
        }
        let stop = rig.command(MotionCommandKind::Stop, 3);
        rig.step(&[stop]);
        rig.assert_done(&[1]);
        assert_eq!(
            rig.final_state(2),
            Some((state::ABORTED, code::ABORTED_BY_GROUP_STOP))
        );
        rig.run_until(10_000, |r| r.is_final(3));
        rig.assert_done(&[3]);
        assert!(!rig.executor.status().moving);
        let stood = rig.feedback.q;
        for _ in 0..100 {
            rig.step(&[]);
        }
        assert_eq!(rig.feedback.q, stood);
        assert_ne!(stood, b_end());
        rig.check_limits();
    }

    #[test]
    fn an_interrupt_during_the_blend_holds_b_and_continue_finishes_it() {
        let mut rig = pair(CORNER_DISTANCE, [0.05, 0.0]);
        rig.run_until(10_000, |r| r.executor.is_blending());
        rig.set_override(3, 0.6);
        rig.interrupt_and_stand(4, 2);
        let resume = rig.command(MotionCommandKind::Continue, 5);
        rig.step(&[resume]);
        rig.run_until(10_000, |r| r.is_final(2));
        rig.assert_done_at(&[1, 2, 3, 4, 5], b_end());
    }

    #[test]
    fn override_changes_during_the_blend_keep_the_limits() {
        let mut rig = pair(CORNER_DISTANCE_1R, [0.05, 0.0]);
        rig.run_until(10_000, |r| r.executor.is_blending());
        rig.set_override(3, 0.2);
        for _ in 0..30 {
            rig.step(&[]);
        }
        rig.set_override(4, 1.0);
        rig.run_until(10_000, |r| r.is_final(2));
        rig.assert_done_at(&[1, 2, 3, 4], b_end());
    }

    #[test]
    fn joint_and_linear_moves_blend_into_each_other() {
        let mut rig = Rig::new();
        let a = rig.blending_to(1, corner(), RAMP_OVERLAP, [1.0, 0.0]);
        let line = rig.blending_line(2, [0.1, 0.05, -0.05], CORNER_DISTANCE_1R, [0.03, 0.0]);
        let back = rig.blending_line(3, [0.1, -0.08, 0.0], RAMP_OVERLAP, [1.0, 0.0]);
        let home_again = rig.move_to(4, home());
        // Joint into line, line into line, line into joint.
        let (_, blends) = run_counting_blends(&mut rig, &[a, line, back, home_again]);
        assert_eq!(blends, 3);
        rig.assert_done_at(&[1, 2, 3, 4], home());
    }

    /// Two lines on in the same direction at 10 % of the TCP speed, A blending 50 mm before
    /// the corner: B speeding up while A still cruises adds their speeds (the blended TCP
    /// ran at 1.22 times the programmed speed). The overlap shrinks until the sum keeps the
    /// speed, and the pair still blends.
    #[test]
    fn blended_lines_keep_their_programmed_tcp_speed() {
        let mut rig = Rig::new();
        let [mut a, mut b] =
            [(1, 0.15), (2, 0.3)].map(|(job, y)| rig.line_by(job, [0.0, y, 0.0], [0.0; 3]));
        for line in [&mut a, &mut b] {
            line.velocity_scale = 0.1;
        }
        let a = with_blending(a, CORNER_DISTANCE, [0.05, 0.0]);
        let (_, blends) = run_counting_blends(&mut rig, &[a, b]);
        assert_eq!(blends, 1);
        rig.assert_done(&[1, 2]);
        let programmed = 0.1 * config().robot.cartesian.max_velocity_mm_s * 1e-3;
        let fastest = rig
            .trace
            .windows(2)
            .map(|w| {
                (tcp_of(&w[1].q).translation.vector - tcp_of(&w[0].q).translation.vector).norm()
                    / DT
            })
            .fold(0.0, f64::max);
        assert!(
            fastest <= programmed * (1.0 + 1e-3),
            "the TCP ran at {fastest:.4} m/s, programmed {programmed:.4} m/s"
        );
    }

    /// Runs `commands` (jobs 1..=n) to their end: the ticks it took and the blends on the
    /// way.
    fn run_counting_blends(rig: &mut Rig, commands: &[MotionCommand]) -> (usize, usize) {
        let last = commands.len() as u32;
        rig.step(commands);
        let (mut blends, mut was_blending) = (0, false);
        for _ in 0..30_000 {
            if rig.is_final(last) {
                break;
            }
            rig.step(&[]);
            let blending = rig.executor.is_blending();
            blends += usize::from(blending && !was_blending);
            was_blending = blending;
        }
        (rig.trace.len(), blends)
    }

    /// Blends whose two moves' jerks add up: joint → line → line → joint at full ramp
    /// overlaps, and a joint braked by A while B starts it on (the jerks of both at the
    /// limit, twice the limit in sum). Their overlaps run slower, the time scale coming
    /// down before them as an override ramp would: the jerk stays within what such a ramp
    /// adds (before: at least 1.65 and 2.0 times the limit), and every blend still shortens
    /// the sequence against exact stops.
    #[test]
    fn blends_whose_jerks_add_up_run_slower_and_keep_the_jerk_near_its_limit() {
        let within = 1.0 + crate::motion::OVERRIDE_JERK_SHARE;
        // (joint pair, RAMP_OVERLAP fraction)
        for (joint_pair, fraction) in [(false, 1.0), (true, 0.5)] {
            let sequence = |rig: &mut Rig, mode: u8| {
                let parameter = [fraction, 0.0];
                if joint_pair {
                    let mut pair = same_joint_pair(rig);
                    pair[0] = with_blending(pair[0], mode, parameter);
                    return pair;
                }
                vec![
                    rig.blending_to(1, corner(), mode, parameter),
                    rig.blending_line(2, [0.1, 0.05, -0.05], mode, parameter),
                    rig.blending_line(3, [0.1, -0.08, 0.0], mode, parameter),
                    rig.move_to(4, home()),
                ]
            };
            let mut exact = Rig::new();
            let commands = sequence(&mut exact, EXACT_STOP);
            let (exact_ticks, _) = run_counting_blends(&mut exact, &commands);
            let mut rig = Rig::new();
            let commands = sequence(&mut rig, RAMP_OVERLAP);
            let (ticks, blends) = run_counting_blends(&mut rig, &commands);
            assert_eq!(blends, commands.len() - 1);
            assert!(ticks < exact_ticks, "{ticks} {exact_ticks}");
            rig.assert_done(&(1..=commands.len() as u32).collect::<Vec<_>>());
            rig.check_limits();
            assert_jerk_within(&rig.trace, &rig.limits, DT, within);
        }
    }

    /// A joint braked by A while B starts it on (twice the jerk limit at full speed).
    fn same_joint_pair(rig: &mut Rig) -> Vec<MotionCommand> {
        let on = shifted_joints(home(), [0.8, 0.0, 0.0, 0.0, 0.0, 0.0]);
        let further = shifted_joints(on, [0.8, 0.0, 0.0, 0.0, 0.0, 0.0]);
        vec![
            rig.blending_to(1, on, RAMP_OVERLAP, [0.5, 0.0]),
            rig.move_to(2, further),
        ]
    }

    /// An override raised after a slowed blend was decided (at 20 %, where σ needs no
    /// slow-down) keeps the jerk near its limit: the slow-down is scheduled for any
    /// override (scheduled for the one at the decision, a review measured 1.96 times the
    /// limit; this case kept it either way). And an override of 0 inside a slowed overlap
    /// halts it, and raised again it resumes (it stood for good while the overlap never
    /// ramped up past where σ came to rest).
    #[test]
    fn slowed_overlaps_follow_later_override_changes() {
        let within = 1.0 + crate::motion::OVERRIDE_JERK_SHARE;
        let mut rig = Rig::new();
        rig.set_override(9, 0.2);
        let commands = same_joint_pair(&mut rig);
        rig.step(&commands);
        rig.run_until(20_000, |r| r.executor.status().active_progress > 10.0);
        rig.set_override(10, 1.0);
        rig.run_until(20_000, |r| r.is_final(2));
        rig.assert_done(&[1, 2, 9, 10]);
        assert_jerk_within(&rig.trace, &rig.limits, DT, within);

        let mut rig = Rig::new();
        rig.set_override(8, 0.1);
        let commands = same_joint_pair(&mut rig);
        rig.step(&commands);
        rig.run_until(20_000, |r| r.executor.is_blending());
        rig.set_override(9, 0.0);
        rig.run_until(20_000, |r| {
            r.trace.last().is_some_and(|p| p.qd == [0.0; AXES])
        });
        assert!(rig.executor.is_blending() && !rig.is_final(2));
        rig.set_override(10, 1.0);
        rig.run_until(20_000, |r| r.is_final(2));
        rig.assert_done(&[1, 2, 8, 9, 10]);
        rig.check_limits();
    }

    #[test]
    fn a_wait_stands_for_its_duration_and_is_not_blended_across() {
        let mut rig = Rig::new();
        let a = rig.blending_to(1, corner(), RAMP_OVERLAP, [1.0, 0.0]);
        let mut wait = rig.command(MotionCommandKind::Wait, 2);
        wait.duration_s = 0.25;
        let b = rig.move_to(3, b_end());
        rig.step(&[a, wait, b]);
        rig.run_until(10_000, |r| r.is_final(1));
        assert_eq!(rig.feedback.q, corner());
        let from = rig.trace.len();
        rig.run_until(10_000, |r| r.is_final(2));
        let waited = rig.trace.len() - from;
        assert!(waited.abs_diff(250) <= 2, "{waited}");
        assert!(rig.trace[from..].iter().all(|p| p.q == corner()));
        rig.run_until(10_000, |r| r.is_final(3));
        rig.assert_done(&[1, 2, 3]);
        assert_eq!(rig.feedback.q, b_end());
    }

    #[test]
    fn an_interrupt_pauses_the_clock_of_a_wait() {
        let mut rig = Rig::new();
        let mut wait = rig.command(MotionCommandKind::Wait, 1);
        wait.duration_s = 0.3;
        let b = rig.move_to(2, corner());
        rig.step(&[wait, b]);
        for _ in 0..99 {
            rig.step(&[]);
        }
        let interrupt = rig.command(MotionCommandKind::Interrupt, 3);
        rig.step(&[interrupt]);
        assert_eq!(
            rig.states_of(1).last(),
            Some(&(state::INTERRUPTED, code::INTERRUPTED_BY_GROUP_INTERRUPT))
        );
        rig.assert_done(&[3]);
        for _ in 0..500 {
            rig.step(&[]);
        }
        assert!(!rig.is_final(1));
        let resume = rig.command(MotionCommandKind::Continue, 4);
        rig.step(&[resume]);
        let from = rig.trace.len();
        rig.run_until(10_000, |r| r.is_final(1));
        let rest = rig.trace.len() - from;
        assert!(rest.abs_diff(200) <= 2, "{rest}");
        rig.run_until(10_000, |r| r.is_final(2));
        rig.assert_done(&[1, 2, 4]);
    }

    #[test]
    fn invalid_blending_and_wait_parameters_are_refused() {
        let mut rig = Rig::new();
        let bad_mode = rig.blending_to(1, corner(), 1, [0.0; 2]);
        let bad_parameter = rig.blending_to(2, corner(), CORNER_DISTANCE, [-0.1, 0.0]);
        let mut bad_wait = rig.command(MotionCommandKind::Wait, 3);
        bad_wait.duration_s = f64::NAN;
        rig.step(&[bad_mode, bad_parameter, bad_wait]);
        let codes: Vec<_> = (1..=3).map(|job| rig.final_state(job)).collect();
        let refused = |code| Some((state::ERROR, code));
        assert_eq!(
            codes,
            [
                refused(code::INVALID_BLENDING_MODE),
                refused(code::INVALID_BLENDING_PARAMETER),
                refused(code::INVALID_TIME)
            ]
        );
    }

    mod random {
        use super::*;
        use proptest::prelude::*;

        #[derive(Debug, Clone)]
        enum Leg {
            /// A joint move to home plus these offsets.
            Joint([f64; AXES]),
            /// A line of the TCP to home's shifted by this much (m).
            Line([f64; 3]),
            /// An arc of the TCP through home's shifted by the first shift (m) to home's
            /// shifted by the second.
            Arc([f64; 3], [f64; 3]),
        }

        fn leg() -> impl Strategy<Value = Leg> {
            let shift = || prop::array::uniform3(-0.12f64..0.12);
            prop_oneof![
                prop::array::uniform6(-0.6f64..0.6).prop_map(Leg::Joint),
                shift().prop_map(Leg::Line),
                (shift(), shift()).prop_map(|(via, end)| Leg::Arc(via, end)),
            ]
        }

        /// VelocityRate, AccelerationRate, DecelerationRate and JerkRate.
        fn rates() -> impl Strategy<Value = [f64; 4]> {
            prop::array::uniform4(0.2f64..=1.0)
        }

        fn blending() -> impl Strategy<Value = (u8, [f64; 2])> {
            prop_oneof![
                Just((EXACT_STOP, [0.0; 2])),
                (0.0f64..1.2).prop_map(|f| (DEFINED_VELOCITY, [f, 0.0])),
                (0.0f64..0.3).prop_map(|r| (CORNER_DISTANCE, [r, 0.0])),
                (0.0f64..0.05).prop_map(|d| (MAX_CORNER_DEVIATION, [d, 0.0])),
                (0.0f64..0.3, 0.0f64..0.3).prop_map(|(l, j)| (CORNER_DISTANCE_2R, [l, j])),
                (0.0f64..1.5).prop_map(|f| (RAMP_OVERLAP, [f, 0.0])),
                (0.0f64..0.3).prop_map(|r| (CORNER_DISTANCE_1R, [r, 0.0])),
            ]
        }

        proptest! {
            #![proptest_config(ProptestConfig::with_cases(16))]

            /// Joint moves, lines and arcs at any rates, blended by any mode, under any
            /// override and within SW limits 0.3 to 1.2 rad either side of home: no tick
            /// leaves a SW limit or a joint velocity or acceleration limit, nor the jerk
            /// limit by more than two moves' jerks (where an overlap had no time to slow
            /// down) and an override ramp add, and every move that was buffered ends DONE
            /// or is refused before it moves.
            #[test]
            fn random_blended_sequences_keep_the_joint_limits(
                legs in prop::collection::vec((leg(), blending(), rates()), 2..6),
                sw_limits in prop::array::uniform6(0.3f64..1.2),
                first_override in 0.3f64..=1.0,
                change in (0usize..3000, 0.0f64..=1.0),
            ) {
                let mut rig = Rig::new();
                rig.set_override(100, first_override);
                let base = home();
                let (lower, upper) = (
                    shifted_joints(base, sw_limits.map(|w| -w)),
                    shifted_joints(base, sw_limits),
                );
                let mut commands = Vec::new();
                for (k, (leg, (mode, parameter), rates)) in legs.iter().enumerate() {
                    let job = k as u32 + 1;
                    let cartesian = |rig: &mut Rig, kind| {
                        let mut c = rig.command(kind, job);
                        c.tool = tool();
                        c
                    };
                    let mut c = match leg {
                        Leg::Joint(offset) => rig.move_to(job, shifted_joints(base, *offset)),
                        Leg::Line(shift) => {
                            let mut c = cartesian(&mut rig, MotionCommandKind::MoveLinear);
                            c.pose = shifted(&tcp_of(&base), *shift, [0.0; 3]);
                            c
                        }
                        Leg::Arc(via, end) => {
                            let mut c = cartesian(&mut rig, MotionCommandKind::MoveCircular);
                            c.aux_pose = shifted(&tcp_of(&base), *via, [0.0; 3]);
                            c.pose = shifted(&tcp_of(&base), *end, [0.0; 3]);
                            c
                        }
                    };
                    [c.velocity_scale, c.acceleration_scale, c.deceleration_scale, c.jerk_scale] =
                        *rates;
                    (c.sw_lower_rad, c.sw_upper_rad) = (lower, upper);
                    commands.push(with_blending(c, *mode, *parameter));
                }
                rig.step(&commands);
                for _ in 0..change.0 {
                    rig.step(&[]);
                }
                rig.set_override(101, change.1);
                for _ in 0..200 {
                    rig.step(&[]);
                }
                rig.set_override(102, 1.0);
                let jobs = 1..=legs.len() as u32;
                rig.run_until(60_000, |r| {
                    jobs.clone().all(|j| r.is_final(j)) && !r.executor.status().moving
                });
                for job in jobs {
                    let states = rig.states_of(job);
                    // A line its start configuration cannot follow is refused at once.
                    let refused = states.len() == 1 && states[0].0 == state::ERROR;
                    prop_assert!(refused || rig.final_state(job) == Some((state::DONE, 0)));
                }
                rig.check_limits();
                for p in &rig.trace {
                    for i in 0..AXES {
                        prop_assert!(
                            p.q[i] >= lower[i] - 1e-9 && p.q[i] <= upper[i] + 1e-9,
                            "joint {} at {} outside its SW limits", i, p.q[i]
                        );
                    }
                }
                let within = 2.0 + crate::motion::OVERRIDE_JERK_SHARE;
                assert_jerk_within(&rig.trace, &rig.limits, DT, within);
            }
        }
    }
}

/// A plan that would leave the guard's limits (here: the guard's velocity limits lowered
/// under a running move, as a planning fault would look) is stopped by the safety filter:
/// the moves end with 0x6C02, the arm brakes within the guard's limits and stands, and
/// after GroupReset moves run again.
#[test]
fn the_safety_filter_stops_a_plan_that_leaves_the_limits() {
    let mut rig = Rig::running(30.0);
    let mut narrow = rig.limits;
    narrow.velocity = narrow.velocity.map(|v| 0.2 * v);
    rig.executor.guard.set_limits(narrow);
    let from = rig.trace.len();
    rig.run_until(5_000, |r| r.is_final(1) && r.is_final(2));
    assert_eq!(rig.final_state(1), Some((state::ERROR, code::MOTION_ERROR)));
    assert_eq!(rig.final_state(2), Some((state::ERROR, code::MOTION_ERROR)));
    assert_eq!(rig.executor.status().error_code, code::MOTION_ERROR);
    rig.run_until(5_000, |r| {
        r.trace.last().is_some_and(|p| p.qd == [0.0; AXES])
    });
    let stood = rig.feedback.q;
    for _ in 0..50 {
        rig.step(&[]);
    }
    assert_eq!(rig.feedback.q, stood, "the arm stands after the guard stop");
    // The stop itself keeps the position and acceleration limits (the velocity limits
    // were lowered under a moving arm: it slows down every tick instead).
    let stop = &rig.trace[from..];
    for w in stop.windows(2) {
        for i in 0..AXES {
            assert!(
                w[1].qd[i].abs() <= w[0].qd[i].abs() + 1e-12,
                "joint {i} speeds up"
            );
            assert!(w[1].qdd[i].abs() <= rig.limits.acceleration[i] * (1.0 + 1e-9));
        }
    }
    rig.executor.guard.set_limits(rig.limits);
    let reset = rig.command(MotionCommandKind::Reset, 3);
    rig.step(&[reset]);
    let back = rig.move_to(4, home());
    rig.step(&[back]);
    rig.run_until(20_000, |r| r.is_final(4));
    rig.assert_done(&[4]);
}
