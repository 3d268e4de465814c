//! UDP transport over IPv4 or IPv6 (`uxr_init_udp_transport`): one message per datagram.

use std::net::{SocketAddr, ToSocketAddrs, UdpSocket};
use std::time::Duration;

use socket2::{Domain, Protocol, Socket, Type};

use super::{Transport, TransportError};
use crate::session::DEFAULT_MTU;

/// IP version of a transport (`uxrIpProtocol`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum IpProtocol {
    /// `UXR_IPv4`.
    V4,
    /// `UXR_IPv6`.
    V6,
}

/// Resolves `ip`:`port` to an address of the wanted IP version.
pub(crate) fn resolve(protocol: IpProtocol, ip: &str, port: &str) -> Result<SocketAddr, TransportError> {
    let port: u16 = port.trim().parse().map_err(|_| TransportError::NotOpen)?;
    (ip, port)
        .to_socket_addrs()?
        .find(|a| matches!((protocol, a), (IpProtocol::V4, SocketAddr::V4(_)) | (IpProtocol::V6, SocketAddr::V6(_))))
        .ok_or(TransportError::NotOpen)
}

/// Converts a C-style timeout (negative: forever; 0: just poll) to a socket timeout.
pub(crate) fn timeout(ms: i32) -> Option<Duration> {
    match ms {
        ms if ms < 0 => None,
        0 => Some(Duration::from_micros(100)),
        ms => Some(Duration::from_millis(u64::from(ms.unsigned_abs()))),
    }
}

/// A UDP socket connected to one agent.
#[derive(Debug)]
pub struct UdpTransport {
    socket: UdpSocket,
    mtu: usize,
}

impl UdpTransport {
    /// `uxr_init_udp_transport`: agent at `ip`, `port` (as strings, like the C API and the examples' argv).
    pub fn new(protocol: IpProtocol, ip: &str, port: &str) -> Result<Self, TransportError> {
        Self::connect(resolve(protocol, ip, port)?)
    }

    /// A transport to the agent at `agent`.
    pub fn connect(agent: SocketAddr) -> Result<Self, TransportError> {
        let socket = Socket::new(Domain::for_address(agent), Type::DGRAM, Some(Protocol::UDP))?;
        let local: SocketAddr = if agent.is_ipv4() { ([0, 0, 0, 0], 0).into() } else { ([0u16; 8], 0).into() };
        socket.bind(&local.into())?;
        socket.connect(&agent.into())?;
        Ok(Self { socket: socket.into(), mtu: DEFAULT_MTU })
    }

    /// A transport over `socket`, already connected to the agent (a program that also uses the socket itself
    /// keeps a `try_clone` of it).
    pub fn from_socket(socket: UdpSocket) -> Self {
        Self { socket, mtu: DEFAULT_MTU }
    }

    /// The local address (the agent identifies keyless sessions by it).
    pub fn local_addr(&self) -> Result<SocketAddr, TransportError> {
        Ok(self.socket.local_addr()?)
    }
}

impl Transport for UdpTransport {
    fn mtu(&self) -> usize {
        self.mtu
    }

    fn send(&mut self, msg: &[u8]) -> Result<(), TransportError> {
        match self.socket.send(msg)? {
            n if n == msg.len() => Ok(()),
            _ => Err(TransportError::ShortWrite),
        }
    }

    /// Waits up to `timeout_ms` (negative: forever) for a datagram. On Unix it waits in poll(2) and reads
    /// without blocking, so a socket the program made non-blocking (PX4 does, through `platform.poll_fd.fd`)
    /// still waits the whole timeout, as eProsima's transport does. An ICMP "port unreachable" from an earlier
    /// datagram (nobody listens yet) is silence: the wait goes on to the end of the timeout.
    #[cfg(unix)]
    fn recv(&mut self, buf: &mut [u8], timeout_ms: i32) -> Result<Option<usize>, TransportError> {
        use nix::poll::{poll, PollFd, PollFlags, PollTimeout};
        use nix::sys::socket::MsgFlags;
        use std::os::fd::{AsFd, AsRawFd};
        // 0: whatever is there now (poll(2) takes 0; the socket option of the other path cannot).
        let now = std::time::Instant::now();
        let deadline = if timeout_ms == 0 { Some(now) } else { timeout(timeout_ms).map(|t| now + t) };
        loop {
            let wait = match deadline {
                None => PollTimeout::NONE,
                Some(d) => {
                    let left = d.saturating_duration_since(std::time::Instant::now());
                    // Rounded up, so a short wait is not a busy loop.
                    let ms = left.as_millis().saturating_add(u128::from(left.subsec_nanos() % 1_000_000 > 0));
                    PollTimeout::try_from(ms).unwrap_or(PollTimeout::MAX)
                }
            };
            let mut fds = [PollFd::new(self.socket.as_fd(), PollFlags::POLLIN)];
            match poll(&mut fds, wait) {
                Ok(0) => return Ok(None),
                Ok(_) | Err(nix::errno::Errno::EINTR) => {}
                Err(e) => return Err(std::io::Error::from(e).into()),
            }
            match nix::sys::socket::recv(self.socket.as_raw_fd(), buf, MsgFlags::MSG_DONTWAIT) {
                Ok(n) => return Ok(Some(n)),
                Err(nix::errno::Errno::EAGAIN | nix::errno::Errno::EINTR | nix::errno::Errno::ECONNREFUSED) => {}
                Err(e) => return Err(std::io::Error::from(e).into()),
            }
            if deadline.is_some_and(|d| std::time::Instant::now() >= d) {
                return Ok(None);
            }
        }
    }

    #[cfg(not(unix))]
    fn recv(&mut self, buf: &mut [u8], timeout_ms: i32) -> Result<Option<usize>, TransportError> {
        self.socket.set_read_timeout(timeout(timeout_ms))?;
        match self.socket.recv(buf) {
            Ok(n) => Ok(Some(n)),
            Err(e) if matches!(e.kind(), std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut) => Ok(None),
            // An ICMP "port unreachable" from a previous datagram: nobody listens yet; treat as silence.
            Err(e) if e.kind() == std::io::ErrorKind::ConnectionRefused => Ok(None),
            Err(e) => Err(e.into()),
        }
    }
}

/// The socket, for programs that poll it (the C library's `platform.poll_fd.fd`).
#[cfg(unix)]
impl std::os::fd::AsRawFd for UdpTransport {
    fn as_raw_fd(&self) -> std::os::fd::RawFd {
        std::os::fd::AsRawFd::as_raw_fd(&self.socket)
    }
}
