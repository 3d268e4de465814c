//! Shared DDS participants, raw topics, writers and readers.
//!
//! eProsima's agent creates one Fast DDS participant per XRCE participant (21 MiB and several threads
//! each) and dies at about 210 clients. Here an XRCE participant is only a handle on a DDS participant
//! shared by every XRCE participant with the same domain and profile, so thousands of clients each with a
//! datawriter fit in one RustDDS participant (issue 5 item 6). Writers can be shared the same way
//! ([`Participant::shared_writer`]): one DDS writer per topic and QoS, however many XRCE datawriters use it.

use std::collections::HashSet;
use std::net::IpAddr;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::Duration;

use rustdds::mio1::Token;
use rustdds::{no_key, with_key, DomainParticipant, DomainParticipantBuilder, Publisher, QosPolicyBuilder};
use rustdds::{RTPSEntity, Subscriber, Topic, TopicKind, WriteOptionsBuilder};

use crate::error::DdsError;
use crate::qos::EndpointQos;
use crate::raw::{RawAdapter, RawSample};
use crate::reader::{Dispatcher, Filter, RawSource, SampleIdentity, SampleQueue};
use crate::shared::{lock, TopicTable, WeakMap};

/// XRCE domain id meaning "the agent's domain" (spec §7.3).
pub const AGENT_DOMAIN: i32 = 255;

/// Environment variable eProsima reads for [`AGENT_DOMAIN`]; 0 when unset.
pub const DOMAIN_OVERRIDE_ENV: &str = "XRCE_DOMAIN_ID_OVERRIDE";

/// Highest domain id RustDDS can map to UDP ports (7400 + 250 × id + 11 must stay below 65536).
pub const MAX_DOMAIN_ID: u16 = 232;

fn create_err(what: &'static str) -> impl FnOnce(rustdds::dds::CreateError) -> DdsError {
    move |e| DdsError::Create { what, reason: e.to_string() }
}

/// How the bridge builds participants.
#[derive(Debug, Clone, Default)]
pub struct BridgeConfig {
    /// Which DDS implementation serves the participants (default: [`Engine::from_env`]).
    pub engine: crate::engine::Engine,
    /// Restrict RustDDS to these local addresses (tests pass `127.0.0.1`); `None` uses every interface.
    pub only_networks: Option<Vec<IpAddr>>,
    /// Domain used for XRCE domain 255; `None` reads [`DOMAIN_OVERRIDE_ENV`] at each participant creation,
    /// as eProsima does.
    pub domain_override: Option<u16>,
    /// ROS 2 discovery settings (Fast DDS engine; [`crate::ros_env::from_env`] reads them as a node does).
    pub discovery: crate::ros_env::DiscoverySettings,
    /// Shared memory beside UDPv4 (Fast DDS engine); `None`: this build's default
    /// (`xrce_fastdds_sys::SHARED_MEMORY_BY_DEFAULT`: on when Fast DDS came from a ROS 2 installation).
    pub shared_memory: Option<bool>,
}

/// What makes two XRCE participants share a DDS participant.
#[derive(Debug, Clone, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct ParticipantKey {
    /// DDS domain (255 already resolved).
    pub domain_id: u16,
    /// The participant's name as the XRCE client gave it (binary `qos_profile_reference`, XML
    /// `<rtps><name>`, or the reference); empty for the agent's default participant. Only the Fast DDS engine
    /// announces it (RustDDS 0.15.1 cannot), so the RustDDS engine keys every participant with "".
    pub name: String,
}

/// Creates and shares DDS participants. Cheap to keep for the agent's lifetime; participants live as long
/// as some [`Participant`] handle (or an entity created from one) does.
pub struct DdsBridge {
    config: BridgeConfig,
    participants: WeakMap<ParticipantKey, ParticipantInner>,
}

impl std::fmt::Debug for DdsBridge {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("DdsBridge")
            .field("config", &self.config)
            .field("participants", &self.participant_count())
            .finish()
    }
}

impl DdsBridge {
    /// A bridge with no participant yet (rustdds engine, whatever `config.engine` says).
    pub fn new(config: BridgeConfig) -> Self {
        Self { config, participants: WeakMap::default() }
    }

