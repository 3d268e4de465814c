//! Serial shells (`serial`, `multiserial`, `pseudoterminal`): XRCE messages in HDLC-like frames (spec §12.3,
//! [`xrce_proto::framing::serial`]). The agent's local address is 0; it accepts frames sent to 0 and
//! answers each client at the source address of its frames. One reader thread per line, plus a thread for
//! the core's timers and middleware wake-ups. Lines are non-blocking: a line nobody reads (a pty whose client
//! left) drops frames after [`WRITE_TIMEOUT`] instead of stalling the agent; reliable streams recover.

use std::fs::File;
use std::io::{self, Read, Write};
use std::os::fd::AsFd;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::thread;
use std::time::{Duration, Instant};

use nix::poll::{poll, PollFd, PollFlags, PollTimeout};
use nix::sys::termios::{self, BaudRate, SetArg};
use xrce_proto::framing::serial::{encode_frame, max_encoded_len, AddressFilter, Event, FrameDecoder};

use super::{anchor_wall_clock, block_for, hexdump, lock, run_due, SharedCore, WakeSignal, MAX_BLOCK};
use crate::core::Transmit;

/// The agent's address on serial lines (eProsima's).
pub const AGENT_ADDRESS: u8 = 0;
/// Largest message on a serial line (eProsima's agent buffer).
pub const MAX_MESSAGE: usize = 65_535;
/// How long a frame may wait for room on a line before it is dropped.
pub const WRITE_TIMEOUT: Duration = Duration::from_secs(1);

/// A client on a serial line: the line's index and the client's address (its frames' source).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct SerialEndpoint {
    /// Index of the line (device) in the server.
    pub line: u16,
    /// Address of the client on that line.
    pub address: u8,
}

/// One serial line: a device or a pseudoterminal master.
#[derive(Debug)]
pub struct Line {
    file: File,
    name: String,
    /// A pseudoterminal's slave side, kept open so reading the master never fails while no client has it open.
    _slave: Option<std::os::fd::OwnedFd>,
}

fn to_io(e: nix::Error) -> io::Error {
    io::Error::from(e)
}

/// The termios speed for `baud`, if it is a standard rate.
pub fn baud_rate(baud: u32) -> Option<BaudRate> {
    Some(match baud {
        1200 => BaudRate::B1200,
        2400 => BaudRate::B2400,
        4800 => BaudRate::B4800,
        9600 => BaudRate::B9600,
        19_200 => BaudRate::B19200,
        38_400 => BaudRate::B38400,
        57_600 => BaudRate::B57600,
        115_200 => BaudRate::B115200,
        230_400 => BaudRate::B230400,
        460_800 => BaudRate::B460800,
        500_000 => BaudRate::B500000,
        576_000 => BaudRate::B576000,
        921_600 => BaudRate::B921600,
        1_000_000 => BaudRate::B1000000,
        1_500_000 => BaudRate::B1500000,
        2_000_000 => BaudRate::B2000000,
        3_000_000 => BaudRate::B3000000,
        4_000_000 => BaudRate::B4000000,
        _ => return None,
    })
}

/// Raw mode (no echo, no line discipline, 8N1) at `baud`.
fn make_raw(fd: impl AsFd, baud: u32) -> io::Result<()> {
    let mut t = termios::tcgetattr(&fd).map_err(to_io)?;
    termios::cfmakeraw(&mut t);
    let speed = baud_rate(baud)
        .ok_or_else(|| io::Error::new(io::ErrorKind::InvalidInput, format!("unsupported baud rate {baud}")))?;
    termios::cfsetspeed(&mut t, speed).map_err(to_io)?;
    termios::tcsetattr(&fd, SetArg::TCSANOW, &t).map_err(to_io)
}

fn set_nonblocking(file: &File) -> io::Result<()> {
    use nix::fcntl::{fcntl, FcntlArg, OFlag};
    let flags = OFlag::from_bits_truncate(fcntl(file, FcntlArg::F_GETFL).map_err(to_io)?);
    fcntl(file, FcntlArg::F_SETFL(flags | OFlag::O_NONBLOCK)).map_err(to_io)?;
    Ok(())
}

