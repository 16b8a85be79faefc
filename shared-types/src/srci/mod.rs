//! The SRCI protocol codec: pure functions from bytes to typed values and back.

pub mod message;
pub mod payload;
pub mod supported;
pub mod telegram;

/// Field tables of every command's request and response, generated from the specification's
/// payload tables (`shared-types/srci/spec_payload_tables.json`).
pub mod tables {
    include!(concat!(env!("OUT_DIR"), "/spec_tables.rs"));

    /// Request and response lengths of a command type, if the specification defines it.
    pub fn payload_lengths(command_type: u16) -> Option<(&'static str, usize, usize)> {
        PAYLOAD_LENGTHS
            .iter()
            .find(|(t, ..)| *t == command_type)
            .map(|&(_, name, req, rsp)| (name, req, rsp))
    }
}
