//! The boundary between the XRCE agent core and whatever carries the data: the in-agent router
//! ([`ced`]), a real DDS domain ([`dds`]), and a ROS 2 graph on rmw_zenoh (`zenoh`, cargo feature `zenoh`).
//!
//! The core calls the middleware synchronously: to create and delete entities, to write samples, requests
//! and replies, and to take samples for readers that have an active read task. A middleware whose data
//! arrives on its own threads (DDS) keeps it in bounded per-reader queues and calls the [`Waker`] it was given
//! so the transport shell runs the core, which then polls the readers with active read tasks
//! ([`Middleware::poll_sample`], a visitor that copies each sample once into the outgoing message). No
//! method blocks or reads the clock: a write the middleware cannot take now returns
//! [`WriteOutcome::WouldBlock`] and the core retries it. CED needs no waker: samples appear only
//! through writes the core itself performs, after which it polls the readers anyway.

pub mod callbacks;
pub mod ced;
pub mod dds;
pub mod describe;
pub mod diagnostics;
pub mod profiles;
pub mod ros_graph;
#[cfg(feature = "zenoh")]
pub mod zenoh;

use std::fmt;
use std::sync::Arc;
use std::time::Instant;

use xrce_proto::layout::SampleBody;
use xrce_proto::{
    BaseObjectRequest, ClientKey, Endianness, EntityVariant, ObjectId, ObjectKind, RequestId, SampleIdentity,
};

pub use describe::{Description, ProfileSource, TopicRef};

/// An entity of a client: the client's key and the object id (kind in the low nibble).
#[derive(Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct EntityRef {
    /// Owner.
    pub client: ClientKey,
    /// Object id with its kind.
    pub id: ObjectId,
}

impl EntityRef {
    /// The entity `id` of `client`.
    pub const fn new(client: ClientKey, id: ObjectId) -> Self {
        Self { client, id }
    }

    /// Kind of the entity.
    pub const fn kind(&self) -> ObjectKind {
        self.id.kind()
    }
}

impl fmt::Debug for EntityRef {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}/{}({:?})", self.client, self.id, self.id.kind())
    }
}

/// What the core asks a middleware to create.
#[derive(Debug, Clone, Copy)]
pub struct Creation<'a> {
    /// The new entity (id rebuilt with the variant's kind, spec §5.2).
    pub entity: EntityRef,
    /// Its parent (participant, publisher or subscriber), already checked to exist in the client's table.
    pub parent: Option<EntityRef>,
    /// The representation as received.
    pub variant: &'a EntityVariant<'a>,
    /// Byte order of binary blobs (the E flag of the CREATE).
    pub endian: Endianness,
    /// When the CREATE was handled.
    pub now: Instant,
}

/// How many entities each client holds in a middleware's registry, so deleting a client whose entities are
/// already gone (the usual case: the core deletes them one by one first) costs no scan of the registry.
#[derive(Debug, Default)]
pub(crate) struct EntityCounts(std::collections::HashMap<ClientKey, u32>);

impl EntityCounts {
    /// `client` gained an entity.
    pub(crate) fn added(&mut self, client: ClientKey) {
        *self.0.entry(client).or_default() += 1;
    }

    /// `client` lost an entity.
    pub(crate) fn removed(&mut self, client: ClientKey) {
        if let Some(n) = self.0.get_mut(&client) {
            *n = n.saturating_sub(1);
            if *n == 0 {
                self.0.remove(&client);
            }
        }
    }

    /// Whether `client` holds any entity.
    pub(crate) fn holds_any(&self, client: ClientKey) -> bool {
        self.0.contains_key(&client)
    }

    /// Forgets `client` (all its entities go at once); whether it held any.
    pub(crate) fn forget(&mut self, client: ClientKey) -> bool {
        self.0.remove(&client).is_some()
    }
}

/// Why a middleware refused an operation; the core maps it to a STATUS code.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum MiddlewareError {
    /// The description could not be understood or refers to something unknown (STATUS_ERR_DDS_ERROR).
    #[error("invalid entity description: {0}")]
    InvalidDescription(String),
    /// A referenced entity does not exist in the middleware (STATUS_ERR_UNKNOWN_REFERENCE).
    #[error("unknown reference: {0}")]
    UnknownReference(String),
    /// A bound was reached (STATUS_ERR_RESOURCES).
    #[error("out of resources: {0}")]
    Resources(String),
    /// The operation does not apply to this entity or middleware (STATUS_ERR_DDS_ERROR).
    #[error("unsupported: {0}")]
    Unsupported(String),
}

