//! The primary and the secondary sequence of the robot interface.
//!
//! The primary sequence carries the program's moves (ExecutionMode 0/1). While it is held
//! (GroupInterrupt, or SetSequence to the secondary sequence from rest), SetSequence(2)
//! activates the secondary sequence: moves with ExecutionMode 7/8 and jogging take the arm
//! away (a jog also without SetSequence(2) while the primary sequence holds moves),
//! ReturnToPrimary brings it back to where the primary sequence was left, and after
//! SetSequence(1) GroupContinue resumes the primary sequence, but only from that position
//! (InPrimaryPos, else 0x8C02), so that the held moves continue on their own path.

use shared_types::ipc::AXES;

/// How close (rad per joint) the arm must be to the primary position to count as there.
pub const IN_POSITION_RAD: f64 = 1e-4;

/// Where the primary sequence was left.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct PrimaryPosition {
    /// Joints in rad.
    pub joints: [f64; AXES],
    /// Flange pose in the world (m and rad).
    pub flange: [f64; 6],
    /// The tool and frame in use then (PrimaryPosToolNo, PrimaryPosFrameNo).
    pub tool_no: u8,
    pub frame_no: u8,
}

/// Which sequence takes new moves, and where the primary one was left.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Sequences {
    secondary_active: bool,
    primary_position: Option<PrimaryPosition>,
}

/// Why SetSequence cannot switch.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SwitchRefused {
    /// To the secondary sequence only from an interrupted or idle primary (0x8F13).
    PrimaryRunning,
    /// Back to the primary sequence only when the secondary is empty (0x8F17).
    SecondaryNotEmpty,
}

impl Sequences {
    /// SecondarySequenceActive.
    pub fn secondary_active(&self) -> bool {
        self.secondary_active
    }

    /// Where the primary sequence was left, if the secondary sequence took over.
    pub fn primary_position(&self) -> Option<PrimaryPosition> {
        self.primary_position
    }

    /// InPrimaryPos: the arm is on the primary path (no secondary excursion, or back at the
    /// position the primary sequence was left at).
    pub fn in_primary_position(&self, joints: &[f64; AXES]) -> bool {
        self.primary_position.is_none_or(|p| {
            p.joints
                .iter()
                .zip(joints)
                .all(|(a, b)| (a - b).abs() <= IN_POSITION_RAD)
        })
    }

    /// SetSequence(2). `primary_running`: a primary move runs or waits and the sequence is
    /// not held; `here`: where the arm stands now.
    pub fn activate_secondary(
        &mut self,
        primary_running: bool,
        here: PrimaryPosition,
    ) -> Result<(), SwitchRefused> {
        if self.secondary_active {
            return Ok(());
        }
        if primary_running {
            return Err(SwitchRefused::PrimaryRunning);
        }
        self.secondary_active = true;
        self.left_primary(here);
        Ok(())
    }

    /// The arm leaves the primary path at `here` while primary moves are held (SetSequence(2),
    /// or a jog): the first excursion's position is the one to return to.
    pub fn left_primary(&mut self, here: PrimaryPosition) {
        self.primary_position.get_or_insert(here);
    }

    /// SetSequence(1). `secondary_busy`: a secondary move or jog still runs or waits.
    pub fn activate_primary(&mut self, secondary_busy: bool) -> Result<(), SwitchRefused> {
        if secondary_busy {
            return Err(SwitchRefused::SecondaryNotEmpty);
        }
        self.secondary_active = false;
        Ok(())
    }

    /// GroupContinue resumed the primary sequence from its position: the excursion is over.
    pub fn primary_resumed(&mut self) {
        self.primary_position = None;
    }

    /// GroupStop or a new session: nothing is held any more.
    pub fn reset(&mut self) {
        *self = Self::default();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn at(j1: f64) -> PrimaryPosition {
        PrimaryPosition {
            joints: [j1, 1.0, 1.0, 1.0, -1.0, 0.0],
            flange: [0.4, 0.0, 0.3, 0.0, 0.0, 0.0],
            tool_no: 2,
            frame_no: 3,
        }
    }

    /// A jog while primary moves are held leaves the primary path without SetSequence(2);
    /// further jogs keep the first position.
    #[test]
    fn a_jog_away_keeps_where_the_primary_sequence_was_left() {
        let mut s = Sequences::default();
        s.left_primary(at(0.5));
        s.left_primary(at(0.7));
        assert!(!s.secondary_active());
        assert_eq!(s.primary_position(), Some(at(0.5)));
        assert!(!s.in_primary_position(&at(0.7).joints));
        s.primary_resumed();
        assert!(s.in_primary_position(&at(0.7).joints));
    }

    #[test]
    fn an_excursion_on_the_secondary_sequence_and_back() {
        let mut s = Sequences::default();
        assert!(s.in_primary_position(&at(0.5).joints), "never left");
        assert_eq!(
            s.activate_secondary(true, at(0.5)),
            Err(SwitchRefused::PrimaryRunning)
        );
        s.activate_secondary(false, at(0.5)).unwrap();
        assert!(s.secondary_active());
        // Jogged away.
        assert!(!s.in_primary_position(&at(0.7).joints));
        assert_eq!(
            s.activate_primary(true),
            Err(SwitchRefused::SecondaryNotEmpty)
        );
        s.activate_primary(false).unwrap();
        assert!(!s.secondary_active());
        assert!(!s.in_primary_position(&at(0.7).joints), "still away");
        assert!(s.in_primary_position(&at(0.5 + 0.5 * IN_POSITION_RAD).joints));
        s.primary_resumed();
        assert_eq!(s.primary_position(), None);
    }

    #[test]
    fn a_second_excursion_keeps_the_first_primary_position() {
        let mut s = Sequences::default();
        s.activate_secondary(false, at(0.5)).unwrap();
        s.activate_primary(false).unwrap();
        s.activate_secondary(false, at(0.9)).unwrap();
        assert_eq!(s.primary_position(), Some(at(0.5)));
        s.reset();
        assert_eq!(s, Sequences::default());
    }
}
