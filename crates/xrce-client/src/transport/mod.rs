//! Transports: the [`Transport`] trait the blocking session runs over, custom transports in both modes of
//! eProsima's custom transport (packet-oriented, or stream-oriented with HDLC-like framing), and with the
//! `std` feature UDP and TCP over IPv4/IPv6 and agent discovery, with `serial` (Unix) serial lines and with
//! `can` (Linux) CAN FD.

use core::fmt;

use xrce_proto::framing::serial::{AddressFilter, FrameParser, ESCAPE, ESCAPE_XOR, FLAG};

#[cfg(all(feature = "can", target_os = "linux"))]
pub mod can;
#[cfg(all(feature = "can", target_os = "linux"))]
mod can_bus;
#[cfg(feature = "std")]
pub mod discovery;
#[cfg(all(feature = "serial", unix))]
mod serial;
#[cfg(feature = "std")]
mod tcp;
#[cfg(feature = "std")]
mod udp;

#[cfg(all(feature = "can", target_os = "linux"))]
pub use can::{BusNode, CanSocket, CanTransport, MemoryBus, SocketCan};
#[cfg(all(feature = "serial", unix))]
pub use serial::{SerialSettings, SerialTransport, SERIAL_MTU};
#[cfg(feature = "std")]
pub use tcp::TcpTransport;
#[cfg(feature = "std")]
pub use udp::{IpProtocol, UdpTransport};

/// Why a transport operation failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TransportError {
    /// The transport is not open (or could not be opened).
    NotOpen,
    /// The peer closed the connection.
    Closed,
    /// The message does not fit the transport.
    MessageTooLarge,
    /// Fewer bytes than the whole message could be written.
    ShortWrite,
    /// An I/O error reported by a custom transport, with its code.
    Custom(u8),
    /// An operating-system I/O error.
    #[cfg(feature = "std")]
    Io(std::io::ErrorKind),
}

impl fmt::Display for TransportError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::NotOpen => f.write_str("transport not open"),
            Self::Closed => f.write_str("connection closed by the peer"),
            Self::MessageTooLarge => f.write_str("message too large for the transport"),
            Self::ShortWrite => f.write_str("message only partly written"),
            Self::Custom(code) => write!(f, "custom transport error {code}"),
            #[cfg(feature = "std")]
            Self::Io(kind) => write!(f, "I/O error: {kind}"),
        }
    }
}

impl core::error::Error for TransportError {}

#[cfg(feature = "std")]
impl From<std::io::Error> for TransportError {
    fn from(e: std::io::Error) -> Self {
        Self::Io(e.kind())
    }
}

/// A message-oriented link to one agent: the session writes whole messages and reads whole messages.
///
/// Timeouts are in milliseconds; a negative timeout waits forever (`UXR_TIMEOUT_INF`).
pub trait Transport {
    /// Opens the link (a no-op for transports opened on creation).
    fn open(&mut self) -> Result<(), TransportError> {
        Ok(())
    }

    /// Closes the link.
    fn close(&mut self) -> Result<(), TransportError> {
        Ok(())
    }

    /// Largest message the transport carries.
    fn mtu(&self) -> usize {
        crate::session::DEFAULT_MTU
    }

    /// Sends one whole message.
    fn send(&mut self, msg: &[u8]) -> Result<(), TransportError>;

    /// Waits up to `timeout_ms` for one message and copies it into `buf`; `Ok(None)` on timeout.
    fn recv(&mut self, buf: &mut [u8], timeout_ms: i32) -> Result<Option<usize>, TransportError>;
}

impl<T: Transport + ?Sized> Transport for &mut T {
    fn open(&mut self) -> Result<(), TransportError> {
        (**self).open()
    }
    fn close(&mut self) -> Result<(), TransportError> {
        (**self).close()
    }
    fn mtu(&self) -> usize {
        (**self).mtu()
    }
    fn send(&mut self, msg: &[u8]) -> Result<(), TransportError> {
        (**self).send(msg)
    }
    fn recv(&mut self, buf: &mut [u8], timeout_ms: i32) -> Result<Option<usize>, TransportError> {
        (**self).recv(buf, timeout_ms)
    }
}

/// The four callbacks of an eProsima custom transport (`uxr_set_custom_transport_callbacks`).
///
/// In packet-oriented mode (framing off) `write` gets one whole message and `read` must return one whole
/// message. In stream-oriented mode (framing on) both move arbitrary byte runs of the framed stream.
pub trait CustomIo {
    /// Opens the medium; `false` on failure.
    fn open(&mut self) -> bool {
        true
    }

