//! What DCP reads and writes: the station's identity, NameOfStation and IP parameter.

use std::net::Ipv4Addr;

use crate::ethernet::MacAddress;

/// Longest NameOfStation.
pub const MAX_NAME_LEN: usize = 240;
/// Longest label of a NameOfStation.
const MAX_LABEL_LEN: usize = 63;

/// A NameOfStation that does not follow the DNS-compatible rules.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum NameOfStationError {
    /// Longer than 240 bytes.
    #[error("NameOfStation is {0} bytes long (at most {MAX_NAME_LEN})")]
    TooLong(usize),
    /// A label is empty or longer than 63 bytes.
    #[error("NameOfStation has a label of {0} bytes (1..=63 allowed)")]
    LabelLength(usize),
    /// A byte other than a-z, 0-9, '-' and '.'.
    #[error("NameOfStation contains {0:#04x} (allowed: a-z 0-9 - .)")]
    Character(u8),
    /// A label begins or ends with '-'.
    #[error("a label of a NameOfStation begins or ends with '-'")]
    Hyphen,
    /// The first label begins with "xn-" (reserved for IDNA).
    #[error("NameOfStation begins with \"xn-\"")]
    Idna,
    /// The name has the form of a port name ("port-xyz" or "port-xyz-abcde").
    #[error("NameOfStation has the form of a port name")]
    PortName,
    /// The name has the form of an IPv4 address.
    #[error("NameOfStation has the form of an IP address")]
    IpAddress,
}

/// A valid NameOfStation (possibly empty: a device with no name).
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct NameOfStation(String);

impl NameOfStation {
    /// Checks `bytes` against the rules of IEC 61158-6-10 for station names.
    pub fn new(bytes: &[u8]) -> Result<Self, NameOfStationError> {
        if bytes.len() > MAX_NAME_LEN {
            return Err(NameOfStationError::TooLong(bytes.len()));
        }
        if let Some(&bad) = bytes
            .iter()
            .find(|&&b| !(b.is_ascii_lowercase() || b.is_ascii_digit() || b == b'-' || b == b'.'))
        {
            return Err(NameOfStationError::Character(bad));
        }
        if !bytes.is_empty() {
            for label in bytes.split(|&b| b == b'.') {
                if label.is_empty() || label.len() > MAX_LABEL_LEN {
                    return Err(NameOfStationError::LabelLength(label.len()));
                }
                if label.first() == Some(&b'-') || label.last() == Some(&b'-') {
                    return Err(NameOfStationError::Hyphen);
                }
            }
            if bytes.starts_with(b"xn-") {
                return Err(NameOfStationError::Idna);
            }
            if is_port_name(bytes) {
                return Err(NameOfStationError::PortName);
            }
            if is_ip_address(bytes) {
                return Err(NameOfStationError::IpAddress);
            }
        }
        // Only ASCII passed the character check.
        Ok(Self(bytes.iter().map(|&b| char::from(b)).collect()))
    }

    /// The name.
    pub fn as_str(&self) -> &str {
        &self.0
    }

    /// True for a device without a name.
    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }
}

/// "port-xyz" or "port-xyz-abcde" with digits x..e.
fn is_port_name(name: &[u8]) -> bool {
    let digits = |part: &[u8], n: usize| part.len() == n && part.iter().all(u8::is_ascii_digit);
    match name.strip_prefix(b"port-") {
        Some(rest) if rest.len() == 3 => digits(rest, 3),
        Some(rest) if rest.len() == 9 => {
            digits(&rest[..3], 3) && rest[3] == b'-' && digits(&rest[4..], 5)
        }
        _ => false,
    }
}

/// Four dot-separated decimal numbers.
fn is_ip_address(name: &[u8]) -> bool {
    let mut labels = name.split(|&b| b == b'.');
    labels.clone().count() == 4
        && labels.all(|label| !label.is_empty() && label.iter().all(u8::is_ascii_digit))
}

/// The IP parameter of the station: address, subnet mask and default gateway.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct IpParameter {
    /// IPv4 address; 0.0.0.0 when none is set.
    pub address: Ipv4Addr,
    /// Subnet mask.
    pub subnet_mask: Ipv4Addr,
    /// Default gateway; 0.0.0.0 for none.
    pub gateway: Ipv4Addr,
}

