//! An AF_PACKET raw socket bound to one interface (needs root or CAP_NET_RAW).
//!
//! It receives every EtherType (`ETH_P_ALL`): where the NIC does not strip the 802.1Q tag,
//! a socket bound to 0x8892 alone would miss tagged PROFINET frames. It joins the DCP
//! Identify multicast group so that the NIC passes those frames up.

use std::ffi::CString;
use std::io;
use std::os::fd::{AsRawFd, FromRawFd, OwnedFd};
use std::time::Duration;

use super::sys;
use crate::ethernet::MacAddress;

/// Opening or using the raw socket failed.
#[derive(Debug, thiserror::Error)]
pub enum RawSocketError {
    /// The interface name cannot be passed to the kernel.
    #[error("interface name {0:?} contains a NUL byte")]
    InterfaceName(String),
    /// No interface of that name.
    #[error("no network interface {name}: {source}")]
    NoInterface {
        /// The name.
        name: String,
        /// What the kernel said.
        source: io::Error,
    },
    /// A socket call failed (creation needs root or CAP_NET_RAW).
    #[error("{call} on the raw socket of {interface} failed: {source}")]
    Call {
        /// The system call.
        call: &'static str,
        /// The interface.
        interface: String,
        /// What the kernel said.
        source: io::Error,
    },
}

/// A raw socket on one interface.
#[derive(Debug)]
pub struct RawSocket {
    fd: OwnedFd,
    interface: String,
    mac: MacAddress,
}

