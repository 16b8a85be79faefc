//! The TCP gateway transport: raw telegrams of fixed length in lockstep, one reply per
//! request, as the public SRCI TCP/IP bridge and the open Python client use it.

use std::io::{self, Read, Write};
use std::net::{SocketAddr, TcpStream, ToSocketAddrs};
use std::time::{Duration, Instant};

/// A reply later than this closes the connection (the open client's response timeout).
pub const DEFAULT_RESPONSE_TIMEOUT: Duration = Duration::from_millis(100);

/// Round trips are counted in 1 µs buckets up to this; longer ones go to an overflow bucket.
const HISTOGRAM_US: usize = 100_000;

/// A failed exchange.
#[derive(Debug, thiserror::Error)]
pub enum TransportError {
    #[error("cannot resolve {addr}: {source}")]
    Resolve { addr: String, source: io::Error },
    #[error("cannot connect to {addr}: {source}")]
    Connect { addr: String, source: io::Error },
    #[error("no reply within {0:?}; connection closed")]
    Timeout(Duration),
    #[error("the robot closed the connection")]
    PeerClosed,
    #[error("the connection is closed")]
    Closed,
    #[error("telegram exchange failed: {0}")]
    Io(#[from] io::Error),
}

/// Carries one PLC telegram to the robot and its reply back.
pub trait Transport {
    /// Sends all of `tx` and fills all of `rx` with the reply.
    fn exchange(&mut self, tx: &[u8], rx: &mut [u8]) -> Result<(), TransportError>;

    /// Round-trip statistics of the exchanges so far.
    fn round_trips(&self) -> RoundTripSummary;
}

/// A borrowed transport, so that the caller keeps it after a run.
impl<T: Transport + ?Sized> Transport for &mut T {
    fn exchange(&mut self, tx: &[u8], rx: &mut [u8]) -> Result<(), TransportError> {
        (**self).exchange(tx, rx)
    }

    fn round_trips(&self) -> RoundTripSummary {
        (**self).round_trips()
    }
}

/// Round-trip times collected in a fixed histogram (allocated once).
#[derive(Debug, Clone)]
pub struct RoundTripStats {
    buckets: Vec<u32>,
    overflow: u64,
    count: u64,
    min: Duration,
    max: Duration,
}

impl Default for RoundTripStats {
    fn default() -> Self {
        Self::new()
    }
}

/// Summary of round-trip times.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct RoundTripSummary {
    pub count: u64,
    pub min: Duration,
    pub median: Duration,
    pub p99: Duration,
    pub max: Duration,
}

impl RoundTripStats {
    pub fn new() -> Self {
        Self {
            buckets: vec![0; HISTOGRAM_US],
            overflow: 0,
            count: 0,
            min: Duration::MAX,
            max: Duration::ZERO,
        }
    }

    pub fn record(&mut self, rtt: Duration) {
        let us = usize::try_from(rtt.as_micros()).unwrap_or(usize::MAX);
        match self.buckets.get_mut(us) {
            Some(b) => *b = b.saturating_add(1),
            None => self.overflow += 1,
        }
        self.count += 1;
        self.min = self.min.min(rtt);
        self.max = self.max.max(rtt);
    }

    /// Median and 99th percentile to the microsecond, exact minimum and maximum.
    pub fn summary(&self) -> RoundTripSummary {
        if self.count == 0 {
            return RoundTripSummary::default();
        }
        RoundTripSummary {
            count: self.count,
            min: self.min,
            median: self.quantile(0.5),
            p99: self.quantile(0.99),
            max: self.max,
        }
    }

    fn quantile(&self, q: f64) -> Duration {
        // Rank of the quantile among `count` samples (1-based, rounded up).
        let rank = ((self.count as f64) * q).ceil().max(1.0) as u64;
        let mut seen = 0u64;
        for (us, &n) in self.buckets.iter().enumerate() {
            seen += u64::from(n);
            if seen >= rank {
                return Duration::from_micros(us as u64);
            }
        }
        self.max
    }
}

/// The TCP gateway transport.
#[derive(Debug)]
pub struct TcpTransport {
    stream: Option<TcpStream>,
    peer: SocketAddr,
    response_timeout: Duration,
    stats: RoundTripStats,
}

