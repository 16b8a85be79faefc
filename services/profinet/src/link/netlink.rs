//! The rtnetlink messages that configure an interface's IPv4 address and default route:
//! built and parsed here without I/O, sent by [`super::address`].
//!
//! A message is `nlmsghdr` (16 bytes), a family header (`ifaddrmsg`, 8 bytes, or `rtmsg`,
//! 12 bytes) and attributes (`rtattr`: length, type, value padded to 4 bytes), all in the
//! host's byte order but the addresses, which are in network order.

use std::net::Ipv4Addr;

/// Length of `nlmsghdr`.
const HEADER_LEN: usize = 16;
/// Length of `ifaddrmsg`.
const IFADDRMSG_LEN: usize = 8;
/// Length of `rtmsg`.
const RTMSG_LEN: usize = 12;
/// Length of an `rtattr` header.
const ATTRIBUTE_HEADER_LEN: usize = 4;
/// Length of an `nlmsgerr` (error code and the request's header).
const ERROR_LEN: usize = 4 + HEADER_LEN;

/// Message types (linux/rtnetlink.h, linux/netlink.h).
const RTM_NEWADDR: u16 = 20;
const RTM_DELADDR: u16 = 21;
const RTM_GETADDR: u16 = 22;
const RTM_NEWROUTE: u16 = 24;
const NLMSG_ERROR: u16 = 2;
const NLMSG_DONE: u16 = 3;

/// Header flags.
const NLM_F_REQUEST: u16 = 0x001;
const NLM_F_ACK: u16 = 0x004;
const NLM_F_REPLACE: u16 = 0x100;
const NLM_F_DUMP: u16 = 0x300;
const NLM_F_CREATE: u16 = 0x400;

/// Attributes of an address and of a route.
const IFA_ADDRESS: u16 = 1;
const IFA_LOCAL: u16 = 2;
const IFA_BROADCAST: u16 = 4;
const RTA_OIF: u16 = 4;
const RTA_GATEWAY: u16 = 5;

/// `AF_INET`, as netlink carries it.
const FAMILY_INET: u8 = 2;
/// The main routing table, a static route, global scope, a unicast route.
const RT_TABLE_MAIN: u8 = 254;
const RTPROT_STATIC: u8 = 4;
const RT_SCOPE_UNIVERSE: u8 = 0;
const RTN_UNICAST: u8 = 1;

/// An IPv4 address of an interface with its prefix length.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct InterfaceAddress {
    /// The address.
    pub address: Ipv4Addr,
    /// The prefix length (the subnet mask's ones).
    pub prefix_len: u8,
}

impl InterfaceAddress {
    /// The address `address` in the subnet of `mask` (a contiguous mask).
    pub fn new(address: Ipv4Addr, mask: Ipv4Addr) -> Self {
        let ones = u32::from(mask).leading_ones();
        Self {
            address,
            prefix_len: u8::try_from(ones).unwrap_or(32),
        }
    }

    /// The subnet's broadcast address.
    fn broadcast(self) -> Ipv4Addr {
        let host_bits = u32::MAX
            .checked_shr(u32::from(self.prefix_len))
            .unwrap_or(0);
        Ipv4Addr::from(u32::from(self.address) | host_bits)
    }
}

/// What the kernel answered to one request.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Reply {
    /// The acknowledgement of request `seq`: 0, or a negative errno.
    Ack {
        /// The request's sequence number.
        seq: u32,
        /// 0 for success, `-errno` for a failure.
        error: i32,
    },
    /// IPv4 addresses of a dump (of every interface: filter by index).
    Addresses(Vec<(u32, InterfaceAddress)>),
    /// The end of a dump.
    Done,
}

/// A datagram from the kernel that is not a well-formed netlink message.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("malformed rtnetlink message at byte {0}")]
pub struct MalformedReply(pub usize);

/// RTM_GETADDR: a dump of the IPv4 addresses.
pub fn dump_addresses(seq: u32) -> Vec<u8> {
    let mut message = header(RTM_GETADDR, NLM_F_REQUEST | NLM_F_DUMP, seq);
    message.extend_from_slice(&ifaddrmsg(0, 0));
    finish(message)
}

