//! The RobotTask: the PLC side of one SRCI axes group, one call per telegram cycle.
//!
//! Pure: no I/O and no clock. The caller passes the time and the robot's last telegram and
//! receives the next PLC telegram. The order inside one cycle follows the open Python client
//! (SRCI_CLIENT_PY's MC_RobotTask): register bookkeeping, frame check and lifesign
//! supervision, Control from the TelegramState, the SEQ decision (on the ACK parsed in the
//! *previous* cycle), the start-up chain and message acknowledgement, the telegram, and only
//! then the parse of the robot telegram given in this cycle. With a robot that acknowledges
//! at once, every SEQ therefore goes out twice.

use std::collections::{HashMap, VecDeque};
use std::time::Duration;

use shared_types::srci::message::{ResponseHeader, iec_date_time, severity, state};
use shared_types::srci::tables;
use shared_types::srci::telegram::{
    Control, MAX_TELEGRAM_LEN, MIN_TELEGRAM_LEN, PLC_HEADER_LEN, PlcHeader, ROBOT_HEADER_LEN,
    RobotHeader, Sequence, SequenceWriter, SrciVersion, TelegramError, next_lifesign,
    sequence_areas, status_bit, telegram_state,
};

use crate::acr::{Acr, CommandHandle, CompletedResponse, FRAGMENTS_MAX, ResponseError};
use crate::request::{Request, command_name};
use crate::response::{Configuration, CyclicPosition, Messages, RobotData, RobotMessage};

/// Lowest LifeSignTimeOut the robot accepts (the client supervises with at least this).
const LIFESIGN_TIMEOUT_MIN_MS: u16 = 10;
/// Received messages kept until the caller takes them.
const MESSAGES_KEPT: usize = 256;

/// Settings of the RobotTask. The defaults are those of the open client's examples.
#[derive(Debug, Clone, PartialEq)]
pub struct EngineOptions {
    /// Bytes sent per telegram (64..=256).
    pub length_plc_to_rob: usize,
    /// Bytes received per telegram (64..=256).
    pub length_rob_to_plc: usize,
    /// Lengths written into the header instead of the two above, to test the robot's length
    /// check (the telegram keeps its configured size).
    pub header_lengths: Option<(u16, u16)>,
    /// AxesGroupID (0..=15); the open clients use 0.
    pub axes_group: u8,
    /// SRCI version byte: major in bits 5..7, minor in bits 0..4 (0x25 = 1.5).
    pub version: u8,
    /// LifeSignTimeOut sent with ExchangeConfiguration, in ms (sent as given, so a robot's
    /// handling of too small values can be tested).
    pub lifesign_timeout_ms: u16,
    /// MessageLevel of ReadMessages (4 debug, 5 info, 20 warning, 28 error).
    pub message_level: u8,
    /// LogLevel of ExchangeConfiguration.
    pub log_level: u8,
    /// The PLC cycle time, used in the supervision times.
    pub cycle_time: Duration,
    /// Optional cyclic position blocks the robot sends every telegram
    /// (ReadActualPositionCyclic).
    pub cyclic_position: CyclicSelection,
}

/// Which cyclic position blocks the robot sends (TelegramNumberRobToPlc bits 1 and 2).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct CyclicSelection {
    /// CartesianPosition (40 bytes); the PLC then sends ToolNo and FrameNo after its header.
    pub cartesian: bool,
    /// JointPosition (30 bytes).
    pub joints: bool,
}

impl CyclicSelection {
    /// The TelegramNumberRobToPlc bits.
    pub fn telegram_number(self) -> u16 {
        (u16::from(self.cartesian) << 1) | (u16::from(self.joints) << 2)
    }

    /// Cyclic bytes after the PLC→robot header (ToolNo, FrameNo).
    pub fn plc_len(self) -> usize {
        if self.cartesian { 2 } else { 0 }
    }

    /// Cyclic bytes after the robot→PLC header.
    pub fn robot_len(self) -> usize {
        usize::from(self.cartesian) * 40 + usize::from(self.joints) * 30
    }
}

impl Default for EngineOptions {
    fn default() -> Self {
        Self {
            length_plc_to_rob: MAX_TELEGRAM_LEN,
            length_rob_to_plc: MAX_TELEGRAM_LEN,
            header_lengths: None,
            axes_group: 0,
            version: SrciVersion::CURRENT.to_byte(),
            lifesign_timeout_ms: 50,
            message_level: severity::WARNING as u8,
            log_level: severity::INFO as u8,
            cycle_time: Duration::from_millis(8),
            cyclic_position: CyclicSelection::default(),
        }
    }
}

/// Invalid [`EngineOptions`].
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum OptionsError {
    #[error("telegram length {0} is outside {MIN_TELEGRAM_LEN}..={MAX_TELEGRAM_LEN}")]
    TelegramLength(usize),
    #[error("AxesGroupID {0} is outside 0..=15")]
    AxesGroup(u8),
}

