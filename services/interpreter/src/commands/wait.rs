//! WaitTime: the sequence stands still for a time before its next move.

use shared_types::ipc::{MotionCommand, MotionCommandKind};
use shared_types::srci::message::CommandHeader;
use shared_types::srci::payload::PayloadReader;
use shared_types::srci::tables::wait_time as wt;

use super::motion::sequence_of;

/// A WaitTime request as a planner command; every time is valid (0: no wait).
pub(super) fn decode(msg: &[u8], h: CommandHeader) -> MotionCommand {
    let mut c = MotionCommand::new(MotionCommandKind::Wait);
    c.duration_s = f64::from(milliseconds(msg)) / 1000.0;
    c.sequence = sequence_of(h.execution_mode) as u8;
    c
}

/// The Time of a WaitTime request (ms).
pub(super) fn milliseconds(msg: &[u8]) -> u32 {
    PayloadReader::new(msg).u32(wt::request::TIME)
}

#[cfg(test)]
mod tests {
    use super::*;
    use shared_types::ipc::MotionSequence;
    use shared_types::srci::message::execution_mode;
    use shared_types::srci::payload::PayloadWriter;

    #[test]
    fn a_wait_queues_on_its_sequence_for_its_time() {
        let mut b = vec![0u8; wt::request::LEN];
        PayloadWriter::new(&mut b).set_u32(wt::request::TIME, 1_500);
        let mut h = CommandHeader {
            command_type: wt::TYPE,
            execution_mode: execution_mode::SEQUENCE_PRIMARY,
            par_seq: 1,
            priority: 3,
        };
        let c = decode(&b, h);
        assert_eq!(c.kind, MotionCommandKind::Wait as u8);
        assert_eq!(c.duration_s, 1.5);
        assert_eq!(c.sequence, MotionSequence::Primary as u8);
        h.execution_mode = execution_mode::SEQUENCE_SECONDARY;
        assert_eq!(decode(&b, h).sequence, MotionSequence::Secondary as u8);
    }
}
