//! The bus side of the gateway: PLC telegrams and link events out to the interpreter
//! (`srci/p2r`), its answers back (`srci/r2p`), matched by the telegram counter.

use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use iceoryx2::port::listener::Listener;
use iceoryx2::port::notifier::Notifier;
use iceoryx2::port::publisher::Publisher;
use iceoryx2::port::subscriber::Subscriber;
use shared_types::bus::{Bus, Ipc, publish, receive_latest, wait_for_wakeup};
use shared_types::ipc::{LinkEvent, PlcTelegram, RobotTelegram, TELEGRAM_CAPACITY, topics};

use crate::{FieldbusError, monotonic_ns};

/// Longest single wait for the answer, so shutdown is noticed while a request is pending.
const WAIT_SLICE: Duration = Duration::from_millis(10);

/// The fieldbus process's ports on the telegram topics.
pub(crate) struct TelegramBridge {
    p2r: Publisher<Ipc, PlcTelegram, ()>,
    p2r_wake: Notifier<Ipc>,
    r2p: Subscriber<Ipc, RobotTelegram, ()>,
    r2p_wake: Listener<Ipc>,
    /// Counter of the last sample published on `srci/p2r`.
    counter: u64,
}

impl TelegramBridge {
    pub(crate) fn open(bus: &Bus) -> Result<Self, FieldbusError> {
        Ok(Self {
            p2r: bus.publisher(topics::P2R)?,
            p2r_wake: bus.notifier(topics::P2R)?,
            r2p: bus.subscriber(topics::R2P)?,
            r2p_wake: bus.listener(topics::R2P)?,
            counter: 0,
        })
    }

    /// Tells the interpreter that a peer connected or went away.
    pub(crate) fn link_event(
        &mut self,
        connection: u32,
        event: LinkEvent,
    ) -> Result<(), FieldbusError> {
        self.counter += 1;
        let sample = PlcTelegram::event(self.counter, monotonic_ns(), connection, event);
        self.send(sample)
    }

    /// Hands one PLC telegram to the interpreter; returns the counter its answer must carry.
    pub(crate) fn forward(
        &mut self,
        connection: u32,
        telegram: &[u8],
        received_ns: u64,
    ) -> Result<u64, FieldbusError> {
        self.counter += 1;
        let mut sample =
            PlcTelegram::event(self.counter, received_ns, connection, LinkEvent::Telegram);
        let len = telegram.len().min(TELEGRAM_CAPACITY);
        sample.bytes[..len].copy_from_slice(&telegram[..len]);
        // `len` is at most TELEGRAM_CAPACITY (256), which fits.
        sample.len = len as u16;
        self.send(sample)?;
        Ok(self.counter)
    }

    fn send(&self, sample: PlcTelegram) -> Result<(), FieldbusError> {
        publish(&self.p2r, sample)?;
        self.p2r_wake.notify().map_err(|e| FieldbusError::Notify {
            topic: topics::P2R,
            detail: format!("{e:?}"),
        })?;
        Ok(())
    }

    /// The newest answer (or handover notice) that arrived, without waiting: the cyclic
    /// transport takes whatever the interpreter said last.
    pub(crate) fn latest_reply(&self) -> Result<Option<RobotTelegram>, FieldbusError> {
        Ok(receive_latest(&self.r2p)?)
    }

    /// Waits up to `timeout` for the answer to request `counter`, or the interpreter's
    /// handover notice. Answers to earlier requests that came too late are discarded on the
    /// way.
    pub(crate) fn await_reply(
        &self,
        counter: u64,
        timeout: Duration,
        shutdown: &AtomicBool,
    ) -> Result<Option<RobotTelegram>, FieldbusError> {
        let deadline = monotonic_ns().saturating_add(timeout.as_nanos() as u64);
        loop {
            // The interpreter answers in order, so the newest answer is ours or an older one.
            if let Some(reply) = receive_latest(&self.r2p)?
                && (reply.counter == counter || reply.is_handover())
            {
                return Ok(Some(reply));
            }
            let now = monotonic_ns();
            if now >= deadline || shutdown.load(Ordering::Relaxed) {
                return Ok(None);
            }
            let remaining = Duration::from_nanos(deadline - now);
            wait_for_wakeup(&self.r2p_wake, remaining.min(WAIT_SLICE))?;
        }
    }
}
