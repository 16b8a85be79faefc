//! State-machine and command tests of the server core, driven by byte telegrams.

use shared_types::ipc::{
    DriveState, JOB_EVENTS, JobEvent, MotionCommand, MotionCommandKind, MotionSequence,
    MotionStatus, ServoFeedback, TargetReference,
};
use shared_types::srci::message::{CommandHeader, ResponseHeader, code, state};
use shared_types::srci::payload::{PayloadReader, PayloadWriter};
use shared_types::srci::supported;
use shared_types::srci::tables as t;
use shared_types::srci::telegram::{
    Control, FragmentAction, PLC_HEADER_LEN, PlcHeader, ROBOT_HEADER_LEN, RobotHeader, Sequence,
    SequenceWriter, SrciVersion, sequence_areas, status_bit, telegram_state as ts,
};

use super::*;

use shared_types::alloc_count as alloc_counter;

#[global_allocator]
static ALLOCATOR: alloc_counter::CountingAllocator = alloc_counter::CountingAllocator;

/// The factory user data of the embedded robot.
fn user_data() -> crate::user_data::UserData {
    let cfg = shared_types::config::Config::load(None).unwrap();
    crate::user_data::UserData::factory(crate::user_data::RobotBounds::of(&cfg.robot).0)
}

fn settings(len: usize) -> Settings {
    let cfg = shared_types::config::Config::load(None).unwrap();
    Settings {
        length_plc_to_rob: len,
        length_rob_to_plc: len,
        acr_length: 8,
        ..Settings::from_config(&cfg)
    }
}

/// A scripted PLC: builds telegrams, collects responses (complete ones, in order) and the
/// motion commands the server emits.
struct Plc {
    len: usize,
    lifesign: u8,
    freeze_lifesign: bool,
    control: Control,
    seq: u16,
    length_in_header: u16,
    version: SrciVersion,
    axes_group: u8,
    number_p2r: u16,
    number_r2p: u16,
    now: u64,
    partial: Vec<(u16, Vec<u8>)>,
    responses: Vec<(u16, Vec<u8>)>,
    motion: Vec<MotionCommand>,
    supervision: Vec<shared_types::health::SupervisionRequest>,
    last_rx: Vec<u8>,
    last_ack: u16,
    /// Optional cyclic bytes after each header (PLC→robot, robot→PLC).
    cyclic: (usize, usize),
    /// Allocations the server made inside `on_telegram` and `poll`.
    server_allocations: u64,
}

impl Plc {
    fn new(len: usize) -> Self {
        Self {
            len,
            lifesign: 0,
            freeze_lifesign: false,
            control: Control::None,
            seq: 0,
            length_in_header: len as u16,
            version: SrciVersion::CURRENT,
            axes_group: 0,
            number_p2r: 0,
            number_r2p: 0,
            now: 1000,
            partial: Vec::new(),
            responses: Vec::new(),
            motion: Vec::new(),
            supervision: Vec::new(),
            last_rx: Vec::new(),
            last_ack: 0,
            cyclic: (0, 0),
            server_allocations: 0,
        }
    }

    fn now(&self) -> Now {
        Now {
            mono_ms: self.now,
            unix_ms: 1_700_000_000_000,
        }
    }

    /// One exchange; `fragments` = (CmdID, action, pointer, bytes).
    fn exchange(&mut self, server: &mut Server, fragments: &[(u16, u8, u16, &[u8])]) -> u8 {
        if !self.freeze_lifesign {
            self.lifesign = next_lifesign(self.lifesign);
        }
        self.now += 8;
        let mut tx = vec![0u8; self.len];
        PlcHeader {
            version: self.version,
            fast_stop: 0,
            lifesign: self.lifesign,
            length_plc_to_rob: self.length_in_header,
            length_rob_to_plc: self.len as u16,
            axes_group: self.axes_group,
            control: self.control,
            telegram_number_plc_to_rob: self.number_p2r,
            telegram_number_rob_to_plc: self.number_r2p,
            client_date: 0,
            client_time: 0,
        }
        .encode(&mut tx)
        .unwrap();
        let (areas, _) = sequence_areas(self.len, PLC_HEADER_LEN, self.cyclic.0, false);
        let (s, l) = areas[0];
        let mut w = SequenceWriter::new(&mut tx[s..s + l], self.seq);
        for &(id, action, ptr, data) in fragments {
            assert!(w.push(id, action, ptr, data));
        }
        let mut rx = vec![0u8; 256];
        let mut fx = Effects::new();
        let now = self.now();
        let (n, allocations) = alloc_counter::count(|| {
            let n = server.on_telegram(now, &tx, &mut rx, &mut fx);
            server.poll(now, &mut fx);
            n
        });
        self.server_allocations += allocations;
        self.motion.extend(fx.motion.iter().copied());
        self.supervision.extend(fx.supervision);
        rx.truncate(n);
        self.collect(&rx);
        self.last_rx = rx;
        RobotHeader::decode(&self.last_rx).unwrap().telegram_state
    }

    fn collect(&mut self, rx: &[u8]) {
        let (areas, _) = sequence_areas(rx.len(), ROBOT_HEADER_LEN, self.cyclic.1, false);
        let (s, l) = areas[0];
        let seq = Sequence::decode(&rx[s..s + l]).unwrap();
        // Like the client: a response is taken only with a new ACK of the SEQ being sent.
        let fresh = seq.seq_ack != self.last_ack && seq.seq_ack == self.seq;
        self.last_ack = seq.seq_ack;
        if !fresh {
            return;
        }
        for f in seq.fragments() {
            let (h, d) = f.unwrap();
            let i = match self.partial.iter().position(|(id, _)| *id == h.cmd_id) {
                Some(i) => i,
                None => {
                    self.partial.push((h.cmd_id, Vec::new()));
                    self.partial.len() - 1
                }
            };
            let buf = &mut self.partial[i].1;
            let p = usize::from(h.pointer);
            if buf.len() < p + d.len() {
                buf.resize(p + d.len(), 0);
            }
            buf[p..p + d.len()].copy_from_slice(d);
            if h.action.complete() {
                let done = self.partial.remove(i);
                self.responses.push(done);
            }
        }
    }

    /// INITIALIZE until 255.
    fn initialize(&mut self, server: &mut Server) {
        self.control = Control::Initialize;
        self.exchange(server, &[]);
        self.control = Control::None;
        assert_eq!(self.exchange(server, &[]), ts::INITIALIZED);
    }

    /// Sends a single-fragment command in a new SEQ and repeats it once, like the client.
    fn command(&mut self, server: &mut Server, cmd_id: u16, action: u8, payload: &[u8]) {
        self.seq = if self.seq >= 254 { 1 } else { self.seq + 1 };
        self.exchange(server, &[(cmd_id, action, 0, payload)]);
        self.exchange(server, &[(cmd_id, action, 0, payload)]);
    }

    /// An empty new SEQ (lets queued responses out).
    fn idle(&mut self, server: &mut Server) {
        self.seq = if self.seq >= 254 { 1 } else { self.seq + 1 };
        self.exchange(server, &[]);
    }

    fn last_response(&self, cmd_id: u16) -> Option<ResponseHeader> {
        self.responses
            .iter()
            .rev()
            .find(|(id, _)| *id == cmd_id)
            .map(|(_, b)| ResponseHeader::decode(b))
    }
}

fn request(command_type: u16, mode: u8, len: usize) -> Vec<u8> {
    let mut b = vec![0u8; len.max(4)];
    CommandHeader {
        command_type,
        execution_mode: mode,
        par_seq: 1,
        priority: 3,
    }
    .encode(&mut b);
    b
}

const NEW: u8 = FragmentAction::RESET | FragmentAction::COMPLETE;

/// Leaves the four rates of a request at "default" (0xFFFF).
fn default_rates(w: &mut PayloadWriter, rates: [shared_types::srci::payload::Field; 4]) {
    for f in rates {
        w.set_u16(f, 0xFFFF);
    }
}

