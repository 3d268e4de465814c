//! The library API of eProsima's agent (seed 003), in Rust.
//!
//! * [`Agent`]: a core with its middleware, usable with or without a running server: `create_client`,
//!   `delete_client`, `create_*_by_xml` / `create_*_by_ref` and `delete_*` for the 8 kinds,
//!   `load_config_file`, `reset`, `set_verbose_level`, `add_middleware_callback` (every callback kind fires,
//!   not only the participant ones as in eProsima).
//! * [`AgentInstance`]: built from `MicroXRCEAgent`-style arguments; starts its server at once, `run` blocks
//!   until `stop` (or a signal wired by the caller to [`AgentInstance::stop_flag`]).

use std::fmt::Debug;
use std::hash::Hash;
use std::net::{Ipv4Addr, Ipv6Addr, SocketAddr};
use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use xrce_proto::object::Representation;
use xrce_proto::submessage::CreationMode;
use xrce_proto::{ClientKey, EntityVariant, ObjectId, ObjectKind, StatusCode};

use crate::cli::{self, Config, Transport};
use crate::config_file::{FileConfig, TransportSpec};
use crate::core::{AgentCore, AgentSnapshot, CoreConfig, SnapshotBoard};
use crate::metrics::MetricsServer;
use crate::middleware::callbacks::{Callback, CallbackKind, CallbackRegistry, WithCallbacks};
use crate::middleware::profiles::StoreProfiles;
use crate::middleware::ros_graph::RosGraphMode;
use crate::middleware::{BuildError, DdsOptions, MiddlewareKind};
use crate::transport::discovery::DiscoveryServer;
use crate::transport::multi::{AnyEndpoint, MultiServer};
use crate::transport::tcp::{ConnId, TcpServer};
use crate::transport::udp::UdpServer;
use crate::transport::{DynMiddleware, SharedCore};

/// A refused operation, with the STATUS code an XRCE client would have received.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("operation failed: {}", .0.name())]
pub struct OpError(pub StatusCode);

