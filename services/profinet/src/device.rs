//! The device model: what is plugged where, with which ident numbers and data lengths.
//!
//! Slot 0 holds the device access point (DAP, subslot 1) with its interface (0x8000) and
//! port (0x8001) submodules, none of which carry IO data. Slot 1 holds the SRCI module:
//! one submodule with the same data length both ways, PLC→robot as output and robot→PLC
//! as input, in one of three sizes. The ident numbers are this device's own (the GSDML
//! must carry the same); the SRCI module's encode its data length.

use crate::rt::c_sdu::SrciModuleSize;

/// VendorID: 0xFFFF, which PI leaves for development, until PI assigns this product one.
pub const VENDOR_ID: u16 = 0xffff;
/// DeviceID of the robot controller (the GSDML's DeviceIdentity).
pub const DEVICE_ID: u16 = 0x0001;
/// TypeOfStation (DCP DeviceVendorValue) and the GSDML's device name.
pub const TYPE_OF_STATION: &str = "rc SRCI robot controller";

/// The application process all submodules belong to.
pub const API: u32 = 0;
/// Slot of the device access point.
pub const DAP_SLOT: u16 = 0;
/// Subslot of the DAP submodule.
pub const DAP_SUBSLOT: u16 = 0x0001;
/// Subslot of the interface submodule.
pub const INTERFACE_SUBSLOT: u16 = 0x8000;
/// Subslot of the (only) port submodule.
pub const PORT_SUBSLOT: u16 = 0x8001;
/// Slot of the SRCI module.
pub const SRCI_SLOT: u16 = 1;
/// Subslot of the SRCI submodule.
pub const SRCI_SUBSLOT: u16 = 1;
/// ModuleIdentNumber of the DAP.
pub const DAP_MODULE_IDENT: u32 = 0x0000_0001;
/// SubmoduleIdentNumber of the DAP submodule.
pub const DAP_SUBMODULE_IDENT: u32 = 0x0000_0001;
/// SubmoduleIdentNumber of the interface submodule.
pub const INTERFACE_SUBMODULE_IDENT: u32 = 0x0000_8000;
/// SubmoduleIdentNumber of the port submodule.
pub const PORT_SUBMODULE_IDENT: u32 = 0x0000_8001;
/// Base of the SRCI module's and submodule's ident numbers; the data length is added.
const SRCI_IDENT_BASE: u32 = 0x0001_0000;

/// One submodule of the device.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SubmoduleModel {
    /// Slot.
    pub slot: u16,
    /// Subslot.
    pub subslot: u16,
    /// ModuleIdentNumber of the module in the slot.
    pub module_ident: u32,
    /// SubmoduleIdentNumber.
    pub submodule_ident: u32,
    /// Input data bytes (device → controller).
    pub input_length: u16,
    /// Output data bytes (controller → device).
    pub output_length: u16,
}

/// The submodules of the device.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct DeviceModel {
    submodules: [SubmoduleModel; 4],
}

impl DeviceModel {
    /// DAP, interface, port and the SRCI module of `size`.
    pub fn srci(size: SrciModuleSize) -> Self {
        let dap = |subslot, submodule_ident| SubmoduleModel {
            slot: DAP_SLOT,
            subslot,
            module_ident: DAP_MODULE_IDENT,
            submodule_ident,
            input_length: 0,
            output_length: 0,
        };
        let length = size.data_length();
        let srci_ident = SRCI_IDENT_BASE + u32::from(length);
        Self {
            submodules: [
                dap(DAP_SUBSLOT, DAP_SUBMODULE_IDENT),
                dap(INTERFACE_SUBSLOT, INTERFACE_SUBMODULE_IDENT),
                dap(PORT_SUBSLOT, PORT_SUBMODULE_IDENT),
                SubmoduleModel {
                    slot: SRCI_SLOT,
                    subslot: SRCI_SUBSLOT,
                    module_ident: srci_ident,
                    submodule_ident: srci_ident,
                    input_length: length,
                    output_length: length,
                },
            ],
        }
    }

    /// All submodules, DAP first.
    pub fn submodules(&self) -> &[SubmoduleModel] {
        &self.submodules
    }

    /// The submodule in `slot`/`subslot`, if one is plugged there.
    pub fn submodule(&self, slot: u16, subslot: u16) -> Option<&SubmoduleModel> {
        self.submodules
            .iter()
            .find(|s| s.slot == slot && s.subslot == subslot)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_srci_module_has_its_size_both_ways_and_in_its_ident() {
        for (size, length, ident) in [
            (SrciModuleSize::Bytes64, 64, 0x0001_0040),
            (SrciModuleSize::Bytes128, 128, 0x0001_0080),
            (SrciModuleSize::Bytes256, 256, 0x0001_0100),
        ] {
            let model = DeviceModel::srci(size);
            let srci = model.submodule(SRCI_SLOT, SRCI_SUBSLOT).unwrap();
            assert_eq!((srci.input_length, srci.output_length), (length, length));
            assert_eq!((srci.module_ident, srci.submodule_ident), (ident, ident));
        }
    }

    #[test]
    fn the_dap_interface_and_port_carry_no_data() {
        let model = DeviceModel::srci(SrciModuleSize::Bytes256);
        assert_eq!(model.submodules().len(), 4);
        for subslot in [DAP_SUBSLOT, INTERFACE_SUBSLOT, PORT_SUBSLOT] {
            let submodule = model.submodule(DAP_SLOT, subslot).unwrap();
            assert_eq!(submodule.module_ident, DAP_MODULE_IDENT);
            assert_eq!((submodule.input_length, submodule.output_length), (0, 0));
        }
        assert_eq!(model.submodule(DAP_SLOT, 0x8002), None);
        assert_eq!(model.submodule(2, 1), None);
    }
}
