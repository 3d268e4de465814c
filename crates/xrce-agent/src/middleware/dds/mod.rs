//! The `dds` middleware (the default of `-m`; `-m rtps` maps here too): XRCE entities become entities of a
//! real DDS domain, through the untyped bridge of the `xrce-dds` crate (Fast DDS where built, else RustDDS).
//!
//! * **Participants by name.** An XRCE participant is a handle on the bridge's DDS participant for its
//!   domain (255 → `XRCE_DOMAIN_ID_OVERRIDE`, as eProsima) and name (binary `qos_profile_reference`, as
//!   micro-ROS sends its node name; XML `<rtps><name>`, as PX4; or the reference): as in eProsima's agent,
//!   the DDS participant announces that name. XRCE participants with the same name share one DDS
//!   participant; unnamed ones share the domain's default participant, `xrce-rs`. With
//!   [`Dds::with_shared_participants`] (`--participant-names off`) all of a domain share the default one:
//!   1,000 clients then cost 1,000 small map entries and one DDS participant instead of 1,000 (Fast DDS:
//!   ~5 MiB and 6 threads each; eProsima's agent: 21 MiB). RustDDS 0.15.1 cannot announce a name, so
//!   there they always share. Only the name is modelled of the participant QoS.
//! * **Topics** are raw: name, type name (a runtime string) and key kind, from XML (`<kind>WITH_KEY`), a
//!   `-r` reference or the binary representation (never keyed, as eProsima).
//! * **Publishers and subscribers** have no DDS counterpart of their own: the bridge gives every
//!   participant one publisher and one subscriber, and endpoints carry their full QoS, with the partitions
//!   of their XRCE publisher or subscriber (applied by the Fast DDS engine; RustDDS 0.15.1 has no PARTITION
//!   policy: logged).
//! * **ROS 2 nodes**: ROS 2 reads node names from `ros_discovery_info`, not from participant names: each
//!   named XRCE participant is also a ROS 2 node there ([`super::ros_graph`]), on both engines and in both
//!   participant modes.
//! * **History depth 0** (eProsima's C client leaves the depth out then) means the DDS default, keep-last 1.
//! * **Datawriters and datareaders** get the QoS of their description: reliability, durability, history
//!   kind and depth and resource limits from XML/references (Fast DDS defaults for what is left out), the
//!   QoS bits of spec §7.4 from binary ones. Resource limits equal to Fast DDS's defaults, or unlimited,
//!   are replaced by the bridge's bounds, which avoid RustDDS' 64-sample cache (no silent loss on reliable
//!   topics); explicit ones are honoured. XRCE datawriters of a participant with the same topic and QoS
//!   share one DDS datawriter ([`Participant::shared_writer`]): 10,000 clients publishing one topic cost one
//!   DDS writer (one GUID, one history, one discovery record at every peer) instead of 10,000 (about 20 KiB
//!   each in RustDDS, and 10,000 SEDP announcements). DDS readers therefore see one publisher where
//!   eProsima's agent shows one per XRCE datawriter (`ros2 topic info` counts); samples, their order per
//!   XRCE writer and reliability are unchanged.
//! * **Samples** are opaque CDR bodies: the bridge adds the `00 01 00 00` encapsulation on publish and
//!   strips it on receive (spec §8.4).
//! * **Requesters and repliers** bridge to request/reply topics with the related sample identity
//!   (spec §8.3), so Fast DDS requesters and repliers are peers, and an XRCE requester reaches an XRCE
//!   replier of the same agent through DDS.
//! * **Delivery**: readers fill bounded queues on the bridge's dispatcher thread, which calls the
//!   [`Waker`] installed with [`Middleware::set_waker`]; the core takes samples one by one
//!   ([`Middleware::poll_sample`], which lends each sample to the core's visitor) under its READ_DATA delivery control,
//!   from a small local buffer refilled [`TAKE_BATCH`] samples at a time (one queue lock per batch).
//! * **Between two clients of the agent** (Fast DDS): Fast DDS delivers a sample to a reader of its own
//!   process inside the write, on the agent's thread, which was the DDS path's cost over CED's. A sample of
//!   a reliable keep-last datawriter goes *ahead* to the agent's reliable readers with a reliable read task
//!   that already received from its DDS writer: queued at once, served in the same turn, and the DDS write
//!   (for every other reader) made once the shell has sent the turn's messages ([`Middleware::flush`]); those
//!   readers drop Fast DDS' copy. See [`Dds::write_after_send`] for why this delivers exactly what DDS would.
//! * **Back-pressure** (no silent loss on reliable topics, issue 5). RustDDS acknowledges a sample as soon
//!   as it is in its reader's topic cache and evicts the oldest cached samples past the cache's resource
//!   limit whether taken or not; so when an XRCE publisher outran an XRCE subscriber of the same agent,
//!   samples vanished inside RustDDS (71 % at 60k samples/s with a KEEP_LAST 1 reader). A datareader whose
//!   read task delivers on a reliable stream is *pinned* ([`Middleware::set_reader_reliable`]); it stays
//!   pinned between read tasks (a subscriber reading with a small `max_samples` must not lose what arrives
//!   meanwhile) until a best-effort read, its deletion, or the core unpinning a dead client's readers. For
//!   a datawriter, [`Middleware::write_credit`] is 0 while a pinned reader of the same topic and domain (in
//!   any of the agent's DDS participants) has [`RELIABLE_BACKLOG`] samples or more (at most half its queue) not yet taken by the core:
//!   those queued, plus those of this writer still in flight towards the queue (last sequence number
//!   written minus the last one the queue received; ignored once the queue has received nothing from the
//!   writer for [`IN_FLIGHT_STALL`], so a reader that never matches cannot stall the writer forever). The
//!   core then holds the publisher's reliable stream, whose history fills, and its writes block. Not
//!   covered by the credit: remote DDS readers (the engine refuses the write when its history is full: the
//!   write is [`WriteOutcome::WouldBlock`], never a wait, [`WOULD_BLOCK_RETRY`]) and remote DDS writers to
//!   a stalled XRCE reader (the engine has acknowledged those samples already).
//! * **First contact** (issue 11). A new DDS writer reaches the readers its participant already knows only
//!   once the engine has matched them, some 20–35 ms after its creation; a volatile writer does not owe a
//!   reader the samples written before it matched it, so the first samples of a client writing right
//!   after STATUS OK were lost at readers (a ROS node) that had matched the writer first. Each new
//!   datawriter and requester is therefore *gated*: [`Middleware::write_credit`] is 0 while its DDS writer
//!   has not matched every remote reader of its topic that the participant has discovered with a
//!   compatible QoS, for [`FIRST_CONTACT_GATE`] at most, or [`FIRST_CONTACT_DISCOVERY_LIMIT`] while such a
//!   reader's participant is still in discovery with the writer's; the core keeps the client's reliable message and
//!   retries it when a small timer thread wakes it ([`GATE_RECHECK`], only while a write is held). Readers
//!   not discovered yet are the ordinary late joiners and are not waited for. Whether the *remote* reader
//!   has matched our writer shows only in its acknowledgements: once our reliable writer has matched it, the
//!   writer keeps samples for it, but a keep-last one only its last `depth`; so a reliable keep-last writer
//!   then writes at most `depth` samples until every matched reader has acknowledged (`Acks`, same
//!   bound). With `eager_participant` (the CLI default)
//!   the default DDS participant exists from the agent's start, so the readers of ROS nodes already
//!   running are known before the first client arrives; once a participant created for a name has run
//!   [`DEFAULT_PARTICIPANT_RETIRE_AFTER`] it knows as much, and the default one is retired (one participant
//!   fewer doing discovery while ROS nodes come and go), to be created again when the domain has none
//!   left. A requester also holds its first request while no replier has matched at all
//!   ([`FIRST_CONTACT_GATE_REQUESTER`]). On the Fast DDS engine a new writer matches the readers its
//!   participant knows while it is created; but a participant created for a new name knows nothing yet
//!   (its endpoint discovery with a ROS node takes 100–300 ms: Fast DDS' 70 ms initial ACKNACK delay, then
//!   the peer's ~93 ms NACK response delay), so there the readers counted are those the domain's
//!   participant running longest has discovered (the default one while it lives), and the gate also waits
//!   while the writer's participant is still in discovery with a remote participant: one it has discovered
//!   without any endpoint yet (a ROS node started with the client is not known to the older participant
//!   either), or one the older participant knows and it has not discovered yet (its first milliseconds; a
//!   participant that missed a peer's answer to its first announcement is created again by the bridge,
//!   docs/dds-engine.md, issue 20).
//!   Best-effort writes (PX4) are not held by the
//!   core: the middleware keeps them at the gate ([`HELD_AT_GATE`]) and replays them once it opens, at
//!   twice the rate they were written (a burst would overflow a keep-last reader's history).
//! * **REUSE** compares the full description (names, types, key kind, QoS, parent), not only names: a node
//!   keeps a 64-bit digest of it (std's `DefaultHasher`, fixed keys), not the description itself, to stay small.

