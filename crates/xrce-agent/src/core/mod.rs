//! The sans-IO agent core: datagrams in, datagrams out, middleware calls on the side.
//!
//! The shell (UDP, TCP, a test) feeds every received message with [`AgentCore::handle_datagram`], calls
//! [`AgentCore::handle_timeout`] when [`AgentCore::poll_timeout`] says so, and sends what
//! [`AgentCore::poll_transmit`] yields. The core never reads a clock or touches a socket: `now` comes from the
//! shell, and wall-clock time (TIMESTAMP_REPLY) from the anchor set with [`AgentCore::set_wall_clock`].
//! `E` is whatever identifies a peer for the shell (a socket address, a connection id).

pub mod config;
pub mod droplog;
pub mod object;
pub mod probe;
pub mod read;
pub mod session;
pub mod stream;
pub mod vecmap;

mod outbox;
mod process;
#[cfg(test)]
mod tests;

use std::collections::{HashMap, VecDeque};
use std::fmt::Debug;
use std::hash::Hash;
use std::time::{Duration, Instant};

use xrce_proto::{ClientKey, MessageHeader, ObjectId, StatusCode};

pub use config::CoreConfig;
use session::ProxyClient;

use crate::middleware::{EntityRef, Middleware};

/// Samples written within one receive batch before readers are served anyway (see
/// [`AgentCore::handle_datagram`]): under the 16 samples a CED topic keeps for best-effort readers, and above
/// a publisher's usual window of 8, whose ACKNACK then leaves before its samples are delivered (8 here cost
/// ~10 % of reliable 16 B throughput: interleaved runs, 12 won 6 of 8 pairs).
pub const PUMP_AFTER_WRITES: usize = 12;

/// A message for the shell to send.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Transmit<E> {
    /// Destination.
    pub to: E,
    /// One complete XRCE message.
    pub data: Vec<u8>,
}

/// Counters for diagnostics; all saturate.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct CoreStats {
    /// Datagrams handed to the core.
    pub datagrams_in: u64,
    /// Datagrams dropped whole (undecodable header, unknown client, out-of-window, ...).
    pub datagrams_dropped: u64,
    /// Submessages that failed to decode.
    pub decode_errors: u64,
    /// Messages queued for sending.
    pub messages_out: u64,
    /// Outgoing messages dropped (transmit queue full, too large for the MTU on a best-effort stream).
    pub messages_dropped_out: u64,
    /// Times the shell polled the middleware after its waker fired ([`AgentCore::poll_middleware`]).
    pub middleware_polls: u64,
    /// Tail-loss probes sent: HEARTBEATs ahead of the period ([`probe`]).
    pub tail_probes: u64,
    /// Samples from best-effort streams the middleware could not take (a full DDS history), dropped.
    pub samples_dropped_in: u64,
}

/// The agent core. See the module documentation.
pub struct AgentCore<E, M> {
    config: CoreConfig,
    middleware: M,
    /// Boxed: the table's spare capacity then costs a pointer per slot, not a whole client.
    clients: HashMap<ClientKey, Box<ProxyClient<E>>>,
    by_endpoint: HashMap<E, ClientKey>,
    /// Replies to peers outside any session (STATUS_AGENT, INFO, the STATUS of a deleted client).
    stateless: VecDeque<Transmit<E>>,
    /// Clients with messages waiting, per class, in turn order ([`outbox`]).
    turns: outbox::TurnLists,
    /// Recycled message buffers (see [`Self::recycle`]).
    pool: stream::BufPool,
    /// Reused list of messages produced while a client is borrowed.
    scratch: Vec<Vec<u8>>,
    heartbeat_due: Option<Instant>,
    /// Tail-loss probe timers of the reliable output streams.
    /// Rate limit of the warnings about bad input, per peer.
    drop_log: droplog::DropLog<E>,
    probes: probe::ProbeTimers,
    pump_needed: bool,
    /// Datagrams were handled since the last pump: samples are delivered (and held-back input retried) once
    /// per batch, by the next [`Self::poll_transmit`], so one message can carry several samples.
    pump_deferred: bool,
    /// Samples written since the last pump: past [`PUMP_AFTER_WRITES`] the pump runs within the batch, so a
    /// best-effort reader (whose CED topic keeps 16 samples) loses nothing to a long batch.
    writes_since_pump: usize,
    /// Reliable input streams holding a message back until the middleware can take its writes.
    blocked: Vec<(ClientKey, xrce_proto::StreamId)>,
    /// Reliable input streams owed an ACKNACK (sent, coalesced, by [`Self::poll_transmit`]).
    acks_due: Vec<(ClientKey, xrce_proto::StreamId)>,
    /// Set while a read task is pumped: reliable DATA waits to be packed.
    pumping: bool,
    /// Clients that may have read tasks (cleaned lazily by the pump).
    reading: Vec<ClientKey>,
    /// Reused list of reader ids while pumping.
    scratch_ids: Vec<ObjectId>,
    wall_anchor: Option<(Instant, Duration)>,
    last_now: Option<Instant>,
    stats: CoreStats,
}