impl MiddlewareError {
    /// The STATUS code eProsima would answer with.
    pub const fn status(&self) -> xrce_proto::StatusCode {
        use xrce_proto::StatusCode;
        match self {
            Self::InvalidDescription(_) | Self::Unsupported(_) => StatusCode::ERR_DDS_ERROR,
            Self::UnknownReference(_) => StatusCode::ERR_UNKNOWN_REFERENCE,
            Self::Resources(_) => StatusCode::ERR_RESOURCES,
        }
    }
}

/// A sample taken for a read task, shaped by the kind of the reading entity (spec §6.8), owned (tests and
/// [`Middleware::take_sample`]); the core sees samples borrowed, as [`SampleRef`].
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Sample {
    /// For a datareader: the serialized sample.
    Data(Vec<u8>),
    /// For a replier: a request and the identity the reply must carry.
    Request {
        /// Identity of the request.
        identity: SampleIdentity,
        /// Request bytes.
        data: Vec<u8>,
    },
    /// For a requester: a reply to the request that was written with `request_id`.
    Reply {
        /// Request id of the WRITE_DATA that carried the request.
        request_id: RequestId,
        /// Reply bytes.
        data: Vec<u8>,
    },
}

impl Sample {
    /// Bytes the sample takes in a DATA payload after the read's `BaseObjectRequest`.
    pub fn wire_size(&self) -> usize {
        self.as_ref().wire_size()
    }

    /// The sample, borrowed.
    pub fn as_ref(&self) -> SampleRef<'_> {
        match self {
            Self::Data(d) => SampleRef::Data(d),
            Self::Request { identity, data } => SampleRef::Request { identity: *identity, data },
            Self::Reply { request_id, data } => SampleRef::Reply { request_id: *request_id, data },
        }
    }
}

/// A sample as the middleware holds it, lent to the core's visitor ([`Middleware::poll_sample`]), which
/// copies it once, straight into the outgoing message.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SampleRef<'a> {
    /// For a datareader: the serialized sample.
    Data(&'a [u8]),
    /// For a replier: a request and the identity the reply must carry.
    Request {
        /// Identity of the request.
        identity: SampleIdentity,
        /// Request bytes.
        data: &'a [u8],
    },
    /// For a requester: a reply to the request that was written with `request_id`.
    Reply {
        /// Request id of the WRITE_DATA that carried the request.
        request_id: RequestId,
        /// Reply bytes.
        data: &'a [u8],
    },
}

impl<'a> SampleRef<'a> {
    /// The sample as the body of a DATA for `reader`'s read task (a reply starts with the request it
    /// answers: the request id of the WRITE_DATA that carried it and the requester, eProsima's format).
    pub fn body(&self, reader: ObjectId) -> SampleBody<'a> {
        match *self {
            Self::Data(d) => SampleBody::Plain(d),
            Self::Request { identity, data } => SampleBody::WithIdentity { identity, data },
            Self::Reply { request_id, data } => {
                SampleBody::Reply { related: BaseObjectRequest { request_id, object_id: reader }, data }
            }
        }
    }

    /// Bytes the sample takes in a DATA payload after the read's `BaseObjectRequest`.
    pub fn wire_size(&self) -> usize {
        // The reader's id does not change the size.
        self.body(ObjectId::INVALID).encoded_len()
    }

    /// An owned copy.
    pub fn to_owned(&self) -> Sample {
        match *self {
            Self::Data(d) => Sample::Data(d.to_vec()),
            Self::Request { identity, data } => Sample::Request { identity, data: data.to_vec() },
            Self::Reply { request_id, data } => Sample::Reply { request_id, data: data.to_vec() },
        }
    }
}

/// What became of a write. A middleware never blocks the core: when it cannot take a sample now it says
/// so, the core keeps the client's message (unacknowledged, on a reliable stream) and retries after the
/// middleware's next poll, which the middleware asks for through its [`Waker`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[must_use]
pub enum WriteOutcome {
    /// The sample was taken.
    Accepted,
    /// No room now (a full DDS history); nothing was written.
    WouldBlock,
}

/// Wakes the transport shell when a middleware has new samples on its own (threaded middlewares).
pub type Waker = Arc<dyn Fn() + Send + Sync>;

