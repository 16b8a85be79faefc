//! ReadRobotReferenceDynamics (5105) and WriteRobotReferenceDynamics (5203): the 100 % values,
//! within the robot's maxima; values below 0 keep the current one.

use plc_client::response::{reference_dynamics, reference_dynamics_written};
use plc_client::{ReferenceDynamics, Request, Timestamp};
use shared_types::srci::message::code;
use shared_types::srci::tables::{
    read_robot_reference_dynamics as rrd, write_robot_reference_dynamics as wrd,
};

use crate::common::{Edit, expect_done, expect_error, initialized};

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