/// Where the interface start-up stands.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Phase {
    /// Control follows the robot's TelegramState until it reports INITIALIZED.
    Connecting,
    /// ReadMessages sent, waiting for it to be ACTIVE.
    StartingMessages,
    /// ExchangeConfiguration sent, waiting for it to be ACTIVE.
    StartingConfiguration,
    /// ReadRobotData sent, waiting for DONE.
    ReadingRobotData,
    /// Commands can be submitted.
    Initialized,
    /// Stopped by a [`EngineFault`]; [`RobotTask::restart`] starts over.
    Faulted,
}

impl Phase {
    /// What the phase is waiting for, for error messages.
    pub fn describe(self) -> &'static str {
        match self {
            Self::Connecting => "waiting for TelegramState INITIALIZED",
            Self::StartingMessages => "waiting for ReadMessages to become ACTIVE",
            Self::StartingConfiguration => "waiting for ExchangeConfiguration to become ACTIVE",
            Self::ReadingRobotData => "waiting for ReadRobotData to be DONE",
            Self::Initialized => "initialized",
            Self::Faulted => "faulted",
        }
    }
}

/// Why the RobotTask stopped; the client error IDs are those of the open client.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum EngineFault {
    /// 0x80A4.
    #[error("robot SRCI major version {robot} differs from the client's {client}")]
    MajorVersion { robot: u8, client: u8 },
    #[error("robot reports undefined TelegramState {0}")]
    UnexpectedTelegramState(u8),
    /// 0x80A2.
    #[error("robot left INITIALIZED: TelegramState {telegram_state} ({})", telegram_state_name(*.telegram_state))]
    InterfaceLost { telegram_state: u8 },
    /// 0x80A5.
    #[error("robot lifesign frozen for more than {timeout_ms} ms")]
    RobotLifeSignTimeout { timeout_ms: u64 },
    /// 0x80A8.
    #[error("no new sequence acknowledged for more than {timeout_ms} ms")]
    SequenceTimeout { timeout_ms: u64 },
    #[error("start-up command {} ended {} with code 0x{code:04X}", command_name(*.command_type), state::name(*.state))]
    StartupCommandFailed {
        command_type: u16,
        state: u8,
        code: u16,
    },
}

/// Why a command could not be submitted or updated.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum SubmitError {
    #[error("the interface is not initialized ({0})")]
    NotInitialized(&'static str),
    #[error("all {0} Active Command Register entries are in use")]
    AcrFull(usize),
    #[error("command payload of {0} bytes exceeds 65535")]
    PayloadTooLong(usize),
    #[error("unknown command handle")]
    UnknownHandle,
    #[error("the command has already ended")]
    Finished,
    #[error("an update must keep command type {expected}, got {got}")]
    TypeMismatch { expected: u16, got: u16 },
}

/// A cycle that could not be run.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum CycleError {
    #[error("telegram buffer of {got} bytes, configured {expected}")]
    TxLength { expected: usize, got: usize },
    #[error(transparent)]
    Telegram(#[from] TelegramError),
}

/// What the client knows about one command.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CommandStatus {
    pub command_type: u16,
    /// CmdID the command used (reused by later commands once this one ended).
    pub cmd_id: u16,
    /// ParSeq of the last parameters sent (1 for a new command).
    pub par_seq_sent: u8,
    /// CmdMessageState of the last complete response (CREATED before any response).
    pub state: u8,
    /// ParSeq echoed by the last response.
    pub par_seq: u8,
    pub severity: i8,
    pub code: u16,
    /// The whole payload of the last complete response.
    pub response: Vec<u8>,
    /// Complete responses received.
    pub responses: u32,
    /// Engine time of the submission and of the first BUFFERED, first ACTIVE and final state.
    pub submitted_at: Duration,
    pub buffered_at: Option<Duration>,
    pub active_at: Option<Duration>,
    pub final_at: Option<Duration>,
    /// The register was reset (by [`RobotTask::restart`]) before the command ended.
    pub abandoned: bool,
}

impl CommandStatus {
    fn new(command_type: u16, cmd_id: u16, now: Duration) -> Self {
        Self {
            command_type,
            cmd_id,
            par_seq_sent: 1,
            state: state::CREATED,
            par_seq: 0,
            severity: severity::NONE,
            code: 0,
            response: Vec::new(),
            responses: 0,
            submitted_at: now,
            buffered_at: None,
            active_at: None,
            final_at: None,
            abandoned: false,
        }
    }

    /// Whether the command reached DONE, ABORTED or ERROR.
    pub fn is_final(&self) -> bool {
        state::is_final(self.state)
    }

