//! The PROFINET row of `rc bench latency` (issue 6): the period of our cyclic input frames
//! (controller → PLC) at 8, 2 and 1 ms, and the SRCI reply latency through PROFINET at 8 and
//! 2 ms, both measured from tshark captures.
//!
//! Two private network namespaces joined by a veth pair: `rc run` with the PROFINET transport
//! in one, profinet-py (`target/profinet-venv`, see `services/profinet/setup.sh`) and tshark
//! in the other. The frame period comes from profinet-py's cyclic IO-controller, a few
//! seconds per period. The reply latency comes from `rc plc` sending ReadActualPosition
//! requests through the system test's gateway script (`services/profinet/tests/
//! srci_gateway.py`: TCP from `rc plc`, profinet-py as the IO-controller), captured on both
//! ends of the veth (a sender's own frames do not show in a capture on its interface, so
//! each end captures what it receives: the PLC's output frames as they reach our device,
//! our input frames as they reach the PLC): every output frame whose telegram carries a new
//! SEQ is matched to the first input frame whose telegram acknowledges it. The device
//! times the same requests on its own monotonic clock (`fieldbus::profinet_timing`) and
//! logs, when the session ends, our processing apart from the wait for its next input
//! frame: the row prints that too, so the phase between the two cycles is not taken for our
//! time. Needs root, `ip`, tshark and the venv; without them the row is skipped with one
//! line saying why.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use anyhow::{Context, bail};
use fieldbus::profinet_timing::REPLY_TIMING_LOG;
use orchestrator::child_process;
use plc_client::engine::CyclicSelection;
use profinet::ethernet::{ETHER_TYPE_PROFINET, EthernetHeader};
use profinet::link::veth::VethPair;
use shared_types::config::Config;
use shared_types::srci::telegram::{
    PLC_HEADER_LEN, PlcHeader, ROBOT_HEADER_LEN, RobotHeader, Sequence, sequence_areas,
};
use toml::{Table, Value};

use super::private_controller::{PrivateConfigError, private_config_text};
use super::stats::Distribution;
use super::{CYCLE_TIMES_MS, progress};

/// Seconds of cyclic exchange per period.
const SECONDS_PER_PERIOD: u32 = 3;
/// Addresses of the PLC and the device on the veth pair.
const PLC_ADDRESS: &str = "192.168.78.1/24";
const DEVICE_IP: &str = "192.168.78.50";
/// profinet-py's wait for DCP answers, seconds.
const DISCOVER_TIMEOUT_S: &str = "3";
/// How long the controller may take until its DCP responder listens.
const START_TIMEOUT: Duration = Duration::from_secs(60);
/// What the controller logs when its DCP responder listens, and when the watchdog ends an AR.
const LISTENING: &str = "DCP responder listening";
const WATCHDOG: &str = "the PLC's cyclic data stopped";
/// The checkout this `rc` was built from: the venv, the GSDML and the gateway script are
/// found there.
const REPOSITORY: &str = env!("CARGO_MANIFEST_DIR");
/// Periods of the reply latency measurement (ms).
const LATENCY_PERIODS_MS: [u64; 2] = [8, 2];
/// ReadActualPosition requests per latency period.
const LATENCY_REQUESTS: usize = 100;
/// The gateway's TCP address for `rc plc`, on the loopback of the PLC namespace.
const GATEWAY_ADDRESS: &str = "127.0.0.1:5000";
/// `rc plc`'s lifesign timeout through the gateway, whose round trip takes three input
/// frames (as in the system test).
const GATEWAY_LIFESIGN_MS: &str = "200";
/// How long the gateway may take until it is in data exchange.
const GATEWAY_TIMEOUT: Duration = Duration::from_secs(30);
/// What the gateway prints once it is in data exchange.
const GATEWAY_READY: &str = "gateway ready";

/// The printed lines of the PROFINET row: the measurement, or one line saying why it was
/// skipped or failed. Never fails: the rest of the bench stands without it.
pub fn report(config: &Config) -> String {
    let tools = match Tools::find() {
        Ok(tools) => tools,
        Err(why) => return format!("PROFINET row skipped: {why}\n"),
    };
    match measure(config, &tools) {
        Ok((periods, latencies)) => render(&periods, &latencies),
        Err(e) => format!("PROFINET row failed: {e:#}\n"),
    }
}

/// What the measurement runs.
struct Tools {
    tshark: PathBuf,
    profinet_py: PathBuf,
    /// The venv's Python, for the gateway script.
    python: PathBuf,
    gateway: PathBuf,
    gsdml: PathBuf,
}

impl Tools {
    /// The tools, or why the row cannot run.
    fn find() -> Result<Self, String> {
        // SAFETY: geteuid has no preconditions.
        if unsafe { libc::geteuid() } != 0 {
            return Err("needs root (network namespaces and raw sockets)".into());
        }
        let in_path = |name: &str| {
            std::env::var_os("PATH").and_then(|paths| {
                std::env::split_paths(&paths)
                    .map(|dir| dir.join(name))
                    .find(|path| path.exists())
            })
        };
        in_path("ip").ok_or("`ip` (iproute2) is not installed")?;
        let tshark = in_path("tshark").ok_or("tshark is not installed")?;
        let venv = std::env::var_os("PROFINET_PY_VENV")
            .map(PathBuf::from)
            .unwrap_or_else(|| Path::new(REPOSITORY).join("target/profinet-venv"));
        let profinet_py = venv.join("bin/profinet");
        if !profinet_py.exists() {
            return Err(format!(
                "profinet-py is missing ({}; bash services/profinet/setup.sh installs it)",
                profinet_py.display()
            ));
        }
        let gsdml = Path::new(REPOSITORY).join("config/GSDML-V2.41-rc-SRCI-20261122.xml");
        let gateway = Path::new(REPOSITORY).join("services/profinet/tests/srci_gateway.py");
        if let Some(missing) = [&gsdml, &gateway].into_iter().find(|path| !path.exists()) {
            return Err(format!("{} is missing", missing.display()));
        }
        Ok(Self {
            tshark,
            profinet_py,
            python: venv.join("bin/python"),
            gateway,
            gsdml,
        })
    }
}

/// How the AR of one period ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Ending {
    /// Without the controller's watchdog (or data-hold time) expiring.
    Clean,
    /// The watchdog expired after profinet-py stopped sending (it ends without a Release).
    AfterPlcStopped,
    /// The watchdog expired while profinet-py still sent: it missed the deadline.
    DuringExchange,
}

/// How the AR ended, from whether the watchdog fired (`expired`) and the capture timestamps
/// of our input frames: when they span less than 90 % of profinet-py's `duration_ns`, the
/// watchdog ended the exchange early. (The PLC's output frames would tell it directly, but
/// profinet-py's sends do not show in a capture on its own interface.)
fn ending(expired: bool, ours_ns: &[u64], duration_ns: u64) -> Ending {
    let span = match (ours_ns.first(), ours_ns.last()) {
        (Some(first), Some(last)) => last.saturating_sub(*first),
        _ => 0,
    };
    match expired {
        false => Ending::Clean,
        true if span < duration_ns / 10 * 9 => Ending::DuringExchange,
        true => Ending::AfterPlcStopped,
    }
}

