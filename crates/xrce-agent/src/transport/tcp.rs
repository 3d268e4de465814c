//! TCP shell (IPv4 and IPv6): messages framed by a 2-byte little-endian length (spec §12.2), many
//! connections, one thread. A `mio` event loop ([`EventLoop`]) accepts, reads every
//! connection without blocking (partial reads reassembled by
//! [`TcpDecoder`]), runs the core's timers, is woken by the
//! middleware through a [`mio::Waker`], and writes each connection from its own outbox with
//! vectored writes as far as the socket takes them: a client that stops reading only fills its own outbox,
//! and is closed once that holds [`MAX_OUTBOX_BYTES`] or has not moved for [`WRITE_TIMEOUT`]. Nothing else
//! waits for it. At most `--max-connections` ([`DEFAULT_MAX_CONNECTIONS`]) are served at once; an accept that
//! fails (no file descriptor left) is tried again after [`ACCEPT_RETRY`], never given up.

use std::collections::{HashMap, VecDeque};
use std::io::{self, IoSlice, Read, Write};
use std::net::{Shutdown, SocketAddr};
use std::sync::atomic::AtomicBool;
use std::sync::Arc;
use std::time::{Duration, Instant};

use mio::event::Event;
use mio::net::{TcpListener, TcpStream};
use mio::{Interest, Registry, Token};
use xrce_proto::framing::tcp::{prefix, TcpDecoder, TcpEvent, MAX_MESSAGE_LEN, PREFIX_LEN};

use super::discovery::DiscoveryServer;
use super::drive::{EventLoop, Inbox, Io, Spent, Tokens};
use super::SharedCore;
use crate::core::Transmit;

/// Simultaneous connections a listener serves unless told otherwise (`--max-connections`); more are closed on
/// accept. As eProsima's agent (its `UAGENT_CONFIG_TCP_MAX_CONNECTIONS`); each takes a file descriptor, and a
/// cap well under the usual limit of 1024 leaves descriptors to the other transports and the DDS participants.
pub const DEFAULT_MAX_CONNECTIONS: usize = crate::cli::DEFAULT_MAX_CONNECTIONS as usize;
/// After an accept fails (no descriptor left: EMFILE, ENFILE; a connection reset while queued), the listener
/// is tried again this long after: the error is transient, and connections queued meanwhile would otherwise
/// wait for a new one to arrive (readiness is edge-triggered).
pub const ACCEPT_RETRY: Duration = Duration::from_millis(100);
/// Descriptors the agent needs besides its TCP connections (standard streams, poll, other transports, DDS
/// participants' sockets, a serial device reopened): a cap closer than this to the process' limit is warned of.
const DESCRIPTORS_KEPT: u64 = 64;
/// A connection whose outbox has not moved for this long while holding data is closed (its peer stopped
/// reading).
pub const WRITE_TIMEOUT: Duration = Duration::from_secs(2);
/// Bytes a connection's outbox may hold; a peer that lets more pile up is closed. 4 MiB is 64 full-size
/// messages, well above what a reliable stream's window keeps in flight.
pub const MAX_OUTBOX_BYTES: usize = 4 * 1024 * 1024;
/// Messages written in one vectored write (two slices each: length prefix and message).
const WRITE_BATCH: usize = 32;

/// The listener's token number in the shell's range.
const LISTENER: usize = 1;
/// Connection token numbers are `FIRST_CONN + ConnId`.
const FIRST_CONN: usize = 2;

/// Identifies a TCP connection to the core: the peer's address and a number unique to the server (a peer
/// that reconnects from the same address is another connection). Logs show it as `address#number`.
#[derive(Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct ConnId {
    /// Number of the connection, from 1 in accept order.
    pub number: u64,
    /// The peer's address.
    pub peer: SocketAddr,
}

impl std::fmt::Debug for ConnId {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}#{}", self.peer, self.number)
    }
}

impl std::fmt::Display for ConnId {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        std::fmt::Debug::fmt(self, f)
    }
}

fn token(tokens: Tokens, number: u64) -> Token {
    tokens.token(usize::try_from(number).unwrap_or(usize::MAX).saturating_add(FIRST_CONN))
}

fn number_of(tokens: Tokens, token: Token) -> Option<u64> {
    tokens.local(token)?.checked_sub(FIRST_CONN).and_then(|n| u64::try_from(n).ok())
}

/// A TCP server around a shared core.
#[derive(Debug)]
pub struct TcpServer {
    listener: std::net::TcpListener,
    looped: EventLoop<ConnId>,
    max_connections: usize,
}

