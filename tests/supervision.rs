//! Supervision of a real controller (`rc run`): cycle statistics in `rc status`, a planned
//! restart with `rc restart`, a frozen (SIGSTOP'ed) service caught by its heartbeat deadline,
//! and the safe stop once the restart intensity is exceeded.
//!
//! Timing is only bounded generously (seconds), as the tests share a 2-core machine.

mod common;

use std::path::Path;
use std::process::{Command, Output};
use std::thread;
use std::time::{Duration, Instant};

use common::{
    Controller, Plc, execute, initialize, move_to, reset_and_enable, run_until_state,
    start_slow_move,
};
use plc_client::Request;
use shared_types::bus::Bus;
use shared_types::health::{
    FailureCause, RequestOutcome, Service, ServiceState, SupervisionStatus, topics,
};
use shared_types::srci::message::state;
use shared_types::srci::telegram::status_bit::ERROR_PENDING;

/// Runs `rc <args> --config <config>` to completion.
fn rc(args: &[&str], config: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_rc"))
        .args(args)
        .arg("--config")
        .arg(config)
        .output()
        .expect("run rc")
}

/// Runs `rc <args>` while the PLC keeps cycling (so its lifesign never expires).
fn rc_while_cycling(plc: &mut Plc, args: &'static [&'static str], config: &Path) -> Output {
    let config = config.to_path_buf();
    let command = thread::spawn(move || rc(args, &config));
    while !command.is_finished() {
        plc.run_for(Duration::from_millis(20)).expect("cycles");
    }
    command.join().expect("rc thread")
}

/// The first supervision status of controller `instance` that satisfies `condition`.
fn supervision_where(
    instance: &str,
    what: &str,
    condition: impl Fn(&SupervisionStatus) -> bool,
) -> SupervisionStatus {
    let bus = Bus::new(instance, "suptest").expect("bus");
    let statuses = bus
        .subscriber::<SupervisionStatus>(topics::SUPERVISION_STATUS)
        .expect("subscriber");
    let start = Instant::now();
    let mut last = None;
    while start.elapsed() < Duration::from_secs(15) {
        while let Some(sample) = statuses.receive().expect("receive") {
            let status = *sample.payload();
            if condition(&status) {
                return status;
            }
            last = Some(status);
        }
        thread::sleep(Duration::from_millis(20));
    }
    panic!("no supervision status with {what}; last {last:?}");
}

fn alive(pid: u32) -> bool {
    // SAFETY: signal 0 only checks that the process exists.
    unsafe { libc::kill(pid as libc::pid_t, 0) == 0 }
}

fn signal(pid: u32, signal: libc::c_int) {
    // SAFETY: kill(2) on a service process of our own controller.
    assert_eq!(unsafe { libc::kill(pid as libc::pid_t, signal) }, 0);
}

/// Waits until the pid file shows a `service` process other than `old`.
fn replaced(c: &Controller, service: &str, old: u32) -> u32 {
    let start = Instant::now();
    loop {
        if let Some(pid) = c.pid_of(service).filter(|&p| p != old) {
            return pid;
        }
        assert!(
            start.elapsed() < Duration::from_secs(15),
            "{service} (pid {old}) not replaced"
        );
        thread::sleep(Duration::from_millis(20));
    }
}

#[test]
fn rc_status_shows_the_cycle_statistics_of_every_service() {
    let c = Controller::start("supstat");
    // Telegrams, so the interpreter and the fieldbus have cycles to count.
    let mut plc = c.client();
    initialize(&mut plc);
    let out = rc_while_cycling(&mut plc, &["status"], &c.dir.join("default.toml"));
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{text}");
    for (service, period_us) in [
        ("servo", 1000),
        ("planner", 1000),
        ("interpreter", 50_000),
        ("fieldbus", 50_000),
    ] {
        let pid = c.pid_of(service).expect("pid").to_string();
        let row: Vec<&str> = text
            .lines()
            .map(|l| l.split_whitespace().collect::<Vec<_>>())
            .find(|f| f.len() == 10 && f[0] == service)
            .unwrap_or_else(|| panic!("no row for {service} in:\n{text}"));
        // service pid uptime period cycles p50 p99 max overruns restarts
        assert_eq!(
            (row[1], row[3], row[9]),
            (pid.as_str(), &*period_us.to_string(), "0")
        );
        let cycles: u64 = row[4].parse().expect("cycles");
        let [p50, p99, max]: [f64; 3] = [5, 6, 7].map(|i| row[i].parse().expect("lateness"));
        assert!(cycles > 0, "{service} counted cycles:\n{text}");
        assert!(p50 <= p99 && p99 <= max && max > 0.0, "{service}:\n{text}");
    }
    assert!(text.contains("supervision: all running"), "{text}");
}

