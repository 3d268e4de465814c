//! CAN FD shell (`canfd -D can0`, spec §12.5): one XRCE message per CAN FD frame, `data[0]` the message
//! length ([`xrce_proto::framing::can`]), so at most 63 bytes per message; clients announce an MTU to match
//! (59 in CREATE_CLIENT) and the core builds its messages within it. A client sends under its own 29-bit
//! identifier; the agent takes every extended frame on the bus (no filter, as eProsima's agent) and answers
//! each client on the identifier its frames came from, which is the client's endpoint. Standard (11-bit)
//! frames carry no XRCE traffic and are ignored. `-I/--id` is accepted and unused, as in eProsima's agent.
//!
//! One thread, one `mio` loop ([`EventLoop`]) on the bus socket and the middleware's waker. The bus is a
//! [`CanBus`]: [`SocketCanBus`], a Linux SocketCAN raw socket in CAN FD mode (through the `socketcan`
//! crate), or anything else with a file descriptor, such as the tests' in-process bus. Frames the interface
//! cannot take yet (its queue is full) wait in an [`Outbox`], in order; reliable streams recover whatever is
//! dropped past [`MAX_OUTBOX`].

use std::collections::VecDeque;
use std::io;
use std::os::fd::{AsRawFd, RawFd};
use std::sync::atomic::AtomicBool;
use std::time::{Duration, Instant};

use mio::event::Event;
use mio::unix::SourceFd;
use mio::{Interest, Registry};
use socketcan::{CanFdFrame, CanFdSocket, CanRawFrame, EmbeddedFrame, ExtendedId, Id, Socket, StandardId};
use xrce_proto::framing::can::{Frame, MAX_MESSAGE_LEN};

use super::drive::{EventLoop, Inbox, Io, Spent, Tokens};
use super::SharedCore;
use crate::core::{CoreConfig, Transmit};

/// Frames read per turn at most, so a flooded bus still lets the agent answer; the rest is read at once in
/// the next turn.
pub const MAX_READ_PER_TURN: usize = 1024;
/// Frames waiting for the interface at most; later ones are dropped (reliable streams resend them).
pub const MAX_OUTBOX: usize = 1024;
/// How long a turn keeps retrying a send the interface refused with `ENOBUFS` (its queue, `txqueuelen`, is
/// full; the kernel gives no readiness event for it) before leaving the rest to the next turn.
pub const NOBUFS_BUDGET: Duration = Duration::from_millis(5);

/// The core settings of a CAN FD agent: messages of at most one frame, whatever MTU a client announces (a
/// client built with a larger one is still answered in frames; its own messages are its business).
pub fn core_config() -> CoreConfig {
    CoreConfig { max_mtu: MAX_MESSAGE_LEN as u16, ..CoreConfig::default() }
}

/// A client on the bus: the 29-bit identifier of its frames. Shown (`{}` and `{:?}`, so in the core's log
/// lines) as `can0, id 0x123`.
#[derive(Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct CanEndpoint {
    /// The client's CAN identifier.
    pub id: u32,
    /// The interface (bus) name, for log lines.
    pub interface: &'static str,
}

impl std::fmt::Display for CanEndpoint {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}, id {:#x}", self.interface, self.id)
    }
}

impl std::fmt::Debug for CanEndpoint {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        std::fmt::Display::fmt(self, f)
    }
}

/// A CAN bus as the server uses it: non-blocking, with a file descriptor for the event loop.
pub trait CanBus: AsRawFd {
    /// Puts one frame on the bus; `WouldBlock` or `ENOBUFS` when the interface cannot take it now.
    fn send(&self, frame: &Frame) -> io::Result<()>;

    /// Takes one received frame without blocking; `Ok(None)` when none is queued.
    fn try_recv(&self) -> io::Result<Option<Frame>>;
}

/// A Linux SocketCAN raw socket in CAN FD mode, non-blocking, without filter.
#[derive(Debug)]
pub struct SocketCanBus {
    socket: CanFdSocket,
    name: String,
}