/// Why an agent could not be built or run.
#[derive(Debug, thiserror::Error)]
pub enum AgentError {
    /// Bad command line (includes `--help`, whose text this is).
    #[error(transparent)]
    Cli(#[from] clap::Error),
    /// The middleware is not available.
    #[error(transparent)]
    Middleware(#[from] BuildError),
    /// The transport is not available on this system.
    #[error("transport `{0}` is not available on this system; available: udp4, udp6, tcp4, tcp6 (and on Linux serial, multiserial, pseudoterminal, canfd)")]
    Transport(&'static str),
    /// `-P/--p2p`: eProsima's agent-to-agent bridging of CED topics, which this agent does not have. micro-ROS
    /// builds eProsima's agent without it (`UAGENT_P2P_PROFILE=OFF`), and with DDS (the default middleware)
    /// agents already share topics through the DDS domain.
    #[error(
        "-P/--p2p {0}: agent-to-agent bridging (eProsima's P2P profile) is not supported; agents on the DDS \
         middleware (the default) share their topics through the DDS domain"
    )]
    P2p(u16),
    /// The configuration file (`--config`) is not valid.
    #[error(transparent)]
    ConfigFile(#[from] crate::config_file::ConfigFileError),
    /// The refs file could not be loaded.
    #[error(transparent)]
    Profile(#[from] crate::profile::ProfileError),
    /// A port or device could not be opened; `what` names it ("UDP port 0.0.0.0:8888", "serial device
    /// /dev/ttyACM0").
    #[error("{what}: {source}")]
    Open {
        /// The port or device.
        what: String,
        /// Why.
        #[source]
        source: std::io::Error,
    },
    /// Socket or thread error.
    #[error(transparent)]
    Io(#[from] std::io::Error),
}

/// An [`AgentError::Open`] naming `what`.
fn cannot_open(what: impl Into<String>) -> impl FnOnce(std::io::Error) -> AgentError {
    let what = what.into();
    move |source| AgentError::Open { what, source }
}

fn to_graph_mode(g: cli::RosGraph) -> RosGraphMode {
    match g {
        cli::RosGraph::On => RosGraphMode::Gid16,
        cli::RosGraph::Humble => RosGraphMode::Gid24,
        cli::RosGraph::Off => RosGraphMode::Off,
    }
}

fn to_cli_kind(kind: cli::MiddlewareKind) -> MiddlewareKind {
    match kind {
        cli::MiddlewareKind::Ced => MiddlewareKind::Ced,
        cli::MiddlewareKind::Dds => MiddlewareKind::Dds,
        cli::MiddlewareKind::Rtps => MiddlewareKind::Rtps,
        cli::MiddlewareKind::Zenoh => MiddlewareKind::Zenoh,
    }
}

/// How often the server's loop publishes a snapshot for `--metrics` and ROS 2 diagnostics.
pub const SNAPSHOT_PERIOD: Duration = Duration::from_secs(1);

/// An entity's text description, owned so that it can travel to the server's loop.
enum Repr {
    Xml(String),
    Reference(String),
}

/// Where an entity goes: a participant in a domain, anything else under its parent.
#[derive(Clone, Copy)]
enum Place {
    Domain(i16),
    Parent(ObjectId),
}

/// An agent core with its middleware, profiles and callbacks, for endpoints of type `E`.
pub struct Agent<E> {
    core: SharedCore<E>,
    profiles: Arc<StoreProfiles>,
    callbacks: CallbackRegistry,
}

impl<E> Clone for Agent<E> {
    fn clone(&self) -> Self {
        Self { core: self.core.clone(), profiles: self.profiles.clone(), callbacks: self.callbacks.clone() }
    }
}

impl<E> Debug for Agent<E> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Agent").finish_non_exhaustive()
    }
}

fn status(code: StatusCode) -> Result<StatusCode, OpError> {
    if code.is_ok() {
        Ok(code)
    } else {
        Err(OpError(code))
    }
}

macro_rules! entity_api {
    ($(($kind:ident, $xml:ident, $by_ref:ident, $delete:ident)),* $(,)?) => {
        $(
            #[doc = concat!("Creates a ", stringify!($kind), " from XML under `parent_id` (object number); `flags` are the CREATE flags (REUSE 0x02, REPLACE 0x04).")]
            pub fn $xml(&self, client_key: u32, id: u16, parent_id: u16, xml: &str, flags: u8) -> Result<StatusCode, OpError> {
                self.create_child(ObjectKind::$kind, client_key, id, parent_id, Repr::Xml(xml.into()), flags)
            }
            #[doc = concat!("Creates a ", stringify!($kind), " from a profile of the loaded refs under `parent_id`.")]
            pub fn $by_ref(&self, client_key: u32, id: u16, parent_id: u16, reference: &str, flags: u8) -> Result<StatusCode, OpError> {
                self.create_child(ObjectKind::$kind, client_key, id, parent_id, Repr::Reference(reference.into()), flags)
            }
            #[doc = concat!("Deletes a ", stringify!($kind), " and what hangs from it.")]
            pub fn $delete(&self, client_key: u32, id: u16) -> Result<StatusCode, OpError> {
                self.delete_entity(ObjectKind::$kind, client_key, id)
            }
        )*
    };
}

impl<E: Copy + Eq + Hash + Debug + Send + 'static> Agent<E> {
    /// An agent on `kind` (only CED exists yet) with the given core limits.
    pub fn new(kind: MiddlewareKind, config: CoreConfig) -> Result<Self, BuildError> {
        Self::with_dds(kind, config, RosGraphMode::default(), DdsOptions::default())
    }

    /// As [`Agent::new`], with the DDS middleware's ROS 2 graph mode (`--ros-graph`) and options
    /// (`--dds-engine`, `--eager-participant`, `--participant-names`).
    pub fn with_dds(
        kind: MiddlewareKind,
        config: CoreConfig,
        ros_graph: RosGraphMode,
        options: DdsOptions,
    ) -> Result<Self, BuildError> {
        let profiles = Arc::new(StoreProfiles::new());
        let middleware = kind.build_dds(profiles.clone(), ros_graph, options)?;
        let callbacks = CallbackRegistry::default();
        let wrapped: DynMiddleware = Box::new(WithCallbacks::with_registry(middleware, callbacks.clone()));
        let core = SharedCore::new(AgentCore::new(config, wrapped));
        Ok(Self { core, profiles, callbacks })
    }

    /// The core's handle, for transport shells (a server's loop owns the core while it runs; these calls
    /// then run in its next turn).
    pub fn core(&self) -> SharedCore<E> {
        self.core.clone()
    }

    /// Registers a ProxyClient ahead of its CREATE_CLIENT (its streams are reset then, its entities kept).
    pub fn create_client(&self, key: u32, session: u8, mtu: u16) -> Result<StatusCode, OpError> {
        status(self.core.with(move |c| c.create_client(ClientKey::from_u32(key), session, mtu, Instant::now())))
    }

    /// Deletes a client and its entities.
    pub fn delete_client(&self, key: u32) -> Result<StatusCode, OpError> {
        status(self.core.with(move |c| c.delete_client(ClientKey::from_u32(key))))
    }

    /// Creates a participant from XML in `domain_id` (255: the agent's domain).
    pub fn create_participant_by_xml(
        &self,
        client_key: u32,
        id: u16,
        domain_id: i16,
        xml: &str,
        flags: u8,
    ) -> Result<StatusCode, OpError> {
        self.create(
            client_key,
            ObjectId::new(id, ObjectKind::Participant),
            Place::Domain(domain_id),
            Repr::Xml(xml.into()),
            flags,
        )
    }

    /// Creates a participant from a profile of the loaded refs.
    pub fn create_participant_by_ref(
        &self,
        client_key: u32,
        id: u16,
        domain_id: i16,
        reference: &str,
        flags: u8,
    ) -> Result<StatusCode, OpError> {
        let repr = Repr::Reference(reference.into());
        self.create(client_key, ObjectId::new(id, ObjectKind::Participant), Place::Domain(domain_id), repr, flags)
    }

    /// Deletes a participant and everything under it.
    pub fn delete_participant(&self, client_key: u32, id: u16) -> Result<StatusCode, OpError> {
        self.delete_entity(ObjectKind::Participant, client_key, id)
    }

    entity_api!(
        (Topic, create_topic_by_xml, create_topic_by_ref, delete_topic),
        (Publisher, create_publisher_by_xml, create_publisher_by_ref, delete_publisher),
        (Subscriber, create_subscriber_by_xml, create_subscriber_by_ref, delete_subscriber),
        (DataWriter, create_datawriter_by_xml, create_datawriter_by_ref, delete_datawriter),
        (DataReader, create_datareader_by_xml, create_datareader_by_ref, delete_datareader),
        (Requester, create_requester_by_xml, create_requester_by_ref, delete_requester),
        (Replier, create_replier_by_xml, create_replier_by_ref, delete_replier),
    );

    fn create_child(
        &self,
        kind: ObjectKind,
        client_key: u32,
        id: u16,
        parent_id: u16,
        repr: Repr,
        flags: u8,
    ) -> Result<StatusCode, OpError> {
        let parent_kind = kind.parent().unwrap_or(ObjectKind::Participant);
        self.create(
            client_key,
            ObjectId::new(id, kind),
            Place::Parent(ObjectId::new(parent_id, parent_kind)),
            repr,
            flags,
        )
    }

    /// Creates an entity on the core (in the running server's turn if one runs: the strings go with it).
    fn create(
        &self,
        client_key: u32,
        id: ObjectId,
        place: Place,
        repr: Repr,
        flags: u8,
    ) -> Result<StatusCode, OpError> {
        status(self.core.with(move |c| {
            let representation = match &repr {
                Repr::Xml(xml) => Representation::Xml(xml),
                Repr::Reference(reference) => Representation::Reference(reference),
            };
            let variant = match place {
                Place::Domain(domain_id) => EntityVariant::participant(representation, domain_id),
                Place::Parent(parent) => EntityVariant::child(id.kind(), representation, parent),
            };
            let mode = CreationMode::from_flags(flags);
            c.create_entity(ClientKey::from_u32(client_key), id, &variant, mode, Instant::now())
        }))
    }

    fn delete_entity(&self, kind: ObjectKind, client_key: u32, id: u16) -> Result<StatusCode, OpError> {
        status(self.core.with(move |c| c.delete_entity(ClientKey::from_u32(client_key), ObjectId::new(id, kind))))
    }

    /// Loads a refs file (Fast DDS XML profiles) for entities created by reference; returns how many
    /// profiles it added.
    pub fn load_config_file(&self, path: impl AsRef<Path>) -> Result<usize, crate::profile::ProfileError> {
        self.profiles.load_file(path)
    }

    /// Deletes every client and its entities.
    pub fn reset(&self) {
        self.core.with(|c| c.reset());
    }

    /// The agent's state now ([`AgentSnapshot`]): every client with its streams and counters, the agent's
    /// totals, the middleware's. Built in the running server's next turn (or at once while none runs).
    pub fn snapshot(&self) -> AgentSnapshot {
        self.core.with(|c| c.snapshot(Instant::now()))
    }

    /// Sets the log level, eProsima's 0 (off) .. 6 (trace with hex dumps).
    pub fn set_verbose_level(&self, level: u8) {
        crate::logging::set_verbose_level(level);
    }

    /// Adds a callback fired after each successful create/delete of the matching kind.
    pub fn add_middleware_callback(
        &self,
        kind: CallbackKind,
        callback: impl Fn(CallbackKind, crate::middleware::EntityRef) + Send + Sync + 'static,
    ) {
        let cb: Callback = Arc::new(callback);
        self.callbacks.write().unwrap_or_else(std::sync::PoisonError::into_inner).push((kind, cb));
    }
}

/// The agent of an [`AgentInstance`], by transport family.
#[derive(Debug, Clone)]
pub enum AgentHandle {
    /// UDP servers: endpoints are socket addresses.
    Udp(Agent<SocketAddr>),
    /// TCP servers: endpoints are connections.
    Tcp(Agent<ConnId>),
    /// Serial servers (`serial`, `multiserial`, `pseudoterminal`): endpoints are (line, address).
    #[cfg(target_os = "linux")]
    Serial(Agent<crate::transport::serial::SerialEndpoint>),
    /// The CAN FD server: endpoints are the clients' CAN identifiers.
    #[cfg(target_os = "linux")]
    Can(Agent<crate::transport::canfd::CanEndpoint>),
    /// Several transports from a configuration file (`--config`): endpoints name the transport too.
    Multi(Agent<AnyEndpoint>),
}

/// Runs `$body` with `$agent` bound to the [`Agent`] of any transport family.
macro_rules! each_agent {
    ($handle:expr, $agent:ident => $body:expr) => {
        match $handle {
            AgentHandle::Udp($agent) => $body,
            AgentHandle::Tcp($agent) => $body,
            #[cfg(target_os = "linux")]
            AgentHandle::Serial($agent) => $body,
            #[cfg(target_os = "linux")]
            AgentHandle::Can($agent) => $body,
            AgentHandle::Multi($agent) => $body,
        }
    };
}

impl AgentHandle {
    /// The agent's state now ([`Agent::snapshot`]).
    pub fn snapshot(&self) -> AgentSnapshot {
        each_agent!(self, agent => agent.snapshot())
    }

