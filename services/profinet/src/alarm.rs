//! Alarms over RTA for the IO AR: the diagnosis alarm of the SRCI submodule that appears
//! when the robot has an error and disappears when the error is cleared (GroupReset).
//!
//! The RTA protocol itself (sequence numbers, transport ACK, the content-level AlarmAck,
//! retries, ERR-RTA) is `pnio`'s `AlarmChannel` and the alarm content its `DiagStore`: both
//! pure and pinned to S7 and p-net captures. What is ours is the decision when an alarm is
//! due and the AR's negotiated parameters. Diagnosis alarms go on the low-priority channel
//! (FrameID 0xFE01), as p-net and the S7 send them.
//!
//! When the AR ends the device closes its alarm endpoint with an ERR-RTA-PDU on that
//! channel ([`DiagnosisAlarms::close`]), PNIOStatus CF 81 FD and the abort reason as
//! ErrorCode2 (RTA_ERR_CLS_PROTOCOL), as p-net does for every AR that ends, a Release
//! included (0x0F, "AR release.ind received"): the controller's alarm endpoint then
//! closes at once instead of by its own timeout. After the controller's own ERR-RTA the
//! endpoint is closed already and nothing is sent.

use std::time::{Duration, Instant};

use pnio::alarm::{AlarmAction, AlarmChannel, AlarmChannelConfig, AlarmReq, Priority};
use pnio::cm::block::AlarmCrBlockReq;
use pnio::cm::{AbortReason, PnioStatus};
use pnio::config::{Direction, Slot};
use pnio::diag::{ChannelError, DiagStore, Diagnosis, Severity, SubmoduleInfo, WHOLE_SUBMODULE};
use pnio::eth::MacAddr;

use crate::device::{SRCI_SLOT, SubmoduleModel};
use crate::ethernet::{MIN_FRAME_LEN, MacAddress};

/// The unit of RTATimeoutFactor.
const RTA_TIMEOUT_UNIT: Duration = Duration::from_millis(100);

/// The alarm CR of an IO AR as the Connect negotiated it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct AlarmCr {
    /// The controller's LocalAlarmReference (our AlarmDstEndpoint).
    pub controller_reference: u16,
    /// The device's LocalAlarmReference (our AlarmSrcEndpoint).
    pub device_reference: u16,
    /// How long to wait for an acknowledgement before resending.
    pub rta_timeout: Duration,
    /// Resends before the AR is given up.
    pub rta_retries: u16,
    /// The answered MaxAlarmDataLength.
    pub max_alarm_data_length: u16,
}

impl AlarmCr {
    /// The alarm CR of `request` with the device's reference and data length answered.
    pub fn negotiated(
        request: &AlarmCrBlockReq,
        device_reference: u16,
        max_alarm_data_length: u16,
    ) -> Self {
        Self {
            controller_reference: request.local_alarm_reference,
            device_reference,
            rta_timeout: RTA_TIMEOUT_UNIT * u32::from(request.rta_timeout_factor),
            rta_retries: request.rta_retries,
            max_alarm_data_length: max_alarm_data_length.min(request.max_alarm_data_length),
        }
    }
}

/// What the device loop must do after an alarm step.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum AlarmOutput {
    /// Send this Ethernet frame.
    Send(Vec<u8>),
    /// The controller acknowledged the alarm that says the robot error `appeared` (or
    /// disappeared).
    Acknowledged {
        /// True for the appearing alarm.
        appeared: bool,
    },
    /// The alarm channel failed: the AR must end.
    AbortAr(AlarmFailure),
}

/// How the alarm channel failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AlarmFailure {
    /// An alarm was not acknowledged after all retries.
    Unacknowledged,
    /// The controller closed the channel with an ERR-RTA-PDU.
    ClosedByController,
}

/// Why the device closes the alarm endpoint of an AR that ends: the ErrorCode2 of the
/// ERR-RTA-PDU's PNIOStatus (the abort reasons of RTA_ERR_CLS_PROTOCOL).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AlarmClose {
    /// The consumer's watchdog or data-hold time expired (0x05).
    ConsumerExpired,
    /// An alarm was not acknowledged (0x08, "AR alarm-send.cnf(-)").
    AlarmUnacknowledged,
    /// ApplicationReady was never confirmed (0x0C, "AR rpc-client call.cnf(-)").
    ApplicationReadyUnanswered,
    /// The device ended the AR for another reason (0x0D, "AR abort.req").
    Aborted,
    /// The controller connected again (0x0E, "AR re-run aborts existing").
    Replaced,
    /// The controller released the AR (0x0F, "AR release.ind received").
    Released,
    /// The device stops (0x10, "AR device deactivated").
    DeviceStops,
}

