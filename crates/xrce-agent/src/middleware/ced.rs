//! CED, "centralized data": routes samples between the clients of this agent, without DDS (spec §15.1).
//!
//! Topics live in a registry keyed by `(domain, topic name)`; each keeps a ring of the last samples
//! ([`DEFAULT_RING_SIZE`], eProsima's 16) and every datareader has its own cursor into it, so a reader created
//! after some writes still gets the samples left in the ring, oldest first. Type names are not compared, as
//! in eProsima. Requesters and repliers meet by `(domain, service name)`: requests go to a ring read by every
//! replier of the service; a reply is routed back to the requester named in the request's sample identity.
//!
//! Unlike eProsima's CED, entities described in XML or by a profile reference work: their names come from
//! the [`ProfileSource`].

use std::collections::{HashMap, VecDeque};
use std::sync::Arc;

use xrce_proto::types::{Guid, SequenceNumber};
use xrce_proto::{ClientKey, ObjectId, ObjectKind, RequestId, SampleIdentity};

use super::describe::{describe, Description, ProfileSource, TopicRef};
use super::{Creation, EntityRef, Middleware, MiddlewareError, Sample};

/// Samples kept per topic and requests per service (eProsima's value).
pub const DEFAULT_RING_SIZE: usize = 16;
/// Replies waiting per requester; older ones are dropped.
pub const MAX_PENDING_REPLIES: usize = 64;
/// Most topics and services the registry holds.
pub const MAX_TOPICS: usize = 4096;

type TopicKey = (i16, String);
/// A request waiting for repliers: its identity and bytes.
type PendingRequest = (SampleIdentity, Arc<[u8]>);

#[derive(Debug, Default)]
struct Ring<T> {
    items: VecDeque<(u64, T)>,
    next_seq: u64,
    users: usize,
}

impl<T> Ring<T> {
    fn push(&mut self, item: T, capacity: usize) {
        if self.items.len() >= capacity {
            self.items.pop_front();
        }
        self.items.push_back((self.next_seq, item));
        self.next_seq += 1;
    }

    /// The item at or after `cursor`, with its sequence number.
    fn at_or_after(&self, cursor: u64) -> Option<&(u64, T)> {
        let oldest = self.items.front()?.0;
        let index = cursor.saturating_sub(oldest);
        self.items.get(usize::try_from(index).ok()?)
    }
}

#[derive(Debug)]
enum Entity {
    Participant { domain: i16 },
    Topic { participant: EntityRef, key: TopicKey },
    Group { participant: EntityRef },
    Writer { key: TopicKey },
    Reader { key: TopicKey, cursor: u64 },
    Requester { key: TopicKey, replies: VecDeque<(RequestId, Vec<u8>)>, sent: u16 },
    Replier { key: TopicKey, cursor: u64 },
}

/// The CED middleware.
pub struct Ced {
    profiles: Arc<dyn ProfileSource>,
    default_domain: i16,
    ring_size: usize,
    topics: HashMap<TopicKey, Ring<Arc<[u8]>>>,
    services: HashMap<TopicKey, Ring<PendingRequest>>,
    entities: HashMap<EntityRef, Entity>,
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
            topics: HashMap::new(),
            services: HashMap::new(),
            entities: HashMap::new(),
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

    fn attach_topic(&mut self, key: &TopicKey) -> Result<(), MiddlewareError> {
        if !self.topics.contains_key(key) && self.topics.len() >= MAX_TOPICS {
            return Err(MiddlewareError::Resources("CED topic registry full".into()));
        }
        self.topics.entry(key.clone()).or_default().users += 1;
        Ok(())
    }