use std::collections::VecDeque;

use foldhash::{HashMap, HashMapExt, HashSet, HashSetExt};
use std::sync::Arc;
use std::time::{Duration, Instant};

use xrce_dds::{
    BridgeConfig, DdsBridge, DdsError, EndpointQos as DdsQos, Participant, RawReader, RawTopic, RawWriter,
    ReceivedSample, Replier, Requester, SampleQueue, AGENT_DOMAIN,
};
use xrce_proto::types::{Guid, SequenceNumber};
use xrce_proto::{ClientKey, ObjectKind, RequestId, SampleIdentity};

use super::describe::ProfileSource;
use super::ros_graph::{RosGraph, RosGraphMode};
use super::{
    Creation, EntityCounts, EntityRef, Middleware, MiddlewareError, SampleRef, SampleVisitor, Waker, WriteOutcome,
};

mod diagnostics;
mod entities;
mod first_contact;
mod gate;
mod observe;
pub(crate) mod spec;
mod write;

use first_contact::{Acks, Gate};
use gate::{GateTimer, HeldSamples};
use spec::{spec_of_creation, Spec, TopicSel};

/// How long a write that found its DDS writer's history full waits before the core is woken to retry it.
/// The agent's DDS writers never block (`max_blocking_time` 0, see `non_blocking`): the write returns
/// [`WriteOutcome::WouldBlock`], the core keeps the client's reliable message unacknowledged, and the gate
/// timer wakes it every [`GATE_RECHECK`] until this has passed since the last refusal.
pub const WOULD_BLOCK_RETRY: Duration = Duration::from_millis(50);

