//! The PNIO blocks of a Connect response: ARBlockRes, one IOCRBlockRes per IOCR (with the
//! FrameID the device serves), AlarmCRBlockRes when the AR has an alarm CR, and
//! ARServerBlockRes with the device's NameOfStation. PNIO blocks are big-endian whatever
//! the DREP of the DCE/RPC envelope.

use pnio::cm::block::ty;

use super::connect::ConnectRequest;
use crate::ethernet::{ETHER_TYPE_PROFINET, MacAddress};

/// AlarmCRType of the only alarm CR there is.
const ALARM_CR_TYPE: u16 = 0x0001;
/// This device's LocalAlarmReference.
const LOCAL_ALARM_REFERENCE: u16 = 0x0000;

/// What the device answers beyond what the request says.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ConnectAnswer<'a> {
    /// The FrameID served per IOCR, in the order of the request's IOCRs.
    pub frame_ids: &'a [u16],
    /// The device's MAC address (CMResponderMacAdd).
    pub device_mac: MacAddress,
    /// The device's NameOfStation (CMResponderStationName).
    pub name_of_station: &'a str,
    /// The longest alarm data the device sends; the answer is the smaller of this and
    /// what the controller offers.
    pub max_alarm_data_length: u16,
}

/// A response that cannot be written.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum ConnectResponseError {
    /// Not one FrameID per IOCR.
    #[error("{frame_ids} FrameIDs for {iocrs} IOCRs")]
    FrameIds {
        /// FrameIDs given.
        frame_ids: usize,
        /// IOCRs of the request.
        iocrs: usize,
    },
    /// A block longer than a block length can say.
    #[error("a Connect response block of {0} bytes is too long")]
    BlockLength(usize),
}

/// The blocks of the response to `request`.
pub fn connect_response_blocks(
    request: &ConnectRequest,
    answer: &ConnectAnswer<'_>,
) -> Result<Vec<u8>, ConnectResponseError> {
    if answer.frame_ids.len() != request.iocrs.len() {
        return Err(ConnectResponseError::FrameIds {
            frame_ids: answer.frame_ids.len(),
            iocrs: request.iocrs.len(),
        });
    }
    let mut out = Vec::new();
    let ar = &request.ar;
    block(
        &mut out,
        ty::AR_BLOCK_RES,
        &[
            &ar.ar_type.to_be_bytes(),
            &ar.ar_uuid.0,
            &ar.session_key.to_be_bytes(),
            &answer.device_mac.0,
            &ETHER_TYPE_PROFINET.to_be_bytes(),
        ],
    )?;
    for (iocr, frame_id) in request.iocrs.iter().zip(answer.frame_ids) {
        block(
            &mut out,
            ty::IOCR_BLOCK_RES,
            &[
                &iocr.iocr_type.to_be_bytes(),
                &iocr.reference.to_be_bytes(),
                &frame_id.to_be_bytes(),
            ],
        )?;
    }
    if let Some(alarm_cr) = &request.alarm_cr {
        let length = answer
            .max_alarm_data_length
            .min(alarm_cr.max_alarm_data_length);
        block(
            &mut out,
            ty::ALARM_CR_BLOCK_RES,
            &[
                &ALARM_CR_TYPE.to_be_bytes(),
                &LOCAL_ALARM_REFERENCE.to_be_bytes(),
                &length.to_be_bytes(),
            ],
        )?;
    }
    let name = answer.name_of_station.as_bytes();
    let name_length =
        u16::try_from(name.len()).map_err(|_| ConnectResponseError::BlockLength(name.len()))?;
    // The whole ARServerBlockRes is padded to a multiple of 4 bytes.
    let padding = [0u8; 3];
    let unpadded = BLOCK_HEADER_LEN + 2 + name.len();
    block(
        &mut out,
        ty::AR_SERVER_BLOCK_RES,
        &[
            &name_length.to_be_bytes(),
            name,
            &padding[..(4 - unpadded % 4) % 4],
        ],
    )?;
    Ok(out)
}

