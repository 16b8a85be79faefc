//! The server log behind CreateServerLog and ReadServerLog: a journal of everything the
//! controller reported (the ReadMessages entries, also after they were acknowledged or
//! cleared by GroupReset), of which the PLC freezes numbered copies and reads them line by
//! line.
//!
//! LogLevel (ExchangeConfiguration) is the lowest severity the journal records; 0 records
//! everything, as MessageLevel 0 shows everything. A ContextFilter entry other than 0 selects a message type
//! (1 interface, 2 controller, 3 arm, 4 command); all zero selects every line. Lines are
//! numbered from 0 within the filtered selection.
//!
//! All storage is reserved at start-up: recording, creating and reading never allocate.

use std::collections::VecDeque;

use shared_types::srci::message::severity;

use crate::messages::{MessageText, MessageType};

/// Stored server logs; creating one more replaces the oldest.
pub const STORED_LOGS: usize = 4;
/// Lines the journal keeps.
pub const JOURNAL_LINES: usize = 1024;
/// Number of ContextFilter entries of ReadServerLog.
pub const CONTEXT_FILTERS: usize = 10;

/// One journal line.
#[derive(Debug, Clone, Copy, serde::Serialize, serde::Deserialize)]
pub struct LogLine {
    /// UNIX time in ms.
    pub unix_ms: u64,
    pub kind: MessageType,
    pub severity: i8,
    pub code: u32,
    pub text: MessageText,
}

impl LogLine {
    /// The line as text: `2026-11-22 01:02:03.456 RC ERROR 0x00008F11 text`, cut to
    /// `out.len()` bytes on a character boundary; returns the length written.
    pub fn format(&self, out: &mut [u8]) -> usize {
        let (y, mo, d) = civil_date(self.unix_ms / 86_400_000);
        let ms_of_day = self.unix_ms % 86_400_000;
        let (h, mi, s, ms) = (
            ms_of_day / 3_600_000,
            ms_of_day / 60_000 % 60,
            ms_of_day / 1000 % 60,
            ms_of_day % 1000,
        );
        let mut buf = [0u8; 256];
        let text = crate::server::write_text(
            &mut buf,
            format_args!(
                "{y:04}-{mo:02}-{d:02} {h:02}:{mi:02}:{s:02}.{ms:03} {} {} 0x{:08X} {}",
                kind_name(self.kind),
                severity_name(self.severity),
                self.code,
                self.text.as_str()
            ),
        );
        let mut cut = text.len().min(out.len());
        while !text.is_char_boundary(cut) {
            cut -= 1;
        }
        out[..cut].copy_from_slice(&text.as_bytes()[..cut]);
        cut
    }
}

fn kind_name(kind: MessageType) -> &'static str {
    match kind {
        MessageType::Interface => "RI",
        MessageType::Controller => "RC",
        MessageType::Arm => "RA",
        MessageType::Command => "CMD",
    }
}

fn severity_name(sev: i8) -> &'static str {
    match sev {
        s if s >= severity::FATAL_ERROR => "FATAL",
        s if s >= severity::ERROR => "ERROR",
        s if s >= severity::WARNING => "WARNING",
        s if s >= severity::INFO => "INFO",
        _ => "DEBUG",
    }
}

/// Year, month, day of a day number counted from 1970-01-01 (proleptic Gregorian).
fn civil_date(days: u64) -> (u64, u64, u64) {
    // Days are shifted to start on 0000-03-01, so that the leap day ends each 400-year era.
    let z = days + 719_468;
    let era = z / 146_097;
    let day_of_era = z % 146_097;
    let year_of_era =
        (day_of_era - day_of_era / 1460 + day_of_era / 36_524 - day_of_era / 146_096) / 365;
    let day_of_year = day_of_era - (365 * year_of_era + year_of_era / 4 - year_of_era / 100);
    let mp = (5 * day_of_year + 2) / 153;
    let day = day_of_year - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = year_of_era + era * 400 + u64::from(month <= 2);
    (year, month, day)
}

/// A ReadServerLog request refers to a log that does not exist (never created or replaced).
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("server log {0} does not exist")]
pub struct UnknownLog(pub u16);