#[test]
fn rc_restart_replaces_the_planner_at_rest_and_the_next_move_works() {
    let c = Controller::start("suprestart");
    let mut plc = c.client();
    initialize(&mut plc);
    reset_and_enable(&mut plc);
    let old = c.pid_of("planner").expect("planner pid");
    let servo = c.pid_of("servo").expect("servo pid");
    let out = rc_while_cycling(
        &mut plc,
        &["restart", "planner"],
        &c.dir.join("default.toml"),
    );
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{text}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let new = c.pid_of("planner").expect("planner pid");
    assert_ne!(new, old);
    assert!(!alive(old), "the old planner is gone");
    assert_eq!(
        text.trim(),
        format!("planner restarted: pid {old} -> {new}")
    );
    assert_eq!(c.pid_of("servo"), Some(servo), "the servo kept running");
    assert!(plc.task().is_enabled(), "still enabled");
    // At rest nothing was lost: no error, no GroupReset needed.
    plc.run_for(Duration::from_millis(200)).expect("cycles");
    assert_eq!(
        plc.task().status_word() & ERROR_PENDING,
        0,
        "a restart at rest is invisible"
    );
    assert!(move_to(&mut plc, [20.0, 80.0, 100.0, 90.0, -90.0, 10.0], 50.0) < 0.01);
    let status = supervision_where(&c.instance, "all running", |s| s.all_running == 1);
    let planner = status.service(Service::Planner);
    assert_eq!((planner.pid, planner.restarts), (new, 1));
    assert_eq!(
        planner.last_failure,
        FailureCause::None as u8,
        "not a failure"
    );
}

