//! How much a tick of the safety filter allocates: nothing when the plan keeps its limits,
//! and, for a corrected tick (a clarabel solve after the in-place data updates), the one
//! small allocation clarabel 0.11.1 makes per solve for its timer map (`Timers` clears its
//! nested sub-timers at the start of every solve and re-creates them).

use planner::kinematics::Kinematics;
use planner::safety_filter::{Intervention, SafetyFilter};
use shared_types::alloc_count::{CountingAllocator, count};
use shared_types::config::Config;
use shared_types::ipc::{AXES, JointPoint};

#[global_allocator]
static ALLOCATOR: CountingAllocator = CountingAllocator;

#[test]
fn a_passing_tick_allocates_nothing_and_a_corrected_tick_at_most_once() {
    let robot = Config::load(None).expect("embedded configuration").robot;
    let limits = robot.limits_rad();
    let kinematics = Kinematics::new(&robot.kinematics);
    let mut filter = SafetyFilter::new(limits).expect("filter");
    let q = [0.3, 0.3, 1.05, -0.7, 1.1, 0.2];
    let current = JointPoint {
        q,
        ..JointPoint::default()
    };
    let jacobian = kinematics.jacobian(&q);
    let runaway: [f64; AXES] = core::array::from_fn(|i| 3.0 * limits.acceleration[i]);
    let gentle: [f64; AXES] = core::array::from_fn(|i| 0.5 * limits.acceleration[i]);
    // The first solve sizes the solver's internal buffers.
    let warm = filter.filter(&current, &runaway, &jacobian, 0.001);
    assert_eq!(warm.intervention, Intervention::Corrected);

    let (passed, allocations) = count(|| filter.filter(&current, &gentle, &jacobian, 0.001));
    assert_eq!(passed.intervention, Intervention::None);
    assert_eq!(allocations, 0, "allocations of a passing tick");

    let (corrected, allocations) = count(|| filter.filter(&current, &runaway, &jacobian, 0.001));
    assert_eq!(corrected.intervention, Intervention::Corrected);
    eprintln!("allocations of one corrected tick: {allocations}");
    assert!(
        allocations <= 1,
        "allocations of one corrected tick: {allocations}"
    );
}