/// One connection: its socket, the reassembly of what it sends and the framed messages waiting to go out.
struct Conn {
    stream: TcpStream,
    id: ConnId,
    decoder: TcpDecoder<Vec<u8>>,
    /// Length prefixes and messages, in order; the front one is `sent` bytes into its prefix + message.
    outbox: VecDeque<([u8; PREFIX_LEN], Vec<u8>)>,
    sent: usize,
    queued: usize,
    /// When the outbox last moved (or got its first message after being empty).
    progress_at: Instant,
    writable_interest: bool,
}

impl Conn {
    fn queue(&mut self, data: Vec<u8>, now: Instant) -> bool {
        let Ok(head) = prefix(data.len()) else {
            tracing::warn!(conn = %self.id, len = data.len(), "message too large for TCP framing");
            return true;
        };
        if self.outbox.is_empty() {
            self.progress_at = now;
        }
        self.queued += PREFIX_LEN + data.len();
        self.outbox.push_back((head, data));
        self.queued <= MAX_OUTBOX_BYTES
    }

    /// Writes as much of the outbox as the socket takes now; `Err` when the connection failed.
    fn flush(&mut self, now: Instant, recycle: &mut Vec<Vec<u8>>) -> io::Result<()> {
        while !self.outbox.is_empty() {
            let mut slices = [IoSlice::new(&[]); 2 * WRITE_BATCH];
            let mut n = 0;
            for (i, (head, data)) in self.outbox.iter().take(WRITE_BATCH).enumerate() {
                // Only the front frame may be partly written already.
                let skip = if i == 0 { self.sent } else { 0 };
                let parts = [
                    head.get(skip.min(PREFIX_LEN)..).unwrap_or(&[]),
                    data.get(skip.saturating_sub(PREFIX_LEN)..).unwrap_or(&[]),
                ];
                for part in parts.into_iter().filter(|p| !p.is_empty()) {
                    if let Some(slot) = slices.get_mut(n) {
                        *slot = IoSlice::new(part);
                        n += 1;
                    }
                }
            }
            let written = match self.stream.write_vectored(slices.get(..n).unwrap_or(&[])) {
                Ok(0) => return Err(io::ErrorKind::WriteZero.into()),
                Ok(w) => w,
                Err(e) if e.kind() == io::ErrorKind::WouldBlock => return Ok(()),
                Err(e) if e.kind() == io::ErrorKind::Interrupted => continue,
                Err(e) => return Err(e),
            };
            self.progress_at = now;
            self.queued = self.queued.saturating_sub(written);
            let mut left = self.sent + written;
            while let Some((_, data)) = self.outbox.front() {
                let whole = PREFIX_LEN + data.len();
                if left < whole {
                    break;
                }
                left -= whole;
                if let Some((_, data)) = self.outbox.pop_front() {
                    recycle.push(data);
                }
            }
            self.sent = left;
        }
        Ok(())
    }

    /// Whether the peer has stopped taking what is sent to it.
    fn stalled(&self, now: Instant) -> bool {
        !self.outbox.is_empty() && now.saturating_duration_since(self.progress_at) >= WRITE_TIMEOUT
    }
}

impl TcpServer {
    /// Binds `addr` (port 0: an ephemeral port) and installs the middleware's waker.
    pub fn bind(addr: SocketAddr, core: SharedCore<ConnId>) -> io::Result<Self> {
        let listener = std::net::TcpListener::bind(addr)?;
        listener.set_nonblocking(true)?;
        Ok(Self { listener, looped: EventLoop::new(core)?, max_connections: DEFAULT_MAX_CONNECTIONS })
    }

    /// Serves at most `max` connections at once (default [`DEFAULT_MAX_CONNECTIONS`]); more are closed on
    /// accept.
    #[must_use]
    pub fn with_max_connections(mut self, max: usize) -> Self {
        self.max_connections = max;
        self
    }

    /// Answers discovery requests (`-d`) from this server's loop.
    #[must_use]
    pub fn with_discovery(mut self, discovery: DiscoveryServer) -> Self {
        self.looped.set_discovery(discovery);
        self
    }

    /// The bound address.
    pub fn local_addr(&self) -> io::Result<SocketAddr> {
        self.listener.local_addr()
    }

    /// Serves until `stop` is set (checked at least every [`super::MAX_BLOCK`]).
    pub fn run(&self, stop: &Arc<AtomicBool>) -> io::Result<()> {
        let name = format!("the TCP server on {}", self.listener.local_addr()?);
        let mut io = self.looped.run(&name, stop, |registry| {
            TcpIo::register(&self.listener, registry, Tokens::ALONE, self.max_connections)
        })?;
        io.close_all();
        Ok(())
    }
}

