//! The fieldbus process: the TCP gateway transport of SRCI, or the PROFINET IO-device
//! ([`profinet_transport`], `fieldbus.transport = "profinet"`).
//!
//! The protocol of the public SRCI TCP/IP bridge and of the open Python SRCI client: raw
//! telegrams without framing, a fixed length in each direction, strict lockstep with the client
//! as the cycle master. Every complete PLC telegram goes to the interpreter on `srci/p2r`; its
//! answer (matched by counter) goes back as exactly one reply. Nothing is ever sent unasked,
//! and a request the interpreter does not answer in time gets no reply at all.

pub mod assembler;
mod bridge;
pub mod holdover;
pub mod profinet_timing;
pub mod profinet_transport;
mod tcp;

use std::io;
use std::net::SocketAddr;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use shared_types::bus::{Bus, BusError};
use shared_types::config::Config;
use shared_types::health::{HealthReporter, Service};
use shared_types::ipc::{LinkEvent, PlcTelegram, TELEGRAM_CAPACITY, topics};
use shared_types::time::monotonic_ns;

use assembler::{TelegramAssembler, TelegramLengthError};
use bridge::TelegramBridge;
use holdover::HoldOver;

/// During a hold-over, how long a request waits for the next interpreter before the
/// hold-over answers it.
const HOLDOVER_WAIT: Duration = Duration::from_millis(5);
use shared_types::throttle::WarnThrottle;
use tcp::{Activity, Disconnect, Ended, TcpLink};

/// Longest wait for socket activity, so shutdown is noticed promptly.
const POLL_INTERVAL: Duration = Duration::from_millis(10);
/// At most one "no reply" warning per this interval.
const LATE_REPLY_LOG_INTERVAL_NS: u64 = 1_000_000_000;

