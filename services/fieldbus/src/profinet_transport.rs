//! The PROFINET transport: the fieldbus process as a PROFINET IO-device
//! (`profinet::link::io_device`), the SRCI telegrams in the SRCI module's data.
//!
//! The PLC is the cycle master as over the TCP gateway, but it does not wait: every cycle
//! its valid output data (a PLC→robot telegram) goes to the interpreter as a request, and
//! every input frame carries the newest answer. An IO AR is a PLC session (its start and
//! end are the link events the interpreter knows from TCP clients); frames that stop or
//! turn invalid end it as a lost connection, and the interpreter stops the robot as on a
//! lifesign timeout. The hold-over during an interpreter handover is the gateway's.
//!
//! The device also waits on the interpreter's answer event, so that an answer is taken as
//! soon as it exists, and times each request inside the device ([`ReplyTiming`]): our
//! processing apart from the wait for the next input frame, logged when a session ends.

use std::net::Ipv4Addr;
use std::os::fd::BorrowedFd;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, SystemTime, UNIX_EPOCH};

use iceoryx2::port::listener::Listener;
use iceoryx2::prelude::{FileDescriptorBased, ipc::Service as Ipc};
use profinet::cm::ar::CmDevice;
use profinet::cm::im::ImRecords;
use profinet::cm::record::Identification;
use profinet::dcp::responder::DcpResponder;
use profinet::dcp::station::{DeviceIdentity, IpParameter, NameOfStation, StationParameters};
use profinet::device::{DEVICE_ID, DeviceModel, TYPE_OF_STATION, VENDOR_ID};
use profinet::link::address::InterfaceAddresses;
use profinet::link::file_store::{FileStore, ImFile};
use profinet::link::io_device::{DeviceEvent, IoDevice, IoDeviceError};
use profinet::link::raw_socket::{RawSocket, RawSocketError};
use profinet::rt::c_sdu::SrciModuleSize;
use shared_types::bus::{Bus, BusError};
use shared_types::config::{Config, ProfinetConfig};
use shared_types::health::{HealthReporter, Service};
use shared_types::ipc::{LinkEvent, TELEGRAM_CAPACITY, topics};
use shared_types::srci::telegram::{RobotHeader, status_bit};
use shared_types::time::monotonic_ns;

use crate::FieldbusError;
use crate::bridge::TelegramBridge;
use crate::holdover::HoldOver;
use crate::profinet_timing::{REPLY_TIMING_LOG, ReplyTiming};

/// Longest wait of one device poll, so that shutdown and the heartbeat are served.
const POLL_INTERVAL: Duration = Duration::from_millis(5);
/// Name of the file of the permanent DCP values in the data folder.
const STATION_FILE: &str = "profinet-station";
/// Name of the file of the I&M1..4 records in the data folder.
const IM_FILE: &str = "profinet-im";

