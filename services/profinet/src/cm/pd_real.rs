//! The physical-device records a controller and TIA Portal's topology view read:
//! PDInterfaceDataReal (index 0x8080 on the interface submodule), PDPortDataReal (0x802A
//! on the port submodule) and PDRealData (0xF841), which carries both, each behind a
//! MultipleBlockHeader that names its submodule.
//!
//! The port's link comes from the Linux interface ([`PortLink::from_sysfs`] takes the text
//! of `/sys/class/net/<if>/{speed,duplex,operstate}`; the shell reads the files). The
//! device runs no LLDP, so the port reports no peers. Fields follow IEC 61158-6-10: every
//! alignment is to four bytes from the start of the block.

use crate::dcp::station::IpParameter;
use crate::device::{API, DAP_SLOT, INTERFACE_SUBSLOT, PORT_SUBSLOT};
use crate::ethernet::MacAddress;

/// Index of PDPortDataReal (port submodule).
pub const INDEX_PD_PORT_DATA_REAL: u16 = 0x802a;
/// Index of PDInterfaceDataReal (interface submodule).
pub const INDEX_PD_INTERFACE_DATA_REAL: u16 = 0x8080;
/// Index of PDRealData (all physical-device submodules).
pub const INDEX_PD_REAL_DATA: u16 = 0xf841;

/// BlockType of PDPortDataReal.
const BLOCK_PD_PORT_DATA_REAL: u16 = 0x020f;
/// BlockType of PDInterfaceDataReal.
const BLOCK_PD_INTERFACE_DATA_REAL: u16 = 0x0240;
/// BlockType of MultipleBlockHeader.
const BLOCK_MULTIPLE_BLOCK_HEADER: u16 = 0x0400;
/// The OwnPortID of the only port (the GSDML names it "port-001" too).
pub const OWN_PORT_ID: &str = "port-001";
/// MediaType: copper cable (a veth reports none; the default is the usual cabling).
const MEDIA_TYPE_COPPER: u32 = 1;

/// MAUType (IETF RFC 4836 dot3MauType numbering, as PROFINET uses it).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MauType(pub u16);

impl MauType {
    /// 10BASE-T, half duplex.
    pub const BASE_T_10_HD: Self = Self(0x000a);
    /// 10BASE-T, full duplex.
    pub const BASE_T_10_FD: Self = Self(0x000b);
    /// 100BASE-TX, half duplex.
    pub const BASE_TX_100_HD: Self = Self(0x000f);
    /// 100BASE-TX, full duplex: what a port without a known speed reports (a veth has
    /// none a PROFINET MAUType names).
    pub const BASE_TX_100_FD: Self = Self(0x0010);
    /// 1000BASE-T, half duplex.
    pub const BASE_T_1000_HD: Self = Self(0x001d);
    /// 1000BASE-T, full duplex.
    pub const BASE_T_1000_FD: Self = Self(0x001e);

    /// The twisted-pair MAU of `speed_mbps` and duplex; other or unknown speeds report
    /// [`Self::BASE_TX_100_FD`], an unknown duplex counts as full.
    pub fn twisted_pair(speed_mbps: Option<u32>, full_duplex: Option<bool>) -> Self {
        let full = full_duplex.unwrap_or(true);
        match (speed_mbps, full) {
            (Some(10), false) => Self::BASE_T_10_HD,
            (Some(10), true) => Self::BASE_T_10_FD,
            (Some(100), false) => Self::BASE_TX_100_HD,
            (Some(1000), false) => Self::BASE_T_1000_HD,
            (Some(1000), true) => Self::BASE_T_1000_FD,
            _ => Self::BASE_TX_100_FD,
        }
    }
}

/// The port's Ethernet link as the interface reports it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PortLink {
    /// The MAU in use.
    pub mau_type: MauType,
    /// The link is up.
    pub up: bool,
}

impl Default for PortLink {
    /// Before the interface was read: the default MAU, link down.
    fn default() -> Self {
        Self {
            mau_type: MauType::BASE_TX_100_FD,
            up: false,
        }
    }
}

impl PortLink {
    /// The link from the text of the interface's sysfs files `speed` (Mbit/s; -1 or
    /// unreadable when unknown), `duplex` (`full`, `half`, `unknown`) and `operstate`
    /// (`up`, `down`, ...); a file that could not be read is given as "".
    pub fn from_sysfs(speed: &str, duplex: &str, operstate: &str) -> Self {
        let speed_mbps = speed.trim().parse::<u32>().ok();
        let full_duplex = match duplex.trim() {
            "full" => Some(true),
            "half" => Some(false),
            _ => None,
        };
        Self {
            mau_type: MauType::twisted_pair(speed_mbps, full_duplex),
            up: operstate.trim() == "up",
        }
    }

    /// LinkState: the Port byte 0 (unknown: the device has no bridge port states), the
    /// Link byte 1 up or 2 down.
    fn link_state(self) -> [u8; 2] {
        [0, if self.up { 1 } else { 2 }]
    }
}

