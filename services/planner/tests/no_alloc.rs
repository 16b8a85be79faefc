//! The planner's per-tick work allocates nothing in the steady state: a counting global
//! allocator watches `Executor::step` while joint and linear moves, override changes, an
//! interrupt, a secondary move (a jog) while the primary sequence is held, a continue, a
//! stop, blended moves and a wait run through it.

use planner::executor::Executor;
use planner::kinematics::Kinematics;
use shared_types::alloc_count::{CountingAllocator, count};
use shared_types::config::Config;
use shared_types::ipc::{
    DriveState, JOB_EVENTS, MotionCommand, MotionCommandKind, MotionSequence, ServoFeedback,
};
use shared_types::srci::message::{code, state};

#[global_allocator]
static ALLOCATOR: CountingAllocator = CountingAllocator;

/// `command` as a jog on the secondary sequence: the last joint turned from `from`.
fn jog(mut command: MotionCommand, from: [f64; 6]) -> MotionCommand {
    command.sequence = MotionSequence::Secondary as u8;
    command.joints_rad = from;
    command.joints_rad[5] += 0.2;
    command
}

#[test]
fn steady_state_ticks_do_not_allocate() {
    let config = Config::load(None).expect("embedded configuration");
    let home = config.robot.home_deg.map(f64::to_radians);
    let mut executor = Executor::new(&config, 1);
    let mut feedback = ServoFeedback::at_rest(2, home, DriveState::Holding, 1_000_000);
    let mut seq = 0;
    let mut command = |kind: MotionCommandKind, job: u32| {
        seq += 1;
        let mut c = MotionCommand::new(kind);
        c.seq = seq;
        c.issuer = 7;
        c.job = job;
        c
    };
    let mut targets = [home, home];
    targets[0][0] += 0.6;
    targets[1][1] -= 0.4;
    // A line of the TCP 12 cm out of the flange, down and sideways, turning it.
    let tool = [0.0, 0.0, 0.12, 0.0, 0.0, 0.0];
    let kinematics = Kinematics::new(&config.robot.kinematics);
    let mut line_target = kinematics.flange_pose(&home);
    line_target[0] += 0.1;
    line_target[2] -= 0.1;
    line_target[5] += 0.3;
    let tool_of_flange = shared_types::pose::isometry(tool);
    let line_target =
        shared_types::pose::pose(&(shared_types::pose::isometry(line_target) * tool_of_flange));
    let mut allocations = 0;
    let mut ticks = 0;
    let mut events = Vec::with_capacity(1000);
    let mut seen = 0;
    let mut blended = false;
    for round in 0..9u32 {
        let mut commands = Vec::with_capacity(4);
        // Rounds 0..6 alternate joint moves; 6 and 7 are linear moves there and back; 8
        // blends a joint move into a line and the line into a joint move, then waits.
        let mv = if round == 8 {
            let mut there = command(MotionCommandKind::MoveAxes, 20);
            there.joints_rad = targets[1];
            there.blending_mode = 11;
            there.blending_parameter = [1.0, 0.0];
            commands.push(there);
            let mut line = command(MotionCommandKind::MoveLinear, 21);
            line.tool = tool;
            line.pose = line_target;
            line.blending_mode = 3;
            line.blending_parameter = [0.05, 0.0];
            commands.push(line);
            let mut wait = command(MotionCommandKind::Wait, 22);
            wait.duration_s = 0.1;
            commands.push(wait);
            let mut back = command(MotionCommandKind::MoveAxes, 23);
            back.joints_rad = targets[0];
            back
        } else if round < 6 {
            let mut mv = command(MotionCommandKind::MoveAxes, 10 + round);
            mv.joints_rad = targets[round as usize % 2];
            mv
        } else {
            let mut mv = command(MotionCommandKind::MoveLinear, 10 + round);
            mv.tool = tool;
            mv.pose = if round == 6 {
                line_target
            } else {
                shared_types::pose::pose(&(kinematics.flange(&targets[1]) * tool_of_flange))
            };
            mv
        };
        commands.push(mv);
        if round == 2 {
            let mut o = command(MotionCommandKind::Override, 100);
            o.override_fraction = 0.5;
            commands.push(o);
        }
        // The linear moves are slower (their joint bounds are conservative).
        let round_ticks = if round < 6 { 3000 } else { 6000 };
        for tick in 0..round_ticks {
            let batch: &[MotionCommand] = match tick {
                0 => &commands,
                400 if round == 4 || round == 6 => &[command(MotionCommandKind::Interrupt, 200)],
                600 if round == 4 => &[jog(command(MotionCommandKind::MoveAxes, 304), feedback.q)],
                900 if round == 4 || round == 6 => &[command(MotionCommandKind::Continue, 201)],
                200 if round == 7 => &[command(MotionCommandKind::Stop, 202)],
                _ => &[],
            };
            let (window, a) = count(|| executor.step(&feedback, batch));
            allocations += a;
            blended |= executor.is_blending();
            ticks += 1;
            let status = executor.status();
            for n in seen + 1..=status.event_head {
                let e = status.events[(n % JOB_EVENTS as u64) as usize];
                events.push((e.job, e.state, e.code));
            }
            seen = status.event_head;
            // The servo follows the first point of each window exactly.
            if let Some(w) = window {
                feedback.q = w.points[0].q;
                feedback.qd = w.points[0].qd;
            }
            feedback.tick += 1;
        }
    }
    assert!(ticks > 10_000);
    // The jog ran while the primary sequence was held, and the held move after it.
    let at = |wanted| events.iter().position(|e| *e == wanted);
    let jog_done = at((304, state::DONE, 0)).expect("the jog is done");
    assert!(at((14, state::DONE, 0)).is_some_and(|done| done > jog_done));
    // The linear moves ran: the first to its end, the second into the stop.
    assert!(events.contains(&(16, state::DONE, 0)), "{events:?}");
    assert!(events.contains(&(17, state::ACTIVE, 0)), "{events:?}");
    assert!(events.contains(&(17, state::ABORTED, code::ABORTED_BY_GROUP_STOP)));
    // The blended moves and the wait ran.
    assert!(blended, "no blend in {events:?}");
    assert!(events.contains(&(22, state::DONE, 0)) && events.contains(&(23, state::DONE, 0)));
    assert_eq!(allocations, 0, "allocations in {ticks} planner ticks");
    let (_, probe) = count(|| std::hint::black_box(vec![0u8; 16]));
    assert_eq!(probe, 1, "the counter sees allocations");
}