    /// The DDS domain for an XRCE domain id: 255 becomes the override (environment or config), anything
    /// else must be a valid RustDDS domain.
    pub fn resolve_domain(&self, xrce_domain_id: i32) -> Result<u16, DdsError> {
        let id = if xrce_domain_id == AGENT_DOMAIN {
            match self.config.domain_override {
                Some(d) => i32::from(d),
                None => match std::env::var(DOMAIN_OVERRIDE_ENV) {
                    Ok(v) => v.trim().parse::<i32>().map_err(|_| DdsError::InvalidDomain(-1))?,
                    Err(_) => 0,
                },
            }
        } else {
            xrce_domain_id
        };
        match u16::try_from(id) {
            Ok(d) if d <= MAX_DOMAIN_ID => Ok(d),
            _ => Err(DdsError::InvalidDomain(id)),
        }
    }

    /// The live participant for `(domain, name)`, if any.
    pub fn existing_participant(&self, xrce_domain_id: i32, name: &str) -> Option<Participant> {
        let key = ParticipantKey { domain_id: self.resolve_domain(xrce_domain_id).ok()?, name: name.to_owned() };
        self.participants.get(&key).map(|inner| Participant { inner })
    }

    /// The shared participant for `(domain, name)`, created on first use. `xrce_domain_id` 255 means
    /// the agent's domain.
    pub fn participant(&self, xrce_domain_id: i32, name: &str) -> Result<Participant, DdsError> {
        let key = ParticipantKey { domain_id: self.resolve_domain(xrce_domain_id)?, name: name.to_owned() };
        let inner = self.participants.get_or_try_insert(key.clone(), || {
            let inner = ParticipantInner::new(key, &self.config)?;
            tracing::info!(domain = inner.key.domain_id, name = %inner.key.name, "DDS participant created (RustDDS)");
            Ok::<_, DdsError>(Arc::new(inner))
        })?;
        Ok(Participant { inner })
    }

    /// The configuration it was built with.
    pub(crate) fn config(&self) -> &BridgeConfig {
        &self.config
    }

    /// DDS participants alive now.
    pub fn participant_count(&self) -> usize {
        self.participants.live()
    }
}

struct ParticipantInner {
    // Field order is drop order: the dispatcher (and the RustDDS readers it owns) goes before the
    // subscriber, publisher and participant they were created from.
    dispatcher: Dispatcher,
    topics: TopicTable<Topic>,
    /// Writers shared by every XRCE datawriter with the same topic and QoS (see [`Participant::shared_writer`]).
    writers: WeakMap<(String, EndpointQos), crate::engine::RawWriter>,
    subscriber: Subscriber,
    publisher: Publisher,
    participant: DomainParticipant,
    key: ParticipantKey,
}

impl ParticipantInner {
    fn new(key: ParticipantKey, config: &BridgeConfig) -> Result<Self, DdsError> {
        let mut builder = DomainParticipantBuilder::new(key.domain_id);
        if let Some(nets) = &config.only_networks {
            builder = builder.with_only_networks(nets.iter().copied());
        }
        let participant = builder.build().map_err(create_err("participant"))?;
        // Group QoS is empty on purpose: every endpoint gets its full QoS explicitly.
        let empty = QosPolicyBuilder::new().build();
        let publisher = participant.create_publisher(&empty).map_err(create_err("publisher"))?;
        let subscriber = participant.create_subscriber(&empty).map_err(create_err("subscriber"))?;
        let dispatcher = Dispatcher::start(format!("xrce-dds-d{}", key.domain_id))?;
        Ok(Self {
            dispatcher,
            topics: TopicTable::default(),
            writers: WeakMap::default(),
            subscriber,
            publisher,
            participant,
            key,
        })
    }
}

/// A handle on a shared DDS participant. Clone it freely: every XRCE participant of the same domain and
/// profile holds one.
#[derive(Clone)]
pub struct Participant {
    inner: Arc<ParticipantInner>,
}

impl std::fmt::Debug for Participant {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Participant").field("key", &self.inner.key).finish()
    }
}

/// A raw topic: name, type name (a runtime string, never a Rust type) and key kind.
#[derive(Clone)]
pub struct RawTopic {
    topic: Topic,
    keyed: bool,
}

impl std::fmt::Debug for RawTopic {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        use rustdds::TopicDescription;
        f.debug_struct("RawTopic")
            .field("name", &self.topic.name())
            .field("type", &self.topic.get_type().name())
            .field("keyed", &self.keyed)
            .finish()
    }
}

impl RawTopic {
    /// Topic name.
    pub fn name(&self) -> String {
        use rustdds::TopicDescription;
        self.topic.name()
    }