    /// Publishes snapshots to `board` every `period` from the server's loop ([`AgentCore::publish_snapshots`]).
    fn publish_snapshots(&self, board: Option<Arc<SnapshotBoard>>, period: Duration) {
        each_agent!(self, agent => agent.core.with(move |c| c.publish_snapshots(board, period, Instant::now())))
    }

    /// Names the transport in snapshots.
    fn set_transport_name(&self, name: &'static str) {
        each_agent!(self, agent => agent.core.with(move |c| c.set_transport_name(name)))
    }
}

/// What shows the agent's state (`--metrics`, `--ros-diagnostics`): started before the transports, so that
/// a metrics port taken stops nothing that runs, and hooked to the agent once it runs.
struct Observer {
    board: Arc<SnapshotBoard>,
    metrics: Option<MetricsServer>,
}

impl Observer {
    /// Binds the `--metrics` server, if asked for.
    fn start(config: &Config) -> Result<Self, AgentError> {
        let board = Arc::new(SnapshotBoard::default());
        let metrics = config
            .metrics
            .map(|addr| MetricsServer::start(addr, board.clone()).map_err(cannot_open(format!("metrics port {addr}"))))
            .transpose()?;
        Ok(Self { board, metrics })
    }

    /// Has `agent`'s loop publish snapshots when something reads them: the metrics server, or ROS 2
    /// diagnostics (written by the DDS middleware from each snapshot); returns the metrics server.
    fn observe(self, agent: &AgentHandle, config: &Config) -> Option<MetricsServer> {
        let diagnostics = config.ros_diagnostics && to_cli_kind(config.middleware) != MiddlewareKind::Ced;
        if self.metrics.is_some() || diagnostics {
            agent.publish_snapshots(self.metrics.is_some().then_some(self.board), SNAPSHOT_PERIOD);
        }
        self.metrics
    }
}

/// A running agent built from command-line arguments (eProsima's `AgentInstance`).
#[derive(Debug)]
pub struct AgentInstance {
    config: Config,
    agent: AgentHandle,
    stop: Arc<AtomicBool>,
    server: Option<JoinHandle<std::io::Result<()>>>,
    local_addr: Option<SocketAddr>,
    metrics: Option<MetricsServer>,
}

impl AgentInstance {
    /// Parses `args` (`args[0]` is the program name) and starts the agent.
    pub fn create<I, T>(args: I) -> Result<Self, AgentError>
    where
        I: IntoIterator<Item = T>,
        T: Into<std::ffi::OsString> + Clone,
    {
        Self::from_config(cli::parse_from(args)?)
    }

