//! CAN FD transport (`uxr_init_can_transport`, spec §12.5): one XRCE message per CAN FD frame, `data[0]` the
//! message length, so messages of at most 63 bytes ([`CAN_MTU`], eProsima's). The client sends under its own
//! 29-bit identifier (EFF flag set) and takes only the frames carrying that identifier, which is also the one
//! the agent answers on.
//!
//! [`CanTransport`] runs over any [`CanSocket`]: [`SocketCan`], a Linux SocketCAN raw socket in CAN FD mode
//! (through the `socketcan` crate), or [`MemoryBus`] nodes, an in-process bus for tests on machines without
//! `vcan`. The framing itself is [`xrce_proto::framing::can`].

use std::io;
use std::time::{Duration, Instant};

use socketcan::{CanFdFrame, CanFdSocket, CanFilter, CanRawFrame, EmbeddedFrame, ExtendedId, Id, StandardId};
use socketcan::{Socket, SocketOptions};
use xrce_proto::framing::can::{Frame, EFF_FLAG, EFF_MASK, MAX_MESSAGE_LEN};

pub use super::can_bus::{BusNode, BusStats, MemoryBus};
use super::{Transport, TransportError};

/// The transport's MTU: the largest message one CAN FD frame carries (eProsima's client constant).
pub const CAN_MTU: usize = MAX_MESSAGE_LEN;

/// Where [`CanTransport`] sends and receives frames.
pub trait CanSocket {
    /// Puts one frame on the bus.
    fn send(&mut self, frame: &Frame) -> io::Result<()>;

    /// Waits up to `timeout` (`None`: no limit; zero: do not wait) for one frame; `Ok(None)` when none came.
    fn recv(&mut self, timeout: Option<Duration>) -> io::Result<Option<Frame>>;
}

/// A link to the agent over a CAN FD bus, under one CAN identifier.
#[derive(Debug)]
pub struct CanTransport<S> {
    socket: S,
    id: u32,
}

impl CanTransport<SocketCan> {
    /// `uxr_init_can_transport`: a CAN FD raw socket on `interface` (`can0`), sending and filtering on the
    /// 29-bit identifier `can_id`.
    pub fn new(interface: &str, can_id: u32) -> Result<Self, TransportError> {
        if can_id & !EFF_MASK != 0 {
            return Err(TransportError::NotOpen);
        }
        Self::with_socket(SocketCan::open(interface, Some(can_id))?, can_id)
    }
}

impl<S: CanSocket> CanTransport<S> {
    /// A transport over `socket` under the 29-bit identifier `can_id`; [`TransportError::NotOpen`] if it does
    /// not fit 29 bits.
    pub fn with_socket(socket: S, can_id: u32) -> Result<Self, TransportError> {
        if can_id & !EFF_MASK != 0 {
            return Err(TransportError::NotOpen);
        }
        Ok(Self { socket, id: can_id })
    }

    /// The CAN identifier the transport sends and listens on.
    pub fn can_id(&self) -> u32 {
        self.id
    }

    /// The socket.
    pub fn socket(&mut self) -> &mut S {
        &mut self.socket
    }
}

/// A session's `timeout_ms` as a wait: negative waits forever, zero only takes what is there.
fn wait_for(timeout_ms: i32) -> Option<Duration> {
    u64::try_from(timeout_ms).ok().map(Duration::from_millis)
}

impl<S: CanSocket> Transport for CanTransport<S> {
    fn mtu(&self) -> usize {
        CAN_MTU
    }

    fn send(&mut self, msg: &[u8]) -> Result<(), TransportError> {
        let frame = Frame::with_message(self.id, msg).map_err(|_| TransportError::MessageTooLarge)?;
        Ok(self.socket.send(&frame)?)
    }