    /// Type name.
    pub fn type_name(&self) -> String {
        use rustdds::TopicDescription;
        self.topic.get_type().name().to_owned()
    }

    /// Whether the topic is keyed.
    pub fn is_keyed(&self) -> bool {
        self.keyed
    }
}

impl Participant {
    /// Remote writers on `topic` this participant has discovered and not seen leave (SEDP): a peer's view of
    /// who publishes, for tests that watch an agent's entities come and go.
    pub fn discovered_writers(&self, topic: &str) -> usize {
        self.inner
            .participant
            .discovered_writers()
            .iter()
            .filter(|d| d.publication_topic_data.topic_name == topic)
            .count()
    }

    /// Remote readers on `topic` this participant has discovered.
    pub fn discovered_readers(&self, topic: &str) -> usize {
        self.inner
            .participant
            .discovered_readers()
            .iter()
            .filter(|d| d.subscription_topic_data.topic_name() == topic)
            .count()
    }

    /// Domain and profile this participant serves.
    pub fn key(&self) -> &ParticipantKey {
        &self.inner.key
    }

    /// The DDS participant's GUID.
    pub fn guid(&self) -> [u8; 16] {
        self.inner.participant.guid().to_bytes()
    }

    /// The participant's topic `name`, created on first use. A second request with another type name or
    /// key kind fails: DDS allows one type per topic name in a participant.
    pub fn topic(&self, name: &str, type_name: &str, keyed: bool) -> Result<RawTopic, DdsError> {
        let kind = if keyed { TopicKind::WithKey } else { TopicKind::NoKey };
        // Empty topic QoS: endpoints carry their own, and RustDDS sizes the topic cache from the readers.
        let topic = self.inner.topics.get_or_try_create(name, type_name, keyed, || {
            self.inner
                .participant
                .create_topic(name.to_owned(), type_name.to_owned(), &QosPolicyBuilder::new().build(), kind)
                .map_err(create_err("topic"))
        })?;
        Ok(RawTopic { topic, keyed })
    }

    /// The participant's topic `name` if some earlier [`Participant::topic`] created it (whatever its type).
    pub fn find_topic(&self, name: &str) -> Option<RawTopic> {
        self.inner.topics.find(name).map(|e| RawTopic { topic: e.topic, keyed: e.keyed })
    }

    /// The datawriter on `topic` with `qos` shared by every caller asking for the same pair, created on first
    /// use and deleted with the last handle. Thousands of XRCE clients publishing one topic then cost one DDS
    /// writer (one GUID, one history, one discovery announcement) instead of a writer each (about 20 KiB
    /// and an SEDP record at every peer). DDS readers see one publisher where eProsima's agent shows one per
    /// XRCE datawriter; samples, order per writer and reliability are the same.
    pub fn shared_writer(
        &self,
        topic: &RawTopic,
        qos: &EndpointQos,
    ) -> Result<Arc<crate::engine::RawWriter>, DdsError> {
        self.inner.writers.get_or_try_insert((topic.name(), qos.clone()), || {
            Ok(Arc::new(crate::engine::RawWriter::Rust(Arc::new(self.create_writer(topic, qos)?))))
        })
    }

    /// A datawriter on `topic`, this caller's own.
    pub fn create_writer(&self, topic: &RawTopic, qos: &EndpointQos) -> Result<RawWriter, DdsError> {
        let q = qos.to_rustdds(false);
        let qos_policies = q.clone();
        let kind = if topic.keyed {
            WriterKind::Keyed(
                self.inner
                    .publisher
                    .create_datawriter::<RawSample, RawAdapter>(&topic.topic, Some(q))
                    .map_err(create_err("datawriter"))?,
            )
        } else {
            WriterKind::NoKey(
                self.inner
                    .publisher
                    .create_datawriter_no_key::<RawSample, RawAdapter>(&topic.topic, Some(q))
                    .map_err(create_err("datawriter"))?,
            )
        };
        Ok(RawWriter {
            kind,
            matched: AtomicUsize::new(0),
            matched_guids: Mutex::new(HashSet::new()),
            topic_name: topic.name(),
            qos: qos_policies,
            participant: Arc::clone(&self.inner),
        })
    }

    /// A datareader on `topic`; received samples appear in its [`SampleQueue`].
    pub fn create_reader(&self, topic: &RawTopic, qos: &EndpointQos) -> Result<RawReader, DdsError> {
        self.create_reader_filtered(topic, qos, None)
    }

