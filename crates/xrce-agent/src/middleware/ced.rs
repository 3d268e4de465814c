//! CED, "centralized data": routes samples between the clients of this agent, without DDS (spec §15.1).
//!
//! Topics live in a registry keyed by `(domain, topic name)`; each keeps a ring of the last samples
//! ([`DEFAULT_RING_SIZE`], eProsima's 16) and every datareader has its own cursor into it, so a reader created
//! after some writes still gets the samples left in the ring, oldest first. Type names are not compared, as
//! in eProsima. Requesters and repliers meet by `(domain, service name)`: requests go to a ring read by every
//! replier of the service; a reply is routed back to the requester named in the request's sample identity.
//!
//! **Back-pressure.** A datareader whose read task delivers on a reliable stream *pins* its topic: samples it
//! has not taken are not overwritten by the ring. Past [`RELIABLE_BACKLOG`] samples not yet taken by the
//! slowest pinning reader, [`Middleware::write_credit`] answers 0 and the core stops consuming the
//! publisher's reliable input stream, so the publisher's history fills and its writes block instead of
//! samples being lost. Best-effort readers never pin (oldest samples are dropped). A single message may carry
//! many writes and is always processed whole: the ring then grows up to [`MAX_BACKLOG`] samples, beyond which
//! the oldest sample is dropped even for a pinning reader (logged and counted, see [`Ced::forced_drops`]).
//! The core unpins the readers of a client silent past its dead time (30 s by default), or whose reliable
//! output has acknowledged nothing for that long, so a vanished or misbehaving subscriber stalls its
//! publishers for that long at most (it pins again once it acknowledges).
//!
//! Unlike eProsima's CED, entities described in XML or by a profile reference work: their names come from
//! the [`ProfileSource`].

use std::collections::VecDeque;

use foldhash::{HashMap, HashMapExt};
use std::sync::Arc;
use std::time::Instant;

use xrce_proto::types::{Guid, SequenceNumber};
use xrce_proto::{ClientKey, ObjectId, ObjectKind, RequestId, SampleIdentity};

use crate::bufpool::BufPool;

use super::describe::{describe, Description, ProfileSource, TopicRef};
use super::{Creation, EntityCounts, EntityRef, Middleware, MiddlewareError, SampleRef, SampleVisitor, WriteOutcome};

/// Spare sample buffers kept for reuse.
const SAMPLE_BUFFERS_KEPT: usize = 1024;

/// Samples kept per topic and requests per service (eProsima's value).
pub const DEFAULT_RING_SIZE: usize = 16;
/// Samples not yet taken by the slowest reliable reader of a topic past which writers are held back.
pub const RELIABLE_BACKLOG: usize = 64;
/// Hard bound of a topic's ring: beyond it the oldest sample goes even if a reliable reader has not taken it.
pub const MAX_BACKLOG: usize = 1024;
/// Replies waiting per requester; older ones are dropped.
pub const MAX_PENDING_REPLIES: usize = 64;
/// Most topics and services the registry holds.
pub const MAX_TOPICS: usize = 4096;

/// Domain and topic (or service) name; names are shared between every entity of a topic.
type TopicKey = (i16, Arc<str>);
/// A topic's index in [`TopicSlab`]: 32 bits keep every entity 8 bytes smaller (thousands of clients hold
/// four each); [`MAX_TOPICS`] is far below its range.
type Slot = u32;
/// A request waiting for repliers: its identity and bytes.
type PendingRequest = (SampleIdentity, Arc<[u8]>);

#[derive(Debug, Default)]
struct Ring<T> {
    items: VecDeque<(u64, T)>,
    next_seq: u64,
    users: usize,
    /// Readers delivering on reliable streams, with their cursors (a copy of the reader's, kept here so a
    /// write needs no lookup per reader): what they have not taken is kept.
    pinned: Vec<(EntityRef, u64)>,
}

