//! The IO-device shell: one raw socket (DCP and the cyclic frames), one UDP socket
//! (PNIO-CM on port 34964) and the [`LinkMonitor`], polled together on the caller's
//! thread, driving the pure [`DcpService`] responder, the [`Cm`] state machine and the
//! cyclic [`Provider`] and [`Consumer`]. The port's link (PDPortDataReal) is read at
//! start and again when the kernel announces a link change.
//!
//! The caller gives the robot→PLC telegram to send and whether the robot has an error,
//! and receives the PLC→robot telegrams and the AR's events. The robot error is also
//! the diagnosis alarm of the SRCI submodule ([`DiagnosisAlarms`]). In data exchange
//! nothing here allocates but an alarm when the robot error changes and the reading of
//! the port's link when a link changes: frames go through buffers allocated at start-up.

use std::io;
use std::net::{Ipv4Addr, SocketAddr, UdpSocket};
use std::os::fd::{AsFd, AsRawFd, BorrowedFd, RawFd};
use std::time::{Duration, Instant};

use pnio::rpc::PNIO_UDP_PORT;

use super::dcp_service::DcpService;
use super::file_store::ImFile;
use super::link_monitor::{LinkMonitor, LinkMonitorError};
use super::port_link::read_port_link;
use super::raw_socket::{RawSocket, RawSocketError};
use crate::alarm::{AlarmClose, AlarmFailure, AlarmOutput, DiagnosisAlarms};
use crate::cm::ar::{ArEnd, Cm, CmDevice, CmEvent, CmOutput, CyclicExchange};
use crate::cm::pd_real::PortLink;
use crate::dcp::responder::DcpResponder;
use crate::dcp::station::{IpInterface, PermanentStore};
use crate::device::{SRCI_SLOT, SRCI_SUBSLOT};
use crate::ethernet::{ETHER_TYPE_PROFINET, EthernetHeader, MAX_FRAME_LEN};
use crate::frame_id::{FrameUse, frame_use};
use crate::rt::cyclic::{Consumed, Consumer, CyclicError, Expiry, Provider};
use crate::rt::frame::RtFrame;

/// Room for a received frame: the longest one with a VLAN tag.
const RECEIVE_BUFFER_LEN: usize = MAX_FRAME_LEN + 4;
/// Room for a received CM datagram.
const DATAGRAM_BUFFER_LEN: usize = 4096;

