//! The thin shell: a raw Ethernet socket on a named interface, the DCP service that feeds
//! it to the pure [`crate::dcp::responder`], the file behind the permanent store, the
//! interface's IPv4 address that DCP sets ([`address`] over [`netlink`]), the port's link
//! ([`port_link`], read again when [`link_monitor`] sees a link change), and the IO device
//! that adds PNIO-CM over UDP and the cyclic exchange; [`veth`] is the link without
//! hardware that the tests and the benchmark run on.

pub mod address;
pub mod dcp_service;
pub mod file_store;
pub mod io_device;
pub mod link_monitor;
pub mod netlink;
pub mod port_link;
pub mod raw_socket;
mod sys;
pub mod veth;