impl<T> Ring<T> {
    /// Appends `item`, keeping `capacity` items, or more while `pin` (the oldest sequence number a reliable
    /// reader still has to take) protects them, up to [`MAX_BACKLOG`]. Returns whether a pinned item was
    /// dropped.
    /// Items that go are handed to `gone` (sample buffers are reused).
    fn push(&mut self, item: T, capacity: usize, pin: Option<u64>, mut gone: impl FnMut(T)) -> bool {
        self.items.push_back((self.next_seq, item));
        self.next_seq += 1;
        let mut forced = false;
        while self.items.len() > capacity {
            let Some(&(oldest, _)) = self.items.front() else { break };
            let protected = pin.is_some_and(|p| oldest >= p);
            if protected && self.items.len() <= MAX_BACKLOG {
                break;
            }
            forced |= protected;
            if let Some((_, old)) = self.items.pop_front() {
                gone(old);
            }
        }
        forced
    }

    /// The item at or after `cursor`, with its sequence number.
    fn at_or_after(&self, cursor: u64) -> Option<&(u64, T)> {
        let oldest = self.items.front()?.0;
        let index = cursor.saturating_sub(oldest);
        self.items.get(usize::try_from(index).ok()?)
    }
}

/// The topics' rings: found by name when an entity attaches, then by the slot the entity keeps, so a sample
/// never hashes its topic's name (that cost more than the rest of a write and a take together).
#[derive(Debug, Default)]
struct TopicSlab {
    slots: HashMap<TopicKey, Slot>,
    rings: Vec<Option<Ring<Vec<u8>>>>,
    free: Vec<Slot>,
}

impl TopicSlab {
    fn len(&self) -> usize {
        self.slots.len()
    }

    /// Attaches one more entity to the topic `key` (created if new), which then shares the registry's copy
    /// of the name; the topic's slot.
    fn attach(&mut self, key: &mut TopicKey) -> Result<Slot, MiddlewareError> {
        if let Some((shared, &slot)) = self.slots.get_key_value(key) {
            *key = shared.clone();
            if let Some(ring) = self.get_mut(slot) {
                ring.users += 1;
            }
            return Ok(slot);
        }
        if self.slots.len() >= MAX_TOPICS {
            return Err(MiddlewareError::Resources("CED topic registry full".into()));
        }
        let ring = Ring { users: 1, ..Ring::default() };
        let slot = match self.free.pop() {
            Some(slot) => {
                if let Some(free) = self.rings.get_mut(slot as usize) {
                    *free = Some(ring);
                }
                slot
            }
            None => {
                let slot = Slot::try_from(self.rings.len())
                    .map_err(|_| MiddlewareError::Resources("CED topic registry full".into()))?;
                self.rings.push(Some(ring));
                slot
            }
        };
        self.slots.insert(key.clone(), slot);
        Ok(slot)
    }

    /// One entity of the topic in `slot` is gone; the topic goes with its last one.
    fn detach(&mut self, key: &TopicKey, slot: Slot) {
        let Some(entry) = self.rings.get_mut(slot as usize) else { return };
        let Some(ring) = entry else { return };
        ring.users = ring.users.saturating_sub(1);
        if ring.users == 0 {
            *entry = None;
            self.slots.remove(key);
            self.free.push(slot);
        }
    }

    fn get(&self, slot: Slot) -> Option<&Ring<Vec<u8>>> {
        self.rings.get(slot as usize)?.as_ref()
    }

    fn get_mut(&mut self, slot: Slot) -> Option<&mut Ring<Vec<u8>>> {
        self.rings.get_mut(slot as usize)?.as_mut()
    }
}

#[derive(Debug)]
enum Entity {
    Participant {
        domain: i16,
    },
    Topic {
        participant: EntityRef,
        key: TopicKey,
        /// In [`TopicSlab`], once attached.
        slot: Slot,
    },
    Group {
        participant: EntityRef,
    },
    Writer {
        key: TopicKey,
        slot: Slot,
    },
    Reader {
        key: TopicKey,
        cursor: u64,
        slot: Slot,
    },
    // Boxed so every entity stays small (requesters are rare, participants and endpoints are not).
    #[allow(clippy::box_collection)]
    Requester {
        key: TopicKey,
        replies: Box<VecDeque<(RequestId, Vec<u8>)>>,
        sent: u16,
    },
    Replier {
        key: TopicKey,
        cursor: u64,
    },
}

