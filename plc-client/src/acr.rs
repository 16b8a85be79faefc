//! The client's Active Command Register: CmdID slots, the outgoing fragments of each command
//! and the reassembly of its responses.
//!
//! As in the open client, the CmdID is the slot index (lowest free of 1..=size), a slot is
//! freed in the cycle after a complete response with a final state, commands are sent in
//! priority order and then oldest first, and a command longer than the room left in a
//! sequence continues in the next sequence at its PayloadPointer.

use shared_types::srci::message::{CommandHeader, state};
use shared_types::srci::telegram::{FragmentAction, FragmentHeader, SequenceWriter};

/// ACTIVE_CMD_REGISTER_ENTRIES_MAX of the open client.
pub const ENTRIES_MAX: usize = 50;
/// Largest response payload the client reassembles (RESPONSE_PAYLOAD_MAX + 1).
pub const RESPONSE_MAX: usize = 256;
/// Most fragments processed or written per sequence (FRAGMENT_MAX after finding F52).
pub const FRAGMENTS_MAX: usize = 31;

/// Identifies one submitted command for the lifetime of the client (CmdIDs are reused).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct CommandHandle(pub(crate) u64);

/// A response fragment the register could not take.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum ResponseError {
    #[error("response for CmdID {0}, which has no active command")]
    UnknownCmdId(u16),
    #[error(
        "response fragment of CmdID {cmd_id} at PayloadPointer {pointer} with {length} bytes runs past {RESPONSE_MAX} bytes"
    )]
    PointerOutOfRange {
        cmd_id: u16,
        pointer: u16,
        length: u16,
    },
}

/// A response that became complete with a fragment.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CompletedResponse {
    pub cmd_id: u16,
    pub handle: CommandHandle,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Kind {
    /// A new command: its first fragment carries Reset.
    New,
    /// A parameter update: its first fragment carries Clear.
    Update,
}

#[derive(Debug)]
struct Slot {
    handle: Option<CommandHandle>,
    /// A complete final response arrived; the slot is freed at the next [`Acr::manage`].
    is_final: bool,
    payload: Vec<u8>,
    kind: Kind,
    /// Bytes of `payload` already placed into sequences.
    offset: usize,
    /// Bytes of `payload` remain to be sent.
    pending: bool,
    /// An update that arrived while `payload` was partly sent.
    buffered_update: Vec<u8>,
    has_buffered_update: bool,
    priority: u8,
    /// Creation order (refreshed by updates), the tie-breaker after the priority.
    order: u64,
    response: [u8; RESPONSE_MAX],
    /// End of the response message being assembled since the last Complete.
    response_extent: usize,
    response_len: usize,
}

impl Slot {
    fn empty() -> Self {
        Self {
            handle: None,
            is_final: false,
            payload: Vec::new(),
            kind: Kind::New,
            offset: 0,
            pending: false,
            buffered_update: Vec::new(),
            has_buffered_update: false,
            priority: 0,
            order: 0,
            response: [0; RESPONSE_MAX],
            response_extent: 0,
            response_len: 0,
        }
    }

    fn free(&mut self) {
        self.handle = None;
        self.is_final = false;
        self.pending = false;
        self.has_buffered_update = false;
        self.response.fill(0);
        self.response_extent = 0;
        self.response_len = 0;
    }

    fn load(&mut self, payload: &[u8], kind: Kind, order: u64) {
        self.payload.clear();
        self.payload.extend_from_slice(payload);
        self.kind = kind;
        self.offset = 0;
        self.pending = true;
        self.priority = CommandHeader::decode(payload).priority;
        self.order = order;
    }
}

/// The Active Command Register.
#[derive(Debug)]
pub struct Acr {
    slots: Vec<Slot>,
    size: usize,
    next_order: u64,
}

impl Default for Acr {
    fn default() -> Self {
        Self::new()
    }
}

impl Acr {
    pub fn new() -> Self {
        Self {
            slots: (0..ENTRIES_MAX).map(|_| Slot::empty()).collect(),
            size: ENTRIES_MAX,
            next_order: 0,
        }
    }

