//! Support for the tests that start DDS participants (`dds`, `dds_interop`, `ros2`, `ros_graph`): they run only
//! inside a loopback-only network namespace (`shared/dds-peers/netns.sh NAME cargo test … -- --ignored`), or,
//! for `ros2_two_hosts`, in one of two namespaces joined only to each other by a veth pair with addresses from
//! 198.18.0.0/15 (`scripts/two-hosts.sh`), and the agent binary they start is killed with them.
#![allow(dead_code)]

use std::net::Ipv4Addr;
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::Duration;

use serde_json::Value;

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

/// Panics unless this namespace is loopback-only, or `scripts/two-hosts.sh`'s "robot" (see [`two_hosts`]).
pub fn require_isolated_namespace() {
    let ifaces: Vec<String> = std::fs::read_dir("/sys/class/net")
        .map(|d| d.filter_map(|e| e.ok()).map(|e| e.file_name().to_string_lossy().into_owned()).collect())
        .unwrap_or_default();
    if ifaces != ["lo"] && two_hosts().is_none() {
        panic!(
            "DDS tests must run inside a loopback-only namespace (shared/dds-peers/netns.sh NAME cargo test ... -- \
             --ignored) or scripts/two-hosts.sh's; interfaces here: {ifaces:?}"
        );
    }
}

/// Panics unless `ns` is `scripts/two-hosts.sh`'s "ground", seen from its "robot" (see [`two_hosts`]).
pub fn require_isolated_netns(ns: &str) {
    let ground = two_hosts().map(|t| t.ground);
    assert_eq!(ground.as_deref(), Some(ns), "DDS participants run only in scripts/two-hosts.sh's ground namespace");
}

/// The link between the two namespaces of `scripts/two-hosts.sh`, seen from this one ("robot").
#[derive(Debug, Clone)]
pub struct TwoHosts {
    /// The other namespace ("ground"), `XRCE_GROUND_NETNS`.
    pub ground: String,
    /// This side's address on the link.
    pub robot_addr: Ipv4Addr,
    /// The ground side's address.
    pub ground_addr: Ipv4Addr,
    /// Whether both ends of the link have the MULTICAST flag (the script clears it, and drops multicast on the
    /// link, for `--multicast off`).
    pub multicast: bool,
}

/// The two-hosts setup, when `XRCE_GROUND_NETNS` names the other namespace; `None` without it. Panics unless
/// this namespace and the ground's have, besides `lo`, exactly one veth each, the two being each other's peers,
/// with IPv4 addresses only from 198.18.0.0/15 (the range reserved for benchmark tests) and IPv6 only
/// link-local: nothing there can reach out of the machine.
pub fn two_hosts() -> Option<TwoHosts> {
    let ground = std::env::var("XRCE_GROUND_NETNS").ok().filter(|s| !s.is_empty())?;
    let here = veths(None).unwrap_or_else(|e| panic!("this namespace is not scripts/two-hosts.sh's robot: {e}"));
    let there = veths(Some(&ground)).unwrap_or_else(|e| panic!("{ground} is not scripts/two-hosts.sh's ground: {e}"));
    let me = run_ip(&["netns", "identify"]).unwrap_or_default();
    let (r, g) = match (here.as_slice(), there.as_slice()) {
        ([r], [g]) => (r, g),
        _ => panic!("two hosts: one veth on each side expected, here {here:?}, in {ground} {there:?}"),
    };
    assert_eq!(r.peer_netns.as_deref(), Some(ground.as_str()), "this namespace's veth leads to {ground}: {r:?}");
    assert_eq!(r.peer_index, g.index, "the veths are each other's peers: {r:?} {g:?}");
    assert!(g.peer_netns.as_deref() == Some(me.trim()) && g.peer_index == r.index, "{ground}'s veth leads here: {g:?}");
    let addr = |v: &Veth| *v.ipv4.first().unwrap_or_else(|| panic!("no IPv4 address on {v:?}"));
    Some(TwoHosts {
        ground: ground.clone(),
        robot_addr: addr(r),
        ground_addr: addr(g),
        multicast: r.multicast && g.multicast,
    })
}

