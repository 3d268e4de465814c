//! The ROS 2 discovery settings a ROS 2 node reads from its environment, read the same way for the agent's
//! DDS participants (issue 21): a micro-ROS board's node then shows up where the user's other nodes do.
//!
//! | variable | as in | what the agent does |
//! |---|---|---|
//! | `ROS_AUTOMATIC_DISCOVERY_RANGE` | rcl (Jazzy and later) | `SUBNET` (unset or empty), `LOCALHOST`, `OFF`, `SYSTEM_DEFAULT`; anything else: a warning, then `LOCALHOST` |
//! | `ROS_STATIC_PEERS` | rcl | `;`-separated addresses or host names, added as initial peers with `SUBNET` and `LOCALHOST`; one that does not resolve stops the agent (a node fails to start) |
//! | `ROS_LOCALHOST_ONLY` | rcl (Humble; deprecated in Jazzy) | `1`: the `LOCALHOST` range, whatever `ROS_AUTOMATIC_DISCOVERY_RANGE` says (Jazzy's rule) |
//! | `ROS_DISCOVERY_SERVER` | Fast DDS itself | checked here (a malformed list stops the agent, where Fast DDS would log and carry on with another discovery); Fast DDS applies it |
//!
//! How each range becomes participant settings is rmw_fastrtps' (`rmw_fastrtps_shared_cpp/src/participant.cpp`):
//! see [`Range`]. The parsing is a pure function of the variables, unit-tested without a participant.

use std::net::{Ipv4Addr, SocketAddr, ToSocketAddrs};

/// `ROS_AUTOMATIC_DISCOVERY_RANGE`.
pub const RANGE_ENV: &str = "ROS_AUTOMATIC_DISCOVERY_RANGE";
/// `ROS_STATIC_PEERS`.
pub const STATIC_PEERS_ENV: &str = "ROS_STATIC_PEERS";
/// `ROS_LOCALHOST_ONLY`.
pub const LOCALHOST_ONLY_ENV: &str = "ROS_LOCALHOST_ONLY";
/// `ROS_DISCOVERY_SERVER`.
pub const DISCOVERY_SERVER_ENV: &str = "ROS_DISCOVERY_SERVER";

/// Longest static peer rcl accepts (longer ones are skipped with a warning).
const MAX_PEER_LEN: usize = 255;

/// How far automatic discovery reaches (`ROS_AUTOMATIC_DISCOVERY_RANGE`), as rmw_fastrtps applies it.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum Range {
    /// Multicast discovery on every interface (Fast DDS' default), plus the static peers (and, with peers,
    /// the multicast address among the initial peers, so announcements still go there).
    #[default]
    Subnet,
    /// Fast DDS' default, static peers ignored.
    SystemDefault,
    /// No multicast discovery: unicast to `127.0.0.1` and the static peers only.
    Localhost,
    /// No automatic discovery.
    Off,
}

impl Range {
    /// Its value in `ROS_AUTOMATIC_DISCOVERY_RANGE`.
    pub const fn name(self) -> &'static str {
        match self {
            Self::Subnet => "SUBNET",
            Self::SystemDefault => "SYSTEM_DEFAULT",
            Self::Localhost => "LOCALHOST",
            Self::Off => "OFF",
        }
    }
}

/// The discovery settings of the agent's DDS participants.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct DiscoverySettings {
    /// The range.
    pub range: Range,
    /// `ROS_STATIC_PEERS`, resolved (first IPv4 address of each); empty when the range ignores them.
    pub static_peers: Vec<Ipv4Addr>,
}

impl DiscoverySettings {
    /// The initial peers a participant adds to its profile's, as rmw_fastrtps adds them.
    pub fn initial_peers(&self) -> Vec<Ipv4Addr> {
        let mut peers = self.static_peers.clone();
        match self.range {
            Range::Localhost => peers.push(Ipv4Addr::LOCALHOST),
            // Announcements still go to the default multicast group when unicast peers are listed.
            Range::Subnet if !peers.is_empty() => peers.push(Ipv4Addr::new(239, 255, 0, 1)),
            _ => {}
        }
        peers
    }
}