/// What ReadServerLog answers for one request.
#[derive(Debug, Clone, Copy)]
pub struct LogPage<'a> {
    /// Lines in the log.
    pub available: u32,
    /// Lines the context filter selects.
    pub filtered: u32,
    /// The requested line of the selection, if it exists.
    pub line: Option<&'a LogLine>,
}

#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
struct StoredLog {
    id: u16,
    lines: Vec<LogLine>,
}

/// The journal and the stored logs.
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
pub struct ServerLog {
    journal: VecDeque<LogLine>,
    capacity: usize,
    stored: Vec<StoredLog>,
    next_id: u16,
    level: i8,
}

impl ServerLog {
    /// A journal of `capacity` lines (the oldest line goes when it is full), recording
    /// from INFO until a PLC sets its LogLevel.
    pub fn new(capacity: usize) -> Self {
        Self {
            journal: VecDeque::with_capacity(capacity),
            capacity,
            stored: (0..STORED_LOGS)
                .map(|_| StoredLog {
                    id: 0,
                    lines: Vec::with_capacity(capacity),
                })
                .collect(),
            next_id: 1,
            level: severity::INFO,
        }
    }

    /// Gives the journal and the stored logs their full capacity again (after they were
    /// restored from a snapshot).
    pub fn reserve_capacity(&mut self) {
        let capacity = self.capacity;
        self.journal
            .reserve(capacity.saturating_sub(self.journal.len()));
        for log in &mut self.stored {
            log.lines.reserve(capacity.saturating_sub(log.lines.len()));
        }
    }

    /// Sets the LogLevel: the lowest severity recorded (0 = everything).
    pub fn set_level(&mut self, level: i8) {
        self.level = level;
    }

    /// Records a line if its severity reaches the LogLevel.
    pub fn record(&mut self, unix_ms: u64, kind: MessageType, sev: i8, code: u32, text: &str) {
        if sev < self.level || self.capacity == 0 {
            return;
        }
        if self.journal.len() == self.capacity {
            self.journal.pop_front();
        }
        self.journal.push_back(LogLine {
            unix_ms,
            kind,
            severity: sev,
            code,
            text: MessageText::new(text),
        });
    }

    /// CreateServerLog: freezes the journal as a new log and returns its ServerLogID
    /// (1..=32767, then from 1 again); the oldest stored log makes room.
    pub fn create(&mut self) -> u16 {
        let id = self.next_id;
        self.next_id = if self.next_id >= i16::MAX as u16 {
            1
        } else {
            self.next_id + 1
        };
        let slot = self
            .stored
            .iter_mut()
            .min_by_key(|l| (l.id != 0, l.id.wrapping_sub(id)))
            .expect("STORED_LOGS > 0");
        slot.id = id;
        slot.lines.clear();
        slot.lines.extend(self.journal.iter().copied());
        id
    }

    /// Number of stored logs (NumberOfServerLogs).
    pub fn count(&self) -> u16 {
        self.stored.iter().filter(|l| l.id != 0).count() as u16
    }

