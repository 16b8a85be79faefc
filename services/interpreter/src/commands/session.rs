//! The commands of the RobotTask start-up: ReadRobotData, ExchangeConfiguration, ReadMessages.

use shared_types::srci::message::{CommandHeader, code, severity, state};
use shared_types::srci::payload::{Field, Layout, PayloadReader, PayloadWriter};
use shared_types::srci::supported;
use shared_types::srci::tables::{
    exchange_configuration as xc, read_messages as rm, read_robot_data as rrd,
};

use super::{IMPLEMENTED, LiveKind};
use crate::server::{Now, Server};
use crate::sync::{SyncReaction, SyncRequest};
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

/// The DataInSync bits of the ExchangeConfiguration response, in the order of
/// [`DataSet::ALL`].
const DATA_IN_SYNC: [Field; 6] = [
    xc::response::TOOL,
    xc::response::FRAME,
    xc::response::LOAD,
    xc::response::SW_LIMITS,
    xc::response::DEFAULT_DYNAMICS,
    xc::response::REFERENCE_DYNAMICS,
];

/// What a live ExchangeConfiguration last reported of the values that change.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct ConfigurationReport {
    in_sync: [bool; 6],
    work_area_in_sync: bool,
    change_index: [u8; 3],
    server_logs: u16,
    step_mode: u8,
}

/// The synchronisation an ExchangeConfiguration request asks for, or the code of an
/// undefined SyncReaction.
fn decode_sync_request(r: &PayloadReader<'_>) -> Result<SyncRequest, u16> {
    use xc::request as q;
    let reaction =
        SyncReaction::from_wire(r.u8(q::SYNC_REACTION)).ok_or(code::INVALID_SYNC_REACTION)?;
    Ok(SyncRequest {
        enabled: [
            q::ENABLE_SYNC_TOOL,
            q::ENABLE_SYNC_FRAME,
            q::ENABLE_SYNC_LOAD,
            q::ENABLE_SYNC_SW_LIMITS,
            q::ENABLE_SYNC_DEFAULT_DYNAMICS,
            q::ENABLE_SYNC_REFERENCE_DYNAMICS,
        ]
        .map(|f| r.bit(f)),
        client_in_sync: [
            q::TOOL_DATA_IN_SYNC_CLIENT,
            q::FRAME_DATA_IN_SYNC_CLIENT,
            q::LOAD_DATA_IN_SYNC_CLIENT,
            q::SW_LIMITS_IN_SYNC_CLIENT,
            q::DEFAULT_DYNAMICS_IN_SYNC_CLIENT,
            q::REFERENCE_DYNAMICS_IN_SYNC_CLIENT,
        ]
        .map(|f| r.bit(f)),
        work_area: r.bit(q::ENABLE_SYNC_WORK_AREA),
        reaction,
        delay_ms: r.u16(q::SYNC_DELAY),
    })
}

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
        let i = self.keep_live(
            cmd_id,
            h,
            LiveKind::Configuration {
                sent: ConfigurationReport::default(),
            },
        );
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
        let refused = if !valid_message_level(log_level) {
            Some(code::INVALID_MODE)
        } else {
            decode_sync_request(&r).err()
        };
        if let Some(c) = refused {
            self.respond(cmd_id, h, state::ERROR, c, now, |_| {});
            return;
        }
        // Validated above.
        self.server_log.set_level(log_level as i8);
        if let Ok(sync) = decode_sync_request(&r) {
            self.sync_request = sync;
        }
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
        self.send_configuration(i, info, now);
    }

    /// What an ExchangeConfiguration response reports that changes during a session.
    fn configuration_report(&self) -> ConfigurationReport {
        let data = &self.user_data;
        let in_sync = crate::sync::data_in_sync(&self.sync_request, data);
        ConfigurationReport {
            in_sync,
            work_area_in_sync: self.sync_request.work_area,
            change_index: [DataSet::Tool, DataSet::Frame, DataSet::Load]
                .map(|set| data.change_index(set)),
            server_logs: self.server_log.count(),
            step_mode: self.step_mode,
        }
    }

    /// Sends the ACTIVE response of live ExchangeConfiguration `i` with message `info`.
    fn send_configuration(&mut self, i: usize, info: u16, now: Now) {
        let report = self.configuration_report();
        self.live[i].kind = LiveKind::Configuration { sent: report };
        let cmd_id = self.live[i].cmd_id;
        let h = self.live_header(i);
        let acr = u16::try_from(self.acr.length()).unwrap_or(u16::MAX);
        self.respond(cmd_id, h, state::ACTIVE, info, now, |b| {
            let mut w = PayloadWriter::new(b);
            w.set_bit(xc::response::ENABLED, true);
            w.set_u16(xc::response::LENGTH_ACR, acr);
            w.set_u16(xc::response::NUMBER_OF_SERVER_LOGS, report.server_logs);
            for f in [
                xc::response::HIGHEST_TOOL_INDEX,
                xc::response::HIGHEST_FRAME_INDEX,
                xc::response::HIGHEST_LOAD_INDEX,
            ] {
                w.set_u8(f, HIGHEST_INDEX);
            }
            let change = [
                xc::response::CHANGE_INDEX_TOOL,
                xc::response::CHANGE_INDEX_FRAME,
                xc::response::CHANGE_INDEX_LOAD,
            ];
            for (f, index) in change.into_iter().zip(report.change_index) {
                w.set_u8(f, index);
            }
            for (f, in_sync) in DATA_IN_SYNC.into_iter().zip(report.in_sync) {
                w.set_bit(f, in_sync);
            }
            w.set_bit(xc::response::WORK_AREA, report.work_area_in_sync);
            // StatusRobotArm reports Accelerating, Decelerating and ConstantVelocity.
            w.set_bit(xc::response::ACCELERATING_SUPPORTED, true);
            w.set_bit(xc::response::DECCELERATING_SUPPORTED, true);
            w.set_bit(xc::response::CONSTANT_VELOCITY_SUPPORTED, true);
            w.set_bit(
                xc::response::STEP_MODE_BLENDING_ACTIVE,
                report.step_mode == 1,
            );
            w.set_bit(
                xc::response::STEP_MODE_EXACT_STOP_ACTIVE,
                report.step_mode == 2,
            );
        });
    }

    /// Re-sends ExchangeConfiguration when DataInSync, a ChangeIndex or the number of server
    /// logs changed, so that the PLC sees it without asking.
    pub(crate) fn refresh_configuration(&mut self, now: Now) {
        let report = self.configuration_report();
        for i in 0..self.live.len() {
            if let LiveKind::Configuration { sent } = self.live[i].kind
                && sent != report
            {
                self.send_configuration(i, 0, now);
            }
        }
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