/// What one period gave.
struct PeriodResult {
    period_ms: u64,
    /// Intervals between our consecutive input frames (ns).
    intervals: Distribution,
    /// How the AR ended.
    ending: Ending,
    /// profinet-py's own summary line, or how it ended without one.
    profinet_py: String,
}

/// What one reply latency period gave.
struct LatencyResult {
    period_ms: u64,
    /// The requests matched to their replies, the device's own timing and `rc plc`'s
    /// result line, or why the period could not be measured.
    outcome: Result<Latency, String>,
}

/// The reply latency of one period.
struct Latency {
    /// On the wire, from the captures.
    replies: Replies,
    /// In the device, from its log; `None` when it logged none (said in the row).
    device: Option<DeviceTiming>,
    /// `rc plc`'s result line.
    rc_plc: String,
}

/// The reply timing the device logged for one session, in µs: p50, p99 and maximum of
/// our processing (output frame received → answer at hand) and of the wait for the input
/// frame that carries the answer.
#[derive(Debug, PartialEq, Eq)]
struct DeviceTiming {
    requests: u64,
    processing: [u64; 3],
    cycle_wait: [u64; 3],
}

/// The device's last reply timing in the controller's log `text`.
fn parse_device_timing(text: &str) -> Option<DeviceTiming> {
    let line = text
        .lines()
        .rev()
        .find(|line| line.contains(REPLY_TIMING_LOG))?;
    let value = |key: &str| -> Option<u64> {
        line.split_whitespace().find_map(|token| {
            token
                .strip_prefix(key)?
                .strip_prefix('=')?
                .trim_matches(|c: char| !c.is_ascii_digit())
                .parse()
                .ok()
        })
    };
    let three = |quantity: &str| -> Option<[u64; 3]> {
        Some([
            value(&format!("{quantity}_p50_us"))?,
            value(&format!("{quantity}_p99_us"))?,
            value(&format!("{quantity}_max_us"))?,
        ])
    };
    Some(DeviceTiming {
        requests: value("requests")?,
        processing: three("processing")?,
        cycle_wait: three("cycle_wait")?,
    })
}

/// How long the device may take to log its timing once the PLC went silent: its
/// watchdog (at most a few cycles) ends the session.
const DEVICE_TIMING_TIMEOUT: Duration = Duration::from_secs(5);

/// The frame periods, then the reply latencies (each period's failure kept in its result).
fn measure(
    config: &Config,
    tools: &Tools,
) -> anyhow::Result<(Vec<PeriodResult>, Vec<LatencyResult>)> {
    let dir = config
        .path
        .as_deref()
        .and_then(Path::parent)
        .context("the bench's configuration has no folder")?
        .join("profinet");
    std::fs::create_dir_all(&dir).with_context(|| format!("cannot create {}", dir.display()))?;
    let namespaces = VethPair::create("rcb", PLC_ADDRESS, &format!("{DEVICE_IP}/24"))?;
    let base = config
        .path
        .as_deref()
        .map(std::fs::read_to_string)
        .transpose()
        .context("cannot read the bench's configuration")?
        .context("the bench's configuration has no file")?;
    let config_file = dir.join("rc.toml");
    let text = profinet_config_text(
        &base,
        &format!("benchpn{}", std::process::id()),
        &namespaces.device_interface,
        &dir.join("data"),
    )?;
    std::fs::write(&config_file, text)
        .with_context(|| format!("cannot write {}", config_file.display()))?;
    let log_path = dir.join("rc.log");
    let log = std::fs::File::create(&log_path)
        .with_context(|| format!("cannot create {}", log_path.display()))?;
    let exe = std::env::current_exe().context("cannot locate the rc executable")?;
    let mut command = VethPair::command(&namespaces.device, &exe);
    command
        .arg("run")
        .arg("--config")
        .arg(&config_file)
        .env("RUST_LOG", "info")
        .stdin(Stdio::null())
        .stdout(log.try_clone().context("cannot share the log file")?)
        .stderr(log);
    let _controller = Running::spawn(command, "the controller")?;
    wait_for_text(&log_path, LISTENING, START_TIMEOUT)
        .with_context(|| format!("controller log: {}", log_path.display()))?;
    let station = &config.main.fieldbus.profinet.station_name;
    let mut results = Vec::new();
    for period_ms in CYCLE_TIMES_MS {
        progress(&format!(
            "PROFINET input frames at {period_ms} ms ({SECONDS_PER_PERIOD} s)"
        ));
        let capture_file = dir.join(format!("{period_ms}ms.pcap"));
        let result = measure_period(
            &namespaces,
            tools,
            station,
            period_ms,
            &capture_file,
            &log_path,
        )
        .with_context(|| format!("{period_ms} ms (controller log: {})", log_path.display()))?;
        results.push(result);
    }
    let run = LatencyRun {
        namespaces: &namespaces,
        tools,
        station,
        module_size: usize::from(config.main.fieldbus.profinet.module_size),
        rc: &exe,
        config_file: &config_file,
        dir: &dir,
        log: &log_path,
    };
    let latencies = LATENCY_PERIODS_MS
        .into_iter()
        .map(|period_ms| {
            progress(&format!(
                "SRCI reply latency through PROFINET at {period_ms} ms \
                 ({LATENCY_REQUESTS} requests)"
            ));
            LatencyResult {
                period_ms,
                outcome: run.measure(period_ms).map_err(|e| format!("{e:#}")),
            }
        })
        .collect();
    Ok((results, latencies))
}

/// What a reply latency period needs.
struct LatencyRun<'a> {
    namespaces: &'a VethPair,
    tools: &'a Tools,
    station: &'a str,
    /// Bytes of the SRCI module (and of each telegram) per direction.
    module_size: usize,
    rc: &'a Path,
    config_file: &'a Path,
    dir: &'a Path,
    /// The controller's log, where the device's timing appears.
    log: &'a Path,
}

