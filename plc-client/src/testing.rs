//! Test doubles: a scripted robot controller that answers PLC telegrams with the codec, and
//! a bench that runs the engine against it on simulated time.

use std::collections::{HashMap, VecDeque};
use std::time::Duration;

use shared_types::srci::message::{CommandHeader, ResponseHeader, code, state};
use shared_types::srci::payload::{PayloadReader, PayloadWriter};
use shared_types::srci::tables;
use shared_types::srci::telegram::{
    Control, FragmentHeader, PLC_HEADER_LEN, PlcHeader, ROBOT_HEADER_LEN, RobotHeader, Sequence,
    SequenceWriter, SrciVersion, next_lifesign, sequence_areas, status_bit, telegram_state,
};

use crate::engine::{EngineOptions, RobotTask};
use crate::transport::{RoundTripSummary, Transport, TransportError};

/// A command the fake robot received completely.
#[derive(Debug, Clone)]
pub struct Received {
    pub cmd_id: u16,
    pub header: CommandHeader,
    pub payload: Vec<u8>,
    /// FragmentAction of the first fragment.
    pub first_action: u8,
}

#[derive(Debug)]
struct Move {
    cmd_id: u16,
    par_seq: u8,
    target: [f32; 6],
    remaining: u32,
    started: bool,
}

/// A scripted robot controller: INITIALIZE → 255, acknowledges every new SEQ at once and
/// attaches queued responses only to a newly acknowledged SEQ.
#[derive(Debug)]
pub struct FakeRobot {
    pub len_r2p: usize,
    pub state: u8,
    pub version: u8,
    pub lifesign: u8,
    pub freeze_lifesign: bool,
    /// When false the robot keeps acknowledging the old SEQ (and ignores new ones).
    pub ack_enabled: bool,
    pub last_seq: u16,
    pub length_acr: u16,
    /// Exchanges a move takes.
    pub move_cycles: u32,
    pub joints: [f32; 6],
    pub enabled: bool,
    /// A message ReadMessages delivers until it is acknowledged.
    pub pending_message: Option<(u8, String)>,
    /// Corrupt the footer of the next reply (and claim this TelegramState in it).
    pub tear_next: Option<u8>,
    pub received: Vec<Received>,
    /// Every fragment received, with the SEQ it came in.
    pub fragments: Vec<(u16, FragmentHeader)>,
    pub controls: Vec<Control>,
    buffers: HashMap<u16, (u8, Vec<u8>)>,
    queue: VecDeque<(u16, Vec<u8>, usize)>,
    moves: VecDeque<Move>,
}

impl FakeRobot {
    pub fn new(len_r2p: usize) -> Self {
        Self {
            len_r2p,
            state: telegram_state::READY_FOR_INITIALIZATION,
            version: SrciVersion::CURRENT.to_byte(),
            lifesign: 0,
            freeze_lifesign: false,
            ack_enabled: true,
            last_seq: 0,
            length_acr: 50,
            move_cycles: 10,
            joints: [0.0, 90.0, 90.0, 90.0, -90.0, 0.0],
            enabled: false,
            pending_message: None,
            tear_next: None,
            received: Vec::new(),
            fragments: Vec::new(),
            controls: Vec::new(),
            buffers: HashMap::new(),
            queue: VecDeque::new(),
            moves: VecDeque::new(),
        }
    }

    /// Received commands of one type.
    pub fn received_of(&self, command_type: u16) -> Vec<&Received> {
        self.received
            .iter()
            .filter(|r| r.header.command_type == command_type)
            .collect()
    }

    /// Answers one PLC telegram.
    pub fn answer(&mut self, tx: &[u8]) -> Vec<u8> {
        let h = PlcHeader::decode(tx).expect("PLC telegram");
        self.controls.push(h.control);
        match h.control {
            Control::Initialize if self.state == telegram_state::READY_FOR_INITIALIZATION => {
                self.state = telegram_state::INITIALIZED;
            }
            Control::Reset => {
                self.state = telegram_state::READY_FOR_INITIALIZATION;
                self.buffers.clear();
                self.queue.clear();
                self.moves.clear();
                self.last_seq = 0;
            }
            _ => {}
        }
        let ([(start, len), _], _) = sequence_areas(tx.len(), PLC_HEADER_LEN, 0, false);
        let seq = Sequence::decode(&tx[start..start + len]).expect("PLC sequence");
        let new_seq = self.ack_enabled && seq.seq_ack != self.last_seq;
        if new_seq {
            self.last_seq = seq.seq_ack;
            for f in seq.fragments() {
                let (fh, data) = f.expect("PLC fragment");
                self.fragments.push((seq.seq_ack, fh));
                self.take_fragment(fh, data);
            }
        }
        self.tick();
        self.reply(new_seq)
    }