/// A setting the agent refuses to start with.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum SettingsError {
    /// A static peer that does not resolve to an IPv4 address.
    #[error(
        "{STATIC_PEERS_ENV}={value:?}: peer {peer:?} does not resolve to an IPv4 address ({reason}); fix or unset it"
    )]
    Peer {
        /// The whole variable.
        value: String,
        /// The peer.
        peer: String,
        /// Why.
        reason: String,
    },
    /// The Fast DDS profiles file is missing or does not parse.
    #[error("{var}={file:?}: {reason}; fix the file or unset {var}")]
    Profiles {
        /// The variable that names it.
        var: &'static str,
        /// The file.
        file: String,
        /// Why.
        reason: &'static str,
    },
    /// A `ROS_DISCOVERY_SERVER` entry that is not `[ADDRESS][:PORT]`.
    #[error(
        "{DISCOVERY_SERVER_ENV}={value:?}: entry {index} {entry:?} is not ADDRESS[:PORT] (IPv4, [IPv6], a host \
         name, or UDPv4:/UDPv6:/TCPv4:/TCPv6:[ADDRESS]; PORT 1-65535); fix or unset it"
    )]
    DiscoveryServer {
        /// The whole variable.
        value: String,
        /// 0-based position (the server id Fast DDS gives it).
        index: usize,
        /// The entry.
        entry: String,
    },
}

/// Loads the user's Fast DDS profiles file before any participant exists, as a ROS 2 node does: the file named
/// by the variable this build's Fast DDS reads (`FASTRTPS_DEFAULT_PROFILES_FILE` for 2.x,
/// `FASTDDS_DEFAULT_PROFILES_FILE` for 3.x). A missing or unparsable file stops the agent: it would otherwise
/// run with settings its user did not write. The other variable, which this version ignores as a ROS node of
/// the same distribution does, gets a warning.
#[cfg(feature = "fastdds")]
pub fn load_fast_dds_profiles() -> Result<(), SettingsError> {
    use xrce_fastdds_sys as sys;
    if !sys::available() {
        return Ok(());
    }
    for other in ["FASTDDS_DEFAULT_PROFILES_FILE", "FASTRTPS_DEFAULT_PROFILES_FILE"] {
        if other != sys::PROFILES_ENV && std::env::var_os(other).is_some() {
            tracing::warn!(
                "{other} is set, but this agent's {} reads {} instead (as ROS 2 nodes of its distribution do): ignored",
                sys::BUILT_WITH,
                sys::PROFILES_ENV
            );
        }
    }
    let file = std::env::var(sys::PROFILES_ENV).ok().filter(|f| !f.is_empty());
    if let Some(file) = &file {
        if !std::path::Path::new(file).is_file() {
            return Err(SettingsError::Profiles { var: sys::PROFILES_ENV, file: file.clone(), reason: "no such file" });
        }
    }
    sys::load_profiles(file.as_deref().map(std::path::Path::new)).map_err(|_| SettingsError::Profiles {
        var: sys::PROFILES_ENV,
        file: file.clone().unwrap_or_default(),
        reason: "Fast DDS cannot parse it (its log says why)",
    })?;
    if let Some(file) = file {
        tracing::info!("Fast DDS profiles loaded from {file} ({})", sys::PROFILES_ENV);
    }
    Ok(())
}

/// Without the Fast DDS engine there are no profiles to load.
#[cfg(not(feature = "fastdds"))]
pub fn load_fast_dds_profiles() -> Result<(), SettingsError> {
    Ok(())
}

/// Reads the settings from the process environment; warnings (an unknown range, a peer too long, settings
/// that cancel each other) are logged.
pub fn from_env() -> Result<DiscoverySettings, SettingsError> {
    let (settings, warnings) = parse(|name| std::env::var(name).ok(), resolve_ipv4)?;
    for w in warnings {
        tracing::warn!("{w}");
    }
    Ok(settings)
}

/// The first IPv4 address of `host`.
fn resolve_ipv4(host: &str) -> Result<Ipv4Addr, String> {
    if let Ok(ip) = host.parse::<Ipv4Addr>() {
        return Ok(ip);
    }
    let addrs = (host, 0).to_socket_addrs().map_err(|e| e.to_string())?;
    addrs
        .into_iter()
        .find_map(|a| match a {
            SocketAddr::V4(v4) => Some(*v4.ip()),
            SocketAddr::V6(_) => None,
        })
        .ok_or_else(|| "no IPv4 address".to_owned())
}