/// What the interface submodule reports about itself.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct InterfaceReal<'a> {
    /// OwnChassisID: the NameOfStation.
    pub chassis_id: &'a str,
    /// The interface's MAC address.
    pub mac: MacAddress,
    /// IP address, subnet mask and gateway.
    pub ip: IpParameter,
}

/// PDInterfaceDataReal, version 1.0.
pub fn pd_interface_data_real(interface: &InterfaceReal<'_>) -> Vec<u8> {
    let mut out = Vec::with_capacity(64);
    begin_block(&mut out, BLOCK_PD_INTERFACE_DATA_REAL);
    let chassis_id = short_string(interface.chassis_id);
    out.push(chassis_id.len() as u8);
    out.extend_from_slice(chassis_id);
    align4(&mut out, 0);
    out.extend_from_slice(&interface.mac.0);
    align4(&mut out, 0);
    out.extend_from_slice(&interface.ip.to_wire());
    end_block(&mut out, 0);
    out
}

/// PDPortDataReal, version 1.0, of the port submodule: OwnPortID "port-001", no peers.
pub fn pd_port_data_real(link: PortLink) -> Vec<u8> {
    let mut out = Vec::with_capacity(48);
    begin_block(&mut out, BLOCK_PD_PORT_DATA_REAL);
    align4(&mut out, 0);
    out.extend_from_slice(&DAP_SLOT.to_be_bytes());
    out.extend_from_slice(&PORT_SUBSLOT.to_be_bytes());
    out.push(OWN_PORT_ID.len() as u8);
    out.extend_from_slice(OWN_PORT_ID.as_bytes());
    // NumberOfPeers: no LLDP, so no neighbour is known.
    out.push(0);
    align4(&mut out, 0);
    out.extend_from_slice(&link.mau_type.0.to_be_bytes());
    align4(&mut out, 0);
    // DomainBoundary and MulticastBoundary: nothing blocked.
    out.extend_from_slice(&[0; 8]);
    out.extend_from_slice(&link.link_state());
    align4(&mut out, 0);
    out.extend_from_slice(&MEDIA_TYPE_COPPER.to_be_bytes());
    end_block(&mut out, 0);
    out
}

/// PDRealData: the interface's and the port's blocks, each in a MultipleBlockHeader of
/// its submodule.
pub fn pd_real_data(interface: &InterfaceReal<'_>, link: PortLink) -> Vec<u8> {
    let mut out = Vec::with_capacity(160);
    for (subslot, block) in [
        (INTERFACE_SUBSLOT, pd_interface_data_real(interface)),
        (PORT_SUBSLOT, pd_port_data_real(link)),
    ] {
        let start = out.len();
        begin_block(&mut out, BLOCK_MULTIPLE_BLOCK_HEADER);
        out.extend_from_slice(&[0; 2]);
        out.extend_from_slice(&API.to_be_bytes());
        out.extend_from_slice(&DAP_SLOT.to_be_bytes());
        out.extend_from_slice(&subslot.to_be_bytes());
        out.extend_from_slice(&block);
        end_block(&mut out, start);
    }
    out
}

/// Writes a block header (its length filled in by [`end_block`]), version 1.0.
fn begin_block(out: &mut Vec<u8>, block_type: u16) {
    out.extend_from_slice(&block_type.to_be_bytes());
    out.extend_from_slice(&[0, 0, 1, 0]);
}

/// Sets the length of the block that starts at `start`: what follows the length field.
fn end_block(out: &mut [u8], start: usize) {
    // The blocks here are below 200 bytes.
    let length = u16::try_from(out.len() - start - 4).unwrap_or(u16::MAX);
    out[start + 2..start + 4].copy_from_slice(&length.to_be_bytes());
}

/// Pads with zeros to four bytes from `start`, the start of the block.
fn align4(out: &mut Vec<u8>, start: usize) {
    while !(out.len() - start).is_multiple_of(4) {
        out.push(0);
    }
}

