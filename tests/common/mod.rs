//! Test harness: starts `rc run` as real processes on a private instance and TCP port, and
//! drives it with the PLC-side client over the real TCP gateway transport.

#![allow(dead_code)]

use std::net::{TcpListener, TcpStream};
use std::path::PathBuf;
use std::process::{Child, Command, Stdio};
use std::sync::{Mutex, MutexGuard};
use std::time::{Duration, Instant};

use plc_client::{CommandStatus, CycleRunner, EngineOptions, Request, RobotTask, TcpTransport};
use shared_types::srci::message::{severity, state};

/// One controller at a time: each runs a 1 kHz servo and planner, and a 2-core machine
/// shared by several would miss the deadlines these tests check.
static ONE_AT_A_TIME: Mutex<()> = Mutex::new(());

/// LifeSignTimeOut (ms) the test PLC asks for: the PLC here is a thread of the test process
/// on a shared machine that also runs every service of the controller, not a real-time PLC,
/// and a test that is not about the lifesign must not fail on one late cycle of its own
/// (ERROR_LIFESIGN_TIMEOUT, once in a clean-clone CI run). The lifesign supervision itself is
/// tested with the product's default of 50 ms.
pub const TEST_LIFESIGN_TIMEOUT_MS: u16 = 250;

/// The PLC client's default options with [`TEST_LIFESIGN_TIMEOUT_MS`].
pub fn plc_options() -> EngineOptions {
    EngineOptions {
        lifesign_timeout_ms: TEST_LIFESIGN_TIMEOUT_MS,
        ..EngineOptions::default()
    }
}

/// A controller (`rc run`) started for one test.
pub struct Controller {
    _turn: MutexGuard<'static, ()>,
    child: Child,
    pub addr: String,
    pub instance: String,
    pub dir: PathBuf,
}

fn free_port() -> u16 {
    TcpListener::bind("127.0.0.1:0")
        .and_then(|l| l.local_addr())
        .map(|a| a.port())
        .expect("a free port")
}

impl Controller {
    /// Starts a controller with the default configuration.
    pub fn start(tag: &str) -> Self {
        Self::start_with(tag, |c| c)
    }

    /// Starts a controller whose `default.toml` text is edited by `edit` first.
    pub fn start_with(tag: &str, edit: impl FnOnce(String) -> String) -> Self {
        let turn = ONE_AT_A_TIME.lock().unwrap_or_else(|p| p.into_inner());
        let port = free_port();
        let instance = format!("t{}{}", tag, std::process::id());
        let dir = std::env::temp_dir().join(format!("rc-test-{instance}"));
        std::fs::create_dir_all(&dir).expect("test dir");
        let text = shared_types::config::EMBEDDED_DEFAULT
            .replace("instance = \"rc\"", &format!("instance = \"{instance}\""))
            .replace("127.0.0.1:5000", &format!("127.0.0.1:{port}"))
            .replace(
                "data_dir = \"\"",
                &format!("data_dir = \"{}\"", dir.join("data").display()),
            );
        let config = dir.join("default.toml");
        std::fs::write(&config, edit(text)).expect("write config");
        let log = std::fs::File::create(dir.join("rc.log")).expect("log file");
        let child = Command::new(env!("CARGO_BIN_EXE_rc"))
            .args(["run", "--config"])
            .arg(&config)
            .env("RUST_LOG", "info")
            .stdout(Stdio::null())
            .stderr(log)
            .spawn()
            .expect("spawn rc run");
        let c = Self {
            _turn: turn,
            child,
            addr: format!("127.0.0.1:{port}"),
            instance,
            dir,
        };
        c.wait_for_port();
        c
    }

    fn wait_for_port(&self) {
        let start = Instant::now();
        while TcpStream::connect(&self.addr).is_err() {
            assert!(
                start.elapsed() < Duration::from_secs(30),
                "controller did not listen on {} within 30 s; log:\n{}",
                self.addr,
                self.log()
            );
            std::thread::sleep(Duration::from_millis(20));
        }
    }

    /// The controller's log so far.
    pub fn log(&self) -> String {
        std::fs::read_to_string(self.dir.join("rc.log")).unwrap_or_default()
    }

    /// The pid of `service` from the orchestrator's pid file.
    pub fn pid_of(&self, service: &str) -> Option<u32> {
        let path = orchestrator::pid_file::pid_file_path(&self.instance);
        let text = std::fs::read_to_string(path).ok()?;
        orchestrator::pid_file::parse(&text)
            .into_iter()
            .find(|e| e.service.name() == service)
            .map(|e| e.pid)
    }

    /// A PLC client over TCP with [`plc_options`] (8 ms cycle, 256/256).
    pub fn client(&self) -> CycleRunner<TcpTransport> {
        self.client_with(plc_options())
    }

