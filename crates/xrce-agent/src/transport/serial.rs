//! Serial shells (`serial`, `multiserial`, `pseudoterminal`): XRCE messages in HDLC-like frames (spec §12.3,
//! [`xrce_proto::framing::serial`]). The agent's local address is 0; it accepts frames sent to 0 and
//! answers each client at the source address of its frames. One thread, one `mio` loop
//! ([`EventLoop`]) over every line and the middleware's waker. Lines are
//! non-blocking and each has its own outbox: a line nobody reads (a pty whose client left) drops what it
//! holds once it has not moved for [`WRITE_TIMEOUT`], and takes no new frame past [`MAX_BACKLOG`] bytes;
//! nothing else waits for it, and reliable streams recover.
//!
//! A device that goes away (a USB adapter unplugged: reads hang up or fail, writes fail with EIO) is closed,
//! which lets the kernel give the adapter the same name when it is plugged back, and opened again with the
//! same settings every [`REOPEN_EVERY`] until it is back; the other lines go on meanwhile. The core keeps the
//! clients' sessions, so a client that kept running goes on where it was (its reliable streams resend what
//! was lost), and one that restarted creates its session again.
//!
//! Line settings (raw 8N1, no flow control, the baud rate) are made by the `serialport` crate, which sets
//! any rate the driver takes (termios2 on Linux), not only the standard ones.

use std::fs::File;
use std::io::{self, Read, Write};
use std::os::fd::{AsFd, AsRawFd};
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;
use std::sync::Arc;
use std::time::{Duration, Instant};

use mio::event::Event as Readiness;
use mio::unix::SourceFd;
use mio::{Interest, Registry, Token};
use xrce_proto::framing::serial::{encode_frame, max_encoded_len, AddressFilter, Event, FrameDecoder};

use super::drive::{EventLoop, Inbox, Io, Spent, Tokens};
use super::{SharedCore, MAX_BLOCK};
use crate::core::Transmit;

/// The agent's address on serial lines (eProsima's).
pub const AGENT_ADDRESS: u8 = 0;
/// Largest message on a serial line (eProsima's agent buffer).
pub const MAX_MESSAGE: usize = 65_535;
/// How long a line's outbox may wait for room before what it holds is dropped.
pub const WRITE_TIMEOUT: Duration = Duration::from_secs(1);
/// Most bytes waiting for a line (5.7 s at 115200 baud); frames past it are dropped.
pub const MAX_BACKLOG: usize = 64 * 1024;
/// How often a device that went away is tried again (the loop turns at least every [`MAX_BLOCK`]).
pub const REOPEN_EVERY: Duration = Duration::from_millis(500);

/// A client on a serial line: the line's index and the client's address (its frames' source). Shown (`{}`
/// and `{:?}`, so in the core's log lines) as `/dev/ttyACM0, address 1`.
#[derive(Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct SerialEndpoint {
    /// Index of the line (device) in the server.
    pub line: u16,
    /// Address of the client on that line.
    pub address: u8,
    /// The line's device path (or pseudoterminal name), for log lines.
    pub device: &'static str,
}

impl std::fmt::Display for SerialEndpoint {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}, address {}", self.device, self.address)
    }
}

impl std::fmt::Debug for SerialEndpoint {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        std::fmt::Display::fmt(self, f)
    }
}

/// One serial line: a device or a pseudoterminal master.
#[derive(Debug)]
pub struct Line {
    file: File,
    name: String,
    /// How to open the device again once it went away; none for a pseudoterminal the agent created.
    reopen: Option<Settings>,
    /// A pseudoterminal's slave side, kept open so reading the master never fails while no client has it open.
    _slave: Option<std::os::fd::OwnedFd>,
}

/// A device's path and line settings.
#[derive(Debug, Clone)]
struct Settings {
    path: PathBuf,
    baud: u32,
    rts_cts: bool,
}

fn to_io(e: nix::Error) -> io::Error {
    io::Error::from(e)
}

