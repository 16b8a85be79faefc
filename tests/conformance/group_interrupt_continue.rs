//! GroupInterrupt (2002) and GroupContinue (2001): the move stops on its path (INTERRUPTED,
//! 0x6F01, PrimarySequencePaused) and resumes to its target.

use std::time::Duration;

use plc_client::Request;
use shared_types::srci::message::{code, state};
use shared_types::srci::tables::{group_continue as gc, group_interrupt as gi};
use shared_types::srci::telegram::status_bit;

use crate::common::{
    actual_joints, cycles_until, expect_done, expect_error, initialized, max_deviation,
    reset_and_enable, run_until_state, start_slow_move,
};

#[test]
fn interrupt_holds_the_move_and_continue_finishes_it() {
    let (_c, mut plc) = initialized("gint");
    expect_error(
        &mut plc,
        &Request::GroupContinue,
        code::CONTINUE_NOT_ENABLED,
    );
    reset_and_enable(&mut plc);
    let target = [40.0, 110.0, 60.0, 80.0, -70.0, 30.0];
    let h = start_slow_move(&mut plc, target);
    expect_done(&mut plc, &Request::GroupInterrupt, gi::response::LEN);
    let s = run_until_state(&mut plc, h, state::INTERRUPTED, Duration::from_secs(2));
    assert_eq!(
        (s.state, s.code),
        (state::INTERRUPTED, code::INTERRUPTED_BY_GROUP_INTERRUPT),
        "{s:?}"
    );
    assert!(
        cycles_until(&mut plc, |t| !t.is_moving(), Duration::from_millis(100)),
        "standing"
    );
    let status = plc.task().status_word();
    assert_ne!(status & status_bit::PRIMARY_SEQUENCE_PAUSED, 0);
    assert_eq!(
        (status >> status_bit::SEQUENCE_STATE_SHIFT) & 0b11,
        2,
        "RaSequenceState INTERRUPTED"
    );
    let held = actual_joints(&mut plc);
    plc.run_for(Duration::from_millis(200)).expect("cycles");
    assert!(max_deviation(held, actual_joints(&mut plc)) < 1e-3, "held");
    assert!(max_deviation(held, target) > 1.0);

    expect_done(&mut plc, &Request::GroupContinue, gc::response::LEN);
    let s = run_until_state(&mut plc, h, state::ACTIVE, Duration::from_secs(2));
    assert_eq!(s.state, state::ACTIVE, "resumed: {s:?}");
    let s = run_until_state(&mut plc, h, state::DONE, Duration::from_secs(30));
    assert_eq!((s.state, s.code), (state::DONE, 0), "{s:?}");
    assert!(max_deviation(actual_joints(&mut plc), target) < 0.01);
    assert_eq!(
        plc.task().status_word() & status_bit::PRIMARY_SEQUENCE_PAUSED,
        0
    );
    for ty in [gi::TYPE, gc::TYPE] {
        expect_error(
            &mut plc,
            &Request::Raw {
                command_type: ty,
                execution_mode: 0,
                payload: Vec::new(),
            },
            code::INVALID_EXECUTION_MODE,
        );
    }
}

#[test]
fn group_stop_aborts_an_interrupted_move() {
    use crate::common::{HOME, move_to};
    use plc_client::MoveAxesAbsolute;
    let (_c, mut plc) = initialized("gintstop");
    reset_and_enable(&mut plc);
    // Interrupt and continue with nothing running: both DONE.
    expect_done(&mut plc, &Request::GroupInterrupt, gi::response::LEN);
    expect_done(&mut plc, &Request::GroupContinue, gc::response::LEN);
    assert!(move_to(&mut plc, [10.0, 90.0, 90.0, 90.0, -90.0, 0.0], 100.0) < 0.01);

    let target = [50.0, 110.0, 60.0, 80.0, -70.0, 30.0];
    let running = start_slow_move(&mut plc, target);
    let buffered = plc
        .task_mut()
        .submit(&Request::MoveAxesAbsolute(MoveAxesAbsolute::to(HOME)))
        .expect("submit");
    expect_done(&mut plc, &Request::GroupInterrupt, gi::response::LEN);
    run_until_state(
        &mut plc,
        running,
        state::INTERRUPTED,
        Duration::from_secs(2),
    );
    expect_done(
        &mut plc,
        &Request::GroupStop,
        shared_types::srci::tables::group_stop::response::LEN,
    );
    for h in [running, buffered] {
        let s = run_until_state(&mut plc, h, state::ABORTED, Duration::from_secs(2));
        assert_eq!(
            (s.state, s.code),
            (state::ABORTED, code::ABORTED_BY_GROUP_STOP),
            "{s:?}"
        );
    }
    // The next move runs (after a GroupContinue, which a PLC sends after an interrupt).
    expect_done(&mut plc, &Request::GroupContinue, gc::response::LEN);
    assert!(move_to(&mut plc, HOME, 100.0) < 0.01);
}
