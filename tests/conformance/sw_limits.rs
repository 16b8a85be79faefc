//! ReadRobotSWLimits (5106) and WriteRobotSWLimits (5204): limits within the mechanical ones,
//! respected by moves and jogs, ResetToFactoryDefault.

use std::time::Duration;

use plc_client::response::sw_limits;
use plc_client::{GroupJog, MoveAxesAbsolute, Request, SwLimits, Timestamp};
use shared_types::srci::message::{code, state};
use shared_types::srci::payload::PayloadReader;
use shared_types::srci::tables::{read_robot_sw_limits as rsl, write_robot_sw_limits as wsl};

use crate::common::{
    Edit, actual_joints, cycles_until, enabled, expect_done, expect_error, run_until_state,
};

pub(crate) const MECHANICAL_LOWER: [f32; 6] = [-359.0, -84.0, -174.0, -84.0, -359.0, -359.0];
pub(crate) const MECHANICAL_UPPER: [f32; 6] = [359.0, 264.0, 174.0, 264.0, 359.0, 359.0];

#[test]
fn sw_limits_narrow_moves_and_jogs_and_reset_to_factory() {
    let (_c, mut plc) = enabled("swlim");
    let s = expect_done(&mut plc, &Request::read_sw_limits(), rsl::response::LEN);
    let factory = sw_limits(&s.response);
    assert_eq!(factory.data.lower_deg, MECHANICAL_LOWER);
    assert_eq!(factory.data.upper_deg, MECHANICAL_UPPER);
    let r = PayloadReader::new(&s.response);
    for f in [
        rsl::response::E1_LOWER_LIMIT,
        rsl::response::E1_UPPER_LIMIT,
        rsl::response::E6_LOWER_LIMIT,
        rsl::response::E6_UPPER_LIMIT,
    ] {
        assert_eq!(r.f32(f), 0.0, "no external axes");
    }

    let mut narrow = SwLimits {
        timestamp: Timestamp {
            date: 15_000,
            time_of_day_ms: 77,
        },
        lower_deg: MECHANICAL_LOWER,
        upper_deg: MECHANICAL_UPPER,
    };
    narrow.lower_deg[0] = -10.0;
    narrow.upper_deg[0] = 10.0;
    let s = expect_done(
        &mut plc,
        &Request::write_sw_limits(&narrow, false),
        wsl::response::LEN,
    );
    assert!(
        !PayloadReader::new(&s.response).bit(wsl::response::RESTART_REQUESTED),
        "applies without a restart"
    );
    let s = expect_done(&mut plc, &Request::read_sw_limits(), rsl::response::LEN);
    let read = sw_limits(&s.response);
    assert_eq!(read.data, narrow);
    assert!(!read.data_changed);

    let to_j1 = |q: f64| {
        let mut m = MoveAxesAbsolute::to([q, 90.0, 90.0, 90.0, -90.0, 0.0]);
        m.velocity_rate = Some(100.0);
        Request::MoveAxesAbsolute(m)
    };
    expect_error(&mut plc, &to_j1(20.0), code::SW_LIMIT_UPPER);
    expect_error(&mut plc, &to_j1(-20.0), code::SW_LIMIT_LOWER);

    // A continuous jog stops inside the limit.
    let jog = GroupJog::axes(50.0);
    let h = plc
        .task_mut()
        .submit(&jog.pressing(0, 1).request())
        .expect("submit");
    run_until_state(&mut plc, h, state::ACTIVE, Duration::from_secs(3));
    assert!(cycles_until(
        &mut plc,
        |t| t.is_moving(),
        Duration::from_secs(2)
    ));
    assert!(
        cycles_until(&mut plc, |t| !t.is_moving(), Duration::from_secs(5)),
        "the jog stops at the limit"
    );
    let j1 = actual_joints(&mut plc)[0];
    assert!((9.0..=10.0).contains(&j1), "J1 {j1} inside the SW limit");
    let mut off = jog.clone();
    off.enable = false;
    plc.task_mut().update(h, &off.request()).expect("disable");
    run_until_state(&mut plc, h, state::DONE, Duration::from_secs(3));

    // Outside the mechanical limits, not finite, or lower >= upper: refused.
    const INDEX_OUT_OF_RANGE: u16 = 0x8D47;
    let edits: [(Edit<SwLimits>, u16); 4] = [
        (|l| l.lower_deg[1] = -85.0, code::SW_LIMIT_LOWER),
        (|l| l.upper_deg[5] = 360.0, code::SW_LIMIT_UPPER),
        (|l| l.lower_deg[2] = l.upper_deg[2], INDEX_OUT_OF_RANGE),
        (|l| l.upper_deg[3] = f32::NAN, INDEX_OUT_OF_RANGE),
    ];
    for (edit, expected) in edits {
        let mut l = narrow;
        edit(&mut l);
        expect_error(&mut plc, &Request::write_sw_limits(&l, false), expected);
    }

    // ResetToFactoryDefault: the mechanical limits, DataChanged set (the robot changed them).
    expect_done(
        &mut plc,
        &Request::write_sw_limits(&SwLimits::default(), true),
        wsl::response::LEN,
    );
    let s = expect_done(&mut plc, &Request::read_sw_limits(), rsl::response::LEN);
    let reset = sw_limits(&s.response);
    assert_eq!(reset.data.upper_deg, MECHANICAL_UPPER);
    assert!(reset.data_changed);
    let s = crate::common::execute(&mut plc, &to_j1(20.0), Duration::from_secs(10));
    assert_eq!((s.state, s.code), (state::DONE, 0), "allowed again: {s:?}");
}