    pub fn client_with(&self, options: EngineOptions) -> CycleRunner<TcpTransport> {
        CycleRunner::new(
            RobotTask::new(options).expect("engine options"),
            self.connect(),
        )
    }

    /// A new TCP connection to the gateway (it replaces the one the gateway had).
    pub fn connect(&self) -> TcpTransport {
        TcpTransport::connect(
            &self.addr,
            Duration::from_secs(2),
            Duration::from_millis(100),
        )
        .expect("connect to the controller")
    }

    /// Sends SIGTERM and waits for the exit; returns whether it exited successfully.
    pub fn stop(&mut self) -> bool {
        // SAFETY: plain kill(2) on our own child's pid.
        unsafe { libc::kill(self.child.id() as i32, libc::SIGTERM) };
        let start = Instant::now();
        while start.elapsed() < Duration::from_secs(10) {
            if let Ok(Some(status)) = self.child.try_wait() {
                return status.success();
            }
            std::thread::sleep(Duration::from_millis(20));
        }
        let _ = self.child.kill();
        let _ = self.child.wait();
        false
    }
}

impl Drop for Controller {
    fn drop(&mut self) {
        if matches!(self.child.try_wait(), Ok(None)) {
            self.stop();
        }
        if std::thread::panicking() {
            // The test failed: show what the controller said, and keep its folder.
            let log = self.log();
            let tail: Vec<&str> = log.lines().rev().take(60).collect();
            eprintln!(
                "--- last lines of {} ---",
                self.dir.join("rc.log").display()
            );
            for line in tail.into_iter().rev() {
                eprintln!("{line}");
            }
        } else {
            let _ = std::fs::remove_dir_all(&self.dir);
        }
    }
}

/// Runs the start-up chain until the client is initialized.
pub fn initialize(runner: &mut CycleRunner<TcpTransport>) {
    plc_client::start_up(runner, Duration::from_secs(10)).expect("SRCI start-up");
}

/// Submits `request` and runs cycles until it reaches a final state (or `until` says so).
pub fn execute(
    runner: &mut CycleRunner<TcpTransport>,
    request: &Request,
    timeout: Duration,
) -> CommandStatus {
    let handle = runner.task_mut().submit(request).expect("submit");
    let result = runner.run_until(|t| t.status(handle).is_some_and(|s| s.is_final()), timeout);
    let status = runner.task().status(handle).cloned().expect("status");
    result.unwrap_or_else(|e| panic!("{request:?} did not finish: {e}; last status {status:?}"));
    status
}

/// Runs cycles until `handle` reaches `state` or a final state.
pub fn run_until_state(
    runner: &mut CycleRunner<TcpTransport>,
    handle: plc_client::CommandHandle,
    wanted: u8,
    timeout: Duration,
) -> CommandStatus {
    let result = runner.run_until(
        |t| {
            t.status(handle)
                .is_some_and(|s| s.state == wanted || s.is_final())
        },
        timeout,
    );
    let status = runner.task().status(handle).cloned().expect("status");
    result.unwrap_or_else(|e| panic!("no state {wanted}: {e}; last status {status:?}"));
    status
}

/// GroupReset, EnableRobot (waits for Enabled) and a 100 % override.
pub fn reset_and_enable(runner: &mut CycleRunner<TcpTransport>) {
    let reset = execute(runner, &Request::GroupReset, Duration::from_secs(5));
    assert_eq!(reset.state, state::DONE, "GroupReset: {reset:?}");
    runner
        .task_mut()
        .submit(&Request::EnableRobot { enable: true })
        .expect("submit EnableRobot");
    runner
        .run_until(|t| t.is_enabled(), Duration::from_secs(10))
        .expect("robot enabled");
    let o = execute(
        runner,
        &Request::ChangeSpeedOverride { percent: 100.0 },
        Duration::from_secs(5),
    );
    assert_eq!(o.state, state::DONE, "ChangeSpeedOverride: {o:?}");
}

/// Reads the actual joints (degrees).
pub fn actual_joints(runner: &mut CycleRunner<TcpTransport>) -> [f64; 6] {
    let s = execute(
        runner,
        &Request::ReadActualPosition { tool: 0, frame: 0 },
        Duration::from_secs(5),
    );
    assert_eq!(s.state, state::DONE, "ReadActualPosition: {s:?}");
    plc_client::response::ActualPosition::decode(&s.response).joints_deg
}

/// Runs cycles (whatever the client's own state) until `done`; false after `timeout`.
pub fn cycles_until(
    runner: &mut CycleRunner<TcpTransport>,
    mut done: impl FnMut(&RobotTask) -> bool,
    timeout: Duration,
) -> bool {
    let start = Instant::now();
    while start.elapsed() < timeout {
        runner.step().expect("telegram exchange");
        if done(runner.task()) {
            return true;
        }
    }
    false
}