    /// Name of the current state.
    pub fn state_name(&self) -> &'static str {
        state::name(self.state)
    }

    fn apply(&mut self, header: ResponseHeader, payload: &[u8], now: Duration) {
        self.state = header.state;
        self.par_seq = header.par_seq;
        self.severity = header.severity;
        self.code = header.code;
        self.response.clear();
        self.response.extend_from_slice(payload);
        self.responses += 1;
        match header.state {
            state::BUFFERED | state::BUFFERED_IN_PLANNER => {
                self.buffered_at.get_or_insert(now);
            }
            state::ACTIVE => {
                self.active_at.get_or_insert(now);
            }
            s if state::is_final(s) => self.final_at = Some(now),
            _ => {}
        }
    }
}

/// Name of a TelegramState value.
pub fn telegram_state_name(s: u8) -> &'static str {
    use telegram_state as t;
    match s {
        t::UNDEFINED => "UNDEFINED",
        t::CONTROL_MISMATCH => "ERROR_CONTROL_MISMATCH",
        t::INITIALIZATION_LOST => "ERROR_INITIALIZATION_LOST",
        t::LENGTH_MISMATCH => "ERROR_TELEGRAM_LENGTH_MISMATCH",
        t::MAJOR_VERSION => "ERROR_MAJOR_VERSION_INCOMPATIBLE",
        t::LIFESIGN_TIMEOUT => "ERROR_LIFESIGN_TIMEOUT",
        t::OPTIONAL_DATA_TOO_LARGE => "ERROR_OPTIONAL_DATA_TOO_LARGE",
        t::RESET_AFTER_INITIALIZED => "ERROR_RESET_AFTER_INITIALIZED",
        t::SEQUENCE_TIMEOUT => "ERROR_SEQUENCE_TIMEOUT",
        t::TELEGRAM_NUMBER_CHANGED => "ERROR_TELEGRAM_NUMBER_CHANGED",
        t::INVALID_AXES_GROUP => "ERROR_INVALID_AXES_GROUP",
        t::TELEGRAM_NUMBER_INVALID => "ERROR_TELEGRAM_NUMBER_INVALID",
        t::TELEGRAM_NUMBER_UNSUPPORTED => "ERROR_TELEGRAM_NUMBER_UNSUPPORTED",
        t::CONNECTION_LOST => "ERROR_CONNECTION_LOST",
        t::READY_TO_RESUME => "READY_TO_RESUME",
        t::READY_FOR_INITIALIZATION => "READY_FOR_INITIALIZATION",
        t::INITIALIZED => "INITIALIZED",
        _ => "UNDEFINED_VALUE",
    }
}

/// The RobotTask of one axes group.
#[derive(Debug)]
pub struct RobotTask {
    opts: EngineOptions,
    now: Duration,
    /// UNIX time in ms at engine time zero, for ClientDate/ClientTime.
    wall_origin_ms: u64,
    cycles: u64,

    phase: Phase,
    fault: Option<EngineFault>,
    /// The phase the fault stopped.
    faulted_in: Option<Phase>,
    control: Control,
    lifesign: u8,
    lifesign_frozen: bool,
    robot: Option<RobotHeader>,
    /// The cyclic position blocks of the last robot telegram in state INITIALIZED.
    cyclic: Option<CyclicPosition>,
    invalid_frames: u64,
    robot_lifesign_byte: u8,
    robot_lifesign_changed_at: Duration,

    current_seq: u16,
    /// SEQ_ACK of the last parsed robot telegram.
    robot_ack: u16,
    new_seq: bool,
    last_new_seq_at: Duration,
    /// The sequence being sent, kept so that it is repeated byte for byte until acknowledged.
    seq_area: [u8; MAX_TELEGRAM_LEN],

    acr: Acr,
    records: HashMap<CommandHandle, CommandStatus>,
    next_handle: u64,
    scratch: Vec<u8>,

    read_messages: Option<CommandHandle>,
    exchange_configuration: Option<CommandHandle>,
    read_robot_data: Option<CommandHandle>,
    configuration: Option<Configuration>,
    robot_data: Option<RobotData>,
    initialized_at: Option<Duration>,

    last_msg_id: u8,
    msg_to_ack: u8,
    acked_msg_id: u8,
    messages: VecDeque<RobotMessage>,

    /// The phase to return to once the robot accepted RESUME after a lost link.
    resume_into: Option<Phase>,
    /// Sessions resumed with RESUME.
    resumes: u64,
}