/// A veth interface of a namespace.
#[derive(Debug, Clone)]
struct Veth {
    name: String,
    index: u64,
    /// The peer's interface index, in its namespace.
    peer_index: u64,
    /// The namespace of the peer, by its `ip netns` name (`None`: one without a name, the host's say).
    peer_netns: Option<String>,
    ipv4: Vec<Ipv4Addr>,
    multicast: bool,
}

/// `ip [-n NS] ARGS…`'s standard output.
fn run_ip_in(ns: Option<&str>, args: &[&str]) -> Result<String, String> {
    let mut cmd = Command::new("ip");
    if let Some(ns) = ns {
        cmd.args(["-n", ns]);
    }
    let out = cmd.args(args).output().map_err(|e| format!("ip: {e}"))?;
    if !out.status.success() {
        return Err(format!("ip {args:?}: {}", String::from_utf8_lossy(&out.stderr).trim()));
    }
    Ok(String::from_utf8_lossy(&out.stdout).into_owned())
}

fn run_ip(args: &[&str]) -> Result<String, String> {
    run_ip_in(None, args)
}

/// The veths of a namespace (this one with `None`); an error unless its every interface is `lo` or a veth whose
/// IPv4 addresses are all in 198.18.0.0/15 and IPv6 ones link-local.
fn veths(ns: Option<&str>) -> Result<Vec<Veth>, String> {
    let json = |args: &[&str]| -> Result<Value, String> {
        serde_json::from_str(&run_ip_in(ns, args)?).map_err(|e| format!("ip {args:?}: {e}"))
    };
    // Listing the links first makes the kernel number the peers' namespaces, which `netns list-id` then names.
    let ifaces = json(&["-details", "-json", "address", "show"])?;
    let ids = json(&["-json", "netns", "list-id"]).unwrap_or(Value::Null);
    let netns_name =
        |id: u64| ids.as_array()?.iter().find(|e| e["nsid"].as_u64() == Some(id))?["name"].as_str().map(str::to_string);
    let benchmark_range = |a: Ipv4Addr| a.octets()[0] == 198 && (a.octets()[1] & 0xfe) == 18;
    let mut found = Vec::new();
    for i in ifaces.as_array().ok_or("no interface list")? {
        let name = i["ifname"].as_str().unwrap_or("?").to_string();
        if i["link_type"] == "loopback" {
            continue;
        }
        if i["linkinfo"]["info_kind"] != "veth" {
            return Err(format!("{name} is not a veth ({})", i["linkinfo"]["info_kind"]));
        }
        let mut ipv4 = Vec::new();
        for a in i["addr_info"].as_array().into_iter().flatten() {
            let local = a["local"].as_str().unwrap_or("");
            match (a["family"].as_str(), local.parse::<Ipv4Addr>()) {
                (Some("inet"), Ok(v4)) if benchmark_range(v4) => ipv4.push(v4),
                (Some("inet6"), _) if a["scope"] == "link" => {}
                _ => return Err(format!("{name} has address {local}, outside 198.18.0.0/15")),
            }
        }
        let flags: Vec<&str> = i["flags"].as_array().into_iter().flatten().filter_map(Value::as_str).collect();
        found.push(Veth {
            name,
            index: i["ifindex"].as_u64().unwrap_or(0),
            peer_index: i["link_index"].as_u64().unwrap_or(0),
            peer_netns: i["link_netnsid"].as_u64().and_then(netns_name),
            ipv4,
            multicast: flags.contains(&"MULTICAST"),
        });
    }
    Ok(found)
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
        Self::start_bin_env(bin, port, &[], &[], extra)
    }

    /// The agent binary `bin` without the environment variables `remove`, with those of `env`.
    pub fn start_bin_env(bin: &Path, port: u16, remove: &[&str], env: &[(&str, &str)], extra: &[&str]) -> Self {
        require_isolated_namespace();
        // `XRCE_AGENT_LOG=FILE` keeps the agent's log (appended; `RUST_LOG` sets its level).
        let log = std::env::var_os("XRCE_AGENT_LOG")
            .and_then(|f| std::fs::OpenOptions::new().create(true).append(true).open(f).ok());
        let mut cmd = Command::new(bin);
        for k in remove {
            cmd.env_remove(k);
        }
        let child = cmd
            .envs(env.iter().copied())
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