/// RTM_NEWADDR (create or replace): `address` on the interface `index`.
pub fn add_address(seq: u32, index: u32, address: InterfaceAddress) -> Vec<u8> {
    let flags = NLM_F_REQUEST | NLM_F_ACK | NLM_F_CREATE | NLM_F_REPLACE;
    let mut message = header(RTM_NEWADDR, flags, seq);
    message.extend_from_slice(&ifaddrmsg(address.prefix_len, index));
    attribute(&mut message, IFA_LOCAL, &address.address.octets());
    attribute(&mut message, IFA_ADDRESS, &address.address.octets());
    attribute(&mut message, IFA_BROADCAST, &address.broadcast().octets());
    finish(message)
}

/// RTM_DELADDR: remove `address` from the interface `index`.
pub fn delete_address(seq: u32, index: u32, address: InterfaceAddress) -> Vec<u8> {
    let mut message = header(RTM_DELADDR, NLM_F_REQUEST | NLM_F_ACK, seq);
    message.extend_from_slice(&ifaddrmsg(address.prefix_len, index));
    attribute(&mut message, IFA_LOCAL, &address.address.octets());
    attribute(&mut message, IFA_ADDRESS, &address.address.octets());
    finish(message)
}

/// RTM_NEWROUTE (create or replace): the default route via `gateway` on the interface
/// `index`.
pub fn default_route(seq: u32, index: u32, gateway: Ipv4Addr) -> Vec<u8> {
    let flags = NLM_F_REQUEST | NLM_F_ACK | NLM_F_CREATE | NLM_F_REPLACE;
    let mut message = header(RTM_NEWROUTE, flags, seq);
    // family, dst_len, src_len, tos, table, protocol, scope, type, flags.
    message.extend_from_slice(&[
        FAMILY_INET,
        0,
        0,
        0,
        RT_TABLE_MAIN,
        RTPROT_STATIC,
        RT_SCOPE_UNIVERSE,
        RTN_UNICAST,
    ]);
    message.extend_from_slice(&0u32.to_ne_bytes());
    debug_assert_eq!(message.len(), HEADER_LEN + RTMSG_LEN);
    attribute(&mut message, RTA_GATEWAY, &gateway.octets());
    attribute(&mut message, RTA_OIF, &index.to_ne_bytes());
    finish(message)
}

/// The messages of one datagram from the kernel.
pub fn parse(datagram: &[u8]) -> Result<Vec<Reply>, MalformedReply> {
    let mut replies = Vec::new();
    let mut addresses = Vec::new();
    let mut at = 0;
    while at + HEADER_LEN <= datagram.len() {
        let length = ne_u32(datagram, at).ok_or(MalformedReply(at))? as usize;
        let kind = ne_u16(datagram, at + 4).ok_or(MalformedReply(at))?;
        let seq = ne_u32(datagram, at + 8).ok_or(MalformedReply(at))?;
        if length < HEADER_LEN || at + length > datagram.len() {
            return Err(MalformedReply(at));
        }
        let body = &datagram[at + HEADER_LEN..at + length];
        match kind {
            NLMSG_ERROR => {
                if body.len() < ERROR_LEN {
                    return Err(MalformedReply(at));
                }
                let error = i32::from_ne_bytes([body[0], body[1], body[2], body[3]]);
                replies.push(Reply::Ack { seq, error });
            }
            NLMSG_DONE => replies.push(Reply::Done),
            RTM_NEWADDR => {
                if let Some(found) = ipv4_address(body) {
                    addresses.push(found);
                }
            }
            _ => {}
        }
        at += align(length);
    }
    if !addresses.is_empty() {
        replies.push(Reply::Addresses(addresses));
    }
    Ok(replies)
}

