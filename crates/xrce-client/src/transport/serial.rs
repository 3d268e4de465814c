//! Serial transport (`uxr_init_serial_transport`): XRCE messages in HDLC-like frames (spec §12.3,
//! [`xrce_proto::framing::serial`]) on a serial device or any other open terminal.
//!
//! Frames carry a source and a destination address: the transport sends from its local address to its remote
//! one, and takes only frames sent to its local address **by** its remote one, as eProsima's serial client
//! does. eProsima's agent answers from address 0, so the remote address is 0 against it (and against ours).
//!
//! Line settings (raw 8N1, the baud rate, RTS/CTS) are made by the `serialport` crate, which the agent uses
//! too: it sets any rate the driver takes (termios2 on Linux), not only termios' standard list. Reads wait
//! with `poll(2)` (the `nix` crate), so the transport needs no `unsafe`.

use std::fs::File;
use std::io::{self, Read, Write};
use std::os::fd::AsFd;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use nix::poll::{poll, PollFd, PollFlags, PollTimeout};
use xrce_proto::framing::serial::{encode_frame, max_encoded_len, AddressFilter, Event, FrameDecoder};

use super::{Transport, TransportError};

/// Largest message by default: eProsima's `UXR_CONFIG_SERIAL_TRANSPORT_MTU`.
pub const SERIAL_MTU: usize = 512;
/// Bytes read from the line per system call.
const CHUNK: usize = 256;
/// How long a write waits for room on a non-blocking descriptor (devices opened by path are) without any byte
/// taken before the message is given up.
const WRITE_TIMEOUT: Duration = Duration::from_secs(1);

/// How a device opened by path is set up: raw 8N1 at `baud_rate`, with or without RTS/CTS.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SerialSettings {
    /// Line speed: any rate the driver takes (250000, 1000000, …), not only the standard ones.
    pub baud_rate: u32,
    /// RTS/CTS hardware flow control (the line then waits for CTS before sending).
    pub rts_cts: bool,
}

impl SerialSettings {
    /// Raw 8N1 at `baud_rate`, no flow control.
    pub const fn new(baud_rate: u32) -> Self {
        Self { baud_rate, rts_cts: false }
    }

    /// With RTS/CTS hardware flow control when `on`.
    #[must_use]
    pub const fn rts_cts(mut self, on: bool) -> Self {
        self.rts_cts = on;
        self
    }
}

impl Default for SerialSettings {
    /// 115200 baud (the agent's default), no flow control.
    fn default() -> Self {
        Self::new(115_200)
    }
}

/// A device the transport opened itself, so it can open it again.
#[derive(Debug, Clone)]
struct Device {
    path: PathBuf,
    settings: SerialSettings,
}

/// A serial link to one agent: a terminal device (or pseudoterminal) carrying framed messages.
#[derive(Debug)]
pub struct SerialTransport {
    file: Option<File>,
    device: Option<Device>,
    local_addr: u8,
    remote_addr: u8,
    mtu: usize,
    decoder: FrameDecoder<Vec<u8>>,
    chunk: [u8; CHUNK],
    chunk_pos: usize,
    chunk_len: usize,
    /// The frame being written, reused.
    frame: Vec<u8>,
}

impl SerialTransport {
    /// `uxr_init_serial_transport(transport, fd, remote_addr, local_addr)`: frames over `file`, an open
    /// terminal used with the settings it has (the caller made them, as with eProsima's API). Blocking and
    /// non-blocking descriptors both work.
    pub fn from_file(file: File, remote_addr: u8, local_addr: u8) -> Self {
        Self {
            file: Some(file),
            device: None,
            local_addr,
            remote_addr,
            mtu: SERIAL_MTU,
            decoder: FrameDecoder::new(vec![0u8; SERIAL_MTU], AddressFilter::Only(local_addr)),
            chunk: [0; CHUNK],
            chunk_pos: 0,
            chunk_len: 0,
            frame: Vec::new(),
        }
    }