/// At most the 255 bytes a one-byte length counts (a NameOfStation has at most 240).
fn short_string(text: &str) -> &[u8] {
    let bytes = text.as_bytes();
    &bytes[..bytes.len().min(255)]
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;
    use std::net::Ipv4Addr;

    fn interface() -> InterfaceReal<'static> {
        InterfaceReal {
            chassis_id: "rc-robot",
            mac: MacAddress([0x02, 0x00, 0x00, 0x00, 0x00, 0x01]),
            ip: IpParameter {
                address: Ipv4Addr::new(192, 168, 0, 50),
                subnet_mask: Ipv4Addr::new(255, 255, 255, 0),
                gateway: Ipv4Addr::new(192, 168, 0, 1),
            },
        }
    }

    #[rustfmt::skip]
    const INTERFACE_BLOCK: [u8; 36] = [
        0x02, 0x40, 0x00, 32, 1, 0,                 // PDInterfaceDataReal, version 1.0
        8, b'r', b'c', b'-', b'r', b'o', b'b', b'o', b't', // OwnChassisID
        0,                                          // padding to 16
        0x02, 0, 0, 0, 0, 0x01, 0, 0,               // MAC address, padding
        192, 168, 0, 50, 255, 255, 255, 0, 192, 168, 0, 1,
    ];

    #[rustfmt::skip]
    const PORT_BLOCK_UP: [u8; 44] = [
        0x02, 0x0f, 0x00, 40, 1, 0,                 // PDPortDataReal, version 1.0
        0, 0,                                       // padding
        0, 0, 0x80, 0x01,                           // slot 0, subslot 0x8001
        8, b'p', b'o', b'r', b't', b'-', b'0', b'0', b'1',
        0,                                          // NumberOfPeers
        0, 0,                                       // padding to 24
        0x00, 0x1e, 0, 0,                           // MAUType 1000BASE-T FD, padding
        0, 0, 0, 0, 0, 0, 0, 0,                     // Domain- and MulticastBoundary
        0x00, 0x01, 0, 0,                           // LinkState: port unknown, link up
        0, 0, 0, 1,                                 // MediaType copper
    ];

    #[test]
    fn pd_interface_data_real_names_the_station_and_its_addresses() {
        assert_eq!(pd_interface_data_real(&interface()), INTERFACE_BLOCK);
        // A name of a length that needs no padding before the MAC address.
        let mut aligned = interface();
        aligned.chassis_id = "abcdefghi";
        let block = pd_interface_data_real(&aligned);
        assert_eq!(block[6..16], *b"\x09abcdefghi");
        assert_eq!(block[16..22], aligned.mac.0);
        assert_eq!(block.len(), 36);
    }

    #[test]
    fn pd_port_data_real_reports_the_link_without_peers() {
        let up = PortLink {
            mau_type: MauType::BASE_T_1000_FD,
            up: true,
        };
        assert_eq!(pd_port_data_real(up), PORT_BLOCK_UP);
        let down = pd_port_data_real(PortLink::default());
        assert_eq!(down[24..26], [0x00, 0x10]);
        assert_eq!(down[36..38], [0x00, 0x02]);
    }

    #[test]
    fn pd_real_data_puts_each_block_behind_its_submodule_s_header() {
        let link = PortLink {
            mau_type: MauType::BASE_T_1000_FD,
            up: true,
        };
        let data = pd_real_data(&interface(), link);
        #[rustfmt::skip]
        let interface_header = [
            0x04, 0x00, 0x00, 48, 1, 0,             // MultipleBlockHeader, 12 + 36 bytes
            0, 0, 0, 0, 0, 0, 0, 0, 0x80, 0x00,     // padding, API 0, slot 0, subslot
        ];
        assert_eq!(data[..16], interface_header);
        assert_eq!(data[16..52], INTERFACE_BLOCK);
        #[rustfmt::skip]
        let port_header = [
            0x04, 0x00, 0x00, 56, 1, 0,
            0, 0, 0, 0, 0, 0, 0, 0, 0x80, 0x01,
        ];
        assert_eq!(data[52..68], port_header);
        assert_eq!(data[68..], PORT_BLOCK_UP);
    }

    #[test]
    fn the_sysfs_text_gives_the_mau_type_and_link() {
        let link = PortLink::from_sysfs("1000\n", "full\n", "up\n");
        assert_eq!(link.mau_type, MauType::BASE_T_1000_FD);
        assert!(link.up);
        let link = PortLink::from_sysfs("100\n", "half\n", "down\n");
        assert_eq!(link.mau_type, MauType::BASE_TX_100_HD);
        assert!(!link.up);
        // A veth says 10000 full; a link without a carrier -1 and unknown; a file
        // that could not be read is empty.
        for (speed, duplex) in [("10000\n", "full\n"), ("-1\n", "unknown\n"), ("", "")] {
            let link = PortLink::from_sysfs(speed, duplex, "lowerlayerdown\n");
            assert_eq!(link.mau_type, MauType::BASE_TX_100_FD, "{speed:?}");
            assert!(!link.up);
        }
        assert_eq!(MauType::twisted_pair(Some(10), None), MauType::BASE_T_10_FD);
        assert_eq!(
            MauType::twisted_pair(Some(10), Some(false)),
            MauType::BASE_T_10_HD
        );
    }

    proptest! {
        #[test]
        fn any_station_name_gives_an_aligned_block_with_the_mac_after_it(
            name in "[a-z0-9.-]{1,240}",
        ) {
            let mut named = interface();
            named.chassis_id = &name;
            let block = pd_interface_data_real(&named);
            let mac_at = (7 + name.len()).next_multiple_of(4);
            prop_assert_eq!(usize::from(u16::from_be_bytes([block[2], block[3]])), block.len() - 4);
            prop_assert_eq!(usize::from(block[6]), name.len());
            prop_assert_eq!(&block[7..7 + name.len()], name.as_bytes());
            prop_assert_eq!(&block[mac_at..mac_at + 6], &named.mac.0[..]);
            prop_assert_eq!(block.len(), mac_at + 8 + 12);
            let real_data = pd_real_data(&named, PortLink::default());
            prop_assert!(real_data.len().is_multiple_of(4));
            prop_assert_eq!(&real_data[16..16 + block.len()], &block[..]);
        }
    }
}