/// Raw mode (no echo, no line discipline, 8N1) at `baud` for the terminal open as `fd`: any rate its driver
/// takes, not only the standard ones; RTS/CTS hardware flow control when `rts_cts` (the line then waits for
/// CTS before sending, as flight controllers' UARTs wired for it expect).
fn make_raw(fd: impl AsFd, baud: u32, rts_cts: bool) -> io::Result<()> {
    let path = nix::unistd::ttyname(fd).map_err(to_io)?;
    let path = path.to_str().ok_or_else(|| io::Error::new(io::ErrorKind::InvalidInput, "device path is not UTF-8"))?;
    // Shared, not exclusive: a client must still be able to open a pseudoterminal's slave side. The port is
    // closed at once; its settings stay with the terminal, which the caller keeps open.
    let port = serialport::new(path, baud)
        .data_bits(serialport::DataBits::Eight)
        .parity(serialport::Parity::None)
        .stop_bits(serialport::StopBits::One)
        .flow_control(if rts_cts { serialport::FlowControl::Hardware } else { serialport::FlowControl::None })
        .exclusive(false)
        .open_native()?;
    drop(port);
    Ok(())
}

fn set_nonblocking(file: &File) -> io::Result<()> {
    use nix::fcntl::{fcntl, FcntlArg, OFlag};
    let flags = OFlag::from_bits_truncate(fcntl(file, FcntlArg::F_GETFL).map_err(to_io)?);
    fcntl(file, FcntlArg::F_SETFL(flags | OFlag::O_NONBLOCK)).map_err(to_io)?;
    Ok(())
}

impl Line {
    /// Opens a serial device in raw mode at `baud`, with RTS/CTS flow control when `rts_cts`.
    pub fn open(path: &Path, baud: u32, rts_cts: bool) -> io::Result<Self> {
        use std::os::unix::fs::OpenOptionsExt;
        let file = std::fs::OpenOptions::new()
            .read(true)
            .write(true)
            .custom_flags(nix::fcntl::OFlag::O_NOCTTY.bits())
            .open(path)?;
        make_raw(&file, baud, rts_cts)?;
        set_nonblocking(&file)?;
        let reopen = Some(Settings { path: path.to_path_buf(), baud, rts_cts });
        Ok(Self { file, name: path.display().to_string(), reopen, _slave: None })
    }

    /// Creates a pseudoterminal; clients open [`Self::name`] (the slave side).
    pub fn pseudoterminal(baud: u32) -> io::Result<Self> {
        let pty = nix::pty::openpty(None, None).map_err(to_io)?;
        make_raw(&pty.slave, baud, false)?;
        let name = nix::unistd::ttyname(&pty.slave).map_err(to_io)?;
        let file = File::from(pty.master);
        set_nonblocking(&file)?;
        Ok(Self { file, name: name.display().to_string(), reopen: None, _slave: Some(pty.slave) })
    }

    /// The device path.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The device path, as a path.
    pub fn path(&self) -> PathBuf {
        PathBuf::from(&self.name)
    }
}

/// A serial server around a shared core: one or more lines.
#[derive(Debug)]
pub struct SerialServer {
    lines: Vec<Line>,
    core: SharedCore<SerialEndpoint>,
}

impl SerialServer {
    /// A server on `lines`.
    pub fn new(lines: Vec<Line>, core: SharedCore<SerialEndpoint>) -> Self {
        Self { lines, core }
    }

    /// The device paths of the lines.
    pub fn names(&self) -> Vec<String> {
        self.lines.iter().map(|l| l.name.clone()).collect()
    }

    /// Serves until `stop` is set (checked at least every [`MAX_BLOCK`]).
    pub fn run(self, stop: &Arc<AtomicBool>) -> io::Result<()> {
        if u16::try_from(self.lines.len()).is_err() {
            return Err(io::Error::other(format!("too many serial lines: {}", self.lines.len())));
        }
        let name = format!("the serial server on {}", self.names().join(" "));
        EventLoop::new(self.core)?
            .run(&name, stop, |registry| SerialIo::register(self.lines, registry, Tokens::ALONE))?;
        Ok(())
    }
}

