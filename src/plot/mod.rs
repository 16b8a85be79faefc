//! The motion plot of a run (`rc demo --plot FILE.svg`, `rc plc PROGRAM --plot FILE.svg`).
//!
//! - [`recorder`] (shell): a thread that subscribes to servo/feedback, motion/status and
//!   motion/command while the program runs;
//! - [`capture`]: turns those payloads into a [`recording::Recording`] (bounded by
//!   decimation), with the TCP speed from [`tcp`];
//! - [`svg`]: renders the recording (three panels over [`axis`] scales);
//! - [`session`] (shell): runs the program, records, and writes the file at the end or on
//!   Ctrl-C.

mod axis;
mod capture;
mod recorder;
mod recording;
mod session;
mod svg;
mod tcp;

pub use session::{PlotRequest, run_recorded};
