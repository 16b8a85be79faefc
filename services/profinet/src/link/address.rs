//! The station's IP parameter on the Linux interface, through rtnetlink (needs
//! CAP_NET_ADMIN): the interface's IPv4 addresses are replaced by the one DCP set, and a
//! default route goes via its gateway when it has one.
//!
//! A netlink socket of the process's own rather than `ip` from iproute2: no other program
//! on the product's machine, and errors come back as errno for the answer to the PLC.
//! Plain `libc` rather than the `rtnetlink` crate: that one is asynchronous (an executor in
//! the fieldbus process for four fixed messages), and the messages are few
//! ([`super::netlink`]).

use std::ffi::CString;
use std::io;
use std::os::fd::{AsRawFd, OwnedFd};
use std::time::Duration;

use super::netlink::{self, InterfaceAddress, Reply};
use super::sys;
use crate::dcp::station::{IpInterface, IpParameter};

/// Longest wait for the kernel's answer.
const REPLY_TIMEOUT: Duration = Duration::from_secs(1);
/// Room for one datagram of a dump.
const RECEIVE_BUFFER_LEN: usize = 16 * 1024;

/// Configuring the interface failed.
#[derive(Debug, thiserror::Error)]
pub enum AddressError {
    /// The process may not configure interfaces.
    #[error(
        "{operation} on {interface}: the fieldbus process lacks CAP_NET_ADMIN \
         (systemd: AmbientCapabilities=CAP_NET_ADMIN CAP_NET_RAW)"
    )]
    Capability {
        /// What was refused.
        operation: &'static str,
        /// The interface.
        interface: String,
    },
    /// Any other failure.
    #[error("{operation} on {interface}: {source}")]
    Failed {
        /// What failed.
        operation: &'static str,
        /// The interface.
        interface: String,
        /// What the kernel said.
        source: io::Error,
    },
}

/// The IPv4 configuration of one interface.
#[derive(Debug)]
pub struct InterfaceAddresses {
    interface: String,
    seq: u32,
}

impl InterfaceAddresses {
    /// The interface named `interface` (looked up at every change, so that an interface
    /// created again later is found).
    pub fn new(interface: &str) -> Self {
        Self {
            interface: interface.to_owned(),
            seq: 0,
        }
    }

    fn failed(&self, operation: &'static str, source: io::Error) -> AddressError {
        if source.raw_os_error() == Some(libc::EPERM) {
            AddressError::Capability {
                operation,
                interface: self.interface.clone(),
            }
        } else {
            AddressError::Failed {
                operation,
                interface: self.interface.clone(),
                source,
            }
        }
    }

    fn index(&self) -> Result<u32, AddressError> {
        let name = CString::new(self.interface.as_str())
            .map_err(|_| self.failed("look-up", io::ErrorKind::InvalidInput.into()))?;
        sys::interface_index(&name).map_err(|e| self.failed("look-up", e))
    }

    fn next_seq(&mut self) -> u32 {
        self.seq = self.seq.wrapping_add(1);
        self.seq
    }

    /// Sends one request and waits for its acknowledgement.
    fn request(
        &mut self,
        socket: &Netlink,
        operation: &'static str,
        build: impl FnOnce(u32) -> Vec<u8>,
    ) -> Result<(), AddressError> {
        let seq = self.next_seq();
        socket
            .send(&build(seq))
            .map_err(|e| self.failed(operation, e))?;
        loop {
            let replies = socket.receive().map_err(|e| self.failed(operation, e))?;
            for reply in replies {
                if let Reply::Ack { seq: acked, error } = reply
                    && acked == seq
                {
                    return match error {
                        0 => Ok(()),
                        errno => Err(self.failed(operation, io::Error::from_raw_os_error(-errno))),
                    };
                }
            }
        }
    }

    /// The IPv4 addresses of the interface `index`.
    fn addresses(
        &mut self,
        socket: &Netlink,
        index: u32,
    ) -> Result<Vec<InterfaceAddress>, AddressError> {
        let operation = "listing the IPv4 addresses";
        socket
            .send(&netlink::dump_addresses(self.next_seq()))
            .map_err(|e| self.failed(operation, e))?;
        let mut found = Vec::new();
        loop {
            let replies = socket.receive().map_err(|e| self.failed(operation, e))?;
            for reply in replies {
                match reply {
                    Reply::Addresses(addresses) => found.extend(
                        addresses
                            .into_iter()
                            .filter(|(of, _)| *of == index)
                            .map(|(_, address)| address),
                    ),
                    Reply::Done => return Ok(found),
                    Reply::Ack { error, .. } if error != 0 => {
                        let source = io::Error::from_raw_os_error(-error);
                        return Err(self.failed(operation, source));
                    }
                    Reply::Ack { .. } => {}
                }
            }
        }
    }
}

