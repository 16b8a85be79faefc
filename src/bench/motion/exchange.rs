//! The exchange with the Python reference planners (bench/reference.py) and the jerk-limited
//! optimum of the lines (bench/optimum.py): the problem set and the limits out, one reference
//! duration per problem back, both as TOML (the `toml` crate here, the standard library's
//! `tomllib` there). The file layout is in bench/README.md.

use std::path::{Path, PathBuf};
use std::process::Command;

use toml::{Table, Value};

use super::problems::{Problems, Robot};

/// A script of the reference environment, embedded so that the binary runs it from any
/// directory, with the names of it and of its result in the output directory.
pub struct Script {
    pub file: &'static str,
    pub text: &'static str,
    pub result: &'static str,
}

/// The reference planners: ruckig, toppra and the jerk-aware bound.
pub const REFERENCE: Script = Script {
    file: "reference.py",
    text: include_str!("../../../bench/reference.py"),
    result: "reference.toml",
};
/// The jerk-limited optimum of the lines (CasADi, IPOPT).
pub const OPTIMUM: Script = Script {
    file: "optimum.py",
    text: include_str!("../../../bench/optimum.py"),
    result: "optimum.toml",
};
/// The problem file in the output directory.
pub const PROBLEMS_FILE: &str = "problems.toml";

/// Why the reference durations could not be had.
#[derive(Debug, thiserror::Error)]
pub enum ReferenceError {
    #[error("no reference environment at {0}")]
    NoEnvironment(PathBuf),
    #[error("cannot write {path}: {source}")]
    Write {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("cannot start {python}: {source}")]
    Spawn {
        python: PathBuf,
        source: std::io::Error,
    },
    #[error("{script} failed ({status}): {stderr}")]
    Script {
        script: &'static str,
        status: String,
        stderr: String,
    },
    #[error("cannot read {path}: {source}")]
    Read {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("the result of {script} is not valid: {reason}")]
    Invalid {
        script: &'static str,
        reason: String,
    },
}

/// What the reference planners answered.
#[derive(Debug, Clone, PartialEq)]
pub struct Reference {
    pub ruckig_version: String,
    pub toppra_version: String,
    /// Wall time of all ruckig and all toppra solves, s.
    pub ruckig_s: f64,
    pub toppra_s: f64,
    /// One duration (s) per joint move, NaN where ruckig failed.
    pub joint: Vec<f64>,
    /// One duration (s) per linear move, NaN where toppra failed.
    pub linear: Vec<f64>,
    /// toppra's duration (s) of the straight joint line of every joint move, without a jerk
    /// limit: next to ruckig's, the cost of the jerk limit.
    pub joint_toppra: Vec<f64>,
    /// The jerk-aware lower bound (s) of every linear move: the larger of toppra's duration
    /// and the slowest coordinate's time-optimal jerk-limited time alone (each joint over its
    /// net displacement, the TCP over the line's length); NaN where ruckig or toppra failed.
    pub linear_bound: Vec<f64>,
}

/// The jerk-limited optimum of the lines.
#[derive(Debug, Clone, PartialEq)]
pub struct Optimum {
    pub casadi_version: String,
    /// Wall time of all solves, s.
    pub seconds: f64,
    /// One duration (s) per linear move, NaN where it was not asked for or did not converge.
    pub linear: Vec<f64>,
    /// Per linear move the largest share of its limit that one term of a joint's
    /// acceleration or jerk takes in the optimum (above 1 where terms beyond their limits
    /// cancel each other), NaN as in `linear`.
    pub largest_term: Vec<f64>,
}

fn floats(values: impl IntoIterator<Item = f64>) -> Value {
    Value::Array(values.into_iter().map(Value::Float).collect())
}

