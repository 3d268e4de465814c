//! One proxy client as a state machine (spec §10): its session, streams, objects and read tasks, what it
//! has to send ([`Outbox`]) and its own timers. The endpoint ([`AgentCore`](super::AgentCore)) routes a
//! datagram to it ([`Connection::handle_message`], in `input.rs`), runs it when its timer is due
//! ([`Connection::handle_timeout`]), and takes what it queued. Everything the connection needs from outside
//! (the middleware, limits, counters, buffers) comes in a [`Ctx`]; what it cannot do alone (delete itself,
//! wake other clients' readers) it reports in the context or with [`Connection::take_delete_request`].

use std::fmt::Debug;
use std::hash::Hash;
use std::time::{Duration, Instant};

use xrce_proto::layout::submessage_offset;
use xrce_proto::{
    BaseObjectReply, BaseObjectRequest, ClientKey, MessageHeader, ObjectId, ResultStatus, StatusCode, StreamId,
    StreamKind, Submessage,
};

use super::droplog::DropLog;
use super::object::ObjectTable;
use xrce_proto::submessage::TimestampReply;

use super::outbox::{Class, Control, Outbox};
use super::read::ReadTask;
use super::session::{Resume, Streams, Unpinned};
use super::stats::{bump, ClientTotals, DropReason};
use super::stream::ReliableOut;
use super::timer::{Timer, TimerTable};
use super::vecmap::VecMap;
use super::{encode_into, encode_submessage, CoreConfig, CoreStats};
use crate::bufpool::BufPool;
use crate::middleware::{EntityRef, Middleware};
use xrce_proto::reliable::FragmentPlan;

/// What a connection borrows from the endpoint while it runs.
pub(crate) struct Ctx<'a, E, M> {
    pub middleware: &'a mut M,
    pub config: &'a CoreConfig,
    pub stats: &'a mut CoreStats,
    pub pool: &'a mut BufPool,
    pub drop_log: &'a mut DropLog<E>,
    /// Instant tied to a wall-clock time, for TIMESTAMP_REPLY.
    pub wall_anchor: Option<(Instant, Duration)>,
    /// Samples the middleware accepted: readers of any client may have something to deliver.
    pub writes: usize,
    /// Something changed that may let held writers go (readers unpinned, an entity created).
    pub retry: bool,
}

impl<E: Copy + Eq + Hash, M> Ctx<'_, E, M> {
    /// [`DropLog::admit`] for a peer that may be unknown (always warned about then).
    pub fn admit_warning(&mut self, peer: Option<E>, now: Instant) -> Option<u64> {
        match peer {
            Some(p) => self.drop_log.admit(p, now),
            None => Some(0),
        }
    }

    /// The wall-clock time at `now`.
    pub fn wall_time(&self, now: Instant) -> xrce_proto::Time {
        let (at, since_epoch) = self.wall_anchor.unwrap_or((now, Duration::ZERO));
        let t = if now >= at { since_epoch.saturating_add(now - at) } else { since_epoch.saturating_sub(at - now) };
        xrce_proto::Time { seconds: i32::try_from(t.as_secs()).unwrap_or(i32::MAX), nanoseconds: t.subsec_nanos() }
    }
}

