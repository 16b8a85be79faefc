//! Hot restart of the interpreter: the state of the SRCI session handed from a stopping
//! interpreter process to its successor, so that a PLC exchanging telegrams notices nothing.
//!
//! A planned stop (SIGTERM, as `rc restart interpreter` sends) writes a [`Snapshot`] of the
//! server (session, ACR, pending responses, sequence numbers, live commands, the planner link
//! with its unacknowledged commands, messages, server logs, sequences, SYNC) next to the user
//! data, atomically, after the last telegram was answered. The next interpreter process of the
//! same controller instance takes it if it is recent, deletes it, and continues from there;
//! while no interpreter runs, the fieldbus holds the PLC over (see the fieldbus crate).
//! A crashed interpreter writes nothing: its successor starts a new session.

use std::fs;
use std::io::Write;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};
use shared_types::ipc::ServoControl;

use crate::acr::Acr;
use crate::commands::LiveCommand;
use crate::messages::MessageLog;
use crate::motion_link::MotionLink;
use crate::responses::ResponseQueue;
use crate::sequences::Sequences;
use crate::server_log::ServerLog;
use crate::sync::{SyncRequest, SyncSupervisor};

/// File name of the snapshot in the data directory.
pub const FILE_NAME: &str = "interpreter.handover";
/// Version of the snapshot layout; another version is not taken.
pub const VERSION: u32 = 2;
/// A snapshot older than this (ms, CLOCK_MONOTONIC) is stale: its PLC has given up.
pub const MAX_AGE_MS: u64 = 5000;

/// The state of the server that outlives its process.
#[derive(Debug, Serialize, Deserialize)]
pub struct Snapshot {
    pub version: u32,
    /// The controller instance it belongs to.
    pub instance: String,
    /// CLOCK_MONOTONIC ms when it was written.
    pub written_mono_ms: u64,
    /// The `counter` of the last PLC telegram answered.
    pub last_counter: u64,
    pub(crate) telegram_state: u8,
    pub(crate) session: Option<crate::server::Session>,
    pub(crate) robot_lifesign: u8,
    pub(crate) plc_lifesign: Option<u8>,
    pub(crate) lifesign_timeout_ms: u16,
    pub(crate) last_seq: [u16; 2],
    pub(crate) reply_areas: [Vec<u8>; 2],
    pub(crate) invalid_frames: u64,
    pub(crate) acr: Acr,
    pub(crate) responses: ResponseQueue,
    pub(crate) messages: MessageLog,
    pub(crate) live: Vec<LiveCommand>,
    pub(crate) motion: MotionLink,
    pub(crate) servo_control: ServoControl,
    pub(crate) override_percent: f64,
    pub(crate) error_pending: bool,
    pub(crate) current_tool: u8,
    pub(crate) current_frame: u8,
    pub(crate) last_drive_fault: u16,
    pub(crate) last_planner_error: u16,
    pub(crate) suspended: bool,
    pub(crate) server_log: ServerLog,
    pub(crate) sync_request: SyncRequest,
    pub(crate) sync_supervisor: SyncSupervisor,
    pub(crate) sequences: Sequences,
    pub(crate) supervision_requests: u64,
    pub(crate) step_mode: u8,
}

/// The snapshot could not be written or read.
#[derive(Debug, thiserror::Error)]
pub enum HandoverError {
    #[error("cannot write the interpreter handover {path}: {source}")]
    Write {
        path: String,
        source: std::io::Error,
    },
    #[error("cannot encode the interpreter state: {0}")]
    Encode(serde_json::Error),
    #[error("interpreter handover {path} is unreadable: {detail}")]
    Read { path: String, detail: String },
}

/// Where the snapshot of `data_dir` lives.
pub fn path(data_dir: &Path) -> PathBuf {
    data_dir.join(FILE_NAME)
}

/// Writes `snapshot` atomically (a temporary file, flushed, then renamed).
pub fn write(data_dir: &Path, snapshot: &Snapshot) -> Result<(), HandoverError> {
    let target = path(data_dir);
    let temporary = data_dir.join(format!("{FILE_NAME}.tmp"));
    let failed = |source| HandoverError::Write {
        path: target.display().to_string(),
        source,
    };
    let bytes = serde_json::to_vec(snapshot).map_err(HandoverError::Encode)?;
    fs::create_dir_all(data_dir).map_err(failed)?;
    let mut file = fs::File::create(&temporary).map_err(failed)?;
    file.write_all(&bytes).map_err(failed)?;
    file.sync_all().map_err(failed)?;
    fs::rename(&temporary, &target).map_err(failed)
}

/// Takes the snapshot of `data_dir` (the file is removed): `Ok(None)` when there is none.
/// One of another instance, another layout version, or older than [`MAX_AGE_MS`] at
/// `now_mono_ms` is refused with the reason.
pub fn take(
    data_dir: &Path,
    instance: &str,
    now_mono_ms: u64,
) -> Result<Option<Snapshot>, HandoverError> {
    let file = path(data_dir);
    let unreadable = |detail: String| HandoverError::Read {
        path: file.display().to_string(),
        detail,
    };
    let bytes = match fs::read(&file) {
        Ok(bytes) => bytes,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(e) => return Err(unreadable(e.to_string())),
    };
    // Used at most once, whatever it holds.
    let _ = fs::remove_file(&file);
    let snapshot: Snapshot =
        serde_json::from_slice(&bytes).map_err(|e| unreadable(e.to_string()))?;
    if snapshot.version != VERSION {
        return Err(unreadable(format!(
            "layout version {} (this interpreter reads {VERSION})",
            snapshot.version
        )));
    }
    if snapshot.instance != instance {
        return Err(unreadable(format!(
            "written by instance {:?}, this is {instance:?}",
            snapshot.instance
        )));
    }
    let age = now_mono_ms.saturating_sub(snapshot.written_mono_ms);
    if age > MAX_AGE_MS {
        return Err(unreadable(format!(
            "{age} ms old (at most {MAX_AGE_MS} ms)"
        )));
    }
    Ok(Some(snapshot))
}

/// Serde for fixed byte buffers (serde's own arrays stop at 32 elements).
pub mod fixed_bytes {
    use serde::de::Error;
    use serde::{Deserialize, Deserializer, Serializer};

    pub fn serialize<S: Serializer, const N: usize>(
        bytes: &[u8; N],
        s: S,
    ) -> Result<S::Ok, S::Error> {
        s.serialize_bytes(bytes)
    }

    pub fn deserialize<'de, D: Deserializer<'de>, const N: usize>(
        d: D,
    ) -> Result<[u8; N], D::Error> {
        let v = Vec::<u8>::deserialize(d)?;
        let mut out = [0u8; N];
        if v.len() > N {
            return Err(D::Error::invalid_length(
                v.len(),
                &"at most the buffer size",
            ));
        }
        out[..v.len()].copy_from_slice(&v);
        Ok(out)
    }
}
