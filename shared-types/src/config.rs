//! The controller configuration: `config/default.toml` and the robot files `config/robots/*.toml`.
//!
//! Both are embedded in the binary, so `rc demo` runs from a bare clone; a file given with
//! `--config` replaces the embedded default, and its `robot = "name"` is looked up first in the
//! `robots/` folder beside it, then among the embedded robots. Every value is checked at load
//! time; an error names the file, the key and the allowed range.

use std::path::{Path, PathBuf};

use serde::Deserialize;

/// The embedded `config/default.toml`.
pub const EMBEDDED_DEFAULT: &str = include_str!("../../config/default.toml");

/// The embedded robot files, by name.
pub const EMBEDDED_ROBOTS: [(&str, &str); 6] = [
    (
        "jaka_zu_3",
        include_str!("../../config/robots/jaka_zu_3.toml"),
    ),
    (
        "jaka_zu_5",
        include_str!("../../config/robots/jaka_zu_5.toml"),
    ),
    (
        "jaka_zu_7",
        include_str!("../../config/robots/jaka_zu_7.toml"),
    ),
    (
        "jaka_zu_12",
        include_str!("../../config/robots/jaka_zu_12.toml"),
    ),
    (
        "jaka_zu_18",
        include_str!("../../config/robots/jaka_zu_18.toml"),
    ),
    ("ur5e", include_str!("../../config/robots/ur5e.toml")),
];

/// A configuration file is missing, malformed or holds a value out of range.
#[derive(Debug, thiserror::Error)]
pub enum ConfigError {
    #[error("{file}: cannot read: {source}")]
    Read {
        file: String,
        source: std::io::Error,
    },
    #[error("{file}: {message}")]
    Parse { file: String, message: String },
    #[error("{file}: {key} = {value} is out of range (allowed {allowed})")]
    Range {
        file: String,
        key: String,
        value: String,
        allowed: String,
    },
    #[error(
        "{file}: robot = \"{robot}\" names no file {robot}.toml in {dir} nor an embedded robot ({known})"
    )]
    UnknownRobot {
        file: String,
        robot: String,
        dir: String,
        known: String,
    },
}

/// The whole configuration of one controller.
#[derive(Debug, Clone)]
pub struct Config {
    /// Where the main file came from (a path, or `<embedded default.toml>`).
    pub source: String,
    /// The path to pass to child processes (`None` = embedded default).
    pub path: Option<PathBuf>,
    pub main: MainConfig,
    pub robot: RobotConfig,
}

/// `default.toml`.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MainConfig {
    /// Prefix of every IPC service name; two controllers on one machine need different ones.
    pub instance: String,
    /// Robot file name without `.toml`.
    pub robot: String,
    pub fieldbus: FieldbusConfig,
    pub interpreter: InterpreterConfig,
    pub planner: PlannerConfig,
    pub servo: ServoConfig,
    pub orchestrator: OrchestratorConfig,
    /// Scheduling of each service's cyclic thread.
    pub realtime: RealtimeConfig,
}

/// `[realtime]`: per service, off by default so that no privileges are needed.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RealtimeConfig {
    pub fieldbus: ThreadScheduling,
    pub interpreter: ThreadScheduling,
    pub planner: ThreadScheduling,
    pub servo: ThreadScheduling,
}

/// `[realtime.<service>]`.
#[derive(Debug, Clone, Copy, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ThreadScheduling {
    /// 0 = normal scheduling (SCHED_OTHER); 1..=99 = SCHED_FIFO with this priority.
    pub priority: u8,
    /// CPU to pin the service to; -1 = any.
    pub cpu: i16,
    /// Lock all memory (mlockall) and prefault the stack.
    pub lock_memory: bool,
}

/// `[fieldbus]`.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FieldbusConfig {
    /// `tcp`: the TCP gateway transport; `profinet`: the PROFINET IO-device.
    pub transport: String,
    /// Listen address of the TCP gateway transport.
    pub listen: String,
    pub telegram_length_plc_to_rob: u16,
    pub telegram_length_rob_to_plc: u16,
    /// How long to wait for the interpreter's answer before dropping a request.
    pub reply_timeout_ms: u64,
    /// How long the gateway holds the PLC over while no interpreter process listens (one is
    /// being replaced): it answers with the last reply and a live lifesign, no new ACK.
    pub holdover_ms: u64,
    /// `[fieldbus.profinet]`: the PROFINET IO-device, used when `transport = "profinet"`.
    #[serde(default)]
    pub profinet: ProfinetConfig,
}

