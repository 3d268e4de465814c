//! Support for the tests that start DDS participants (`dds`, `dds_interop`, `ros2`, `ros_graph`): they run only
//! inside a loopback-only network namespace (`shared/dds-peers/netns.sh NAME cargo test … -- --ignored`), and
//! the agent binary they start is killed with them.
#![allow(dead_code)]

use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::Duration;

/// Panics unless the only network interface is `lo`: DDS discovery multicast must never leave the machine.
pub fn require_loopback_namespace() {
    let ifaces: Vec<String> = std::fs::read_dir("/sys/class/net")
        .map(|d| d.filter_map(|e| e.ok()).map(|e| e.file_name().to_string_lossy().into_owned()).collect())
        .unwrap_or_default();
    assert!(
        ifaces == ["lo"],
        "DDS tests must run inside a loopback-only namespace (shared/dds-peers/netns.sh NAME cargo test ... -- --ignored); interfaces here: {ifaces:?}"
    );
}

/// The transports of the rclpy nodes the ROS 2 tests start (`FASTDDS_BUILTIN_TRANSPORTS`): UDPv4 only, unless
/// `XRCE_ROS_SHM=1`, which leaves them their distribution's default (shared memory and UDPv4), for an agent
/// built against the same Fast DDS (its shared memory on), sharing the namespace's private `/dev/shm`.
pub fn ros_node_transports(cmd: &mut Command) -> &mut Command {
    if std::env::var("XRCE_ROS_SHM").is_ok_and(|v| v == "1") {
        cmd.env_remove("FASTDDS_BUILTIN_TRANSPORTS")
    } else {
        cmd.env("FASTDDS_BUILTIN_TRANSPORTS", "UDPv4")
    }
}

/// An agent binary (`udp4 -p PORT -v 3`, default middleware: dds), killed when dropped.
pub struct AgentProcess(Child);

impl AgentProcess {
    /// This crate's agent binary.
    pub fn start(port: u16) -> Self {
        Self::start_bin(Path::new(env!("CARGO_BIN_EXE_xrce-agent")), port)
    }

    /// This crate's agent binary with more options after the usual ones.
    pub fn start_with(port: u16, extra: &[&str]) -> Self {
        Self::start_bin_with(Path::new(env!("CARGO_BIN_EXE_xrce-agent")), port, extra)
    }

    /// The agent binary `bin` (another build, or eProsima's `MicroXRCEAgent`).
    pub fn start_bin(bin: &Path, port: u16) -> Self {
        Self::start_bin_with(bin, port, &[])
    }

    fn start_bin_with(bin: &Path, port: u16, extra: &[&str]) -> Self {
        require_loopback_namespace();
        // `XRCE_AGENT_LOG=FILE` keeps the agent's log (appended; `RUST_LOG` sets its level).
        let log = std::env::var_os("XRCE_AGENT_LOG")
            .and_then(|f| std::fs::OpenOptions::new().create(true).append(true).open(f).ok());
        let child = Command::new(bin)
            .args(["udp4", "-p", &port.to_string(), "-v", "3"])
            .args(extra)
            .stdout(log.map_or_else(Stdio::null, Stdio::from))
            .spawn()
            .expect("agent starts");
        std::thread::sleep(Duration::from_millis(300));
        Self(child)
    }
}

impl Drop for AgentProcess {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}
