//! System tests: `rc run` as real processes, driven over the TCP gateway transport by the
//! PLC-side client, checking what a commissioning engineer would check.

mod common;

use std::time::{Duration, Instant};

use common::{
    Controller, actual_joints, cycles_until, execute, initialize, max_deviation, move_to,
    plc_options, reset_and_enable, run_until_state, start_slow_move,
};
use plc_client::{EngineOptions, MoveAxesAbsolute, Request};
use shared_types::srci::message::{code, state};
use shared_types::srci::tables as t;
use shared_types::srci::telegram::telegram_state as ts;

const HOME: [f64; 6] = [0.0, 90.0, 90.0, 90.0, -90.0, 0.0];

#[test]
fn handshake_enable_and_moves_reach_their_targets() {
    let c = Controller::start("moves");
    let mut plc = c.client();
    initialize(&mut plc);
    let data = plc.task().robot_data().cloned().expect("ReadRobotData");
    assert!(data.supports(t::move_axes_absolute::TYPE));
    assert!(data.supports(t::enable_robot::TYPE));
    assert!(data.supports(t::move_linear_absolute::TYPE));
    assert!(
        !data.supports(common::UNIMPLEMENTED_TYPE),
        "only what is implemented"
    );
    reset_and_enable(&mut plc);

    let start = actual_joints(&mut plc);
    assert!(
        max_deviation(start, HOME) < 0.01,
        "starts at home: {start:?}"
    );
    let position = execute(
        &mut plc,
        &Request::ReadActualPosition { tool: 0, frame: 0 },
        Duration::from_secs(5),
    );
    assert_eq!(
        position.response[34] & 0b111,
        0b111,
        "home is shoulder BACK, elbow DOWN, wrist FLIP"
    );
    for target in [
        [20.0, 100.0, 70.0, 80.0, -80.0, 30.0],
        [-15.0, 80.0, 100.0, 95.0, -100.0, -20.0],
    ] {
        let deviation = move_to(&mut plc, target, 80.0);
        assert!(
            deviation < 0.01,
            "{target:?} reached within {deviation} deg"
        );
    }
    assert!(!plc.task().is_moving());
}

#[test]
fn unsupported_command_gets_8f11_and_a_message() {
    let c = Controller::start("unsup");
    let mut plc = c.client();
    initialize(&mut plc);
    let s = execute(
        &mut plc,
        &common::unimplemented_request(),
        Duration::from_secs(5),
    );
    assert_eq!(
        (s.state, s.code),
        (state::ERROR, code::NOT_IMPLEMENTED),
        "{s:?}"
    );
    plc.run_for(Duration::from_millis(200)).expect("cycles");
    let messages = plc.task_mut().take_messages();
    assert!(
        messages
            .iter()
            .any(|m| m.code == u32::from(code::NOT_IMPLEMENTED)),
        "ReadMessages delivered the error: {messages:?}"
    );
}

#[test]
fn wrong_telegram_length_gets_163() {
    let c = Controller::start("len");
    let mut plc = c.client_with(EngineOptions {
        header_lengths: Some((128, 256)),
        ..plc_options()
    });
    // The client answers 163 with RESET and tries again, so the state alternates 163/254;
    // it never becomes 255.
    let seen = cycles_until(
        &mut plc,
        |t| t.telegram_state() == ts::LENGTH_MISMATCH,
        Duration::from_secs(2),
    );
    assert!(seen, "TelegramState 163 reported");
    let initialized = cycles_until(
        &mut plc,
        |t| t.telegram_state() == ts::INITIALIZED,
        Duration::from_secs(1),
    );
    assert!(!initialized, "never initialized with a wrong length");
}

