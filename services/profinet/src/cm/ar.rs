//! The application relations (ARs) of the device: the connection-management state
//! machine behind UDP port 34964, pure (datagrams and the time come in as arguments).
//!
//! One IO AR (ARType 1) and one supervisor's device-access AR (ARType 6) may exist at
//! the same time; profinet-py opens the second, reads RealIdentificationData, releases it
//! and connects again with IOCRs. The IO AR goes
//!
//! ```text
//! Connect ──▶ Parameterising ──PrmEnd──▶ ApplicationReady (the device's request,
//!             (Writes)                    resent until confirmed) ──Done──▶ Data
//! ```
//!
//! and ends with Release, with an unanswered ApplicationReady, with [`Cm::abort`] (the
//! consumer's watchdog) or with a new Connect from the same controller (a controller that
//! restarted). A Connect from another controller while an IO AR exists is refused.

use std::net::SocketAddr;
use std::time::Duration;

use pnio::cm::block::ty;
use pnio::cm::{
    ConnectBlock, ControlBlock, PnioStatus, ReadReq, WriteReq, app_ready_req, build_read_res, cmd,
    prm_end_done, release_done,
};
use pnio::rpc::{Opnum, PNIO_CONTROLLER_INTERFACE, PNIO_UDP_PORT, RpcError, RpcHeader, Uuid};

use super::connect::{
    AR_TYPE_DEVICE_ACCESS, AR_TYPE_IOC, ConnectError, ConnectRequest, IOCR_TYPE_INPUT,
    IOCR_TYPE_OUTPUT,
};
use super::connect_response::{ConnectAnswer, LOCAL_ALARM_REFERENCE, connect_response_blocks};
use super::im::ImRecords;
use super::iocr::{AcceptedIocr, IocrRefusal, accept_iocr};
use super::module_diff::{SubmoduleDiff, module_diff};
use super::pd_real::{InterfaceReal, PortLink};
use super::record::{self, Identification, RecordSources, WrittenRecords};
use super::rpc::{self, Call, RpcPdu};
use crate::alarm::AlarmCr;
use crate::dcp::station::IpParameter;
use crate::device::{DeviceModel, SRCI_SLOT, SRCI_SUBSLOT};
use crate::ethernet::MacAddress;
use crate::rt::c_sdu::CSduLayout;
use crate::rt::cyclic::CrConfig;

/// Time between two ApplicationReady requests the controller does not confirm.
pub const APPLICATION_READY_RETRY: Duration = Duration::from_secs(1);
/// ApplicationReady requests sent before the AR is given up.
pub const APPLICATION_READY_ATTEMPTS: u8 = 5;
/// The longest alarm data this device sends (p-net's value).
const MAX_ALARM_DATA_LENGTH: u16 = 200;
/// ARBlockReq field ARType (PNIOStatus.ErrorCode2 of a refused Connect).
const FIELD_AR_TYPE: u8 = 4;
/// IOCRBlockReq field IOCRType: also named when an input or output CR is missing.
const FIELD_IOCR_TYPE: u8 = 4;
/// PNIOStatus.ErrorCode of a failed Release and of a failed Control.
const CODE_RELEASE: u8 = 0xdc;
const CODE_CONTROL: u8 = 0xdd;

/// What the device tells the controller about itself in CM.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CmDevice {
    /// The submodules.
    pub model: DeviceModel,
    /// What a Read of I&M0 returns.
    pub identification: Identification,
    /// I&M1 to I&M4 as stored (the controller may write them).
    pub im: ImRecords,
    /// The device's MAC address.
    pub mac: MacAddress,
    /// The device's activity for its own calls (ApplicationReady); unique per start.
    pub activity: Uuid,
}

/// One CR of the IO AR, as the cyclic engine needs it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CyclicCr {
    /// FrameID, times and RT class.
    pub accepted: AcceptedIocr,
    /// Where each object sits in the C_SDU.
    pub layout: CSduLayout,
    /// The index in `layout` of the SRCI submodule's data object; `None` when the
    /// controller does not exchange the SRCI module's data in this CR.
    pub srci_object: Option<usize>,
}

impl CyclicCr {
    /// The CR as the cyclic engine runs it.
    pub fn config(&self) -> CrConfig {
        CrConfig {
            frame_id: self.accepted.frame_id,
            timing: self.accepted.timing,
            layout: self.layout,
            srci_object: self.srci_object,
        }
    }
}

/// The cyclic exchange an IO AR sets up.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CyclicExchange {
    /// The controller's MAC address (destination of the input frames).
    pub controller_mac: MacAddress,
    /// The input CR (device → controller).
    pub input: CyclicCr,
    /// The output CR (controller → device).
    pub output: CyclicCr,
    /// The expected submodules that differ from the device (the ModuleDiffBlock).
    pub module_diff: Vec<SubmoduleDiff>,
    /// The alarm CR, when the controller asked for one.
    pub alarm_cr: Option<AlarmCr>,
}

/// Why an IO AR ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ArEnd {
    /// The controller released it.
    Released,
    /// The controller never confirmed ApplicationReady.
    ApplicationReadyUnanswered,
    /// The device aborted it (the consumer's watchdog or data-hold time expired).
    Aborted,
    /// The same controller connected again.
    Replaced,
}

/// What happened to the IO AR.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum CmEvent {
    /// An IO AR was established: provide input frames and consume output frames.
    Connected(Box<CyclicExchange>),
    /// The controller ended parameterisation.
    ParameterisationEnded,
    /// The controller confirmed ApplicationReady: the AR is in data exchange.
    DataExchange,
    /// The IO AR ended.
    Ended(ArEnd),
    /// A controller wrote I&M1..4 with new values: the shell keeps them
    /// ([`Cm::im_records`]).
    ImWritten,
}

/// A datagram to send.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Datagram {
    /// Where to.
    pub to: SocketAddr,
    /// The UDP payload.
    pub pdu: Vec<u8>,
}

/// What one input to the state machine produced.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct CmOutput {
    /// A datagram to send, if any.
    pub datagram: Option<Datagram>,
    /// Events, in order.
    pub events: Vec<CmEvent>,
}

