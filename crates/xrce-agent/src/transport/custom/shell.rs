//! The loop side of a custom transport: an [`Io`] that takes the reader thread's messages from its channel,
//! names each endpoint with a small copyable [`EndpointId`] for the core, and writes the core's messages
//! with the user's `write` (framed in stream mode).

use std::collections::{BTreeMap, HashMap};
use std::fmt;
use std::io::{self, Read};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::mpsc::{Receiver, SyncSender};
use std::sync::{Arc, Mutex, PoisonError};

use mio::event::Event;
use xrce_proto::framing::serial::{encode_frame, max_encoded_len};

use super::endpoint::Endpoint;
use super::reader::{Incoming, Wake};
use super::{CustomAgentIo, EndpointId, Mode, AGENT_ADDRESS};
use crate::core::Transmit;
use crate::transport::drive::{Inbox, Io, Spent};

/// Most messages handed to the core per turn; the rest come at once in the next turn.
const BATCH: usize = 64;
/// Stream mode: `write` calls in a row that take nothing before a message is given up.
const MAX_STALLS: usize = 16;

/// The custom transport as the event loop sees it.
pub(crate) struct Shell {
    pub(super) name: String,
    pub(super) io: Arc<dyn CustomAgentIo>,
    pub(super) mode: Mode,
    pub(super) rx: Receiver<Incoming>,
    /// Buffers back to the reader.
    pub(super) spare: SyncSender<Vec<u8>>,
    pub(super) wake: Arc<Wake>,
    /// The loop's end of the reader's wake-up pipe.
    pub(super) woken: mio::unix::pipe::Receiver,
    pub(super) table: EndpointTable,
    /// A message taken by [`Io::prefetch`], delivered first in the next turn.
    pub(super) stash: Option<Incoming>,
    /// Scratch for framing.
    pub(super) frame: Vec<u8>,
}

impl Shell {
    /// Registers the reader's wake-up pipe with the loop's `registry` under `token`.
    pub(crate) fn register(&mut self, registry: &mio::Registry, token: mio::Token) -> io::Result<()> {
        registry.register(&mut self.woken, token, mio::Interest::READABLE)
    }
}

impl Io<EndpointId> for Shell {
    fn ready(&mut self, _event: &Event) {}

    fn prefetch(&mut self) -> io::Result<bool> {
        if self.stash.is_none() {
            self.stash = self.rx.try_recv().ok();
        }
        Ok(self.stash.is_some())
    }

    fn receive(&mut self, inbox: &mut Inbox<'_, EndpointId>) -> io::Result<()> {
        // Lowered before draining: a message queued after the drain raises it again and wakes the loop.
        self.wake.flag.take();
        let mut drain = [0u8; 64];
        // Emptied, so the next byte is a new edge for the poll.
        while matches!((&self.woken).read(&mut drain), Ok(n) if n > 0) {}
        let first = self.stash.take();
        let rx = &self.rx;
        for msg in first.into_iter().chain(std::iter::from_fn(|| rx.try_recv().ok())).take(BATCH) {
            let (id, evicted) = self.table.intern(msg.from, msg.address);
            if let Some(old) = evicted {
                inbox.forget(old);
            }
            inbox.deliver(id, &msg.bytes);
            // The reader allocates anew when none comes back.
            let _ = self.spare.try_send(msg.bytes);
        }
        Ok(())
    }

    fn send(&mut self, out: &mut Vec<Transmit<EndpointId>>, spent: &mut Spent<EndpointId>) {
        for t in out.drain(..) {
            match self.table.get(t.to) {
                Some((to, address)) => {
                    write_message(&*self.io, self.mode, &mut self.frame, to, *address, &t.data, &self.name);
                }
                None => tracing::debug!(transport = %self.name, to = ?t.to, "endpoint forgotten, message dropped"),
            }
            spent.buffers.push(t.data);
        }
    }
}

