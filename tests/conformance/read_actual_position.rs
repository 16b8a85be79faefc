//! ReadActualPosition (5100): joints, pose, configuration and turns, in the requested tool and
//! frame.

use plc_client::response::{ActualPosition, ArmConfiguration};
use plc_client::{FrameData, Request, ToolData};
use shared_types::srci::message::code;
use shared_types::srci::payload::PayloadReader;
use shared_types::srci::tables::{read_actual_position as rap, write_frame_data as wfd};

use crate::common::{HOME, Plc, enabled, expect_done, expect_error, max_deviation, move_to};

fn read(plc: &mut Plc, tool: u8, frame: u8) -> (ActualPosition, Vec<u8>) {
    let s = expect_done(
        plc,
        &Request::ReadActualPosition { tool, frame },
        rap::response::LEN,
    );
    (ActualPosition::decode(&s.response), s.response)
}

#[test]
fn position_in_tool_and_frame_with_configuration_and_turns() {
    let (_c, mut plc) = enabled("rapos");
    let (home, bytes) = read(&mut plc, 0, 0);
    assert!(max_deviation(home.joints_deg, HOME) < 0.01, "{home:?}");
    assert_eq!((home.tool, home.frame), (0, 0));
    let config = ArmConfiguration::decode(&bytes);
    assert!(
        config.shoulder && config.elbow && config.wrist,
        "home: shoulder BACK, elbow DOWN, wrist FLIP: {config:?}"
    );
    assert_eq!(config.turn_numbers, [0; 4], "no turns at home");
    let r = PayloadReader::new(&bytes);
    for f in [
        rap::response::ACTUAL_CARTESIAN_POSITION_E1,
        rap::response::ACTUAL_JOINT_POSITION_E1,
        rap::response::ACTUAL_JOINT_POSITION_E6,
    ] {
        assert_eq!(r.f32(f), 0.0, "no external axes");
    }
    // -1 (255) reports the tool and frame in use: flange and world.
    let (current, _) = read(&mut plc, 255, 255);
    assert_eq!((current.tool, current.frame), (0, 0));
    assert!(max_deviation(current.cartesian, home.cartesian) < 1e-3);

    // J6 at 200 degrees: one positive turn of J6 (sign-magnitude nibble, J6 = high nibble of
    // byte 2), the pose unchanged but rotated.
    let turned = [0.0, 90.0, 90.0, 90.0, -90.0, 200.0];
    assert!(move_to(&mut plc, turned, 100.0) < 0.01);
    let (there, bytes) = read(&mut plc, 0, 0);
    assert!(max_deviation(there.joints_deg, turned) < 0.01, "{there:?}");
    let turns = ArmConfiguration::decode(&bytes).turn_numbers;
    assert_eq!(turns, [0, 0, 0x10, 0], "J6 turn +1");

    // A user frame 200 mm along X: X in the frame is 200 mm less.
    let frame = FrameData {
        pose: [200.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        ..FrameData::default()
    };
    expect_done(
        &mut plc,
        &Request::write_frame_data(4, &frame),
        wfd::response::LEN,
    );
    let tool = ToolData {
        pose: [0.0, 0.0, 50.0, 0.0, 0.0, 0.0],
        ..ToolData::default()
    };
    expect_done(&mut plc, &Request::write_tool_data(6, &tool), 4);
    let (in_frame, _) = read(&mut plc, 0, 4);
    assert_eq!((in_frame.tool, in_frame.frame), (0, 4));
    assert!((in_frame.cartesian[0] - (there.cartesian[0] - 200.0)).abs() < 0.01);
    let (tcp, _) = read(&mut plc, 6, 0);
    let d = (0..3)
        .map(|i| (tcp.cartesian[i] - there.cartesian[i]).powi(2))
        .sum::<f64>()
        .sqrt();
    assert!((d - 50.0).abs() < 0.01, "TCP 50 mm from the flange: {d}");
    assert!(
        max_deviation(tcp.joints_deg, turned) < 0.01,
        "joints unchanged"
    );

    expect_error(
        &mut plc,
        &Request::ReadActualPosition { tool: 16, frame: 0 },
        code::INVALID_TOOL_NO,
    );
    expect_error(
        &mut plc,
        &Request::ReadActualPosition { tool: 0, frame: 16 },
        code::INVALID_FRAME_NO,
    );
    expect_error(
        &mut plc,
        &Request::Raw {
            command_type: rap::TYPE,
            execution_mode: 0,
            payload: vec![0; rap::request::LEN - 4],
        },
        code::INVALID_EXECUTION_MODE,
    );
}