    /// Closes the medium; `false` on failure.
    fn close(&mut self) -> bool {
        true
    }

    /// Writes up to `buf.len()` bytes; returns how many were written.
    fn write(&mut self, buf: &[u8]) -> Result<usize, TransportError>;

    /// Reads up to `buf.len()` bytes within `timeout_ms` (negative: no limit); 0 on timeout.
    fn read(&mut self, buf: &mut [u8], timeout_ms: i32) -> Result<usize, TransportError>;
}

/// Bytes read from a stream-oriented medium per call.
const CHUNK: usize = 64;
/// Writes returning 0 bytes tolerated in a row before giving up (the C TCP client allows 16).
const MAX_ZERO_WRITES: usize = 16;

/// A custom transport (`uxrCustomTransport`): a [`CustomIo`] with or without framing, messages up to `MTU`.
#[derive(Debug)]
pub struct CustomTransport<IO, const MTU: usize = 512> {
    io: IO,
    framing: bool,
    local_addr: u8,
    remote_addr: u8,
    decoder: FrameParser<[u8; MTU]>,
    chunk: [u8; CHUNK],
    chunk_pos: usize,
    chunk_len: usize,
    open: bool,
}

impl<IO: CustomIo, const MTU: usize> CustomTransport<IO, MTU> {
    /// `uxr_set_custom_transport_callbacks` + `uxr_init_custom_transport`: opens `io`. With `framing`, frames go
    /// from address 0 to address 0, as eProsima's custom transport sends them.
    pub fn new(io: IO, framing: bool) -> Result<Self, TransportError> {
        Self::with_addresses(io, framing, 0, 0)
    }

    /// As [`new`](Self::new) with explicit framing addresses (serial links: remote 0 is eProsima's agent).
    pub fn with_addresses(mut io: IO, framing: bool, local_addr: u8, remote_addr: u8) -> Result<Self, TransportError> {
        if !io.open() {
            return Err(TransportError::NotOpen);
        }
        Ok(Self {
            io,
            framing,
            local_addr,
            remote_addr,
            decoder: FrameParser::new([0; MTU], AddressFilter::Only(local_addr)),
            chunk: [0; CHUNK],
            chunk_pos: 0,
            chunk_len: 0,
            open: true,
        })
    }

    /// The callbacks' state (`transport->args`).
    pub fn io(&mut self) -> &mut IO {
        &mut self.io
    }

    /// Writes `bytes`: with `whole` in one write that must take them all (packet mode), else in as many
    /// writes as it takes (stream mode). The one place that calls `io.write`, so it is inlined here and its
    /// result stays in registers (firmware size).
    fn write_all(&mut self, mut bytes: &[u8], whole: bool) -> Result<(), TransportError> {
        let mut zero = 0;
        // One loop that `whole` only ends early, so the write is not duplicated for each mode (firmware size).
        while whole || !bytes.is_empty() {
            let n = self.io.write(bytes)?;
            if n == bytes.len() {
                return Ok(());
            }
            if whole {
                return Err(TransportError::ShortWrite);
            }
            if n == 0 {
                zero += 1;
                if zero >= MAX_ZERO_WRITES {
                    return Err(TransportError::ShortWrite);
                }
            }
            bytes = bytes.get(n..).unwrap_or(&[]);
        }
        Ok(())
    }
}

impl<IO: CustomIo, const MTU: usize> Transport for CustomTransport<IO, MTU> {
    fn open(&mut self) -> Result<(), TransportError> {
        if !self.open {
            self.open = self.io.open();
        }
        if self.open {
            Ok(())
        } else {
            Err(TransportError::NotOpen)
        }
    }

    fn close(&mut self) -> Result<(), TransportError> {
        self.open = false;
        if self.io.close() {
            Ok(())
        } else {
            Err(TransportError::Custom(0))
        }
    }

    fn mtu(&self) -> usize {
        MTU
    }