impl SocketCanBus {
    /// Opens the interface `name` (`can0`).
    pub fn open(name: &str) -> io::Result<Self> {
        let socket = CanFdSocket::open(name)?;
        socket.set_nonblocking(true)?;
        Ok(Self { socket, name: name.to_owned() })
    }

    /// The interface name.
    pub fn name(&self) -> &str {
        &self.name
    }
}

impl AsRawFd for SocketCanBus {
    fn as_raw_fd(&self) -> RawFd {
        self.socket.as_raw_fd()
    }
}

impl CanBus for SocketCanBus {
    fn send(&self, frame: &Frame) -> io::Result<()> {
        self.socket.write_frame(&to_socketcan(frame)?)
    }

    fn try_recv(&self) -> io::Result<Option<Frame>> {
        match self.socket.read_raw_frame() {
            Ok(raw) => Ok(Some(from_socketcan(&raw))),
            Err(e) if e.kind() == io::ErrorKind::WouldBlock => Ok(None),
            Err(e) => Err(e),
        }
    }
}

fn invalid_frame() -> io::Error {
    io::Error::new(io::ErrorKind::InvalidInput, "CAN identifier or data out of range")
}

/// The `socketcan` frame of `frame`: extended or standard per its EFF flag, data padded by the crate with
/// zeros to the next CAN FD length.
pub fn to_socketcan(frame: &Frame) -> io::Result<CanFdFrame> {
    let id: Id = match frame.id() {
        Some(raw) => ExtendedId::new(raw).ok_or_else(invalid_frame)?.into(),
        None => u16::try_from(frame.can_id).ok().and_then(StandardId::new).ok_or_else(invalid_frame)?.into(),
    };
    CanFdFrame::new(id, frame.bytes()).ok_or_else(invalid_frame)
}

/// A received raw frame as a [`Frame`], with its whole data field (see [`Frame::message`] for why bytes past
/// the frame length count).
pub fn from_socketcan(raw: &CanRawFrame) -> Frame {
    match raw {
        CanRawFrame::Fd(f) => Frame { can_id: f.can_id, len: f.len.min(64), data: f.data },
        CanRawFrame::Classic(f) => {
            let len = usize::from(f.can_dlc).min(f.data.len());
            Frame::from_parts(f.can_id, f.data.get(..len).unwrap_or(&[]))
        }
    }
}

/// What [`Outbox::flush`] left behind.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Flushed {
    /// Everything was sent.
    All,
    /// The interface is full (`WouldBlock`): wait until it is writable.
    Blocked,
    /// The interface refused with `ENOBUFS` past [`NOBUFS_BUDGET`]: try again next turn.
    Later,
}

/// Frames waiting for the interface, oldest first.
#[derive(Debug, Default)]
pub struct Outbox {
    frames: VecDeque<Frame>,
    dropped: u64,
}

impl Outbox {
    /// Queues `frame`; false (and the frame is dropped) past [`MAX_OUTBOX`].
    pub fn push(&mut self, frame: Frame) -> bool {
        if self.frames.len() >= MAX_OUTBOX {
            self.dropped += 1;
            return false;
        }
        self.frames.push_back(frame);
        true
    }

    /// Frames waiting.
    pub fn len(&self) -> usize {
        self.frames.len()
    }

    /// Whether no frame waits.
    pub fn is_empty(&self) -> bool {
        self.frames.is_empty()
    }

    /// Frames dropped because the outbox was full or the interface failed.
    pub fn dropped(&self) -> u64 {
        self.dropped
    }