    /// Limits the CmdIDs to 1..=min(50, `length_acr`); 0 (not reported) keeps 50.
    pub fn set_size(&mut self, length_acr: u16) {
        let n = usize::from(length_acr);
        self.size = if n == 0 {
            ENTRIES_MAX
        } else {
            n.min(ENTRIES_MAX)
        };
    }

    /// Usable register entries.
    pub fn size(&self) -> usize {
        self.size
    }

    /// Entries in use.
    pub fn in_use(&self) -> usize {
        self.slots.iter().filter(|s| s.handle.is_some()).count()
    }

    /// Frees every entry; returns the handles that were still in the register.
    pub fn reset(&mut self) -> Vec<CommandHandle> {
        let live = self.slots.iter().filter_map(|s| s.handle).collect();
        self.slots.iter_mut().for_each(Slot::free);
        live
    }

    /// Puts a new command into the lowest free slot; returns its CmdID, or `None` if full.
    pub fn add(&mut self, handle: CommandHandle, payload: &[u8]) -> Option<u16> {
        let index = self.slots[..self.size]
            .iter()
            .position(|s| s.handle.is_none())?;
        let order = self.bump_order();
        let slot = &mut self.slots[index];
        slot.free();
        slot.handle = Some(handle);
        slot.load(payload, Kind::New, order);
        Some(cmd_id_of(index))
    }

    /// Queues a parameter update of the command in `cmd_id`; false if there is none.
    ///
    /// Parameters not sent at all yet are replaced in place; an update of a command that is
    /// partly sent waits until its last fragment is out.
    pub fn update(&mut self, cmd_id: u16, payload: &[u8]) -> bool {
        let order = self.bump_order();
        let Some(slot) = self.live_slot_mut(cmd_id) else {
            return false;
        };
        if slot.is_final {
            return false;
        }
        if slot.pending && slot.offset == 0 {
            let kind = slot.kind;
            slot.load(payload, kind, order);
        } else if !slot.pending {
            slot.load(payload, Kind::Update, order);
        } else {
            slot.buffered_update.clear();
            slot.buffered_update.extend_from_slice(payload);
            slot.has_buffered_update = true;
        }
        true
    }

    /// Start-of-cycle bookkeeping: frees final entries and activates buffered updates.
    pub fn manage(&mut self) {
        let mut order = self.next_order;
        for slot in &mut self.slots {
            if slot.is_final {
                slot.free();
            } else if slot.handle.is_some() && !slot.pending && slot.has_buffered_update {
                std::mem::swap(&mut slot.payload, &mut slot.buffered_update);
                slot.has_buffered_update = false;
                slot.kind = Kind::Update;
                slot.offset = 0;
                slot.pending = true;
                slot.order = order;
                order += 1;
            }
        }
        self.next_order = order;
    }

    /// Fills a new sequence with the pending fragments, in execution order.
    pub fn fill(&mut self, w: &mut SequenceWriter<'_>) {
        let mut order = [0u8; ENTRIES_MAX];
        let mut n = 0;
        for (i, slot) in self.slots.iter().enumerate() {
            if slot.handle.is_some() && slot.pending {
                // ENTRIES_MAX < 256, so the index fits a byte.
                order[n] = i as u8;
                n += 1;
            }
        }
        let order = &mut order[..n];
        order.sort_unstable_by_key(|&i| {
            let s = &self.slots[usize::from(i)];
            (s.priority, s.order)
        });
        let mut fragments = 0;
        for &i in order.iter() {
            let index = usize::from(i);
            let slot = &mut self.slots[index];
            while slot.pending {
                let room = w.room();
                if room == 0 || fragments == FRAGMENTS_MAX {
                    return;
                }
                let start = slot.offset;
                let end = (start + room).min(slot.payload.len());
                let mut action = 0;
                if start == 0 {
                    action |= match slot.kind {
                        Kind::New => FragmentAction::RESET,
                        Kind::Update => FragmentAction::CLEAR,
                    };
                }
                if end == slot.payload.len() {
                    action |= FragmentAction::COMPLETE;
                }
                // Payloads are limited to u16::MAX bytes when they are submitted.
                let pointer = start as u16;
                if !w.push(cmd_id_of(index), action, pointer, &slot.payload[start..end]) {
                    return;
                }
                fragments += 1;
                slot.offset = end;
                slot.pending = end < slot.payload.len();
            }
        }
    }

