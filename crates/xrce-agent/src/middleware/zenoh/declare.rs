//! The Zenoh side of each XRCE entity, as rmw_zenoh declares its own: a liveliness token for every node
//! and endpoint; publishers and subscriptions as (advanced) publishers and subscribers, with a cache
//! answering late joiners when transient local; services as queryables; clients as queries. Zenoh calls
//! the callbacks here on its own threads: they only decode and queue ([`Inbox`]).

use std::collections::HashMap;
use std::sync::{Arc, Mutex, PoisonError};
use std::time::{Duration, Instant};

use xrce_proto::types::{Guid, SequenceNumber};
use xrce_proto::{RequestId, SampleIdentity};
use zenoh::key_expr::KeyExpr;
use zenoh::liveliness::LivelinessToken;
use zenoh::query::{ConsolidationMode, Query, QueryTarget, Queryable};
use zenoh::Wait;
use zenoh_ext::{
    AdvancedPublisher, AdvancedPublisherBuilderExt, AdvancedSubscriber, AdvancedSubscriberBuilderExt, CacheConfig,
    HistoryConfig, MissDetectionConfig, RecoveryConfig,
};

use super::attachment::{Attachment, GID_LEN};
use super::inbox::Inbox;
use super::keys::{gid, liveliness_token, topic_keyexpr, EntityKind, NodeIdent, TopicIdent};
use super::qos::{Durability, Reliability};
use super::session::Shell;
use crate::middleware::{MiddlewareError, Sample};

/// The CDR encapsulation (little endian) Zenoh payloads start with; XRCE samples are the bodies
/// (spec §8.4), as the `dds` middleware's bridge adds and strips it.
const CDR_LE: [u8; 4] = [0, 1, 0, 0];

/// Period of the heartbeats a reliable transient local publisher sends so subscribers detect lost samples
/// (rmw_zenoh's).
const MISS_DETECTION_HEARTBEAT: Duration = Duration::from_millis(500);

/// How long a query waits for its replies: as rmw_zenoh, practically forever (actions take long).
const QUERY_TIMEOUT: Duration = Duration::from_secs(365 * 24 * 3600);

/// Requests a replier holds for the XRCE client's replies; beyond, new ones are refused (a client that
/// never replies cannot grow the table without bound).
pub const MAX_PENDING_QUERIES: usize = 4_096;

fn failed(what: &str, e: impl std::fmt::Display) -> MiddlewareError {
    MiddlewareError::Resources(format!("Zenoh {what}: {e}"))
}

fn keyexpr(key: String) -> Result<KeyExpr<'static>, MiddlewareError> {
    KeyExpr::try_from(key).map_err(|e| MiddlewareError::InvalidDescription(format!("key expression: {e}")))
}

/// The token announcing an entity, declared; undeclared when dropped.
pub fn declare_token(shell: &Shell, token: &str) -> Result<LivelinessToken, MiddlewareError> {
    shell.session.liveliness().declare_token(keyexpr(token.to_owned())?).wait().map_err(|e| failed("token", e))
}

/// The CDR body of a payload (its encapsulation dropped).
fn body(payload: &zenoh::bytes::ZBytes) -> Vec<u8> {
    let bytes = payload.to_bytes();
    bytes.get(CDR_LE.len()..).unwrap_or_default().to_vec()
}

/// A payload: the encapsulation, then `data`.
fn payload(data: &[u8]) -> Vec<u8> {
    let mut out = Vec::with_capacity(CDR_LE.len() + data.len());
    out.extend_from_slice(&CDR_LE);
    out.extend_from_slice(data);
    out
}

/// Where an endpoint is declared: the session, its node, its id and its topic or service.
#[derive(Clone, Copy)]
pub struct At<'a> {
    /// The session.
    pub shell: &'a Shell,
    /// The node the endpoint belongs to.
    pub node: &'a NodeIdent,
    /// The endpoint's id.
    pub id: u64,
    /// Its topic or service.
    pub topic: &'a TopicIdent,
}

impl At<'_> {
    fn key(&self) -> Result<KeyExpr<'static>, MiddlewareError> {
        keyexpr(topic_keyexpr(self.node.domain, self.topic))
    }

    /// Declares the endpoint's token (after its Zenoh entity, so whoever sees the token finds the entity).
    fn announce(&self, kind: EntityKind) -> Result<Announced, MiddlewareError> {
        let token = liveliness_token(self.node, self.id, kind, Some(self.topic));
        Ok(Announced { gid: gid(&token), _token: declare_token(self.shell, &token)? })
    }
}

/// An endpoint's announcement: its token (kept alive) and the GID rmw_zenoh derives from it.
struct Announced {
    gid: [u8; GID_LEN],
    _token: LivelinessToken,
}

/// An XRCE datawriter: a ROS publisher.
pub struct Writer {
    publisher: AdvancedPublisher<'static>,
    announced: Announced,
    sequence_number: i64,
}