/// Writes one message to `to`: whole in packet mode, framed from the agent to the client's `address` and
/// written until all is taken in stream mode. Failures are logged; reliable streams recover the loss.
fn write_message(
    io: &dyn CustomAgentIo,
    mode: Mode,
    frame: &mut Vec<u8>,
    to: &Endpoint,
    address: Option<u8>,
    data: &[u8],
    name: &str,
) {
    match mode {
        Mode::Packet => match io.write(to, data) {
            Ok(n) if n == data.len() => {}
            Ok(n) => tracing::warn!(transport = %name, endpoint = %to, "short write: {n} of {} bytes", data.len()),
            Err(e) => tracing::warn!(transport = %name, endpoint = %to, "write failed: {e}"),
        },
        Mode::Stream => {
            frame.resize(max_encoded_len(data.len()), 0);
            let n = match encode_frame(AGENT_ADDRESS, address.unwrap_or(AGENT_ADDRESS), data, frame) {
                Ok(n) => n,
                Err(e) => {
                    tracing::warn!(transport = %name, len = data.len(), "cannot frame message: {e}");
                    return;
                }
            };
            if let Err(e) = write_all(io, to, frame.get(..n).unwrap_or(&[])) {
                // The peer's decoder drops the cut frame at the next flag.
                tracing::warn!(transport = %name, endpoint = %to, "write failed: {e}");
            }
        }
    }
}

/// eProsima's stream-mode `write` may take part of the bytes: call it until it took them all.
fn write_all(io: &dyn CustomAgentIo, to: &Endpoint, mut rest: &[u8]) -> io::Result<()> {
    let mut stalls = 0;
    while !rest.is_empty() {
        match io.write(to, rest) {
            Ok(0) => stalls += 1,
            Ok(n) => rest = rest.get(n..).unwrap_or(&[]),
            Err(e) if matches!(e.kind(), io::ErrorKind::Interrupted | io::ErrorKind::WouldBlock) => stalls += 1,
            Err(e) => return Err(e),
        }
        if stalls >= MAX_STALLS {
            return Err(io::Error::new(io::ErrorKind::WriteZero, format!("{} bytes not taken", rest.len())));
        }
    }
    Ok(())
}

/// Endpoint ids, drawn for the whole process: never reused, whichever agent draws them.
static NEXT_ID: AtomicU64 = AtomicU64::new(0);

/// What each known endpoint id is shown as: the core only has the id to log, and the members live in the
/// table of the loop thread. Bounded by the tables' bounds: an entry goes when its endpoint is forgotten.
static NAMES: Mutex<BTreeMap<u64, Box<str>>> = Mutex::new(BTreeMap::new());

fn names() -> std::sync::MutexGuard<'static, BTreeMap<u64, Box<str>>> {
    NAMES.lock().unwrap_or_else(PoisonError::into_inner)
}

/// `ip=2130706433, port=8888` (`, address=N` in stream mode) for a known id, `endpoint #N` otherwise.
pub(super) fn write_endpoint_name(id: EndpointId, f: &mut fmt::Formatter<'_>) -> fmt::Result {
    let name = names().get(&id.0).cloned();
    match name {
        Some(name) => f.write_str(&name),
        None => write!(f, "endpoint #{}", id.0),
    }
}

fn endpoint_name((endpoint, address): &(Endpoint, Option<u8>)) -> Box<str> {
    match address {
        Some(a) => format!("{endpoint}, address={a}").into(),
        None => endpoint.to_string().into(),
    }
}

/// The endpoints seen, each under an id the core uses as its peer: ids are never reused (the counter
/// outlives a table lost with a failed loop, and the table outlives a restart, because the core keeps its
/// clients' ids across both), and at most `max` endpoints are kept; a new one beyond that evicts the least
/// recently used, whose client is reached again as soon as it sends (under a new id).
pub(crate) struct EndpointTable {
    ids: HashMap<(Endpoint, Option<u8>), EndpointId>,
    entries: HashMap<EndpointId, Entry>,
    max: usize,
    clock: u64,
}

struct Entry {
    key: (Endpoint, Option<u8>),
    used: u64,
}

impl EndpointTable {
    /// An empty table.
    pub fn new(max: usize) -> Self {
        Self { ids: HashMap::new(), entries: HashMap::new(), max: max.max(1), clock: 0 }
    }

    /// Changes the bound (applies from the next new endpoint).
    pub fn set_max(&mut self, max: usize) {
        self.max = max.max(1);
    }

