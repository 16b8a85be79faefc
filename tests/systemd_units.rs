//! The systemd units in `config/systemd/`: `systemd-analyze verify` on a copy that starts the
//! built `rc` with the repository's configuration (so the paths it checks are real), and the
//! settings the services rely on, checked in the files themselves.

use std::path::{Path, PathBuf};
use std::process::Command;

const SERVICES: [&str; 4] = ["servo", "planner", "interpreter", "fieldbus"];
const COMMON_DROP_IN: &str = "rc-.service.d/10-rc-common.conf";
const INSTALLED_BINARY: &str = "/usr/local/bin/rc";
const INSTALLED_CONFIG: &str = "/etc/rc/default.toml";

fn units_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("config/systemd")
}

fn read(relative: &str) -> String {
    let path = units_dir().join(relative);
    std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// The values of `key` in a unit file, in order.
fn values<'a>(unit: &'a str, key: &str) -> Vec<&'a str> {
    unit.lines()
        .filter_map(|line| line.strip_prefix(key)?.strip_prefix('='))
        .map(str::trim)
        .collect()
}

/// A copy of the units in a fresh temporary folder, pointing at the built binary and at the
/// repository's default configuration instead of the installed paths.
struct Staged {
    dir: PathBuf,
}

impl Staged {
    fn new() -> Self {
        let dir = std::env::temp_dir().join(format!("rc-systemd-units-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let config = Path::new(env!("CARGO_MANIFEST_DIR")).join("config/default.toml");
        assert!(config.is_file());
        let binary = env!("CARGO_BIN_EXE_rc");
        let mut files = unit_files();
        files.push(COMMON_DROP_IN.to_string());
        for relative in &files {
            let text = read(relative)
                .replace(INSTALLED_BINARY, binary)
                .replace(INSTALLED_CONFIG, &config.to_string_lossy());
            let target = dir.join(relative);
            std::fs::create_dir_all(target.parent().unwrap()).unwrap();
            std::fs::write(&target, text).unwrap();
        }
        Self { dir }
    }
}

impl Drop for Staged {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.dir);
    }
}

fn unit_files() -> Vec<String> {
    std::iter::once("rc.target".to_string())
        .chain(SERVICES.map(|s| format!("rc-{s}.service")))
        .collect()
}

#[test]
fn systemd_analyze_verifies_the_units_without_warnings() {
    let Ok(probe) = Command::new("systemd-analyze").arg("--version").output() else {
        eprintln!(
            "skipped: systemd-analyze is not installed (Debian package `systemd`), so the \
             units are not verified"
        );
        return;
    };
    assert!(probe.status.success());
    let staged = Staged::new();
    let output = Command::new("systemd-analyze")
        .args(["verify", "--man=no"])
        .args(unit_files().iter().map(|unit| staged.dir.join(unit)))
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(output.status.success(), "verify failed:\n{stderr}");
    // Unknown keys and sections are only warnings, with exit code 0; any line about our
    // units is one too many.
    let ours: Vec<&str> = stderr
        .lines()
        .filter(|line| line.contains("rc-") || line.contains("rc.target"))
        .collect();
    assert!(
        ours.is_empty(),
        "warnings about the units:\n{}",
        ours.join("\n")
    );
}

#[test]
fn every_service_starts_the_installed_binary_with_its_own_name() {
    for service in SERVICES {
        let unit = read(&format!("rc-{service}.service"));
        assert_eq!(
            values(&unit, "ExecStart"),
            [format!(
                "{INSTALLED_BINARY} service {service} --config {INSTALLED_CONFIG}"
            )],
            "rc-{service}.service"
        );
    }
}

#[test]
fn services_start_in_pipeline_order_and_the_target_pulls_them_all() {
    for pair in SERVICES.windows(2) {
        let unit = read(&format!("rc-{}.service", pair[1]));
        let before = format!("rc-{}.service", pair[0]);
        assert_eq!(values(&unit, "After"), [before.as_str()], "{}", pair[1]);
        assert_eq!(values(&unit, "Wants"), [before.as_str()], "{}", pair[1]);
    }
    assert!(values(&read("rc-servo.service"), "After").is_empty());
    let target = read("rc.target");
    let all = SERVICES.map(|s| format!("rc-{s}.service")).join(" ");
    assert_eq!(values(&target, "Wants"), [all.as_str()]);
}

#[test]
fn the_shared_settings_keep_iceoryx2_working_and_permit_real_time() {
    let common = read(COMMON_DROP_IN);
    for (key, value) in [
        ("PartOf", "rc.target"),
        ("Type", "notify"),
        ("NotifyAccess", "main"),
        ("Restart", "on-failure"),
        ("RemoveIPC", "no"),
        ("PrivateTmp", "no"),
        ("LimitMEMLOCK", "infinity"),
        ("User", "rc"),
    ] {
        assert_eq!(values(&common, key), [value], "{key}");
    }
    for key in [
        "WatchdogSec",
        "RestartSec",
        "StartLimitIntervalSec",
        "StartLimitBurst",
        "LimitRTPRIO",
    ] {
        assert_eq!(values(&common, key).len(), 1, "{key}");
    }
    // One place for the user and the limits: no unit overrides the drop-in.
    for service in SERVICES {
        let unit = read(&format!("rc-{service}.service"));
        for key in ["User", "Type", "RemoveIPC", "PrivateTmp", "LimitRTPRIO"] {
            assert!(
                values(&unit, key).is_empty(),
                "rc-{service}.service sets {key}"
            );
        }
    }
}
