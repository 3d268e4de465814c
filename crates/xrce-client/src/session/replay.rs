//! What the blocking session creates again when the agent lost the session: the entities and the continuous
//! reads it saw leaving, kept as the submessages sent, and the order to send them in after a re-creation.
//!
//! Watching the outgoing messages (rather than the `buffer_create_*` calls) catches every way of writing a
//! CREATE (XML, reference, binary, raw `WriteAccess`), exactly as the agent received it.

use std::collections::{HashMap, VecDeque};

use crate::stream::seq;
use xrce_proto::message::{RawSubmessage, Submessages};
use xrce_proto::submessage::DataDeliveryControl;
use xrce_proto::view::{mark_reuse, submessage_id, SubmessageId};
use xrce_proto::{MessageHeader, ObjectId, ObjectVariant, StreamId, StreamKind, Submessage};

/// Largest reassembled submessage kept (the client never sends more; a bound all the same).
const MAX_REASSEMBLED: usize = 1 << 20;

/// A CREATE or READ_DATA as sent.
#[derive(Debug, Clone)]
struct Sent {
    object: ObjectId,
    parent: Option<ObjectId>,
    stream: StreamId,
    /// The whole submessage, header included.
    bytes: Vec<u8>,
}

/// A submessage to write (header included) after a re-creation, and the stream it goes on.
#[derive(Debug)]
pub(super) struct Item {
    pub(super) stream: StreamId,
    pub(super) bytes: Vec<u8>,
    /// Taken from the unacknowledged output (not a recorded creation or read).
    pub(super) taken: bool,
}

/// The entities and reads seen leaving, and what is still to be written after a re-creation.
#[derive(Debug, Default)]
pub(super) struct Replay {
    entities: Vec<Sent>,
    reads: Vec<Sent>,
    /// Last sequence number seen per reliable stream (retransmissions are not read twice).
    last_seq: HashMap<u8, u16>,
    /// FRAGMENT payloads being reassembled, per stream.
    fragments: HashMap<u8, Vec<u8>>,
    pub(super) pending: VecDeque<Item>,
}

impl Replay {
    /// Forgets everything (the application created or deleted the session itself).
    pub(super) fn clear(&mut self) {
        *self = Self::default();
    }

    /// Entities recorded (for tests and diagnostics).
    pub(super) fn entity_count(&self) -> usize {
        self.entities.len()
    }

    /// Reads one outgoing message.
    pub(super) fn observe(&mut self, msg: &[u8]) {
        let Ok((header, hs)) = MessageHeader::decode(msg) else { return };
        let stream = header.stream_id;
        match stream.kind() {
            StreamKind::None => return,
            StreamKind::Reliable => {
                let last = self.last_seq.get(&stream.0).copied();
                if last.is_some_and(|l| !seq::lt(l, header.sequence_nr)) {
                    return;
                }
                self.last_seq.insert(stream.0, header.sequence_nr);
            }
            StreamKind::BestEffort => {}
        }
        for raw in Submessages::new(msg, hs) {
            let Ok(raw) = raw else { return };
            if let Some(last) = raw.fragment_last() {
                let buf = self.fragments.entry(stream.0).or_default();
                buf.extend_from_slice(raw.payload());
                if buf.len() > MAX_REASSEMBLED {
                    buf.clear();
                }
                if last {
                    let whole = std::mem::take(buf);
                    for inner in Submessages::new(&whole, 0).map_while(Result::ok) {
                        self.submessage(stream, &inner);
                    }
                }
            } else {
                self.submessage(stream, &raw);
            }
        }
    }