    /// Starts an agent for a parsed command line.
    pub fn from_config(config: Config) -> Result<Self, AgentError> {
        let kind = to_cli_kind(config.middleware);
        let graph = to_graph_mode(config.ros_graph);
        let dds = dds_options(&config);
        let stop = Arc::new(AtomicBool::new(false));
        if let Some(port) = config.p2p {
            return Err(AgentError::P2p(port));
        }
        let observer = Observer::start(&config)?;
        let (agent, server, local_addr) = match config.transport {
            Transport::Udp4 { port } | Transport::Udp6 { port } => {
                let agent = Agent::<SocketAddr>::with_dds(
                    kind,
                    CoreConfig { info_port: port, ..core_config(&config) },
                    graph,
                    dds,
                )?;
                load_refs(&config, &agent.profiles)?;
                agent.core.with(|c| c.set_peer_address(|peer| Some(*peer)));
                let addr = bind_addr(&config.transport, port);
                let mut server =
                    UdpServer::bind(addr, agent.core()).map_err(cannot_open(format!("UDP port {addr}")))?;
                let local = server.local_addr()?;
                if let Some(d) = discovery_for(&config, local.port())? {
                    server = server.with_discovery(d);
                }
                tracing::info!(%local, middleware = kind.name(), "UDP agent running");
                let stop2 = stop.clone();
                let handle = std::thread::Builder::new().name("xrce-udp".into()).spawn(move || server.run(&stop2))?;
                (AgentHandle::Udp(agent), handle, Some(local))
            }
            Transport::Tcp4 { port } | Transport::Tcp6 { port } => {
                let agent = Agent::<ConnId>::with_dds(
                    kind,
                    CoreConfig { info_port: port, ..core_config(&config) },
                    graph,
                    dds,
                )?;
                load_refs(&config, &agent.profiles)?;
                agent.core.with(|c| c.set_peer_address(|conn| Some(conn.peer)));
                let addr = bind_addr(&config.transport, port);
                let mut server = TcpServer::bind(addr, agent.core())
                    .map_err(cannot_open(format!("TCP port {addr}")))?
                    .with_max_connections(config.max_connections);
                let local = server.local_addr()?;
                if let Some(d) = discovery_for(&config, local.port())? {
                    server = server.with_discovery(d);
                }
                tracing::info!(%local, middleware = kind.name(), "TCP agent running");
                let stop2 = stop.clone();
                let handle = std::thread::Builder::new().name("xrce-tcp".into()).spawn(move || server.run(&stop2))?;
                (AgentHandle::Tcp(agent), handle, Some(local))
            }
            #[cfg(target_os = "linux")]
            Transport::Serial { ref device, baudrate } => {
                let line = crate::transport::serial::Line::open(Path::new(device), baudrate, config.flow_control)
                    .map_err(cannot_open(format!("serial device {device}")))?;
                start_serial(kind, &config, vec![line], &stop)?
            }
            #[cfg(target_os = "linux")]
            Transport::MultiSerial { ref devices, baudrate } => {
                let lines = devices
                    .iter()
                    .map(|d| {
                        crate::transport::serial::Line::open(Path::new(d), baudrate, config.flow_control)
                            .map_err(cannot_open(format!("serial device {d}")))
                    })
                    .collect::<Result<Vec<_>, _>>()?;
                start_serial(kind, &config, lines, &stop)?
            }
            #[cfg(target_os = "linux")]
            Transport::PseudoTerminal { baudrate } => {
                let line =
                    crate::transport::serial::Line::pseudoterminal(baudrate).map_err(cannot_open("pseudoterminal"))?;
                // eProsima's message; scripts read the device name from it.
                println!("Pseudo-Serial device opened at {}", line.name());
                start_serial(kind, &config, vec![line], &stop)?
            }
            #[cfg(target_os = "linux")]
            Transport::CanFd { ref device, can_id } => start_can(kind, &config, device, can_id, &stop)?,
            #[cfg(not(target_os = "linux"))]
            ref other => return Err(AgentError::Transport(other.name())),
        };
        if config.discovery.is_some() && local_addr.is_none() {
            tracing::warn!("-d/--discovery needs a UDP or TCP transport; ignored");
        }
        agent.set_transport_name(config.transport.name());
        let metrics = observer.observe(&agent, &config);
        Ok(Self { config, agent, stop, server: Some(server), local_addr, metrics })
    }

