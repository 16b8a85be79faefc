//! The PROFINET row of `rc bench latency` (issue 6): the period of our cyclic input frames
//! (controller → PLC) at 8, 2 and 1 ms, measured from a tshark capture.
//!
//! Two private network namespaces joined by a veth pair: `rc run` with the PROFINET transport
//! in one, profinet-py's cyclic IO-controller (`target/profinet-venv`, see
//! `services/profinet/setup.sh`) and tshark in the other, a few seconds per period. Needs
//! root, `ip`, tshark and the venv; without them the row is skipped with one line saying why.
//! The SRCI reply latency through PROFINET is not measured: profinet-py's cyclic command
//! sends no SRCI telegrams (zero output data), so there is no request to time a reply to.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use anyhow::{Context, bail};
use orchestrator::child_process;
use shared_types::config::Config;
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
/// The checkout this `rc` was built from: the venv and the GSDML are found there.
const REPOSITORY: &str = env!("CARGO_MANIFEST_DIR");

/// The printed lines of the PROFINET row: the measurement, or one line saying why it was
/// skipped or failed. Never fails: the rest of the bench stands without it.
pub fn report(config: &Config) -> String {
    let tools = match Tools::find() {
        Ok(tools) => tools,
        Err(why) => return format!("PROFINET row skipped: {why}\n"),
    };
    match measure(config, &tools) {
        Ok(periods) => render(&periods),
        Err(e) => format!("PROFINET row failed: {e:#}\n"),
    }
}