impl RobotTask {
    /// A RobotTask that starts its interface with the first cycle.
    pub fn new(opts: EngineOptions) -> Result<Self, OptionsError> {
        for len in [opts.length_plc_to_rob, opts.length_rob_to_plc] {
            if !(MIN_TELEGRAM_LEN..=MAX_TELEGRAM_LEN).contains(&len) {
                return Err(OptionsError::TelegramLength(len));
            }
        }
        if opts.axes_group > 15 {
            return Err(OptionsError::AxesGroup(opts.axes_group));
        }
        Ok(Self {
            opts,
            now: Duration::ZERO,
            wall_origin_ms: 0,
            cycles: 0,
            phase: Phase::Connecting,
            fault: None,
            faulted_in: None,
            control: Control::None,
            lifesign: 0,
            lifesign_frozen: false,
            robot: None,
            cyclic: None,
            invalid_frames: 0,
            robot_lifesign_byte: 0,
            robot_lifesign_changed_at: Duration::ZERO,
            current_seq: 0,
            robot_ack: 0,
            new_seq: false,
            last_new_seq_at: Duration::ZERO,
            seq_area: [0; MAX_TELEGRAM_LEN],
            acr: Acr::new(),
            records: HashMap::new(),
            next_handle: 1,
            scratch: Vec::with_capacity(MAX_TELEGRAM_LEN),
            read_messages: None,
            exchange_configuration: None,
            read_robot_data: None,
            configuration: None,
            robot_data: None,
            initialized_at: None,
            last_msg_id: 0,
            msg_to_ack: 0,
            acked_msg_id: 0,
            messages: VecDeque::new(),
            resume_into: None,
            resumes: 0,
        })
    }

    /// Runs one cycle: `rx` is the robot's last telegram (empty if none yet), `tx` receives
    /// the next PLC telegram and must have the configured PLC→robot length.
    pub fn cycle(&mut self, now: Duration, rx: &[u8], tx: &mut [u8]) -> Result<(), CycleError> {
        if tx.len() != self.opts.length_plc_to_rob {
            return Err(CycleError::TxLength {
                expected: self.opts.length_plc_to_rob,
                got: tx.len(),
            });
        }
        self.now = now;
        self.cycles += 1;
        self.acr.manage();
        let valid = self.accept_frame(rx);
        if valid {
            self.note_robot_lifesign(rx[1]);
        }
        self.supervise();
        self.follow_telegram_state();
        self.advance_sequence();
        self.run_startup();
        self.acknowledge_messages();
        self.write_telegram(tx)?;
        if valid {
            self.parse(rx);
        }
        Ok(())
    }

    /// Starts the interface over after a fault: the register is reset (commands still in it
    /// are marked abandoned), SEQ restarts at 1 and Control follows the TelegramState again.
    pub fn restart(&mut self) {
        for handle in self.acr.reset() {
            if let Some(rec) = self.records.get_mut(&handle) {
                rec.abandoned = true;
            }
        }
        self.acr.set_size(0);
        self.phase = Phase::Connecting;
        self.fault = None;
        self.faulted_in = None;
        self.control = Control::None;
        self.current_seq = 0;
        self.robot_ack = 0;
        self.new_seq = false;
        self.seq_area.fill(0);
        self.read_messages = None;
        self.exchange_configuration = None;
        self.read_robot_data = None;
        self.initialized_at = None;
        self.last_msg_id = 0;
        self.msg_to_ack = 0;
        self.acked_msg_id = 0;
        tracing::info!("RobotTask restarts the interface");
    }

    /// The fieldbus link was lost and a new one is up: the commands stay in the register and
    /// Control follows the TelegramState again, so that the session is resumed (RESUME on
    /// READY_TO_RESUME) and continues where it was, start-up commands included.
    pub fn link_restored(&mut self) {
        if self.in_session() {
            self.resume_into = Some(self.phase);
        }
        self.phase = Phase::Connecting;
        self.control = Control::None;
        self.robot = None;
        self.robot_lifesign_changed_at = self.now;
        self.last_new_seq_at = self.now;
        tracing::info!(
            commands = self.acr.in_use(),
            "fieldbus link restored: resuming the session"
        );
    }

    /// How many times the robot accepted RESUME of this session.
    pub fn resumes(&self) -> u64 {
        self.resumes
    }

    /// Submits a command; allowed once the interface is initialized.
    pub fn submit(&mut self, request: &Request) -> Result<CommandHandle, SubmitError> {
        if self.phase != Phase::Initialized {
            return Err(SubmitError::NotInitialized(self.phase.describe()));
        }
        self.submit_internal(request)
    }

    /// Sends new parameters for a running command under its CmdID (ParSeq + 1, Clear).
    pub fn update(&mut self, handle: CommandHandle, request: &Request) -> Result<(), SubmitError> {
        let rec = self
            .records
            .get_mut(&handle)
            .ok_or(SubmitError::UnknownHandle)?;
        if rec.is_final() || rec.abandoned {
            return Err(SubmitError::Finished);
        }
        if request.command_type() != rec.command_type {
            return Err(SubmitError::TypeMismatch {
                expected: rec.command_type,
                got: request.command_type(),
            });
        }
        check_payload_len(request)?;
        // ParSeq is a 4-bit field; the open client's byte counter wraps on the wire.
        let par_seq = (rec.par_seq_sent + 1) & 0x0F;
        request.encode(par_seq, &mut self.scratch);
        if !self.acr.update(rec.cmd_id, &self.scratch) {
            return Err(SubmitError::Finished);
        }
        rec.par_seq_sent = par_seq;
        Ok(())
    }