impl Line {
    /// Opens a serial device in raw mode at `baud`.
    pub fn open(path: &Path, baud: u32) -> io::Result<Self> {
        use std::os::unix::fs::OpenOptionsExt;
        let file = std::fs::OpenOptions::new()
            .read(true)
            .write(true)
            .custom_flags(nix::fcntl::OFlag::O_NOCTTY.bits())
            .open(path)?;
        make_raw(&file, baud)?;
        set_nonblocking(&file)?;
        Ok(Self { file, name: path.display().to_string(), _slave: None })
    }

    /// Creates a pseudoterminal; clients open [`Self::name`] (the slave side).
    pub fn pseudoterminal(baud: u32) -> io::Result<Self> {
        let pty = nix::pty::openpty(None, None).map_err(to_io)?;
        make_raw(&pty.slave, baud)?;
        let name = nix::unistd::ttyname(&pty.slave).map_err(to_io)?;
        let file = File::from(pty.master);
        set_nonblocking(&file)?;
        Ok(Self { file, name: name.display().to_string(), _slave: Some(pty.slave) })
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

type Writers = Arc<Vec<Mutex<File>>>;

/// A serial server around a shared core: one or more lines.
#[derive(Debug)]
pub struct SerialServer {
    lines: Vec<Line>,
    core: SharedCore<SerialEndpoint>,
    wake: Arc<WakeSignal>,
}

/// Writes a whole frame to a non-blocking line, waiting for room at most [`WRITE_TIMEOUT`].
fn write_frame(file: &mut File, mut bytes: &[u8]) -> io::Result<()> {
    let deadline = Instant::now() + WRITE_TIMEOUT;
    while !bytes.is_empty() {
        match file.write(bytes) {
            Ok(0) => return Err(io::ErrorKind::WriteZero.into()),
            Ok(n) => bytes = bytes.get(n..).unwrap_or(&[]),
            Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
            Err(e) if e.kind() == io::ErrorKind::WouldBlock => {
                let left = deadline.saturating_duration_since(Instant::now());
                if left.is_zero() {
                    return Err(io::ErrorKind::TimedOut.into());
                }
                let timeout = PollTimeout::try_from(left.min(Duration::from_millis(100))).unwrap_or(PollTimeout::ZERO);
                let mut fds = [PollFd::new(file.as_fd(), PollFlags::POLLOUT)];
                let _ = poll(&mut fds, timeout);
            }
            Err(e) => return Err(e),
        }
    }
    Ok(())
}

/// Frames and sends what the core produced.
fn dispatch(core: &SharedCore<SerialEndpoint>, writers: &Writers, names: &[String]) {
    let transmits: Vec<Transmit<SerialEndpoint>> = {
        let mut c = lock(core);
        std::iter::from_fn(|| c.poll_transmit()).collect()
    };
    let mut frame = Vec::new();
    for t in &transmits {
        let Some(writer) = writers.get(usize::from(t.to.line)) else { continue };
        let name = names.get(usize::from(t.to.line)).map_or("?", String::as_str);
        frame.resize(max_encoded_len(t.data.len()), 0);
        let n = match encode_frame(AGENT_ADDRESS, t.to.address, &t.data, &mut frame) {
            Ok(n) => n,
            Err(e) => {
                tracing::warn!(line = name, len = t.data.len(), "cannot frame message: {e}");
                continue;
            }
        };
        hexdump("send", &t.to, &t.data);
        let mut file = writer.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        if let Err(e) = write_frame(&mut file, frame.get(..n).unwrap_or(&[])) {
            tracing::debug!(line = name, "serial write failed, frame dropped: {e}");
        }
    }
    let mut c = lock(core);
    for t in transmits {
        c.recycle(t.data);
    }
}

impl SerialServer {
    /// A server on `lines`; installs the middleware waker.
    pub fn new(lines: Vec<Line>, core: SharedCore<SerialEndpoint>) -> Self {
        let wake = Arc::new(WakeSignal::default());
        {
            let mut c = lock(&core);
            anchor_wall_clock(&mut c);
            wake.install(&mut c);
        }
        Self { lines, core, wake }
    }

    /// The device paths of the lines.
    pub fn names(&self) -> Vec<String> {
        self.lines.iter().map(|l| l.name.clone()).collect()
    }

    /// Serves until `stop` is set.
    pub fn run(self, stop: &Arc<AtomicBool>) -> io::Result<()> {
        let names = self.names();
        let mut readers = Vec::new();
        let mut writers = Vec::new();
        for line in &self.lines {
            writers.push(Mutex::new(line.file.try_clone()?));
        }
        let writers: Writers = Arc::new(writers);
        for (index, line) in self.lines.into_iter().enumerate() {
            let index = u16::try_from(index).map_err(|_| io::Error::other("too many serial lines"))?;
            let (core, writers, names, stop) = (self.core.clone(), writers.clone(), names.clone(), stop.clone());
            readers.push(
                thread::Builder::new()
                    .name(format!("xrce-serial-{index}"))
                    .spawn(move || read_loop(line, index, &core, &writers, &names, &stop))?,
            );
        }
        timer_loop(&self.core, &writers, &names, stop, &self.wake);
        for r in readers {
            let _ = r.join();
        }
        Ok(())
    }
}

fn read_loop(
    mut line: Line,
    index: u16,
    core: &SharedCore<SerialEndpoint>,
    writers: &Writers,
    names: &[String],
    stop: &AtomicBool,
) {
    let mut decoder = FrameDecoder::new(vec![0u8; MAX_MESSAGE], AddressFilter::Only(AGENT_ADDRESS));
    let mut buf = vec![0u8; 4096];
    let timeout = PollTimeout::try_from(MAX_BLOCK).unwrap_or(PollTimeout::ZERO);
    while !stop.load(Ordering::Relaxed) {
        let mut fds = [PollFd::new(line.file.as_fd(), PollFlags::POLLIN)];
        match poll(&mut fds, timeout) {
            Ok(0) | Err(nix::Error::EINTR) => continue,
            Ok(_) => {}
            Err(e) => {
                tracing::warn!(line = %line.name, "poll failed: {e}");
                break;
            }
        }
        let n = match line.file.read(&mut buf) {
            Ok(0) => {
                // A serial line at EOF (no carrier): try again later rather than spin.
                thread::sleep(MAX_BLOCK);
                continue;
            }
            Ok(n) => n,
            Err(e) if matches!(e.kind(), io::ErrorKind::WouldBlock | io::ErrorKind::Interrupted) => continue,
            Err(e) => {
                // A pty master reports EIO while no slave is open: wait for a client.
                tracing::debug!(line = %line.name, "read failed: {e}");
                thread::sleep(MAX_BLOCK);
                continue;
            }
        };
        {
            let mut c = lock(core);
            let now = Instant::now();
            decoder.push(buf.get(..n).unwrap_or(&[]), |event| match event {
                Event::Frame { src, payload, .. } => {
                    let from = SerialEndpoint { line: index, address: src };
                    hexdump("recv", &from, payload);
                    c.handle_datagram(from, payload, now);
                }
                Event::Error(e) => tracing::debug!(line = %line.name, "frame dropped: {e}"),
            });
        }
        dispatch(core, writers, names);
    }
}

fn timer_loop(
    core: &SharedCore<SerialEndpoint>,
    writers: &Writers,
    names: &[String],
    stop: &AtomicBool,
    wake: &WakeSignal,
) {
    while !stop.load(Ordering::Relaxed) {
        let next = lock(core).poll_timeout();
        let woken = wake.wait(block_for(next, Instant::now()));
        run_due(&mut lock(core), woken, Instant::now());
        dispatch(core, writers, names);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::core::{AgentCore, CoreConfig};
    use crate::middleware::ced::Ced;
    use crate::middleware::describe::FallbackProfiles;
    use crate::transport::DynMiddleware;

    /// A client on the pseudoterminal's slave side pings the agent (GET_INFO out of session) in a frame from
    /// address 1 and gets the INFO back in a frame from 0 to 1.
    #[test]
    fn pseudoterminal_answers_a_framed_ping() {
        let core =
            AgentCore::new(CoreConfig::default(), Box::new(Ced::new(Arc::new(FallbackProfiles))) as DynMiddleware);
        let core = Arc::new(Mutex::new(core));
        let line = Line::pseudoterminal(115_200).unwrap();
        let path = line.path();
        assert!(path.starts_with("/dev/pts"), "{path:?}");
        let server = SerialServer::new(vec![line], core);
        let stop = Arc::new(AtomicBool::new(false));
        let s2 = stop.clone();
        let t = thread::spawn(move || server.run(&s2));

        let mut client = std::fs::OpenOptions::new().read(true).write(true).open(&path).unwrap();
        make_raw(&client, 115_200).unwrap();
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
}
