//! Data synchronisation (SYNC) between the user data the PLC keeps and the controller's.
//!
//! The PLC says in ExchangeConfiguration which data sets it synchronises (EnableSync) and
//! which of its copies it holds in sync (client DataInSync); the controller answers its own
//! DataInSync bits: a set is in sync when it is synchronised, the PLC holds it in sync and no
//! entry carries DataChanged (a value the PLC did not write, e.g. after a factory reset).
//! The interface is SYNCHRONIZED when every synchronised set is in sync; sets the controller
//! does not keep (work areas) never block it.
//!
//! SyncReaction says what happens while it is not (after SyncDelay ms of grace):
//! 0 nothing; 1 EnableRobot is refused (0x8C06), an enabled robot stays enabled;
//! 2 as 1, and the primary sequence is interrupted once it has run empty; 3 as 1, and the
//! primary sequence is interrupted at once. GroupContinue resumes it after the data is in
//! sync again.

use crate::user_data::{DataSet, UserData};

/// What the controller does while the interface is not synchronized.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
pub enum SyncReaction {
    /// Nothing.
    #[default]
    None,
    /// EnableRobot is refused.
    DenyEnable,
    /// EnableRobot is refused, and the primary sequence stops once it is empty.
    InterruptWhenEmpty,
    /// EnableRobot is refused, and the primary sequence stops at once.
    InterruptNow,
}

impl SyncReaction {
    /// Decodes the wire value; `None` for an undefined one (0x8D33).
    pub fn from_wire(v: u8) -> Option<Self> {
        Some(match v {
            0 => Self::None,
            1 => Self::DenyEnable,
            2 => Self::InterruptWhenEmpty,
            3 => Self::InterruptNow,
            _ => return None,
        })
    }
}

/// The synchronisation the PLC asked for in its last ExchangeConfiguration.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct SyncRequest {
    /// EnableSync per data set, in the order of [`DataSet::ALL`].
    pub enabled: [bool; 6],
    /// The PLC's DataInSync per data set, same order.
    pub client_in_sync: [bool; 6],
    /// EnableSync of work areas, which the controller does not keep: reported in sync, as
    /// there is nothing to differ.
    pub work_area: bool,
    pub reaction: SyncReaction,
    /// Grace time in ms before the reaction.
    pub delay_ms: u16,
}

/// The controller's DataInSync per data set, in the order of [`DataSet::ALL`].
pub fn data_in_sync(request: &SyncRequest, data: &UserData) -> [bool; 6] {
    core::array::from_fn(|k| {
        request.enabled[k] && request.client_in_sync[k] && !data.data_changed(DataSet::ALL[k])
    })
}

/// Whether every data set the PLC synchronises is in sync (RI state SYNCHRONIZED).
pub fn synchronized(request: &SyncRequest, data: &UserData) -> bool {
    let in_sync = data_in_sync(request, data);
    (0..DataSet::ALL.len()).all(|k| !request.enabled[k] || in_sync[k])
}

/// What the reaction asks for now.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SyncAction {
    /// Nothing to do.
    None,
    /// Interrupt the primary sequence (once).
    Interrupt,
}

/// Tracks how long the interface has not been synchronized and when to react.
#[derive(Debug, Clone, Copy, Default, serde::Serialize, serde::Deserialize)]
pub struct SyncSupervisor {
    /// Since when (ms) the interface is not synchronized.
    unsynchronized_since: Option<u64>,
    /// The reaction has interrupted the sequence since the interface lost its sync.
    reacted: bool,
}

