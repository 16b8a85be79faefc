//! The commands of the RobotTask start-up: ReadRobotData, ExchangeConfiguration, ReadMessages.

use shared_types::srci::message::{CommandHeader, code, severity, state};
use shared_types::srci::payload::{Field, Layout, PayloadReader, PayloadWriter};
use shared_types::srci::supported;
use shared_types::srci::tables::{
    exchange_configuration as xc, read_messages as rm, read_robot_data as rrd,
};

use super::{IMPLEMENTED, LiveKind};
use crate::server::{Now, Server};
use crate::user_data::{DataSet, HIGHEST_INDEX};

/// Lower limit of LifeSignTimeOut; smaller values are raised to it (info 0x6001).
const MIN_LIFESIGN_MS: u16 = 10;

/// ReadMessages request byte 5 bit 0: the Enable flag the SIMATIC and open PLC libraries send.
/// The specification table marks the byte reserved, so a request without it still counts as
/// enabled; only an update that clears a flag seen set disables the command.
const READ_MESSAGES_ENABLE: Field = Field {
    offset: 5,
    layout: Layout::Bit(0),
};

/// Whether `level` is a defined MessageLevel or LogLevel (0 = everything).
fn valid_message_level(level: u8) -> bool {
    matches!(level, 0 | 4 | 5 | 20 | 28 | 29)
}

impl Server {
    pub(crate) fn read_robot_data(&mut self, cmd_id: u16, h: CommandHeader, now: Now) {
        let s = &self.settings;
        let manufacturer = s.manufacturer.clone();
        let serial = s.serial_number.clone();
        let robot = s.robot_name.clone();
        let cycle = s.cycle_time_ms;
        let mut map = supported::bitmap(&IMPLEMENTED);
        // ReadActualPositionCyclic has no command type: the cyclic blocks are offered.
        let (byte, bit) = supported::CYCLIC_POSITION;
        map[usize::from(byte)] |= 1 << bit;
        self.respond(cmd_id, h, state::DONE, 0, now, |b| {
            let mut w = PayloadWriter::new(b);
            w.set_chars(rrd::response::RC_MANUFACTURER, &manufacturer);
            w.set_chars(rrd::response::RC_ORDER_ID, "rc-sim");
            w.set_chars(rrd::response::RC_SERIAL_NUMBER, &serial);
            w.set_chars(rrd::response::RA_SERIAL_NUMBER, &robot);
            w.set_chars(
                rrd::response::RC_FIRMWARE_VERSION,
                env!("CARGO_PKG_VERSION"),
            );
            w.set_chars(rrd::response::RC_INTERPRETER_VERSION, "1.5");
            // J1..J6 are bits 1..6; all joints rotary (unit bits 0 = degrees).
            w.set_u8(rrd::response::AXIS_JOINT_USED, 0b0111_1110);
            w.set_bytes(rrd::response::RC_SUPPORTED_FUNCTIONS, &map);
            w.set_chars(rrd::response::ROBOT_ID, &robot);
            w.set_u16(rrd::response::INTERPRETER_CYCLE_TIME, cycle);
        });
    }

    pub(crate) fn exchange_configuration(
        &mut self,
        cmd_id: u16,
        h: CommandHeader,
        msg: &[u8],
        now: Now,
    ) {
        let i = self.keep_live(cmd_id, h, LiveKind::Configuration);
        self.update_exchange_configuration(i, msg, now);
    }

    pub(crate) fn update_exchange_configuration(&mut self, i: usize, msg: &[u8], now: Now) {
        let r = PayloadReader::new(msg);
        let cmd_id = self.live[i].cmd_id;
        let h = self.live_header(i);
        if !r.bit(xc::request::ENABLE) {
            self.respond(cmd_id, h, state::DONE, 0, now, |_| {});
            return;
        }
        let log_level = r.u8(xc::request::LOG_LEVEL);
        if !valid_message_level(log_level) {
            self.respond(cmd_id, h, state::ERROR, code::INVALID_MODE, now, |_| {});
            return;
        }
        // Validated: at most 29.
        self.server_log.set_level(log_level as i8);
        let requested = r.u16(xc::request::LIFE_SIGN_TIME_OUT);
        let mut info = 0;
        self.lifesign_timeout_ms = if requested < MIN_LIFESIGN_MS {
            info = code::LIFESIGN_RAISED;
            self.raise(
                now,
                crate::messages::MessageType::Interface,
                severity::INFO,
                code::LIFESIGN_RAISED,
                "LifeSignTimeOut below 10 ms: raised to 10 ms",
            );
            MIN_LIFESIGN_MS
        } else {
            requested
        };
        let acr = u16::try_from(self.acr.length()).unwrap_or(u16::MAX);
        let server_logs = self.server_log.count();
        let data = &self.user_data;
        let change = [
            (
                xc::response::CHANGE_INDEX_TOOL,
                data.change_index(DataSet::Tool),
            ),
            (
                xc::response::CHANGE_INDEX_FRAME,
                data.change_index(DataSet::Frame),
            ),
            (
                xc::response::CHANGE_INDEX_LOAD,
                data.change_index(DataSet::Load),
            ),
        ];
        self.respond(cmd_id, h, state::ACTIVE, info, now, |b| {
            let mut w = PayloadWriter::new(b);
            w.set_bit(xc::response::ENABLED, true);
            w.set_u16(xc::response::LENGTH_ACR, acr);
            w.set_u16(xc::response::NUMBER_OF_SERVER_LOGS, server_logs);
            for f in [
                xc::response::HIGHEST_TOOL_INDEX,
                xc::response::HIGHEST_FRAME_INDEX,
                xc::response::HIGHEST_LOAD_INDEX,
            ] {
                w.set_u8(f, HIGHEST_INDEX);
            }
            for (f, index) in change {
                w.set_u8(f, index);
            }
        });
    }