#[test]
fn frozen_plc_lifesign_gets_165_and_stops_motion() {
    let c = Controller::start("life");
    // The product's default LifeSignTimeOut, not the test PLC's lenient one.
    let mut plc = c.client_with(EngineOptions::default());
    initialize(&mut plc);
    reset_and_enable(&mut plc);
    let target = [60.0, 120.0, 40.0, 60.0, -40.0, 90.0];
    start_slow_move(&mut plc, target);
    assert!(plc.task().is_moving(), "the arm moves before the freeze");

    plc.task_mut().set_lifesign_frozen(true);
    let frozen_at = Instant::now();
    assert!(
        cycles_until(
            &mut plc,
            |t| t.telegram_state() == ts::LIFESIGN_TIMEOUT,
            Duration::from_secs(2)
        ),
        "TelegramState 165 reported"
    );
    let detected = frozen_at.elapsed();
    assert!(
        detected < Duration::from_millis(500),
        "165 after {detected:?}"
    );
    assert!(
        cycles_until(&mut plc, |t| !t.is_moving(), Duration::from_secs(3)),
        "motion stopped after the lifesign timeout"
    );

    // A new session (RESET, INITIALIZE) finds the arm standing short of the target.
    drop(plc);
    let mut plc = c.client();
    initialize(&mut plc);
    let a = actual_joints(&mut plc);
    plc.run_for(Duration::from_millis(200)).expect("cycles");
    let b = actual_joints(&mut plc);
    assert!(max_deviation(a, b) < 1e-3, "standing still: {a:?} vs {b:?}");
    assert!(
        max_deviation(a, target) > 1.0,
        "stopped before the target: {a:?}"
    );
}

#[test]
fn planner_killed_during_a_move_stops_the_arm_and_recovers_after_group_reset() {
    let c = Controller::start("kill");
    let mut plc = c.client();
    initialize(&mut plc);
    reset_and_enable(&mut plc);
    let target = [-60.0, 130.0, 30.0, 50.0, -30.0, -90.0];
    let handle = start_slow_move(&mut plc, target);
    let planner = c.pid_of("planner").expect("planner pid");
    // SAFETY: kill(2) on the planner process of our own controller.
    assert_eq!(unsafe { libc::kill(planner as i32, libc::SIGKILL) }, 0);

    let s = run_until_state(&mut plc, handle, state::DONE, Duration::from_secs(5));
    assert!(
        matches!(s.state, state::ERROR | state::ABORTED) && s.code != 0,
        "the move ends with an error code: {s:?}"
    );
    plc.run_until(|t| !t.is_moving(), Duration::from_secs(3))
        .expect("the servo stops the arm");
    let restarted = Instant::now();
    while c.pid_of("planner").is_none_or(|p| p == planner) {
        assert!(
            restarted.elapsed() < Duration::from_secs(10),
            "planner restarted"
        );
        plc.run_for(Duration::from_millis(50)).expect("cycles");
    }
    let stopped_at = actual_joints(&mut plc);
    assert!(
        max_deviation(stopped_at, target) > 1.0,
        "stopped short of the target"
    );

    let reset = execute(&mut plc, &Request::GroupReset, Duration::from_secs(10));
    assert_eq!(
        reset.state,
        state::DONE,
        "GroupReset after the restart: {reset:?}"
    );
    let deviation = move_to(&mut plc, HOME, 100.0);
    assert!(deviation < 0.01, "home reached within {deviation} deg");
}

