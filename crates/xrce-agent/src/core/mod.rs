//! The sans-IO agent core: datagrams in, datagrams out, middleware calls on the side.
//!
//! Shaped like quinn-proto's `Endpoint` and `Connection`: [`AgentCore`] is the endpoint (the client table,
//! routing by key or address, CREATE_CLIENT, the turn order of outgoing messages, the timer queue); each
//! proxy client is a [`connection::Connection`], a state machine that handles its messages, keeps its own
//! timers and queues what it has to send.
//!
//! The shell (UDP, TCP, serial, a test) feeds every received message with [`AgentCore::handle_datagram`],
//! calls [`AgentCore::handle_timeout`] when [`AgentCore::poll_timeout`] says so, and sends what
//! [`AgentCore::poll_transmit`] yields. The core never reads a clock or touches a socket: `now` comes from
//! the shell, and wall-clock time (TIMESTAMP_REPLY) from the anchor set with [`AgentCore::set_wall_clock`].
//! `E` is whatever identifies a peer for the shell (a socket address, a connection id).

mod auth;
mod clients;
mod config;
mod connection;
mod deliver;
mod droplog;
mod entities;
mod input;
mod liveness;
mod object;
mod outbox;
mod probe;
mod read;
mod session;
mod snapshot;
mod stats;
mod stream;
mod timer;
mod vecmap;

#[cfg(test)]
mod ghost_tests;
#[cfg(test)]
mod snapshot_tests;
#[cfg(test)]
mod tests;

use std::cmp::Reverse;
use std::collections::{BinaryHeap, VecDeque};

use foldhash::{HashMap, HashMapExt};
use std::fmt::Debug;
use std::hash::Hash;
use std::time::{Duration, Instant};

use xrce_proto::layout;
use xrce_proto::{ClientKey, MessageHeader, ObjectId, StatusCode};

pub use auth::{AddressMatch, AllowRule, AllowRuleError, AuthPolicy};
pub use config::{
    CoreConfig, DEFAULT_CLIENT_DEAD_TIME, DEFAULT_CLIENT_TIMEOUT, DEFAULT_HEARTBEAT_PERIOD, DEFAULT_MAX_CLIENTS,
    DEFAULT_MAX_LIVELINESS_PROBES, DEFAULT_RELIABLE_WINDOW, DEFAULT_SUSPECT_GRACE,
};
use connection::{Connection, Ctx, Liveness};
use probe::TimerTick;
pub use snapshot::{
    AgentSnapshot, ClientSnapshot, EntityCounts, SnapshotBoard, StreamSnapshot, MAX_CLIENT_SERIES, MAX_CLIENT_STATUSES,
};
pub use stats::{ClientCounters, CoreStats, DatagramDrops, DropReason, RemoveReason};

use crate::bufpool::BufPool;
use crate::middleware::Middleware;

/// Samples written within one receive batch before readers are served anyway (see
/// [`AgentCore::handle_datagram`]): under the 16 samples a CED topic keeps for best-effort readers, and above
/// a publisher's usual window of 8, whose ACKNACK then leaves before its samples are delivered (8 here cost
/// ~10 % of reliable 16 B throughput: interleaved runs, 12 won 6 of 8 pairs).
const PUMP_AFTER_WRITES: usize = 12;

/// A message and where it goes: what a shell sends (and the core's replies outside a session, queued).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Transmit<E> {
    /// Destination.
    pub to: E,
    /// One complete XRCE message.
    pub data: Vec<u8>,
}

/// The context a connection runs in, borrowed field by field from the endpoint `$core` (so the client table
/// stays free to borrow alongside).
macro_rules! endpoint_ctx {
    ($core:ident) => {
        Ctx {
            middleware: &mut $core.middleware,
            config: &$core.config,
            stats: &mut $core.stats,
            pool: &mut $core.pool,
            drop_log: &mut $core.drop_log,
            wall_anchor: $core.wall_anchor,
            writes: 0,
            retry: false,
        }
    };
}

