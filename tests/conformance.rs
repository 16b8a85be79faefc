//! SRCI conformance suite: one module per SRCI function, each driving the real processes
//! (`rc run`) over the TCP gateway with the PLC-side client and checking the response bytes a
//! PLC programmer relies on (decoded through the generated specification tables), the state
//! sequence, and the error codes the server answers, with their ReadMessages entries.

mod common;

mod conformance {
    mod blending;
    mod change_speed_override;
    mod default_dynamics;
    mod enable_robot;
    mod exchange_configuration;
    mod frame_data;
    mod group_interrupt_continue;
    mod group_jog;
    mod group_reset;
    mod group_stop;
    mod load_data;
    mod move_axes_absolute;
    mod move_axes_relative;
    mod move_circular_absolute;
    mod move_circular_relative;
    mod move_direct_absolute;
    mod move_direct_offset;
    mod move_direct_relative;
    mod move_linear_absolute;
    mod move_linear_absolute_j;
    mod move_linear_offset;
    mod move_linear_relative;
    mod move_requests;
    mod read_actual_position;
    mod read_actual_position_cyclic;
    mod read_messages;
    mod read_robot_data;
    mod reference_dynamics;
    mod robot_task;
    mod sequences;
    mod server_log;
    mod sw_limits;
    mod sync;
    mod tool_data;
    mod unsupported;
    mod wait_time;
}