/// `[fieldbus.profinet]`.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ProfinetConfig {
    /// The Linux network interface the device is on.
    pub interface: String,
    /// The factory NameOfStation (DCP may set another one, kept in `data_dir`).
    pub station_name: String,
    /// Bytes of the SRCI module per direction: 64, 128 or 256; the telegram lengths are
    /// the same.
    pub module_size: u16,
    /// The factory IP address, netmask and gateway ("0.0.0.0": none).
    pub ip: String,
    pub netmask: String,
    pub gateway: String,
    /// Folder of the NameOfStation and IP a controller sets permanently over DCP. Empty:
    /// `$XDG_STATE_HOME/rc/<instance>`, or `~/.local/state/rc/<instance>`.
    pub data_dir: String,
}

impl Default for ProfinetConfig {
    fn default() -> Self {
        Self {
            interface: "eth0".into(),
            station_name: "rc-robot".into(),
            module_size: 256,
            ip: "0.0.0.0".into(),
            netmask: "0.0.0.0".into(),
            gateway: "0.0.0.0".into(),
            data_dir: String::new(),
        }
    }
}

impl ProfinetConfig {
    /// Checks the table; `telegram_lengths` are the transport's two telegram lengths.
    fn validate(&self, c: &Checker<'_>, telegram_lengths: [u16; 2]) -> Result<(), ConfigError> {
        let interface_ok = !self.interface.is_empty()
            && self.interface.len() < 16
            && !self.interface.contains(['/', ' ', '\0']);
        if !interface_ok {
            return Err(c.out_of_range(
                "fieldbus.profinet.interface",
                format!("\"{}\"", self.interface),
                "a network interface name of 1 to 15 characters".into(),
            ));
        }
        let name_ok = !self.station_name.is_empty()
            && self.station_name.len() <= 240
            && self.station_name.split('.').all(|label| {
                !label.is_empty()
                    && label.len() <= 63
                    && !label.starts_with('-')
                    && !label.ends_with('-')
                    && label
                        .bytes()
                        .all(|b| b.is_ascii_lowercase() || b.is_ascii_digit() || b == b'-')
            });
        if !name_ok {
            return Err(c.out_of_range(
                "fieldbus.profinet.station_name",
                format!("\"{}\"", self.station_name),
                "a NameOfStation: labels of a-z 0-9 - separated by dots, at most 240 characters"
                    .into(),
            ));
        }
        if ![64, 128, 256].contains(&self.module_size) {
            return Err(c.out_of_range(
                "fieldbus.profinet.module_size",
                self.module_size.to_string(),
                "64, 128 or 256".into(),
            ));
        }
        if telegram_lengths != [self.module_size; 2] {
            return Err(c.out_of_range(
                "fieldbus.profinet.module_size",
                self.module_size.to_string(),
                format!(
                    "the telegram lengths ({} and {}): the telegrams fill the SRCI module",
                    telegram_lengths[0], telegram_lengths[1]
                ),
            ));
        }
        for (key, value) in [
            ("fieldbus.profinet.ip", &self.ip),
            ("fieldbus.profinet.netmask", &self.netmask),
            ("fieldbus.profinet.gateway", &self.gateway),
        ] {
            if value.parse::<std::net::Ipv4Addr>().is_err() {
                return Err(c.out_of_range(
                    key,
                    format!("\"{value}\""),
                    "an IPv4 address such as \"192.168.0.50\"".into(),
                ));
            }
        }
        Ok(())
    }
}

