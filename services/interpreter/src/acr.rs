//! The Active Command Register: per-CmdID receive buffers that reassemble command fragments.
//!
//! A fragment with Reset starts a new command under its CmdID, Clear starts a parameter
//! update (the buffer is zeroed first), Complete hands the message over for processing.
//! Entries are allocated once at start-up; nothing allocates per telegram.

use shared_types::srci::telegram::FragmentHeader;

/// Largest command message the register reassembles (the biggest request table is 211 bytes).
pub const MESSAGE_CAPACITY: usize = 512;

/// What a fragment did to the register.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FragmentOutcome {
    /// Stored; more fragments follow.
    Partial,
    /// The message of this entry is complete: `len` bytes, `new_command` if it began with Reset.
    Complete {
        slot: usize,
        len: usize,
        new_command: bool,
    },
    /// A fragment without Reset for a CmdID the register does not know, or a fragment
    /// without Reset or Clear for a message that was already complete (it would run the
    /// command a second time).
    UnknownCommand,
    /// No free entry for a new command (more live commands than LengthACR).
    RegisterFull,
    /// The fragment points past the end of the receive buffer.
    OutOfBounds,
}

/// One entry of the register.
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
struct Entry {
    cmd_id: u16,
    live: bool,
    /// The current message began with Reset (a new command, not an update).
    new_command: bool,
    /// The current message was complete and handed over.
    handed_over: bool,
    /// Highest byte written + 1.
    len: usize,
    #[serde(with = "crate::handover::fixed_bytes")]
    buffer: [u8; MESSAGE_CAPACITY],
}

/// The register with a fixed number of entries (LengthACR).
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
pub struct Acr {
    entries: Vec<Entry>,
}

impl Acr {
    /// A register with `length` entries, all free.
    pub fn new(length: usize) -> Self {
        Self {
            entries: vec![
                Entry {
                    cmd_id: 0,
                    live: false,
                    new_command: false,
                    handed_over: false,
                    len: 0,
                    buffer: [0; MESSAGE_CAPACITY],
                };
                length
            ],
        }
    }

    /// Number of entries (reported as LengthACR).
    pub fn length(&self) -> usize {
        self.entries.len()
    }

    /// Number of live entries.
    pub fn live(&self) -> usize {
        self.entries.iter().filter(|e| e.live).count()
    }

    fn find(&self, cmd_id: u16) -> Option<usize> {
        self.entries
            .iter()
            .position(|e| e.live && e.cmd_id == cmd_id)
    }

    /// Applies one fragment.
    pub fn on_fragment(&mut self, header: &FragmentHeader, data: &[u8]) -> FragmentOutcome {
        let slot = match (self.find(header.cmd_id), header.action.reset()) {
            (Some(slot), _) => slot,
            (None, true) => match self.entries.iter().position(|e| !e.live) {
                Some(slot) => slot,
                None => return FragmentOutcome::RegisterFull,
            },
            (None, false) => return FragmentOutcome::UnknownCommand,
        };
        let entry = &mut self.entries[slot];
        let starts_message = header.action.reset() || header.action.clear();
        if entry.live && entry.handed_over && !starts_message {
            return FragmentOutcome::UnknownCommand;
        }
        let start = usize::from(header.pointer);
        let end = start + data.len();
        if end > MESSAGE_CAPACITY {
            return FragmentOutcome::OutOfBounds;
        }
        if starts_message {
            entry.buffer.fill(0);
            entry.len = 0;
            entry.new_command = header.action.reset();
            entry.handed_over = false;
        }
        entry.cmd_id = header.cmd_id;
        entry.live = true;
        entry.buffer[start..end].copy_from_slice(data);
        entry.len = entry.len.max(end);
        if header.action.complete() {
            entry.handed_over = true;
            FragmentOutcome::Complete {
                slot,
                len: entry.len,
                new_command: entry.new_command,
            }
        } else {
            FragmentOutcome::Partial
        }
    }

