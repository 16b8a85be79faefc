//! The SRCI interpreter service: the robot-interface state machine, the Active Command
//! Register and the semantics of every implemented command, as a pure core ([`server`])
//! wrapped by a small process loop (`service`).

pub mod acr;
pub mod arm;
pub mod cartesian_jog;
pub mod commands;
pub mod cyclic;
pub mod displacement;
pub mod handover;
pub mod messages;
pub mod motion_link;
pub mod responses;
pub mod sequences;
pub mod server;
pub mod server_log;
mod service;
pub mod sync;
pub mod tcp_pose;
pub mod user_data;

pub use service::{InterpreterError, run};