/// One client known to the agent.
#[derive(Debug)]
pub struct Connection<E> {
    /// Its key.
    pub key: ClientKey,
    /// Session id from CREATE_CLIENT.
    pub session_id: u8,
    /// Largest message the agent sends it.
    pub mtu: usize,
    /// Where replies go (the source of its latest message); unknown for a client created through the API
    /// until it sends something.
    pub endpoint: Option<E>,
    /// Streams.
    pub streams: Streams,
    /// Objects.
    pub objects: ObjectTable,
    /// Active read tasks by reader/requester/replier id.
    pub reads: VecMap<ObjectId, ReadTask>,
    /// Last time anything came from it.
    pub last_heard: Instant,
    /// Dead time from `uxr_hl`: when present, a dead client is probed and removed.
    pub hard_liveliness: Option<Duration>,
    /// Probes sent since it went silent.
    pub probes: u8,
    /// Whether it asked for the shared-memory shortcut (`uxr_sm`); kept for the DDS middleware.
    pub shared_memory: bool,
    /// Several DATA submessages may share one message ([`PACK_PROPERTY`](super::session::PACK_PROPERTY),
    /// or [`CoreConfig::pack_data`]). Off for eProsima's C client, which does not skip a DATA payload and
    /// so cannot read a second submessage after one.
    pub pack_data: bool,
    /// Its reliable readers stopped holding writers back (see [`Unpinned`]).
    pub unpinned: Option<Unpinned>,
    /// Reliable input streams whose held message was processed in part: where to resume.
    /// Boxed when there is one: rare (back-pressure on a fragmented or multi-submessage message), and 16 B
    /// less in each of thousands of idle connections.
    pub resume: Option<Box<VecMap<u8, Resume>>>,
    /// Reliable input streams holding a message until the middleware can take its writes.
    pub blocked: Vec<StreamId>,
    /// Reliable input streams owed an ACKNACK (built with their latest state when the endpoint sends it).
    pub acks_due: Vec<u8>,
    /// What it has to send.
    pub outbox: Outbox,
    /// Its periodic and liveness turns ([`TimerTable`]); probes and paced reads keep their own deadlines.
    pub(crate) timers: TimerTable,
    /// The instant of its entry in the endpoint's timer queue, if one is queued.
    pub(super) timer_queued: Option<Instant>,
    /// A DELETE of the client itself: the endpoint removes it and answers.
    pub(super) delete_request: Option<(BaseObjectRequest, MessageHeader)>,
    /// In the endpoint's lists of clients owing ACKNACKs, with read tasks, with held input: kept here so a
    /// turn checks membership without scanning the lists (thousands of subscribers read at once).
    pub(super) listed: Listed,
    /// Its liveness timer ([`liveness`](super::liveness)).
    pub(super) watch: super::liveness::Watch,
    /// When the agent created it.
    pub created_at: Instant,
    /// Its totals ([`snapshot`](super::snapshot)).
    pub counters: ClientTotals,
}

/// Which of the endpoint's client lists a connection is in.
#[derive(Debug, Default, Clone, Copy)]
pub(super) struct Listed {
    pub acking: bool,
    pub reading: bool,
    pub blocked: bool,
}

/// What a timer turn decided about the connection.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Liveness {
    Alive,
    /// Silent past its limit (or unanswered liveliness probes): the endpoint removes it.
    Remove,
}

impl<E: Copy + Eq + Hash + Debug> Connection<E> {
    /// A fresh client.
    pub fn new(key: ClientKey, session_id: u8, mtu: usize, endpoint: Option<E>, now: Instant) -> Self {
        Self {
            key,
            session_id,
            mtu,
            endpoint,
            streams: Streams::default(),
            objects: ObjectTable::default(),
            reads: VecMap::default(),
            last_heard: now,
            hard_liveliness: None,
            probes: 0,
            shared_memory: false,
            pack_data: false,
            unpinned: None,
            resume: None,
            blocked: Vec::new(),
            acks_due: Vec::new(),
            outbox: Outbox::default(),
            timers: TimerTable::default(),
            timer_queued: None,
            delete_request: None,
            listed: Listed::default(),
            watch: super::liveness::Watch::default(),
            created_at: now,
            counters: ClientTotals::default(),
        }
    }

    /// Counts a datagram of this client dropped for `reason`, in its totals and the agent's.
    pub(super) fn drop_datagram<M>(&mut self, ctx: &mut Ctx<'_, E, M>, reason: DropReason) {
        ctx.stats.drop_datagram(reason);
        bump(&mut self.counters.rare().datagrams_dropped);
    }

    /// Header of a message to this client on `stream` with `seq`.
    pub fn header(&self, stream: StreamId, seq: u16) -> MessageHeader {
        MessageHeader::new(self.session_id, stream, seq, self.key)
    }

    /// Largest message several submessages may be packed into: the MTU, or 0 (one submessage per message)
    /// unless the client reads packed messages.
    pub fn pack_mtu(&self) -> usize {
        if self.pack_data {
            self.mtu
        } else {
            0
        }
    }

    /// Its dead time.
    pub fn dead_time(&self, default: Duration) -> Duration {
        self.hard_liveliness.unwrap_or(default)
    }

    /// Whether it has been silent longer than its dead time.
    pub fn is_dead(&self, now: Instant, default: Duration) -> bool {
        now.saturating_duration_since(self.last_heard) > self.dead_time(default)
    }