/// A move request on the primary sequence with its `rates` at default; `edit` sets the rest.
fn move_message(
    command_type: u16,
    len: usize,
    rates: [shared_types::srci::payload::Field; 4],
    edit: impl FnOnce(&mut PayloadWriter),
) -> Vec<u8> {
    let mut msg = request(command_type, 0, len);
    let mut w = PayloadWriter::new(&mut msg);
    default_rates(&mut w, rates);
    edit(&mut w);
    msg
}

fn feedback(state: DriveState) -> ServoFeedback {
    ServoFeedback::at_rest(1, [0.0, 1.57, 1.57, 1.57, -1.57, 0.0], state, 1_000_000)
}

fn status(instance: u64, events: &[(u64, u32, u8, u16)]) -> MotionStatus {
    let mut s = MotionStatus::initial(instance, 1.0);
    s.flange_pose = [0.5, 0.1, 0.2, 0.0, 0.0, 0.0];
    for &(n, job, st, c) in events {
        s.events[(n % JOB_EVENTS as u64) as usize] = JobEvent {
            number: n,
            job,
            state: st,
            reason: 0,
            code: c,
        };
        s.event_head = n;
    }
    s
}

/// An initialized session with a live planner (instance 5) and drives in `drives`.
fn session(drives: DriveState) -> (Server, Plc, Effects) {
    let mut server = Server::new(settings(256), 9, user_data());
    let mut plc = Plc::new(256);
    plc.initialize(&mut server);
    let mut fx = Effects::new();
    server.on_motion_status(plc.now(), &status(5, &[]), &mut fx);
    server.on_servo_feedback(plc.now(), &feedback(drives), &mut fx);
    (server, plc, fx)
}

#[test]
fn initializes_from_254_to_255_and_acknowledges_sequences() {
    let mut server = Server::new(settings(256), 9, user_data());
    let mut plc = Plc::new(256);
    assert_eq!(plc.exchange(&mut server, &[]), ts::READY_FOR_INITIALIZATION);
    plc.initialize(&mut server);
    plc.idle(&mut server);
    let (areas, _) = sequence_areas(256, ROBOT_HEADER_LEN, 0, false);
    let seq = Sequence::decode(&plc.last_rx[areas[0].0..]).unwrap();
    assert_eq!(seq.seq_ack, plc.seq);
    let rh = RobotHeader::decode(&plc.last_rx).unwrap();
    assert!(RobotHeader::is_consistent(&plc.last_rx));
    assert_eq!(rh.override_centi, 10_000);
    assert_eq!(
        rh.status & (7 << status_bit::OPERATION_MODE_SHIFT),
        4 << status_bit::OPERATION_MODE_SHIFT
    );
}

#[test]
fn header_faults_give_their_telegram_states_and_reset_recovers() {
    type Fault = fn(&mut Plc);
    let cases: [(Fault, u8); 4] = [
        (|p| p.length_in_header = 128, ts::LENGTH_MISMATCH),
        (
            |p| p.version = SrciVersion { major: 2, minor: 0 },
            ts::MAJOR_VERSION,
        ),
        (|p| p.axes_group = 5, ts::INVALID_AXES_GROUP),
        (|p| p.number_p2r = 1 << 8, ts::TELEGRAM_NUMBER_INVALID),
    ];
    for (fault, expected) in cases {
        let mut server = Server::new(settings(256), 9, user_data());
        let mut plc = Plc::new(256);
        fault(&mut plc);
        plc.control = Control::Initialize;
        assert_eq!(plc.exchange(&mut server, &[]), expected);
        plc.control = Control::Reset;
        assert_eq!(plc.exchange(&mut server, &[]), ts::READY_FOR_INITIALIZATION);
    }
}

#[test]
fn frozen_lifesign_gives_165_holds_motion_and_reset_halts_it() {
    let mut server = Server::new(settings(256), 9, user_data());
    let mut plc = Plc::new(256);
    plc.initialize(&mut server);
    plc.freeze_lifesign = true;
    let mut state = ts::INITIALIZED;
    for _ in 0..10 {
        state = plc.exchange(&mut server, &[]);
    }
    assert_eq!(state, ts::LIFESIGN_TIMEOUT);
    let kinds = |plc: &Plc| plc.motion.iter().map(|c| c.kind).collect::<Vec<_>>();
    assert_eq!(kinds(&plc), [MotionCommandKind::Interrupt as u8]);
    // The client answers 165 with RESET: the held session ends.
    plc.control = Control::Reset;
    assert_eq!(plc.exchange(&mut server, &[]), ts::READY_FOR_INITIALIZATION);
    assert_eq!(
        kinds(&plc),
        [
            MotionCommandKind::Interrupt as u8,
            MotionCommandKind::Halt as u8
        ]
    );
    // A changed header after initialization is refused as well.
    let mut server = Server::new(settings(256), 9, user_data());
    let mut plc = Plc::new(256);
    plc.initialize(&mut server);
    plc.number_r2p = 2;
    assert_eq!(plc.exchange(&mut server, &[]), ts::TELEGRAM_NUMBER_CHANGED);
}

#[test]
fn torn_frames_are_not_interpreted() {
    let mut server = Server::new(settings(64), 9, user_data());
    let mut plc = Plc::new(64);
    plc.initialize(&mut server);
    let mut tx = vec![0u8; 64];
    tx[1] = 5;
    tx[63] = 6;
    let mut rx = [0u8; 256];
    let mut fx = Effects::new();
    server.on_telegram(plc.now(), &tx, &mut rx, &mut fx);
    assert_eq!(server.invalid_frames(), 1);
    assert_eq!(server.telegram_state(), ts::INITIALIZED);
}

#[test]
fn unsupported_command_is_answered_8f11_once_per_sequence() {
    let mut server = Server::new(settings(256), 9, user_data());
    let mut plc = Plc::new(256);
    plc.initialize(&mut server);
    let msg = request(
        t::move_depart_linear::TYPE,
        0,
        t::move_depart_linear::request::LEN,
    );
    plc.command(&mut server, 1, NEW, &msg);
    let responses: Vec<_> = plc.responses.iter().filter(|(id, _)| *id == 1).collect();
    assert_eq!(responses.len(), 1, "a repeated SEQ is processed once");
    let h = plc.last_response(1).unwrap();
    assert_eq!(
        (h.state, h.code, h.severity),
        (state::ERROR, code::NOT_IMPLEMENTED, 28)
    );
}

#[test]
fn read_robot_data_is_fragmented_in_small_telegrams_and_tells_the_truth() {
    let mut server = Server::new(settings(64), 9, user_data());
    let mut plc = Plc::new(64);
    plc.initialize(&mut server);
    plc.command(
        &mut server,
        2,
        NEW,
        &request(t::read_robot_data::TYPE, 2, 4),
    );
    for _ in 0..4 {
        plc.idle(&mut server);
    }
    let (_, body) = plc.responses.iter().find(|(id, _)| *id == 2).unwrap();
    assert_eq!(body.len(), t::read_robot_data::response::LEN);
    let r = PayloadReader::new(body);
    assert_eq!(r.u8(t::read_robot_data::response::STATE), state::DONE);
    let map: [u8; 19] = core::array::from_fn(|i| {
        r.u8(t::read_robot_data::response::RC_SUPPORTED_FUNCTIONS.element(i))
    });
    // Every implemented function that has a bit (the server logs have none) is announced.
    for ty in crate::commands::IMPLEMENTED
        .into_iter()
        .filter(|&ty| supported::BITS.iter().any(|b| b.0 == ty))
    {
        assert!(supported::announces(&map, ty), "type {ty} announced");
    }
    assert!(!supported::announces(&map, t::move_depart_linear::TYPE));
    let (byte, bit) = supported::CYCLIC_POSITION;
    assert_ne!(
        map[usize::from(byte)] & (1 << bit),
        0,
        "ReadActualPositionCyclic"
    );
}