/// BlockType(2) BlockLength(2) BlockVersionHigh(1) BlockVersionLow(1).
const BLOCK_HEADER_LEN: usize = 6;

/// Appends a block of version 1.0 with the concatenated `body`.
fn block(out: &mut Vec<u8>, block_type: u16, body: &[&[u8]]) -> Result<(), ConnectResponseError> {
    let body_len: usize = body.iter().map(|part| part.len()).sum();
    // BlockLength counts the version bytes, not type and length.
    let length =
        u16::try_from(body_len + 2).map_err(|_| ConnectResponseError::BlockLength(body_len))?;
    out.extend_from_slice(&block_type.to_be_bytes());
    out.extend_from_slice(&length.to_be_bytes());
    out.extend_from_slice(&[1, 0]);
    for part in body {
        out.extend_from_slice(part);
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cm::connect::IOCR_TYPE_OUTPUT;
    use crate::cm::iocr::accept_iocr;
    use crate::testdata;
    use pnio::cm::block::BlockHeader;
    use pnio::rpc::RpcHeader;

    /// Where the PNIO blocks start in the golden response: Ethernet, IPv4, UDP, the RPC
    /// header and the NDR response header with its PNIOStatus.
    const RESPONSE_BLOCKS: usize = 42 + RpcHeader::LEN + 20;

    fn request() -> ConnectRequest {
        ConnectRequest::parse(&testdata::frame("connect_req")[42..]).unwrap()
    }

    fn p_net_answer(frame_ids: &[u16]) -> ConnectAnswer<'_> {
        ConnectAnswer {
            frame_ids,
            device_mac: MacAddress([0x8c, 0xf3, 0x19, 0xcd, 0x19, 0xf8]),
            name_of_station: "rt-labs-dev",
            max_alarm_data_length: 200,
        }
    }

    #[test]
    fn the_response_to_the_golden_connect_is_p_net_s_byte_for_byte() {
        let request = request();
        let mut frame_ids = Vec::new();
        for iocr in &request.iocrs {
            frame_ids.push(accept_iocr(iocr, &frame_ids).unwrap().frame_id);
        }
        let blocks = connect_response_blocks(&request, &p_net_answer(&frame_ids)).unwrap();
        let golden = testdata::frame("connect_res");
        assert_eq!(blocks, golden[RESPONSE_BLOCKS..]);
    }

    #[test]
    fn a_device_chosen_frame_id_is_answered_and_a_device_access_ar_has_no_alarm_cr() {
        let mut request = request();
        let blocks = connect_response_blocks(&request, &p_net_answer(&[0x8000, 0x8123])).unwrap();
        let all = BlockHeader::read_all(&blocks).unwrap();
        let output = all
            .iter()
            .find(|(h, body)| {
                h.block_type == ty::IOCR_BLOCK_RES && body[..2] == IOCR_TYPE_OUTPUT.to_be_bytes()
            })
            .unwrap();
        assert_eq!(output.1[4..6], [0x81, 0x23]);
        request.iocrs.clear();
        request.alarm_cr = None;
        let blocks = connect_response_blocks(&request, &p_net_answer(&[])).unwrap();
        let types: Vec<u16> = BlockHeader::read_all(&blocks)
            .unwrap()
            .iter()
            .map(|(h, _)| h.block_type)
            .collect();
        assert_eq!(types, [ty::AR_BLOCK_RES, ty::AR_SERVER_BLOCK_RES]);
        let (_, server) = BlockHeader::read_all(&blocks).unwrap()[1];
        assert_eq!((BlockHeader::LEN + server.len()) % 4, 0);
    }

    #[test]
    fn one_frame_id_per_iocr_is_required() {
        assert_eq!(
            connect_response_blocks(&request(), &p_net_answer(&[0x8000])),
            Err(ConnectResponseError::FrameIds {
                frame_ids: 1,
                iocrs: 2
            })
        );
    }
}
