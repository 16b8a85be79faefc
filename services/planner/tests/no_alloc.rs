//! The planner's per-tick work allocates nothing in the steady state: a counting global
//! allocator watches `Executor::step` while moves, override changes, an interrupt and a
//! continue run through it.

use planner::executor::Executor;
use shared_types::alloc_count::{CountingAllocator, count};
use shared_types::config::Config;
use shared_types::ipc::{DriveState, MotionCommand, MotionCommandKind, ServoFeedback};

#[global_allocator]
static ALLOCATOR: CountingAllocator = CountingAllocator;

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
    let mut allocations = 0;
    let mut ticks = 0;
    for round in 0..6u32 {
        let mut commands = Vec::with_capacity(2);
        let mut mv = command(MotionCommandKind::MoveAxes, 10 + round);
        mv.joints_rad = targets[round as usize % 2];
        commands.push(mv);
        if round == 2 {
            let mut o = command(MotionCommandKind::Override, 100);
            o.override_fraction = 0.5;
            commands.push(o);
        }
        for tick in 0..3000u32 {
            let batch: &[MotionCommand] = match tick {
                0 => &commands,
                400 if round == 4 => &[command(MotionCommandKind::Interrupt, 200)],
                900 if round == 4 => &[command(MotionCommandKind::Continue, 201)],
                _ => &[],
            };
            let (window, a) = count(|| executor.step(&feedback, batch));
            allocations += a;
            ticks += 1;
            // The servo follows the first point of each window exactly.
            if let Some(w) = window {
                feedback.q = w.points[0].q;
                feedback.qd = w.points[0].qd;
            }
            feedback.tick += 1;
        }
    }
    assert!(ticks > 10_000);
    assert_eq!(allocations, 0, "allocations in {ticks} planner ticks");
    let (_, probe) = count(|| std::hint::black_box(vec![0u8; 16]));
    assert_eq!(probe, 1, "the counter sees allocations");
}
