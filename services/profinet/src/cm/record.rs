//! Record data: what a Read returns (I&M0 to I&M4, RealIdentificationData, the diagnosis
//! records, the physical-device records of [`super::pd_real`]) and what a Write does with
//! each record (PDInterfaceAdjust, PDPortDataCheck and PDPortDataAdjust kept, I&M1 to I&M4
//! taken, the rest refused by name), with the Write response carrying one PNIOStatus per
//! record. An index this device does not have is answered with PNIOStatus "invalid
//! index" (0xDE/0xDF 0x80 0xB0), never left unanswered.
//!
//! The record codecs of `pnio` parse the requests and encode I&M0; the Write response is
//! written here because `pnio`'s answers every record with OK.

use pnio::cm::block::{BlockHeader, ty};
use pnio::cm::{INDEX_MULTIPLE_WRITE, PnioStatus, ReadReq, Record};
use pnio::im::encode_im0;
pub use pnio::im::{Im0, SwRevision};
use pnio::rpc::Drep;

use super::diagnosis::{DiagnosisRecord, Scope};
use super::im::{IM_SUPPORTED, ImRecords, ImWriteError};
use super::pd_real::{
    INDEX_PD_INTERFACE_DATA_REAL, INDEX_PD_PORT_DATA_REAL, INDEX_PD_REAL_DATA, InterfaceReal,
    PortLink, pd_interface_data_real, pd_port_data_real, pd_real_data,
};
use crate::device::{
    API, DAP_SLOT, DeviceModel, INTERFACE_SUBSLOT, PORT_SUBSLOT, SRCI_SLOT, SRCI_SUBSLOT,
};

/// Index of I&M0.
pub const INDEX_IM0: u16 = 0xaff0;
/// Index of RealIdentificationData for one AR's API (what profinet-py reads to find the
/// slots).
pub const INDEX_REAL_IDENTIFICATION_DATA: u16 = 0xf000;
/// Index of PDInterfaceAdjust (interface submodule).
pub const INDEX_PD_INTERFACE_ADJUST: u16 = 0x8071;
/// Index of PDPortDataCheck (port submodule): the partner port a project expects.
pub const INDEX_PD_PORT_DATA_CHECK: u16 = 0x802b;
/// Index of PDPortDataAdjust (port submodule): boundaries and MAU settings of the port.
pub const INDEX_PD_PORT_DATA_ADJUST: u16 = 0x802f;
/// BlockType of RealIdentificationData.
const BLOCK_REAL_IDENTIFICATION_DATA: u16 = 0x0013;
/// Fixed part of an IODWriteResHeader body after its block header.
const WRITE_RES_BODY_LEN: u16 = 58;

/// The identity a Read of I&M0 reports.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Identification {
    /// VendorID.
    pub vendor_id: u16,
    /// The I&M0 fields.
    pub im0: Im0,
}

impl Identification {
    /// This robot controller's identity, with `serial_number` (cut to the 16 characters
    /// I&M0 holds).
    pub fn robot_controller(serial_number: &str) -> Self {
        Self {
            vendor_id: crate::device::VENDOR_ID,
            im0: Im0 {
                order_id: "rc-srci".into(),
                serial_number: serial_number.chars().take(16).collect(),
                hardware_revision: 1,
                software_revision: SwRevision {
                    prefix: 'V',
                    functional: 0,
                    bug_fix: 1,
                    internal: 0,
                },
                revision_counter: 0,
                profile_id: 0,
                profile_specific_type: 0,
            },
        }
    }
}

/// PNIOStatus of a Read or Write of an index this device does not have.
pub fn invalid_index(write: bool) -> PnioStatus {
    PnioStatus::new(read_write_code(write), 0x80, 0xb0, 0x00)
}

/// PNIOStatus of a Read or Write of a slot or subslot this device does not have.
pub fn invalid_slot(write: bool) -> PnioStatus {
    PnioStatus::new(read_write_code(write), 0x80, 0xb2, 0x00)
}

