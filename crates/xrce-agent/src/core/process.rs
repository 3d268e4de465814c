//! Message processing: routing a datagram to its client and stream, then each submessage to its handler
//! (spec §10.3), and the agent's outgoing traffic per stream.

use std::time::Instant;

use xrce_proto::message::parse;
use xrce_proto::object::{AgentRepresentation, ClientRepresentation};
use xrce_proto::submessage::{
    ActivityInfo, Create, CreationMode, DataFormat, DataPayload, GetInfo, Info, ReadData, StatusAgent, TimestampReply,
};
use xrce_proto::view::{self, RequestHead, SubmessageId};
use xrce_proto::{
    BaseObjectReply, BaseObjectRequest, ClientKey, Endianness, EntityVariant, MessageHeader, ObjectId, ObjectKind,
    ObjectVariant, RawSubmessage, ResultStatus, StatusCode, StreamId, StreamKind, Submessage, XRCE_COOKIE,
};

use super::object::is_entity_kind;
use super::outbox::Class;
use super::read::{ReadRequest, ReadTask};
use super::session::{parse_hard_liveliness, ProxyClient, Resume};
use super::stream::{fragment, InAction, ReliableIn, ReliableOut};
use super::{encode_message, encode_submessage, AgentCore};
use crate::middleware::{Creation, EntityRef, Middleware, SampleRef, WriteOutcome};

use std::fmt::Debug;
use std::hash::Hash;

/// Samples one read task may send per pump on a best-effort stream (reliable streams are bounded by their
/// window).
const MAX_SAMPLES_PER_PUMP: usize = 64;

/// The stream STATUS replies go on: 0x80 for requests from reliable streams, 0x01 otherwise (spec §10.3).
fn reply_stream(input: StreamId) -> StreamId {
    if input.is_reliable() {
        StreamId::BUILTIN_RELIABLE
    } else {
        StreamId::BUILTIN_BEST_EFFORT
    }
}

/// Whether processing of the message continues after a submessage.
#[derive(Debug, Clone, PartialEq, Eq)]
enum Flow {
    Continue,
    Stop,
    /// A write the middleware could not take yet ([`WriteOutcome::WouldBlock`]) on a reliable stream: the
    /// message is held and resumes at this submessage.
    Blocked,
    /// The same inside the message a FRAGMENT completed: it and where in it.
    BlockedIn(Vec<u8>, usize),
}