impl RawSocket {
    /// Opens a raw socket on `interface`, joined to the DCP Identify multicast group.
    pub fn open(interface: &str) -> Result<Self, RawSocketError> {
        let c_name = CString::new(interface)
            .map_err(|_| RawSocketError::InterfaceName(interface.to_owned()))?;
        let index =
            sys::interface_index(&c_name).map_err(|source| RawSocketError::NoInterface {
                name: interface.to_owned(),
                source,
            })?;
        let index = i32::try_from(index).map_err(|_| RawSocketError::NoInterface {
            name: interface.to_owned(),
            source: io::Error::from(io::ErrorKind::InvalidInput),
        })?;
        let call = |call: &'static str| {
            let source = io::Error::last_os_error();
            RawSocketError::Call {
                call,
                interface: interface.to_owned(),
                source,
            }
        };
        let all = (libc::ETH_P_ALL as u16).to_be();
        // SAFETY: plain socket creation; the result is checked.
        let raw = unsafe {
            libc::socket(
                libc::AF_PACKET,
                libc::SOCK_RAW | libc::SOCK_CLOEXEC,
                i32::from(all),
            )
        };
        if raw < 0 {
            return Err(call("socket(AF_PACKET)"));
        }
        // SAFETY: raw is a fresh descriptor owned by nobody else.
        let fd = unsafe { OwnedFd::from_raw_fd(raw) };
        // SAFETY: sockaddr_ll is plain data; all-zero is a valid value.
        let mut address: libc::sockaddr_ll = unsafe { std::mem::zeroed() };
        address.sll_family = libc::AF_PACKET as u16;
        address.sll_protocol = all;
        address.sll_ifindex = index;
        // SAFETY: address is a valid sockaddr_ll of the given size.
        let bound = unsafe {
            libc::bind(
                fd.as_raw_fd(),
                (&address as *const libc::sockaddr_ll).cast(),
                size_of::<libc::sockaddr_ll>() as libc::socklen_t,
            )
        };
        if bound < 0 {
            return Err(call("bind"));
        }
        let mut membership = libc::packet_mreq {
            mr_ifindex: index,
            mr_type: libc::PACKET_MR_MULTICAST as u16,
            mr_alen: 6,
            mr_address: [0; 8],
        };
        membership.mr_address[..6].copy_from_slice(&MacAddress::DCP_IDENTIFY.0);
        // SAFETY: membership is a valid packet_mreq of the given size.
        let joined = unsafe {
            libc::setsockopt(
                fd.as_raw_fd(),
                libc::SOL_PACKET,
                libc::PACKET_ADD_MEMBERSHIP,
                (&membership as *const libc::packet_mreq).cast(),
                size_of::<libc::packet_mreq>() as libc::socklen_t,
            )
        };
        if joined < 0 {
            return Err(call("setsockopt(PACKET_ADD_MEMBERSHIP)"));
        }
        let mac = hardware_address(&fd, &c_name).map_err(|source| RawSocketError::Call {
            call: "ioctl(SIOCGIFHWADDR)",
            interface: interface.to_owned(),
            source,
        })?;
        Ok(Self {
            fd,
            interface: interface.to_owned(),
            mac,
        })
    }

    /// The interface's MAC address.
    pub fn mac(&self) -> MacAddress {
        self.mac
    }

    /// The interface's name.
    pub fn interface(&self) -> &str {
        &self.interface
    }

    /// Waits up to `timeout` for a frame another host sent; returns its length in `buf`, or
    /// `None` when none came. Frames this host sends itself are skipped.
    pub fn receive(
        &self,
        buf: &mut [u8],
        timeout: Duration,
    ) -> Result<Option<usize>, RawSocketError> {
        let mut poll = libc::pollfd {
            fd: self.fd.as_raw_fd(),
            events: libc::POLLIN,
            revents: 0,
        };
        let millis = i32::try_from(timeout.as_millis()).unwrap_or(i32::MAX);
        // SAFETY: one valid pollfd.
        let ready = unsafe { libc::poll(&mut poll, 1, millis) };
        if ready < 0 {
            let source = io::Error::last_os_error();
            if source.kind() == io::ErrorKind::Interrupted {
                return Ok(None);
            }
            return Err(self.failed("poll", source));
        }
        if ready == 0 {
            return Ok(None);
        }
        // SAFETY: sockaddr_ll is plain data; all-zero is a valid value.
        let mut from: libc::sockaddr_ll = unsafe { std::mem::zeroed() };
        let mut from_len = size_of::<libc::sockaddr_ll>() as libc::socklen_t;
        // SAFETY: buf and from are valid for writes of the given lengths.
        let received = unsafe {
            libc::recvfrom(
                self.fd.as_raw_fd(),
                buf.as_mut_ptr().cast(),
                buf.len(),
                libc::MSG_DONTWAIT,
                (&mut from as *mut libc::sockaddr_ll).cast(),
                &mut from_len,
            )
        };
        if received < 0 {
            let source = io::Error::last_os_error();
            if matches!(
                source.kind(),
                io::ErrorKind::WouldBlock | io::ErrorKind::Interrupted
            ) {
                return Ok(None);
            }
            return Err(self.failed("recvfrom", source));
        }
        if from.sll_pkttype == libc::PACKET_OUTGOING {
            return Ok(None);
        }
        // A frame longer than buf is cut to buf's length by the kernel.
        Ok(Some((received as usize).min(buf.len())))
    }

    /// Sends one complete frame.
    pub fn send(&self, frame: &[u8]) -> Result<(), RawSocketError> {
        // SAFETY: frame is valid for reads of its length.
        let sent =
            unsafe { libc::send(self.fd.as_raw_fd(), frame.as_ptr().cast(), frame.len(), 0) };
        if sent < 0 {
            return Err(self.failed("send", io::Error::last_os_error()));
        }
        Ok(())
    }

    fn failed(&self, call: &'static str, source: io::Error) -> RawSocketError {
        RawSocketError::Call {
            call,
            interface: self.interface.clone(),
            source,
        }
    }
}

/// The MAC address of the interface `name`.
fn hardware_address(fd: &OwnedFd, name: &CString) -> io::Result<MacAddress> {
    // SAFETY: ifreq is plain data; all-zero is a valid value.
    let mut request: libc::ifreq = unsafe { std::mem::zeroed() };
    let bytes = name.as_bytes();
    if bytes.len() >= request.ifr_name.len() {
        return Err(io::Error::from(io::ErrorKind::InvalidInput));
    }
    for (slot, &byte) in request.ifr_name.iter_mut().zip(bytes) {
        *slot = byte as libc::c_char;
    }
    // SAFETY: request is a valid ifreq with a NUL-terminated name.
    if unsafe { libc::ioctl(fd.as_raw_fd(), libc::SIOCGIFHWADDR, &mut request) } < 0 {
        return Err(io::Error::last_os_error());
    }
    // SAFETY: SIOCGIFHWADDR filled the hwaddr member of the union.
    let data = unsafe { request.ifr_ifru.ifru_hwaddr.sa_data };
    let mut mac = [0u8; 6];
    for (slot, &byte) in mac.iter_mut().zip(&data) {
        *slot = byte as u8;
    }
    Ok(MacAddress(mac))
}

impl std::os::fd::AsFd for RawSocket {
    fn as_fd(&self) -> std::os::fd::BorrowedFd<'_> {
        self.fd.as_fd()
    }
}