/// A datagram that is not a PNIO-CM call this device can answer at all.
#[derive(Debug, thiserror::Error)]
pub enum CmError {
    /// The DCE/RPC envelope is broken.
    #[error("DCE/RPC: {0}")]
    Rpc(#[from] RpcError),
    /// A Connect request is broken.
    #[error("Connect: {0}")]
    Connect(#[from] ConnectError),
}

/// The state of the IO AR.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum ArState {
    /// Connected; Writes are taken until PrmEnd.
    Parameterising,
    /// PrmEnd answered; ApplicationReady goes out at `due`, as call `seq_num`.
    ApplicationReady {
        attempts: u8,
        due: Duration,
        seq_num: u32,
    },
    /// ApplicationReady confirmed.
    Data,
}

/// An established IO AR.
#[derive(Debug, Clone)]
struct IoAr {
    uuid: Uuid,
    session_key: u16,
    controller_mac: MacAddress,
    controller_object: Uuid,
    controller: SocketAddr,
    state: ArState,
}

/// The last answered call, answered again when the controller repeats it.
#[derive(Debug, Clone)]
struct Answered {
    activity: Uuid,
    seq_num: u32,
    datagram: Datagram,
}

/// The connection manager.
#[derive(Debug, Clone)]
pub struct Cm {
    device: CmDevice,
    name_of_station: String,
    io_ar: Option<IoAr>,
    supervisor_ar: Option<Uuid>,
    written: WrittenRecords,
    next_seq_num: u32,
    answered: Option<Answered>,
    robot_error: bool,
    /// The interface's IP parameter, as PDInterfaceDataReal reports it.
    ip: IpParameter,
    /// The port's link, as PDPortDataReal reports it.
    port: PortLink,
}

impl Cm {
    /// A device without ARs.
    pub fn new(device: CmDevice, name_of_station: &str) -> Self {
        Self {
            device,
            name_of_station: name_of_station.to_owned(),
            io_ar: None,
            supervisor_ar: None,
            written: WrittenRecords::default(),
            next_seq_num: 0,
            answered: None,
            robot_error: false,
            ip: IpParameter::UNSET,
            port: PortLink::default(),
        }
    }

    /// The interface's IP parameter now (DCP or the configuration set it).
    pub fn set_ip(&mut self, ip: IpParameter) {
        self.ip = ip;
    }

    /// The port's link now, as the interface reports it.
    pub fn set_port_link(&mut self, link: PortLink) {
        self.port = link;
    }

    /// Whether the robot has an error now: the diagnosis records report it.
    pub fn set_robot_error(&mut self, error: bool) {
        self.robot_error = error;
    }

    /// I&M1 to I&M4 as the controllers wrote them.
    pub fn im_records(&self) -> &ImRecords {
        &self.device.im
    }

    /// The NameOfStation reported in the Connect response (DCP may change it).
    pub fn set_name_of_station(&mut self, name: &str) {
        name.clone_into(&mut self.name_of_station);
    }

    /// The device model the ARs are checked against.
    pub fn model(&self) -> &DeviceModel {
        &self.device.model
    }

    /// What the controller wrote and the device keeps.
    pub fn written(&self) -> &WrittenRecords {
        &self.written
    }

    /// True while an IO AR exchanges data (ApplicationReady confirmed).
    pub fn in_data_exchange(&self) -> bool {
        self.io_ar
            .as_ref()
            .is_some_and(|ar| ar.state == ArState::Data)
    }

    /// Handles a datagram from `from` at `now` (a monotonic time).
    pub fn on_datagram(
        &mut self,
        pdu: &[u8],
        from: SocketAddr,
        now: Duration,
    ) -> Result<CmOutput, CmError> {
        match rpc::parse(pdu)? {
            RpcPdu::Request {
                header,
                args_max,
                blocks,
            } => {
                if let Some(answered) = &self.answered
                    && answered.activity == header.activity
                    && answered.seq_num == header.seq_num
                {
                    return Ok(CmOutput {
                        datagram: Some(answered.datagram.clone()),
                        events: Vec::new(),
                    });
                }
                let (status, blocks, events) = self.request(&header, pdu, blocks, from, now)?;
                let datagram = Datagram {
                    to: from,
                    pdu: rpc::response(&header, args_max, status, &blocks),
                };
                self.answered = Some(Answered {
                    activity: header.activity,
                    seq_num: header.seq_num,
                    datagram: datagram.clone(),
                });
                Ok(CmOutput {
                    datagram: Some(datagram),
                    events,
                })
            }
            RpcPdu::Response {
                header,
                status,
                blocks,
            } => Ok(self.confirmation(&header, status, blocks)),
            RpcPdu::Other(_) => Ok(CmOutput::default()),
        }
    }

    /// Sends ApplicationReady when it is due, and gives the AR up when the controller
    /// never confirms it.
    pub fn poll(&mut self, now: Duration) -> CmOutput {
        let Some(ar) = &mut self.io_ar else {
            return CmOutput::default();
        };
        let ArState::ApplicationReady {
            attempts,
            due,
            seq_num,
        } = ar.state
        else {
            return CmOutput::default();
        };
        if now < due {
            return CmOutput::default();
        }
        if attempts >= APPLICATION_READY_ATTEMPTS {
            self.io_ar = None;
            return ended(ArEnd::ApplicationReadyUnanswered);
        }
        ar.state = ArState::ApplicationReady {
            attempts: attempts + 1,
            due: now + APPLICATION_READY_RETRY,
            seq_num,
        };
        let mut blocks = Vec::new();
        app_ready_req(ar.uuid, ar.session_key).write(&mut blocks);
        let call = Call {
            object: ar.controller_object,
            interface: PNIO_CONTROLLER_INTERFACE,
            activity: self.device.activity,
            seq_num,
            opnum: Opnum::Control.to_u16(),
        };
        CmOutput {
            datagram: Some(Datagram {
                to: SocketAddr::new(ar.controller.ip(), PNIO_UDP_PORT),
                pdu: rpc::request(&call, &blocks),
            }),
            events: Vec::new(),
        }
    }