#[test]
fn move_needs_enabled_drives_and_reports_planner_events() {
    let (mut server, mut plc, mut fx) = session(DriveState::Powered);
    let mut msg = request(
        t::move_axes_absolute::TYPE,
        0,
        t::move_axes_absolute::request::LEN,
    );
    {
        let mut w = PayloadWriter::new(&mut msg);
        default_rates(
            &mut w,
            [
                t::move_axes_absolute::request::VELOCITY_RATE,
                t::move_axes_absolute::request::ACCELERATION_RATE,
                t::move_axes_absolute::request::DECELERATION_RATE,
                t::move_axes_absolute::request::JERK_RATE,
            ],
        );
        w.set_f32(t::move_axes_absolute::request::JOINT_POSITION_J1, 10.0);
    }
    plc.command(&mut server, 3, NEW, &msg);
    let h = plc.last_response(3).unwrap();
    assert_eq!((h.state, h.code), (state::ERROR, code::ROBOT_DISABLED));
    assert!(
        plc.motion
            .iter()
            .all(|c| c.kind != MotionCommandKind::MoveAxes as u8)
    );

    server.on_servo_feedback(plc.now(), &feedback(DriveState::Holding), &mut fx);
    plc.command(&mut server, 3, NEW, &msg);
    let mv = *plc
        .motion
        .iter()
        .find(|c| c.kind == MotionCommandKind::MoveAxes as u8)
        .unwrap();
    assert!((mv.joints_rad[0] - 10f64.to_radians()).abs() < 1e-6);
    server.on_motion_status(
        plc.now(),
        &status(
            5,
            &[
                (1, mv.job, state::BUFFERED, 0),
                (2, mv.job, state::ACTIVE, 0),
                (3, mv.job, state::DONE, 0),
            ],
        ),
        &mut fx,
    );
    plc.idle(&mut server);
    let states: Vec<u8> = plc
        .responses
        .iter()
        .filter(|(id, _)| *id == 3)
        .map(|(_, b)| ResponseHeader::decode(b).state)
        .collect();
    assert_eq!(
        states,
        [state::ERROR, state::BUFFERED, state::ACTIVE, state::DONE]
    );
    let (_, done) = plc.responses.last().unwrap();
    assert_eq!(
        PayloadReader::new(done).u16(t::move_axes_absolute::response::PROGRESS),
        10_000
    );
}

#[test]
fn planner_restart_ends_moves_with_an_error_until_group_reset() {
    let (mut server, mut plc, mut fx) = session(DriveState::Holding);
    let mut msg = request(
        t::move_axes_absolute::TYPE,
        0,
        t::move_axes_absolute::request::LEN,
    );
    PayloadWriter::new(&mut msg).set_u16(t::move_axes_absolute::request::DECELERATION_RATE, 0xFFFF);
    plc.command(&mut server, 4, NEW, &msg);
    fx.clear();
    server.on_motion_status(plc.now(), &status(6, &[]), &mut fx);
    assert!(
        fx.motion
            .iter()
            .any(|c| c.kind == MotionCommandKind::Override as u8 && c.override_fraction == 1.0),
        "the restarted planner gets the current override"
    );
    plc.idle(&mut server);
    let h = plc.last_response(4).unwrap();
    assert_eq!((h.state, h.code), (state::ERROR, code::MOTION_ERROR));
    let rh = RobotHeader::decode(&plc.last_rx).unwrap();
    assert_ne!(rh.status & status_bit::ERROR_PENDING, 0);

    plc.command(&mut server, 4, NEW, &msg);
    assert_eq!(
        plc.last_response(4).unwrap().code,
        code::DISABLED_DUE_TO_ERROR
    );

    plc.command(&mut server, 5, NEW, &request(t::group_reset::TYPE, 2, 4));
    let reset = *plc
        .motion
        .iter()
        .rev()
        .find(|c| c.kind == MotionCommandKind::Reset as u8)
        .unwrap();
    server.on_motion_status(
        plc.now(),
        &status(6, &[(1, reset.job, state::DONE, 0)]),
        &mut fx,
    );
    plc.idle(&mut server);
    assert_eq!(plc.last_response(5).unwrap().state, state::DONE);
    let rh = RobotHeader::decode(&plc.last_rx).unwrap();
    assert_eq!(rh.status & status_bit::ERROR_PENDING, 0);
}

#[test]
fn read_messages_delivers_and_takes_acknowledgements() {
    let mut server = Server::new(settings(256), 9, user_data());
    let mut plc = Plc::new(256);
    plc.initialize(&mut server);
    let mut rm = request(t::read_messages::TYPE, 2, t::read_messages::request::LEN);
    PayloadWriter::new(&mut rm).set_u8(t::read_messages::request::MESSAGE_LEVEL, 20);
    plc.command(&mut server, 1, NEW, &rm);
    assert_eq!(plc.last_response(1).unwrap().state, state::ACTIVE);
    // An unsupported command raises an error message.
    plc.command(
        &mut server,
        2,
        NEW,
        &request(
            t::move_depart_linear::TYPE,
            0,
            t::move_depart_linear::request::LEN,
        ),
    );
    plc.idle(&mut server);
    let (_, body) = plc.responses.iter().rev().find(|(id, _)| *id == 1).unwrap();
    let r = PayloadReader::new(body);
    let id = r.u8(t::read_messages::response::MSG_ID);
    assert_ne!(id, 0);
    assert_eq!(
        r.u32(t::read_messages::response::ERROR_CODE),
        u32::from(code::NOT_IMPLEMENTED)
    );
    assert_eq!(r.u8(t::read_messages::response::NUMBER_OF_ACTIVE_ERRORS), 1);
    // Acknowledge by a parameter update (Clear, ParSeq + 1).
    let mut ack = rm.clone();
    CommandHeader {
        command_type: t::read_messages::TYPE,
        execution_mode: 2,
        par_seq: 2,
        priority: 3,
    }
    .encode(&mut ack);
    PayloadWriter::new(&mut ack).set_u8(t::read_messages::request::MSG_ID, id);
    plc.command(
        &mut server,
        1,
        FragmentAction::CLEAR | FragmentAction::COMPLETE,
        &ack,
    );
    let (_, body) = plc.responses.iter().rev().find(|(id, _)| *id == 1).unwrap();
    let h = ResponseHeader::decode(body);
    assert_eq!((h.par_seq, h.state), (2, state::ACTIVE));
    assert_eq!(
        PayloadReader::new(body).u8(t::read_messages::response::MSG_ID),
        0
    );
}

/// Rounds of a steady session: a move run to DONE, a position read and a refused command
/// each; returns the allocations the server made (ReadMessages must be live as `1`).
fn steady_rounds(server: &mut Server, plc: &mut Plc, fx: &mut Effects, events: &mut u64) -> u64 {
    let mut mv = request(
        t::move_axes_absolute::TYPE,
        0,
        t::move_axes_absolute::request::LEN,
    );
    PayloadWriter::new(&mut mv).set_u16(t::move_axes_absolute::request::DECELERATION_RATE, 0xFFFF);
    plc.server_allocations = 0;
    for round in 0..50u16 {
        plc.command(server, 2, NEW, &mv);
        plc.command(
            server,
            3,
            NEW,
            &request(t::read_actual_position::TYPE, 2, 12),
        );
        plc.command(
            server,
            4,
            NEW,
            &request(
                t::move_depart_linear::TYPE,
                0,
                t::move_depart_linear::request::LEN,
            ),
        );
        // The newest move (unacknowledged older commands are re-sent after it).
        let job = plc
            .motion
            .iter()
            .filter(|c| c.kind == MotionCommandKind::MoveAxes as u8)
            .map(|c| c.job)
            .max()
            .unwrap_or(0);
        *events += 1;
        let s = status(5, &[(*events, job, state::DONE, 0)]);
        let ((), a) = alloc_counter::count(|| {
            server.on_motion_status(plc.now(), &s, fx);
            server.on_servo_feedback(plc.now(), &feedback(DriveState::Holding), fx);
        });
        plc.server_allocations += a;
        fx.clear();
        plc.idle(server);
        assert_eq!(
            plc.last_response(2).map(|h| h.state),
            Some(state::DONE),
            "round {round}"
        );
    }
    plc.server_allocations
}

