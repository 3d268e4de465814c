//! The agent's state as one value ([`AgentSnapshot`]): each client with its streams and totals, the agent's
//! totals and the middleware's. Built by the loop's thread from the core's plain counters
//! ([`AgentCore::snapshot`]); what reads it (the `--metrics` server, ROS 2 diagnostics, the library API)
//! never touches the core.

use std::cmp::Reverse;
use std::fmt::Debug;
use std::hash::Hash;
use std::sync::{Arc, Mutex, OnceLock, PoisonError};
use std::time::{Duration, Instant};

use xrce_proto::{ClientKey, ObjectKind};

use super::connection::Connection;
use super::stats::{ClientCounters, CoreStats};
use super::AgentCore;
use crate::middleware::{Middleware, MiddlewareStats};

/// Clients with their own `/metrics` series, at most: past it those silent and probed are shown first, then
/// the lowest keys (the snapshot carries only those), and `xrce_agent_clients_not_shown` says how many are not
/// (the agent totals count everyone). At 1,000 clients and ~15 series each a scrape is ~2 MB of text. Here,
/// below the metrics and the middleware that read it, because the snapshot is cut to it.
pub const MAX_CLIENT_SERIES: usize = 1000;

/// Clients with a ROS 2 diagnostics status of their own, at most, worst level first (a bigger array helps no
/// monitor and would cost the DDS link every second); the agent's status says how many are not shown.
pub const MAX_CLIENT_STATUSES: usize = 256;

/// Entities a client holds, by kind.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct EntityCounts {
    /// Participants.
    pub participants: u32,
    /// Topics.
    pub topics: u32,
    /// Publishers.
    pub publishers: u32,
    /// Subscribers.
    pub subscribers: u32,
    /// Data writers.
    pub datawriters: u32,
    /// Data readers.
    pub datareaders: u32,
    /// Requesters.
    pub requesters: u32,
    /// Repliers.
    pub repliers: u32,
}

impl EntityCounts {
    /// The counts with their kind's name, as metric labels.
    pub fn by_kind(&self) -> [(&'static str, u32); 8] {
        [
            ("participant", self.participants),
            ("topic", self.topics),
            ("publisher", self.publishers),
            ("subscriber", self.subscribers),
            ("datawriter", self.datawriters),
            ("datareader", self.datareaders),
            ("requester", self.requesters),
            ("replier", self.repliers),
        ]
    }

    fn count(&mut self, kind: ObjectKind) {
        let n = match kind {
            ObjectKind::Participant => &mut self.participants,
            ObjectKind::Topic => &mut self.topics,
            ObjectKind::Publisher => &mut self.publishers,
            ObjectKind::Subscriber => &mut self.subscribers,
            ObjectKind::DataWriter => &mut self.datawriters,
            ObjectKind::DataReader => &mut self.datareaders,
            ObjectKind::Requester => &mut self.requesters,
            ObjectKind::Replier => &mut self.repliers,
            _ => return,
        };
        *n = n.saturating_add(1);
    }
}

/// One stream of a client's session.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct StreamSnapshot {
    /// Its id (1-127 best effort, 128-255 reliable).
    pub id: u8,
    /// Whether it carries the client's messages to the agent (else the agent's to the client).
    pub input: bool,
    /// Messages it carried (taken in, or numbered and built out; retransmissions apart).
    pub messages: u64,
    /// Messages the agent sent again (reliable output only).
    pub retransmissions: u64,
    /// Reliable streams: messages in the window now (output: unacknowledged; input: stored ahead of a gap).
    pub window_used: usize,
    /// Reliable streams: the window's size (0 for best effort).
    pub window: u16,
}

/// One client as the agent sees it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ClientSnapshot {
    /// Its key.
    pub key: ClientKey,
    /// Its session id.
    pub session_id: u8,
    /// Its named participant's name (its ROS 2 node), when the middleware keeps it (DDS).
    pub name: Option<String>,
    /// Where it sends from, as the logs print it (`None` for a client created through the API that has not
    /// sent yet).
    pub peer: Option<String>,
    /// Its transport (`udp4`, `tcp4`, `serial`, ...): the agent's, or on an agent serving several transports
    /// the one its endpoint is on.
    pub transport: &'static str,
    /// Largest message the agent sends it.
    pub mtu: usize,
    /// When the agent created it.
    pub created_at: Instant,
    /// When the agent last heard from it.
    pub last_heard: Instant,
    /// Liveness probes sent since it went silent (0 while it is heard from).
    pub probes_unanswered: u8,
    /// Its entities, by kind.
    pub entities: EntityCounts,
    /// Its streams.
    pub streams: Vec<StreamSnapshot>,
    /// Its totals since it was created, its streams' included (also those of streams reset since).
    pub counters: ClientCounters,
}

