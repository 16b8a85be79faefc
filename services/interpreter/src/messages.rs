//! The message log behind ReadMessages: errors, warnings and infos with date and time,
//! delivered one at a time and acknowledged by MsgID.

use std::collections::VecDeque;

use shared_types::srci::message::severity;

/// Who a message is about (ReadMessages MsgType).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[repr(u8)]
pub enum MessageType {
    /// The robot interface (telegram level).
    Interface = 1,
    /// The robot controller.
    Controller = 2,
    /// The robot arm.
    Arm = 3,
    /// A command.
    Command = 4,
}

/// Longest text ReadMessages carries.
pub const TEXT_CAPACITY: usize = 150;

/// A message text of at most [`TEXT_CAPACITY`] bytes, stored inline (no allocation).
#[derive(Debug, Clone, Copy, serde::Serialize, serde::Deserialize)]
#[serde(into = "String", from = "String")]
pub struct MessageText {
    bytes: [u8; TEXT_CAPACITY],
    len: u8,
}

impl MessageText {
    /// `text`, cut at 150 bytes on a character boundary.
    pub fn new(text: &str) -> Self {
        let mut cut = text.len().min(TEXT_CAPACITY);
        while !text.is_char_boundary(cut) {
            cut -= 1;
        }
        let mut bytes = [0u8; TEXT_CAPACITY];
        bytes[..cut].copy_from_slice(&text.as_bytes()[..cut]);
        // `cut` <= 150.
        Self {
            bytes,
            len: cut as u8,
        }
    }

    /// The text.
    pub fn as_str(&self) -> &str {
        core::str::from_utf8(&self.bytes[..usize::from(self.len)]).unwrap_or("")
    }
}

impl From<MessageText> for String {
    fn from(t: MessageText) -> Self {
        t.as_str().to_owned()
    }
}

impl From<String> for MessageText {
    fn from(s: String) -> Self {
        MessageText::new(&s)
    }
}

/// One logged message.
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
pub struct Message {
    /// 1..=255, never 0 (0 means "no message").
    pub id: u8,
    /// UNIX time in ms when it was raised.
    pub unix_ms: u64,
    pub kind: MessageType,
    pub severity: i8,
    pub code: u32,
    text: MessageText,
    acknowledged: bool,
}

impl Message {
    /// The message text.
    pub fn text(&self) -> &str {
        self.text.as_str()
    }
}

/// The log: a bounded ring; when full, the oldest message goes.
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
pub struct MessageLog {
    entries: VecDeque<Message>,
    capacity: usize,
    next_id: u8,
    active_errors: u8,
    active_warnings: u8,
}

impl MessageLog {
    pub fn new(capacity: usize) -> Self {
        Self {
            entries: VecDeque::with_capacity(capacity),
            capacity,
            next_id: 1,
            active_errors: 0,
            active_warnings: 0,
        }
    }

    /// Records a message; the text is cut at 150 bytes (on a character boundary).
    pub fn raise(&mut self, unix_ms: u64, kind: MessageType, sev: i8, code: u32, text: &str) {
        if self.entries.len() >= self.capacity {
            self.entries.pop_front();
        }
        let id = self.next_id;
        self.next_id = if self.next_id == 255 {
            1
        } else {
            self.next_id + 1
        };
        if sev >= severity::ERROR {
            self.active_errors = self.active_errors.saturating_add(1);
        } else if sev >= severity::WARNING {
            self.active_warnings = self.active_warnings.saturating_add(1);
        }
        self.entries.push_back(Message {
            id,
            unix_ms,
            kind,
            severity: sev,
            code,
            text: MessageText::new(text),
            acknowledged: false,
        });
    }

    /// The oldest unacknowledged message at or above `level` (MessageLevel).
    pub fn current(&self, level: i8) -> Option<&Message> {
        self.entries
            .iter()
            .find(|m| !m.acknowledged && m.severity >= level)
    }

    /// Acknowledges message `id`; returns whether it was pending.
    pub fn acknowledge(&mut self, id: u8) -> bool {
        match self
            .entries
            .iter_mut()
            .find(|m| m.id == id && !m.acknowledged)
        {
            Some(m) => {
                m.acknowledged = true;
                true
            }
            None => false,
        }
    }

    /// Errors and warnings raised since the last GroupReset.
    pub fn active_counts(&self) -> (u8, u8) {
        (self.active_errors, self.active_warnings)
    }

    /// Gives the log its full capacity again (after it was restored from a snapshot).
    pub fn reserve_capacity(&mut self) {
        self.entries
            .reserve(self.capacity.saturating_sub(self.entries.len()));
    }

    /// GroupReset: deletes every message and clears the active counts.
    pub fn reset(&mut self) {
        self.entries.clear();
        self.active_errors = 0;
        self.active_warnings = 0;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn delivers_one_at_a_time_filtered_by_level_and_acknowledged_by_id() {
        let mut log = MessageLog::new(4);
        log.raise(1, MessageType::Controller, severity::INFO, 0x6001, "info");
        log.raise(2, MessageType::Command, severity::ERROR, 0x8F11, "error");
        let first = log.current(severity::WARNING).unwrap();
        assert_eq!((first.id, first.code, first.text()), (2, 0x8F11, "error"));
        assert_eq!(log.current(severity::DEBUG).unwrap().id, 1);
        assert!(log.acknowledge(2));
        assert!(!log.acknowledge(2));
        assert!(log.current(severity::WARNING).is_none());
        assert_eq!(log.active_counts(), (1, 0));
        log.reset();
        assert_eq!(log.active_counts(), (0, 0));
        assert!(log.current(severity::DEBUG).is_none());
    }

    #[test]
    fn ids_skip_zero_and_text_is_cut_on_a_char_boundary() {
        let mut log = MessageLog::new(2);
        for _ in 0..300 {
            log.raise(
                0,
                MessageType::Arm,
                severity::WARNING,
                1,
                "ü".repeat(100).as_str(),
            );
        }
        assert!(log.entries.iter().all(|m| m.id != 0));
        assert_eq!(log.current(0).unwrap().text().len(), 150);
    }
}