/// The listener and the connections, as the event loop sees them.
pub(crate) struct TcpIo {
    listener: TcpListener,
    /// The listener's address, for logs.
    local: SocketAddr,
    max_connections: usize,
    /// When the last accept failed: the listener is tried again [`ACCEPT_RETRY`] after.
    accept_failed_at: Option<Instant>,
    /// The last connection accepted was over the cap and closed.
    refusing: bool,
    registry: Registry,
    /// By connection number.
    conns: HashMap<u64, Conn>,
    next_id: u64,
    buf: Vec<u8>,
    /// Connections reported readable (or closed) since the last turn.
    readable: Vec<u64>,
    tokens: Tokens,
}

impl Io<ConnId> for TcpIo {
    fn ready(&mut self, event: &Event) {
        match self.tokens.local(event.token()) {
            Some(LISTENER) => self.accept(),
            _ => {
                if let Some(number) = number_of(self.tokens, event.token()) {
                    if event.is_readable() || event.is_read_closed() || event.is_error() {
                        self.readable.push(number);
                    }
                }
            }
        }
    }

    fn receive(&mut self, inbox: &mut Inbox<'_, ConnId>) -> io::Result<()> {
        if self.accept_failed_at.is_some_and(|at| inbox.now().saturating_duration_since(at) >= ACCEPT_RETRY) {
            self.accept();
        }
        for number in std::mem::take(&mut self.readable) {
            self.read(number, inbox);
        }
        Ok(())
    }

    /// Moves what the core produced into the outboxes and writes them; closes connections whose peer
    /// stopped reading or failed.
    fn send(&mut self, out: &mut Vec<Transmit<ConnId>>, spent: &mut Spent<ConnId>) {
        let now = Instant::now();
        let mut overflowing = Vec::new();
        for Transmit { to, data } in out.drain(..) {
            match self.conns.get_mut(&to.number) {
                Some(conn) => {
                    if !conn.queue(data, now) && !overflowing.contains(&to.number) {
                        overflowing.push(to.number);
                    }
                }
                None => spent.buffers.push(data),
            }
        }
        let mut failed = Vec::new();
        for (&number, conn) in &mut self.conns {
            if conn.outbox.is_empty() {
                continue;
            }
            if let Err(e) = conn.flush(now, &mut spent.buffers) {
                failed.push((number, format!("write failed: {e}")));
                continue;
            }
            let want_writable = !conn.outbox.is_empty();
            if want_writable != conn.writable_interest {
                let interest = if want_writable { Interest::READABLE | Interest::WRITABLE } else { Interest::READABLE };
                if self.registry.reregister(&mut conn.stream, token(self.tokens, number), interest).is_ok() {
                    conn.writable_interest = want_writable;
                }
            }
        }
        for (&number, conn) in &self.conns {
            if overflowing.contains(&number) && conn.queued > MAX_OUTBOX_BYTES {
                failed.push((number, format!("peer not reading: {} bytes waiting", conn.queued)));
            } else if conn.stalled(now) {
                failed.push((number, format!("peer took nothing for {WRITE_TIMEOUT:?}")));
            }
        }
        for (number, why) in failed {
            spent.gone.extend(self.close(number, &why));
        }
    }
}

impl TcpIo {
    /// Registers (a clone of) `listener` with the loop's `registry` in the shell's token range.
    pub(crate) fn register(
        listener: &std::net::TcpListener,
        registry: &Registry,
        tokens: Tokens,
        max_connections: usize,
    ) -> io::Result<Self> {
        let local = listener.local_addr()?;
        warn_if_over_descriptor_limit(local, max_connections);
        let mut listener = TcpListener::from_std(listener.try_clone()?);
        registry.register(&mut listener, tokens.token(LISTENER), Interest::READABLE)?;
        Ok(Self {
            listener,
            local,
            max_connections,
            accept_failed_at: None,
            refusing: false,
            registry: registry.try_clone()?,
            conns: HashMap::new(),
            next_id: 1,
            buf: vec![0u8; 64 * 1024],
            readable: Vec::new(),
            tokens,
        })
    }

    /// Shuts every connection down (the server stops).
    pub(crate) fn close_all(&mut self) {
        for (_, conn) in self.conns.drain() {
            let _ = conn.stream.shutdown(Shutdown::Both);
        }
    }