/// The visitor [`Middleware::poll_sample`] lends a sample to; it returns whether it took the sample.
pub type SampleVisitor<'v> = dyn FnMut(SampleRef<'_>) -> bool + 'v;

/// What the agent core needs from a middleware. No method blocks or reads the clock: `now` is passed in.
pub trait Middleware {
    /// Creates an entity. The core has already applied the creation mode (spec §11) and checked the parent.
    fn create(&mut self, creation: &Creation<'_>) -> Result<(), MiddlewareError>;

    /// Whether an existing entity is "the same" as the one `creation` describes (REUSE, spec §7.5).
    fn matches(&self, creation: &Creation<'_>) -> bool;

    /// Deletes one entity; the core deletes children first.
    fn delete(&mut self, entity: EntityRef) -> Result<(), MiddlewareError>;

    /// Forgets everything of a client (after the core deleted its entities one by one).
    fn delete_client(&mut self, _client: ClientKey) {}

    /// Publishes a sample through a datawriter.
    fn write_data(&mut self, writer: EntityRef, data: &[u8], now: Instant) -> Result<WriteOutcome, MiddlewareError>;

    /// Sends a request through a requester; replies come back as [`SampleRef::Reply`] with `request_id`.
    fn write_request(
        &mut self,
        requester: EntityRef,
        request_id: RequestId,
        data: &[u8],
        now: Instant,
    ) -> Result<WriteOutcome, MiddlewareError>;

    /// Sends a reply through a replier to the request identified by `identity`.
    fn write_reply(
        &mut self,
        replier: EntityRef,
        identity: &SampleIdentity,
        data: &[u8],
        now: Instant,
    ) -> Result<WriteOutcome, MiddlewareError>;

    /// A read task starts on a datareader, requester or replier.
    fn start_reading(&mut self, reader: EntityRef) -> Result<(), MiddlewareError>;

    /// The read task of `reader` ended (cancelled, finished, entity deleted).
    fn stop_reading(&mut self, _reader: EntityRef) {}

    /// Lends the next sample of `reader` to `visit`, which copies it out and returns true, or returns false
    /// to leave it for later (it does not fit the message or the read's pace yet). `None`: no sample.
    fn poll_sample(&mut self, reader: EntityRef, visit: &mut SampleVisitor<'_>) -> Option<bool>;

    /// Takes the next sample of `reader`, copied (tests, tools; the core uses [`Self::poll_sample`]).
    fn take_sample(&mut self, reader: EntityRef) -> Option<Sample> {
        let mut taken = None;
        self.poll_sample(reader, &mut |s| {
            taken = Some(s.to_owned());
            true
        });
        taken
    }

    /// Runs the middleware's own pending work (the DDS middleware: best-effort samples held at a
    /// first-contact gate); the core calls it when the waker fired and on its timers. Default: nothing.
    fn poll(&mut self, _now: Instant) {}

    /// Does the work the middleware put off until the shell has sent its turn's messages (the DDS
    /// middleware: the DDS writes of samples it handed to the agent's own readers ahead, so that the DDS write
    /// is not on the way from one client to the other). The core calls it from
    /// [`AgentCore::after_send`](crate::core::AgentCore::after_send), and from `handle_timeout` once
    /// [`Self::flush_due`]. Not from [`Self::poll`], which runs before the turn's sends. Default: nothing.
    fn flush(&mut self, _now: Instant) {}

    /// When work waiting for [`Self::flush`] is due at the latest, if any: the core's `poll_timeout` reports
    /// it, so a shell that does not call `after_send` runs it with its timers. Default: never.
    fn flush_due(&self) -> Option<Instant> {
        None
    }

    /// Installs the waker for samples arriving outside core calls; synchronous middlewares ignore it.
    fn set_waker(&mut self, _waker: Waker) {}

    /// Back-pressure for reliable writers, as one number: how many samples `writer` (a datawriter, requester
    /// or replier) may publish now without making the middleware drop a sample that a reliable reader has
    /// not taken yet, or that a reader it is about to match would miss (DDS: the first-contact gate of a new
    /// writer). At 0 the core leaves the client's reliable message unprocessed (held in its input window,
    /// unacknowledged) and retries after deliveries or the middleware's next poll, so the client's own
    /// history fills and its writes block. Default: unlimited.
    fn write_credit(&mut self, _writer: EntityRef, _now: Instant) -> u32 {
        u32::MAX
    }

    /// The read task of `reader` delivers on a reliable stream (`true`, from its start) or ended / is best
    /// effort / its client stopped acknowledging (`false`): what a reliable reader has not taken should be
    /// kept, and counts against the credit of its topic's writers ([`Self::write_credit`]).
    fn set_reader_reliable(&mut self, _reader: EntityRef, _reliable: bool) {}

    /// Its state for [`AgentCore::snapshot`](crate::core::AgentCore::snapshot); read once per snapshot, not
    /// per sample. Default: nothing known (zeros).
    fn stats(&self) -> MiddlewareStats {
        MiddlewareStats::default()
    }

    /// The name of `client`'s named participant (its ROS 2 node, for micro-ROS), if the middleware keeps
    /// one; read once per snapshot. Default: none.
    fn client_name(&self, _client: ClientKey) -> Option<String> {
        None
    }

    /// Sees each snapshot the core publishes ([`AgentCore::publish_snapshots`](crate::core::AgentCore::publish_snapshots)),
    /// on the loop's thread: the DDS middleware writes ROS 2 `/diagnostics` from it. Default: nothing.
    fn on_snapshot(&mut self, _snapshot: &crate::core::AgentSnapshot, _now: Instant) {}
}

/// A middleware's state in a snapshot: what holds samples back, and what it created in DDS.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct MiddlewareStats {
    /// Writers whose [`Middleware::write_credit`] is 0 now (their clients' reliable input is held).
    pub writers_without_credit: u64,
    /// Samples held at a new DDS writer's first-contact gate (until its readers are matched).
    pub samples_at_gate: u64,
    /// DDS participants (or CED's per-client participants).
    pub participants: u64,
    /// Topics.
    pub topics: u64,
}

impl<M: Middleware + ?Sized> Middleware for Box<M> {
    fn create(&mut self, creation: &Creation<'_>) -> Result<(), MiddlewareError> {
        (**self).create(creation)
    }
    fn matches(&self, creation: &Creation<'_>) -> bool {
        (**self).matches(creation)
    }
    fn delete(&mut self, entity: EntityRef) -> Result<(), MiddlewareError> {
        (**self).delete(entity)
    }
    fn delete_client(&mut self, client: ClientKey) {
        (**self).delete_client(client);
    }
    fn write_data(&mut self, writer: EntityRef, data: &[u8], now: Instant) -> Result<WriteOutcome, MiddlewareError> {
        (**self).write_data(writer, data, now)
    }
    fn write_request(
        &mut self,
        requester: EntityRef,
        id: RequestId,
        data: &[u8],
        now: Instant,
    ) -> Result<WriteOutcome, MiddlewareError> {
        (**self).write_request(requester, id, data, now)
    }
    fn write_reply(
        &mut self,
        replier: EntityRef,
        identity: &SampleIdentity,
        data: &[u8],
        now: Instant,
    ) -> Result<WriteOutcome, MiddlewareError> {
        (**self).write_reply(replier, identity, data, now)
    }
    fn start_reading(&mut self, reader: EntityRef) -> Result<(), MiddlewareError> {
        (**self).start_reading(reader)
    }
    fn stop_reading(&mut self, reader: EntityRef) {
        (**self).stop_reading(reader);
    }
    fn poll_sample(&mut self, reader: EntityRef, visit: &mut SampleVisitor<'_>) -> Option<bool> {
        (**self).poll_sample(reader, visit)
    }
    fn poll(&mut self, now: Instant) {
        (**self).poll(now);
    }
    fn flush(&mut self, now: Instant) {
        (**self).flush(now);
    }
    fn flush_due(&self) -> Option<Instant> {
        (**self).flush_due()
    }
    fn set_waker(&mut self, waker: Waker) {
        (**self).set_waker(waker);
    }
    fn write_credit(&mut self, writer: EntityRef, now: Instant) -> u32 {
        (**self).write_credit(writer, now)
    }
    fn set_reader_reliable(&mut self, reader: EntityRef, reliable: bool) {
        (**self).set_reader_reliable(reader, reliable);
    }
    fn stats(&self) -> MiddlewareStats {
        (**self).stats()
    }
    fn client_name(&self, client: ClientKey) -> Option<String> {
        (**self).client_name(client)
    }
    fn on_snapshot(&mut self, snapshot: &crate::core::AgentSnapshot, now: Instant) {
        (**self).on_snapshot(snapshot, now);
    }
}

/// The middlewares of the command line's `-m`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum MiddlewareKind {
    /// Centralized data: routing between the agent's own clients.
    Ced,
    /// A real DDS domain through the pure-Rust `xrce-dds` bridge ([`dds::Dds`]); the default.
    Dds,
    /// eProsima's legacy Fast RTPS name: the same DDS middleware (eProsima accepts the word, then has none).
    Rtps,
    /// A ROS 2 graph on rmw_zenoh, through one Zenoh session (cargo feature `zenoh`, docs/zenoh.md).
    Zenoh,
}

/// Error for middlewares this build does not have.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("middleware `{0}` is not implemented yet; run the agent with `-m ced` (in-agent routing between clients)")]
pub struct UnsupportedMiddleware(pub &'static str);

/// Why a middleware could not be built.
#[derive(Debug, thiserror::Error)]
pub enum BuildError {
    /// This build does not have it.
    #[error(transparent)]
    Unsupported(#[from] UnsupportedMiddleware),
    /// The DDS middleware refuses a ROS 2 or Fast DDS setting of the environment (`ROS_STATIC_PEERS`,
    /// `ROS_DISCOVERY_SERVER`, the profiles file): it names the variable and the value.
    #[error(transparent)]
    DdsSettings(#[from] xrce_dds::SettingsError),
    /// This agent was built without the `zenoh` feature.
    #[error(
        "middleware `zenoh`: this agent was built without it; rebuild with `cargo build --release -p xrce-agent \
         --features zenoh` (docs/zenoh.md)"
    )]
    ZenohNotBuilt,
    /// The Zenoh session could not be opened (its configuration file, `ROS_DOMAIN_ID`, Zenoh itself).
    #[error("middleware `zenoh`: {0}")]
    Zenoh(String),
}

impl MiddlewareKind {
    /// Its command-line name.
    pub const fn name(self) -> &'static str {
        match self {
            Self::Ced => "ced",
            Self::Dds => "dds",
            Self::Rtps => "rtps",
            Self::Zenoh => "zenoh",
        }
    }

    /// Builds the middleware, or says why not.
    pub fn build(self, profiles: Arc<dyn ProfileSource>) -> Result<Box<dyn Middleware + Send>, BuildError> {
        self.build_dds(profiles, ros_graph::RosGraphMode::default(), DdsOptions::default())
    }

    /// As [`Self::build`], with the ROS 2 graph mode and the options of the DDS middleware (ignored by CED).
    pub fn build_dds(
        self,
        profiles: Arc<dyn ProfileSource>,
        ros_graph: ros_graph::RosGraphMode,
        options: DdsOptions,
    ) -> Result<Box<dyn Middleware + Send>, BuildError> {
        match self {
            Self::Ced => Ok(Box::new(ced::Ced::new(profiles))),
            Self::Zenoh => build_zenoh(profiles, &options),
            Self::Dds | Self::Rtps => {
                let engine = options.engine.unwrap_or_default();
                warn_if_fallback(engine, options.engine.is_some());
                // As a ROS 2 node: the user's Fast DDS profiles and ROS discovery settings, read once at start.
                if engine == xrce_dds::Engine::FastDds {
                    xrce_dds::ros_env::load_fast_dds_profiles()?;
                }
                let discovery = xrce_dds::ros_env::from_env()?;
                let config = xrce_dds::BridgeConfig {
                    engine,
                    discovery,
                    shared_memory: options.shared_memory,
                    ..xrce_dds::BridgeConfig::default()
                };
                Ok(Box::new(
                    dds::Dds::with_config(profiles, config)
                        .with_ros_graph(ros_graph)
                        .with_eager_participant(options.eager_participant)
                        .with_shared_participants(options.share_participants)
                        .with_ros_diagnostics(options.ros_diagnostics),
                ))
            }
        }
    }
}

/// The `zenoh` middleware, when this build has it.
#[cfg(feature = "zenoh")]
fn build_zenoh(
    profiles: Arc<dyn ProfileSource>,
    options: &DdsOptions,
) -> Result<Box<dyn Middleware + Send>, BuildError> {
    let z = zenoh::Zenoh::open_with(profiles, options.zenoh_config.as_deref(), options.ros_diagnostics);
    Ok(Box::new(z.map_err(|e| BuildError::Zenoh(e.to_string()))?))
}

/// The `zenoh` middleware, when this build has it.
#[cfg(not(feature = "zenoh"))]
fn build_zenoh(
    _profiles: Arc<dyn ProfileSource>,
    _options: &DdsOptions,
) -> Result<Box<dyn Middleware + Send>, BuildError> {
    Err(BuildError::ZenohNotBuilt)
}

/// Says, as the agent's first warning, that the DDS middleware runs the RustDDS fallback because this build
/// has no Fast DDS, and how to get it: nobody should find out from lost first samples (docs/dds-engine.md).
fn warn_if_fallback(engine: xrce_dds::Engine, chosen: bool) {
    let env_chose = std::env::var_os(xrce_dds::ENGINE_ENV).is_some();
    if engine != xrce_dds::Engine::RustDds || chosen || env_chose {
        return;
    }
    tracing::warn!(
        "DDS engine: RustDDS (the pure-Rust fallback), because this agent was built without Fast DDS (its headers \
         were not found at build time); RustDDS meets ROS 2 nodes with 1-3 s stalls at first contact. Fix: install \
         Fast DDS (`sudo apt-get install libfastrtps-dev g++`) or source a ROS 2 environment (Humble, Jazzy, Kilted), then \
         rebuild (`cargo build --release -p xrce-agent`); `--dds-engine rustdds` silences this"
    );
}

/// Options of the DDS and Zenoh middlewares that the command line sets (ours, not eProsima's).
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct DdsOptions {
    /// The DDS engine (`--dds-engine`; `None`: `XRCE_DDS_ENGINE`, else rustdds).
    pub engine: Option<xrce_dds::Engine>,
    /// Create the default domain's DDS participant at start (`--eager-participant`).
    pub eager_participant: bool,
    /// Every XRCE participant shares the domain's default DDS participant instead of one DDS participant
    /// per participant name (`--participant-names off`).
    pub share_participants: bool,
    /// Shared memory beside UDPv4 for the Fast DDS participants (`--dds-shm`); `None`: this build's default
    /// (on when Fast DDS came from a ROS 2 installation, whose nodes share it).
    pub shared_memory: Option<bool>,
    /// Write ROS 2 `/diagnostics` from the snapshots the core publishes (`--ros-diagnostics`).
    pub ros_diagnostics: bool,
    /// The Zenoh session's configuration file (`--zenoh-config`); `None`: `ZENOH_SESSION_CONFIG_URI`, else
    /// rmw_zenoh's node defaults.
    pub zenoh_config: Option<std::path::PathBuf>,
}

#[cfg(test)]
mod tests {
    use super::*;
    use xrce_proto::layout::DataSubmessage;