/// The fieldbus process failed.
#[derive(Debug, thiserror::Error)]
pub enum FieldbusError {
    #[error("cannot listen on {addr}: {source}")]
    Bind { addr: String, source: io::Error },
    #[error("fieldbus.{key}: {source}")]
    TelegramLength {
        key: &'static str,
        source: TelegramLengthError,
    },
    #[error("poll on the fieldbus sockets failed: {0}")]
    Poll(io::Error),
    #[error("cannot read the listen address: {0}")]
    LocalAddr(io::Error),
    #[error(transparent)]
    Bus(#[from] BusError),
    #[error("PROFINET: {0}")]
    Profinet(#[from] profinet_transport::ProfinetError),
    #[error("wake-up notification on '{topic}' failed: {detail}")]
    Notify { topic: &'static str, detail: String },
}

/// The TCP gateway: a listening socket bound to the bus.
pub struct Gateway {
    link: TcpLink,
    bridge: TelegramBridge,
    reply_timeout: Duration,
    reply_length: usize,
    late_replies: WarnThrottle,
    holdover: HoldOver,
    // Declared last: the ports above are dropped before their node.
    _bus: Bus,
}

impl Gateway {
    /// Opens the telegram topics and listens on `fieldbus.listen`.
    pub fn bind(config: &Config) -> Result<Self, FieldbusError> {
        let fb = &config.main.fieldbus;
        let assembler = TelegramAssembler::new(usize::from(fb.telegram_length_plc_to_rob))
            .map_err(|source| FieldbusError::TelegramLength {
                key: "telegram_length_plc_to_rob",
                source,
            })?;
        let reply_length = usize::from(fb.telegram_length_rob_to_plc);
        if !(1..=TELEGRAM_CAPACITY).contains(&reply_length) {
            return Err(FieldbusError::TelegramLength {
                key: "telegram_length_rob_to_plc",
                source: TelegramLengthError(reply_length),
            });
        }
        let bus = Bus::new(&config.main.instance, "fieldbus")?;
        let bridge = TelegramBridge::open(&bus)?;
        let link = TcpLink::bind(&fb.listen, assembler)?;
        Ok(Self {
            link,
            bridge,
            reply_timeout: Duration::from_millis(fb.reply_timeout_ms),
            reply_length,
            late_replies: WarnThrottle::new(LATE_REPLY_LOG_INTERVAL_NS),
            holdover: HoldOver::new(fb.holdover_ms),
            _bus: bus,
        })
    }

    /// The address clients connect to (tells the port when `listen` asked for port 0).
    pub fn local_addr(&self) -> Result<SocketAddr, FieldbusError> {
        self.link.local_addr().map_err(FieldbusError::LocalAddr)
    }

    /// Serves clients until `shutdown` becomes true; the client then present is closed and
    /// reported as disconnected.
    pub fn serve(&mut self, shutdown: &AtomicBool) -> Result<(), FieldbusError> {
        tracing::info!(
            listen = %self.local_addr()?,
            plc_to_rob = self.link.request_length(),
            rob_to_plc = self.reply_length,
            "fieldbus TCP gateway listening"
        );
        let period_ns = u64::try_from(self.reply_timeout.as_nanos()).unwrap_or(u64::MAX);
        let mut health = HealthReporter::new(&self._bus, Service::Fieldbus, period_ns)?;
        while !shutdown.load(Ordering::Relaxed) {
            shared_types::supervision::beat();
            health.beat()?;
            match self.link.poll(POLL_INTERVAL)? {
                Activity::Idle => {}
                Activity::Connected {
                    connection,
                    peer,
                    replaced,
                } => {
                    self.holdover.forget();
                    if let Some(old) = replaced {
                        tracing::info!(connection = old, "fieldbus client replaced by a new one");
                        self.bridge.link_event(old, LinkEvent::Disconnected)?;
                    }
                    tracing::info!(connection, %peer, "fieldbus client connected");
                    self.bridge.link_event(connection, LinkEvent::Connected)?;
                }
                Activity::Disconnected(ended) => {
                    self.holdover.forget();
                    self.report_ended(ended)?
                }
                Activity::Telegram => {
                    let received_ns = monotonic_ns();
                    self.exchange(shutdown)?;
                    health.record(received_ns);
                }
            }
        }
        if let Some(connection) = self.link.close() {
            tracing::info!(connection, "fieldbus client closed at shutdown");
            self.bridge
                .link_event(connection, LinkEvent::Disconnected)?;
        }
        Ok(())
    }

    /// One lockstep cycle: the complete request to the interpreter, its answer to the client.
    /// While the interpreter process is being replaced (it said so), the client is held over.
    fn exchange(&mut self, shutdown: &AtomicBool) -> Result<(), FieldbusError> {
        let received_ns = monotonic_ns();
        let Some((connection, telegram)) = self.link.take_telegram() else {
            return Ok(());
        };
        // Forwarded during a hold-over too: the next interpreter takes it once it listens.
        let counter = self.bridge.forward(connection, telegram, received_ns)?;
        let holding = self.holdover.can_answer(received_ns);
        let timeout = if holding {
            HOLDOVER_WAIT.min(self.reply_timeout)
        } else {
            self.reply_timeout
        };
        match self.bridge.await_reply(counter, timeout, shutdown)? {
            Some(notice) if notice.is_handover() => {
                tracing::info!(
                    connection,
                    "the interpreter hands its session over: holding the PLC over"
                );
                self.holdover.begin(monotonic_ns());
                self.hold_over(connection)?;
            }
            Some(reply) => {
                if self.holdover.active() {
                    tracing::info!(connection, "the interpreter answers again: hold-over ended");
                }
                let bytes = &reply.bytes[..self.reply_length];
                self.holdover.remember(bytes);
                if let Err(ended) = self.link.reply(connection, bytes) {
                    self.report_ended(ended)?;
                }
            }
            // Cut short by shutdown: not the interpreter's fault, nothing to report.
            None if shutdown.load(Ordering::Relaxed) => {}
            None if self.holdover.can_answer(monotonic_ns()) => self.hold_over(connection)?,
            None => {
                if self.holdover.active() {
                    tracing::warn!(
                        connection,
                        "hold-over over: no interpreter took the session"
                    );
                    self.holdover.forget();
                }
                if let Some(suppressed) = self.late_replies.admit(monotonic_ns()) {
                    tracing::warn!(
                        counter,
                        connection,
                        timeout_ms = self.reply_timeout.as_millis() as u64,
                        suppressed,
                        "no answer from the interpreter in time; request left unanswered"
                    );
                }
            }
        }
        Ok(())
    }

    /// Answers the PLC in place of an interpreter being replaced (see [`holdover`]).
    fn hold_over(&mut self, connection: u32) -> Result<(), FieldbusError> {
        if let Some(reply) = self.holdover.answer()
            && let Err(ended) = self.link.reply(connection, reply)
        {
            self.report_ended(ended)?;
        }
        Ok(())
    }

    fn report_ended(&mut self, ended: Ended) -> Result<(), FieldbusError> {
        match ended.reason {
            Disconnect::Closed => tracing::info!(
                connection = ended.connection,
                partial_bytes = ended.partial_bytes,
                "fieldbus client disconnected"
            ),
            Disconnect::Failed(kind) => tracing::warn!(
                connection = ended.connection,
                error = %kind,
                partial_bytes = ended.partial_bytes,
                "fieldbus client connection failed"
            ),
        }
        self.bridge
            .link_event(ended.connection, LinkEvent::Disconnected)
    }
}

/// Runs the configured transport until `shutdown` becomes true (returns within about 10 ms).
///
/// PLC connections are accepted only once the interpreter listens on `srci/p2r`: a PLC that
/// connected earlier would get no answers and drop the connection.
pub fn run(config: &Config, shutdown: &AtomicBool) -> Result<(), FieldbusError> {
    if !wait_for_interpreter(config, shutdown)? {
        return Ok(());
    }
    if config.main.fieldbus.transport == "profinet" {
        let mut transport = profinet_transport::ProfinetTransport::open(config)?;
        shared_types::supervision::ready();
        transport.serve(shutdown)
    } else {
        let mut gateway = Gateway::bind(config)?;
        shared_types::supervision::ready();
        gateway.serve(shutdown)
    }
}

/// Waits until the interpreter subscribes to the PLC telegrams; false if shut down first.
fn wait_for_interpreter(config: &Config, shutdown: &AtomicBool) -> Result<bool, FieldbusError> {
    let bus = Bus::new(&config.main.instance, "fieldbus-start")?;
    let mut logged = false;
    while !shutdown.load(Ordering::Relaxed) {
        if bus.subscriber_count::<PlcTelegram>(topics::P2R)? > 0 {
            return Ok(true);
        }
        if !logged {
            tracing::info!("waiting for the interpreter before accepting PLC connections");
            logged = true;
        }
        std::thread::sleep(POLL_INTERVAL);
    }
    Ok(false)
}