/// The agent's state at one instant.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct AgentSnapshot {
    /// When it was taken.
    pub taken_at: Instant,
    /// The transport the clients use (`udp4`, `tcp4`, `serial`, ...; set by the server that runs the core;
    /// `multi` on an agent serving several, whose clients name their own: [`ClientSnapshot::transport`]).
    pub transport: &'static str,
    /// The agent's totals.
    pub totals: CoreStats,
    /// The middleware's state.
    pub middleware: MiddlewareStats,
    /// The clients, in no particular order: every one ([`AgentCore::snapshot`]), or a few
    /// ([`AgentCore::snapshot_of`]).
    pub clients: Vec<ClientSnapshot>,
    /// Every client's key, also those `clients` leaves out.
    pub keys: Vec<ClientKey>,
    /// The present clients' counters summed: every client's, also those `clients` leaves out.
    pub present_clients: ClientCounters,
}

impl AgentSnapshot {
    /// The agent's totals of what clients did: the removed clients' and the present ones'. Counters: they
    /// never go down.
    pub fn client_totals(&self) -> ClientCounters {
        let mut all = self.totals.removed_clients;
        all.absorb(&self.present_clients);
        all
    }
}

impl<E: Copy + Eq + Hash + Debug> Connection<E> {
    /// This client's part of a snapshot.
    pub(super) fn snapshot(&self, transport: &'static str) -> ClientSnapshot {
        let mut entities = EntityCounts::default();
        for id in self.objects.ids() {
            entities.count(id.kind());
        }
        let s = &self.streams;
        let mut streams = Vec::with_capacity(s.count());
        for (id, st) in s.be_in.iter() {
            streams.push(StreamSnapshot::best_effort(*id, true, st.messages));
        }
        for (id, st) in s.be_out.iter() {
            streams.push(StreamSnapshot::best_effort(*id, false, st.messages));
        }
        for (id, st) in s.rel_in.iter() {
            streams.push(StreamSnapshot::reliable(*id, true, st.messages, 0, st.window_use()));
        }
        for (id, st) in s.rel_out.iter() {
            streams.push(StreamSnapshot::reliable(*id, false, st.messages, st.retransmissions, st.window_use()));
        }
        ClientSnapshot {
            counters: self.counters_with_streams(),
            key: self.key,
            session_id: self.session_id,
            name: None,
            peer: self.endpoint.map(|e| format!("{e:?}")),
            transport,
            mtu: self.mtu,
            created_at: self.created_at,
            last_heard: self.last_heard,
            probes_unanswered: self.probes,
            entities,
            streams,
        }
    }

    /// Its counters with its streams' counts added.
    pub(super) fn counters_with_streams(&self) -> ClientCounters {
        let s = &self.streams;
        let mut c = self.counters.counters();
        let add = |n: &mut u64, by: u64| *n = n.saturating_add(by);
        s.be_in.values().for_each(|st| add(&mut c.messages_in, st.messages));
        s.rel_in.values().for_each(|st| add(&mut c.messages_in, st.messages));
        s.be_out.values().for_each(|st| add(&mut c.messages_out, st.messages));
        for st in s.rel_out.values() {
            add(&mut c.messages_out, st.messages);
            add(&mut c.retransmissions, st.retransmissions);
        }
        c
    }
}

impl StreamSnapshot {
    fn best_effort(id: u8, input: bool, messages: u64) -> Self {
        Self { id, input, messages, retransmissions: 0, window_used: 0, window: 0 }
    }

    fn reliable(id: u8, input: bool, messages: u64, retransmissions: u64, (window_used, window): (usize, u16)) -> Self {
        Self { id, input, messages, retransmissions, window_used, window }
    }
}

impl<E, M> AgentCore<E, M>
where
    E: Copy + Eq + Hash + Debug,
    M: Middleware,
{
    /// The agent's state now: one allocation per client and stream, none on the per-sample path.
    pub fn snapshot(&self, now: Instant) -> AgentSnapshot {
        self.snapshot_of(now, usize::MAX)
    }

    /// [`Self::snapshot`] with `max_clients` clients at most: those silent and probed first (most probes
    /// first), then the lowest keys. What ROS 2 diagnostics alone need, without a copy of every client (at
    /// 10,000 clients a full snapshot is ~3 MB, made again every second).
    pub fn snapshot_of(&self, now: Instant, max_clients: usize) -> AgentSnapshot {
        let named = |c: &Connection<E>| {
            let transport = c.endpoint.as_ref().zip(self.endpoint_transport).map_or(self.transport_name, |(e, f)| f(e));
            ClientSnapshot { name: self.middleware.client_name(c.key), ..c.snapshot(transport) }
        };
        let clients = if max_clients >= self.clients.len() {
            self.clients.values().map(|c| named(c)).collect()
        } else {
            let mut order: Vec<(Reverse<u8>, u32, &Connection<E>)> =
                self.clients.values().map(|c| (Reverse(c.probes), c.key.to_u32(), &**c)).collect();
            if max_clients > 0 {
                order.select_nth_unstable_by_key(max_clients - 1, |(p, k, _)| (*p, *k));
            }
            order.truncate(max_clients);
            order.iter().map(|(_, _, c)| named(c)).collect()
        };
        AgentSnapshot {
            taken_at: now,
            transport: self.transport_name,
            totals: self.stats,
            middleware: self.middleware.stats(),
            clients,
            keys: self.clients.keys().copied().collect(),
            // Summed in place (no copy of a client): totals stay whole however few clients are copied.
            present_clients: self.clients.values().fold(ClientCounters::default(), |mut all, c| {
                all.absorb(&c.counters_with_streams());
                all
            }),
        }
    }
}