#[test]
fn rc_restart_of_the_planner_during_a_move_stops_the_arm_and_ends_the_move_with_an_error() {
    let c = Controller::start("supmoving");
    let mut plc = c.client();
    initialize(&mut plc);
    reset_and_enable(&mut plc);
    let handle = start_slow_move(&mut plc, [-60.0, 130.0, 30.0, 50.0, -30.0, -90.0]);
    let out = rc_while_cycling(
        &mut plc,
        &["restart", "planner"],
        &c.dir.join("default.toml"),
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let s = run_until_state(&mut plc, handle, state::DONE, Duration::from_secs(5));
    assert!(
        matches!(s.state, state::ERROR | state::ABORTED) && s.code != 0,
        "the move ends with an error code: {s:?}"
    );
    plc.run_until(|t| !t.is_moving(), Duration::from_secs(3))
        .expect("the arm stops");
    let reset = execute(&mut plc, &Request::GroupReset, Duration::from_secs(5));
    assert_eq!(reset.state, state::DONE, "GroupReset: {reset:?}");
    assert!(move_to(&mut plc, common::HOME, 100.0) < 0.01);
}

#[test]
fn rc_restart_of_the_interpreter_keeps_the_session_and_the_running_move() {
    let c = Controller::start("suphot");
    // The product's default LifeSignTimeOut of 50 ms: the handover must fit within it.
    let mut plc = c.client_with(plc_client::EngineOptions::default());
    initialize(&mut plc);
    reset_and_enable(&mut plc);
    let old = c.pid_of("interpreter").expect("interpreter pid");
    let target = [40.0, 100.0, 80.0, 80.0, -70.0, 30.0];
    let handle = start_slow_move(&mut plc, target);
    // The PLC exchanges every 8 ms with a 50 ms lifesign throughout.
    let out = rc_while_cycling(
        &mut plc,
        &["restart", "interpreter"],
        &c.dir.join("default.toml"),
    );
    assert!(
        out.status.success(),
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    let new = c.pid_of("interpreter").expect("interpreter pid");
    assert_ne!(new, old, "a new interpreter process");
    let done = run_until_state(&mut plc, handle, state::DONE, Duration::from_secs(30));
    assert_eq!(
        (done.state, done.code),
        (state::DONE, 0),
        "the running move finished normally: {done:?}"
    );
    assert_eq!(
        plc.task().resumes(),
        0,
        "no RESUME: the session never broke"
    );
    assert_eq!(plc.task().status_word() & ERROR_PENDING, 0);
    assert!(
        move_to(&mut plc, common::HOME, 100.0) < 0.01,
        "and the next move works"
    );
}

#[test]
fn rc_restart_without_a_controller_says_so() {
    let dir = std::env::temp_dir().join(format!("rc-test-norestart-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("dir");
    let config = dir.join("default.toml");
    std::fs::write(
        &config,
        shared_types::config::EMBEDDED_DEFAULT.replace(
            "instance = \"rc\"",
            &format!("instance = \"none{}\"", std::process::id()),
        ),
    )
    .expect("config");
    let out = rc(&["restart", "servo"], &config);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(err.contains("is not running"), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_frozen_service_is_killed_by_its_heartbeat_deadline_and_restarted() {
    let c = Controller::start("supfrozen");
    let planner = c.pid_of("planner").expect("planner pid");
    let servo = c.pid_of("servo").expect("servo pid");
    // Frozen, not dead: only the missing heartbeat can tell.
    signal(planner, libc::SIGSTOP);
    let new = replaced(&c, "planner", planner);
    assert!(!alive(planner), "the frozen planner was killed");
    let status = supervision_where(&c.instance, "the planner running again", |s| {
        s.service(Service::Planner).pid == new
            && ServiceState::from_wire(s.service(Service::Planner).state) == ServiceState::Running
    });
    let entry = status.service(Service::Planner);
    assert_eq!(
        FailureCause::from_wire(entry.last_failure),
        FailureCause::MissedHeartbeat
    );
    assert_eq!(entry.signal, libc::SIGKILL);
    assert_eq!(c.pid_of("servo"), Some(servo), "one_for_one");
    assert!(
        c.log()
            .contains("missed its heartbeat deadline: killing it"),
        "{}",
        c.log()
    );
}

#[test]
fn beyond_the_restart_intensity_the_arm_is_held_and_a_reset_brings_the_planner_back() {
    let c = Controller::start_with("supheld", |text| {
        text.replace("max_restarts = 5", "max_restarts = 1")
    });
    let servo = c.pid_of("servo").expect("servo pid");
    let first = c.pid_of("planner").expect("planner pid");
    signal(first, libc::SIGKILL);
    let second = replaced(&c, "planner", first);
    // The restarted planner must have started (and beaten) before the second kill, so the
    // kill hits a running planner.
    supervision_where(&c.instance, "the planner back", |s| {
        s.service(Service::Planner).pid == second && s.all_running == 1
    });
    signal(second, libc::SIGKILL);
    let status = supervision_where(&c.instance, "a safe stop", |s| s.safe_stop == 1);
    assert_eq!(status.failed_service(), Some(Service::Planner));
    assert_eq!(
        FailureCause::from_wire(status.failure),
        FailureCause::Signaled
    );
    assert_eq!(status.service(Service::Planner).signal, libc::SIGKILL);
    assert!(
        status
            .reason()
            .starts_with("planner killed by signal 9; 2 failures"),
        "{}",
        status.reason()
    );
    assert_eq!(status.all_running, 0);
    for service in [Service::Servo, Service::Interpreter, Service::Fieldbus] {
        let entry = status.service(service);
        assert_eq!(
            ServiceState::from_wire(entry.state),
            ServiceState::Running,
            "{service} keeps running"
        );
        assert!(alive(entry.pid));
    }
    assert_eq!(status.service(Service::Servo).pid, servo);
    let out = rc(&["status"], &c.dir.join("default.toml"));
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        text.contains("supervision: SAFE STOP: planner killed by signal 9"),
        "{text}"
    );
    // A PLC that connects now finds the error and its cause. (A generous lifesign: a process
    // start loads this 2-core machine while the PLC must keep cycling.)
    let mut plc = c.client_with(plc_client::EngineOptions {
        lifesign_timeout_ms: 500,
        ..Default::default()
    });
    initialize(&mut plc);
    plc.run_for(Duration::from_millis(500)).expect("cycles");
    assert_eq!(c.pid_of("planner"), None, "the planner is not restarted");
    assert_ne!(plc.task().status_word() & ERROR_PENDING, 0, "ErrorPending");
    let messages = plc.task_mut().take_messages();
    assert!(
        messages
            .iter()
            .any(|m| m.text.contains("safe stop: planner killed by signal 9")),
        "ReadMessages names the cause: {messages:?}"
    );

    // The PLC's GroupReset asks the orchestrator to start the planner again and is DONE once
    // every service runs and the planner has reset.
    let reset = execute(&mut plc, &Request::GroupReset, Duration::from_secs(20));
    assert_eq!(
        (reset.state, reset.code),
        (state::DONE, 0),
        "GroupReset: {reset:?}"
    );
    let status = supervision_where(&c.instance, "all running again", |s| s.all_running == 1);
    assert_eq!(
        RequestOutcome::from_wire(status.request_outcome),
        RequestOutcome::Done
    );
    assert_eq!(status.safe_stop, 0);
    assert_eq!(c.pid_of("servo"), Some(servo));
    assert_eq!(plc.task().status_word() & ERROR_PENDING, 0);
    reset_and_enable(&mut plc);
    assert!(move_to(&mut plc, [20.0, 80.0, 100.0, 90.0, -90.0, 10.0], 50.0) < 0.01);
}