/// The settings from the variables `var` returns, resolving peers with `resolve`; with the warnings to log.
pub fn parse(
    var: impl Fn(&str) -> Option<String>,
    resolve: impl Fn(&str) -> Result<Ipv4Addr, String>,
) -> Result<(DiscoverySettings, Vec<String>), SettingsError> {
    let mut warnings = Vec::new();
    if let Some(value) = var(DISCOVERY_SERVER_ENV) {
        check_discovery_server(&value)?;
    }
    let range_value = var(RANGE_ENV);
    let range = if var(LOCALHOST_ONLY_ENV).as_deref() == Some("1") {
        warnings.push(format!(
            "{LOCALHOST_ONLY_ENV}=1 is deprecated but honoured: discovery range LOCALHOST{}",
            if range_value.as_deref().is_some_and(|v| !v.is_empty()) {
                format!(" ({RANGE_ENV} ignored)")
            } else {
                String::new()
            }
        ));
        Range::Localhost
    } else {
        match range_value.as_deref().unwrap_or("") {
            "" | "SUBNET" => Range::Subnet,
            "SYSTEM_DEFAULT" => Range::SystemDefault,
            "LOCALHOST" => Range::Localhost,
            "OFF" => Range::Off,
            other => {
                warnings.push(format!(
                    "{RANGE_ENV}={other:?} is not OFF, LOCALHOST, SUBNET or SYSTEM_DEFAULT; assuming LOCALHOST, as \
                     ROS 2 nodes do"
                ));
                Range::Localhost
            }
        }
    };
    let mut static_peers = Vec::new();
    if let Some(value) = var(STATIC_PEERS_ENV) {
        let peers: Vec<&str> = value.split(';').map(str::trim).filter(|p| !p.is_empty()).collect();
        if matches!(range, Range::Off | Range::SystemDefault) && !peers.is_empty() {
            warnings.push(format!("{STATIC_PEERS_ENV} is ignored with the discovery range {}", range.name()));
        } else {
            for peer in peers {
                if peer.len() > MAX_PEER_LEN {
                    warnings.push(format!("{STATIC_PEERS_ENV}: peer {peer:?} is longer than {MAX_PEER_LEN}; skipped"));
                    continue;
                }
                let ip = resolve(peer).map_err(|reason| SettingsError::Peer {
                    value: value.clone(),
                    peer: peer.to_owned(),
                    reason,
                })?;
                static_peers.push(ip);
            }
        }
    }
    Ok((DiscoverySettings { range, static_peers }, warnings))
}

/// Checks `ROS_DISCOVERY_SERVER` as Fast DDS reads it: `;`-separated entries, the position being the server
/// id, an empty entry skipping an id.
fn check_discovery_server(value: &str) -> Result<(), SettingsError> {
    for (index, entry) in value.split(';').enumerate() {
        let entry = entry.trim();
        if !entry.is_empty() && !server_entry_ok(entry) {
            return Err(SettingsError::DiscoveryServer { value: value.to_owned(), index, entry: entry.to_owned() });
        }
    }
    Ok(())
}