    fn take_fragment(&mut self, fh: FragmentHeader, data: &[u8]) {
        let entry = self.buffers.entry(fh.cmd_id).or_insert((0, Vec::new()));
        if fh.action.reset() || fh.action.clear() {
            *entry = (fh.action.0, Vec::new());
        }
        let end = usize::from(fh.pointer) + data.len();
        if entry.1.len() < end {
            entry.1.resize(end, 0);
        }
        entry.1[usize::from(fh.pointer)..end].copy_from_slice(data);
        if fh.action.complete() {
            let (first_action, payload) = std::mem::take(entry);
            let header = CommandHeader::decode(&payload);
            self.received.push(Received {
                cmd_id: fh.cmd_id,
                header,
                payload: payload.clone(),
                first_action,
            });
            self.execute(fh.cmd_id, header, &payload);
        }
    }

    fn respond(
        &mut self,
        cmd_id: u16,
        len: usize,
        header: ResponseHeader,
        body: impl FnOnce(&mut PayloadWriter<'_>),
    ) {
        let mut p = vec![0u8; len];
        header.encode(&mut p);
        body(&mut PayloadWriter::new(&mut p));
        self.queue.push_back((cmd_id, p, 0));
    }

    fn execute(&mut self, cmd_id: u16, h: CommandHeader, payload: &[u8]) {
        let r = PayloadReader::new(payload);
        let ok = |s| ResponseHeader {
            par_seq: h.par_seq,
            state: s,
            severity: 0,
            code: 0,
        };
        match h.command_type {
            tables::read_messages::TYPE => {
                use tables::read_messages::{request as q, response as f};
                let acked = r.u8(q::MSG_ID);
                if self
                    .pending_message
                    .as_ref()
                    .is_some_and(|(id, _)| *id == acked)
                {
                    self.pending_message = None;
                }
                let message = self.pending_message.clone();
                self.respond(cmd_id, f::LEN, ok(state::ACTIVE), |w| {
                    w.set_bit(f::ENABLED, true);
                    if let Some((id, text)) = &message {
                        w.set_u8(f::MSG_ID, *id);
                        w.set_u8(f::MSG_TYPE, 3);
                        w.set_i8(f::SEVERITY, 28);
                        w.set_u32(f::ERROR_CODE, 0x6C01);
                        w.set_chars(f::TEXT, text);
                    }
                });
            }
            tables::exchange_configuration::TYPE => {
                use tables::exchange_configuration::response as f;
                let acr = self.length_acr;
                self.respond(cmd_id, f::LEN, ok(state::ACTIVE), |w| {
                    w.set_bit(f::ENABLED, true);
                    w.set_u16(f::LENGTH_ACR, acr);
                });
            }
            tables::read_robot_data::TYPE => {
                use tables::read_robot_data::response as f;
                self.respond(cmd_id, f::LEN, ok(state::DONE), |w| {
                    w.set_chars(f::RC_MANUFACTURER, "Fake robot RC");
                    w.set_chars(f::ROBOT_ID, "FAKE-7");
                    w.set_u16(f::INTERPRETER_CYCLE_TIME, 8);
                });
            }
            tables::enable_robot::TYPE => {
                use tables::enable_robot::{request as q, response as f};
                self.enabled = r.bit(q::ENABLE);
                let enabled = self.enabled;
                self.respond(cmd_id, f::LEN, ok(state::ACTIVE), |w| {
                    w.set_bit(f::ENABLED, enabled);
                });
            }
            tables::group_reset::TYPE | tables::change_speed_override::TYPE => {
                self.respond(cmd_id, 4, ok(state::DONE), |_| {});
            }
            tables::read_actual_position::TYPE => {
                use tables::read_actual_position::response as f;
                let joints = self.joints;
                self.respond(cmd_id, f::LEN, ok(state::DONE), |w| {
                    let fields = f::ACTUAL_JOINT_POSITION_J1_J6;
                    for (field, q) in fields.into_iter().zip(joints) {
                        w.set_f32(field, q);
                    }
                });
            }
            tables::move_axes_absolute::TYPE => {
                use tables::move_axes_absolute::request as q;
                if h.execution_mode == 1 {
                    while let Some(m) = self.moves.pop_front() {
                        let aborted = ResponseHeader {
                            par_seq: m.par_seq,
                            state: state::ABORTED,
                            severity: 5,
                            code: code::ABORTED_BY_MOTION_COMMAND,
                        };
                        self.respond(m.cmd_id, 10, aborted, |_| {});
                    }
                }
                let target = q::JOINT_POSITION_J1_J6.map(|f| r.f32(f));
                self.moves.push_back(Move {
                    cmd_id,
                    par_seq: h.par_seq,
                    target,
                    remaining: self.move_cycles,
                    started: false,
                });
                if self.moves.len() > 1 {
                    self.respond(cmd_id, 10, ok(state::BUFFERED), |_| {});
                }
            }
            _ => {
                let error = ResponseHeader {
                    par_seq: h.par_seq,
                    state: state::ERROR,
                    severity: 28,
                    code: code::NOT_IMPLEMENTED,
                };
                self.respond(cmd_id, 4, error, |_| {});
            }
        }
    }

    /// Advances the first move by one exchange.
    fn tick(&mut self) {
        use tables::move_axes_absolute::response as f;
        let total = self.move_cycles.max(1);
        let Some(m) = self.moves.front_mut() else {
            return;
        };
        let (cmd_id, par_seq) = (m.cmd_id, m.par_seq);
        let (s, progress) = if !m.started {
            m.started = true;
            (state::ACTIVE, 0)
        } else {
            m.remaining = m.remaining.saturating_sub(1);
            if m.remaining > 0 {
                if m.remaining % 3 != 0 {
                    return;
                }
                (
                    state::ACTIVE,
                    ((total - m.remaining) * 10_000 / total) as u16,
                )
            } else {
                self.joints = m.target;
                self.moves.pop_front();
                (state::DONE, 10_000)
            }
        };
        let h = ResponseHeader {
            par_seq,
            state: s,
            severity: 0,
            code: 0,
        };
        self.respond(cmd_id, f::LEN, h, |w| w.set_u16(f::PROGRESS, progress));
    }

    fn reply(&mut self, new_seq: bool) -> Vec<u8> {
        let mut r = vec![0u8; self.len_r2p];
        if !self.freeze_lifesign {
            self.lifesign = next_lifesign(self.lifesign);
        }
        let moving = if self.moves.front().is_some_and(|m| m.started) {
            status_bit::IS_MOVING
        } else {
            0
        };
        let enabled = if self.enabled { status_bit::ENABLED } else { 0 };
        RobotHeader {
            version: SrciVersion::from_byte(self.version),
            lifesign: self.lifesign,
            telegram_state: self.state,
            status: moving | enabled,
            override_centi: 10_000,
        }
        .encode(&mut r)
        .expect("robot telegram");
        let ([(start, len), _], _) = sequence_areas(r.len(), ROBOT_HEADER_LEN, 0, false);
        let mut w = SequenceWriter::new(&mut r[start..start + len], self.last_seq);
        while new_seq && w.room() > 0 {
            let Some((cmd_id, bytes, offset)) = self.queue.front_mut() else {
                break;
            };
            let end = (*offset + w.room()).min(bytes.len());
            let action = if end == bytes.len() { 1 } else { 0 };
            assert!(w.push(*cmd_id, action, *offset as u16, &bytes[*offset..end]));
            if end == bytes.len() {
                self.queue.pop_front();
            } else {
                *offset = end;
                break;
            }
        }
        if let Some(claimed) = self.tear_next.take() {
            r[3] = claimed;
            let last = r.len() - 1;
            r[last] ^= 0x10;
        }
        r
    }
}

impl Transport for FakeRobot {
    fn exchange(&mut self, tx: &[u8], rx: &mut [u8]) -> Result<(), TransportError> {
        rx.copy_from_slice(&self.answer(tx));
        Ok(())
    }