/// `[interpreter]`.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct InterpreterConfig {
    /// Lifesign timeout until the PLC sets its own with ExchangeConfiguration.
    pub lifesign_timeout_ms: u16,
    /// Entries of the Active Command Register (reported as LengthACR).
    pub acr_length: u16,
    /// Messages kept for ReadMessages.
    pub message_capacity: u16,
    /// Speed override after start-up, percent.
    pub initial_override_percent: f64,
    /// Time the planner may stay silent before the interpreter declares it lost.
    pub planner_timeout_ms: u64,
    /// Identity reported by ReadRobotData.
    pub manufacturer: String,
    pub serial_number: String,
    /// Folder of the persistent user data (tools, frames, loads, dynamics, SW limits).
    /// Empty: `$XDG_STATE_HOME/rc/<instance>` (or `~/.local/state/rc/<instance>`).
    pub data_dir: String,
}

/// `[planner]`.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PlannerConfig {
    /// Moves the primary sequence buffers.
    pub queue_length: u16,
    /// Share of the acceleration limit that pays for override changes at full speed: the
    /// override changes the time scale by up to `reserve·a/v` per second, and a move keeps
    /// free what its own speeds need of that (a joint move peaking below full speed less).
    pub override_reserve: f64,
    /// Longest wait of a standing arm for the time-optimal table of a line before it starts
    /// the line on constant bounds (0: at once).
    pub table_wait_ms: u64,
}

/// `[servo]`.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ServoConfig {
    /// Interpolation period.
    pub period_us: u64,
    /// Time without a fresh setpoint after which the drives stop the arm.
    pub setpoint_timeout_ms: u64,
    /// Simulated time from power request to powered.
    pub power_on_delay_ms: u64,
    /// Simulated time from enable request to enabled.
    pub enable_delay_ms: u64,
}

/// `[orchestrator]`.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OrchestratorConfig {
    /// Restarts allowed within `restart_window_s` before the failing service is held in a
    /// safe stop instead of being restarted.
    pub max_restarts: u32,
    pub restart_window_s: u64,
    /// Time a service gets to exit after SIGTERM before it is killed.
    pub shutdown_timeout_ms: u64,
    /// Time a running service's heartbeat may stand still before it is killed as hung.
    pub heartbeat_timeout_ms: u64,
    /// Time a (re)started service has to send its first heartbeat before it is killed.
    pub start_timeout_ms: u64,
    /// `[orchestrator.strategy]`: what else is restarted with a failed service.
    pub strategy: RestartStrategies,
}

/// `[orchestrator.strategy]`: the restart strategy of each service.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RestartStrategies {
    pub servo: RestartStrategy,
    pub planner: RestartStrategy,
    pub interpreter: RestartStrategy,
    pub fieldbus: RestartStrategy,
}

impl RestartStrategies {
    /// The strategy of `service`.
    pub fn of(&self, service: crate::health::Service) -> RestartStrategy {
        use crate::health::Service;
        match service {
            Service::Servo => self.servo,
            Service::Planner => self.planner,
            Service::Interpreter => self.interpreter,
            Service::Fieldbus => self.fieldbus,
        }
    }
}

/// What the orchestrator restarts when a service fails (as in Erlang/OTP supervisors).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum RestartStrategy {
    /// Only the failed service.
    OneForOne,
    /// The failed service and every service started after it (servo → planner →
    /// interpreter → fieldbus), stopped in reverse and started again in order.
    RestForOne,
}

/// `robots/<name>.toml`.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RobotConfig {
    pub name: String,
    pub manufacturer: String,
    /// Where the numbers come from.
    pub sources: Vec<String>,
    pub kinematics: KinematicsConfig,
    pub joints: JointLimits,
    pub cartesian: CartesianLimits,
    /// Joint position the simulated arm starts in, degrees.
    pub home_deg: [f64; 6],
}

/// Standard Denavit-Hartenberg parameters: T_i = Rz(q_i + offset_i)·Tz(d_i)·Tx(a_i)·Rx(alpha_i).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct KinematicsConfig {
    pub d_m: [f64; 6],
    pub a_m: [f64; 6],
    pub alpha_deg: [f64; 6],
    pub offset_deg: [f64; 6],
}

/// Joint limits, degrees.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct JointLimits {
    pub min_deg: [f64; 6],
    pub max_deg: [f64; 6],
    pub max_velocity_deg_s: [f64; 6],
    pub max_acceleration_deg_s2: [f64; 6],
    pub max_jerk_deg_s3: [f64; 6],
}