    /// Starts one agent on every transport of a configuration file (`--config`): every port and device is
    /// opened before any is served, so a failure leaves nothing running.
    pub fn from_file(file: FileConfig) -> Result<Self, AgentError> {
        let config = file.options;
        if let Some(port) = config.p2p {
            return Err(AgentError::P2p(port));
        }
        let kind = to_cli_kind(config.middleware);
        let observer = Observer::start(&config)?;
        let mut core = core_config(&config);
        if file.transports.iter().any(|t| matches!(t.transport, Transport::CanFd { .. })) {
            // One frame per message on the bus; the clients of the other transports get it too (one core).
            #[cfg(target_os = "linux")]
            {
                core.max_mtu = crate::transport::canfd::core_config().max_mtu;
            }
        }
        core.info_port = file.transports.iter().find_map(|t| t.transport.port()).unwrap_or(core.info_port);
        let agent = Agent::<AnyEndpoint>::with_dds(kind, core, to_graph_mode(config.ros_graph), dds_options(&config))?;
        load_refs(&config, &agent.profiles)?;
        agent.core.with(|c| {
            c.set_peer_address(AnyEndpoint::ip_address);
            c.set_transport_name("multi");
            c.set_endpoint_transport(AnyEndpoint::transport_name);
        });
        let mut server = MultiServer::new(agent.core())?;
        let mut local_addr = None;
        for spec in &file.transports {
            let opened = open_transport(&mut server, spec)?;
            local_addr = local_addr.or(opened);
        }
        if let Some(d) = local_addr.map(|a| discovery_for(&config, a.port())).transpose()?.flatten() {
            server = server.with_discovery(d);
        } else if config.discovery.is_some() {
            tracing::warn!("-d/--discovery needs a UDP or TCP transport; ignored");
        }
        tracing::info!(transports = ?server.names(), middleware = kind.name(), "agent running");
        let stop = Arc::new(AtomicBool::new(false));
        let stop2 = stop.clone();
        let handle = std::thread::Builder::new().name("xrce-agent".into()).spawn(move || server.run(&stop2))?;
        let agent = AgentHandle::Multi(agent);
        let metrics = observer.observe(&agent, &config);
        Ok(Self { config, agent, stop, server: Some(handle), local_addr, metrics })
    }