    fn round_trips(&self) -> RoundTripSummary {
        RoundTripSummary::default()
    }
}

/// The engine against a [`FakeRobot`] on simulated time (one cycle time per exchange).
pub struct Bench {
    pub task: RobotTask,
    pub robot: FakeRobot,
    pub now: Duration,
    rx: Vec<u8>,
    /// Every PLC telegram sent.
    pub sent: Vec<Vec<u8>>,
}

impl Bench {
    pub fn new(opts: EngineOptions) -> Self {
        let robot = FakeRobot::new(opts.length_rob_to_plc);
        Self {
            task: RobotTask::new(opts).expect("options"),
            robot,
            now: Duration::ZERO,
            rx: Vec::new(),
            sent: Vec::new(),
        }
    }

    /// One cycle and one exchange; returns the PLC telegram.
    pub fn step(&mut self) -> Vec<u8> {
        let mut tx = vec![0u8; self.task.options().length_plc_to_rob];
        self.task.cycle(self.now, &self.rx, &mut tx).expect("cycle");
        self.rx = self.robot.answer(&tx);
        self.now += self.task.options().cycle_time;
        self.sent.push(tx.clone());
        tx
    }

    /// Steps until `done`, at most `max` cycles; panics if it never happens.
    pub fn run_until(&mut self, max: usize, mut done: impl FnMut(&Self) -> bool) {
        for _ in 0..max {
            self.step();
            if done(self) {
                return;
            }
        }
        panic!(
            "condition not reached in {max} cycles (phase {:?}, fault {:?})",
            self.task.phase(),
            self.task.fault()
        );
    }

    /// A bench whose engine is already initialized.
    pub fn initialized(opts: EngineOptions) -> Self {
        let mut b = Self::new(opts);
        b.run_until(200, |b| b.task.initialized());
        b
    }
}

/// SEQ of a PLC telegram (no optional cyclic data, one sequence).
pub fn plc_seq(tx: &[u8]) -> u16 {
    u16::from_be_bytes([tx[PLC_HEADER_LEN], tx[PLC_HEADER_LEN + 1]])
}