#[test]
fn steady_state_telegrams_do_not_allocate() {
    let (mut server, mut plc, mut fx) = session(DriveState::Holding);
    let mut rm = request(t::read_messages::TYPE, 2, t::read_messages::request::LEN);
    PayloadWriter::new(&mut rm).set_u8(t::read_messages::request::MESSAGE_LEVEL, 20);
    plc.command(&mut server, 1, NEW, &rm);
    let mut events = 0;
    let allocations = steady_rounds(&mut server, &mut plc, &mut fx, &mut events);
    assert_eq!(allocations, 0, "allocations in the steady state");
    let (_, probe) = alloc_counter::count(|| std::hint::black_box(vec![1u8; 8]));
    assert_eq!(probe, 1, "the counter sees allocations");
}

#[test]
fn a_successor_process_continues_the_session_from_the_snapshot() {
    let (mut server, mut plc, mut fx) = session(DriveState::Holding);
    let mut rm = request(t::read_messages::TYPE, 2, t::read_messages::request::LEN);
    PayloadWriter::new(&mut rm).set_u8(t::read_messages::request::MESSAGE_LEVEL, 20);
    plc.command(&mut server, 1, NEW, &rm);
    let job = running_move(&mut server, &mut plc, &mut fx, 5);
    let issuer = plc.motion.last().unwrap().issuer;

    // Through the file format, into a new process's server.
    let bytes = serde_json::to_vec(&server.snapshot("inst", plc.now(), 41)).unwrap();
    let snapshot: crate::handover::Snapshot = serde_json::from_slice(&bytes).unwrap();
    assert_eq!(snapshot.last_counter, 41);
    let mut successor = Server::new(settings(256), 1234, user_data());
    successor.restore(snapshot, plc.now());
    assert_eq!(successor.telegram_state(), ts::INITIALIZED);
    successor.on_servo_feedback(plc.now(), &feedback(DriveState::Holding), &mut fx);
    // The running move's DONE reaches the PLC through the successor.
    let events = [
        (1, job, state::BUFFERED, 0),
        (2, job, state::ACTIVE, 0),
        (3, job, state::DONE, 0),
    ];
    successor.on_motion_status(plc.now(), &status(5, &events), &mut fx);
    plc.idle(&mut successor);
    assert_eq!(plc.last_response(5).unwrap().state, state::DONE);
    // New commands go to the planner as the same issuer, numbered on.
    plc.motion.clear();
    let mut events = 3;
    let allocations = steady_rounds(&mut successor, &mut plc, &mut fx, &mut events);
    assert!(plc.motion.iter().all(|c| c.issuer == issuer));
    assert_eq!(
        allocations, 0,
        "the successor's steady state does not allocate"
    );
}

#[test]
fn cyclic_position_blocks_come_with_every_telegram_and_shift_the_sequences() {
    let mut server = Server::new(settings(256), 9, user_data());
    let mut plc = Plc::new(256);
    plc.number_r2p = crate::cyclic::CARTESIAN_POSITION | crate::cyclic::JOINT_POSITION;
    plc.cyclic = (2, 70);
    plc.initialize(&mut server);
    let mut fx = Effects::new();
    server.on_motion_status(plc.now(), &status(5, &[]), &mut fx);
    server.on_servo_feedback(plc.now(), &feedback(DriveState::Holding), &mut fx);
    plc.command(
        &mut server,
        7,
        NEW,
        &request(t::read_robot_data::TYPE, 2, 4),
    );
    assert_eq!(plc.last_response(7).map(|h| h.state), Some(state::DONE));
    let rx = &plc.last_rx;
    let f = |at: usize| f32::from_be_bytes([rx[at], rx[at + 1], rx[at + 2], rx[at + 3]]);
    assert!(
        (f(10) - 500.0).abs() < 1e-3,
        "X in mm from the planner's flange pose"
    );
    assert!(
        (f(50 + 4) - 1.57f32.to_degrees()).abs() < 1e-3,
        "J2 in degrees from the drives"
    );
    // Blocks the robot does not offer are refused at INITIALIZE.
    let mut server = Server::new(settings(256), 9, user_data());
    let mut plc = Plc::new(256);
    plc.number_r2p = 1 << 3;
    plc.control = Control::Initialize;
    assert_eq!(
        plc.exchange(&mut server, &[]),
        ts::TELEGRAM_NUMBER_UNSUPPORTED
    );
}

/// A move that the planner is executing as job `job` for command `cmd_id`.
fn running_move(server: &mut Server, plc: &mut Plc, fx: &mut Effects, cmd_id: u16) -> u32 {
    let mut msg = request(
        t::move_axes_absolute::TYPE,
        0,
        t::move_axes_absolute::request::LEN,
    );
    PayloadWriter::new(&mut msg).set_u16(t::move_axes_absolute::request::DECELERATION_RATE, 0xFFFF);
    plc.command(server, cmd_id, NEW, &msg);
    let job = plc
        .motion
        .iter()
        .rev()
        .find(|c| c.kind == MotionCommandKind::MoveAxes as u8)
        .unwrap()
        .job;
    let events = [(1, job, state::BUFFERED, 0), (2, job, state::ACTIVE, 0)];
    server.on_motion_status(plc.now(), &status(5, &events), fx);
    plc.idle(server);
    job
}

#[test]
fn lost_link_offers_resume_and_the_same_commands_continue() {
    let (mut server, mut plc, mut fx) = session(DriveState::Holding);
    let job = running_move(&mut server, &mut plc, &mut fx, 4);
    assert_eq!(plc.last_response(4).unwrap().state, state::ACTIVE);

    plc.motion.clear();
    let mut link_fx = Effects::new();
    server.on_link(plc.now(), LinkEvent::Disconnected, &mut link_fx);
    assert_eq!(server.telegram_state(), ts::CONNECTION_LOST);
    let held: Vec<u8> = link_fx.motion.iter().map(|c| c.kind).collect();
    assert_eq!(
        held,
        [MotionCommandKind::Interrupt as u8],
        "held, not halted"
    );
    let events = [
        (1, job, state::BUFFERED, 0),
        (2, job, state::ACTIVE, 0),
        (
            3,
            job,
            state::INTERRUPTED,
            code::INTERRUPTED_BY_GROUP_INTERRUPT,
        ),
    ];
    server.on_motion_status(plc.now(), &status(5, &events), &mut fx);

    server.on_link(plc.now(), LinkEvent::Connected, &mut link_fx);
    assert_eq!(plc.exchange(&mut server, &[]), ts::READY_TO_RESUME);
    plc.control = Control::Resume;
    assert_eq!(plc.exchange(&mut server, &[]), ts::INITIALIZED);
    plc.control = Control::None;
    plc.idle(&mut server);
    let h = plc.last_response(4).unwrap();
    assert_eq!(
        (h.state, h.code),
        (state::INTERRUPTED, code::INTERRUPTED_BY_GROUP_INTERRUPT),
        "the move is still registered and reports the interruption"
    );
    let interrupt_seq = link_fx.motion[0].seq;
    assert!(
        plc.motion.iter().all(|c| c.seq <= interrupt_seq),
        "nothing new reaches the planner before GroupContinue (only re-sends of unacknowledged commands): {:?}",
        plc.motion
    );
    plc.command(
        &mut server,
        5,
        NEW,
        &request(t::group_continue::TYPE, 2, t::group_continue::request::LEN),
    );
    assert!(
        plc.motion
            .iter()
            .any(|c| c.kind == MotionCommandKind::Continue as u8)
    );
    let events = [
        (
            3,
            job,
            state::INTERRUPTED,
            code::INTERRUPTED_BY_GROUP_INTERRUPT,
        ),
        (4, job, state::ACTIVE, 0),
        (5, job, state::DONE, 0),
    ];
    server.on_motion_status(plc.now(), &status(5, &events), &mut fx);
    plc.idle(&mut server);
    assert_eq!(plc.last_response(4).unwrap().state, state::DONE);
}

