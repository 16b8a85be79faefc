//! The TCP side of the gateway transport: one listening socket and at most one client,
//! polled together, so a new client, incoming bytes and shutdown are noticed on one thread.

use std::io::{self, Read, Write};
use std::net::{SocketAddr, TcpListener, TcpStream};
use std::os::fd::AsRawFd;
use std::time::Duration;

use crate::FieldbusError;
use crate::assembler::TelegramAssembler;

/// A reply that cannot be written within this time means the client stopped reading.
const WRITE_TIMEOUT: Duration = Duration::from_millis(20);
/// Guards the read after a readiness report; a read never waits longer than this.
const READ_TIMEOUT: Duration = Duration::from_millis(2);

/// Why a client connection ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Disconnect {
    /// The client closed the connection.
    Closed,
    /// Reading or writing failed.
    Failed(io::ErrorKind),
}

/// A client connection that ended, with the bytes of a telegram it left unfinished.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Ended {
    pub connection: u32,
    pub reason: Disconnect,
    pub partial_bytes: usize,
}

/// What one [`TcpLink::poll`] found.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Activity {
    /// Nothing within the timeout, or only part of a telegram.
    Idle,
    /// A client connected; `replaced` is the connection it closed.
    Connected {
        connection: u32,
        peer: SocketAddr,
        replaced: Option<u32>,
    },
    /// The client went away.
    Disconnected(Ended),
    /// A complete telegram is waiting in [`TcpLink::take_telegram`].
    Telegram,
}

struct Client {
    stream: TcpStream,
    connection: u32,
}

/// The listening socket, the current client and its partial telegram.
pub(crate) struct TcpLink {
    listener: TcpListener,
    client: Option<Client>,
    /// Number of the newest connection (0 = none yet).
    connections: u32,
    assembler: TelegramAssembler,
}

impl TcpLink {
    /// Listens on `addr` for clients sending telegrams of `assembler.length()` bytes.
    pub(crate) fn bind(addr: &str, assembler: TelegramAssembler) -> Result<Self, FieldbusError> {
        let bind_error = |source| FieldbusError::Bind {
            addr: addr.to_string(),
            source,
        };
        let listener = TcpListener::bind(addr).map_err(bind_error)?;
        listener.set_nonblocking(true).map_err(bind_error)?;
        Ok(Self {
            listener,
            client: None,
            connections: 0,
            assembler,
        })
    }

    /// Length of a PLC→robot telegram.
    pub(crate) fn request_length(&self) -> usize {
        self.assembler.length()
    }

    pub(crate) fn local_addr(&self) -> io::Result<SocketAddr> {
        self.listener.local_addr()
    }

    /// Waits up to `timeout` for a new client or for bytes of the current one.
    pub(crate) fn poll(&mut self, timeout: Duration) -> Result<Activity, FieldbusError> {
        let mut fds = [
            libc::pollfd {
                fd: self.listener.as_raw_fd(),
                events: libc::POLLIN,
                revents: 0,
            },
            libc::pollfd {
                // A negative descriptor is skipped by poll(2).
                fd: self.client.as_ref().map_or(-1, |c| c.stream.as_raw_fd()),
                events: libc::POLLIN,
                revents: 0,
            },
        ];
        let timeout_ms = libc::c_int::try_from(timeout.as_millis()).unwrap_or(libc::c_int::MAX);
        // SAFETY: `fds` is a valid array of two pollfd that outlives the call.
        let ready = unsafe { libc::poll(fds.as_mut_ptr(), fds.len() as libc::nfds_t, timeout_ms) };
        if ready < 0 {
            let err = io::Error::last_os_error();
            return match err.kind() {
                io::ErrorKind::Interrupted => Ok(Activity::Idle),
                _ => Err(FieldbusError::Poll(err)),
            };
        }
        // A new client first: it replaces the current one, whose pending bytes no longer matter.
        if fds[0].revents != 0
            && let Some(activity) = self.accept()
        {
            return Ok(activity);
        }
        if fds[1].revents != 0 {
            return Ok(self.read());
        }
        Ok(Activity::Idle)
    }

    fn accept(&mut self) -> Option<Activity> {
        let (stream, peer) = match self.listener.accept() {
            Ok(accepted) => accepted,
            Err(e) if e.kind() == io::ErrorKind::WouldBlock => return None,
            Err(e) => {
                tracing::warn!(error = %e, "accepting a fieldbus client failed");
                return None;
            }
        };
        if let Err(e) = configure(&stream) {
            tracing::warn!(%peer, error = %e, "cannot configure the fieldbus client socket; closed");
            return None;
        }
        self.connections = self.connections.wrapping_add(1);
        self.assembler.clear();
        let replaced = self
            .client
            .replace(Client {
                stream,
                connection: self.connections,
            })
            .map(|old| old.connection);
        Some(Activity::Connected {
            connection: self.connections,
            peer,
            replaced,
        })
    }

    fn read(&mut self) -> Activity {
        let Some(client) = self.client.as_mut() else {
            return Activity::Idle;
        };
        match client.stream.read(self.assembler.unfilled()) {
            Ok(0) => Activity::Disconnected(self.drop_client(Disconnect::Closed)),
            Ok(n) if self.assembler.fill(n) => Activity::Telegram,
            Ok(_) => Activity::Idle,
            Err(e)
                if matches!(
                    e.kind(),
                    io::ErrorKind::WouldBlock
                        | io::ErrorKind::TimedOut
                        | io::ErrorKind::Interrupted
                ) =>
            {
                Activity::Idle
            }
            Err(e) => Activity::Disconnected(self.drop_client(Disconnect::Failed(e.kind()))),
        }
    }

    /// The completed telegram and the connection it came from; the next read starts anew.
    pub(crate) fn take_telegram(&mut self) -> Option<(u32, &[u8])> {
        let connection = self.client.as_ref()?.connection;
        self.assembler.take().map(|t| (connection, t))
    }

    /// Sends `bytes` to the client of `connection`; nothing if that client is gone already.
    /// A failed write ends the connection.
    pub(crate) fn reply(&mut self, connection: u32, bytes: &[u8]) -> Result<(), Ended> {
        let Some(client) = self.client.as_mut().filter(|c| c.connection == connection) else {
            return Ok(());
        };
        client
            .stream
            .write_all(bytes)
            .map_err(|e| self.drop_client(Disconnect::Failed(e.kind())))
    }

    /// Closes the current client, if any, and returns its connection number.
    pub(crate) fn close(&mut self) -> Option<u32> {
        self.assembler.clear();
        self.client.take().map(|c| c.connection)
    }

    fn drop_client(&mut self, reason: Disconnect) -> Ended {
        let partial_bytes = self.assembler.buffered();
        Ended {
            connection: self.close().unwrap_or(self.connections),
            reason,
            partial_bytes,
        }
    }
}

/// Lockstep with a cycle master: every telegram must leave at once (no Nagle delay), and no
/// read or write may stall the loop.
fn configure(stream: &TcpStream) -> io::Result<()> {
    stream.set_nonblocking(false)?;
    stream.set_nodelay(true)?;
    stream.set_read_timeout(Some(READ_TIMEOUT))?;
    stream.set_write_timeout(Some(WRITE_TIMEOUT))
}
