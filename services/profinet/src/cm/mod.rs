//! Connection management (CM) over DCE/RPC: the codecs come from `pnio` (see the design
//! note in the crate root), the decisions are ours.

pub mod connect;
pub mod connect_response;
pub mod iocr;
pub mod module_diff;