    pub(crate) fn create_reader_filtered(
        &self,
        topic: &RawTopic,
        qos: &EndpointQos,
        filter: Option<Filter>,
    ) -> Result<RawReader, DdsError> {
        let (source, guid): (Box<dyn RawSource>, [u8; 16]) = if topic.keyed {
            let r = self
                .inner
                .subscriber
                .create_datareader::<RawSample, RawAdapter>(&topic.topic, Some(qos.to_rustdds(true)))
                .map_err(create_err("datareader"))?;
            let g = r.guid().to_bytes();
            (Box::new(r), g)
        } else {
            let r = self
                .inner
                .subscriber
                .create_simple_datareader_no_key::<RawSample, RawAdapter>(&topic.topic, Some(qos.to_rustdds(false)))
                .map_err(create_err("datareader"))?;
            let g = r.guid().to_bytes();
            (Box::new(r), g)
        };
        let (queue, token) = self.inner.dispatcher.add(source, qos.queue_capacity(), filter)?;
        Ok(RawReader { queue, token, guid, participant: Arc::clone(&self.inner) })
    }
}

enum WriterKind {
    NoKey(no_key::DataWriter<RawSample, RawAdapter>),
    Keyed(with_key::DataWriter<RawSample, RawAdapter>),
}

/// A raw datawriter: publishes XRCE payloads (CDR bodies) as DDS samples.
pub struct RawWriter {
    kind: WriterKind,
    /// Last known matched reader count (status events are consumed when read).
    matched: AtomicUsize,
    /// GUIDs of the readers matched now, from the same status events (see
    /// [`RawWriter::unmatched_known_readers`]).
    matched_guids: Mutex<HashSet<[u8; 16]>>,
    /// Topic name and the writer's QoS, to tell which discovered readers it should match.
    topic_name: String,
    qos: rustdds::QosPolicies,
    // Keeps the shared participant alive as long as one of its writers is; its discovery database answers
    // `unmatched_known_readers`.
    participant: Arc<ParticipantInner>,
}

impl std::fmt::Debug for RawWriter {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("RawWriter").field("guid", &self.guid()).finish()
    }
}

impl RawWriter {
    /// Publishes one sample whose CDR body is `body` (RustDDS adds the `00 01 00 00` header). Returns the
    /// sample's identity. A reliable write blocks at most the QoS' `max_blocking_time` when the send
    /// window is full, then fails with [`DdsError::Resources`].
    pub fn write(&self, body: &[u8]) -> Result<SampleIdentity, DdsError> {
        self.write_related(body, None)
    }

    /// As [`RawWriter::write`], with the related sample identity (replies) sent as inline QoS.
    pub fn write_related(&self, body: &[u8], related: Option<SampleIdentity>) -> Result<SampleIdentity, DdsError> {
        let sample = RawSample { body: rustdds::bytes::Bytes::copy_from_slice(body), encapsulation: [0, 1] };
        let opts =
            WriteOptionsBuilder::new().related_sample_identity_opt(related.map(SampleIdentity::to_rustdds)).build();
        let res = match &self.kind {
            WriterKind::NoKey(w) => w.write_with_options(sample, opts).map_err(|e| e.forget_data()),
            WriterKind::Keyed(w) => w.write_with_options(sample, opts).map_err(|e| e.forget_data()),
        };
        match res {
            Ok(id) => Ok(SampleIdentity::from_rustdds(id)),
            Err(rustdds::dds::WriteError::WouldBlock { .. }) => {
                Err(DdsError::Resources("reliable send window full".to_owned()))
            }
            Err(e) => Err(DdsError::Write(e.to_string())),
        }
    }

    /// The writer's GUID (the `writer_guid` of every identity it returns).
    pub fn guid(&self) -> [u8; 16] {
        match &self.kind {
            WriterKind::NoKey(w) => w.guid().to_bytes(),
            WriterKind::Keyed(w) => w.guid().to_bytes(),
        }
    }

    /// Readers currently matched (discovered and QoS-compatible), from the writer's PUBLICATION_MATCHED
    /// status events (RustDDS' `get_matched_subscriptions` is a panicking placeholder in 0.15.1).
    pub fn matched_readers(&self) -> usize {
        self.drain_status();
        self.matched.load(Ordering::Relaxed)
    }

    /// Whether the writer has matched a reader of the participant whose GUID prefix is `prefix`.
    pub fn matched_participant(&self, prefix: &[u8; 12]) -> bool {
        self.drain_status();
        lock(&self.matched_guids).iter().any(|g| g.starts_with(prefix))
    }

