//! CreateServerLog and ReadServerLog: the PLC freezes the controller's journal as a numbered
//! log and reads it line by line (see [`crate::server_log`]).

use shared_types::srci::message::{CommandHeader, state};
use shared_types::srci::payload::{PayloadReader, PayloadWriter};
use shared_types::srci::tables::{create_server_log as csl, read_server_log as rsl};

use super::LiveKind;
use crate::server::{Now, Server};
use crate::server_log::CONTEXT_FILTERS;
use crate::user_data::codes::INDEX_OUT_OF_RANGE;

/// Bytes of one line ReadServerLog carries.
const LINE_CAPACITY: usize = rsl::response::LOG_CONTENT.size();

impl Server {
    /// CreateServerLog: answers the ServerLogID of the new log.
    pub(crate) fn create_server_log(&mut self, cmd_id: u16, h: CommandHeader, now: Now) {
        let id = self.server_log.create();
        self.respond(cmd_id, h, state::DONE, 0, now, |b| {
            // 1..=32767: fits the INT field.
            PayloadWriter::new(b).set_i16(csl::response::SERVER_LOG_ID, id as i16);
        });
    }

    /// ReadServerLog (Enable type): stays ACTIVE and answers the requested line again with
    /// every parameter update (ServerLogID, StartLine, ContextFilter); Enable = FALSE ends it.
    pub(crate) fn read_server_log(&mut self, cmd_id: u16, h: CommandHeader, msg: &[u8], now: Now) {
        let i = self.keep_live(cmd_id, h, LiveKind::ServerLog);
        self.update_read_server_log(i, msg, now);
    }

    pub(crate) fn update_read_server_log(&mut self, i: usize, msg: &[u8], now: Now) {
        let r = PayloadReader::new(msg);
        let cmd_id = self.live[i].cmd_id;
        let h = self.live_header(i);
        if !r.bit(rsl::request::ENABLE) {
            self.respond(cmd_id, h, state::DONE, 0, now, |_| {});
            return;
        }
        let filter: [u8; CONTEXT_FILTERS] =
            core::array::from_fn(|k| r.u8(rsl::request::CONTEXT_FILTER.element(k)));
        let mut line = [0u8; LINE_CAPACITY];
        let page = self
            .server_log
            .read(
                r.u16(rsl::request::SERVER_LOG_ID),
                r.u32(rsl::request::START_LINE),
                &filter,
            )
            .map(|p| {
                (
                    p.available,
                    p.filtered,
                    p.line.map_or(0, |l| l.format(&mut line)),
                )
            });
        match page {
            Ok((available, filtered, len)) => {
                self.respond(cmd_id, h, state::ACTIVE, 0, now, |b| {
                    let mut w = PayloadWriter::new(b);
                    w.set_u32(rsl::response::AVAILABLE_LOG_LINES, available);
                    w.set_u32(rsl::response::AVAILABLE_FILTERED_LOG_LINES, filtered);
                    // At most LINE_CAPACITY (187) bytes.
                    w.set_u8(rsl::response::LOG_CONTENT_LENGTH, len as u8);
                    let content = core::str::from_utf8(&line[..len]).unwrap_or("");
                    w.set_chars(rsl::response::LOG_CONTENT, content);
                })
            }
            Err(_) => self.respond(cmd_id, h, state::ERROR, INDEX_OUT_OF_RANGE, now, |_| {}),
        }
    }
}