#[test]
fn a_plc_that_initializes_instead_of_resuming_ends_the_held_session() {
    let (mut server, mut plc, mut fx) = session(DriveState::Holding);
    running_move(&mut server, &mut plc, &mut fx, 4);
    server.on_link(plc.now(), LinkEvent::Connected, &mut fx);
    assert_eq!(plc.exchange(&mut server, &[]), ts::READY_TO_RESUME);
    plc.motion.clear();
    plc.seq = 0;
    plc.initialize(&mut server);
    assert!(
        plc.motion
            .iter()
            .any(|c| c.kind == MotionCommandKind::Halt as u8)
    );
    plc.idle(&mut server);
    assert_eq!(
        server.acr.live(),
        0,
        "a new session starts with an empty ACR"
    );
}

#[test]
fn resume_with_a_different_header_is_refused() {
    let (mut server, mut plc, mut fx) = session(DriveState::Holding);
    running_move(&mut server, &mut plc, &mut fx, 4);
    server.on_link(plc.now(), LinkEvent::Disconnected, &mut fx);
    server.on_link(plc.now(), LinkEvent::Connected, &mut fx);
    plc.number_r2p = 2;
    plc.control = Control::Resume;
    assert_eq!(plc.exchange(&mut server, &[]), ts::TELEGRAM_NUMBER_CHANGED);
}

#[test]
fn server_logs_are_created_and_read_line_by_line() {
    let (mut server, mut plc, _fx) = session(DriveState::Holding);
    // Something to log: an unsupported command.
    let unsupported = request(
        t::move_depart_linear::TYPE,
        0,
        t::move_depart_linear::request::LEN,
    );
    plc.command(&mut server, 1, NEW, &unsupported);
    plc.command(
        &mut server,
        2,
        NEW,
        &request(
            t::create_server_log::TYPE,
            2,
            t::create_server_log::request::LEN,
        ),
    );
    let (_, created) = plc.responses.iter().rev().find(|(id, _)| *id == 2).unwrap();
    let r = PayloadReader::new(created);
    assert_eq!(r.u8(t::create_server_log::response::STATE), state::DONE);
    let log_id = r.i16(t::create_server_log::response::SERVER_LOG_ID);
    assert_eq!(log_id, 1);

    let mut read = request(
        t::read_server_log::TYPE,
        2,
        t::read_server_log::request::LEN,
    );
    {
        let mut w = PayloadWriter::new(&mut read);
        w.set_bit(t::read_server_log::request::ENABLE, true);
        w.set_u16(t::read_server_log::request::SERVER_LOG_ID, 1);
        // Only command messages.
        w.set_u8(t::read_server_log::request::CONTEXT_FILTER.element(0), 4);
    }
    plc.command(&mut server, 3, NEW, &read);
    let (_, page) = plc.responses.iter().rev().find(|(id, _)| *id == 3).unwrap();
    assert_eq!(page.len(), t::read_server_log::response::LEN);
    let r = PayloadReader::new(page);
    assert_eq!(r.u8(t::read_server_log::response::STATE), state::ACTIVE);
    assert!(r.u32(t::read_server_log::response::AVAILABLE_LOG_LINES) >= 1);
    assert_eq!(
        r.u32(t::read_server_log::response::AVAILABLE_FILTERED_LOG_LINES),
        1
    );
    let len = usize::from(r.u8(t::read_server_log::response::LOG_CONTENT_LENGTH));
    let content = &page[14..14 + len];
    let text = core::str::from_utf8(content).unwrap();
    assert!(text.contains("CMD ERROR 0x00008F11"), "{text}");

    // A log that does not exist.
    PayloadWriter::new(&mut read).set_u16(t::read_server_log::request::SERVER_LOG_ID, 9);
    plc.command(&mut server, 4, NEW, &read);
    let h = plc.last_response(4).unwrap();
    assert_eq!((h.state, h.code), (state::ERROR, 0x8D47));
}

/// An ExchangeConfiguration request synchronising the SW limits with `reaction`.
fn exchange_configuration_syncing_sw_limits(client_in_sync: bool, reaction: u8) -> Vec<u8> {
    use t::exchange_configuration::request as q;
    let mut msg = request(t::exchange_configuration::TYPE, 2, q::LEN);
    let mut w = PayloadWriter::new(&mut msg);
    w.set_bit(q::ENABLE, true);
    w.set_u8(q::LOG_LEVEL, 5);
    w.set_u16(q::LIFE_SIGN_TIME_OUT, 1000);
    w.set_bit(q::ENABLE_SYNC_SW_LIMITS, true);
    w.set_bit(q::SW_LIMITS_IN_SYNC_CLIENT, client_in_sync);
    w.set_u8(q::SYNC_REACTION, reaction);
    msg
}

fn last_body(plc: &Plc, cmd_id: u16) -> Vec<u8> {
    plc.responses
        .iter()
        .rev()
        .find(|(id, _)| *id == cmd_id)
        .unwrap()
        .1
        .clone()
}

#[test]
fn sync_reports_data_in_sync_follows_data_changed_and_denies_enabling() {
    use t::exchange_configuration::response as xr;
    let (mut server, mut plc, _fx) = session(DriveState::Powered);
    plc.command(
        &mut server,
        1,
        NEW,
        &exchange_configuration_syncing_sw_limits(true, 1),
    );
    let r = last_body(&plc, 1);
    let r = PayloadReader::new(&r);
    assert_eq!(r.u8(xr::STATE), state::ACTIVE);
    assert!(r.bit(xr::SW_LIMITS), "SW limits in sync");
    assert!(!r.bit(xr::TOOL), "tools are not synchronised");

    // The controller resets its SW limits: DataChanged, so no longer in sync; the live
    // ExchangeConfiguration says so by itself.
    let mut reset = request(
        t::write_robot_sw_limits::TYPE,
        2,
        t::write_robot_sw_limits::request::LEN,
    );
    PayloadWriter::new(&mut reset).set_bit(
        t::write_robot_sw_limits::request::RESET_TO_FACTORY_DEFAULT,
        true,
    );
    plc.command(&mut server, 2, NEW, &reset);
    plc.idle(&mut server);
    let r = last_body(&plc, 1);
    assert!(!PayloadReader::new(&r).bit(xr::SW_LIMITS));

    // SyncReaction 1: EnableRobot is refused while not synchronized.
    let mut enable = request(t::enable_robot::TYPE, 2, t::enable_robot::request::LEN);
    PayloadWriter::new(&mut enable).set_bit(t::enable_robot::request::ENABLE, true);
    plc.command(&mut server, 3, NEW, &enable);
    let h = plc.last_response(3).unwrap();
    assert_eq!((h.state, h.code), (state::ERROR, code::NOT_SYNCHRONIZED));

    // An undefined SyncReaction.
    plc.command(
        &mut server,
        4,
        NEW,
        &exchange_configuration_syncing_sw_limits(true, 9),
    );
    let h = plc.last_response(4).unwrap();
    assert_eq!(
        (h.state, h.code),
        (state::ERROR, code::INVALID_SYNC_REACTION)
    );
}

