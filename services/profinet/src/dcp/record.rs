//! The text form of the permanent station parameters, as the shell stores them.
//!
//! ```text
//! name_of_station = rc-robot
//! ip = 192.168.0.50
//! subnet_mask = 255.255.255.0
//! gateway = 0.0.0.0
//! ```
//!
//! Every key is required; unknown keys are refused so that a damaged file is noticed.

use std::fmt::Write as _;
use std::net::Ipv4Addr;

use super::station::{
    IpParameter, IpParameterError, NameOfStation, NameOfStationError, StationParameters,
};

/// A stored record that cannot be read back.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum PermanentRecordError {
    /// A line is not `key = value`.
    #[error("line {0}: expected `key = value`")]
    Syntax(usize),
    /// A key this record does not have.
    #[error("line {line}: unknown key `{key}`")]
    UnknownKey {
        /// Line number (from 1).
        line: usize,
        /// The key.
        key: String,
    },
    /// A required key is missing.
    #[error("missing key `{0}`")]
    Missing(&'static str),
    /// An address is not a dotted IPv4 address.
    #[error("line {line}: `{value}` is not an IPv4 address")]
    Address {
        /// Line number (from 1).
        line: usize,
        /// The value.
        value: String,
    },
    /// The stored name breaks the NameOfStation rules.
    #[error(transparent)]
    Name(#[from] NameOfStationError),
    /// The stored IP parameter is invalid.
    #[error(transparent)]
    Ip(#[from] IpParameterError),
}

/// The record of `parameters`.
pub fn encode(parameters: &StationParameters) -> String {
    let mut text = String::new();
    let ip = parameters.ip;
    // Writing to a String cannot fail.
    let _ = write!(
        text,
        "name_of_station = {}\nip = {}\nsubnet_mask = {}\ngateway = {}\n",
        parameters.name_of_station.as_str(),
        ip.address,
        ip.subnet_mask,
        ip.gateway
    );
    text
}

/// The `key = value` lines of a text record, trimmed, with their line numbers (from 1);
/// blank lines are skipped, any other line is `Err(its line number)`. The I&M records
/// are stored in the same form ([`crate::cm::im`]).
pub fn key_values(text: &str) -> impl Iterator<Item = Result<(usize, &str, &str), usize>> {
    text.lines()
        .enumerate()
        .filter(|(_, raw)| !raw.trim().is_empty())
        .map(|(index, raw)| {
            raw.split_once('=')
                .map(|(key, value)| (index + 1, key.trim(), value.trim()))
                .ok_or(index + 1)
        })
}

/// Reads a record written by [`encode`].
pub fn decode(text: &str) -> Result<StationParameters, PermanentRecordError> {
    let mut name = None;
    let mut addresses: [Option<Ipv4Addr>; 3] = [None; 3];
    for entry in key_values(text) {
        let (line, key, value) = entry.map_err(PermanentRecordError::Syntax)?;
        let slot = match key {
            "name_of_station" => {
                name = Some(NameOfStation::new(value.as_bytes())?);
                continue;
            }
            "ip" => 0,
            "subnet_mask" => 1,
            "gateway" => 2,
            other => {
                return Err(PermanentRecordError::UnknownKey {
                    line,
                    key: other.to_owned(),
                });
            }
        };
        let address = value.parse().map_err(|_| PermanentRecordError::Address {
            line,
            value: value.to_owned(),
        })?;
        addresses[slot] = Some(address);
    }
    let [address, subnet_mask, gateway] = addresses;
    let ip = IpParameter {
        address: address.ok_or(PermanentRecordError::Missing("ip"))?,
        subnet_mask: subnet_mask.ok_or(PermanentRecordError::Missing("subnet_mask"))?,
        gateway: gateway.ok_or(PermanentRecordError::Missing("gateway"))?,
    }
    .validate()?;
    Ok(StationParameters {
        name_of_station: name.ok_or(PermanentRecordError::Missing("name_of_station"))?,
        ip,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parameters() -> StationParameters {
        StationParameters {
            name_of_station: NameOfStation::new(b"rc-robot").unwrap(),
            ip: IpParameter {
                address: Ipv4Addr::new(192, 168, 0, 50),
                subnet_mask: Ipv4Addr::new(255, 255, 255, 0),
                gateway: Ipv4Addr::UNSPECIFIED,
            },
        }
    }

    #[test]
    fn a_record_reads_back() {
        let text = encode(&parameters());
        assert_eq!(
            text,
            "name_of_station = rc-robot\nip = 192.168.0.50\nsubnet_mask = 255.255.255.0\ngateway = 0.0.0.0\n"
        );
        assert_eq!(decode(&text), Ok(parameters()));
    }

    #[test]
    fn an_empty_name_reads_back() {
        let mut unnamed = parameters();
        unnamed.name_of_station = NameOfStation::default();
        assert_eq!(decode(&encode(&unnamed)), Ok(unnamed));
    }

    #[test]
    fn damaged_records_are_refused() {
        let good = encode(&parameters());
        assert_eq!(
            decode(&good.replace("ip = 192.168.0.50\n", "")),
            Err(PermanentRecordError::Missing("ip"))
        );
        assert_eq!(
            decode(&format!("{good}colour = red\n")),
            Err(PermanentRecordError::UnknownKey {
                line: 5,
                key: "colour".into()
            })
        );
        assert_eq!(
            decode(&good.replace("gateway = 0.0.0.0", "gateway")),
            Err(PermanentRecordError::Syntax(4))
        );
        assert!(matches!(
            decode(&good.replace("192.168.0.50", "192.168.0")),
            Err(PermanentRecordError::Address { line: 2, .. })
        ));
        assert!(matches!(
            decode(&good.replace("rc-robot", "RC")),
            Err(PermanentRecordError::Name(_))
        ));
        assert!(matches!(
            decode(&good.replace("255.255.255.0", "255.0.255.0")),
            Err(PermanentRecordError::Ip(_))
        ));
    }
}