impl AlarmClose {
    /// ErrorCode2 of the PNIOStatus.
    pub fn code(self) -> u8 {
        match self {
            AlarmClose::ConsumerExpired => 0x05,
            AlarmClose::AlarmUnacknowledged => 0x08,
            AlarmClose::ApplicationReadyUnanswered => 0x0c,
            AlarmClose::Aborted => 0x0d,
            AlarmClose::Replaced => 0x0e,
            AlarmClose::Released => 0x0f,
            AlarmClose::DeviceStops => 0x10,
        }
    }
}

/// The diagnosis of the SRCI submodule while the robot has an error: a fault of the
/// whole submodule, both directions. The alarm announces it; the diagnosis records
/// ([`crate::cm::diagnosis`]) report it while it lasts.
pub fn robot_error_diagnosis() -> Diagnosis {
    Diagnosis {
        slot: Slot(SRCI_SLOT),
        channel: WHOLE_SUBMODULE,
        error: ChannelError::Error,
        severity: Severity::Fault,
        direction: Direction::InputOutput,
    }
}

/// Alarm ids handed to the channel: which of the two alarms was acknowledged.
const ID_APPEARS: u32 = 1;
/// See [`ID_APPEARS`].
const ID_DISAPPEARS: u32 = 0;

/// The diagnosis alarms of one IO AR.
pub struct DiagnosisAlarms {
    channel: AlarmChannel,
    diagnoses: DiagStore,
    robot_error: bool,
}

impl std::fmt::Debug for DiagnosisAlarms {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("DiagnosisAlarms")
            .field("robot_error", &self.robot_error)
            .field("in_flight", &self.channel.in_flight())
            .finish_non_exhaustive()
    }
}

impl DiagnosisAlarms {
    /// The alarms of an AR with `alarm_cr` between `device` and `controller`, about the
    /// SRCI submodule `srci`.
    pub fn new(
        alarm_cr: AlarmCr,
        device: MacAddress,
        controller: MacAddress,
        srci: &SubmoduleModel,
    ) -> Self {
        let channel = AlarmChannel::new(AlarmChannelConfig {
            local_ref: alarm_cr.device_reference,
            remote_ref: alarm_cr.controller_reference,
            rta_timeout: alarm_cr.rta_timeout,
            rta_retries: alarm_cr.rta_retries,
            max_alarm_data_length: alarm_cr.max_alarm_data_length,
            peer_mac: MacAddr(controller.0),
            our_mac: MacAddr(device.0),
        });
        let diagnoses = DiagStore::new(vec![SubmoduleInfo {
            slot: Slot(srci.slot),
            subslot: srci.subslot,
            module_ident: srci.module_ident,
            submodule_ident: srci.submodule_ident,
            direction: Direction::InputOutput,
        }]);
        Self {
            channel,
            diagnoses,
            robot_error: false,
        }
    }

    /// Tells whether the robot has an error now; raises the diagnosis alarm when the
    /// error appears and its disappearing alarm when it is gone. Without a change
    /// nothing happens (and nothing is allocated).
    pub fn robot_error(&mut self, error: bool, now: Instant) -> Vec<AlarmOutput> {
        if error == self.robot_error {
            return Vec::new();
        }
        self.robot_error = error;
        let notification = if error {
            self.diagnoses.raise(robot_error_diagnosis())
        } else {
            self.diagnoses
                .clear(Slot(SRCI_SLOT), WHOLE_SUBMODULE, ChannelError::Error)
        };
        let Some(mut notification) = notification else {
            return Vec::new();
        };
        notification.specifier.sequence = self.channel.next_specifier_sequence();
        let request = AlarmReq {
            id: if error { ID_APPEARS } else { ID_DISAPPEARS },
            priority: Priority::Low,
            notification,
        };
        match self.channel.enqueue(request, now) {
            Ok(actions) => outputs(actions),
            // A ChannelDiagnosis is far below any MaxAlarmDataLength a controller
            // offers; one that offers less gets no alarm, the StationProblemIndicator
            // still says it.
            Err(_) => Vec::new(),
        }
    }

    /// A frame with FrameID 0xFE01 from the controller.
    pub fn on_frame(&mut self, frame: &[u8], now: Instant) -> Vec<AlarmOutput> {
        outputs(self.channel.on_frame(frame, now))
    }

    /// Resends or gives up when an acknowledgement is overdue.
    pub fn on_tick(&mut self, now: Instant) -> Vec<AlarmOutput> {
        outputs(self.channel.on_tick(now))
    }

    /// The ERR-RTA-PDU that closes the alarm endpoint when the AR ends for `reason`
    /// (with the channel's current sequence numbers); the alarms end with it.
    pub fn close(mut self, reason: AlarmClose) -> Vec<u8> {
        let mut frame = self.channel.err_rta(PnioStatus::rta_abort(reason.code()));
        // An ERR-RTA is shorter than the shortest Ethernet frame; padded here so that
        // an interface that does not pad (veth) sends a valid frame too.
        frame.resize(frame.len().max(MIN_FRAME_LEN), 0);
        frame
    }