/// The CED middleware.
pub struct Ced {
    profiles: Arc<dyn ProfileSource>,
    default_domain: i16,
    ring_size: usize,
    topics: TopicSlab,
    /// Sample buffers to reuse: a write or a take costs no allocation once warm.
    spare: BufPool,
    services: HashMap<TopicKey, Ring<PendingRequest>>,
    entities: HashMap<EntityRef, Entity>,
    /// Entities per client (see [`EntityCounts`]).
    owned: EntityCounts,
    forced_drops: u64,
}

impl std::fmt::Debug for Ced {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Ced")
            .field("topics", &self.topics.len())
            .field("services", &self.services.len())
            .field("entities", &self.entities.len())
            .finish()
    }
}

fn invalid(msg: impl Into<String>) -> MiddlewareError {
    MiddlewareError::InvalidDescription(msg.into())
}

/// The identity CED gives a request: the requester (client key, object id) in the GUID and the XRCE request
/// id in the sequence number, so a reply finds its way back without a table.
fn request_identity(requester: EntityRef, request_id: RequestId, counter: u16) -> SampleIdentity {
    let mut prefix = [0u8; 12];
    if let Some(p) = prefix.get_mut(..4) {
        p.copy_from_slice(&requester.client.0);
    }
    if let Some(p) = prefix.get_mut(4..6) {
        p.copy_from_slice(&requester.id.0);
    }
    SampleIdentity {
        writer_guid: Guid { prefix, entity_key: [0, 0, 0], entity_kind: ObjectKind::Requester as u8 },
        sequence_number: SequenceNumber { high: 0, low: (u32::from(counter) << 16) | u32::from(request_id.0) },
    }
}

fn requester_of(identity: &SampleIdentity) -> (EntityRef, RequestId) {
    let p = identity.writer_guid.prefix;
    let client = ClientKey([p[0], p[1], p[2], p[3]]);
    let id = ObjectId([p[4], p[5]]);
    (EntityRef::new(client, id), RequestId((identity.sequence_number.low & 0xFFFF) as u16))
}

impl Ced {
    /// A CED with an empty registry, resolving references and XML with `profiles`.
    pub fn new(profiles: Arc<dyn ProfileSource>) -> Self {
        Self {
            profiles,
            default_domain: 0,
            ring_size: DEFAULT_RING_SIZE,
            topics: TopicSlab::default(),
            spare: BufPool::with_max_free(SAMPLE_BUFFERS_KEPT),
            services: HashMap::new(),
            entities: HashMap::new(),
            owned: EntityCounts::default(),
            forced_drops: 0,
        }
    }

    /// Sample buffers created so far; constant once warm (writes and takes reuse buffers).
    pub fn sample_buffers_created(&self) -> u64 {
        self.spare.created()
    }

    /// Samples a reliable reader had not taken but that went anyway ([`MAX_BACKLOG`] exceeded).
    pub fn forced_drops(&self) -> u64 {
        self.forced_drops
    }

    /// Samples of topic `slot` its slowest reliable reader has not taken, if it has one.
    fn backlog(&self, slot: Slot) -> Option<u64> {
        let pin = self.pin(slot)?;
        Some(self.topics.get(slot).map_or(0, |r| r.next_seq).saturating_sub(pin))
    }

    /// The oldest sequence number a pinning (reliable) reader of the topic in `slot` has not taken.
    fn pin(&self, slot: Slot) -> Option<u64> {
        self.topics.get(slot)?.pinned.iter().map(|(_, cursor)| *cursor).min()
    }

    fn unpin(&mut self, reader: EntityRef) {
        if let Some(&Entity::Reader { slot, .. }) = self.entities.get(&reader) {
            if let Some(ring) = self.topics.get_mut(slot) {
                ring.pinned.retain(|(r, _)| *r != reader);
            }
        }
    }

