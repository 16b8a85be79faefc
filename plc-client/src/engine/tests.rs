//! The RobotTask against the scripted robot of `testing`, on simulated time.

use super::*;
use crate::request::MoveAxesAbsolute;
use crate::testing::{Bench, plc_seq};
use shared_types::srci::message::execution_mode;
use shared_types::srci::payload::PayloadReader;
use shared_types::srci::telegram::FragmentAction;

fn opts() -> EngineOptions {
    EngineOptions::default()
}

/// The sequence area of a 256-byte PLC telegram.
fn seq_area(tx: &[u8]) -> &[u8] {
    let ([(start, len), _], _) = sequence_areas(tx.len(), PLC_HEADER_LEN, 0, false);
    &tx[start..start + len]
}

#[test]
fn handshake_reaches_initialized_in_the_open_clients_order() {
    let mut b = Bench::new(opts());
    b.robot.length_acr = 12;
    b.run_until(200, |b| b.task.initialized());

    let types: Vec<u16> = b
        .robot
        .received
        .iter()
        .map(|r| r.header.command_type)
        .collect();
    assert_eq!(
        types,
        [
            tables::read_messages::TYPE,
            tables::exchange_configuration::TYPE,
            tables::read_robot_data::TYPE
        ]
    );
    for (i, r) in b.robot.received.iter().enumerate() {
        assert_eq!(r.cmd_id, i as u16 + 1, "lowest free CmdIDs");
        assert_eq!(r.header.execution_mode, execution_mode::PARALLEL);
        assert_eq!(r.header.priority, 3);
        assert_eq!(r.header.par_seq, 1);
        assert_eq!(
            r.first_action,
            FragmentAction::RESET | FragmentAction::COMPLETE
        );
    }
    let rm = PayloadReader::new(&b.robot.received[0].payload);
    assert_eq!(rm.u8(tables::read_messages::request::MESSAGE_LEVEL), 20);
    assert_eq!(
        b.robot.received[0].payload[5] & 1,
        1,
        "ST Enable bit of ReadMessages"
    );
    let ec = PayloadReader::new(&b.robot.received[1].payload);
    use tables::exchange_configuration::request as ecf;
    assert!(ec.bit(ecf::ENABLE));
    assert_eq!(ec.u16(ecf::LIFE_SIGN_TIME_OUT), 50);

    // Control: NONE until the robot's 254 was seen, then INITIALIZE, then NONE.
    let c = &b.robot.controls;
    assert_eq!(c[0], Control::None);
    let first_init = c.iter().position(|&c| c == Control::Initialize).unwrap();
    assert!(c[first_init..].contains(&Control::None));
    assert_eq!(*c.last().unwrap(), Control::None);

    assert_eq!(b.task.robot_data().unwrap().manufacturer, "Fake robot RC");
    assert_eq!(b.task.robot_data().unwrap().interpreter_cycle_time_ms, 8);
    assert_eq!(b.task.configuration().unwrap().length_acr, 12);
    // ReadMessages and ExchangeConfiguration stay; ReadRobotData is freed next cycle.
    b.step();
    assert_eq!(b.task.acr_usage(), (12, 2));
    assert!(b.task.submit(&Request::GroupReset).is_ok());
}

#[test]
fn submit_before_initialized_is_refused() {
    let mut b = Bench::new(opts());
    b.step();
    assert!(matches!(
        b.task.submit(&Request::GroupReset),
        Err(SubmitError::NotInitialized(_))
    ));
}

#[test]
fn seq_starts_at_1_goes_out_twice_and_wraps_from_254_to_1() {
    let mut b = Bench::new(opts());
    for _ in 0..1100 {
        b.step();
    }
    let seqs: Vec<u16> = b.sent.iter().map(|t| plc_seq(t)).collect();
    assert_eq!(seqs[0], 1, "the first telegram carries SEQ 1");
    assert!(!seqs.contains(&0));
    // Pairs: 1,1,2,2,...,254,254,1,1,...
    for (i, pair) in seqs.chunks(2).enumerate() {
        assert_eq!(pair[0], pair[pair.len() - 1], "SEQ {} sent twice", pair[0]);
        assert_eq!(usize::from(pair[0]), i % 254 + 1);
    }
    assert!(seqs.windows(2).any(|w| w == [254, 1]));
    assert!(b.task.initialized());
}