    /// What the client knows about a command.
    pub fn status(&self, handle: CommandHandle) -> Option<&CommandStatus> {
        self.records.get(&handle)
    }

    /// Forgets an ended command's status (long runs call this to keep memory bounded).
    pub fn release(&mut self, handle: CommandHandle) {
        if self
            .records
            .get(&handle)
            .is_some_and(|r| r.is_final() || r.abandoned)
        {
            self.records.remove(&handle);
        }
    }

    /// Takes the robot messages received so far (oldest first).
    pub fn take_messages(&mut self) -> Vec<RobotMessage> {
        self.messages.drain(..).collect()
    }

    /// Freezes (or releases) the PLC lifesign, to test the robot's supervision.
    pub fn set_lifesign_frozen(&mut self, frozen: bool) {
        self.lifesign_frozen = frozen;
    }

    /// Sets the UNIX time in ms that engine time zero corresponds to (for ClientDate/Time).
    pub fn set_wall_clock_origin(&mut self, unix_ms: u64) {
        self.wall_origin_ms = unix_ms;
    }

    pub fn options(&self) -> &EngineOptions {
        &self.opts
    }

    pub fn phase(&self) -> Phase {
        self.phase
    }

    /// Whether commands can be submitted.
    pub fn initialized(&self) -> bool {
        self.phase == Phase::Initialized
    }

    /// Engine time at which the start-up chain completed.
    pub fn initialized_at(&self) -> Option<Duration> {
        self.initialized_at
    }

    pub fn fault(&self) -> Option<EngineFault> {
        self.fault
    }

    /// The phase a fault interrupted.
    pub fn faulted_in(&self) -> Option<Phase> {
        self.faulted_in
    }

    /// Engine time of the last cycle.
    pub fn now(&self) -> Duration {
        self.now
    }

    pub fn cycles(&self) -> u64 {
        self.cycles
    }

    /// Robot telegrams dropped because of a wrong length or a header/footer lifesign mismatch.
    pub fn invalid_frames(&self) -> u64 {
        self.invalid_frames
    }

    /// The SEQ being sent.
    pub fn current_seq(&self) -> u16 {
        self.current_seq
    }

    /// The Control nibble being sent.
    pub fn control(&self) -> Control {
        self.control
    }

    /// Usable and used Active Command Register entries.
    pub fn acr_usage(&self) -> (usize, usize) {
        (self.acr.size(), self.acr.in_use())
    }

    /// The header of the last valid robot telegram.
    pub fn robot_header(&self) -> Option<&RobotHeader> {
        self.robot.as_ref()
    }

    /// ReadActualPositionCyclic: the position blocks of the last robot telegram (when
    /// selected in [`EngineOptions::cyclic_position`]).
    pub fn cyclic_position(&self) -> Option<&CyclicPosition> {
        self.cyclic.as_ref()
    }

    /// TelegramState of the last valid robot telegram (UNDEFINED before any).
    pub fn telegram_state(&self) -> u8 {
        self.robot
            .map_or(telegram_state::UNDEFINED, |h| h.telegram_state)
    }

    /// StatusRobotArm of the last valid robot telegram.
    pub fn status_word(&self) -> u32 {
        self.robot.map_or(0, |h| h.status)
    }

    /// StatusRobotArm.IsMoving.
    pub fn is_moving(&self) -> bool {
        self.status_word() & status_bit::IS_MOVING != 0
    }

    /// StatusRobotArm.Enabled (RA power).
    pub fn is_enabled(&self) -> bool {
        self.status_word() & status_bit::ENABLED != 0
    }

    /// Override of the last valid robot telegram in percent.
    pub fn override_percent(&self) -> f64 {
        self.robot
            .map_or(0.0, |h| f64::from(h.override_centi) / 100.0)
    }

    /// The ReadRobotData answer of the start-up.
    pub fn robot_data(&self) -> Option<&RobotData> {
        self.robot_data.as_ref()
    }

    /// The ExchangeConfiguration answer of the start-up.
    pub fn configuration(&self) -> Option<&Configuration> {
        self.configuration.as_ref()
    }