/// Moves to `target` (degrees) at `velocity_rate` percent, expects DONE, and returns the
/// largest joint deviation of the position read back afterwards.
pub fn move_to(
    runner: &mut CycleRunner<TcpTransport>,
    target: [f64; 6],
    velocity_rate: f64,
) -> f64 {
    let mut m = plc_client::MoveAxesAbsolute::to(target);
    m.velocity_rate = Some(velocity_rate);
    m.acceleration_rate = Some(velocity_rate);
    let s = execute(
        runner,
        &Request::MoveAxesAbsolute(m),
        Duration::from_secs(15),
    );
    assert_eq!(
        (s.state, s.code),
        (state::DONE, 0),
        "move to {target:?}: {s:?}"
    );
    let reached = actual_joints(runner);
    max_deviation(reached, target)
}

/// Largest absolute difference of two joint vectors.
pub fn max_deviation(a: [f64; 6], b: [f64; 6]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max)
}

/// Starts a move to `target` at 10 % velocity and returns once it has run for 300 ms.
pub fn start_slow_move(
    runner: &mut CycleRunner<TcpTransport>,
    target: [f64; 6],
) -> plc_client::CommandHandle {
    let mut m = plc_client::MoveAxesAbsolute::to(target);
    m.velocity_rate = Some(10.0);
    let handle = runner
        .task_mut()
        .submit(&Request::MoveAxesAbsolute(m))
        .expect("submit");
    run_until_state(runner, handle, state::ACTIVE, Duration::from_secs(5));
    runner.run_for(Duration::from_millis(300)).expect("moving");
    handle
}

/// The home position of the simulated arm (degrees).
pub const HOME: [f64; 6] = [0.0, 90.0, 90.0, 90.0, -90.0, 0.0];

/// A PLC client over the TCP gateway.
pub type Plc = CycleRunner<TcpTransport>;

/// A controller and a client that has run the SRCI start-up (robot not enabled).
pub fn initialized(tag: &str) -> (Controller, Plc) {
    let c = Controller::start(tag);
    let mut plc = c.client();
    initialize(&mut plc);
    (c, plc)
}

/// A controller and a client that has run the start-up, GroupReset and EnableRobot.
pub fn enabled(tag: &str) -> (Controller, Plc) {
    let (c, mut plc) = initialized(tag);
    reset_and_enable(&mut plc);
    (c, plc)
}

/// Executes `request` and expects DONE with code 0 and a response of the spec's `len` bytes.
pub fn expect_done(plc: &mut Plc, request: &Request, len: usize) -> CommandStatus {
    let s = execute(plc, request, Duration::from_secs(10));
    assert_eq!(
        (s.state, s.severity, s.code),
        (state::DONE, 0, 0),
        "{} DONE without a code: {s:?}",
        request.name()
    );
    assert_eq!(
        s.response.len(),
        len,
        "{} response length (spec table)",
        request.name()
    );
    s
}

/// Executes `request` and expects ERROR with `code` and severity ERROR; ReadMessages must
/// then deliver a command message with the same code.
pub fn expect_error(plc: &mut Plc, request: &Request, code: u16) -> CommandStatus {
    let s = execute(plc, request, Duration::from_secs(10));
    assert_eq!(
        (s.state, s.severity, s.code),
        (state::ERROR, severity::ERROR, code),
        "{} answered ERROR 0x{code:04X}: {s:?}",
        request.name()
    );
    let m = wait_for_message(plc, code);
    assert_eq!(
        (m.msg_type, m.severity),
        (4, severity::ERROR),
        "a command error message: {m:?}"
    );
    assert!(!m.text.is_empty(), "the message explains the error");
    s
}

/// Runs cycles until ReadMessages delivers a message with `code` (within 3 s) and returns it;
/// messages received before it are dropped.
pub fn wait_for_message(plc: &mut Plc, code: u16) -> plc_client::response::RobotMessage {
    let start = Instant::now();
    loop {
        let found = plc
            .task_mut()
            .take_messages()
            .into_iter()
            .find(|m| m.code == u32::from(code));
        if let Some(m) = found {
            return m;
        }
        assert!(
            start.elapsed() < Duration::from_secs(3),
            "ReadMessages delivered no message 0x{code:04X}"
        );
        plc.step().expect("telegram exchange");
    }
}

/// Submits `request` and runs cycles until it ends; returns every state its responses went
/// through (consecutive repeats folded) and the final status.
pub fn state_trace(
    plc: &mut Plc,
    request: &Request,
    timeout: Duration,
) -> (Vec<u8>, CommandStatus) {
    let handle = plc.task_mut().submit(request).expect("submit");
    follow(plc, handle, timeout)
}

