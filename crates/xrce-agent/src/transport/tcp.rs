//! TCP shell (IPv4 and IPv6): messages framed by a 2-byte little-endian length (spec §12.2), many
//! connections, each read by its own thread; partial reads are reassembled by
//! [`TcpDecoder`](xrce_proto::framing::tcp::TcpDecoder) and partial writes completed by `write_all` with a
//! write timeout (a client that stops reading is disconnected).

use std::collections::HashMap;
use std::io::{self, Read, Write};
use std::net::{Shutdown, SocketAddr, TcpListener, TcpStream};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::thread;
use std::time::{Duration, Instant};

use xrce_proto::framing::tcp::{prefix, TcpDecoder, TcpEvent, MAX_MESSAGE_LEN};

use super::{anchor_wall_clock, block_for, hexdump, lock, SharedCore, WakeSignal, MAX_BLOCK};
use crate::core::Transmit;

/// Most simultaneous connections; more are closed on accept.
pub const MAX_CONNECTIONS: usize = 1024;
/// A connection whose peer does not take a message within this time is closed.
pub const WRITE_TIMEOUT: Duration = Duration::from_secs(2);

/// Identifies a TCP connection to the core.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct ConnId(pub u64);

type Writers = Arc<Mutex<HashMap<ConnId, (SocketAddr, TcpStream)>>>;

/// A TCP server around a shared core.
#[derive(Debug)]
pub struct TcpServer {
    listener: TcpListener,
    core: SharedCore<ConnId>,
    writers: Writers,
    next_id: Arc<AtomicU64>,
    wake: Arc<WakeSignal>,
}

fn lock_writers(w: &Writers) -> std::sync::MutexGuard<'_, HashMap<ConnId, (SocketAddr, TcpStream)>> {
    w.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
}

/// Sends what the core produced to the connections; a failed connection is closed.
fn dispatch(core: &SharedCore<ConnId>, writers: &Writers, transmits: Vec<Transmit<ConnId>>) {
    let mut failed = Vec::new();
    {
        let map = lock_writers(writers);
        for t in transmits {
            let Some((peer, stream)) = map.get(&t.to) else { continue };
            let Ok(head) = prefix(t.data.len()) else {
                tracing::warn!(%peer, len = t.data.len(), "message too large for TCP framing");
                continue;
            };
            hexdump("send", peer, &t.data);
            let mut framed = Vec::with_capacity(2 + t.data.len());
            framed.extend_from_slice(&head);
            framed.extend_from_slice(&t.data);
            let mut s: &TcpStream = stream;
            if let Err(e) = s.write_all(&framed) {
                tracing::warn!(%peer, "TCP write failed, closing: {e}");
                failed.push(t.to);
            }
        }
    }
    for id in failed {
        close(core, writers, id);
    }
}

fn close(core: &SharedCore<ConnId>, writers: &Writers, id: ConnId) {
    if let Some((_, s)) = lock_writers(writers).remove(&id) {
        let _ = s.shutdown(Shutdown::Both);
    }
    lock(core).forget_endpoint(id);
}

fn drain(core: &SharedCore<ConnId>) -> Vec<Transmit<ConnId>> {
    let mut c = lock(core);
    let mut out = Vec::new();
    while let Some(t) = c.poll_transmit() {
        out.push(t);
    }
    out
}

impl TcpServer {
    /// Binds `addr` (port 0: an ephemeral port).
    pub fn bind(addr: SocketAddr, core: SharedCore<ConnId>) -> io::Result<Self> {
        let listener = TcpListener::bind(addr)?;
        let wake = Arc::new(WakeSignal::default());
        {
            let mut c = lock(&core);
            anchor_wall_clock(&mut c);
            wake.install(&mut c);
        }
        Ok(Self { listener, core, writers: Arc::default(), next_id: Arc::new(AtomicU64::new(1)), wake })
    }

    /// The bound address.
    pub fn local_addr(&self) -> io::Result<SocketAddr> {
        self.listener.local_addr()
    }