    fn submit_internal(&mut self, request: &Request) -> Result<CommandHandle, SubmitError> {
        check_payload_len(request)?;
        request.encode(1, &mut self.scratch);
        let handle = CommandHandle(self.next_handle);
        let cmd_id = self
            .acr
            .add(handle, &self.scratch)
            .ok_or(SubmitError::AcrFull(self.acr.size()))?;
        self.next_handle += 1;
        self.records.insert(
            handle,
            CommandStatus::new(request.command_type(), cmd_id, self.now),
        );
        tracing::debug!(cmd_id, command = request.name(), "command submitted");
        Ok(handle)
    }

    fn stop(&mut self, fault: EngineFault) {
        tracing::warn!(%fault, phase = ?self.phase, "RobotTask stopped");
        self.fault = Some(fault);
        self.faulted_in = Some(self.phase);
        self.phase = Phase::Faulted;
        self.control = Control::None;
    }

    fn in_session(&self) -> bool {
        !matches!(self.phase, Phase::Connecting | Phase::Faulted)
    }

    /// The frame check of the open client (its fix F66): a robot telegram whose header and
    /// footer lifesign differ was torn and is dropped; so is one of the wrong length.
    fn accept_frame(&mut self, rx: &[u8]) -> bool {
        if rx.is_empty() {
            return false;
        }
        // The configured length is at least 64, so byte 3 (TelegramState) exists.
        let invalid = rx.len() != self.opts.length_rob_to_plc
            || ((rx[3] == telegram_state::INITIALIZED
                || self.telegram_state() == telegram_state::INITIALIZED)
                && !RobotHeader::is_consistent(rx));
        if invalid {
            self.invalid_frames += 1;
            if self.invalid_frames.is_power_of_two() {
                tracing::warn!(
                    count = self.invalid_frames,
                    length = rx.len(),
                    "invalid robot telegram dropped"
                );
            }
            return false;
        }
        true
    }

    fn note_robot_lifesign(&mut self, byte: u8) {
        if byte != self.robot_lifesign_byte {
            self.robot_lifesign_byte = byte;
            self.robot_lifesign_changed_at = self.now;
        }
    }

    fn lifesign_timeout(&self) -> Duration {
        Duration::from_millis(u64::from(
            self.opts.lifesign_timeout_ms.max(LIFESIGN_TIMEOUT_MIN_MS),
        ))
    }

    /// Robot lifesign frozen longer than LifeSignTimeOut + one cycle, or no new SEQ for
    /// 4 × LifeSignTimeOut + one cycle (the open client's fixes F65).
    fn supervise(&mut self) {
        if !self.in_session() {
            return;
        }
        let lifesign_limit = self.lifesign_timeout() + self.opts.cycle_time;
        if self.robot_lifesign_byte != 0
            && self.now.saturating_sub(self.robot_lifesign_changed_at) > lifesign_limit
        {
            self.stop(EngineFault::RobotLifeSignTimeout {
                timeout_ms: lifesign_limit.as_millis() as u64,
            });
            return;
        }
        let sequence_limit = 4 * self.lifesign_timeout() + self.opts.cycle_time;
        if self.phase == Phase::Initialized
            && self.now.saturating_sub(self.last_new_seq_at) > sequence_limit
        {
            self.stop(EngineFault::SequenceTimeout {
                timeout_ms: sequence_limit.as_millis() as u64,
            });
        }
    }

    /// Control from the TelegramState seen in the previous cycle.
    fn follow_telegram_state(&mut self) {
        use telegram_state as t;
        let s = self.telegram_state();
        match self.phase {
            Phase::Faulted => {}
            Phase::Connecting => match s {
                t::UNDEFINED => {}
                // The open client always resets, so that the robot also clears its register.
                s if t::is_error(s) => self.control = Control::Reset,
                // Resuming makes sense only for a client that still holds the commands of
                // the robot's register; a fresh client resets it instead of inheriting them.
                t::READY_TO_RESUME if self.acr.in_use() > 0 => self.control = Control::Resume,
                t::READY_TO_RESUME => self.control = Control::Reset,
                t::READY_FOR_INITIALIZATION => self.control = Control::Initialize,
                t::INITIALIZED if self.control == Control::Resume => {
                    self.control = Control::None;
                    self.resumes += 1;
                    self.robot_lifesign_changed_at = self.now;
                    self.last_new_seq_at = self.now;
                    self.phase = self.resume_into.take().unwrap_or(Phase::Initialized);
                }
                t::INITIALIZED => {
                    self.control = Control::None;
                    self.resume_into = None;
                    let robot = self.robot.map_or(0, |h| h.version.major);
                    let client = SrciVersion::from_byte(self.opts.version).major;
                    if robot == client {
                        self.enter_session();
                    } else {
                        self.stop(EngineFault::MajorVersion { robot, client });
                    }
                }
                other => self.stop(EngineFault::UnexpectedTelegramState(other)),
            },
            _ if s != t::INITIALIZED => self.stop(EngineFault::InterfaceLost { telegram_state: s }),
            _ => {}
        }
    }