impl<E: Debug, M> Debug for AgentCore<E, M> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("AgentCore")
            .field("clients", &self.clients.len())
            .field("stateless", &self.stateless.len())
            .field("stats", &self.stats)
            .finish_non_exhaustive()
    }
}

impl<E, M> AgentCore<E, M>
where
    E: Copy + Eq + Hash + Debug,
    M: Middleware,
{
    /// A core with no clients.
    pub fn new(config: CoreConfig, middleware: M) -> Self {
        Self {
            config,
            middleware,
            clients: HashMap::new(),
            by_endpoint: HashMap::new(),
            stateless: VecDeque::new(),
            turns: outbox::TurnLists::default(),
            pool: stream::BufPool::default(),
            scratch: Vec::new(),
            heartbeat_due: None,
            probes: probe::ProbeTimers::default(),
            drop_log: droplog::DropLog::default(),
            pump_needed: false,
            pump_deferred: false,
            writes_since_pump: 0,
            blocked: Vec::new(),
            acks_due: Vec::new(),
            pumping: false,
            reading: Vec::new(),
            scratch_ids: Vec::new(),
            wall_anchor: None,
            last_now: None,
            stats: CoreStats::default(),
        }
    }

    /// Ties `now` to a wall-clock time (duration since the Unix epoch) for TIMESTAMP_REPLY. Without it the
    /// core answers with times counted from the first instant it saw.
    pub fn set_wall_clock(&mut self, now: Instant, since_epoch: Duration) {
        self.wall_anchor = Some((now, since_epoch));
    }

    /// The configuration.
    pub fn config(&self) -> &CoreConfig {
        &self.config
    }

    /// The middleware.
    pub fn middleware(&self) -> &M {
        &self.middleware
    }

    /// The middleware, mutably.
    pub fn middleware_mut(&mut self) -> &mut M {
        &mut self.middleware
    }

    /// Diagnostics counters.
    pub fn stats(&self) -> CoreStats {
        self.stats
    }

    /// Keys of the registered clients.
    pub fn client_keys(&self) -> Vec<ClientKey> {
        self.clients.keys().copied().collect()
    }

    /// Whether `key` is registered.
    pub fn has_client(&self, key: ClientKey) -> bool {
        self.clients.contains_key(&key)
    }

    /// Whether `key` has object `id`.
    pub fn has_object(&self, key: ClientKey, id: ObjectId) -> bool {
        self.clients.get(&key).is_some_and(|c| c.objects.contains(id))
    }

    /// Handles one received message from `from`. Its samples reach readers at the end of the batch (the next
    /// [`Self::poll_transmit`] or [`Self::end_batch`]), so several can share one message, or sooner once
    /// [`PUMP_AFTER_WRITES`] samples wait.
    pub fn handle_datagram(&mut self, from: E, bytes: &[u8], now: Instant) {
        self.stats.datagrams_in = self.stats.datagrams_in.saturating_add(1);
        if self.wall_anchor.is_none() {
            self.wall_anchor = Some((now, Duration::ZERO));
        }
        self.last_now = Some(now);
        self.process_datagram(from, bytes, now);
        self.pump_deferred = true;
        if self.writes_since_pump >= PUMP_AFTER_WRITES {
            self.pump_and_retry(now);
        }
    }

    /// Runs the delivery deferred by [`Self::handle_datagram`] (also done by [`Self::poll_transmit`]).
    pub fn end_batch(&mut self) {
        if std::mem::take(&mut self.pump_deferred) {
            if let Some(now) = self.last_now {
                self.pump_and_retry(now);
            }
        }
    }

    /// Delivers samples, then retries held-back reliable input streams while that makes progress.
    fn pump_and_retry(&mut self, now: Instant) {
        self.pump_deferred = false;
        self.writes_since_pump = 0;
        for _ in 0..4 {
            if self.pump_needed {
                self.pump_reads(now);
            }
            if self.blocked.is_empty() {
                break;
            }
            self.retry_blocked(now);
            if !self.pump_needed {
                break;
            }
        }
    }

    /// The next instant [`Self::handle_timeout`] must be called, if any.
    pub fn poll_timeout(&self) -> Option<Instant> {
        let reads = self
            .reading
            .iter()
            .filter_map(|k| self.clients.get(k))
            .flat_map(|c| c.reads.values())
            .filter_map(read::ReadTask::wake_at)
            .min();
        [self.heartbeat_due, self.probes.next_due(), reads].into_iter().flatten().min()
    }

    /// Runs timers: heartbeats, liveliness probes, removal of dead clients, paced reads.
    pub fn handle_timeout(&mut self, now: Instant) {
        self.last_now = Some(now);
        if self.heartbeat_due.is_some_and(|due| now >= due) {
            self.heartbeat_due = None;
            self.heartbeat_tick(now);
        }
        self.fire_probes(now);
        self.middleware.poll(now);
        self.pump_needed = true;
        self.pump_and_retry(now);
    }

    /// Polls the readers of active read tasks; call it when an asynchronous middleware's waker fired.
    pub fn poll_middleware(&mut self, now: Instant) {
        self.stats.middleware_polls = self.stats.middleware_polls.saturating_add(1);
        self.middleware.poll(now);
        self.pump_needed = true;
        self.pump_and_retry(now);
    }

    /// The ACKNACKs owed for the reliable messages handled so far, one at a time, before the batch's samples
    /// are delivered: a shell can send them ahead of the rest, so a publisher whose history is full gets its
    /// slots back without waiting for the deliveries to be built.
    pub fn poll_acknack(&mut self) -> Option<Transmit<E>> {
        self.next_acknack()
    }

    /// The next message to send, in this order: ACKNACKs owed, replies outside a session, clients' control
    /// messages, clients' stream messages, one per client in turn ([`outbox`]).
    pub fn poll_transmit(&mut self) -> Option<Transmit<E>> {
        self.end_batch();
        if let Some(t) = self.next_acknack() {
            return Some(t);
        }
        if let Some(t) = self.stateless.pop_front() {
            return Some(t);
        }
        for class in [outbox::Class::Control, outbox::Class::Stream] {
            while let Some((client, data)) = self.turns.next(class, &mut self.clients, client_outbox) {
                match client.endpoint {
                    Some(to) => return Some(Transmit { to, data }),
                    None => self.pool.put(data),
                }
            }
        }
        None
    }

    /// An ACKNACK owed, built now from its input stream's state (so a batch of messages from a client costs
    /// it one ACKNACK per stream, with the latest state).
    fn next_acknack(&mut self) -> Option<Transmit<E>> {
        while !self.acks_due.is_empty() {
            let (key, stream) = self.acks_due.remove(0);
            let Some(client) = self.clients.get(&key) else { continue };
            let Some(ack) = client.streams.rel_in.get(&stream.0).map(|s| s.acknack(stream.0)) else { continue };
            let Some(to) = client.endpoint else { continue };
            let header = client.header(xrce_proto::StreamId::NONE, 0);
            let mut buf = self.pool.get();
            if encode_into(&mut buf, &header, &xrce_proto::Submessage::AckNack(ack)) {
                self.stats.messages_out = self.stats.messages_out.saturating_add(1);
                return Some(Transmit { to, data: buf });
            }
            self.pool.put(buf);
        }
        None
    }

    /// Gives the buffer of a sent [`Transmit`] back for reuse (optional; saves an allocation per message).
    pub fn recycle(&mut self, data: Vec<u8>) {
        self.pool.put(data);
    }

    /// Number of messages waiting in [`Self::poll_transmit`] (at least one while a batch awaits delivery).
    pub fn pending_transmits(&self) -> usize {
        let queued: usize = self.clients.values().map(|c| c.outbox.len()).sum();
        queued + self.stateless.len() + self.acks_due.len() + usize::from(self.pump_deferred)
    }

    /// Creates or refreshes a client without a CREATE_CLIENT message (library API; eProsima's
    /// `create_client`). Its endpoint is learned from its first message.
    pub fn create_client(&mut self, key: ClientKey, session_id: u8, mtu: u16, now: Instant) -> StatusCode {
        self.register_client(None, key, session_id, mtu, None, now)
    }

    /// Forgets a transport endpoint (a closed TCP connection): clients bound to it keep their entities but
    /// get no traffic until they send again from a new endpoint.
    pub fn forget_endpoint(&mut self, endpoint: E) {
        self.by_endpoint.remove(&endpoint);
        for client in self.clients.values_mut() {
            if client.endpoint == Some(endpoint) {
                client.endpoint = None;
                client.outbox.clear();
            }
        }
        self.stateless.retain(|t| t.to != endpoint);
    }

    /// Deletes a client and all its entities.
    pub fn delete_client(&mut self, key: ClientKey) -> StatusCode {
        if self.remove_client(key) {
            StatusCode::OK
        } else {
            StatusCode::ERR_UNKNOWN_REFERENCE
        }
    }

    /// Deletes every client (eProsima's `Agent::reset`).
    pub fn reset(&mut self) {
        for key in self.client_keys() {
            self.remove_client(key);
        }
        self.stateless.clear();
        self.turns.clear();
    }

    /// Creates an entity for a client as a CREATE would (library API).
    pub fn create_entity(
        &mut self,
        key: ClientKey,
        id: ObjectId,
        variant: &xrce_proto::EntityVariant<'_>,
        mode: xrce_proto::submessage::CreationMode,
        now: Instant,
    ) -> StatusCode {
        if !self.clients.contains_key(&key) {
            return StatusCode::ERR_UNKNOWN_REFERENCE;
        }
        self.pump_needed = true;
        self.create_object(key, id, variant, mode, xrce_proto::Endianness::Little, now)
    }

    /// Deletes an entity and its children (library API).
    pub fn delete_entity(&mut self, key: ClientKey, id: ObjectId) -> StatusCode {
        self.delete_object(key, id)
    }

    // ---- internals shared by the submodules ----

    /// Queues a reply to a peer outside any session; beyond the transmit bound the newest is dropped.
    fn push_stateless(&mut self, to: E, data: Vec<u8>) {
        if self.stateless.len() >= self.config.max_transmit_queue {
            self.stats.messages_dropped_out = self.stats.messages_dropped_out.saturating_add(1);
            return;
        }
        self.stats.messages_out = self.stats.messages_out.saturating_add(1);
        self.stateless.push_back(Transmit { to, data });
    }

    /// Queues a message for a client; dropped when the client has no endpoint yet, or (the oldest stream
    /// message, which a reliable stream retransmits) when its outbox is full.
    fn push_client(&mut self, key: ClientKey, class: outbox::Class, data: Vec<u8>) {
        let max = self.config.max_transmit_queue;
        let Some(client) = self.clients.get_mut(&key).filter(|c| c.endpoint.is_some()) else {
            self.stats.messages_dropped_out = self.stats.messages_dropped_out.saturating_add(1);
            self.pool.put(data);
            return;
        };
        if let Some(dropped) = client.outbox.push(class, data, max) {
            self.stats.messages_dropped_out = self.stats.messages_dropped_out.saturating_add(1);
            self.pool.put(dropped);
        }
        self.stats.messages_out = self.stats.messages_out.saturating_add(1);
        self.turns.enlist(key, &mut client.outbox, class);
    }

    fn wall_time(&self, now: Instant) -> xrce_proto::Time {
        let (at, since_epoch) = self.wall_anchor.unwrap_or((now, Duration::ZERO));
        let t = if now >= at { since_epoch.saturating_add(now - at) } else { since_epoch.saturating_sub(at - now) };
        xrce_proto::Time { seconds: i32::try_from(t.as_secs()).unwrap_or(i32::MAX), nanoseconds: t.subsec_nanos() }
    }

    /// Sends the tail-loss probes that are due (see [`probe`]).
    fn fire_probes(&mut self, now: Instant) {
        let period = self.config.heartbeat_period;
        while let Some((due, key, sid)) = self.probes.pop_due(now) {
            let Some(out) = self.clients.get_mut(&key).and_then(|c| c.streams.rel_out.get_mut(&sid)) else { continue };
            let (beat, next) = out.fire_probe(sid, due, now, period);
            if let Some(next) = next {
                self.probes.push(next, key, sid);
            }
            if let Some(hb) = beat {
                self.stats.tail_probes = self.stats.tail_probes.saturating_add(1);
                self.send_control(key, &xrce_proto::Submessage::Heartbeat(hb));
            }
        }
    }

    /// Schedules a tail-loss probe a stream has just armed ([`stream::ReliableOut::arm_probe`]).
    fn schedule_probe(&mut self, due: Option<Instant>, key: ClientKey, sid: u8) {
        let Some(due) = due else { return };
        self.probes.push(due, key, sid);
        if self.probes.len() > 4 * self.clients.len() + 1024 {
            let clients = &self.clients;
            self.probes.retain(|due, key, sid| {
                clients.get(&key).and_then(|c| c.streams.rel_out.get(&sid)).and_then(|o| o.probe_due()) == Some(due)
            });
        }
    }

    fn arm_heartbeat(&mut self, now: Instant) {
        if self.heartbeat_due.is_none() {
            self.heartbeat_due = Some(now + self.config.heartbeat_period);
        }
    }

    /// Removes a client: its entities (children first, so middleware callbacks see each), its read tasks, its
    /// endpoint binding.
    fn remove_client(&mut self, key: ClientKey) -> bool {
        let Some(mut client) = self.clients.remove(&key) else { return false };
        for (reader, _) in client.reads.drain() {
            self.middleware.stop_reading(EntityRef::new(key, reader));
        }
        for root in client.objects.roots() {
            for id in client.objects.subtree(root) {
                if let Err(e) = self.middleware.delete(EntityRef::new(key, id)) {
                    tracing::debug!(client = %key, %id, "middleware delete failed: {e}");
                }
                client.objects.remove(id);
            }
        }
        self.middleware.delete_client(key);
        if let Some(ep) = client.endpoint {
            if self.by_endpoint.get(&ep) == Some(&key) {
                self.by_endpoint.remove(&ep);
            }
        }
        tracing::info!(client = %key, "client removed");
        true
    }

    fn heartbeat_tick(&mut self, now: Instant) {
        let dead_time = self.config.client_dead_time;
        let mut remove = Vec::new();
        let mut probe = Vec::new();
        let mut beats = Vec::new();
        let mut unpin = Vec::new();
        let mut again = false;
        for (key, client) in &mut self.clients {
            let silent = now.saturating_duration_since(client.last_heard);
            if self.config.remove_silent_clients_after.is_some_and(|limit| silent > limit) {
                remove.push(*key);
                continue;
            }
            // Back-pressure bound: a reader that is dead, or alive but acknowledging nothing for the dead time,
            // stops holding its writers back.
            let stalled = client.streams.rel_out.iter_mut().map(|(_, s)| s.stalled_for(now)).max().unwrap_or_default();
            let dead = client.is_dead(now, dead_time);
            if client.unpinned.is_none()
                && (dead || stalled > dead_time)
                && client.reads.values().any(|t| t.stream.is_reliable())
            {
                client.unpinned = Some(if dead { session::Unpinned::Dead } else { session::Unpinned::Stalled });
                unpin.push(*key);
            }
            if dead {
                if client.hard_liveliness.is_some() {
                    if client.probes >= self.config.max_liveliness_probes {
                        remove.push(*key);
                    } else {
                        client.probes += 1;
                        probe.push(*key);
                        again = true;
                    }
                }
                continue;
            }
            if client.hard_liveliness.is_some() || self.config.remove_silent_clients_after.is_some() {
                again = true;
            }
            for (sid, stream) in client.streams.rel_out.iter_mut() {
                stream.trim();
                if let Some(hb) = stream.heartbeat(*sid) {
                    beats.push((*key, hb));
                    again = true;
                }
            }
        }
        for key in unpin {
            self.pin_readers(key, false);
        }
        for key in remove {
            tracing::info!(client = %key, "client dead, removing");
            self.remove_client(key);
        }
        for key in probe {
            let probe = xrce_proto::submessage::GetInfo {
                request: xrce_proto::BaseObjectRequest {
                    request_id: xrce_proto::RequestId(0),
                    object_id: ObjectId::CLIENT,
                },
                info_mask: 0,
            };
            self.send_control(key, &xrce_proto::Submessage::GetInfo(probe));
        }
        for (key, hb) in beats {
            self.send_control(key, &xrce_proto::Submessage::Heartbeat(hb));
        }
        if again {
            self.heartbeat_due = Some(now + self.config.heartbeat_period);
        }
    }

    /// Encodes a one-submessage control message on stream 0 to a client.
    fn send_control(&mut self, key: ClientKey, sub: &xrce_proto::Submessage<'_>) {
        let Some(client) = self.clients.get(&key) else { return };
        let header = client.header(xrce_proto::StreamId::NONE, 0);
        let mut buf = self.pool.get();
        if encode_into(&mut buf, &header, sub) {
            self.push_client(key, outbox::Class::Control, buf);
        } else {
            self.pool.put(buf);
        }
    }
}