    /// Sends frames in order through `send` until one is refused. `ENOBUFS` is retried with short pauses
    /// for up to [`NOBUFS_BUDGET`]; any other error drops what waits (the interface is down or gone).
    pub fn flush(&mut self, mut send: impl FnMut(&Frame) -> io::Result<()>) -> Flushed {
        let mut nobufs_since: Option<Instant> = None;
        while let Some(frame) = self.frames.front() {
            match send(frame) {
                Ok(()) => {
                    self.frames.pop_front();
                }
                Err(e) if e.kind() == io::ErrorKind::WouldBlock => return Flushed::Blocked,
                Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
                Err(e) if e.raw_os_error() == Some(nix::errno::Errno::ENOBUFS as i32) => {
                    let since = *nobufs_since.get_or_insert_with(Instant::now);
                    if since.elapsed() >= NOBUFS_BUDGET {
                        return Flushed::Later;
                    }
                    std::thread::sleep(Duration::from_micros(100));
                }
                Err(e) => {
                    tracing::warn!(frames = self.frames.len(), "CAN send failed, frames dropped: {e}");
                    self.dropped += self.frames.len() as u64;
                    self.frames.clear();
                }
            }
        }
        Flushed::All
    }
}

/// A CAN FD server around a shared core.
#[derive(Debug)]
pub struct CanServer<B> {
    bus: B,
    name: String,
    /// `name`, for the endpoints of its clients.
    interface: &'static str,
    looped: EventLoop<CanEndpoint>,
}

impl<B: CanBus> CanServer<B> {
    /// A server on `bus` (named `name` in logs and errors); installs the middleware waker.
    pub fn new(bus: B, name: impl Into<String>, core: SharedCore<CanEndpoint>) -> io::Result<Self> {
        let name = name.into();
        Ok(Self { interface: super::device_name(&name), bus, name, looped: EventLoop::new(core)? })
    }

    /// The bus name.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Serves until `stop` is set (checked at least every [`super::MAX_BLOCK`]).
    pub fn run(&self, stop: &AtomicBool) -> io::Result<()> {
        let name = format!("the CAN FD server on {}", self.name);
        let io = self
            .looped
            .run(&name, stop, |registry| CanIo::register(&self.bus, self.interface, registry, Tokens::ALONE))?;
        if io.outbox.dropped() > 0 {
            tracing::debug!(bus = %self.name, dropped = io.outbox.dropped(), "CAN frames dropped while sending");
        }
        Ok(())
    }
}

/// The bus as the event loop sees it.
pub(crate) struct CanIo<'a, B> {
    bus: &'a B,
    interface: &'static str,
    registry: Registry,
    /// Frames may be queued: readiness was reported, or the last turn stopped at [`MAX_READ_PER_TURN`].
    readable: bool,
    outbox: Outbox,
    writable_interest: bool,
    /// The interface refused with `ENOBUFS` past the turn's budget: turn again at once, reading too.
    retry_send: bool,
    tokens: Tokens,
}

impl<'a, B: CanBus> CanIo<'a, B> {
    /// Registers `bus` (its clients' endpoints name `interface`) with the loop's `registry` in the shell's
    /// token range.
    pub(crate) fn register(
        bus: &'a B,
        interface: &'static str,
        registry: &Registry,
        tokens: Tokens,
    ) -> io::Result<Self> {
        registry.register(&mut SourceFd(&bus.as_raw_fd()), tokens.token(1), Interest::READABLE)?;
        Ok(Self {
            bus,
            interface,
            registry: registry.try_clone()?,
            // Frames may have come before the registration.
            readable: true,
            outbox: Outbox::default(),
            writable_interest: false,
            retry_send: false,
            tokens,
        })
    }

    /// Frames dropped while sending.
    pub(crate) fn dropped(&self) -> u64 {
        self.outbox.dropped()
    }

    fn want_writable(&mut self, want: bool) {
        if want != self.writable_interest {
            let interest = if want { Interest::READABLE | Interest::WRITABLE } else { Interest::READABLE };
            if self.registry.reregister(&mut SourceFd(&self.bus.as_raw_fd()), self.tokens.token(1), interest).is_ok() {
                self.writable_interest = want;
            }
        }
    }
}