    /// The command line it was built from.
    pub fn config(&self) -> &Config {
        &self.config
    }

    /// The agent, to create clients and entities or add callbacks.
    pub fn agent(&self) -> &AgentHandle {
        &self.agent
    }

    /// The address the server listens on.
    pub fn local_addr(&self) -> Option<SocketAddr> {
        self.local_addr
    }

    /// The address of the `--metrics` server, if it runs.
    pub fn metrics_addr(&self) -> Option<SocketAddr> {
        self.metrics.as_ref().map(MetricsServer::local_addr)
    }

    /// Setting this flag stops the agent (e.g. from a signal handler).
    pub fn stop_flag(&self) -> Arc<AtomicBool> {
        self.stop.clone()
    }

    /// Blocks until the agent is stopped, then returns the server's result.
    pub fn run(&mut self) -> Result<(), AgentError> {
        // The server checks the stop flag itself (at least every `MAX_BLOCK`), so joining it is enough: this
        // thread sleeps without waking up to poll the flag (it did 20 times a second, issue 21).
        let joined = self.join_server();
        self.stop.store(true, Ordering::Relaxed);
        joined
    }

    /// Stops the agent and waits for its server to finish.
    pub fn stop(&mut self) -> Result<(), AgentError> {
        self.stop.store(true, Ordering::Relaxed);
        self.join_server()
    }