impl LatencyRun<'_> {
    /// Runs the gateway at `period_ms` and `rc plc` through it while capturing on the
    /// device's interface; the requests matched to their replies, the device's timing and
    /// `rc plc`'s result.
    fn measure(&self, period_ms: u64) -> anyhow::Result<Latency> {
        let (namespaces, tools) = (self.namespaces, self.tools);
        let timings_before = count_in_file(self.log, REPLY_TIMING_LOG);
        let program = self.dir.join("reply-latency.toml");
        std::fs::write(&program, latency_program(LATENCY_REQUESTS))
            .with_context(|| format!("cannot write {}", program.display()))?;
        // A sender's frames do not show in a capture on its own interface (neither
        // profinet-py's nor ours): each end of the veth captures the frames it receives.
        let captures = [
            (&namespaces.device, &namespaces.device_interface, "device"),
            (&namespaces.plc, &namespaces.plc_interface, "plc"),
        ]
        .map(|(namespace, interface, end)| {
            let file = self.dir.join(format!("srci-{period_ms}ms-{end}.pcap"));
            start_capture(tools, namespace, interface, &file).map(|capture| (capture, file))
        });
        let mut running = captures.into_iter().collect::<anyhow::Result<Vec<_>>>()?;
        let gateway_log = self.dir.join(format!("gateway-{period_ms}ms.log"));
        let log = std::fs::File::create(&gateway_log)
            .with_context(|| format!("cannot create {}", gateway_log.display()))?;
        let mut gateway = VethPair::command(&namespaces.plc, &tools.python);
        gateway
            .arg(&tools.gateway)
            .arg(&namespaces.plc_interface)
            .arg(self.station)
            .arg(&tools.gsdml)
            .args(["--listen", GATEWAY_ADDRESS])
            .args(["--cycle-ms", &period_ms.to_string()])
            .args(["--size", &self.module_size.to_string()])
            .stdin(Stdio::null())
            .stdout(log.try_clone().context("cannot share the log file")?)
            .stderr(log);
        let mut gateway = Running::spawn(gateway, "the gateway")?;
        wait_for_text(&gateway_log, GATEWAY_READY, GATEWAY_TIMEOUT)
            .with_context(|| format!("gateway log: {}", gateway_log.display()))?;
        let layout = std::fs::read_to_string(&gateway_log)
            .ok()
            .as_deref()
            .and_then(parse_layout)
            .with_context(|| {
                format!(
                    "the gateway printed no SRCI layout ({})",
                    gateway_log.display()
                )
            })?;
        let output = VethPair::command(&namespaces.plc, self.rc)
            .arg("plc")
            .arg(&program)
            .args(["--addr", GATEWAY_ADDRESS])
            .args(["--cycle-ms", &period_ms.to_string()])
            .args(["--lifesign-ms", GATEWAY_LIFESIGN_MS])
            .arg("--config")
            .arg(self.config_file)
            .stdin(Stdio::null())
            .output()
            .context("cannot run rc plc")?;
        for (capture, _) in &mut running {
            capture.stop()?;
        }
        gateway.stop()?;
        // The device logs its timing when the session ends (by its watchdog, now).
        let device = wait_for_occurrences(
            self.log,
            REPLY_TIMING_LOG,
            timings_before + 1,
            DEVICE_TIMING_TIMEOUT,
        )
        .ok()
        .and_then(|()| std::fs::read_to_string(self.log).ok())
        .as_deref()
        .and_then(parse_device_timing);
        let rc_plc = outcome(
            "rc plc",
            &String::from_utf8_lossy(&output.stdout),
            "result:",
            &output.status.to_string(),
        );
        let mut files = Vec::new();
        for (_, file) in &running {
            let bytes =
                std::fs::read(file).with_context(|| format!("cannot read {}", file.display()))?;
            files.push((file, bytes));
        }
        let mut captures = Vec::new();
        for (file, bytes) in &files {
            captures.push(
                pcap_frames(bytes).with_context(|| format!("cannot read {}", file.display()))?,
            );
        }
        let frames = merge_captures(captures);
        Ok(Latency {
            replies: match_replies(&frames, &layout, self.module_size),
            device,
            rc_plc,
        })
    }
}

/// A `rc plc` program of `requests` ReadActualPosition calls.
fn latency_program(requests: usize) -> String {
    let mut text = String::from("name = \"reply latency\"\n");
    for _ in 0..requests {
        text.push_str("\n[[step]]\ncall = \"ReadActualPosition\"\n");
    }
    text
}

