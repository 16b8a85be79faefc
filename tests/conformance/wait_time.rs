//! WaitTime (7005): the primary sequence stands still for the time before its next move;
//! ElapsedTime in the response.

use std::time::{Duration, Instant};

use plc_client::{MoveAxesAbsolute, Request};
use shared_types::srci::message::{code, execution_mode, state};
use shared_types::srci::payload::{PayloadReader, PayloadWriter};
use shared_types::srci::tables::wait_time as wt;

use crate::common::{HOME, enabled, execute, expect_error};

fn wait(ms: u32, mode: u8) -> Request {
    let mut b = vec![0u8; wt::request::LEN];
    PayloadWriter::new(&mut b).set_u32(wt::request::TIME, ms);
    Request::Raw {
        command_type: wt::TYPE,
        execution_mode: mode,
        payload: b.split_off(4),
    }
}

#[test]
fn a_wait_delays_the_next_move_of_its_sequence() {
    let (_c, mut plc) = enabled("wt");
    let started = Instant::now();
    let s = execute(
        &mut plc,
        &wait(400, execution_mode::SEQUENCE_PRIMARY),
        Duration::from_secs(5),
    );
    assert_eq!((s.state, s.code), (state::DONE, 0), "{s:?}");
    assert!(
        started.elapsed() >= Duration::from_millis(400),
        "{:?}",
        started.elapsed()
    );
    assert_eq!(s.response.len(), wt::response::LEN);
    assert_eq!(
        PayloadReader::new(&s.response).u32(wt::response::ELAPSED_TIME),
        400
    );

    // A move queued behind a wait starts only after it.
    let w = plc
        .task_mut()
        .submit(&wait(500, execution_mode::SEQUENCE_PRIMARY))
        .expect("submit");
    let mut target = HOME;
    target[0] += 5.0;
    let m = plc
        .task_mut()
        .submit(&Request::MoveAxesAbsolute(MoveAxesAbsolute::to(target)))
        .expect("submit");
    let queued = Instant::now();
    let mut move_started = None;
    plc.run_until(
        |t| {
            if move_started.is_none() && t.status(m).is_some_and(|s| s.state == state::ACTIVE) {
                move_started = Some(queued.elapsed());
            }
            t.status(m).is_some_and(|s| s.is_final())
        },
        Duration::from_secs(10),
    )
    .expect("the move ends");
    assert_eq!(plc.task().status(w).map(|s| s.state), Some(state::DONE));
    let started = move_started.expect("the move became ACTIVE");
    assert!(
        started >= Duration::from_millis(450),
        "the move started after {started:?}"
    );
    expect_error(
        &mut plc,
        &wait(100, execution_mode::PARALLEL),
        code::INVALID_EXECUTION_MODE,
    );
}