/// Cartesian reference dynamics of the TCP.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CartesianLimits {
    pub max_velocity_mm_s: f64,
    pub max_acceleration_mm_s2: f64,
    pub max_jerk_mm_s3: f64,
}

impl Config {
    /// Loads `path`, or the embedded default when `None`.
    pub fn load(path: Option<&Path>) -> Result<Self, ConfigError> {
        let (source, text, dir) = match path {
            Some(p) => {
                let text = std::fs::read_to_string(p).map_err(|source| ConfigError::Read {
                    file: p.display().to_string(),
                    source,
                })?;
                let dir = p.parent().map(Path::to_path_buf);
                (p.display().to_string(), text, dir)
            }
            None => (
                "<embedded config/default.toml>".to_string(),
                EMBEDDED_DEFAULT.to_string(),
                None,
            ),
        };
        let main: MainConfig = parse(&source, &text)?;
        main.validate(&source)?;
        let (robot_source, robot_text) = find_robot(&source, dir.as_deref(), &main.robot)?;
        let robot: RobotConfig = parse(&robot_source, &robot_text)?;
        robot.validate(&robot_source)?;
        Ok(Self {
            source,
            path: path.map(Path::to_path_buf),
            main,
            robot,
        })
    }
}

fn parse<T: serde::de::DeserializeOwned>(file: &str, text: &str) -> Result<T, ConfigError> {
    toml::from_str(text).map_err(|e| ConfigError::Parse {
        file: file.to_string(),
        message: e.to_string().trim_end().to_string(),
    })
}

fn find_robot(
    file: &str,
    dir: Option<&Path>,
    robot: &str,
) -> Result<(String, String), ConfigError> {
    if let Some(dir) = dir {
        let candidate = dir.join("robots").join(format!("{robot}.toml"));
        if candidate.is_file() {
            let text = std::fs::read_to_string(&candidate).map_err(|source| ConfigError::Read {
                file: candidate.display().to_string(),
                source,
            })?;
            return Ok((candidate.display().to_string(), text));
        }
    }
    EMBEDDED_ROBOTS
        .iter()
        .find(|(name, _)| *name == robot)
        .map(|(name, text)| {
            (
                format!("<embedded config/robots/{name}.toml>"),
                text.to_string(),
            )
        })
        .ok_or_else(|| ConfigError::UnknownRobot {
            file: file.to_string(),
            robot: robot.to_string(),
            dir: dir
                .map(|d| d.join("robots").display().to_string())
                .unwrap_or_else(|| "<none>".into()),
            known: EMBEDDED_ROBOTS
                .iter()
                .map(|(n, _)| *n)
                .collect::<Vec<_>>()
                .join(", "),
        })
}

/// Collects range checks of one file.
struct Checker<'a> {
    file: &'a str,
}

impl Checker<'_> {
    fn range<T: PartialOrd + core::fmt::Display + Copy>(
        &self,
        key: &str,
        value: T,
        min: T,
        max: T,
    ) -> Result<(), ConfigError> {
        if value >= min && value <= max {
            Ok(())
        } else {
            Err(self.out_of_range(key, value, format!("{min}..={max}")))
        }
    }

    fn positive(&self, key: &str, value: f64) -> Result<(), ConfigError> {
        if value.is_finite() && value > 0.0 {
            Ok(())
        } else {
            Err(self.out_of_range(key, value, "a finite number > 0".into()))
        }
    }

    fn finite(&self, key: &str, value: f64) -> Result<(), ConfigError> {
        if value.is_finite() {
            Ok(())
        } else {
            Err(self.out_of_range(key, value, "a finite number".into()))
        }
    }

    fn out_of_range(
        &self,
        key: &str,
        value: impl core::fmt::Display,
        allowed: String,
    ) -> ConfigError {
        ConfigError::Range {
            file: self.file.to_string(),
            key: key.to_string(),
            value: value.to_string(),
            allowed,
        }
    }
}