    /// Resets every stream (same-session CREATE_CLIENT, RESET).
    pub fn reset_streams(&mut self) {
        // Their counts stay in the client's totals.
        self.counters = self.counters_with_streams().into();
        self.streams = Streams::default();
        self.resume = None;
        self.blocked.clear();
        self.acks_due.clear();
    }

    /// The DELETE of the client itself it received, if any.
    pub(super) fn take_delete_request(&mut self) -> Option<(BaseObjectRequest, MessageHeader)> {
        self.delete_request.take()
    }

    // ---- timers ----

    /// The next instant [`Self::handle_timeout`] has work: the periodic turn, a tail-loss probe, a paced read.
    pub fn poll_timeout(&self) -> Option<Instant> {
        let probes = self.streams.rel_out.values().filter_map(ReliableOut::probe_due).min();
        let reads = self.reads.values().filter_map(ReadTask::wake_at).min();
        [self.timers.next_timeout(), probes, reads].into_iter().flatten().min()
    }

    /// Starts the periodic turn if it is not running.
    pub fn arm_heartbeat(&mut self, now: Instant, period: Duration) {
        self.timers.set_if_unset(Timer::Heartbeat, now + period);
    }

    /// Runs what is due: tail-loss probes, paced reads, then the periodic turn (HEARTBEATs of streams with messages in
    /// flight, back-pressure release of a dead or stalled reader, liveliness probes).
    pub(crate) fn handle_timeout<M: Middleware>(&mut self, ctx: &mut Ctx<'_, E, M>, now: Instant) -> Liveness {
        self.fire_probes(ctx, now);
        if self.reads.values().any(|t| t.wake_at().is_some_and(|t| t <= now)) {
            // A paced read may go on: its expired timers are forgotten whether or not a sample goes.
            for (_, task) in self.reads.iter_mut() {
                task.expire_timers(now);
            }
            self.pump_reads(ctx, now);
        }
        if self.timers.is_expired(Timer::Liveness, now) && self.liveness_turn(ctx, now) == Liveness::Remove {
            return Liveness::Remove;
        }
        if self.timers.take_expired(Timer::Heartbeat, now) {
            self.heartbeat_turn(ctx, now);
        }
        Liveness::Alive
    }

    fn fire_probes<M: Middleware>(&mut self, ctx: &mut Ctx<'_, E, M>, now: Instant) {
        let period = ctx.config.heartbeat_period;
        // Collected first: sending needs the connection, which the streams borrow. A stream re-arms its probe
        // itself when `fire_probe` says so.
        let beats: Vec<u8> = self
            .streams
            .rel_out
            .iter_mut()
            .filter_map(|(sid, out)| {
                let due = out.probe_due().filter(|due| *due <= now)?;
                out.fire_probe(*sid, due, now, period).0.map(|_| *sid)
            })
            .collect();
        for sid in beats {
            ctx.stats.tail_probes = ctx.stats.tail_probes.saturating_add(1);
            self.queue_heartbeat(ctx, sid);
        }
    }

    fn heartbeat_turn<M: Middleware>(&mut self, ctx: &mut Ctx<'_, E, M>, now: Instant) {
        let config = ctx.config;
        // Back-pressure bound: a reader that is dead, or alive but acknowledging nothing for the dead time,
        // stops holding its writers back.
        let stalled = self.streams.rel_out.iter_mut().map(|(_, s)| s.stalled_for(now)).max().unwrap_or_default();
        let dead = self.is_dead(now, config.client_dead_time);
        if self.unpinned.is_none()
            && (dead || stalled > config.client_dead_time)
            && self.reads.values().any(|t| t.stream.is_reliable())
        {
            self.unpinned = Some(if dead { Unpinned::Dead } else { Unpinned::Stalled });
            self.pin_readers(ctx, false);
        }
        self.trim_idle_buffers();
        // A dead client's streams too: what it has not acknowledged stays for retransmission, its empty
        // queues go.
        for (_, stream) in self.streams.rel_out.iter_mut() {
            stream.trim();
        }
        // A dead client gets liveness probes instead ([`liveness`](super::liveness)).
        if !dead {
            let beats: Vec<u8> =
                self.streams.rel_out.iter().filter_map(|(sid, stream)| stream.has_unacked().then_some(*sid)).collect();
            if !beats.is_empty() {
                self.timers.set(Timer::Heartbeat, now + config.heartbeat_period);
            }
            for sid in beats {
                self.queue_heartbeat(ctx, sid);
            }
        }
    }

