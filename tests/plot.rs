//! `rc plc PROGRAM --plot FILE.svg` through the real processes: the plot's position traces end
//! at the program's last target and its velocity traces stay within the joint limits.

mod common;

use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use common::Controller;

/// The last target of [`PROGRAM`] (deg).
const LAST_TARGET: [f64; 6] = [-15.0, 85.0, 100.0, 85.0, -80.0, -20.0];

const PROGRAM: &str = r#"
name = "plot test"
[[step]]
call = "GroupReset"
[[step]]
call = "EnableRobot"
[[step]]
call = "ChangeSpeedOverride"
override = 100.0
[[step]]
call = "MoveAxesAbsolute"
joints = [20.0, 95.0, 80.0, 95.0, -95.0, 25.0]
velocity_rate = 100.0
acceleration_rate = 100.0
[[step]]
call = "MoveAxesAbsolute"
joints = [-15.0, 85.0, 100.0, 85.0, -80.0, -20.0]
velocity_rate = 100.0
acceleration_rate = 100.0
"#;

/// Runs `rc` with `args` (at most 30 s); its exit success, stdout and stderr.
fn rc(args: &[&str], cwd: &Path) -> (bool, String, String) {
    let mut child = Command::new(env!("CARGO_BIN_EXE_rc"))
        .args(args)
        .current_dir(cwd)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("spawn rc");
    let start = Instant::now();
    while child.try_wait().expect("wait for rc").is_none() {
        if start.elapsed() > Duration::from_secs(30) {
            let _ = child.kill();
            panic!("rc {args:?} did not end within 30 s");
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    let output = child.wait_with_output().expect("rc output");
    (
        output.status.success(),
        String::from_utf8_lossy(&output.stdout).into_owned(),
        String::from_utf8_lossy(&output.stderr).into_owned(),
    )
}

/// Runs `rc plc PROGRAM --plot` against `c` (which must succeed): its stdout and the plot.
fn plc_with_plot(c: &Controller, program: &Path) -> (String, String) {
    let svg_path = c.dir.join("run.svg");
    let (ok, stdout, stderr) = rc(
        &[
            "plc",
            program.to_str().expect("utf-8 path"),
            "--addr",
            &c.addr,
            "--config",
            c.dir.join("default.toml").to_str().expect("utf-8 path"),
            "--plot",
            svg_path.to_str().expect("utf-8 path"),
        ],
        &c.dir,
    );
    assert!(ok, "rc plc failed\nstdout:\n{stdout}\nstderr:\n{stderr}");
    let svg = std::fs::read_to_string(&svg_path).expect("the plot file");
    (stdout, svg)
}

/// The configuration `c` runs with.
fn configuration(c: &Controller) -> shared_types::config::Config {
    shared_types::config::Config::load(Some(&c.dir.join("default.toml")))
        .expect("the test's configuration")
}

/// The opening tags of the elements named `element` in `svg`.
fn elements<'a>(svg: &'a str, element: &str) -> Vec<&'a str> {
    let open = format!("<{element} ");
    svg.match_indices(&open)
        .map(|(i, _)| &svg[i..i + svg[i..].find('>').expect("tag end")])
        .collect()
}

fn attribute<'a>(tag: &'a str, name: &str) -> &'a str {
    let key = format!(" {name}=\"");
    let start = tag.find(&key).unwrap_or_else(|| panic!("{name} in {tag}")) + key.len();
    &tag[start..start + tag[start..].find('"').expect("closing quote")]
}

fn attribute_f64(tag: &str, name: &str) -> f64 {
    attribute(tag, name).parse().expect("a number")
}

/// The data values of the polyline of `joint` in panel `panel`, from its pixel coordinates
/// and the panel's range.
fn trace_values(svg: &str, panel: &str, joint: usize) -> Vec<f64> {
    let group = elements(svg, "g")
        .into_iter()
        .find(|g| g.contains(&format!(" id=\"{panel}\"")))
        .expect("panel group");
    let (low, high) = (
        attribute_f64(group, "data-low"),
        attribute_f64(group, "data-high"),
    );
    let (top, bottom) = (
        attribute_f64(group, "data-top"),
        attribute_f64(group, "data-bottom"),
    );
    let line = elements(svg, "polyline")
        .into_iter()
        .find(|l| {
            attribute(l, "data-panel") == panel && attribute(l, "data-joint") == joint.to_string()
        })
        .expect("trace");
    attribute(line, "points")
        .split_whitespace()
        .map(|point| {
            let y: f64 = point.split_once(',').expect("x,y").1.parse().expect("y");
            low + (bottom - y) / (bottom - top) * (high - low)
        })
        .collect()
}

#[test]
fn rc_plc_with_plot_writes_the_motion_of_the_run() {
    let c = Controller::start("plot");
    let program = c.dir.join("plot.toml");
    std::fs::write(&program, PROGRAM).expect("write program");
    let (stdout, svg) = plc_with_plot(&c, &program);
    assert!(stdout.contains("plot written to"), "{stdout}");
    assert!(svg.starts_with("<?xml") && svg.trim_end().ends_with("</svg>"));
    assert!(svg.contains("rc plc plot test"), "title names the program");

    let limits = configuration(&c).robot.joints.max_velocity_deg_s;
    for joint in 1..=6 {
        let positions = trace_values(&svg, "positions", joint);
        let last = *positions.last().expect("a position trace");
        // A pixel of a 240 px panel spans well under a degree.
        assert!(
            (last - LAST_TARGET[joint - 1]).abs() < 1.0,
            "J{joint} ends at {last:.2} deg, target {}",
            LAST_TARGET[joint - 1]
        );
        let velocities = trace_values(&svg, "velocities", joint);
        let peak = velocities.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let limit = limits[joint - 1];
        assert!(
            peak <= limit * 1.01,
            "J{joint} peaks at {peak:.1} deg/s, limit {limit}"
        );
        assert!(peak > 1.0, "J{joint} moved ({peak:.2} deg/s)");
    }
    let markers = elements(&svg, "line")
        .into_iter()
        .filter(|l| l.contains("class=\"marker\""))
        .map(|l| attribute(l, "data-state"))
        .collect::<Vec<_>>();
    for state in ["ACTIVE", "DONE"] {
        assert!(
            markers.iter().filter(|s| **s == state).count() >= 2,
            "two moves {state}: {markers:?}"
        );
    }
}