    fn send(&mut self, msg: &[u8]) -> Result<(), TransportError> {
        if !self.open {
            return Err(TransportError::NotOpen);
        }
        if msg.len() > MTU {
            return Err(TransportError::MessageTooLarge);
        }
        if !self.framing {
            return self.write_all(msg, true);
        }
        // The frame's bytes (as `FrameBytes` yields them) escaped straight into a chunk, no iterator state
        // (firmware size).
        let len = u16::try_from(msg.len()).map_err(|_| TransportError::MessageTooLarge)?;
        let [len_lo, len_hi] = len.to_le_bytes();
        let header = [self.local_addr, self.remote_addr, len_lo, len_hi];
        let crc = xrce_proto::framing::crc16(msg).to_le_bytes();
        let mut buf = [0u8; CHUNK];
        let mut n = 1;
        if let Some(first) = buf.first_mut() {
            *first = FLAG;
        }
        // The header, the payload, the CRC in turn (no array of the three slices on the stack).
        let mut part: &[u8] = &header;
        let mut parts = 1;
        loop {
            for &byte in part {
                // An escaped byte goes as ESCAPE, then itself xored.
                let mut escape = byte == FLAG || byte == ESCAPE;
                let mut out = if escape { ESCAPE } else { byte };
                loop {
                    if let Some(slot) = buf.get_mut(n) {
                        *slot = out;
                        n += 1;
                    }
                    if n == CHUNK {
                        self.write_all(&buf, false)?;
                        n = 0;
                    }
                    if !escape {
                        break;
                    }
                    escape = false;
                    out = byte ^ ESCAPE_XOR;
                }
            }
            part = match parts {
                1 => msg,
                2 => &crc,
                _ => break,
            };
            parts += 1;
        }
        self.write_all(buf.get(..n).unwrap_or(&[]), false)
    }

    fn recv(&mut self, buf: &mut [u8], timeout_ms: i32) -> Result<Option<usize>, TransportError> {
        if !self.open {
            return Err(TransportError::NotOpen);
        }
        // One byte at a time through the parser, which has no error to report; `io.read` called at one
        // place for both modes, so it is inlined here (firmware size).
        loop {
            if !self.framing || self.chunk_pos >= self.chunk_len {
                let into: &mut [u8] = if self.framing { &mut self.chunk } else { &mut *buf };
                let n = self.io.read(into, timeout_ms)?;
                if n == 0 {
                    return Ok(None);
                }
                if !self.framing {
                    return Ok(Some(n));
                }
                self.chunk_pos = 0;
                self.chunk_len = n.min(CHUNK);
            }
            let raw = self.chunk.get(self.chunk_pos).copied().unwrap_or(0);
            self.chunk_pos += 1;
            if let Some((src, payload)) = self.decoder.push_byte(raw) {
                if src != self.remote_addr {
                    continue;
                }
                let dst = buf.get_mut(..payload.len()).ok_or(TransportError::MessageTooLarge)?;
                xrce_proto::bytes::copy(dst, payload);
                return Ok(Some(payload.len()));
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Accepts at most `max` bytes per write (0: none), records calls and what was written.
    struct Io {
        max: usize,
        calls: usize,
        written: std::vec::Vec<u8>,
    }

    impl CustomIo for Io {
        fn write(&mut self, buf: &[u8]) -> Result<usize, TransportError> {
            self.calls += 1;
            let n = buf.len().min(self.max);
            self.written.extend_from_slice(&buf[..n]);
            Ok(n)
        }

        fn read(&mut self, _: &mut [u8], _: i32) -> Result<usize, TransportError> {
            Ok(0)
        }
    }

    fn transport(max: usize, framing: bool) -> CustomTransport<Io, 512> {
        CustomTransport::new(Io { max, calls: 0, written: std::vec::Vec::new() }, framing).unwrap()
    }

    #[test]
    fn packet_mode_writes_each_message_once_whole() {
        let mut t = transport(512, false);
        assert_eq!(t.send(&[1, 2, 3]), Ok(()));
        assert_eq!(t.send(&[]), Ok(()));
        assert_eq!((t.io().calls, t.io().written.as_slice()), (2, &[1, 2, 3][..]));
        let mut short = transport(2, false);
        assert_eq!(short.send(&[1, 2, 3]), Err(TransportError::ShortWrite));
        assert_eq!(short.io().calls, 1);
    }

    #[test]
    fn stream_mode_writes_in_pieces_and_gives_up_after_zero_writes() {
        let mut t = transport(3, true);
        assert_eq!(t.send(&[0x7E, 5]), Ok(()));
        let mut frame = [0u8; 32];
        let len = xrce_proto::framing::encode_frame(0, 0, &[0x7E, 5], &mut frame).unwrap();
        assert_eq!(t.io().written, frame[..len]);
        assert!(t.io().calls >= len / 3);
        let mut stuck = transport(0, true);
        assert_eq!(stuck.send(&[1]), Err(TransportError::ShortWrite));
        assert_eq!(stuck.io().calls, MAX_ZERO_WRITES);
    }
}
