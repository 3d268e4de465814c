//! Several transports on one core (issue 24): UDP sockets, TCP listeners, serial lines and CAN FD buses served
//! by one [`EventLoop`], so that their clients share one client table, one set of CED topics and one set of
//! DDS participants. Each transport is the same shell as when it runs alone ([`UdpIo`], [`TcpIo`],
//! [`SerialIo`], [`CanIo`]), registered in a token range of its own ([`Tokens::shared`]); the core's
//! endpoints are [`AnyEndpoint`]s, the shell's endpoint tagged with the transport's index.
//!
//! One thread serves them all: every source is a file descriptor `mio` polls, the core is single-threaded
//! anyway, and a loop per transport would need a lock or a channel hop per message to reach it. A transport
//! whose reads fail (its socket broke) is logged and left aside; the others go on (serial devices that go
//! away are reopened by their shell, as when alone).

use std::fmt;
use std::io;
use std::net::{SocketAddr, TcpListener, UdpSocket};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::Instant;

use mio::event::Event;
use mio::Registry;

#[cfg(target_os = "linux")]
use super::canfd::{CanEndpoint, CanIo, SocketCanBus};
use super::custom::shell::{EndpointTable, Shell as CustomShell};
use super::custom::{CustomAgentError, CustomAgentIo, CustomOptions, EndpointDesc, EndpointId, Mode, Parts};
use super::discovery::DiscoveryServer;
use super::drive::{EventLoop, Inbox, Io, Sink, Spent, Tokens};
#[cfg(target_os = "linux")]
use super::serial::{Line, SerialEndpoint, SerialIo};
use super::tcp::{ConnId, TcpIo};
use super::udp::UdpIo;
use super::SharedCore;
use crate::core::Transmit;

/// A client's endpoint on one of the transports: which one, and the shell's own endpoint.
#[derive(Clone, Copy, PartialEq, Eq, Hash)]
pub struct AnyEndpoint {
    /// Index of the transport, in the order they were added to the [`MultiServer`].
    pub transport: u8,
    /// The endpoint on that transport.
    pub peer: Peer,
}

/// A shell's own endpoint.
#[derive(Clone, Copy, PartialEq, Eq, Hash)]
pub enum Peer {
    /// A UDP peer.
    Udp(SocketAddr),
    /// A TCP connection.
    Tcp(ConnId),
    /// A client on a serial line.
    #[cfg(target_os = "linux")]
    Serial(SerialEndpoint),
    /// A client on a CAN FD bus.
    #[cfg(target_os = "linux")]
    Can(CanEndpoint),
    /// An endpoint of a custom transport.
    Custom(EndpointId),
}

impl fmt::Debug for AnyEndpoint {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match &self.peer {
            Peer::Udp(a) => write!(f, "udp {a}"),
            Peer::Tcp(c) => write!(f, "tcp {c}"),
            #[cfg(target_os = "linux")]
            Peer::Serial(s) => write!(f, "{s}"),
            #[cfg(target_os = "linux")]
            Peer::Can(c) => write!(f, "{c:?}"),
            Peer::Custom(e) => write!(f, "{e}"),
        }
    }
}

impl AnyEndpoint {
    /// The peer's IP address, for `--allow` rules (none on serial lines and CAN buses).
    pub fn ip_address(&self) -> Option<SocketAddr> {
        match self.peer {
            Peer::Udp(a) => Some(a),
            Peer::Tcp(c) => Some(c.peer),
            _ => None,
        }
    }

    /// The name of the transport the peer is on, as the command line's subcommands name them (`udp4`,
    /// `tcp6`, `serial`, `canfd`, `custom`): a client's own transport in snapshots and metrics.
    pub fn transport_name(&self) -> &'static str {
        match self.peer {
            Peer::Udp(a) if a.is_ipv4() => "udp4",
            Peer::Udp(_) => "udp6",
            Peer::Tcp(c) if c.peer.is_ipv4() => "tcp4",
            Peer::Tcp(_) => "tcp6",
            #[cfg(target_os = "linux")]
            Peer::Serial(_) => "serial",
            #[cfg(target_os = "linux")]
            Peer::Can(_) => "canfd",
            Peer::Custom(_) => "custom",
        }
    }
}

/// The shells' endpoint types, as [`Peer`]s and back.
trait ShellEndpoint: Copy + fmt::Debug + Sized {
    fn wrap(self) -> Peer;
    fn unwrap(peer: Peer) -> Option<Self>;
}