    /// Domain used for participants created with domain 255 (eProsima: `XRCE_DOMAIN_ID_OVERRIDE`).
    pub fn set_default_domain(&mut self, domain: i16) {
        self.default_domain = domain;
    }

    /// Samples kept per topic (at least 1).
    pub fn set_ring_size(&mut self, size: usize) {
        self.ring_size = size.max(1);
    }

    fn participant_domain(&self, participant: EntityRef) -> Result<i16, MiddlewareError> {
        match self.entities.get(&participant) {
            Some(Entity::Participant { domain }) => Ok(*domain),
            _ => Err(MiddlewareError::UnknownReference(format!("participant {participant:?}"))),
        }
    }

    /// Domain of a group (publisher/subscriber) and the participant above it.
    fn group_participant(&self, group: EntityRef) -> Result<(EntityRef, i16), MiddlewareError> {
        match self.entities.get(&group) {
            Some(Entity::Group { participant }) => Ok((*participant, self.participant_domain(*participant)?)),
            _ => Err(MiddlewareError::UnknownReference(format!("group {group:?}"))),
        }
    }

    fn attach_service(&mut self, key: &mut TopicKey) -> Result<(), MiddlewareError> {
        if let Some((shared, _)) = self.services.get_key_value(key) {
            *key = shared.clone();
        }
        if !self.services.contains_key(key) && self.services.len() >= MAX_TOPICS {
            return Err(MiddlewareError::Resources("CED service registry full".into()));
        }
        self.services.entry(key.clone()).or_default().users += 1;
        Ok(())
    }

    fn detach<T>(map: &mut HashMap<TopicKey, Ring<T>>, key: &TopicKey) {
        if let Some(ring) = map.get_mut(key) {
            ring.users = ring.users.saturating_sub(1);
            if ring.users == 0 {
                map.remove(key);
            }
        }
    }

    /// The registry key an endpoint attaches to.
    fn endpoint_topic(
        &self,
        entity: EntityRef,
        participant: EntityRef,
        domain: i16,
        topic: &TopicRef,
    ) -> Result<TopicKey, MiddlewareError> {
        match topic {
            TopicRef::Name { name, .. } => Ok((domain, Arc::from(name.as_str()))),
            TopicRef::Object(id) => {
                let topic_ref = EntityRef::new(entity.client, id.with_kind(ObjectKind::Topic));
                match self.entities.get(&topic_ref) {
                    Some(Entity::Topic { participant: p, key, .. }) if *p == participant => Ok(key.clone()),
                    Some(Entity::Topic { .. }) => {
                        Err(invalid(format!("topic {topic_ref:?} belongs to another participant")))
                    }
                    _ => Err(MiddlewareError::UnknownReference(format!("topic {topic_ref:?}"))),
                }
            }
        }
    }

    fn build(&self, creation: &Creation<'_>) -> Result<Entity, MiddlewareError> {
        let description =
            describe(&*self.profiles, creation.variant, creation.endian, self.default_domain).map_err(invalid)?;
        let entity = creation.entity;
        let parent = creation.parent;
        let need_parent = || parent.ok_or_else(|| invalid("missing parent"));
        Ok(match (entity.kind(), description) {
            (ObjectKind::Participant, Description::Participant { domain_id, .. }) => {
                Entity::Participant { domain: domain_id }
            }
            (ObjectKind::Topic, Description::Topic { name, .. }) => {
                let participant = need_parent()?;
                Entity::Topic { participant, key: (self.participant_domain(participant)?, Arc::from(name)), slot: 0 }
            }
            (ObjectKind::Publisher | ObjectKind::Subscriber, _) => {
                let participant = need_parent()?;
                self.participant_domain(participant)?;
                Entity::Group { participant }
            }
            (ObjectKind::DataWriter, Description::Endpoint { topic }) => {
                let (participant, domain) = self.group_participant(need_parent()?)?;
                Entity::Writer { key: self.endpoint_topic(entity, participant, domain, &topic)?, slot: 0 }
            }
            (ObjectKind::DataReader, Description::Endpoint { topic }) => {
                let (participant, domain) = self.group_participant(need_parent()?)?;
                Entity::Reader { key: self.endpoint_topic(entity, participant, domain, &topic)?, cursor: 0, slot: 0 }
            }
            (ObjectKind::Requester, Description::Service { service_name, .. }) => {
                let domain = self.participant_domain(need_parent()?)?;
                Entity::Requester { key: (domain, Arc::from(service_name)), replies: Box::default(), sent: 0 }
            }
            (ObjectKind::Replier, Description::Service { service_name, .. }) => {
                let domain = self.participant_domain(need_parent()?)?;
                Entity::Replier { key: (domain, Arc::from(service_name)), cursor: 0 }
            }
            (kind, d) => return Err(invalid(format!("{kind:?} cannot be described as {d:?}"))),
        })
    }