/// Where the loop's thread publishes snapshots: readers (the `--metrics` server, the library API) take the
/// latest without touching the core. The lock guards one pointer, held for a swap or a clone of it: never
/// while a snapshot is built or read.
#[derive(Default)]
pub struct SnapshotBoard {
    latest: Mutex<Option<Arc<AgentSnapshot>>>,
    /// Called after each new snapshot (on the loop's thread: it must be quick, a wake-up).
    on_store: OnceLock<Box<dyn Fn() + Send + Sync>>,
}

impl std::fmt::Debug for SnapshotBoard {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SnapshotBoard").field("watched", &self.on_store.get().is_some()).finish_non_exhaustive()
    }
}

impl SnapshotBoard {
    /// The latest snapshot published, if any yet.
    pub fn latest(&self) -> Option<Arc<AgentSnapshot>> {
        self.latest.lock().unwrap_or_else(PoisonError::into_inner).clone()
    }

    /// Has `notify` called after each new snapshot, on the loop's thread (so it only wakes a reader: the
    /// `--metrics` server renders the new text at once, not when the next scrape comes). The first call wins.
    pub fn watch(&self, notify: impl Fn() + Send + Sync + 'static) {
        let _ = self.on_store.set(Box::new(notify));
    }

    fn store(&self, snapshot: Arc<AgentSnapshot>) {
        // The old one is dropped after the lock is released, by whoever holds it last.
        let old = self.latest.lock().unwrap_or_else(PoisonError::into_inner).replace(snapshot);
        drop(old);
        if let Some(notify) = self.on_store.get() {
            notify();
        }
    }
}

/// What a core publishes to, and when next.
#[derive(Debug)]
pub(super) struct Publisher {
    /// Where every client's snapshot goes, when something reads it (`--metrics`); `None`: only the
    /// middleware sees a snapshot of [`MAX_CLIENT_STATUSES`] clients.
    board: Option<Arc<SnapshotBoard>>,
    period: Duration,
    pub(super) next: Instant,
}

impl<E, M> AgentCore<E, M>
where
    E: Copy + Eq + Hash + Debug,
    M: Middleware,
{
    /// Publishes a snapshot to `board` now, then every `period` (at least 10 ms) from
    /// [`Self::handle_timeout`]; the middleware sees each ([`Middleware::on_snapshot`]: ROS 2 diagnostics).
    /// Without a board only the middleware sees them, with the [`MAX_CLIENT_STATUSES`] clients ROS 2
    /// diagnostics show ([`Self::snapshot_of`]); with one, the [`MAX_CLIENT_SERIES`] clients `/metrics` gives
    /// series of their own (those silent and probed first, then the lowest keys). Either way `keys` and the
    /// totals count every client: at 10,000 clients a snapshot copies 1,000 of them a second, not all (~3 MB).
    pub fn publish_snapshots(&mut self, board: Option<Arc<SnapshotBoard>>, period: Duration, now: Instant) {
        self.publisher = Some(Publisher { board, period: period.max(Duration::from_millis(10)), next: now });
        self.publish_due(now);
    }

    /// Publishes a snapshot when one is due.
    pub(super) fn publish_due(&mut self, now: Instant) {
        let Some(publisher) = &self.publisher else { return };
        if publisher.next > now {
            return;
        }
        let limit =
            if publisher.board.is_some() { MAX_CLIENT_SERIES.max(MAX_CLIENT_STATUSES) } else { MAX_CLIENT_STATUSES };
        let snapshot = Arc::new(self.snapshot_of(now, limit));
        self.middleware.on_snapshot(&snapshot, now);
        if let Some(publisher) = &mut self.publisher {
            if let Some(board) = &publisher.board {
                board.store(snapshot);
            }
            publisher.next = now + publisher.period;
        }
    }
}