macro_rules! shell_endpoint {
    ($($ty:ty => $variant:ident $(#[$cfg:meta])?),* $(,)?) => {
        $(
            $(#[$cfg])?
            impl ShellEndpoint for $ty {
                fn wrap(self) -> Peer {
                    Peer::$variant(self)
                }
                #[allow(irrefutable_let_patterns, unreachable_patterns)]
                fn unwrap(peer: Peer) -> Option<Self> {
                    match peer {
                        Peer::$variant(e) => Some(e),
                        _ => None,
                    }
                }
            }
        )*
    };
}

shell_endpoint!(
    SocketAddr => Udp,
    ConnId => Tcp,
    EndpointId => Custom,
    SerialEndpoint => Serial #[cfg(target_os = "linux")],
    CanEndpoint => Can #[cfg(target_os = "linux")],
);

/// A shell's view of the shared inbox: its endpoints go in tagged with its index.
struct Tagged<'i, 'c> {
    inbox: &'i mut Inbox<'c, AnyEndpoint>,
    transport: u8,
}

impl<E: ShellEndpoint> Sink<E> for Tagged<'_, '_> {
    fn deliver(&mut self, from: E, bytes: &[u8], _now: Instant) {
        self.inbox.deliver(AnyEndpoint { transport: self.transport, peer: from.wrap() }, bytes);
    }

    fn forget(&mut self, endpoint: E) {
        self.inbox.forget(AnyEndpoint { transport: self.transport, peer: endpoint.wrap() });
    }
}

/// One shell with its share of a turn's messages.
struct Served<I, E> {
    io: I,
    out: Vec<Transmit<E>>,
    spent: Spent<E>,
    name: String,
    /// Its reads failed: left aside, the others go on.
    failed: bool,
}

impl<I: Io<E>, E: ShellEndpoint> Served<I, E> {
    fn new(io: I, name: String) -> Self {
        Self { io, out: Vec::new(), spent: Spent { buffers: Vec::new(), gone: Vec::new() }, name, failed: false }
    }

    /// Sets the shell aside when `result` is an error.
    fn check<T: Default>(&mut self, result: io::Result<T>) -> T {
        result.unwrap_or_else(|e| {
            tracing::error!(transport = %self.name, "transport failed, the others go on: {e}");
            self.failed = true;
            T::default()
        })
    }

    fn prefetch(&mut self) -> bool {
        if self.failed {
            return false;
        }
        let got = self.io.prefetch();
        self.check(got)
    }

    fn receive(&mut self, transport: u8, inbox: &mut Inbox<'_, AnyEndpoint>) {
        if self.failed {
            return;
        }
        let now = inbox.now();
        let mut tagged = Tagged { inbox, transport };
        let mut own = Inbox::new(&mut tagged, now, false);
        let got = self.io.receive(&mut own);
        self.check(got);
    }

    fn queue(&mut self, to: Peer, data: Vec<u8>, spent: &mut Spent<AnyEndpoint>) {
        match E::unwrap(to) {
            Some(to) => self.out.push(Transmit { to, data }),
            None => spent.buffers.push(data),
        }
    }

    /// Every turn, as when alone, even with nothing new: TCP and serial shells write their outboxes as their
    /// peers take them, and close those that stopped taking.
    fn send(&mut self, transport: u8, spent: &mut Spent<AnyEndpoint>) {
        self.io.send(&mut self.out, &mut self.spent);
        spent.buffers.append(&mut self.spent.buffers);
        spent.gone.extend(self.spent.gone.drain(..).map(|e| AnyEndpoint { transport, peer: e.wrap() }));
    }
}

/// The shells of a [`MultiServer`], as its loop runs them. A handful live in one vector for the server's
/// life: the UDP shell's inline batch headers cost nothing there, and a box would cost a pointer hop per turn.
#[allow(clippy::large_enum_variant)]
enum Shell<'a> {
    Udp(Served<UdpIo<'a>, SocketAddr>),
    Tcp(Served<TcpIo, ConnId>),
    #[cfg(target_os = "linux")]
    Serial(Served<SerialIo, SerialEndpoint>),
    #[cfg(target_os = "linux")]
    Can(Served<CanIo<'a, SocketCanBus>, CanEndpoint>),
    Custom(Served<CustomShell, EndpointId>),
}

/// Runs `$body` on the [`Served`] of any shell.
macro_rules! each {
    ($shell:expr, $s:ident => $body:expr) => {
        match $shell {
            Shell::Udp($s) => $body,
            Shell::Tcp($s) => $body,
            #[cfg(target_os = "linux")]
            Shell::Serial($s) => $body,
            #[cfg(target_os = "linux")]
            Shell::Can($s) => $body,
            Shell::Custom($s) => $body,
        }
    };
}

/// Every shell as one [`Io`] for the loop.
struct MultiIo<'a> {
    shells: Vec<Shell<'a>>,
}

impl Io<AnyEndpoint> for MultiIo<'_> {
    /// UDP's gain; the other shells' ACKNACKs only leave in a send of their own.
    const EARLY_ACKNACKS: bool = true;

    fn ready(&mut self, event: &Event) {
        if let Some(shell) = Tokens::shell_of(event.token()).and_then(|i| self.shells.get_mut(i)) {
            each!(shell, s => s.io.ready(event));
        }
    }

    fn idle(&mut self) {
        for shell in &mut self.shells {
            each!(shell, s => s.io.idle());
        }
    }

    fn prefetch(&mut self) -> io::Result<bool> {
        let mut any = false;
        for shell in &mut self.shells {
            any |= each!(shell, s => s.prefetch());
        }
        Ok(any)
    }

    fn receive(&mut self, inbox: &mut Inbox<'_, AnyEndpoint>) -> io::Result<()> {
        for (index, shell) in (0u8..).zip(&mut self.shells) {
            each!(shell, s => s.receive(index, inbox));
        }
        Ok(())
    }

    fn send(&mut self, out: &mut Vec<Transmit<AnyEndpoint>>, spent: &mut Spent<AnyEndpoint>) {
        for Transmit { to, data } in out.drain(..) {
            match self.shells.get_mut(usize::from(to.transport)) {
                Some(shell) => each!(shell, s => s.queue(to.peer, data, spent)),
                None => spent.buffers.push(data),
            }
        }
        for (index, shell) in (0u8..).zip(&mut self.shells) {
            each!(shell, s => s.send(index, spent));
        }
    }
}

/// A transport waiting for its server to run.
#[derive(Debug)]
enum Source {
    Udp(UdpSocket),
    Tcp(TcpListener, usize),
    #[cfg(target_os = "linux")]
    Serial(Vec<Line>),
    #[cfg(target_os = "linux")]
    Can(SocketCanBus, String),
    Custom(CustomSource),
}

/// A custom transport (the user's `read` and `write`, [`super::custom`]), opened, its reader not started.
struct CustomSource {
    name: String,
    desc: EndpointDesc,
    mode: Mode,
    options: CustomOptions,
    io: Arc<dyn CustomAgentIo>,
}

impl fmt::Debug for CustomSource {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("CustomSource").field("name", &self.name).field("mode", &self.mode).finish_non_exhaustive()
    }
}

impl Source {
    fn name(&self) -> String {
        match self {
            Self::Udp(s) => format!("UDP {}", s.local_addr().map_or_else(|e| e.to_string(), |a| a.to_string())),
            Self::Tcp(l, _) => format!("TCP {}", l.local_addr().map_or_else(|e| e.to_string(), |a| a.to_string())),
            #[cfg(target_os = "linux")]
            Self::Serial(lines) => {
                format!("serial {}", lines.iter().map(Line::name).collect::<Vec<_>>().join(" "))
            }
            #[cfg(target_os = "linux")]
            Self::Can(_, name) => format!("CAN FD {name}"),
            Self::Custom(c) => format!("custom {}", c.name),
        }
    }
}

/// A server on several transports at once, around one core (endpoints [`AnyEndpoint`]).
#[derive(Debug)]
pub struct MultiServer {
    looped: EventLoop<AnyEndpoint>,
    sources: Vec<Source>,
}

/// Too many transports for one server ([`Tokens::MAX_SHARED`]).
fn too_many() -> io::Error {
    io::Error::other(format!("one agent serves at most {} transports", Tokens::MAX_SHARED))
}

impl MultiServer {
    /// A server with no transport yet; installs the middleware's waker.
    pub fn new(core: SharedCore<AnyEndpoint>) -> io::Result<Self> {
        Ok(Self { looped: EventLoop::new(core)?, sources: Vec::new() })
    }

    fn add(&mut self, source: Source) -> io::Result<u8> {
        let index = u8::try_from(self.sources.len()).ok().filter(|&i| usize::from(i) < Tokens::MAX_SHARED);
        let index = index.ok_or_else(too_many)?;
        self.sources.push(source);
        Ok(index)
    }

    /// Adds a bound UDP socket (e.g. from [`super::udp::bind_socket`]); returns the transport's index.
    pub fn add_udp(&mut self, socket: UdpSocket) -> io::Result<u8> {
        self.add(Source::Udp(socket))
    }

    /// Adds a listening TCP socket serving at most `max_connections` at once (more are closed on accept;
    /// [`super::tcp::DEFAULT_MAX_CONNECTIONS`] is the command line's default); returns the transport's index.
    pub fn add_tcp(&mut self, listener: TcpListener, max_connections: usize) -> io::Result<u8> {
        listener.set_nonblocking(true)?;
        self.add(Source::Tcp(listener, max_connections))
    }

    /// Adds serial lines (devices or pseudoterminals), served as one `multiserial` transport.
    #[cfg(target_os = "linux")]
    pub fn add_serial(&mut self, lines: Vec<Line>) -> io::Result<u8> {
        if u16::try_from(lines.len()).is_err() {
            return Err(io::Error::other(format!("too many serial lines: {}", lines.len())));
        }
        self.add(Source::Serial(lines))
    }

    /// Adds a CAN FD bus named `name` in logs.
    #[cfg(target_os = "linux")]
    pub fn add_can(&mut self, bus: SocketCanBus, name: impl Into<String>) -> io::Result<u8> {
        self.add(Source::Can(bus, name.into()))
    }

    /// Adds a custom transport (eProsima's `CustomAgent` operations, [`super::custom`]): opens it now (its
    /// `open`), starts its reader thread when the server runs, closes it when the server stops.
    pub fn add_custom(
        &mut self,
        name: impl Into<String>,
        endpoint: EndpointDesc,
        mode: impl Into<Mode>,
        io: impl CustomAgentIo,
        options: CustomOptions,
    ) -> Result<u8, CustomAgentError> {
        let name = name.into();
        if let Err(source) = endpoint.validate() {
            return Err(CustomAgentError::Endpoint { name, source });
        }
        let io: Arc<dyn CustomAgentIo> = Arc::new(io);
        io.open().map_err(|source| CustomAgentError::Open { name: name.clone(), source })?;
        let source =
            Source::Custom(CustomSource { name: name.clone(), desc: endpoint, mode: mode.into(), options, io });
        self.add(source).map_err(|source| CustomAgentError::Io { name, source })
    }

    /// Answers discovery requests (`-d`) from this server's loop.
    #[must_use]
    pub fn with_discovery(mut self, discovery: DiscoveryServer) -> Self {
        self.looped.set_discovery(discovery);
        self
    }

    /// The transports' names, in order ("UDP 0.0.0.0:8888", "serial /dev/ttyACM0", …).
    pub fn names(&self) -> Vec<String> {
        self.sources.iter().map(Source::name).collect()
    }

    /// Serves every transport until `stop` is set (checked at least every [`super::MAX_BLOCK`]).
    pub fn run(mut self, stop: &AtomicBool) -> io::Result<()> {
        let label = format!("the server on {}", self.names().join(", "));
        let readers_stop = Arc::new(AtomicBool::new(false));
        let mut readers = Vec::new();
        let served = self
            .looped
            .run(&label, stop, |registry| register(&mut self.sources, registry, &readers_stop, &mut readers))
            .map(|io| io.shells);
        readers_stop.store(true, Ordering::Relaxed);
        let result = served.map(|shells| shells.into_iter().for_each(finish));
        // The custom transports' loop sides are gone: their readers end, then the transports are closed.
        for reader in readers {
            let _ = reader.join();
        }
        for source in &self.sources {
            if let Source::Custom(c) = source {
                if let Err(e) = c.io.close() {
                    tracing::warn!(transport = %c.name, "custom transport close failed: {e}");
                }
            }
        }
        result
    }
}

/// What a shell leaves when its server stops: TCP connections shut, CAN losses logged.
fn finish(shell: Shell<'_>) {
    match shell {
        Shell::Tcp(mut s) => s.io.close_all(),
        #[cfg(target_os = "linux")]
        Shell::Can(s) if s.io.dropped() > 0 => {
            tracing::debug!(bus = %s.name, dropped = s.io.dropped(), "CAN frames dropped while sending");
        }
        _ => {}
    }
}

/// Registers every source with the loop's `registry`, each in its own token range; custom transports' readers
/// start (until `readers_stop`), their handles going to `readers`.
fn register<'a>(
    sources: &'a mut [Source],
    registry: &Registry,
    readers_stop: &Arc<AtomicBool>,
    readers: &mut Vec<JoinHandle<()>>,
) -> io::Result<MultiIo<'a>> {
    let mut shells = Vec::with_capacity(sources.len());
    for (index, source) in sources.iter_mut().enumerate() {
        let tokens = Tokens::shared(index).ok_or_else(too_many)?;
        let name = source.name();
        shells.push(match source {
            Source::Udp(socket) => Shell::Udp(Served::new(UdpIo::register(socket, registry, tokens)?, name)),
            Source::Tcp(listener, max) => {
                Shell::Tcp(Served::new(TcpIo::register(listener, registry, tokens, *max)?, name))
            }
            #[cfg(target_os = "linux")]
            Source::Serial(lines) => {
                let io = SerialIo::register(std::mem::take(lines), registry, tokens)?;
                Shell::Serial(Served::new(io, name))
            }
            #[cfg(target_os = "linux")]
            Source::Can(bus, interface) => {
                let io = CanIo::register(bus, super::device_name(interface), registry, tokens)?;
                Shell::Can(Served::new(io, name))
            }
            Source::Custom(c) => {
                let parts = Parts { name: &c.name, desc: &c.desc, mode: c.mode, options: &c.options, io: &c.io };
                let (mut shell, reader) = parts.start(EndpointTable::new(c.options.max_endpoints), readers_stop)?;
                readers.push(reader);
                shell.register(registry, tokens.token(1))?;
                Shell::Custom(Served::new(shell, name))
            }
        });
    }
    Ok(MultiIo { shells })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::core::{AgentCore, CoreConfig};
    use crate::middleware::ced::Ced;
    use crate::middleware::describe::FallbackProfiles;
    use crate::transport::home::Core;

    /// A transport whose reads fail: its socket broke.
    #[derive(Default)]
    struct Broken {
        reads: usize,
    }

    impl Io<SocketAddr> for Broken {
        fn ready(&mut self, _: &Event) {}
        fn receive(&mut self, _: &mut Inbox<'_, SocketAddr>) -> io::Result<()> {
            self.reads += 1;
            Err(io::Error::other("socket broke"))
        }
        fn send(&mut self, out: &mut Vec<Transmit<SocketAddr>>, spent: &mut Spent<SocketAddr>) {
            spent.buffers.extend(out.drain(..).map(|t| t.data));
        }
    }

    /// A transport that fails is set aside, once: no error reaches the loop (which would stop every
    /// transport), and it is not read again.
    #[test]
    fn a_failing_transport_is_set_aside_without_stopping_the_loop() {
        let mut core: Core<AnyEndpoint> =
            AgentCore::new(CoreConfig::default(), Box::new(Ced::new(Arc::new(FallbackProfiles))));
        let mut served = Served::new(Broken::default(), "UDP 127.0.0.1:1".into());
        let mut inbox = Inbox::new(&mut core, Instant::now(), false);
        served.receive(0, &mut inbox);
        served.receive(0, &mut inbox);
        assert!(served.failed);
        assert_eq!(served.io.reads, 1, "not read again");
        assert!(!served.prefetch());
        // What the core still sends it goes back to the pool.
        let mut spent = Spent { buffers: Vec::new(), gone: Vec::new() };
        served.queue(Peer::Udp(([127, 0, 0, 1], 2).into()), vec![1, 2, 3], &mut spent);
        served.queue(Peer::Tcp(ConnId { number: 1, peer: ([127, 0, 0, 1], 3).into() }), vec![4], &mut spent);
        served.send(0, &mut spent);
        assert_eq!(spent.buffers.len(), 2, "the message of another transport's kind and the sent one");
    }

    #[test]
    fn an_endpoint_names_its_transport_by_kind_and_address_family() {
        let on = |peer| AnyEndpoint { transport: 3, peer }.transport_name();
        let v6: SocketAddr = "[::1]:7".parse().unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(on(Peer::Udp(([127, 0, 0, 1], 7).into())), "udp4");
        assert_eq!(on(Peer::Udp(v6)), "udp6");
        assert_eq!(on(Peer::Tcp(ConnId { number: 1, peer: ([127, 0, 0, 1], 7).into() })), "tcp4");
        assert_eq!(on(Peer::Tcp(ConnId { number: 1, peer: v6 })), "tcp6");
    }
}
