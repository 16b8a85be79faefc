//! The planner process loop over real iceoryx2 services, driven in lockstep by a simulated
//! servo in the test.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use planner::kinematics::Kinematics;
use shared_types::bus::{Bus, publish, receive_latest};
use shared_types::config::Config;
use shared_types::ipc::{
    AXES, DriveState, JOB_EVENTS, MotionCommand, MotionCommandKind, MotionSequence, MotionStatus,
    ServoFeedback, ServoSetpoint, topics,
};
use shared_types::pose;
use shared_types::srci::message::state;

fn feedback(tick: u64, q: [f64; AXES]) -> ServoFeedback {
    let mut f = ServoFeedback::at_rest(42, q, DriveState::Holding, 1_000_000);
    f.tick = tick;
    f
}

/// What a planner process did with one move command, driven in lockstep until the move was
/// done.
struct Outcome {
    /// Where the servo ended.
    q: [f64; AXES],
    /// Every position the servo applied.
    trace: Vec<[f64; AXES]>,
    events: Vec<(u32, u8)>,
    /// Time from the shutdown request to the end of the planner thread.
    shutdown: Duration,
}

/// Starts the planner of `cfg` on a thread, sends `command` (seq 1, job 1) and drives a
/// simulated servo from `start` until job 1 is final.
fn drive(cfg: &Config, start: [f64; AXES], command: MotionCommand) -> Outcome {
    let shutdown = Arc::new(AtomicBool::new(false));
    let planner = {
        let (cfg, shutdown) = (cfg.clone(), Arc::clone(&shutdown));
        std::thread::spawn(move || planner::run(&cfg, &shutdown))
    };

    let bus = Bus::new(&cfg.main.instance, "servo_sim").expect("bus");
    let feedback_publisher = bus
        .publisher::<ServoFeedback>(topics::SERVO_FEEDBACK)
        .unwrap();
    let feedback_notifier = bus.notifier(topics::SERVO_FEEDBACK).unwrap();
    let command_publisher = bus
        .publisher::<MotionCommand>(topics::MOTION_COMMAND)
        .unwrap();
    let setpoints = bus
        .subscriber::<ServoSetpoint>(topics::SERVO_SETPOINT)
        .unwrap();
    let statuses = bus
        .subscriber::<MotionStatus>(topics::MOTION_STATUS)
        .unwrap();

    let mut q = start;
    let mut trace = Vec::new();
    let mut events = Vec::new();
    let mut seen = 0;
    let deadline = Instant::now() + Duration::from_secs(20);
    let mut tick = 1;
    while !events
        .iter()
        .any(|&(job, s)| job == command.job && state::is_final(s))
    {
        assert!(
            Instant::now() < deadline,
            "the move did not finish: {events:?}"
        );
        // Lockstep: wait for the planner's answer to this tick. The feedback is sent again
        // meanwhile, as a servo does every period: iceoryx2 connects a new subscriber (the
        // planner's, at start) only when the publisher sends.
        let status = 'answer: loop {
            publish(&feedback_publisher, feedback(tick, q)).unwrap();
            feedback_notifier.notify().unwrap();
            for _ in 0..20 {
                assert!(Instant::now() < deadline, "no status for tick {tick}");
                if planner.is_finished() {
                    panic!("planner ended: {:?}", planner.join());
                }
                match receive_latest(&statuses).unwrap() {
                    Some(s) if s.tick == tick => break 'answer s,
                    _ => std::thread::sleep(Duration::from_micros(100)),
                }
            }
        };
        for n in seen + 1..=status.event_head {
            let e = status.events[(n % JOB_EVENTS as u64) as usize];
            events.push((e.job, e.state));
        }
        seen = status.event_head;
        if status.acked_seq < command.seq {
            publish(&command_publisher, command).unwrap();
        }
        if let Some(window) = receive_latest(&setpoints).unwrap() {
            assert_eq!(window.first_tick, tick + 1);
            q = window.points[0].q;
            trace.push(q);
        }
        tick += 1;
    }

    let asked = Instant::now();
    shutdown.store(true, Ordering::Relaxed);
    planner
        .join()
        .expect("planner thread")
        .expect("planner run");
    Outcome {
        q,
        trace,
        events,
        shutdown: asked.elapsed(),
    }
}