/// The interface index and IPv4 address of an RTM_NEWADDR body; `None` for another
/// family or one without an address.
fn ipv4_address(body: &[u8]) -> Option<(u32, InterfaceAddress)> {
    let family = *body.first()?;
    let prefix_len = *body.get(1)?;
    let index = ne_u32(body, 4)?;
    if family != FAMILY_INET {
        return None;
    }
    let mut local = None;
    let mut address = None;
    let mut at = IFADDRMSG_LEN;
    while at + ATTRIBUTE_HEADER_LEN <= body.len() {
        let length = usize::from(ne_u16(body, at)?);
        let kind = ne_u16(body, at + 2)?;
        if length < ATTRIBUTE_HEADER_LEN || at + length > body.len() {
            return None;
        }
        let value = &body[at + ATTRIBUTE_HEADER_LEN..at + length];
        let quad = <[u8; 4]>::try_from(value).ok().map(Ipv4Addr::from);
        match kind {
            IFA_LOCAL => local = quad,
            IFA_ADDRESS => address = quad,
            _ => {}
        }
        at += align(length);
    }
    // IFA_LOCAL is the interface's own address; IFA_ADDRESS differs only on
    // point-to-point links.
    let address = local.or(address)?;
    Some((
        index,
        InterfaceAddress {
            address,
            prefix_len,
        },
    ))
}

fn header(kind: u16, flags: u16, seq: u32) -> Vec<u8> {
    let mut message = Vec::with_capacity(64);
    // The length is filled in by `finish`.
    message.extend_from_slice(&0u32.to_ne_bytes());
    message.extend_from_slice(&kind.to_ne_bytes());
    message.extend_from_slice(&flags.to_ne_bytes());
    message.extend_from_slice(&seq.to_ne_bytes());
    // The port id: 0, the kernel fills in ours.
    message.extend_from_slice(&0u32.to_ne_bytes());
    message
}

fn ifaddrmsg(prefix_len: u8, index: u32) -> [u8; IFADDRMSG_LEN] {
    let [i0, i1, i2, i3] = index.to_ne_bytes();
    // family, prefixlen, flags, scope, index.
    [
        FAMILY_INET,
        prefix_len,
        0,
        RT_SCOPE_UNIVERSE,
        i0,
        i1,
        i2,
        i3,
    ]
}

fn attribute(message: &mut Vec<u8>, kind: u16, value: &[u8]) {
    let length = ATTRIBUTE_HEADER_LEN + value.len();
    // Attribute values here are 4 bytes long: the length always fits.
    message.extend_from_slice(&u16::try_from(length).unwrap_or(u16::MAX).to_ne_bytes());
    message.extend_from_slice(&kind.to_ne_bytes());
    message.extend_from_slice(value);
    message.resize(align(message.len()), 0);
}

fn finish(mut message: Vec<u8>) -> Vec<u8> {
    let length = u32::try_from(message.len()).unwrap_or(u32::MAX);
    message[..4].copy_from_slice(&length.to_ne_bytes());
    message
}

fn align(length: usize) -> usize {
    length.div_ceil(4) * 4
}

fn ne_u16(bytes: &[u8], at: usize) -> Option<u16> {
    Some(u16::from_ne_bytes(bytes.get(at..at + 2)?.try_into().ok()?))
}

