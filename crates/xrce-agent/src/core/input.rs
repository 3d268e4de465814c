//! A connection's incoming traffic: a message routed to its stream (spec §9), each submessage to its handler
//! (spec §10.3), reliable back-pressure (a message held unacknowledged until the middleware can take its
//! writes, resumed where it stopped), reassembly of FRAGMENTs.

use std::fmt::Debug;
use std::hash::Hash;
use std::time::Instant;

use xrce_proto::message::parse;
use xrce_proto::object::AgentRepresentation;
use xrce_proto::submessage::{ActivityInfo, Create, DataFormat, DataPayload, GetInfo, Info, ReadData};
use xrce_proto::view::{self, FragmentHead, SubmessageId};
use xrce_proto::{
    BaseObjectReply, BaseObjectRequest, MessageHeader, ObjectId, ObjectKind, ObjectVariant, RawSubmessage,
    ResultStatus, StatusCode, StreamId, StreamKind, Submessage,
};

use super::connection::{Connection, Ctx};
use super::outbox::Control;
use super::read::{ReadRequest, ReadTask};
use super::session::{Resume, Unpinned};
use super::stats::{self, DropReason};
use super::stream::{InAction, ReliableIn};
use crate::middleware::{EntityRef, Middleware, WriteOutcome};

/// The stream STATUS replies go on: 0x80 for requests from reliable streams, 0x01 otherwise (spec §10.3).
pub(super) fn reply_stream(input: StreamId) -> StreamId {
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

impl<E: Copy + Eq + Hash + Debug> Connection<E> {
    /// One in-session message from `from`: refreshes liveliness and the reply address, then processes it
    /// on its stream.
    pub(crate) fn handle_message<M: Middleware>(
        &mut self,
        ctx: &mut Ctx<'_, E, M>,
        from: E,
        header: &MessageHeader,
        bytes: &[u8],
        now: Instant,
    ) {
        self.last_heard = now;
        self.probes = 0;
        if self.unpinned == Some(Unpinned::Dead) {
            self.unpinned = None;
            self.pin_readers(ctx, true);
        }
        if header.client_key.is_some() || self.endpoint.is_none() {
            // Keyed sessions: replies follow the client wherever it now sends from.
            self.endpoint = Some(from);
        }
        let stream = header.stream_id;
        match stream.kind() {
            StreamKind::None => self.process_unreliable(ctx, bytes, stream, now),
            StreamKind::BestEffort => {
                if !self.streams.be_in.contains_key(&stream.0)
                    && self.streams.count() >= ctx.config.max_streams_per_client
                {
                    if let Some(held_back) = ctx.drop_log.admit(from, now) {
                        tracing::warn!(peer = ?from, client = %self.key, held_back, "dropping message: too many streams");
                    }
                    self.drop_datagram(ctx, DropReason::TooManyStreams);
                    return;
                }
                if self.streams.be_in.get_or_insert_with(stream.0, Default::default).accept(header.sequence_nr) {
                    self.process_unreliable(ctx, bytes, stream, now);
                } else {
                    tracing::trace!(client = %self.key, seq = header.sequence_nr, "best-effort: old message dropped");
                    self.drop_datagram(ctx, DropReason::OutOfOrder);
                }
            }
            StreamKind::Reliable => self.process_reliable(ctx, from, header, bytes, now),
        }
    }

    /// A message of stream 0 or a best-effort stream: a write the middleware cannot take is lost, as on the
    /// wire (see [`Self::handle_write`]).
    fn process_unreliable<M: Middleware>(
        &mut self,
        ctx: &mut Ctx<'_, E, M>,
        bytes: &[u8],
        stream: StreamId,
        now: Instant,
    ) {
        let _ = self.process_message(ctx, bytes, stream, now, false, Resume::default());
    }

    fn process_reliable<M: Middleware>(
        &mut self,
        ctx: &mut Ctx<'_, E, M>,
        from: E,
        header: &MessageHeader,
        bytes: &[u8],
        now: Instant,
    ) {
        let stream = header.stream_id;
        if !self.streams.rel_in.contains_key(&stream.0) && self.streams.count() >= ctx.config.max_streams_per_client {
            if let Some(held_back) = ctx.drop_log.admit(from, now) {
                tracing::warn!(peer = ?from, client = %self.key, held_back, "dropping message: too many streams");
            }
            self.drop_datagram(ctx, DropReason::TooManyStreams);
            return;
        }
        let room = ctx.config.max_buffered_bytes_per_client.saturating_sub(self.streams.buffered());
        let window = ctx.config.reliable_window;
        let input = self.streams.rel_in.get_or_insert_with(stream.0, || ReliableIn::new(window));
        match input.receive(header.sequence_nr, bytes, room) {
            InAction::Process => {
                let resume = if self.write_blocked(ctx, stream, bytes, now) {
                    Some(Resume::default())
                } else {
                    self.process_message(ctx, bytes, stream, now, false, Resume::default())
                };
                let Some(input) = self.streams.rel_in.get_mut(&stream.0) else { return };
                match resume {
                    Some(resume) => {
                        input.hold(bytes);
                        self.hold_at(stream, resume);
                    }
                    None => {
                        input.advance();
                        self.drain_reliable(ctx, stream, now);
                    }
                }
            }
            InAction::Stored => {}
            InAction::Dropped => self.drop_datagram(ctx, DropReason::OutOfOrder),
        }
        self.owe_acknack(stream);
    }

    /// Processes the stored messages of a reliable input stream that became next in order, stopping at one
    /// whose writes the middleware cannot take yet (back-pressure). Returns whether any was processed.
    fn drain_reliable<M: Middleware>(&mut self, ctx: &mut Ctx<'_, E, M>, stream: StreamId, now: Instant) -> bool {
        let mut progress = false;
        while let Some(msg) = self.streams.rel_in.get_mut(&stream.0).and_then(ReliableIn::pop_ready) {
            let resume = self.take_resume(stream);
            let blocked = if resume.is_none() && self.write_blocked(ctx, stream, &msg, now) {
                Some(Resume::default())
            } else {
                self.process_message(ctx, &msg, stream, now, false, resume.unwrap_or_default())
            };
            if let Some(resume) = blocked {
                if let Some(input) = self.streams.rel_in.get_mut(&stream.0) {
                    input.unpop(msg);
                }
                self.hold_at(stream, resume);
                break;
            }
            progress = true;
        }
        progress
    }

    /// Where the held message of `stream` resumes, if it was processed in part; the table goes with its last
    /// entry.
    fn take_resume(&mut self, stream: StreamId) -> Option<Resume> {
        let table = self.resume.as_mut()?;
        let resume = table.remove(&stream.0);
        if table.is_empty() {
            self.resume = None;
        }
        resume
    }

    /// Holds a reliable input stream at `resume` until the middleware can take its writes.
    fn hold_at(&mut self, stream: StreamId, resume: Resume) {
        if resume != Resume::default() {
            self.resume.get_or_insert_with(Box::default).insert(stream.0, resume);
        }
        if !self.blocked.contains(&stream) {
            self.blocked.push(stream);
        }
    }

    /// Retries the reliable input streams held back; acknowledges what went through. Whether any stream is
    /// still held.
    pub(crate) fn retry_blocked<M: Middleware>(&mut self, ctx: &mut Ctx<'_, E, M>, now: Instant) -> bool {
        for stream in std::mem::take(&mut self.blocked) {
            if self.drain_reliable(ctx, stream, now) {
                self.owe_acknack(stream);
            }
        }
        !self.blocked.is_empty()
    }

    /// Whether a reliable message writes to a datawriter whose middleware has no credit for it now (spec:
    /// none; this is our back-pressure, see [`Middleware::write_credit`]). A FRAGMENT completing a message
    /// is judged by the WRITE_DATA at the start of the reassembled message.
    fn write_blocked<M: Middleware>(
        &self,
        ctx: &mut Ctx<'_, E, M>,
        stream: StreamId,
        msg: &[u8],
        now: Instant,
    ) -> bool {
        let Ok((_, subs)) = parse(msg) else { return false };
        let mut writers: [Option<ObjectId>; 4] = [None; 4];
        let mut n = 0;
        for raw in subs.map_while(Result::ok) {
            let object = match SubmessageId::from_u8(raw.header.id) {
                Some(SubmessageId::WriteData) => view::write_data_object(raw.header.id, raw.payload()),
                Some(SubmessageId::Fragment) if FragmentHead::from_header(raw.header).is_some_and(|f| f.last) => {
                    let start = self.streams.rel_in.get(&stream.0).and_then(ReliableIn::reassembly_start);
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
        writers.iter().flatten().any(|id| ctx.middleware.write_credit(EntityRef::new(self.key, *id), now) == 0)
    }

    /// Processes the submessages of one in-session message, in order, from `resume`, stopping at the first
    /// failure; where it stopped when a write would block (reliable streams only). `nested`: the message
    /// was rebuilt from fragments (FRAGMENTs inside it are ignored).
    fn process_message<M: Middleware>(
        &mut self,
        ctx: &mut Ctx<'_, E, M>,
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
                    let peer = self.endpoint;
                    if let Some(held_back) = ctx.admit_warning(peer, now) {
                        tracing::warn!(?peer, client = %self.key, held_back, "submessage length past the end: {e}");
                    }
                    ctx.stats.decode_errors = ctx.stats.decode_errors.saturating_add(1);
                    break;
                }
            };
            let flow = if let Some((rebuilt, at)) = inner.take() {
                // The message this FRAGMENT completed, held part-way.
                match self.process_message(ctx, &rebuilt, stream, now, true, Resume { at, inner: None }) {
                    Some(Resume { at, .. }) => Flow::BlockedIn(rebuilt, at),
                    None => Flow::Continue,
                }
            } else {
                match raw.decode() {
                    Ok(sub) => self.handle_submessage(ctx, &header, msg, stream, &raw, sub, now, nested),
                    Err(e) => {
                        let peer = self.endpoint;
                        if let Some(held_back) = ctx.admit_warning(peer, now) {
                            tracing::warn!(?peer, client = %self.key, id = raw.header.id, held_back, "undecodable submessage: {e}");
                        }
                        ctx.stats.decode_errors = ctx.stats.decode_errors.saturating_add(1);
                        self.answer_undecodable(ctx, stream, &raw, now);
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
            if self.delete_request.is_some() {
                break;
            }
        }
        None
    }

    /// A CREATE or DELETE whose payload did not decode still gets a STATUS when its request id is readable,
    /// so the client does not wait forever.
    fn answer_undecodable<M>(
        &mut self,
        ctx: &mut Ctx<'_, E, M>,
        stream: StreamId,
        raw: &RawSubmessage<'_>,
        now: Instant,
    ) {
        if !matches!(SubmessageId::from_u8(raw.header.id), Some(SubmessageId::Create | SubmessageId::Delete)) {
            return;
        }
        if let Some(request) = BaseObjectRequest::from_prefix(raw.payload()) {
            self.send_status(ctx, reply_stream(stream), request, StatusCode::ERR_INVALID_DATA, now);
        }
    }

    #[allow(clippy::too_many_arguments)]
    fn handle_submessage<M: Middleware>(
        &mut self,
        ctx: &mut Ctx<'_, E, M>,
        header: &MessageHeader,
        msg: &[u8],
        stream: StreamId,
        raw: &RawSubmessage<'_>,
        sub: Submessage<'_>,
        now: Instant,
        nested: bool,
    ) -> Flow {
        match sub {
            Submessage::Create(create) => {
                self.handle_create(ctx, stream, &create, raw.header.endianness(), now);
                Flow::Continue
            }
            Submessage::Delete(req) if req.object_id == ObjectId::CLIENT => {
                // The endpoint removes the client and answers with its header, on stream 0.
                self.delete_request = Some((req, *header));
                Flow::Stop
            }
            Submessage::Delete(req) => {
                let status = self.delete_object(ctx, req.object_id);
                self.send_status(ctx, reply_stream(stream), req, status, now);
                Flow::Continue
            }
            Submessage::GetInfo(get) => {
                self.send_control(ctx, &Submessage::Info(info_reply(&get, 1)));
                Flow::Continue
            }
            Submessage::WriteData(data) => self.handle_write(ctx, stream, &data, now),
            Submessage::ReadData(read) => {
                self.handle_read(ctx, &read, now);
                Flow::Continue
            }
            Submessage::AckNack(ack) => {
                self.handle_acknack(ctx, &ack, now);
                Flow::Continue
            }
            Submessage::Heartbeat(hb) => {
                let sid = StreamId(hb.stream_id);
                if sid.is_reliable() {
                    // A HEARTBEAT may come before any message of its stream got through (the first one was
                    // lost): the stream is created here so the ACKNACK asks for what the client holds.
                    let window = ctx.config.reliable_window;
                    if !self.streams.rel_in.contains_key(&hb.stream_id)
                        && self.streams.count() >= ctx.config.max_streams_per_client
                    {
                        if let Some(held_back) = ctx.admit_warning(self.endpoint, now) {
                            tracing::warn!(peer = ?self.endpoint, client = %self.key, stream = hb.stream_id, held_back, "HEARTBEAT ignored: too many streams");
                        }
                        return Flow::Continue;
                    }
                    self.streams.rel_in.get_or_insert_with(hb.stream_id, || ReliableIn::new(window)).on_heartbeat(&hb);
                    let _ = self.drain_reliable(ctx, sid, now);
                    self.owe_acknack(sid);
                }
                Flow::Continue
            }
            Submessage::Reset => {
                self.reset_streams();
                Flow::Stop
            }
            Submessage::Fragment { last, data } => {
                if nested || !stream.is_reliable() {
                    return Flow::Continue;
                }
                self.handle_fragment(ctx, msg, header, stream, data, last, now)
            }
            Submessage::Timestamp(t) => {
                let received = ctx.wall_time(now);
                self.push_control(ctx, Control::TimestampReply { originate: t, received });
                Flow::Continue
            }
            Submessage::CreateClient(_) => {
                tracing::debug!(client = %self.key, "CREATE_CLIENT inside a session ignored");
                Flow::Continue
            }
            other => {
                tracing::debug!(client = %self.key, id = other.id(), "unexpected submessage: rest of message ignored");
                Flow::Stop
            }
        }
    }

    #[allow(clippy::too_many_arguments)]
    fn handle_fragment<M: Middleware>(
        &mut self,
        ctx: &mut Ctx<'_, E, M>,
        msg: &[u8],
        header: &MessageHeader,
        stream: StreamId,
        data: &[u8],
        last: bool,
        now: Instant,
    ) -> Flow {
        let max = ctx.config.max_reassembly_size;
        let buffered = self.streams.buffered();
        let Some(input) = self.streams.rel_in.get_mut(&stream.0) else { return Flow::Continue };
        let head = msg.get(..header.size()).unwrap_or(&[]);
        let limit =
            max.min(ctx.config.max_buffered_bytes_per_client.saturating_sub(buffered).saturating_add(input.buffered()));
        match input.push_fragment(head, data, last, limit) {
            Ok(Some(rebuilt)) => match self.process_message(ctx, &rebuilt, stream, now, true, Resume::default()) {
                Some(Resume { at, .. }) => Flow::BlockedIn(rebuilt, at),
                None => Flow::Continue,
            },
            Ok(None) => Flow::Continue,
            Err(size) => {
                if let Some(held_back) = ctx.admit_warning(self.endpoint, now) {
                    tracing::warn!(peer = ?self.endpoint, client = %self.key, size, limit, held_back, "fragmented message too large, dropped");
                }
                Flow::Continue
            }
        }
    }

    fn handle_create<M: Middleware>(
        &mut self,
        ctx: &mut Ctx<'_, E, M>,
        stream: StreamId,
        create: &Create<'_>,
        endian: xrce_proto::Endianness,
        now: Instant,
    ) {
        ctx.retry = true;
        let status = match &create.variant {
            ObjectVariant::Entity(variant) => {
                let id = create.request.object_id.with_kind(variant.kind);
                self.create_object(ctx, id, variant, create.mode, endian, now)
            }
            // eProsima stores nothing for these and answers with the initial STATUS_OK (spec §7.1).
            ObjectVariant::Profile { .. } => StatusCode::OK,
            ObjectVariant::Agent(_) | ObjectVariant::Client(_) => StatusCode::ERR_INVALID_DATA,
        };
        self.send_status(ctx, reply_stream(stream), create.request, status, now);
    }

    fn handle_write<M: Middleware>(
        &mut self,
        ctx: &mut Ctx<'_, E, M>,
        stream: StreamId,
        data: &DataPayload<'_>,
        now: Instant,
    ) -> Flow {
        if data.format != DataFormat::DATA {
            // eProsima implements FORMAT_DATA only and stops processing the message.
            tracing::debug!(client = %self.key, format = data.format.0, "WRITE_DATA format not supported");
            return Flow::Stop;
        }
        let id = data.request.object_id;
        if !self.objects.contains(id) {
            tracing::debug!(client = %self.key, %id, "WRITE_DATA to an unknown object dropped");
            return Flow::Continue;
        }
        let entity = EntityRef::new(self.key, id);
        let result = match id.kind() {
            ObjectKind::DataWriter => ctx.middleware.write_data(entity, data.data, now),
            ObjectKind::Requester => ctx.middleware.write_request(entity, data.request.request_id, data.data, now),
            ObjectKind::Replier => match data.split_sample_identity() {
                Ok((identity, reply)) => ctx.middleware.write_reply(entity, &identity, reply, now),
                Err(e) => {
                    if let Some(held_back) = ctx.admit_warning(self.endpoint, now) {
                        tracing::warn!(peer = ?self.endpoint, client = %self.key, %id, held_back, "reply without a sample identity: {e}");
                    }
                    return Flow::Continue;
                }
            },
            other => {
                tracing::debug!(client = %self.key, %id, ?other, "WRITE_DATA to an object that cannot write");
                return Flow::Continue;
            }
        };
        match result {
            Ok(WriteOutcome::Accepted) => {
                ctx.writes = ctx.writes.saturating_add(1);
                stats::bump(&mut self.counters.samples_in);
                stats::add(&mut self.counters.bytes_in, data.data.len());
            }
            Ok(WriteOutcome::WouldBlock) if stream.is_reliable() => return Flow::Blocked,
            Ok(WriteOutcome::WouldBlock) => {
                tracing::debug!(client = %self.key, %id, "middleware full: best-effort sample dropped");
                stats::bump(&mut ctx.stats.samples_dropped_in);
                stats::bump(&mut self.counters.rare().samples_dropped_in);
            }
            Err(e) => tracing::debug!(client = %self.key, %id, "write failed: {e}"),
        }
        Flow::Continue
    }

    fn handle_read<M: Middleware>(&mut self, ctx: &mut Ctx<'_, E, M>, read: &ReadData<'_>, now: Instant) {
        let id = read.request.object_id;
        let entity = EntityRef::new(self.key, id);
        let readable = matches!(id.kind(), ObjectKind::DataReader | ObjectKind::Requester | ObjectKind::Replier);
        if !readable || !self.objects.contains(id) {
            self.send_status(ctx, StreamId::BUILTIN_RELIABLE, read.request, StatusCode::ERR_UNKNOWN_REFERENCE, now);
            return;
        }
        let (what, task) = ReadTask::from_spec(read.request, &read.spec, now);
        if self.reads.remove(&id).is_some() {
            ctx.middleware.stop_reading(entity);
        }
        if what == ReadRequest::Cancel {
            return;
        }
        if self.reads.len() >= ctx.config.max_read_tasks_per_client {
            self.send_status(ctx, StreamId::BUILTIN_RELIABLE, read.request, StatusCode::ERR_RESOURCES, now);
            return;
        }
        if let Err(e) = ctx.middleware.start_reading(entity) {
            if let Some(held_back) = ctx.admit_warning(self.endpoint, now) {
                tracing::warn!(peer = ?self.endpoint, client = %self.key, %id, held_back, "cannot start reading: {e}");
            }
            self.send_status(ctx, StreamId::BUILTIN_RELIABLE, read.request, StatusCode::ERR_RESOURCES, now);
            return;
        }
        ctx.middleware.set_reader_reliable(entity, task.stream.is_reliable());
        self.reads.insert(id, task);
    }
}

/// The INFO answering a GET_INFO; `implementation_status` 1 when the peer is a known client.
pub(super) fn info_reply(get: &GetInfo, implementation_status: u8) -> Info<'static> {
    Info {
        reply: BaseObjectReply {
            related_request: get.request,
            result: ResultStatus { status: StatusCode::OK, implementation_status },
        },
        config: Some(ObjectVariant::Agent(AgentRepresentation::EPROSIMA)),
        activity: Some(ActivityInfo::Agent { availability: 1, address_seq: xrce_proto::cdr::Seq::EMPTY }),
    }
}

/// Submessages of a message whose header is already decoded; stops at the first length error.
pub(super) fn parse_submessages<'a>(
    bytes: &'a [u8],
    header: &MessageHeader,
) -> impl Iterator<Item = RawSubmessage<'a>> {
    xrce_proto::Submessages::new(bytes, header.size()).map_while(Result::ok)
}