    #[cfg(not(feature = "zenoh"))]
    #[test]
    fn zenoh_in_a_build_without_it_says_how_to_rebuild() {
        let Err(e) = MiddlewareKind::Zenoh.build(Arc::new(describe::FallbackProfiles)) else {
            panic!("built without the feature")
        };
        assert!(e.to_string().contains("--features zenoh"), "{e}");
    }

    #[test]
    fn a_reply_is_delivered_after_its_request_and_the_requester() {
        let requester = ObjectId::new(1, ObjectKind::Requester);
        let read = BaseObjectRequest { request_id: RequestId(0x0c), object_id: requester };
        let reply = SampleRef::Reply { request_id: RequestId(0x0f), data: &[4, 0, 0, 0, 0, 0, 0, 0] };
        let sub = DataSubmessage::data(read, reply.body(requester));
        let mut out = [0u8; 20];
        assert_eq!(sub.emit_into(&mut out), Ok(20));
        // Packet 33 of `request_reply_adder_udp.txt` (eProsima's agent), after the message header.
        assert_eq!(
            out,
            [0x09, 0x01, 0x10, 0x00, 0x00, 0x0c, 0x00, 0x17, 0x00, 0x0f, 0x00, 0x17, 4, 0, 0, 0, 0, 0, 0, 0]
        );
        assert_eq!(reply.wire_size(), 12);
        let request = SampleRef::Request { identity: SampleIdentity::default(), data: &[1, 2] };
        assert_eq!(request.wire_size(), SampleIdentity::SIZE + 2);
        assert_eq!(SampleRef::Data(&[1, 2, 3]).wire_size(), 3);
    }
}