/// The shipped example `plc-client/programs/blends.toml`: through the real processes, every
/// BlendingMode (2, 4, 10, 12, 11, 3) blends its move into the next (line into arc, arc into
/// line, line into joint move, joint move into line, line into joint move, joint into joint
/// move): all steps DONE, six overlaps in the plot, and the arm home where it ended.
#[test]
fn the_shipped_blends_program_blends_by_every_mode() {
    let c = Controller::start("blends");
    let program = Path::new(env!("CARGO_MANIFEST_DIR")).join("plc-client/programs/blends.toml");
    let (stdout, svg) = plc_with_plot(&c, &program);
    assert!(
        stdout.contains("result: SUCCESS (12/12 steps passed)"),
        "{stdout}"
    );
    assert_eq!(
        spans(&svg, "blending").len(),
        6,
        "one overlap per mode: {svg}"
    );
}

/// The widths (px) of the plot's spans of `class` (blending, interrupted, ...).
fn spans(svg: &str, class: &str) -> Vec<f64> {
    elements(svg, "rect")
        .into_iter()
        .filter(|r| r.contains(&format!("class=\"{class}\"")) && r.contains("y=\"100\""))
        .map(|r| attribute_f64(r, "width"))
        .collect()
}

/// The shipped example `plc-client/programs/cell.toml`, whose moves are written with the
/// specification's field names: every step passes through the real processes, its two
/// corner blends (line into circle, circle into line) and its interrupt show in the plot, the
/// TCP keeps its speed limit and the arm ends at home.
#[test]
fn the_shipped_cell_program_runs_its_lines_circle_blends_and_interrupt() {
    let c = Controller::start("cell");
    let program = Path::new(env!("CARGO_MANIFEST_DIR")).join("plc-client/programs/cell.toml");
    let (stdout, svg) = plc_with_plot(&c, &program);
    assert!(
        stdout.contains("result: SUCCESS (18/18 steps passed)"),
        "{stdout}"
    );
    // The read after the MoveDirectAbsolute compares the flange with its target pose.
    let direct = stdout
        .lines()
        .find(|l| l.contains(" MoveDirectAbsolute "))
        .expect("the MoveDirectAbsolute row");
    assert!(
        direct.contains("pose -417.03 115.01 373.15")
            && direct.contains(" mm ")
            && direct.trim_end().ends_with(" ok"),
        "{direct}"
    );
    for call in [
        "MoveLinearAbsolute",
        "MoveCircularAbsolute",
        "MoveLinearRelative",
        "WaitTime",
        "MoveDirectAbsolute",
        "GroupInterrupt",
        "GroupContinue",
    ] {
        assert!(
            stdout
                .lines()
                .any(|l| l.contains(&format!(" {call} ")) && l.contains(" DONE ")),
            "{call} DONE in\n{stdout}"
        );
    }
    let spans = |class: &str| spans(&svg, class);
    assert!(spans("blending").len() >= 2, "two blends: {svg}");
    // From the GroupInterrupt to the GroupContinue 300 ms after the arm stood: about 0.7 s
    // of the 6-odd seconds over 940 px.
    assert!(
        spans("interrupted").iter().any(|w| *w > 20.0),
        "the interrupt: {:?}",
        spans("interrupted")
    );
    let limit = configuration(&c).robot.cartesian.max_velocity_mm_s;
    let tcp = trace_values(&svg, "tcp", 0);
    let peak = tcp.iter().fold(0.0f64, |m, v| m.max(*v));
    assert!(
        peak > 100.0 && peak <= limit * 1.01,
        "TCP speed peaks at {peak:.0} mm/s, limit {limit}"
    );
    for joint in 1..=6 {
        let last = *trace_values(&svg, "positions", joint)
            .last()
            .expect("a position trace");
        let home = [0.0, 90.0, 90.0, 90.0, -90.0, 0.0][joint - 1];
        assert!((last - home).abs() < 1.0, "J{joint} ends at {last:.2} deg");
    }
}

#[test]
fn an_unwritable_plot_file_is_named_before_the_run() {
    let dir = std::env::temp_dir().join(format!("rc-plot-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("test dir");
    let program = dir.join("p.toml");
    std::fs::write(&program, PROGRAM).expect("write program");
    let target = dir.join("no-such-dir").join("run.svg");
    let (ok, _, stderr) = rc(
        &[
            "plc",
            program.to_str().expect("utf-8 path"),
            // Nothing listens here: the run must not even start.
            "--addr",
            "127.0.0.1:9",
            "--plot",
            target.to_str().expect("utf-8 path"),
        ],
        &dir,
    );
    let _ = std::fs::remove_dir_all(&dir);
    assert!(!ok);
    assert!(
        stderr.contains(&format!("cannot write the plot {}", target.display())),
        "{stderr}"
    );
}