/// Line token numbers are `1 + index`.
fn token(tokens: Tokens, index: usize) -> Token {
    tokens.token(index.saturating_add(1))
}

/// The lines, as the event loop sees them.
pub(crate) struct SerialIo {
    lines: Vec<LineIo>,
    registry: Registry,
    buf: Vec<u8>,
    tokens: Tokens,
}

impl SerialIo {
    /// Registers `lines` with the loop's `registry` in the shell's token range (line `i` is number `1 + i`).
    pub(crate) fn register(lines: Vec<Line>, registry: &Registry, tokens: Tokens) -> io::Result<Self> {
        let now = Instant::now();
        let mut served = Vec::with_capacity(lines.len());
        for (index, line) in lines.into_iter().enumerate() {
            registry.register(&mut SourceFd(&line.file.as_raw_fd()), token(tokens, index), Interest::READABLE)?;
            served.push(LineIo {
                name: line.name.clone(),
                device: super::device_name(&line.name),
                reopen: line.reopen.clone(),
                line: Some(line),
                decoder: FrameDecoder::new(vec![0u8; MAX_MESSAGE], AddressFilter::Only(AGENT_ADDRESS)),
                // Bytes may have arrived before the registration.
                readable: true,
                retry_at: None,
                outbox: Vec::new(),
                progress_at: now,
                writable_interest: false,
            });
        }
        Ok(Self { lines: served, registry: registry.try_clone()?, buf: vec![0u8; 4096], tokens })
    }
}

/// One line's reading and writing state.
struct LineIo {
    /// The open line; none while its device is gone.
    line: Option<Line>,
    name: String,
    /// `name`, for the endpoints of its clients.
    device: &'static str,
    /// How to open the device again; none for a pseudoterminal the agent created.
    reopen: Option<Settings>,
    decoder: FrameDecoder<Vec<u8>>,
    /// Readiness was reported since the last read.
    readable: bool,
    /// The last read failed (a pseudoterminal with no client) or the device is gone: read again, or open
    /// it again, from then on, rather than spin.
    retry_at: Option<Instant>,
    /// Encoded frames waiting for room on the line, front first.
    outbox: Vec<u8>,
    /// When the outbox last moved (or got its first bytes after being empty).
    progress_at: Instant,
    writable_interest: bool,
}

impl Io<SerialEndpoint> for SerialIo {
    fn ready(&mut self, event: &Readiness) {
        if let Some(l) =
            self.tokens.local(event.token()).and_then(|n| n.checked_sub(1)).and_then(|i| self.lines.get_mut(i))
        {
            l.readable |= event.is_readable() || event.is_read_closed() || event.is_error();
        }
    }

    fn receive(&mut self, inbox: &mut Inbox<'_, SerialEndpoint>) -> io::Result<()> {
        let now = inbox.now();
        for (index, l) in (0u16..).zip(self.lines.iter_mut()) {
            let retry = l.retry_at.is_some_and(|t| t <= now);
            if l.line.is_none() {
                if retry {
                    l.reopen(&self.registry, token(self.tokens, usize::from(index)), now);
                }
                if l.line.is_none() {
                    continue;
                }
            } else if !(l.readable || retry) {
                continue;
            }
            l.readable = false;
            l.retry_at = None;
            while let Some(line) = l.line.as_mut() {
                let n = match line.file.read(&mut self.buf) {
                    // In raw mode a terminal reads 0 only once hung up (device unplugged, other side closed).
                    Ok(0) => {
                        l.failed(&self.registry, now, &"hung up");
                        break;
                    }
                    Ok(n) => n,
                    Err(e) if e.kind() == io::ErrorKind::WouldBlock => break,
                    Err(e) if e.kind() == io::ErrorKind::Interrupted => continue,
                    Err(e) => {
                        l.failed(&self.registry, now, &e);
                        break;
                    }
                };
                let (name, device) = (&l.name, l.device);
                l.decoder.push(self.buf.get(..n).unwrap_or(&[]), |event| match event {
                    Event::Frame { src, payload, .. } => {
                        inbox.deliver(SerialEndpoint { line: index, address: src, device }, payload);
                    }
                    Event::Error(e) => tracing::debug!(line = %name, "frame dropped: {e}"),
                });
            }
        }
        Ok(())
    }

