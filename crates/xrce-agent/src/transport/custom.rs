//! Custom agent transports (eProsima's `CustomAgent` and `CustomEndPoint`, seed 004): an agent served over
//! the user's own I/O code, in packet mode (each `read` returns one whole XRCE message, each `write` sends
//! one) or stream mode (the bytes are a stream carrying the HDLC-like frames of
//! [`xrce_proto::framing::serial`], as eProsima's custom transport with `framing = true`).
//!
//! The user gives four operations, as a [`CustomAgentIo`] or as closures ([`CustomCallbacks`]), and
//! declares the members of its endpoints ([`EndpointDesc`]): `read` fills an [`Endpoint`] with where the
//! message came from, and the agent hands that endpoint back to `write` for every message to that client.
//!
//! # How user I/O meets the event loop
//!
//! The user's `read` may block (a vendor SDK, a blocking socket, a bus driver) and need not have a file
//! descriptor, so it cannot be polled by `mio`. It runs on a reader thread of its own, called with a
//! timeout ([`CustomOptions::read_timeout`], also how soon [`crate::custom_agent::CustomAgent::stop`] returns); each message
//! goes to the agent's event loop ([`EventLoop`]) through a bounded channel, and the reader wakes the
//! loop's poll through a pipe the loop registers (`mio` allows one `Waker` per poll, the middleware's),
//! once for any number of messages between two turns; the loop then drains the channel without waiting.
//! Unframing happens on the reader thread too, one decoder per endpoint, so peers sharing the transport
//! never corrupt each other's frames. A full channel blocks
//! the reader: the user's medium buffers meanwhile. `write` is called from the loop thread, as the UDP
//! server sends; it may block, which delays the other clients as a full socket would. The cost over a
//! polled descriptor is one channel hop per message (a session ping's round trip over an in-memory medium:
//! median 33-35 µs in a debug build, against 26 µs through the built-in UDP server on loopback; the
//! ignored `round_trip_report` tests of `tests/custom_agent.rs` measure it). Registering a
//! descriptor of the user's with the loop instead would save that hop for media that have one, at the
//! price of a second way to write a transport; the thread serves every medium.
//!
//! The core needs a small copyable peer type, and endpoints hold strings: each distinct endpoint (with, in
//! stream mode, its frame's source address) gets an [`EndpointId`], kept in a bounded table
//! ([`CustomOptions::max_endpoints`]).

mod endpoint;
mod reader;
pub(crate) mod shell;

use std::io;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::sync_channel;
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::Duration;

pub use endpoint::{Endpoint, EndpointDesc, EndpointError, Member, MemberKind, MemberValue};

use super::drive::EventLoop;
use super::{SharedCore, WakeFlag};
use crate::middleware::BuildError;
use reader::{Reader, Wake};
pub(crate) use shell::EndpointTable;
use shell::Shell;

/// The agent's framing address, as eProsima's custom agent uses: it takes frames sent to it and answers
/// each client at its frames' source address.
pub const AGENT_ADDRESS: u8 = 0;

/// The loop's token for the reader's wake-up pipe (the middleware's waker is 0).
const READER: mio::Token = mio::Token(1);

/// The four operations of a custom transport (eProsima's `InitFunction`, `FiniFunction`, `SendMsgFunction`,
/// `RecvMsgFunction`). They take `&self` because the agent reads on one thread while it writes on another,
/// as eProsima's do: keep mutable state behind a lock (one per direction keeps them apart). After a failed
/// `read`, `close` and `open` run on the reading thread while `write` may still be called.
pub trait CustomAgentIo: Send + Sync + 'static {
    /// Opens the medium; called by [`CustomAgent::start`], and again after a failed `read`.
    fn open(&self) -> io::Result<()> {
        Ok(())
    }

    /// Closes the medium; called by [`CustomAgent::stop`], and before reopening after a failed `read`.
    fn close(&self) -> io::Result<()> {
        Ok(())
    }

    /// Sends `bytes` to `to`, returning how many were taken. Packet mode: one whole message, anything less
    /// is an error. Stream mode: part of it may be taken, and the rest comes in the next call.
    fn write(&self, to: &Endpoint, bytes: &[u8]) -> io::Result<usize>;

    /// Waits up to `timeout` for input and copies it into `buf`, setting every member of `from` to where it
    /// came from. Packet mode: one whole message. Stream mode: any run of bytes of the stream from `from`.
    /// `Ok(0)`, or an error of kind `TimedOut` or `WouldBlock`, means nothing came; any other error makes
    /// the agent close and reopen the transport. It must return within about `timeout`, or stopping the
    /// agent waits for it.
    fn read(&self, from: &mut Endpoint, buf: &mut [u8], timeout: Duration) -> io::Result<usize>;
}

