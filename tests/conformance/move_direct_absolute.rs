//! MoveDirectAbsolute (2102): a Cartesian target reached by a joint move, in the taught
//! configuration and turns or as ConfigMode/TurnMode choose; progress and remaining distance.

use std::time::Duration;

use plc_client::response::{ActualPosition, ArmConfiguration, CartesianMoveProgress};
use plc_client::{MoveDirectAbsolute, Request};
use shared_types::srci::message::{code, state};
use shared_types::srci::tables::{move_direct_absolute as mda, read_actual_position as rap};

use crate::common::{
    Edit, HOME, Plc, actual_joints, expect_done, expect_error, follow, initialized, max_deviation,
    move_to, reset_and_enable,
};

/// The pose, configuration bits and turns at the current position.
fn teach(plc: &mut Plc) -> ([f64; 6], u8, [u8; 4]) {
    let s = expect_done(
        plc,
        &Request::ReadActualPosition { tool: 0, frame: 0 },
        rap::response::LEN,
    );
    let c = ArmConfiguration::decode(&s.response);
    (
        ActualPosition::decode(&s.response).cartesian,
        c.bits(),
        c.turn_numbers,
    )
}

#[test]
fn taught_pose_is_reached_in_its_configuration() {
    let (_c, mut plc) = initialized("mda");
    let taught = [25.0, 100.0, 70.0, 100.0, -70.0, 200.0];
    let (home_pose, home_config, home_turns) = teach(&mut plc);
    let home_move = MoveDirectAbsolute::to(home_pose, home_config, home_turns);
    expect_error(&mut plc, &home_move.request(), code::ROBOT_DISABLED);
    reset_and_enable(&mut plc);
    assert!(move_to(&mut plc, taught, 100.0) < 0.01);
    let (pose, config, turns) = teach(&mut plc);
    assert_eq!(turns, [0, 0, 0x10, 0], "J6 at 200 degrees: one turn");
    assert!(move_to(&mut plc, HOME, 100.0) < 0.01);

    let h = plc
        .task_mut()
        .submit(&MoveDirectAbsolute::to(pose, config, turns).request())
        .expect("submit");
    let mut active_remaining = Vec::new();
    plc.run_until(
        |t| {
            let s = t.status(h).expect("status");
            if s.state == state::ACTIVE && s.responses > 0 {
                active_remaining
                    .push(CartesianMoveProgress::decode(&s.response).remaining_distance);
            }
            s.is_final()
        },
        Duration::from_secs(15),
    )
    .expect("move ends");
    let s = plc.task().status(h).cloned().expect("status");
    assert_eq!((s.state, s.code), (state::DONE, 0), "{s:?}");
    assert_eq!(s.response.len(), mda::response::LEN);
    let done = CartesianMoveProgress::decode(&s.response);
    assert_eq!(done.progress_percent, Some(100.0));
    assert_eq!(done.remaining_distance, 0.0, "0: target reached");
    // Once it moves (-1, no valid value, before): the TCP's path left, shrinking, at first
    // at least the straight distance (it stayed -1 while joint moves ran).
    let straight = (0..3)
        .map(|i| (pose[i] - home_pose[i]).powi(2))
        .sum::<f64>()
        .sqrt() as f32;
    let moving: Vec<f32> = active_remaining
        .iter()
        .copied()
        .skip_while(|d| *d == -1.0)
        .collect();
    assert!(
        moving.first().is_some_and(|&d| d >= straight)
            && moving.windows(2).all(|w| w[1] <= w[0])
            && moving.iter().all(|&d| d >= 0.0),
        "{active_remaining:?}, straight {straight} mm"
    );
    assert!(max_deviation(actual_joints(&mut plc), taught) < 0.01);

    // ConfigMode SAME and TurnMode SAME from here: the same joints again.
    let mut same = MoveDirectAbsolute::to(pose, 0, [0; 4]);
    same.config_mode = [1, 1, 1];
    same.turn_mode = 1;
    let (_, s) = {
        let h = plc.task_mut().submit(&same.request()).expect("submit");
        follow(&mut plc, h, Duration::from_secs(10))
    };
    assert_eq!((s.state, s.code), (state::DONE, 0), "{s:?}");
    assert!(max_deviation(actual_joints(&mut plc), taught) < 0.01);

    // USE_TURN_NUMBER with no turn: J6 160 degrees lower.
    let mut unturned = MoveDirectAbsolute::to(pose, config, [0; 4]);
    unturned.velocity_rate = Some(100.0);
    unturned.acceleration_rate = Some(100.0);
    let (_, s) = {
        let h = plc.task_mut().submit(&unturned.request()).expect("submit");
        follow(&mut plc, h, Duration::from_secs(10))
    };
    assert_eq!((s.state, s.code), (state::DONE, 0), "{s:?}");
    let j = actual_joints(&mut plc);
    assert!((j[5] - (200.0 - 360.0)).abs() < 0.01, "J6 {j:?}");

    // Refusals by the interpreter and by the planner.
    let mut far = MoveDirectAbsolute::to(pose, config, turns);
    far.pose[0] = 5000.0;
    let s = crate::common::execute(&mut plc, &far.request(), Duration::from_secs(5));
    assert_eq!(
        (s.state, s.code),
        (state::ERROR, code::TARGET_UNREACHABLE),
        "{s:?}"
    );
    let edits: [(Edit<MoveDirectAbsolute>, u16); 10] = [
        (|m| m.pose[1] = f64::NAN, code::INVALID_POSITION),
        (|m| m.frame = 16, code::INVALID_FRAME_NO),
        (|m| m.tool = 16, code::INVALID_TOOL_NO),
        (
            |m| m.velocity_rate = Some(100.01),
            code::INVALID_VELOCITY_RATE,
        ),
        (
            |m| m.deceleration_rate = Some(100.01),
            code::INVALID_DECELERATION_RATE,
        ),
        (|m| m.blending_mode = 5, code::INVALID_BLENDING_MODE),
        (|m| m.config_mode[0] = 9, code::INVALID_CONFIG_MODE_SHOULDER),
        (|m| m.config_mode[1] = 9, code::INVALID_CONFIG_MODE_ELBOW),
        (|m| m.config_mode[2] = 9, code::INVALID_CONFIG_MODE_WRIST),
        (|m| m.turn_mode = 9, code::INVALID_TURN_MODE),
    ];
    for (edit, expected) in edits {
        let mut m = MoveDirectAbsolute::to(pose, config, turns);
        edit(&mut m);
        expect_error(&mut plc, &m.request(), expected);
    }
    let mut parallel = home_move.request();
    if let Request::Raw { execution_mode, .. } = &mut parallel {
        *execution_mode = 2;
    }
    expect_error(&mut plc, &parallel, code::INVALID_EXECUTION_MODE);
}