/// The outbox of a client, for [`outbox::TurnLists::next`].
fn client_outbox<E>(client: &mut Box<ProxyClient<E>>) -> &mut outbox::Outbox {
    &mut client.outbox
}

/// Encodes `header` + one submessage.
fn encode_message(header: &MessageHeader, sub: &xrce_proto::Submessage<'_>) -> Option<Vec<u8>> {
    let mut buf = Vec::new();
    encode_into(&mut buf, header, sub).then_some(buf)
}

/// Encodes `header` + one submessage into `buf` (replacing its content); false when it cannot be encoded.
fn encode_into(buf: &mut Vec<u8>, header: &MessageHeader, sub: &xrce_proto::Submessage<'_>) -> bool {
    buf.clear();
    buf.resize(buf.capacity().clamp(64, 256), 0);
    let n = match xrce_proto::message::encode_single(buf, header, sub, xrce_proto::Endianness::Little) {
        Ok(n) => n,
        Err(xrce_proto::cdr::Error::BufferTooSmall { needed }) if needed <= 65_535 + 8 => {
            buf.resize(needed, 0);
            match xrce_proto::message::encode_single(buf, header, sub, xrce_proto::Endianness::Little) {
                Ok(n) => n,
                Err(_) => return false,
            }
        }
        Err(e) => {
            tracing::warn!("cannot encode {}: {e}", sub.id());
            return false;
        }
    };
    buf.truncate(n);
    true
}

/// Encodes one submessage (header included) as it would sit after a message header of `header_len` bytes.
fn encode_submessage(header_len: usize, sub: &xrce_proto::Submessage<'_>) -> Option<Vec<u8>> {
    let header = MessageHeader::new(
        if header_len == 8 { 0x01 } else { 0x81 },
        xrce_proto::StreamId::NONE,
        0,
        ClientKey::INVALID,
    );
    let mut msg = encode_message(&header, sub)?;
    Some(msg.split_off(header_len))
}
