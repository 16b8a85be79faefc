//! The comparison of the submodules a controller expects (ExpectedSubmoduleBlockReq) with
//! the device model: the content of the Connect response's ModuleDiffBlock.
//!
//! A mismatch does not refuse the AR: the controller gets the AR with the differences
//! reported and does not exchange data with the submodules concerned (its diagnosis shows
//! them), which tells an engineer far more than a refused Connect.

use pnio::cm::block::{DataDescription, ExpectedSubmoduleBlockReq};

use crate::device::DeviceModel;

/// How an expected submodule differs from the real one.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mismatch {
    /// No module in the slot.
    NoModule,
    /// Another module in the slot.
    WrongModule,
    /// The module has no submodule in the subslot.
    NoSubmodule,
    /// Another submodule in the subslot.
    WrongSubmodule,
    /// The submodule carries another number of data bytes (or none) in one direction.
    DataLength {
        /// True for the input direction (device → controller).
        input: bool,
        /// Bytes the controller expects (None: no data that way).
        expected: Option<u16>,
        /// Bytes the device has.
        real: u16,
    },
}

/// One expected submodule that differs from the device.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SubmoduleDiff {
    /// API.
    pub api: u32,
    /// Slot.
    pub slot: u16,
    /// Subslot.
    pub subslot: u16,
    /// ModuleIdentNumber of the real module in the slot (0: none).
    pub module_ident: u32,
    /// SubmoduleIdentNumber of the real submodule in the subslot (0: none).
    pub submodule_ident: u32,
    /// How it differs.
    pub mismatch: Mismatch,
}

/// ModuleState of a ModuleDiffBlock: NoModule.
const MODULE_STATE_NO_MODULE: u16 = 0;
/// ModuleState: WrongModule.
const MODULE_STATE_WRONG_MODULE: u16 = 1;
/// ModuleState: ProperModule.
const MODULE_STATE_PROPER_MODULE: u16 = 2;
/// SubmoduleState FormatIndicator: the detailed format (IdentInfo, ARInfo, ...).
const SUBMODULE_STATE_DETAILED: u16 = 0x8000;
/// SubmoduleState IdentInfo (bits 11..14): Wrong.
const IDENT_INFO_WRONG: u16 = 2 << 11;
/// SubmoduleState IdentInfo: NoSubmodule.
const IDENT_INFO_NO_SUBMODULE: u16 = 3 << 11;

impl SubmoduleDiff {
    /// The ModuleState of the slot this difference lies in.
    pub fn module_state(&self) -> u16 {
        match self.mismatch {
            Mismatch::NoModule => MODULE_STATE_NO_MODULE,
            Mismatch::WrongModule => MODULE_STATE_WRONG_MODULE,
            Mismatch::NoSubmodule | Mismatch::WrongSubmodule | Mismatch::DataLength { .. } => {
                MODULE_STATE_PROPER_MODULE
            }
        }
    }

    /// The SubmoduleState (detailed format, ARInfo "own") of the subslot. A data length
    /// that differs makes the submodule a wrong one: the controller cannot exchange it.
    pub fn submodule_state(&self) -> u16 {
        let ident_info = match self.mismatch {
            Mismatch::NoModule | Mismatch::NoSubmodule => IDENT_INFO_NO_SUBMODULE,
            Mismatch::WrongModule | Mismatch::WrongSubmodule | Mismatch::DataLength { .. } => {
                IDENT_INFO_WRONG
            }
        };
        SUBMODULE_STATE_DETAILED | ident_info
    }
}

/// The differences between what the controller expects and `model`, in request order;
/// empty when everything matches.
pub fn module_diff(
    expected: &[ExpectedSubmoduleBlockReq],
    model: &DeviceModel,
) -> Vec<SubmoduleDiff> {
    let mut diffs = Vec::new();
    for api in expected.iter().flat_map(|block| &block.apis) {
        let in_slot = || model.submodules().iter().filter(|s| s.slot == api.slot);
        for wanted in &api.submodules {
            let module = in_slot().next();
            let real = in_slot().find(|s| s.subslot == wanted.subslot);
            let diff = |mismatch| SubmoduleDiff {
                api: api.api,
                slot: api.slot,
                subslot: wanted.subslot,
                module_ident: module.map_or(0, |m| m.module_ident),
                submodule_ident: real.map_or(0, |s| s.submodule_ident),
                mismatch,
            };
            let Some(module) = module else {
                diffs.push(diff(Mismatch::NoModule));
                continue;
            };
            if module.module_ident != api.module_ident {
                diffs.push(diff(Mismatch::WrongModule));
                continue;
            }
            let Some(real) = real else {
                diffs.push(diff(Mismatch::NoSubmodule));
                continue;
            };
            if real.submodule_ident != wanted.submodule_ident {
                diffs.push(diff(Mismatch::WrongSubmodule));
                continue;
            }
            let directions = [
                (true, wanted.input, real.input_length),
                (false, wanted.output, real.output_length),
            ];
            if let Some((input, expected, real)) = directions
                .into_iter()
                .find(|(_, expected, real)| !length_matches(*expected, *real))
            {
                diffs.push(diff(Mismatch::DataLength {
                    input,
                    expected: expected.map(|d| d.data_length),
                    real,
                }));
            }
        }
    }
    diffs
}