    /// Remote readers the participant has already discovered on this writer's topic, with a QoS this
    /// writer can serve, that the writer has not matched yet (0 once it reaches every reader known now).
    ///
    /// Why: a new writer matches the readers its participant knows only after the engine processed it,
    /// tens of milliseconds later; a sample written meanwhile is not owed to them (volatile writers start
    /// each new reader after their history), so the remote side, which may have matched the writer first,
    /// sees it skipped. Holding the first writes until this is 0 (bounded by the caller) closes that gap.
    /// Readers not discovered yet cannot be waited for: they are the ordinary late joiners.
    pub fn unmatched_known_readers(&self) -> usize {
        self.drain_status();
        let matched = lock(&self.matched_guids);
        self.participant
            .participant
            .discovered_readers()
            .iter()
            .filter(|d| d.subscription_topic_data.topic_name == self.topic_name)
            .filter(|d| !matched.contains(&d.reader_proxy.remote_reader_guid.to_bytes()))
            .filter(|d| self.qos.compliance_failure_wrt(&d.subscription_topic_data.qos()).is_none())
            .count()
    }

    /// Consumes the writer's status events: matched count and matched reader GUIDs.
    fn drain_status(&self) {
        use rustdds::{DataWriterStatus, StatusEvented};
        let mut last = None;
        let mut guids: Option<MutexGuard<'_, HashSet<[u8; 16]>>> = None;
        loop {
            let st = match &self.kind {
                WriterKind::NoKey(w) => w.try_recv_status(),
                WriterKind::Keyed(w) => w.try_recv_status(),
            };
            match st {
                Some(DataWriterStatus::PublicationMatched { current, reader, .. }) => {
                    last = Some(current.count());
                    let set = guids.get_or_insert_with(|| lock(&self.matched_guids));
                    if current.count_change() < 0 {
                        set.remove(&reader.to_bytes());
                    } else {
                        set.insert(reader.to_bytes());
                    }
                }
                Some(_) => {}
                None => break,
            }
        }
        if let Some(c) = last {
            self.matched.store(usize::try_from(c).unwrap_or(0), Ordering::Relaxed);
        }
    }

    /// Waits until every matched reliable reader acknowledged everything written; `Ok(false)` on timeout.
    pub fn wait_for_acknowledgments(&self, max_wait: Duration) -> Result<bool, DdsError> {
        let d = max_wait;
        let r = match &self.kind {
            WriterKind::NoKey(w) => w.wait_for_acknowledgments(d),
            WriterKind::Keyed(w) => w.wait_for_acknowledgments(d),
        };
        r.map_err(|e| DdsError::Write(e.to_string()))
    }
}

/// A raw datareader: its samples are delivered by the participant's dispatcher into [`RawReader::queue`].
pub struct RawReader {
    queue: SampleQueue,
    token: Token,
    guid: [u8; 16],
    participant: Arc<ParticipantInner>,
}

impl std::fmt::Debug for RawReader {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("RawReader").field("guid", &self.guid).field("queue", &self.queue).finish()
    }
}

impl RawReader {
    /// The queue the agent drains (or waits on).
    pub fn queue(&self) -> &SampleQueue {
        &self.queue
    }

    /// The reader's GUID.
    pub fn guid(&self) -> [u8; 16] {
        self.guid
    }
}

impl Drop for RawReader {
    fn drop(&mut self) {
        self.participant.dispatcher.remove(self.token);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn domain_255_takes_the_override_and_others_are_checked() {
        let b = DdsBridge::new(BridgeConfig { domain_override: Some(42), ..BridgeConfig::default() });
        assert_eq!(b.resolve_domain(255).unwrap(), 42);
        assert_eq!(b.resolve_domain(7).unwrap(), 7);
        assert!(b.resolve_domain(233).is_err());
        assert!(b.resolve_domain(-1).is_err());
        // Without an override in the config, the environment decides (0 when unset); the variable is not
        // set by this test to keep it free of process-global state.
        let b = DdsBridge::new(BridgeConfig::default());
        let expected = std::env::var(DOMAIN_OVERRIDE_ENV).ok().and_then(|v| v.trim().parse::<u16>().ok()).unwrap_or(0);
        if expected <= MAX_DOMAIN_ID {
            assert_eq!(b.resolve_domain(255).unwrap(), expected);
        }
        assert_eq!(b.participant_count(), 0);
    }
}
