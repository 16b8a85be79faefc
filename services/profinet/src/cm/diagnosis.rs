//! The diagnosis records a controller reads to fill its diagnosis buffer and the
//! device's status: one subslot (0x800A..), one slot (0xC00A..), one AR (0xE00A..), one
//! API (0xF00A..) and the device (0xF80C). The device's only diagnosis is the robot error
//! on the SRCI submodule ([`crate::alarm::robot_error_diagnosis`]), a fault: while the
//! robot has an error the diagnosis records whose scope holds the SRCI submodule carry
//! one DiagnosisData block (version 1.1: API, slot, subslot, the summary channel 0x8000
//! "appears", USI 0x8000 ChannelDiagnosis and the channel's entry); otherwise, and for
//! the maintenance records (0x8010..0x8013 and their wider scopes), the answer is a
//! record of no data, as p-net answers a subslot without diagnosis.

use pnio::alarm::{ChannelProperties, Maintenance, Specifier, USI_CHANNEL_DIAG};
use pnio::cm::block::BlockHeader;
use pnio::config::Direction;
use pnio::diag::{Diagnosis, Severity, WHOLE_SUBMODULE};

use crate::alarm::robot_error_diagnosis;
use crate::device::{API, SubmoduleModel};

/// BlockType of DiagnosisData.
const BLOCK_DIAGNOSIS_DATA: u16 = 0x0010;
/// ChannelProperties of the summary channel: Specifier "appears".
const SUMMARY_APPEARS: u16 = 0x0800;

/// Which part of the device a diagnosis record covers.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Scope {
    /// One subslot: 0x800A..0x800C, 0x8010..0x8013.
    Subslot,
    /// One slot: 0xC00A..0xC00C, 0xC010..0xC013.
    Slot,
    /// The AR's submodules: 0xE00A..0xE00C, 0xE010..0xE013.
    Ar,
    /// One API: 0xF00A..0xF00C, 0xF010..0xF013.
    Api,
    /// The device: 0xF80C.
    Device,
}

/// A diagnosis record: its scope and whether faults are in it (the maintenance records
/// hold maintenance demands only, which this device never has).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct DiagnosisRecord {
    /// What the record covers.
    pub scope: Scope,
    /// True for the records with faults: channel coding, all codings, and
    /// "diagnosis, maintenance, qualified and status".
    pub faults: bool,
}

impl DiagnosisRecord {
    /// The diagnosis record at `index`, if it is one.
    pub fn at(index: u16) -> Option<Self> {
        if index == 0xf80c {
            return Some(Self {
                scope: Scope::Device,
                faults: true,
            });
        }
        let scope = match index & 0xff00 {
            0x8000 => Scope::Subslot,
            0xc000 => Scope::Slot,
            0xe000 => Scope::Ar,
            0xf000 => Scope::Api,
            _ => return None,
        };
        let faults = match index & 0x00ff {
            0x0a..=0x0c => true,
            0x10..=0x13 => false,
            _ => return None,
        };
        Some(Self { scope, faults })
    }

    /// The record data for a Read of `api`/`slot`/`subslot` when the robot has an error
    /// (`robot_error`) or not, on a device whose SRCI submodule is `srci`.
    pub fn data(
        self,
        (api, slot, subslot): (u32, u16, u16),
        srci: &SubmoduleModel,
        robot_error: bool,
    ) -> Vec<u8> {
        let covers_srci = match self.scope {
            Scope::Subslot => api == API && slot == srci.slot && subslot == srci.subslot,
            Scope::Slot => api == API && slot == srci.slot,
            Scope::Api => api == API,
            Scope::Ar | Scope::Device => true,
        };
        if !(robot_error && self.faults && covers_srci) {
            return Vec::new();
        }
        diagnosis_data(srci, &robot_error_diagnosis())
    }
}