/// PNIOStatus of a Write whose data has another length than the record's.
fn write_length_error() -> PnioStatus {
    PnioStatus::new(read_write_code(true), 0x80, 0xb1, 0x00)
}

/// PNIOStatus of a Write whose data is not the record's (another block).
fn invalid_parameter() -> PnioStatus {
    PnioStatus::new(read_write_code(true), 0x80, 0xb8, 0x00)
}

/// PNIOStatus.ErrorCode of a failed Read (0xDE) or Write (0xDF).
fn read_write_code(write: bool) -> u8 {
    if write { 0xdf } else { 0xde }
}

/// What a Read answers from, besides the request.
#[derive(Debug, Clone, Copy)]
pub struct RecordSources<'a> {
    /// The submodules.
    pub model: &'a DeviceModel,
    /// I&M0.
    pub identification: &'a Identification,
    /// I&M1 to I&M4.
    pub im: &'a ImRecords,
    /// The robot has an error: the SRCI submodule's diagnosis.
    pub robot_error: bool,
    /// The interface submodule's station name and addresses.
    pub interface: InterfaceReal<'a>,
    /// The port's link.
    pub port: PortLink,
}

/// The record a Read asks for.
pub fn read_record(request: &ReadReq, sources: &RecordSources<'_>) -> Result<Vec<u8>, PnioStatus> {
    let model = sources.model;
    if request.index == INDEX_REAL_IDENTIFICATION_DATA {
        return Ok(real_identification_data(model));
    }
    if let Some(record) = DiagnosisRecord::at(request.index) {
        let known = match record.scope {
            Scope::Subslot => model.submodule(request.slot, request.subslot).is_some(),
            Scope::Slot => model.submodules().iter().any(|s| s.slot == request.slot),
            Scope::Api => request.api == API,
            Scope::Ar | Scope::Device => true,
        };
        let srci = model.submodule(SRCI_SLOT, SRCI_SUBSLOT);
        return match srci {
            Some(srci) if known => {
                let address = (request.api, request.slot, request.subslot);
                Ok(record.data(address, srci, sources.robot_error))
            }
            _ => Err(invalid_slot(false)),
        };
    }
    if request.api != API || model.submodule(request.slot, request.subslot).is_none() {
        return Err(invalid_slot(false));
    }
    match (request.slot, request.subslot, request.index) {
        (_, _, INDEX_PD_REAL_DATA) => Ok(pd_real_data(&sources.interface, sources.port)),
        (DAP_SLOT, INTERFACE_SUBSLOT, INDEX_PD_INTERFACE_DATA_REAL) => {
            Ok(pd_interface_data_real(&sources.interface))
        }
        (DAP_SLOT, PORT_SUBSLOT, INDEX_PD_PORT_DATA_REAL) => Ok(pd_port_data_real(sources.port)),
        (_, _, INDEX_IM0) => Ok(encode_im0(
            sources.identification.vendor_id,
            &sources.identification.im0,
            IM_SUPPORTED,
        )),
        (_, _, index) => sources.im.read(index).ok_or(invalid_index(false)),
    }
}

/// RealIdentificationData version 1.1: every slot with its module and submodules.
pub fn real_identification_data(model: &DeviceModel) -> Vec<u8> {
    let submodules = model.submodules();
    let mut slots: Vec<u16> = submodules.iter().map(|s| s.slot).collect();
    slots.dedup();
    let mut body = Vec::new();
    body.extend_from_slice(&1u16.to_be_bytes());
    body.extend_from_slice(&API.to_be_bytes());
    body.extend_from_slice(&count(slots.len()).to_be_bytes());
    for slot in slots {
        let in_slot: Vec<_> = submodules.iter().filter(|s| s.slot == slot).collect();
        body.extend_from_slice(&slot.to_be_bytes());
        body.extend_from_slice(&in_slot[0].module_ident.to_be_bytes());
        body.extend_from_slice(&count(in_slot.len()).to_be_bytes());
        for submodule in in_slot {
            body.extend_from_slice(&submodule.subslot.to_be_bytes());
            body.extend_from_slice(&submodule.submodule_ident.to_be_bytes());
        }
    }
    let mut out = Vec::with_capacity(BlockHeader::LEN + body.len());
    out.extend_from_slice(&BLOCK_REAL_IDENTIFICATION_DATA.to_be_bytes());
    out.extend_from_slice(&count(body.len() + 2).to_be_bytes());
    out.extend_from_slice(&[1, 1]);
    out.extend_from_slice(&body);
    out
}