/// The PROFINET transport cannot start or run.
#[derive(Debug, thiserror::Error)]
pub enum ProfinetError {
    /// A value of `[fieldbus.profinet]` the device cannot use.
    #[error("fieldbus.profinet.{key}: {detail}")]
    Config {
        /// The key.
        key: &'static str,
        /// What is wrong.
        detail: String,
    },
    /// The interface cannot be opened.
    #[error(transparent)]
    Socket(#[from] RawSocketError),
    /// The device failed.
    #[error(transparent)]
    Device(#[from] IoDeviceError),
}

/// The IO-device bound to the bus.
pub struct ProfinetTransport {
    device: IoDevice<FileStore, InterfaceAddresses>,
    bridge: TelegramBridge,
    holdover: HoldOver,
    /// The robot→PLC telegram the input frames carry.
    input: [u8; TELEGRAM_CAPACITY],
    input_len: usize,
    /// The PLC session (IO AR) in progress; 0 before the first.
    connection: u32,
    connected: bool,
    /// The interpreter's answer event, polled with the device's sockets.
    reply_wake: Listener<Ipc>,
    /// The device's poll found `reply_wake` readable: an answer (or handover notice) is
    /// to be taken. True at the start, for an answer published before the poll began.
    reply_pending: bool,
    timing: ReplyTiming,
    // Declared last: the ports above are dropped before their node.
    bus: Bus,
}

impl ProfinetTransport {
    /// Opens the interface and UDP port 34964 and the telegram topics.
    pub fn open(config: &Config) -> Result<Self, FieldbusError> {
        let fb = &config.main.fieldbus;
        let pn = &fb.profinet;
        let size = module_size(pn.module_size)?;
        let factory = factory_parameters(pn)?;
        let socket = RawSocket::open(&pn.interface).map_err(ProfinetError::from)?;
        let mac = socket.mac();
        let identity = DeviceIdentity {
            mac,
            vendor_id: VENDOR_ID,
            device_id: DEVICE_ID,
            device_instance: 0x0001,
            type_of_station: TYPE_OF_STATION.to_owned(),
        };
        let data_dir = data_dir(config, pn);
        let store = FileStore::new(data_dir.join(STATION_FILE));
        let interface = InterfaceAddresses::new(&pn.interface);
        let responder = DcpResponder::new(identity, factory, store, interface);
        let device = CmDevice {
            model: DeviceModel::srci(size),
            identification: Identification::robot_controller(
                &config.main.interpreter.serial_number,
            ),
            im: ImRecords::default(),
            mac,
            activity: profinet::cm::ar::activity(mac, start_seed()),
        };
        let im_file = ImFile::new(data_dir.join(IM_FILE));
        let device = IoDevice::open(socket, responder, device, Some(im_file))
            .map_err(ProfinetError::from)?;
        let bus = Bus::new(&config.main.instance, "fieldbus")?;
        let bridge = TelegramBridge::open(&bus)?;
        let reply_wake = bus.listener(topics::R2P)?;
        let input_len = usize::from(fb.telegram_length_rob_to_plc).min(TELEGRAM_CAPACITY);
        Ok(Self {
            device,
            bridge,
            holdover: HoldOver::new(fb.holdover_ms),
            input: [0; TELEGRAM_CAPACITY],
            input_len,
            connection: 0,
            connected: false,
            reply_wake,
            reply_pending: true,
            timing: ReplyTiming::default(),
            bus,
        })
    }

    /// Serves the PLC until `shutdown` becomes true.
    pub fn serve(&mut self, shutdown: &AtomicBool) -> Result<(), FieldbusError> {
        let period_ns = u64::try_from(POLL_INTERVAL.as_nanos()).unwrap_or(u64::MAX);
        let mut health = HealthReporter::new(&self.bus, Service::Fieldbus, period_ns)?;
        while !shutdown.load(Ordering::Relaxed) {
            shared_types::supervision::beat();
            health.beat()?;
            if self.reply_pending {
                self.take_reply()?;
            }
            let station_problem = RobotHeader::decode(&self.input[..self.input_len])
                .is_ok_and(|header| header.status & status_bit::ERROR_PENDING != 0);
            let mut failure = None;
            let mut telegrams = 0u32;
            let (bridge, connection, connected, timing) = (
                &mut self.bridge,
                &mut self.connection,
                &mut self.connected,
                &mut self.timing,
            );
            // SAFETY: the descriptor belongs to `reply_wake`, which outlives this poll
            // and is not closed by it.
            let wake = unsafe {
                BorrowedFd::borrow_raw(self.reply_wake.file_descriptor().native_handle())
            };
            self.reply_pending = self
                .device
                .poll(
                    POLL_INTERVAL,
                    Some(wake),
                    &self.input[..self.input_len],
                    station_problem,
                    |event| {
                        let result = match event {
                            DeviceEvent::Connected => {
                                let replaced = connected.then_some(*connection);
                                *connection = connection.wrapping_add(1);
                                *connected = true;
                                replaced
                                    .map_or(Ok(()), |old| {
                                        bridge.link_event(old, LinkEvent::Disconnected)
                                    })
                                    .and_then(|()| {
                                        bridge.link_event(*connection, LinkEvent::Connected)
                                    })
                            }
                            DeviceEvent::Output(telegram) => {
                                telegrams += 1;
                                let received_ns = monotonic_ns();
                                bridge
                                    .forward(*connection, telegram, received_ns)
                                    .map(|counter| timing.request(counter, received_ns))
                            }
                            DeviceEvent::InputSent => {
                                timing.input_sent(monotonic_ns());
                                Ok(())
                            }
                            DeviceEvent::Ended(end) => {
                                tracing::info!(?end, "PLC session over PROFINET ended");
                                log_reply_timing(timing);
                                *connected = false;
                                bridge.link_event(*connection, LinkEvent::Disconnected)
                            }
                        };
                        if let Err(error) = result {
                            failure.get_or_insert(error);
                        }
                    },
                )
                .map_err(ProfinetError::from)?;
            if let Some(error) = failure {
                return Err(error);
            }
            if telegrams > 0 {
                health.record(monotonic_ns());
                self.hold_over_if_due();
            }
        }
        self.device.stop().map_err(ProfinetError::from)?;
        if self.connected {
            log_reply_timing(&mut self.timing);
            self.bridge
                .link_event(self.connection, LinkEvent::Disconnected)?;
        }
        Ok(())
    }

    /// Takes the interpreter's newest answer (or its handover notice) into the input data;
    /// called when the device's poll found the answer event readable, as the interpreter
    /// publishes each answer before it signals the event.
    fn take_reply(&mut self) -> Result<(), FieldbusError> {
        // The wake-ups only end the device's wait (the answer itself is the newest
        // sample); drained without blocking, so that the descriptor is quiet until the
        // next answer.
        self.reply_wake.try_wait(|_| {}).map_err(|error| BusError {
            action: "drain the wake-ups of",
            service: topics::R2P.to_owned(),
            detail: format!("{error:?}"),
        })?;
        let Some(reply) = self.bridge.latest_reply()? else {
            return Ok(());
        };
        if reply.is_handover() {
            tracing::info!("the interpreter hands its session over: holding the PLC over");
            self.holdover.begin(monotonic_ns());
            return Ok(());
        }
        if self.holdover.active() {
            tracing::info!("the interpreter answers again: hold-over ended");
        }
        self.timing.answer(reply.counter, monotonic_ns());
        let bytes = &reply.bytes[..self.input_len];
        self.input[..self.input_len].copy_from_slice(bytes);
        self.holdover.remember(bytes);
        Ok(())
    }

    /// During a hold-over, each PLC telegram is answered with the last reply and a live
    /// lifesign, as the TCP gateway does.
    fn hold_over_if_due(&mut self) {
        if !self.holdover.can_answer(monotonic_ns()) {
            return;
        }
        if let Some(answer) = self.holdover.answer() {
            let n = answer.len().min(self.input_len);
            self.input[..n].copy_from_slice(&answer[..n]);
        }
    }
}

/// Logs the reply timing of the session that ended (read back by `rc bench latency`).
fn log_reply_timing(timing: &mut ReplyTiming) {
    let Some(summary) = timing.summary() else {
        return;
    };
    let us = |ns: u64| ns / 1_000;
    tracing::info!(
        requests = summary.requests,
        processing_p50_us = us(summary.processing.p50),
        processing_p99_us = us(summary.processing.p99),
        processing_max_us = us(summary.processing.max),
        cycle_wait_p50_us = us(summary.cycle_wait.p50),
        cycle_wait_p99_us = us(summary.cycle_wait.p99),
        cycle_wait_max_us = us(summary.cycle_wait.max),
        dropped = summary.dropped,
        "{REPLY_TIMING_LOG} (output frame received -> answer at hand -> input frame sent)"
    );
}

/// The SRCI module of `bytes` per direction.
fn module_size(bytes: u16) -> Result<SrciModuleSize, ProfinetError> {
    match bytes {
        64 => Ok(SrciModuleSize::Bytes64),
        128 => Ok(SrciModuleSize::Bytes128),
        256 => Ok(SrciModuleSize::Bytes256),
        other => Err(ProfinetError::Config {
            key: "module_size",
            detail: format!("{other} (64, 128 or 256)"),
        }),
    }
}

/// The factory NameOfStation and IP parameters.
fn factory_parameters(pn: &ProfinetConfig) -> Result<StationParameters, ProfinetError> {
    let name_of_station =
        NameOfStation::new(pn.station_name.as_bytes()).map_err(|e| ProfinetError::Config {
            key: "station_name",
            detail: e.to_string(),
        })?;
    let address = |key: &'static str, value: &str| {
        value
            .parse::<Ipv4Addr>()
            .map_err(|e| ProfinetError::Config {
                key,
                detail: format!("\"{value}\": {e}"),
            })
    };
    let ip = IpParameter {
        address: address("ip", &pn.ip)?,
        subnet_mask: address("netmask", &pn.netmask)?,
        gateway: address("gateway", &pn.gateway)?,
    }
    .validate()
    .map_err(|e| ProfinetError::Config {
        key: "ip",
        detail: e.to_string(),
    })?;
    Ok(StationParameters {
        name_of_station,
        ip,
    })
}

/// Where the permanent DCP values and the I&M records are kept.
fn data_dir(config: &Config, pn: &ProfinetConfig) -> PathBuf {
    if pn.data_dir.is_empty() {
        config.main.data_dir()
    } else {
        PathBuf::from(&pn.data_dir)
    }
}

/// Differs at every start, so that the device's calls of one run are not taken for
/// repetitions of the last run's.
fn start_seed() -> u64 {
    let since_epoch = SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .unwrap_or_default();
    u64::try_from(since_epoch.as_nanos()).unwrap_or(u64::MAX) ^ u64::from(std::process::id())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_module_size_is_one_of_the_three() {
        assert_eq!(module_size(64).unwrap(), SrciModuleSize::Bytes64);
        assert_eq!(module_size(256).unwrap(), SrciModuleSize::Bytes256);
        let error = module_size(100).unwrap_err().to_string();
        assert!(error.contains("fieldbus.profinet.module_size"), "{error}");
    }

    #[test]
    fn the_factory_parameters_name_the_key_they_fail_on() {
        let mut pn = ProfinetConfig::default();
        let factory = factory_parameters(&pn).unwrap();
        assert_eq!(factory.name_of_station.as_str(), "rc-robot");
        pn.station_name = "Robot_1".into();
        let error = factory_parameters(&pn).unwrap_err().to_string();
        assert!(error.contains("fieldbus.profinet.station_name"), "{error}");
        pn.station_name = "rc-robot".into();
        pn.ip = "192.168.0.50".into();
        pn.netmask = "255.255.255.0".into();
        assert!(factory_parameters(&pn).unwrap().ip.is_set());
    }
}