/// Starts tshark in `namespace`, writing the PROFINET frames on `interface` to
/// `capture_file` (classic pcap, which [`pcap_frames`] reads); returns once it captures.
fn start_capture(
    tools: &Tools,
    namespace: &str,
    interface: &str,
    capture_file: &Path,
) -> anyhow::Result<Running> {
    // A file of an earlier run would look like a started capture.
    match std::fs::remove_file(capture_file) {
        Err(e) if e.kind() != std::io::ErrorKind::NotFound => {
            return Err(e).with_context(|| format!("cannot remove {}", capture_file.display()));
        }
        _ => {}
    }
    let log_path = capture_file.with_extension("tshark.log");
    let log = std::fs::File::create(&log_path)
        .with_context(|| format!("cannot create {}", log_path.display()))?;
    let mut capture = VethPair::command(namespace, &tools.tshark);
    capture
        .args([
            "-i",
            interface,
            "-f",
            "ether proto 0x8892",
            "-F",
            "pcap",
            "-w",
        ])
        .arg(capture_file)
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(log);
    let mut capture = Running::spawn(capture, "tshark")?;
    let deadline = Instant::now() + Duration::from_secs(10);
    while !capture_file.exists() {
        let ended = capture.child.try_wait().ok().flatten();
        if ended.is_some() || Instant::now() > deadline {
            let log = std::fs::read_to_string(&log_path).unwrap_or_default();
            let how = ended.map_or_else(|| "within 10 s".to_string(), |s| format!("({s})"));
            bail!("tshark did not start capturing {how}: {}", log.trim());
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    // dumpcap creates the file before the capture filter is applied.
    std::thread::sleep(Duration::from_millis(500));
    Ok(capture)
}

fn measure_period(
    namespaces: &VethPair,
    tools: &Tools,
    station: &str,
    period_ms: u64,
    capture_file: &Path,
    log_path: &Path,
) -> anyhow::Result<PeriodResult> {
    let aborts_before = count_in_file(log_path, WATCHDOG);
    let mut capture = start_capture(
        tools,
        &namespaces.plc,
        &namespaces.plc_interface,
        capture_file,
    )?;
    let output = VethPair::command(&namespaces.plc, &tools.profinet_py)
        .args(["-i", &namespaces.plc_interface, "-t", DISCOVER_TIMEOUT_S])
        .args(["cyclic", station, "--gsdml"])
        .arg(&tools.gsdml)
        .args(["--cycle-ms", &period_ms.to_string()])
        .args(["--duration", &SECONDS_PER_PERIOD.to_string()])
        .stdin(Stdio::null())
        .output()
        .context("cannot run profinet-py")?;
    capture.stop()?;
    let stdout = String::from_utf8_lossy(&output.stdout);
    let profinet_py = outcome(
        "profinet-py",
        &stdout,
        "Stopped.",
        &output.status.to_string(),
    );
    let Some(input) = input_frame_id(&stdout) else {
        bail!(
            "profinet-py did not connect: {}",
            String::from_utf8_lossy(&output.stderr).trim()
        );
    };
    let ours = frame_times(&tools.tshark, capture_file, input)?;
    let expired = count_in_file(log_path, WATCHDOG) > aborts_before;
    Ok(PeriodResult {
        period_ms,
        intervals: intervals(&ours),
        ending: ending(
            expired,
            &ours,
            u64::from(SECONDS_PER_PERIOD) * 1_000_000_000,
        ),
        profinet_py,
    })
}

/// The capture timestamps (ns) of the frames with `frame_id` in `capture_file`.
fn frame_times(tshark: &Path, capture_file: &Path, frame_id: &str) -> anyhow::Result<Vec<u64>> {
    let output = Command::new(tshark)
        .arg("-r")
        .arg(capture_file)
        .args(["-Y", &format!("pn_rt.frame_id == {frame_id}")])
        .args(["-T", "fields", "-e", "frame.time_epoch"])
        .output()
        .context("cannot run tshark on the capture")?;
    if !output.status.success() {
        bail!(
            "tshark -r {}: {}",
            capture_file.display(),
            String::from_utf8_lossy(&output.stderr).trim()
        );
    }
    Ok(parse_timestamps_ns(&String::from_utf8_lossy(
        &output.stdout,
    ))?)
}

/// `text` (the bench's private configuration) with the PROFINET transport on `interface`,
/// the instance `instance` and its data in `data_dir`.
fn profinet_config_text(
    text: &str,
    instance: &str,
    interface: &str,
    data_dir: &Path,
) -> Result<String, PrivateConfigError> {
    // The fieldbus.listen is unused with the PROFINET transport.
    let text = private_config_text(text, instance, "127.0.0.1:0", data_dir)?;
    let mut table: Table = text.parse()?;
    let fieldbus = table
        .get_mut("fieldbus")
        .and_then(Value::as_table_mut)
        .ok_or(PrivateConfigError::MissingTable("fieldbus"))?;
    fieldbus.insert("transport".into(), Value::String("profinet".into()));
    let profinet = fieldbus
        .get_mut("profinet")
        .and_then(Value::as_table_mut)
        .ok_or(PrivateConfigError::MissingTable("fieldbus.profinet"))?;
    for (key, value) in [
        ("interface", interface),
        ("ip", DEVICE_IP),
        ("netmask", "255.255.255.0"),
        ("data_dir", &data_dir.display().to_string()),
    ] {
        profinet.insert(key.into(), Value::String(value.into()));
    }
    Ok(toml::to_string(&table)?)
}

/// A line of tshark's `frame.time_epoch` output could not be read.
#[derive(Debug, PartialEq, Eq, thiserror::Error)]
#[error("not a capture timestamp: {0:?}")]
struct TimestampError(String);

/// Capture timestamps (`seconds[.fraction]`, one per line, blank lines ignored) in ns since
/// the epoch, exactly (no floating point).
fn parse_timestamps_ns(text: &str) -> Result<Vec<u64>, TimestampError> {
    let parse = |line: &str| -> Option<u64> {
        let (seconds, fraction) = line.split_once('.').unwrap_or((line, ""));
        let digits = |s: &str| s.bytes().all(|b| b.is_ascii_digit());
        if seconds.is_empty() || !digits(seconds) || !digits(fraction) || fraction.len() > 9 {
            return None;
        }
        let nanos: u64 = format!("{fraction:0<9}").parse().ok()?;
        seconds
            .parse::<u64>()
            .ok()?
            .checked_mul(1_000_000_000)?
            .checked_add(nanos)
    };
    text.lines()
        .map(str::trim)
        .filter(|line| !line.is_empty())
        .map(|line| parse(line).ok_or_else(|| TimestampError(line.to_owned())))
        .collect()
}

/// The intervals between consecutive timestamps (ns; a timestamp earlier than the one before
/// it counts as 0).
fn intervals(times_ns: &[u64]) -> Distribution {
    Distribution::new(
        times_ns
            .windows(2)
            .map(|w| w[1].saturating_sub(w[0]))
            .collect(),
    )
}

/// Our input FrameID as profinet-py reports it (`Input frame: 0xC001, ...`).
fn input_frame_id(stdout: &str) -> Option<&str> {
    stdout.lines().find_map(|line| {
        let rest = line.split_once("Input frame:")?.1.trim_start();
        let id = rest.split([',', ' ']).next()?;
        (id.starts_with("0x") && id.len() > 2).then_some(id)
    })
}

/// `who`'s summary line (the first line of `stdout` starting with `marker`), or its exit
/// `status` when it has none.
fn outcome(who: &str, stdout: &str, marker: &str, status: &str) -> String {
    stdout
        .lines()
        .map(str::trim)
        .find(|line| line.starts_with(marker))
        .map_or_else(
            || format!("{who} ended without a summary ({status})"),
            |line| format!("{who}: {line}"),
        )
}

/// Where the SRCI module's data sits in one direction's frames.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Place {
    frame_id: u16,
    /// Offset of the telegram in the C_SDU.
    offset: usize,
}

impl Place {
    /// The telegram of `size` bytes in the C_SDU `c_sdu` (`None` when it is too short).
    fn telegram<'a>(&self, c_sdu: &'a [u8], size: usize) -> Option<&'a [u8]> {
        c_sdu.get(self.offset..self.offset.checked_add(size)?)
    }
}

/// Where the SRCI module's data sits in the PLC's output frames and in our input frames.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct SrciLayout {
    output: Place,
    input: Place,
}

/// The layout from the gateway's line
/// `srci layout: output frame 0xC000 offset 0 input frame 0xC001 offset 3`.
fn parse_layout(text: &str) -> Option<SrciLayout> {
    let line = text
        .lines()
        .find_map(|line| line.strip_prefix("srci layout:"))?;
    let words: Vec<&str> = line.split_whitespace().collect();
    let place = |id: &str, offset: &str| {
        Some(Place {
            frame_id: u16::from_str_radix(id.strip_prefix("0x")?, 16).ok()?,
            offset: offset.parse().ok()?,
        })
    };
    match words.as_slice() {
        [
            "output",
            "frame",
            output_id,
            "offset",
            output_offset,
            "input",
            "frame",
            input_id,
            "offset",
            input_offset,
        ] => Some(SrciLayout {
            output: place(output_id, output_offset)?,
            input: place(input_id, input_offset)?,
        }),
        _ => None,
    }
}

/// A capture file that is not a classic pcap file of Ethernet frames.
#[derive(Debug, PartialEq, Eq, thiserror::Error)]
enum PcapError {
    #[error("not a pcap file")]
    Magic,
    #[error("link type {0} is not Ethernet")]
    LinkType(u32),
    #[error("the capture ends inside the record at byte {0}")]
    Truncated(usize),
}

