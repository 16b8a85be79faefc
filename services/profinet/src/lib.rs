//! The PROFINET IO-device of the robot controller (issue 6): pure protocol modules and a
//! thin socket shell.
//!
//! # Design note: what comes from the `pnio` crate
//!
//! `pnio` 0.1.0 (core-engineering/pnio-rs, MIT OR Apache-2.0) is a PROFINET RT IO-device in
//! Rust: DCP, DCE/RPC CM, cyclic RT, alarms, I&M, validated byte-exact against an S7-1515.
//! We depend on it for the DCE/RPC and CM block codecs only, not for the layer-2
//! protocols, and take its **golden frames** as test data (`testdata/pnio/`, with
//! attribution):
//!
//! - *DCP*: its device side answers Identify and accepts a Set IP only when it equals the
//!   configured address; it has no Get, no Set NameOfStation, no Signal, no reset to
//!   factory, no response delay and no permanent storage. What we need is the behaviour it
//!   lacks, not a codec around it; its block API also allocates per block and logs through
//!   `log` rather than `tracing`. Written here ([`dcp`]).
//! - *Ethernet and RT frames*: its `rt::frame` codec is sound and allocation-free, but it is
//!   about a hundred lines and the rest of its RT engine is bound to its own limits (FrameIDs
//!   0x8000..=0xBBFF only, one AR, typed REAL/BOOL slots rather than a 256-byte SRCI
//!   module). Tying our frame types to a 0.1 crate for that gains little; written here
//!   ([`ethernet`], [`frame_id`], [`rt`]), checked against its RT captures.
//! - *CM over DCE/RPC*: this is where it serves. Its `rpc` (header with both DREPs, NDR,
//!   UUIDs) and `cm::block` parsers (ARBlockReq, IOCRBlockReq, ExpectedSubmoduleBlockReq,
//!   AlarmCRBlockReq) are pure and pinned to the S7-1515 capture, so [`cm`] uses them
//!   (`pnio` with default features off: no `pcap-file`), as are its DCE/RPC header and NDR
//!   writers, its Control, Read and Write request parsers, its Read response and its I&M0
//!   encoding, and its alarm channel (RTA) and diagnosis store. The decisions are ours, because
//!   its `cm::connect` grouping and validation refuse what we must accept: RTClass 1 with
//!   FrameIDs 0xC000.., an output FrameID 0xFFFF outside 0x8000.., a device-access AR
//!   without an AlarmCR (profinet-py's first connect); and its Connect response builder
//!   has a fixed shape (ARType 1, two IOCRs, always an AlarmCR), so the response blocks are
//!   written here too; its Write response answers every record OK, so ours carries one
//!   PNIOStatus per record. The AR state machine ([`cm::ar`]) is ours: `pnio`'s allows one
//!   AR of one shape.
//!
//! p-net, profinet-py, scapy and Wireshark are GPL: read for facts only.
//!
//! # Layout
//!
//! Pure: [`ethernet`] (Ethernet II, 802.1Q), [`frame_id`] (FrameID ranges and RT classes),
//! [`dcp`] (codec, station parameters, the responder), [`rt`] (cyclic frame, C_SDU layout,
//! IOxS, DataStatus, cycle counter, the provider and the consumer with watchdog and
//! data-hold time), [`device`] (identity; DAP, interface, port, SRCI module), [`cm`] (the
//! DCE/RPC envelope, the Connect request on `pnio`'s codecs, IOCR acceptance, the
//! ModuleDiff content, the Connect response blocks with the ModuleDiffBlock, records
//! (I&M0..4, RealIdentificationData, the diagnosis records, PDRealData with the
//! interface's and the port's real data), and the AR state machine:
//! Connect, Write, PrmEnd, ApplicationReady with its retries, Release, Read), [`alarm`]
//! (the diagnosis alarm of a robot error over `pnio`'s RTA channel, and the ERR-RTA that
//! closes the alarm endpoint when the AR ends). Shell:
//! [`link`] (AF_PACKET socket, the DCP service, the file store, the interface's IPv4
//! address over rtnetlink, the port's link from sysfs, read again on rtnetlink's link
//! changes, and the IO device that polls the raw and the UDP socket together); `src/bin/profinet-dcp.rs` runs the DCP
//! responder, or with `--srci-echo` the whole device with an echoing SRCI module.

pub mod alarm;
pub mod cm;
pub mod dcp;
pub mod device;
pub mod ethernet;
pub mod frame_id;
pub mod link;
pub mod rt;

#[cfg(test)]
mod testdata;