/// Samples a pinned (reliable) local datareader may have waiting — queued for the core plus in flight from
/// the writer — before the writers of its topic are held back ([`Middleware::write_credit`]). Half the reader's
/// queue if that is less. Well below RustDDS' smallest topic cache (1,024 samples, which also holds
/// already-taken samples) and its writers' send window, and large enough that a fast subscriber never
/// waits for a publisher: 256 × 16-byte samples are ~4 ms of traffic at 60k samples/s.
pub const RELIABLE_BACKLOG: usize = 256;

/// How long samples of a local writer may stay "in flight" towards a pinned reader without any of them
/// arriving before they are no longer counted in its backlog (the reader does not match the writer, or
/// RustDDS gave up on them).
pub const IN_FLIGHT_STALL: std::time::Duration = std::time::Duration::from_millis(500);

/// Samples moved at once from a reader's bridge queue to the middleware's local buffer.
pub const TAKE_BATCH: usize = 64;

/// Longest a new datawriter or replier holds its first writes until its DDS writer has matched the remote
/// readers already discovered on its topic (see the module documentation), once no such reader's participant
/// is in discovery with the writer's any more ([`FIRST_CONTACT_DISCOVERY_LIMIT`] applies until then).
/// Matching a known reader takes RustDDS 20–35 ms, and a Fast DDS writer matches the readers of a
/// participant as soon as its endpoints arrive; so 500 ms runs out only when a known reader will never match
/// (an incompatibility our check does not see, such as a deadline or a partition; a status event the engine
/// dropped), and it stays below the 1 s micro-ROS waits by default for a reliable publish to be confirmed.
/// After it, writes go through as before the gate existed.
pub const FIRST_CONTACT_GATE: Duration = Duration::from_millis(500);

/// Longest a new datawriter, requester or replier holds its first writes while a reader it has not matched,
/// known on its topic, belongs to a participant still in discovery with the writer's own (not discovered yet,
/// or no endpoint of it yet): the writer will match that reader once discovery ends, so writing earlier would
/// skip it. Discovery normally ends in 100–300 ms; when one of its messages is lost it resumes at the peer's
/// next periodic announcement, 3 s apart by default in Fast DDS (ROS 2 keeps it). 3.5 s covers that once,
/// and stays below what a micro-ROS publisher holds in its reliable stream (4 slots, 1 s confirmation wait
/// per publish). A peer gone without saying so (its lease not run out) is waited for this long, no longer.
pub const FIRST_CONTACT_DISCOVERY_LIMIT: Duration = Duration::from_millis(3500);

/// The same bound for a new requester, which also holds its first request while no replier has matched at
/// all: a request written then is lost for certain (volatile), and applications call a service right after
/// creating its client, while discovery with the server may still be under way (a Fast DDS 2.14 node and
/// our participant take up to a few hundred ms). Still below micro-ROS' 1 s confirmation wait.
pub const FIRST_CONTACT_GATE_REQUESTER: Duration = Duration::from_millis(600);

/// Longest a reply is held while the replier's reply writer has not matched its requester's reply reader yet
/// (see [`Dds::write_reply`]): a requester that discovered the replier first may call at once, and a reply
/// written before the match never reaches its volatile reader (a ROS 2 service client: 1 call in 50 timed out
/// so). After it the reply goes anyway (a requester that never matches must not hold the client).
pub const REPLY_MATCH_WAIT: Duration = Duration::from_millis(500);

/// How long a participant the agent created for a name must have run before the default participant created
/// at start ([`Dds::with_eager_participant`]) is retired: by then it has discovered every remote participant
/// and endpoint the default one knows (discovery takes 100–300 ms, [`FIRST_CONTACT_DISCOVERY_LIMIT`] when a
/// message is lost), and it becomes the oracle of the participants created after it (the domain's participant
/// running longest, `xrce_dds`). Each participant of the agent does discovery with every remote one, so one
/// fewer saves CPU time while ROS nodes come and go (docs/dds-engine.md, issue 21).
pub const DEFAULT_PARTICIPANT_RETIRE_AFTER: Duration = Duration::from_secs(10);

/// How often [`Middleware::poll`] drops the gates of endpoints that never wrote and whose every bound has
/// passed ([`GATE_EXPIRED`]): such a gate would open at the first write anyway, and an idle client's would
/// otherwise stay for its life (72 B in a table of every gate, which keeps its largest size: ~120 B per
/// client after 10,000 clients connected at once, issue 22).
const GATE_SWEEP: Duration = Duration::from_secs(1);

/// Age after which a gate holds nothing any more: its longest bound ([`FIRST_CONTACT_DISCOVERY_LIMIT`]) plus
/// the acknowledgement watch's shorter one after a late match, with room to spare.
const GATE_EXPIRED: Duration = Duration::from_secs(5);

/// How often [`Middleware::poll`] looks whether the default participant can be retired.
const DEFAULT_PARTICIPANT_CHECK: Duration = Duration::from_secs(1);

/// DDS participants the agent creates for XRCE participant names (~1.7 MiB and 5 threads each on Fast DDS);
/// XRCE participants named after that share the default participant, with a warning. 128 named nodes is more
/// than one agent serves in the deployments we know (PX4: one; micro-ROS: a few per board).
pub const MAX_NAMED_PARTICIPANTS: usize = 128;

/// Best-effort samples a datawriter at its first-contact gate keeps for when it opens ([`HeldSamples`]);
/// beyond, the oldest go. 256 is a 500 ms gate at 500 Hz, more than PX4 publishes on one topic.
pub const HELD_AT_GATE: usize = 256;

/// The same bound in payload bytes, per datawriter.
pub const HELD_AT_GATE_BYTES: usize = 64 * 1024;

