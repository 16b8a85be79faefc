//! The thin shell: a raw Ethernet socket on a named interface, the DCP service that feeds
//! it to the pure [`crate::dcp::responder`], the file behind the permanent store, the
//! interface's IPv4 address that DCP sets ([`address`] over [`netlink`]), and the
//! IO device that adds PNIO-CM over UDP and the cyclic exchange; [`veth`] is the link without
//! hardware that the tests and the benchmark run on.

pub mod address;
pub mod dcp_service;
pub mod file_store;
pub mod io_device;
pub mod netlink;
pub mod raw_socket;
pub mod veth;
