//! The PNIO blocks of a Connect response: ARBlockRes, one IOCRBlockRes per IOCR (with the
//! FrameID the device serves), AlarmCRBlockRes when the AR has an alarm CR, ModuleDiffBlock
//! when the expected submodules differ from the real ones, and ARServerBlockRes with the device's NameOfStation. PNIO blocks are big-endian whatever
//! the DREP of the DCE/RPC envelope.

use pnio::cm::block::ty;

use super::connect::ConnectRequest;
use super::module_diff::SubmoduleDiff;
use crate::ethernet::{ETHER_TYPE_PROFINET, MacAddress};

/// AlarmCRType of the only alarm CR there is.
const ALARM_CR_TYPE: u16 = 0x0001;
/// This device's LocalAlarmReference.
pub const LOCAL_ALARM_REFERENCE: u16 = 0x0000;
/// BlockType of the ModuleDiffBlock (not among `pnio`'s block types).
pub const MODULE_DIFF_BLOCK: u16 = 0x8104;

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
    /// The expected submodules that differ from the device, in request order (see
    /// `module_diff`); empty: no ModuleDiffBlock.
    pub module_diff: &'a [SubmoduleDiff],
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
    /// More APIs, modules or submodules than a ModuleDiffBlock count can say.
    #[error("{0} entries are too many for a ModuleDiffBlock")]
    ModuleDiffCount(usize),
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
    if !answer.module_diff.is_empty() {
        block(
            &mut out,
            MODULE_DIFF_BLOCK,
            &[&module_diff_body(answer.module_diff)?],
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

/// The body of a ModuleDiffBlock: NumberOfAPIs, per API its modules (SlotNumber,
/// ModuleIdentNumber, ModuleState) and per module its submodules (SubslotNumber,
/// SubmoduleIdentNumber, SubmoduleState). `diffs` lists one entry per submodule; the
/// entries of one API and slot are grouped in the order they first appear.
fn module_diff_body(diffs: &[SubmoduleDiff]) -> Result<Vec<u8>, ConnectResponseError> {
    let mut out = Vec::new();
    let apis = first_of_each(diffs, |d| d.api);
    put_count(&mut out, apis.len())?;
    for api in apis {
        let in_api: Vec<&SubmoduleDiff> = diffs.iter().filter(|d| d.api == api.api).collect();
        out.extend_from_slice(&api.api.to_be_bytes());
        let modules = first_of_each(&in_api, |d| d.slot);
        put_count(&mut out, modules.len())?;
        for module in modules {
            let submodules: Vec<&&SubmoduleDiff> =
                in_api.iter().filter(|d| d.slot == module.slot).collect();
            out.extend_from_slice(&module.slot.to_be_bytes());
            out.extend_from_slice(&module.module_ident.to_be_bytes());
            out.extend_from_slice(&module.module_state().to_be_bytes());
            put_count(&mut out, submodules.len())?;
            for submodule in submodules {
                out.extend_from_slice(&submodule.subslot.to_be_bytes());
                out.extend_from_slice(&submodule.submodule_ident.to_be_bytes());
                out.extend_from_slice(&submodule.submodule_state().to_be_bytes());
            }
        }
    }
    Ok(out)
}

/// The first item of each distinct `key`, in order.
fn first_of_each<T: Copy, K: PartialEq>(items: &[T], key: impl Fn(&T) -> K) -> Vec<T> {
    let mut firsts: Vec<T> = Vec::new();
    for item in items {
        if !firsts.iter().any(|f| key(f) == key(item)) {
            firsts.push(*item);
        }
    }
    firsts
}

/// Appends a 16-bit count.
fn put_count(out: &mut Vec<u8>, count: usize) -> Result<(), ConnectResponseError> {
    let count = u16::try_from(count).map_err(|_| ConnectResponseError::ModuleDiffCount(count))?;
    out.extend_from_slice(&count.to_be_bytes());
    Ok(())
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
            module_diff: &[],
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
    fn the_module_diff_block_groups_the_differences_by_api_and_slot() {
        use crate::cm::module_diff::Mismatch;
        let diff = |slot, subslot, module_ident, submodule_ident, mismatch| SubmoduleDiff {
            api: 0,
            slot,
            subslot,
            module_ident,
            submodule_ident,
            mismatch,
        };
        let diffs = [
            diff(1, 1, 0x0001_0100, 0x0001_0100, Mismatch::WrongModule),
            diff(0, 0x8001, 0x10, 0, Mismatch::NoSubmodule),
            diff(2, 1, 0, 0, Mismatch::NoModule),
            diff(1, 2, 0x0001_0100, 0, Mismatch::WrongModule),
        ];
        let mut request = request();
        request.iocrs.clear();
        request.alarm_cr = None;
        let answer = ConnectAnswer {
            module_diff: &diffs,
            ..p_net_answer(&[])
        };
        let blocks = connect_response_blocks(&request, &answer).unwrap();
        let all = BlockHeader::read_all(&blocks).unwrap();
        let types: Vec<u16> = all.iter().map(|(h, _)| h.block_type).collect();
        assert_eq!(
            types,
            [ty::AR_BLOCK_RES, MODULE_DIFF_BLOCK, ty::AR_SERVER_BLOCK_RES]
        );
        #[rustfmt::skip]
        let expected: &[u8] = &[
            0, 1, // NumberOfAPIs
            0, 0, 0, 0, 0, 3, // API 0, NumberOfModules
            0, 1, 0, 1, 1, 0, 0, 1, 0, 2, // slot 1, its real module, WrongModule, 2 submodules
            0, 1, 0, 1, 1, 0, 0x90, 0, // subslot 1, real submodule, Wrong
            0, 2, 0, 0, 0, 0, 0x90, 0, // subslot 2, none, Wrong
            0, 0, 0, 0, 0, 0x10, 0, 2, 0, 1, // slot 0, ProperModule, 1 submodule
            0x80, 0x01, 0, 0, 0, 0, 0x98, 0, // subslot 0x8001, none, NoSubmodule
            0, 2, 0, 0, 0, 0, 0, 0, 0, 1, // slot 2, NoModule, 1 submodule
            0, 1, 0, 0, 0, 0, 0x98, 0, // subslot 1, none, NoSubmodule
        ];
        assert_eq!(all[1].0.block_length, 2 + expected.len() as u16);
        assert_eq!(all[1].1, expected);
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
