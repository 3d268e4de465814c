//! The Fast DDS engine (cargo feature `fastdds`): the bridge API over Fast DDS 2.x or 3.x through
//! `xrce-fastdds-sys`.
//!
//! Why a second engine: RustDDS' reliable readers withhold samples from a newly matched Fast DDS writer until
//! a HEARTBEAT arrives, and their first ACKNACK does not obtain one, so ROS 2 (rmw_fastrtps) first contact
//! waits for Fast DDS' 3 s periodic HEARTBEAT. Fast DDS itself has no such stall and carries the related
//! sample identity rmw_fastrtps services need.
//!
//! One Fast DDS participant per (domain, participant name), topics per name,
//! writers shareable per (topic, QoS). Received samples are taken on Fast DDS' listener thread, straight into
//! the reader's bounded [`SampleQueue`]; when the queue is full, taking stops (samples wait in Fast DDS'
//! history, whose reliable flow control then holds the writer back) and the agent's draining resumes it.

use std::collections::HashMap;
use std::sync::{Arc, Mutex, OnceLock, Weak};
use std::time::{Duration, Instant};

use xrce_fastdds_sys as sys;

use crate::qos::{Durability, EndpointQos, History, Reliability};
use crate::reader::{Filter, ReceivedSample, Resume};
use crate::ros_env::Range as DiscoveryRange;
use crate::shared::{lock, TopicTable, WeakMap};
use crate::{BridgeConfig, DdsError, ParticipantKey, SampleIdentity, SampleQueue};

/// Samples moved from Fast DDS to a queue per lock of the queue.
const BATCH: usize = 256;

/// Name the agent's default participant (XRCE participants without a name) announces.
const DEFAULT_PARTICIPANT_NAME: &str = "xrce-rs";

fn create_err(what: &'static str) -> impl FnOnce(sys::Error) -> DdsError {
    move |e| DdsError::Create { what, reason: e.to_string() }
}

/// The bridge's participants by key; each participant holds it too, to find its domain's oracle.
type ParticipantTable = WeakMap<ParticipantKey, ParticipantInner>;

/// Creates and shares Fast DDS participants.
pub(crate) struct Bridge {
    config: BridgeConfig,
    participants: Arc<ParticipantTable>,
}

impl std::fmt::Debug for Bridge {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("FastBridge").field("participants", &self.participant_count()).finish()
    }
}

impl Bridge {
    pub(crate) fn new(config: BridgeConfig) -> Self {
        Self { config, participants: Arc::default() }
    }

    pub(crate) fn participant(&self, domain_id: u16, name: &str) -> Result<Participant, DdsError> {
        let key = ParticipantKey { domain_id, name: name.to_owned() };
        // Looked up before the table's lock is taken for the insert.
        let oracle = oldest_of_domain(&self.participants, domain_id);
        let inner = self.participants.get_or_try_insert(key.clone(), || {
            let cfg = sys::ParticipantConfig {
                domain: u32::from(domain_id),
                name: if name.is_empty() { DEFAULT_PARTICIPANT_NAME.to_owned() } else { name.to_owned() },
                whitelist: self.config.only_networks.iter().flatten().map(ToString::to_string).collect(),
                // Fast DDS' default is 5 announcements 100 ms apart; a denser start lets peers that are
                // already up discover us (and answer with their own SPDP) sooner.
                announcements: (10, Duration::from_millis(50)),
                shared_memory: self.config.shared_memory.unwrap_or(sys::SHARED_MEMORY_BY_DEFAULT),
                range: match self.config.discovery.range {
                    DiscoveryRange::Subnet | DiscoveryRange::SystemDefault => sys::DiscoveryRange::Default,
                    DiscoveryRange::Localhost => sys::DiscoveryRange::Localhost,
                    DiscoveryRange::Off => sys::DiscoveryRange::Off,
                },
                peers: self.config.discovery.initial_peers().iter().map(ToString::to_string).collect(),
            };
            let participant =
                create_heard(&cfg, oracle.as_ref().map(|o| &o.participant)).map_err(create_err("participant"))?;
            tracing::info!(domain = domain_id, name = %cfg.name, "DDS participant created (Fast DDS)");
            Ok::<_, DdsError>(Arc::new(ParticipantInner {
                topics: TopicTable::default(),
                writers: WeakMap::default(),
                participant,
                key,
                born: Instant::now(),
                table: Arc::clone(&self.participants),
            }))
        })?;
        Ok(Participant { inner })
    }

