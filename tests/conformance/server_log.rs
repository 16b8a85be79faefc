//! CreateServerLog and ReadServerLog: a numbered copy of the controller's journal, read one
//! line per request, selected by ServerLogID, StartLine and ContextFilter.

use std::time::Duration;

use plc_client::Request;
use shared_types::srci::message::{code, execution_mode, state};
use shared_types::srci::payload::{PayloadReader, PayloadWriter};
use shared_types::srci::tables::{
    create_server_log as csl, exchange_configuration as xc, read_server_log as rsl,
};

use crate::common::{
    exchange_configuration, expect_done, expect_error, initialized, run_until_state,
};

/// ReadServerLog of log `id` from `start_line`, command messages only.
fn read_log(enable: bool, id: u16, start_line: u32) -> Request {
    let mut b = vec![0u8; rsl::request::LEN];
    let mut w = PayloadWriter::new(&mut b);
    w.set_bit(rsl::request::ENABLE, enable);
    w.set_u16(rsl::request::SERVER_LOG_ID, id);
    w.set_u32(rsl::request::START_LINE, start_line);
    w.set_u8(rsl::request::CONTEXT_FILTER.element(0), 4);
    Request::Raw {
        command_type: rsl::TYPE,
        execution_mode: execution_mode::PARALLEL,
        payload: b.split_off(4),
    }
}

/// The text of a ReadServerLog response.
fn content(response: &[u8]) -> String {
    let r = PayloadReader::new(response);
    let len = usize::from(r.u8(rsl::response::LOG_CONTENT_LENGTH));
    let start = rsl::response::LOG_CONTENT.offset;
    String::from_utf8_lossy(&response[start..start + len]).into_owned()
}

#[test]
fn a_server_log_is_created_counted_and_read_line_by_line() {
    let (_c, mut plc) = initialized("slog");
    // Something for the log: a command the controller does not implement.
    expect_error(
        &mut plc,
        &crate::common::unimplemented_request(),
        code::NOT_IMPLEMENTED,
    );
    let created = expect_done(
        &mut plc,
        &Request::Raw {
            command_type: csl::TYPE,
            execution_mode: execution_mode::PARALLEL,
            payload: vec![0; csl::request::LEN - 4],
        },
        csl::response::LEN,
    );
    let id = PayloadReader::new(&created.response).i16(csl::response::SERVER_LOG_ID);
    assert_eq!(id, 1, "the first log");

    // ExchangeConfiguration counts it.
    let h = plc
        .task_mut()
        .submit(&exchange_configuration(true, 1000))
        .expect("submit");
    let s = run_until_state(&mut plc, h, state::ACTIVE, Duration::from_secs(3));
    assert_eq!(
        PayloadReader::new(&s.response).u16(xc::response::NUMBER_OF_SERVER_LOGS),
        1
    );

    let h = plc
        .task_mut()
        .submit(&read_log(true, 1, 0))
        .expect("submit");
    let s = run_until_state(&mut plc, h, state::ACTIVE, Duration::from_secs(3));
    assert_eq!(s.response.len(), rsl::response::LEN);
    let r = PayloadReader::new(&s.response);
    assert!(r.u32(rsl::response::AVAILABLE_LOG_LINES) >= 1);
    assert_eq!(r.u32(rsl::response::AVAILABLE_FILTERED_LOG_LINES), 1);
    let line = content(&s.response);
    assert!(
        line.contains("CMD ERROR 0x00008F11 command not implemented"),
        "{line}"
    );
    // Paging on by an update: past the last selected line there is no content.
    plc.task_mut()
        .update(h, &read_log(true, 1, 1))
        .expect("update");
    let s = run_until_state(&mut plc, h, state::ACTIVE, Duration::from_secs(3));
    plc.run_until(
        |t| t.status(h).is_some_and(|s| s.par_seq == 2),
        Duration::from_secs(3),
    )
    .expect("the update answered");
    let s = plc.task().status(h).cloned().unwrap_or(s);
    assert_eq!(content(&s.response), "", "{s:?}");
    plc.task_mut()
        .update(h, &read_log(false, 1, 0))
        .expect("disable");
    let s = run_until_state(&mut plc, h, state::DONE, Duration::from_secs(3));
    assert_eq!(s.state, state::DONE);

    // A log that does not exist.
    expect_error(&mut plc, &read_log(true, 9, 0), 0x8D47);
}