/// The frames of a classic pcap file (either byte order, µs or ns timestamps) with their
/// capture times in ns since the epoch.
fn pcap_frames(bytes: &[u8]) -> Result<Vec<(u64, &[u8])>, PcapError> {
    let (big_endian, nanoseconds) = match bytes.get(0..4) {
        Some([0xd4, 0xc3, 0xb2, 0xa1]) => (false, false),
        Some([0xa1, 0xb2, 0xc3, 0xd4]) => (true, false),
        Some([0x4d, 0x3c, 0xb2, 0xa1]) => (false, true),
        Some([0xa1, 0xb2, 0x3c, 0x4d]) => (true, true),
        _ => return Err(PcapError::Magic),
    };
    let u32_at = |at: usize| {
        let field: [u8; 4] = bytes.get(at..at.checked_add(4)?)?.try_into().ok()?;
        Some(if big_endian {
            u32::from_be_bytes(field)
        } else {
            u32::from_le_bytes(field)
        })
    };
    let link_type = u32_at(20).ok_or(PcapError::Truncated(0))?;
    if link_type != 1 {
        return Err(PcapError::LinkType(link_type));
    }
    let fraction_ns = if nanoseconds { 1 } else { 1_000 };
    let mut frames = Vec::new();
    let mut at = 24;
    while at < bytes.len() {
        let field = |i: usize| u32_at(at + 4 * i).ok_or(PcapError::Truncated(at));
        let (seconds, fraction, captured) = (field(0)?, field(1)?, field(2)?);
        let start = at + 16;
        let frame = usize::try_from(captured)
            .ok()
            .and_then(|length| bytes.get(start..start.checked_add(length)?))
            .ok_or(PcapError::Truncated(at))?;
        let time = u64::from(seconds) * 1_000_000_000 + u64::from(fraction) * fraction_ns;
        frames.push((time, frame));
        at = start + frame.len();
    }
    Ok(frames)
}

/// The frames of `captures` (each in time order, all timed by the same clock) in time order,
/// cut to the span in which all of them captured: tshark loses a different tail of each
/// capture when stopped, and a request whose reply fell into a lost tail is no unanswered
/// request.
fn merge_captures(captures: Vec<Vec<(u64, &[u8])>>) -> Vec<(u64, &[u8])> {
    // An empty capture has no span: then nothing was captured by all of them.
    let span = |capture: &Vec<(u64, &[u8])>| Some((capture.first()?.0, capture.last()?.0));
    let Some(spans) = captures.iter().map(span).collect::<Option<Vec<_>>>() else {
        return Vec::new();
    };
    let first = spans.iter().map(|s| s.0).max().unwrap_or(0);
    let last = spans.iter().map(|s| s.1).min().unwrap_or(0);
    let mut frames: Vec<_> = captures
        .into_iter()
        .flatten()
        .filter(|&(time, _)| (first..=last).contains(&time))
        .collect();
    // Stable: each capture keeps its order among equal times.
    frames.sort_by_key(|&(time, _)| time);
    frames
}

/// The FrameID and what follows it (the C_SDU, then the APDU status) of a PROFINET RT frame
/// (tagged or untagged); `None` for any other frame.
fn rt_payload(frame: &[u8]) -> Option<(u16, &[u8])> {
    let (header, payload) = EthernetHeader::parse(frame).ok()?;
    (header.ether_type == ETHER_TYPE_PROFINET).then_some(())?;
    let frame_id = u16::from_be_bytes(payload.get(..2)?.try_into().ok()?);
    Some((frame_id, &payload[2..]))
}

/// The SEQ_ACK of the (first) sequence of `telegram`, behind its header and `cyclic_len`
/// bytes of cyclic data.
fn seq_ack(telegram: &[u8], header_len: usize, cyclic_len: usize) -> Option<u16> {
    let ([(start, length), _], _) = sequence_areas(telegram.len(), header_len, cyclic_len, false);
    let area = telegram.get(start..start.checked_add(length)?)?;
    Some(Sequence::decode(area).ok()?.seq_ack)
}

/// The SEQ of a PLC→robot telegram and the bytes of cyclic data the robot sends before its
/// ACK; `None` for a telegram torn between two writes (header and footer lifesign differ)
/// or one with two sequences (not matched here).
fn plc_seq(telegram: &[u8]) -> Option<(u16, usize)> {
    if !PlcHeader::is_consistent(telegram) {
        return None;
    }
    let header = PlcHeader::decode(telegram).ok()?;
    if header.two_sequences() {
        return None;
    }
    let selected = header.telegram_number_rob_to_plc;
    let cyclic = CyclicSelection {
        cartesian: selected & (1 << 1) != 0,
        joints: selected & (1 << 2) != 0,
    };
    let seq = seq_ack(telegram, PLC_HEADER_LEN, cyclic.plc_len())?;
    Some((seq, cyclic.robot_len()))
}

/// The ACK of a robot→PLC telegram with `cyclic_len` bytes of cyclic data; `None` for a
/// torn telegram.
fn robot_ack(telegram: &[u8], cyclic_len: usize) -> Option<u16> {
    RobotHeader::is_consistent(telegram)
        .then(|| seq_ack(telegram, ROBOT_HEADER_LEN, cyclic_len))
        .flatten()
}

/// SRCI requests matched to their replies in a capture.
#[derive(Debug, Default, PartialEq, Eq)]
struct Replies {
    /// From each output frame that carried a new SEQ to the first input frame whose ACK is
    /// that SEQ (ns).
    latencies: Vec<u64>,
    /// Of those, the replies in the first input frame after their request.
    next_frame: usize,
    /// New SEQs that no input frame acknowledged before the next SEQ or the capture's end.
    unanswered: usize,
    /// New SEQs the robot's ACK already equalled when they appeared: not timed.
    ambiguous: usize,
    /// SRCI frames whose telegram could not be read (too short, torn, two sequences).
    unreadable: usize,
}

/// Matches, in capture order (`frames` sorted by time), every PLC→robot telegram with a new SEQ (0, the SEQ before
/// the first request, excluded) to the first robot→PLC telegram whose ACK is that SEQ.
fn match_replies(frames: &[(u64, &[u8])], layout: &SrciLayout, size: usize) -> Replies {
    let mut replies = Replies::default();
    let mut last_seq = None;
    let mut ack = None;
    let mut robot_cyclic_len = 0;
    // The SEQ waiting for its ACK, when it was sent, and whether an input frame without
    // its ACK followed it.
    let mut pending: Option<(u16, u64, bool)> = None;
    for &(time, frame) in frames {
        let Some((frame_id, c_sdu)) = rt_payload(frame) else {
            continue;
        };
        if frame_id == layout.output.frame_id {
            let Some((seq, cyclic_len)) = layout.output.telegram(c_sdu, size).and_then(plc_seq)
            else {
                replies.unreadable += 1;
                continue;
            };
            robot_cyclic_len = cyclic_len;
            if last_seq == Some(seq) {
                continue;
            }
            last_seq = Some(seq);
            if pending.take().is_some() {
                replies.unanswered += 1;
            }
            if seq == 0 {
                continue;
            }
            if ack == Some(seq) {
                replies.ambiguous += 1;
            } else {
                pending = Some((seq, time, false));
            }
        } else if frame_id == layout.input.frame_id {
            let Some(robot) = layout
                .input
                .telegram(c_sdu, size)
                .and_then(|telegram| robot_ack(telegram, robot_cyclic_len))
            else {
                replies.unreadable += 1;
                continue;
            };
            ack = Some(robot);
            match &mut pending {
                Some((seq, sent, missed)) if *seq == robot => {
                    replies.latencies.push(time.saturating_sub(*sent));
                    replies.next_frame += usize::from(!*missed);
                    pending = None;
                }
                Some((_, _, missed)) => *missed = true,
                None => {}
            }
        }
    }
    replies.unanswered += usize::from(pending.is_some());
    replies
}