    fn attach_service(&mut self, key: &TopicKey) -> Result<(), MiddlewareError> {
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
            TopicRef::Name { name, .. } => Ok((domain, name.clone())),
            TopicRef::Object(id) => {
                let topic_ref = EntityRef::new(entity.client, id.with_kind(ObjectKind::Topic));
                match self.entities.get(&topic_ref) {
                    Some(Entity::Topic { participant: p, key }) if *p == participant => Ok(key.clone()),
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
                Entity::Topic { participant, key: (self.participant_domain(participant)?, name) }
            }
            (ObjectKind::Publisher | ObjectKind::Subscriber, _) => {
                let participant = need_parent()?;
                self.participant_domain(participant)?;
                Entity::Group { participant }
            }
            (ObjectKind::DataWriter, Description::Endpoint { topic }) => {
                let (participant, domain) = self.group_participant(need_parent()?)?;
                Entity::Writer { key: self.endpoint_topic(entity, participant, domain, &topic)? }
            }
            (ObjectKind::DataReader, Description::Endpoint { topic }) => {
                let (participant, domain) = self.group_participant(need_parent()?)?;
                Entity::Reader { key: self.endpoint_topic(entity, participant, domain, &topic)?, cursor: 0 }
            }
            (ObjectKind::Requester, Description::Service { service_name, .. }) => {
                let domain = self.participant_domain(need_parent()?)?;
                Entity::Requester { key: (domain, service_name), replies: VecDeque::new(), sent: 0 }
            }
            (ObjectKind::Replier, Description::Service { service_name, .. }) => {
                let domain = self.participant_domain(need_parent()?)?;
                Entity::Replier { key: (domain, service_name), cursor: 0 }
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
            Entity::Topic { key, .. } | Entity::Writer { key } => self.attach_topic(key)?,
            Entity::Reader { key, cursor } => {
                self.attach_topic(key)?;
                // A new reader gets what is still in the ring, oldest first.
                *cursor = self.topics.get(key).and_then(|r| r.items.front()).map_or(0, |(s, _)| *s);
            }
            Entity::Requester { key, .. } => self.attach_service(key)?,
            Entity::Replier { key, cursor } => {
                self.attach_service(key)?;
                // Requests written before the replier existed are not its business.
                *cursor = self.services.get(key).map_or(0, |r| r.next_seq);
            }
            Entity::Participant { .. } | Entity::Group { .. } => {}
        }
        if let Some(old) = self.entities.insert(creation.entity, built) {
            self.release(old);
        }
        Ok(())
    }

    fn matches(&self, creation: &Creation<'_>) -> bool {
        let Ok(new) = self.build(creation) else { return false };
        match (self.entities.get(&creation.entity), new) {
            (Some(Entity::Participant { domain: a }), Entity::Participant { domain: b }) => *a == b,
            (Some(Entity::Topic { key: a, .. }), Entity::Topic { key: b, .. })
            | (Some(Entity::Writer { key: a }), Entity::Writer { key: b })
            | (Some(Entity::Reader { key: a, .. }), Entity::Reader { key: b, .. })
            | (Some(Entity::Requester { key: a, .. }), Entity::Requester { key: b, .. })
            | (Some(Entity::Replier { key: a, .. }), Entity::Replier { key: b, .. }) => *a == b,
            (Some(Entity::Group { participant: a }), Entity::Group { participant: b }) => *a == b,
            _ => false,
        }
    }

    fn delete(&mut self, entity: EntityRef) -> Result<(), MiddlewareError> {
        let old =
            self.entities.remove(&entity).ok_or_else(|| MiddlewareError::UnknownReference(format!("{entity:?}")))?;
        self.release(old);
        Ok(())
    }

    fn delete_client(&mut self, client: ClientKey) {
        let mine: Vec<EntityRef> = self.entities.keys().filter(|e| e.client == client).copied().collect();
        for e in mine {
            if let Some(old) = self.entities.remove(&e) {
                self.release(old);
            }
        }
    }

    fn write_data(&mut self, writer: EntityRef, data: &[u8]) -> Result<(), MiddlewareError> {
        let Entity::Writer { key } = self.entity_mut(writer)? else {
            return Err(MiddlewareError::Unsupported(format!("{writer:?} is not a datawriter")));
        };
        let key = key.clone();
        let capacity = self.ring_size;
        if let Some(ring) = self.topics.get_mut(&key) {
            ring.push(Arc::from(data), capacity);
        }
        Ok(())
    }

    fn write_request(
        &mut self,
        requester: EntityRef,
        request_id: RequestId,
        data: &[u8],
    ) -> Result<(), MiddlewareError> {
        let Entity::Requester { key, sent, .. } = self.entity_mut(requester)? else {
            return Err(MiddlewareError::Unsupported(format!("{requester:?} is not a requester")));
        };
        *sent = sent.wrapping_add(1);
        let identity = request_identity(requester, request_id, *sent);
        let key = key.clone();
        let capacity = self.ring_size;
        if let Some(ring) = self.services.get_mut(&key) {
            ring.push((identity, Arc::from(data)), capacity);
        }
        Ok(())
    }

    fn write_reply(
        &mut self,
        replier: EntityRef,
        identity: &SampleIdentity,
        data: &[u8],
    ) -> Result<(), MiddlewareError> {
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
        Ok(())
    }

    fn start_reading(&mut self, reader: EntityRef) -> Result<(), MiddlewareError> {
        match self.entities.get(&reader) {
            Some(Entity::Reader { .. } | Entity::Requester { .. } | Entity::Replier { .. }) => Ok(()),
            Some(_) => Err(MiddlewareError::Unsupported(format!("{reader:?} cannot read"))),
            None => Err(MiddlewareError::UnknownReference(format!("{reader:?}"))),
        }
    }

    fn next_sample_size(&mut self, reader: EntityRef) -> Option<usize> {
        match self.entities.get(&reader)? {
            Entity::Reader { key, cursor } => self.topics.get(key)?.at_or_after(*cursor).map(|(_, d)| d.len()),
            Entity::Replier { key, cursor } => {
                self.services.get(key)?.at_or_after(*cursor).map(|(_, (_, d))| SampleIdentity::SIZE + d.len())
            }
            Entity::Requester { replies, .. } => replies.front().map(|(_, d)| 4 + d.len()),
            _ => None,
        }
    }

    fn take_sample(&mut self, reader: EntityRef) -> Option<Sample> {
        let topics = &self.topics;
        let services = &self.services;
        match self.entities.get_mut(&reader)? {
            Entity::Reader { key, cursor } => {
                let (seq, data) = topics.get(key)?.at_or_after(*cursor)?;
                *cursor = seq + 1;
                Some(Sample::Data(data.to_vec()))
            }
            Entity::Replier { key, cursor } => {
                let (seq, (identity, data)) = services.get(key)?.at_or_after(*cursor)?;
                *cursor = seq + 1;
                Some(Sample::Request { identity: *identity, data: data.to_vec() })
            }
            Entity::Requester { replies, .. } => {
                replies.pop_front().map(|(request_id, data)| Sample::Reply { request_id, data })
            }
            _ => None,
        }
    }
}

impl Ced {
    fn release(&mut self, old: Entity) {
        match old {
            Entity::Topic { key, .. } | Entity::Writer { key } | Entity::Reader { key, .. } => {
                Self::detach(&mut self.topics, &key);
            }
            Entity::Requester { key, .. } | Entity::Replier { key, .. } => Self::detach(&mut self.services, &key),
            Entity::Participant { .. } | Entity::Group { .. } => {}
        }
    }
}
