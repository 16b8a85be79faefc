//! Outgoing responses: queued per state change, split into fragments over as many new
//! sequences as they need, in order per CmdID.

use std::collections::VecDeque;

use shared_types::srci::message::ResponseHeader;
use shared_types::srci::telegram::{FragmentAction, SequenceWriter};

/// Largest response (ReadMessages: 170 bytes).
pub const RESPONSE_CAPACITY: usize = 256;

/// One response message waiting to be sent.
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
struct Pending {
    cmd_id: u16,
    state: u8,
    len: usize,
    /// Bytes already sent in earlier sequences.
    sent: usize,
    #[serde(with = "crate::handover::fixed_bytes")]
    bytes: [u8; RESPONSE_CAPACITY],
}

/// Response queue with a fixed capacity allocated at start-up.
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
pub struct ResponseQueue {
    queue: VecDeque<Pending>,
    capacity: usize,
    dropped: u64,
}

impl ResponseQueue {
    pub fn new(capacity: usize) -> Self {
        Self {
            queue: VecDeque::with_capacity(capacity),
            capacity,
            dropped: 0,
        }
    }

    /// Queues a response: `header`, then `body` written by `fill` into a zeroed buffer of
    /// `len` bytes (the full length of the response table). A response that only refreshes
    /// data (same CmdID and state as one not yet started) replaces that one instead.
    pub fn push(
        &mut self,
        cmd_id: u16,
        header: ResponseHeader,
        len: usize,
        fill: impl FnOnce(&mut [u8]),
    ) {
        let len = len.clamp(ResponseHeader::LEN, RESPONSE_CAPACITY);
        let mut bytes = [0u8; RESPONSE_CAPACITY];
        header.encode(&mut bytes);
        fill(&mut bytes[..len]);
        let replaceable = self
            .queue
            .iter_mut()
            .rev()
            .find(|p| p.cmd_id == cmd_id)
            .filter(|p| p.sent == 0 && p.state == header.state);
        if let Some(p) = replaceable {
            p.len = len;
            p.bytes = bytes;
            return;
        }
        if self.queue.len() >= self.capacity {
            // Only refreshes can be lost: a final response always finds room because the
            // oldest non-final entry gives way.
            match self
                .queue
                .iter()
                .position(|p| p.sent == 0 && !shared_types::srci::message::state::is_final(p.state))
            {
                Some(i) => {
                    self.queue.remove(i);
                    self.dropped += 1;
                }
                None => {
                    self.dropped += 1;
                    return;
                }
            }
        }
        self.queue.push_back(Pending {
            cmd_id,
            state: header.state,
            len,
            sent: 0,
            bytes,
        });
    }

    /// Writes as much as fits into `seq`, oldest first; fully sent responses leave the queue.
    pub fn fill(&mut self, seq: &mut SequenceWriter<'_>) {
        while let Some(p) = self.queue.front_mut() {
            let room = seq.room();
            if room == 0 {
                break;
            }
            let remaining = p.len - p.sent;
            let take = remaining.min(room);
            let last = take == remaining;
            let action = if last { FragmentAction::COMPLETE } else { 0 };
            // `sent` < 256, so it fits the u16 PayloadPointer.
            if !seq.push(
                p.cmd_id,
                action,
                p.sent as u16,
                &p.bytes[p.sent..p.sent + take],
            ) {
                break;
            }
            p.sent += take;
            if last {
                self.queue.pop_front();
            } else {
                // Only a full sequence leaves a response partly sent.
                break;
            }
        }
    }

    /// Drops everything (interface reset).
    /// Gives the queue its full capacity again (after it was restored from a snapshot).
    pub fn reserve_capacity(&mut self) {
        self.queue
            .reserve(self.capacity.saturating_sub(self.queue.len()));
    }

    pub fn clear(&mut self) {
        self.queue.clear();
    }

    pub fn len(&self) -> usize {
        self.queue.len()
    }

    pub fn is_empty(&self) -> bool {
        self.queue.is_empty()
    }

    /// Refresh responses lost to a full queue since start.
    pub fn dropped(&self) -> u64 {
        self.dropped
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use shared_types::srci::telegram::Sequence;

    fn header(state: u8) -> ResponseHeader {
        ResponseHeader {
            par_seq: 1,
            state,
            severity: 0,
            code: 0,
        }
    }

    #[test]
    fn long_response_is_split_over_sequences_and_reassembles() {
        let mut q = ResponseQueue::new(4);
        q.push(5, header(10), 134, |b| {
            for (i, x) in b.iter_mut().enumerate().skip(4) {
                *x = i as u8;
            }
        });
        let mut got = [0u8; 134];
        for _ in 0..4 {
            let mut area = [0u8; 53];
            let mut w = SequenceWriter::new(&mut area, 1);
            q.fill(&mut w);
            let seq = Sequence::decode(&area).unwrap();
            for f in seq.fragments() {
                let (h, d) = f.unwrap();
                let p = usize::from(h.pointer);
                got[p..p + d.len()].copy_from_slice(d);
            }
            if q.is_empty() {
                break;
            }
        }
        assert!(q.is_empty());
        assert_eq!(got[0], 0x1A);
        assert_eq!(got[133], 133);
    }

    #[test]
    fn refresh_replaces_unsent_response_of_same_state() {
        let mut q = ResponseQueue::new(4);
        q.push(1, header(4), 10, |b| b[8] = 1);
        q.push(1, header(4), 10, |b| b[8] = 2);
        assert_eq!(q.len(), 1);
        q.push(1, header(10), 10, |_| {});
        assert_eq!(q.len(), 2);
    }

    #[test]
    fn final_responses_survive_a_full_queue() {
        let mut q = ResponseQueue::new(2);
        q.push(1, header(4), 10, |_| {});
        q.push(2, header(4), 10, |_| {});
        q.push(3, header(10), 10, |_| {});
        assert_eq!(q.len(), 2);
        assert_eq!(q.dropped(), 1);
    }
}
