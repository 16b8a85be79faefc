//! Requests and user data shared by the unit tests of the move commands.

use shared_types::srci::message::CommandHeader;
use shared_types::srci::payload::PayloadWriter;

use super::motion::{CartesianLayout, DynamicsLayout};
use crate::user_data::{RobotBounds, UserData};

/// The header of a `command_type` request on the primary sequence.
pub fn header(command_type: u16) -> CommandHeader {
    CommandHeader {
        command_type,
        execution_mode: 0,
        par_seq: 1,
        priority: 3,
    }
}

/// The factory user data of the embedded robot.
pub fn factory_data() -> UserData {
    let cfg = shared_types::config::Config::load(None).unwrap();
    UserData::factory(RobotBounds::of(&cfg.robot).0)
}

/// Sets the four rates of `dynamics` to default (0xFFFF).
pub fn default_rates(w: &mut PayloadWriter, dynamics: &DynamicsLayout) {
    for f in [
        dynamics.velocity,
        dynamics.acceleration,
        dynamics.deceleration,
        dynamics.jerk,
    ] {
        w.set_u16(f, 0xFFFF);
    }
}

/// A `len`-byte request of a Cartesian move: rates at default, ConfigMode SAME, TurnMode
/// FREE, `position` (mm, degrees) in `layout`'s pose; `edit` sets the rest.
pub fn cartesian_request(
    layout: &CartesianLayout,
    len: usize,
    position: [f32; 6],
    edit: impl FnOnce(&mut PayloadWriter),
) -> Vec<u8> {
    let mut b = vec![0u8; len];
    let mut w = PayloadWriter::new(&mut b);
    default_rates(&mut w, &layout.common.dynamics);
    w.set_u8(layout.config_mode.element(0), 0x11);
    w.set_u8(layout.config_mode.element(1), 0x01);
    w.set_u8(layout.turn_mode, 2);
    for (f, v) in layout.position.into_iter().zip(position) {
        w.set_f32(f, v);
    }
    edit(&mut w);
    b
}
