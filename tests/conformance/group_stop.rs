//! GroupStop (2003): stops on the path, aborts the running and the buffered moves (0x6C05),
//! AbortedSequence.

use std::time::Duration;

use plc_client::response::aborted_sequence;
use plc_client::{MoveAxesAbsolute, Request};
use shared_types::srci::message::{code, state};
use shared_types::srci::tables::group_stop as gs;

use crate::common::{
    HOME, actual_joints, cycles_until, enabled, expect_done, expect_error, max_deviation, move_to,
    run_until_state, start_slow_move,
};

#[test]
fn group_stop_aborts_running_and_buffered_moves() {
    let (_c, mut plc) = enabled("gstop");
    let idle = expect_done(&mut plc, &Request::GroupStop, gs::response::LEN);
    assert_eq!(aborted_sequence(&idle.response), 0, "nothing to abort");

    let far = [60.0, 120.0, 40.0, 60.0, -40.0, 90.0];
    let running = start_slow_move(&mut plc, far);
    let buffered = plc
        .task_mut()
        .submit(&Request::MoveAxesAbsolute(MoveAxesAbsolute::to(HOME)))
        .expect("submit");
    plc.run_for(Duration::from_millis(50)).expect("cycles");
    let stop = expect_done(&mut plc, &Request::GroupStop, gs::response::LEN);
    assert_eq!(aborted_sequence(&stop.response), 1, "moves were aborted");
    for h in [running, buffered] {
        let s = run_until_state(&mut plc, h, state::ABORTED, Duration::from_secs(2));
        assert_eq!(
            (s.state, s.code),
            (state::ABORTED, code::ABORTED_BY_GROUP_STOP),
            "{s:?}"
        );
    }
    assert!(
        cycles_until(&mut plc, |t| !t.is_moving(), Duration::from_millis(100)),
        "standing after GroupStop"
    );
    let here = actual_joints(&mut plc);
    assert!(max_deviation(here, far) > 1.0, "stopped short: {here:?}");
    // The next move runs without a GroupReset.
    assert!(move_to(&mut plc, HOME, 100.0) < 0.01);
    expect_error(
        &mut plc,
        &Request::Raw {
            command_type: gs::TYPE,
            execution_mode: 0,
            payload: Vec::new(),
        },
        code::INVALID_EXECUTION_MODE,
    );
}
