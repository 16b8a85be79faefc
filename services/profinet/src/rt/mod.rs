//! Cyclic real-time data: the RT frame, the layout of its C_SDU, IOxS, DataStatus, the
//! cycle counter, and the provider and consumer of an IO AR.

pub mod c_sdu;
pub mod cycle_counter;
pub mod cyclic;
pub mod data_status;
pub mod frame;
pub mod ioxs;
