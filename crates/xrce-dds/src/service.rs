//! Request/reply (eProsima's requester and replier entities, spec §8.3) over two DDS topics.
//!
//! A requester is a writer on the request topic and a reader on the reply topic; a replier the reverse.
//! Replies carry the *related sample identity* (the request's writer GUID and sequence number) as inline
//! QoS, which is how Fast DDS (and ROS 2 services over Fast DDS) correlate them. RustDDS 0.15.1 writes it
//! under both parameter ids Fast DDS uses (PID 0x800f, Fast DDS ≤ 2.10, and 0x0083, the DDS-RPC value Fast
//! DDS switched to in 2023) and reads either.
//!
//! A requester keeps only replies whose related writer GUID is its own request writer (as eProsima's agent
//! does) or its reply reader (rmw_fastrtps services relate replies to the client's reply reader when the
//! request names it, and rmw_fastrtps clients accept both), and maps the related sequence number back to the
//! XRCE request id of the WRITE_DATA.

use std::collections::BTreeMap;
use std::sync::{Arc, Mutex};

use crate::engine::{Participant, RawReader, RawWriter};
use crate::error::DdsError;
use crate::qos::EndpointQos;
use crate::reader::{SampleIdentity, SampleQueue};
use crate::shared::lock;

/// Requests awaiting a reply, per requester; beyond this the oldest is forgotten (its late reply is
/// dropped), so a replier that never answers cannot grow the table without bound.
pub const MAX_PENDING_REQUESTS: usize = 4_096;

/// What an XRCE requester or replier describes (binary representation, or XML/reference resolved).
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub struct ServiceDescription {
    /// Service name.
    pub service_name: String,
    /// Request type name.
    pub request_type: String,
    /// Reply type name.
    pub reply_type: String,
    /// Request topic; `None` → `<service_name>_Request`.
    pub request_topic_name: Option<String>,
    /// Reply topic; `None` → `<service_name>_Reply`.
    pub reply_topic_name: Option<String>,
}

impl ServiceDescription {
    /// The request topic name. eProsima's C client always sends both names; when absent we use Fast DDS'
    /// convention (`<service>_Request`, as Fast DDS' own RPC service implementation names it).
    pub fn request_topic(&self) -> String {
        self.request_topic_name.clone().unwrap_or_else(|| format!("{}_Request", self.service_name))
    }

    /// The reply topic name (`<service>_Reply` when absent).
    pub fn reply_topic(&self) -> String {
        self.reply_topic_name.clone().unwrap_or_else(|| format!("{}_Reply", self.service_name))
    }
}

/// Sequence number of a request → XRCE request id.
#[derive(Default)]
pub(crate) struct Pending {
    map: BTreeMap<i64, u32>,
}

/// A requester: writes requests, receives the replies to them.
pub struct Requester {
    writer: RawWriter,
    reader: RawReader,
    pending: Arc<Mutex<Pending>>,
}

impl std::fmt::Debug for Requester {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Requester").field("writer", &self.writer).field("reader", &self.reader).finish()
    }
}

impl Requester {
    /// Creates the request writer and the reply reader. eProsima forces the reply reader reliable; so do we.
    pub fn new(participant: &Participant, desc: &ServiceDescription, qos: &EndpointQos) -> Result<Self, DdsError> {
        let req_topic = participant.topic(&desc.request_topic(), &desc.request_type, false)?;
        let rep_topic = participant.topic(&desc.reply_topic(), &desc.reply_type, false)?;
        let writer = participant.create_writer(&req_topic, qos)?;
        let own = writer.guid();
        // Known only once the reader exists; no reply can arrive before a request, written after that.
        let reader_guid: Arc<std::sync::OnceLock<[u8; 16]>> = Arc::new(std::sync::OnceLock::new());
        let own_reader = Arc::clone(&reader_guid);
        let pending = Arc::new(Mutex::new(Pending::default()));
        let p = Arc::clone(&pending);
        let filter = Box::new(move |mut s: crate::ReceivedSample| {
            let related = s.related_identity?;
            if related.writer_guid != own && own_reader.get() != Some(&related.writer_guid) {
                return None; // a reply to another requester on the same topic
            }
            let id = lock(&p).map.remove(&related.sequence_number)?;
            s.request_id = Some(id);
            Some(s)
        });
        let reply_qos = EndpointQos { reliability: crate::Reliability::Reliable, ..qos.clone() };
        let reader = participant.create_reader_filtered(&rep_topic, &reply_qos, Some(filter))?;
        // Cannot fail: set only here.
        let _ = reader_guid.set(reader.guid());
        Ok(Self { writer, reader, pending })
    }

    /// Writes a request whose body is `body`, remembering `request_id` (the XRCE WRITE_DATA's) for its
    /// reply. The pending table is locked across the write so a very fast reply cannot overtake the
    /// bookkeeping.
    pub fn write_request(&self, request_id: u32, body: &[u8]) -> Result<SampleIdentity, DdsError> {
        let mut pending = lock(&self.pending);
        let id = self.writer.write(body)?;
        if pending.map.len() >= MAX_PENDING_REQUESTS {
            pending.map.pop_first();
        }
        pending.map.insert(id.sequence_number, request_id);
        Ok(id)
    }

    /// Replies to this requester's requests, each with [`ReceivedSample::request_id`](crate::ReceivedSample)
    /// set.
    pub fn replies(&self) -> &SampleQueue {
        self.reader.queue()
    }