/// A submodule without data one way has either no DataDescription for it or one of 0
/// bytes (the DAP's input description carries only its IOPS).
fn length_matches(expected: Option<DataDescription>, real: u16) -> bool {
    expected.map_or(0, |d| d.data_length) == real
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::cm::connect::ConnectRequest;
    use crate::device::{self, SubmoduleModel};
    use crate::rt::c_sdu::SrciModuleSize;
    use crate::testdata;
    use pnio::cm::block::{ExpectedApi, ExpectedSubmodule};

    fn description(data_length: u16) -> Option<DataDescription> {
        Some(DataDescription {
            data_length,
            length_iocs: 1,
            length_iops: 1,
        })
    }

    /// What TIA would send for a controller configured exactly like `model`.
    pub(crate) fn expected_for(model: &DeviceModel) -> Vec<ExpectedSubmoduleBlockReq> {
        let slot = |slot: u16| {
            let submodules: Vec<&SubmoduleModel> = model
                .submodules()
                .iter()
                .filter(|s| s.slot == slot)
                .collect();
            ExpectedSubmoduleBlockReq {
                apis: vec![ExpectedApi {
                    api: device::API,
                    slot,
                    module_ident: submodules[0].module_ident,
                    module_properties: 0,
                    submodules: submodules
                        .iter()
                        .map(|s| ExpectedSubmodule {
                            subslot: s.subslot,
                            submodule_ident: s.submodule_ident,
                            properties: if s.output_length > 0 { 3 } else { 0 },
                            input: description(s.input_length),
                            output: (s.output_length > 0)
                                .then(|| description(s.output_length))
                                .flatten(),
                        })
                        .collect(),
                }],
            }
        };
        vec![slot(device::DAP_SLOT), slot(device::SRCI_SLOT)]
    }

    #[test]
    fn a_controller_configured_like_the_device_sees_no_difference() {
        for size in [
            SrciModuleSize::Bytes64,
            SrciModuleSize::Bytes128,
            SrciModuleSize::Bytes256,
        ] {
            let model = DeviceModel::srci(size);
            assert_eq!(module_diff(&expected_for(&model), &model), []);
        }
    }

    #[test]
    fn another_srci_size_is_a_wrong_module() {
        let configured = DeviceModel::srci(SrciModuleSize::Bytes128);
        let real = DeviceModel::srci(SrciModuleSize::Bytes256);
        assert_eq!(
            module_diff(&expected_for(&configured), &real),
            [SubmoduleDiff {
                api: 0,
                slot: 1,
                subslot: 1,
                module_ident: 0x0001_0100,
                submodule_ident: 0x0001_0100,
                mismatch: Mismatch::WrongModule
            }]
        );
    }

    #[test]
    fn wrong_submodules_and_lengths_are_reported() {
        let model = DeviceModel::srci(SrciModuleSize::Bytes256);
        let mut expected = expected_for(&model);
        let srci = &mut expected[1].apis[0].submodules[0];
        srci.output = description(200);
        let port = &mut expected[0].apis[0].submodules[2];
        port.submodule_ident = 0x8002;
        expected[0].apis[0].submodules.push(ExpectedSubmodule {
            subslot: 0x8002,
            submodule_ident: 0x8002,
            properties: 0,
            input: description(0),
            output: None,
        });
        let mismatches: Vec<Mismatch> = module_diff(&expected, &model)
            .iter()
            .map(|d| d.mismatch)
            .collect();
        assert_eq!(
            mismatches,
            [
                Mismatch::WrongSubmodule,
                Mismatch::NoSubmodule,
                Mismatch::DataLength {
                    input: false,
                    expected: Some(200),
                    real: 256
                },
            ]
        );
    }

    #[test]
    fn the_golden_s7_connect_of_p_net_s_modules_differs_in_every_io_slot() {
        let pdu = testdata::frame("connect_req")[42..].to_vec();
        let connect = ConnectRequest::parse(&pdu).unwrap();
        let model = DeviceModel::srci(SrciModuleSize::Bytes256);
        let diffs = module_diff(&connect.expected, &model);
        // The DAP matches (p-net uses the same DAP idents); slot 1 holds another module,
        // slots 2..4 hold none here.
        let summary: Vec<(u16, Mismatch)> = diffs.iter().map(|d| (d.slot, d.mismatch)).collect();
        assert_eq!(
            summary,
            [
                (1, Mismatch::WrongModule),
                (2, Mismatch::NoModule),
                (3, Mismatch::NoModule),
                (4, Mismatch::NoModule),
            ]
        );
    }
}