/// The IO device cannot run.
#[derive(Debug, thiserror::Error)]
pub enum IoDeviceError {
    /// The raw socket failed.
    #[error(transparent)]
    Raw(#[from] RawSocketError),
    /// The CM socket failed.
    #[error("UDP port {PNIO_UDP_PORT} (PNIO-CM): {0}")]
    Udp(io::Error),
    /// poll(2) failed.
    #[error("poll on the PROFINET sockets failed: {0}")]
    Poll(io::Error),
    /// The link monitor failed.
    #[error(transparent)]
    LinkMonitor(#[from] LinkMonitorError),
}

/// What the IO device reports to its application.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DeviceEvent<'a> {
    /// An IO AR was established: a PLC session begins.
    Connected,
    /// The PLC's valid SRCI data of one cycle.
    Output(&'a [u8]),
    /// An input frame went out with the input data given to this poll.
    InputSent,
    /// The IO AR ended: released, given up or timed out.
    Ended(SessionEnd),
}

/// Why the IO AR ended, as the application sees it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SessionEnd {
    /// The controller or the connection management ended it.
    Ar(ArEnd),
    /// The PLC's frames stopped or stayed invalid: as a lifesign timeout.
    Consumer(Expiry),
}

/// One reading of the clock, in the two forms the parts of the device keep time in.
#[derive(Debug, Clone, Copy)]
struct ClockReading {
    /// For the DCP response delays and the alarm channel.
    instant: Instant,
    /// Since the device's epoch, for the CM and the cyclic exchange.
    since_epoch: Duration,
}

/// Which of the descriptors a device poll waits on have something to read.
#[derive(Debug, Clone, Copy)]
struct Readiness {
    raw: bool,
    udp: bool,
    link: bool,
    wake: bool,
}

/// The running cyclic exchange of the IO AR.
#[derive(Debug)]
struct Exchange {
    provider: Provider,
    consumer: Consumer,
    /// None when the controller asked for no alarm CR.
    alarms: Option<DiagnosisAlarms>,
}

/// A PROFINET IO-device on one interface.
#[derive(Debug)]
pub struct IoDevice<S: PermanentStore, I: IpInterface> {
    dcp: DcpService<S, I>,
    udp: UdpSocket,
    cm: Cm,
    /// Announces link changes, after which the port's link is read again.
    link_monitor: LinkMonitor,
    /// The port's link as last read.
    port_link: PortLink,
    /// Where I&M1..4 are kept across restarts; `None`: not kept.
    im_file: Option<ImFile>,
    exchange: Option<Exchange>,
    epoch: Instant,
    received: Vec<u8>,
    sent: Vec<u8>,
    datagram: Vec<u8>,
}

impl<S: PermanentStore, I: IpInterface> IoDevice<S, I> {
    /// Opens the sockets: `socket` on the interface (its responder answers DCP) and UDP
    /// port 34964 on every address. `device.im` is replaced by what `im_file` holds (a
    /// damaged file is logged and the device starts with blank records).
    pub fn open(
        socket: RawSocket,
        responder: DcpResponder<S, I>,
        mut device: CmDevice,
        im_file: Option<ImFile>,
    ) -> Result<Self, IoDeviceError> {
        if let Some(file) = &im_file {
            match file.load() {
                Ok(records) => device.im = records,
                Err(error) => tracing::error!(%error, "I&M1..4 unreadable; blank ones are used"),
            }
        }
        let udp =
            UdpSocket::bind((Ipv4Addr::UNSPECIFIED, PNIO_UDP_PORT)).map_err(IoDeviceError::Udp)?;
        udp.set_nonblocking(true).map_err(IoDeviceError::Udp)?;
        let name = responder.current().name_of_station.as_str().to_owned();
        let mut cm = Cm::new(device, &name);
        cm.set_ip(responder.current().ip);
        // Opened before the first read, so that no change between the two is missed.
        let link_monitor = LinkMonitor::open()?;
        let port_link = read_port_link(socket.interface());
        log_port_link(socket.interface(), port_link);
        cm.set_port_link(port_link);
        let dcp = DcpService::new(socket, responder);
        dcp.log_listening();
        Ok(Self {
            dcp,
            udp,
            cm,
            link_monitor,
            port_link,
            im_file,
            exchange: None,
            epoch: Instant::now(),
            received: vec![0; RECEIVE_BUFFER_LEN],
            sent: vec![0; RECEIVE_BUFFER_LEN],
            datagram: vec![0; DATAGRAM_BUFFER_LEN],
        })
    }