    /// Opens the device at `path` in raw 8N1 with `settings`. After [`Transport::close`], or once the device
    /// was unplugged and is back, [`Transport::open`] opens it again with the same settings.
    pub fn open_device(
        path: impl AsRef<Path>,
        settings: SerialSettings,
        remote_addr: u8,
        local_addr: u8,
    ) -> Result<Self, TransportError> {
        let device = Device { path: path.as_ref().to_path_buf(), settings };
        let file = open_raw(&device)?;
        let mut transport = Self::from_file(file, remote_addr, local_addr);
        transport.device = Some(device);
        Ok(transport)
    }

    /// Carries messages up to `mtu` bytes (default [`SERIAL_MTU`]; eProsima's agent takes up to 65535).
    #[must_use]
    pub fn with_mtu(mut self, mtu: usize) -> Self {
        self.mtu = mtu.max(1);
        self.decoder = FrameDecoder::new(vec![0u8; self.mtu], AddressFilter::Only(self.local_addr));
        self
    }

    /// Goes on over `file`: the same device opened again after it was unplugged, or another line to the same
    /// agent. A frame half read is dropped; the session and its streams go on (reliable streams resend what
    /// was lost in between).
    pub fn reattach(&mut self, file: File) {
        self.file = Some(file);
        self.forget_input();
    }

    /// The address frames are sent from, and must be sent to.
    pub fn local_addr(&self) -> u8 {
        self.local_addr
    }

    /// The address frames are sent to, and must come from.
    pub fn remote_addr(&self) -> u8 {
        self.remote_addr
    }

    /// Whether a device is open.
    pub fn is_open(&self) -> bool {
        self.file.is_some()
    }

    fn forget_input(&mut self) {
        self.decoder.reset();
        self.chunk_pos = 0;
        self.chunk_len = 0;
    }

    /// Writes all of `bytes`, waiting for room if the descriptor is non-blocking.
    fn write_all(file: &mut File, mut bytes: &[u8]) -> Result<(), TransportError> {
        let mut stalled_since = None;
        while !bytes.is_empty() {
            match file.write(bytes) {
                Ok(0) => return Err(TransportError::ShortWrite),
                Ok(n) => {
                    bytes = bytes.get(n..).unwrap_or(&[]);
                    stalled_since = None;
                }
                Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
                Err(e) if e.kind() == io::ErrorKind::WouldBlock => {
                    let since = *stalled_since.get_or_insert_with(Instant::now);
                    let left = WRITE_TIMEOUT.saturating_sub(since.elapsed());
                    if left.is_zero() {
                        return Err(TransportError::ShortWrite);
                    }
                    wait(file, PollFlags::POLLOUT, Some(left))?;
                }
                Err(e) => return Err(e.into()),
            }
        }
        Ok(())
    }
}

/// Opens `device` and makes it raw 8N1 at its speed.
fn open_raw(device: &Device) -> Result<File, TransportError> {
    use std::os::unix::fs::OpenOptionsExt;
    // Not the controlling terminal: a hang-up must not signal the process. Non-blocking, so a line held back
    // by flow control (CTS low, nobody reading) fails a send after WRITE_TIMEOUT instead of blocking for ever;
    // reads wait in poll(2) anyway.
    let file = std::fs::OpenOptions::new()
        .read(true)
        .write(true)
        .custom_flags(nix::libc::O_NOCTTY | nix::libc::O_NONBLOCK)
        .open(&device.path)?;
    let flow = if device.settings.rts_cts { serialport::FlowControl::Hardware } else { serialport::FlowControl::None };
    let path = device.path.to_str().ok_or(TransportError::NotOpen)?;
    // Shared, not exclusive, and closed at once: the settings stay with the terminal, which `file` keeps open.
    let port = serialport::new(path, device.settings.baud_rate)
        .data_bits(serialport::DataBits::Eight)
        .parity(serialport::Parity::None)
        .stop_bits(serialport::StopBits::One)
        .flow_control(flow)
        .exclusive(false)
        .open_native()
        .map_err(|e| TransportError::Io(io::Error::from(e).kind()))?;
    drop(port);
    Ok(file)
}