impl MainConfig {
    /// The folder of the persistent user data (see [`InterpreterConfig::data_dir`]).
    pub fn data_dir(&self) -> PathBuf {
        if !self.interpreter.data_dir.is_empty() {
            return PathBuf::from(&self.interpreter.data_dir);
        }
        let base = std::env::var_os("XDG_STATE_HOME")
            .filter(|v| !v.is_empty())
            .map(PathBuf::from)
            .or_else(|| {
                std::env::var_os("HOME").map(|h| PathBuf::from(h).join(".local").join("state"))
            })
            .unwrap_or_else(std::env::temp_dir);
        base.join("rc").join(&self.instance)
    }

    fn validate(&self, file: &str) -> Result<(), ConfigError> {
        let c = Checker { file };
        let name_ok = !self.instance.is_empty()
            && self.instance.len() <= 32
            && self
                .instance
                .bytes()
                .all(|b| b.is_ascii_alphanumeric() || b == b'_' || b == b'-');
        if !name_ok {
            return Err(c.out_of_range(
                "instance",
                format!("\"{}\"", self.instance),
                "1 to 32 characters of A-Z a-z 0-9 _ -".into(),
            ));
        }
        match self.fieldbus.transport.as_str() {
            "tcp" => {}
            "profinet" => self.fieldbus.profinet.validate(
                &c,
                [
                    self.fieldbus.telegram_length_plc_to_rob,
                    self.fieldbus.telegram_length_rob_to_plc,
                ],
            )?,
            other => {
                return Err(c.out_of_range(
                    "fieldbus.transport",
                    format!("\"{other}\""),
                    "\"tcp\" or \"profinet\"".into(),
                ));
            }
        }
        if self
            .fieldbus
            .listen
            .parse::<std::net::SocketAddr>()
            .is_err()
        {
            return Err(c.out_of_range(
                "fieldbus.listen",
                format!("\"{}\"", self.fieldbus.listen),
                "an address with port, e.g. \"127.0.0.1:5000\"".into(),
            ));
        }
        c.range(
            "fieldbus.telegram_length_plc_to_rob",
            self.fieldbus.telegram_length_plc_to_rob,
            64,
            256,
        )?;
        c.range(
            "fieldbus.telegram_length_rob_to_plc",
            self.fieldbus.telegram_length_rob_to_plc,
            64,
            256,
        )?;
        c.range(
            "fieldbus.reply_timeout_ms",
            self.fieldbus.reply_timeout_ms,
            1,
            1000,
        )?;
        c.range("fieldbus.holdover_ms", self.fieldbus.holdover_ms, 0, 5000)?;
        c.range(
            "interpreter.lifesign_timeout_ms",
            self.interpreter.lifesign_timeout_ms,
            10,
            10_000,
        )?;
        c.range("interpreter.acr_length", self.interpreter.acr_length, 1, 64)?;
        c.range(
            "interpreter.message_capacity",
            self.interpreter.message_capacity,
            1,
            1024,
        )?;
        c.range(
            "interpreter.initial_override_percent",
            self.interpreter.initial_override_percent,
            0.0,
            100.0,
        )?;
        c.range(
            "interpreter.planner_timeout_ms",
            self.interpreter.planner_timeout_ms,
            5,
            5_000,
        )?;
        c.range(
            "interpreter.manufacturer (length)",
            self.interpreter.manufacturer.len(),
            1,
            20,
        )?;
        c.range(
            "interpreter.serial_number (length)",
            self.interpreter.serial_number.len(),
            1,
            16,
        )?;
        c.range("planner.queue_length", self.planner.queue_length, 1, 256)?;
        c.range(
            "planner.table_wait_ms",
            self.planner.table_wait_ms,
            0,
            1_000,
        )?;
        let rt = &self.realtime;
        for (name, t) in [
            ("fieldbus", &rt.fieldbus),
            ("interpreter", &rt.interpreter),
            ("planner", &rt.planner),
            ("servo", &rt.servo),
        ] {
            c.range(&format!("realtime.{name}.priority"), t.priority, 0, 99)?;
            c.range(&format!("realtime.{name}.cpu"), t.cpu, -1, 1023)?;
        }
        c.range(
            "planner.override_reserve",
            self.planner.override_reserve,
            0.05,
            0.5,
        )?;
        c.range("servo.period_us", self.servo.period_us, 250, 8_000)?;
        c.range(
            "servo.setpoint_timeout_ms",
            self.servo.setpoint_timeout_ms,
            1,
            1_000,
        )?;
        c.range(
            "servo.power_on_delay_ms",
            self.servo.power_on_delay_ms,
            0,
            60_000,
        )?;
        c.range(
            "servo.enable_delay_ms",
            self.servo.enable_delay_ms,
            0,
            60_000,
        )?;
        c.range(
            "orchestrator.max_restarts",
            self.orchestrator.max_restarts,
            0,
            100,
        )?;
        c.range(
            "orchestrator.restart_window_s",
            self.orchestrator.restart_window_s,
            1,
            3_600,
        )?;
        c.range(
            "orchestrator.shutdown_timeout_ms",
            self.orchestrator.shutdown_timeout_ms,
            10,
            60_000,
        )?;
        c.range(
            "orchestrator.heartbeat_timeout_ms",
            self.orchestrator.heartbeat_timeout_ms,
            100,
            60_000,
        )?;
        c.range(
            "orchestrator.start_timeout_ms",
            self.orchestrator.start_timeout_ms,
            500,
            120_000,
        )?;
        Ok(())
    }
}

