//! Batched UDP I/O for the UDP shell: on Linux one `recvmmsg` takes up to [`BATCH`] queued datagrams and one
//! `sendmmsg` sends up to [`BATCH`] messages (through `nix`'s safe wrappers); elsewhere one datagram per
//! system call. Buffers are allocated once.

use std::io;
use std::net::{SocketAddr, UdpSocket};

use crate::core::Transmit;

/// Datagrams per system call.
pub const BATCH: usize = 32;

/// Receive buffers for one batch.
pub struct RecvBatch {
    bufs: Vec<u8>,
    slot: usize,
    lens: [usize; BATCH],
    addrs: [Option<SocketAddr>; BATCH],
    count: usize,
    #[cfg(target_os = "linux")]
    headers: nix::sys::socket::MultiHeaders<nix::sys::socket::SockaddrStorage>,
}

impl std::fmt::Debug for RecvBatch {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("RecvBatch").field("slot", &self.slot).field("count", &self.count).finish()
    }
}

/// Whether an I/O error only means "nothing this time" (timeout, signal, ICMP error of an earlier send).
fn is_transient(e: &io::Error) -> bool {
    matches!(
        e.kind(),
        io::ErrorKind::WouldBlock
            | io::ErrorKind::TimedOut
            | io::ErrorKind::Interrupted
            | io::ErrorKind::ConnectionReset
            | io::ErrorKind::ConnectionRefused
    )
}

impl RecvBatch {
    /// Buffers for [`BATCH`] datagrams of up to `slot` bytes.
    pub fn new(slot: usize) -> Self {
        Self {
            bufs: vec![0u8; slot * BATCH],
            slot,
            lens: [0; BATCH],
            addrs: [None; BATCH],
            count: 0,
            #[cfg(target_os = "linux")]
            headers: nix::sys::socket::MultiHeaders::preallocate(BATCH, None),
        }
    }

    /// Waits (up to the socket's read timeout) for one datagram, then takes every queued one up to
    /// [`BATCH`]. Returns how many were received (0 on timeout).
    pub fn recv(&mut self, socket: &UdpSocket) -> io::Result<usize> {
        self.count = 0;
        match self.recv_inner(socket) {
            Ok(n) => {
                self.count = n;
                Ok(n)
            }
            Err(e) if is_transient(&e) => Ok(0),
            Err(e) => Err(e),
        }
    }

    #[cfg(target_os = "linux")]
    fn recv_inner(&mut self, socket: &UdpSocket) -> io::Result<usize> {
        use nix::sys::socket::{recvmmsg, MsgFlags, SockaddrStorage};
        use std::io::IoSliceMut;
        use std::os::fd::AsRawFd;

        let Self { bufs, slot, lens, addrs, headers, .. } = self;
        let mut chunks = bufs.chunks_mut(*slot);
        let mut iovs: [[IoSliceMut<'_>; 1]; BATCH] =
            std::array::from_fn(|_| [IoSliceMut::new(chunks.next().unwrap_or(&mut []))]);
        let results = recvmmsg(socket.as_raw_fd(), headers, iovs.iter_mut(), MsgFlags::MSG_WAITFORONE, None)
            .map_err(io::Error::from)?;
        let mut n = 0;
        for (r, (len, addr)) in results.zip(lens.iter_mut().zip(addrs.iter_mut())) {
            *len = r.bytes;
            *addr = r.address.and_then(|a: SockaddrStorage| {
                if let Some(v4) = a.as_sockaddr_in() {
                    Some(SocketAddr::from(*v4))
                } else {
                    a.as_sockaddr_in6().map(|v6| SocketAddr::from(*v6))
                }
            });
            n += 1;
        }
        Ok(n)
    }

    #[cfg(not(target_os = "linux"))]
    fn recv_inner(&mut self, socket: &UdpSocket) -> io::Result<usize> {
        let buf = self.bufs.get_mut(..self.slot).unwrap_or(&mut []);
        let (n, from) = socket.recv_from(buf)?;
        self.lens[0] = n;
        self.addrs[0] = Some(from);
        Ok(1)
    }

    /// Datagram `i` of the last batch: its source and bytes.
    pub fn get(&self, i: usize) -> Option<(SocketAddr, &[u8])> {
        if i >= self.count {
            return None;
        }
        let from = (*self.addrs.get(i)?)?;
        let len = (*self.lens.get(i)?).min(self.slot);
        let start = i * self.slot;
        Some((from, self.bufs.get(start..start + len)?))
    }
}

/// Send state reused between batches.
pub struct SendBatch {
    #[cfg(target_os = "linux")]
    headers: nix::sys::socket::MultiHeaders<nix::sys::socket::SockaddrStorage>,
    #[cfg(target_os = "linux")]
    addrs: Vec<Option<nix::sys::socket::SockaddrStorage>>,
}

impl std::fmt::Debug for SendBatch {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SendBatch").finish_non_exhaustive()
    }
}

impl Default for SendBatch {
    fn default() -> Self {
        Self::new()
    }
}

impl SendBatch {
    /// Empty state.
    pub fn new() -> Self {
        Self {
            #[cfg(target_os = "linux")]
            headers: nix::sys::socket::MultiHeaders::preallocate(BATCH, None),
            #[cfg(target_os = "linux")]
            addrs: Vec::with_capacity(BATCH),
        }
    }

    /// Sends every message; a message the kernel refuses is logged and skipped.
    pub fn send(&mut self, socket: &UdpSocket, msgs: &[Transmit<SocketAddr>]) {
        let mut rest = msgs;
        while !rest.is_empty() {
            match self.send_some(socket, rest) {
                Ok(0) => break,
                Ok(n) => rest = rest.get(n..).unwrap_or(&[]),
                Err(e) => {
                    if let Some(t) = rest.first() {
                        if e.kind() != io::ErrorKind::Interrupted {
                            tracing::warn!(peer = %t.to, "UDP send failed: {e}");
                            rest = rest.get(1..).unwrap_or(&[]);
                        }
                    }
                }
            }
        }
    }

    #[cfg(target_os = "linux")]
    fn send_some(&mut self, socket: &UdpSocket, msgs: &[Transmit<SocketAddr>]) -> io::Result<usize> {
        use nix::sys::socket::{sendmmsg, ControlMessage, MsgFlags, SockaddrStorage};
        use std::io::IoSlice;
        use std::os::fd::AsRawFd;

        let batch = msgs.get(..msgs.len().min(BATCH)).unwrap_or(&[]);
        self.addrs.clear();
        self.addrs.extend(batch.iter().map(|t| Some(SockaddrStorage::from(t.to))));
        let mut it = batch.iter();
        let iovs: [[IoSlice<'_>; 1]; BATCH] =
            std::array::from_fn(|_| [IoSlice::new(it.next().map_or(&[][..], |t| t.data.as_slice()))]);
        let cmsgs: [ControlMessage<'_>; 0] = [];
        let sent = sendmmsg(
            socket.as_raw_fd(),
            &mut self.headers,
            iovs.iter().take(batch.len()),
            &self.addrs,
            cmsgs,
            MsgFlags::empty(),
        )
        .map_err(io::Error::from)?;
        Ok(sent.count())
    }

    #[cfg(not(target_os = "linux"))]
    fn send_some(&mut self, socket: &UdpSocket, msgs: &[Transmit<SocketAddr>]) -> io::Result<usize> {
        match msgs.first() {
            Some(t) => socket.send_to(&t.data, t.to).map(|_| 1),
            None => Ok(0),
        }
    }
}
