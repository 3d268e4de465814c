//! The ROS 2 and Fast DDS settings of the environment (issue 21 item 4), on the agent binary with `-m dds`:
//! what a ROS 2 node of the agent's distribution does with them, the agent's participants do; a setting the
//! agent cannot honour stops it with an error naming the variable and its value.
//!
//! Each test starts agents with DDS participants, so they run inside a loopback-only namespace:
//!
//!   ../shared/dds-peers/netns.sh xenv cargo test -p xrce-agent --test ros_env -- --ignored --test-threads 1
//!
//! What is observed needs no DDS peer: the sockets the agent binds (`/proc/net/udp`) and the RTPS datagrams
//! it sends to addresses of `127.0.0.0/8` that the test listens on. Only the Fast DDS engine reads these
//! settings (the tests say so and pass on a build without it: the RustDDS fallback has no such settings).

mod netns;
use netns::require_loopback_namespace;

use std::net::UdpSocket;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::time::{Duration, Instant};

/// Domain 0's discovery multicast port (RTPS: 7400 + 250 × domain).
const MULTICAST_DISCOVERY_PORT: u16 = 7400;

/// The agent under test: `XRCE_ROS_AGENT` (another build, against another Fast DDS) if set, else this crate's.
fn agent() -> Command {
    let bin = std::env::var_os("XRCE_ROS_AGENT")
        .map_or_else(|| PathBuf::from(env!("CARGO_BIN_EXE_xrce-agent")), PathBuf::from);
    let mut c = Command::new(bin);
    // Only what a test sets: none of the runner's own ROS or Fast DDS settings.
    for var in [
        "ROS_AUTOMATIC_DISCOVERY_RANGE",
        "ROS_STATIC_PEERS",
        "ROS_LOCALHOST_ONLY",
        "ROS_DISCOVERY_SERVER",
        "FASTRTPS_DEFAULT_PROFILES_FILE",
        "FASTDDS_DEFAULT_PROFILES_FILE",
        "XRCE_DDS_ENGINE",
    ] {
        c.env_remove(var);
    }
    c
}

/// Whether the agent runs Fast DDS (`--version` names the engine it was built with).
fn fast_dds() -> bool {
    let out = agent().arg("--version").output().expect("agent --version");
    String::from_utf8_lossy(&out.stdout).contains("Fast DDS")
}

/// An agent with `-m dds` on `port` and the environment `env`, killed when dropped.
struct Running(Child);

impl Running {
    fn start(port: u16, env: &[(&str, &str)]) -> Self {
        require_loopback_namespace();
        let child = agent()
            .args(["udp4", "-p", &port.to_string(), "-v", "3"])
            .envs(env.iter().copied())
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .expect("agent starts");
        Self(child)
    }
}