/// How often the gate timer wakes the core to retry a write held at a gate (only while one is held): the
/// added latency once the writer has matched, at the cost of a few hundred wake-ups at most per gate.
pub const GATE_RECHECK: Duration = Duration::from_millis(2);

/// Longest the DDS write of a sample that went ahead to the agent's own readers waits for a shell that does
/// not call [`AgentCore::after_send`](crate::core::AgentCore::after_send) (the core's timers run it then).
/// The agent's shells call it after every turn's sends, so the write follows within microseconds.
pub const AFTER_SEND_LIMIT: Duration = Duration::from_millis(1);

/// A topic as the agent's DDS participants see it: domain and topic name. A local writer reaches the local
/// readers of the same topic in every participant of the agent in that domain (participants per name).
type TopicId = (u16, Arc<str>);

/// What a datawriter has written: for the in-flight part of a reader's backlog.
#[derive(Debug, Clone, Copy)]
struct Written {
    /// Sequence number of the first sample written.
    first_seq: i64,
    /// When it was written.
    first_at: Instant,
    /// Sequence number of the last sample written.
    last_seq: i64,
}

/// A datawriter's DDS side. `writer` is shared by every XRCE datawriter of the participant with the same
/// topic and QoS; `written` is this datawriter's own part of its sequence numbers.
struct WriterState {
    writer: Arc<RawWriter>,
    topic: TopicId,
    written: Option<Written>,
    /// Its samples may go ahead to the agent's own readers, the DDS write following once the shell has sent
    /// its messages ([`Dds::write_after_send`]): Fast DDS, reliable, keep-last (the write cannot be refused),
    /// unkeyed, no lifespan.
    ahead: bool,
}

/// A datareader's DDS side.
struct ReaderState {
    reader: RawReader,
    topic: TopicId,
    /// Reliable QoS (its DDS history is KEEP_ALL: a sample of a matched writer of the agent arrives in order
    /// and is never dropped, so one queued ahead is exactly the next the writer sends it).
    reliable: bool,
    /// Samples already taken from the bridge queue ([`Node::front`]).
    local: VecDeque<ReceivedSample>,
}

/// A requester or replier and the samples already taken from its bridge queue ([`Node::front`]).
struct Queued<T> {
    service: T,
    local: VecDeque<ReceivedSample>,
}

impl<T> Queued<T> {
    fn new(service: T) -> Box<Self> {
        Box::new(Self { service, local: VecDeque::new() })
    }
}

impl<T> std::ops::Deref for Queued<T> {
    type Target = T;
    fn deref(&self) -> &T {
        &self.service
    }
}

/// The DDS side of an entity.
enum Handle {
    Participant(Participant),
    Topic(RawTopic),
    /// A publisher or subscriber: its partitions (boxed slice: nodes stay small, and empty allocates nothing).
    Group(Box<[String]>),
    // Endpoints are boxed like requesters and repliers: a node per entity stays small (thousands of clients).
    Writer(Box<WriterState>),
    Reader(Box<ReaderState>),
    // Boxed: rare and large; the common variants stay small (a node per entity, thousands of clients).
    Requester(Box<Queued<Requester>>),
    Replier(Box<Queued<Replier>>),
}

impl Handle {
    /// The queue the core reads from, for readers, requesters and repliers.
    fn queue(&self) -> Option<&SampleQueue> {
        match self {
            Handle::Reader(r) => Some(r.reader.queue()),
            Handle::Requester(r) => Some(r.replies()),
            Handle::Replier(r) => Some(r.requests()),
            _ => None,
        }
    }

    /// The samples already taken from the bridge queue, for the same entities as [`Handle::queue`].
    fn local(&self) -> Option<&VecDeque<ReceivedSample>> {
        match self {
            Handle::Reader(r) => Some(&r.local),
            Handle::Requester(r) => Some(&r.local),
            Handle::Replier(r) => Some(&r.local),
            _ => None,
        }
    }

    /// [`Handle::queue`] and [`Handle::local`] together.
    fn queue_and_local(&mut self) -> Option<(&SampleQueue, &mut VecDeque<ReceivedSample>)> {
        match self {
            Handle::Reader(r) => {
                let r = &mut **r;
                Some((r.reader.queue(), &mut r.local))
            }
            Handle::Requester(r) => {
                let r = &mut **r;
                Some((r.service.replies(), &mut r.local))
            }
            Handle::Replier(r) => {
                let r = &mut **r;
                Some((r.service.requests(), &mut r.local))
            }
            _ => None,
        }
    }
}

struct Node {
    parent: Option<EntityRef>,
    /// [`Spec::digest`] of what the entity was created from (for REUSE).
    spec: u64,
    handle: Handle,
}

impl Node {
    /// The queue the core reads from, for readers, requesters and repliers.
    fn queue(&self) -> Option<&SampleQueue> {
        self.handle.queue()
    }

    /// The next sample for the core, refilling the local buffer from the bridge queue in batches.
    /// Readers, requesters and repliers keep the samples taken from the bridge queue, in order, for the core;
    /// refilled [`TAKE_BATCH`] at a time.
    fn front(&mut self) -> Option<&ReceivedSample> {
        let (queue, local) = self.handle.queue_and_local()?;
        if local.is_empty() {
            queue.take_batch(TAKE_BATCH, local);
        }
        local.front()
    }

