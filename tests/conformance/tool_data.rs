//! ReadToolData (5107) and WriteToolData (5205): indices 1..15 writable, 0 fixed (flange),
//! -1 the tool in use; every field read back as written; ChangeIndexTool.

use plc_client::response::tool_data;
use plc_client::{Request, Timestamp, ToolData};
use shared_types::srci::message::code;
use shared_types::srci::tables::{read_tool_data as rtd, write_tool_data as wtd};

use crate::common::{change_indices, expect_done, expect_error, initialized};

#[test]
fn tools_are_written_read_back_and_checked() {
    let (_c, mut plc) = initialized("tool");
    let tool = ToolData {
        timestamp: Timestamp {
            date: 0x2B67,
            time_of_day_ms: 3_600_000,
        },
        pose: [12.5, -3.25, 150.0, 0.5, -90.0, 180.0],
        id: 42,
        load_no: 3,
        external_tcp: false,
    };
    let before = change_indices(&mut plc);
    expect_done(
        &mut plc,
        &Request::write_tool_data(3, &tool),
        wtd::response::LEN,
    );
    let after = change_indices(&mut plc);
    assert_eq!(
        after[0],
        before[0].wrapping_add(1),
        "ChangeIndexTool counts writes"
    );
    assert_eq!(after[1..], before[1..], "frames and loads unchanged");

    let s = expect_done(&mut plc, &Request::read_tool_data(3), rtd::response::LEN);
    let (index, read) = tool_data(&s.response);
    assert_eq!(index, 3);
    assert_eq!(
        read.data, tool,
        "every field as written, timestamp included"
    );
    assert!(!read.data_changed, "written by the client");

    // Tool 0 is the flange; -1 is the tool in use (the flange).
    let s = expect_done(&mut plc, &Request::read_tool_data(0), rtd::response::LEN);
    assert_eq!(tool_data(&s.response).0, 0);
    assert_eq!(tool_data(&s.response).1.data, ToolData::default());
    let s = expect_done(&mut plc, &Request::read_tool_data(255), rtd::response::LEN);
    assert_eq!(tool_data(&s.response).0, 0, "ToolNo of the tool in use");
    // An unwritten tool reads as zero.
    let s = expect_done(&mut plc, &Request::read_tool_data(15), rtd::response::LEN);
    assert_eq!(tool_data(&s.response).1.data.pose, [0.0; 6]);

    for index in [0, 16, 255] {
        expect_error(
            &mut plc,
            &Request::write_tool_data(index, &tool),
            code::INVALID_TOOL_NO,
        );
    }
    expect_error(
        &mut plc,
        &Request::read_tool_data(16),
        code::INVALID_TOOL_NO,
    );
    let mut bad = tool;
    bad.pose[4] = f32::NAN;
    expect_error(&mut plc, &Request::write_tool_data(2, &bad), 0x8D24);
    let mut bad = tool;
    bad.load_no = 16;
    expect_error(&mut plc, &Request::write_tool_data(2, &bad), 0x8D17);
    let mut bad = tool;
    bad.external_tcp = true;
    expect_error(&mut plc, &Request::write_tool_data(2, &bad), 0x8E29);
    // A refused write leaves the tool as it was.
    let s = expect_done(&mut plc, &Request::read_tool_data(2), rtd::response::LEN);
    assert_eq!(tool_data(&s.response).1.data, ToolData::default());
    let mut sequence = Request::read_tool_data(3);
    if let Request::Raw { execution_mode, .. } = &mut sequence {
        *execution_mode = 0;
    }
    expect_error(&mut plc, &sequence, code::INVALID_EXECUTION_MODE);
}