/// `ns` in ms with three decimals.
fn ms(ns: u64) -> String {
    format!("{:.3}", ns as f64 / 1e6)
}

/// The count and percentiles of `distribution`, or `empty` when it has no samples.
fn figures(distribution: &Distribution, empty: &str) -> String {
    distribution.summary().map_or_else(
        || empty.to_string(),
        |s| {
            format!(
                "n {:>5}  p50 {:>7} ms  p99 {:>7} ms  max {:>7} ms",
                s.count,
                ms(s.p50),
                ms(s.p99),
                ms(s.max)
            )
        },
    )
}

/// The printed lines of the measured row.
fn render(periods: &[PeriodResult], latencies: &[LatencyResult]) -> String {
    let mut text = format!(
        "PROFINET input frame period (controller -> PLC, veth between two namespaces, \
         profinet-py IO-controller, tshark capture, {SECONDS_PER_PERIOD} s per period):\n"
    );
    for p in periods {
        let figures = figures(&p.intervals, "no intervals captured");
        let ending = match p.ending {
            Ending::Clean => String::new(),
            Ending::AfterPlcStopped => {
                "; AR ended by the watchdog after profinet-py stopped (it sends no Release)".into()
            }
            Ending::DuringExchange => format!(
                "; aborted by the controller's watchdog after {} frames (profinet-py missed \
                 its deadline)",
                p.intervals.count() + 1
            ),
        };
        let _ = writeln!(
            text,
            "  {:>2} ms  {figures}{ending}; {}",
            p.period_ms, p.profinet_py
        );
    }
    let _ = writeln!(
        text,
        "SRCI reply latency through PROFINET ({LATENCY_REQUESTS} ReadActualPosition from rc plc \
         through the gateway script and profinet-py; captures on both veth ends, from the \
         PLC's output frame with a new SEQ reaching our device to our first input frame whose \
         ACK is that SEQ reaching the PLC: our device, fieldbus process and interpreter plus \
         the wait for the next input cycle):"
    );
    for l in latencies {
        let line = match &l.outcome {
            Ok(latency) => format!(
                "{}; {}\n         in the device: {}",
                replies_line(&latency.replies),
                latency.rc_plc,
                device_line(latency.device.as_ref())
            ),
            Err(why) => format!("not measured: {why}"),
        };
        let _ = writeln!(text, "  {:>2} ms  {line}", l.period_ms);
    }
    text
}

/// The device's own timing of the requests, or why there is none.
fn device_line(timing: Option<&DeviceTiming>) -> String {
    let Some(timing) = timing else {
        return "no timing in the controller's log".to_owned();
    };
    let ms3 = |[p50, p99, max]: [u64; 3]| {
        format!(
            "p50 {:.3} ms, p99 {:.3} ms, max {:.3} ms",
            p50 as f64 / 1e3,
            p99 as f64 / 1e3,
            max as f64 / 1e3
        )
    };
    format!(
        "processing (output frame received -> answer at hand) {}; wait for the input \
         frame {} ({} requests)",
        ms3(timing.processing),
        ms3(timing.cycle_wait),
        timing.requests
    )
}

/// The figures of `replies`, with what could not be matched; no figures at all when nothing
/// could.
fn replies_line(replies: &Replies) -> String {
    let mut line = figures(
        &Distribution::new(replies.latencies.clone()),
        "no request could be matched to a reply in the capture",
    );
    if !replies.latencies.is_empty() {
        let _ = write!(
            line,
            "; {}/{} in the first input frame after the request",
            replies.next_frame,
            replies.latencies.len()
        );
    }
    for (count, what) in [
        (
            replies.unanswered,
            "requests without an acknowledging reply",
        ),
        (
            replies.ambiguous,
            "requests not timed (the ACK already equalled the new SEQ)",
        ),
        (replies.unreadable, "unreadable SRCI frames"),
    ] {
        if count > 0 {
            let _ = write!(line, "; {count} {what}");
        }
    }
    line
}

/// How often `text` occurs in `file` (0 when it cannot be read).
fn count_in_file(file: &Path, text: &str) -> usize {
    std::fs::read_to_string(file).map_or(0, |content| content.matches(text).count())
}

/// Waits until `file` contains `text`.
fn wait_for_text(file: &Path, text: &str, timeout: Duration) -> anyhow::Result<()> {
    wait_for_occurrences(file, text, 1, timeout)
}

/// Waits until `file` contains `text` at least `count` times.
fn wait_for_occurrences(
    file: &Path,
    text: &str,
    count: usize,
    timeout: Duration,
) -> anyhow::Result<()> {
    let deadline = Instant::now() + timeout;
    while count_in_file(file, text) < count {
        if Instant::now() > deadline {
            bail!("{text:?} did not appear within {timeout:?}");
        }
        std::thread::sleep(Duration::from_millis(100));
    }
    Ok(())
}

/// A child process stopped (SIGTERM, then SIGKILL) at the latest when dropped.
struct Running {
    child: Child,
    what: &'static str,
}

/// How long a child may take to stop after SIGTERM.
const STOP_TIMEOUT: Duration = Duration::from_secs(10);

impl Running {
    fn spawn(mut command: Command, what: &'static str) -> anyhow::Result<Self> {
        child_process::die_with_parent(&mut command);
        let child = command
            .spawn()
            .with_context(|| format!("cannot start {what}"))?;
        Ok(Self { child, what })
    }

    /// Stops the child and waits for it.
    fn stop(&mut self) -> anyhow::Result<()> {
        child_process::terminate(&self.child);
        child_process::stop(&mut self.child, STOP_TIMEOUT)
            .with_context(|| format!("cannot stop {}", self.what))?;
        Ok(())
    }
}