    /// Copies one response fragment to its PayloadPointer; returns the completed response
    /// when the fragment carries Complete. A final state frees the entry at the next
    /// [`Acr::manage`].
    pub fn add_response(
        &mut self,
        h: FragmentHeader,
        data: &[u8],
    ) -> Result<Option<CompletedResponse>, ResponseError> {
        let slot = self
            .live_slot_mut(h.cmd_id)
            .ok_or(ResponseError::UnknownCmdId(h.cmd_id))?;
        let start = usize::from(h.pointer);
        let end = start + data.len();
        if end > RESPONSE_MAX {
            return Err(ResponseError::PointerOutOfRange {
                cmd_id: h.cmd_id,
                pointer: h.pointer,
                length: h.length,
            });
        }
        if h.action.clear() {
            slot.response.fill(0);
            slot.response_extent = 0;
        }
        slot.response[start..end].copy_from_slice(data);
        slot.response_extent = slot.response_extent.max(end);
        if !h.action.complete() {
            return Ok(None);
        }
        slot.response_len = slot.response_extent;
        slot.response_extent = 0;
        if state::is_final(slot.response[0] & 0x0F) {
            slot.is_final = true;
        }
        Ok(slot.handle.map(|handle| CompletedResponse {
            cmd_id: h.cmd_id,
            handle,
        }))
    }

    /// The last complete response of `cmd_id` (empty if none).
    pub fn response(&self, cmd_id: u16) -> &[u8] {
        slot_index(cmd_id)
            .and_then(|i| self.slots.get(i))
            .map_or(&[], |s| &s.response[..s.response_len])
    }

    fn live_slot_mut(&mut self, cmd_id: u16) -> Option<&mut Slot> {
        slot_index(cmd_id)
            .and_then(|i| self.slots.get_mut(i))
            .filter(|s| s.handle.is_some())
    }

    fn bump_order(&mut self) -> u64 {
        self.next_order += 1;
        self.next_order
    }
}

fn cmd_id_of(index: usize) -> u16 {
    // index < ENTRIES_MAX.
    index as u16 + 1
}

fn slot_index(cmd_id: u16) -> Option<usize> {
    usize::from(cmd_id).checked_sub(1)
}

#[cfg(test)]
mod tests {
    use super::*;
    use shared_types::srci::telegram::Sequence;

    fn payload(len: usize, priority: u8) -> Vec<u8> {
        let mut p = vec![0xAB; len];
        CommandHeader {
            command_type: 2101,
            execution_mode: 0,
            par_seq: 1,
            priority,
        }
        .encode(&mut p);
        p
    }

    fn fragments(area: &[u8]) -> Vec<(u16, u8, u16, usize)> {
        Sequence::decode(area)
            .unwrap()
            .fragments()
            .map(|f| {
                let (h, d) = f.unwrap();
                (h.cmd_id, h.action.0, h.pointer, d.len())
            })
            .collect()
    }

    #[test]
    fn lowest_free_slot_and_reuse_after_final() {
        let mut acr = Acr::new();
        assert_eq!(acr.add(CommandHandle(1), &payload(4, 3)), Some(1));
        assert_eq!(acr.add(CommandHandle(2), &payload(4, 3)), Some(2));
        let done = FragmentHeader {
            cmd_id: 1,
            action: FragmentAction(FragmentAction::COMPLETE),
            pointer: 0,
            length: 4,
        };
        let c = acr.add_response(done, &[0x1A, 0, 0, 0]).unwrap();
        assert_eq!(c.map(|c| c.handle), Some(CommandHandle(1)));
        // Freed only in the next cycle's bookkeeping.
        assert_eq!(acr.add(CommandHandle(3), &payload(4, 3)), Some(3));
        acr.manage();
        assert_eq!(acr.add(CommandHandle(4), &payload(4, 3)), Some(1));
    }