    fn recv(&mut self, buf: &mut [u8], timeout_ms: i32) -> Result<Option<usize>, TransportError> {
        let wait = wait_for(timeout_ms);
        let deadline = wait.and_then(|w| Instant::now().checked_add(w));
        loop {
            let left = match (wait, deadline) {
                (None, _) => None,
                (Some(_), Some(d)) => Some(d.saturating_duration_since(Instant::now())),
                (Some(w), None) => Some(w),
            };
            let Some(frame) = self.socket.recv(left)? else { return Ok(None) };
            // Frames of other nodes pass where the socket does not filter (the in-memory bus).
            if frame.id() == Some(self.id) {
                if let Ok(msg) = frame.message() {
                    let dst = buf.get_mut(..msg.len()).ok_or(TransportError::MessageTooLarge)?;
                    xrce_proto::bytes::copy(dst, msg);
                    return Ok(Some(msg.len()));
                }
            }
            if left.is_some_and(|l| l.is_zero()) {
                return Ok(None);
            }
        }
    }
}

/// A Linux SocketCAN raw socket in CAN FD mode (it also receives classic CAN frames).
#[derive(Debug)]
pub struct SocketCan {
    socket: CanFdSocket,
}

impl SocketCan {
    /// Opens `interface`; with `only`, the kernel passes only extended frames carrying that identifier (the
    /// client's filter), otherwise every frame.
    pub fn open(interface: &str, only: Option<u32>) -> io::Result<Self> {
        let socket = CanFdSocket::open(interface)?;
        if let Some(id) = only {
            socket.set_filters(&[CanFilter::new(id | EFF_FLAG, EFF_MASK | EFF_FLAG)])?;
        }
        Ok(Self { socket })
    }
}

/// The raw CAN socket, for programs that poll it (the C library's `platform.poll_fd.fd`).
impl std::os::fd::AsRawFd for SocketCan {
    fn as_raw_fd(&self) -> std::os::fd::RawFd {
        std::os::fd::AsRawFd::as_raw_fd(&self.socket)
    }
}

impl CanSocket for SocketCan {
    fn send(&mut self, frame: &Frame) -> io::Result<()> {
        self.socket.write_frame(&to_socketcan(frame)?)
    }

    fn recv(&mut self, timeout: Option<Duration>) -> io::Result<Option<Frame>> {
        // SO_RCVTIMEO takes no zero: a zero wait is the shortest one.
        let timeout = timeout.map(|t| t.max(Duration::from_micros(100)));
        self.socket.set_read_timeout(timeout)?;
        match self.socket.read_raw_frame() {
            Ok(raw) => Ok(Some(from_socketcan(&raw))),
            Err(e) if matches!(e.kind(), io::ErrorKind::WouldBlock | io::ErrorKind::TimedOut) => Ok(None),
            Err(e) => Err(e),
        }
    }
}

/// The `socketcan` frame of `frame`: extended or standard per its EFF flag, data padded by the crate to the
/// next CAN FD length with zeros.
pub fn to_socketcan(frame: &Frame) -> io::Result<CanFdFrame> {
    let invalid = || io::Error::new(io::ErrorKind::InvalidInput, "CAN identifier or data out of range");
    let id: Id = match frame.id() {
        Some(raw) => ExtendedId::new(raw).ok_or_else(invalid)?.into(),
        None => u16::try_from(frame.can_id).ok().and_then(StandardId::new).ok_or_else(invalid)?.into(),
    };
    CanFdFrame::new(id, frame.bytes()).ok_or_else(invalid)
}

