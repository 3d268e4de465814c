//! UDP shell (IPv4 and IPv6): one XRCE message per datagram, replies to the datagram's source (spec §12.1).
//!
//! One thread, one `mio` loop ([`EventLoop`]) on the socket and the middleware's
//! waker. When the socket is readable a turn takes every queued datagram up to a batch
//! ([`batch`](super::batch), `recvmmsg` on Linux), runs them through the core under one lock, sends the
//! ACKNACKs owed at once (`AgentCore::poll_acknack`), then delivers
//! the batch's samples and sends the rest in batches (`sendmmsg`; a run of equal-size datagrams to one peer,
//! such as the fragments of a sample, as one UDP GSO send). After a turn that received datagrams the next
//! batch is read at once, without a readiness poll, as long as batches come back full. Socket buffers are
//! enlarged ([`SOCKET_BUFFER`]) so bursts are queued rather than dropped while the thread is descheduled.
//! Sent buffers go back to the core's pool: no allocation per message once warm. Sends block (the socket
//! stays in blocking mode) as they always did; receives never do.

use std::io;
use std::net::{SocketAddr, UdpSocket};
use std::os::fd::AsRawFd;
use std::sync::atomic::AtomicBool;

use mio::event::Event;
use mio::unix::SourceFd;
use mio::{Interest, Registry};
use socket2::{Domain, Protocol, Socket, Type};

use super::batch::{RecvBatch, SendBatch, BATCH};
use super::discovery::DiscoveryServer;
use super::drive::{EventLoop, Inbox, Io, Spent, Tokens};
use super::SharedCore;
use crate::core::Transmit;

/// Largest datagram received (eProsima's agent buffer).
pub const MAX_DATAGRAM: usize = 65_535;
/// Requested `SO_RCVBUF` / `SO_SNDBUF` (the kernel caps it at `net.core.rmem_max` / `wmem_max`).
pub const SOCKET_BUFFER: usize = 4 << 20;

/// A UDP server around a shared core.
#[derive(Debug)]
pub struct UdpServer {
    socket: UdpSocket,
    looped: EventLoop<SocketAddr>,
}

/// Binds a UDP socket with enlarged buffers.
pub fn bind_socket(addr: SocketAddr) -> io::Result<UdpSocket> {
    let socket = Socket::new(Domain::for_address(addr), Type::DGRAM, Some(Protocol::UDP))?;
    if let Err(e) = socket.set_recv_buffer_size(SOCKET_BUFFER) {
        tracing::debug!("cannot enlarge the UDP receive buffer: {e}");
    }
    if let Err(e) = socket.set_send_buffer_size(SOCKET_BUFFER) {
        tracing::debug!("cannot enlarge the UDP send buffer: {e}");
    }
    socket.bind(&addr.into())?;
    Ok(socket.into())
}

impl UdpServer {
    /// Binds `addr` (port 0: an ephemeral port) and installs the middleware waker.
    pub fn bind(addr: SocketAddr, core: SharedCore<SocketAddr>) -> io::Result<Self> {
        Self::from_socket(bind_socket(addr)?, core)
    }

    /// A server on a bound socket (e.g. one from [`bind_socket`] with options of the caller's); installs the
    /// middleware waker.
    pub fn from_socket(socket: UdpSocket, core: SharedCore<SocketAddr>) -> io::Result<Self> {
        Ok(Self { socket, looped: EventLoop::new(core)? })
    }

    /// Answers discovery requests (`-d`) from this server's loop.
    #[must_use]
    pub fn with_discovery(mut self, discovery: DiscoveryServer) -> Self {
        self.looped.set_discovery(discovery);
        self
    }

    /// The bound address.
    pub fn local_addr(&self) -> io::Result<SocketAddr> {
        self.socket.local_addr()
    }

    /// Serves until `stop` is set (checked at least every [`super::MAX_BLOCK`]).
    pub fn run(&self, stop: &AtomicBool) -> io::Result<()> {
        let name = format!("the UDP server on {}", self.socket.local_addr()?);
        self.looped.run(&name, stop, |registry| UdpIo::register(&self.socket, registry, Tokens::ALONE))?;
        Ok(())
    }
}

/// The socket as the event loop sees it.
pub(crate) struct UdpIo<'a> {
    socket: &'a UdpSocket,
    rx: RecvBatch,
    tx: SendBatch,
    /// Datagrams may be queued: readiness was reported, or the last batch was full (it may have left some
    /// behind, which edge-triggered readiness does not announce again). A partial batch drained the queue:
    /// the kernel's `recvmmsg` stops short only at an empty queue or at an error, and an error is queued
    /// on an unconnected socket only with `IP_RECVERR`, which the agent does not set. Every datagram that
    /// arrives later raises a readiness event of its own (Linux wakes an edge-triggered epoll per arrival),
    /// so skipping the read that would find the queue empty costs nothing (one system call per wake-up
    /// less); a turn woken by its timer alone reads anyway ([`Io::idle`]), in case.
    readable: bool,
    /// The last read got datagrams: under load more have likely arrived during the turn, so the loop reads
    /// again before waiting for readiness, which saves the `epoll_wait` per turn while datagrams keep coming
    /// (a read that finds nothing ends it).
    busy: bool,
    /// Datagrams in `rx` not yet handed to the core.
    fetched: usize,
}

impl<'a> UdpIo<'a> {
    /// Registers `socket` with the loop's `registry` in the shell's token range.
    pub(crate) fn register(socket: &'a UdpSocket, registry: &Registry, tokens: Tokens) -> io::Result<Self> {
        registry.register(&mut SourceFd(&socket.as_raw_fd()), tokens.token(1), Interest::READABLE)?;
        Ok(Self {
            socket,
            rx: RecvBatch::new(MAX_DATAGRAM),
            tx: SendBatch::new(),
            // Datagrams may have been queued before the registration.
            readable: true,
            busy: false,
            fetched: 0,
        })
    }

    fn fetch(&mut self) -> io::Result<()> {
        self.fetched = self.rx.recv(self.socket)?;
        self.readable = self.fetched == BATCH;
        self.busy = self.fetched > 0;
        Ok(())
    }
}

impl Io<SocketAddr> for UdpIo<'_> {
    const EARLY_ACKNACKS: bool = true;

    fn ready(&mut self, _event: &Event) {
        self.readable = true;
    }

    fn idle(&mut self) {
        self.readable = true;
    }

    fn prefetch(&mut self) -> io::Result<bool> {
        if (self.readable || self.busy) && self.fetched == 0 {
            self.fetch()?;
        }
        Ok(self.fetched > 0)
    }

    fn receive(&mut self, inbox: &mut Inbox<'_, SocketAddr>) -> io::Result<()> {
        if self.readable && self.fetched == 0 {
            self.fetch()?;
        }
        for i in 0..std::mem::take(&mut self.fetched) {
            if let Some((from, bytes)) = self.rx.get(i) {
                inbox.deliver(from, bytes);
            }
        }
        Ok(())
    }

    fn send(&mut self, out: &mut Vec<Transmit<SocketAddr>>, spent: &mut Spent<SocketAddr>) {
        self.tx.send(self.socket, out);
        spent.buffers.extend(out.drain(..).map(|t| t.data));
    }
}