/// The device model has four submodules; the counts and lengths here stay tiny.
fn count(n: usize) -> u16 {
    u16::try_from(n).unwrap_or(u16::MAX)
}

/// What the device keeps from a controller's Writes.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct WrittenRecords {
    /// The last PDInterfaceAdjust record (its data, block header included).
    pub pd_interface_adjust: Option<Vec<u8>>,
    /// The last PDPortDataCheck record. Kept, not checked: without LLDP the device knows
    /// no neighbour to compare, and refusing it would fail the start-up of a project that
    /// configures the partner port.
    pub pd_port_data_check: Option<Vec<u8>>,
    /// The last PDPortDataAdjust record, kept as written (the port has no settings to
    /// adjust: boundaries concern multicast forwarding of a switch port, which it is not).
    pub pd_port_data_adjust: Option<Vec<u8>>,
}

/// Applies one record of a Write and returns its status: PDInterfaceAdjust on the
/// interface submodule and PDPortDataCheck/PDPortDataAdjust on the port submodule are
/// kept, I&M1 to I&M4 (on any submodule, one set per device) go
/// to `im`; records of submodules this device does not have, and indices it does not
/// know, are refused.
pub fn write_record(
    record: &Record,
    model: &DeviceModel,
    kept: &mut WrittenRecords,
    im: &mut ImRecords,
) -> PnioStatus {
    if record.api != API || model.submodule(record.slot, record.subslot).is_none() {
        return invalid_slot(true);
    }
    if let Some(written) = im.write(record.index, &record.data) {
        return match written {
            Ok(_) => PnioStatus::OK,
            Err(ImWriteError::Block(_)) => invalid_parameter(),
            Err(ImWriteError::Length { .. }) => write_length_error(),
        };
    }
    match (record.subslot, record.index) {
        (INTERFACE_SUBSLOT, INDEX_PD_INTERFACE_ADJUST) => {
            kept.pd_interface_adjust = Some(record.data.clone());
            PnioStatus::OK
        }
        (PORT_SUBSLOT, INDEX_PD_PORT_DATA_CHECK) => {
            kept.pd_port_data_check = Some(record.data.clone());
            PnioStatus::OK
        }
        (PORT_SUBSLOT, INDEX_PD_PORT_DATA_ADJUST) => {
            kept.pd_port_data_adjust = Some(record.data.clone());
            PnioStatus::OK
        }
        _ => invalid_index(true),
    }
}

/// The Write response blocks: one IODWriteResHeader per record, in request order, the
/// MultipleWrite container's first (always OK: its own statuses are per record).
pub fn write_response(records: &[(Record, PnioStatus)]) -> Vec<u8> {
    let mut out = Vec::with_capacity(records.len() * 64);
    for (record, status) in records {
        BlockHeader::write(&mut out, ty::IOD_WRITE_RES_HEADER, WRITE_RES_BODY_LEN);
        out.extend_from_slice(&record.seq.to_be_bytes());
        record.ar_uuid.write(&mut out, Drep::BIG);
        out.extend_from_slice(&record.api.to_be_bytes());
        out.extend_from_slice(&record.slot.to_be_bytes());
        out.extend_from_slice(&record.subslot.to_be_bytes());
        out.extend_from_slice(&[0; 2]);
        out.extend_from_slice(&record.index.to_be_bytes());
        // RecordDataLength and AdditionalValue1/2.
        out.extend_from_slice(&[0; 8]);
        out.extend_from_slice(&status.to_u32().to_be_bytes());
        out.extend_from_slice(&[0; 16]);
    }
    out
}