/// A received raw frame as a [`Frame`], with the whole data field: bytes past the frame length are kept, as
/// eProsima's readers see them (see [`Frame::message`]).
pub fn from_socketcan(raw: &CanRawFrame) -> Frame {
    match raw {
        CanRawFrame::Fd(f) => Frame { can_id: f.can_id, len: f.len.min(64), data: f.data },
        CanRawFrame::Classic(f) => {
            let len = usize::from(f.can_dlc).min(f.data.len());
            Frame::from_parts(f.can_id, f.data.get(..len).unwrap_or(&[]))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use socketcan::Frame as _;

    #[test]
    fn socketcan_frames_carry_the_id_flag_and_padded_data() {
        let msg = [0xA5u8; 24];
        let frame = Frame::with_message(0x0ABC_DEF0, &msg).unwrap();
        let fd = to_socketcan(&frame).unwrap();
        assert_eq!(fd.id_word(), 0x8ABC_DEF0, "29-bit id with the EFF flag");
        assert!(fd.is_extended());
        // 25 bytes padded with zeros to the next CAN FD length, 32.
        assert_eq!(fd.len(), 32);
        assert_eq!(fd.data()[0], 24);
        assert_eq!(&fd.data()[1..25], &msg);
        assert!(fd.data()[25..].iter().all(|&b| b == 0));

        let back = from_socketcan(&CanRawFrame::Fd(*fd.as_ref()));
        assert_eq!(back.can_id, 0x8ABC_DEF0);
        assert_eq!(back.len, 32);
        assert_eq!(back.message(), Ok(&msg[..]));

        let standard = to_socketcan(&Frame::from_parts(0x123, &[1, 2])).unwrap();
        assert_eq!(standard.id_word(), 0x123);
        assert!(to_socketcan(&Frame::from_parts(0x7FF + 1, &[0])).is_err(), "not an 11-bit id");
    }

    #[test]
    fn received_frames_keep_bytes_past_their_length() {
        // eProsima's agent sends a 24-byte message in a frame of length 24: its last byte is padding.
        let msg: Vec<u8> = (1..=24).collect();
        let mut raw = *to_socketcan(&Frame::with_message(5, &msg).unwrap()).unwrap().as_ref();
        raw.len = 24;
        let frame = from_socketcan(&CanRawFrame::Fd(raw));
        assert_eq!(frame.len, 24);
        assert_eq!(frame.message(), Ok(&msg[..]));
    }

    #[test]
    fn classic_frames_are_read_up_to_their_dlc() {
        let classic = socketcan::CanDataFrame::new(ExtendedId::new(9).unwrap(), &[3, 7, 8, 9, 0xEE]).unwrap();
        let frame = from_socketcan(&CanRawFrame::Classic(*classic.as_ref()));
        assert_eq!(frame.id(), Some(9));
        assert_eq!(frame.len, 5);
        assert_eq!(frame.message(), Ok(&[7, 8, 9][..]));
    }

    #[test]
    fn the_transport_sends_under_its_id_and_takes_only_its_own_frames() {
        let bus = MemoryBus::new();
        let mut transport = CanTransport::with_socket(bus.node().unwrap(), 0x0123_4567).unwrap();
        let other = bus.node().unwrap();
        assert_eq!(transport.mtu(), 63);

        transport.send(b"ping").unwrap();
        let sent = other.try_recv().unwrap().unwrap();
        assert_eq!((sent.can_id, sent.len, sent.message()), (0x8123_4567, 5, Ok(&b"ping"[..])));
        assert_eq!(transport.send(&[0; 64]), Err(TransportError::MessageTooLarge));
        transport.send(&[7; 63]).unwrap();
        assert_eq!(other.try_recv().unwrap().unwrap().len, 64);

        // Another node's identifier, a standard frame of the same number, then ours.
        other.send(&Frame::with_message(0x0123_4568, b"not mine").unwrap()).unwrap();
        other.send(&Frame::from_parts(0x567, &[2, 1, 1])).unwrap();
        other.send(&Frame::with_message(0x0123_4567, b"mine").unwrap()).unwrap();
        let mut buf = [0u8; 64];
        assert_eq!(transport.recv(&mut buf, 1000), Ok(Some(4)));
        assert_eq!(&buf[..4], b"mine");
        assert_eq!(transport.recv(&mut buf, 0), Ok(None));
        assert_eq!(transport.recv(&mut buf, 20), Ok(None));
        assert!(CanTransport::with_socket(bus.node().unwrap(), 0x2000_0000).is_err());
    }

    #[test]
    fn opening_a_missing_interface_fails() {
        assert!(CanTransport::new("xrce-no-such-can", 1).is_err());
        assert_eq!(CanTransport::new("can0", 0x2000_0000).err(), Some(TransportError::NotOpen));
    }
}