/// What the measurement runs.
struct Tools {
    tshark: PathBuf,
    profinet_py: PathBuf,
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
        if !gsdml.exists() {
            return Err(format!("{} is missing", gsdml.display()));
        }
        Ok(Self {
            tshark,
            profinet_py,
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

fn measure(config: &Config, tools: &Tools) -> anyhow::Result<Vec<PeriodResult>> {
    let dir = config
        .path
        .as_deref()
        .and_then(Path::parent)
        .context("the bench's configuration has no folder")?
        .join("profinet");
    std::fs::create_dir_all(&dir).with_context(|| format!("cannot create {}", dir.display()))?;
    let namespaces = Namespaces::create()?;
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
    let mut command = namespaces.command(&namespaces.device, &exe);
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
        let capture_file = dir.join(format!("{period_ms}ms.pcapng"));
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
    Ok(results)
}

fn measure_period(
    namespaces: &Namespaces,
    tools: &Tools,
    station: &str,
    period_ms: u64,
    capture_file: &Path,
    log_path: &Path,
) -> anyhow::Result<PeriodResult> {
    let aborts_before = count_in_file(log_path, WATCHDOG);
    let mut capture = namespaces.command(&namespaces.plc, &tools.tshark);
    capture
        .args([
            "-i",
            &namespaces.plc_interface,
            "-f",
            "ether proto 0x8892",
            "-w",
        ])
        .arg(capture_file)
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::null());
    let mut capture = Running::spawn(capture, "tshark")?;
    let deadline = Instant::now() + Duration::from_secs(10);
    while !capture_file.exists() {
        if Instant::now() > deadline {
            bail!("tshark did not start capturing");
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    // dumpcap creates the file before the capture filter is applied.
    std::thread::sleep(Duration::from_millis(500));
    let output = namespaces
        .command(&namespaces.plc, &tools.profinet_py)
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
    let profinet_py = profinet_py_outcome(&stdout, &output.status.to_string());
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

/// profinet-py's `Stopped.` summary line, or its exit status when it has none.
fn profinet_py_outcome(stdout: &str, status: &str) -> String {
    stdout
        .lines()
        .find(|line| line.starts_with("Stopped."))
        .map_or_else(
            || format!("profinet-py ended without a summary ({status})"),
            |line| format!("profinet-py: {}", line.trim()),
        )
}

/// The printed lines of the measured row.
fn render(periods: &[PeriodResult]) -> String {
    let ms = |ns: u64| format!("{:.3}", ns as f64 / 1e6);
    let mut text = format!(
        "PROFINET input frame period (controller -> PLC, veth between two namespaces, \
         profinet-py IO-controller, tshark capture, {SECONDS_PER_PERIOD} s per period):\n"
    );
    for p in periods {
        let figures = p.intervals.summary().map_or_else(
            || "no intervals captured".to_string(),
            |s| {
                format!(
                    "n {:>5}  p50 {:>7} ms  p99 {:>7} ms  max {:>7} ms",
                    s.count,
                    ms(s.p50),
                    ms(s.p99),
                    ms(s.max)
                )
            },
        );
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
    text.push_str(
        "  SRCI reply latency through PROFINET: not measured (profinet-py's cyclic command \
         sends no SRCI telegrams to reply to)\n",
    );
    text
}

/// How often `text` occurs in `file` (0 when it cannot be read).
fn count_in_file(file: &Path, text: &str) -> usize {
    std::fs::read_to_string(file).map_or(0, |content| content.matches(text).count())
}

/// Waits until `file` contains `text`.
fn wait_for_text(file: &Path, text: &str, timeout: Duration) -> anyhow::Result<()> {
    let deadline = Instant::now() + timeout;
    while count_in_file(file, text) == 0 {
        if Instant::now() > deadline {
            bail!("{text:?} did not appear within {timeout:?}");
        }
        std::thread::sleep(Duration::from_millis(100));
    }
    Ok(())
}

/// Runs `ip` with `args`.
fn ip(args: &[&str]) -> anyhow::Result<()> {
    let output = Command::new("ip")
        .args(args)
        .output()
        .with_context(|| format!("cannot run ip {args:?}"))?;
    if !output.status.success() {
        bail!(
            "ip {args:?}: {}",
            String::from_utf8_lossy(&output.stderr).trim()
        );
    }
    Ok(())
}

/// Two namespaces, PLC and device, joined by a veth pair; removed on drop.
struct Namespaces {
    plc: String,
    device: String,
    plc_interface: String,
    device_interface: String,
}

impl Namespaces {
    /// Namespaces and interfaces named after this process.
    fn create() -> anyhow::Result<Self> {
        let id = std::process::id();
        // Built first, so that a failure below removes what was created.
        let this = Self {
            plc: format!("rcbplc{id}"),
            device: format!("rcbdev{id}"),
            plc_interface: format!("rcbva{id}"),
            device_interface: format!("rcbvb{id}"),
        };
        ip(&["netns", "add", &this.plc])?;
        ip(&["netns", "add", &this.device])?;
        ip(&[
            "link",
            "add",
            &this.plc_interface,
            "type",
            "veth",
            "peer",
            "name",
            &this.device_interface,
        ])?;
        let device_address = format!("{DEVICE_IP}/24");
        for (interface, namespace, address) in [
            (&this.plc_interface, &this.plc, PLC_ADDRESS),
            (&this.device_interface, &this.device, &device_address),
        ] {
            ip(&["link", "set", interface, "netns", namespace])?;
            ip(&["-n", namespace, "link", "set", interface, "up"])?;
            ip(&["-n", namespace, "addr", "add", address, "dev", interface])?;
            ip(&["-n", namespace, "link", "set", "lo", "up"])?;
        }
        Ok(this)
    }

    /// `program` run inside `namespace` (`ip netns exec` replaces itself with it, so the
    /// child's pid is the program's).
    fn command(&self, namespace: &str, program: &Path) -> Command {
        let mut command = Command::new("ip");
        command.args(["netns", "exec", namespace]).arg(program);
        command
    }
}

impl Drop for Namespaces {
    fn drop(&mut self) {
        // Deleting a namespace deletes the veth end in it, and with it the pair; a veth
        // pair still outside them (a failure before the move) is deleted by name.
        let _ = Command::new("ip")
            .args(["link", "del", &self.plc_interface])
            .stderr(Stdio::null())
            .status();
        for namespace in [&self.plc, &self.device] {
            let _ = Command::new("ip")
                .args(["netns", "del", namespace])
                .stderr(Stdio::null())
                .status();
        }
    }
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
            profinet_py_outcome(stdout, "exit status: 0"),
            "profinet-py: Stopped. TX=375 RX=374 missed=0"
        );
        assert!(profinet_py_outcome("", "exit status: 1").contains("exit status: 1"));
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
        let text = render(&[PeriodResult {
            period_ms: 1,
            intervals: intervals(&[0, 1_000_000, 2_000_000]),
            ending: Ending::DuringExchange,
            profinet_py: "profinet-py: Stopped.".into(),
        }]);
        assert!(text.contains("aborted by the controller's watchdog after 3 frames"));
        assert!(text.contains("p50   1.000 ms"));
        assert!(text.contains("SRCI reply latency"));
    }
}