fn table(entries: impl IntoIterator<Item = (&'static str, Value)>) -> Value {
    Value::Table(
        entries
            .into_iter()
            .map(|(k, v)| (k.to_string(), v))
            .collect(),
    )
}

/// The problem file: the limits the planner used (rad, m) and every problem.
pub fn problems_toml(robot: &Robot, problems: &Problems) -> String {
    let l = &robot.limits;
    let mut root = Table::new();
    root.insert("robot".into(), Value::String(robot.name.clone()));
    root.insert("seed".into(), Value::String(problems.seed.to_string()));
    root.insert("override_reserve".into(), Value::Float(robot.reserve));
    root.insert(
        "joint_limits".into(),
        table([
            ("min", floats(l.min)),
            ("max", floats(l.max)),
            ("velocity", floats(l.velocity)),
            ("acceleration", floats(l.acceleration)),
            ("jerk", floats(l.jerk)),
        ]),
    );
    root.insert(
        "tcp_limits".into(),
        table([
            ("velocity", Value::Float(robot.tcp.velocity)),
            ("acceleration", Value::Float(robot.tcp.acceleration)),
            ("jerk", Value::Float(robot.tcp.jerk)),
        ]),
    );
    let joint = problems.joint.iter().map(|c| {
        table([
            ("start", floats(c.start)),
            ("target", floats(c.target)),
            ("ours_s", Value::Float(c.ours.as_planned_s)),
        ])
    });
    root.insert("joint".into(), Value::Array(joint.collect()));
    let linear = problems.linear.iter().map(|c| {
        table([
            ("start", floats(c.start)),
            ("pose", floats(c.pose)),
            ("length_m", Value::Float(c.length_m)),
            ("ours_s", Value::Float(c.ours.as_planned_s)),
            (
                "path",
                Value::Array(c.path.iter().map(|q| floats(*q)).collect()),
            ),
        ])
    });
    root.insert("linear".into(), Value::Array(linear.collect()));
    root.to_string()
}

/// The strings, numbers and arrays of numbers of a result file.
struct ResultFile(Table);

impl ResultFile {
    fn parse(text: &str) -> Result<Self, String> {
        text.parse()
            .map(Self)
            .map_err(|e: toml::de::Error| e.to_string())
    }

    fn string(&self, key: &str) -> Result<String, String> {
        self.0
            .get(key)
            .and_then(Value::as_str)
            .map(str::to_string)
            .ok_or_else(|| format!("no string {key}"))
    }

    fn float(&self, key: &str) -> Result<f64, String> {
        self.0
            .get(key)
            .and_then(Value::as_float)
            .ok_or_else(|| format!("no number {key}"))
    }

    /// The array `key` of exactly `expected` numbers.
    fn numbers(&self, key: &str, expected: usize) -> Result<Vec<f64>, String> {
        let values = self
            .0
            .get(key)
            .and_then(Value::as_array)
            .ok_or_else(|| format!("no array {key}"))?
            .iter()
            .map(|v| {
                v.as_float()
                    .ok_or_else(|| format!("{key}: {v} is no number"))
            })
            .collect::<Result<Vec<f64>, String>>()?;
        if values.len() != expected {
            return Err(format!(
                "{key}: {} numbers for {expected} problems",
                values.len()
            ));
        }
        Ok(values)
    }
}

/// Parses the reference result, which must hold `joints` and `lines` durations.
pub fn parse_reference(text: &str, joints: usize, lines: usize) -> Result<Reference, String> {
    let file = ResultFile::parse(text)?;
    Ok(Reference {
        ruckig_version: file.string("ruckig")?,
        toppra_version: file.string("toppra")?,
        ruckig_s: file.float("ruckig_seconds")?,
        toppra_s: file.float("toppra_seconds")?,
        joint: file.numbers("joint", joints)?,
        linear: file.numbers("linear", lines)?,
        joint_toppra: file.numbers("joint_toppra", joints)?,
        linear_bound: file.numbers("linear_bound", lines)?,
    })
}

/// Parses the optimum's result, which must hold `lines` durations and their largest terms.
pub fn parse_optimum(text: &str, lines: usize) -> Result<Optimum, String> {
    let file = ResultFile::parse(text)?;
    Ok(Optimum {
        casadi_version: file.string("casadi")?,
        seconds: file.float("optimum_seconds")?,
        linear: file.numbers("linear_optimum", lines)?,
        largest_term: file.numbers("linear_optimum_largest_term", lines)?,
    })
}

/// Writes the problem file and the reference script into `dir`, runs the script with
/// `python` and reads its answer.
pub fn run_reference(
    python: &Path,
    dir: &Path,
    robot: &Robot,
    problems: &Problems,
) -> Result<Reference, ReferenceError> {
    let text = run_script(&REFERENCE, python, dir, robot, problems, &[])?;
    parse_reference(&text, problems.joint.len(), problems.linear.len()).map_err(|reason| {
        ReferenceError::Invalid {
            script: REFERENCE.file,
            reason,
        }
    })
}

/// The jerk-limited optimum of the first `lines` linear moves, as [`run_reference`].
pub fn run_optimum(
    python: &Path,
    dir: &Path,
    robot: &Robot,
    problems: &Problems,
    lines: usize,
) -> Result<Optimum, ReferenceError> {
    let text = run_script(&OPTIMUM, python, dir, robot, problems, &[lines.to_string()])?;
    parse_optimum(&text, problems.linear.len()).map_err(|reason| ReferenceError::Invalid {
        script: OPTIMUM.file,
        reason,
    })
}

/// Writes the problem file and `script` into `dir`, runs `python SCRIPT PROBLEMS RESULT
/// ARGS...` and returns the text of its result.
fn run_script(
    script: &Script,
    python: &Path,
    dir: &Path,
    robot: &Robot,
    problems: &Problems,
    args: &[String],
) -> Result<String, ReferenceError> {
    if !python.exists() {
        return Err(ReferenceError::NoEnvironment(python.to_path_buf()));
    }
    let write = |name: &str, text: &str| {
        let path = dir.join(name);
        std::fs::create_dir_all(dir)
            .and_then(|()| std::fs::write(&path, text))
            .map_err(|source| ReferenceError::Write { path, source })
    };
    write(PROBLEMS_FILE, &problems_toml(robot, problems))?;
    write(script.file, script.text)?;
    let result = dir.join(script.result);
    // A result of an earlier run must not pass for this one's.
    let _ = std::fs::remove_file(&result);
    let output = Command::new(python)
        .arg(dir.join(script.file))
        .arg(dir.join(PROBLEMS_FILE))
        .arg(&result)
        .args(args)
        .output()
        .map_err(|source| ReferenceError::Spawn {
            python: python.to_path_buf(),
            source,
        })?;
    if !output.status.success() {
        let stderr = String::from_utf8_lossy(&output.stderr);
        // The last lines carry the exception.
        let tail: Vec<&str> = stderr.lines().rev().take(3).collect();
        return Err(ReferenceError::Script {
            script: script.file,
            status: output.status.to_string(),
            stderr: tail.into_iter().rev().collect::<Vec<_>>().join(" | "),
        });
    }
    std::fs::read_to_string(&result).map_err(|source| ReferenceError::Read {
        path: result.clone(),
        source,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bench::motion::problems::Robot;
    use shared_types::config::Config;

    #[test]
    fn the_problem_file_holds_the_limits_and_every_problem() {
        let robot = Robot::from_config(&Config::load(None).unwrap()).unwrap();
        let problems = Problems::generate(&robot, 5, 3, 1).unwrap();
        let text = problems_toml(&robot, &problems);
        let root: Table = text.parse().unwrap();
        let velocity = root["joint_limits"]["velocity"].as_array().unwrap();
        assert_eq!(velocity[0].as_float(), Some(robot.limits.velocity[0]));
        assert_eq!(
            root["tcp_limits"]["acceleration"].as_float(),
            Some(robot.tcp.acceleration)
        );
        // The jerk limits, for the jerk-aware bound.
        let jerk = root["joint_limits"]["jerk"].as_array().unwrap();
        assert_eq!(jerk[5].as_float(), Some(robot.limits.jerk[5]));
        assert_eq!(root["tcp_limits"]["jerk"].as_float(), Some(robot.tcp.jerk));
        let joint = root["joint"].as_array().unwrap();
        assert_eq!(joint.len(), 3);
        // Floats survive the round trip exactly.
        assert_eq!(
            joint[2]["target"][4].as_float(),
            Some(problems.joint[2].target[4])
        );
        let path = root["linear"][0]["path"].as_array().unwrap();
        assert_eq!(path.len(), problems.linear[0].path.len());
    }

    const RESULT: &str = "ruckig = \"0.19.4\"\ntoppra = \"0.6.10\"\nruckig_seconds = 0.5\n\
                          toppra_seconds = 2.0\njoint = [1.5, nan]\nlinear = [0.25]\n\
                          joint_toppra = [1.0, 1.25]\nlinear_bound = [0.375]\n";

    #[test]
    fn the_reference_result_is_read_with_its_failures() {
        let r = parse_reference(RESULT, 2, 1).unwrap();
        assert_eq!(r.ruckig_version, "0.19.4");
        assert_eq!(r.joint[0], 1.5);
        assert!(r.joint[1].is_nan());
        assert_eq!(r.linear, [0.25]);
        assert_eq!(r.toppra_s, 2.0);
        assert_eq!(r.joint_toppra, [1.0, 1.25]);
        assert_eq!(r.linear_bound, [0.375]);
    }

    #[test]
    fn a_result_without_the_bound_of_every_line_is_refused() {
        let without = RESULT.replace("linear_bound = [0.375]\n", "");
        let e = parse_reference(&without, 2, 1).unwrap_err();
        assert!(e.contains("no array linear_bound"), "{e}");
        let short = RESULT.replace("linear_bound = [0.375]", "linear_bound = []");
        let e = parse_reference(&short, 2, 1).unwrap_err();
        assert!(e.contains("linear_bound: 0 numbers for 1 problems"), "{e}");
    }

    #[test]
    fn a_result_for_other_problems_is_refused() {
        let e = parse_reference(RESULT, 3, 1).unwrap_err();
        assert!(e.contains("2 numbers for 3 problems"), "{e}");
        assert!(parse_reference("joint = [1.0]", 1, 0).is_err());
    }

    #[test]
    fn the_optimum_is_read_for_every_line_and_checked_against_their_number() {
        let text = "casadi = \"3.7.2\"\noptimum_seconds = 4.5\nlinear_optimum = [0.5, nan]\n\
                    linear_optimum_largest_term = [2.5, nan]\n";
        let o = parse_optimum(text, 2).unwrap();
        assert_eq!((o.casadi_version.as_str(), o.seconds), ("3.7.2", 4.5));
        assert_eq!((o.linear[0], o.largest_term[0]), (0.5, 2.5));
        assert!(o.linear[1].is_nan() && o.largest_term[1].is_nan());
        let without = text.replace("linear_optimum_largest_term = [2.5, nan]\n", "");
        let e = parse_optimum(&without, 2).unwrap_err();
        assert!(e.contains("no array linear_optimum_largest_term"), "{e}");
        let e = parse_optimum(text, 3).unwrap_err();
        assert!(
            e.contains("linear_optimum: 2 numbers for 3 problems"),
            "{e}"
        );
        let e = parse_optimum(&text.replace("casadi", "ipopt"), 2).unwrap_err();
        assert!(e.contains("no string casadi"), "{e}");
    }

    #[test]
    fn a_missing_environment_is_reported_before_anything_is_written() {
        let robot = Robot::from_config(&Config::load(None).unwrap()).unwrap();
        let problems = Problems::generate(&robot, 5, 1, 1).unwrap();
        let dir = std::env::temp_dir().join(format!("rc-motion-test-{}", std::process::id()));
        let e = run_reference(Path::new("/nonexistent/python"), &dir, &robot, &problems);
        assert!(matches!(e, Err(ReferenceError::NoEnvironment(_))), "{e:?}");
        let e = run_optimum(Path::new("/nonexistent/python"), &dir, &robot, &problems, 1);
        assert!(matches!(e, Err(ReferenceError::NoEnvironment(_))), "{e:?}");
        assert!(!dir.exists());
    }
}