/// DiagnosisData (version 1.1) with the channel diagnosis `diagnosis` of `submodule`.
fn diagnosis_data(submodule: &SubmoduleModel, diagnosis: &Diagnosis) -> Vec<u8> {
    let maintenance = match diagnosis.severity {
        Severity::Fault => Maintenance::Fault,
        Severity::MaintenanceRequired => Maintenance::Required,
        Severity::MaintenanceDemanded => Maintenance::Demanded,
    };
    let direction = match diagnosis.direction {
        Direction::Input => 1,
        Direction::Output => 2,
        Direction::InputOutput => 3,
    };
    let properties = ChannelProperties {
        type_: 0,
        accumulative: false,
        maintenance,
        specifier: Specifier::Appears,
        direction,
    };
    let mut body = Vec::with_capacity(24);
    body.extend_from_slice(&API.to_be_bytes());
    body.extend_from_slice(&submodule.slot.to_be_bytes());
    body.extend_from_slice(&submodule.subslot.to_be_bytes());
    body.extend_from_slice(&WHOLE_SUBMODULE.to_be_bytes());
    body.extend_from_slice(&SUMMARY_APPEARS.to_be_bytes());
    body.extend_from_slice(&USI_CHANNEL_DIAG.to_be_bytes());
    body.extend_from_slice(&diagnosis.channel.to_be_bytes());
    body.extend_from_slice(&properties.to_u16().to_be_bytes());
    body.extend_from_slice(&diagnosis.error.code().to_be_bytes());
    let mut out = Vec::with_capacity(BlockHeader::LEN + body.len());
    out.extend_from_slice(&BLOCK_DIAGNOSIS_DATA.to_be_bytes());
    // The length counts the two version bytes; the body is 20 bytes.
    out.extend_from_slice(&(body.len() as u16 + 2).to_be_bytes());
    out.extend_from_slice(&[1, 1]);
    out.extend_from_slice(&body);
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::device::{DeviceModel, SRCI_SLOT, SRCI_SUBSLOT};
    use crate::rt::c_sdu::SrciModuleSize;

    fn srci() -> SubmoduleModel {
        *DeviceModel::srci(SrciModuleSize::Bytes256)
            .submodule(SRCI_SLOT, SRCI_SUBSLOT)
            .unwrap()
    }

    #[test]
    fn the_indices_name_their_scope_and_content() {
        let record = |scope, faults| Some(DiagnosisRecord { scope, faults });
        assert_eq!(DiagnosisRecord::at(0x800a), record(Scope::Subslot, true));
        assert_eq!(DiagnosisRecord::at(0x800c), record(Scope::Subslot, true));
        assert_eq!(DiagnosisRecord::at(0x8013), record(Scope::Subslot, false));
        assert_eq!(DiagnosisRecord::at(0xc00b), record(Scope::Slot, true));
        assert_eq!(DiagnosisRecord::at(0xe00a), record(Scope::Ar, true));
        assert_eq!(DiagnosisRecord::at(0xf00c), record(Scope::Api, true));
        assert_eq!(DiagnosisRecord::at(0xf80c), record(Scope::Device, true));
        for other in [0xaff0, 0xf000, 0xf841, 0x8071, 0x800d, 0x8014, 0xf80d] {
            assert_eq!(DiagnosisRecord::at(other), None, "{other:#06x}");
        }
    }

    #[test]
    fn a_robot_error_is_one_channel_diagnosis_of_the_srci_submodule() {
        let record = DiagnosisRecord::at(0x800a).unwrap();
        let data = record.data((0, SRCI_SLOT, SRCI_SUBSLOT), &srci(), true);
        #[rustfmt::skip]
        let expected = [
            0x00, 0x10, 0x00, 22, 1, 1,     // DiagnosisData, version 1.1
            0, 0, 0, 0, 0, 1, 0, 1,         // API 0, slot 1, subslot 1
            0x80, 0x00, 0x08, 0x00,         // summary channel, appears
            0x80, 0x00,                     // USI ChannelDiagnosis
            0x80, 0x00,                     // the whole submodule
            0x68, 0x00,                     // fault, appears, input and output
            0x00, 0x09,                     // ChannelErrorType: error
        ];
        assert_eq!(data, expected);
        // The same entry in every wider scope.
        for (index, address) in [
            (0xc00a, (0, SRCI_SLOT, 0)),
            (0xe00b, (0, 0, 0)),
            (0xf00c, (0, 0, 0)),
            (0xf80c, (0, 0, 0)),
        ] {
            let wider = DiagnosisRecord::at(index).unwrap();
            assert_eq!(wider.data(address, &srci(), true), expected, "{index:#06x}");
        }
    }

    #[test]
    fn without_an_error_or_outside_its_scope_the_record_is_empty() {
        let subslot = DiagnosisRecord::at(0x800a).unwrap();
        assert!(subslot.data((0, 1, 1), &srci(), false).is_empty());
        assert!(subslot.data((0, 0, 1), &srci(), true).is_empty());
        let slot = DiagnosisRecord::at(0xc00a).unwrap();
        assert!(slot.data((0, 0, 0), &srci(), true).is_empty());
        let api = DiagnosisRecord::at(0xf00a).unwrap();
        assert!(api.data((7, 0, 0), &srci(), true).is_empty());
        let maintenance = DiagnosisRecord::at(0x8010).unwrap();
        assert!(maintenance.data((0, 1, 1), &srci(), true).is_empty());
    }
}
