//! Building blocks of the move tests: raw requests of any move command from its spec table,
//! and the TCP read back in a tool and frame.

use std::time::Duration;

use plc_client::response::ActualPosition;
use plc_client::{CommandStatus, CyclicSelection, EngineOptions, Request};
use shared_types::srci::message::{execution_mode, state};
use shared_types::srci::payload::{Field, PayloadWriter};
use shared_types::srci::tables::{self, read_actual_position as rap};

use crate::common::{Controller, Plc, execute, expect_done, initialize, plc_options};

/// ConfigMode SAME for shoulder and elbow (byte 0) and wrist (byte 1).
pub const SAME_CONFIG: [u8; 2] = [0x11, 0x01];
/// TurnMode FREE.
pub const FREE_TURNS: u8 = 2;

/// A request of `command_type` on the primary sequence with the four `rates` at default
/// (0xFFFF); `edit` sets the rest.
pub fn move_request(
    command_type: u16,
    rates: [Field; 4],
    edit: impl FnOnce(&mut PayloadWriter),
) -> Request {
    let len = tables::payload_lengths(command_type)
        .map(|(_, request, _)| request)
        .expect("a command type of the specification");
    let mut b = vec![0u8; len];
    let mut w = PayloadWriter::new(&mut b);
    for f in rates {
        w.set_u16(f, 0xFFFF);
    }
    edit(&mut w);
    Request::Raw {
        command_type,
        execution_mode: execution_mode::SEQUENCE_PRIMARY,
        payload: b.split_off(4),
    }
}

/// Writes the six values of a pose (mm, degrees) into `fields`.
pub fn set_pose(w: &mut PayloadWriter, fields: [Field; 6], pose: [f64; 6]) {
    for (f, v) in fields.into_iter().zip(pose) {
        w.set_f32(f, v as f32);
    }
}

/// Keeps the configuration of the start (ConfigMode SAME) and lets the turns follow (FREE).
pub fn keep_configuration(w: &mut PayloadWriter, config_mode: Field, turn_mode: Field) {
    w.set_u8(config_mode.element(0), SAME_CONFIG[0]);
    w.set_u8(config_mode.element(1), SAME_CONFIG[1]);
    w.set_u8(turn_mode, FREE_TURNS);
}

/// The TCP of `tool` in `frame` (mm, degrees), read back.
pub fn tcp(plc: &mut Plc, tool: u8, frame: u8) -> [f64; 6] {
    let s = expect_done(
        plc,
        &Request::ReadActualPosition { tool, frame },
        rap::response::LEN,
    );
    ActualPosition::decode(&s.response).cartesian
}

/// Executes a move and expects DONE without a code within 30 s; returns its final response.
pub fn expect_move_done(plc: &mut Plc, request: &Request) -> Vec<u8> {
    let s = execute(plc, request, Duration::from_secs(30));
    assert_eq!(
        (s.state, s.code),
        (state::DONE, 0),
        "{} DONE: {s:?}",
        request.name()
    );
    s.response
}

/// Largest difference of the positions (mm) of two poses.
pub fn position_deviation(a: [f64; 6], b: [f64; 6]) -> f64 {
    (0..3).map(|i| (a[i] - b[i]).abs()).fold(0.0, f64::max)
}

/// `p` shifted by `d` (mm), orientation kept.
pub fn shifted(p: [f64; 6], d: [f64; 3]) -> [f64; 6] {
    [p[0] + d[0], p[1] + d[1], p[2] + d[2], p[3], p[4], p[5]]
}

/// `p` shifted by `d` mm along its own Z axis (orientation in degrees, R = Rz·Ry·Rx).
pub fn along_own_z(p: [f64; 6], d: f64) -> [f64; 6] {
    let r = shared_types::pose::rotation_from_rpy(
        p[3].to_radians(),
        p[4].to_radians(),
        p[5].to_radians(),
    );
    let m = r.matrix();
    shifted(p, [d * m[(0, 2)], d * m[(1, 2)], d * m[(2, 2)]])
}

/// The TCP of tool 0 in frame 0 is at the position of `expected` (within 0.05 mm).
pub fn assert_tcp_at(plc: &mut Plc, expected: [f64; 6]) {
    let reached = tcp(plc, 0, 0);
    assert!(
        position_deviation(reached, expected) < 0.05,
        "{reached:?} vs {expected:?}"
    );
}

/// A controller and an initialized client that receives the TCP (tool and frame in use) in
/// every telegram's CartesianPosition block.
pub fn initialized_with_cyclic_tcp(tag: &str) -> (Controller, Plc) {
    let c = Controller::start(tag);
    let mut plc = c.client_with(EngineOptions {
        cyclic_position: CyclicSelection {
            cartesian: true,
            joints: false,
        },
        ..plc_options()
    });
    initialize(&mut plc);
    (c, plc)
}

/// Submits `request` and runs cycles until it ends, giving `sample` every telegram's TCP of
/// the CartesianPosition block when it is in `tool_frame`, and the command's status; returns
/// the final status.
pub fn follow_tcp(
    plc: &mut Plc,
    request: &Request,
    tool_frame: (u8, u8),
    mut sample: impl FnMut(Option<[f64; 6]>, &CommandStatus),
) -> CommandStatus {
    let handle = plc.task_mut().submit(request).expect("submit");
    plc.run_until(
        |t| {
            let pose = t
                .cyclic_position()
                .filter(|p| p.tool_frame == Some(tool_frame))
                .and_then(|p| p.cartesian);
            let Some(status) = t.status(handle) else {
                return false;
            };
            sample(pose, status);
            status.is_final()
        },
        Duration::from_secs(20),
    )
    .expect("the move ends");
    plc.task().status(handle).cloned().expect("status")
}