/// Waits up to `timeout` (`None`: no limit) for `events` on `file`; false on timeout. A hang-up counts as
/// ready: the read or write that follows reports it.
fn wait(file: &File, events: PollFlags, timeout: Option<Duration>) -> Result<bool, TransportError> {
    let timeout = match timeout {
        None => PollTimeout::NONE,
        // Rounded up, so a short wait is not a busy loop; the longest poll(2) takes is ~24 days.
        Some(t) => PollTimeout::try_from(t.as_millis().saturating_add(u128::from(t.subsec_nanos() % 1_000_000 > 0)))
            .unwrap_or(PollTimeout::MAX),
    };
    let mut fds = [PollFd::new(file.as_fd(), events)];
    match poll(&mut fds, timeout) {
        Ok(n) => Ok(n > 0),
        Err(nix::errno::Errno::EINTR) => Ok(false),
        Err(e) => Err(io::Error::from(e).into()),
    }
}

impl Transport for SerialTransport {
    /// Opens the device again if it is closed (after [`Transport::close`] or an unplug); fails with
    /// [`TransportError::NotOpen`] for a transport made [`from_file`](SerialTransport::from_file).
    fn open(&mut self) -> Result<(), TransportError> {
        if self.file.is_some() {
            return Ok(());
        }
        let device = self.device.as_ref().ok_or(TransportError::NotOpen)?;
        let file = open_raw(device)?;
        self.reattach(file);
        Ok(())
    }

    /// Closes the device (`uxr_close_serial_transport`).
    fn close(&mut self) -> Result<(), TransportError> {
        self.file = None;
        self.forget_input();
        Ok(())
    }

    fn mtu(&self) -> usize {
        self.mtu
    }

    fn send(&mut self, msg: &[u8]) -> Result<(), TransportError> {
        let file = self.file.as_mut().ok_or(TransportError::NotOpen)?;
        if msg.len() > self.mtu {
            return Err(TransportError::MessageTooLarge);
        }
        self.frame.resize(max_encoded_len(msg.len()), 0);
        let n = encode_frame(self.local_addr, self.remote_addr, msg, &mut self.frame)
            .map_err(|_| TransportError::MessageTooLarge)?;
        Self::write_all(file, self.frame.get(..n).unwrap_or(&[]))
    }