#[test]
fn sync_reaction_3_interrupts_the_primary_sequence_after_the_delay() {
    let (mut server, mut plc, _fx) = session(DriveState::Holding);
    plc.command(
        &mut server,
        1,
        NEW,
        &exchange_configuration_syncing_sw_limits(false, 3),
    );
    // SyncDelay 0: the next poll reacts, once.
    plc.idle(&mut server);
    plc.idle(&mut server);
    let interrupts = plc
        .motion
        .iter()
        .filter(|c| c.kind == MotionCommandKind::Interrupt as u8)
        .map(|c| c.seq)
        .collect::<std::collections::BTreeSet<_>>();
    assert_eq!(interrupts.len(), 1, "{:?}", plc.motion);
}

#[test]
fn a_linear_move_reports_the_distance_left_on_its_line() {
    use t::move_linear_absolute as mla;
    let (mut server, mut plc, mut fx) = session(DriveState::Holding);
    let rates = [
        mla::request::VELOCITY_RATE,
        mla::request::ACCELERATION_RATE,
        mla::request::DECELERATION_RATE,
        mla::request::JERK_RATE,
    ];
    let msg = move_message(mla::TYPE, mla::request::LEN, rates, |w| {
        for (f, v) in mla::request::POSITION_X_RZ
            .into_iter()
            .zip([400.0, 0.0, 300.0, 0.0, 0.0, 0.0])
        {
            w.set_f32(f, v);
        }
    });
    plc.command(&mut server, 6, NEW, &msg);
    let mv = *plc
        .motion
        .iter()
        .find(|c| c.kind == MotionCommandKind::MoveLinear as u8)
        .expect("handed to the planner");
    assert!((mv.pose[0] - 0.4).abs() < 1e-6 && (mv.pose[2] - 0.3).abs() < 1e-6);
    // The planner reports the flange at (500, 100, 200) mm: 173.2 mm from the target.
    let events = [
        (1, mv.job, state::BUFFERED, 0),
        (2, mv.job, state::ACTIVE, 0),
    ];
    server.on_motion_status(plc.now(), &status(5, &events), &mut fx);
    plc.idle(&mut server);
    let body = plc
        .responses
        .iter()
        .rev()
        .find(|(id, _)| *id == 6)
        .unwrap()
        .1
        .clone();
    let r = PayloadReader::new(&body);
    assert_eq!(r.u8(mla::response::STATE), state::ACTIVE);
    let remaining = r.f32(mla::response::REMAINING_DISTANCE);
    assert!((remaining - 173.205).abs() < 0.01, "{remaining}");

    // GroupStop reports that it aborted a move of the primary sequence.
    assert_eq!(group_stop(&mut server, &mut plc, &mut fx, mv.job, 3), 1);
}

/// A GroupStop (CmdID 7) that aborts `job`, planner events from number `event`; returns its
/// AbortedSequence.
fn group_stop(server: &mut Server, plc: &mut Plc, fx: &mut Effects, job: u32, event: u64) -> i8 {
    plc.command(
        server,
        7,
        NEW,
        &request(t::group_stop::TYPE, 2, t::group_stop::request::LEN),
    );
    let stop = plc
        .motion
        .iter()
        .find(|c| c.kind == MotionCommandKind::Stop as u8)
        .unwrap()
        .job;
    let events = [
        (event, job, state::ABORTED, code::ABORTED_BY_GROUP_STOP),
        (event + 1, stop, state::DONE, 0),
    ];
    server.on_motion_status(plc.now(), &status(5, &events), fx);
    plc.idle(server);
    let (_, body) = plc.responses.iter().rev().find(|(id, _)| *id == 7).unwrap();
    PayloadReader::new(body).i8(t::group_stop::response::ABORTED_SEQUENCE)
}

fn set_sequence(target: u8) -> Vec<u8> {
    let mut msg = request(t::set_sequence::TYPE, 2, t::set_sequence::request::LEN);
    PayloadWriter::new(&mut msg).set_u8(t::set_sequence::request::TARGET_SEQUENCE, target);
    msg
}

/// A MoveAxesAbsolute to J1 = `j1_deg` with ExecutionMode `mode`.
fn move_axes(mode: u8, j1_deg: f32) -> Vec<u8> {
    let mut msg = request(
        t::move_axes_absolute::TYPE,
        mode,
        t::move_axes_absolute::request::LEN,
    );
    let mut w = PayloadWriter::new(&mut msg);
    default_rates(
        &mut w,
        [
            t::move_axes_absolute::request::VELOCITY_RATE,
            t::move_axes_absolute::request::ACCELERATION_RATE,
            t::move_axes_absolute::request::DECELERATION_RATE,
            t::move_axes_absolute::request::JERK_RATE,
        ],
    );
    w.set_f32(t::move_axes_absolute::request::JOINT_POSITION_J1, j1_deg);
    msg
}

/// The planner's status: standing at J1 = `j1`, the primary sequence held or not.
fn standing(j1: f64, held: bool, events: &[(u64, u32, u8, u16)]) -> MotionStatus {
    let mut s = status(5, events);
    s.joints_rad = [j1, 1.57, 1.57, 1.57, -1.57, 0.0];
    s.sequence_paused = held;
    s.queued_jobs = u32::from(held);
    s
}

#[test]
fn an_excursion_on_the_secondary_sequence_returns_to_the_primary_position() {
    let (mut server, mut plc, mut fx) = session(DriveState::Holding);
    let job = running_move(&mut server, &mut plc, &mut fx, 4);
    let mut running = standing(
        0.1,
        false,
        &[(1, job, state::BUFFERED, 0), (2, job, state::ACTIVE, 0)],
    );
    running.active_job = job;
    server.on_motion_status(plc.now(), &running, &mut fx);
    // Not while the primary sequence runs; no secondary moves before SetSequence.
    plc.command(&mut server, 5, NEW, &set_sequence(2));
    assert_eq!(
        plc.last_response(5).unwrap().code,
        code::REQUIRES_INTERRUPT_OR_IDLE
    );
    plc.command(&mut server, 6, NEW, &move_axes(7, 5.0));
    assert_eq!(
        plc.last_response(6).unwrap().code,
        code::SECONDARY_NOT_ACTIVE
    );

    // GroupInterrupt held the move at J1 = 0.2 rad.
    let interrupted = [
        (1, job, state::BUFFERED, 0),
        (2, job, state::ACTIVE, 0),
        (
            3,
            job,
            state::INTERRUPTED,
            code::INTERRUPTED_BY_GROUP_INTERRUPT,
        ),
    ];
    server.on_motion_status(plc.now(), &standing(0.2, true, &interrupted), &mut fx);
    plc.command(&mut server, 5, NEW, &set_sequence(2));
    assert_eq!(plc.last_response(5).unwrap().state, state::DONE);
    let secondary = shared_types::srci::telegram::status_bit::SECONDARY_SEQUENCE_ACTIVE;
    let in_primary = shared_types::srci::telegram::status_bit::IN_PRIMARY_POS;
    let word = |plc: &Plc| RobotHeader::decode(&plc.last_rx).unwrap().status;
    assert_ne!(word(&plc) & secondary, 0);

    // A secondary move takes the arm away.
    plc.motion.clear();
    plc.command(&mut server, 6, NEW, &move_axes(7, 30.0));
    let away = *plc
        .motion
        .iter()
        .find(|c| c.kind == MotionCommandKind::MoveAxes as u8)
        .unwrap();
    assert_eq!(
        away.sequence,
        shared_types::ipc::MotionSequence::Secondary as u8
    );
    plc.command(&mut server, 7, NEW, &set_sequence(1));
    assert_eq!(
        plc.last_response(7).unwrap().code,
        code::SECONDARY_NOT_EMPTY
    );
    let mut events = interrupted.to_vec();
    events.extend([
        (4, away.job, state::ACTIVE, 0),
        (5, away.job, state::DONE, 0),
    ]);
    server.on_motion_status(plc.now(), &standing(0.52, true, &events), &mut fx);
    plc.idle(&mut server);
    assert_eq!(word(&plc) & in_primary, 0, "away from the primary position");
    plc.command(&mut server, 7, NEW, &set_sequence(1));
    assert_eq!(plc.last_response(7).unwrap().state, state::DONE);
    plc.command(
        &mut server,
        8,
        NEW,
        &request(t::group_continue::TYPE, 2, t::group_continue::request::LEN),
    );
    assert_eq!(
        plc.last_response(8).unwrap().code,
        code::NOT_IN_PRIMARY_POSITION
    );

    // ReturnToPrimary: a secondary joint move back to J1 = 0.2 rad.
    plc.motion.clear();
    let mut back = request(
        t::return_to_primary::TYPE,
        0,
        t::return_to_primary::request::LEN,
    );
    {
        let mut w = PayloadWriter::new(&mut back);
        default_rates(
            &mut w,
            [
                t::return_to_primary::request::VELOCITY_RATE,
                t::return_to_primary::request::ACCELERATION_RATE,
                t::return_to_primary::request::DECELERATION_RATE,
                t::return_to_primary::request::JERK_RATE,
            ],
        );
        w.set_bit(t::return_to_primary::request::ENABLE, true);
    }
    plc.command(&mut server, 9, NEW, &back);
    let ret = *plc
        .motion
        .iter()
        .find(|c| c.kind == MotionCommandKind::MoveAxes as u8)
        .expect("the way back");
    assert_eq!(
        ret.sequence,
        shared_types::ipc::MotionSequence::Secondary as u8
    );
    assert!((ret.joints_rad[0] - 0.2).abs() < 1e-9);
    events.extend([(6, ret.job, state::ACTIVE, 0), (7, ret.job, state::DONE, 0)]);
    server.on_motion_status(plc.now(), &standing(0.2, true, &events), &mut fx);
    plc.idle(&mut server);
    let (_, body) = plc.responses.iter().rev().find(|(id, _)| *id == 9).unwrap();
    let r = PayloadReader::new(body);
    assert_eq!(r.u8(t::return_to_primary::response::STATE), state::DONE);
    assert_eq!(r.u16(t::return_to_primary::response::PROGRESS), 10_000);
    assert_ne!(word(&plc) & in_primary, 0, "back on the primary path");

    plc.motion.clear();
    plc.command(
        &mut server,
        8,
        NEW,
        &request(t::group_continue::TYPE, 2, t::group_continue::request::LEN),
    );
    let cont = plc
        .motion
        .iter()
        .find(|c| c.kind == MotionCommandKind::Continue as u8)
        .expect("GroupContinue reaches the planner");
    assert_eq!(
        cont.sequence,
        shared_types::ipc::MotionSequence::Primary as u8
    );
}