    /// Samples of pinned reader `self` not yet taken by the core that count against `writer`'s writes:
    /// queued (bridge queue and local buffer) plus `writer`'s samples in flight towards the queue.
    fn backlog_for(&self, writer: &[u8; 16], written: Option<Written>, now: Instant) -> usize {
        let Some(q) = self.queue() else { return 0 };
        let (queued, progress) = q.backlog_of(writer);
        let in_flight = match (written, progress) {
            (None, _) => 0,
            (Some(w), Some((seq, at))) if now.saturating_duration_since(at) < IN_FLIGHT_STALL => {
                w.last_seq.saturating_sub(seq)
            }
            (Some(_), Some(_)) => 0,
            (Some(w), None) if now.saturating_duration_since(w.first_at) < IN_FLIGHT_STALL => {
                w.last_seq.saturating_sub(w.first_seq).saturating_add(1)
            }
            (Some(_), None) => 0,
        };
        queued + self.handle.local().map_or(0, VecDeque::len) + usize::try_from(in_flight.max(0)).unwrap_or(usize::MAX)
    }
}

/// The DDS middleware. See the module documentation.
pub struct Dds {
    profiles: Arc<dyn ProfileSource>,
    bridge: Arc<DdsBridge>,
    /// Boxed nodes: the table's spare capacity then costs a pointer per slot, not a whole node.
    entities: HashMap<EntityRef, Box<Node>>,
    /// Entities per client (see [`EntityCounts`]).
    owned: EntityCounts,
    waker: Option<Waker>,
    /// Datareaders whose samples must not be lost: they hold writers back (see the module documentation).
    pinned: HashSet<EntityRef>,
    /// The ROS 2 graph (`ros_discovery_info`), unless turned off.
    graph: Option<RosGraph>,
    /// Datawriters, requesters and repliers still at their first-contact gate.
    gates: HashMap<EntityRef, Gate>,
    /// Writers whose credit was 0 when the core last asked ([`Middleware::write_credit`]): the core holds their
    /// clients' reliable input and asks again until they have credit. What the snapshot counts as "writers
    /// without credit" (gated, or a full backlog behind the agent's own slowest reliable reader).
    without_credit: HashSet<EntityRef>,
    /// Best-effort samples written to a datawriter at its gate, replayed once it opens.
    held: HashMap<EntityRef, HeldSamples>,
    /// Repliers holding a reply until its requester's reply reader is matched: since when.
    replies_held: HashMap<EntityRef, Instant>,
    gate_timer: GateTimer,
    /// When [`Middleware::poll`] last dropped the gates of writers that never wrote ([`GATE_SWEEP`]).
    gates_swept_at: Option<Instant>,
    /// The default domain's DDS participant, created with the middleware when asked
    /// ([`Dds::with_eager_participant`]) and while the domain has no older participant that knows as much.
    eager: Option<Participant>,
    /// The default participant was retired ([`DEFAULT_PARTICIPANT_RETIRE_AFTER`]): it is created again once
    /// the domain has no participant left, and when to look whether it can be retired.
    eager_retired: bool,
    eager_check_at: Option<Instant>,
    /// [`DEFAULT_PARTICIPANT_RETIRE_AFTER`] unless set ([`Dds::with_default_participant_retire_after`]).
    eager_retire_after: Duration,
    /// Every XRCE participant of a domain shares the default DDS participant, whatever its name
    /// ([`Dds::with_shared_participants`]).
    share_participants: bool,
    /// Participants created for names at most ([`MAX_NAMED_PARTICIPANTS`] by default).
    named_limit: usize,
    /// Samples handed ahead to the agent's own readers whose DDS write waits for [`Middleware::flush`], in
    /// the order written ([`Dds::write_after_send`]), and since when the oldest waits.
    after_send: VecDeque<(EntityRef, Vec<u8>)>,
    after_send_since: Option<Instant>,
    /// Per DDS writer with samples in `after_send`: the readers they went ahead to. A later sample goes ahead
    /// only to these (a reader that got an earlier one through DDS must get the later one after it).
    ahead_to: HashMap<[u8; 16], Vec<EntityRef>>,
    /// ROS 2 `/diagnostics` (`--ros-diagnostics`), when on.
    diagnostics: Option<diagnostics::RosDiagnostics>,
    /// The name of each client's named participant (the last one created), for snapshots.
    names: HashMap<ClientKey, String>,
}

impl Drop for Dds {
    fn drop(&mut self) {
        self.flush_pending();
    }
}

impl std::fmt::Debug for Dds {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Dds").field("bridge", &self.bridge).field("entities", &self.entities.len()).finish()
    }
}

/// `qos` for a writer the core calls: a full history refuses the write at once instead of blocking the core
/// for `max_blocking_time` (the core retries; see [`WOULD_BLOCK_RETRY`]).
fn non_blocking(qos: &DdsQos) -> DdsQos {
    DdsQos { max_blocking_time: Duration::ZERO, ..qos.clone() }
}

pub(crate) fn invalid(msg: impl Into<String>) -> MiddlewareError {
    MiddlewareError::InvalidDescription(msg.into())
}

fn dds_error(e: DdsError) -> MiddlewareError {
    match e {
        DdsError::Resources(m) => MiddlewareError::Resources(m),
        other => MiddlewareError::InvalidDescription(other.to_string()),
    }
}

pub(crate) fn unknown(what: impl std::fmt::Debug) -> MiddlewareError {
    MiddlewareError::UnknownReference(format!("{what:?}"))
}

/// The DDS reader and the DDS writer behind an XRCE endpoint (each if it has one).
type EndpointGids = (Option<[u8; 16]>, Option<[u8; 16]>);