/// The embedded configuration with an instance name of its own for test `name`.
fn config(name: &str) -> Config {
    let mut cfg = Config::load(None).expect("embedded configuration");
    cfg.main.instance = format!("{name}{}", std::process::id());
    cfg
}

#[test]
fn the_planner_process_drives_a_move_to_its_target_and_shuts_down_promptly() {
    let cfg = config("plan");
    let home: [f64; AXES] = cfg.robot.home_deg.map(f64::to_radians);
    let mut target = home;
    target[0] += 0.3;
    target[4] -= 0.2;
    let mut command = MotionCommand::new(MotionCommandKind::MoveAxes);
    (command.seq, command.issuer, command.job, command.joints_rad) = (1, 9, 1, target);
    let outcome = drive(&cfg, home, command);
    assert_eq!(outcome.q, target);
    assert_eq!(
        outcome.events,
        vec![(1, state::BUFFERED), (1, state::ACTIVE), (1, state::DONE)]
    );
    // A liveness bound (a planner that misses the flag or waits on a thread that never
    // ends), not a speed target: about 25 ms here (the 20 ms wake-up timeout), but under the
    // parallel tests of a loaded 2-core CI machine 200 ms was once missed.
    assert!(
        outcome.shutdown < Duration::from_secs(2),
        "{:?}",
        outcome.shutdown
    );
}

#[test]
fn the_planner_process_drives_the_tcp_on_a_straight_line() {
    let cfg = config("planlin");
    let home: [f64; AXES] = cfg.robot.home_deg.map(f64::to_radians);
    let kinematics = Kinematics::new(&cfg.robot.kinematics);
    let tool = [0.0, 0.0, 0.1, 0.0, 0.0, 0.0];
    let tcp = |q: &[f64; AXES]| kinematics.flange(q) * pose::isometry(tool);
    let start = tcp(&home).translation.vector;
    let mut target = pose::pose(&tcp(&home));
    target[0] += 0.1;
    target[1] -= 0.1;
    target[2] -= 0.05;
    let mut command = MotionCommand::new(MotionCommandKind::MoveLinear);
    (command.seq, command.issuer, command.job) = (1, 9, 1);
    (command.pose, command.tool) = (target, tool);
    let outcome = drive(&cfg, home, command);
    assert_eq!(
        outcome.events,
        vec![(1, state::BUFFERED), (1, state::ACTIVE), (1, state::DONE)]
    );
    let end = pose::isometry(target).translation.vector;
    assert!((tcp(&outcome.q).translation.vector - end).norm() < 1e-9);
    assert!(outcome.trace.len() > 100);
    let direction = (end - start).normalize();
    for q in &outcome.trace {
        let d = tcp(q).translation.vector - start;
        let off = (d - direction * d.dot(&direction)).norm();
        assert!(off < 1e-5, "{off} m off the line");
    }
}

#[test]
fn the_planner_process_runs_a_secondary_move_within_the_plc_sw_limits() {
    let cfg = config("plansec");
    let home: [f64; AXES] = cfg.robot.home_deg.map(f64::to_radians);
    let mut target = home;
    target[5] += 0.2;
    let mut command = MotionCommand::new(MotionCommandKind::MoveAxes);
    (command.seq, command.issuer, command.job, command.joints_rad) = (1, 9, 1, target);
    command.sequence = MotionSequence::Secondary as u8;
    command.sw_lower_rad = home.map(|q| q - 0.3);
    command.sw_upper_rad = home.map(|q| q + 0.3);
    let outcome = drive(&cfg, home, command);
    assert_eq!(outcome.q, target);
    assert_eq!(
        outcome.events,
        vec![(1, state::BUFFERED), (1, state::ACTIVE), (1, state::DONE)]
    );
}