    fn join_server(&mut self) -> Result<(), AgentError> {
        match self.server.take().map(JoinHandle::join) {
            Some(Ok(result)) => Ok(result?),
            Some(Err(_)) => Err(AgentError::Io(std::io::Error::other("server thread panicked"))),
            None => Ok(()),
        }
    }
}

impl Drop for AgentInstance {
    fn drop(&mut self) {
        let _ = self.stop();
    }
}

/// A server thread and what an [`AgentInstance`] keeps of it.
#[cfg(target_os = "linux")]
type Started = (AgentHandle, JoinHandle<std::io::Result<()>>, Option<SocketAddr>);

/// The core's settings from the command line (`--client-timeout`, `--allow`, `--psk-file`).
fn core_config(config: &Config) -> CoreConfig {
    if config.auth.is_enabled() {
        tracing::info!(allow = config.auth.allow.len(), psk = config.auth.psk.is_some(), "client authentication on");
    }
    CoreConfig {
        remove_silent_clients_after: config.client_timeout,
        auth: config.auth.clone(),
        ..CoreConfig::default()
    }
}

/// The DDS middleware's options from the command line.
fn dds_options(config: &Config) -> DdsOptions {
    DdsOptions {
        engine: config.dds_engine.map(xrce_dds::Engine::from),
        eager_participant: config.eager_participant,
        share_participants: !config.participant_names,
        shared_memory: config.dds_shm,
        ros_diagnostics: config.ros_diagnostics,
        zenoh_config: config.zenoh_config.clone(),
    }
}

/// Starts a serial server on `lines`.
#[cfg(target_os = "linux")]
fn start_serial(
    kind: MiddlewareKind,
    config: &Config,
    lines: Vec<crate::transport::serial::Line>,
    stop: &Arc<AtomicBool>,
) -> Result<Started, AgentError> {
    let agent = Agent::with_dds(kind, core_config(config), to_graph_mode(config.ros_graph), dds_options(config))?;
    load_refs(config, &agent.profiles)?;
    let server = crate::transport::serial::SerialServer::new(lines, agent.core());
    tracing::info!(lines = ?server.names(), middleware = kind.name(), "serial agent running");
    let stop2 = stop.clone();
    let handle = std::thread::Builder::new().name("xrce-serial".into()).spawn(move || server.run(&stop2))?;
    Ok((AgentHandle::Serial(agent), handle, None))
}

/// Starts a CAN FD server on the SocketCAN interface `device`. `can_id` (`-I`) is logged only: eProsima's agent
/// takes it and does not use it either (it answers every client on the client's own identifier).
#[cfg(target_os = "linux")]
fn start_can(
    kind: MiddlewareKind,
    config: &Config,
    device: &str,
    can_id: u32,
    stop: &Arc<AtomicBool>,
) -> Result<Started, AgentError> {
    use crate::transport::canfd::{core_config as can_core_config, CanServer, SocketCanBus};
    let bus = SocketCanBus::open(device).map_err(cannot_open(format!("CAN interface {device}")))?;
    let core = CoreConfig { max_mtu: can_core_config().max_mtu, ..core_config(config) };
    let agent = Agent::with_dds(kind, core, to_graph_mode(config.ros_graph), dds_options(config))?;
    load_refs(config, &agent.profiles)?;
    let server = CanServer::new(bus, device, agent.core())?;
    tracing::info!(device, id = format_args!("{can_id:#x}"), middleware = kind.name(), "CAN FD agent running");
    let stop2 = stop.clone();
    let handle = std::thread::Builder::new().name("xrce-canfd".into()).spawn(move || server.run(&stop2))?;
    Ok((AgentHandle::Can(agent), handle, None))
}

/// The `-d` discovery responder on its port (joining 239.255.0.2), advertising `service_port`, if asked for;
/// the server answers it from its own loop.
fn discovery_for(config: &Config, service_port: u16) -> Result<Option<DiscoveryServer>, AgentError> {
    let Some(port) = config.discovery else { return Ok(None) };
    let server = DiscoveryServer::bind_multicast(port, service_port)
        .map_err(cannot_open(format!("discovery port 0.0.0.0:{port}")))?;
    tracing::info!(port, service_port, "discovery server running");
    Ok(Some(server))
}

/// Opens the transport of `spec` and adds it to `server`; returns its address if it has one.
fn open_transport(server: &mut MultiServer, spec: &TransportSpec) -> Result<Option<SocketAddr>, AgentError> {
    let transport = &spec.transport;
    match transport {
        Transport::Udp4 { port } | Transport::Udp6 { port } => {
            let addr = bind_addr(transport, *port);
            let socket = crate::transport::udp::bind_socket(addr).map_err(cannot_open(format!("UDP port {addr}")))?;
            let local = socket.local_addr()?;
            server.add_udp(socket)?;
            Ok(Some(local))
        }
        Transport::Tcp4 { port } | Transport::Tcp6 { port } => {
            let addr = bind_addr(transport, *port);
            let listener = std::net::TcpListener::bind(addr).map_err(cannot_open(format!("TCP port {addr}")))?;
            let local = listener.local_addr()?;
            server.add_tcp(listener, spec.max_connections)?;
            Ok(Some(local))
        }
        #[cfg(target_os = "linux")]
        Transport::Serial { device, baudrate } => {
            open_serial(server, std::slice::from_ref(device), *baudrate, spec.flow_control)?;
            Ok(None)
        }
        #[cfg(target_os = "linux")]
        Transport::MultiSerial { devices, baudrate } => {
            open_serial(server, devices, *baudrate, spec.flow_control)?;
            Ok(None)
        }
        #[cfg(target_os = "linux")]
        Transport::PseudoTerminal { baudrate } => {
            let line =
                crate::transport::serial::Line::pseudoterminal(*baudrate).map_err(cannot_open("pseudoterminal"))?;
            // eProsima's message; scripts read the device name from it.
            println!("Pseudo-Serial device opened at {}", line.name());
            server.add_serial(vec![line])?;
            Ok(None)
        }
        #[cfg(target_os = "linux")]
        Transport::CanFd { device, .. } => {
            let bus = crate::transport::canfd::SocketCanBus::open(device)
                .map_err(cannot_open(format!("CAN interface {device}")))?;
            server.add_can(bus, device.clone())?;
            Ok(None)
        }
        #[cfg(not(target_os = "linux"))]
        other => Err(AgentError::Transport(other.name())),
    }
}

/// Opens serial `devices` and adds them to `server` as one transport.
#[cfg(target_os = "linux")]
fn open_serial(server: &mut MultiServer, devices: &[String], baud: u32, flow_control: bool) -> Result<(), AgentError> {
    let lines = devices
        .iter()
        .map(|d| {
            crate::transport::serial::Line::open(Path::new(d), baud, flow_control)
                .map_err(cannot_open(format!("serial device {d}")))
        })
        .collect::<Result<Vec<_>, _>>()?;
    server.add_serial(lines)?;
    Ok(())
}

fn load_refs(config: &Config, profiles: &StoreProfiles) -> Result<(), AgentError> {
    if let Some(path) = &config.refs {
        let n = profiles.load_file(path)?;
        tracing::info!(path = %path.display(), profiles = n, "refs loaded");
    }
    Ok(())
}

fn bind_addr(transport: &Transport, port: u16) -> SocketAddr {
    match transport {
        Transport::Udp6 { .. } | Transport::Tcp6 { .. } => SocketAddr::from((Ipv6Addr::UNSPECIFIED, port)),
        _ => SocketAddr::from((Ipv4Addr::UNSPECIFIED, port)),
    }
}