    fn entity_mut(&mut self, entity: EntityRef) -> Result<&mut Entity, MiddlewareError> {
        self.entities.get_mut(&entity).ok_or_else(|| MiddlewareError::UnknownReference(format!("{entity:?}")))
    }
}

impl Middleware for Ced {
    fn create(&mut self, creation: &Creation<'_>) -> Result<(), MiddlewareError> {
        let mut built = self.build(creation)?;
        match &mut built {
            Entity::Topic { key, slot, .. } | Entity::Writer { key, slot } => *slot = self.topics.attach(key)?,
            Entity::Reader { key, cursor, slot } => {
                *slot = self.topics.attach(key)?;
                // A new reader gets what is still in the ring, oldest first.
                *cursor = self.topics.get(*slot).and_then(|r| r.items.front()).map_or(0, |(s, _)| *s);
            }
            Entity::Requester { key, .. } => self.attach_service(key)?,
            Entity::Replier { key, cursor } => {
                self.attach_service(key)?;
                // Requests written before the replier existed are not its business.
                *cursor = self.services.get(key).map_or(0, |r| r.next_seq);
            }
            Entity::Participant { .. } | Entity::Group { .. } => {}
        }
        match self.entities.insert(creation.entity, built) {
            Some(old) => self.release(old),
            None => self.owned.added(creation.entity.client),
        }
        Ok(())
    }

    fn matches(&self, creation: &Creation<'_>) -> bool {
        let Ok(new) = self.build(creation) else { return false };
        match (self.entities.get(&creation.entity), new) {
            (Some(Entity::Participant { domain: a }), Entity::Participant { domain: b }) => *a == b,
            (Some(Entity::Topic { key: a, .. }), Entity::Topic { key: b, .. })
            | (Some(Entity::Writer { key: a, .. }), Entity::Writer { key: b, .. })
            | (Some(Entity::Reader { key: a, .. }), Entity::Reader { key: b, .. })
            | (Some(Entity::Requester { key: a, .. }), Entity::Requester { key: b, .. })
            | (Some(Entity::Replier { key: a, .. }), Entity::Replier { key: b, .. }) => *a == b,
            (Some(Entity::Group { participant: a }), Entity::Group { participant: b }) => *a == b,
            _ => false,
        }
    }

    fn delete(&mut self, entity: EntityRef) -> Result<(), MiddlewareError> {
        self.unpin(entity);
        let old =
            self.entities.remove(&entity).ok_or_else(|| MiddlewareError::UnknownReference(format!("{entity:?}")))?;
        self.owned.removed(entity.client);
        self.release(old);
        Ok(())
    }

    fn delete_client(&mut self, client: ClientKey) {
        if !self.owned.holds_any(client) {
            return;
        }
        let mine: Vec<EntityRef> = self.entities.keys().filter(|e| e.client == client).copied().collect();
        for e in mine {
            self.unpin(e);
            if let Some(old) = self.entities.remove(&e) {
                self.owned.removed(client);
                self.release(old);
            }
        }
    }

