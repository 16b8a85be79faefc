//! Runs the DCP responder of the PROFINET IO-device on one interface (needs root, or
//! CAP_NET_RAW and CAP_NET_ADMIN), until SIGINT or SIGTERM.
//!
//! ```text
//! profinet-dcp --interface eth1 --name rc-robot [--ip 192.168.0.50 --netmask 255.255.255.0
//!              --gateway 0.0.0.0] [--store /var/lib/rc/station] [--vendor-id 0xffff]
//!              [--device-id 0x0001]
//! ```
//!
//! The name and IP are the factory values; values set permanently over DCP are kept in the
//! store file and win at the next start. An IP set over DCP (and a set IP at start) is
//! configured on the interface. With `--srci-echo` the I&M1..4 a controller writes are
//! kept in `<store>.im`.
//!
//! With `--srci-echo 64|128|256` it runs the whole IO-device (DCP, connection management,
//! cyclic exchange) with an SRCI module of that size whose input data echoes the PLC's
//! output data: the device side of the cyclic tests against a third-party controller.

use std::net::Ipv4Addr;
use std::process::ExitCode;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

use profinet::cm::ar::{CmDevice, activity};
use profinet::cm::im::ImRecords;
use profinet::cm::record::Identification;
use profinet::dcp::responder::DcpResponder;
use profinet::dcp::station::{
    DeviceIdentity, IpInterface, IpParameter, MemoryStore, NameOfStation, PermanentStore,
    StationParameters,
};
use profinet::device::{DEVICE_ID, DeviceModel, TYPE_OF_STATION, VENDOR_ID};
use profinet::link::address::InterfaceAddresses;
use profinet::link::dcp_service::DcpService;
use profinet::link::file_store::{FileStore, ImFile};
use profinet::link::io_device::{DeviceEvent, IoDevice, IoDeviceError};
use profinet::link::raw_socket::RawSocket;
use profinet::rt::c_sdu::SrciModuleSize;

/// Longest wait of one device poll, so that shutdown is noticed.
const POLL_INTERVAL: std::time::Duration = std::time::Duration::from_millis(20);

struct Options {
    interface: String,
    factory: StationParameters,
    store: Option<String>,
    vendor_id: u16,
    device_id: u16,
    echo: Option<SrciModuleSize>,
}

fn parse_options() -> Result<Options, String> {
    let mut interface = None;
    let mut name = NameOfStation::default();
    let mut ip = IpParameter::UNSET;
    let mut store = None;
    let mut vendor_id = VENDOR_ID;
    let mut device_id = DEVICE_ID;
    let mut echo = None;
    let mut args = std::env::args().skip(1);
    while let Some(flag) = args.next() {
        let value = args.next().ok_or_else(|| format!("{flag} needs a value"))?;
        let address = || {
            value
                .parse::<Ipv4Addr>()
                .map_err(|e| format!("{flag} {value}: {e}"))
        };
        let id = || {
            u16::from_str_radix(value.trim_start_matches("0x"), 16)
                .map_err(|e| format!("{flag} {value}: {e}"))
        };
        match flag.as_str() {
            "--interface" => interface = Some(value.clone()),
            "--name" => {
                name = NameOfStation::new(value.as_bytes()).map_err(|e| format!("--name: {e}"))?
            }
            "--ip" => ip.address = address()?,
            "--netmask" => ip.subnet_mask = address()?,
            "--gateway" => ip.gateway = address()?,
            "--store" => store = Some(value.clone()),
            "--vendor-id" => vendor_id = id()?,
            "--device-id" => device_id = id()?,
            "--srci-echo" => {
                echo = Some(match value.as_str() {
                    "64" => SrciModuleSize::Bytes64,
                    "128" => SrciModuleSize::Bytes128,
                    "256" => SrciModuleSize::Bytes256,
                    _ => return Err(format!("--srci-echo {value}: 64, 128 or 256")),
                })
            }
            other => return Err(format!("unknown option {other}")),
        }
    }
    let ip = ip
        .validate()
        .map_err(|e| format!("--ip/--netmask/--gateway: {e}"))?;
    Ok(Options {
        interface: interface.ok_or("--interface is required")?,
        factory: StationParameters {
            name_of_station: name,
            ip,
        },
        store,
        vendor_id,
        device_id,
        echo,
    })
}

fn serve<S: PermanentStore>(
    options: Options,
    store: S,
    im_file: Option<ImFile>,
) -> Result<(), String> {
    let socket = RawSocket::open(&options.interface).map_err(|e| e.to_string())?;
    let identity = DeviceIdentity {
        mac: socket.mac(),
        vendor_id: options.vendor_id,
        device_id: options.device_id,
        device_instance: 0x0001,
        type_of_station: TYPE_OF_STATION.to_owned(),
    };
    let interface = InterfaceAddresses::new(&options.interface);
    let responder = DcpResponder::new(identity, options.factory, store, interface);
    let shutdown = Arc::new(AtomicBool::new(false));
    let flag = Arc::clone(&shutdown);
    ctrlc::set_handler(move || flag.store(true, Ordering::Relaxed))
        .map_err(|e| format!("cannot handle SIGINT/SIGTERM: {e}"))?;
    match options.echo {
        None => DcpService::new(socket, responder)
            .run(&shutdown)
            .map_err(|e| e.to_string()),
        Some(size) => echo(socket, responder, size, im_file, &shutdown).map_err(|e| e.to_string()),
    }
}

/// The IO-device with an SRCI module whose input data is the last valid output data.
fn echo<S: PermanentStore, I: IpInterface>(
    socket: RawSocket,
    responder: DcpResponder<S, I>,
    size: SrciModuleSize,
    im_file: Option<ImFile>,
    shutdown: &AtomicBool,
) -> Result<(), IoDeviceError> {
    let mac = socket.mac();
    let seed = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs());
    let device = CmDevice {
        model: DeviceModel::srci(size),
        identification: Identification::robot_controller("echo"),
        im: ImRecords::default(),
        mac,
        activity: activity(mac, seed),
    };
    let mut device = IoDevice::open(socket, responder, device, im_file)?;
    let length = usize::from(size.data_length());
    let mut input = [0u8; 256];
    let mut received = [0u8; 256];
    while !shutdown.load(Ordering::Relaxed) {
        let mut fresh = false;
        device.poll(POLL_INTERVAL, None, &input[..length], false, |event| {
            if let DeviceEvent::Output(data) = event {
                received[..data.len()].copy_from_slice(data);
                fresh = true;
            }
        })?;
        if fresh {
            input = received;
        }
    }
    device.stop()
}

fn main() -> ExitCode {
    tracing_subscriber::fmt()
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env()
                .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("info")),
        )
        .init();
    let result = parse_options().and_then(|mut options| match options.store.take() {
        Some(path) => {
            let im_file = ImFile::new(format!("{path}.im"));
            serve(options, FileStore::new(path), Some(im_file))
        }
        None => serve(options, MemoryStore::default(), None),
    });
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(error) => {
            eprintln!("profinet-dcp: {error}");
            ExitCode::FAILURE
        }
    }
}