    /// Frees the buffers of empty queues (outbox, ACKNACKs owed) on a heartbeat turn, the last turn a
    /// client gets before it goes idle: 10,000 idle clients then keep none. The streams trim themselves
    /// ([`ReliableOut::trim`]); a busy client refills its queues between turns, so this costs it an
    /// allocation per heartbeat period at most, never one per message.
    fn trim_idle_buffers(&mut self) {
        self.outbox.trim();
        if self.acks_due.is_empty() && self.acks_due.capacity() > 0 {
            self.acks_due = Vec::new();
        }
    }

    /// Tells the middleware whether this client's reliable readers hold writers back (see
    /// [`Middleware::write_credit`]): not while the client is dead or stalled, so a vanished subscriber
    /// stalls its publishers for the dead time at most.
    pub(crate) fn pin_readers<M: Middleware>(&mut self, ctx: &mut Ctx<'_, E, M>, pin: bool) {
        for (id, task) in self.reads.iter() {
            if task.stream.is_reliable() {
                ctx.middleware.set_reader_reliable(EntityRef::new(self.key, *id), pin);
            }
        }
        if !pin {
            tracing::info!(client = %self.key, "client dead or not acknowledging: its reliable readers no longer hold writers back");
            ctx.retry = true;
        }
    }

    // ---- output ----

    /// Queues a stream message; dropped (counted) when the client has no endpoint yet, or, the oldest
    /// (best effort), when its outbox is full.
    pub(crate) fn push_stream<M>(&mut self, ctx: &mut Ctx<'_, E, M>, data: Vec<u8>) {
        if self.endpoint.is_none() {
            ctx.stats.messages_dropped_out = ctx.stats.messages_dropped_out.saturating_add(1);
            ctx.pool.put(data);
            return;
        }
        if let Some(dropped) = self.outbox.push_stream(data, ctx.config.max_transmit_queue) {
            ctx.stats.messages_dropped_out = ctx.stats.messages_dropped_out.saturating_add(1);
            ctx.pool.put(dropped);
        }
        ctx.stats.messages_out = ctx.stats.messages_out.saturating_add(1);
    }

    /// Queues a control message on stream 0; dropped (counted) without an endpoint or past
    /// [`MAX_CONTROL_QUEUE`](super::outbox::MAX_CONTROL_QUEUE).
    pub(crate) fn push_control<M>(&mut self, ctx: &mut Ctx<'_, E, M>, item: Control) {
        let refused = if self.endpoint.is_none() { Err(item) } else { self.outbox.push_control(item) };
        match refused {
            Ok(()) => ctx.stats.messages_out = ctx.stats.messages_out.saturating_add(1),
            Err(item) => {
                ctx.stats.messages_dropped_out = ctx.stats.messages_dropped_out.saturating_add(1);
                if let Control::Message(data) = item {
                    ctx.pool.put(data);
                }
            }
        }
    }

    /// Encodes a one-submessage control message on stream 0 and queues it.
    pub(crate) fn send_control<M>(&mut self, ctx: &mut Ctx<'_, E, M>, sub: &Submessage<'_>) {
        let header = self.header(StreamId::NONE, 0);
        let mut buf = ctx.pool.get();
        if encode_into(&mut buf, &header, sub) {
            self.push_control(ctx, Control::Message(buf));
        } else {
            ctx.pool.put(buf);
        }
    }

    /// Queues a HEARTBEAT of reliable output stream `stream`, built with its range when sent.
    pub(crate) fn queue_heartbeat<M>(&mut self, ctx: &mut Ctx<'_, E, M>, stream: u8) {
        self.push_control(ctx, Control::Heartbeat(stream));
    }

    /// Writes its next control message into `buf` (replacing its content): intents are encoded now (a
    /// HEARTBEAT with its stream's range, skipped once all is acknowledged; a TIMESTAMP_REPLY with the
    /// transmit time). False when none waits.
    pub(crate) fn poll_control<M>(&mut self, ctx: &mut Ctx<'_, E, M>, now: Instant, buf: &mut Vec<u8>) -> bool {
        let header = self.header(StreamId::NONE, 0);
        while let Some(item) = self.outbox.pop_control() {
            let sub = match item {
                Control::Message(data) => {
                    ctx.pool.put(std::mem::replace(buf, data));
                    return true;
                }
                Control::Heartbeat(sid) => match self.streams.rel_out.get(&sid).and_then(|out| out.heartbeat(sid)) {
                    Some(hb) => Submessage::Heartbeat(hb),
                    None => continue,
                },
                Control::TimestampReply { originate, received } => Submessage::TimestampReply(TimestampReply {
                    transmit_timestamp: ctx.wall_time(now),
                    receive_timestamp: received,
                    originate_timestamp: originate,
                }),
            };
            if encode_into(buf, &header, &sub) {
                return true;
            }
        }
        false
    }