    fn write_data(&mut self, writer: EntityRef, data: &[u8], _now: Instant) -> Result<WriteOutcome, MiddlewareError> {
        let &mut Entity::Writer { slot, .. } = self.entity_mut(writer)? else {
            return Err(MiddlewareError::Unsupported(format!("{writer:?} is not a datawriter")));
        };
        let capacity = self.ring_size;
        let pin = self.pin(slot);
        if let Some(ring) = self.topics.get_mut(slot) {
            let buf = self.spare.copy_fitted(data);
            let spare = &mut self.spare;
            if ring.push(buf, capacity, pin, |old| spare.put(old)) {
                self.forced_drops = self.forced_drops.saturating_add(1);
                tracing::warn!(
                    ?writer,
                    "CED: backlog bound reached, a sample a reliable reader had not taken was dropped"
                );
            }
        }
        Ok(WriteOutcome::Accepted)
    }

    fn write_request(
        &mut self,
        requester: EntityRef,
        request_id: RequestId,
        data: &[u8],
        _now: Instant,
    ) -> Result<WriteOutcome, MiddlewareError> {
        let Entity::Requester { key, sent, .. } = self.entity_mut(requester)? else {
            return Err(MiddlewareError::Unsupported(format!("{requester:?} is not a requester")));
        };
        *sent = sent.wrapping_add(1);
        let identity = request_identity(requester, request_id, *sent);
        let key = key.clone();
        let capacity = self.ring_size;
        if let Some(ring) = self.services.get_mut(&key) {
            ring.push((identity, Arc::from(data)), capacity, None, drop);
        }
        Ok(WriteOutcome::Accepted)
    }

    fn write_reply(
        &mut self,
        replier: EntityRef,
        identity: &SampleIdentity,
        data: &[u8],
        _now: Instant,
    ) -> Result<WriteOutcome, MiddlewareError> {
        let Entity::Replier { key: service, .. } = self.entity_mut(replier)? else {
            return Err(MiddlewareError::Unsupported(format!("{replier:?} is not a replier")));
        };
        let service = service.clone();
        let (requester, request_id) = requester_of(identity);
        match self.entities.get_mut(&requester) {
            Some(Entity::Requester { key, replies, .. }) if *key == service => {
                if replies.len() >= MAX_PENDING_REPLIES {
                    replies.pop_front();
                }
                replies.push_back((request_id, data.to_vec()));
            }
            // The requester is gone, or the identity was not one of ours: the reply has nowhere to go.
            _ => tracing::debug!(?replier, ?requester, "CED: reply for an unknown requester dropped"),
        }
        Ok(WriteOutcome::Accepted)
    }

    fn start_reading(&mut self, reader: EntityRef) -> Result<(), MiddlewareError> {
        match self.entities.get(&reader) {
            Some(Entity::Reader { .. } | Entity::Requester { .. } | Entity::Replier { .. }) => Ok(()),
            Some(_) => Err(MiddlewareError::Unsupported(format!("{reader:?} cannot read"))),
            None => Err(MiddlewareError::UnknownReference(format!("{reader:?}"))),
        }
    }

    fn stop_reading(&mut self, reader: EntityRef) {
        self.unpin(reader);
    }

    fn write_credit(&mut self, writer: EntityRef, _now: Instant) -> u32 {
        let Some(&Entity::Writer { slot, .. }) = self.entities.get(&writer) else { return u32::MAX };
        let Some(backlog) = self.backlog(slot) else { return u32::MAX };
        u32::try_from((RELIABLE_BACKLOG as u64).saturating_sub(backlog)).unwrap_or(u32::MAX)
    }

    fn stats(&self) -> super::MiddlewareStats {
        let mut stats = super::MiddlewareStats::default();
        for entity in self.entities.values() {
            match entity {
                Entity::Participant { .. } => stats.participants += 1,
                Entity::Topic { .. } => stats.topics += 1,
                Entity::Writer { slot, .. } if self.backlog(*slot).is_some_and(|b| b >= RELIABLE_BACKLOG as u64) => {
                    stats.writers_without_credit += 1;
                }
                _ => {}
            }
        }
        stats
    }