    pub(crate) fn existing_participant(&self, domain_id: u16, name: &str) -> Option<Participant> {
        self.participants.get(&ParticipantKey { domain_id, name: name.to_owned() }).map(|inner| Participant { inner })
    }

    pub(crate) fn participant_count(&self) -> usize {
        self.participants.live()
    }

    /// When the longest-running live participant of `domain_id` with a name was created, if any.
    pub(crate) fn oldest_named_since(&self, domain_id: u16) -> Option<Instant> {
        let named = self.participants.live_where(|k| k.domain_id == domain_id && !k.name.is_empty());
        named.iter().map(|p| p.born).min()
    }

    /// Whether the participant of `domain_id` that has run longest knows a remote reader on `topic` (`None`:
    /// the domain has no participant).
    pub(crate) fn domain_knows_reader(&self, domain_id: u16, topic: &str) -> Option<bool> {
        oldest_of_domain(&self.participants, domain_id).map(|p| p.participant.known_readers(topic) > 0)
    }

    /// Whether some participant of `domain_id` is alive.
    pub(crate) fn domain_has_participant(&self, domain_id: u16) -> bool {
        !self.participants.live_where(|k| k.domain_id == domain_id).is_empty()
    }
}

/// The live participant of `domain_id` that has run longest: it knows the most of the domain (remote
/// participants and readers), so a new participant's discovery and its writers' first-contact gates are
/// checked against it. The default participant when it has run longest (created at start with
/// `--eager-participant`), else the oldest named one (the agent retires the default participant once a named
/// one has run a while).
fn oldest_of_domain(table: &ParticipantTable, domain_id: u16) -> Option<Arc<ParticipantInner>> {
    table.live_where(|k| k.domain_id == domain_id).into_iter().min_by_key(|p| p.born)
}

/// Longest a new participant is given to discover the participants its domain's oracle knows
/// (they answer its first announcement within 1–6 ms on loopback, with 1 to 11 peers) before it is taken
/// for one that missed an answer ([`create_heard`]).
const ANSWER_WAIT: Duration = Duration::from_millis(30);

/// When a new participant that has not heard every participant of the agent yet asks them to announce again
/// ([`create_heard`]); answers come within 1–6 ms.
const REANNOUNCE_AFTER: Duration = Duration::from_millis(8);

/// Participants created at most for one name by [`create_heard`]. Each attempt misses an answer with
/// probability p (0.1 with the default participant and a ROS node beside it, 0.3 with 10 of the agent's
/// participants alive: `discovery_race` example of xrce-fastdds-sys), so p⁵ ≤ 0.3 %.
const CREATE_ATTEMPTS: u32 = 5;