    fn send(&mut self, out: &mut Vec<Transmit<SerialEndpoint>>, spent: &mut Spent<SerialEndpoint>) {
        let now = Instant::now();
        for t in out.drain(..) {
            // Nothing is queued for a device that is gone: the clients' reliable streams resend once it is back.
            if let Some(l) = self.lines.get_mut(usize::from(t.to.line)).filter(|l| l.line.is_some()) {
                l.queue(t.to.address, &t.data, now);
            }
            spent.buffers.push(t.data);
        }
        for (index, l) in self.lines.iter_mut().enumerate() {
            if l.outbox.is_empty() {
                continue;
            }
            if let Err(e) = l.flush(now) {
                l.failed(&self.registry, now, &e);
                continue;
            }
            let want_writable = !l.outbox.is_empty();
            let Some(line) = l.line.as_ref() else { continue };
            if want_writable != l.writable_interest {
                let interest = if want_writable { Interest::READABLE | Interest::WRITABLE } else { Interest::READABLE };
                let fd = line.file.as_raw_fd();
                if self.registry.reregister(&mut SourceFd(&fd), token(self.tokens, index), interest).is_ok() {
                    l.writable_interest = want_writable;
                }
            }
        }
    }
}

impl LineIo {
    /// A read or write failed. A device is closed (deregistered first) and opened again from
    /// [`REOPEN_EVERY`] on; a pseudoterminal the agent created (EIO while no client has it open) is read
    /// again after [`MAX_BLOCK`].
    fn failed(&mut self, registry: &Registry, now: Instant, why: &dyn std::fmt::Display) {
        if self.reopen.is_none() {
            tracing::debug!(line = %self.name, "read or write failed: {why}");
            self.retry_at = Some(now + MAX_BLOCK);
            return;
        }
        if let Some(line) = self.line.take() {
            // Deregistered before it is closed (dropped here).
            let _ = registry.deregister(&mut SourceFd(&line.file.as_raw_fd()));
            tracing::warn!(
                "serial device {} is gone ({why}); trying to open it again every {REOPEN_EVERY:?}",
                self.name
            );
        }
        self.outbox.clear();
        self.writable_interest = false;
        self.readable = false;
        self.decoder.reset();
        self.retry_at = Some(now + REOPEN_EVERY);
    }

    /// Tries to open a device that went away again, with its settings, and registers it under `token`.
    fn reopen(&mut self, registry: &Registry, token: Token, now: Instant) {
        let Some(settings) = self.reopen.as_ref() else { return };
        self.retry_at = Some(now + REOPEN_EVERY);
        let line = match Line::open(&settings.path, settings.baud, settings.rts_cts) {
            Ok(line) => line,
            Err(e) => {
                tracing::debug!(device = %self.name, "serial device still gone: {e}");
                return;
            }
        };
        if let Err(e) = registry.register(&mut SourceFd(&line.file.as_raw_fd()), token, Interest::READABLE) {
            tracing::warn!(device = %self.name, "serial device reopened but not watched: {e}");
            return;
        }
        tracing::info!(
            baud = settings.baud,
            rts_cts = settings.rts_cts,
            "serial device {} is back, open again",
            self.name
        );
        self.line = Some(line);
        // Bytes may have arrived before the registration.
        self.readable = true;
        self.retry_at = None;
    }