    /// Serves until `stop` is set: accepts connections (one reader thread each) and runs the core's timers.
    pub fn run(&self, stop: &Arc<AtomicBool>) -> io::Result<()> {
        self.listener.set_nonblocking(true)?;
        let timers = {
            let (core, writers, stop, wake) =
                (self.core.clone(), self.writers.clone(), stop.clone(), self.wake.clone());
            thread::Builder::new()
                .name("xrce-tcp-timers".into())
                .spawn(move || timer_loop(&core, &writers, &stop, &wake))?
        };
        let mut readers = Vec::new();
        while !stop.load(Ordering::Relaxed) {
            match self.listener.accept() {
                Ok((stream, peer)) => {
                    readers.retain(|h: &thread::JoinHandle<()>| !h.is_finished());
                    if lock_writers(&self.writers).len() >= MAX_CONNECTIONS {
                        tracing::warn!(%peer, "too many TCP connections, refusing");
                        continue;
                    }
                    match self.start_connection(stream, peer, stop) {
                        Ok(h) => readers.push(h),
                        Err(e) => tracing::warn!(%peer, "cannot serve TCP connection: {e}"),
                    }
                }
                Err(e) if e.kind() == io::ErrorKind::WouldBlock => thread::sleep(Duration::from_millis(20)),
                Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
                Err(e) => tracing::warn!("TCP accept failed: {e}"),
            }
        }
        for (_, (_, s)) in lock_writers(&self.writers).drain() {
            let _ = s.shutdown(Shutdown::Both);
        }
        for h in readers {
            let _ = h.join();
        }
        let _ = timers.join();
        Ok(())
    }

    fn start_connection(
        &self,
        stream: TcpStream,
        peer: SocketAddr,
        stop: &Arc<AtomicBool>,
    ) -> io::Result<thread::JoinHandle<()>> {
        stream.set_nonblocking(false)?;
        stream.set_nodelay(true)?;
        stream.set_write_timeout(Some(WRITE_TIMEOUT))?;
        stream.set_read_timeout(Some(MAX_BLOCK))?;
        let id = ConnId(self.next_id.fetch_add(1, Ordering::Relaxed));
        lock_writers(&self.writers).insert(id, (peer, stream.try_clone()?));
        tracing::info!(%peer, conn = id.0, "TCP connection accepted");
        let (core, writers, stop) = (self.core.clone(), self.writers.clone(), stop.clone());
        thread::Builder::new()
            .name(format!("xrce-tcp-{}", id.0))
            .spawn(move || read_loop(stream, peer, id, &core, &writers, &stop))
    }
}

fn read_loop(
    mut stream: TcpStream,
    peer: SocketAddr,
    id: ConnId,
    core: &SharedCore<ConnId>,
    writers: &Writers,
    stop: &AtomicBool,
) {
    let mut decoder = TcpDecoder::new(vec![0u8; MAX_MESSAGE_LEN]);
    let mut buf = vec![0u8; 64 * 1024];
    while !stop.load(Ordering::Relaxed) {
        let n = match stream.read(&mut buf) {
            Ok(0) => break,
            Ok(n) => n,
            Err(e)
                if matches!(
                    e.kind(),
                    io::ErrorKind::WouldBlock | io::ErrorKind::TimedOut | io::ErrorKind::Interrupted
                ) =>
            {
                continue
            }
            Err(e) => {
                tracing::debug!(%peer, "TCP read failed: {e}");
                break;
            }
        };
        {
            let mut c = lock(core);
            decoder.push(buf.get(..n).unwrap_or(&[]), |event| match event {
                TcpEvent::Message(msg) => {
                    hexdump("recv", &peer, msg);
                    c.handle_datagram(id, msg, Instant::now());
                }
                TcpEvent::Error(e) => tracing::warn!(%peer, "{e}"),
            });
        }
        dispatch(core, writers, drain(core));
    }
    tracing::info!(%peer, conn = id.0, "TCP connection closed");
    close(core, writers, id);
}

/// Runs the core's timers, and polls the middleware when its waker fired (samples from a threaded
/// middleware).
fn timer_loop(core: &SharedCore<ConnId>, writers: &Writers, stop: &AtomicBool, wake: &WakeSignal) {
    while !stop.load(Ordering::Relaxed) {
        let next = lock(core).poll_timeout();
        let woken = wake.wait(block_for(next, Instant::now()));
        {
            let mut c = lock(core);
            let now = Instant::now();
            if woken {
                c.poll_middleware(now);
            }
            if c.poll_timeout().is_some_and(|t| t <= now) {
                c.handle_timeout(now);
            }
        }
        dispatch(core, writers, drain(core));
    }
}
