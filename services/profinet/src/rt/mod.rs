//! Cyclic real-time data: the RT frame, the layout of its C_SDU, IOxS, DataStatus and the
//! cycle counter.

pub mod c_sdu;
pub mod cycle_counter;
pub mod data_status;
pub mod frame;
pub mod ioxs;