    /// Waits up to `timeout_ms` for a frame from the remote address; frames from elsewhere, damaged ones and
    /// ones too large for the MTU are skipped. A hung-up line (a USB adapter unplugged) is
    /// [`TransportError::Closed`].
    fn recv(&mut self, buf: &mut [u8], timeout_ms: i32) -> Result<Option<usize>, TransportError> {
        let deadline = u64::try_from(timeout_ms).ok().map(|ms| Instant::now() + Duration::from_millis(ms));
        loop {
            while self.chunk_pos < self.chunk_len {
                let input = self.chunk.get(self.chunk_pos..self.chunk_len).unwrap_or(&[]);
                let (used, event) = self.decoder.feed(input);
                self.chunk_pos += used;
                if let Some(Event::Frame { src, payload, .. }) = event {
                    if src == self.remote_addr {
                        let dst = buf.get_mut(..payload.len()).ok_or(TransportError::MessageTooLarge)?;
                        xrce_proto::bytes::copy(dst, payload);
                        return Ok(Some(payload.len()));
                    }
                }
            }
            let file = self.file.as_mut().ok_or(TransportError::NotOpen)?;
            let left = deadline.map(|d| d.saturating_duration_since(Instant::now()));
            if !wait(file, PollFlags::POLLIN, left)? {
                return Ok(None);
            }
            match file.read(&mut self.chunk) {
                // A terminal in raw mode reads 0 only once hung up.
                Ok(0) => return Err(TransportError::Closed),
                Ok(n) => {
                    self.chunk_pos = 0;
                    self.chunk_len = n.min(CHUNK);
                }
                Err(e) if matches!(e.kind(), io::ErrorKind::WouldBlock | io::ErrorKind::Interrupted) => {}
                Err(e) => return Err(e.into()),
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A pseudoterminal: the transport on its slave side (opened by path, as a device), the test on the master.
    fn pty() -> (File, PathBuf) {
        let pty = nix::pty::openpty(None, None).unwrap();
        let path = nix::unistd::ttyname(&pty.slave).unwrap();
        (File::from(pty.master), path)
    }

    fn frame(src: u8, dst: u8, payload: &[u8]) -> Vec<u8> {
        let mut out = vec![0u8; max_encoded_len(payload.len())];
        let n = encode_frame(src, dst, payload, &mut out).unwrap();
        out.truncate(n);
        out
    }

    /// Only frames from the remote address to the local one are messages; the rest of the line's traffic (other
    /// nodes on a shared line, another remote) is skipped, even within one read.
    #[test]
    fn only_frames_from_the_remote_to_the_local_address_are_received() {
        let (mut master, path) = pty();
        let mut t = SerialTransport::open_device(&path, SerialSettings::new(115_200), 0, 7).unwrap();
        let mut line = Vec::new();
        line.extend(frame(3, 7, b"from another remote"));
        line.extend(frame(0, 8, b"to another node"));
        line.extend(frame(0, 7, b"for us"));
        master.write_all(&line).unwrap();
        let mut buf = [0u8; SERIAL_MTU];
        let n = t.recv(&mut buf, 1000).unwrap().expect("a message");
        assert_eq!(&buf[..n], b"for us");
        master.write_all(&frame(3, 7, b"ignored")).unwrap();
        assert_eq!(t.recv(&mut buf, 50).unwrap(), None, "a frame from elsewhere is not a message");
    }

    /// Sent messages leave as frames from the local address to the remote one.
    #[test]
    fn messages_are_framed_from_local_to_remote() {
        let (mut master, path) = pty();
        let mut t = SerialTransport::open_device(&path, SerialSettings::new(921_600), 0, 7).unwrap();
        t.send(&[0x7E, 1, 2, 0x7D]).unwrap();
        let expected = frame(7, 0, &[0x7E, 1, 2, 0x7D]);
        let mut got = vec![0u8; expected.len()];
        master.read_exact(&mut got).unwrap();
        assert_eq!(got, expected);
        assert_eq!(t.send(&[0u8; SERIAL_MTU + 1]), Err(TransportError::MessageTooLarge));
    }

    /// A line nobody reads (held back, as by CTS low) fails a send once it took nothing for WRITE_TIMEOUT,
    /// rather than blocking the session for ever.
    #[test]
    fn a_send_on_a_line_nobody_reads_gives_up() {
        let (_master, path) = pty();
        let mut t = SerialTransport::open_device(&path, SerialSettings::default(), 0, 1).unwrap();
        let outcome = (0..100_000).map(|_| t.send(&[0x55; SERIAL_MTU])).find(Result::is_err);
        assert_eq!(outcome, Some(Err(TransportError::ShortWrite)));
    }

    /// The device is set raw at the asked rate, non-standard ones included, with RTS/CTS when asked.
    #[test]
    fn device_settings_are_applied() {
        use nix::sys::termios::{tcgetattr, ControlFlags};
        let (_master, path) = pty();
        let t = SerialTransport::open_device(&path, SerialSettings::new(250_000).rts_cts(true), 0, 1).unwrap();
        let attrs = tcgetattr(t.file.as_ref().unwrap()).unwrap();
        assert!(attrs.control_flags.contains(ControlFlags::CRTSCTS));
        assert!(!attrs.local_flags.contains(nix::sys::termios::LocalFlags::ICANON), "raw mode");
        assert_eq!(attrs.control_flags.bits() & nix::libc::CBAUD, nix::libc::BOTHER, "custom rate");
    }

    /// A timeout returns `None`; a hung-up line (the other end gone) is `Closed`; `open` after `close` opens the
    /// device again, and a transport made from a file cannot.
    #[test]
    fn timeout_hangup_and_reopen() {
        let (master, path) = pty();
        let mut t = SerialTransport::open_device(&path, SerialSettings::default(), 0, 1).unwrap();
        let mut buf = [0u8; SERIAL_MTU];
        assert_eq!(t.recv(&mut buf, 0).unwrap(), None);
        assert_eq!(t.recv(&mut buf, 20).unwrap(), None);
        t.close().unwrap();
        assert_eq!(t.send(b"x"), Err(TransportError::NotOpen));
        t.open().unwrap();
        assert!(t.is_open());
        drop(master);
        assert_eq!(t.recv(&mut buf, 1000), Err(TransportError::Closed));

        let (master, path) = pty();
        let file = std::fs::OpenOptions::new().read(true).write(true).open(path).unwrap();
        let mut t = SerialTransport::from_file(file, 0, 1);
        t.close().unwrap();
        assert_eq!(t.open(), Err(TransportError::NotOpen));
        drop(master);
    }
}