    /// Ends the IO AR from the device side (the consumer's watchdog or data-hold time
    /// expired); the controller notices by its own watchdog and connects again.
    pub fn abort(&mut self) -> CmOutput {
        if self.io_ar.take().is_some() {
            ended(ArEnd::Aborted)
        } else {
            CmOutput::default()
        }
    }

    fn request(
        &mut self,
        header: &RpcHeader,
        pdu: &[u8],
        blocks: &[u8],
        from: SocketAddr,
        now: Duration,
    ) -> Result<(PnioStatus, Vec<u8>, Vec<CmEvent>), CmError> {
        Ok(match Opnum::from_u16(header.opnum) {
            Some(Opnum::Connect) => self.connect(&ConnectRequest::parse(pdu)?, from),
            Some(Opnum::Release) => self.release(blocks),
            Some(Opnum::Read) => {
                let (status, blocks) = self.read(blocks, true);
                (status, blocks, Vec::new())
            }
            Some(Opnum::ReadImplicit) => {
                let (status, blocks) = self.read(blocks, false);
                (status, blocks, Vec::new())
            }
            Some(Opnum::Write) => {
                let before = self.device.im.clone();
                let (status, blocks) = self.write(blocks);
                let events = if self.device.im == before {
                    Vec::new()
                } else {
                    vec![CmEvent::ImWritten]
                };
                (status, blocks, events)
            }
            Some(Opnum::Control) => self.control(blocks, now),
            None => (PnioStatus::service_unsupported(), Vec::new(), Vec::new()),
        })
    }

    fn connect(
        &mut self,
        request: &ConnectRequest,
        from: SocketAddr,
    ) -> (PnioStatus, Vec<u8>, Vec<CmEvent>) {
        let mut events = Vec::new();
        let (frame_ids, differences) = match request.ar.ar_type {
            AR_TYPE_DEVICE_ACCESS => {
                self.supervisor_ar = Some(request.ar.ar_uuid);
                (Vec::new(), Vec::new())
            }
            AR_TYPE_IOC => {
                let controller_mac = MacAddress(request.ar.initiator_mac.0);
                if let Some(existing) = &self.io_ar {
                    if existing.controller_mac != controller_mac {
                        return (PnioStatus::connect_ar_already_exists(), vec![], events);
                    }
                    self.io_ar = None;
                    events.push(CmEvent::Ended(ArEnd::Replaced));
                }
                let exchange = match self.cyclic_exchange(request, controller_mac) {
                    Ok(exchange) => exchange,
                    Err(status) => return (status, vec![], events),
                };
                let frame_ids = request
                    .iocrs
                    .iter()
                    .map(|iocr| {
                        if iocr.iocr_type == IOCR_TYPE_INPUT {
                            exchange.input.accepted.frame_id
                        } else {
                            exchange.output.accepted.frame_id
                        }
                    })
                    .collect();
                self.io_ar = Some(IoAr {
                    uuid: request.ar.ar_uuid,
                    session_key: request.ar.session_key,
                    controller_mac,
                    controller_object: request.ar.initiator_object_uuid,
                    controller: from,
                    state: ArState::Parameterising,
                });
                self.written = WrittenRecords::default();
                let differences = exchange.module_diff.clone();
                events.push(CmEvent::Connected(Box::new(exchange)));
                (frame_ids, differences)
            }
            _ => {
                let status = PnioStatus::connect_reject(ConnectBlock::ArBlock, FIELD_AR_TYPE);
                return (status, vec![], events);
            }
        };
        let answer = ConnectAnswer {
            frame_ids: &frame_ids,
            device_mac: self.device.mac,
            name_of_station: &self.name_of_station,
            max_alarm_data_length: MAX_ALARM_DATA_LENGTH,
            module_diff: &differences,
        };
        match connect_response_blocks(request, &answer) {
            Ok(blocks) => (PnioStatus::OK, blocks, events),
            Err(_) => {
                let status = PnioStatus::connect_reject(ConnectBlock::ArBlock, FIELD_AR_TYPE);
                (status, vec![], events)
            }
        }
    }

    /// Checks the IOCRs of an IO AR and fixes their FrameIDs and layouts.
    fn cyclic_exchange(
        &self,
        request: &ConnectRequest,
        controller_mac: MacAddress,
    ) -> Result<CyclicExchange, PnioStatus> {
        let refuse_iocr = |field| PnioStatus::connect_reject(ConnectBlock::IocrBlock, field);
        let (Some(input), Some(output)) = (
            request.iocr(IOCR_TYPE_INPUT),
            request.iocr(IOCR_TYPE_OUTPUT),
        ) else {
            return Err(refuse_iocr(FIELD_IOCR_TYPE));
        };
        let accepted_input = accept_iocr(input, &[]).map_err(|r| refuse_iocr(iocr_field(r)))?;
        let accepted_output = accept_iocr(output, &[accepted_input.frame_id])
            .map_err(|r| refuse_iocr(iocr_field(r)))?;
        let cr = |iocr, accepted| -> Result<CyclicCr, PnioStatus> {
            let layout = request
                .c_sdu_layout(iocr)
                .map_err(|_| PnioStatus::connect_reject(ConnectBlock::ExpectedSubmodule, 0))?;
            let srci_object = srci_object(iocr, &layout, &self.device.model, request);
            Ok(CyclicCr {
                accepted,
                layout,
                srci_object,
            })
        };
        Ok(CyclicExchange {
            controller_mac,
            input: cr(input, accepted_input)?,
            output: cr(output, accepted_output)?,
            module_diff: module_diff(&request.expected, &self.device.model),
            alarm_cr: request
                .alarm_cr
                .as_ref()
                .map(|cr| AlarmCr::negotiated(cr, LOCAL_ALARM_REFERENCE, MAX_ALARM_DATA_LENGTH)),
        })
    }

