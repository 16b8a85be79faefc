//! Message codes of the user-data functions (spec tables 7-1, 7-3, 7-5) that the shared code
//! table does not have yet, and the texts ReadMessages shows for every code these functions
//! answer with.

use shared_types::srci::message::code;

/// WriteToolData refused: the tool is in use by the moving robot.
pub const TOOL_IN_MOTION: u16 = 0x8C16;
/// WriteLoadData refused: the load is in use by the moving robot.
pub const LOAD_IN_MOTION: u16 = 0x8C17;
pub const INVALID_LOAD_NO: u16 = 0x8D17;
/// A position or orientation value (X..Rz) is not a finite number.
pub const INVALID_POSITION: u16 = 0x8D24;
pub const INVALID_VELOCITY: u16 = 0x8D29;
/// A value outside its range that has no code of its own (SW limits, inertia).
pub const INDEX_OUT_OF_RANGE: u16 = 0x8D47;
/// Mass below zero or above the robot's payload.
pub const MASS_EXCEEDS_PAYLOAD: u16 = 0x8D49;
pub const INVALID_REFERENCE_FRAME: u16 = 0x8D88;
pub const EXTERNAL_TCP_NOT_SUPPORTED: u16 = 0x8E29;

/// Text for the message log of a user-data function that ended with `c`, for the codes the
/// command texts of the other functions do not cover (rates and SW limits they do).
pub fn describe(c: u16) -> Option<&'static str> {
    Some(match c {
        TOOL_IN_MOTION => "tool in use by the moving robot: not written",
        LOAD_IN_MOTION => "load in use by the moving robot: not written",
        code::INVALID_TOOL_NO => "ToolNo invalid (read 0..15 or -1, write 1..15)",
        code::INVALID_FRAME_NO => "FrameNo invalid (read 0..15 or -1, write 1..15)",
        INVALID_LOAD_NO => "LoadNo invalid (read 0..15 or -1, write 1..15, in a tool 0..15)",
        INVALID_POSITION => "position or orientation is not a finite number",
        INVALID_VELOCITY => "VelocityReference not finite, 0 or above the robot's maximum",
        INDEX_OUT_OF_RANGE => "value out of range (SW limit not finite or lower >= upper, inertia)",
        MASS_EXCEEDS_PAYLOAD => "load mass below 0 or above the robot's payload",
        INVALID_REFERENCE_FRAME => "ReferenceFrame invalid or making a cycle of frames",
        EXTERNAL_TCP_NOT_SUPPORTED => "ExternalTCP (stationary tool) is not supported",
        _ => return None,
    })
}