impl<T: CustomAgentIo + ?Sized> CustomAgentIo for Arc<T> {
    fn open(&self) -> io::Result<()> {
        (**self).open()
    }
    fn close(&self) -> io::Result<()> {
        (**self).close()
    }
    fn write(&self, to: &Endpoint, bytes: &[u8]) -> io::Result<usize> {
        (**self).write(to, bytes)
    }
    fn read(&self, from: &mut Endpoint, buf: &mut [u8], timeout: Duration) -> io::Result<usize> {
        (**self).read(from, buf, timeout)
    }
}

/// The four operations as closures, eProsima's callback style.
#[derive(Debug, Clone)]
pub struct CustomCallbacks<O, C, W, R> {
    open: O,
    close: C,
    write: W,
    read: R,
}

impl<O, C, W, R> CustomCallbacks<O, C, W, R>
where
    O: Fn() -> io::Result<()> + Send + Sync + 'static,
    C: Fn() -> io::Result<()> + Send + Sync + 'static,
    W: Fn(&Endpoint, &[u8]) -> io::Result<usize> + Send + Sync + 'static,
    R: Fn(&mut Endpoint, &mut [u8], Duration) -> io::Result<usize> + Send + Sync + 'static,
{
    /// The operations of [`CustomAgentIo`], in its order.
    pub fn new(open: O, close: C, write: W, read: R) -> Self {
        Self { open, close, write, read }
    }
}

impl<O, C, W, R> CustomAgentIo for CustomCallbacks<O, C, W, R>
where
    O: Fn() -> io::Result<()> + Send + Sync + 'static,
    C: Fn() -> io::Result<()> + Send + Sync + 'static,
    W: Fn(&Endpoint, &[u8]) -> io::Result<usize> + Send + Sync + 'static,
    R: Fn(&mut Endpoint, &mut [u8], Duration) -> io::Result<usize> + Send + Sync + 'static,
{
    fn open(&self) -> io::Result<()> {
        (self.open)()
    }
    fn close(&self) -> io::Result<()> {
        (self.close)()
    }
    fn write(&self, to: &Endpoint, bytes: &[u8]) -> io::Result<usize> {
        (self.write)(to, bytes)
    }
    fn read(&self, from: &mut Endpoint, buf: &mut [u8], timeout: Duration) -> io::Result<usize> {
        (self.read)(from, buf, timeout)
    }
}

/// eProsima's `framing` flag: `true` is [`Mode::Stream`], `false` [`Mode::Packet`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mode {
    /// Framing off: the medium carries whole messages (datagrams, CAN-like packets, queues).
    Packet,
    /// Framing on: the medium is a byte stream (UART, pipe, TCP-like), messages travel in HDLC-like frames.
    Stream,
}

impl From<bool> for Mode {
    fn from(framing: bool) -> Self {
        if framing {
            Self::Stream
        } else {
            Self::Packet
        }
    }
}

/// The core's name for an endpoint of a custom transport (see the module documentation). Shown (`{}` and
/// `{:?}`, so in the core's log lines) as the endpoint's members, `ip=2130706433, port=8888` (with
/// `, address=N` in stream mode), while its agent knows it; as `endpoint #N` once forgotten.
#[derive(Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct EndpointId(u64);

impl std::fmt::Display for EndpointId {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        shell::write_endpoint_name(*self, f)
    }
}

impl std::fmt::Debug for EndpointId {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        std::fmt::Display::fmt(self, f)
    }
}

/// Limits and timing of a custom agent.
#[derive(Debug, Clone)]
pub struct CustomOptions {
    /// Timeout of each `read` call; stopping waits up to about this long for the reader. Default 100 ms.
    pub read_timeout: Duration,
    /// Largest message: the packet-mode read buffer and the stream-mode frame buffers. Default 65535
    /// (eProsima's agent buffer; the frame length field allows no more).
    pub max_message: usize,
    /// Most endpoints known at once. Default 1024.
    pub max_endpoints: usize,
    /// Stream mode: most endpoints with a frame decoder (each `max_message` bytes). Default 64.
    pub max_streams: usize,
    /// Messages waiting between the reader thread and the loop. Default 256.
    pub queue: usize,
}