    fn enter_session(&mut self) {
        self.robot_lifesign_changed_at = self.now;
        self.phase = Phase::StartingMessages;
        let request = Request::ReadMessages {
            msg_id: 0,
            message_level: self.opts.message_level,
        };
        match self.submit_internal(&request) {
            Ok(h) => self.read_messages = Some(h),
            Err(e) => tracing::error!(%e, "ReadMessages could not be submitted"),
        }
    }

    /// A new SEQ once the robot acknowledged the current one; 254 wraps to 1, 0 is only the
    /// value before the first telegram.
    fn advance_sequence(&mut self) {
        if self.robot_ack == self.current_seq {
            self.current_seq = if self.current_seq >= 254 {
                1
            } else {
                self.current_seq + 1
            };
            self.new_seq = true;
            self.last_new_seq_at = self.now;
        }
    }

    /// ReadMessages ACTIVE → ExchangeConfiguration ACTIVE → ReadRobotData DONE.
    fn run_startup(&mut self) {
        let waiting_on = match self.phase {
            Phase::StartingMessages => self.read_messages,
            Phase::StartingConfiguration => self.exchange_configuration,
            Phase::ReadingRobotData => self.read_robot_data,
            _ => return,
        };
        let Some(rec) = waiting_on.and_then(|h| self.records.get(&h)) else {
            return;
        };
        let reached = if self.phase == Phase::ReadingRobotData {
            rec.state == state::DONE
        } else {
            rec.state == state::ACTIVE
        };
        if !reached {
            if rec.is_final() {
                let fault = EngineFault::StartupCommandFailed {
                    command_type: rec.command_type,
                    state: rec.state,
                    code: rec.code,
                };
                self.stop(fault);
            }
            return;
        }
        match self.phase {
            Phase::StartingMessages => {
                self.phase = Phase::StartingConfiguration;
                let request = Request::ExchangeConfiguration {
                    log_level: self.opts.log_level,
                    lifesign_timeout_ms: self.opts.lifesign_timeout_ms,
                };
                self.exchange_configuration = self.submit_startup(&request);
            }
            Phase::StartingConfiguration => {
                let configuration = Configuration::decode(&rec.response);
                self.acr.set_size(configuration.length_acr);
                self.configuration = Some(configuration);
                self.phase = Phase::ReadingRobotData;
                self.read_robot_data = self.submit_startup(&Request::ReadRobotData);
            }
            Phase::ReadingRobotData => {
                let data = RobotData::decode(&rec.response);
                tracing::info!(
                    manufacturer = %data.manufacturer,
                    acr = self.acr.size(),
                    "SRCI interface initialized"
                );
                self.robot_data = Some(data);
                self.phase = Phase::Initialized;
                self.initialized_at = Some(self.now);
                self.last_new_seq_at = self.now;
            }
            _ => {}
        }
    }

    fn submit_startup(&mut self, request: &Request) -> Option<CommandHandle> {
        match self.submit_internal(request) {
            Ok(h) => Some(h),
            Err(e) => {
                tracing::error!(%e, command = request.name(), "start-up command not submitted");
                None
            }
        }
    }

    /// A received MsgID goes back to the robot as a ReadMessages parameter update.
    fn acknowledge_messages(&mut self) {
        if !self.in_session() || self.msg_to_ack == self.acked_msg_id {
            return;
        }
        let Some(handle) = self.read_messages else {
            return;
        };
        let request = Request::ReadMessages {
            msg_id: self.msg_to_ack,
            message_level: self.opts.message_level,
        };
        match self.update(handle, &request) {
            Ok(()) => self.acked_msg_id = self.msg_to_ack,
            Err(e) => {
                tracing::warn!(%e, msg_id = self.msg_to_ack, "message not acknowledged");
                self.acked_msg_id = self.msg_to_ack;
            }
        }
    }

    fn write_telegram(&mut self, tx: &mut [u8]) -> Result<(), CycleError> {
        if !self.lifesign_frozen {
            self.lifesign = next_lifesign(self.lifesign);
        }
        // Telegram lengths are at most 256 (checked in `new`).
        let (length_plc_to_rob, length_rob_to_plc) = self.opts.header_lengths.unwrap_or((
            self.opts.length_plc_to_rob as u16,
            self.opts.length_rob_to_plc as u16,
        ));
        let unix_ms = self
            .wall_origin_ms
            .saturating_add(self.now.as_millis() as u64);
        let (client_date, client_time) = iec_date_time(unix_ms);
        PlcHeader {
            version: SrciVersion::from_byte(self.opts.version),
            fast_stop: 0,
            lifesign: self.lifesign,
            length_plc_to_rob,
            length_rob_to_plc,
            axes_group: self.opts.axes_group,
            control: self.control,
            telegram_number_plc_to_rob: 0,
            telegram_number_rob_to_plc: self.opts.cyclic_position.telegram_number(),
            client_date,
            client_time,
        }
        .encode(tx)?;
        let cyclic = self.opts.cyclic_position;
        if cyclic.cartesian {
            // The position in the tool and frame in use (-1).
            tx[PLC_HEADER_LEN] = 0xFF;
            tx[PLC_HEADER_LEN + 1] = 0xFF;
        }
        let ([(start, len), _], _) =
            sequence_areas(tx.len(), PLC_HEADER_LEN, cyclic.plc_len(), false);
        if self.new_seq {
            let mut w = SequenceWriter::new(&mut self.seq_area[..len], self.current_seq);
            self.acr.fill(&mut w);
            self.new_seq = false;
        }
        tx[start..start + len].copy_from_slice(&self.seq_area[..len]);
        Ok(())
    }

