//! The port's Ethernet link as Linux reports it: `/sys/class/net/<if>/{speed,duplex,operstate}`,
//! handed to the pure [`PortLink::from_sysfs`]. A file that cannot be read (a veth or a
//! link without carrier has no speed) counts as unknown, which the pure side maps to its
//! documented default.

use std::path::Path;

use crate::cm::pd_real::PortLink;

/// Where Linux describes its network interfaces.
const SYSFS_NET: &str = "/sys/class/net";

/// The link of `interface` now.
pub fn read_port_link(interface: &str) -> PortLink {
    let folder = Path::new(SYSFS_NET).join(interface);
    let read = |file: &str| std::fs::read_to_string(folder.join(file)).unwrap_or_default();
    PortLink::from_sysfs(&read("speed"), &read("duplex"), &read("operstate"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_loopback_interface_reads_and_a_missing_one_is_down() {
        // lo has no speed (EINVAL) and the operstate "unknown": not up.
        let lo = read_port_link("lo");
        assert_eq!(lo, PortLink::default());
        let missing = read_port_link("no-such-interface0");
        assert_eq!(missing, PortLink::default());
    }
}