impl Drop for Running {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// Runs an agent that is expected to stop by itself within 10 s.
fn run_to_exit(env: &[(&str, &str)]) -> Output {
    require_loopback_namespace();
    let mut child = agent()
        .args(["udp4", "-p", "29001", "-v", "3"])
        .envs(env.iter().copied())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("agent starts");
    let deadline = Instant::now() + Duration::from_secs(10);
    while child.try_wait().expect("wait").is_none() {
        if Instant::now() > deadline {
            let _ = child.kill();
            panic!("the agent kept running with {env:?}");
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    child.wait_with_output().expect("output")
}

/// UDP ports bound in this namespace (`/proc/net/udp`).
fn bound_udp_ports() -> Vec<u16> {
    let table = std::fs::read_to_string("/proc/net/udp").unwrap_or_default();
    table
        .lines()
        .skip(1)
        .filter_map(|l| l.split_whitespace().nth(1))
        .filter_map(|local| local.split(':').nth(1))
        .filter_map(|port| u16::from_str_radix(port, 16).ok())
        .collect()
}

/// Whether some socket has `port` bound within `wait`.
fn port_bound_within(port: u16, wait: Duration) -> bool {
    let deadline = Instant::now() + wait;
    loop {
        if bound_udp_ports().contains(&port) {
            return true;
        }
        if Instant::now() > deadline {
            return false;
        }
        std::thread::sleep(Duration::from_millis(50));
    }
}

/// Whether an RTPS datagram arrives at `addr` within `wait`.
fn rtps_arrives_at(socket: &UdpSocket, wait: Duration) -> bool {
    socket.set_read_timeout(Some(Duration::from_millis(100))).expect("timeout");
    let deadline = Instant::now() + wait;
    let mut buf = [0u8; 2048];
    while Instant::now() < deadline {
        if let Ok((n, _)) = socket.recv_from(&mut buf) {
            if n >= 4 && buf.get(..4) == Some(b"RTPS".as_slice()) {
                return true;
            }
        }
    }
    false
}

fn temp_file(name: &str, text: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("xrce-ros-env-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let path = dir.join(name);
    std::fs::write(&path, text).expect("write");
    path
}

/// Both profiles variables (2.x reads one, 3.x the other; the agent warns about the one it ignores).
fn profiles_env(path: &Path) -> Vec<(&'static str, String)> {
    let p = path.display().to_string();
    vec![("FASTRTPS_DEFAULT_PROFILES_FILE", p.clone()), ("FASTDDS_DEFAULT_PROFILES_FILE", p)]
}

fn as_refs<'a>(env: &'a [(&'static str, String)]) -> Vec<(&'static str, &'a str)> {
    env.iter().map(|(k, v)| (*k, v.as_str())).collect()
}

#[test]
#[ignore = "starts DDS: run inside shared/dds-peers/netns.sh with --ignored"]
fn bad_settings_stop_the_agent_naming_the_variable_and_value() {
    let malformed = temp_file("malformed.xml", "<profiles><participant");
    let malformed_env = profiles_env(&malformed);
    let missing_env = profiles_env(Path::new("/nonexistent/profiles.xml"));
    // (environment, what the error must say)
    type Case<'a> = (Vec<(&'a str, &'a str)>, Vec<&'a str>);
    let mut cases: Vec<Case> = vec![
        (
            vec![("ROS_STATIC_PEERS", "198.18.0.9;no-such-host.invalid")],
            vec!["ROS_STATIC_PEERS", "no-such-host.invalid"],
        ),
        (
            vec![("ROS_DISCOVERY_SERVER", "127.0.0.1:11811;127.0.0.1:port")],
            vec!["ROS_DISCOVERY_SERVER", "127.0.0.1:port"],
        ),
    ];
    if fast_dds() {
        cases.push((as_refs(&missing_env), vec!["PROFILES_FILE", "/nonexistent/profiles.xml", "no such file"]));
        cases.push((as_refs(&malformed_env), vec!["PROFILES_FILE", "malformed.xml", "cannot parse"]));
    }
    for (env, says) in cases {
        let out = run_to_exit(&env);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{env:?}: {stderr}");
        for s in says {
            assert!(stderr.contains(s), "{env:?}: the error should say {s:?}: {stderr}");
        }
        // Nothing was started: no discovery socket was ever bound (the agent exited before its participants).
        assert!(!bound_udp_ports().contains(&MULTICAST_DISCOVERY_PORT));
    }
}

#[test]
#[ignore = "starts DDS: run inside shared/dds-peers/netns.sh with --ignored"]
fn the_user_s_profile_is_the_base_of_the_agent_s_participants() {
    if !fast_dds() {
        println!("ROS-ENV skipped: this agent has no Fast DDS (profiles are Fast DDS')");
        return;
    }
    // The user's default participant profile moves discovery's unicast port to one nobody else uses.
    let port = 17911;
    let profile = temp_file(
        "profile.xml",
        &format!(
            r#"<?xml version="1.0" encoding="UTF-8" ?>
<profiles xmlns="http://www.eprosima.com/XMLSchemas/fastRTPS_Profiles">
  <participant profile_name="user_default" is_default_profile="true">
    <rtps><builtin><metatrafficUnicastLocatorList>
      <locator><udpv4><address>127.0.0.1</address><port>{port}</port></udpv4></locator>
    </metatrafficUnicastLocatorList></builtin></rtps>
  </participant>
</profiles>
"#
        ),
    );
    assert!(!port_bound_within(port, Duration::ZERO));
    let env = profiles_env(&profile);
    let _agent = Running::start(29002, &as_refs(&env));
    assert!(port_bound_within(port, Duration::from_secs(5)), "the profile's discovery port {port} is not bound");
}

#[test]
#[ignore = "starts DDS: run inside shared/dds-peers/netns.sh with --ignored"]
fn localhost_and_off_ranges_leave_multicast_discovery_alone() {
    if !fast_dds() {
        println!("ROS-ENV skipped: this agent has no Fast DDS (RustDDS has no discovery ranges)");
        return;
    }
    {
        let _agent = Running::start(29003, &[]);
        assert!(port_bound_within(MULTICAST_DISCOVERY_PORT, Duration::from_secs(5)), "default: multicast discovery");
    }
    std::thread::sleep(Duration::from_millis(300));
    for range in ["LOCALHOST", "OFF"] {
        let _agent = Running::start(29004, &[("ROS_AUTOMATIC_DISCOVERY_RANGE", range)]);
        // The agent is up (its XRCE port) and has not bound the multicast discovery port.
        assert!(port_bound_within(29004, Duration::from_secs(5)));
        std::thread::sleep(Duration::from_millis(500));
        assert!(!bound_udp_ports().contains(&MULTICAST_DISCOVERY_PORT), "{range}: multicast discovery port bound");
    }
    // ROS_LOCALHOST_ONLY=1 (Humble's variable, deprecated in Jazzy) is LOCALHOST.
    let _agent = Running::start(29005, &[("ROS_LOCALHOST_ONLY", "1")]);
    assert!(port_bound_within(29005, Duration::from_secs(5)));
    std::thread::sleep(Duration::from_millis(500));
    assert!(!bound_udp_ports().contains(&MULTICAST_DISCOVERY_PORT), "ROS_LOCALHOST_ONLY=1: multicast port bound");
}

#[test]
#[ignore = "starts DDS: run inside shared/dds-peers/netns.sh with --ignored"]
fn static_peers_and_the_discovery_server_are_announced_to() {
    if !fast_dds() {
        println!("ROS-ENV skipped: this agent has no Fast DDS");
        return;
    }
    // A static peer on another loopback address: the agent's announcements reach its first participant port
    // (7410 for domain 0), with LOCALHOST and SUBNET alike; not without the variable.
    let peer = UdpSocket::bind("127.0.0.5:7410").expect("bind the peer's port");
    for (range, peers, expected) in [
        ("LOCALHOST", Some("127.0.0.5"), true),
        ("SUBNET", Some("127.0.0.5"), true),
        ("LOCALHOST", None, false),
        ("SYSTEM_DEFAULT", Some("127.0.0.5"), false),
    ] {
        let mut env = vec![("ROS_AUTOMATIC_DISCOVERY_RANGE", range)];
        if let Some(p) = peers {
            env.push(("ROS_STATIC_PEERS", p));
        }
        let agent = Running::start(29006, &env);
        let arrived = rtps_arrives_at(&peer, Duration::from_secs(3));
        drop(agent);
        assert_eq!(arrived, expected, "{env:?}");
        // Drain what the agent sent before it went.
        while rtps_arrives_at(&peer, Duration::from_millis(200)) {}
    }
    // ROS_DISCOVERY_SERVER: Fast DDS makes the participants clients of that server.
    let server = UdpSocket::bind("127.0.0.6:11811").expect("bind the server's port");
    let _agent = Running::start(29007, &[("ROS_DISCOVERY_SERVER", "127.0.0.6:11811")]);
    assert!(rtps_arrives_at(&server, Duration::from_secs(3)), "nothing reached the discovery server");
}
