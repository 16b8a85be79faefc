//! ReadActualPositionCyclic: the CartesianPosition and JointPosition blocks the robot puts
//! into every telegram, chosen at INITIALIZE.

use std::time::Duration;

use plc_client::response::ActualPosition;
use plc_client::{CyclicSelection, EngineOptions, Request};
use shared_types::srci::tables::read_actual_position as rap;

use crate::common::{
    Controller, HOME, expect_done, initialize, max_deviation, move_to, plc_options,
    reset_and_enable,
};

#[test]
fn cyclic_blocks_agree_with_read_actual_position() {
    let c = Controller::start("cyclic");
    let both = CyclicSelection {
        cartesian: true,
        joints: true,
    };
    let mut plc = c.client_with(EngineOptions {
        cyclic_position: both,
        ..plc_options()
    });
    initialize(&mut plc);
    let data = plc.task().robot_data().cloned().expect("robot data");
    assert_ne!(data.supported_functions[0] & (1 << 5), 0, "announced");
    reset_and_enable(&mut plc);
    let target = [15.0, 100.0, 80.0, 95.0, -80.0, 20.0];
    assert!(move_to(&mut plc, target, 100.0) < 0.01);
    plc.run_for(Duration::from_millis(30)).expect("cycles");
    let cyclic = *plc.task().cyclic_position().expect("blocks");
    let s = expect_done(
        &mut plc,
        &Request::ReadActualPosition { tool: 0, frame: 0 },
        rap::response::LEN,
    );
    let read = ActualPosition::decode(&s.response);
    let joints = cyclic.joints_deg.expect("JointPosition block");
    assert!(max_deviation(joints, read.joints_deg) < 1e-3, "{joints:?}");
    let pose = cyclic.cartesian.expect("CartesianPosition block");
    assert!(
        max_deviation(pose, read.cartesian) < 1e-3,
        "{pose:?} vs {:?}",
        read.cartesian
    );
    assert_eq!(cyclic.tool_frame, Some((0, 0)), "ToolNo, FrameNo in use");

    // A second session with the joint block only: no ToolNo/FrameNo bytes from the PLC.
    drop(plc);
    let mut plc = c.client_with(EngineOptions {
        cyclic_position: CyclicSelection {
            cartesian: false,
            joints: true,
        },
        ..plc_options()
    });
    initialize(&mut plc);
    let only = *plc.task().cyclic_position().expect("blocks");
    assert_eq!(only.cartesian, None);
    assert!(max_deviation(only.joints_deg.expect("joints"), target) < 0.01);
    assert!(max_deviation(target, HOME) > 1.0);
}