    /// The reassembled message of `slot`.
    pub fn message(&self, slot: usize) -> &[u8] {
        let e = &self.entries[slot];
        &e.buffer[..e.len]
    }

    /// The reassembled message of the live command `cmd_id`.
    pub fn message_of(&self, cmd_id: u16) -> Option<&[u8]> {
        self.find(cmd_id).map(|slot| self.message(slot))
    }

    /// The CmdID of `slot`.
    pub fn cmd_id(&self, slot: usize) -> u16 {
        self.entries[slot].cmd_id
    }

    /// Frees the entry of `cmd_id` (after its final response).
    pub fn release(&mut self, cmd_id: u16) {
        if let Some(slot) = self.find(cmd_id) {
            self.entries[slot].live = false;
        }
    }

    /// Frees every entry (interface reset).
    pub fn clear(&mut self) {
        for e in &mut self.entries {
            e.live = false;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use shared_types::srci::telegram::FragmentAction;

    fn frag(cmd_id: u16, action: u8, pointer: u16, len: u16) -> FragmentHeader {
        FragmentHeader {
            cmd_id,
            action: FragmentAction(action),
            pointer,
            length: len,
        }
    }

    #[test]
    fn reassembles_split_command_at_payload_pointers() {
        let mut acr = Acr::new(2);
        assert_eq!(
            acr.on_fragment(&frag(7, FragmentAction::RESET, 0, 3), &[1, 2, 3]),
            FragmentOutcome::Partial
        );
        let out = acr.on_fragment(&frag(7, FragmentAction::COMPLETE, 3, 2), &[4, 5]);
        let FragmentOutcome::Complete {
            slot,
            len,
            new_command,
        } = out
        else {
            panic!("{out:?}")
        };
        assert_eq!((len, new_command), (5, true));
        assert_eq!(acr.message(slot), &[1, 2, 3, 4, 5]);
    }

    #[test]
    fn clear_zeroes_the_buffer_for_an_update() {
        let mut acr = Acr::new(1);
        acr.on_fragment(&frag(1, 0x03, 0, 4), &[9, 9, 9, 9]);
        let out = acr.on_fragment(&frag(1, 0x05, 0, 2), &[7, 7]);
        let FragmentOutcome::Complete {
            slot, new_command, ..
        } = out
        else {
            panic!()
        };
        assert!(!new_command);
        assert_eq!(acr.message(slot), &[7, 7]);
    }

    #[test]
    fn a_complete_message_is_not_handed_over_again_without_reset_or_clear() {
        let mut acr = Acr::new(1);
        assert!(matches!(
            acr.on_fragment(&frag(7, 0x03, 0, 2), &[1, 2]),
            FragmentOutcome::Complete { .. }
        ));
        // Found by fuzzing: a bare Complete fragment re-ran the running command.
        assert_eq!(
            acr.on_fragment(&frag(7, 0x01, 0, 0), &[]),
            FragmentOutcome::UnknownCommand
        );
        assert!(matches!(
            acr.on_fragment(&frag(7, 0x05, 0, 1), &[3]),
            FragmentOutcome::Complete {
                new_command: false,
                ..
            }
        ));
    }

    #[test]
    fn unknown_full_and_out_of_bounds_are_reported() {
        let mut acr = Acr::new(1);
        assert_eq!(
            acr.on_fragment(&frag(3, 0x01, 0, 1), &[1]),
            FragmentOutcome::UnknownCommand
        );
        acr.on_fragment(&frag(1, 0x02, 0, 1), &[1]);
        assert_eq!(
            acr.on_fragment(&frag(2, 0x03, 0, 1), &[1]),
            FragmentOutcome::RegisterFull
        );
        assert_eq!(
            acr.on_fragment(&frag(1, 0x01, 511, 2), &[1, 2]),
            FragmentOutcome::OutOfBounds
        );
        acr.release(1);
        assert_eq!(acr.live(), 0);
    }
}