#[test]
fn unacknowledged_sequence_is_resent_byte_identically() {
    let mut b = Bench::initialized(opts());
    b.task.submit(&Request::GroupReset).unwrap();
    b.robot.ack_enabled = false;
    let sent: Vec<Vec<u8>> = (0..6).map(|_| b.step()).collect();
    // The command goes into the next new SEQ; from then on every telegram repeats it.
    let first = sent.iter().position(|t| seq_area(t)[3] != 0).unwrap();
    let areas: Vec<&[u8]> = sent[first..].iter().map(|t| seq_area(t)).collect();
    assert!(areas.len() >= 4);
    assert!(areas.windows(2).all(|w| w[0] == w[1]));
    // Only the header (lifesign, time) changes.
    assert_ne!(sent[first][1], sent[first + 1][1]);
    b.robot.ack_enabled = true;
    b.run_until(20, |b| {
        b.robot.received_of(tables::group_reset::TYPE).len() == 1
    });
}

#[test]
fn long_command_is_fragmented_and_long_responses_reassembled() {
    let mut o = opts();
    o.length_plc_to_rob = 64;
    o.length_rob_to_plc = 64;
    // ReadRobotData's 134-byte response needs four 64-byte robot telegrams.
    let mut b = Bench::initialized(o);
    assert_eq!(b.task.robot_data().unwrap().robot_id, "FAKE-7");
    assert_eq!(b.task.robot_data().unwrap().interpreter_cycle_time_ms, 8);

    let mut mv = MoveAxesAbsolute::to([10.0, 80.0, 95.0, 90.0, -90.0, 5.0]);
    mv.velocity_rate = Some(25.0);
    let request = Request::MoveAxesAbsolute(mv);
    let h = b.task.submit(&request).unwrap();
    b.run_until(100, |b| {
        b.task.status(h).is_some_and(CommandStatus::is_final)
    });

    // The CmdID was ReadRobotData's before (freed and reused): skip its fragment.
    let cmd_id = b.task.status(h).unwrap().cmd_id;
    let frags: Vec<(u16, u8, u16, u16)> = b
        .robot
        .fragments
        .iter()
        .filter(|(_, f)| f.cmd_id == cmd_id)
        .skip_while(|(_, f)| f.length != 33)
        .map(|(seq, f)| (*seq, f.action.0, f.pointer, f.length))
        .take(3)
        .collect();
    // 64 - 18 header - 1 footer - 4 sequence header - 8 fragment header = 33 bytes each.
    let parts: Vec<(u8, u16, u16)> = frags.iter().map(|f| (f.1, f.2, f.3)).collect();
    assert_eq!(parts, [(0x02, 0, 33), (0x00, 33, 33), (0x01, 66, 14)]);
    assert!(
        frags.windows(2).all(|w| w[1].0 == w[0].0 + 1),
        "one fragment per new SEQ"
    );
    let mut expected = Vec::new();
    request.encode(1, &mut expected);
    let got = b.robot.received_of(tables::move_axes_absolute::TYPE);
    assert_eq!(got[0].payload, expected);
    assert_eq!(b.task.status(h).unwrap().state, state::DONE);
}

