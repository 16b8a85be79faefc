//! A PROFINET link without hardware: two network namespaces, a PLC end and a device end,
//! joined by a veth pair, removed on drop. The network-namespace tests and the PROFINET row of
//! `rc bench latency` run the controller and the IO-controller on it. Needs root and `ip`
//! (iproute2).

use std::ffi::OsStr;
use std::process::{Command, Stdio};

/// Why the veth pair could not be set up.
#[derive(Debug, thiserror::Error)]
pub enum VethError {
    #[error("cannot run ip {args:?}: {source}")]
    Spawn {
        args: Vec<String>,
        source: std::io::Error,
    },
    #[error("ip {args:?}: {stderr}")]
    Failed { args: Vec<String>, stderr: String },
    #[error("no MAC address in {0:?}")]
    NoMac(String),
}

/// Two namespaces, PLC and device, joined by a veth pair; removed on drop.
#[derive(Debug)]
pub struct VethPair {
    /// The PLC's namespace and its end of the pair.
    pub plc: String,
    pub plc_interface: String,
    /// The device's namespace and its end of the pair.
    pub device: String,
    pub device_interface: String,
}

impl VethPair {
    /// Namespaces `{prefix}plc{pid}` and `{prefix}dev{pid}` with the interfaces
    /// `{prefix}va{pid}` (address `plc_address`, e.g. `192.168.77.1/24`) and `{prefix}vb{pid}`
    /// (`device_address`), both up, with the loopback up in both namespaces. Interface names
    /// have at most 15 characters: keep `prefix` to 3 or 4.
    pub fn create(
        prefix: &str,
        plc_address: &str,
        device_address: &str,
    ) -> Result<Self, VethError> {
        let id = std::process::id();
        // Built first, so that a failure below removes what was created.
        let pair = Self {
            plc: format!("{prefix}plc{id}"),
            plc_interface: format!("{prefix}va{id}"),
            device: format!("{prefix}dev{id}"),
            device_interface: format!("{prefix}vb{id}"),
        };
        ip(&["netns", "add", &pair.plc])?;
        ip(&["netns", "add", &pair.device])?;
        ip(&[
            "link",
            "add",
            &pair.plc_interface,
            "type",
            "veth",
            "peer",
            "name",
            &pair.device_interface,
        ])?;
        for (interface, namespace, address) in [
            (&pair.plc_interface, &pair.plc, plc_address),
            (&pair.device_interface, &pair.device, device_address),
        ] {
            ip(&["link", "set", interface, "netns", namespace])?;
            ip(&["-n", namespace, "link", "set", interface, "up"])?;
            ip(&["-n", namespace, "addr", "add", address, "dev", interface])?;
            // Helpers in a namespace (a gateway and its client) talk over its loopback.
            ip(&["-n", namespace, "link", "set", "lo", "up"])?;
        }
        Ok(pair)
    }

    /// `program` run inside `namespace` (`ip netns exec` replaces itself with it, so the
    /// child's pid is the program's).
    pub fn command(namespace: &str, program: impl AsRef<OsStr>) -> Command {
        let mut command = Command::new("ip");
        command.args(["netns", "exec", namespace]).arg(program);
        command
    }

    /// The MAC address of the device's end, as `ip` prints it (`aa:bb:cc:dd:ee:ff`).
    pub fn device_mac(&self) -> Result<String, VethError> {
        let text = ip(&[
            "-n",
            &self.device,
            "-br",
            "link",
            "show",
            &self.device_interface,
        ])?;
        text.split_whitespace()
            .nth(2)
            .map(str::to_owned)
            .ok_or(VethError::NoMac(text))
    }
}

impl Drop for VethPair {
    fn drop(&mut self) {
        // Deleting a namespace deletes the veth end in it, and with it the pair; a pair still
        // outside them (a failure before the move) is deleted by name.
        let _ = Command::new("ip")
            .args(["link", "del", &self.plc_interface])
            .stderr(Stdio::null())
            .status();
        for namespace in [&self.plc, &self.device] {
            let _ = Command::new("ip")
                .args(["netns", "del", namespace])
                .stderr(Stdio::null())
                .status();
        }
    }
}

/// Runs `ip` with `args`; its standard output.
fn ip(args: &[&str]) -> Result<String, VethError> {
    let owned = || args.iter().map(|a| (*a).to_owned()).collect();
    let output = Command::new("ip")
        .args(args)
        .output()
        .map_err(|source| VethError::Spawn {
            args: owned(),
            source,
        })?;
    if !output.status.success() {
        return Err(VethError::Failed {
            args: owned(),
            stderr: String::from_utf8_lossy(&output.stderr).trim().to_owned(),
        });
    }
    Ok(String::from_utf8_lossy(&output.stdout).into_owned())
}