fn server_entry_ok(entry: &str) -> bool {
    const KINDS: [&str; 4] = ["UDPv4:", "UDPv6:", "TCPv4:", "TCPv6:"];
    let (address, port) = if let Some(rest) = KINDS.iter().find_map(|k| entry.strip_prefix(k)) {
        // KIND:[ADDRESS][:PORT]
        let Some(inner) = rest.strip_prefix('[') else { return false };
        let Some((address, after)) = inner.split_once(']') else { return false };
        (address, after)
    } else if let Some(inner) = entry.strip_prefix('[') {
        let Some((address, after)) = inner.split_once(']') else { return false };
        if address.parse::<std::net::Ipv6Addr>().is_err() {
            return false;
        }
        (address, after)
    } else if entry.parse::<std::net::Ipv6Addr>().is_ok() {
        (entry, "")
    } else {
        match entry.split_once(':') {
            Some((address, port)) => (address, port),
            None => (entry, ""),
        }
    };
    // After a bracketed address the port keeps its ':'; after a plain one split_once took it.
    let port = port.strip_prefix(':').unwrap_or(port);
    let port_ok = port.is_empty() || port.parse::<u16>().is_ok_and(|p| p > 0);
    let address_ok = address.is_empty()
        || address.parse::<std::net::IpAddr>().is_ok()
        || (address.len() <= 63 && address.chars().all(|c| c.is_ascii_alphanumeric() || "._-".contains(c)));
    port_ok && address_ok
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::HashMap;

    fn settings(vars: &[(&str, &str)]) -> Result<(DiscoverySettings, Vec<String>), SettingsError> {
        let vars: HashMap<String, String> = vars.iter().map(|(k, v)| ((*k).to_owned(), (*v).to_owned())).collect();
        parse(
            |n| vars.get(n).cloned(),
            |h| match h {
                "ground" => Ok(Ipv4Addr::new(198, 18, 0, 2)),
                h => h.parse().map_err(|_| format!("unknown host {h}")),
            },
        )
    }

    #[test]
    fn nothing_set_is_subnet_without_peers() {
        let (s, w) = settings(&[]).unwrap();
        assert_eq!(s, DiscoverySettings { range: Range::Subnet, static_peers: vec![] });
        assert!(s.initial_peers().is_empty());
        assert!(w.is_empty());
    }

    #[test]
    fn each_range_by_name() {
        for (value, range) in [
            ("", Range::Subnet),
            ("SUBNET", Range::Subnet),
            ("SYSTEM_DEFAULT", Range::SystemDefault),
            ("LOCALHOST", Range::Localhost),
            ("OFF", Range::Off),
        ] {
            assert_eq!(settings(&[(RANGE_ENV, value)]).unwrap().0.range, range, "{value:?}");
        }
    }

    #[test]
    fn an_unknown_range_is_localhost_with_a_warning() {
        let (s, w) = settings(&[(RANGE_ENV, "subnet")]).unwrap();
        assert_eq!(s.range, Range::Localhost);
        assert!(w[0].contains("\"subnet\""), "{w:?}");
    }

    #[test]
    fn localhost_only_wins_over_the_range() {
        let (s, w) = settings(&[(LOCALHOST_ONLY_ENV, "1"), (RANGE_ENV, "SUBNET")]).unwrap();
        assert_eq!(s.range, Range::Localhost);
        assert!(w[0].contains("ignored"), "{w:?}");
        assert_eq!(settings(&[(LOCALHOST_ONLY_ENV, "0")]).unwrap().0.range, Range::Subnet);
    }

    #[test]
    fn static_peers_resolve_and_add_the_range_s_own_peer() {
        let (s, _) = settings(&[(STATIC_PEERS_ENV, "198.18.0.9; ground;")]).unwrap();
        assert_eq!(s.static_peers, [Ipv4Addr::new(198, 18, 0, 9), Ipv4Addr::new(198, 18, 0, 2)]);
        assert_eq!(s.initial_peers().last(), Some(&Ipv4Addr::new(239, 255, 0, 1)));
        let (s, _) = settings(&[(STATIC_PEERS_ENV, "ground"), (RANGE_ENV, "LOCALHOST")]).unwrap();
        assert_eq!(s.initial_peers(), [Ipv4Addr::new(198, 18, 0, 2), Ipv4Addr::LOCALHOST]);
    }

    #[test]
    fn static_peers_are_ignored_when_the_range_ignores_them() {
        for range in ["OFF", "SYSTEM_DEFAULT"] {
            let (s, w) = settings(&[(STATIC_PEERS_ENV, "ground"), (RANGE_ENV, range)]).unwrap();
            assert!(s.static_peers.is_empty());
            assert!(w[0].contains("ignored"), "{w:?}");
        }
    }

    #[test]
    fn an_unresolvable_peer_names_the_variable_and_the_peer() {
        let e = settings(&[(STATIC_PEERS_ENV, "198.18.0.9;nowhere")]).unwrap_err();
        let text = e.to_string();
        assert!(text.contains("ROS_STATIC_PEERS=\"198.18.0.9;nowhere\"") && text.contains("\"nowhere\""), "{text}");
    }

    #[test]
    fn a_too_long_peer_is_skipped() {
        let long = "a".repeat(300);
        let (s, w) = settings(&[(STATIC_PEERS_ENV, &format!("{long};198.18.0.9"))]).unwrap();
        assert_eq!(s.static_peers, [Ipv4Addr::new(198, 18, 0, 9)]);
        assert!(w[0].contains("skipped"));
    }

    #[test]
    fn discovery_server_lists_fast_dds_accepts() {
        for ok in [
            "127.0.0.1:11811",
            "198.18.0.1",
            ";198.18.0.1:11811",
            "localhost:11811;;robot-2.lan:11812",
            "[::1]:11811",
            "UDPv4:[198.18.0.1]:11811",
            "TCPv4:[198.18.0.1]:42100",
            "",
        ] {
            assert!(settings(&[(DISCOVERY_SERVER_ENV, ok)]).is_ok(), "{ok:?}");
        }
    }

    #[test]
    fn discovery_server_errors_name_the_entry() {
        for (bad, index) in [
            ("127.0.0.1:port", 0),
            ("127.0.0.1:11811;198.18.0.1:70000", 1),
            ("a b:1", 0),
            (";;[::1", 2),
            ("UDPv4:198.18.0.1:11811", 0),
            ("127.0.0.1:0", 0),
        ] {
            match settings(&[(DISCOVERY_SERVER_ENV, bad)]) {
                Err(SettingsError::DiscoveryServer { index: i, .. }) => assert_eq!(i, index, "{bad:?}"),
                other => panic!("{bad:?}: {other:?}"),
            }
        }
    }
}