fn ne_u32(bytes: &[u8], at: usize) -> Option<u32> {
    Some(u32::from_ne_bytes(bytes.get(at..at + 4)?.try_into().ok()?))
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    const CELL: InterfaceAddress = InterfaceAddress {
        address: Ipv4Addr::new(192, 168, 77, 60),
        prefix_len: 24,
    };

    #[test]
    fn the_prefix_and_broadcast_follow_the_mask() {
        let address = InterfaceAddress::new(
            Ipv4Addr::new(192, 168, 77, 60),
            Ipv4Addr::new(255, 255, 255, 0),
        );
        assert_eq!(address, CELL);
        assert_eq!(address.broadcast(), Ipv4Addr::new(192, 168, 77, 255));
        let host = InterfaceAddress::new(Ipv4Addr::new(10, 0, 0, 1), Ipv4Addr::BROADCAST);
        assert_eq!((host.prefix_len, host.broadcast()), (32, host.address));
    }

    #[test]
    fn an_address_request_has_its_header_family_header_and_attributes() {
        let message = add_address(7, 3, CELL);
        // 16 header + 8 ifaddrmsg + 3 attributes of 8.
        assert_eq!(message.len(), 48);
        assert_eq!(ne_u32(&message, 0), Some(48));
        assert_eq!(ne_u16(&message, 4), Some(RTM_NEWADDR));
        assert_eq!(
            ne_u16(&message, 6),
            Some(NLM_F_REQUEST | NLM_F_ACK | NLM_F_CREATE | NLM_F_REPLACE)
        );
        assert_eq!(ne_u32(&message, 8), Some(7));
        assert_eq!(message[16..18], [FAMILY_INET, 24]);
        assert_eq!(ne_u32(&message, 20), Some(3));
        assert_eq!(ne_u16(&message, 24), Some(8));
        assert_eq!(ne_u16(&message, 26), Some(IFA_LOCAL));
        assert_eq!(message[28..32], [192, 168, 77, 60]);
        assert_eq!(message[44..48], [192, 168, 77, 255]);
        let delete = delete_address(8, 3, CELL);
        assert_eq!(ne_u16(&delete, 4), Some(RTM_DELADDR));
        assert_eq!(delete.len(), 40);
    }

    #[test]
    fn the_default_route_names_the_gateway_and_the_interface() {
        let message = default_route(9, 3, Ipv4Addr::new(192, 168, 77, 1));
        assert_eq!(message.len(), HEADER_LEN + RTMSG_LEN + 16);
        assert_eq!(ne_u16(&message, 4), Some(RTM_NEWROUTE));
        // No destination: the default route, in the main table.
        assert_eq!(message[16..24], [2, 0, 0, 0, 254, 4, 0, 1]);
        assert_eq!(ne_u16(&message, 30), Some(RTA_GATEWAY));
        assert_eq!(message[32..36], [192, 168, 77, 1]);
        assert_eq!(ne_u16(&message, 38), Some(RTA_OIF));
        assert_eq!(ne_u32(&message, 40), Some(3));
    }

    /// An RTM_NEWADDR as the kernel dumps it, with a label attribute of odd length.
    fn dumped(index: u32, address: InterfaceAddress, family: u8) -> Vec<u8> {
        let mut message = header(RTM_NEWADDR, 2, 1);
        let mut family_header = ifaddrmsg(address.prefix_len, index);
        family_header[0] = family;
        message.extend_from_slice(&family_header);
        attribute(&mut message, IFA_ADDRESS, &address.address.octets());
        attribute(&mut message, 3, b"eth0\0");
        attribute(&mut message, IFA_LOCAL, &address.address.octets());
        finish(message)
    }

    fn ack(seq: u32, error: i32) -> Vec<u8> {
        let mut message = header(NLMSG_ERROR, 0, seq);
        message.extend_from_slice(&error.to_ne_bytes());
        message.extend_from_slice(&header(RTM_NEWADDR, 0, seq));
        finish(message)
    }

    #[test]
    fn a_dump_yields_the_ipv4_addresses_and_its_end() {
        let mut datagram = dumped(3, CELL, FAMILY_INET);
        datagram.extend(dumped(4, CELL, 10));
        datagram.extend(finish(header(NLMSG_DONE, 2, 1)));
        assert_eq!(
            parse(&datagram),
            Ok(vec![Reply::Done, Reply::Addresses(vec![(3, CELL)])])
        );
    }

    #[test]
    fn acknowledgements_carry_the_errno() {
        let mut datagram = ack(5, 0);
        datagram.extend(ack(6, -libc::EPERM));
        assert_eq!(
            parse(&datagram),
            Ok(vec![
                Reply::Ack { seq: 5, error: 0 },
                Reply::Ack {
                    seq: 6,
                    error: -libc::EPERM
                }
            ])
        );
        let mut cut = ack(5, 0);
        cut.truncate(20);
        cut[..4].copy_from_slice(&20u32.to_ne_bytes());
        assert_eq!(parse(&cut), Err(MalformedReply(0)));
    }

    proptest! {
        #[test]
        fn parse_never_panics(bytes in proptest::collection::vec(any::<u8>(), 0..96)) {
            let _ = parse(&bytes);
        }

        #[test]
        fn a_dumped_address_reads_back(octets in any::<[u8; 4]>(), prefix_len in 0u8..=32, index in any::<u32>()) {
            let address = InterfaceAddress { address: Ipv4Addr::from(octets), prefix_len };
            let parsed = parse(&dumped(index, address, FAMILY_INET)).unwrap();
            prop_assert_eq!(parsed, vec![Reply::Addresses(vec![(index, address)])]);
        }
    }
}
