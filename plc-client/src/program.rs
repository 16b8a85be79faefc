//! Client programs: small TOML files with a list of `[[step]]`s, each one SRCI call.
//!
//! ```toml
//! name = "demo"
//! [[step]]
//! call = "MoveAxesAbsolute"
//! joints = [0.0, 90.0, 90.0, 90.0, -90.0, 0.0]
//! velocity_rate = 50.0     # percent; omitted = the robot's default dynamics
//! wait = "done"            # done (default) | active | none
//! expect = "DONE"          # DONE (default) | ABORTED | ERROR
//! expect_code = 0x6C06     # optional
//! delay_ms = 0             # pause before the step
//! timeout_ms = 30000       # optional; otherwise the client's command timeout
//! ```
//!
//! Calls and their keys are listed in [`CALLS`]. Errors name the step (1-based) and the key.

use std::path::Path;
use std::time::Duration;

use serde::Deserialize;
use shared_types::srci::message::state;

use crate::request::{MoveAxesAbsolute, Request};
use crate::table_step::{self, PERCENT_MAX};

/// Keys every step accepts.
const COMMON_KEYS: &[&str] = &[
    "call",
    "wait",
    "expect",
    "expect_code",
    "delay_ms",
    "timeout_ms",
];

/// Every call a step can make, with the keys it takes besides the common ones (`call`,
/// `wait`, `expect`, `expect_code`, `delay_ms`, `timeout_ms`).
pub const CALLS: &[(&str, &[&str])] = &[
    ("GroupReset", &[]),
    ("GroupStop", &[]),
    ("GroupInterrupt", &[]),
    ("GroupContinue", &[]),
    ("EnableRobot", &["enable"]),
    ("ChangeSpeedOverride", &["override"]),
    (
        "MoveAxesAbsolute",
        &[
            "joints",
            "velocity_rate",
            "acceleration_rate",
            "deceleration_rate",
            "jerk_rate",
            "aborting",
            "time_ms",
            "blending_mode",
            "blending_parameter",
            "tool",
        ],
    ),
    ("ReadActualPosition", &["tool", "frame"]),
    ("ReadRobotData", &[]),
    ("Raw", &["command_type", "execution_mode", "payload"]),
];

/// A program that could not be read.
#[derive(Debug, thiserror::Error)]
pub enum ProgramError {
    #[error("cannot read {path}: {source}")]
    Io {
        path: String,
        source: std::io::Error,
    },
    #[error("{origin}: {message}")]
    Syntax { origin: String, message: String },
    #[error("{origin}: step {index}{}: {message}", call.as_deref().map(|c| format!(" ({c})")).unwrap_or_default())]
    Step {
        origin: String,
        /// 1-based step number.
        index: usize,
        call: Option<String>,
        message: String,
    },
}

/// When a step lets the program go on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum Wait {
    /// After the command's final state (for Enable-type commands: once it reports ACTIVE
    /// with the requested Enabled bit).
    #[default]
    Done,
    /// Once the command is ACTIVE (or already final).
    Active,
    /// Right after submitting.
    None,
}

/// The final state a step expects.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Default)]
#[serde(rename_all = "UPPERCASE")]
pub enum Expect {
    #[default]
    Done,
    Aborted,
    Error,
}

impl Expect {
    /// The CmdMessageState expected.
    pub fn state(self) -> u8 {
        match self {
            Self::Done => state::DONE,
            Self::Aborted => state::ABORTED,
            Self::Error => state::ERROR,
        }
    }
}

/// One step of a program.
#[derive(Debug, Clone, PartialEq)]
pub struct Step {
    /// The call's name as written in the program.
    pub call: String,
    pub request: Request,
    pub wait: Wait,
    pub expect: Expect,
    pub expect_code: Option<u16>,
    /// Pause before the step.
    pub delay: Duration,
    /// Time from submission to the final state; `None` = the client's command timeout.
    pub timeout: Option<Duration>,
}

/// A parsed program.
#[derive(Debug, Clone, PartialEq)]
pub struct Program {
    pub name: String,
    pub steps: Vec<Step>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ProgramDef {
    #[serde(default)]
    name: Option<String>,
    #[serde(default)]
    step: Vec<toml::Table>,
}

/// Every key any step may carry; all optional, so that one key can be checked alone.
#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct StepDef {
    /// Read from the table before deserializing (it selects the allowed keys); declared so
    /// that `deny_unknown_fields` accepts it.
    #[serde(rename = "call")]
    _call: Option<String>,
    enable: Option<bool>,
    #[serde(rename = "override")]
    override_percent: Option<f64>,
    joints: Option<[f64; 6]>,
    velocity_rate: Option<f64>,
    acceleration_rate: Option<f64>,
    deceleration_rate: Option<f64>,
    jerk_rate: Option<f64>,
    aborting: Option<bool>,
    time_ms: Option<u16>,
    blending_mode: Option<u8>,
    blending_parameter: Option<[f64; 2]>,
    tool: Option<u8>,
    frame: Option<u8>,
    command_type: Option<u16>,
    execution_mode: Option<u8>,
    payload: Option<Vec<u8>>,
    wait: Option<Wait>,
    expect: Option<Expect>,
    expect_code: Option<u16>,
    delay_ms: Option<u64>,
    timeout_ms: Option<u64>,
}