    fn set_reader_reliable(&mut self, reader: EntityRef, reliable: bool) {
        self.unpin(reader);
        if !reliable {
            return;
        }
        if let Some(&Entity::Reader { slot, cursor, .. }) = self.entities.get(&reader) {
            if let Some(ring) = self.topics.get_mut(slot) {
                ring.pinned.push((reader, cursor));
            }
        }
    }

    fn poll_sample(&mut self, reader: EntityRef, visit: &mut SampleVisitor<'_>) -> Option<bool> {
        let topics = &mut self.topics;
        let services = &self.services;
        match self.entities.get_mut(&reader)? {
            Entity::Reader { cursor, slot, .. } => {
                let (seq, taken) = {
                    let (seq, data) = topics.get(*slot)?.at_or_after(*cursor)?;
                    (*seq, visit(SampleRef::Data(data)))
                };
                if taken {
                    *cursor = seq + 1;
                    if let Some(ring) = topics.get_mut(*slot) {
                        if let Some((_, pinned)) = ring.pinned.iter_mut().find(|(r, _)| *r == reader) {
                            *pinned = seq + 1;
                        }
                    }
                }
                Some(taken)
            }
            Entity::Replier { key, cursor } => {
                let (seq, (identity, data)) = services.get(key)?.at_or_after(*cursor)?;
                let taken = visit(SampleRef::Request { identity: *identity, data });
                if taken {
                    *cursor = seq + 1;
                }
                Some(taken)
            }
            Entity::Requester { replies, .. } => {
                let (request_id, data) = replies.front()?;
                let taken = visit(SampleRef::Reply { request_id: *request_id, data });
                if taken {
                    replies.pop_front();
                }
                Some(taken)
            }
            _ => None,
        }
    }
}