    /// ReadServerLog: line `start_line` of the lines of log `id` that `filter` selects.
    pub fn read(
        &self,
        id: u16,
        start_line: u32,
        filter: &[u8; CONTEXT_FILTERS],
    ) -> Result<LogPage<'_>, UnknownLog> {
        let log = self
            .stored
            .iter()
            .find(|l| l.id == id && id != 0)
            .ok_or(UnknownLog(id))?;
        let any = filter.iter().all(|&f| f == 0);
        let selected = |l: &&LogLine| any || filter.contains(&(l.kind as u8));
        let filtered = log.lines.iter().filter(selected).count();
        Ok(LogPage {
            available: log.lines.len() as u32,
            filtered: filtered as u32,
            line: log.lines.iter().filter(selected).nth(start_line as usize),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn log_with(lines: &[(MessageType, i8, &str)]) -> ServerLog {
        let mut log = ServerLog::new(8);
        log.set_level(severity::DEBUG);
        for (i, &(kind, sev, text)) in lines.iter().enumerate() {
            log.record(1_763_773_323_456 + i as u64, kind, sev, 0x8F11, text);
        }
        log
    }

    #[test]
    fn a_created_log_is_a_frozen_copy_read_line_by_line_through_the_filter() {
        let mut log = log_with(&[
            (MessageType::Command, severity::ERROR, "first"),
            (MessageType::Arm, severity::WARNING, "second"),
            (MessageType::Command, severity::INFO, "third"),
        ]);
        let id = log.create();
        log.record(0, MessageType::Command, severity::ERROR, 1, "after");
        let all = log.read(id, 0, &[0; CONTEXT_FILTERS]).unwrap();
        assert_eq!((all.available, all.filtered), (3, 3));
        assert_eq!(all.line.unwrap().text.as_str(), "first");
        let mut commands = [0; CONTEXT_FILTERS];
        commands[3] = MessageType::Command as u8;
        let page = log.read(id, 1, &commands).unwrap();
        assert_eq!((page.available, page.filtered), (3, 2));
        assert_eq!(page.line.unwrap().text.as_str(), "third");
        assert!(log.read(id, 2, &commands).unwrap().line.is_none());
        assert_eq!(
            log.read(id + 1, 0, &commands).unwrap_err(),
            UnknownLog(id + 1)
        );
    }

    #[test]
    fn log_level_filters_recording_and_zero_records_everything() {
        let mut log = ServerLog::new(8);
        log.set_level(severity::WARNING);
        log.record(0, MessageType::Arm, severity::INFO, 1, "info");
        log.record(0, MessageType::Arm, severity::ERROR, 2, "error");
        log.set_level(severity::NONE);
        log.record(0, MessageType::Arm, severity::DEBUG, 3, "debug");
        let id = log.create();
        let page = log.read(id, 0, &[0; CONTEXT_FILTERS]).unwrap();
        assert_eq!(page.available, 2);
        assert_eq!(page.line.unwrap().code, 2);
    }

    #[test]
    fn the_oldest_stored_log_makes_room_and_ids_count_on() {
        let mut log = log_with(&[(MessageType::Arm, severity::ERROR, "x")]);
        let ids: Vec<u16> = (0..STORED_LOGS + 1).map(|_| log.create()).collect();
        assert_eq!(ids, [1, 2, 3, 4, 5]);
        assert_eq!(log.count(), STORED_LOGS as u16);
        assert!(log.read(1, 0, &[0; CONTEXT_FILTERS]).is_err());
        assert!(log.read(5, 0, &[0; CONTEXT_FILTERS]).is_ok());
    }

    #[test]
    fn a_full_journal_drops_its_oldest_line() {
        let mut log = ServerLog::new(2);
        for code in 1..=3 {
            log.record(0, MessageType::Arm, severity::ERROR, code, "x");
        }
        let id = log.create();
        let first = log.read(id, 0, &[0; CONTEXT_FILTERS]).unwrap();
        assert_eq!((first.available, first.line.unwrap().code), (2, 2));
    }

    #[test]
    fn lines_format_with_utc_date_type_severity_code_and_text() {
        let line = LogLine {
            // 2025-11-22 01:02:03.456 UTC
            unix_ms: 1_763_773_323_456,
            kind: MessageType::Command,
            severity: severity::ERROR,
            code: 0x8F11,
            text: MessageText::new("command not implemented"),
        };
        let mut out = [0u8; 187];
        let n = line.format(&mut out);
        assert_eq!(
            core::str::from_utf8(&out[..n]).unwrap(),
            "2025-11-22 01:02:03.456 CMD ERROR 0x00008F11 command not implemented"
        );
        let mut short = [0u8; 10];
        assert_eq!(line.format(&mut short), 10);
        // Leap days and the turn of a century.
        assert_eq!(civil_date(11_016), (2000, 2, 29));
        assert_eq!(civil_date(0), (1970, 1, 1));
    }

    #[test]
    fn recording_creating_and_reading_do_not_allocate() {
        let mut log = log_with(&[]);
        let (_, allocations) = shared_types::alloc_count::count(|| {
            for i in 0..20 {
                log.record(i, MessageType::Arm, severity::ERROR, 1, "x");
            }
            let id = log.create();
            let mut out = [0u8; 187];
            let page = log.read(id, 3, &[0; CONTEXT_FILTERS]).unwrap();
            page.line.map(|l| l.format(&mut out))
        });
        assert_eq!(allocations, 0);
    }
}