#[test]
fn step_mode_holds_the_primary_sequence_after_each_move() {
    let (mut server, mut plc, _fx) = session(DriveState::Powered);
    let mut enable = request(t::enable_robot::TYPE, 2, t::enable_robot::request::LEN);
    {
        let mut w = PayloadWriter::new(&mut enable);
        w.set_bit(t::enable_robot::request::ENABLE, true);
        w.set_u8(t::enable_robot::request::STEP_MODE, 2);
    }
    plc.command(&mut server, 1, NEW, &enable);
    assert_eq!(plc.last_response(1).unwrap().state, state::ACTIVE);
    let mut fx = Effects::new();
    server.on_servo_feedback(plc.now(), &feedback(DriveState::Holding), &mut fx);
    plc.command(&mut server, 2, NEW, &move_axes(0, 10.0));
    let mv = plc
        .motion
        .iter()
        .find(|c| c.kind == MotionCommandKind::MoveAxes as u8)
        .unwrap();
    assert!(mv.hold_after, "StepMode EXACT_STOP holds after the move");
    plc.command(
        &mut server,
        3,
        NEW,
        &exchange_configuration_syncing_sw_limits(true, 0),
    );
    let body = last_body(&plc, 3);
    let r = PayloadReader::new(&body);
    assert!(r.bit(t::exchange_configuration::response::STEP_MODE_EXACT_STOP_ACTIVE));
    assert!(!r.bit(t::exchange_configuration::response::STEP_MODE_BLENDING_ACTIVE));
}

fn supervision_status(
    request_id: u64,
    all_running: bool,
    safe_stop: bool,
) -> shared_types::health::SupervisionStatus {
    let mut s = shared_types::health::SupervisionStatus::new(77);
    s.generation = 1;
    s.request_id = request_id;
    s.request_outcome = shared_types::health::RequestOutcome::Done as u8;
    s.all_running = u8::from(all_running);
    s.safe_stop = u8::from(safe_stop);
    s.set_reason(
        "planner killed by signal 9; 2 failures within 60 s exceed orchestrator.max_restarts = 1",
    );
    s
}

#[test]
fn a_safe_stop_is_an_error_and_group_reset_waits_for_the_services() {
    let (mut server, mut plc, mut fx) = session(DriveState::Holding);
    let mut rm = request(t::read_messages::TYPE, 2, t::read_messages::request::LEN);
    PayloadWriter::new(&mut rm).set_u8(t::read_messages::request::MESSAGE_LEVEL, 20);
    plc.command(&mut server, 1, NEW, &rm);
    server.on_supervision_status(plc.now(), &supervision_status(0, false, true), &mut fx);
    plc.idle(&mut server);
    let error_pending = shared_types::srci::telegram::status_bit::ERROR_PENDING;
    assert_ne!(
        RobotHeader::decode(&plc.last_rx).unwrap().status & error_pending,
        0
    );
    let body = last_body(&plc, 1);
    let text = &body[20..];
    let text =
        core::str::from_utf8(&text[..text.iter().position(|&b| b == 0).unwrap_or(text.len())])
            .unwrap();
    assert!(text.contains("planner killed by signal 9"), "{text}");

    // GroupReset asks the orchestrator first; the planner's reset follows once all run.
    plc.motion.clear();
    plc.command(
        &mut server,
        2,
        NEW,
        &request(t::group_reset::TYPE, 2, t::group_reset::request::LEN),
    );
    let [reset] = plc.supervision[..] else {
        panic!("one request: {:?}", plc.supervision);
    };
    assert_eq!(reset.kind, shared_types::health::RequestKind::Reset as u8);
    assert!(
        plc.motion
            .iter()
            .all(|c| c.kind != MotionCommandKind::Reset as u8)
    );
    assert!(
        plc.last_response(2).is_none(),
        "no answer while the services restart"
    );
    server.on_supervision_status(
        plc.now(),
        &supervision_status(reset.request_id, true, false),
        &mut fx,
    );
    let planner_reset = fx
        .motion
        .iter()
        .find(|c| c.kind == MotionCommandKind::Reset as u8)
        .copied()
        .expect("the planner's reset follows");
    server.on_motion_status(
        plc.now(),
        &status(5, &[(1, planner_reset.job, state::DONE, 0)]),
        &mut fx,
    );
    plc.idle(&mut server);
    assert_eq!(plc.last_response(2).unwrap().state, state::DONE);
    assert_eq!(
        RobotHeader::decode(&plc.last_rx).unwrap().status & error_pending,
        0
    );
}

#[test]
fn without_an_orchestrator_group_reset_goes_to_the_planner_at_once() {
    let (mut server, mut plc, _fx) = session(DriveState::Holding);
    plc.command(
        &mut server,
        2,
        NEW,
        &request(t::group_reset::TYPE, 2, t::group_reset::request::LEN),
    );
    assert!(plc.supervision.is_empty());
    assert!(
        plc.motion
            .iter()
            .any(|c| c.kind == MotionCommandKind::Reset as u8)
    );
}