impl Program {
    /// Reads a program file.
    pub fn load(path: &Path) -> Result<Self, ProgramError> {
        let text = std::fs::read_to_string(path).map_err(|source| ProgramError::Io {
            path: path.display().to_string(),
            source,
        })?;
        Self::parse(&text, &path.display().to_string())
    }

    /// Parses program text; `origin` names it in errors (e.g. the file name).
    pub fn parse(text: &str, origin: &str) -> Result<Self, ProgramError> {
        let def: ProgramDef = toml::from_str(text).map_err(|e| ProgramError::Syntax {
            origin: origin.to_owned(),
            message: e.to_string().trim_end().to_owned(),
        })?;
        if def.step.is_empty() {
            return Err(ProgramError::Syntax {
                origin: origin.to_owned(),
                message: "the program has no [[step]]".to_owned(),
            });
        }
        let steps = def
            .step
            .into_iter()
            .enumerate()
            .map(|(i, table)| {
                parse_step(&table).map_err(|(call, message)| ProgramError::Step {
                    origin: origin.to_owned(),
                    index: i + 1,
                    call,
                    message,
                })
            })
            .collect::<Result<_, _>>()?;
        Ok(Self {
            name: def.name.unwrap_or_else(|| "program".to_owned()),
            steps,
        })
    }
}

type StepError = (Option<String>, String);

fn parse_step(table: &toml::Table) -> Result<Step, StepError> {
    let call = match table.get("call") {
        Some(toml::Value::String(s)) => s.clone(),
        Some(other) => {
            return Err((
                None,
                format!("key `call` must be a string, found {}", other.type_str()),
            ));
        }
        None => return Err((None, "missing key `call`".to_owned())),
    };
    let err = |message: String| (Some(call.clone()), message);
    let Some((_, keys)) = CALLS.iter().find(|(name, _)| *name == call) else {
        if let Some(request_table) = table_step::find(&call) {
            return parse_table_step(table, call, request_table);
        }
        if let Some(spelled) = table_step::find_ignoring_case(&call) {
            return Err((
                None,
                format!("unknown call `{call}`; the specification spells it `{spelled}`"),
            ));
        }
        let known: Vec<&str> = CALLS.iter().map(|(n, _)| *n).collect();
        return Err((
            None,
            format!(
                "unknown call `{call}`; known calls: {}, and any request of the \
                 specification by its function name (MoveLinearAbsolute, WaitTime, ...)",
                known.join(", ")
            ),
        ));
    };
    for key in table.keys() {
        if !COMMON_KEYS.contains(&key.as_str()) && !keys.contains(&key.as_str()) {
            let mut allowed: Vec<&str> = keys.to_vec();
            allowed.extend(COMMON_KEYS.iter().skip(1));
            return Err(err(format!(
                "unknown key `{key}`; {call} takes: {}",
                allowed.join(", ")
            )));
        }
    }
    let def = deserialize_step(table).map_err(err)?;
    let request = build_request(&call, &def).map_err(err)?;
    Ok(step(call, request, &def))
}

/// A step of a call without a typed request: `request_table`'s fields by name
/// ([`table_step`]).
fn parse_table_step(
    table: &toml::Table,
    call: String,
    request_table: &shared_types::srci::payload::FieldTable,
) -> Result<Step, StepError> {
    let (common, parameters): (toml::Table, toml::Table) = table
        .clone()
        .into_iter()
        .partition(|(key, _)| COMMON_KEYS.contains(&key.as_str()));
    let err = |message: String| (Some(call.clone()), message);
    let def = deserialize_step(&common).map_err(err)?;
    let request = table_step::request(request_table, &parameters).map_err(err)?;
    Ok(step(call, request, &def))
}

fn step(call: String, request: Request, def: &StepDef) -> Step {
    Step {
        call,
        request,
        wait: def.wait.unwrap_or_default(),
        expect: def.expect.unwrap_or_default(),
        expect_code: def.expect_code,
        delay: Duration::from_millis(def.delay_ms.unwrap_or(0)),
        timeout: def.timeout_ms.map(Duration::from_millis),
    }
}

