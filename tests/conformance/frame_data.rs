//! ReadFrameData (5102) and WriteFrameData (5200): frames chained through their reference
//! frames, cycles refused, positions reported in a chained frame.

use plc_client::response::{ActualPosition, frame_data};
use plc_client::{FrameData, Request, Timestamp};
use shared_types::srci::message::code;
use shared_types::srci::tables::{
    read_actual_position as rap, read_frame_data as rfd, write_frame_data as wfd,
};

use crate::common::{change_indices, expect_done, expect_error, initialized};

fn frame(reference_frame: u8, x: f32) -> FrameData {
    FrameData {
        timestamp: Timestamp {
            date: 11_000,
            time_of_day_ms: 1234,
        },
        reference_frame,
        pose: [x, 0.0, 0.0, 0.0, 0.0, 0.0],
    }
}

#[test]
fn frames_chain_and_cycles_are_refused() {
    let (_c, mut plc) = initialized("frame");
    let before = change_indices(&mut plc);
    expect_done(
        &mut plc,
        &Request::write_frame_data(1, &frame(0, 100.0)),
        wfd::response::LEN,
    );
    let mut second = frame(1, 50.0);
    second.pose[5] = 90.0;
    expect_done(
        &mut plc,
        &Request::write_frame_data(2, &second),
        wfd::response::LEN,
    );
    let after = change_indices(&mut plc);
    assert_eq!(
        after[1],
        before[1].wrapping_add(2),
        "ChangeIndexFrame counts writes"
    );

    let s = expect_done(&mut plc, &Request::read_frame_data(2), rfd::response::LEN);
    let (index, read) = frame_data(&s.response);
    assert_eq!(index, 2);
    assert_eq!(read.data, second);
    assert!(!read.data_changed);
    let s = expect_done(&mut plc, &Request::read_frame_data(255), rfd::response::LEN);
    assert_eq!(frame_data(&s.response).0, 0, "the world frame is in use");

    // The position in frame 2 = world shifted by 150 mm in X (rotations after the shift).
    let read_in = |plc: &mut crate::common::Plc, frame| {
        let s = expect_done(
            plc,
            &Request::ReadActualPosition { tool: 0, frame },
            rap::response::LEN,
        );
        ActualPosition::decode(&s.response)
    };
    let world = read_in(&mut plc, 0);
    let chained = read_in(&mut plc, 2);
    assert_eq!(chained.frame, 2);
    // Frame 2 is rotated 90 degrees about Z: its X is the world Y, its Y the world -X.
    assert!(
        (chained.cartesian[0] - world.cartesian[1]).abs() < 0.01,
        "{chained:?} {world:?}"
    );
    assert!((chained.cartesian[1] + (world.cartesian[0] - 150.0)).abs() < 0.01);
    assert!((chained.cartesian[2] - world.cartesian[2]).abs() < 0.01);

    // Cycles and unknown reference frames are refused.
    expect_error(
        &mut plc,
        &Request::write_frame_data(1, &frame(2, 0.0)),
        0x8D88,
    );
    expect_error(
        &mut plc,
        &Request::write_frame_data(3, &frame(3, 0.0)),
        0x8D88,
    );
    expect_error(
        &mut plc,
        &Request::write_frame_data(3, &frame(16, 0.0)),
        0x8D88,
    );
    for index in [0, 16, 255] {
        expect_error(
            &mut plc,
            &Request::write_frame_data(index, &frame(0, 0.0)),
            code::INVALID_FRAME_NO,
        );
    }
    expect_error(
        &mut plc,
        &Request::read_frame_data(16),
        code::INVALID_FRAME_NO,
    );
    let mut bad = frame(0, 0.0);
    bad.pose[0] = f32::INFINITY;
    expect_error(&mut plc, &Request::write_frame_data(3, &bad), 0x8D24);
    let s = expect_done(&mut plc, &Request::read_frame_data(1), rfd::response::LEN);
    assert_eq!(frame_data(&s.response).1.data, frame(0, 100.0), "unchanged");
}