impl SyncSupervisor {
    /// One check at `now_ms`; `sequence_empty` is whether no move runs or waits.
    pub fn check(
        &mut self,
        request: &SyncRequest,
        synchronized: bool,
        sequence_empty: bool,
        now_ms: u64,
    ) -> SyncAction {
        if synchronized {
            *self = Self::default();
            return SyncAction::None;
        }
        let since = *self.unsynchronized_since.get_or_insert(now_ms);
        let due = now_ms.saturating_sub(since) >= u64::from(request.delay_ms);
        let wanted = match request.reaction {
            SyncReaction::InterruptNow => true,
            SyncReaction::InterruptWhenEmpty => sequence_empty,
            SyncReaction::None | SyncReaction::DenyEnable => false,
        };
        if due && wanted && !self.reacted {
            self.reacted = true;
            SyncAction::Interrupt
        } else {
            SyncAction::None
        }
    }

    /// Whether EnableRobot is to be refused (0x8C06).
    pub fn denies_enable(request: &SyncRequest, synchronized: bool) -> bool {
        !synchronized && request.reaction != SyncReaction::None
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::user_data::RobotBounds;

    fn data() -> UserData {
        let cfg = shared_types::config::Config::load(None).unwrap();
        UserData::factory(RobotBounds::of(&cfg.robot).0)
    }

    fn tools_only(client_in_sync: bool, reaction: SyncReaction) -> SyncRequest {
        SyncRequest {
            enabled: [true, false, false, false, false, false],
            client_in_sync: [client_in_sync, false, false, false, false, false],
            work_area: false,
            reaction,
            delay_ms: 100,
        }
    }

    #[test]
    fn a_set_is_in_sync_when_enabled_held_in_sync_by_the_plc_and_unchanged() {
        let data = data();
        let request = tools_only(true, SyncReaction::None);
        assert_eq!(
            data_in_sync(&request, &data),
            [true, false, false, false, false, false]
        );
        assert!(synchronized(&request, &data));
        assert!(!synchronized(&tools_only(false, SyncReaction::None), &data));
        assert!(
            synchronized(&SyncRequest::default(), &data),
            "nothing to synchronise"
        );
    }

    #[test]
    fn values_the_plc_did_not_write_break_the_sync() {
        let mut data = data();
        // SW limits reset to the factory values carry DataChanged: the PLC has not seen them.
        let mut request = tools_only(true, SyncReaction::None);
        request.enabled[3] = true;
        request.client_in_sync[3] = true;
        assert!(synchronized(&request, &data));
        data.write_sw_limits(Default::default(), None).unwrap();
        assert!(data.data_changed(DataSet::SwLimits));
        assert!(!synchronized(&request, &data));
    }

    #[test]
    fn reactions_wait_for_the_delay_and_interrupt_once() {
        let now = tools_only(false, SyncReaction::InterruptNow);
        let mut s = SyncSupervisor::default();
        assert_eq!(s.check(&now, false, false, 1000), SyncAction::None);
        assert_eq!(s.check(&now, false, false, 1099), SyncAction::None);
        assert_eq!(s.check(&now, false, false, 1100), SyncAction::Interrupt);
        assert_eq!(s.check(&now, false, false, 1200), SyncAction::None);
        assert_eq!(s.check(&now, true, false, 1300), SyncAction::None);
        assert_eq!(s.check(&now, false, false, 1300), SyncAction::None);
        assert_eq!(s.check(&now, false, false, 1400), SyncAction::Interrupt);

        let empty = tools_only(false, SyncReaction::InterruptWhenEmpty);
        let mut s = SyncSupervisor::default();
        assert_eq!(s.check(&empty, false, false, 0), SyncAction::None);
        assert_eq!(s.check(&empty, false, false, 500), SyncAction::None);
        assert_eq!(s.check(&empty, false, true, 600), SyncAction::Interrupt);

        let deny = tools_only(false, SyncReaction::DenyEnable);
        let mut s = SyncSupervisor::default();
        assert_eq!(s.check(&deny, false, true, 10_000), SyncAction::None);
        assert!(SyncSupervisor::denies_enable(&deny, false));
        assert!(!SyncSupervisor::denies_enable(&deny, true));
        assert!(!SyncSupervisor::denies_enable(
            &tools_only(false, SyncReaction::None),
            false
        ));
    }
}