/// An IP parameter a device must refuse.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum IpParameterError {
    /// The mask's ones are not contiguous.
    #[error("subnet mask {0} is not contiguous")]
    SubnetMask(Ipv4Addr),
    /// The address is a multicast, broadcast or loopback address.
    #[error("{0} cannot be a station address")]
    Address(Ipv4Addr),
    /// The gateway lies outside the station's subnet.
    #[error("gateway {gateway} is outside the subnet of {address}/{mask}")]
    Gateway {
        /// Station address.
        address: Ipv4Addr,
        /// Subnet mask.
        mask: Ipv4Addr,
        /// Gateway.
        gateway: Ipv4Addr,
    },
}

impl IpParameter {
    /// No address: what a factory-new device has.
    pub const UNSET: IpParameter = IpParameter {
        address: Ipv4Addr::UNSPECIFIED,
        subnet_mask: Ipv4Addr::UNSPECIFIED,
        gateway: Ipv4Addr::UNSPECIFIED,
    };

    /// Decodes the 12 bytes of an IP parameter block and checks them.
    pub fn from_wire(value: &[u8]) -> Result<Option<Self>, IpParameterError> {
        let Ok(bytes) = <[u8; 12]>::try_from(value) else {
            return Ok(None);
        };
        let quad =
            |at: usize| Ipv4Addr::new(bytes[at], bytes[at + 1], bytes[at + 2], bytes[at + 3]);
        let parameter = Self {
            address: quad(0),
            subnet_mask: quad(4),
            gateway: quad(8),
        };
        parameter.validate().map(Some)
    }

    /// The 12 bytes on the wire.
    pub fn to_wire(self) -> [u8; 12] {
        let mut out = [0; 12];
        out[0..4].copy_from_slice(&self.address.octets());
        out[4..8].copy_from_slice(&self.subnet_mask.octets());
        out[8..12].copy_from_slice(&self.gateway.octets());
        out
    }

    /// True when an address is set.
    pub fn is_set(&self) -> bool {
        !self.address.is_unspecified()
    }

    /// The default router, if the station has one: a gateway of 0.0.0.0, or equal to the
    /// station's own address (what an S7 sends when the project uses no router, as in the
    /// golden Set IP), means none.
    pub fn router(&self) -> Option<Ipv4Addr> {
        (!self.gateway.is_unspecified() && self.gateway != self.address).then_some(self.gateway)
    }

    /// Checks the parameter; all zeros (delete the address) is valid.
    pub fn validate(self) -> Result<Self, IpParameterError> {
        if self == Self::UNSET {
            return Ok(self);
        }
        let mask = u32::from(self.subnet_mask);
        if mask.leading_ones() + mask.trailing_zeros() != 32 {
            return Err(IpParameterError::SubnetMask(self.subnet_mask));
        }
        let address = self.address;
        if address.is_multicast() || address.is_broadcast() || address.is_loopback() {
            return Err(IpParameterError::Address(address));
        }
        let gateway = u32::from(self.gateway);
        if gateway != 0 && gateway & mask != u32::from(address) & mask {
            return Err(IpParameterError::Gateway {
                address,
                mask: self.subnet_mask,
                gateway: self.gateway,
            });
        }
        Ok(self)
    }
}

/// The parameters DCP can set: they are temporary or permanent.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct StationParameters {
    /// NameOfStation.
    pub name_of_station: NameOfStation,
    /// IP parameter.
    pub ip: IpParameter,
}

/// The fixed identity of the device, as Identify and Get report it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct DeviceIdentity {
    /// MAC address of the interface.
    pub mac: MacAddress,
    /// VendorID assigned by PI (0xFFFF is for development).
    pub vendor_id: u16,
    /// DeviceID chosen by the vendor.
    pub device_id: u16,
    /// DeviceInstance (high byte, low byte).
    pub device_instance: u16,
    /// TypeOfStation (DeviceVendorValue), e.g. the product name.
    pub type_of_station: String,
}

/// Where the permanent station parameters live across restarts; the shell implements it
/// (a file), tests use memory.
pub trait PermanentStore {
    /// Reading or writing the store failed.
    type Error: std::error::Error + Send + Sync + 'static;

    /// The parameters stored last, or `None` when nothing is stored.
    fn load(&mut self) -> Result<Option<StationParameters>, Self::Error>;

    /// Stores `parameters`, replacing what was stored.
    fn save(&mut self, parameters: &StationParameters) -> Result<(), Self::Error>;

    /// Forgets the stored parameters (reset to factory).
    fn erase(&mut self) -> Result<(), Self::Error>;
}

/// Where the station's IP parameter takes effect: the shell configures the network
/// interface (see `crate::link::address`), tests record what they were asked.
pub trait IpInterface {
    /// Configuring the interface failed.
    type Error: std::error::Error + Send + Sync + 'static;

