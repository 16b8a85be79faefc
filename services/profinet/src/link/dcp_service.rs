//! The DCP service loop: frames from the raw socket into the responder, its replies back
//! out, the Identify replies held back for their response delay.

use std::collections::VecDeque;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use super::raw_socket::{RawSocket, RawSocketError};
use crate::dcp::responder::DcpResponder;
use crate::dcp::station::PermanentStore;
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
pub struct DcpService<S: PermanentStore> {
    socket: RawSocket,
    responder: DcpResponder<S>,
    pending: VecDeque<PendingReply>,
}

impl<S: PermanentStore> DcpService<S> {
    /// A service answering with `responder` on `socket`.
    pub fn new(socket: RawSocket, responder: DcpResponder<S>) -> Self {
        Self {
            socket,
            responder,
            pending: VecDeque::with_capacity(MAX_PENDING),
        }
    }

    /// The responder and its station parameters.
    pub fn responder(&self) -> &DcpResponder<S> {
        &self.responder
    }

    /// Serves until `shutdown` becomes true.
    pub fn run(&mut self, shutdown: &AtomicBool) -> Result<(), RawSocketError> {
        let mut received = vec![0u8; RECEIVE_BUFFER_LEN];
        let mut reply = vec![0u8; MAX_FRAME_LEN];
        let station = self.responder.current();
        tracing::info!(
            interface = self.socket.interface(),
            mac = %self.socket.mac(),
            name_of_station = station.name_of_station.as_str(),
            ip = %station.ip.address,
            "DCP responder listening"
        );
        while !shutdown.load(Ordering::Relaxed) {
            let now = Instant::now();
            self.send_due(now)?;
            let wait = self
                .pending
                .iter()
                .map(|p| p.due.saturating_duration_since(now))
                .min()
                .map_or(POLL_INTERVAL, |due| due.min(POLL_INTERVAL));
            let Some(len) = self.socket.receive(&mut received, wait)? else {
                continue;
            };
            let outcome = match self.responder.handle(&received[..len], &mut reply) {
                Ok(outcome) => outcome,
                Err(error) => {
                    tracing::debug!(%error, "malformed DCP request ignored");
                    continue;
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
                let frame = &reply[..answer.len];
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
        }
        Ok(())
    }

    fn send_due(&mut self, now: Instant) -> Result<(), RawSocketError> {
        while let Some(index) = self.pending.iter().position(|p| p.due <= now) {
            if let Some(due) = self.pending.remove(index) {
                self.socket.send(&due.frame)?;
            }
        }
        Ok(())
    }
}