impl<B: CanBus> Io<CanEndpoint> for CanIo<'_, B> {
    fn ready(&mut self, event: &Event) {
        self.readable |= event.is_readable() || event.is_error();
    }

    fn idle(&mut self) {
        // A timer turn reads too (one system call), in case a readiness edge went unseen.
        self.readable = true;
    }

    fn prefetch(&mut self) -> io::Result<bool> {
        // Frames left behind by the last turn, or sends to retry: run the next turn at once (it reads too,
        // as no readiness poll runs before it). Each retrying turn waits up to NOBUFS_BUDGET for the
        // interface, so this paces the loop rather than spinning it.
        if self.retry_send {
            self.readable = true;
        }
        Ok(self.readable)
    }

    fn receive(&mut self, inbox: &mut Inbox<'_, CanEndpoint>) -> io::Result<()> {
        if !self.readable {
            return Ok(());
        }
        self.readable = false;
        let mut failed = false;
        for _ in 0..MAX_READ_PER_TURN {
            let frame = match self.bus.try_recv() {
                Ok(Some(frame)) => frame,
                Ok(None) => return Ok(()),
                Err(e) if e.kind() == io::ErrorKind::Interrupted => continue,
                // A socket error (the interface went down, a bus-off restart) is reported once and the
                // frames queued behind it are still there: read on. Failing again ends the turn; the agent
                // keeps serving and reads at the next readiness.
                Err(e) => {
                    tracing::warn!("CAN receive failed: {e}");
                    if std::mem::replace(&mut failed, true) {
                        return Ok(());
                    }
                    continue;
                }
            };
            let Some(id) = frame.id() else { continue };
            match frame.message() {
                Ok(msg) => inbox.deliver(CanEndpoint { id, interface: self.interface }, msg),
                Err(e) => tracing::debug!(id = format_args!("{id:#x}"), "CAN frame dropped: {e}"),
            }
        }
        self.readable = true;
        Ok(())
    }

    fn send(&mut self, out: &mut Vec<Transmit<CanEndpoint>>, spent: &mut Spent<CanEndpoint>) {
        for t in out.drain(..) {
            match Frame::with_message(t.to.id, &t.data) {
                Ok(frame) => {
                    if !self.outbox.push(frame) {
                        tracing::debug!(to = %t.to, "CAN outbox full, frame dropped");
                    }
                }
                Err(e) => tracing::warn!(to = %t.to, "cannot send over CAN FD: {e}"),
            }
            spent.buffers.push(t.data);
        }
        if self.outbox.is_empty() {
            self.retry_send = false;
            self.want_writable(false);
            return;
        }
        let bus = self.bus;
        let flushed = self.outbox.flush(|f| bus.send(f));
        self.retry_send = flushed == Flushed::Later;
        self.want_writable(flushed == Flushed::Blocked);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use socketcan::Frame as _;
    use std::cell::RefCell;

    /// Log lines name a client by its interface and CAN id in hexadecimal (the core logs peers with `{:?}`).
    #[test]
    fn endpoints_show_the_interface_and_the_id_in_hex() {
        let e = CanEndpoint { id: 0x123, interface: crate::transport::device_name("can0") };
        assert_eq!(format!("{e}"), "can0, id 0x123");
        assert_eq!(format!("{e:?}"), "can0, id 0x123");
        assert!(std::ptr::eq(e.interface, crate::transport::device_name("can0")), "one copy per name");
    }

    #[test]
    fn socketcan_frames_carry_the_id_flag_and_padded_data() {
        let msg = [0x5Au8; 40];
        let fd = to_socketcan(&Frame::with_message(0x1FFF_FFFF, &msg).unwrap()).unwrap();
        assert_eq!(fd.id_word(), 0x9FFF_FFFF);
        assert_eq!(fd.len(), 48, "41 bytes padded to the next CAN FD length");
        assert_eq!(fd.data()[0], 40);
        assert!(fd.data()[41..].iter().all(|&b| b == 0));
        let back = from_socketcan(&CanRawFrame::Fd(*fd.as_ref()));
        assert_eq!((back.id(), back.message()), (Some(0x1FFF_FFFF), Ok(&msg[..])));
        assert!(to_socketcan(&Frame::from_parts(0x800, &[0])).is_err(), "not an 11-bit id");
    }

    #[test]
    fn received_frames_keep_bytes_past_their_length() {
        // eProsima's agent and clients read data[0] bytes whatever the frame length says.
        let msg: Vec<u8> = (1..=12).collect();
        let mut raw = *to_socketcan(&Frame::with_message(3, &msg).unwrap()).unwrap().as_ref();
        raw.len = 12;
        assert_eq!(from_socketcan(&CanRawFrame::Fd(raw)).message(), Ok(&msg[..]));
        let classic = socketcan::CanDataFrame::new(StandardId::new(0x10).unwrap(), &[1, 9]).unwrap();
        let frame = from_socketcan(&CanRawFrame::Classic(*classic.as_ref()));
        assert_eq!((frame.id(), frame.message()), (None, Ok(&[9][..])));
    }

    fn frames(n: u8) -> Outbox {
        let mut o = Outbox::default();
        for i in 0..n {
            assert!(o.push(Frame::with_message(1, &[i]).unwrap()));
        }
        o
    }

    #[test]
    fn a_full_interface_keeps_the_rest_in_order() {
        let mut outbox = frames(5);
        let sent = RefCell::new(Vec::new());
        let mut room = 2;
        let send = |f: &Frame, room: &mut i32| {
            if *room == 0 {
                return Err(io::Error::from(io::ErrorKind::WouldBlock));
            }
            *room -= 1;
            sent.borrow_mut().push(f.message().unwrap()[0]);
            Ok(())
        };
        assert_eq!(outbox.flush(|f| send(f, &mut room)), Flushed::Blocked);
        assert_eq!(outbox.len(), 3);
        room = 10;
        assert_eq!(outbox.flush(|f| send(f, &mut room)), Flushed::All);
        assert_eq!(*sent.borrow(), [0, 1, 2, 3, 4]);
        assert_eq!(outbox.dropped(), 0);
    }

    #[test]
    fn enobufs_is_retried_then_left_for_later() {
        let nobufs = || io::Error::from_raw_os_error(nix::errno::Errno::ENOBUFS as i32);
        // Refused twice, then taken: everything goes out in this turn.
        let mut outbox = frames(3);
        let mut refusals = 2;
        let flushed = outbox.flush(|_| {
            if refusals > 0 {
                refusals -= 1;
                return Err(nobufs());
            }
            Ok(())
        });
        assert_eq!((flushed, outbox.len()), (Flushed::All, 0));
        // Refused for good: the turn gives up after its budget, frames kept.
        let mut outbox = frames(3);
        assert_eq!(outbox.flush(|_| Err(nobufs())), Flushed::Later);
        assert_eq!(outbox.len(), 3);
    }

    #[test]
    fn a_failed_interface_drops_what_waits_and_the_outbox_is_bounded() {
        let mut outbox = frames(4);
        assert_eq!(
            outbox.flush(|_| Err(io::Error::from_raw_os_error(nix::errno::Errno::ENETDOWN as i32))),
            Flushed::All
        );
        assert_eq!((outbox.len(), outbox.dropped()), (0, 4));
        let mut full = Outbox::default();
        for _ in 0..MAX_OUTBOX {
            assert!(full.push(Frame::with_message(1, &[]).unwrap()));
        }
        assert!(!full.push(Frame::with_message(1, &[]).unwrap()));
        assert_eq!(full.dropped(), 1);
    }

    #[test]
    fn opening_a_missing_interface_fails() {
        assert!(SocketCanBus::open("xrce-no-such-can").is_err());
    }
}