    pub(crate) fn read_messages(&mut self, cmd_id: u16, h: CommandHeader, msg: &[u8], now: Now) {
        let r = PayloadReader::new(msg);
        let level = r.u8(rm::request::MESSAGE_LEVEL);
        if !valid_message_level(level) {
            self.respond(cmd_id, h, state::ERROR, code::INVALID_MODE, now, |_| {});
            return;
        }
        let i = self.keep_live(
            cmd_id,
            h,
            LiveKind::Messages {
                // Validated above: at most 29.
                level: level as i8,
                shown: 0,
                counts: (0, 0),
                enable_seen: r.bit(READ_MESSAGES_ENABLE),
            },
        );
        self.send_messages(i, now);
    }

    pub(crate) fn update_read_messages(&mut self, i: usize, msg: &[u8], now: Now) {
        let r = PayloadReader::new(msg);
        let LiveKind::Messages {
            shown, enable_seen, ..
        } = self.live[i].kind
        else {
            return;
        };
        let cmd_id = self.live[i].cmd_id;
        let h = self.live_header(i);
        let level = r.u8(rm::request::MESSAGE_LEVEL);
        if !valid_message_level(level) {
            self.respond(cmd_id, h, state::ERROR, code::INVALID_MODE, now, |_| {});
            return;
        }
        let ack = r.u8(rm::request::MSG_ID);
        if ack != 0 && ack == shown {
            self.messages.acknowledge(ack);
        }
        if enable_seen && !r.bit(READ_MESSAGES_ENABLE) {
            self.respond(cmd_id, h, state::DONE, 0, now, |_| {});
            return;
        }
        if let LiveKind::Messages { level: l, .. } = &mut self.live[i].kind {
            *l = level as i8;
        }
        self.send_messages(i, now);
    }

    /// Sends the current message (or none) to live ReadMessages command `i`.
    fn send_messages(&mut self, i: usize, now: Now) {
        let LiveKind::Messages {
            level, enable_seen, ..
        } = self.live[i].kind
        else {
            return;
        };
        let counts = self.messages.active_counts();
        let current = self.messages.current(level).cloned();
        let shown = current.as_ref().map_or(0, |m| m.id);
        self.live[i].kind = LiveKind::Messages {
            level,
            shown,
            counts,
            enable_seen,
        };
        let cmd_id = self.live[i].cmd_id;
        let h = self.live_header(i);
        self.respond(cmd_id, h, state::ACTIVE, 0, now, |b| {
            let mut w = PayloadWriter::new(b);
            w.set_bit(rm::response::ENABLED, true);
            w.set_u8(rm::response::NUMBER_OF_ACTIVE_ERRORS, counts.0);
            w.set_u8(rm::response::NUMBER_OF_ACTIVE_WARNINGS, counts.1);
            if let Some(m) = &current {
                let (date, time) = shared_types::srci::message::iec_date_time(m.unix_ms);
                w.set_u8(rm::response::MSG_ID, m.id);
                w.set_u16(rm::response::DATE, date);
                w.set_u32(rm::response::TIME, time);
                w.set_u8(rm::response::MSG_TYPE, m.kind as u8);
                w.set_i8(rm::response::SEVERITY, m.severity);
                w.set_u32(rm::response::ERROR_CODE, m.code);
                w.set_chars(rm::response::TEXT, m.text());
            }
        });
    }

    /// Re-sends ReadMessages when the message to show or the counts changed.
    pub(crate) fn refresh_messages(&mut self) {
        let counts = self.messages.active_counts();
        for i in 0..self.live.len() {
            if let LiveKind::Messages {
                level,
                shown,
                counts: sent,
                ..
            } = self.live[i].kind
            {
                let now_shown = self.messages.current(level).map_or(0, |m| m.id);
                if now_shown != shown || sent != counts {
                    self.send_messages(i, Now::default());
                }
            }
        }
    }
}