impl Drop for Running {
    fn drop(&mut self) {
        if let Ok(None) = self.child.try_wait() {
            // Errors here have no one to go to; the child dies with us at the latest.
            let _ = self.stop();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn timestamps_are_read_exactly_in_nanoseconds() {
        let text = "1763790000.123456789\n\n1763790000.5\n 1763790001 \n";
        assert_eq!(
            parse_timestamps_ns(text).unwrap(),
            [
                1_763_790_000_123_456_789,
                1_763_790_000_500_000_000,
                1_763_790_001_000_000_000
            ]
        );
        for bad in ["1.2.3", "x", ".5", "1.1234567890", "-1.0"] {
            assert_eq!(
                parse_timestamps_ns(bad),
                Err(TimestampError(bad.into())),
                "{bad}"
            );
        }
    }

    #[test]
    fn intervals_are_between_consecutive_frames() {
        let d = intervals(&[0, 8_000_000, 16_100_000, 24_000_000, 36_000_000]);
        let s = d.summary().unwrap();
        assert_eq!(s.count, 4);
        assert_eq!(s.p50, 8_000_000);
        assert_eq!(s.max, 12_000_000);
        assert_eq!(intervals(&[5]).count(), 0);
        assert_eq!(intervals(&[5, 3]).summary().unwrap().max, 0);
    }

    #[test]
    fn the_input_frame_id_and_summary_come_from_profinet_py() {
        let stdout = "PrmEnd OK\nInput frame: 0xC001, Output frame: 0xC000\n\
                      Stopped. TX=375 RX=374 missed=0\n";
        assert_eq!(input_frame_id(stdout), Some("0xC001"));
        assert_eq!(input_frame_id("Input frame: none"), None);
        assert_eq!(
            outcome("profinet-py", stdout, "Stopped.", "exit status: 0"),
            "profinet-py: Stopped. TX=375 RX=374 missed=0"
        );
        assert!(outcome("rc plc", "", "result:", "exit status: 1").contains("exit status: 1"));
        assert_eq!(
            outcome(
                "rc plc",
                "  result: SUCCESS (3/3 steps passed)\n",
                "result:",
                ""
            ),
            "rc plc: result: SUCCESS (3/3 steps passed)"
        );
    }

    #[test]
    fn the_config_switches_to_profinet_on_the_interface() {
        let dir = std::env::temp_dir().join(format!("rc-bench-pn-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let text = profinet_config_text(
            shared_types::config::EMBEDDED_DEFAULT,
            "benchpn1",
            "rcbvb1",
            &dir.join("d"),
        )
        .unwrap();
        let path = dir.join("rc.toml");
        std::fs::write(&path, text).unwrap();
        let config = Config::load(Some(&path)).unwrap();
        std::fs::remove_dir_all(&dir).unwrap();
        let fieldbus = &config.main.fieldbus;
        assert_eq!(config.main.instance, "benchpn1");
        assert_eq!(fieldbus.transport, "profinet");
        assert_eq!(fieldbus.profinet.interface, "rcbvb1");
        assert_eq!(fieldbus.profinet.ip, DEVICE_IP);
    }

    #[test]
    fn the_watchdog_counts_as_an_abort_only_when_our_frames_stopped_early() {
        let ours = [1000, 1500, 1900];
        assert_eq!(ending(false, &ours, 2000), Ending::Clean);
        assert_eq!(ending(true, &ours, 1000), Ending::AfterPlcStopped);
        assert_eq!(ending(true, &ours, 1010), Ending::DuringExchange);
        assert_eq!(ending(true, &[], 1000), Ending::DuringExchange);
    }

    #[test]
    fn an_aborted_period_says_so() {
        let text = render(
            &[PeriodResult {
                period_ms: 1,
                intervals: intervals(&[0, 1_000_000, 2_000_000]),
                ending: Ending::DuringExchange,
                profinet_py: "profinet-py: Stopped.".into(),
            }],
            &[
                LatencyResult {
                    period_ms: 8,
                    outcome: Ok(Latency {
                        replies: Replies {
                            latencies: vec![9_000_000, 10_000_000],
                            next_frame: 2,
                            unanswered: 1,
                            ..Replies::default()
                        },
                        device: Some(DeviceTiming {
                            requests: 2,
                            processing: [210, 400, 900],
                            cycle_wait: [6_500, 7_800, 7_900],
                        }),
                        rc_plc: "rc plc: result: SUCCESS".into(),
                    }),
                },
                LatencyResult {
                    period_ms: 2,
                    outcome: Err("the gateway died".into()),
                },
            ],
        );
        assert!(text.contains("aborted by the controller's watchdog after 3 frames"));
        assert!(text.contains("p50   1.000 ms"));
        assert!(text.contains(
            "   8 ms  n     2  p50   9.000 ms  p99  10.000 ms  max  10.000 ms; \
             2/2 in the first input frame after the request; 1 requests without an acknowledging reply; rc plc: result: SUCCESS\n"
        ));
        assert!(text.contains(
            "in the device: processing (output frame received -> answer at hand) p50 0.210 ms, \
             p99 0.400 ms, max 0.900 ms; wait for the input frame p50 6.500 ms, p99 7.800 ms, \
             max 7.900 ms (2 requests)\n"
        ));
        assert_eq!(device_line(None), "no timing in the controller's log");
        assert!(text.contains("   2 ms  not measured: the gateway died\n"));
        assert_eq!(
            replies_line(&Replies {
                ambiguous: 2,
                ..Replies::default()
            }),
            "no request could be matched to a reply in the capture; 2 requests not timed \
             (the ACK already equalled the new SEQ)"
        );
    }

    #[test]
    fn the_device_timing_is_read_from_the_last_line_of_the_log() {
        let older = format!(
            "INFO fieldbus: {REPLY_TIMING_LOG} (...) requests=5 processing_p50_us=1 \
             processing_p99_us=2 processing_max_us=3 cycle_wait_p50_us=4 cycle_wait_p99_us=5 \
             cycle_wait_max_us=6 dropped=0"
        );
        let newer = older.replace("requests=5", "requests=100");
        let log = format!("{older}\nother line\n{newer}\n");
        assert_eq!(
            parse_device_timing(&log),
            Some(DeviceTiming {
                requests: 100,
                processing: [1, 2, 3],
                cycle_wait: [4, 5, 6],
            })
        );
        assert_eq!(parse_device_timing("nothing here\n"), None);
        let cut = newer.replace("cycle_wait_max_us=6", "");
        assert_eq!(parse_device_timing(&cut), None);
    }

    #[test]
    fn the_layout_comes_from_the_gateway() {
        let log = "srci layout: output frame 0xC000 offset 0 input frame 0xC001 offset 3\n\
                   gateway ready\n";
        assert_eq!(
            parse_layout(log),
            Some(SrciLayout {
                output: Place {
                    frame_id: 0xC000,
                    offset: 0
                },
                input: Place {
                    frame_id: 0xC001,
                    offset: 3
                },
            })
        );
        assert_eq!(parse_layout("gateway ready\n"), None);
        assert_eq!(
            parse_layout("srci layout: output frame C000 offset 0 input frame 0xC001 offset 3"),
            None
        );
        assert_eq!(
            parse_layout("srci layout: output frame 0xC000 offset 0"),
            None
        );
    }

    /// A classic pcap file (little-endian, µs) of `frames` with their times in µs.
    fn pcap(frames: &[(u32, Vec<u8>)]) -> Vec<u8> {
        let mut bytes = vec![0xd4, 0xc3, 0xb2, 0xa1, 2, 0, 4, 0];
        bytes.extend([0; 8]);
        bytes.extend(65535u32.to_le_bytes());
        bytes.extend(1u32.to_le_bytes());
        for (micros, frame) in frames {
            bytes.extend(1_763_790_000u32.to_le_bytes());
            bytes.extend(micros.to_le_bytes());
            let length = u32::try_from(frame.len()).unwrap();
            bytes.extend(length.to_le_bytes());
            bytes.extend(length.to_le_bytes());
            bytes.extend(frame);
        }
        bytes
    }

    #[test]
    fn pcap_records_are_read_with_their_times() {
        let bytes = pcap(&[(5, vec![1, 2, 3]), (999_999, vec![])]);
        let frames = pcap_frames(&bytes).unwrap();
        assert_eq!(
            frames,
            [
                (1_763_790_000_000_005_000, &[1u8, 2, 3][..]),
                (1_763_790_000_999_999_000, &[][..])
            ]
        );
        assert_eq!(
            pcap_frames(&bytes[..bytes.len() - 1]),
            Err(PcapError::Truncated(43))
        );
        assert_eq!(pcap_frames(b"\x0a\x0d\x0d\x0a"), Err(PcapError::Magic));
        let mut raw_ip = pcap(&[]);
        raw_ip[20] = 101;
        assert_eq!(pcap_frames(&raw_ip), Err(PcapError::LinkType(101)));
        let mut nanoseconds = pcap(&[(7, vec![])]);
        nanoseconds[..4].copy_from_slice(&[0x4d, 0x3c, 0xb2, 0xa1]);
        assert_eq!(
            pcap_frames(&nanoseconds).unwrap()[0].0,
            1_763_790_000_000_000_007
        );
    }

    /// An RT frame with `frame_id` and `c_sdu`, tagged or not.
    fn rt_frame(frame_id: u16, c_sdu: &[u8], tagged: bool) -> Vec<u8> {
        let mut frame = vec![0x02; 12];
        if tagged {
            frame.extend([0x81, 0x00, 0xC0, 0x00]);
        }
        frame.extend([0x88, 0x92]);
        frame.extend(frame_id.to_be_bytes());
        frame.extend(c_sdu);
        frame.extend([0, 0, 0x35, 0]);
        frame
    }

    #[test]
    fn rt_frames_are_found_behind_vlan_tags() {
        let tagged = rt_frame(0xC001, &[7, 8], true);
        assert_eq!(
            rt_payload(&tagged),
            Some((0xC001, &[7, 8, 0, 0, 0x35, 0][..]))
        );
        let untagged = rt_frame(0xC000, &[], false);
        assert_eq!(rt_payload(&untagged), Some((0xC000, &[0, 0, 0x35, 0][..])));
        let mut ip = untagged.clone();
        ip[12..14].copy_from_slice(&[0x08, 0x00]);
        assert_eq!(rt_payload(&ip), None);
        assert_eq!(rt_payload(&untagged[..15]), None);
    }

    const SIZE: usize = 64;
    const LAYOUT: SrciLayout = SrciLayout {
        output: Place {
            frame_id: 0xC000,
            offset: 0,
        },
        input: Place {
            frame_id: 0xC001,
            offset: 3,
        },
    };

    /// A PLC output frame whose telegram carries `seq` (lifesign 1; torn: footer 2).
    fn request(seq: u16, torn: bool) -> Vec<u8> {
        let mut telegram = vec![0; SIZE];
        telegram[1] = 1;
        telegram[SIZE - 1] = if torn { 2 } else { 1 };
        telegram[PLC_HEADER_LEN..PLC_HEADER_LEN + 2].copy_from_slice(&seq.to_be_bytes());
        let mut c_sdu = telegram;
        c_sdu.push(0x80);
        rt_frame(LAYOUT.output.frame_id, &c_sdu, false)
    }

    /// One of our input frames whose telegram carries `ack`, after three IOPS bytes.
    fn reply(ack: u16) -> Vec<u8> {
        let mut telegram = vec![0; SIZE];
        telegram[1] = 0x30;
        telegram[SIZE - 1] = 0x30;
        telegram[ROBOT_HEADER_LEN..ROBOT_HEADER_LEN + 2].copy_from_slice(&ack.to_be_bytes());
        let mut c_sdu = vec![0x80; 3];
        c_sdu.extend(telegram);
        c_sdu.push(0x80);
        rt_frame(LAYOUT.input.frame_id, &c_sdu, true)
    }

    fn replies(frames: &[(u64, Vec<u8>)]) -> Replies {
        let frames: Vec<(u64, &[u8])> = frames.iter().map(|(t, f)| (*t, &f[..])).collect();
        match_replies(&frames, &LAYOUT, SIZE)
    }

    #[test]
    fn each_new_seq_is_timed_to_the_first_reply_acknowledging_it() {
        let frames = [
            (0, request(0, false)),
            (1, reply(0)),
            (10, request(1, false)),
            (12, reply(0)),
            (18, request(1, false)),
            (20, reply(1)),
            (28, reply(1)),
            (30, request(2, false)),
            (31, request(2, true)),
            (36, reply(2)),
            (40, rt_frame(0xFEFE, &[1, 2], false)),
        ];
        assert_eq!(
            replies(&frames),
            Replies {
                latencies: vec![10, 6],
                next_frame: 1,
                unreadable: 1,
                ..Replies::default()
            }
        );
    }

    #[test]
    fn requests_without_a_clear_reply_are_counted_not_timed() {
        let frames = [
            (0, reply(5)),
            // Already acknowledged when it appears: cannot be timed.
            (10, request(5, false)),
            // Replaced by the next SEQ before any reply acknowledged it.
            (20, request(6, false)),
            (30, request(7, false)),
            (40, reply(7)),
            // A reset to SEQ 0 abandons the pending request.
            (50, request(8, false)),
            (60, request(0, false)),
            // Unanswered at the capture's end.
            (70, request(1, false)),
            (80, reply(0)),
        ];
        assert_eq!(
            replies(&frames),
            Replies {
                latencies: vec![10],
                next_frame: 1,
                unanswered: 3,
                ambiguous: 1,
                unreadable: 0,
            }
        );
        let short = rt_frame(LAYOUT.input.frame_id, &[0; 10], false);
        assert_eq!(replies(&[(0, short)]).unreadable, 1);
    }

    #[test]
    fn captures_are_merged_over_their_common_span() {
        let (a, b, c): (&[u8], &[u8], &[u8]) = (&[1], &[2], &[3]);
        let merged = merge_captures(vec![
            vec![(1, a), (5, a), (9, a)],
            vec![(3, b), (5, b), (7, b)],
            vec![(2, c), (8, c)],
        ]);
        assert_eq!(merged, [(3, b), (5, a), (5, b), (7, b)]);
        assert_eq!(merge_captures(vec![vec![(1, a)], vec![]]), []);
    }

    #[test]
    fn the_latency_program_repeats_read_actual_position() {
        let text = latency_program(3);
        let table: Table = text.parse().unwrap();
        let steps = table["step"].as_array().unwrap();
        assert_eq!(steps.len(), 3);
        assert_eq!(steps[2]["call"].as_str(), Some("ReadActualPosition"));
    }
}
