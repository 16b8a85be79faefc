//! The DCE/RPC envelope of PNIO-CM over UDP 34964: a request's header and NDR arguments
//! in, a response with its PNIOStatus out, and the device's own requests (the
//! ApplicationReady it sends to the controller).
//!
//! Requests arrive in either DREP; this device answers big-endian, as p-net does. The
//! header fields a response echoes (object, interface, activity, sequence number, opnum)
//! tie it to the call, and `max_count` echoes the request's `args_max`.

use pnio::cm::PnioStatus;
use pnio::rpc::{
    Drep, FLAG1_IDEMPOTENT, FLAG1_NO_FACK, NdrRequest, NdrResponse, PacketType, RpcError,
    RpcHeader, Uuid,
};

/// The RPC argument buffer this device offers the controller for its answers (p-net's
/// value in the golden ApplicationReady).
pub const ARGS_MAX: u32 = 1340;
/// Hints that say "no hint".
const NO_HINT: u16 = 0xffff;
/// Interface version 1.0 of the PNIO interfaces.
const INTERFACE_VERSION: u32 = 1;

/// A call that arrived: a request, or a response to a call of this device.
#[derive(Debug, Clone, PartialEq)]
pub enum RpcPdu<'a> {
    /// A request with its PNIO blocks.
    Request {
        /// The DCE/RPC header.
        header: RpcHeader,
        /// The caller's argument buffer size, echoed in the response.
        args_max: u32,
        /// The PNIO blocks.
        blocks: &'a [u8],
    },
    /// A response with its PNIOStatus and PNIO blocks.
    Response {
        /// The DCE/RPC header.
        header: RpcHeader,
        /// The PNIOStatus.
        status: PnioStatus,
        /// The PNIO blocks.
        blocks: &'a [u8],
    },
    /// Any other packet type (ping, ack, fault, ...): nothing to do with it here.
    Other(RpcHeader),
}

/// Parses a UDP payload of port 34964.
pub fn parse(pdu: &[u8]) -> Result<RpcPdu<'_>, RpcError> {
    let header = RpcHeader::parse(pdu)?;
    let body = body(pdu, &header)?;
    match header.ptype {
        PacketType::Request => {
            let (ndr, blocks) = NdrRequest::parse(body, header.drep)?;
            Ok(RpcPdu::Request {
                args_max: ndr.args_max,
                header,
                blocks,
            })
        }
        PacketType::Response => {
            let (ndr, blocks) = NdrResponse::parse(body, header.drep)?;
            Ok(RpcPdu::Response {
                header,
                status: PnioStatus(ndr.status),
                blocks,
            })
        }
        _ => Ok(RpcPdu::Other(header)),
    }
}

/// The body the header's fragment length announces.
fn body<'a>(pdu: &'a [u8], header: &RpcHeader) -> Result<&'a [u8], RpcError> {
    let end = RpcHeader::LEN + usize::from(header.frag_len);
    pdu.get(RpcHeader::LEN..end).ok_or(RpcError::TooShort {
        need: end,
        have: pdu.len(),
    })
}

/// The response to the request `request` (with its `args_max`): `status` and, when it is
/// OK, `blocks`.
pub fn response(request: &RpcHeader, args_max: u32, status: PnioStatus, blocks: &[u8]) -> Vec<u8> {
    let ndr = if status.is_ok() {
        NdrResponse::ok(args_max, len_u32(blocks))
    } else {
        NdrResponse::error(status.to_u32(), args_max)
    };
    let blocks = if status.is_ok() { blocks } else { &[] };
    let call = Call {
        object: request.object,
        interface: request.interface,
        activity: request.activity,
        seq_num: request.seq_num,
        opnum: request.opnum,
    };
    let flags1 = FLAG1_IDEMPOTENT | FLAG1_NO_FACK;
    let body_len = NdrResponse::LEN + blocks.len();
    let header = header(
        PacketType::Response,
        flags1,
        &call,
        request.if_version,
        body_len,
    );
    let mut out = Vec::with_capacity(RpcHeader::LEN + NdrResponse::LEN + blocks.len());
    header.write(&mut out);
    ndr.write(&mut out, Drep::BIG);
    out.extend_from_slice(blocks);
    out
}

/// Who a request of this device goes to, and as which call.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Call {
    /// The object called (the controller's CMInitiatorObjectUUID).
    pub object: Uuid,
    /// The interface called (the controller interface).
    pub interface: Uuid,
    /// This device's activity.
    pub activity: Uuid,
    /// The call's sequence number within the activity.
    pub seq_num: u32,
    /// Operation number.
    pub opnum: u16,
}