    /// Gives the interface `ip` as its only IPv4 address (and the default route via its
    /// router, [`IpParameter::router`], when it has one); [`IpParameter::UNSET`] removes
    /// the address.
    fn apply(&mut self, ip: &IpParameter) -> Result<(), Self::Error>;
}

/// A store that keeps the parameters in memory only: for tests, and for a device that
/// must not persist anything.
#[derive(Debug, Clone, Default)]
pub struct MemoryStore {
    /// What is stored.
    pub stored: Option<StationParameters>,
}

impl PermanentStore for MemoryStore {
    type Error = std::convert::Infallible;

    fn load(&mut self) -> Result<Option<StationParameters>, Self::Error> {
        Ok(self.stored.clone())
    }

    fn save(&mut self, parameters: &StationParameters) -> Result<(), Self::Error> {
        self.stored = Some(parameters.clone());
        Ok(())
    }

    fn erase(&mut self) -> Result<(), Self::Error> {
        self.stored = None;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn valid_names_are_accepted() {
        for name in [
            "",
            "rc-robot",
            "rt-labs-dev",
            "cell1.robot-2",
            "port-12",
            "a",
        ] {
            assert_eq!(NameOfStation::new(name.as_bytes()).unwrap().as_str(), name);
        }
    }

    #[test]
    fn invalid_names_are_refused_with_the_rule_they_break() {
        use NameOfStationError::*;
        let cases: [(&[u8], NameOfStationError); 10] = [
            (b"Robot", Character(b'R')),
            (b"rob ot", Character(b' ')),
            (b"robot.", LabelLength(0)),
            (b".robot", LabelLength(0)),
            (b"-robot", Hyphen),
            (b"robot-", Hyphen),
            (b"xn-robot", Idna),
            (b"port-001", PortName),
            (b"port-001-00002", PortName),
            (b"192.168.0.1", IpAddress),
        ];
        for (name, error) in cases {
            assert_eq!(NameOfStation::new(name), Err(error), "{name:?}");
        }
        assert_eq!(NameOfStation::new(&[b'a'; 241]), Err(TooLong(241)));
        assert_eq!(NameOfStation::new(&[b'a'; 64]), Err(LabelLength(64)));
    }

    #[test]
    fn ip_parameters_are_checked() {
        let wire = |a: [u8; 4], m: [u8; 4], g: [u8; 4]| {
            let mut v = Vec::new();
            v.extend_from_slice(&a);
            v.extend_from_slice(&m);
            v.extend_from_slice(&g);
            IpParameter::from_wire(&v)
        };
        let ok = wire([172, 16, 2, 10], [255, 255, 255, 0], [172, 16, 2, 1])
            .unwrap()
            .unwrap();
        assert_eq!(ok.address, Ipv4Addr::new(172, 16, 2, 10));
        assert!(ok.is_set());
        assert_eq!(IpParameter::from_wire(&ok.to_wire()), Ok(Some(ok)));
        assert_eq!(wire([0; 4], [0; 4], [0; 4]), Ok(Some(IpParameter::UNSET)));
        assert!(matches!(
            wire([172, 16, 2, 10], [255, 0, 255, 0], [0; 4]),
            Err(IpParameterError::SubnetMask(_))
        ));
        assert!(matches!(
            wire([224, 0, 0, 1], [255, 0, 0, 0], [0; 4]),
            Err(IpParameterError::Address(_))
        ));
        assert!(matches!(
            wire([172, 16, 2, 10], [255, 255, 255, 0], [172, 16, 3, 1]),
            Err(IpParameterError::Gateway { .. })
        ));
        assert_eq!(IpParameter::from_wire(&[0; 11]), Ok(None));
        assert_eq!(ok.router(), Some(Ipv4Addr::new(172, 16, 2, 1)));
        let own = wire([172, 16, 2, 10], [255, 255, 255, 0], [172, 16, 2, 10]);
        assert_eq!(own.unwrap().unwrap().router(), None);
        assert_eq!(IpParameter::UNSET.router(), None);
    }

    proptest! {
        #[test]
        fn accepted_names_contain_only_allowed_bytes(bytes in proptest::collection::vec(any::<u8>(), 0..20)) {
            if let Ok(name) = NameOfStation::new(&bytes) {
                prop_assert_eq!(name.as_str().as_bytes(), &bytes[..]);
                prop_assert!(bytes.iter().all(|b| b.is_ascii_lowercase() || b.is_ascii_digit() || *b == b'-' || *b == b'.'));
            }
        }
    }
}
