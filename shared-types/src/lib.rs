//! Types shared by every process of the rc controller: the iceoryx2 payloads and topics,
//! the configuration, and the SRCI telegram codec.

pub mod alloc_count;
pub mod bus;
pub mod config;
pub mod health;
pub mod ipc;
pub mod pose;
pub mod realtime;
pub mod srci;
pub mod supervision;
pub mod throttle;
pub mod time;