/// The DDS reader and writer GUIDs behind an endpoint (both for requesters and repliers); `None` for
/// entities that are no endpoint.
fn endpoint_gids(h: &Handle) -> Option<EndpointGids> {
    match h {
        Handle::Writer(w) => Some((None, Some(w.writer.guid()))),
        Handle::Reader(r) => Some((Some(r.reader.guid()), None)),
        Handle::Requester(r) => Some((Some(r.reply_reader_guid()), Some(r.request_writer_guid()))),
        Handle::Replier(r) => Some((Some(r.request_reader_guid()), Some(r.reply_writer_guid()))),
        Handle::Participant(_) | Handle::Topic(_) | Handle::Group(_) => None,
    }
}

/// XRCE sample identity of a DDS sample identity.
fn identity_to_xrce(id: &xrce_dds::SampleIdentity) -> SampleIdentity {
    let (high, low) = id.sequence_parts();
    SampleIdentity { writer_guid: Guid::from_bytes(id.writer_guid), sequence_number: SequenceNumber { high, low } }
}

/// DDS sample identity of an XRCE one (the identity a replier's WRITE_DATA carries back).
fn identity_to_dds(id: &SampleIdentity) -> xrce_dds::SampleIdentity {
    xrce_dds::SampleIdentity::from_parts(id.writer_guid.to_bytes(), id.sequence_number.high, id.sequence_number.low)
}

impl Dds {
    /// A DDS middleware on every network interface (run the agent in a loopback-only namespace to keep
    /// DDS on the machine). No DDS participant exists until a client creates one.
    pub fn new(profiles: Arc<dyn ProfileSource>) -> Self {
        Self::with_config(profiles, BridgeConfig::default())
    }

    /// A DDS middleware with an explicit bridge configuration (networks, domain override).
    pub fn with_config(profiles: Arc<dyn ProfileSource>, config: BridgeConfig) -> Self {
        Self::with_bridge(profiles, Arc::new(DdsBridge::new(config)))
    }

    /// A DDS middleware on an existing bridge (its participants are shared with whoever else holds it).
    pub fn with_bridge(profiles: Arc<dyn ProfileSource>, bridge: Arc<DdsBridge>) -> Self {
        Self {
            profiles,
            bridge,
            entities: HashMap::new(),
            owned: EntityCounts::default(),
            waker: None,
            pinned: HashSet::new(),
            graph: RosGraph::new(RosGraphMode::default()),
            gates: HashMap::new(),
            without_credit: HashSet::default(),
            held: HashMap::new(),
            replies_held: HashMap::new(),
            gate_timer: GateTimer::default(),
            gates_swept_at: None,
            eager: None,
            eager_retired: false,
            eager_check_at: None,
            eager_retire_after: DEFAULT_PARTICIPANT_RETIRE_AFTER,
            share_participants: false,
            named_limit: MAX_NAMED_PARTICIPANTS,
            after_send: VecDeque::new(),
            after_send_since: None,
            ahead_to: HashMap::new(),
            diagnostics: None,
            names: HashMap::new(),
        }
    }

    /// How many DDS participants the middleware may create for XRCE participant names (live participants of
    /// the bridge counted); past it, named XRCE participants share the default one, with a warning.
    pub fn with_named_participant_limit(mut self, limit: usize) -> Self {
        self.named_limit = limit;
        self
    }

    /// With `share`, every XRCE participant of a domain uses the domain's default DDS participant (named
    /// `xrce-rs`) instead of one DDS participant per XRCE participant name (see the module documentation).
    pub fn with_shared_participants(mut self, share: bool) -> Self {
        self.share_participants = share;
        self
    }

    /// Writes ROS 2 `/diagnostics` from each snapshot the core publishes (`--ros-diagnostics`).
    pub fn with_ros_diagnostics(mut self, on: bool) -> Self {
        self.diagnostics = on.then(diagnostics::RosDiagnostics::default);
        self
    }

    /// Creates now the DDS participant an XRCE participant of the agent's domain (255) without profile
    /// will use, so that discovery with the DDS applications already running is done before the first
    /// client arrives (see the module documentation). Once a participant created for a name has run
    /// [`DEFAULT_PARTICIPANT_RETIRE_AFTER`], it knows as much and the default one is released (it stays while
    /// an XRCE participant uses it); it is created again when the domain has no participant left. A failure
    /// is logged and the participant is then created on first use, as without this.
    pub fn with_eager_participant(mut self, eager: bool) -> Self {
        self.eager = None;
        self.eager_retired = false;
        if eager {
            self.create_default_participant("at start");
        }
        self
    }

    /// How long a participant created for a name must have run before the default participant created at
    /// start is retired ([`DEFAULT_PARTICIPANT_RETIRE_AFTER`] by default; tests shorten it).
    pub fn with_default_participant_retire_after(mut self, after: Duration) -> Self {
        self.eager_retire_after = after;
        self
    }

    fn create_default_participant(&mut self, when: &str) {
        match self.bridge.participant(AGENT_DOMAIN, "") {
            Ok(p) => {
                tracing::info!(guid = ?p.guid(), "default DDS participant created {when} (discovery runs before clients arrive)");
                self.eager = Some(p);
            }
            Err(e) => tracing::warn!("default DDS participant not created {when}: {e}"),
        }
    }

