//! The servo tick allocates nothing in the steady state: a counting global allocator watches
//! `SimulatedDrives::tick` through power-on, enable, a followed trajectory, a stop when the
//! setpoints end, and holding.

use servo::drives::{DriveParams, SimulatedDrives};
use shared_types::alloc_count::{CountingAllocator, count};
use shared_types::config::Config;
use shared_types::ipc::{JointPoint, SETPOINT_WINDOW, ServoControl, ServoSetpoint};

#[global_allocator]
static ALLOCATOR: CountingAllocator = CountingAllocator;

#[test]
fn steady_state_ticks_do_not_allocate() {
    let mut config = Config::load(None).expect("embedded configuration");
    config.main.servo.power_on_delay_ms = 5;
    config.main.servo.enable_delay_ms = 5;
    let home = config.robot.home_deg.map(f64::to_radians);
    let mut drives = SimulatedDrives::new(DriveParams::from_config(&config), home);
    let control = ServoControl {
        seq: 1,
        power: true,
        enable: true,
        ..ServoControl::default()
    };
    let mut q = home;
    let mut allocations = 0;
    for tick in 0..6000u64 {
        // A slow ramp on J1 for 3 s after enabling, then no setpoints at all.
        let setpoint = (20..3000).contains(&tick).then(|| {
            let points = core::array::from_fn::<_, SETPOINT_WINDOW, _>(|i| {
                let mut p = JointPoint {
                    q,
                    ..JointPoint::default()
                };
                p.q[0] += 1e-4 * (i as f64 + 1.0);
                p.qd[0] = 0.1;
                p
            });
            ServoSetpoint {
                planner_instance: 1,
                first_tick: tick,
                points,
            }
        });
        let (report, a) = count(|| drives.tick(tick, &control, setpoint.as_ref()));
        allocations += a;
        q = report.status.q;
    }
    assert!(q[0] > home[0] + 0.1, "the drives followed the ramp");
    assert_eq!(allocations, 0, "allocations in 6000 servo ticks");
    let (_, probe) = count(|| std::hint::black_box(vec![0u8; 16]));
    assert_eq!(probe, 1, "the counter sees allocations");
}
