//! The system calls that more than one link module makes: the index of a named
//! interface, and an rtnetlink socket (the route family of netlink), each in one place so
//! that its checks and flags are the same for every caller.

use std::ffi::CStr;
use std::io;
use std::os::fd::{FromRawFd, OwnedFd};

/// The kernel's index of the interface `name`; the error is the kernel's (ENODEV when
/// there is no such interface).
pub(crate) fn interface_index(name: &CStr) -> io::Result<u32> {
    // SAFETY: name is a valid NUL-terminated string.
    match unsafe { libc::if_nametoindex(name.as_ptr()) } {
        0 => Err(io::Error::last_os_error()),
        index => Ok(index),
    }
}

/// A new NETLINK_ROUTE socket, closed on exec; `flags` adds socket type flags (say
/// `SOCK_NONBLOCK`).
pub(crate) fn route_socket(flags: libc::c_int) -> io::Result<OwnedFd> {
    // SAFETY: plain socket creation; the result is checked.
    let raw = unsafe {
        libc::socket(
            libc::AF_NETLINK,
            libc::SOCK_RAW | libc::SOCK_CLOEXEC | flags,
            libc::NETLINK_ROUTE,
        )
    };
    if raw < 0 {
        return Err(io::Error::last_os_error());
    }
    // SAFETY: raw is a fresh descriptor owned by nobody else.
    Ok(unsafe { OwnedFd::from_raw_fd(raw) })
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::os::fd::AsRawFd;

    #[test]
    fn the_loopback_has_an_index_and_a_missing_interface_none() {
        assert!(interface_index(c"lo").unwrap() > 0);
        let error = interface_index(c"rc-no-such-if").unwrap_err();
        assert_eq!(error.raw_os_error(), Some(libc::ENODEV), "{error}");
    }

    #[test]
    fn the_route_socket_carries_the_flags_asked_for() {
        let nonblocking = |fd: &OwnedFd| {
            // SAFETY: fd is an open descriptor.
            let status = unsafe { libc::fcntl(fd.as_raw_fd(), libc::F_GETFL) };
            status & libc::O_NONBLOCK != 0
        };
        let close_on_exec = |fd: &OwnedFd| {
            // SAFETY: fd is an open descriptor.
            let flags = unsafe { libc::fcntl(fd.as_raw_fd(), libc::F_GETFD) };
            flags & libc::FD_CLOEXEC != 0
        };
        let blocking = route_socket(0).unwrap();
        assert!(!nonblocking(&blocking) && close_on_exec(&blocking));
        let polled = route_socket(libc::SOCK_NONBLOCK).unwrap();
        assert!(nonblocking(&polled) && close_on_exec(&polled));
    }
}