/// Creates a participant that has heard every participant `oracle` (the domain's participant running longest,
/// [`oldest_of_domain`]) knows, recreating it when it has not within [`ANSWER_WAIT`].
///
/// Why: Fast DDS sends a participant's first announcement before it registers the receivers of its sockets
/// (`RTPSParticipantImpl::enable`, every version to 3.x; eProsima/Fast-DDS PR #6204). A peer answers a new
/// participant once, with its own announcement, and on loopback that answer can arrive inside the window and
/// be dropped; the new participant then learns of the peer only at the peer's next periodic announcement,
/// 3 s later, and its writers match nobody meanwhile (docs/dds-engine.md). A recreated participant has a new
/// GUID, so every peer answers it again; but first the agent's own participants, whose answers come first
/// and are the ones most often dropped, are asked to announce again ([`REANNOUNCE_AFTER`]). After
/// [`CREATE_ATTEMPTS`] the last one is kept: the first-contact gate still holds its writers while its
/// discovery is under way.
fn create_heard(
    cfg: &sys::ParticipantConfig,
    oracle: Option<&sys::Participant>,
) -> Result<sys::Participant, sys::Error> {
    let mut attempt = 1;
    loop {
        let participant = sys::Participant::new(cfg)?;
        let Some(oracle) = oracle else { return Ok(participant) };
        let started = std::time::Instant::now();
        let mut unheard = participant.undiscovered(oracle);
        let mut reannounced = false;
        while unheard > 0 && started.elapsed() < ANSWER_WAIT {
            std::thread::sleep(Duration::from_micros(500));
            unheard = participant.undiscovered(oracle);
            // The agent's own participants answer first, so theirs are the answers most often dropped; they
            // can be asked again, remote ones cannot.
            if unheard > 0 && !reannounced && started.elapsed() >= REANNOUNCE_AFTER {
                reannounced = true;
                participant.reannounce_unheard();
            }
        }
        if unheard == 0 {
            return Ok(participant);
        }
        if attempt == CREATE_ATTEMPTS {
            tracing::info!(name = %cfg.name, unheard, attempts = attempt, "new DDS participant still misses answers to its first announcement; keeping it (its discovery completes at the peers' next periodic announcement)");
            return Ok(participant);
        }
        tracing::debug!(name = %cfg.name, unheard, attempt, "new DDS participant missed answers to its first announcement; creating it again");
        attempt += 1;
    }
}

struct ParticipantInner {
    topics: TopicTable<Arc<TopicInner>>,
    writers: WeakMap<(String, EndpointQos), crate::engine::RawWriter>,
    participant: sys::Participant,
    key: ParticipantKey,
    born: Instant,
    /// The bridge's participants, among which this one's oracle ([`oldest_of_domain`]).
    table: Arc<ParticipantTable>,
}

impl ParticipantInner {
    /// The participant of this one's domain that knows the most of it (this one when it has run longest).
    fn oracle(self: &Arc<Self>) -> Arc<Self> {
        oldest_of_domain(&self.table, self.key.domain_id).unwrap_or_else(|| Arc::clone(self))
    }
}

/// A handle on a shared Fast DDS participant.
#[derive(Clone)]
pub struct Participant {
    inner: Arc<ParticipantInner>,
}

impl std::fmt::Debug for Participant {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("FastParticipant").field("key", &self.inner.key).finish()
    }
}

/// A topic of a Fast DDS participant, shared by every handle on it (its participant's table holds one).
struct TopicInner {
    topic: sys::Topic,
    name: Arc<str>,
    type_name: String,
    keyed: bool,
}

/// A handle on a topic of a Fast DDS participant: a pointer, so that the thousands of clients naming the same
/// topic cost no allocation each.
#[derive(Clone)]
pub struct RawTopic(Arc<TopicInner>);

impl std::fmt::Debug for RawTopic {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("FastTopic")
            .field("name", &self.0.name)
            .field("type", &self.0.type_name)
            .field("keyed", &self.0.keyed)
            .finish()
    }
}

impl RawTopic {
    pub(crate) fn name(&self) -> String {
        self.0.name.to_string()
    }
    pub(crate) fn shared_name(&self) -> Arc<str> {
        Arc::clone(&self.0.name)
    }
    pub(crate) fn type_name(&self) -> String {
        self.0.type_name.clone()
    }
    pub(crate) fn is_keyed(&self) -> bool {
        self.0.keyed
    }
}

