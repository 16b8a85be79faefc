//! ReadRobotReferenceDynamics (5105) and WriteRobotReferenceDynamics (5203): the 100 % values,
//! within the robot's maxima; values below 0 keep the current one.

use plc_client::response::{reference_dynamics, reference_dynamics_written};
use plc_client::{ReferenceDynamics, Request, Timestamp};
use shared_types::srci::message::code;
use shared_types::srci::tables::{
    read_robot_reference_dynamics as rrd, write_robot_reference_dynamics as wrd,
};

use crate::common::{Edit, FROM_HOME, expect_done, expect_error, initialized, run_passing_program};

#[test]
fn reference_dynamics_within_the_robot() {
    let (_c, mut plc) = initialized("rdyn");
    let s = expect_done(
        &mut plc,
        &Request::read_reference_dynamics(),
        rrd::response::LEN,
    );
    let factory = reference_dynamics(&s.response);
    assert!(!factory.data_changed);
    let f = factory.data;
    assert_eq!(
        (f.velocity, f.acceleration, f.deceleration, f.jerk),
        (2500.0, 5000.0, 5000.0, 25000.0),
        "the robot's Cartesian maxima (robot file)"
    );

    let write = ReferenceDynamics {
        timestamp: Timestamp {
            date: 14_000,
            time_of_day_ms: 7,
        },
        velocity: 800.0,
        acceleration: -1.0,
        deceleration: -1.0,
        jerk: 12_000.0,
    };
    let s = expect_done(
        &mut plc,
        &Request::write_reference_dynamics(&write),
        wrd::response::LEN,
    );
    let in_effect = reference_dynamics_written(&s.response);
    assert_eq!(
        (
            in_effect.velocity,
            in_effect.acceleration,
            in_effect.deceleration,
            in_effect.jerk
        ),
        (800.0, 5000.0, 5000.0, 12_000.0),
        "below 0: not changed"
    );
    let s = expect_done(
        &mut plc,
        &Request::read_reference_dynamics(),
        rrd::response::LEN,
    );
    let read = reference_dynamics(&s.response);
    assert_eq!(read.data.timestamp, write.timestamp);
    assert_eq!((read.data.velocity, read.data.jerk), (800.0, 12_000.0));

    const INVALID_VELOCITY: u16 = 0x8D29;
    let edits: [(Edit<ReferenceDynamics>, u16); 5] = [
        (|r| r.velocity = 0.0, INVALID_VELOCITY),
        (|r| r.velocity = 2600.0, INVALID_VELOCITY),
        (
            |r| r.acceleration = f32::NAN,
            code::INVALID_ACCELERATION_RATE,
        ),
        (
            |r| r.deceleration = f32::INFINITY,
            code::INVALID_DECELERATION_RATE,
        ),
        (|r| r.jerk = 50_000.0, code::INVALID_JERK_RATE),
    ];
    for (edit, expected) in edits {
        let mut r = write;
        edit(&mut r);
        expect_error(&mut plc, &Request::write_reference_dynamics(&r), expected);
    }
}

/// 100 % of a Cartesian move's VelocityRate means the reference velocity: written down to
/// 100 mm/s, it holds a 200 mm line at the default rates to at least 2 s, and the line still
/// ends on its target. (The reference was stored and read back only: the line took 0.77 s.)
#[test]
fn a_lower_reference_velocity_slows_the_tcp_of_a_line() {
    let steps = run_passing_program(
        "rdyn-line",
        &(FROM_HOME.to_owned()
            + r#"
        [[step]]
        call = "ChangeSpeedOverride"
        override = 100.0
        [[step]]
        call = "WriteRobotReferenceDynamics"
        velocity_reference = 100.0
        acceleration_reference = -1.0
        deceleration_reference = -1.0
        jerk_reference = -1.0
        [[step]]
        call = "MoveLinearAbsolute"
        position = [-417.03, 315.01, 373.15, -180.0, 0.0, 90.0]
        ori_mode = 1
        config_mode = [0x11, 0x01]
        turn_mode = 1
        [[step]]
        call = "ReadActualPosition"
        "#),
    );
    let line = &steps[5];
    let took = line.duration.expect("the line ended").as_secs_f64();
    assert!(took >= 2.0, "200 mm at 100 mm/s took {took:.3} s");
    assert!(line.deviation.is_some(), "compared with the pose read");
}