impl RobotConfig {
    fn validate(&self, file: &str) -> Result<(), ConfigError> {
        let c = Checker { file };
        let k = &self.kinematics;
        for i in 0..6 {
            c.finite(&format!("kinematics.d_m[{i}]"), k.d_m[i])?;
            c.finite(&format!("kinematics.a_m[{i}]"), k.a_m[i])?;
            c.range(
                &format!("kinematics.alpha_deg[{i}]"),
                k.alpha_deg[i],
                -180.0,
                180.0,
            )?;
            c.range(
                &format!("kinematics.offset_deg[{i}]"),
                k.offset_deg[i],
                -360.0,
                360.0,
            )?;
            let j = &self.joints;
            c.range(&format!("joints.min_deg[{i}]"), j.min_deg[i], -720.0, 720.0)?;
            c.range(
                &format!("joints.max_deg[{i}]"),
                j.max_deg[i],
                j.min_deg[i] + 1.0,
                720.0,
            )?;
            c.positive(
                &format!("joints.max_velocity_deg_s[{i}]"),
                j.max_velocity_deg_s[i],
            )?;
            c.positive(
                &format!("joints.max_acceleration_deg_s2[{i}]"),
                j.max_acceleration_deg_s2[i],
            )?;
            c.positive(
                &format!("joints.max_jerk_deg_s3[{i}]"),
                j.max_jerk_deg_s3[i],
            )?;
            c.range(
                &format!("home_deg[{i}]"),
                self.home_deg[i],
                j.min_deg[i],
                j.max_deg[i],
            )?;
        }
        c.positive(
            "cartesian.max_velocity_mm_s",
            self.cartesian.max_velocity_mm_s,
        )?;
        c.positive(
            "cartesian.max_acceleration_mm_s2",
            self.cartesian.max_acceleration_mm_s2,
        )?;
        c.positive("cartesian.max_jerk_mm_s3", self.cartesian.max_jerk_mm_s3)?;
        Ok(())
    }

    /// Joint limits in SI units (rad, rad/s, rad/s², rad/s³).
    pub fn limits_rad(&self) -> JointLimitsRad {
        let r = |v: [f64; 6]| v.map(f64::to_radians);
        JointLimitsRad {
            min: r(self.joints.min_deg),
            max: r(self.joints.max_deg),
            velocity: r(self.joints.max_velocity_deg_s),
            acceleration: r(self.joints.max_acceleration_deg_s2),
            jerk: r(self.joints.max_jerk_deg_s3),
        }
    }
}