impl Default for CustomOptions {
    fn default() -> Self {
        Self {
            read_timeout: Duration::from_millis(100),
            max_message: xrce_proto::framing::serial::MAX_PAYLOAD_LEN,
            max_endpoints: 1024,
            max_streams: 64,
            queue: 256,
        }
    }
}

/// Why a custom agent could not be built, started or stopped.
#[derive(Debug, thiserror::Error)]
pub enum CustomAgentError {
    /// The endpoint declaration is unusable.
    #[error("custom transport `{name}`: {source}")]
    Endpoint {
        /// The transport's name.
        name: String,
        /// What is wrong.
        #[source]
        source: EndpointError,
    },
    /// The middleware is not available.
    #[error(transparent)]
    Middleware(#[from] BuildError),
    /// The transport's `open` failed.
    #[error("custom transport `{name}` could not be opened: {source}")]
    Open {
        /// The transport's name.
        name: String,
        /// The error `open` returned.
        #[source]
        source: io::Error,
    },
    /// The transport's `close` failed (the agent is stopped nevertheless).
    #[error("custom transport `{name}` could not be closed: {source}")]
    Close {
        /// The transport's name.
        name: String,
        /// The error `close` returned.
        #[source]
        source: io::Error,
    },
    /// `start` while running.
    #[error("custom agent `{0}` is already running")]
    AlreadyRunning(String),
    /// The event loop or a thread failed.
    #[error("custom agent `{name}`: {source}")]
    Io {
        /// The transport's name.
        name: String,
        /// What failed.
        #[source]
        source: io::Error,
    },
}

/// What a custom transport is made of, to start its reader thread and loop side ([`CustomAgent`], or one
/// transport among others in a [`super::multi::MultiServer`]).
pub(crate) struct Parts<'a> {
    pub name: &'a str,
    pub desc: &'a EndpointDesc,
    pub mode: Mode,
    pub options: &'a CustomOptions,
    pub io: &'a Arc<dyn CustomAgentIo>,
}

impl Parts<'_> {
    /// Serves `core` over this transport: the reader thread and an event loop thread on the loop side
    /// ([`Self::start`]), until `stop` is set; the loop's thread gives the endpoint table back when it ends.
    pub(crate) fn serve(
        self,
        core: SharedCore<EndpointId>,
        table: EndpointTable,
        stop: &Arc<AtomicBool>,
    ) -> io::Result<(JoinHandle<io::Result<EndpointTable>>, JoinHandle<()>)> {
        let looped = EventLoop::new(core)?;
        let label = format!("the custom agent `{}`", self.name);
        let (mut shell, reader) = self.start(table, stop)?;
        let loop_stop = stop.clone();
        let served = std::thread::Builder::new().name("xrce-custom".into()).spawn(move || {
            looped
                .run(&label, &loop_stop, |registry| {
                    shell.register(registry, READER)?;
                    Ok(shell)
                })
                .map(|shell| shell.table)
        });
        match served {
            Ok(server) => Ok((server, reader)),
            Err(e) => {
                // The loop's side of the channel is gone with the closure: the reader ends.
                stop.store(true, Ordering::Relaxed);
                let _ = reader.join();
                Err(e)
            }
        }
    }

    /// Starts the reader thread (until `stop` is set or the loop side is dropped) and returns the loop side,
    /// whose wake-up pipe the caller registers with its poll, with the reader's handle.
    pub(crate) fn start(self, mut table: EndpointTable, stop: &Arc<AtomicBool>) -> io::Result<(Shell, JoinHandle<()>)> {
        let queue = self.options.queue.max(1);
        let (tx, rx) = sync_channel(queue);
        let (spare_tx, spare_rx) = sync_channel(queue);
        let (pipe, woken) = mio::unix::pipe::new()?;
        let wake = Arc::new(Wake { flag: WakeFlag::default(), pipe });
        let reader = Reader {
            name: self.name.to_owned(),
            io: self.io.clone(),
            blank: self.desc.endpoint(),
            mode: self.mode,
            options: self.options.clone(),
            tx,
            spare: spare_rx,
            wake: wake.clone(),
            stop: stop.clone(),
        };
        let reader = std::thread::Builder::new().name("xrce-custom-rx".into()).spawn(move || reader.run())?;
        table.set_max(self.options.max_endpoints);
        let shell = Shell {
            name: self.name.to_owned(),
            io: self.io.clone(),
            mode: self.mode,
            rx,
            spare: spare_tx,
            wake,
            woken,
            table,
            stash: None,
            frame: Vec::new(),
        };
        Ok((shell, reader))
    }
}