impl Ced {
    fn release(&mut self, old: Entity) {
        match old {
            Entity::Topic { key, slot, .. } | Entity::Writer { key, slot } | Entity::Reader { key, slot, .. } => {
                self.topics.detach(&key, slot);
            }
            Entity::Requester { key, .. } | Entity::Replier { key, .. } => Self::detach(&mut self.services, &key),
            Entity::Participant { .. } | Entity::Group { .. } => {}
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::middleware::describe::FallbackProfiles;
    use xrce_proto::object::{BinaryObject, DataReaderBinary, DataWriterBinary, Representation, TopicBinary};
    use xrce_proto::{Endianness, EntityVariant};

    fn create(ced: &mut Ced, entity: EntityRef, parent: Option<EntityRef>, variant: &EntityVariant<'_>) {
        let creation = Creation { entity, parent, variant, endian: Endianness::Little, now: Instant::now() };
        ced.create(&creation).expect("create");
    }

    /// A CED with one client holding a datawriter and a datareader on one topic.
    fn writer_and_reader() -> (Ced, EntityRef, EntityRef) {
        let mut ced = Ced::new(Arc::new(FallbackProfiles));
        let client = ClientKey([1, 2, 3, 4]);
        let e = |id: u16, kind: ObjectKind| EntityRef::new(client, ObjectId::new(id, kind));
        let (p, t) = (e(1, ObjectKind::Participant), e(1, ObjectKind::Topic));
        let (pu, su) = (e(1, ObjectKind::Publisher), e(1, ObjectKind::Subscriber));
        let (w, r) = (e(1, ObjectKind::DataWriter), e(1, ObjectKind::DataReader));
        let empty = BinaryObject::Raw(&[0, 0]);
        create(&mut ced, p, None, &EntityVariant::participant(Representation::Binary(empty), 0));
        let topic = BinaryObject::Topic(TopicBinary { topic_name: "t", type_reference: None, type_name: Some("T") });
        create(&mut ced, t, Some(p), &EntityVariant::child(ObjectKind::Topic, Representation::Binary(topic), p.id));
        for (g, kind) in [(pu, ObjectKind::Publisher), (su, ObjectKind::Subscriber)] {
            create(&mut ced, g, Some(p), &EntityVariant::child(kind, Representation::Binary(empty), p.id));
        }
        let wb = BinaryObject::DataWriter(DataWriterBinary { topic_id: t.id, qos: None });
        create(&mut ced, w, Some(pu), &EntityVariant::child(ObjectKind::DataWriter, Representation::Binary(wb), pu.id));
        let rb = BinaryObject::DataReader(DataReaderBinary { topic_id: t.id, qos: None });
        create(&mut ced, r, Some(su), &EntityVariant::child(ObjectKind::DataReader, Representation::Binary(rb), su.id));
        (ced, w, r)
    }

    #[test]
    fn sample_buffers_are_reused_once_warm() {
        let (mut ced, w, r) = writer_and_reader();
        // Writes, and samples lent to the core's visitor as it polls them: the ring's buffers are reused.
        let cycle = |ced: &mut Ced, round: usize| {
            assert_eq!(ced.write_data(w, &[round as u8; 24], Instant::now()), Ok(WriteOutcome::Accepted));
            let seen = ced.poll_sample(r, &mut |s| {
                assert_eq!(s, SampleRef::Data(&[round as u8; 24]));
                true
            });
            assert_eq!(seen, Some(true), "a sample");
        };
        for round in 0..2 * DEFAULT_RING_SIZE {
            cycle(&mut ced, round);
        }
        let warm = ced.sample_buffers_created();
        assert!(warm <= DEFAULT_RING_SIZE as u64 + 2, "a ring's worth of buffers: {warm}");
        for round in 0..10 * DEFAULT_RING_SIZE {
            cycle(&mut ced, round);
        }
        assert_eq!(ced.sample_buffers_created(), warm, "no buffer created per sample once warm");
    }

    #[test]
    fn a_topic_slot_is_shared_by_name_and_reused_once_its_last_entity_is_gone() {
        let mut slab = TopicSlab::default();
        let mut a: TopicKey = (0, Arc::from("a"));
        let mut a2: TopicKey = (0, Arc::from("a"));
        let mut b: TopicKey = (1, Arc::from("a"));
        let slot_a = slab.attach(&mut a).expect("a");
        assert_eq!(slab.attach(&mut a2).expect("a again"), slot_a, "same name and domain, same ring");
        assert!(Arc::ptr_eq(&a.1, &a2.1), "the name is shared");
        let slot_b = slab.attach(&mut b).expect("b");
        assert_ne!(slot_b, slot_a, "another domain is another topic");
        if let Some(ring) = slab.get_mut(slot_a) {
            ring.push(vec![1], 16, None, drop);
        }
        slab.detach(&a, slot_a);
        assert!(slab.get(slot_a).is_some_and(|r| r.items.len() == 1), "one user left");
        slab.detach(&a2, slot_a);
        assert!(slab.get(slot_a).is_none() && slab.len() == 1, "gone with its last user");
        let mut c: TopicKey = (0, Arc::from("c"));
        let slot_c = slab.attach(&mut c).expect("c");
        assert_eq!(slot_c, slot_a, "the free slot is reused");
        assert!(slab.get(slot_c).is_some_and(|r| r.items.is_empty() && r.next_seq == 0), "with a fresh ring");
    }

    #[test]
    fn a_sample_the_visitor_leaves_is_lent_again() {
        let (mut ced, w, r) = writer_and_reader();
        for v in [1u8, 2] {
            assert_eq!(ced.write_data(w, &[v], Instant::now()), Ok(WriteOutcome::Accepted));
        }
        assert_eq!(ced.poll_sample(r, &mut |_| false), Some(false), "left in place");
        assert_eq!(ced.take_sample(r), Some(crate::middleware::Sample::Data(vec![1])), "the same sample again");
        assert_eq!(ced.take_sample(r), Some(crate::middleware::Sample::Data(vec![2])));
        assert_eq!(ced.poll_sample(r, &mut |_| true), None, "no more");
    }
}