    /// Retires the default participant created at start once a named one knows the domain as well
    /// ([`DEFAULT_PARTICIPANT_RETIRE_AFTER`]), at most every [`DEFAULT_PARTICIPANT_CHECK`].
    fn retire_default_participant(&mut self, now: Instant) {
        if self.eager.is_none() || self.eager_check_at.is_some_and(|at| now < at) {
            return;
        }
        self.eager_check_at = Some(now + DEFAULT_PARTICIPANT_CHECK);
        let settled = self
            .bridge
            .oldest_named_participant_since(AGENT_DOMAIN)
            .is_some_and(|born| now.saturating_duration_since(born) >= self.eager_retire_after);
        if settled {
            let deleting = Instant::now();
            self.eager = None;
            self.eager_retired = true;
            let (took, after) = (deleting.elapsed(), self.eager_retire_after);
            tracing::info!(?took, "default DDS participant retired: a participant running longer than {after:?} knows the domain (one participant fewer in discovery)");
        }
    }

    /// Creates the retired default participant again once the domain has no participant left, so that
    /// discovery runs before the next client arrives.
    fn restore_default_participant(&mut self) {
        if self.eager_retired && !self.bridge.domain_has_participant(AGENT_DOMAIN) {
            self.eager_retired = false;
            self.eager_check_at = None;
            self.create_default_participant("again (the domain had no participant left)");
        }
    }

    /// Publishes the ROS 2 graph with `mode`'s GIDs, or not at all ([`RosGraphMode::Off`]).
    pub fn with_ros_graph(mut self, mode: RosGraphMode) -> Self {
        self.graph = RosGraph::new(mode);
        self
    }

    /// The bridge (DDS participants alive, domain resolution).
    pub fn bridge(&self) -> &Arc<DdsBridge> {
        &self.bridge
    }

    /// Number of XRCE entities held.
    pub fn entity_count(&self) -> usize {
        self.entities.len()
    }
}

impl Middleware for Dds {
    fn create(&mut self, creation: &Creation<'_>) -> Result<(), MiddlewareError> {
        self.flush_writes(creation.now);
        let spec = self.spec_of(creation)?;
        let handle = self.build(creation, &spec)?;
        let node = Node { parent: creation.parent, spec: spec.digest(), handle };
        if let Some(old) = self.entities.get(&creation.entity) {
            self.graph_unlink(creation.entity, old);
        }
        // A replaced entity starts unpinned; the core pins it again with its next reliable read.
        self.pinned.remove(&creation.entity);
        if matches!(node.handle, Handle::Writer(_) | Handle::Replier(_)) {
            let acks = match &spec {
                Spec::Endpoint { qos, .. } if matches!(node.handle, Handle::Writer(_)) => self.ack_watch_for(qos),
                _ => Acks::Unwatched,
            };
            self.gates.insert(creation.entity, Gate { created: creation.now, short: FIRST_CONTACT_GATE, acks });
        } else if matches!(node.handle, Handle::Requester(_)) {
            let gate = Gate { created: creation.now, short: FIRST_CONTACT_GATE_REQUESTER, acks: Acks::Unwatched };
            self.gates.insert(creation.entity, gate);
        } else {
            self.gates.remove(&creation.entity);
        }
        if let (Some(w), Some(q)) = (&self.waker, node.queue()) {
            q.set_waker(Some(Arc::clone(w)));
        }
        if self.entities.insert(creation.entity, Box::new(node)).is_none() {
            self.owned.added(creation.entity.client);
        }
        let name = match &spec {
            Spec::Participant { name, .. } => name.as_deref(),
            _ => None,
        };
        self.graph_link(creation.entity, name);
        if let Some(name) = name {
            self.names.insert(creation.entity.client, name.to_owned());
        }
        Ok(())
    }

    fn matches(&self, creation: &Creation<'_>) -> bool {
        let Some(node) = self.entities.get(&creation.entity) else { return false };
        match self.spec_of(creation) {
            Ok(spec) => node.parent == creation.parent && node.spec == spec.digest(),
            Err(_) => false,
        }
    }

    fn delete(&mut self, entity: EntityRef) -> Result<(), MiddlewareError> {
        self.flush_pending();
        self.pinned.remove(&entity);
        self.without_credit.remove(&entity);
        self.gates.remove(&entity);
        self.held.remove(&entity);
        self.replies_held.remove(&entity);
        let node = self.entities.remove(&entity).ok_or_else(|| unknown(entity))?;
        self.graph_unlink(entity, &node);
        self.owned.removed(entity.client);
        drop(node);
        self.restore_default_participant();
        Ok(())
    }

    fn delete_client(&mut self, client: ClientKey) {
        self.flush_pending();
        if !self.owned.forget(client) {
            return;
        }
        self.names.remove(&client);
        self.pinned.retain(|e| e.client != client);
        self.without_credit.retain(|e| e.client != client);
        self.gates.retain(|e, _| e.client != client);
        self.held.retain(|e, _| e.client != client);
        if let Some(g) = &self.graph {
            // A node goes with its endpoints.
            for (e, node) in self.entities.iter().filter(|(e, _)| e.client == client) {
                if let Handle::Participant(p) = &node.handle {
                    g.remove_node(p.guid(), *e);
                }
            }
        }
        self.entities.retain(|e, _| e.client != client);
        self.restore_default_participant();
    }

    fn write_data(&mut self, writer: EntityRef, data: &[u8], now: Instant) -> Result<WriteOutcome, MiddlewareError> {
        // Only best-effort writes reach a closed gate: the core holds reliable ones (`write_credit`).
        let closed = self.gates.contains_key(&writer) && !self.gate_open(writer, now);
        if closed || self.held.contains_key(&writer) {
            self.held.entry(writer).or_default().push(now, data);
            if !closed {
                self.replay_held(writer, now);
            }
            return Ok(WriteOutcome::Accepted);
        }
        self.write_now(writer, data, now)
    }