    fn release(&mut self, blocks: &[u8]) -> (PnioStatus, Vec<u8>, Vec<CmEvent>) {
        let wrong = || PnioStatus::new(CODE_RELEASE, 0x81, 0x3d, 0x03);
        let Ok(control) = ControlBlock::parse(blocks) else {
            return (wrong(), vec![], vec![]);
        };
        if control.block_type != ty::RELEASE_BLOCK_REQ || control.command != cmd::RELEASE {
            return (wrong(), vec![], vec![]);
        }
        let mut events = Vec::new();
        if self.supervisor_ar == Some(control.ar_uuid) {
            self.supervisor_ar = None;
        } else if self
            .io_ar
            .as_ref()
            .is_some_and(|ar| ar.uuid == control.ar_uuid && ar.session_key == control.session_key)
        {
            self.io_ar = None;
            events.push(CmEvent::Ended(ArEnd::Released));
        } else {
            return (wrong(), vec![], vec![]);
        }
        let mut out = Vec::new();
        release_done(&control).write(&mut out);
        (PnioStatus::OK, out, events)
    }

    /// A Read; an explicit one (`explicit`) must name an existing AR.
    fn read(&self, blocks: &[u8], explicit: bool) -> (PnioStatus, Vec<u8>) {
        let Ok(request) = ReadReq::parse(blocks) else {
            return (record::invalid_index(false), vec![]);
        };
        if explicit && !self.knows_ar(request.ar_uuid) {
            return (PnioStatus::read_wrong_ar(), vec![]);
        }
        let sources = RecordSources {
            model: &self.device.model,
            identification: &self.device.identification,
            im: &self.device.im,
            robot_error: self.robot_error,
            interface: InterfaceReal {
                chassis_id: &self.name_of_station,
                mac: self.device.mac,
                ip: self.ip,
            },
            port: self.port,
        };
        match record::read_record(&request, &sources) {
            Ok(data) => (PnioStatus::OK, build_read_res(&request, &data)),
            Err(status) => (status, vec![]),
        }
    }

    fn write(&mut self, blocks: &[u8]) -> (PnioStatus, Vec<u8>) {
        let Ok(request) = WriteReq::parse(blocks) else {
            return (record::invalid_index(true), vec![]);
        };
        if !request.records.iter().all(|r| self.knows_ar(r.ar_uuid)) {
            return (PnioStatus::write_wrong_ar(), vec![]);
        }
        let answered: Vec<_> = request
            .records
            .into_iter()
            .map(|record| {
                let status = if record::is_multiple_write(&record) {
                    PnioStatus::OK
                } else {
                    let device = &mut self.device;
                    record::write_record(&record, &device.model, &mut self.written, &mut device.im)
                };
                (record, status)
            })
            .collect();
        // A single record's failure is the call's; a MultipleWrite reports per record.
        match answered.as_slice() {
            [(_, status)] if !status.is_ok() => (*status, vec![]),
            _ => (PnioStatus::OK, record::write_response(&answered)),
        }
    }

    fn control(&mut self, blocks: &[u8], now: Duration) -> (PnioStatus, Vec<u8>, Vec<CmEvent>) {
        let wrong = || PnioStatus::new(CODE_CONTROL, 0x81, 0x3d, 0x03);
        let Ok(control) = ControlBlock::parse(blocks) else {
            return (wrong(), vec![], vec![]);
        };
        let seq_num = self.next_seq_num;
        let Some(ar) = self.io_ar.as_mut().filter(|ar| {
            ar.uuid == control.ar_uuid
                && ar.session_key == control.session_key
                && ar.state == ArState::Parameterising
        }) else {
            return (wrong(), vec![], vec![]);
        };
        if control.block_type != ty::IOD_CONTROL_REQ_PRM_END || control.command != cmd::PRM_END {
            return (wrong(), vec![], vec![]);
        }
        ar.state = ArState::ApplicationReady {
            attempts: 0,
            due: now,
            seq_num,
        };
        self.next_seq_num = self.next_seq_num.wrapping_add(1);
        let mut out = Vec::new();
        prm_end_done(&control).write(&mut out);
        (PnioStatus::OK, out, vec![CmEvent::ParameterisationEnded])
    }

    /// The controller's answer to ApplicationReady.
    fn confirmation(&mut self, header: &RpcHeader, status: PnioStatus, blocks: &[u8]) -> CmOutput {
        let Some(ar) = &mut self.io_ar else {
            return CmOutput::default();
        };
        let ArState::ApplicationReady { seq_num, .. } = ar.state else {
            return CmOutput::default();
        };
        if header.activity != self.device.activity || header.seq_num != seq_num {
            return CmOutput::default();
        }
        let done = ControlBlock::parse(blocks).is_ok_and(|c| {
            c.block_type == ty::IOX_BLOCK_RES_APP_READY
                && c.command == cmd::DONE
                && c.ar_uuid == ar.uuid
        });
        if !(status.is_ok() && done) {
            // A refused ApplicationReady leaves the AR without data exchange.
            self.io_ar = None;
            return ended(ArEnd::ApplicationReadyUnanswered);
        }
        ar.state = ArState::Data;
        CmOutput {
            datagram: None,
            events: vec![CmEvent::DataExchange],
        }
    }

