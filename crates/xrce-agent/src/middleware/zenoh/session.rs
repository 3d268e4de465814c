//! The Zenoh session shell: its configuration (rmw_zenoh's node defaults, `ZENOH_SESSION_CONFIG_URI`,
//! `--zenoh-config`), the wall clock of the attachments, and the watch that says once when no router is
//! reachable. Everything here runs at start or on its own thread; the core's calls never wait on it.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use zenoh::Wait;

/// The variable rmw_zenoh's nodes read their session configuration file from.
pub const SESSION_CONFIG_ENV: &str = "ZENOH_SESSION_CONFIG_URI";

/// Where rmw_zenoh's nodes look for their router by default.
pub const DEFAULT_ROUTER: &str = "tcp/localhost:7447";

/// How long after start the agent waits for a router before saying how to start one.
const ROUTER_GRACE: Duration = Duration::from_secs(3);

/// Why the Zenoh session could not be opened.
#[derive(Debug, thiserror::Error)]
pub enum SessionError {
    /// The configuration file could not be read or parsed.
    #[error("Zenoh configuration {path}: {reason}")]
    Config {
        /// The file.
        path: PathBuf,
        /// What was wrong.
        reason: String,
    },
    /// A setting of ours was refused (a bug, or a configuration that fixes it otherwise).
    #[error("Zenoh configuration: {0}")]
    Setting(String),
    /// Zenoh refused to open.
    #[error("cannot open the Zenoh session: {0}")]
    Open(String),
}

/// Where the session configuration comes from: `--zenoh-config`, else `ZENOH_SESSION_CONFIG_URI`, else
/// rmw_zenoh's node defaults.
pub fn config_file(cli: Option<&Path>) -> Option<PathBuf> {
    cli.map(Path::to_path_buf).or_else(|| std::env::var_os(SESSION_CONFIG_ENV).map(PathBuf::from))
}

