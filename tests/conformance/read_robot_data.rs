//! ReadRobotData (9002): identity, axes and RCSupportedFunctions.

use plc_client::Request;
use plc_client::response::RobotData;
use shared_types::srci::message::code;
use shared_types::srci::supported;
use shared_types::srci::tables::{self as t, read_robot_data as rrd};

use crate::common::{expect_done, expect_error, initialized};

#[test]
fn identity_axes_and_supported_functions() {
    let (_c, mut plc) = initialized("rrd");
    let s = expect_done(&mut plc, &Request::ReadRobotData, rrd::response::LEN);
    let d = RobotData::decode(&s.response);
    assert_eq!(
        plc.task().robot_data(),
        Some(&d),
        "the start-up read the same data"
    );
    assert_eq!(d.manufacturer, "rc SRCI controller");
    assert_eq!(d.serial_number, "SIM-0001");
    assert_eq!(d.order_id, "rc-sim");
    assert_eq!(d.ra_serial_number, "JAKA Zu 7");
    assert_eq!(d.robot_id, "JAKA Zu 7");
    assert_eq!(d.interpreter_version, "1.5");
    assert!(!d.firmware_version.is_empty());
    assert_eq!(d.axis_joint_used, 0b0111_1110, "J1..J6 in bits 1..6");
    assert_eq!(d.axis_external_used, 0, "no external axes");
    assert_eq!(d.axis_joint_unit, 0, "all joints in degrees");
    assert_eq!(d.interpreter_cycle_time_ms, 1, "servo period 1 ms");

    // Every set bit belongs to a function the map defines: nothing reserved is announced.
    let mut known = [0u8; 19];
    for &(_, byte, bit) in &supported::BITS {
        known[usize::from(byte)] |= 1 << bit;
    }
    let (byte, bit) = supported::CYCLIC_POSITION;
    known[usize::from(byte)] |= 1 << bit;
    for (i, (&map, &k)) in d.supported_functions.iter().zip(&known).enumerate() {
        assert_eq!(map & !k, 0, "byte {i}: only defined bits");
    }
    assert_ne!(
        d.supported_functions[usize::from(byte)] & (1 << bit),
        0,
        "ReadActualPositionCyclic"
    );
    // The Core functions this controller runs (the unsupported module checks the others).
    for ty in [
        t::read_robot_data::TYPE,
        t::enable_robot::TYPE,
        t::group_reset::TYPE,
        t::read_actual_position::TYPE,
        t::exchange_configuration::TYPE,
        t::change_speed_override::TYPE,
        t::read_messages::TYPE,
        t::read_robot_reference_dynamics::TYPE,
        t::write_robot_reference_dynamics::TYPE,
        t::read_robot_default_dynamics::TYPE,
        t::write_robot_default_dynamics::TYPE,
        t::read_frame_data::TYPE,
        t::write_frame_data::TYPE,
        t::read_tool_data::TYPE,
        t::write_tool_data::TYPE,
        t::read_load_data::TYPE,
        t::write_load_data::TYPE,
        t::read_robot_sw_limits::TYPE,
        t::write_robot_sw_limits::TYPE,
        t::group_jog::TYPE,
        t::move_direct_absolute::TYPE,
        t::move_axes_absolute::TYPE,
        t::group_stop::TYPE,
        t::group_continue::TYPE,
        t::group_interrupt::TYPE,
    ] {
        assert!(d.supports(ty), "announces {ty}");
    }

    // Execute-type functions run in parallel: a sequence ExecutionMode is refused.
    expect_error(
        &mut plc,
        &Request::Raw {
            command_type: rrd::TYPE,
            execution_mode: 0,
            payload: Vec::new(),
        },
        code::INVALID_EXECUTION_MODE,
    );
}
