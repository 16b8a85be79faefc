//! The RCSupportedFunctions bitmap of ReadRobotData (19 bytes; byte.bit per function).

use super::tables as t;

/// (command type, byte, bit) of every function that has a bit in RCSupportedFunctions.
/// ReadActualPositionCyclic has a bit but no command type; it is listed in [`CYCLIC_POSITION`].
pub const BITS: [(u16, u8, u8); 37] = [
    (t::read_robot_data::TYPE, 0, 1),
    (t::enable_robot::TYPE, 0, 2),
    (t::group_reset::TYPE, 0, 3),
    (t::read_actual_position::TYPE, 0, 4),
    (t::exchange_configuration::TYPE, 0, 6),
    (t::set_sequence::TYPE, 0, 7),
    (t::change_speed_override::TYPE, 1, 0),
    (t::read_messages::TYPE, 1, 1),
    (t::read_robot_reference_dynamics::TYPE, 1, 2),
    (t::write_frame_data::TYPE, 1, 3),
    (t::write_tool_data::TYPE, 1, 4),
    (t::write_load_data::TYPE, 1, 5),
    (t::write_robot_reference_dynamics::TYPE, 1, 6),
    (t::write_robot_default_dynamics::TYPE, 1, 7),
    (t::read_robot_default_dynamics::TYPE, 2, 0),
    (t::read_frame_data::TYPE, 2, 1),
    (t::read_tool_data::TYPE, 2, 2),
    (t::read_load_data::TYPE, 2, 3),
    (t::read_robot_sw_limits::TYPE, 2, 4),
    (t::group_jog::TYPE, 2, 5),
    (t::move_linear_absolute::TYPE, 2, 6),
    (t::move_direct_absolute::TYPE, 2, 7),
    (t::move_axes_absolute::TYPE, 3, 0),
    (t::group_stop::TYPE, 3, 1),
    (t::group_continue::TYPE, 3, 2),
    (t::group_interrupt::TYPE, 3, 3),
    (t::return_to_primary::TYPE, 3, 4),
    (t::move_linear_absolute_j::TYPE, 3, 5),
    (t::move_direct_relative::TYPE, 3, 6),
    (t::move_axes_relative::TYPE, 3, 7),
    (t::move_circular_absolute::TYPE, 4, 0),
    (t::move_circular_relative::TYPE, 4, 1),
    (t::move_linear_offset::TYPE, 4, 2),
    (t::move_direct_offset::TYPE, 4, 3),
    (t::wait_time::TYPE, 4, 4),
    (t::move_linear_relative::TYPE, 7, 7),
    (t::write_robot_sw_limits::TYPE, 9, 0),
];

/// Byte and bit of ReadActualPositionCyclic.
pub const CYCLIC_POSITION: (u8, u8) = (0, 5);

/// Builds the bitmap for the given implemented command types.
pub fn bitmap(implemented: &[u16]) -> [u8; 19] {
    let mut map = [0u8; 19];
    for &(ty, byte, bit) in &BITS {
        if implemented.contains(&ty) {
            map[usize::from(byte)] |= 1 << bit;
        }
    }
    map
}

/// Whether the bitmap announces `command_type`.
pub fn announces(map: &[u8; 19], command_type: u16) -> bool {
    BITS.iter()
        .find(|(t, ..)| *t == command_type)
        .is_some_and(|&(_, byte, bit)| map[usize::from(byte)] & (1 << bit) != 0)
}