/// True for the MultipleWrite container record.
pub fn is_multiple_write(record: &Record) -> bool {
    record.index == INDEX_MULTIPLE_WRITE
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::device::{DAP_SLOT, DAP_SUBSLOT, SRCI_SLOT};
    use crate::rt::c_sdu::SrciModuleSize;
    use crate::testdata;
    use pnio::cm::WriteReq;
    use pnio::rpc::{NdrRequest, RpcHeader};

    fn model() -> DeviceModel {
        DeviceModel::srci(SrciModuleSize::Bytes256)
    }

    /// Reads `request` from this device with p-net's identity, blank I&M1..4 and the
    /// robot error `robot_error`.
    fn read(request: &ReadReq, robot_error: bool) -> Result<Vec<u8>, PnioStatus> {
        let identification = p_net_identification();
        let sources = RecordSources {
            model: &model(),
            identification: &identification,
            im: &ImRecords::default(),
            robot_error,
            interface: interface(),
            port: PortLink::default(),
        };
        read_record(request, &sources)
    }

    /// The interface the reads of [`read`] report.
    fn interface() -> InterfaceReal<'static> {
        InterfaceReal {
            chassis_id: "rc-robot",
            mac: crate::ethernet::MacAddress([2, 0, 0, 0, 0, 1]),
            ip: crate::dcp::station::IpParameter::UNSET,
        }
    }

    /// The PNIO blocks of a golden request.
    fn blocks(name: &str) -> Vec<u8> {
        testdata::frame(name)[42 + RpcHeader::LEN + NdrRequest::LEN..].to_vec()
    }

    /// p-net's identity in the golden I&M0 response.
    pub(crate) fn p_net_identification() -> Identification {
        Identification {
            vendor_id: 0x0493,
            im0: Im0 {
                order_id: "12345 Abcdefghijk".into(),
                serial_number: "007".into(),
                hardware_revision: 3,
                software_revision: SwRevision {
                    prefix: 'V',
                    functional: 0,
                    bug_fix: 2,
                    internal: 0,
                },
                revision_counter: 0,
                profile_id: 0x1234,
                profile_specific_type: 0x5678,
            },
        }
    }

    #[test]
    fn i_and_m0_is_read_on_a_known_submodule_only() {
        let request = ReadReq::parse(&blocks("im0_read_req")).unwrap();
        assert_eq!((request.slot, request.subslot), (DAP_SLOT, DAP_SUBSLOT));
        let record = read(&request, false).unwrap();
        let golden = testdata::frame("im0_read_res");
        // The golden I&M0 says IM_Supported 0x000E (p-net has I&M1..3); this device
        // has I&M1..4.
        assert_eq!(record[..58], golden[golden.len() - 60..golden.len() - 2]);
        assert_eq!(record[58..], [0, 0x1e]);
        let mut elsewhere = request.clone();
        elsewhere.slot = 7;
        assert_eq!(read(&elsewhere, false), Err(invalid_slot(false)));
        let mut other = request;
        for index in [0xaff5, 0x802a, 0x8080, 0x8028, 0x1234] {
            other.index = index;
            assert_eq!(
                read(&other, false),
                Err(invalid_index(false)),
                "{index:#06x}"
            );
        }
    }

    #[test]
    fn i_and_m1_to_4_are_read_and_written_on_every_submodule() {
        let mut request = ReadReq::parse(&blocks("im0_read_req")).unwrap();
        request.index = crate::cm::im::INDEX_IM3;
        let blank = read(&request, false).unwrap();
        assert_eq!(blank[..6], [0x00, 0x23, 0x00, 56, 1, 0]);
        let write = WriteReq::parse(&blocks("write_req")).unwrap();
        let mut record = write.records[1].clone();
        (record.slot, record.subslot) = (SRCI_SLOT, 1);
        record.index = crate::cm::im::INDEX_IM3;
        record.data = blank.clone();
        record.data[6..].fill(b'x');
        let mut im = ImRecords::default();
        let mut kept = WrittenRecords::default();
        let status = write_record(&record, &model(), &mut kept, &mut im);
        assert_eq!(status, PnioStatus::OK);
        assert_eq!(im.read(record.index), Some(record.data.clone()));
        // Another block, another length: refused, nothing changes.
        let mut wrong = record.clone();
        wrong.index = crate::cm::im::INDEX_IM1;
        assert_eq!(
            write_record(&wrong, &model(), &mut kept, &mut im),
            invalid_parameter()
        );
        wrong.index = record.index;
        wrong.data.pop();
        wrong.data[3] -= 1;
        assert_eq!(
            write_record(&wrong, &model(), &mut kept, &mut im),
            write_length_error()
        );
        assert_eq!(im.read(record.index), Some(record.data));
    }

    #[test]
    fn the_diagnosis_records_report_the_robot_error() {
        let mut request = ReadReq::parse(&blocks("im0_read_req")).unwrap();
        (request.slot, request.subslot, request.index) = (SRCI_SLOT, 1, 0x800a);
        assert_eq!(read(&request, false), Ok(Vec::new()));
        let diagnosis = read(&request, true).unwrap();
        assert_eq!(diagnosis[..2], [0x00, 0x10]);
        (request.slot, request.subslot, request.index) = (0, 0, 0xf80c);
        assert_eq!(read(&request, true), Ok(diagnosis));
        // A subslot or slot the device does not have.
        (request.slot, request.subslot, request.index) = (1, 2, 0x800a);
        assert_eq!(read(&request, true), Err(invalid_slot(false)));
        (request.slot, request.index) = (5, 0xc00a);
        assert_eq!(read(&request, true), Err(invalid_slot(false)));
    }

    #[test]
    fn the_physical_device_records_are_read_where_they_belong() {
        let mut request = ReadReq::parse(&blocks("im0_read_req")).unwrap();
        // PDRealData on the DAP, as profinet-py reads it, and on the SRCI submodule.
        for (slot, subslot) in [(DAP_SLOT, DAP_SUBSLOT), (SRCI_SLOT, SRCI_SUBSLOT)] {
            (request.slot, request.subslot, request.index) = (slot, subslot, 0xf841);
            let expected = pd_real_data(&interface(), PortLink::default());
            assert_eq!(read(&request, false), Ok(expected));
        }
        (request.slot, request.subslot, request.index) = (DAP_SLOT, INTERFACE_SUBSLOT, 0x8080);
        let expected = pd_interface_data_real(&interface());
        assert_eq!(read(&request, false), Ok(expected));
        (request.slot, request.subslot, request.index) = (DAP_SLOT, PORT_SUBSLOT, 0x802a);
        let expected = pd_port_data_real(PortLink::default());
        assert_eq!(read(&request, false), Ok(expected));
        // Each on its own submodule only.
        request.subslot = INTERFACE_SUBSLOT;
        assert_eq!(read(&request, false), Err(invalid_index(false)));
        (request.subslot, request.index) = (PORT_SUBSLOT, 0x8080);
        assert_eq!(read(&request, false), Err(invalid_index(false)));
    }

    #[test]
    fn the_robot_controller_s_serial_number_is_cut_to_what_i_and_m0_holds() {
        let im0 = Identification::robot_controller("a serial number longer than 16").im0;
        assert_eq!(im0.serial_number, "a serial number ");
        im0.validate().unwrap();
    }

    #[test]
    fn real_identification_data_lists_every_slot_and_subslot() {
        let data = real_identification_data(&model());
        let body = &data[BlockHeader::LEN..];
        // Type 0x0013, the length after it, version 1.1.
        let length = u16::try_from(body.len() + 2).unwrap().to_be_bytes();
        assert_eq!(data[..6], [0, 0x13, length[0], length[1], 1, 1]);
        #[rustfmt::skip]
        let expected = [
            0, 1, 0, 0, 0, 0, 0, 2, // one API (0) with two slots
            0, 0, 0, 0, 0, 1, 0, 3, // slot 0: DAP, three submodules
            0, 1, 0, 0, 0, 1, 0x80, 0, 0, 0, 0x80, 0, 0x80, 1, 0, 0, 0x80, 1,
            0, 1, 0, 1, 1, 0, 0, 1, // slot 1: SRCI 256, one submodule
            0, 1, 0, 1, 1, 0,
        ];
        assert_eq!(body, expected);
        assert_eq!(SRCI_SLOT, 1);
    }

    #[test]
    fn pd_interface_adjust_is_kept_and_foreign_records_are_refused() {
        let request = WriteReq::parse(&blocks("write_req")).unwrap();
        let mut kept = WrittenRecords::default();
        let answered: Vec<(Record, PnioStatus)> = request
            .records
            .iter()
            .map(|record| {
                let status = if is_multiple_write(record) {
                    PnioStatus::OK
                } else {
                    write_record(record, &model(), &mut kept, &mut ImRecords::default())
                };
                (record.clone(), status)
            })
            .collect();
        let adjust = request
            .records
            .iter()
            .find(|r| r.index == INDEX_PD_INTERFACE_ADJUST)
            .unwrap();
        assert_eq!(kept.pd_interface_adjust.as_ref(), Some(&adjust.data));
        // p-net's slots 3 and 4 do not exist here: their records get "invalid slot"
        // where p-net said OK; everything else is p-net's response byte for byte.
        let ours = write_response(&answered);
        let golden = testdata::frame("write_res");
        let golden = &golden[golden.len() - ours.len()..];
        for (i, (record, status)) in answered.iter().enumerate() {
            let (ours, golden) = (&ours[i * 64..][..64], &golden[i * 64..][..64]);
            assert_eq!(ours[..44], golden[..44]);
            assert_eq!(ours[48..], golden[48..]);
            assert_eq!(ours[44..48], status.to_u32().to_be_bytes());
            let foreign = record.slot == 3 || record.slot == 4;
            assert_eq!(*status != PnioStatus::OK, foreign, "{record:?}");
        }
    }

    #[test]
    fn the_port_s_expected_topology_is_kept_on_the_port_only() {
        let mut kept = WrittenRecords::default();
        let mut im = ImRecords::default();
        let record = |subslot, index| Record {
            seq: 0,
            ar_uuid: pnio::rpc::uuid::Uuid::NIL,
            api: API,
            slot: DAP_SLOT,
            subslot,
            index,
            data: vec![
                0x02, 0x00, 0x00, 0x08, 0x01, 0x00, 0x00, 0x00, 0x80, 0x01, 0x00, 0x00,
            ],
        };
        for index in [INDEX_PD_PORT_DATA_CHECK, INDEX_PD_PORT_DATA_ADJUST] {
            let written = record(PORT_SUBSLOT, index);
            assert_eq!(
                write_record(&written, &model(), &mut kept, &mut im),
                PnioStatus::OK
            );
            assert_ne!(
                write_record(
                    &record(INTERFACE_SUBSLOT, index),
                    &model(),
                    &mut kept,
                    &mut im
                ),
                PnioStatus::OK
            );
        }
        let expected = Some(record(PORT_SUBSLOT, 0).data);
        assert_eq!(kept.pd_port_data_check, expected);
        assert_eq!(kept.pd_port_data_adjust, expected);
    }
}
