//! The Connect request (opnum 0 of the PNIO device interface), grouped and checked for
//! what this device needs to know, and the C_SDU layouts it fixes.
//!
//! Unlike `pnio::cm::ConnectReq`, a Connect without an AlarmCRBlockReq and without IOCRs
//! is accepted here: profinet-py's first connect is such a device-access AR (ARType 6).

use pnio::cm::BlockError;
use pnio::cm::block::{
    AlarmCrBlockReq, ArBlockReq, BlockHeader, ExpectedSubmoduleBlockReq, IocrBlockReq, ty,
};
use pnio::rpc::{NdrRequest, Opnum, PacketType, RpcError, RpcHeader};

use crate::frame_id::RtClass;
use crate::rt::c_sdu::{CSduLayout, IoDataObject, LayoutError};

/// ARType of an IO controller AR (IOCARSingle).
pub const AR_TYPE_IOC: u16 = 0x0001;
/// ARType of a supervisor's device-access AR: records only, no cyclic data, no alarms.
pub const AR_TYPE_DEVICE_ACCESS: u16 = 0x0006;
/// IOCRType of an input CR (device → controller).
pub const IOCR_TYPE_INPUT: u16 = 1;
/// IOCRType of an output CR (controller → device).
pub const IOCR_TYPE_OUTPUT: u16 = 2;
/// ARProperties bit 30: StartupMode Advanced (else Legacy).
const AR_PROPERTIES_STARTUP_ADVANCED: u32 = 1 << 30;