/// The Fast DDS QoS of an endpoint. Writers keep the XRCE history and the bounded limits of
/// [`EndpointQos::effective_limits`]; a reliable write waits at most `max_blocking_time` for room. Keyed raw
/// readers are KEEP_ALL for the reason given in `raw.rs` (one local instance for all real instances), and so
/// are reliable readers: while their queue is paused, samples wait in Fast DDS' history, and a KEEP_LAST one
/// would overwrite them (measured: 975 of 5,000 lost behind a slow XRCE subscriber) where KEEP_ALL stops
/// acknowledging and so holds the writer back.
fn to_fast(qos: &EndpointQos, reader: bool, keyed: bool) -> sys::Qos {
    let limits = qos.effective_limits();
    let hold = reader && (keyed || qos.reliability == Reliability::Reliable);
    let keep_last = match qos.history {
        History::KeepLast(d) if !hold => Some(d.max(1)),
        _ => None,
    };
    sys::Qos {
        reliable: qos.reliability == Reliability::Reliable,
        transient_local: qos.durability != Durability::Volatile,
        keep_last,
        limits: (limits.max_samples, limits.max_instances, limits.max_samples_per_instance),
        max_blocking_time: qos.max_blocking_time,
        partitions: qos.partitions.clone(),
        ..sys::Qos::default()
    }
}

fn identity(id: &sys::SampleIdentity) -> SampleIdentity {
    SampleIdentity { writer_guid: id.writer.v, sequence_number: id.sn }
}

impl Participant {
    pub(crate) fn key(&self) -> &ParticipantKey {
        &self.inner.key
    }

    pub(crate) fn guid(&self) -> [u8; 16] {
        self.inner.participant.guid().v
    }

    pub(crate) fn topic(&self, name: &str, type_name: &str, keyed: bool) -> Result<RawTopic, DdsError> {
        let topic = self.inner.topics.get_or_try_create(name, type_name, keyed, || {
            let topic = self.inner.participant.topic(name, type_name, keyed).map_err(create_err("topic"))?;
            Ok(Arc::new(TopicInner { topic, name: Arc::from(name), type_name: type_name.to_owned(), keyed }))
        })?;
        Ok(RawTopic(topic))
    }

    pub(crate) fn find_topic(&self, name: &str) -> Option<RawTopic> {
        Some(RawTopic(self.inner.topics.find(name)?.topic))
    }

    pub(crate) fn shared_writer(
        &self,
        topic: &RawTopic,
        qos: &EndpointQos,
    ) -> Result<Arc<crate::engine::RawWriter>, DdsError> {
        self.inner.writers.get_or_try_insert((topic.name(), qos.clone()), || {
            Ok(Arc::new(crate::engine::RawWriter::Fast(Arc::new(self.create_writer(topic, qos)?))))
        })
    }

    pub(crate) fn create_writer(&self, topic: &RawTopic, qos: &EndpointQos) -> Result<RawWriter, DdsError> {
        let writer = self
            .inner
            .participant
            .writer(&topic.0.topic, &to_fast(qos, false, topic.0.keyed))
            .map_err(create_err("datawriter"))?;
        let reliable = matches!(qos.reliability, Reliability::Reliable);
        Ok(RawWriter { writer, _topic: Arc::clone(&topic.0), participant: Arc::clone(&self.inner), reliable })
    }