#[test]
fn the_tool_and_frame_of_an_accepted_move_become_the_ones_in_use() {
    use t::move_linear_absolute as mla;
    let (mut server, mut plc, _fx) = session(DriveState::Holding);
    let mut msg = request(mla::TYPE, 0, mla::request::LEN);
    {
        let mut w = PayloadWriter::new(&mut msg);
        default_rates(
            &mut w,
            [
                mla::request::VELOCITY_RATE,
                mla::request::ACCELERATION_RATE,
                mla::request::DECELERATION_RATE,
                mla::request::JERK_RATE,
            ],
        );
        w.set_u8(mla::request::TOOL_NO, 3);
        w.set_u8(mla::request::FRAME_NO, 2);
        w.set_f32(mla::request::POSITION_X, 400.0);
    }
    plc.command(&mut server, 6, NEW, &msg);
    let mut read = request(
        t::read_actual_position::TYPE,
        2,
        t::read_actual_position::request::LEN,
    );
    {
        let mut w = PayloadWriter::new(&mut read);
        w.set_u8(t::read_actual_position::request::TOOL_NO, 255);
        w.set_u8(t::read_actual_position::request::FRAME_NO, 255);
    }
    plc.command(&mut server, 7, NEW, &read);
    let body = last_body(&plc, 7);
    let r = PayloadReader::new(&body);
    assert_eq!(
        (
            r.u8(t::read_actual_position::response::TOOL_NO_RETURN),
            r.u8(t::read_actual_position::response::FRAME_NO_RETURN)
        ),
        (3, 2)
    );
}

#[test]
fn a_continuous_read_answers_again_until_it_is_stopped() {
    use t::read_actual_position as rap;
    let (mut server, mut plc, _fx) = session(DriveState::Holding);
    let continuous = request(rap::TYPE, 3, rap::request::LEN);
    plc.command(&mut server, 6, NEW, &continuous);
    let answers = |plc: &Plc| {
        plc.responses
            .iter()
            .filter(|(id, _)| *id == 6)
            .map(|(_, b)| ResponseHeader::decode(b).state)
            .collect::<Vec<_>>()
    };
    assert_eq!(answers(&plc), [state::ACTIVE]);
    // 8 ms per telegram: 15 idle telegrams are 120 ms, one more answer.
    for _ in 0..15 {
        plc.idle(&mut server);
    }
    assert_eq!(answers(&plc), [state::ACTIVE, state::ACTIVE]);
    let (_, last) = plc.responses.iter().rev().find(|(id, _)| *id == 6).unwrap();
    assert_eq!(last.len(), rap::response::LEN, "a full position every time");

    // STOP_PARALLEL_CONTINUOUS_TRIGGER as a new command ends it.
    plc.command(
        &mut server,
        7,
        NEW,
        &request(rap::TYPE, 9, rap::request::LEN),
    );
    assert_eq!(plc.last_response(7).unwrap().state, state::DONE);
    assert_eq!(plc.last_response(6).unwrap().state, state::DONE);
    // Other functions do not run continuously.
    plc.command(
        &mut server,
        8,
        NEW,
        &request(t::group_reset::TYPE, 3, t::group_reset::request::LEN),
    );
    assert_eq!(
        plc.last_response(8).unwrap().code,
        code::INVALID_EXECUTION_MODE
    );
}

#[test]
fn a_continuous_frame_jog_halves_its_step_where_the_planner_finds_no_way() {
    use t::group_jog as gj;
    let (mut server, mut plc, mut fx) = session(DriveState::Holding);
    let mut jog = request(gj::TYPE, 7, gj::request::LEN);
    {
        let mut w = PayloadWriter::new(&mut jog);
        w.set_bit(gj::request::ENABLE, true);
        w.set_u8(gj::request::MODE, 0);
        w.set_u16(gj::request::OVERRIDE, 2000);
        w.set_bit(gj::request::X_J1_POS, true);
    }
    plc.command(&mut server, 3, NEW, &jog);
    let first = *plc
        .motion
        .iter()
        .find(|c| c.kind == MotionCommandKind::MoveLinear as u8)
        .expect("a line along X");
    // The flange stands at x = 0.5 m (the test status): the line heads 0.4 m further.
    assert!((first.pose[0] - 0.9).abs() < 1e-9, "{:?}", first.pose);
    assert_eq!(
        first.sequence,
        shared_types::ipc::MotionSequence::Secondary as u8
    );
    let refused = [(1, first.job, state::ERROR, code::TARGET_UNREACHABLE)];
    server.on_motion_status(plc.now(), &status(5, &refused), &mut fx);
    let second = fx
        .motion
        .iter()
        .find(|c| c.kind == MotionCommandKind::MoveLinear as u8)
        .copied()
        .expect("a shorter line");
    assert!((second.pose[0] - 0.7).abs() < 1e-9, "{:?}", second.pose);
    plc.idle(&mut server);
    assert_eq!(
        plc.last_response(3).unwrap().state,
        state::ACTIVE,
        "the jog goes on"
    );
}

#[test]
fn a_wait_reports_its_elapsed_time_and_counts_as_a_move_for_group_stop() {
    use t::wait_time as wt;
    let (mut server, mut plc, mut fx) = session(DriveState::Holding);
    let mut msg = request(wt::TYPE, 0, wt::request::LEN);
    PayloadWriter::new(&mut msg).set_u32(wt::request::TIME, 2_000);
    plc.command(&mut server, 6, NEW, &msg);
    let wait = *plc
        .motion
        .iter()
        .find(|c| c.kind == MotionCommandKind::Wait as u8)
        .expect("handed to the planner");
    assert_eq!(wait.duration_s, 2.0);
    assert_eq!(wait.sequence, MotionSequence::Primary as u8);
    // Half-way through the wait, after the first ACTIVE response (progress is sent at most
    // every 100 ms).
    let mut s = status(5, &[(1, wait.job, state::ACTIVE, 0)]);
    s.active_job = wait.job;
    server.on_motion_status(plc.now(), &s, &mut fx);
    plc.idle(&mut server);
    plc.now += 200;
    s.active_progress = 50.0;
    server.on_motion_status(plc.now(), &s, &mut fx);
    plc.idle(&mut server);
    let elapsed = |plc: &Plc| {
        let (_, body) = plc.responses.iter().rev().find(|(id, _)| *id == 6).unwrap();
        PayloadReader::new(body).u32(wt::response::ELAPSED_TIME)
    };
    assert_eq!(elapsed(&plc), 1_000);
    assert_eq!(group_stop(&mut server, &mut plc, &mut fx, wait.job, 2), 1);
}

#[test]
fn a_relative_line_has_no_remaining_distance_until_it_ends() {
    use t::move_linear_relative as mlr;
    let (mut server, mut plc, mut fx) = session(DriveState::Holding);
    let rates = [
        mlr::request::VELOCITY_RATE,
        mlr::request::ACCELERATION_RATE,
        mlr::request::DECELERATION_RATE,
        mlr::request::JERK_RATE,
    ];
    let msg = move_message(mlr::TYPE, mlr::request::LEN, rates, |w| {
        w.set_f32(mlr::request::DISTANCE_Z, 50.0)
    });
    plc.command(&mut server, 6, NEW, &msg);
    let mv = *plc
        .motion
        .iter()
        .find(|c| c.kind == MotionCommandKind::MoveLinear as u8)
        .expect("handed to the planner");
    assert_eq!(mv.target_reference, TargetReference::RelativeInTool as u8);
    let remaining = |plc: &Plc| {
        let (_, body) = plc.responses.iter().rev().find(|(id, _)| *id == 6).unwrap();
        let r = PayloadReader::new(body);
        (
            r.u8(mlr::response::STATE),
            r.f32(mlr::response::REMAINING_DISTANCE),
        )
    };
    let events = [(1, mv.job, state::ACTIVE, 0)];
    server.on_motion_status(plc.now(), &status(5, &events), &mut fx);
    plc.idle(&mut server);
    assert_eq!(remaining(&plc), (state::ACTIVE, -1.0));
    let events = [(2, mv.job, state::DONE, 0)];
    server.on_motion_status(plc.now(), &status(5, &events), &mut fx);
    plc.idle(&mut server);
    assert_eq!(remaining(&plc), (state::DONE, 0.0));
}