impl Writer {
    /// Declares the publisher, then its token (so a subscriber that sees the token finds the publisher).
    pub fn declare(at: At<'_>) -> Result<Self, MiddlewareError> {
        let topic = at.topic;
        let mut builder = at.shell.session.declare_publisher(at.key()?).advanced();
        if topic.qos.durability == Durability::TransientLocal {
            builder = builder.cache(CacheConfig::default().max_samples(topic.qos.cache_depth())).publisher_detection();
            if topic.qos.reliability == Reliability::Reliable {
                builder = builder
                    .sample_miss_detection(MissDetectionConfig::default().sporadic_heartbeat(MISS_DETECTION_HEARTBEAT));
            }
        }
        let reliability = match topic.qos.reliability {
            Reliability::Reliable => zenoh::qos::Reliability::Reliable,
            Reliability::BestEffort => zenoh::qos::Reliability::BestEffort,
        };
        // Congestion control stays "drop" (rmw_zenoh blocks keep-all reliable publishers; the core must not).
        let publisher = builder.reliability(reliability).wait().map_err(|e| failed("publisher", e))?;
        let announced = at.announce(EntityKind::Publisher)?;
        Ok(Self { publisher, announced, sequence_number: 0 })
    }

    /// Publishes one sample with rmw_zenoh's attachment.
    pub fn write(&mut self, data: &[u8], source_timestamp: i64) -> Result<(), MiddlewareError> {
        self.sequence_number += 1;
        let attachment =
            Attachment { sequence_number: self.sequence_number, source_timestamp, gid: self.announced.gid };
        self.publisher.put(payload(data)).attachment(attachment.encode().to_vec()).wait().map_err(|e| failed("put", e))
    }
}

/// An XRCE datareader: a ROS subscription.
pub struct Reader {
    _subscriber: AdvancedSubscriber<()>,
    _announced: Announced,
    /// Where its samples wait for the core.
    pub inbox: Inbox,
}

impl Reader {
    /// Declares the subscriber (querying late publishers' caches when transient local), then its token.
    pub fn declare(at: At<'_>, inbox: Inbox) -> Result<Self, MiddlewareError> {
        let topic = at.topic;
        let queue = inbox.clone();
        let mut builder = at
            .shell
            .session
            .declare_subscriber(at.key()?)
            .callback(move |sample| queue.push(Sample::Data(body(sample.payload()))))
            .advanced();
        if topic.qos.durability == Durability::TransientLocal {
            builder = builder
                .subscriber_detection()
                .query_timeout(QUERY_TIMEOUT)
                .history(HistoryConfig::default().detect_late_publishers().max_samples(topic.qos.cache_depth()));
            if topic.qos.reliability == Reliability::Reliable {
                builder = builder.recovery(RecoveryConfig::default().heartbeat());
            }
        }
        let subscriber = builder.wait().map_err(|e| failed("subscriber", e))?;
        let announced = at.announce(EntityKind::Subscription)?;
        Ok(Self { _subscriber: subscriber, _announced: announced, inbox })
    }
}

/// An XRCE requester: a ROS service client, each request a query.
pub struct Requester {
    key: KeyExpr<'static>,
    announced: Announced,
    sequence_number: i64,
    /// Where replies wait for the core.
    pub inbox: Inbox,
}

impl Requester {
    /// Declares its token (a client has no Zenoh entity until it sends).
    pub fn declare(at: At<'_>, inbox: Inbox) -> Result<Self, MiddlewareError> {
        Ok(Self { key: at.key()?, announced: at.announce(EntityKind::Client)?, sequence_number: 0, inbox })
    }

    /// Sends a request to every service server of the key; each reply that carries this request's sequence
    /// number is queued as the reply to XRCE request `request_id`.
    pub fn request(
        &mut self,
        shell: &Shell,
        request_id: RequestId,
        data: &[u8],
        source_timestamp: i64,
    ) -> Result<(), MiddlewareError> {
        self.sequence_number += 1;
        let sequence_number = self.sequence_number;
        let attachment = Attachment { sequence_number, source_timestamp, gid: self.announced.gid };
        let inbox = self.inbox.clone();
        shell
            .session
            .get(self.key.clone())
            .payload(payload(data))
            .attachment(attachment.encode().to_vec())
            .target(QueryTarget::AllComplete)
            .consolidation(ConsolidationMode::None)
            .timeout(QUERY_TIMEOUT)
            .callback(move |reply| {
                let Ok(sample) = reply.result() else { return };
                let answers = sample.attachment().and_then(|a| Attachment::decode(&a.to_bytes()));
                if answers.is_some_and(|a| a.sequence_number == sequence_number) {
                    inbox.push(Sample::Reply { request_id, data: body(sample.payload()) });
                } else {
                    tracing::debug!(key = %sample.key_expr(), "reply without this request's attachment dropped");
                }
            })
            .wait()
            .map_err(|e| failed("query", e))
    }
}

/// Queries a replier holds until the XRCE client replies, by (client GID, sequence number).
type PendingQueries = Arc<Mutex<HashMap<([u8; GID_LEN], i64), Query>>>;