    pub(crate) fn create_reader_filtered(
        &self,
        topic: &RawTopic,
        qos: &EndpointQos,
        filter: Option<Filter>,
    ) -> Result<RawReader, DdsError> {
        // The data callback is installed with the reader, before its handle exists: it finds the source
        // through this cell, which is filled right after creation (no sample can match before that).
        let cell: Arc<OnceLock<Weak<Source>>> = Arc::new(OnceLock::new());
        let on_data = {
            let cell = Arc::clone(&cell);
            move || {
                if let Some(src) = cell.get().and_then(Weak::upgrade) {
                    src.drain();
                }
            }
        };
        let reader = self
            .inner
            .participant
            .reader(&topic.0.topic, &to_fast(qos, true, topic.0.keyed), on_data)
            .map_err(create_err("datareader"))?;
        let resume_cell = Arc::clone(&cell);
        let resume: Resume = Arc::new(move || {
            if let Some(src) = resume_cell.get().and_then(Weak::upgrade) {
                src.drain();
            }
        });
        let queue = SampleQueue::new_detached(qos.queue_capacity(), resume);
        let drain = Mutex::new(Drain { filter, ahead: HashMap::new() });
        let source = Arc::new(Source { handle: reader.handle(), queue: queue.clone(), drain });
        // Cannot fail: the cell was created above and is set only here.
        let _ = cell.set(Arc::downgrade(&source));
        // Samples may have arrived before the cell was set.
        source.drain();
        let guid = reader.guid().v;
        Ok(RawReader {
            queue,
            guid,
            _source: source,
            _reader: reader,
            _topic: Arc::clone(&topic.0),
            _participant: Arc::clone(&self.inner),
        })
    }
}

/// How long a remote participant's endpoints must have stopped arriving before its discovery counts as done
/// for a reliable writer's first-contact gate: its endpoints come in bursts, and the reader a writer waits
/// for may come last (a Kilted node's reader came after the gate had opened in 3 of 8 runs, and its first
/// sample was lost). Best-effort writers do not wait for it: while a ROS graph's endpoints keep arriving it
/// held PX4-like telemetry up to the gate's 500 ms bound (first sample 330–540 ms after STATUS OK).
const ENDPOINTS_SETTLE: Duration = Duration::from_millis(100);

/// A Fast DDS writer of raw samples.
pub struct RawWriter {
    writer: sys::Writer,
    // Drop order: the writer goes before its topic and participant.
    _topic: Arc<TopicInner>,
    participant: Arc<ParticipantInner>,
    reliable: bool,
}

impl std::fmt::Debug for RawWriter {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("FastWriter").field("guid", &self.guid()).finish()
    }
}

impl RawWriter {
    pub(crate) fn write(&self, body: &[u8]) -> Result<SampleIdentity, DdsError> {
        self.write_related(body, None)
    }

    pub(crate) fn write_related(
        &self,
        body: &[u8],
        related: Option<SampleIdentity>,
    ) -> Result<SampleIdentity, DdsError> {
        let rel =
            related.map(|r| sys::SampleIdentity { writer: sys::Guid { v: r.writer_guid }, sn: r.sequence_number });
        match self.writer.write(body, rel.as_ref()) {
            Ok(id) => Ok(identity(&id)),
            Err(sys::Error::WouldBlock) => Err(DdsError::Resources("reliable writer history full".to_owned())),
            Err(e) => Err(DdsError::Write(e.to_string())),
        }
    }

    pub(crate) fn guid(&self) -> [u8; 16] {
        self.writer.guid().v
    }

    /// The participant that knows the most of the domain ([`oldest_of_domain`]), the writer's own included.
    fn oracle(&self) -> Arc<ParticipantInner> {
        self.participant.oracle()
    }

    /// How long endpoints must have stopped arriving ([`ENDPOINTS_SETTLE`] for reliable writers).
    fn settle(&self) -> Duration {
        if self.reliable {
            ENDPOINTS_SETTLE
        } else {
            Duration::ZERO
        }
    }

    pub(crate) fn participant_in_discovery(&self) -> usize {
        self.participant.participant.in_discovery(&self.oracle().participant, self.settle())
    }

    pub(crate) fn unmatched_known_readers(&self) -> usize {
        self.writer.unmatched_known(&self.oracle().participant)
    }

    pub(crate) fn unmatched_readers_in_discovery(&self) -> usize {
        self.writer.unmatched_in_discovery(&self.oracle().participant, self.settle())
    }