impl<E, M> AgentCore<E, M>
where
    E: Copy + Eq + Hash + Debug,
    M: Middleware,
{
    /// [`DropLog::admit`](super::droplog::DropLog::admit) for a peer that may be unknown (always warned
    /// about then).
    fn admit_drop_log(&mut self, peer: Option<E>, now: Instant) -> Option<u64> {
        match peer {
            Some(p) => self.drop_log.admit(p, now),
            None => Some(0),
        }
    }

    fn drop_datagram(&mut self) {
        self.stats.datagrams_dropped = self.stats.datagrams_dropped.saturating_add(1);
    }

    pub(super) fn process_datagram(&mut self, from: E, bytes: &[u8], now: Instant) {
        let header = match MessageHeader::decode(bytes) {
            Ok((h, _)) => h,
            Err(e) => {
                if let Some(held_back) = self.drop_log.admit(from, now) {
                    tracing::warn!(peer = ?from, len = bytes.len(), held_back, "dropping message: bad header: {e}");
                }
                self.drop_datagram();
                return;
            }
        };
        if header.session_id == xrce_proto::SESSION_ID_NONE_WITH_KEY
            || header.session_id == xrce_proto::SESSION_ID_NONE_WITHOUT_KEY
        {
            self.out_of_session(from, &header, bytes, now);
            return;
        }
        let key = match header.client_key {
            Some(k) => Some(k),
            None => self.by_endpoint.get(&from).copied(),
        };
        let Some(key) = key.filter(|k| self.clients.contains_key(k)) else {
            self.unknown_client(from, &header, bytes);
            return;
        };
        let Some(client) = self.clients.get_mut(&key) else { return };
        client.last_heard = now;
        client.probes = 0;
        if client.unpinned == Some(super::session::Unpinned::Dead) {
            client.unpinned = None;
            self.pin_readers(key, true);
        }
        let Some(client) = self.clients.get_mut(&key) else { return };
        if header.client_key.is_some() {
            // Keyed sessions: replies follow the client wherever it now sends from.
            client.endpoint = Some(from);
        } else if client.endpoint.is_none() {
            client.endpoint = Some(from);
        }
        let stream = header.stream_id;
        match stream.kind() {
            StreamKind::None => self.process_unreliable(key, bytes, stream, now),
            StreamKind::BestEffort => {
                let Some(client) = self.clients.get_mut(&key) else { return };
                if !client.streams.be_in.contains_key(&stream.0)
                    && client.streams.count() >= self.config.max_streams_per_client
                {
                    tracing::warn!(peer = ?from, client = %key, "dropping message: too many streams");
                    self.drop_datagram();
                    return;
                }
                if client.streams.be_in.get_or_insert_with(stream.0, Default::default).accept(header.sequence_nr) {
                    self.process_unreliable(key, bytes, stream, now);
                } else {
                    tracing::trace!(client = %key, seq = header.sequence_nr, "best-effort: old message dropped");
                    self.drop_datagram();
                }
            }
            StreamKind::Reliable => self.process_reliable(from, key, &header, bytes, now),
        }
    }

    /// A message of stream 0 or a best-effort stream: a write the middleware cannot take is lost, as on the
    /// wire (handled in [`Self::handle_write`]).
    fn process_unreliable(&mut self, key: ClientKey, bytes: &[u8], stream: StreamId, now: Instant) {
        let _ = self.process_message(key, bytes, stream, now, false, Resume::default());
    }

    fn process_reliable(&mut self, from: E, key: ClientKey, header: &MessageHeader, bytes: &[u8], now: Instant) {
        let stream = header.stream_id;
        let window = self.config.reliable_window;
        let max_streams = self.config.max_streams_per_client;
        let max_buffered = self.config.max_buffered_bytes_per_client;
        let Some(client) = self.clients.get_mut(&key) else { return };
        if !client.streams.rel_in.contains_key(&stream.0) && client.streams.count() >= max_streams {
            tracing::warn!(peer = ?from, client = %key, "dropping message: too many streams");
            self.drop_datagram();
            return;
        }
        let room = max_buffered.saturating_sub(client.streams.buffered());
        let input = client.streams.rel_in.get_or_insert_with(stream.0, || ReliableIn::new(window));
        match input.receive(header.sequence_nr, bytes, room) {
            InAction::Process => {
                let resume = if self.write_blocked(key, stream, bytes, now) {
                    Some(Resume::default())
                } else {
                    self.process_held(key, bytes, stream, now, None)
                };
                let Some(input) = self.clients.get_mut(&key).and_then(|c| c.streams.rel_in.get_mut(&stream.0)) else {
                    return;
                };
                match resume {
                    Some(resume) => {
                        input.hold(bytes);
                        self.hold_at(key, stream, resume);
                    }
                    None => {
                        input.advance();
                        self.drain_reliable(key, stream, now);
                    }
                }
            }
            InAction::Stored => {}
            InAction::Dropped => self.drop_datagram(),
        }
        self.send_acknack(key, stream);
    }

    /// Processes the stored messages of a reliable input stream that became next in order, stopping at one
    /// whose writes the middleware cannot take yet (back-pressure). Returns whether any was processed.
    fn drain_reliable(&mut self, key: ClientKey, stream: StreamId, now: Instant) -> bool {
        let mut progress = false;
        while let Some(client) = self.clients.get_mut(&key) {
            let Some(msg) = client.streams.rel_in.get_mut(&stream.0).and_then(ReliableIn::pop_ready) else { break };
            let resume = client.resume.remove(&stream.0);
            let blocked = if resume.is_none() && self.write_blocked(key, stream, &msg, now) {
                Some(Resume::default())
            } else {
                self.process_held(key, &msg, stream, now, resume)
            };
            if let Some(resume) = blocked {
                let Some(client) = self.clients.get_mut(&key) else { break };
                if let Some(input) = client.streams.rel_in.get_mut(&stream.0) {
                    input.unpop(msg);
                }
                self.hold_at(key, stream, resume);
                break;
            }
            progress = true;
        }
        progress
    }

    /// Processes a reliable message from `resume` on; where it stopped if a write would block.
    fn process_held(
        &mut self,
        key: ClientKey,
        msg: &[u8],
        stream: StreamId,
        now: Instant,
        resume: Option<Resume>,
    ) -> Option<Resume> {
        self.process_message(key, msg, stream, now, false, resume.unwrap_or_default())
    }

    /// Holds a reliable input stream at `resume` until the middleware can take its writes.
    fn hold_at(&mut self, key: ClientKey, stream: StreamId, resume: Resume) {
        if let Some(client) = self.clients.get_mut(&key) {
            if resume != Resume::default() {
                client.resume.insert(stream.0, resume);
            }
        }
        self.mark_blocked(key, stream);
    }

    /// Tells the middleware whether the reliable readers of a client hold writers back (see
    /// [`Middleware::write_credit`]): not while the client is dead, so a vanished subscriber stalls its
    /// publishers for the dead time at most.
    pub(super) fn pin_readers(&mut self, key: ClientKey, pin: bool) {
        let Some(client) = self.clients.get(&key) else { return };
        let readers: Vec<ObjectId> =
            client.reads.iter().filter(|(_, t)| t.stream.is_reliable()).map(|(id, _)| *id).collect();
        for id in readers {
            self.middleware.set_reader_reliable(EntityRef::new(key, id), pin);
        }
        if !pin {
            tracing::info!(client = %key, "client dead or not acknowledging: its reliable readers no longer hold writers back");
            self.pump_needed = true;
        }
    }

    fn mark_blocked(&mut self, key: ClientKey, stream: StreamId) {
        if !self.blocked.contains(&(key, stream)) {
            self.blocked.push((key, stream));
        }
    }

    /// Whether a reliable message writes to a datawriter whose middleware has no credit for it now (spec:
    /// none; this is our back-pressure, see [`Middleware::write_credit`]). A FRAGMENT completing a message
    /// is judged by the WRITE_DATA at the start of the reassembled message.
    fn write_blocked(&mut self, key: ClientKey, stream: StreamId, msg: &[u8], now: Instant) -> bool {
        let Ok((_, subs)) = parse(msg) else { return false };
        let Some(client) = self.clients.get(&key) else { return false };
        let mut writers: [Option<ObjectId>; 4] = [None; 4];
        let mut n = 0;
        for raw in subs.map_while(Result::ok) {
            let object = match SubmessageId::from_u8(raw.header.id) {
                Some(SubmessageId::WriteData) => view::write_data_object(raw.header.id, raw.payload()),
                Some(SubmessageId::Fragment) if raw.header.flags & xrce_proto::submessage::flag::LAST_FRAGMENT != 0 => {
                    let start = client.streams.rel_in.get(&stream.0).and_then(ReliableIn::reassembly_start);
                    view::write_data_object_in_message(start.unwrap_or_else(|| raw.payload()))
                }
                _ => None,
            };
            let Some(id) = object else { continue };
            // Requesters and repliers too: their request or reply writer has a first-contact gate like a
            // datawriter's.
            if !matches!(id.kind(), ObjectKind::DataWriter | ObjectKind::Requester | ObjectKind::Replier)
                || writers.contains(&Some(id))
            {
                continue;
            }
            if let Some(slot) = writers.get_mut(n) {
                *slot = Some(id);
                n += 1;
            }
        }
        writers.iter().flatten().any(|id| self.middleware.write_credit(EntityRef::new(key, *id), now) == 0)
    }

    /// Retries the reliable input streams held back by [`Self::write_blocked`]; acknowledges what went through.
    pub(super) fn retry_blocked(&mut self, now: Instant) {
        if self.blocked.is_empty() {
            return;
        }
        for (key, stream) in std::mem::take(&mut self.blocked) {
            if self.drain_reliable(key, stream, now) {
                self.send_acknack(key, stream);
            }
        }
    }

    /// Schedules an ACKNACK for a reliable input stream. ACKNACKs are coalesced: the shell's next
    /// [`AgentCore::poll_transmit`] sends one per stream with its latest state, so a batch of messages from a
    /// client costs it one ACKNACK, not one per message.
    fn send_acknack(&mut self, key: ClientKey, stream: StreamId) {
        if !self.acks_due.contains(&(key, stream)) {
            self.acks_due.push((key, stream));
        }
    }

    /// CREATE_CLIENT and GET_INFO outside a session (header session id 0x00 or 0x80).
    fn out_of_session(&mut self, from: E, header: &MessageHeader, bytes: &[u8], now: Instant) {
        for raw in parse_submessages(bytes, header) {
            let decoded = match raw.decode() {
                Ok(d) => d,
                Err(e) => {
                    if let Some(held_back) = self.drop_log.admit(from, now) {
                        tracing::warn!(peer = ?from, id = raw.header.id, held_back, "dropping submessage: {e}");
                    }
                    self.stats.decode_errors = self.stats.decode_errors.saturating_add(1);
                    break;
                }
            };
            match decoded {
                Submessage::CreateClient(rep) => self.handle_create_client(from, header, &rep, now),
                Submessage::GetInfo(get) => {
                    let known = self.by_endpoint.contains_key(&from)
                        || header
                            .client_key
                            .and_then(|k| self.clients.get(&k))
                            .is_some_and(|c| c.endpoint == Some(from));
                    let reply = info_reply(&get, u8::from(known));
                    if let Some(msg) = encode_message(header, &Submessage::Info(reply)) {
                        self.push_stateless(from, msg);
                    }
                }
                other => {
                    tracing::debug!(peer = ?from, id = other.id(), "submessage outside a session ignored");
                    break;
                }
            }
        }
    }

    /// A message for a session the agent does not know (spec §10.3).
    fn unknown_client(&mut self, from: E, header: &MessageHeader, bytes: &[u8]) {
        let mut answered = false;
        for raw in parse_submessages(bytes, header) {
            match raw.decode() {
                Ok(Submessage::Delete(req)) if req.object_id == ObjectId::CLIENT => {
                    let reply = BaseObjectReply { related_request: req, result: ResultStatus::new(StatusCode::OK) };
                    let h = MessageHeader { stream_id: StreamId::NONE, sequence_nr: 0, ..*header };
                    if let Some(msg) = encode_message(&h, &Submessage::Status(reply)) {
                        self.push_stateless(from, msg);
                    }
                    answered = true;
                }
                Ok(Submessage::GetInfo(get)) => {
                    let h = MessageHeader { stream_id: StreamId::NONE, sequence_nr: 0, ..*header };
                    if let Some(msg) = encode_message(&h, &Submessage::Info(info_reply(&get, 0))) {
                        self.push_stateless(from, msg);
                    }
                    answered = true;
                }
                _ => break,
            }
        }
        if !answered {
            tracing::debug!(peer = ?from, session = header.session_id, "message for an unknown session dropped");
            self.drop_datagram();
        }
    }

    fn handle_create_client(&mut self, from: E, header: &MessageHeader, rep: &ClientRepresentation<'_>, now: Instant) {
        let status = self.register_client(Some(from), rep.client_key, rep.session_id, rep.mtu, Some(rep), now);
        if status.is_ok() {
            tracing::info!(peer = ?from, client = %rep.client_key, session = rep.session_id, mtu = rep.mtu, "session established");
        } else {
            tracing::warn!(peer = ?from, client = %rep.client_key, status = status.name(), "CREATE_CLIENT refused");
        }
        let key = header.client_key.unwrap_or(rep.client_key);
        let reply_header = MessageHeader::new(rep.session_id, StreamId::NONE, 0, key);
        let reply = StatusAgent { result: ResultStatus::new(status), agent: AgentRepresentation::EPROSIMA };
        if let Some(msg) = encode_message(&reply_header, &Submessage::StatusAgent(reply)) {
            self.push_stateless(from, msg);
        }
    }

    /// CREATE_CLIENT semantics (spec §10.2), shared with the library API (`from` = None).
    pub(super) fn register_client(
        &mut self,
        from: Option<E>,
        key: ClientKey,
        session_id: u8,
        mtu: u16,
        rep: Option<&ClientRepresentation<'_>>,
        now: Instant,
    ) -> StatusCode {
        // An endpoint speaks for one client: a new key from it replaces the old client.
        if let Some(ep) = from {
            if let Some(old) = self.by_endpoint.get(&ep).copied().filter(|old| *old != key) {
                self.remove_client(old);
            }
        }
        if key == ClientKey::INVALID {
            return StatusCode::ERR_INVALID_DATA;
        }
        if let Some(rep) = rep {
            if rep.xrce_cookie != XRCE_COOKIE {
                return StatusCode::ERR_INVALID_DATA;
            }
            if rep.xrce_version[0] != xrce_proto::XRCE_VERSION[0] {
                return StatusCode::ERR_INCOMPATIBLE;
            }
        }
        if mtu < self.config.min_mtu {
            return StatusCode::ERR_INVALID_DATA;
        }
        let mtu = usize::from(mtu.min(self.config.max_mtu));
        let same_session = self.clients.get(&key).map(|c| c.session_id == session_id);
        match same_session {
            Some(true) => {
                let Some(client) = self.clients.get_mut(&key) else { return StatusCode::ERR_RESOURCES };
                client.reset_streams();
                client.mtu = mtu;
                client.last_heard = now;
                client.probes = 0;
            }
            Some(false) | None => {
                if same_session == Some(false) {
                    self.remove_client(key);
                } else if self.clients.len() >= self.config.max_clients && !self.evict_dead_client(now) {
                    return StatusCode::ERR_RESOURCES;
                }
                let mut client = ProxyClient::new(key, session_id, mtu, from, now);
                client.pack_data = self.config.pack_data;
                if let Some(rep) = rep {
                    client.hard_liveliness = rep.property("uxr_hl").and_then(parse_hard_liveliness);
                    client.shared_memory = rep.property("uxr_sm") == Some("1");
                    client.pack_data |= rep.property(super::session::PACK_PROPERTY) == Some("1");
                }
                if client.hard_liveliness.is_some() {
                    self.arm_heartbeat(now);
                }
                self.clients.insert(key, Box::new(client));
            }
        }
        if let Some(ep) = from {
            if let Some(client) = self.clients.get_mut(&key) {
                if let Some(old) = client.endpoint.replace(ep) {
                    if old != ep && self.by_endpoint.get(&old) == Some(&key) {
                        self.by_endpoint.remove(&old);
                    }
                }
            }
            if !xrce_proto::session_has_key(session_id) {
                self.by_endpoint.insert(ep, key);
            }
        }
        StatusCode::OK
    }

    /// Makes room in a full client table by removing the client silent the longest, if it is dead.
    fn evict_dead_client(&mut self, now: Instant) -> bool {
        let dead_time = self.config.client_dead_time;
        let victim =
            self.clients.values().filter(|c| c.is_dead(now, dead_time)).min_by_key(|c| c.last_heard).map(|c| c.key);
        victim.is_some_and(|k| self.remove_client(k))
    }

    /// Processes the submessages of one in-session message, in order, from `resume`, stopping at the first
    /// failure; where it stopped when a write would block (reliable streams only). `nested`: the message
    /// was rebuilt from fragments (FRAGMENTs inside it are ignored).
    fn process_message(
        &mut self,
        key: ClientKey,
        msg: &[u8],
        stream: StreamId,
        now: Instant,
        nested: bool,
        resume: Resume,
    ) -> Option<Resume> {
        let Ok((header, subs)) = parse(msg) else { return None };
        let mut inner = resume.inner;
        for (index, raw) in subs.enumerate().skip(resume.at) {
            let raw = match raw {
                Ok(r) => r,
                Err(e) => {
                    let peer = self.clients.get(&key).and_then(|c| c.endpoint);
                    if let Some(held_back) = self.admit_drop_log(peer, now) {
                        tracing::warn!(?peer, client = %key, held_back, "submessage length past the end: {e}");
                    }
                    self.stats.decode_errors = self.stats.decode_errors.saturating_add(1);
                    break;
                }
            };
            let flow = if let Some((rebuilt, at)) = inner.take() {
                // The message this FRAGMENT completed, held part-way.
                match self.process_message(key, &rebuilt, stream, now, true, Resume { at, inner: None }) {
                    Some(Resume { at, .. }) => Flow::BlockedIn(rebuilt, at),
                    None => Flow::Continue,
                }
            } else {
                match raw.decode() {
                    Ok(sub) => self.handle_submessage(key, &header, msg, stream, &raw, sub, now, nested),
                    Err(e) => {
                        let peer = self.clients.get(&key).and_then(|c| c.endpoint);
                        if let Some(held_back) = self.admit_drop_log(peer, now) {
                            tracing::warn!(?peer, client = %key, id = raw.header.id, held_back, "undecodable submessage: {e}");
                        }
                        self.stats.decode_errors = self.stats.decode_errors.saturating_add(1);
                        self.answer_undecodable(key, stream, &raw);
                        Flow::Stop
                    }
                }
            };
            match flow {
                Flow::Continue => {}
                Flow::Stop => break,
                Flow::Blocked => return Some(Resume { at: index, inner: None }),
                Flow::BlockedIn(rebuilt, at) => return Some(Resume { at: index, inner: Some((rebuilt, at)) }),
            }
            if !self.clients.contains_key(&key) {
                break;
            }
        }
        None
    }

    /// A CREATE or DELETE whose payload did not decode still gets a STATUS when its request id is readable,
    /// so the client does not wait forever.
    fn answer_undecodable(&mut self, key: ClientKey, stream: StreamId, raw: &RawSubmessage<'_>) {
        if !matches!(SubmessageId::from_u8(raw.header.id), Some(SubmessageId::Create | SubmessageId::Delete)) {
            return;
        }
        if let Some(request) = BaseObjectRequest::from_prefix(raw.payload()) {
            self.send_status(key, reply_stream(stream), request, StatusCode::ERR_INVALID_DATA);
        }
    }

    #[allow(clippy::too_many_arguments)]
    fn handle_submessage(
        &mut self,
        key: ClientKey,
        header: &MessageHeader,
        msg: &[u8],
        stream: StreamId,
        raw: &RawSubmessage<'_>,
        sub: Submessage<'_>,
        now: Instant,
        nested: bool,
    ) -> Flow {
        let endian = raw.header.endianness();
        match sub {
            Submessage::Create(create) => {
                self.handle_create(key, stream, &create, endian, now);
                Flow::Continue
            }
            Submessage::Delete(req) if req.object_id == ObjectId::CLIENT => {
                let to = self.clients.get(&key).and_then(|c| c.endpoint);
                let status = if self.remove_client(key) { StatusCode::OK } else { StatusCode::ERR_UNKNOWN_REFERENCE };
                // The client is gone: answer with its header, on stream 0, to where it was.
                let reply = BaseObjectReply { related_request: req, result: ResultStatus::new(status) };
                let h = MessageHeader { stream_id: StreamId::NONE, sequence_nr: 0, ..*header };
                if let (Some(to), Some(m)) = (to, encode_message(&h, &Submessage::Status(reply))) {
                    self.push_stateless(to, m);
                }
                Flow::Stop
            }
            Submessage::Delete(req) => {
                let status = self.delete_object(key, req.object_id);
                self.send_status(key, reply_stream(stream), req, status);
                Flow::Continue
            }
            Submessage::GetInfo(get) => {
                self.send_control(key, &Submessage::Info(info_reply(&get, 1)));
                Flow::Continue
            }
            Submessage::WriteData(data) => self.handle_write(key, stream, &data, now),
            Submessage::ReadData(read) => {
                self.handle_read(key, &read, now);
                Flow::Continue
            }
            Submessage::AckNack(ack) => {
                self.handle_acknack(key, &ack, now);
                Flow::Continue
            }
            Submessage::Heartbeat(hb) => {
                let sid = StreamId(hb.stream_id);
                if sid.is_reliable() {
                    // A HEARTBEAT may come before any message of its stream got through (the first one was
                    // lost): the stream is created here so the ACKNACK asks for what the client holds.
                    let window = self.config.reliable_window;
                    let max_streams = self.config.max_streams_per_client;
                    if let Some(c) = self.clients.get_mut(&key) {
                        if !c.streams.rel_in.contains_key(&hb.stream_id) && c.streams.count() >= max_streams {
                            tracing::warn!(client = %key, stream = hb.stream_id, "HEARTBEAT ignored: too many streams");
                            return Flow::Continue;
                        }
                        c.streams.rel_in.get_or_insert_with(hb.stream_id, || ReliableIn::new(window)).on_heartbeat(&hb);
                    }
                    let _ = self.drain_reliable(key, sid, now);
                    self.send_acknack(key, sid);
                }
                Flow::Continue
            }
            Submessage::Reset => {
                if let Some(c) = self.clients.get_mut(&key) {
                    c.reset_streams();
                }
                Flow::Stop
            }
            Submessage::Fragment { last, data } => {
                if nested || !stream.is_reliable() {
                    return Flow::Continue;
                }
                self.handle_fragment(key, msg, header, stream, data, last, now)
            }
            Submessage::Timestamp(t) => {
                let received = self.wall_time(now);
                let reply = TimestampReply {
                    transmit_timestamp: received,
                    receive_timestamp: received,
                    originate_timestamp: t,
                };
                self.send_control(key, &Submessage::TimestampReply(reply));
                Flow::Continue
            }
            Submessage::CreateClient(_) => {
                tracing::debug!(client = %key, "CREATE_CLIENT inside a session ignored");
                Flow::Continue
            }
            other => {
                tracing::debug!(client = %key, id = other.id(), "unexpected submessage: rest of message ignored");
                Flow::Stop
            }
        }
    }

    #[allow(clippy::too_many_arguments)]
    fn handle_fragment(
        &mut self,
        key: ClientKey,
        msg: &[u8],
        header: &MessageHeader,
        stream: StreamId,
        data: &[u8],
        last: bool,
        now: Instant,
    ) -> Flow {
        let max = self.config.max_reassembly_size;
        let max_buffered = self.config.max_buffered_bytes_per_client;
        let Some(client) = self.clients.get_mut(&key) else { return Flow::Continue };
        let buffered = client.streams.buffered();
        let Some(input) = client.streams.rel_in.get_mut(&stream.0) else { return Flow::Continue };
        let head = msg.get(..header.size()).unwrap_or(&[]);
        let limit = max.min(max_buffered.saturating_sub(buffered).saturating_add(input.buffered()));
        match input.push_fragment(head, data, last, limit) {
            Ok(Some(rebuilt)) => match self.process_message(key, &rebuilt, stream, now, true, Resume::default()) {
                Some(Resume { at, .. }) => Flow::BlockedIn(rebuilt, at),
                None => Flow::Continue,
            },
            Ok(None) => Flow::Continue,
            Err(size) => {
                let peer = client.endpoint;
                tracing::warn!(?peer, client = %key, size, limit, "fragmented message too large, dropped");
                Flow::Continue
            }
        }
    }

    // ---- objects ----

    fn handle_create(
        &mut self,
        key: ClientKey,
        stream: StreamId,
        create: &Create<'_>,
        endian: Endianness,
        now: Instant,
    ) {
        self.pump_needed = true;
        let status = match &create.variant {
            ObjectVariant::Entity(variant) => {
                let id = create.request.object_id.with_kind(variant.kind);
                self.create_object(key, id, variant, create.mode, endian, now)
            }
            // eProsima stores nothing for these and answers with the initial STATUS_OK (spec §7.1).
            ObjectVariant::Profile { .. } => StatusCode::OK,
            ObjectVariant::Agent(_) | ObjectVariant::Client(_) => StatusCode::ERR_INVALID_DATA,
        };
        self.send_status(key, reply_stream(stream), create.request, status);
    }

    /// CREATE semantics with creation modes (spec §11).
    pub(super) fn create_object(
        &mut self,
        key: ClientKey,
        id: ObjectId,
        variant: &EntityVariant<'_>,
        mode: CreationMode,
        endian: Endianness,
        now: Instant,
    ) -> StatusCode {
        let kind = variant.kind;
        if !is_entity_kind(kind) {
            return StatusCode::ERR_DDS_ERROR;
        }
        let id = id.with_kind(kind);
        let parent = match (variant.parent(), kind.parent()) {
            (Some(p), Some(parent_kind)) => Some(p.with_kind(parent_kind)),
            _ => None,
        };
        let max_objects = self.config.max_objects_per_client;
        let Some(client) = self.clients.get(&key) else { return StatusCode::ERR_UNKNOWN_REFERENCE };
        if let Some(p) = parent {
            if !client.objects.contains(p) {
                return StatusCode::ERR_UNKNOWN_REFERENCE;
            }
        }
        let exists = client.objects.contains(id);
        if !exists && client.objects.len() >= max_objects {
            return StatusCode::ERR_RESOURCES;
        }
        let creation = Creation {
            entity: EntityRef::new(key, id),
            parent: parent.map(|p| EntityRef::new(key, p)),
            variant,
            endian,
            now,
        };
        if exists {
            match (mode.reuse, mode.replace) {
                (false, false) => return StatusCode::ERR_ALREADY_EXISTS,
                (true, replace) => {
                    if self.middleware.matches(&creation) {
                        return StatusCode::OK_MATCHED;
                    }
                    if !replace {
                        return StatusCode::ERR_MISMATCH;
                    }
                }
                (false, true) => {}
            }
            self.delete_object(key, id);
        }
        match self.middleware.create(&creation) {
            Ok(()) => {
                if let Some(client) = self.clients.get_mut(&key) {
                    client.objects.insert(id, parent);
                }
                tracing::debug!(client = %key, %id, ?kind, "entity created");
                StatusCode::OK
            }
            Err(e) => {
                tracing::warn!(client = %key, %id, ?kind, "entity creation failed: {e}");
                e.status()
            }
        }
    }

    /// Deletes an object and everything below it.
    pub(super) fn delete_object(&mut self, key: ClientKey, id: ObjectId) -> StatusCode {
        let Some(client) = self.clients.get_mut(&key) else { return StatusCode::ERR_UNKNOWN_REFERENCE };
        if !client.objects.contains(id) {
            return StatusCode::ERR_UNKNOWN_REFERENCE;
        }
        for victim in client.objects.subtree(id) {
            if client.reads.remove(&victim).is_some() {
                self.middleware.stop_reading(EntityRef::new(key, victim));
            }
            if let Err(e) = self.middleware.delete(EntityRef::new(key, victim)) {
                tracing::debug!(client = %key, id = %victim, "middleware delete failed: {e}");
            }
            client.objects.remove(victim);
        }
        StatusCode::OK
    }

    // ---- data ----

    fn handle_write(&mut self, key: ClientKey, stream: StreamId, data: &DataPayload<'_>, now: Instant) -> Flow {
        if data.format != DataFormat::DATA {
            // eProsima implements FORMAT_DATA only and stops processing the message.
            tracing::debug!(client = %key, format = data.format.0, "WRITE_DATA format not supported");
            return Flow::Stop;
        }
        let id = data.request.object_id;
        if !self.has_object(key, id) {
            tracing::debug!(client = %key, %id, "WRITE_DATA to an unknown object dropped");
            return Flow::Continue;
        }
        let entity = EntityRef::new(key, id);
        let result = match id.kind() {
            ObjectKind::DataWriter => self.middleware.write_data(entity, data.data, now),
            ObjectKind::Requester => self.middleware.write_request(entity, data.request.request_id, data.data, now),
            ObjectKind::Replier => match data.split_sample_identity() {
                Ok((identity, reply)) => self.middleware.write_reply(entity, &identity, reply, now),
                Err(e) => {
                    tracing::warn!(client = %key, %id, "reply without a sample identity: {e}");
                    return Flow::Continue;
                }
            },
            other => {
                tracing::debug!(client = %key, %id, ?other, "WRITE_DATA to an object that cannot write");
                return Flow::Continue;
            }
        };
        match result {
            Ok(WriteOutcome::Accepted) => {
                self.pump_needed = true;
                self.writes_since_pump = self.writes_since_pump.saturating_add(1);
            }
            Ok(WriteOutcome::WouldBlock) if stream.is_reliable() => return Flow::Blocked,
            Ok(WriteOutcome::WouldBlock) => {
                tracing::debug!(client = %key, %id, "middleware full: best-effort sample dropped");
                self.stats.samples_dropped_in = self.stats.samples_dropped_in.saturating_add(1);
            }
            Err(e) => tracing::debug!(client = %key, %id, "write failed: {e}"),
        }
        Flow::Continue
    }

    fn handle_read(&mut self, key: ClientKey, read: &ReadData<'_>, now: Instant) {
        let id = read.request.object_id;
        let entity = EntityRef::new(key, id);
        let readable = matches!(id.kind(), ObjectKind::DataReader | ObjectKind::Requester | ObjectKind::Replier);
        if !readable || !self.has_object(key, id) {
            self.send_status(key, StreamId::BUILTIN_RELIABLE, read.request, StatusCode::ERR_UNKNOWN_REFERENCE);
            return;
        }
        let (what, task) = ReadTask::from_spec(read.request, &read.spec, now);
        let max_tasks = self.config.max_read_tasks_per_client;
        let Some(client) = self.clients.get_mut(&key) else { return };
        if client.reads.remove(&id).is_some() {
            self.middleware.stop_reading(entity);
        }
        if what == ReadRequest::Cancel {
            return;
        }
        if client.reads.len() >= max_tasks {
            self.send_status(key, StreamId::BUILTIN_RELIABLE, read.request, StatusCode::ERR_RESOURCES);
            return;
        }
        if let Err(e) = self.middleware.start_reading(entity) {
            tracing::warn!(client = %key, %id, "cannot start reading: {e}");
            self.send_status(key, StreamId::BUILTIN_RELIABLE, read.request, StatusCode::ERR_RESOURCES);
            return;
        }
        self.middleware.set_reader_reliable(entity, task.stream.is_reliable());
        if let Some(client) = self.clients.get_mut(&key) {
            client.reads.insert(id, task);
        }
        if !self.reading.contains(&key) {
            self.reading.push(key);
        }
        self.pump_needed = true;
    }

    fn handle_acknack(&mut self, key: ClientKey, ack: &xrce_proto::submessage::AckNack, now: Instant) {
        let Some(client) = self.clients.get_mut(&key) else { return };
        let header = client.header(StreamId(ack.stream_id), 0);
        let mtu = client.pack_mtu();
        let Some(out) = client.streams.rel_out.get_mut(&ack.stream_id) else { return };
        let before = out.first_unacked();
        let mut sent = std::mem::take(&mut self.scratch);
        out.on_acknack(ack, now, self.config.heartbeat_period, &mut self.pool, |m| sent.push(m));
        let progressed = out.first_unacked() != before;
        let repin = progressed && client.unpinned.take().is_some();
        out.flush(&header, mtu, Some(now), &mut self.pool, |m| sent.push(m));
        let probe = out.arm_probe(now, self.config.heartbeat_period);
        for m in sent.drain(..) {
            self.push_client(key, Class::Stream, m);
        }
        self.scratch = sent;
        self.schedule_probe(probe, key, ack.stream_id);
        if repin {
            self.pin_readers(key, true);
        }
        self.pump_needed = true;
    }

    /// Delivers samples for every active read task while streams have room.
    pub(super) fn pump_reads(&mut self, now: Instant) {
        self.pump_needed = false;
        // Only clients with read tasks (not every client), without allocating: the lists are reused.
        let clients = &self.clients;
        self.reading.retain(|k| clients.get(k).is_some_and(|c| !c.reads.is_empty()));
        let keys = std::mem::take(&mut self.reading);
        let mut readers = std::mem::take(&mut self.scratch_ids);
        for &key in &keys {
            readers.clear();
            if let Some(c) = self.clients.get(&key) {
                readers.extend(c.reads.keys().copied());
            }
            for &reader in &readers {
                self.pump_reader(key, reader, now);
            }
        }
        self.scratch_ids = readers;
        // Tasks started meanwhile (none from pumping, but keep them if any).
        let started = std::mem::replace(&mut self.reading, keys);
        for k in started {
            if !self.reading.contains(&k) {
                self.reading.push(k);
            }
        }
    }

    /// Sends what is queued on a reliable output stream, as far as its window allows.
    fn flush_stream(&mut self, key: ClientKey, stream: StreamId, now: Instant) {
        let Some(client) = self.clients.get_mut(&key) else { return };
        let header = client.header(stream, 0);
        let mtu = client.pack_mtu();
        let Some(out) = client.streams.rel_out.get_mut(&stream.0) else { return };
        let mut sent = std::mem::take(&mut self.scratch);
        out.flush(&header, mtu, Some(now), &mut self.pool, |m| sent.push(m));
        let probe = out.arm_probe(now, self.config.heartbeat_period);
        for m in sent.drain(..) {
            self.push_client(key, Class::Stream, m);
        }
        self.scratch = sent;
        self.schedule_probe(probe, key, stream.0);
    }

    /// Delivers the samples one read task may take now. On a reliable stream samples are queued and packed
    /// several per message (a message's worth at a time) while the window has room.
    fn pump_reader(&mut self, key: ClientKey, reader: ObjectId, now: Instant) {
        let reliable =
            self.clients.get(&key).and_then(|c| c.reads.get(&reader)).map(|t| t.stream).filter(|s| s.is_reliable());
        self.pumping = true;
        self.pump_reader_inner(key, reader, reliable, now);
        self.pumping = false;
        if let Some(stream) = reliable {
            self.flush_stream(key, stream, now);
        }
    }

    fn pump_reader_inner(&mut self, key: ClientKey, reader: ObjectId, reliable: Option<StreamId>, now: Instant) {
        let entity = EntityRef::new(key, reader);
        for _ in 0..MAX_SAMPLES_PER_PUMP {
            if let Some(stream) = reliable {
                let state = self.clients.get(&key).and_then(|c| {
                    c.streams.rel_out.get(&stream.0).map(|s| s.pending_bytes() >= c.pack_mtu() && s.has_window_room())
                });
                if state == Some(true) {
                    self.flush_stream(key, stream, now);
                }
                let can_take = self
                    .clients
                    .get(&key)
                    .and_then(|c| c.streams.rel_out.get(&stream.0).map(|s| s.can_take(c.pack_mtu())))
                    .unwrap_or(true);
                if !can_take {
                    return;
                }
            }
            let Some(client) = self.clients.get_mut(&key) else { return };
            let Some(task) = client.reads.get_mut(&reader) else { return };
            if task.finished(now) {
                client.reads.remove(&reader);
                self.middleware.stop_reading(entity);
                return;
            }
            task.expire_timers(now);
            let (stream, request) = (task.stream, task.request);
            // The sample is copied once, from the middleware into the DATA submessage; left in place when the
            // read's pace does not allow it yet.
            let mut sub = None;
            let pool = &mut self.pool;
            let taken = self.middleware.poll_sample(entity, &mut |sample| {
                let size = sample.wire_size();
                if task.ready(size, now).is_err() {
                    return false;
                }
                sub = data_submessage(key, request, &sample, pool);
                task.sent(size, now);
                true
            });
            if taken != Some(true) {
                return;
            }
            if let Some(sub) = sub {
                self.send_on_stream(key, stream, sub, Some(now));
            }
        }
    }

    fn send_status(&mut self, key: ClientKey, stream: StreamId, request: BaseObjectRequest, status: StatusCode) {
        let reply = BaseObjectReply { related_request: request, result: ResultStatus::new(status) };
        let Some(client) = self.clients.get(&key) else { return };
        let header_len = client.header(stream, 0).size();
        if let Some(sub) = encode_submessage(header_len, &Submessage::Status(reply)) {
            let now = self.last_now;
            self.send_on_stream(key, stream, sub, now);
        }
    }

    /// Sends one submessage (header included) to a client on an output stream.
    fn send_on_stream(&mut self, key: ClientKey, stream: StreamId, sub: Vec<u8>, now: Option<Instant>) {
        let window = self.config.reliable_window;
        let max_pending = self.config.max_pending_per_stream;
        let max_streams = self.config.max_streams_per_client;
        let Some(client) = self.clients.get_mut(&key) else { return };
        let header = client.header(stream, 0);
        let header_len = header.size();
        let fits = header_len + sub.len() <= client.mtu;
        let pack_mtu = client.pack_mtu();
        let is_new = match stream.kind() {
            StreamKind::None => false,
            StreamKind::BestEffort => !client.streams.be_out.contains_key(&stream.0),
            StreamKind::Reliable => !client.streams.rel_out.contains_key(&stream.0),
        };
        if is_new && client.streams.count() >= max_streams {
            tracing::warn!(client = %key, stream = stream.0, "too many streams: message dropped");
            return;
        }
        match stream.kind() {
            StreamKind::None | StreamKind::BestEffort => {
                if !fits {
                    tracing::debug!(client = %key, stream = stream.0, len = sub.len(), "message over the MTU on an unreliable stream dropped");
                    self.stats.messages_dropped_out = self.stats.messages_dropped_out.saturating_add(1);
                    return;
                }
                // A DATA on a best-effort stream joins the client's newest message of that stream if it is still
                // queued and has room: one datagram for several samples.
                let mtu = client.mtu;
                if client.pack_data && stream.kind() == StreamKind::BestEffort {
                    if let Some(last) = client.outbox.open_message(stream.0) {
                        let pad = (4 - last.len() % 4) % 4;
                        if last.len() + pad + sub.len() <= mtu {
                            last.resize(last.len() + pad, 0);
                            last.extend_from_slice(&sub);
                            self.pool.put(sub);
                            return;
                        }
                    }
                }
                let seq = if stream.kind() == StreamKind::None {
                    0
                } else {
                    client.streams.be_out.get_or_insert_with(stream.0, Default::default).next_seq()
                };
                let mut msg = self.pool.get();
                msg.resize(header_len, 0);
                if (MessageHeader { sequence_nr: seq, ..header }).encode(&mut msg).is_err() {
                    return;
                }
                msg.extend_from_slice(&sub);
                self.pool.put(sub);
                if stream.kind() == StreamKind::None {
                    self.push_client(key, Class::Control, msg);
                } else {
                    self.push_client(key, Class::Stream, msg);
                    if let Some(client) = self.clients.get_mut(&key) {
                        client.outbox.leave_open(stream.0);
                    }
                }
            }
            StreamKind::Reliable => {
                let out = client.streams.rel_out.get_or_insert_with(stream.0, || ReliableOut::new(window, max_pending));
                let queued = if fits { out.queue_one(sub) } else { out.queue(fragment(&sub, client.mtu, header_len)) };
                if !queued {
                    tracing::warn!(client = %key, stream = stream.0, "reliable output queue full: message dropped");
                    self.stats.messages_dropped_out = self.stats.messages_dropped_out.saturating_add(1);
                    return;
                }
                // While pumping, samples wait to be packed into one message (see `pump_reader`).
                let mut sent = std::mem::take(&mut self.scratch);
                if !self.pumping {
                    out.flush(&header, pack_mtu, now, &mut self.pool, |m| sent.push(m));
                }
                let probe = now.and_then(|now| out.arm_probe(now, self.config.heartbeat_period));
                for m in sent.drain(..) {
                    self.push_client(key, Class::Stream, m);
                }
                self.scratch = sent;
                if let Some(now) = now {
                    self.arm_heartbeat(now);
                    self.schedule_probe(probe, key, stream.0);
                }
            }
        }
    }
}