/// A request of this device, big-endian, carrying `blocks`.
pub fn request(call: &Call, blocks: &[u8]) -> Vec<u8> {
    let body_len = NdrRequest::LEN + blocks.len();
    let header = header(
        PacketType::Request,
        FLAG1_IDEMPOTENT,
        call,
        INTERFACE_VERSION,
        body_len,
    );
    let mut out = Vec::with_capacity(RpcHeader::LEN + NdrRequest::LEN + blocks.len());
    header.write(&mut out);
    NdrRequest::for_blocks(ARGS_MAX, len_u32(blocks)).write(&mut out, Drep::BIG);
    out.extend_from_slice(blocks);
    out
}

/// The header of a PDU of this device (big-endian, no hints, one fragment) for `call`.
fn header(
    ptype: PacketType,
    flags1: u8,
    call: &Call,
    if_version: u32,
    body_len: usize,
) -> RpcHeader {
    RpcHeader {
        ptype,
        flags1,
        flags2: 0,
        drep: Drep::BIG,
        serial_hi: 0,
        object: call.object,
        interface: call.interface,
        activity: call.activity,
        server_boot: 0,
        if_version,
        seq_num: call.seq_num,
        opnum: call.opnum,
        ihint: NO_HINT,
        ahint: NO_HINT,
        frag_len: frag_len(body_len),
        frag_num: 0,
        auth_proto: 0,
        serial_lo: 0,
    }
}

/// PNIO blocks this device writes stay far below a UDP datagram; a longer body would be
/// a bug in this crate, so it saturates rather than wraps.
fn frag_len(body: usize) -> u16 {
    u16::try_from(body).unwrap_or(u16::MAX)
}

fn len_u32(blocks: &[u8]) -> u32 {
    u32::try_from(blocks.len()).unwrap_or(u32::MAX)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testdata;
    use pnio::rpc::PNIO_CONTROLLER_INTERFACE;

    /// The UDP payload of a golden frame (Ethernet, IPv4 and UDP headers cut).
    fn udp(name: &str) -> Vec<u8> {
        testdata::frame(name)[42..].to_vec()
    }

    #[test]
    fn requests_of_both_dreps_parse() {
        let pdu = udp("prmend_req");
        let RpcPdu::Request {
            header,
            args_max,
            blocks,
        } = parse(&pdu).unwrap()
        else {
            panic!("not a request")
        };
        assert_eq!((header.opnum, header.seq_num), (4, 2));
        assert_eq!(args_max, 32);
        assert_eq!(blocks.len(), 32);
        let pdu = udp("appready_req");
        assert!(matches!(parse(&pdu), Ok(RpcPdu::Request { .. })));
    }

    #[test]
    fn a_response_carries_its_status() {
        let pdu = udp("appready_res");
        let RpcPdu::Response { status, blocks, .. } = parse(&pdu).unwrap() else {
            panic!("not a response")
        };
        assert!(status.is_ok());
        assert_eq!(blocks[..2], [0x81, 0x12]);
    }

    #[test]
    fn the_response_envelope_is_p_net_s_byte_for_byte() {
        let request = udp("prmend_req");
        let RpcPdu::Request {
            header, args_max, ..
        } = parse(&request).unwrap()
        else {
            panic!("not a request")
        };
        let golden = udp("prmend_res");
        let blocks = &golden[RpcHeader::LEN + NdrResponse::LEN..];
        assert_eq!(response(&header, args_max, PnioStatus::OK, blocks), golden);
    }

    #[test]
    fn an_error_response_has_the_status_and_no_blocks() {
        let request = udp("prmend_req");
        let RpcPdu::Request { header, .. } = parse(&request).unwrap() else {
            panic!("not a request")
        };
        let status = PnioStatus::control_wrong_state();
        let pdu = response(&header, 32, status, &[1, 2, 3]);
        assert_eq!(pdu.len(), RpcHeader::LEN + NdrResponse::LEN);
        let RpcPdu::Response {
            status: parsed,
            blocks,
            ..
        } = parse(&pdu).unwrap()
        else {
            panic!("not a response")
        };
        assert_eq!((parsed, blocks.len()), (status, 0));
    }

    #[test]
    fn the_device_request_envelope_is_p_net_s_byte_for_byte() {
        let golden = udp("appready_req");
        let parsed = RpcHeader::parse(&golden).unwrap();
        let call = Call {
            object: parsed.object,
            interface: PNIO_CONTROLLER_INTERFACE,
            activity: parsed.activity,
            seq_num: 0,
            opnum: 4,
        };
        let blocks = &golden[RpcHeader::LEN + NdrRequest::LEN..];
        assert_eq!(request(&call, blocks), golden);
    }

    #[test]
    fn a_body_shorter_than_announced_is_refused() {
        let mut pdu = udp("prmend_req");
        pdu.truncate(pdu.len() - 1);
        assert!(parse(&pdu).is_err());
    }
}
