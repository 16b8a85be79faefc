//! The thin shell: a raw Ethernet socket on a named interface and the DCP service loop that
//! feeds it to the pure [`crate::dcp::responder`], and the file behind the permanent store.

pub mod dcp_service;
pub mod file_store;
pub mod raw_socket;