    pub(crate) fn matched_readers(&self) -> usize {
        usize::try_from(self.writer.matched()).unwrap_or(0)
    }

    pub(crate) fn matched_participant(&self, prefix: &[u8; 12]) -> bool {
        self.writer.matched_prefix(prefix)
    }

    pub(crate) fn wait_for_acknowledgments(&self, max_wait: Duration) -> Result<bool, DdsError> {
        Ok(self.writer.wait_for_acknowledgments(max_wait))
    }
}

/// Moves samples from Fast DDS into a reader's queue, from the listener thread or from the agent (resume).
struct Source {
    handle: sys::ReaderHandle,
    queue: SampleQueue,
    /// Also serializes drains, so samples enter the queue in the order Fast DDS gives them.
    drain: Mutex<Drain>,
}

/// What a drain applies to the samples it takes.
struct Drain {
    filter: Option<Filter>,
    /// Per writer GUID, how many of its next samples were queued ahead ([`RawReader::deliver_ahead`]):
    /// Fast DDS' copies are dropped.
    ahead: HashMap<[u8; 16], u32>,
}

impl Source {
    fn drain(&self) {
        let mut guard = lock(&self.drain);
        let Drain { filter, ahead } = &mut *guard;
        let mut batch = Vec::new();
        loop {
            let room = self.queue.room_or_pause();
            if room == 0 {
                return;
            }
            let want = room.min(BATCH);
            while batch.len() < want {
                match self.handle.take() {
                    Ok(Some(s)) if s.valid => batch.push(ReceivedSample {
                        data: s.body,
                        encapsulation: s.encapsulation.to_be_bytes(),
                        identity: identity(&s.identity),
                        related_identity: (s.related.sn >= 0 || s.related.writer.v != [0; 16])
                            .then(|| identity(&s.related)),
                        request_id: None,
                    }),
                    // Dispose/unregister notifications carry no data for an XRCE client.
                    Ok(Some(_)) => {}
                    Ok(None) => break,
                    Err(e) => {
                        tracing::warn!("taking from Fast DDS reader: {e}");
                        break;
                    }
                }
            }
            if batch.is_empty() {
                return;
            }
            let took = batch.len();
            self.queue.deliver_skipping(&mut batch, filter, ahead);
            if took < want {
                return;
            }
        }
    }
}

/// A Fast DDS reader whose samples land in [`RawReader::queue`].
pub struct RawReader {
    queue: SampleQueue,
    guid: [u8; 16],
    _source: Arc<Source>,
    // Drop order: the reader (and its callback) goes before its topic and participant.
    _reader: sys::Reader,
    _topic: Arc<TopicInner>,
    _participant: Arc<ParticipantInner>,
}

impl std::fmt::Debug for RawReader {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("FastReader").field("guid", &self.guid).field("queue", &self.queue).finish()
    }
}

impl RawReader {
    pub(crate) fn queue(&self) -> &SampleQueue {
        &self.queue
    }

    /// Queues `body` as a sample of `writer` (a writer of this process, matched with this reader, that will
    /// publish it next), ahead of Fast DDS' copy, which the reader then drops. See
    /// [`crate::RawReader::deliver_ahead`].
    pub(crate) fn deliver_ahead(&self, writer: &[u8; 16], body: &[u8]) -> bool {
        let mut d = lock(&self._source.drain);
        if d.filter.is_some() {
            return false;
        }
        let queued = self.queue.push_ahead(|| ReceivedSample {
            data: body.to_vec(),
            // What `RawWriter::write` sends: CDR little endian.
            encapsulation: [0, 1],
            identity: SampleIdentity { writer_guid: *writer, sequence_number: -1 },
            related_identity: None,
            request_id: None,
        });
        if queued {
            *d.ahead.entry(*writer).or_insert(0) += 1;
        }
        queued
    }
    pub(crate) fn guid(&self) -> [u8; 16] {
        self.guid
    }
}