/// Joint limits in rad-based SI units.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointLimitsRad {
    pub min: [f64; 6],
    pub max: [f64; 6],
    pub velocity: [f64; 6],
    pub acceleration: [f64; 6],
    pub jerk: [f64; 6],
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn embedded_default_and_every_robot_load() {
        let cfg = Config::load(None).expect("embedded default");
        assert_eq!(cfg.main.robot, "jaka_zu_7");
        for (name, text) in EMBEDDED_ROBOTS {
            let robot: RobotConfig = parse(name, text).expect(name);
            robot.validate(name).expect(name);
        }
    }

    #[test]
    fn out_of_range_value_names_file_key_and_range() {
        let dir = std::env::temp_dir().join(format!("rc-config-test-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let file = dir.join("bad.toml");
        let text = EMBEDDED_DEFAULT.replace(
            "telegram_length_plc_to_rob = 256",
            "telegram_length_plc_to_rob = 300",
        );
        std::fs::write(&file, text).unwrap();
        let err = Config::load(Some(&file)).unwrap_err().to_string();
        assert!(err.contains("bad.toml"), "{err}");
        assert!(
            err.contains("fieldbus.telegram_length_plc_to_rob = 300"),
            "{err}"
        );
        assert!(err.contains("64..=256"), "{err}");
    }

    #[test]
    fn the_profinet_transport_is_checked_key_by_key() {
        let profinet = EMBEDDED_DEFAULT.replace("transport = \"tcp\"", "transport = \"profinet\"");
        let main: MainConfig = parse("p.toml", &profinet).unwrap();
        main.validate("p.toml").unwrap();
        assert_eq!(main.fieldbus.profinet.module_size, 256);
        let refused = |from: &str, to: &str| {
            let text = profinet.replace(from, to);
            assert_ne!(text, profinet, "{from}");
            let main: MainConfig = parse("p.toml", &text).unwrap();
            main.validate("p.toml").unwrap_err().to_string()
        };
        let err = refused("module_size = 256", "module_size = 100");
        assert!(err.contains("fieldbus.profinet.module_size = 100"), "{err}");
        let err = refused("module_size = 256", "module_size = 128");
        assert!(err.contains("telegram lengths (256 and 256)"), "{err}");
        let err = refused("station_name = \"rc-robot\"", "station_name = \"RC_Robot\"");
        assert!(err.contains("fieldbus.profinet.station_name"), "{err}");
        let err = refused("interface = \"eth0\"", "interface = \"\"");
        assert!(err.contains("fieldbus.profinet.interface"), "{err}");
        let err = refused("ip = \"0.0.0.0\"", "ip = \"300.1.1.1\"");
        assert!(err.contains("fieldbus.profinet.ip"), "{err}");
        let err = refused("transport = \"profinet\"", "transport = \"udp\"");
        assert!(err.contains("\"tcp\" or \"profinet\""), "{err}");
    }

    #[test]
    fn restart_strategies_are_read_per_service() {
        use crate::health::Service;
        let cfg = Config::load(None).expect("embedded default");
        let strategy = cfg.main.orchestrator.strategy;
        assert_eq!(strategy.of(Service::Servo), RestartStrategy::OneForOne);
        assert_eq!(
            strategy.of(Service::Interpreter),
            RestartStrategy::RestForOne
        );
        let text =
            EMBEDDED_DEFAULT.replace("planner = \"one_for_one\"", "planner = \"one_for_all\"");
        let err = parse::<MainConfig>("x.toml", &text)
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("one_for_all") && err.contains("planner"),
            "{err}"
        );
    }

    #[test]
    fn unknown_key_and_unknown_robot_are_reported() {
        let dir = std::env::temp_dir().join(format!("rc-config-test2-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let file = dir.join("typo.toml");
        std::fs::write(
            &file,
            EMBEDDED_DEFAULT.replace("reply_timeout_ms", "reply_timout_ms"),
        )
        .unwrap();
        let err = Config::load(Some(&file)).unwrap_err().to_string();
        assert!(
            err.contains("typo.toml") && err.contains("reply_timout_ms"),
            "{err}"
        );

        std::fs::write(
            &file,
            EMBEDDED_DEFAULT.replace("robot = \"jaka_zu_7\"", "robot = \"zu99\""),
        )
        .unwrap();
        let err = Config::load(Some(&file)).unwrap_err().to_string();
        assert!(err.contains("zu99") && err.contains("jaka_zu_7"), "{err}");
    }
}