/// A sample as one DATA submessage (spec §6.8), header included, in a buffer of `pool`; `None` (logged)
/// when it is too large for one submessage.
fn data_submessage(
    key: ClientKey,
    request: BaseObjectRequest,
    sample: &SampleRef<'_>,
    pool: &mut crate::bufpool::BufPool,
) -> Option<Vec<u8>> {
    let head = RequestHead::data(SubmessageId::Data, request, sample.wire_size());
    let Some(head_bytes) = head.to_bytes() else {
        tracing::warn!(client = %key, size = head.encoded_len(), "sample too large for one DATA submessage, dropped");
        return None;
    };
    let mut sub = pool.get();
    sub.extend_from_slice(&head_bytes);
    match *sample {
        SampleRef::Data(d) => sub.extend_from_slice(d),
        SampleRef::Request { identity, data } => {
            let mut id_buf = [0u8; xrce_proto::SampleIdentity::SIZE];
            let mut w = xrce_proto::cdr::Writer::new(&mut id_buf, Endianness::Little);
            w.write(&identity);
            sub.extend_from_slice(&id_buf);
            sub.extend_from_slice(data);
        }
        SampleRef::Reply { request_id, data } => {
            // A reply starts with the request it answers (eProsima's requester format).
            let related = BaseObjectRequest { request_id, object_id: request.object_id };
            sub.extend_from_slice(&related.to_bytes());
            sub.extend_from_slice(data);
        }
    }
    Some(sub)
}

/// Submessages of a message whose header is already decoded; stops at the first length error.
fn parse_submessages<'a>(bytes: &'a [u8], header: &MessageHeader) -> impl Iterator<Item = RawSubmessage<'a>> {
    xrce_proto::Submessages::new(bytes, header.size()).map_while(Result::ok)
}

/// The INFO the agent answers a GET_INFO with (spec §6.7): configuration and activity, no locators.
fn info_reply(get: &GetInfo, implementation_status: u8) -> Info<'static> {
    Info {
        reply: BaseObjectReply {
            related_request: get.request,
            result: ResultStatus { status: StatusCode::OK, implementation_status },
        },
        config: Some(ObjectVariant::Agent(AgentRepresentation::EPROSIMA)),
        activity: Some(ActivityInfo::Agent { availability: 1, address_seq: xrce_proto::cdr::Seq::EMPTY }),
    }
}
