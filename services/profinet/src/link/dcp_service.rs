//! The DCP service loop: frames from the raw socket into the responder, its replies back
//! out, the Identify replies held back for their response delay.

use std::collections::VecDeque;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use super::raw_socket::{RawSocket, RawSocketError};
use crate::dcp::responder::DcpResponder;
use crate::dcp::station::{IpInterface, PermanentStore};
use crate::ethernet::MAX_FRAME_LEN;

/// Longest wait for a frame, so that shutdown is noticed promptly.
const POLL_INTERVAL: Duration = Duration::from_millis(50);
/// Most delayed replies held at once; a controller flooding Identify requests gets no more.
const MAX_PENDING: usize = 16;
/// Room for a received frame: the longest one with a VLAN tag.
const RECEIVE_BUFFER_LEN: usize = MAX_FRAME_LEN + 4;

/// A reply waiting for its response delay.
#[derive(Debug)]
struct PendingReply {
    due: Instant,
    frame: Vec<u8>,
}

/// Answers DCP on one interface.
#[derive(Debug)]
pub struct DcpService<S: PermanentStore, I: IpInterface> {
    socket: RawSocket,
    responder: DcpResponder<S, I>,
    pending: VecDeque<PendingReply>,
    reply: Vec<u8>,
}

impl<S: PermanentStore, I: IpInterface> DcpService<S, I> {
    /// A service answering with `responder` on `socket`.
    pub fn new(socket: RawSocket, responder: DcpResponder<S, I>) -> Self {
        Self {
            socket,
            responder,
            pending: VecDeque::with_capacity(MAX_PENDING),
            reply: vec![0; MAX_FRAME_LEN],
        }
    }

    /// The responder and its station parameters.
    pub fn responder(&self) -> &DcpResponder<S, I> {
        &self.responder
    }

    /// The raw socket, shared with the cyclic exchange of an IO device.
    pub fn socket(&self) -> &RawSocket {
        &self.socket
    }

    /// Serves until `shutdown` becomes true.
    pub fn run(&mut self, shutdown: &AtomicBool) -> Result<(), RawSocketError> {
        let mut received = vec![0u8; RECEIVE_BUFFER_LEN];
        self.log_listening();
        while !shutdown.load(Ordering::Relaxed) {
            let now = Instant::now();
            self.send_due(now)?;
            let wait = self.next_due().map_or(POLL_INTERVAL, |due| {
                due.saturating_duration_since(now).min(POLL_INTERVAL)
            });
            if let Some(len) = self.socket.receive(&mut received, wait)? {
                self.on_frame(&received[..len])?;
            }
        }
        Ok(())
    }

    /// Logs what the responder answers as.
    pub fn log_listening(&self) {
        let station = self.responder.current();
        tracing::info!(
            interface = self.socket.interface(),
            mac = %self.socket.mac(),
            name_of_station = station.name_of_station.as_str(),
            ip = %station.ip.address,
            "DCP responder listening"
        );
    }

    /// When the next delayed reply is due.
    pub fn next_due(&self) -> Option<Instant> {
        self.pending.iter().map(|p| p.due).min()
    }

    /// Answers one received DCP frame (sent at once, or held back for its response
    /// delay); returns true when the station parameters changed.
    pub fn on_frame(&mut self, frame: &[u8]) -> Result<bool, RawSocketError> {
        let outcome = match self.responder.handle(frame, &mut self.reply) {
            Ok(outcome) => outcome,
            Err(error) => {
                tracing::debug!(%error, "malformed DCP request ignored");
                return Ok(false);
            }
        };
        if outcome.signal {
            tracing::info!("DCP Signal: flash the identification LED");
        }
        if outcome.changed {
            let station = self.responder.current();
            tracing::info!(
                name_of_station = station.name_of_station.as_str(),
                ip = %station.ip.address,
                subnet_mask = %station.ip.subnet_mask,
                gateway = %station.ip.gateway,
                "station parameters changed by DCP"
            );
        }
        if let Some(answer) = outcome.reply {
            let frame = &self.reply[..answer.len];
            if answer.delay.is_zero() {
                self.socket.send(frame)?;
            } else if self.pending.len() < MAX_PENDING {
                self.pending.push_back(PendingReply {
                    due: Instant::now() + answer.delay,
                    frame: frame.to_vec(),
                });
            } else {
                tracing::warn!("too many delayed DCP replies; one dropped");
            }
        }
        Ok(outcome.changed)
    }

    /// Sends the delayed replies due at `now`.
    pub fn send_due(&mut self, now: Instant) -> Result<(), RawSocketError> {
        while let Some(index) = self.pending.iter().position(|p| p.due <= now) {
            if let Some(due) = self.pending.remove(index) {
                self.socket.send(&due.frame)?;
            }
        }
        Ok(())
    }
}