    fn submessage(&mut self, stream: StreamId, raw: &RawSubmessage<'_>) {
        if !matches!(raw.id(), Some(SubmessageId::Create | SubmessageId::Delete | SubmessageId::ReadData)) {
            return;
        }
        let Ok(sub) = raw.decode() else { return };
        let bytes = || raw.bytes().to_vec();
        match sub {
            Submessage::Create(c) => {
                let object = c.request.object_id;
                let parent = match (&c.variant, object.kind().parent()) {
                    (ObjectVariant::Entity(e), Some(kind)) => e.parent().map(|p| p.with_kind(kind)),
                    _ => None,
                };
                let sent = Sent { object, parent, stream, bytes: bytes() };
                match self.entities.iter_mut().find(|e| e.object == object) {
                    Some(e) => *e = sent,
                    None => self.entities.push(sent),
                }
            }
            Submessage::Delete(d) if d.object_id == ObjectId::CLIENT => {
                self.entities.clear();
                self.reads.clear();
            }
            Submessage::Delete(d) => self.forget(d.object_id),
            Submessage::ReadData(r) => {
                let reader = r.request.object_id;
                self.reads.retain(|s| s.object != reader);
                let continuous = r.spec.delivery_control.is_some_and(|c: DataDeliveryControl| {
                    c.max_samples == DataDeliveryControl::UNLIMITED && r.spec.preferred_stream_id != 0
                });
                if continuous {
                    self.reads.push(Sent { object: reader, parent: None, stream, bytes: bytes() });
                }
            }
            _ => {}
        }
    }

    /// Forgets `object` and everything created under it, as the agent deletes them.
    fn forget(&mut self, object: ObjectId) {
        let mut gone = vec![object];
        while let Some(id) = gone.pop() {
            self.reads.retain(|s| s.object != id);
            let (children, kept): (Vec<Sent>, Vec<Sent>) =
                self.entities.drain(..).partition(|e| e.object == id || e.parent == Some(id));
            self.entities = kept;
            gone.extend(children.iter().filter(|c| c.object != id).map(|c| c.object));
        }
    }

    /// After a re-creation: the entity creations (with REUSE, so an agent that kept them answers OK_MATCHED and
    /// keeps them), then the reads, then the unacknowledged submessages `taken` from the streams, then whatever
    /// an interrupted replay still had to give back.
    pub(super) fn start(&mut self, taken: Vec<Item>) {
        self.last_seq.clear();
        self.fragments.clear();
        let leftover: Vec<Item> = self.pending.drain(..).filter(|i| i.taken).collect();
        for e in &self.entities {
            let mut bytes = e.bytes.clone();
            mark_reuse(&mut bytes);
            self.pending.push_back(Item { stream: e.stream, bytes, taken: false });
        }
        for r in &self.reads {
            self.pending.push_back(Item { stream: r.stream, bytes: r.bytes.clone(), taken: false });
        }
        self.pending.extend(taken);
        self.pending.extend(leftover);
    }
}

/// The submessages of the unacknowledged messages of `stream` (as [`SessionCore::take_reliable_output`] gives
/// them), fragmented ones reassembled, without the CREATEs and READ_DATAs: the replay sends those already, in
/// their latest form; sent again after it, an unacknowledged CREATE with REPLACE would replace the entity just
/// re-created (and drop a reader's read).
///
/// [`SessionCore::take_reliable_output`]: super::SessionCore::take_reliable_output
#[derive(Debug, Default)]
pub(super) struct Unacked {
    fragments: Vec<u8>,
    pub(super) items: Vec<Item>,
}

impl Unacked {
    /// One taken message (its bytes after the header).
    pub(super) fn message(&mut self, stream: StreamId, body: &[u8]) {
        for raw in Submessages::new(body, 0).map_while(Result::ok) {
            if let Some(last) = raw.fragment_last() {
                self.fragments.extend_from_slice(raw.payload());
                if last {
                    let whole = std::mem::take(&mut self.fragments);
                    self.keep(stream, &whole);
                }
            } else {
                self.keep(stream, raw.bytes());
            }
        }
    }

    fn keep(&mut self, stream: StreamId, submessage: &[u8]) {
        if !submessage.is_empty()
            && !matches!(submessage_id(submessage), Some(SubmessageId::Create | SubmessageId::ReadData))
        {
            self.items.push(Item { stream, bytes: submessage.to_vec(), taken: true });
        }
    }
}
