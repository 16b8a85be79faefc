//! Link changes as the kernel announces them: an rtnetlink socket subscribed to the link
//! group (RTMGRP_LINK), polled with the device's sockets, so that the port's link values
//! are read again when a link goes up or down rather than on every cycle. Subscribing
//! needs no privilege.

use std::io;
use std::os::fd::{AsFd, AsRawFd, BorrowedFd, OwnedFd};

use super::sys;

/// The multicast group of link changes (linux/rtnetlink.h).
const RTMGRP_LINK: u32 = 1;
/// Room for a batch of link messages; the content is not read, only that one came.
const BUFFER_LEN: usize = 8192;

/// The link monitor cannot be set up.
#[derive(Debug, thiserror::Error)]
#[error("rtnetlink link monitor: {0}")]
pub struct LinkMonitorError(#[from] io::Error);

/// A non-blocking rtnetlink socket that receives every link change of the host's
/// namespace.
#[derive(Debug)]
pub struct LinkMonitor {
    fd: OwnedFd,
    buffer: Vec<u8>,
}

impl LinkMonitor {
    /// Opens the socket and joins the link group.
    pub fn open() -> Result<Self, LinkMonitorError> {
        // Non-blocking: it is read only after poll(2) said so, until it is empty.
        let fd = sys::route_socket(libc::SOCK_NONBLOCK)?;
        // SAFETY: sockaddr_nl is plain data; all zeros is a valid value.
        let mut address: libc::sockaddr_nl = unsafe { std::mem::zeroed() };
        address.nl_family = libc::AF_NETLINK as libc::sa_family_t;
        address.nl_groups = RTMGRP_LINK;
        // SAFETY: address is a valid sockaddr_nl of the given size.
        let bound = unsafe {
            libc::bind(
                fd.as_raw_fd(),
                (&address as *const libc::sockaddr_nl).cast(),
                size_of::<libc::sockaddr_nl>() as libc::socklen_t,
            )
        };
        if bound < 0 {
            return Err(io::Error::last_os_error().into());
        }
        Ok(Self {
            fd,
            buffer: vec![0; BUFFER_LEN],
        })
    }

    /// Reads every pending message; true when a link changed since the last call.
    pub fn changed(&mut self) -> Result<bool, LinkMonitorError> {
        let mut changed = false;
        loop {
            // SAFETY: buffer is valid for writes of its length.
            let received = unsafe {
                libc::recv(
                    self.fd.as_raw_fd(),
                    self.buffer.as_mut_ptr().cast(),
                    self.buffer.len(),
                    0,
                )
            };
            if received >= 0 {
                changed = true;
                continue;
            }
            let error = io::Error::last_os_error();
            match error.kind() {
                io::ErrorKind::WouldBlock => return Ok(changed),
                io::ErrorKind::Interrupted => continue,
                // The kernel dropped messages (ENOBUFS): something changed.
                _ if error.raw_os_error() == Some(libc::ENOBUFS) => changed = true,
                _ => return Err(error.into()),
            }
        }
    }
}

impl AsFd for LinkMonitor {
    fn as_fd(&self) -> BorrowedFd<'_> {
        self.fd.as_fd()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_monitor_opens_without_privilege_and_reads_without_blocking() {
        let mut monitor = LinkMonitor::open().unwrap();
        // Whether another test changed a link meanwhile is not known; the read returns.
        monitor.changed().unwrap();
        assert!(monitor.as_fd().as_raw_fd() >= 0);
    }
}