/// rmw_zenoh's node defaults (its `DEFAULT_RMW_ZENOH_SESSION_CONFIG.json5`, 0.2.x): a peer that connects to
/// the router on localhost, listens on an ephemeral localhost port, scouts by gossip only (no multicast, gossip
/// sent to the router), and keeps a link 60 s without news (Zenoh's own default is 10 s), so that the agent's
/// nodes leave a graph when a ROS node on the same router would, not sooner. Timestamps are set after.
const NODE_DEFAULTS: &[(&str, &str)] = &[
    ("mode", r#""peer""#),
    ("connect/endpoints", r#"["tcp/localhost:7447"]"#),
    ("listen/endpoints", r#"["tcp/localhost:0"]"#),
    ("scouting/multicast/enabled", "false"),
    ("scouting/gossip/enabled", "true"),
    ("scouting/gossip/multihop", "false"),
    ("scouting/gossip/target", r#"{"router": ["router", "peer"], "peer": ["router"]}"#),
    ("scouting/gossip/autoconnect", r#"{"router": [], "peer": ["router", "peer"]}"#),
    ("transport/unicast/open_timeout", "60000"),
    ("transport/unicast/accept_timeout", "60000"),
    ("transport/link/tx/lease", "60000"),
    ("transport/link/tx/keep_alive", "2"),
];

/// The session's configuration: the file's when given, else rmw_zenoh's node defaults; timestamping on in
/// both (AdvancedPublisher caches refuse to start without it). A peer (the default) connects in the
/// background and keeps retrying (Zenoh's peer defaults: no connect timeout, no exit on failure), so no
/// router does not hold the agent's start; a file's own connect settings are left as they are.
pub fn build_config(file: Option<&Path>) -> Result<zenoh::Config, SessionError> {
    let mut config = match file {
        Some(path) => zenoh::Config::from_file(path)
            .map_err(|e| SessionError::Config { path: path.to_path_buf(), reason: e.to_string() })?,
        None => {
            let mut c = zenoh::Config::default();
            for (key, value) in NODE_DEFAULTS {
                c.insert_json5(key, value).map_err(|e| SessionError::Setting(format!("{key}: {e}")))?;
            }
            c
        }
    };
    config
        .insert_json5("timestamping/enabled", "true")
        .map_err(|e| SessionError::Setting(format!("timestamping/enabled: {e}")))?;
    Ok(config)
}

/// Wall-clock time for the attachments without reading the clock on the core's calls: the instant and the
/// system time the session started, and the monotonic time since.
#[derive(Debug, Clone, Copy)]
pub struct WallClock {
    start: Instant,
    start_ns: i64,
}

impl WallClock {
    /// Anchored now.
    pub fn anchored_now() -> Self {
        let since_epoch = SystemTime::now().duration_since(UNIX_EPOCH).unwrap_or_default();
        Self { start: Instant::now(), start_ns: i64::try_from(since_epoch.as_nanos()).unwrap_or(i64::MAX) }
    }

    /// Nanoseconds since the Unix epoch at `now`.
    pub fn ns_at(&self, now: Instant) -> i64 {
        let elapsed = i64::try_from(now.saturating_duration_since(self.start).as_nanos()).unwrap_or(i64::MAX);
        self.start_ns.saturating_add(elapsed)
    }
}

/// The open session and its router watch.
pub struct Shell {
    /// The session.
    pub session: zenoh::Session,
    /// Its id as tokens carry it.
    pub zid: String,
    /// The attachments' clock.
    pub clock: WallClock,
    watch_stop: Arc<AtomicBool>,
}

impl std::fmt::Debug for Shell {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Shell").field("zid", &self.zid).finish_non_exhaustive()
    }
}

impl Shell {
    /// Opens the session (it connects in the background) and starts the router watch.
    pub fn open(config: zenoh::Config, uses_defaults: bool) -> Result<Self, SessionError> {
        let session = zenoh::open(config).wait().map_err(|e| SessionError::Open(e.to_string()))?;
        let zid = session.zid().to_string();
        tracing::info!(%zid, "Zenoh session open (rmw_zenoh conventions)");
        let watch_stop = Arc::new(AtomicBool::new(false));
        let (watched, stop) = (session.clone(), Arc::clone(&watch_stop));
        let spawned = std::thread::Builder::new()
            .name("zenoh-router-watch".into())
            .spawn(move || watch_router(&watched, &stop, uses_defaults));
        if let Err(e) = spawned {
            tracing::warn!("Zenoh router watch not started: {e}");
        }
        Ok(Self { session, zid, clock: WallClock::anchored_now(), watch_stop })
    }
}

impl Drop for Shell {
    fn drop(&mut self) {
        self.watch_stop.store(true, Ordering::Relaxed);
    }
}

/// Says once, after [`ROUTER_GRACE`], that no router is reachable and how to start one; says when one is.
/// The session itself keeps retrying its connect endpoints.
fn watch_router(session: &zenoh::Session, stop: &AtomicBool, uses_defaults: bool) {
    let started = Instant::now();
    let (mut warned, mut connected) = (false, false);
    while !stop.load(Ordering::Relaxed) && !session.is_closed() {
        let routers = session.info().routers_zid().wait().count();
        if routers > 0 && !connected {
            tracing::info!(routers, "Zenoh router reachable: XRCE entities are in the ROS 2 graph");
        } else if routers == 0 && connected {
            tracing::warn!("Zenoh router lost; the session keeps retrying, XRCE clients are still served");
        }
        connected = routers > 0;
        if !connected && !warned && started.elapsed() >= ROUTER_GRACE {
            warned = true;
            let where_ = if uses_defaults {
                format!("at {DEFAULT_ROUTER} (rmw_zenoh's default)")
            } else {
                "through the configured endpoints".to_owned()
            };
            tracing::warn!(
                "no Zenoh router reachable {where_}: ROS 2 nodes on rmw_zenoh will not see the XRCE clients until \
                 one runs. The agent keeps serving XRCE clients and retrying. Start one with \
                 `ros2 run rmw_zenoh_cpp rmw_zenohd` (or `zenohd`), or point the agent elsewhere with \
                 --zenoh-config FILE or {SESSION_CONFIG_ENV}"
            );
        }
        std::thread::sleep(Duration::from_millis(250));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_config_is_a_peer_connecting_to_the_local_router() {
        let c = build_config(None).unwrap();
        let json = |k: &str| c.get_json(k).unwrap();
        assert_eq!(json("mode"), r#""peer""#);
        assert!(json("connect/endpoints").contains("tcp/localhost:7447"), "{}", json("connect/endpoints"));
        assert_eq!(json("scouting/multicast/enabled"), "false");
        assert!(json("timestamping/enabled").contains("true"));
        // rmw_zenoh's lease, not Zenoh's 10 s: a link is given up when a ROS node on the same router gives it up.
        assert_eq!(json("transport/link/tx/lease"), "60000");
        assert_eq!(json("transport/link/tx/keep_alive"), "2");
        assert!(json("scouting/gossip/target").contains(r#""peer":["router"]"#), "{}", json("scouting/gossip/target"));
    }

    #[test]
    fn a_missing_config_file_is_named() {
        let err = build_config(Some(Path::new("/nonexistent/zenoh.json5"))).unwrap_err().to_string();
        assert!(err.contains("/nonexistent/zenoh.json5"), "{err}");
    }

    #[test]
    fn the_cli_file_wins_over_the_environment() {
        assert_eq!(config_file(Some(Path::new("a.json5"))), Some(PathBuf::from("a.json5")));
    }

    #[test]
    fn wall_clock_advances_with_the_instants_given() {
        let c = WallClock::anchored_now();
        let later = c.start + Duration::from_millis(5);
        assert_eq!(c.ns_at(later) - c.ns_at(c.start), 5_000_000);
    }
}