#[test]
fn invalid_config_fails_at_start_naming_file_key_and_range() {
    let dir = std::env::temp_dir().join(format!("rc-test-badcfg-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("dir");
    let file = dir.join("bad.toml");
    let text = shared_types::config::EMBEDDED_DEFAULT.replace("period_us = 1000", "period_us = 20");
    std::fs::write(&file, text).expect("write");
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_rc"))
        .args(["run", "--config"])
        .arg(&file)
        .output()
        .expect("run rc");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("bad.toml"), "{stderr}");
    assert!(stderr.contains("servo.period_us = 20"), "{stderr}");
    assert!(stderr.contains("250..=8000"), "{stderr}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn group_interrupt_holds_on_the_path_and_group_continue_finishes_the_move() {
    let c = Controller::start("intr");
    let mut plc = c.client();
    initialize(&mut plc);
    reset_and_enable(&mut plc);
    let target = [50.0, 110.0, 60.0, 70.0, -60.0, 60.0];
    let handle = start_slow_move(&mut plc, target);
    let s = execute(&mut plc, &Request::GroupInterrupt, Duration::from_secs(5));
    assert_eq!((s.state, s.code), (state::DONE, 0), "GroupInterrupt: {s:?}");
    let moving = plc.task().status(handle).cloned().expect("move status");
    assert_eq!(
        (moving.state, moving.code),
        (state::INTERRUPTED, code::INTERRUPTED_BY_GROUP_INTERRUPT),
        "{moving:?}"
    );
    let paused = shared_types::srci::telegram::status_bit::PRIMARY_SEQUENCE_PAUSED;
    assert_ne!(
        plc.task().status_word() & paused,
        0,
        "PrimarySequencePaused"
    );
    // The drives report the last tick of the stop a telegram later than the planner.
    assert!(
        cycles_until(&mut plc, |t| !t.is_moving(), Duration::from_millis(100)),
        "standing after GroupInterrupt"
    );
    let held = actual_joints(&mut plc);
    plc.run_for(Duration::from_millis(300)).expect("cycles");
    assert!(max_deviation(held, actual_joints(&mut plc)) < 1e-3, "holds");

    let s = execute(&mut plc, &Request::GroupContinue, Duration::from_secs(5));
    assert_eq!((s.state, s.code), (state::DONE, 0), "GroupContinue: {s:?}");
    let done = run_until_state(&mut plc, handle, state::DONE, Duration::from_secs(30));
    assert_eq!((done.state, done.code), (state::DONE, 0), "{done:?}");
    assert_eq!(plc.task().status_word() & paused, 0);
    assert!(max_deviation(actual_joints(&mut plc), target) < 0.01);
}

#[test]
fn a_lost_link_is_resumed_and_the_held_move_finishes_after_group_continue() {
    let c = Controller::start("resume");
    let mut plc = c.client();
    initialize(&mut plc);
    reset_and_enable(&mut plc);
    let target = [50.0, 110.0, 60.0, 70.0, -60.0, 60.0];
    let handle = start_slow_move(&mut plc, target);

    // The PLC's connection drops and a new one comes up (the cable, a switch, the PLC's
    // communication processor): the robot offers READY_TO_RESUME and the client resumes.
    plc.reconnect(c.connect());
    assert!(
        cycles_until(&mut plc, |t| t.initialized(), Duration::from_secs(5)),
        "session resumed, TelegramState {}",
        plc.task().telegram_state()
    );
    assert_eq!(plc.task().resumes(), 1, "resumed, not initialized anew");
    let held = run_until_state(&mut plc, handle, state::INTERRUPTED, Duration::from_secs(5));
    assert_eq!(
        (held.state, held.code),
        (state::INTERRUPTED, code::INTERRUPTED_BY_GROUP_INTERRUPT),
        "the move is still registered and held: {held:?}"
    );
    assert!(
        cycles_until(&mut plc, |t| !t.is_moving(), Duration::from_millis(500)),
        "the arm stands while the PLC was away"
    );
    let standing = actual_joints(&mut plc);
    plc.run_for(Duration::from_millis(300)).expect("cycles");
    assert!(
        max_deviation(standing, actual_joints(&mut plc)) < 1e-3,
        "nothing moves before GroupContinue"
    );

    let s = execute(&mut plc, &Request::GroupContinue, Duration::from_secs(5));
    assert_eq!((s.state, s.code), (state::DONE, 0), "GroupContinue: {s:?}");
    let done = run_until_state(&mut plc, handle, state::DONE, Duration::from_secs(30));
    assert_eq!((done.state, done.code), (state::DONE, 0), "{done:?}");
    assert!(max_deviation(actual_joints(&mut plc), target) < 0.01);
}

#[test]
fn group_stop_aborts_the_running_and_the_buffered_moves() {
    let c = Controller::start("stop");
    let mut plc = c.client();
    initialize(&mut plc);
    reset_and_enable(&mut plc);
    let first = start_slow_move(&mut plc, [30.0, 100.0, 80.0, 80.0, -80.0, 20.0]);
    let second = plc
        .task_mut()
        .submit(&Request::MoveAxesAbsolute(MoveAxesAbsolute::to(HOME)))
        .expect("submit");
    run_until_state(&mut plc, second, state::BUFFERED, Duration::from_secs(5));
    let s = execute(&mut plc, &Request::GroupStop, Duration::from_secs(5));
    assert_eq!((s.state, s.code), (state::DONE, 0), "GroupStop: {s:?}");
    let aborted_sequence = s.response.get(4).copied();
    assert_eq!(aborted_sequence, Some(1), "AbortedSequence: {s:?}");
    for handle in [first, second] {
        let m = plc.task().status(handle).cloned().expect("status");
        assert_eq!(
            (m.state, m.code),
            (state::ABORTED, code::ABORTED_BY_GROUP_STOP),
            "{m:?}"
        );
    }
    // The drives report the last tick of the stop a telegram later than the planner.
    assert!(
        cycles_until(&mut plc, |t| !t.is_moving(), Duration::from_millis(100)),
        "standing after GroupStop"
    );
}

#[test]
fn cyclic_position_blocks_follow_the_arm_in_every_telegram() {
    let c = Controller::start("cyclic");
    let mut plc = c.client_with(EngineOptions {
        cyclic_position: plc_client::CyclicSelection {
            cartesian: true,
            joints: true,
        },
        ..plc_options()
    });
    initialize(&mut plc);
    reset_and_enable(&mut plc);
    let cyclic = |plc: &plc_client::CycleRunner<plc_client::TcpTransport>| {
        plc.task()
            .cyclic_position()
            .copied()
            .expect("cyclic blocks")
    };
    let at_home = cyclic(&plc);
    let joints = at_home.joints_deg.expect("joint block");
    assert!(max_deviation(joints, HOME) < 0.01, "{joints:?}");
    let read = actual_joints(&mut plc);
    assert!(max_deviation(read, joints) < 0.01);
    assert_eq!(
        at_home.tool_frame,
        Some((0, 0)),
        "flange in the world frame"
    );
    let target = [10.0, 95.0, 85.0, 95.0, -85.0, 10.0];
    assert!(move_to(&mut plc, target, 100.0) < 0.01);
    plc.run_for(std::time::Duration::from_millis(50))
        .expect("cycles");
    let there = cyclic(&plc);
    assert!(max_deviation(there.joints_deg.expect("joints"), target) < 0.01);
    let moved = there.cartesian.expect("pose");
    let before = at_home.cartesian.expect("pose");
    assert!(
        (0..3).any(|i| (moved[i] - before[i]).abs() > 1.0),
        "the TCP moved: {before:?} -> {moved:?}"
    );
}

/// GroupJog parameters after the 4-byte header: joint mode, override, direction bits.
fn jog_payload(enable: bool, direction: Option<shared_types::srci::payload::Field>) -> Vec<u8> {
    use shared_types::srci::payload::PayloadWriter;
    use shared_types::srci::tables::group_jog::request as f;
    let mut b = vec![0u8; f::LEN];
    let mut w = PayloadWriter::new(&mut b);
    w.set_bit(f::ENABLE, enable);
    w.set_u8(f::MODE, 2);
    w.set_u16(f::OVERRIDE, 2000);
    if let Some(d) = direction {
        w.set_bit(d, true);
    }
    b.split_off(4)
}

#[test]
fn group_jog_moves_a_joint_while_its_bit_is_set() {
    use shared_types::srci::tables::group_jog as gj;
    let c = Controller::start("jog");
    let mut plc = c.client();
    initialize(&mut plc);
    reset_and_enable(&mut plc);
    let jog = |enable, direction| Request::Raw {
        command_type: gj::TYPE,
        execution_mode: 7,
        payload: jog_payload(enable, direction),
    };
    let before = actual_joints(&mut plc);
    let handle = plc
        .task_mut()
        .submit(&jog(true, Some(gj::request::X_J1_POS)))
        .expect("submit GroupJog");
    let active = run_until_state(&mut plc, handle, state::ACTIVE, Duration::from_secs(5));
    assert_eq!(active.state, state::ACTIVE, "{active:?}");
    assert!(
        cycles_until(&mut plc, |t| t.is_moving(), Duration::from_secs(2)),
        "jogging J1"
    );
    plc.run_for(Duration::from_millis(300)).expect("jogging");
    plc.task_mut()
        .update(handle, &jog(true, None))
        .expect("release the key");
    assert!(
        cycles_until(&mut plc, |t| !t.is_moving(), Duration::from_secs(2)),
        "stops when the bit is released"
    );
    let after = actual_joints(&mut plc);
    assert!(
        after[0] > before[0] + 1.0,
        "J1 moved positive: {before:?} -> {after:?}"
    );
    for i in 1..6 {
        assert!((after[i] - before[i]).abs() < 1e-3, "only J1 moved");
    }
    let s = plc.task().status(handle).cloned().expect("status");
    assert_eq!(
        s.response.get(4).map(|b| b & 0b101),
        Some(0b001),
        "Enabled, not moving"
    );
    plc.task_mut()
        .update(handle, &jog(false, None))
        .expect("disable");
    let done = run_until_state(&mut plc, handle, state::DONE, Duration::from_secs(5));
    assert_eq!((done.state, done.code), (state::DONE, 0), "{done:?}");
}

/// A PLC program jogs with GroupJog steps written by the table's field names: the first
/// step enables the jog with J1's plus key (ACTIVE), the next releases the key under the
/// same CmdID, the last disables it (DONE); J1 moved positive, the others stood.
#[test]
fn a_program_jogs_with_group_jog_steps_that_update_one_command() {
    let s = &common::run_passing_program(
        "progjog",
        r#"
        [[step]]
        call = "GroupReset"
        [[step]]
        call = "EnableRobot"
        [[step]]
        call = "ReadActualPosition"
        [[step]]
        call = "GroupJog"
        enable = true
        mode = 2
        override = 20.0
        x_j1_pos = true
        [[step]]
        call = "GroupJog"
        delay_ms = 300
        enable = true
        mode = 2
        override = 20.0
        [[step]]
        call = "GroupJog"
        delay_ms = 300
        enable = false
        [[step]]
        call = "ReadActualPosition"
        "#,
    );
    assert_eq!(
        [3, 4, 5].map(|i| s[i].state.as_str()),
        ["ACTIVE", "ACTIVE", "DONE"]
    );
    let (before, after) = (
        s[2].reached.expect("position before").joints_deg,
        s[6].reached.expect("position after").joints_deg,
    );
    assert!(after[0] > before[0] + 1.0, "J1: {before:?} -> {after:?}");
    for i in 1..6 {
        assert!((after[i] - before[i]).abs() < 1e-3, "only J1 moved");
    }
}

/// A tool written and read back by table steps: the report shows the read's response by
/// field, the tool's six values as one list.
#[test]
fn a_program_writes_a_tool_and_reads_it_back_by_field_names() {
    let s = &common::run_passing_program(
        "progtool",
        r#"
        [[step]]
        call = "GroupReset"
        [[step]]
        call = "WriteToolData"
        tool_no = 4
        tool_data = [10.0, 0.0, 120.0, 0.0, 0.0, 45.0]
        [[step]]
        call = "ReadToolData"
        tool_no = 4
        "#,
    );
    let field = |name: &str| {
        s[2].response
            .iter()
            .find(|(n, _)| *n == name)
            .map(|(_, v)| v.clone())
    };
    assert_eq!(
        field("tool_no").as_deref(),
        Some("4"),
        "{:?}",
        s[2].response
    );
    assert_eq!(
        field("tool_data").as_deref(),
        Some("[10, 0, 120, 0, 0, 45]"),
        "{:?}",
        s[2].response
    );
}

/// A config edit that keeps the user data in `dir`.
fn with_data_dir(dir: &std::path::Path) -> impl FnOnce(String) -> String {
    let line = format!("data_dir = \"{}\"", dir.display());
    move |text: String| {
        text.lines()
            .map(|l| {
                if l.starts_with("data_dir = ") {
                    line.clone()
                } else {
                    l.to_string()
                }
            })
            .collect::<Vec<_>>()
            .join("\n")
    }
}

#[test]
fn tool_data_is_stored_and_survives_a_restart() {
    use shared_types::srci::payload::{PayloadReader, PayloadWriter};
    use shared_types::srci::tables::{read_tool_data as rtd, write_tool_data as wtd};
    let data = std::env::temp_dir().join(format!("rc-test-userdata-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&data);
    let mut write = vec![0u8; wtd::request::LEN];
    {
        let mut w = PayloadWriter::new(&mut write);
        w.set_f32(wtd::request::TOOL_DATA_X, 12.5);
        w.set_f32(wtd::request::TOOL_DATA_Z, 150.0);
        w.set_f32(wtd::request::TOOL_DATA_RZ, 45.0);
        w.set_u8(wtd::request::TOOL_DATA_LOAD_NO, 1);
        w.set_u8(wtd::request::TOOL_NO, 3);
    }
    {
        let c = Controller::start_with("tool1", with_data_dir(&data));
        let mut plc = c.client();
        initialize(&mut plc);
        let s = execute(
            &mut plc,
            &Request::Raw {
                command_type: wtd::TYPE,
                execution_mode: 2,
                payload: write[4..].to_vec(),
            },
            Duration::from_secs(5),
        );
        assert_eq!((s.state, s.code), (state::DONE, 0), "WriteToolData: {s:?}");
        let zero = execute(
            &mut plc,
            &Request::Raw {
                command_type: wtd::TYPE,
                execution_mode: 2,
                payload: vec![0; wtd::request::LEN - 4],
            },
            Duration::from_secs(5),
        );
        assert_eq!(zero.state, state::ERROR, "tool 0 is the flange: {zero:?}");
        plc.run_for(Duration::from_millis(200))
            .expect("saved in the background");
    }
    let c = Controller::start_with("tool2", with_data_dir(&data));
    let mut plc = c.client();
    initialize(&mut plc);
    let s = execute(
        &mut plc,
        &Request::Raw {
            command_type: rtd::TYPE,
            execution_mode: 2,
            payload: vec![3],
        },
        Duration::from_secs(5),
    );
    assert_eq!((s.state, s.code), (state::DONE, 0), "ReadToolData: {s:?}");
    assert_eq!(s.response.len(), rtd::response::LEN);
    let r = PayloadReader::new(&s.response);
    assert_eq!(r.f32(rtd::response::TOOL_DATA_X), 12.5);
    assert_eq!(r.f32(rtd::response::TOOL_DATA_Z), 150.0);
    assert_eq!(r.f32(rtd::response::TOOL_DATA_RZ), 45.0);
    assert_eq!(r.u8(rtd::response::TOOL_NO), 3);
    let _ = std::fs::remove_dir_all(&data);
}

#[test]
fn move_direct_absolute_reaches_the_joints_of_a_taught_pose() {
    use shared_types::srci::payload::PayloadWriter;
    use shared_types::srci::tables::move_direct_absolute as mda;
    let c = Controller::start("direct");
    let mut plc = c.client();
    initialize(&mut plc);
    reset_and_enable(&mut plc);
    // Teach: move to joints, read the pose with its configuration and turns.
    let taught = [25.0, 100.0, 70.0, 100.0, -70.0, 200.0];
    assert!(move_to(&mut plc, taught, 100.0) < 0.01);
    let read = execute(
        &mut plc,
        &Request::ReadActualPosition { tool: 0, frame: 0 },
        Duration::from_secs(5),
    );
    let pose = plc_client::response::ActualPosition::decode(&read.response).cartesian;
    let config = read.response[34];
    let turns = [
        read.response[36],
        read.response[37],
        read.response[38],
        read.response[39],
    ];
    assert!(move_to(&mut plc, HOME, 100.0) < 0.01);

    let mut msg = vec![0u8; mda::request::LEN];
    {
        let mut w = PayloadWriter::new(&mut msg);
        for f in [
            mda::request::VELOCITY_RATE,
            mda::request::ACCELERATION_RATE,
            mda::request::DECELERATION_RATE,
            mda::request::JERK_RATE,
        ] {
            w.set_u16(f, 0xFFFF);
        }
        for (f, v) in mda::request::POSITION_X_RZ.into_iter().zip(pose) {
            w.set_f32(f, v as f32);
        }
        w.set_u8(mda::request::SHOULDER, config & 1);
        w.set_u8(mda::request::ELBOW, (config >> 1) & 1);
        w.set_u8(mda::request::WRIST, (config >> 2) & 1);
        w.set_bytes(mda::request::POSITION_TURN_NUMBER, &turns);
        // ConfigMode USE_CONFIG for all three, TurnMode USE_TURN_NUMBER.
        w.set_bytes(mda::request::CONFIG_MODE, &[0x00, 0x00]);
        w.set_u8(mda::request::TURN_MODE, 0);
    }
    let s = execute(
        &mut plc,
        &Request::Raw {
            command_type: mda::TYPE,
            execution_mode: 0,
            payload: msg[4..].to_vec(),
        },
        Duration::from_secs(15),
    );
    assert_eq!(
        (s.state, s.code),
        (state::DONE, 0),
        "MoveDirectAbsolute: {s:?}"
    );
    let reached = actual_joints(&mut plc);
    // The pose travels as REAL (f32), so the joints agree to a few thousandths of a degree.
    assert!(
        max_deviation(reached, taught) < 0.01,
        "{reached:?} vs {taught:?}"
    );

    msg[mda::request::POSITION_X.offset..mda::request::POSITION_X.offset + 4]
        .copy_from_slice(&5000f32.to_be_bytes());
    let far = execute(
        &mut plc,
        &Request::Raw {
            command_type: mda::TYPE,
            execution_mode: 0,
            payload: msg[4..].to_vec(),
        },
        Duration::from_secs(5),
    );
    assert_eq!(
        (far.state, far.code),
        (state::ERROR, code::TARGET_UNREACHABLE),
        "{far:?}"
    );
}

#[test]
fn a_restarted_servo_keeps_the_arm_where_it_stood_and_needs_a_new_enable() {
    let c = Controller::start("servo");
    let mut plc = c.client();
    initialize(&mut plc);
    reset_and_enable(&mut plc);
    let parked = [30.0, 95.0, 80.0, 85.0, -85.0, 40.0];
    assert!(move_to(&mut plc, parked, 100.0) < 0.01);
    // The position memory is written every 20 ms.
    plc.run_for(Duration::from_millis(300)).expect("cycles");
    let servo = c.pid_of("servo").expect("servo pid");
    // SAFETY: kill(2) on the servo process of our own controller.
    assert_eq!(unsafe { libc::kill(servo as i32, libc::SIGKILL) }, 0);
    let restarted = Instant::now();
    while c.pid_of("servo").is_none_or(|p| p == servo) {
        assert!(
            restarted.elapsed() < Duration::from_secs(10),
            "servo restarted"
        );
        plc.run_for(Duration::from_millis(50)).expect("cycles");
    }
    plc.run_for(Duration::from_millis(700)).expect("cycles");
    assert!(!plc.task().is_enabled(), "drives stay off after a restart");
    let here = actual_joints(&mut plc);
    assert!(
        max_deviation(here, parked) < 0.01,
        "the arm did not jump: {here:?}"
    );
    reset_and_enable(&mut plc);
    assert!(move_to(&mut plc, HOME, 100.0) < 0.01);
}

#[test]
fn rc_status_shows_the_services_and_the_servo_tick() {
    let c = Controller::start("status");
    let config = c.dir.join("default.toml");
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_rc"))
        .args(["status", "--config"])
        .arg(&config)
        .output()
        .expect("rc status");
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{text}");
    for service in ["servo", "planner", "interpreter", "fieldbus"] {
        let pid = c.pid_of(service).expect("pid").to_string();
        assert!(
            text.lines()
                .any(|l| l.starts_with(service) && l.contains(&pid) && l.ends_with(" 0")),
            "{service} with pid and 0 restarts in:\n{text}"
        );
    }
    assert!(text.contains("period 1000 µs"), "{text}");
    assert!(text.contains("planner: active job 0"), "{text}");
    drop(c);
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_rc"))
        .args(["status", "--config"])
        .arg(&config)
        .output()
        .expect("rc status");
    assert!(!out.status.success(), "not running any more");
}

#[test]
fn actual_position_in_a_user_tool_and_frame() {
    use plc_client::response::ActualPosition;
    use shared_types::srci::payload::PayloadWriter;
    use shared_types::srci::tables::{write_frame_data as wfd, write_tool_data as wtd};
    let c = Controller::start("toolframe");
    let mut plc = c.client();
    initialize(&mut plc);
    let write = |plc: &mut plc_client::CycleRunner<plc_client::TcpTransport>,
                 command_type: u16,
                 msg: Vec<u8>| {
        let s = execute(
            plc,
            &Request::Raw {
                command_type,
                execution_mode: 2,
                payload: msg[4..].to_vec(),
            },
            Duration::from_secs(5),
        );
        assert_eq!((s.state, s.code), (state::DONE, 0), "{s:?}");
    };
    let mut tool = vec![0u8; wtd::request::LEN];
    {
        let mut w = PayloadWriter::new(&mut tool);
        w.set_f32(wtd::request::TOOL_DATA_Z, 100.0);
        w.set_u8(wtd::request::TOOL_NO, 2);
    }
    write(&mut plc, wtd::TYPE, tool);
    let mut frame = vec![0u8; wfd::request::LEN];
    {
        let mut w = PayloadWriter::new(&mut frame);
        w.set_f32(wfd::request::FRAME_DATA_X, 100.0);
        w.set_u8(wfd::request::FRAME_NO, 1);
    }
    write(&mut plc, wfd::TYPE, frame);
    let read = |plc: &mut plc_client::CycleRunner<plc_client::TcpTransport>, tool, frame| {
        let s = execute(
            plc,
            &Request::ReadActualPosition { tool, frame },
            Duration::from_secs(5),
        );
        assert_eq!(s.state, state::DONE, "{s:?}");
        ActualPosition::decode(&s.response)
    };
    let flange = read(&mut plc, 0, 0);
    let in_frame = read(&mut plc, 0, 1);
    assert_eq!((in_frame.tool, in_frame.frame), (0, 1));
    assert!((in_frame.cartesian[0] - (flange.cartesian[0] - 100.0)).abs() < 0.01);
    for i in 1..6 {
        assert!(
            (in_frame.cartesian[i] - flange.cartesian[i]).abs() < 0.01,
            "{i}"
        );
    }
    let tcp = read(&mut plc, 2, 0);
    assert_eq!((tcp.tool, tcp.frame), (2, 0));
    let d: f64 = (0..3)
        .map(|i| (tcp.cartesian[i] - flange.cartesian[i]).powi(2))
        .sum::<f64>()
        .sqrt();
    assert!(
        (d - 100.0).abs() < 0.01,
        "the TCP is 100 mm from the flange: {d}"
    );
    let missing = execute(
        &mut plc,
        &Request::ReadActualPosition { tool: 7, frame: 0 },
        Duration::from_secs(5),
    );
    assert_eq!(
        missing.state,
        state::DONE,
        "an unwritten tool is the identity: {missing:?}"
    );
}