impl IpInterface for InterfaceAddresses {
    type Error = AddressError;

    fn apply(&mut self, ip: &IpParameter) -> Result<(), Self::Error> {
        let index = self.index()?;
        let socket = Netlink::open().map_err(|e| self.failed("opening rtnetlink", e))?;
        let wanted = ip
            .is_set()
            .then(|| InterfaceAddress::new(ip.address, ip.subnet_mask));
        for address in self.addresses(&socket, index)? {
            if Some(address) == wanted {
                continue;
            }
            let removed = self.request(&socket, "removing an IPv4 address", |seq| {
                netlink::delete_address(seq, index, address)
            });
            match removed {
                // A secondary address goes with its primary.
                Err(AddressError::Failed { ref source, .. })
                    if source.raw_os_error() == Some(libc::EADDRNOTAVAIL) => {}
                other => other?,
            }
        }
        let Some(wanted) = wanted else {
            tracing::info!(interface = self.interface, "IPv4 address removed");
            return Ok(());
        };
        self.request(&socket, "setting the IPv4 address", |seq| {
            netlink::add_address(seq, index, wanted)
        })?;
        if let Some(router) = ip.router() {
            self.request(&socket, "setting the default route", |seq| {
                netlink::default_route(seq, index, router)
            })?;
        }
        tracing::info!(
            interface = self.interface,
            address = %ip.address,
            subnet_mask = %ip.subnet_mask,
            gateway = %ip.gateway,
            "IPv4 address applied"
        );
        Ok(())
    }
}

/// A NETLINK_ROUTE socket.
struct Netlink {
    fd: OwnedFd,
}

impl Netlink {
    fn open() -> io::Result<Self> {
        // Blocking, with a receive timeout: a request waits for its acknowledgement.
        let fd = sys::route_socket(0)?;
        let timeout = libc::timeval {
            tv_sec: libc::time_t::try_from(REPLY_TIMEOUT.as_secs()).unwrap_or(1),
            tv_usec: 0,
        };
        // SAFETY: timeout is a valid timeval of the given size.
        let set = unsafe {
            libc::setsockopt(
                fd.as_raw_fd(),
                libc::SOL_SOCKET,
                libc::SO_RCVTIMEO,
                (&timeout as *const libc::timeval).cast(),
                size_of::<libc::timeval>() as libc::socklen_t,
            )
        };
        if set < 0 {
            return Err(io::Error::last_os_error());
        }
        Ok(Self { fd })
    }

    /// Sends `message` to the kernel (an unbound netlink socket's peer).
    fn send(&self, message: &[u8]) -> io::Result<()> {
        // SAFETY: message is valid for reads of its length.
        let sent = unsafe {
            libc::send(
                self.fd.as_raw_fd(),
                message.as_ptr().cast(),
                message.len(),
                0,
            )
        };
        if sent < 0 {
            return Err(io::Error::last_os_error());
        }
        Ok(())
    }

    /// The messages of the next datagram; a timeout is an error.
    fn receive(&self) -> io::Result<Vec<Reply>> {
        let mut buffer = vec![0u8; RECEIVE_BUFFER_LEN];
        // SAFETY: buffer is valid for writes of its length.
        let received = unsafe {
            libc::recv(
                self.fd.as_raw_fd(),
                buffer.as_mut_ptr().cast(),
                buffer.len(),
                0,
            )
        };
        if received < 0 {
            return Err(io::Error::last_os_error());
        }
        let length = usize::try_from(received).unwrap_or(0).min(buffer.len());
        netlink::parse(&buffer[..length])
            .map_err(|error| io::Error::new(io::ErrorKind::InvalidData, error))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_missing_interface_is_an_error_naming_it() {
        let mut interface = InterfaceAddresses::new("rc-no-such-if");
        let error = interface.apply(&IpParameter::UNSET).unwrap_err();
        assert!(error.to_string().contains("rc-no-such-if"), "{error}");
    }

    #[test]
    fn a_refused_operation_names_the_missing_capability() {
        let interface = InterfaceAddresses::new("eth1");
        let error = interface.failed(
            "setting the IPv4 address",
            io::Error::from_raw_os_error(libc::EPERM),
        );
        let text = error.to_string();
        assert!(
            text.contains("eth1") && text.contains("CAP_NET_ADMIN"),
            "{text}"
        );
        let other = interface.failed(
            "setting the IPv4 address",
            io::Error::from_raw_os_error(libc::EEXIST),
        );
        assert!(matches!(other, AddressError::Failed { .. }));
    }
}