/// A Connect request that cannot be used.
#[derive(Debug, thiserror::Error)]
pub enum ConnectError {
    /// The DCE/RPC envelope is broken.
    #[error("DCE/RPC: {0}")]
    Rpc(#[from] RpcError),
    /// The PDU is not a Connect request.
    #[error("not a Connect request (packet type {ptype:?}, opnum {opnum})")]
    NotConnect {
        /// DCE/RPC packet type.
        ptype: PacketType,
        /// Operation number.
        opnum: u16,
    },
    /// A PNIO block is broken.
    #[error("PNIO block: {0}")]
    Block(#[from] BlockError),
    /// No ARBlockReq.
    #[error("Connect without an ARBlockReq")]
    MissingArBlock,
    /// A block that may appear once appears twice.
    #[error("block type {0:#06x} appears twice")]
    DuplicateBlock(u16),
    /// A block type a Connect request does not carry.
    #[error("unexpected block type {0:#06x} in a Connect request")]
    UnexpectedBlock(u16),
    /// An IOCR places data of a submodule the controller does not expect.
    #[error("IOCR object of slot {slot} subslot {subslot:#06x} has no expected submodule")]
    UnexpectedObject {
        /// Slot.
        slot: u16,
        /// Subslot.
        subslot: u16,
    },
    /// The IOCR's layout does not fit its DataLength.
    #[error("IOCR layout: {0}")]
    Layout(#[from] LayoutError),
}

/// The blocks of a Connect request.
#[derive(Debug, Clone, PartialEq)]
pub struct ConnectRequest {
    /// The DCE/RPC header (activity, sequence number and DREP for the response).
    pub rpc: RpcHeader,
    /// The AR's parameters.
    pub ar: ArBlockReq,
    /// The IOCRs, normally one input and one output CR (none for device access).
    pub iocrs: Vec<IocrBlockReq>,
    /// What the controller expects in each slot.
    pub expected: Vec<ExpectedSubmoduleBlockReq>,
    /// The alarm CR (none for device access).
    pub alarm_cr: Option<AlarmCrBlockReq>,
}

impl ConnectRequest {
    /// Parses a DCE/RPC PDU (the UDP payload) that must be a Connect request.
    pub fn parse(pdu: &[u8]) -> Result<Self, ConnectError> {
        let rpc = RpcHeader::parse(pdu)?;
        if rpc.ptype != PacketType::Request || Opnum::from_u16(rpc.opnum) != Some(Opnum::Connect) {
            return Err(ConnectError::NotConnect {
                ptype: rpc.ptype,
                opnum: rpc.opnum,
            });
        }
        let (_, blocks) = NdrRequest::parse(&pdu[RpcHeader::LEN..], rpc.drep)?;
        let mut ar = None;
        let mut iocrs = Vec::new();
        let mut expected = Vec::new();
        let mut alarm_cr = None;
        for (header, body) in BlockHeader::read_all(blocks)? {
            match header.block_type {
                ty::AR_BLOCK_REQ => once(&mut ar, header, ArBlockReq::parse(body)?)?,
                ty::IOCR_BLOCK_REQ => iocrs.push(IocrBlockReq::parse(body)?),
                ty::EXPECTED_SUBMODULE_BLOCK_REQ => {
                    expected.push(ExpectedSubmoduleBlockReq::parse(body)?)
                }
                ty::ALARM_CR_BLOCK_REQ => {
                    once(&mut alarm_cr, header, AlarmCrBlockReq::parse(body)?)?
                }
                other => return Err(ConnectError::UnexpectedBlock(other)),
            }
        }
        Ok(Self {
            rpc,
            ar: ar.ok_or(ConnectError::MissingArBlock)?,
            iocrs,
            expected,
            alarm_cr,
        })
    }

    /// True for a supervisor's device-access AR.
    pub fn is_device_access(&self) -> bool {
        self.ar.ar_type == AR_TYPE_DEVICE_ACCESS
    }

    /// True for StartupMode Advanced (S7-1500), false for Legacy (profinet-py).
    pub fn startup_advanced(&self) -> bool {
        self.ar.ar_properties & AR_PROPERTIES_STARTUP_ADVANCED != 0
    }

    /// The IOCR of `iocr_type` ([`IOCR_TYPE_INPUT`] or [`IOCR_TYPE_OUTPUT`]), if present.
    pub fn iocr(&self, iocr_type: u16) -> Option<&IocrBlockReq> {
        self.iocrs.iter().find(|iocr| iocr.iocr_type == iocr_type)
    }

    /// The C_SDU layout `iocr` fixes: its objects' offsets, with the data lengths the
    /// expected submodules give for its direction (IOPS and IOCS are one byte each).
    pub fn c_sdu_layout(&self, iocr: &IocrBlockReq) -> Result<CSduLayout, ConnectError> {
        let mut layout = CSduLayout::new(iocr.data_length)?;
        for api in &iocr.apis {
            for object in &api.io_data {
                let data_length =
                    self.expected_length(api.api, object.slot, object.subslot, iocr.iocr_type)?;
                layout.add_data_object(IoDataObject {
                    frame_offset: object.frame_offset,
                    data_length,
                })?;
            }
            for iocs in &api.iocs {
                layout.add_iocs(iocs.frame_offset)?;
            }
        }
        Ok(layout)
    }

    /// The data length the controller expects from submodule `slot`/`subslot` in the
    /// direction of `iocr_type` (0 for a submodule without data that way).
    fn expected_length(
        &self,
        api: u32,
        slot: u16,
        subslot: u16,
        iocr_type: u16,
    ) -> Result<u16, ConnectError> {
        let submodule = self
            .expected
            .iter()
            .flat_map(|block| &block.apis)
            .filter(|expected| expected.api == api && expected.slot == slot)
            .flat_map(|expected| &expected.submodules)
            .find(|submodule| submodule.subslot == subslot)
            .ok_or(ConnectError::UnexpectedObject { slot, subslot })?;
        let description = if iocr_type == IOCR_TYPE_INPUT {
            submodule.input
        } else {
            submodule.output
        };
        Ok(description.map_or(0, |d| d.data_length))
    }
}

/// The RT class an IOCR asks for (IOCRProperties bits 0..3); `None` for RT_CLASS_3 and
/// RT_CLASS_UDP, which this device does not offer.
pub fn rt_class(iocr: &IocrBlockReq) -> Option<RtClass> {
    match iocr.properties & 0x0f {
        1 => Some(RtClass::One),
        2 => Some(RtClass::Two),
        _ => None,
    }
}

fn once<T>(slot: &mut Option<T>, header: BlockHeader, value: T) -> Result<(), ConnectError> {
    if slot.is_some() {
        return Err(ConnectError::DuplicateBlock(header.block_type));
    }
    *slot = Some(value);
    Ok(())
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::rt::frame::RtFrame;
    use crate::rt::ioxs::Ioxs;
    use crate::testdata;
    use pnio::rpc::Drep;

    /// The RPC PDU of the golden S7-1515 Connect (Ethernet, IPv4 and UDP headers cut).
    pub(crate) fn golden_pdu() -> Vec<u8> {
        testdata::frame("connect_req")[42..].to_vec()
    }

    #[test]
    fn the_golden_s7_connect_parses() {
        let connect = ConnectRequest::parse(&golden_pdu()).unwrap();
        assert_eq!(connect.rpc.drep, Drep::from_byte(0x10));
        assert_eq!(connect.ar.ar_type, AR_TYPE_IOC);
        assert_eq!(connect.ar.ar_properties, 0x4000_0011);
        assert!(connect.startup_advanced());
        assert!(!connect.is_device_access());
        assert_eq!(connect.ar.activity_timeout_factor, 200);
        assert_eq!(
            connect.ar.station_name,
            "plcxbbench.profinetxainterfacexb25fbd"
        );
        let input = connect.iocr(IOCR_TYPE_INPUT).unwrap();
        let output = connect.iocr(IOCR_TYPE_OUTPUT).unwrap();
        assert_eq!((input.frame_id, output.frame_id), (0x8000, 0x8001));
        assert_eq!(rt_class(input), Some(RtClass::Two));
        assert!(RtClass::Two.accepts(input.frame_id));
        // profinet-py's legacy IOCRs say RTClass 1; RT_CLASS_3 and UDP are not offered.
        let mut legacy = input.clone();
        legacy.properties = 1;
        assert_eq!(rt_class(&legacy), Some(RtClass::One));
        for unsupported in [3, 4] {
            legacy.properties = unsupported;
            assert_eq!(rt_class(&legacy), None);
        }
        assert_eq!((input.send_clock_factor, input.reduction_ratio), (32, 32));
        assert_eq!((input.watchdog_factor, input.data_hold_factor), (3, 3));
        assert_eq!(connect.expected.len(), 5);
        assert!(connect.alarm_cr.is_some());
    }

    #[test]
    fn the_layouts_from_the_connect_decode_the_golden_cyclic_frames() {
        let connect = ConnectRequest::parse(&golden_pdu()).unwrap();
        let input = connect
            .c_sdu_layout(connect.iocr(IOCR_TYPE_INPUT).unwrap())
            .unwrap();
        let output = connect
            .c_sdu_layout(connect.iocr(IOCR_TYPE_OUTPUT).unwrap())
            .unwrap();
        assert_eq!(input.data_objects().len(), 6);
        assert_eq!(input.iocs_offsets(), [5, 8, 18]);
        assert_eq!(output.iocs_offsets(), [0, 1, 2, 3, 6, 9]);
        let frame = testdata::frame("rtc_dev_8000");
        let (_, rt) = RtFrame::parse(&frame).unwrap();
        assert_eq!(input.data(rt.c_sdu, 3), Some((&[0x2c][..], Ioxs::GOOD)));
        assert_eq!(input.data(rt.c_sdu, 5), Some((&[0; 8][..], Ioxs::GOOD)));
        let frame = testdata::frame("echo_cpu_8001");
        let (_, rt) = RtFrame::parse(&frame).unwrap();
        let echo = [0x12, 0x34, 0x56, 0x78, 0x3f, 0xc0, 0, 0];
        assert_eq!(output.data(rt.c_sdu, 2), Some((&echo[..], Ioxs::GOOD)));
    }

    /// The golden PDU cut down to its ARBlockReq, turned into a device-access AR: what
    /// profinet-py sends first (no IOCR, no AlarmCR).
    pub(crate) fn device_access_pdu() -> Vec<u8> {
        let golden = golden_pdu();
        let blocks = &golden[RpcHeader::LEN + NdrRequest::LEN..];
        let ar_len = 4 + usize::from(u16::from_be_bytes([blocks[2], blocks[3]]));
        let mut pdu = golden[..RpcHeader::LEN + NdrRequest::LEN].to_vec();
        let mut ar = blocks[..ar_len].to_vec();
        ar[6..8].copy_from_slice(&AR_TYPE_DEVICE_ACCESS.to_be_bytes());
        pdu.extend_from_slice(&ar);
        // NDR ArgsLength and ActualCount (little-endian DREP), and the RPC body length.
        let args = u32::try_from(ar_len).unwrap().to_le_bytes();
        pdu[RpcHeader::LEN + 4..RpcHeader::LEN + 8].copy_from_slice(&args);
        pdu[RpcHeader::LEN + 16..RpcHeader::LEN + 20].copy_from_slice(&args);
        let body = u16::try_from(NdrRequest::LEN + ar_len)
            .unwrap()
            .to_le_bytes();
        pdu[74..76].copy_from_slice(&body);
        pdu
    }

    #[test]
    fn a_device_access_ar_without_iocrs_and_alarm_cr_is_accepted() {
        let connect = ConnectRequest::parse(&device_access_pdu()).unwrap();
        assert!(connect.is_device_access());
        assert!(connect.iocrs.is_empty());
        assert!(connect.expected.is_empty());
        assert_eq!(connect.alarm_cr, None);
        // pnio's own grouping refuses it.
        let blocks = &device_access_pdu()[RpcHeader::LEN + NdrRequest::LEN..];
        assert!(pnio::cm::ConnectReq::parse(blocks).is_err());
    }

    #[test]
    fn other_pdus_are_not_connects() {
        let mut pdu = golden_pdu();
        pdu[68] = 3; // opnum (little-endian DREP): Write
        assert!(matches!(
            ConnectRequest::parse(&pdu),
            Err(ConnectError::NotConnect { opnum: 3, .. })
        ));
        assert!(matches!(
            ConnectRequest::parse(&golden_pdu()[..60]),
            Err(ConnectError::Rpc(_))
        ));
    }

    #[test]
    fn a_truncated_block_is_refused() {
        let mut pdu = golden_pdu();
        let len = pdu.len();
        pdu.truncate(len - 10);
        // The NDR ActualCount now overruns the PDU.
        assert!(ConnectRequest::parse(&pdu).is_err());
    }
}