    fn poll(&mut self, now: Instant) {
        self.retire_default_participant(now);
        self.sweep_gates(now);
        if self.held.is_empty() {
            return;
        }
        let writers: Vec<EntityRef> = self.held.keys().copied().collect();
        for w in writers {
            if self.gate_open(w, now) {
                self.replay_held(w, now);
            }
        }
    }

    fn write_request(
        &mut self,
        requester: EntityRef,
        request_id: RequestId,
        data: &[u8],
        now: Instant,
    ) -> Result<WriteOutcome, MiddlewareError> {
        self.flush_writes(now);
        let node = self.node(requester)?;
        let Handle::Requester(r) = &node.handle else {
            return Err(MiddlewareError::Unsupported(format!("{requester:?} is not a requester")));
        };
        match r.write_request(u32::from(request_id.0), data) {
            Ok(_) => Ok(WriteOutcome::Accepted),
            Err(e) => self.refused(requester, e, now),
        }
    }

    fn write_reply(
        &mut self,
        replier: EntityRef,
        identity: &SampleIdentity,
        data: &[u8],
        now: Instant,
    ) -> Result<WriteOutcome, MiddlewareError> {
        self.flush_writes(now);
        let node = self.entities.get(&replier).map(|n| &**n).ok_or_else(|| unknown(replier))?;
        let Handle::Replier(r) = &node.handle else {
            return Err(MiddlewareError::Unsupported(format!("{replier:?} is not a replier")));
        };
        let request = identity_to_dds(identity);
        if !r.requester_matched(&request) {
            let since = *self.replies_held.entry(replier).or_insert(now);
            if now.saturating_duration_since(since) < REPLY_MATCH_WAIT {
                // Held (the core keeps the message and retries when the gate timer wakes it).
                self.gate_timer.arm(now + GATE_RECHECK, self.waker.as_ref());
                return Ok(WriteOutcome::WouldBlock);
            }
            tracing::debug!(
                ?replier,
                "reply written before its requester's reader matched (waited {REPLY_MATCH_WAIT:?})"
            );
        }
        self.replies_held.remove(&replier);
        match r.write_reply(&request, data) {
            Ok(_) => Ok(WriteOutcome::Accepted),
            Err(e) => self.refused(replier, e, now),
        }
    }

    fn start_reading(&mut self, reader: EntityRef) -> Result<(), MiddlewareError> {
        let node = self.node(reader)?;
        match node.queue() {
            Some(q) => {
                if let Some(w) = &self.waker {
                    q.set_waker(Some(Arc::clone(w)));
                }
                Ok(())
            }
            None => Err(MiddlewareError::Unsupported(format!("{reader:?} cannot read"))),
        }
    }

    fn poll_sample(&mut self, reader: EntityRef, visit: &mut SampleVisitor<'_>) -> Option<bool> {
        let node = self.entities.get_mut(&reader)?;
        let kind = match node.handle {
            Handle::Replier(_) => ObjectKind::Replier,
            Handle::Requester(_) => ObjectKind::Requester,
            _ => ObjectKind::DataReader,
        };
        let s = node.front()?;
        let taken = match kind {
            ObjectKind::Replier => visit(SampleRef::Request { identity: identity_to_xrce(&s.identity), data: &s.data }),
            ObjectKind::Requester => {
                let id = s.request_id.and_then(|id| u16::try_from(id).ok()).unwrap_or(0);
                visit(SampleRef::Reply { request_id: RequestId(id), data: &s.data })
            }
            _ => visit(SampleRef::Data(&s.data)),
        };
        if taken {
            if let Some((_, local)) = node.handle.queue_and_local() {
                local.pop_front();
            }
        }
        Some(taken)
    }

    fn flush(&mut self, now: Instant) {
        self.flush_writes(now);
    }

    fn flush_due(&self) -> Option<Instant> {
        self.after_send_since.map(|since| since + AFTER_SEND_LIMIT)
    }

    fn set_waker(&mut self, waker: Waker) {
        for node in self.entities.values() {
            if let Some(q) = node.queue() {
                q.set_waker(Some(Arc::clone(&waker)));
            }
        }
        self.waker = Some(waker);
    }

    fn write_credit(&mut self, writer: EntityRef, now: Instant) -> u32 {
        let credit = self.credit_now(writer, now);
        if credit == 0 {
            self.without_credit.insert(writer);
        } else if !self.without_credit.is_empty() {
            self.without_credit.remove(&writer);
        }
        credit
    }

    fn set_reader_reliable(&mut self, reader: EntityRef, reliable: bool) {
        let is_reader =
            matches!(self.entities.get(&reader).map(|n| &**n), Some(Node { handle: Handle::Reader(_), .. }));
        if reliable && is_reader {
            self.pinned.insert(reader);
        } else {
            self.pinned.remove(&reader);
        }
    }

    fn stats(&self) -> super::MiddlewareStats {
        self.observed_stats()
    }

    fn client_name(&self, client: ClientKey) -> Option<String> {
        self.names.get(&client).cloned()
    }

    fn on_snapshot(&mut self, snapshot: &crate::core::AgentSnapshot, _now: Instant) {
        self.write_diagnostics(snapshot);
    }
}

#[cfg(test)]
mod tests;