#[test]
fn acr_frees_and_reuses_cmd_ids_within_length_acr() {
    let mut b = Bench::new(opts());
    b.robot.length_acr = 5;
    b.robot.move_cycles = 400;
    b.run_until(200, |b| b.task.initialized());
    b.step();
    // 1 ReadMessages, 2 ExchangeConfiguration; 3 (ReadRobotData) is free again.
    let reset = b.task.submit(&Request::GroupReset).unwrap();
    let moving = b
        .task
        .submit(&Request::MoveAxesAbsolute(MoveAxesAbsolute::to([0.0; 6])))
        .unwrap();
    let held = b
        .task
        .submit(&Request::EnableRobot { enable: true })
        .unwrap();
    assert_eq!(b.task.status(reset).unwrap().cmd_id, 3);
    assert_eq!(b.task.status(moving).unwrap().cmd_id, 4);
    assert_eq!(b.task.status(held).unwrap().cmd_id, 5);
    assert_eq!(
        b.task.submit(&Request::GroupReset),
        Err(SubmitError::AcrFull(5))
    );
    b.run_until(20, |b| b.task.status(reset).unwrap().state == state::DONE);
    b.step();
    let again = b.task.submit(&Request::GroupReset).unwrap();
    assert_eq!(
        b.task.status(again).unwrap().cmd_id,
        3,
        "lowest free CmdID reused"
    );
    b.run_until(20, |b| b.task.status(again).unwrap().is_final());
    let ids: Vec<u16> = b
        .robot
        .received_of(tables::group_reset::TYPE)
        .iter()
        .map(|r| r.cmd_id)
        .collect();
    assert_eq!(ids, [3, 3]);
}

#[test]
fn messages_are_acknowledged_with_a_clear_update_of_read_messages() {
    let mut b = Bench::new(opts());
    // Delivered with the first ReadMessages response of the start-up.
    b.robot.pending_message = Some((7, "Collision detected on J3".to_owned()));
    b.run_until(200, |b| {
        b.task.initialized() && b.robot.pending_message.is_none()
    });
    let rm_cmd = b.robot.received_of(tables::read_messages::TYPE)[0].cmd_id;

    let updates = b.robot.received_of(tables::read_messages::TYPE);
    let ack = updates.last().unwrap();
    assert_eq!(ack.cmd_id, rm_cmd, "same CmdID");
    assert_eq!(
        ack.first_action,
        FragmentAction::CLEAR | FragmentAction::COMPLETE
    );
    assert_eq!(
        PayloadReader::new(&ack.payload).u8(tables::read_messages::request::MSG_ID),
        7
    );
    assert!(ack.header.par_seq >= 2, "ParSeq incremented");
    let msgs = b.task.take_messages();
    assert_eq!(msgs.len(), 1);
    assert_eq!(msgs[0].msg_id, 7);
    assert_eq!(msgs[0].text, "Collision detected on J3");
    assert_eq!(msgs[0].code, 0x6C01);
}

#[test]
fn torn_robot_frame_is_counted_and_ignored() {
    let mut b = Bench::initialized(opts());
    // A torn frame that claims an error state would stop the task if it were parsed.
    b.robot.tear_next = Some(telegram_state::LIFESIGN_TIMEOUT);
    b.step();
    b.step();
    b.step();
    assert_eq!(b.task.invalid_frames(), 1);
    assert!(b.task.initialized(), "fault: {:?}", b.task.fault());
}

#[test]
fn lifesign_counts_1_to_15_in_header_and_footer_and_can_be_frozen() {
    let mut b = Bench::new(opts());
    let signs: Vec<u8> = (0..32)
        .map(|_| b.step())
        .map(|t| {
            assert_eq!(t[1] & 0x0F, t[255], "header and footer agree");
            t[1] & 0x0F
        })
        .collect();
    assert_eq!(
        &signs[..17],
        &[1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15, 1, 2]
    );
    b.task.set_lifesign_frozen(true);
    let frozen: Vec<u8> = (0..3).map(|_| b.step()[1] & 0x0F).collect();
    assert!(frozen.iter().all(|&s| s == frozen[0]));
}

#[test]
fn frozen_robot_lifesign_stops_the_task_and_restart_starts_over() {
    let mut b = Bench::initialized(opts());
    b.robot.freeze_lifesign = true;
    // LifeSignTimeOut 50 ms + one 8 ms cycle.
    b.run_until(20, |b| b.task.fault().is_some());
    assert_eq!(
        b.task.fault(),
        Some(EngineFault::RobotLifeSignTimeout { timeout_ms: 58 })
    );
    assert!(matches!(
        b.task.submit(&Request::GroupReset),
        Err(SubmitError::NotInitialized(_))
    ));
    b.robot.freeze_lifesign = false;
    // The robot reports the timeout; the client reads it one cycle after the exchange.
    b.robot.state = telegram_state::LIFESIGN_TIMEOUT;
    b.step();
    b.step();
    assert_eq!(b.task.telegram_state(), telegram_state::LIFESIGN_TIMEOUT);
    b.task.restart();
    b.run_until(200, |b| b.task.initialized());
    assert!(b.robot.controls.contains(&Control::Reset));
}