    /// GUID of the request writer (the `writer_guid` repliers relate their replies to).
    pub fn request_writer_guid(&self) -> [u8; 16] {
        self.writer.guid()
    }

    /// GUID of the reply reader.
    pub fn reply_reader_guid(&self) -> [u8; 16] {
        self.reader.guid()
    }

    /// Matched repliers (readers of the request topic).
    pub fn matched_repliers(&self) -> usize {
        self.writer.matched_readers()
    }

    /// Repliers (request readers) already discovered that the request writer has not matched yet; see
    /// [`RawWriter::unmatched_known_readers`].
    pub fn unmatched_known_repliers(&self) -> usize {
        self.writer.unmatched_known_readers()
    }

    /// Of those, the ones whose participant is still in discovery with the requester's participant; see
    /// [`RawWriter::unmatched_readers_in_discovery`].
    pub fn repliers_in_discovery(&self) -> usize {
        self.writer.unmatched_readers_in_discovery()
    }
}

/// A replier: receives requests with their identity, writes replies related to them.
pub struct Replier {
    reader: RawReader,
    writer: RawWriter,
}

impl std::fmt::Debug for Replier {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Replier").field("reader", &self.reader).field("writer", &self.writer).finish()
    }
}

impl Replier {
    /// Creates the request reader (forced reliable, as eProsima does) and the reply writer, which is
    /// transient-local with a history of one sample as in eProsima's agent (Fast DDS' default writer QoS):
    /// a requester with a transient-local reply reader matches it, and a late one is sent at most one old
    /// reply (which it drops, its GUID being new). RustDDS never evicts a reply a reliable reader has not
    /// acknowledged, so keep-last 1 loses nothing.
    pub fn new(participant: &Participant, desc: &ServiceDescription, qos: &EndpointQos) -> Result<Self, DdsError> {
        let req_topic = participant.topic(&desc.request_topic(), &desc.request_type, false)?;
        let rep_topic = participant.topic(&desc.reply_topic(), &desc.reply_type, false)?;
        let request_qos = EndpointQos { reliability: crate::Reliability::Reliable, ..qos.clone() };
        let reader = participant.create_reader(&req_topic, &request_qos)?;
        let writer = participant.create_writer(&rep_topic, &Self::reply_qos(qos))?;
        Ok(Self { reader, writer })
    }

    /// Why a first reply should wait, as a count (0: none): requesters' reply readers already discovered that
    /// the reply writer has not matched yet, and peers whose discovery with the writer's participant is
    /// still under way (see [`RawWriter::unmatched_known_readers`], [`RawWriter::participant_in_discovery`]).
    /// A reply written before its requester's reader matched is lost: the reader is volatile.
    pub fn unmatched_known_requesters(&self) -> usize {
        self.writer.unmatched_known_readers() + self.writer.participant_in_discovery()
    }

    /// Requesters' reply readers already discovered and not matched yet whose participant is still in
    /// discovery with the replier's participant; see [`RawWriter::unmatched_readers_in_discovery`].
    pub fn requesters_in_discovery(&self) -> usize {
        self.writer.unmatched_readers_in_discovery()
    }

    /// QoS of the reply writer for a replier described with `qos`.
    pub fn reply_qos(qos: &EndpointQos) -> EndpointQos {
        EndpointQos {
            durability: crate::Durability::TransientLocal,
            history: crate::History::KeepLast(1),
            ..qos.clone()
        }
    }

    /// Incoming requests; answer each with its [`ReceivedSample::identity`](crate::ReceivedSample).
    pub fn requests(&self) -> &SampleQueue {
        self.reader.queue()
    }

    /// Writes the reply to the request identified by `request`.
    pub fn write_reply(&self, request: &SampleIdentity, body: &[u8]) -> Result<SampleIdentity, DdsError> {
        self.writer.write_related(body, Some(*request))
    }

    /// GUID of the request reader.
    pub fn request_reader_guid(&self) -> [u8; 16] {
        self.reader.guid()
    }

    /// GUID of the reply writer.
    pub fn reply_writer_guid(&self) -> [u8; 16] {
        self.writer.guid()
    }

    /// Whether the reply writer has matched a reply reader of the participant that wrote `request` (its
    /// requester): a reply written before that is never delivered to a volatile reader (ROS 2 service
    /// clients), and a requester that saw this replier first may already have sent its request.
    pub fn requester_matched(&self, request: &SampleIdentity) -> bool {
        let prefix: [u8; 12] = std::array::from_fn(|i| request.writer_guid.get(i).copied().unwrap_or(0));
        self.writer.matched_participant(&prefix)
    }

    /// Matched requesters (readers of the reply topic).
    pub fn matched_requesters(&self) -> usize {
        self.writer.matched_readers()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Durability, History, Reliability};

    #[test]
    fn reply_writers_are_transient_local_keep_last_one() {
        let q = Replier::reply_qos(&EndpointQos::best_effort(10));
        assert_eq!((q.durability, q.history), (Durability::TransientLocal, History::KeepLast(1)));
        assert_eq!(q.reliability, Reliability::BestEffort, "the description's reliability is kept");
        let q = Replier::reply_qos(&EndpointQos::default());
        assert_eq!(q.reliability, Reliability::Reliable);
    }
}
