//! UDP shell (IPv4 and IPv6): one XRCE message per datagram, replies to the datagram's source (spec §12.1).

use std::io;
use std::net::{SocketAddr, UdpSocket};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

use super::{anchor_wall_clock, block_for, hexdump, lock, SharedCore};

/// Largest datagram received (eProsima's agent buffer).
pub const MAX_DATAGRAM: usize = 65_535;

/// A UDP server around a shared core.
#[derive(Debug)]
pub struct UdpServer {
    socket: UdpSocket,
    core: SharedCore<SocketAddr>,
}

impl UdpServer {
    /// Binds `addr` (port 0: an ephemeral port).
    pub fn bind(addr: SocketAddr, core: SharedCore<SocketAddr>) -> io::Result<Self> {
        let socket = UdpSocket::bind(addr)?;
        anchor_wall_clock(&mut lock(&core));
        Ok(Self { socket, core })
    }

    /// The bound address.
    pub fn local_addr(&self) -> io::Result<SocketAddr> {
        self.socket.local_addr()
    }

    /// Serves until `stop` is set. Blocks on the socket until data or the core's next timer.
    pub fn run(&self, stop: &AtomicBool) -> io::Result<()> {
        let mut buf = vec![0u8; MAX_DATAGRAM];
        let mut out = Vec::new();
        while !stop.load(Ordering::Relaxed) {
            let next = lock(&self.core).poll_timeout();
            self.socket.set_read_timeout(Some(block_for(next, Instant::now())))?;
            let received = match self.socket.recv_from(&mut buf) {
                Ok((n, from)) => Some((n, from)),
                Err(e) if matches!(e.kind(), io::ErrorKind::WouldBlock | io::ErrorKind::TimedOut) => None,
                // ICMP port unreachable from an earlier send, interrupted calls: not fatal.
                Err(e) if matches!(e.kind(), io::ErrorKind::ConnectionReset | io::ErrorKind::Interrupted) => None,
                Err(e) => return Err(e),
            };
            {
                let mut core = lock(&self.core);
                let now = Instant::now();
                if let Some((n, from)) = received {
                    let bytes = buf.get(..n).unwrap_or(&[]);
                    hexdump("recv", &from, bytes);
                    core.handle_datagram(from, bytes, now);
                }
                if core.poll_timeout().is_some_and(|t| t <= now) {
                    core.handle_timeout(now);
                }
                while let Some(t) = core.poll_transmit() {
                    out.push(t);
                }
            }
            for t in out.drain(..) {
                hexdump("send", &t.to, &t.data);
                if let Err(e) = self.socket.send_to(&t.data, t.to) {
                    tracing::warn!(peer = %t.to, "UDP send failed: {e}");
                }
            }
        }
        Ok(())
    }
}