    /// Schedules an ACKNACK for a reliable input stream; a batch of messages costs one per stream.
    pub(crate) fn owe_acknack(&mut self, stream: StreamId) {
        if !self.acks_due.contains(&stream.0) {
            self.acks_due.push(stream.0);
        }
    }

    /// Writes the next ACKNACK owed into `buf`, built now from its stream's state; false when none is owed.
    pub(crate) fn write_acknack(&mut self, buf: &mut Vec<u8>) -> bool {
        while !self.acks_due.is_empty() {
            let stream = self.acks_due.remove(0);
            let Some(ack) = self.streams.rel_in.get(&stream).map(|s| s.acknack(stream)) else { continue };
            if encode_into(buf, &self.header(StreamId::NONE, 0), &Submessage::AckNack(ack)) {
                return true;
            }
        }
        false
    }

    /// Sends a STATUS reply on `stream`.
    pub(crate) fn send_status<M>(
        &mut self,
        ctx: &mut Ctx<'_, E, M>,
        stream: StreamId,
        request: BaseObjectRequest,
        status: StatusCode,
        now: Instant,
    ) {
        let reply = BaseObjectReply { related_request: request, result: ResultStatus::new(status) };
        let header_len = self.header(stream, 0).size();
        if let Some(sub) = encode_submessage(header_len, &Submessage::Status(reply)) {
            self.send_on_stream(ctx, stream, sub, now);
        }
    }

    /// Sends one submessage (header included) on an output stream: packed with the previous best-effort
    /// DATA when the client allows, queued on a reliable stream (fragmented past the MTU) and flushed as
    /// far as its window allows.
    pub(crate) fn send_on_stream<M>(&mut self, ctx: &mut Ctx<'_, E, M>, stream: StreamId, sub: Vec<u8>, now: Instant) {
        let header = self.header(stream, 0);
        let header_len = header.size();
        let fits = header_len + sub.len() <= self.mtu;
        let is_new = match stream.kind() {
            StreamKind::None => false,
            StreamKind::BestEffort => !self.streams.be_out.contains_key(&stream.0),
            StreamKind::Reliable => !self.streams.rel_out.contains_key(&stream.0),
        };
        if is_new && self.streams.count() >= ctx.config.max_streams_per_client {
            if let Some(held_back) = ctx.admit_warning(self.endpoint, now) {
                tracing::warn!(client = %self.key, stream = stream.0, held_back, "too many streams: message dropped");
            }
            ctx.pool.put(sub);
            return;
        }
        match stream.kind() {
            StreamKind::None | StreamKind::BestEffort => {
                if !fits {
                    tracing::debug!(client = %self.key, stream = stream.0, len = sub.len(), "message over the MTU on an unreliable stream dropped");
                    ctx.stats.messages_dropped_out = ctx.stats.messages_dropped_out.saturating_add(1);
                    ctx.pool.put(sub);
                    return;
                }
                // A DATA on a best-effort stream joins the client's newest message of that stream if it is
                // still queued and has room: one datagram for several samples.
                if self.pack_data && stream.kind() == StreamKind::BestEffort {
                    if let Some(last) = self.outbox.open_message(stream.0) {
                        let at = submessage_offset(last.len());
                        if at + sub.len() <= self.mtu {
                            last.resize(at, 0);
                            last.extend_from_slice(&sub);
                            ctx.pool.put(sub);
                            return;
                        }
                    }
                }
                let seq = if stream.kind() == StreamKind::None {
                    0
                } else {
                    self.streams.be_out.get_or_insert_with(stream.0, Default::default).next_seq()
                };
                let mut msg = ctx.pool.get();
                msg.resize(header_len, 0);
                if (MessageHeader { sequence_nr: seq, ..header }).encode(&mut msg).is_err() {
                    ctx.pool.put(msg);
                    ctx.pool.put(sub);
                    return;
                }
                msg.extend_from_slice(&sub);
                ctx.pool.put(sub);
                if stream.kind() == StreamKind::None {
                    self.push_control(ctx, Control::Message(msg));
                } else {
                    self.push_stream(ctx, msg);
                    self.outbox.leave_open(stream.0);
                }
            }
            StreamKind::Reliable => {
                let (window, max_pending) = (ctx.config.reliable_window, ctx.config.max_pending_per_stream);
                let out = self.streams.rel_out.get_or_insert_with(stream.0, || ReliableOut::new(window, max_pending));
                let queued = if fits {
                    out.queue_one(sub)
                } else {
                    out.queue_cut(sub, FragmentPlan::for_mtu(self.mtu, header_len))
                };
                if !queued {
                    if let Some(held_back) = ctx.admit_warning(self.endpoint, now) {
                        tracing::warn!(client = %self.key, stream = stream.0, held_back, "reliable output queue full: message dropped");
                    }
                    ctx.stats.messages_dropped_out = ctx.stats.messages_dropped_out.saturating_add(1);
                    return;
                }
                // Built into messages when the endpoint asks for this client's next one
                // ([`Self::next_stream_message`]), packed with whatever else waits by then.
                self.arm_heartbeat(now, ctx.config.heartbeat_period);
            }
        }
    }