    /// The id of `from` (with its frame address), made if new; and the id evicted to make room, if any.
    pub fn intern(&mut self, from: Endpoint, address: Option<u8>) -> (EndpointId, Option<EndpointId>) {
        self.clock = self.clock.wrapping_add(1);
        let key = (from, address);
        if let Some(id) = self.ids.get(&key).copied() {
            if let Some(entry) = self.entries.get_mut(&id) {
                entry.used = self.clock;
            }
            return (id, None);
        }
        let mut evicted = None;
        while self.entries.len() >= self.max {
            // Past a lowered bound, the core learns of the last eviction only; the others' ids are never
            // reused, so at worst it keeps an entry for an endpoint no one will send from.
            match self.evict() {
                Some(id) => evicted = Some(id),
                None => break,
            }
        }
        let id = EndpointId(NEXT_ID.fetch_add(1, Ordering::Relaxed));
        names().insert(id.0, endpoint_name(&key));
        tracing::debug!(endpoint = %id, id = id.0, "new custom endpoint");
        self.ids.insert(key.clone(), id);
        self.entries.insert(id, Entry { key, used: self.clock });
        (id, evicted)
    }

    /// The endpoint and frame address of `id`.
    pub fn get(&mut self, id: EndpointId) -> Option<&(Endpoint, Option<u8>)> {
        self.clock = self.clock.wrapping_add(1);
        let entry = self.entries.get_mut(&id)?;
        entry.used = self.clock;
        Some(&entry.key)
    }

    fn evict(&mut self) -> Option<EndpointId> {
        let oldest = self.entries.iter().min_by_key(|(_, e)| e.used).map(|(id, _)| *id)?;
        tracing::debug!(endpoint = %oldest, id = oldest.0, "custom endpoint table full, least recently used forgotten");
        let entry = self.entries.remove(&oldest)?;
        self.ids.remove(&entry.key);
        names().remove(&oldest.0);
        Some(oldest)
    }

    /// Endpoints kept.
    #[cfg(test)]
    pub fn len(&self) -> usize {
        self.entries.len()
    }
}

impl Drop for EndpointTable {
    fn drop(&mut self) {
        let mut names = names();
        for id in self.entries.keys() {
            names.remove(&id.0);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::transport::custom::EndpointDesc;

    fn endpoint(port: u16) -> Endpoint {
        let mut e = EndpointDesc::new().member_u16("port").member_string("host").endpoint();
        e.set("port", port).unwrap();
        e.set_str("host", "localhost").unwrap();
        e
    }

    #[test]
    fn equal_endpoints_share_an_id_and_addresses_tell_peers_apart() {
        let mut t = EndpointTable::new(8);
        let (a, _) = t.intern(endpoint(1), None);
        assert_eq!(t.intern(endpoint(1), None), (a, None));
        let (b, _) = t.intern(endpoint(2), None);
        let (c, _) = t.intern(endpoint(1), Some(3));
        assert!(a != b && a != c && b != c);
        assert_eq!(t.get(b).map(|(e, _)| e.get::<u16>("port")), Some(Ok(2)));
        assert_eq!(t.get(c).map(|(_, addr)| *addr), Some(Some(3)));
    }

    /// The table stays within its bound; the least recently used endpoint (not the oldest) goes, and its id
    /// is not reused, so the core never sends one client's messages to another.
    #[test]
    fn the_least_recently_used_endpoint_is_evicted() {
        let mut t = EndpointTable::new(2);
        let (one, _) = t.intern(endpoint(1), None);
        let (two, _) = t.intern(endpoint(2), None);
        assert!(t.get(one).is_some(), "one used after two");
        let (three, evicted) = t.intern(endpoint(3), None);
        assert_eq!(evicted, Some(two));
        assert_eq!(t.len(), 2);
        assert!(t.get(two).is_none());
        let (two_again, evicted) = t.intern(endpoint(2), None);
        assert_eq!(evicted, Some(one), "one was used before three");
        assert!(two_again != two && two_again != three);
    }

    /// The core logs an endpoint id as the members the user declared, with the frame address in stream mode;
    /// once forgotten, as its number.
    #[test]
    fn endpoint_ids_show_their_members() {
        let mut t = EndpointTable::new(1);
        let (a, _) = t.intern(endpoint(8888), None);
        assert_eq!(format!("{a}"), "port=8888, host=\"localhost\"");
        assert_eq!(format!("{a:?}"), "port=8888, host=\"localhost\"", "the core logs peers with {{:?}}");
        let (b, evicted) = t.intern(endpoint(7000), Some(3));
        assert_eq!(evicted, Some(a));
        assert_eq!(format!("{b:?}"), "port=7000, host=\"localhost\", address=3");
        assert_eq!(format!("{a:?}"), format!("endpoint #{}", a.0), "forgotten");
        drop(t);
        assert_eq!(format!("{b}"), format!("endpoint #{}", b.0), "gone with its table");
    }
}
