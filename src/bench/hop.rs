//! One IPC hop: the same 256-byte message ping-ponged between two threads over iceoryx2
//! (publish-subscribe plus a wake-up event, as the controller's services use it) and over a
//! Unix domain socket. Both sides sleep until woken (no busy waiting); one-way latency is
//! half the round trip.

use std::io::{Read, Write};
use std::os::unix::net::UnixStream;
use std::sync::Barrier;
use std::sync::atomic::{AtomicBool, Ordering};
use std::thread;
use std::time::{Duration, Instant};

use anyhow::{Context, bail};
use iceoryx2::port::listener::Listener;
use iceoryx2::port::notifier::Notifier;
use iceoryx2::port::publisher::Publisher;
use iceoryx2::port::subscriber::Subscriber;
use iceoryx2::prelude::*;
use shared_types::bus::{self, Bus, BusError, Ipc};

use super::elapsed_ns;
use super::stats::{Distribution, Recorder};

/// Bytes per message, as a full SRCI telegram.
pub const MESSAGE_LEN: usize = 256;
/// Round trips run before measuring (connections, caches, page faults).
const WARM_UP: usize = 200;
/// How long the answering side sleeps before it looks whether it should stop.
const STOP_POLL: Duration = Duration::from_millis(50);
/// A round trip longer than this means the other side is gone.
const REPLY_TIMEOUT: Duration = Duration::from_secs(2);

/// The message of both transports.
#[repr(C)]
#[derive(Debug, Clone, Copy, ZeroCopySend)]
#[type_name("rc::BenchHopMessage")]
struct HopMessage {
    bytes: [u8; MESSAGE_LEN],
}

/// One-way latencies (ns) of both transports.
pub struct Hops {
    pub iceoryx2: Distribution,
    pub unix_socket: Distribution,
}

/// Measures `round_trips` round trips over each transport; `instance` prefixes the
/// benchmark's iceoryx2 services.
pub fn measure(instance: &str, round_trips: usize) -> anyhow::Result<Hops> {
    Ok(Hops {
        iceoryx2: iceoryx2_hops(instance, round_trips)?,
        unix_socket: unix_socket_hops(round_trips)?,
    })
}

const PING: &str = "bench/ping";
const PONG: &str = "bench/pong";

/// One side's ports: what it sends on and what it listens to. Created inside the thread that
/// uses them (iceoryx2's `ipc::Service` ports are not `Send`).
struct Side {
    _bus: Bus,
    publisher: Publisher<Ipc, HopMessage, ()>,
    notifier: Notifier<Ipc>,
    subscriber: Subscriber<Ipc, HopMessage, ()>,
    listener: Listener<Ipc>,
}

impl Side {
    fn open(instance: &str, node: &str, send: &str, receive: &str) -> Result<Self, BusError> {
        let bus = Bus::new(instance, node)?;
        Ok(Self {
            publisher: bus.publisher(send)?,
            notifier: bus.notifier(send)?,
            subscriber: bus.subscriber(receive)?,
            listener: bus.listener(receive)?,
            _bus: bus,
        })
    }

    fn send(&self, message: HopMessage) -> anyhow::Result<()> {
        bus::publish(&self.publisher, message)?;
        self.notifier
            .notify()
            .map_err(|e| anyhow::anyhow!("iceoryx2 notify: {e:?}"))?;
        Ok(())
    }

    fn take(&self) -> anyhow::Result<Option<HopMessage>> {
        let sample = self
            .subscriber
            .receive()
            .map_err(|e| anyhow::anyhow!("iceoryx2 receive: {e:?}"))?;
        Ok(sample.map(|s| *s.payload()))
    }

    /// Sleeps until a message comes (or `timeout`), and takes it. A wake-up may be left
    /// over from a message already taken, so it waits again until one is there.
    fn wait(&self, timeout: Duration) -> anyhow::Result<Option<HopMessage>> {
        let deadline = Instant::now() + timeout;
        loop {
            if let Some(m) = self.take()? {
                return Ok(Some(m));
            }
            let left = deadline.saturating_duration_since(Instant::now());
            if left.is_zero() {
                return Ok(None);
            }
            bus::wait_for_wakeup(&self.listener, left)?;
        }
    }
}

fn iceoryx2_hops(instance: &str, round_trips: usize) -> anyhow::Result<Distribution> {
    // Both sides' ports exist before the first message, so none is lost.
    let ports_ready = Barrier::new(2);
    let done = AtomicBool::new(false);
    thread::scope(|scope| {
        let echo = scope.spawn(|| -> anyhow::Result<()> {
            let side = Side::open(instance, "bench-pong", PONG, PING);
            ports_ready.wait();
            let side = side?;
            while !done.load(Ordering::Relaxed) {
                if let Some(m) = side.wait(STOP_POLL)? {
                    side.send(m)?;
                }
            }
            Ok(())
        });
        let pinger = scope.spawn(|| -> anyhow::Result<Distribution> {
            let side = Side::open(instance, "bench-ping", PING, PONG);
            ports_ready.wait();
            let result = side.map_err(anyhow::Error::from).and_then(|side| {
                time_round_trips(round_trips, || {
                    side.send(HopMessage {
                        bytes: [0x5A; MESSAGE_LEN],
                    })?;
                    match side.wait(REPLY_TIMEOUT)? {
                        Some(_) => Ok(()),
                        None => bail!("no iceoryx2 reply within {REPLY_TIMEOUT:?}"),
                    }
                })
            });
            done.store(true, Ordering::Relaxed);
            result
        });
        let hops = join(pinger)?;
        // The echo's failure explains a missing reply best.
        join(echo)??;
        hops
    })
}

fn unix_socket_hops(round_trips: usize) -> anyhow::Result<Distribution> {
    let (mut near, mut far) = UnixStream::pair().context("cannot create a Unix socket pair")?;
    near.set_read_timeout(Some(REPLY_TIMEOUT))?;
    thread::scope(|scope| {
        // Echoes until the other end closes.
        let echo = scope.spawn(move || -> std::io::Result<()> {
            let mut buf = [0u8; MESSAGE_LEN];
            loop {
                match far.read_exact(&mut buf) {
                    Ok(()) => far.write_all(&buf)?,
                    Err(e) if e.kind() == std::io::ErrorKind::UnexpectedEof => return Ok(()),
                    Err(e) => return Err(e),
                }
            }
        });
        let message = [0x5Au8; MESSAGE_LEN];
        let mut reply = [0u8; MESSAGE_LEN];
        let hops = time_round_trips(round_trips, || {
            near.write_all(&message)?;
            near.read_exact(&mut reply)?;
            Ok(())
        });
        drop(near);
        join(echo)?.context("Unix socket echo")?;
        hops
    })
}

/// Runs `round_trip` for the warm-up, then `n` more times, each timed; returns half of each.
fn time_round_trips(
    n: usize,
    mut round_trip: impl FnMut() -> anyhow::Result<()>,
) -> anyhow::Result<Distribution> {
    for _ in 0..WARM_UP {
        round_trip()?;
    }
    let mut one_way = Recorder::with_capacity(n);
    for _ in 0..n {
        let start = Instant::now();
        round_trip()?;
        one_way.record(elapsed_ns(start) / 2);
    }
    Ok(one_way.into_distribution())
}

fn join<T>(handle: thread::ScopedJoinHandle<'_, T>) -> anyhow::Result<T> {
    handle
        .join()
        .map_err(|_| anyhow::anyhow!("a benchmark thread panicked"))
}