    fn accept(&mut self) {
        loop {
            let (mut stream, peer) = match self.listener.accept() {
                Ok(a) => a,
                Err(e) if e.kind() == io::ErrorKind::WouldBlock => {
                    self.accepting_again();
                    return;
                }
                // A connection reset while queued is gone; the next may be fine.
                Err(e) if matches!(e.kind(), io::ErrorKind::Interrupted | io::ErrorKind::ConnectionAborted) => continue,
                Err(e) => {
                    // Logged once per outage; the retries that fail again are debug.
                    if self.accept_failed_at.is_none() {
                        tracing::warn!(listener = %self.local, "TCP accept failed, trying again every {ACCEPT_RETRY:?}: {e}");
                    } else {
                        tracing::debug!(listener = %self.local, "TCP accept failed again: {e}");
                    }
                    self.accept_failed_at = Some(Instant::now());
                    return;
                }
            };
            self.accepting_again();
            if self.conns.len() >= self.max_connections {
                // Logged once per flood; the next refusals are debug.
                if self.refusing {
                    tracing::debug!(listener = %self.local, %peer, "too many TCP connections, refusing");
                } else {
                    tracing::warn!(listener = %self.local, %peer, max = self.max_connections, "too many TCP connections, refusing");
                    self.refusing = true;
                }
                continue;
            }
            self.refusing = false;
            let id = ConnId { number: self.next_id, peer };
            self.next_id += 1;
            let _ = stream.set_nodelay(true);
            if let Err(e) = self.registry.register(&mut stream, token(self.tokens, id.number), Interest::READABLE) {
                tracing::warn!(%peer, "cannot serve TCP connection: {e}");
                continue;
            }
            tracing::info!(conn = %id, "TCP connection accepted");
            let conn = Conn {
                stream,
                id,
                decoder: TcpDecoder::new(vec![0u8; MAX_MESSAGE_LEN]),
                outbox: VecDeque::new(),
                sent: 0,
                queued: 0,
                progress_at: Instant::now(),
                writable_interest: false,
            };
            self.conns.insert(id.number, conn);
        }
    }

    /// The listener took a connection or had none queued: no retry pending.
    fn accepting_again(&mut self) {
        if self.accept_failed_at.take().is_some() {
            tracing::info!(listener = %self.local, "TCP listener accepting again");
        }
    }

    /// Reads what connection `number` has sent and hands every complete message to the core.
    fn read(&mut self, number: u64, inbox: &mut Inbox<'_, ConnId>) {
        let Some(conn) = self.conns.get_mut(&number) else { return };
        let id = conn.id;
        let mut closed = false;
        loop {
            let n = match conn.stream.read(&mut self.buf) {
                Ok(0) => {
                    closed = true;
                    break;
                }
                Ok(n) => n,
                Err(e) if e.kind() == io::ErrorKind::WouldBlock => break,
                Err(e) if e.kind() == io::ErrorKind::Interrupted => continue,
                Err(e) => {
                    tracing::debug!(conn = %id, "TCP read failed: {e}");
                    closed = true;
                    break;
                }
            };
            conn.decoder.push(self.buf.get(..n).unwrap_or(&[]), |event| match event {
                TcpEvent::Message(msg) => inbox.deliver(id, msg),
                TcpEvent::Error(e) => tracing::warn!(peer = %id, "{e}"),
            });
        }
        if closed {
            if let Some(id) = self.close(number, "closed by the peer") {
                inbox.forget(id);
            }
        }
    }

    /// Closes connection `number`; returns its id for the core to forget.
    fn close(&mut self, number: u64, why: &str) -> Option<ConnId> {
        let mut conn = self.conns.remove(&number)?;
        let _ = self.registry.deregister(&mut conn.stream);
        let _ = conn.stream.shutdown(Shutdown::Both);
        tracing::info!(conn = %conn.id, "TCP connection closed: {why}");
        Some(conn.id)
    }
}

/// Warns when `max_connections` leaves fewer than [`DESCRIPTORS_KEPT`] of the process' file descriptors
/// (`ulimit -n`) to the rest of the agent: a flood of connections would then reach the limit.
fn warn_if_over_descriptor_limit(listener: SocketAddr, max_connections: usize) {
    let Ok((limit, _)) = nix::sys::resource::getrlimit(nix::sys::resource::Resource::RLIMIT_NOFILE) else { return };
    let max = u64::try_from(max_connections).unwrap_or(u64::MAX);
    if max.saturating_add(DESCRIPTORS_KEPT) > limit {
        tracing::warn!(
            %listener,
            "--max-connections {max_connections} leaves fewer than {DESCRIPTORS_KEPT} of the {limit} file \
             descriptors allowed (ulimit -n) to the rest of the agent: lower it, or raise the limit"
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::transport::drive::WAKER;

    #[test]
    fn connections_are_logged_by_address_and_number() {
        let id = ConnId { number: 3, peer: "127.0.0.1:40000".parse().unwrap() };
        assert_eq!(format!("{id:?}"), "127.0.0.1:40000#3");
        assert_eq!(id.to_string(), "127.0.0.1:40000#3");
        assert_eq!(number_of(Tokens::ALONE, token(Tokens::ALONE, id.number)), Some(3));
        assert_eq!(number_of(Tokens::ALONE, WAKER), None);
        let shared = Tokens::shared(2).unwrap();
        assert_eq!(number_of(shared, token(shared, id.number)), Some(3));
        assert_eq!(number_of(shared, token(Tokens::ALONE, id.number)), None, "another shell's token");
    }
}