    #[test]
    fn size_limits_the_register() {
        let mut acr = Acr::new();
        acr.set_size(2);
        assert!(acr.add(CommandHandle(1), &payload(4, 3)).is_some());
        assert!(acr.add(CommandHandle(2), &payload(4, 3)).is_some());
        assert_eq!(acr.add(CommandHandle(3), &payload(4, 3)), None);
    }

    #[test]
    fn priority_then_age_orders_the_fragments() {
        let mut acr = Acr::new();
        acr.add(CommandHandle(1), &payload(4, 3));
        acr.add(CommandHandle(2), &payload(4, 1));
        acr.add(CommandHandle(3), &payload(4, 3));
        let mut area = [0u8; 100];
        acr.fill(&mut SequenceWriter::new(&mut area, 1));
        let ids: Vec<u16> = fragments(&area).iter().map(|f| f.0).collect();
        assert_eq!(ids, [2, 1, 3]);
    }

    #[test]
    fn long_command_continues_at_its_payload_pointer() {
        let mut acr = Acr::new();
        acr.add(CommandHandle(1), &payload(80, 3));
        let mut area = [0u8; 45];
        acr.fill(&mut SequenceWriter::new(&mut area, 1));
        assert_eq!(fragments(&area), [(1, 0x02, 0, 33)]);
        acr.fill(&mut SequenceWriter::new(&mut area, 2));
        assert_eq!(fragments(&area), [(1, 0x00, 33, 33)]);
        acr.fill(&mut SequenceWriter::new(&mut area, 3));
        assert_eq!(fragments(&area), [(1, 0x01, 66, 14)]);
        acr.fill(&mut SequenceWriter::new(&mut area, 4));
        assert!(fragments(&area).is_empty());
    }

    #[test]
    fn update_during_sending_waits_for_the_last_fragment() {
        let mut acr = Acr::new();
        acr.add(CommandHandle(1), &payload(80, 3));
        let mut area = [0u8; 45];
        acr.fill(&mut SequenceWriter::new(&mut area, 1));
        assert!(acr.update(1, &payload(6, 3)));
        acr.manage();
        acr.fill(&mut SequenceWriter::new(&mut area, 2));
        acr.fill(&mut SequenceWriter::new(&mut area, 3));
        assert_eq!(fragments(&area), [(1, 0x01, 66, 14)]);
        acr.manage();
        acr.fill(&mut SequenceWriter::new(&mut area, 4));
        assert_eq!(fragments(&area), [(1, 0x05, 0, 6)]);
    }

    #[test]
    fn response_reassembles_at_payload_pointers() {
        let mut acr = Acr::new();
        acr.add(CommandHandle(9), &payload(4, 3));
        let part = |action, pointer: u16, length: u16| FragmentHeader {
            cmd_id: 1,
            action: FragmentAction(action),
            pointer,
            length,
        };
        assert_eq!(acr.add_response(part(0x04, 0, 3), &[0x24, 0, 0]), Ok(None));
        let c = acr.add_response(part(0x01, 3, 3), &[0, 7, 8]).unwrap();
        assert!(c.is_some());
        assert_eq!(acr.response(1), [0x24, 0, 0, 0, 7, 8]);
        assert!(matches!(
            acr.add_response(part(0x01, 250, 10), &[0; 10]),
            Err(ResponseError::PointerOutOfRange { .. })
        ));
        assert_eq!(
            acr.add_response(
                FragmentHeader {
                    cmd_id: 5,
                    ..part(1, 0, 1)
                },
                &[0]
            ),
            Err(ResponseError::UnknownCmdId(5))
        );
    }
}