/// Deserializes the step; on failure, finds the key whose value is wrong by checking each
/// key alone, so the message can name it.
fn deserialize_step(table: &toml::Table) -> Result<StepDef, String> {
    let whole = toml::Value::Table(table.clone()).try_into::<StepDef>();
    whole.map_err(|e| {
        for (key, value) in table {
            let mut single = toml::Table::new();
            single.insert(key.clone(), value.clone());
            if let Err(e) = toml::Value::Table(single).try_into::<StepDef>() {
                return format!("key `{key}`: {}", e.to_string().trim_end());
            }
        }
        e.to_string().trim_end().to_owned()
    })
}

fn percent(key: &str, v: Option<f64>) -> Result<Option<f64>, String> {
    match v {
        Some(p) if !(0.0..=PERCENT_MAX).contains(&p) => Err(format!(
            "key `{key}`: {p} is outside 0..={PERCENT_MAX} percent"
        )),
        other => Ok(other),
    }
}

fn build_request(call: &str, d: &StepDef) -> Result<Request, String> {
    Ok(match call {
        "GroupReset" => Request::GroupReset,
        "GroupStop" => Request::GroupStop,
        "GroupInterrupt" => Request::GroupInterrupt,
        "GroupContinue" => Request::GroupContinue,
        "ReadRobotData" => Request::ReadRobotData,
        "EnableRobot" => Request::EnableRobot {
            enable: d.enable.unwrap_or(true),
        },
        "ChangeSpeedOverride" => Request::ChangeSpeedOverride {
            percent: percent("override", d.override_percent)?
                .ok_or("missing key `override` (percent)")?,
        },
        "MoveAxesAbsolute" => {
            let joints = d
                .joints
                .ok_or("missing key `joints` (6 values in degrees)")?;
            if let Some(q) = joints.iter().find(|q| !q.is_finite()) {
                return Err(format!("key `joints`: {q} is not a finite angle"));
            }
            Request::MoveAxesAbsolute(MoveAxesAbsolute {
                velocity_rate: percent("velocity_rate", d.velocity_rate)?,
                acceleration_rate: percent("acceleration_rate", d.acceleration_rate)?,
                deceleration_rate: percent("deceleration_rate", d.deceleration_rate)?,
                jerk_rate: percent("jerk_rate", d.jerk_rate)?,
                aborting: d.aborting.unwrap_or(false),
                time_ms: d.time_ms.unwrap_or(0),
                blending_mode: d.blending_mode.unwrap_or(0),
                blending_parameter: d.blending_parameter.unwrap_or([0.0; 2]),
                tool: d.tool.unwrap_or(0),
                ..MoveAxesAbsolute::to(joints)
            })
        }
        "ReadActualPosition" => Request::ReadActualPosition {
            tool: d.tool.unwrap_or(0),
            frame: d.frame.unwrap_or(0),
        },
        "Raw" => {
            let execution_mode = d.execution_mode.unwrap_or(2);
            if execution_mode > 15 {
                return Err(format!(
                    "key `execution_mode`: {execution_mode} does not fit a nibble (0..=15)"
                ));
            }
            let payload = d.payload.clone().unwrap_or_default();
            if payload.len() > usize::from(u16::MAX) - 4 {
                return Err(format!(
                    "key `payload`: {} bytes is too long",
                    payload.len()
                ));
            }
            Request::Raw {
                command_type: d.command_type.ok_or("missing key `command_type`")?,
                execution_mode,
                payload,
            }
        }
        other => return Err(format!("unknown call `{other}`")),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn step_error(toml: &str) -> String {
        Program::parse(toml, "test.toml").unwrap_err().to_string()
    }

    #[test]
    fn demo_program_parses() {
        let p = Program::parse(crate::DEMO_PROGRAM, "demo.toml").unwrap();
        assert_eq!(p.name, "demo");
        let moves: Vec<&Step> = p
            .steps
            .iter()
            .filter(|s| s.call == "MoveAxesAbsolute")
            .collect();
        assert_eq!(moves.len(), 4);
        assert_eq!(moves[0].wait, Wait::Active);
        assert_eq!(moves[0].expect, Expect::Aborted);
        assert_eq!(moves[0].expect_code, Some(0x6C06));
        assert!(matches!(&moves[1].request, Request::MoveAxesAbsolute(m) if m.aborting));
        // The last two blend: the first is sent on and buffered while the other runs.
        assert_eq!(moves[2].wait, Wait::Active);
        assert!(matches!(&moves[2].request, Request::MoveAxesAbsolute(m) if m.blending_mode == 11));
    }

    #[test]
    fn full_step_is_read() {
        let p = Program::parse(
            r#"
            [[step]]
            call = "MoveAxesAbsolute"
            joints = [1, 2, 3, 4, 5, 6]
            velocity_rate = 50.0
            wait = "none"
            expect = "ERROR"
            expect_code = 0x8D13
            delay_ms = 20
            [[step]]
            call = "Raw"
            command_type = 2103
            payload = [1, 2]
            "#,
            "t",
        )
        .unwrap();
        let s = &p.steps[0];
        assert_eq!(s.wait, Wait::None);
        assert_eq!(s.expect.state(), state::ERROR);
        assert_eq!(s.expect_code, Some(0x8D13));
        assert_eq!(s.delay, Duration::from_millis(20));
        let Request::MoveAxesAbsolute(m) = &s.request else {
            panic!("not a move")
        };
        assert_eq!(m.joints_deg, [1.0, 2.0, 3.0, 4.0, 5.0, 6.0]);
        assert_eq!(m.velocity_rate, Some(50.0));
        assert_eq!(m.acceleration_rate, None);
        assert!(matches!(
            &p.steps[1].request,
            Request::Raw { command_type: 2103, execution_mode: 2, payload } if payload == &[1, 2]
        ));
    }

    #[test]
    fn errors_name_the_step_and_the_key() {
        let e = step_error(
            "[[step]]\ncall = \"GroupReset\"\n[[step]]\ncall = \"MoveAxesAbsolute\"\njoints = [0,0,0,0,0,0]\nvelocty_rate = 5.0\n",
        );
        assert!(e.contains("step 2 (MoveAxesAbsolute)"), "{e}");
        assert!(e.contains("unknown key `velocty_rate`"), "{e}");

        let e = step_error("[[step]]\ncall = \"MoveAxesAbsolute\"\njoints = \"home\"\n");
        assert!(e.contains("step 1 (MoveAxesAbsolute): key `joints`"), "{e}");

        let e = step_error("[[step]]\ncall = \"MoveAxesAbsolute\"\njoints = [0.0, 1.0]\n");
        assert!(e.contains("key `joints`"), "{e}");

        let e = step_error("[[step]]\ncall = \"ChangeSpeedOverride\"\n");
        assert!(
            e.contains("step 1 (ChangeSpeedOverride): missing key `override`"),
            "{e}"
        );

        let e = step_error("[[step]]\ncall = \"ChangeSpeedOverride\"\noverride = 800.0\n");
        assert!(e.contains("key `override`: 800 is outside"), "{e}");

        let e = step_error("[[step]]\ncall = \"GroupReset\"\nwait = \"finished\"\n");
        assert!(e.contains("key `wait`") && e.contains("finished"), "{e}");

        let e = step_error("[[step]]\ncall = \"Jump\"\n");
        assert!(e.contains("step 1: unknown call `Jump`"), "{e}");

        let e = step_error("[[step]]\nwait = \"done\"\n");
        assert!(e.contains("step 1: missing key `call`"), "{e}");

        let e = step_error("[[step]]\ncall = \"GroupReset\"\njoints = [0,0,0,0,0,0]\n");
        assert!(
            e.contains("unknown key `joints`; GroupReset takes: wait"),
            "{e}"
        );
    }

    #[test]
    fn any_request_of_the_tables_is_a_step_with_its_field_names() {
        let p = Program::parse(
            r#"
            [[step]]
            call = "MoveLinearAbsolute"
            position = [450.0, -120.0, 300.0, 180.0, 0.0, 90.0]
            velocity_rate = 50.0
            wait = "active"
            delay_ms = 20
            "#,
            "t",
        )
        .unwrap();
        let s = &p.steps[0];
        assert_eq!((s.wait, s.delay), (Wait::Active, Duration::from_millis(20)));
        assert_eq!(s.request.name(), "MoveLinearAbsolute");
        assert_eq!(s.request.execution_mode(), 0);

        let e = step_error("[[step]]\ncall = \"WriteRobotSwLimits\"\n");
        assert!(
            e.contains("unknown call `WriteRobotSwLimits`; the specification spells it `WriteRobotSWLimits`"),
            "{e}"
        );
        let e = step_error("[[step]]\ncall = \"MoveLinearAbsolute\"\ntool_no = 300\n");
        assert!(
            e.contains("step 1 (MoveLinearAbsolute): key `tool_no`: 300 is outside 0..=255"),
            "{e}"
        );
        let e = step_error("[[step]]\ncall = \"WaitTime\"\ntime = 5\nwait = \"soon\"\n");
        assert!(e.contains("step 1 (WaitTime): key `wait`"), "{e}");
    }

    #[test]
    fn program_level_errors() {
        let e = step_error("name = \"x\"\nsteps = []\n");
        assert!(e.contains("test.toml") && e.contains("steps"), "{e}");
        let e = step_error("name = \"x\"\n");
        assert!(e.contains("no [[step]]"), "{e}");
        let e = step_error("[[step]\n");
        assert!(e.starts_with("test.toml: "), "{e}");
    }
}