    /// Frames `data` for the client at `address` into the outbox.
    fn queue(&mut self, address: u8, data: &[u8], now: Instant) {
        let start = self.outbox.len();
        // A frame larger than the whole backlog still goes out alone.
        if start > 0 && start + max_encoded_len(data.len()) > MAX_BACKLOG {
            tracing::debug!(line = %self.name, "line backlog full, frame dropped");
            return;
        }
        self.outbox.resize(start + max_encoded_len(data.len()), 0);
        match encode_frame(AGENT_ADDRESS, address, data, self.outbox.get_mut(start..).unwrap_or(&mut [])) {
            Ok(n) => self.outbox.truncate(start + n),
            Err(e) => {
                self.outbox.truncate(start);
                tracing::warn!(line = %self.name, len = data.len(), "cannot frame message: {e}");
                return;
            }
        }
        if start == 0 {
            self.progress_at = now;
        }
    }

    /// Writes as much of the outbox as the line takes now; drops it when the line failed (the error is
    /// returned) or has taken nothing for [`WRITE_TIMEOUT`] (a frame cut short is discarded by the peer's
    /// decoder at the next flag).
    fn flush(&mut self, now: Instant) -> io::Result<()> {
        let Some(line) = self.line.as_mut() else {
            self.outbox.clear();
            return Ok(());
        };
        let mut written = 0;
        let failed = loop {
            match line.file.write(self.outbox.get(written..).unwrap_or(&[])) {
                Ok(0) => break None,
                Ok(n) => {
                    written += n;
                    if written >= self.outbox.len() {
                        break None;
                    }
                }
                Err(e) if e.kind() == io::ErrorKind::WouldBlock => break None,
                Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
                Err(e) => break Some(e),
            }
        };
        if written > 0 {
            self.outbox.drain(..written.min(self.outbox.len()));
            self.progress_at = now;
        }
        if let Some(e) = failed {
            tracing::debug!(line = %self.name, bytes = self.outbox.len(), "serial write failed, frames dropped: {e}");
            self.outbox.clear();
            return Err(e);
        } else if !self.outbox.is_empty() && now.saturating_duration_since(self.progress_at) >= WRITE_TIMEOUT {
            tracing::debug!(line = %self.name, bytes = self.outbox.len(), "line not read for {WRITE_TIMEOUT:?}, frames dropped");
            self.outbox.clear();
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::core::{AgentCore, CoreConfig};
    use crate::middleware::ced::Ced;
    use crate::middleware::describe::FallbackProfiles;
    use crate::transport::DynMiddleware;
    use nix::poll::{poll, PollFd, PollFlags, PollTimeout};
    use std::sync::atomic::Ordering;
    use std::thread;

    /// Log lines name a client by its device path and address (the core logs peers with `{:?}`).
    #[test]
    fn endpoints_show_the_device_path() {
        let e = SerialEndpoint { line: 1, address: 3, device: crate::transport::device_name("/dev/ttyACM0") };
        assert_eq!(format!("{e}"), "/dev/ttyACM0, address 3");
        assert_eq!(format!("{e:?}"), "/dev/ttyACM0, address 3");
    }

    /// A client on the pseudoterminal's slave side pings the agent (GET_INFO out of session) in a frame from
    /// address 1 and gets the INFO back in a frame from 0 to 1.
    #[test]
    fn pseudoterminal_answers_a_framed_ping() {
        let core =
            AgentCore::new(CoreConfig::default(), Box::new(Ced::new(Arc::new(FallbackProfiles))) as DynMiddleware);
        let core = SharedCore::new(core);
        let line = Line::pseudoterminal(115_200).unwrap();
        let path = line.path();
        assert!(path.starts_with("/dev/pts"), "{path:?}");
        let server = SerialServer::new(vec![line], core);
        let stop = Arc::new(AtomicBool::new(false));
        let s2 = stop.clone();
        let t = thread::spawn(move || server.run(&s2));

        let mut client = std::fs::OpenOptions::new().read(true).write(true).open(&path).unwrap();
        make_raw(&client, 115_200, false).unwrap();
        // Header 80 00 00 00 + GET_INFO {request 00 0A, object FF FD, mask 2} (a ping, spec §14.2).
        let ping = [0x80, 0, 0, 0, 0x02, 0x01, 0x08, 0x00, 0x00, 0x0A, 0xFF, 0xFD, 0x02, 0, 0, 0];
        let mut frame = vec![0u8; max_encoded_len(ping.len())];
        let n = encode_frame(1, 0, &ping, &mut frame).unwrap();
        client.write_all(&frame[..n]).unwrap();

        let mut decoder = FrameDecoder::new(vec![0u8; 1024], AddressFilter::Only(1));
        let mut got = None;
        let mut buf = [0u8; 256];
        let deadline = Instant::now() + Duration::from_secs(5);
        let mut fds_timeout = PollTimeout::from(100u16);
        while got.is_none() && Instant::now() < deadline {
            let mut fds = [PollFd::new(client.as_fd(), PollFlags::POLLIN)];
            if poll(&mut fds, fds_timeout).unwrap_or(0) == 0 {
                continue;
            }
            let k = client.read(&mut buf).unwrap();
            decoder.push(&buf[..k], |e| {
                if let Event::Frame { src, payload, .. } = e {
                    got = Some((src, payload.to_vec()));
                }
            });
            fds_timeout = PollTimeout::from(100u16);
        }
        stop.store(true, Ordering::Relaxed);
        t.join().unwrap().unwrap();
        let (src, reply) = got.expect("an answer");
        assert_eq!(src, AGENT_ADDRESS);
        let (_, mut subs) = xrce_proto::message::parse(&reply).unwrap();
        assert!(matches!(subs.next().unwrap().unwrap().decode(), Ok(xrce_proto::Submessage::Info(_))));
    }

    /// Rates outside termios' list (250000, common on 3D printers; any other) used to be refused when the
    /// line was opened: they are set through termios2 (`BOTHER`), on a pseudoterminal and on a device path.
    #[test]
    fn non_standard_baud_rates_are_set() {
        let is_custom = |fd: &std::os::fd::OwnedFd| {
            let t = nix::sys::termios::tcgetattr(fd).unwrap();
            t.control_flags.bits() & nix::libc::CBAUD == nix::libc::BOTHER
        };
        for baud in [250_000, 1_000_000, 123_457] {
            let line = Line::pseudoterminal(baud).unwrap();
            assert!(is_custom(line._slave.as_ref().unwrap()), "{baud}");
            let device = Line::open(&line.path(), baud, false).unwrap();
            assert_eq!(device.name(), line.name());
        }
        let mut agent =
            crate::agent::AgentInstance::create(["xrce-agent", "pseudoterminal", "-b", "250000", "-m", "ced"])
                .expect("a pseudoterminal at 250000 baud");
        agent.stop().unwrap();
    }

    /// `--flow-control` sets RTS/CTS on the line (CRTSCTS; a pseudoterminal keeps the flag, though nothing
    /// drives its lines), and lines open without it by default.
    #[test]
    fn rts_cts_flow_control_is_set_when_asked() {
        let rts_cts = |line: &Line| {
            let t = nix::sys::termios::tcgetattr(&line.file).unwrap();
            t.control_flags.contains(nix::sys::termios::ControlFlags::CRTSCTS)
        };
        let pty = Line::pseudoterminal(115_200).unwrap();
        assert!(!rts_cts(&Line::open(&pty.path(), 115_200, false).unwrap()), "off by default");
        assert!(rts_cts(&Line::open(&pty.path(), 115_200, true).unwrap()), "on when asked");
        let path = pty.path();
        let path = path.to_str().unwrap();
        let mut agent =
            crate::agent::AgentInstance::create(["xrce-agent", "serial", "--dev", path, "--flow-control", "-m", "ced"])
                .expect("a serial agent with flow control");
        assert!(agent.config().flow_control);
        agent.stop().unwrap();
    }
}
