//! The two sequences of moves and which of them a standing arm serves next.
//!
//! The primary sequence holds the program's moves (ExecutionMode 0/1); the secondary one
//! jogging and the moves with ExecutionMode 7/8, which run while the primary one is held.
//! The secondary sequence has precedence: while one of its moves runs or waits, no primary
//! move starts. A held sequence starts nothing, and a held secondary sequence with a move
//! waiting still keeps the primary one from starting.

use shared_types::ipc::{MotionCommand, MotionSequence};

use crate::queue::{MoveQueue, QueuedMove};

/// One of the two sequences.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Sequence {
    Primary,
    Secondary,
}

impl Sequence {
    /// Both sequences.
    pub const BOTH: [Self; 2] = [Self::Primary, Self::Secondary];

    /// The sequence a move of `command` belongs to (`All` means the primary one).
    pub fn of_move(command: &MotionCommand) -> Self {
        match MotionSequence::from_wire(command.sequence) {
            MotionSequence::Secondary => Self::Secondary,
            MotionSequence::Primary | MotionSequence::All => Self::Primary,
        }
    }

    /// The sequences a command acting on `scope` acts on.
    pub fn within(scope: MotionSequence) -> impl Iterator<Item = Self> {
        Self::BOTH.into_iter().filter(move |s| s.is_in(scope))
    }

    /// Whether a command acting on `scope` acts on this sequence.
    pub fn is_in(self, scope: MotionSequence) -> bool {
        match scope {
            MotionSequence::All => true,
            MotionSequence::Primary => self == Self::Primary,
            MotionSequence::Secondary => self == Self::Secondary,
        }
    }

    /// The scope of a command that acts on this sequence only.
    pub fn scope(self) -> MotionSequence {
        match self {
            Self::Primary => MotionSequence::Primary,
            Self::Secondary => MotionSequence::Secondary,
        }
    }
}

/// Whether two scopes share a sequence.
pub fn overlap(a: MotionSequence, b: MotionSequence) -> bool {
    Sequence::BOTH.iter().any(|s| s.is_in(a) && s.is_in(b))
}

/// Which sequences are held (by GroupInterrupt, StepMode or disabled drives): a held
/// sequence starts none of its moves.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Holds {
    /// The primary sequence is held (SRCI PrimarySequencePaused).
    pub primary: bool,
    pub secondary: bool,
}

impl Holds {
    /// Whether `sequence` is held.
    pub fn of(&self, sequence: Sequence) -> bool {
        match sequence {
            Sequence::Primary => self.primary,
            Sequence::Secondary => self.secondary,
        }
    }

    /// Holds or releases `sequence`.
    pub fn set(&mut self, sequence: Sequence, held: bool) {
        match sequence {
            Sequence::Primary => self.primary = held,
            Sequence::Secondary => self.secondary = held,
        }
    }
}

/// How many moves of each sequence a look-ahead has started already.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Cursor {
    primary: usize,
    secondary: usize,
}

impl Cursor {
    /// Moves of `sequence` started.
    pub fn passed(&self, sequence: Sequence) -> usize {
        match sequence {
            Sequence::Primary => self.primary,
            Sequence::Secondary => self.secondary,
        }
    }

    /// Counts a started move of `sequence`.
    pub fn pass(&mut self, sequence: Sequence) {
        match sequence {
            Sequence::Primary => self.primary += 1,
            Sequence::Secondary => self.secondary += 1,
        }
    }
}

/// The buffered moves of both sequences.
#[derive(Debug)]
pub struct Sequences {
    primary: MoveQueue,
    secondary: MoveQueue,
}

impl Sequences {
    /// Empty sequences for `capacity` moves each.
    pub fn with_capacity(capacity: usize) -> Self {
        Self {
            primary: MoveQueue::with_capacity(capacity),
            secondary: MoveQueue::with_capacity(capacity),
        }
    }

    /// The moves of `sequence`.
    pub fn queue(&self, sequence: Sequence) -> &MoveQueue {
        match sequence {
            Sequence::Primary => &self.primary,
            Sequence::Secondary => &self.secondary,
        }
    }

    /// The moves of `sequence`, to change them.
    pub fn queue_mut(&mut self, sequence: Sequence) -> &mut MoveQueue {
        match sequence {
            Sequence::Primary => &mut self.primary,
            Sequence::Secondary => &mut self.secondary,
        }
    }

    /// Whether no move waits in either sequence.
    pub fn is_empty(&self) -> bool {
        self.primary.is_empty() && self.secondary.is_empty()
    }

    /// The move a standing arm starts next, past the moves `cursor` counts as started, and
    /// its sequence; `None` if it waits.
    pub fn next(&self, cursor: &Cursor, holds: Holds) -> Option<(Sequence, &QueuedMove)> {
        if let Some(secondary) = self.secondary.get(cursor.secondary) {
            return (!holds.secondary).then_some((Sequence::Secondary, secondary));
        }
        if holds.primary {
            return None;
        }
        self.primary
            .get(cursor.primary)
            .map(|primary| (Sequence::Primary, primary))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use shared_types::ipc::MotionCommandKind;

    use crate::test_support::queued as job;

    fn next_job(s: &Sequences, cursor: &Cursor, holds: Holds) -> Option<(Sequence, u32)> {
        s.next(cursor, holds).map(|(q, m)| (q, m.command.job))
    }

    #[test]
    fn secondary_moves_go_first_and_a_held_one_blocks_the_primary_sequence() {
        let mut s = Sequences::with_capacity(4);
        s.queue_mut(Sequence::Primary).push(job(1)).unwrap();
        s.queue_mut(Sequence::Secondary).push(job(2)).unwrap();
        let free = Holds::default();
        let mut cursor = Cursor::default();
        assert_eq!(next_job(&s, &cursor, free), Some((Sequence::Secondary, 2)));
        let secondary_held = Holds {
            secondary: true,
            ..free
        };
        assert_eq!(next_job(&s, &cursor, secondary_held), None);
        cursor.pass(Sequence::Secondary);
        assert_eq!(next_job(&s, &cursor, free), Some((Sequence::Primary, 1)));
        let primary_held = Holds {
            primary: true,
            ..free
        };
        assert_eq!(
            next_job(&s, &Cursor::default(), primary_held).map(|n| n.1),
            Some(2)
        );
        assert_eq!(next_job(&s, &cursor, primary_held), None);
        assert_eq!(cursor.passed(Sequence::Secondary), 1);
        assert_eq!(cursor.passed(Sequence::Primary), 0);
    }

    #[test]
    fn scopes_select_their_sequences() {
        let mut c = MotionCommand::new(MotionCommandKind::MoveAxes);
        assert_eq!(Sequence::of_move(&c), Sequence::Primary);
        c.sequence = MotionSequence::Secondary as u8;
        assert_eq!(Sequence::of_move(&c), Sequence::Secondary);
        assert!(Sequence::Primary.is_in(MotionSequence::All));
        assert!(!Sequence::Primary.is_in(MotionSequence::Secondary));
        assert!(overlap(MotionSequence::All, MotionSequence::Secondary));
        let all: Vec<Sequence> = Sequence::within(MotionSequence::All).collect();
        assert_eq!(all, Sequence::BOTH);
        let secondary: Vec<Sequence> = Sequence::within(MotionSequence::Secondary).collect();
        assert_eq!(secondary, [Sequence::Secondary]);
        assert!(!overlap(MotionSequence::Primary, MotionSequence::Secondary));
        let mut holds = Holds::default();
        holds.set(Sequence::Secondary, true);
        assert!(holds.of(Sequence::Secondary) && !holds.of(Sequence::Primary));
    }
}
