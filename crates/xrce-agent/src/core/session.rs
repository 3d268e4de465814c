//! A proxy client: the agent's view of one XRCE client — session, streams, objects, read tasks,
//! liveliness (spec §10).

use std::time::{Duration, Instant};

use xrce_proto::{ClientKey, MessageHeader, ObjectId, StreamId};

use super::object::ObjectTable;
use super::outbox::Outbox;
use super::read::ReadTask;
use super::stream::{BestEffortIn, BestEffortOut, ReliableIn, ReliableOut};
use super::vecmap::VecMap;

/// Streams of a session, created on first use.
#[derive(Debug, Default)]
pub struct Streams {
    /// Best-effort input streams.
    pub be_in: VecMap<u8, BestEffortIn>,
    /// Reliable input streams.
    pub rel_in: VecMap<u8, ReliableIn>,
    /// Best-effort output streams.
    pub be_out: VecMap<u8, BestEffortOut>,
    /// Reliable output streams.
    pub rel_out: VecMap<u8, ReliableOut>,
}

impl Streams {
    /// Number of streams of all kinds.
    pub fn count(&self) -> usize {
        self.be_in.len() + self.rel_in.len() + self.be_out.len() + self.rel_out.len()
    }

    /// Bytes held in reliable input buffers.
    pub fn buffered(&self) -> usize {
        self.rel_in.values().map(ReliableIn::buffered).sum()
    }
}

/// One client known to the agent.
#[derive(Debug)]
pub struct ProxyClient<E> {
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
    /// Several DATA submessages may share one message ([`PACK_PROPERTY`], or
    /// [`CoreConfig::pack_data`](super::CoreConfig::pack_data)). Off for eProsima's C client, which does not
    /// skip a DATA payload and so cannot read a second submessage after one.
    pub pack_data: bool,
    /// Its reliable readers stopped holding writers back (see [`Unpinned`]).
    pub unpinned: Option<Unpinned>,
    /// Reliable input streams whose held message was processed in part before a write the middleware could
    /// not take yet ([`WriteOutcome::WouldBlock`](crate::middleware::WriteOutcome::WouldBlock)): where to
    /// resume, so no submessage runs twice.
    pub resume: VecMap<u8, Resume>,
    /// What it has to send ([`Outbox`]).
    pub outbox: Outbox,
}

/// Where the processing of a held reliable message resumes.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct Resume {
    /// Index of the submessage that could not run yet.
    pub at: usize,
    /// When that submessage was the last FRAGMENT of a message: the rebuilt message and where in it.
    pub inner: Option<(Vec<u8>, usize)>,
}

/// Why a client's reliable readers no longer hold writers back (back-pressure, see
/// [`Middleware::write_credit`](crate::middleware::Middleware::write_credit)).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Unpinned {
    /// Silent past its dead time; pinned again when heard from.
    Dead,
    /// Its reliable output made no progress for the dead time (it does not acknowledge); pinned again when
    /// an ACKNACK acknowledges something.
    Stalled,
}

/// CREATE_CLIENT property a client sets to `1` when it reads every submessage of a message (eProsima's C
/// client does not after a DATA): the agent then packs several samples per message.
pub const PACK_PROPERTY: &str = "xrce_rs_pack";

impl<E: Copy> ProxyClient<E> {
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
            resume: VecMap::default(),
            outbox: Outbox::default(),
        }
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
        self.streams = Streams::default();
        self.resume = VecMap::default();
    }
}

/// Parses the `uxr_hl` value: milliseconds as decimal digits.
pub fn parse_hard_liveliness(value: &str) -> Option<Duration> {
    let ms: u64 = value.trim().parse().ok()?;
    (ms > 0).then(|| Duration::from_millis(ms))
}