    /// Runs the device for at most `max_wait`, or until `wake` (a descriptor of the
    /// caller's, say the interpreter's answer event) is readable: sends the input frame
    /// when due with `input` (the robot→PLC telegram; StationProblemIndicator cleared and
    /// the diagnosis alarm raised when `station_problem`, the robot's error), answers DCP,
    /// CM and alarm acknowledgements, and hands what happens to `on_event`. Returns
    /// whether `wake` became readable (false without one), so that the caller reads it
    /// only then.
    pub fn poll(
        &mut self,
        max_wait: Duration,
        wake: Option<BorrowedFd<'_>>,
        input: &[u8],
        station_problem: bool,
        mut on_event: impl FnMut(DeviceEvent<'_>),
    ) -> Result<bool, IoDeviceError> {
        // One reading for all the work before the wait: that work takes microseconds, so a
        // deadline judged from this reading is met at most that much later (the wait is
        // computed from it too), never earlier.
        let before_wait = self.read_clock();
        self.cm.set_robot_error(station_problem);
        if self.provide(before_wait.since_epoch, input, station_problem)? {
            on_event(DeviceEvent::InputSent);
        }
        self.supervise(before_wait.since_epoch, &mut on_event)?;
        self.raise_alarms(station_problem, before_wait, &mut on_event)?;
        let output = self.cm.poll(before_wait.since_epoch);
        self.apply(output, before_wait, &mut on_event)?;
        self.dcp.send_due(before_wait.instant)?;

        let wait = self.wait(before_wait, max_wait);
        let ready = self.ready(wait, wake)?;
        if ready.link && self.link_monitor.changed()? {
            self.refresh_port_link();
        }
        if ready.raw || ready.udp {
            // Read again: the first reading is older by the wait, and frames stamped with
            // it would bring the consumer's watchdog forward. One reading serves all that
            // arrived, as the batch takes microseconds against a watchdog of cycles.
            let arrived = self.read_clock();
            if ready.raw {
                self.receive_frames(arrived, &mut on_event)?;
            }
            if ready.udp {
                self.receive_datagrams(arrived, &mut on_event)?;
            }
        }
        Ok(ready.wake)
    }

    fn read_clock(&self) -> ClockReading {
        let instant = Instant::now();
        ClockReading {
            instant,
            since_epoch: instant.saturating_duration_since(self.epoch),
        }
    }

    /// Sends the input frame when it is due; true when one went out.
    fn provide(
        &mut self,
        now: Duration,
        input: &[u8],
        station_problem: bool,
    ) -> Result<bool, IoDeviceError> {
        let Some(exchange) = &mut self.exchange else {
            return Ok(false);
        };
        if now < exchange.provider.due() {
            return Ok(false);
        }
        match exchange
            .provider
            .frame(now, input, station_problem, &mut self.sent)
        {
            Ok(len) => {
                self.dcp.socket().send(&self.sent[..len])?;
                Ok(true)
            }
            Err(error) => {
                tracing::warn!(%error, "input frame not sent");
                Ok(false)
            }
        }
    }

    /// Raises or clears the diagnosis alarm once the AR exchanges data, and resends an
    /// unacknowledged one.
    fn raise_alarms(
        &mut self,
        robot_error: bool,
        now: ClockReading,
        on_event: &mut impl FnMut(DeviceEvent<'_>),
    ) -> Result<(), IoDeviceError> {
        let in_data_exchange = self.cm.in_data_exchange();
        let Some(alarms) = self.exchange.as_mut().and_then(|e| e.alarms.as_mut()) else {
            return Ok(());
        };
        let mut outputs = alarms.on_tick(now.instant);
        if in_data_exchange {
            outputs.extend(alarms.robot_error(robot_error, now.instant));
        }
        self.apply_alarms(outputs, now, on_event)
    }

    /// Sends the alarm frames and ends the AR when the alarm channel failed.
    fn apply_alarms(
        &mut self,
        outputs: Vec<AlarmOutput>,
        now: ClockReading,
        on_event: &mut impl FnMut(DeviceEvent<'_>),
    ) -> Result<(), IoDeviceError> {
        for output in outputs {
            match output {
                AlarmOutput::Send(frame) => self.dcp.socket().send(&frame)?,
                AlarmOutput::Acknowledged { appeared } => {
                    tracing::info!(appeared, "the controller acknowledged the diagnosis alarm");
                }
                AlarmOutput::AbortAr(failure) => {
                    tracing::warn!(?failure, "the alarm channel failed: the AR is aborted");
                    match failure {
                        AlarmFailure::Unacknowledged => {
                            self.close_alarms(AlarmClose::AlarmUnacknowledged)?;
                        }
                        // The controller's endpoint is closed already.
                        AlarmFailure::ClosedByController => {
                            if let Some(exchange) = &mut self.exchange {
                                exchange.alarms = None;
                            }
                        }
                    }
                    let ended = self.cm.abort();
                    self.apply(ended, now, on_event)?;
                }
            }
        }
        Ok(())
    }

    fn supervise(
        &mut self,
        now: Duration,
        on_event: &mut impl FnMut(DeviceEvent<'_>),
    ) -> Result<(), IoDeviceError> {
        let Some(expiry) = self
            .exchange
            .as_mut()
            .and_then(|exchange| exchange.consumer.check(now))
        else {
            return Ok(());
        };
        tracing::warn!(?expiry, "the PLC's cyclic data stopped: the AR is aborted");
        self.close_alarms(AlarmClose::ConsumerExpired)?;
        self.exchange = None;
        self.cm.abort();
        on_event(DeviceEvent::Ended(SessionEnd::Consumer(expiry)));
        Ok(())
    }

    /// Ends the IO AR, if there is one, because the device stops: its alarm endpoint is
    /// closed with an ERR-RTA-PDU, so that the controller learns it at once rather than by
    /// its watchdog. Call before dropping the device.
    pub fn stop(&mut self) -> Result<(), IoDeviceError> {
        self.close_alarms(AlarmClose::DeviceStops)?;
        self.exchange = None;
        self.cm.abort();
        Ok(())
    }

    /// Closes the alarm endpoint of the ending AR with an ERR-RTA-PDU, when it has one.
    fn close_alarms(&mut self, reason: AlarmClose) -> Result<(), IoDeviceError> {
        let Some(alarms) = self.exchange.as_mut().and_then(|e| e.alarms.take()) else {
            return Ok(());
        };
        tracing::info!(?reason, "alarm endpoint closed with ERR-RTA");
        self.dcp.socket().send(&alarms.close(reason))?;
        Ok(())
    }

    /// How long to wait for traffic: until the next input frame, the consumer's deadline,
    /// an alarm's retry or a delayed DCP reply, at most `max_wait`.
    fn wait(&self, now: ClockReading, max_wait: Duration) -> Duration {
        let since_epoch = |instant: Instant| instant.saturating_duration_since(self.epoch);
        let exchange = self.exchange.as_ref();
        let deadlines = [
            exchange.map(|e| e.provider.due()),
            exchange.and_then(|e| e.consumer.deadline()),
            exchange
                .and_then(|e| e.alarms.as_ref())
                .and_then(DiagnosisAlarms::deadline)
                .map(since_epoch),
            self.dcp.next_due().map(since_epoch),
        ];
        wait_until_earliest(now.since_epoch, max_wait, deadlines.into_iter().flatten())
    }

    /// Waits up to `wait` for the raw or the UDP socket, the link monitor, or `wake`.
    fn ready(
        &self,
        wait: Duration,
        wake: Option<BorrowedFd<'_>>,
    ) -> Result<Readiness, IoDeviceError> {
        let [raw, udp, link, wake] = wait_readable(
            [
                self.dcp.socket().as_fd().as_raw_fd(),
                self.udp.as_raw_fd(),
                self.link_monitor.as_fd().as_raw_fd(),
                wake.map_or(-1, |fd| fd.as_raw_fd()),
            ],
            wait,
        )
        .map_err(IoDeviceError::Poll)?;
        Ok(Readiness {
            raw,
            udp,
            link,
            wake,
        })
    }

    fn receive_frames(
        &mut self,
        now: ClockReading,
        on_event: &mut impl FnMut(DeviceEvent<'_>),
    ) -> Result<(), IoDeviceError> {
        while let Some(len) = self
            .dcp
            .socket()
            .receive(&mut self.received, Duration::ZERO)?
        {
            let frame = &self.received[..len];
            let Ok((ethernet, payload)) = EthernetHeader::parse(frame) else {
                continue;
            };
            if ethernet.ether_type != ETHER_TYPE_PROFINET || payload.len() < 2 {
                continue;
            }
            match frame_use(u16::from_be_bytes([payload[0], payload[1]])) {
                // The guard answers the DCP frame; the arm follows a new NameOfStation.
                FrameUse::DcpGetSet | FrameUse::DcpIdentifyRequest
                    if self.dcp.on_frame(frame)? =>
                {
                    let current = self.dcp.responder().current();
                    self.cm
                        .set_name_of_station(current.name_of_station.as_str());
                    self.cm.set_ip(current.ip);
                }
                FrameUse::Cyclic { .. } => {
                    let Some(exchange) = &mut self.exchange else {
                        continue;
                    };
                    let Ok((ethernet, rt)) = RtFrame::parse(frame) else {
                        continue;
                    };
                    if let Consumed::Data(data) =
                        exchange
                            .consumer
                            .on_frame(ethernet.source, &rt, now.since_epoch)
                    {
                        on_event(DeviceEvent::Output(data));
                    }
                }
                FrameUse::AlarmLow => {
                    let Some(alarms) = self.exchange.as_mut().and_then(|e| e.alarms.as_mut())
                    else {
                        continue;
                    };
                    let outputs = alarms.on_frame(&self.received[..len], now.instant);
                    self.apply_alarms(outputs, now, on_event)?;
                }
                _ => {}
            }
        }
        Ok(())
    }

    fn receive_datagrams(
        &mut self,
        now: ClockReading,
        on_event: &mut impl FnMut(DeviceEvent<'_>),
    ) -> Result<(), IoDeviceError> {
        loop {
            let (len, from) = match self.udp.recv_from(&mut self.datagram) {
                Ok(received) => received,
                Err(error) if error.kind() == io::ErrorKind::WouldBlock => return Ok(()),
                Err(error) if error.kind() == io::ErrorKind::Interrupted => continue,
                Err(error) => return Err(IoDeviceError::Udp(error)),
            };
            match self
                .cm
                .on_datagram(&self.datagram[..len], from, now.since_epoch)
            {
                Ok(output) => self.apply(output, now, on_event)?,
                Err(error) => tracing::debug!(%error, %from, "PNIO-CM datagram ignored"),
            }
        }
    }

    /// Reads the port's link again after a link change (of any interface: the kernel
    /// announces them all), for the Reads of PDPortDataReal and PDRealData.
    fn refresh_port_link(&mut self) {
        let link = read_port_link(self.dcp.socket().interface());
        if self.port_link != link {
            log_port_link(self.dcp.socket().interface(), link);
            self.port_link = link;
            self.cm.set_port_link(link);
        }
    }

    /// Sends what the CM answered and acts on its events.
    fn apply(
        &mut self,
        output: CmOutput,
        now: ClockReading,
        on_event: &mut impl FnMut(DeviceEvent<'_>),
    ) -> Result<(), IoDeviceError> {
        if let Some(datagram) = output.datagram {
            self.send_datagram(&datagram.pdu, datagram.to)?;
        }
        for event in output.events {
            match event {
                CmEvent::Connected(exchange) => {
                    let input = exchange.input.config();
                    let output = exchange.output.config();
                    let started = Provider::new(
                        &input,
                        exchange.controller_mac,
                        self.dcp.socket().mac(),
                        now.since_epoch,
                    )
                    .map(|provider| Exchange {
                        provider,
                        consumer: Consumer::new(
                            &output,
                            exchange.controller_mac,
                            exchange.output.accepted.watchdog,
                            exchange.output.accepted.data_hold,
                        ),
                        alarms: self.diagnosis_alarms(&exchange),
                    });
                    self.exchange = started_or_log(started);
                    tracing::info!(
                        controller = %exchange.controller_mac,
                        input_frame_id = format_args!("{:#06x}", input.frame_id),
                        output_frame_id = format_args!("{:#06x}", output.frame_id),
                        cycle_us = input.timing.cycle().as_micros() as u64,
                        srci = exchange.input.srci_object.is_some()
                            && exchange.output.srci_object.is_some(),
                        "IO AR connected"
                    );
                    if !exchange.module_diff.is_empty() {
                        tracing::warn!(
                            differences = ?exchange.module_diff,
                            "the controller expects other submodules than this device has \
                             (reported in the ModuleDiffBlock)"
                        );
                    }
                    on_event(DeviceEvent::Connected);
                }
                CmEvent::ParameterisationEnded => tracing::info!("IO AR: PrmEnd"),
                CmEvent::DataExchange => tracing::info!("IO AR: ApplicationReady confirmed"),
                CmEvent::Ended(end) => {
                    tracing::info!(?end, "IO AR ended");
                    self.close_alarms(match end {
                        ArEnd::Released => AlarmClose::Released,
                        ArEnd::ApplicationReadyUnanswered => AlarmClose::ApplicationReadyUnanswered,
                        ArEnd::Aborted => AlarmClose::Aborted,
                        ArEnd::Replaced => AlarmClose::Replaced,
                    })?;
                    self.exchange = None;
                    on_event(DeviceEvent::Ended(SessionEnd::Ar(end)));
                }
                CmEvent::ImWritten => self.keep_im_records(),
            }
        }
        Ok(())
    }

    /// Stores I&M1..4 after a controller wrote them; a failure is logged: the values are
    /// in use until the next start.
    fn keep_im_records(&self) {
        let Some(file) = &self.im_file else {
            return;
        };
        match file.save(self.cm.im_records()) {
            Ok(()) => tracing::info!("I&M1..4 written by the controller and stored"),
            Err(error) => tracing::error!(%error, "I&M1..4 written by the controller not stored"),
        }
    }

    /// The diagnosis alarms of the AR `exchange` sets up, when it has an alarm CR.
    fn diagnosis_alarms(&self, exchange: &CyclicExchange) -> Option<DiagnosisAlarms> {
        let alarm_cr = exchange.alarm_cr?;
        let srci = self.cm.model().submodule(SRCI_SLOT, SRCI_SUBSLOT)?;
        Some(DiagnosisAlarms::new(
            alarm_cr,
            self.dcp.socket().mac(),
            exchange.controller_mac,
            srci,
        ))
    }

    fn send_datagram(&self, pdu: &[u8], to: SocketAddr) -> Result<(), IoDeviceError> {
        match self.udp.send_to(pdu, to) {
            Ok(_) => Ok(()),
            // A full send queue loses this datagram; DCE/RPC retransmits.
            Err(error) if error.kind() == io::ErrorKind::WouldBlock => Ok(()),
            Err(error) => Err(IoDeviceError::Udp(error)),
        }
    }
}

/// Logs the port's link of `interface`.
fn log_port_link(interface: &str, link: PortLink) {
    tracing::info!(
        interface,
        up = link.up,
        mau_type = format_args!("{:#06x}", link.mau_type.0),
        "port link"
    );
}

/// How long a pass at `now` may wait: until the earliest of `deadlines` (a past one: not
/// at all), at most `max_wait`.
fn wait_until_earliest(
    now: Duration,
    max_wait: Duration,
    deadlines: impl IntoIterator<Item = Duration>,
) -> Duration {
    deadlines.into_iter().fold(max_wait, |wait, deadline| {
        wait.min(deadline.saturating_sub(now))
    })
}

/// Waits up to `wait` until one of `fds` is readable (a negative one is ignored); which
/// are. A signal ends the wait early with none readable.
fn wait_readable<const N: usize>(fds: [RawFd; N], wait: Duration) -> io::Result<[bool; N]> {
    let mut polled = fds.map(|fd| libc::pollfd {
        fd,
        events: libc::POLLIN,
        revents: 0,
    });
    // ppoll(2) rather than poll(2): a frame due in 0.7 ms must not wait 1 ms.
    let timeout = libc::timespec {
        tv_sec: libc::time_t::try_from(wait.as_secs()).unwrap_or(libc::time_t::MAX),
        tv_nsec: libc::c_long::from(wait.subsec_nanos() as i32),
    };
    // SAFETY: `polled` is a valid array of N pollfd and `timeout` a valid timespec, both
    // outliving the call; no signal mask is given.
    let ready = unsafe {
        libc::ppoll(
            polled.as_mut_ptr(),
            N as libc::nfds_t,
            &timeout,
            std::ptr::null(),
        )
    };
    if ready < 0 {
        let error = io::Error::last_os_error();
        if error.kind() == io::ErrorKind::Interrupted {
            return Ok([false; N]);
        }
        return Err(error);
    }
    Ok(polled.map(|fd| fd.revents != 0))
}

/// The exchange, or none (logged) when its CR cannot be served.
fn started_or_log(started: Result<Exchange, CyclicError>) -> Option<Exchange> {
    started
        .inspect_err(|error| tracing::warn!(%error, "cyclic exchange not started"))
        .ok()
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Write;
    use std::os::unix::net::UnixStream;

    #[test]
    fn readiness_is_told_per_descriptor_and_a_negative_one_is_ignored() {
        let (quiet, _quiet_peer) = UnixStream::pair().unwrap();
        let (woken, mut waker) = UnixStream::pair().unwrap();
        waker.write_all(b"!").unwrap();
        let ready = wait_readable(
            [quiet.as_raw_fd(), -1, woken.as_raw_fd()],
            Duration::from_secs(1),
        )
        .unwrap();
        assert_eq!(ready, [false, false, true]);
    }

    #[test]
    fn nothing_readable_waits_the_time_given() {
        let (quiet, _quiet_peer) = UnixStream::pair().unwrap();
        let started = Instant::now();
        let ready = wait_readable([quiet.as_raw_fd()], Duration::from_millis(20)).unwrap();
        assert_eq!(ready, [false]);
        assert!(started.elapsed() >= Duration::from_millis(20));
    }

    #[test]
    fn the_wait_ends_at_the_earliest_deadline_and_a_past_one_waits_not() {
        let ms = Duration::from_millis;
        assert_eq!(wait_until_earliest(ms(100), ms(5), []), ms(5));
        assert_eq!(
            wait_until_earliest(ms(100), ms(5), [ms(103), ms(102)]),
            ms(2)
        );
        assert_eq!(wait_until_earliest(ms(100), ms(5), [ms(110)]), ms(5));
        assert_eq!(
            wait_until_earliest(ms(100), ms(5), [ms(102), ms(99)]),
            ms(0)
        );
    }
}