impl TcpTransport {
    /// Connects to `addr` ("host:port") with TCP_NODELAY.
    pub fn connect(
        addr: &str,
        connect_timeout: Duration,
        response_timeout: Duration,
    ) -> Result<Self, TransportError> {
        let addrs = addr
            .to_socket_addrs()
            .map_err(|source| TransportError::Resolve {
                addr: addr.to_owned(),
                source,
            })?;
        let mut last = io::Error::new(io::ErrorKind::NotFound, "no address");
        for peer in addrs {
            match TcpStream::connect_timeout(&peer, connect_timeout) {
                Ok(stream) => {
                    stream.set_nodelay(true)?;
                    stream.set_write_timeout(Some(response_timeout))?;
                    tracing::info!(%peer, "connected to the SRCI gateway");
                    return Ok(Self {
                        stream: Some(stream),
                        peer,
                        response_timeout,
                        stats: RoundTripStats::new(),
                    });
                }
                Err(e) => last = e,
            }
        }
        Err(TransportError::Connect {
            addr: addr.to_owned(),
            source: last,
        })
    }

    /// The robot's address.
    pub fn peer(&self) -> SocketAddr {
        self.peer
    }

    fn close(&mut self) {
        if let Some(stream) = self.stream.take() {
            // Already failing; nothing more to do if the shutdown fails too.
            let _ = stream.shutdown(std::net::Shutdown::Both);
        }
    }

    fn read_reply(
        stream: &mut TcpStream,
        rx: &mut [u8],
        deadline: Instant,
        timeout: Duration,
    ) -> Result<(), TransportError> {
        let mut got = 0;
        while got < rx.len() {
            let remaining = deadline.saturating_duration_since(Instant::now());
            if remaining.is_zero() {
                return Err(TransportError::Timeout(timeout));
            }
            stream.set_read_timeout(Some(remaining))?;
            match stream.read(&mut rx[got..]) {
                Ok(0) => return Err(TransportError::PeerClosed),
                Ok(n) => got += n,
                Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
                Err(e)
                    if matches!(
                        e.kind(),
                        io::ErrorKind::WouldBlock | io::ErrorKind::TimedOut
                    ) =>
                {
                    return Err(TransportError::Timeout(timeout));
                }
                Err(e) => return Err(e.into()),
            }
        }
        Ok(())
    }
}

impl Transport for TcpTransport {
    fn exchange(&mut self, tx: &[u8], rx: &mut [u8]) -> Result<(), TransportError> {
        let timeout = self.response_timeout;
        let stream = self.stream.as_mut().ok_or(TransportError::Closed)?;
        let start = Instant::now();
        let result = stream
            .write_all(tx)
            .map_err(TransportError::from)
            .and_then(|()| Self::read_reply(stream, rx, start + timeout, timeout));
        match result {
            Ok(()) => {
                self.stats.record(start.elapsed());
                Ok(())
            }
            Err(e) => {
                // A late or partial reply would shift every later telegram: drop the link.
                tracing::warn!(%e, peer = %self.peer, "closing the gateway connection");
                self.close();
                Err(e)
            }
        }
    }

    fn round_trips(&self) -> RoundTripSummary {
        self.stats.summary()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::net::TcpListener;

    #[test]
    fn statistics_of_known_samples() {
        let mut s = RoundTripStats::new();
        for us in 1..=100 {
            s.record(Duration::from_micros(us));
        }
        s.record(Duration::from_secs(1));
        let r = s.summary();
        assert_eq!(r.count, 101);
        assert_eq!(r.min, Duration::from_micros(1));
        assert_eq!(r.median, Duration::from_micros(51));
        assert_eq!(r.p99, Duration::from_micros(100));
        assert_eq!(r.max, Duration::from_secs(1));
    }

    /// Loopback only: an echo peer answers the first telegram, then stays silent.
    #[test]
    fn late_reply_closes_the_connection() {
        let listener = TcpListener::bind("127.0.0.1:0").unwrap();
        let addr = listener.local_addr().unwrap().to_string();
        let peer = std::thread::spawn(move || {
            let (mut s, _) = listener.accept().unwrap();
            let mut buf = [0u8; 64];
            s.read_exact(&mut buf).unwrap();
            s.write_all(&buf).unwrap();
            s.read_exact(&mut buf).unwrap();
            // No reply; wait for the client to give up.
            let _ = s.read(&mut buf);
        });
        let timeout = Duration::from_millis(30);
        let mut t = TcpTransport::connect(&addr, Duration::from_secs(1), timeout).unwrap();
        let tx = [7u8; 64];
        let mut rx = [0u8; 64];
        t.exchange(&tx, &mut rx).unwrap();
        assert_eq!(rx, tx);
        assert!(matches!(
            t.exchange(&tx, &mut rx),
            Err(TransportError::Timeout(_))
        ));
        assert!(matches!(
            t.exchange(&tx, &mut rx),
            Err(TransportError::Closed)
        ));
        assert_eq!(t.round_trips().count, 1);
        peer.join().unwrap();
    }
}