/// An XRCE replier: a ROS service server, a queryable.
pub struct Replier {
    _queryable: Queryable<()>,
    _announced: Announced,
    pending: PendingQueries,
    /// Where requests wait for the core.
    pub inbox: Inbox,
}

impl Replier {
    /// Declares the queryable (complete, as rmw_zenoh's), then its token.
    pub fn declare(at: At<'_>, inbox: Inbox) -> Result<Self, MiddlewareError> {
        let pending = PendingQueries::default();
        let (queue, held) = (inbox.clone(), Arc::clone(&pending));
        let queryable = at
            .shell
            .session
            .declare_queryable(at.key()?)
            .complete(true)
            .callback(move |query| hold_query(query, &held, &queue))
            .wait()
            .map_err(|e| failed("queryable", e))?;
        let announced = at.announce(EntityKind::Service)?;
        Ok(Self { _queryable: queryable, _announced: announced, pending, inbox })
    }

    /// Answers the request `identity` names, with rmw_zenoh's attachment (the request's sequence number and
    /// client GID). A request no longer held (answered, or its replier recreated) is ignored, as rmw_zenoh does.
    pub fn reply(&self, identity: &SampleIdentity, data: &[u8], source_timestamp: i64) -> Result<(), MiddlewareError> {
        let (client, sequence_number) = from_identity(identity);
        let query = self.pending.lock().unwrap_or_else(PoisonError::into_inner).remove(&(client, sequence_number));
        let Some(query) = query else {
            tracing::debug!(sequence_number, "reply to a request not held (answered already, or unknown)");
            return Ok(());
        };
        let attachment = Attachment { sequence_number, source_timestamp, gid: client };
        query
            .reply(query.key_expr().clone(), payload(data))
            .attachment(attachment.encode().to_vec())
            .wait()
            .map_err(|e| failed("reply", e))
        // Dropping the query tells the client no more replies come from here.
    }
}

/// Queues a request for the XRCE replier and keeps its query for the reply (Zenoh's thread).
fn hold_query(query: Query, held: &PendingQueries, inbox: &Inbox) {
    let Some(attachment) = query.attachment().and_then(|a| Attachment::decode(&a.to_bytes())) else {
        tracing::debug!(key = %query.key_expr(), "request without rmw_zenoh's attachment dropped");
        return;
    };
    let data = query.payload().map(body).unwrap_or_default();
    {
        let mut pending = held.lock().unwrap_or_else(PoisonError::into_inner);
        if pending.len() >= MAX_PENDING_QUERIES {
            tracing::warn!(key = %query.key_expr(), "{MAX_PENDING_QUERIES} requests unanswered: request dropped");
            return;
        }
        pending.insert((attachment.gid, attachment.sequence_number), query);
    }
    inbox.push(Sample::Request { identity: to_identity(&attachment.gid, attachment.sequence_number), data });
}

/// A request's identity for the XRCE replier: the client's GID as the writer GUID, the sequence number.
pub fn to_identity(gid: &[u8; GID_LEN], sequence_number: i64) -> SampleIdentity {
    let [p0, p1, p2, p3, p4, p5, p6, p7, p8, p9, p10, p11, k0, k1, k2, kind] = *gid;
    SampleIdentity {
        writer_guid: Guid {
            prefix: [p0, p1, p2, p3, p4, p5, p6, p7, p8, p9, p10, p11],
            entity_key: [k0, k1, k2],
            entity_kind: kind,
        },
        sequence_number: SequenceNumber { high: (sequence_number >> 32) as i32, low: sequence_number as u32 },
    }
}

/// The inverse of [`to_identity`].
pub fn from_identity(identity: &SampleIdentity) -> ([u8; GID_LEN], i64) {
    let g = &identity.writer_guid;
    let [p0, p1, p2, p3, p4, p5, p6, p7, p8, p9, p10, p11] = g.prefix;
    let [k0, k1, k2] = g.entity_key;
    let gid = [p0, p1, p2, p3, p4, p5, p6, p7, p8, p9, p10, p11, k0, k1, k2, g.entity_kind];
    let seq = &identity.sequence_number;
    (gid, (i64::from(seq.high) << 32) | i64::from(seq.low))
}

/// Nanoseconds since the epoch for an attachment written at `now`.
pub fn source_time(shell: &Shell, now: Instant) -> i64 {
    shell.clock.ns_at(now)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_request_identity_carries_the_client_gid_and_sequence_number_back() {
        let gid: [u8; 16] = core::array::from_fn(|i| 0xf0 ^ i as u8);
        for seq in [1, 0x1_0000_0002, i64::MAX] {
            assert_eq!(from_identity(&to_identity(&gid, seq)), (gid, seq));
        }
    }

    #[test]
    fn payloads_carry_the_encapsulation_and_bodies_drop_it() {
        let p = payload(&[9, 8]);
        assert_eq!(p, vec![0, 1, 0, 0, 9, 8]);
        assert_eq!(body(&zenoh::bytes::ZBytes::from(p)), vec![9, 8]);
        assert_eq!(body(&zenoh::bytes::ZBytes::from(vec![0u8, 1])), Vec::<u8>::new());
    }
}
