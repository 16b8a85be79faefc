//! The servo process loop over a private iceoryx2 instance: power up, follow a planner-like
//! ramp, stop when it goes silent, and shut down promptly.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::thread;
use std::time::{Duration, Instant};

use shared_types::bus::{Bus, publish, receive_latest, wait_for_wakeup};
use shared_types::config::Config;
use shared_types::ipc::{
    AXES, DriveState, JointPoint, SETPOINT_WINDOW, ServoControl, ServoFeedback, ServoSetpoint,
    topics,
};

#[test]
fn powers_up_follows_setpoints_stops_when_they_end_and_shuts_down() {
    let mut cfg = Config::load(None).expect("embedded config");
    cfg.main.instance = format!("servo{}", std::process::id());
    cfg.main.interpreter.data_dir = std::env::temp_dir()
        .join(format!("rc-servo-loop-{}", std::process::id()))
        .display()
        .to_string();
    cfg.main.servo.power_on_delay_ms = 5;
    cfg.main.servo.enable_delay_ms = 5;
    let home = cfg.robot.home_deg.map(f64::to_radians);

    let bus = Bus::new(&cfg.main.instance, "fakeplanner").unwrap();
    let control = bus
        .publisher::<ServoControl>(topics::SERVO_CONTROL)
        .unwrap();
    let setpoints = bus
        .publisher::<ServoSetpoint>(topics::SERVO_SETPOINT)
        .unwrap();
    let feedback = bus
        .subscriber::<ServoFeedback>(topics::SERVO_FEEDBACK)
        .unwrap();
    let feedback_wake = bus.listener(topics::SERVO_FEEDBACK).unwrap();

    let shutdown = Arc::new(AtomicBool::new(false));
    let servo = {
        let shutdown = shutdown.clone();
        let cfg = cfg.clone();
        thread::spawn(move || servo::run(&cfg, &shutdown))
    };

    // A wait may end early without a wake-up (a signal to the process interrupts it), so
    // only the deadline means no feedback.
    let next = || {
        let deadline = Instant::now() + Duration::from_secs(2);
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            assert!(
                !left.is_zero(),
                "no feedback; servo finished: {}",
                servo.is_finished()
            );
            wait_for_wakeup(&feedback_wake, left).unwrap();
            if let Some(f) = receive_latest(&feedback).unwrap() {
                return f;
            }
        }
    };

    // Published every cycle, like the interpreter does: a subscriber that connects later
    // gets the history only once the publisher sends again.
    let request_power = || {
        let on = ServoControl {
            seq: 3,
            power: true,
            enable: true,
            ..ServoControl::default()
        };
        publish(&control, on).unwrap();
    };
    request_power();
    let mut f = next();
    let instance = f.instance;
    while DriveState::from_wire(f.state) != DriveState::Holding {
        request_power();
        f = next();
        assert!(f.tick < 1000, "never enabled");
    }
    assert_eq!(f.control_seq, 3);
    assert_eq!(f.period_ns, 1_000_000);
    assert_eq!(f.instance, instance);
    assert_eq!(f.q, home);

    // A planner moving joint 0 at 0.2 rad/s, always a window ahead of the feedback.
    let speed = 0.2;
    let start_tick = f.tick + 1;
    let q_at = |tick: u64| {
        let mut q = home;
        q[0] += speed * (tick - start_tick) as f64 * 1e-3;
        q
    };
    let mut following = 0;
    while following < 100 {
        let first_tick = f.tick + 1;
        let points = core::array::from_fn::<_, SETPOINT_WINDOW, _>(|i| {
            let tick = first_tick + i as u64;
            let mut qd = [0.0; AXES];
            qd[0] = if tick > start_tick { speed } else { 0.0 };
            JointPoint {
                q: q_at(tick.max(start_tick)),
                qd,
                qdd: [0.0; AXES],
            }
        });
        publish(
            &setpoints,
            ServoSetpoint {
                planner_instance: 1,
                first_tick,
                points,
            },
        )
        .unwrap();
        request_power();
        f = next();
        if DriveState::from_wire(f.state) == DriveState::Following {
            following += 1;
        }
        assert!(f.tick < start_tick + 2000, "never followed");
    }
    assert!(f.qd[0] > 0.0);

    // The planner goes silent: the servo brakes to a standstill on its own.
    while DriveState::from_wire(f.state) != DriveState::Holding {
        request_power();
        f = next();
        assert!(f.tick < start_tick + 5000, "never stopped");
    }
    assert_eq!(f.qd, [0.0; AXES]);
    assert!(f.setpoint_misses >= 10);

    let t0 = Instant::now();
    shutdown.store(true, Ordering::Relaxed);
    servo.join().unwrap().expect("servo ran cleanly");
    assert!(t0.elapsed() < Duration::from_millis(50));
}