    /// When [`Self::on_tick`] must be called next.
    pub fn deadline(&self) -> Option<Instant> {
        self.channel.next_deadline()
    }
}

fn outputs(actions: Vec<AlarmAction>) -> Vec<AlarmOutput> {
    actions
        .into_iter()
        .filter_map(|action| match action {
            AlarmAction::Send(frame) => Some(AlarmOutput::Send(frame)),
            AlarmAction::Acked { id, .. } => Some(AlarmOutput::Acknowledged {
                appeared: id == ID_APPEARS,
            }),
            AlarmAction::Abort(AbortReason::ControllerErrRta(_)) => {
                Some(AlarmOutput::AbortAr(AlarmFailure::ClosedByController))
            }
            AlarmAction::Abort(_) => Some(AlarmOutput::AbortAr(AlarmFailure::Unacknowledged)),
            AlarmAction::UnexpectedRx => None,
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::device::{DeviceModel, SRCI_SUBSLOT};
    use crate::rt::c_sdu::SrciModuleSize;
    use crate::testdata;
    use pnio::alarm::{
        AlarmType, PduType, RtaBody, RtaData, RtaHeader, RtaPdu, Specifier, UserData, build_frame,
        parse_frame,
    };

    /// The MACs of the golden alarm frames: p-net's device and the S7.
    const DEVICE: MacAddress = MacAddress([0x8c, 0xf3, 0x19, 0xcd, 0x19, 0xf8]);
    const S7: MacAddress = MacAddress([0xec, 0x1c, 0x5d, 0x61, 0xe7, 0x3c]);

    /// The S7's alarm CR of the golden Connect, with the references of the golden
    /// alarm frames (both 0).
    fn alarms() -> DiagnosisAlarms {
        let model = DeviceModel::srci(SrciModuleSize::Bytes256);
        let srci = model.submodule(SRCI_SLOT, SRCI_SUBSLOT).unwrap();
        let alarm_cr = AlarmCr {
            controller_reference: 0,
            device_reference: 0,
            rta_timeout: Duration::from_millis(100),
            rta_retries: 3,
            max_alarm_data_length: 200,
        };
        DiagnosisAlarms::new(alarm_cr, DEVICE, S7, srci)
    }

    fn sent(outputs: &[AlarmOutput]) -> Vec<RtaPdu> {
        outputs
            .iter()
            .filter_map(|o| match o {
                AlarmOutput::Send(frame) => Some(parse_frame(frame).unwrap()),
                _ => None,
            })
            .collect()
    }

    fn notification(pdu: &RtaPdu) -> (AlarmType, Specifier, bool) {
        let RtaBody::Data(RtaData::Notification(n)) = &pdu.body else {
            panic!("not a notification: {pdu:?}")
        };
        let UserData::Channel(channel) = n.data else {
            panic!("not a channel diagnosis: {n:?}")
        };
        assert_eq!((n.slot, n.subslot), (SRCI_SLOT, SRCI_SUBSLOT));
        assert_eq!(channel.channel, WHOLE_SUBMODULE);
        (
            n.alarm_type,
            channel.properties.specifier,
            n.specifier.submodule_diag,
        )
    }

    #[test]
    fn a_robot_error_raises_the_diagnosis_alarm_as_p_net_frames_it_and_the_s7_acknowledges_it() {
        let t0 = Instant::now();
        let mut alarms = alarms();
        assert_eq!(alarms.robot_error(false, t0), []);
        let raised = alarms.robot_error(true, t0);
        let [AlarmOutput::Send(frame)] = raised.as_slice() else {
            panic!("{raised:?}")
        };
        // Ethernet (tagged, priority 5), FrameID 0xFE01 and the RTA header up to the
        // AckSeqNum: as p-net's first diagnosis alarm.
        assert_eq!(frame[..28], testdata::frame("alarm_diag_notif")[..28]);
        let pdus = sent(&raised);
        assert_eq!(pdus[0].priority, Priority::Low);
        assert_eq!(
            notification(&pdus[0]),
            (AlarmType::Diagnosis, Specifier::Appears, true)
        );
        assert_eq!(alarms.robot_error(true, t0), []);

        let transport_ack = testdata::frame("alarm_ack_rta_low_cpu");
        assert_eq!(alarms.on_frame(&transport_ack, t0), []);
        let acknowledged = alarms.on_frame(&testdata::frame("alarm_diag_ack_cpu"), t0);
        assert_eq!(
            acknowledged[1],
            AlarmOutput::Acknowledged { appeared: true }
        );
        let ack_rta = &sent(&acknowledged)[0];
        assert_eq!(ack_rta.header.pdu_type, PduType::Ack);
        assert_eq!(ack_rta.header.ack_seq, 0xffff);
        assert_eq!(alarms.deadline(), None);

        let cleared = sent(&alarms.robot_error(false, t0));
        assert_eq!(
            notification(&cleared[0]),
            (AlarmType::DiagnosisDisappears, Specifier::Disappears, false)
        );
        assert_eq!(cleared[0].header.send_seq, 0);
    }

    #[test]
    fn an_unacknowledged_alarm_is_resent_rta_retries_times_then_the_ar_ends() {
        let t0 = Instant::now();
        let mut alarms = alarms();
        let first = alarms.robot_error(true, t0);
        assert_eq!(alarms.on_tick(t0 + Duration::from_millis(99)), []);
        let mut at = t0;
        for _ in 0..3 {
            at = alarms.deadline().unwrap();
            assert_eq!(alarms.on_tick(at), first);
        }
        assert_eq!(at, t0 + Duration::from_millis(300));
        let deadline = alarms.deadline().unwrap();
        assert_eq!(
            alarms.on_tick(deadline),
            [AlarmOutput::AbortAr(AlarmFailure::Unacknowledged)]
        );
    }

    #[test]
    fn an_err_rta_of_the_controller_ends_the_ar() {
        let t0 = Instant::now();
        let mut alarms = alarms();
        alarms.robot_error(true, t0);
        let err_rta = testdata::frame("alarm_err_rta_cpu");
        assert_eq!(
            alarms.on_frame(&err_rta, t0),
            [AlarmOutput::AbortAr(AlarmFailure::ClosedByController)]
        );
    }

    #[test]
    fn a_released_ar_closes_the_alarm_endpoint_with_err_rta() {
        let t0 = Instant::now();
        let mut alarms = alarms();
        // One alarm sent first: the ERR-RTA carries the sequence number it used.
        let data = sent(&alarms.robot_error(true, t0));
        let frame = alarms.close(AlarmClose::Released);
        let pdu = parse_frame(&frame).unwrap();
        assert_eq!(pdu.priority, Priority::Low);
        assert_eq!(pdu.header.pdu_type, PduType::Err);
        assert_eq!(pdu.header.send_seq, data[0].header.send_seq);
        assert_eq!(
            pdu.body,
            RtaBody::Err(PnioStatus::new(0xcf, 0x81, 0xfd, 0x0f))
        );
        // To the controller, from the device (FrameID 0xFE01: parsed as Low above).
        assert_eq!(frame[..6], S7.0);
        assert_eq!(frame[6..12], DEVICE.0);
        assert_eq!(frame.len(), MIN_FRAME_LEN);
    }

    #[test]
    fn every_close_reason_has_its_abort_code() {
        let codes: Vec<u8> = [
            AlarmClose::ConsumerExpired,
            AlarmClose::AlarmUnacknowledged,
            AlarmClose::ApplicationReadyUnanswered,
            AlarmClose::Aborted,
            AlarmClose::Replaced,
            AlarmClose::Released,
            AlarmClose::DeviceStops,
        ]
        .map(AlarmClose::code)
        .to_vec();
        assert_eq!(codes, [0x05, 0x08, 0x0c, 0x0d, 0x0e, 0x0f, 0x10]);
    }

    #[test]
    fn frames_of_another_station_are_ignored() {
        let t0 = Instant::now();
        let mut alarms = alarms();
        alarms.robot_error(true, t0);
        let stranger = RtaPdu {
            priority: Priority::Low,
            header: RtaHeader {
                dst_ref: 0,
                src_ref: 0,
                pdu_type: PduType::Ack,
                tack: false,
                send_seq: 0xfffe,
                ack_seq: 0xffff,
            },
            body: RtaBody::Ack,
        };
        let frame = build_frame(MacAddr([2, 0, 0, 0, 0, 9]), MacAddr(DEVICE.0), &stranger);
        assert_eq!(alarms.on_frame(&frame, t0), []);
        assert!(alarms.deadline().is_some());
    }

    #[test]
    fn the_negotiated_alarm_cr_takes_the_smaller_data_length_and_100_ms_units() {
        let request =
            crate::cm::connect::ConnectRequest::parse(&testdata::frame("connect_req")[42..])
                .unwrap()
                .alarm_cr
                .unwrap();
        let cr = AlarmCr::negotiated(&request, 0, 200);
        assert_eq!(cr.rta_timeout, Duration::from_millis(100));
        assert_eq!((cr.rta_retries, cr.max_alarm_data_length), (3, 200));
        assert_eq!(cr.controller_reference, request.local_alarm_reference);
    }
}