    fn knows_ar(&self, uuid: Uuid) -> bool {
        self.supervisor_ar == Some(uuid) || self.io_ar.as_ref().is_some_and(|ar| ar.uuid == uuid)
    }
}

/// An activity UUID for the device's calls: a version-4-shaped UUID from `seed` (which
/// must differ at every start) and the device's MAC address.
pub fn activity(mac: MacAddress, seed: u64) -> Uuid {
    let mut bytes = [0; 16];
    bytes[..8].copy_from_slice(&seed.to_be_bytes());
    bytes[8] = 0x80 | (bytes[7] & 0x3f);
    bytes[9] = 0;
    bytes[10..].copy_from_slice(&mac.0);
    bytes[6] = 0x40 | (bytes[6] & 0x0f);
    Uuid(bytes)
}

fn ended(end: ArEnd) -> CmOutput {
    CmOutput {
        datagram: None,
        events: vec![CmEvent::Ended(end)],
    }
}

/// The IOCRBlockReq field a refusal names (PNIOStatus.ErrorCode2).
fn iocr_field(refusal: IocrRefusal) -> u8 {
    match refusal {
        IocrRefusal::IocrType(_) => 4,
        IocrRefusal::Lt(_) => 6,
        IocrRefusal::RtClass(_) => 7,
        IocrRefusal::DataLength(_) => 8,
        IocrRefusal::FrameId { .. } => 9,
        IocrRefusal::SendClockFactor(_) => 10,
        IocrRefusal::ReductionRatio(_) | IocrRefusal::Cycle { .. } => 11,
        IocrRefusal::WatchdogFactor(_) => 15,
        IocrRefusal::DataHoldFactor(_) => 16,
        IocrRefusal::TagHeader(_) => 17,
    }
}

/// The index of the SRCI submodule's data object in `layout`, when the controller
/// expects the SRCI module this device has (same ident, same length).
fn srci_object(
    iocr: &pnio::cm::block::IocrBlockReq,
    layout: &CSduLayout,
    model: &DeviceModel,
    request: &ConnectRequest,
) -> Option<usize> {
    let real = model.submodule(SRCI_SLOT, SRCI_SUBSLOT)?;
    let expected_ident = request
        .expected
        .iter()
        .flat_map(|block| &block.apis)
        .find(|api| api.slot == SRCI_SLOT)
        .filter(|api| api.module_ident == real.module_ident)?
        .submodules
        .iter()
        .find(|s| s.subslot == SRCI_SUBSLOT)?
        .submodule_ident;
    if expected_ident != real.submodule_ident {
        return None;
    }
    let index = iocr
        .apis
        .iter()
        .flat_map(|api| &api.io_data)
        .position(|o| o.slot == SRCI_SLOT && o.subslot == SRCI_SUBSLOT)?;
    let length = layout.data_objects().get(index)?.data_length;
    let wanted = if iocr.iocr_type == IOCR_TYPE_INPUT {
        real.input_length
    } else {
        real.output_length
    };
    (length == wanted).then_some(index)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cm::connect::tests::device_access_pdu;
    use crate::cm::connect_response::MODULE_DIFF_BLOCK;
    use crate::cm::record::INDEX_REAL_IDENTIFICATION_DATA;
    use crate::frame_id::RtClass;
    use crate::rt::c_sdu::SrciModuleSize;
    use crate::testdata;
    use pnio::im::Im0;
    use pnio::rpc::{NdrRequest, PNIO_DEVICE_INTERFACE};
    use std::net::IpAddr;

    /// The UDP payload of a golden frame.
    fn udp(name: &str) -> Vec<u8> {
        testdata::frame(name)[42..].to_vec()
    }

    /// The S7's address in the golden capture.
    fn s7() -> SocketAddr {
        let frame = testdata::frame("connect_req");
        let ip: [u8; 4] = frame[26..30].try_into().unwrap();
        SocketAddr::new(IpAddr::from(ip), 54766)
    }

    /// A CM with p-net's MAC, name and activity, so that its answers can be compared
    /// with p-net's.
    fn p_net() -> Cm {
        let activity = RpcHeader::parse(&udp("appready_req")).unwrap().activity;
        let device = CmDevice {
            model: DeviceModel::srci(SrciModuleSize::Bytes256),
            identification: Identification {
                vendor_id: 0xffff,
                im0: Im0::default(),
            },
            im: ImRecords::default(),
            mac: MacAddress([0x8c, 0xf3, 0x19, 0xcd, 0x19, 0xf8]),
            activity,
        };
        Cm::new(device, "rt-labs-dev")
    }

    const T0: Duration = Duration::from_secs(10);

    fn send(cm: &mut Cm, pdu: &[u8]) -> CmOutput {
        cm.on_datagram(pdu, s7(), T0).unwrap()
    }

    fn status(output: &CmOutput) -> PnioStatus {
        match rpc::parse(&output.datagram.as_ref().unwrap().pdu).unwrap() {
            RpcPdu::Response { status, .. } => status,
            other => panic!("not a response: {other:?}"),
        }
    }

    /// A Release of the AR of the golden Connect (`connect`), as the controller's call
    /// `seq_num`.
    fn release(connect: &[u8], seq_num: u32) -> Vec<u8> {
        let request = ConnectRequest::parse(connect).unwrap();
        let mut blocks = Vec::new();
        ControlBlock {
            block_type: ty::RELEASE_BLOCK_REQ,
            ar_uuid: request.ar.ar_uuid,
            session_key: request.ar.session_key,
            command: cmd::RELEASE,
            properties: 0,
        }
        .write(&mut blocks);
        let call = Call {
            object: request.rpc.object,
            interface: PNIO_DEVICE_INTERFACE,
            activity: request.rpc.activity,
            seq_num,
            opnum: Opnum::Release.to_u16(),
        };
        rpc::request(&call, &blocks)
    }

    /// The status and blocks of a response, but its ModuleDiffBlock: the S7 expects
    /// p-net's modules, which p-net had and this device has not.
    fn without_module_diff(pdu: &[u8]) -> (PnioStatus, Vec<u8>) {
        let RpcPdu::Response { status, blocks, .. } = rpc::parse(pdu).unwrap() else {
            panic!("not a response")
        };
        let mut kept = Vec::new();
        let mut rest = blocks;
        while !rest.is_empty() {
            let (header, body) = pnio::cm::block::BlockHeader::parse(rest).unwrap();
            let (block, after) = rest.split_at(pnio::cm::block::BlockHeader::LEN + body.len());
            if header.block_type != MODULE_DIFF_BLOCK {
                kept.extend_from_slice(block);
            }
            rest = after;
        }
        (status, kept)
    }

    /// The body of the ModuleDiffBlock among `blocks`, if there is one.
    fn module_diff_body(blocks: &[u8]) -> Option<Vec<u8>> {
        pnio::cm::block::BlockHeader::read_all(blocks)
            .unwrap()
            .into_iter()
            .find(|(header, _)| header.block_type == MODULE_DIFF_BLOCK)
            .map(|(_, body)| body.to_vec())
    }

    #[test]
    fn the_golden_s7_start_up_is_answered_as_p_net_answered_it() {
        let mut cm = p_net();
        let connected = send(&mut cm, &udp("connect_req"));
        assert_eq!(
            without_module_diff(&connected.datagram.as_ref().unwrap().pdu),
            without_module_diff(&udp("connect_res"))
        );
        let ours = connected.datagram.as_ref().unwrap();
        let RpcPdu::Response { blocks, .. } = rpc::parse(&ours.pdu).unwrap() else {
            panic!("not a response")
        };
        assert!(module_diff_body(blocks).is_some());
        assert_eq!(connected.datagram.as_ref().unwrap().to, s7());
        let [CmEvent::Connected(exchange)] = connected.events.as_slice() else {
            panic!("{:?}", connected.events)
        };
        assert_eq!(exchange.input.accepted.frame_id, 0x8000);
        assert_eq!(exchange.output.accepted.frame_id, 0x8001);
        assert_eq!(exchange.input.accepted.rt_class, RtClass::Two);
        // The S7 expects p-net's modules, not the SRCI module.
        assert_eq!(exchange.input.srci_object, None);

        let written = send(&mut cm, &udp("write_req"));
        assert!(status(&written).is_ok());
        assert!(cm.written().pd_interface_adjust.is_some());

        let prm_end = send(&mut cm, &udp("prmend_req"));
        assert_eq!(prm_end.datagram.unwrap().pdu, udp("prmend_res"));
        assert_eq!(prm_end.events, [CmEvent::ParameterisationEnded]);

        let app_ready = cm.poll(T0).datagram.unwrap();
        assert_eq!(app_ready.pdu, udp("appready_req"));
        assert_eq!(app_ready.to, SocketAddr::new(s7().ip(), PNIO_UDP_PORT));
        assert!(!cm.in_data_exchange());
        let confirmed = send(&mut cm, &udp("appready_res"));
        assert_eq!(confirmed.events, [CmEvent::DataExchange]);
        assert!(cm.in_data_exchange());
        assert_eq!(cm.poll(T0 + Duration::from_secs(5)), CmOutput::default());

        let released = send(&mut cm, &release(&udp("connect_req"), 3));
        assert!(status(&released).is_ok());
        assert_eq!(released.events, [CmEvent::Ended(ArEnd::Released)]);
        assert!(!cm.in_data_exchange());
    }

    #[test]
    fn a_repeated_call_gets_the_same_answer_and_no_second_transition() {
        let mut cm = p_net();
        send(&mut cm, &udp("connect_req"));
        let first = send(&mut cm, &udp("prmend_req"));
        let again = send(&mut cm, &udp("prmend_req"));
        assert_eq!(again.datagram, first.datagram);
        assert!(again.events.is_empty());
    }

    #[test]
    fn application_ready_is_resent_and_the_ar_given_up_when_never_confirmed() {
        let mut cm = p_net();
        send(&mut cm, &udp("connect_req"));
        send(&mut cm, &udp("prmend_req"));
        let first = cm.poll(T0).datagram.unwrap();
        assert_eq!(
            cm.poll(T0 + APPLICATION_READY_RETRY / 2),
            CmOutput::default()
        );
        let mut now = T0;
        for _ in 1..APPLICATION_READY_ATTEMPTS {
            now += APPLICATION_READY_RETRY;
            // A retransmission is the same call.
            assert_eq!(cm.poll(now).datagram.unwrap(), first);
        }
        now += APPLICATION_READY_RETRY;
        assert_eq!(
            cm.poll(now).events,
            [CmEvent::Ended(ArEnd::ApplicationReadyUnanswered)]
        );
        // The late confirmation finds no AR.
        assert!(send(&mut cm, &udp("appready_res")).events.is_empty());
    }

    #[test]
    fn controls_and_writes_out_of_state_or_for_another_ar_are_refused() {
        let mut cm = p_net();
        let prm_end = send(&mut cm, &udp("prmend_req"));
        assert_eq!(status(&prm_end).code(), CODE_CONTROL);
        assert!(prm_end.events.is_empty());
        let write = send(&mut cm, &udp("write_req"));
        assert_eq!(status(&write), PnioStatus::write_wrong_ar());
        let read = send(&mut cm, &udp("im0_read_req"));
        assert_eq!(status(&read), PnioStatus::read_wrong_ar());
        let release = send(&mut cm, &release(&udp("connect_req"), 9));
        assert_eq!(status(&release).code(), CODE_RELEASE);
    }

    #[test]
    fn another_controller_is_refused_while_the_same_one_replaces_its_ar() {
        let mut cm = p_net();
        send(&mut cm, &udp("connect_req"));
        let mut other = udp("connect_req");
        // CMInitiatorMacAdd of the ARBlockReq, and a new activity for a new call.
        let ar_block = RpcHeader::LEN + NdrRequest::LEN;
        other[ar_block + 6 + 20] ^= 0x02;
        other[40] ^= 0x01;
        let refused = send(&mut cm, &other);
        assert_eq!(status(&refused), PnioStatus::connect_ar_already_exists());
        let mut again = udp("connect_req");
        again[40] ^= 0x02;
        let replaced = send(&mut cm, &again);
        assert!(status(&replaced).is_ok());
        assert!(matches!(
            replaced.events.as_slice(),
            [CmEvent::Ended(ArEnd::Replaced), CmEvent::Connected(_)]
        ));
    }

    #[test]
    fn activities_of_two_starts_differ_and_name_the_device() {
        let mac = MacAddress([2, 0, 0, 0, 0, 7]);
        let (a, b) = (activity(mac, 1), activity(mac, 2));
        assert_ne!(a, b);
        assert_eq!(a.0[10..], mac.0);
        assert_eq!(a.0[6] >> 4, 4);
    }

    /// The golden Connect as a controller configured with this device's GSDML sends it:
    /// the DAP (data objects without data), and the SRCI 64 module in slot 1.
    fn srci_connect() -> ConnectRequest {
        use crate::cm::module_diff::tests::expected_for;
        use crate::device::{DAP_SLOT, DAP_SUBSLOT, INTERFACE_SUBSLOT, PORT_SUBSLOT};
        use pnio::cm::block::{IocrApi, IocrObject};
        let model = DeviceModel::srci(SrciModuleSize::Bytes64);
        let mut request = ConnectRequest::parse(&udp("connect_req")).unwrap();
        request.expected = expected_for(&model);
        let object = |slot, subslot, frame_offset| IocrObject {
            slot,
            subslot,
            frame_offset,
        };
        let dap = [DAP_SUBSLOT, INTERFACE_SUBSLOT, PORT_SUBSLOT];
        for iocr in &mut request.iocrs {
            iocr.data_length = 72;
            let mut io_data: Vec<IocrObject> = (0u16..3)
                .map(|i| object(DAP_SLOT, dap[usize::from(i)], i))
                .collect();
            io_data.push(object(SRCI_SLOT, SRCI_SUBSLOT, 3));
            let iocs = if iocr.iocr_type == IOCR_TYPE_INPUT {
                vec![object(SRCI_SLOT, SRCI_SUBSLOT, 68)]
            } else {
                dap.iter()
                    .zip(68..)
                    .map(|(&subslot, at)| object(DAP_SLOT, subslot, at))
                    .collect()
            };
            if iocr.iocr_type == IOCR_TYPE_OUTPUT {
                io_data.retain(|o| o.slot == SRCI_SLOT);
                io_data[0].frame_offset = 0;
            }
            iocr.apis = vec![IocrApi {
                api: 0,
                io_data,
                iocs,
            }];
        }
        request
    }

    #[test]
    fn a_controller_configured_with_the_gsdml_exchanges_the_srci_module() {
        let mut cm = p_net();
        cm.device.model = DeviceModel::srci(SrciModuleSize::Bytes64);
        let request = srci_connect();
        let (status, blocks, events) = cm.connect(&request, s7());
        assert!(status.is_ok(), "{status:?}");
        assert_eq!(module_diff_body(&blocks), None);
        let [CmEvent::Connected(exchange)] = events.as_slice() else {
            panic!("{events:?}")
        };
        assert_eq!(exchange.input.srci_object, Some(3));
        assert_eq!(exchange.output.srci_object, Some(0));
        let srci = exchange.input.layout.data_objects()[3];
        assert_eq!((srci.frame_offset, srci.data_length), (3, 64));
        // Another module size in the project: the AR stands, the SRCI data is not used.
        cm.device.model = DeviceModel::srci(SrciModuleSize::Bytes128);
        cm.abort();
        let (_, blocks, events) = cm.connect(&request, s7());
        let [CmEvent::Connected(exchange)] = events.as_slice() else {
            panic!("{events:?}")
        };
        assert_eq!(exchange.input.srci_object, None);
        // ... and the controller learns why: slot 1 holds a wrong module, the 128-byte one.
        #[rustfmt::skip]
        let wrong_srci_module: &[u8] = &[
            0, 1, 0, 0, 0, 0, 0, 1,
            0, 1, 0, 1, 0, 0x80, 0, 1, 0, 1,
            0, 1, 0, 1, 0, 0x80, 0x90, 0,
        ];
        assert_eq!(
            module_diff_body(&blocks).as_deref(),
            Some(wrong_srci_module)
        );
    }

    #[test]
    fn the_watchdog_aborts_the_io_ar() {
        let mut cm = p_net();
        assert_eq!(cm.abort(), CmOutput::default());
        send(&mut cm, &udp("connect_req"));
        assert_eq!(cm.abort().events, [CmEvent::Ended(ArEnd::Aborted)]);
    }

    /// A Read of `index` on slot 0 subslot 1 on the AR of `connect`, as call `seq_num`.
    fn read(connect: &[u8], index: u16, seq_num: u32) -> Vec<u8> {
        let golden = udp("im0_read_req");
        let header = RpcHeader::parse(&golden).unwrap();
        let mut pdu = golden;
        let blocks = RpcHeader::LEN + NdrRequest::LEN;
        let request = ConnectRequest::parse(connect).unwrap();
        // IODReadReqHeader: SeqNumber, then the ARUUID; Index at 6 + 28.
        pdu[blocks + 8..blocks + 24].copy_from_slice(&request.ar.ar_uuid.0);
        pdu[blocks + 34..blocks + 36].copy_from_slice(&index.to_be_bytes());
        pdu[64..68].copy_from_slice(&seq_num.to_le_bytes());
        assert_eq!(RpcHeader::parse(&pdu).unwrap().activity, header.activity);
        pdu
    }

    #[test]
    fn the_legacy_start_up_reads_the_slots_on_a_device_access_ar_first() {
        let mut cm = p_net();
        let access = device_access_pdu();
        let connected = send(&mut cm, &access);
        assert!(status(&connected).is_ok());
        assert!(connected.events.is_empty());
        let answer = send(&mut cm, &read(&access, INDEX_REAL_IDENTIFICATION_DATA, 1));
        let pdu = answer.datagram.unwrap().pdu;
        let RpcPdu::Response {
            status: read_status,
            blocks,
            ..
        } = rpc::parse(&pdu).unwrap()
        else {
            panic!("not a response")
        };
        assert!(read_status.is_ok());
        let real = record::real_identification_data(&DeviceModel::srci(SrciModuleSize::Bytes256));
        assert_eq!(blocks[64..], real);
        let released = send(&mut cm, &release(&access, 2));
        assert!(status(&released).is_ok() && released.events.is_empty());
        // The AR is gone: a Read on it is refused.
        let late = send(&mut cm, &read(&access, INDEX_REAL_IDENTIFICATION_DATA, 3));
        assert_eq!(status(&late), PnioStatus::read_wrong_ar());

        // Then the IO AR, RTClass 1, the output FrameID left to the device.
        let legacy = legacy_connect(&udp("connect_req"));
        let connected = send(&mut cm, &legacy);
        assert!(status(&connected).is_ok());
        let [CmEvent::Connected(exchange)] = connected.events.as_slice() else {
            panic!("{:?}", connected.events)
        };
        assert_eq!(exchange.input.accepted.rt_class, RtClass::One);
        assert_eq!(exchange.input.accepted.frame_id, 0xc001);
        assert_eq!(exchange.output.accepted.frame_id, 0xc000);
        assert!(!ConnectRequest::parse(&legacy).unwrap().startup_advanced());
        // I&M0 on the IO AR.
        let im0 = send(&mut cm, &read(&legacy, record::INDEX_IM0, 4));
        assert!(status(&im0).is_ok());
    }

    /// A Write of I&M1 (`data`, block header included) to slot 0 subslot 1 on the AR of
    /// `connect`, as call `seq_num`.
    fn write_im1(connect: &[u8], seq_num: u32, data: &[u8]) -> Vec<u8> {
        let request = ConnectRequest::parse(connect).unwrap();
        let mut blocks = Vec::new();
        pnio::cm::block::BlockHeader::write(&mut blocks, ty::IOD_WRITE_REQ_HEADER, 58);
        blocks.extend_from_slice(&1u16.to_be_bytes());
        request.ar.ar_uuid.write(&mut blocks, pnio::rpc::Drep::BIG);
        blocks.extend_from_slice(&[0, 0, 0, 0, 0, 0, 0, 1, 0, 0]);
        blocks.extend_from_slice(&crate::cm::im::INDEX_IM1.to_be_bytes());
        blocks.extend_from_slice(&(data.len() as u32).to_be_bytes());
        blocks.extend_from_slice(&[0; 24]);
        blocks.extend_from_slice(data);
        let call = Call {
            object: request.rpc.object,
            interface: PNIO_DEVICE_INTERFACE,
            activity: request.rpc.activity,
            seq_num,
            opnum: Opnum::Write.to_u16(),
        };
        rpc::request(&call, &blocks)
    }

    #[test]
    fn a_written_i_and_m1_is_kept_and_reported_once() {
        let mut cm = p_net();
        let connect = udp("connect_req");
        send(&mut cm, &connect);
        let mut record = ImRecords::default().read(crate::cm::im::INDEX_IM1).unwrap();
        record[6..18].copy_from_slice(b"robot cell 1");
        let written = send(&mut cm, &write_im1(&connect, 7, &record));
        assert!(status(&written).is_ok());
        assert_eq!(written.events, [CmEvent::ImWritten]);
        assert_eq!(
            cm.im_records().read(crate::cm::im::INDEX_IM1),
            Some(record.clone())
        );
        // The same values again change nothing: nothing to store.
        let again = send(&mut cm, &write_im1(&connect, 8, &record));
        assert!(status(&again).is_ok() && again.events.is_empty());
    }

    #[test]
    fn the_device_diagnosis_follows_the_robot_error() {
        let mut cm = p_net();
        let connect = udp("connect_req");
        send(&mut cm, &connect);
        let blocks_of = |output: CmOutput| match rpc::parse(&output.datagram.unwrap().pdu) {
            Ok(RpcPdu::Response { blocks, .. }) => blocks.to_vec(),
            other => panic!("not a response: {other:?}"),
        };
        // The IODReadResHeader (64 bytes), then the record data.
        let quiet = blocks_of(send(&mut cm, &read(&connect, 0xf80c, 11)));
        assert_eq!(quiet.len(), 64);
        cm.set_robot_error(true);
        let faulty = blocks_of(send(&mut cm, &read(&connect, 0xf80c, 12)));
        assert_eq!(faulty[64..66], [0x00, 0x10]);
    }

    #[test]
    fn pd_real_data_reports_the_station_s_name_addresses_and_link() {
        let mut cm = p_net();
        let connect = udp("connect_req");
        send(&mut cm, &connect);
        let ip = IpParameter {
            address: std::net::Ipv4Addr::new(192, 168, 0, 50),
            subnet_mask: std::net::Ipv4Addr::new(255, 255, 255, 0),
            gateway: std::net::Ipv4Addr::UNSPECIFIED,
        };
        cm.set_ip(ip);
        cm.set_name_of_station("cell1-robot");
        let link = PortLink {
            mau_type: crate::cm::pd_real::MauType::BASE_T_1000_FD,
            up: true,
        };
        cm.set_port_link(link);
        let pdu = send(&mut cm, &read(&connect, 0xf841, 11))
            .datagram
            .unwrap()
            .pdu;
        let Ok(RpcPdu::Response { status, blocks, .. }) = rpc::parse(&pdu) else {
            panic!("not a response");
        };
        assert!(status.is_ok());
        let interface = InterfaceReal {
            chassis_id: "cell1-robot",
            mac: MacAddress([0x8c, 0xf3, 0x19, 0xcd, 0x19, 0xf8]),
            ip,
        };
        let expected = crate::cm::pd_real::pd_real_data(&interface, link);
        // The IODReadResHeader (64 bytes) with RecordDataLength, then the record.
        assert_eq!(blocks[64..], expected);
        assert_eq!(blocks[36..40], (expected.len() as u32).to_be_bytes());
    }

    /// The golden Connect turned into profinet-py's style: StartupMode Legacy, RTClass 1,
    /// input FrameID 0xC001, output FrameID 0xFFFF.
    fn legacy_connect(golden: &[u8]) -> Vec<u8> {
        let mut pdu = golden.to_vec();
        let mut at = RpcHeader::LEN + NdrRequest::LEN;
        while at < pdu.len() {
            let block_type = u16::from_be_bytes([pdu[at], pdu[at + 1]]);
            let length = usize::from(u16::from_be_bytes([pdu[at + 2], pdu[at + 3]]));
            match block_type {
                // ARProperties: bit 30 (StartupMode) cleared.
                ty::AR_BLOCK_REQ => pdu[at + 6 + 42] &= !0x40,
                ty::IOCR_BLOCK_REQ => {
                    let input = pdu[at + 7] == 1;
                    pdu[at + 15] = 1;
                    let frame_id: u16 = if input { 0xc001 } else { 0xffff };
                    pdu[at + 18..at + 20].copy_from_slice(&frame_id.to_be_bytes());
                }
                _ => {}
            }
            at += 4 + length;
        }
        pdu
    }
}