    /// Reads the robot telegram; its response fragments count only if its SEQ_ACK is new and
    /// acknowledges the SEQ being sent.
    fn parse(&mut self, rx: &[u8]) {
        let Ok(header) = RobotHeader::decode(rx) else {
            return;
        };
        if header.telegram_state != self.telegram_state() {
            tracing::info!(
                telegram_state = header.telegram_state,
                name = telegram_state_name(header.telegram_state),
                "robot TelegramState changed"
            );
        }
        self.robot = Some(header);
        let cyclic = self.opts.cyclic_position;
        if header.telegram_state == telegram_state::INITIALIZED && cyclic.robot_len() > 0 {
            self.cyclic = Some(CyclicPosition::decode(rx, cyclic));
        }
        let ([(start, len), _], _) =
            sequence_areas(rx.len(), ROBOT_HEADER_LEN, cyclic.robot_len(), false);
        let seq = match Sequence::decode(&rx[start..start + len]) {
            Ok(seq) => seq,
            Err(e) => {
                tracing::warn!(%e, "robot sequence dropped");
                return;
            }
        };
        let fresh = seq.seq_ack != self.robot_ack && seq.seq_ack == self.current_seq;
        self.robot_ack = seq.seq_ack;
        if !fresh {
            return;
        }
        for (i, fragment) in seq.fragments().enumerate() {
            if i == FRAGMENTS_MAX {
                tracing::warn!("more than {FRAGMENTS_MAX} response fragments; rest dropped");
                break;
            }
            let (h, data) = match fragment {
                Ok(f) => f,
                Err(e) => {
                    tracing::warn!(%e, "malformed response fragment");
                    break;
                }
            };
            match self.acr.add_response(h, data) {
                Ok(Some(done)) => self.on_response(done),
                Ok(None) => {}
                Err(e @ ResponseError::UnknownCmdId(_)) => tracing::warn!(%e, "response ignored"),
                Err(e) => {
                    tracing::warn!(%e, "invalid fragment payload pointer");
                    break;
                }
            }
        }
    }

    fn on_response(&mut self, done: CompletedResponse) {
        let payload = self.acr.response(done.cmd_id);
        let header = ResponseHeader::decode(payload);
        let Some(rec) = self.records.get_mut(&done.handle) else {
            return;
        };
        if rec.state != header.state {
            tracing::debug!(
                cmd_id = done.cmd_id,
                command = command_name(rec.command_type),
                state = state::name(header.state),
                code = header.code,
                "command state"
            );
        }
        rec.apply(header, payload, self.now);
        let internal_ended = rec.is_final()
            && self.phase == Phase::Initialized
            && (Some(done.handle) == self.read_messages
                || Some(done.handle) == self.exchange_configuration);
        if internal_ended {
            tracing::warn!(
                command = command_name(rec.command_type),
                code = rec.code,
                "enable-type start-up command ended"
            );
        }
        if Some(done.handle) == self.read_messages
            && rec.command_type == tables::read_messages::TYPE
        {
            let messages = Messages::decode(payload);
            self.on_messages(messages);
        }
    }

    fn on_messages(&mut self, m: Messages) {
        let Some(msg) = m.message else {
            return;
        };
        if msg.msg_id != self.last_msg_id {
            self.last_msg_id = msg.msg_id;
            tracing::info!(
                msg_id = msg.msg_id,
                severity = msg.severity,
                code = msg.code,
                text = %msg.text,
                "robot message"
            );
            if self.messages.len() == MESSAGES_KEPT {
                self.messages.pop_front();
            }
            self.msg_to_ack = msg.msg_id;
            self.messages.push_back(msg);
        }
    }
}

fn check_payload_len(request: &Request) -> Result<(), SubmitError> {
    let len = request.payload_len();
    if len > usize::from(u16::MAX) {
        return Err(SubmitError::PayloadTooLong(len));
    }
    Ok(())
}

#[cfg(test)]
mod tests;