    /// Whether it has stream messages to send: built ones (best effort, retransmissions) or reliable
    /// submessages its windows let it build.
    pub(crate) fn has_stream_work(&self) -> bool {
        self.outbox.has(Class::Stream) || self.streams.rel_out.values().any(ReliableOut::has_buildable)
    }

    /// Writes its next stream message into `buf` (replacing its content), in this order: a reliable
    /// stream's message built now (a retransmission due, else new submessages its window has room for,
    /// several per message when the client reads packed messages), then best-effort messages as delivered.
    /// False when none waits.
    pub(crate) fn poll_stream<M>(&mut self, ctx: &mut Ctx<'_, E, M>, now: Instant, buf: &mut Vec<u8>) -> bool {
        let (session_id, key, mtu, period) = (self.session_id, self.key, self.pack_mtu(), ctx.config.heartbeat_period);
        for (sid, out) in self.streams.rel_out.iter_mut() {
            if !out.has_buildable() {
                continue;
            }
            let header = MessageHeader::new(session_id, StreamId(*sid), 0, key);
            if out.build_next(&header, mtu, now, ctx.pool, buf) {
                let _ = out.arm_probe(now, period);
                ctx.stats.messages_out = ctx.stats.messages_out.saturating_add(1);
                return true;
            }
        }
        match self.outbox.pop_stream() {
            Some(data) => {
                ctx.pool.put(std::mem::replace(buf, data));
                true
            }
            None => false,
        }
    }

    /// An ACKNACK for one of its reliable output streams: schedules what it asks for again (retransmissions,
    /// like new messages the window now allows, are built when the endpoint asks for the client's next
    /// message); pins its readers again once it acknowledges something after a stall.
    pub(crate) fn handle_acknack<M: Middleware>(
        &mut self,
        ctx: &mut Ctx<'_, E, M>,
        ack: &xrce_proto::submessage::AckNack,
        now: Instant,
    ) {
        let period = ctx.config.heartbeat_period;
        let Some(out) = self.streams.rel_out.get_mut(&ack.stream_id) else { return };
        let before = out.first_unacked();
        out.on_acknack(ack, now, period, ctx.pool);
        let progressed = out.first_unacked() != before;
        let _ = out.arm_probe(now, period);
        if progressed && self.unpinned.take().is_some() {
            self.pin_readers(ctx, true);
        }
    }

    /// Deletes everything it holds from the middleware (children first, so callbacks see each).
    pub(crate) fn release<M: Middleware>(&mut self, middleware: &mut M) {
        for (reader, _) in self.reads.drain() {
            middleware.stop_reading(EntityRef::new(self.key, reader));
        }
        for root in self.objects.roots() {
            for id in self.objects.subtree(root) {
                if let Err(e) = middleware.delete(EntityRef::new(self.key, id)) {
                    tracing::debug!(client = %self.key, %id, "middleware delete failed: {e}");
                }
                self.objects.remove(id);
            }
        }
        middleware.delete_client(self.key);
    }
}