#[test]
fn header_can_carry_wrong_lengths_and_other_settings() {
    let mut o = opts();
    o.header_lengths = Some((200, 256));
    o.axes_group = 1;
    o.version = 0x23;
    let mut b = Bench::new(o);
    let t = b.step();
    assert_eq!(t.len(), 256);
    assert_eq!(u16::from_be_bytes([t[2], t[3]]), 200);
    assert_eq!(u16::from_be_bytes([t[4], t[5]]), 256);
    assert_eq!(t[6] >> 4, 1);
    assert_eq!(t[0], 0x23);
}

#[test]
fn major_version_mismatch_stops_the_start_up() {
    let mut b = Bench::new(opts());
    b.robot.version = 0x45;
    b.run_until(20, |b| b.task.fault().is_some());
    assert_eq!(
        b.task.fault(),
        Some(EngineFault::MajorVersion {
            robot: 2,
            client: 1
        })
    );
}

#[test]
fn error_state_is_answered_with_reset() {
    let mut b = Bench::new(opts());
    b.robot.state = telegram_state::CONTROL_MISMATCH;
    b.run_until(200, |b| b.task.initialized());
    let c = &b.robot.controls;
    let reset = c.iter().position(|&c| c == Control::Reset).unwrap();
    let init = c.iter().position(|&c| c == Control::Initialize).unwrap();
    assert!(reset < init);
}

#[test]
fn enable_robot_update_uses_same_cmd_id_with_clear_and_next_par_seq() {
    let mut b = Bench::initialized(opts());
    let h = b
        .task
        .submit(&Request::EnableRobot { enable: true })
        .unwrap();
    b.run_until(20, |b| b.task.status(h).unwrap().state == state::ACTIVE);
    b.task
        .update(h, &Request::EnableRobot { enable: false })
        .unwrap();
    b.run_until(20, |b| !b.robot.enabled);
    let sent = b.robot.received_of(tables::enable_robot::TYPE);
    assert_eq!(sent.len(), 2);
    assert_eq!(sent[0].cmd_id, sent[1].cmd_id);
    assert_eq!(
        sent[0].first_action,
        FragmentAction::RESET | FragmentAction::COMPLETE
    );
    assert_eq!(
        sent[1].first_action,
        FragmentAction::CLEAR | FragmentAction::COMPLETE
    );
    assert_eq!((sent[0].header.par_seq, sent[1].header.par_seq), (1, 2));
    assert_eq!(
        b.task.update(h, &Request::GroupReset),
        Err(SubmitError::TypeMismatch {
            expected: tables::enable_robot::TYPE,
            got: tables::group_reset::TYPE
        })
    );
}

#[test]
fn abort_reports_aborted_with_code_and_times() {
    let mut b = Bench::initialized(opts());
    b.robot.move_cycles = 100;
    let a = b
        .task
        .submit(&Request::MoveAxesAbsolute(MoveAxesAbsolute::to([10.0; 6])))
        .unwrap();
    b.run_until(20, |b| b.task.status(a).unwrap().state == state::ACTIVE);
    let mut mv = MoveAxesAbsolute::to([20.0; 6]);
    mv.aborting = true;
    let c = b.task.submit(&Request::MoveAxesAbsolute(mv)).unwrap();
    b.run_until(400, |b| b.task.status(c).unwrap().is_final());
    let sa = b.task.status(a).unwrap();
    assert_eq!((sa.state, sa.code), (state::ABORTED, 0x6C06));
    assert!(sa.active_at.unwrap() < sa.final_at.unwrap());
    assert_eq!(b.task.status(c).unwrap().state, state::DONE);
    let modes: Vec<u8> = b
        .robot
        .received_of(tables::move_axes_absolute::TYPE)
        .iter()
        .map(|r| r.header.execution_mode)
        .collect();
    assert_eq!(modes, [0, 1]);
}