/// Runs cycles until `handle` ends; returns the states seen (repeats folded) and the status.
pub fn follow(
    plc: &mut Plc,
    handle: plc_client::CommandHandle,
    timeout: Duration,
) -> (Vec<u8>, CommandStatus) {
    let mut states = Vec::new();
    let start = Instant::now();
    loop {
        plc.step().expect("telegram exchange");
        let s = plc.task().status(handle).cloned().expect("status");
        if s.responses > 0 && states.last() != Some(&s.state) {
            states.push(s.state);
        }
        if s.is_final() {
            return (states, s);
        }
        assert!(
            start.elapsed() < timeout,
            "no final state within {timeout:?}: {states:?} {s:?}"
        );
    }
}

/// ChangeIndexTool, ChangeIndexFrame and ChangeIndexLoad, read with a second
/// ExchangeConfiguration that is then disabled again.
pub fn change_indices(plc: &mut Plc) -> [u8; 3] {
    use shared_types::srci::payload::PayloadReader;
    use shared_types::srci::tables::exchange_configuration as xc;
    let lifesign_timeout_ms = plc.task().options().lifesign_timeout_ms;
    let configuration = |enable| exchange_configuration(enable, lifesign_timeout_ms);
    let h = plc.task_mut().submit(&configuration(true)).expect("submit");
    let s = run_until_state(plc, h, state::ACTIVE, Duration::from_secs(3));
    assert_eq!(s.state, state::ACTIVE, "ExchangeConfiguration: {s:?}");
    let r = PayloadReader::new(&s.response);
    let indices = [
        r.u8(xc::response::CHANGE_INDEX_TOOL),
        r.u8(xc::response::CHANGE_INDEX_FRAME),
        r.u8(xc::response::CHANGE_INDEX_LOAD),
    ];
    plc.task_mut()
        .update(h, &configuration(false))
        .expect("disable");
    let s = run_until_state(plc, h, state::DONE, Duration::from_secs(3));
    assert_eq!(
        s.state,
        state::DONE,
        "ExchangeConfiguration disabled: {s:?}"
    );
    indices
}

/// An ExchangeConfiguration request with Enable and LifeSignTimeOut (the typed request always
/// enables).
pub fn exchange_configuration(enable: bool, lifesign_timeout_ms: u16) -> Request {
    use shared_types::srci::payload::PayloadWriter;
    use shared_types::srci::tables::exchange_configuration as xc;
    let mut b = vec![0u8; xc::request::LEN];
    let mut w = PayloadWriter::new(&mut b);
    w.set_u8(xc::request::LOG_LEVEL, severity::INFO as u8);
    w.set_bit(xc::request::ENABLE, enable);
    w.set_u16(xc::request::LIFE_SIGN_TIME_OUT, lifesign_timeout_ms);
    Request::Raw {
        command_type: xc::TYPE,
        execution_mode: 2,
        payload: b.split_off(4),
    }
}

/// One change to a request's parameters, for tables of refused requests.
pub type Edit<T> = fn(&mut T);

/// A command type of the specification that the controller does not implement (answered
/// ERROR 0x8F11), the one place the tests name it: change it here when it gets implemented.
pub const UNIMPLEMENTED_TYPE: u16 = shared_types::srci::tables::move_depart_linear::TYPE;

/// A request of [`UNIMPLEMENTED_TYPE`] with a zero payload of its table's length.
pub fn unimplemented_request() -> Request {
    use shared_types::srci::tables::move_depart_linear as unimplemented;
    Request::Raw {
        command_type: UNIMPLEMENTED_TYPE,
        execution_mode: 0,
        payload: vec![0; unimplemented::request::LEN - 4],
    }
}

/// The first steps of a test program: reset, enable, and the arm to [`HOME`].
pub const FROM_HOME: &str = r#"
[[step]]
call = "GroupReset"
[[step]]
call = "EnableRobot"
[[step]]
call = "MoveAxesAbsolute"
joints = [0.0, 90.0, 90.0, 90.0, -90.0, 0.0]
"#;

/// Runs the PLC program `text` against a new controller (instance `tag`) with the client's
/// default options, after asserting that every step passed.
pub fn run_passing(tag: &str, text: &str) -> plc_client::Report {
    let c = Controller::start(tag);
    let program = plc_client::Program::parse(text, "test program").expect("the program");
    let report = plc_client::run_program(
        &c.addr,
        &program,
        &plc_client::ClientOptions::default(),
        &mut |_| {},
    )
    .expect("the run");
    assert!(report.success(), "{:#?}", report.steps);
    report
}

/// The steps of [`run_passing`].
pub fn run_passing_program(tag: &str, text: &str) -> Vec<plc_client::StepReport> {
    run_passing(tag, text).steps
}