/// The agent core. See the module documentation.
pub struct AgentCore<E, M> {
    config: CoreConfig,
    middleware: M,
    /// Boxed: the table's spare capacity then costs a pointer per slot, not a whole client.
    clients: HashMap<ClientKey, Box<Connection<E>>>,
    by_endpoint: HashMap<E, ClientKey>,
    /// Replies to peers outside any session (STATUS_AGENT, INFO, the STATUS of a deleted client).
    stateless: VecDeque<Transmit<E>>,
    /// Clients with messages waiting, per class, in turn order ([`outbox`]).
    turns: outbox::TurnLists,
    /// Clients owing ACKNACKs, in turn order.
    acking: VecDeque<ClientKey>,
    /// Each client's next timer, earliest first; an entry that no longer matches its client's is stale.
    /// Instants as [`TimerTick`]s: 16 B an entry instead of 24.
    timers: BinaryHeap<Reverse<(TimerTick, ClientKey)>>,
    /// Clients with read tasks, whose readers the middleware may have samples for.
    reading: Vec<ClientKey>,
    /// Clients with reliable input held back until the middleware can take its writes.
    blocked: Vec<ClientKey>,
    /// Samples written since readers were last served: they are served once per batch of datagrams (so
    /// one message carries several samples), or within it past [`PUMP_AFTER_WRITES`]; `None` when nothing
    /// waits for delivery.
    unserved_writes: Option<usize>,
    /// Recycled message buffers (see [`Self::recycle`]).
    pool: BufPool,
    /// Rate limit of the warnings about bad input, per peer.
    drop_log: droplog::DropLog<E>,
    wall_anchor: Option<(Instant, Duration)>,
    last_now: Option<Instant>,
    stats: CoreStats,
    /// Client authentication state ([`auth`]).
    auth: auth::Gate<E>,
    /// The clients each endpoint created ([`liveness`]).
    created_from: liveness::CreatedFrom<E>,
    /// The transport's name in snapshots ([`Self::set_transport_name`]).
    transport_name: &'static str,
    /// A client's own transport in snapshots, from its endpoint ([`Self::set_endpoint_transport`]).
    endpoint_transport: Option<fn(&E) -> &'static str>,
    /// Where snapshots are published, and how often ([`Self::publish_snapshots`]).
    publisher: Option<snapshot::Publisher>,
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
            acking: VecDeque::new(),
            timers: BinaryHeap::new(),
            reading: Vec::new(),
            blocked: Vec::new(),
            unserved_writes: None,
            pool: BufPool::default(),
            drop_log: droplog::DropLog::default(),
            wall_anchor: None,
            last_now: None,
            stats: CoreStats::default(),
            auth: auth::Gate::default(),
            created_from: liveness::CreatedFrom::default(),
            transport_name: "custom",
            endpoint_transport: None,
            publisher: None,
        }
    }

    /// Names the transport its clients use in snapshots (`udp4`, `tcp4`, `serial`, ...).
    pub fn set_transport_name(&mut self, name: &'static str) {
        self.transport_name = name;
    }

    /// Names each client's transport in snapshots from its endpoint, for a core serving several transports
    /// at once; without it every client has the core's ([`Self::set_transport_name`]).
    pub fn set_endpoint_transport(&mut self, name_of: fn(&E) -> &'static str) {
        self.endpoint_transport = Some(name_of);
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

    /// Objects (participants, topics, ... ) the clients hold, all clients together.
    pub fn object_count(&self) -> usize {
        self.clients.values().map(|c| c.objects.len()).sum()
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
    /// [`Self::poll_transmit`]), so several can share one message, or sooner once a dozen samples wait
    /// (`PUMP_AFTER_WRITES`).
    pub fn handle_datagram(&mut self, from: E, bytes: &[u8], now: Instant) {
        self.stats.datagrams_in = self.stats.datagrams_in.saturating_add(1);
        if self.wall_anchor.is_none() {
            self.wall_anchor = Some((now, Duration::ZERO));
        }
        self.last_now = Some(now);
        self.route_datagram(from, bytes, now);
        if self.unserved_writes.is_some_and(|n| n >= PUMP_AFTER_WRITES) {
            self.serve_readers(now);
        }
    }

    /// Runs the delivery deferred by [`Self::handle_datagram`] (done first by [`Self::poll_transmit`]).
    fn end_batch(&mut self) {
        if let (Some(_), Some(now)) = (self.unserved_writes, self.last_now) {
            self.serve_readers(now);
        }
    }

    /// The next instant [`Self::handle_timeout`] must be called, if any (work the middleware put off until
    /// [`Self::after_send`] counts as due).
    pub fn poll_timeout(&self) -> Option<Instant> {
        let timer = self.timers.peek().map(|Reverse((due, _))| due.instant());
        let publish = self.publisher.as_ref().map(|p| p.next);
        [timer, self.middleware.flush_due(), publish].into_iter().flatten().min()
    }

    /// Call once the messages taken from [`Self::poll_transmit`] are sent: the middleware does the work it
    /// put off so that it would not delay them (the DDS middleware's DDS writes of samples that went ahead to
    /// the agent's own readers). Samples this delivers wake the middleware's waker as usual.
    pub fn after_send(&mut self, now: Instant) {
        self.middleware.flush(now);
    }

    /// Runs the clients' timers that are due (heartbeats, liveliness, tail-loss probes, paced reads) and the
    /// middleware's pending work.
    pub fn handle_timeout(&mut self, now: Instant) {
        self.last_now = Some(now);
        // The clients due now, each run once per call (a timer it re-arms at or before `now` waits for the
        // next call, so a turn cannot loop).
        let mut due_now = Vec::new();
        while let Some(Reverse((due, key))) = self.timers.peek().copied() {
            if due.instant() > now {
                break;
            }
            self.timers.pop();
            let Some(client) = self.clients.get_mut(&key) else { continue };
            if !due.matches(client.timer_queued) {
                continue; // stale: an earlier entry was queued for this client since
            }
            client.timer_queued = None;
            due_now.push(key);
        }
        for key in due_now {
            let (mut ctx, client) = self.ctx_for(key);
            let Some(client) = client else { continue };
            if client.poll_timeout().is_none_or(|t| t > now) {
                // The client's timer moved later since: queue it at its new instant.
                self.schedule(key);
                continue;
            }
            let liveness = client.handle_timeout(&mut ctx, now);
            let retry = ctx.retry;
            if liveness == Liveness::Remove {
                tracing::info!(client = %key, "client dead, removing");
                self.remove_client(key, RemoveReason::Timeout);
                continue;
            }
            self.after_turn(key, retry);
        }
        if self.middleware.flush_due().is_some_and(|due| due <= now) {
            // The shell did not call `after_send`.
            self.middleware.flush(now);
        }
        self.middleware.poll(now);
        self.unserved_writes = Some(self.unserved_writes.unwrap_or(0));
        self.serve_readers(now);
        self.publish_due(now);
    }

    /// Polls the readers of active read tasks; call it when an asynchronous middleware's waker fired.
    pub fn poll_middleware(&mut self, now: Instant) {
        self.stats.middleware_polls = self.stats.middleware_polls.saturating_add(1);
        self.middleware.poll(now);
        self.unserved_writes = Some(self.unserved_writes.unwrap_or(0));
        self.serve_readers(now);
    }

    /// The ACKNACKs owed for the reliable messages handled so far, one at a time, before the batch's samples
    /// are delivered: a shell can send them ahead of the rest, so a publisher whose history is full gets its
    /// slots back without waiting for the deliveries to be built. Written into `buf` like
    /// [`Self::poll_transmit`], which yields them too; the UDP shell calls this first.
    pub(crate) fn poll_acknack(&mut self, buf: &mut Vec<u8>) -> Option<E> {
        while let Some(key) = self.acking.pop_front() {
            let Some(client) = self.clients.get_mut(&key) else { continue };
            let built = client.write_acknack(buf);
            if client.acks_due.is_empty() {
                client.listed.acking = false;
            } else {
                self.acking.push_back(key);
            }
            if let (true, Some(to)) = (built, client.endpoint) {
                self.stats.messages_out = self.stats.messages_out.saturating_add(1);
                return Some(to);
            }
        }
        None
    }

    /// Writes the next message to send into `buf` (replacing its content; its allocation is reused or
    /// swapped for one the core holds) and returns where it goes. The order is written down: ACKNACKs owed,
    /// replies outside a session, every client's control messages, then every client's stream messages, one
    /// client per turn ([`outbox`]). Everything whose content depends on the moment is built now: ACKNACKs
    /// and HEARTBEATs from their stream's latest state, TIMESTAMP_REPLY with the transmit time, a reliable
    /// stream's retransmission or new message (packing every sample that waits by then, `now` stamping it for
    /// retransmission). The message fits the client's MTU, fixed at CREATE_CLIENT from the client's and the
    /// transport's.
    pub fn poll_transmit(&mut self, now: Instant, buf: &mut Vec<u8>) -> Option<E> {
        self.end_batch();
        if let Some(to) = self.poll_acknack(buf) {
            return Some(to);
        }
        if let Some(t) = self.stateless.pop_front() {
            self.pool.put(std::mem::replace(buf, t.data));
            return Some(t.to);
        }
        for class in [outbox::Class::Control, outbox::Class::Stream] {
            while let Some(key) = self.turns.pop(class) {
                let Some(client) = self.clients.get_mut(&key) else { continue };
                let mut ctx = endpoint_ctx!(self);
                let (built, more) = match class {
                    outbox::Class::Control => {
                        let built = client.poll_control(&mut ctx, now, buf);
                        (built, client.outbox.has(class))
                    }
                    outbox::Class::Stream => {
                        let built = client.poll_stream(&mut ctx, now, buf);
                        // Building a reliable message armed its tail-loss probe.
                        Self::queue_timer(&mut self.timers, key, client);
                        (built, client.has_stream_work())
                    }
                };
                if more {
                    self.turns.requeue(class, key);
                } else {
                    client.outbox.set_listed(class, false);
                }
                if let (true, Some(to)) = (built, client.endpoint) {
                    return Some(to);
                }
            }
        }
        None
    }

    /// [`Self::poll_transmit`] into a fresh buffer, for the unit tests.
    #[cfg(test)]
    pub(crate) fn next_transmit(&mut self, now: Instant) -> Option<Transmit<E>> {
        let mut data = Vec::new();
        self.poll_transmit(now, &mut data).map(|to| Transmit { to, data })
    }

    /// Gives a spare buffer to the core's pool (optional: the buffers a shell passes to
    /// [`Self::poll_transmit`] are its own, and the core keeps those it swaps out).
    pub fn recycle(&mut self, data: Vec<u8>) {
        self.pool.put(data);
    }

    /// Number of messages waiting in [`Self::poll_transmit`] (at least one while a batch awaits delivery).
    /// For the integration tests' harness (`tests/common`), not an API: hidden from the documentation.
    #[doc(hidden)]
    pub fn pending_transmits(&self) -> usize {
        let queued: usize =
            self.clients.values().map(|c| c.outbox.len() + c.acks_due.len() + usize::from(c.has_stream_work())).sum();
        queued + self.stateless.len() + usize::from(self.unserved_writes.is_some())
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
        if self.remove_client(key, RemoveReason::Deleted) {
            StatusCode::OK
        } else {
            StatusCode::ERR_UNKNOWN_REFERENCE
        }
    }

    /// Deletes every client (eProsima's `Agent::reset`).
    pub fn reset(&mut self) {
        for key in self.client_keys() {
            self.remove_client(key, RemoveReason::Deleted);
        }
        self.stateless.clear();
        self.turns.clear();
        self.acking.clear();
        self.timers.clear();
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
        let (mut ctx, client) = self.ctx_for(key);
        let Some(client) = client else { return StatusCode::ERR_UNKNOWN_REFERENCE };
        let status = client.create_object(&mut ctx, id, variant, mode, xrce_proto::Endianness::Little, now);
        self.unserved_writes = Some(self.unserved_writes.unwrap_or(0));
        self.after_turn(key, true);
        status
    }

    /// Deletes an entity and its children (library API).
    pub fn delete_entity(&mut self, key: ClientKey, id: ObjectId) -> StatusCode {
        let (mut ctx, client) = self.ctx_for(key);
        let Some(client) = client else { return StatusCode::ERR_UNKNOWN_REFERENCE };
        client.delete_object(&mut ctx, id)
    }

    // ---- internals shared by the submodules ----

    /// A client with the context it runs in (the endpoint's middleware, limits, counters and buffers).
    fn ctx_for(&mut self, key: ClientKey) -> (Ctx<'_, E, M>, Option<&mut Connection<E>>) {
        let ctx = endpoint_ctx!(self);
        (ctx, self.clients.get_mut(&key).map(|c| &mut **c))
    }

    /// Takes up what a client's turn left: its messages and ACKNACKs in the turn lists, its timer, its read
    /// tasks and held input in the endpoint's lists; `retry`: readers are served (and held input retried)
    /// at the end of the batch.
    fn after_turn(&mut self, key: ClientKey, retry: bool) {
        let Some(client) = self.clients.get_mut(&key) else { return };
        if client.outbox.has(outbox::Class::Control) {
            self.turns.enlist(key, &mut client.outbox, outbox::Class::Control);
        }
        if client.has_stream_work() {
            self.turns.enlist(key, &mut client.outbox, outbox::Class::Stream);
        }
        if !client.acks_due.is_empty() && !client.listed.acking {
            client.listed.acking = true;
            self.acking.push_back(key);
        }
        if !client.reads.is_empty() && !client.listed.reading {
            client.listed.reading = true;
            self.reading.push(key);
        }
        if !client.blocked.is_empty() && !client.listed.blocked {
            client.listed.blocked = true;
            self.blocked.push(key);
        }
        if retry {
            self.unserved_writes = Some(self.unserved_writes.unwrap_or(0));
        }
        Self::queue_timer(&mut self.timers, key, client);
        self.purge_timers();
    }

    /// Queues the client's next timer unless an entry at or before it is queued already.
    fn schedule(&mut self, key: ClientKey) {
        let Some(client) = self.clients.get_mut(&key) else { return };
        Self::queue_timer(&mut self.timers, key, client);
        self.purge_timers();
    }

    fn queue_timer(
        timers: &mut BinaryHeap<Reverse<(TimerTick, ClientKey)>>,
        key: ClientKey,
        client: &mut Connection<E>,
    ) {
        let Some(due) = client.poll_timeout() else { return };
        if client.timer_queued.is_some_and(|queued| queued <= due) {
            return;
        }
        client.timer_queued = Some(due);
        timers.push(Reverse((TimerTick::of(due), key)));
    }

    fn purge_timers(&mut self) {
        // Stale entries are dropped when they come due; past half as many again as there are clients the heap
        // is rebuilt (amortized: one O(n) pass per n/2 pushes). So the heap never needs more than 1.5 entries
        // per client, and its spare capacity after a burst of clients is given back: at 10,000 clients the
        // heap stays in 16,384 slots (262 kB of 16 B entries) instead of growing to 32,768.
        if self.timers.len() > self.clients.len() + self.clients.len() / 2 + 64 {
            let clients = &self.clients;
            self.timers.retain(|Reverse((due, key))| clients.get(key).is_some_and(|c| due.matches(c.timer_queued)));
            if self.timers.capacity() > 4 * self.timers.len() + 1024 {
                self.timers.shrink_to(2 * self.timers.len());
            }
        }
    }

    /// Delivers samples to every client with read tasks, then retries held reliable input while that makes
    /// progress (a delivery may free a writer's credit).
    fn serve_readers(&mut self, now: Instant) {
        self.unserved_writes = None;
        for _ in 0..4 {
            let clients = &mut self.clients;
            self.reading.retain(|k| match clients.get_mut(k) {
                Some(c) if !c.reads.is_empty() => true,
                Some(c) => {
                    c.listed.reading = false;
                    false
                }
                None => false,
            });
            for i in 0..self.reading.len() {
                let Some(&key) = self.reading.get(i) else { break };
                let (mut ctx, client) = self.ctx_for(key);
                if let Some(client) = client {
                    client.pump_reads(&mut ctx, now);
                }
                self.after_turn(key, false);
            }
            if self.blocked.is_empty() {
                break;
            }
            let mut wrote = false;
            for key in std::mem::take(&mut self.blocked) {
                let (mut ctx, client) = self.ctx_for(key);
                let Some(client) = client else { continue };
                client.listed.blocked = false;
                client.retry_blocked(&mut ctx, now);
                wrote |= ctx.writes > 0;
                self.after_turn(key, false);
            }
            if !wrote {
                break;
            }
        }
        self.unserved_writes = None;
    }

    /// Removes a client: its entities (children first, so middleware callbacks see each), its read tasks, its
    /// endpoint binding.
    fn remove_client(&mut self, key: ClientKey, reason: RemoveReason) -> bool {
        let Some(mut client) = self.clients.remove(&key) else { return false };
        self.stats.client_removed(reason);
        self.stats.removed_clients.absorb(&client.counters_with_streams());
        client.release(&mut self.middleware);
        if let Some(ep) = client.endpoint {
            if self.by_endpoint.get(&ep) == Some(&key) {
                self.by_endpoint.remove(&ep);
            }
        }
        self.reading.retain(|k| *k != key);
        self.blocked.retain(|k| *k != key);
        tracing::info!(client = %key, reason = reason.name(), "client removed");
        true
    }
}

/// Encodes `header` + one submessage.
pub(crate) fn encode_message(header: &MessageHeader, sub: &xrce_proto::Submessage<'_>) -> Option<Vec<u8>> {
    let mut buf = Vec::new();
    encode_into(&mut buf, header, sub).then_some(buf)
}

/// Encodes `header` + one submessage into `buf` (replacing its content); false when it cannot be encoded.
fn encode_into(buf: &mut Vec<u8>, header: &MessageHeader, sub: &xrce_proto::Submessage<'_>) -> bool {
    buf.clear();
    buf.resize(buf.capacity().clamp(64, 256), 0);
    let n = match xrce_proto::message::encode_single(buf, header, sub, xrce_proto::Endianness::Little) {
        Ok(n) => n,
        Err(xrce_proto::cdr::Error::BufferTooSmall { needed })
            if needed <= layout::MAX_SINGLE_SUBMESSAGE_MESSAGE_LEN =>
        {
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

/// Encodes one submessage (header included) as it will sit at byte `at` of its message (after a message
/// header of `at` bytes).
fn encode_submessage(at: usize, sub: &xrce_proto::Submessage<'_>) -> Option<Vec<u8>> {
    let mut buf = vec![0u8; 64];
    let n = match layout::encode_submessage(&mut buf, at, sub, xrce_proto::Endianness::Little) {
        Ok(n) => n,
        Err(xrce_proto::cdr::Error::BufferTooSmall { needed }) if needed <= layout::MAX_SUBMESSAGE_LEN => {
            buf.resize(needed, 0);
            layout::encode_submessage(&mut buf, at, sub, xrce_proto::Endianness::Little).ok()?
        }
        Err(e) => {
            tracing::warn!("cannot encode {}: {e}", sub.id());
            return None;
        }
    };
    buf.truncate(n);
    Some(buf)
}
