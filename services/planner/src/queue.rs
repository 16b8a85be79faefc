//! One sequence's buffered moves: a fixed-capacity FIFO, allocated once.

use shared_types::ipc::{MotionCommand, MotionCommandKind};

use crate::linear_move::LinearPlan;

/// A buffered move: the command and, for a linear move, its plan from where the move is
/// expected to start (planning a line surveys it, too slow to repeat every tick).
#[derive(Debug, Clone, Copy)]
pub struct QueuedMove {
    /// The command; for a linear move `joints_rad` holds the joints it ends in.
    pub command: MotionCommand,
    pub linear: Option<LinearPlan>,
    /// The executor's number of the request for its table
    /// ([`refinement`](crate::refinement)), 0 for none.
    pub table_request: u64,
    /// While its table is being planned, a standing arm starts the move no earlier than in
    /// this servo tick (0: at once).
    pub earliest_start_tick: u64,
}

impl QueuedMove {
    /// An element without a Cartesian plan: a joint move (MoveAxes) or a WaitTime.
    pub fn joint(command: MotionCommand) -> Self {
        Self {
            command,
            linear: None,
            table_request: 0,
            earliest_start_tick: 0,
        }
    }
}

/// The sequence holds as many moves as it may.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("the sequence is full")]
pub struct QueueFull;

/// Buffered moves in execution order.
#[derive(Debug)]
pub struct MoveQueue {
    /// One slot more than `limit`: room for an interrupted move put back at the front.
    slots: Box<[QueuedMove]>,
    limit: usize,
    head: usize,
    len: usize,
}

impl MoveQueue {
    /// An empty queue for `capacity` moves (at least one).
    pub fn with_capacity(capacity: usize) -> Self {
        let limit = capacity.max(1);
        Self {
            slots: vec![
                QueuedMove::joint(MotionCommand::new(MotionCommandKind::MoveAxes));
                limit + 1
            ]
            .into_boxed_slice(),
            limit,
            head: 0,
            len: 0,
        }
    }

    /// Number of buffered moves.
    pub fn len(&self) -> usize {
        self.len
    }

    /// Whether no move is buffered.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Appends `command`, unless the queue is full.
    pub fn push(&mut self, command: QueuedMove) -> Result<(), QueueFull> {
        if self.len >= self.limit {
            return Err(QueueFull);
        }
        let tail = (self.head + self.len) % self.slots.len();
        self.slots[tail] = command;
        self.len += 1;
        Ok(())
    }

    /// Puts an interrupted move back at the front, to run again on continue. There is always
    /// room for the one move that was running.
    pub fn push_front(&mut self, command: QueuedMove) -> Result<(), QueueFull> {
        if self.len == self.slots.len() {
            return Err(QueueFull);
        }
        self.head = (self.head + self.slots.len() - 1) % self.slots.len();
        self.slots[self.head] = command;
        self.len += 1;
        Ok(())
    }

    /// The `index`-th move from the front, without removing it.
    pub fn get(&self, index: usize) -> Option<&QueuedMove> {
        (index < self.len).then(|| &self.slots[(self.head + index) % self.slots.len()])
    }

    /// The `index`-th move from the front, to change it in place.
    pub fn get_mut(&mut self, index: usize) -> Option<&mut QueuedMove> {
        let slots = self.slots.len();
        (index < self.len).then(|| &mut self.slots[(self.head + index) % slots])
    }

    /// The front move, to change it in place.
    pub fn front_mut(&mut self) -> Option<&mut QueuedMove> {
        (self.len > 0).then(|| &mut self.slots[self.head])
    }

    /// The last move, the one that will end the sequence.
    pub fn back(&self) -> Option<&QueuedMove> {
        self.len.checked_sub(1).and_then(|i| self.get(i))
    }

    /// Removes and returns the front move.
    pub fn pop_front(&mut self) -> Option<QueuedMove> {
        let front = *self.get(0)?;
        self.head = (self.head + 1) % self.slots.len();
        self.len -= 1;
        Some(front)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::test_support::queued as job;

    #[test]
    fn an_interrupted_move_goes_back_to_the_front_even_when_full() {
        let mut q = MoveQueue::with_capacity(2);
        q.push(job(2)).unwrap();
        q.push(job(3)).unwrap();
        assert!(q.push(job(4)).is_err());
        q.push_front(job(1)).unwrap();
        assert_eq!(q.len(), 3);
        let order: Vec<u32> =
            core::iter::from_fn(|| q.pop_front().map(|c| c.command.job)).collect();
        assert_eq!(order, [1, 2, 3]);
    }

    #[test]
    fn fifo_order_wraps_around_and_reports_full() {
        let mut q = MoveQueue::with_capacity(3);
        for round in 0..5 {
            let base = round * 10;
            for i in 0..3 {
                assert!(q.push(job(base + i)).is_ok());
            }
            assert_eq!(q.push(job(99)), Err(QueueFull));
            assert_eq!(q.get(1).map(|c| c.command.job), Some(base + 1));
            assert_eq!(q.back().map(|c| c.command.job), Some(base + 2));
            for i in 0..3 {
                assert_eq!(q.pop_front().map(|c| c.command.job), Some(base + i));
            }
            assert!(q.is_empty() && q.pop_front().is_none() && q.back().is_none());
        }
    }
}
