//! Connection management (CM) over DCE/RPC, UDP port 34964: the codecs come from `pnio`
//! (see the design note in the crate root), the decisions are ours ([`ar`]).

pub mod ar;
pub mod connect;
pub mod connect_response;
pub mod diagnosis;
pub mod im;
pub mod iocr;
pub mod module_diff;
pub mod pd_real;
pub mod record;
pub mod rpc;
