//! Batched UDP I/O for the UDP shell: on Linux one `recvmmsg` takes up to [`BATCH`] queued datagrams and one
//! `sendmmsg` sends up to [`BATCH`] messages (through `nix`'s safe wrappers); elsewhere one datagram per
//! system call. Buffers are allocated once.
//!
//! A *train* (consecutive messages to one peer, all of one size but the last, which may be shorter: the
//! fragments of a large sample, or equal-size samples to a subscriber that does not take packed messages)
//! goes out as one UDP GSO send (`UDP_SEGMENT`): the kernel walks its stack once and cuts the datagrams at
//! the end, so the peer receives exactly the datagrams it would otherwise. A kernel or device without GSO
//! refuses the first train; the socket then falls back to plain sends for good. A segment larger than the
//! path's MTU is refused too (`EMSGSIZE`, `EINVAL` before Linux 6, e.g. 4 KiB datagrams over Ethernet, which plain sends fragment at
//! the IP layer): trains are then kept to segments below that size.

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

    /// Takes every queued datagram up to [`BATCH`] without waiting (the shell waits for readiness on its
    /// event loop). Returns how many were received: 0 only when none is queued. A pending socket error (the
    /// ICMP error of an earlier send to a closed port, a signal) is passed over, since datagrams may wait
    /// behind it and an edge-triggered loop would hear of them only at the next arrival.
    pub fn recv(&mut self, socket: &UdpSocket) -> io::Result<usize> {
        self.count = 0;
        loop {
            match self.recv_inner(socket) {
                Ok(n) => {
                    self.count = n;
                    return Ok(n);
                }
                Err(e) if matches!(e.kind(), io::ErrorKind::WouldBlock | io::ErrorKind::TimedOut) => return Ok(0),
                // Reading reports and clears one error each time: this ends.
                Err(e) if is_transient(&e) => {}
                Err(e) => return Err(e),
            }
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
        let results = recvmmsg(
            socket.as_raw_fd(),
            headers,
            iovs.iter_mut(),
            MsgFlags::MSG_WAITFORONE | MsgFlags::MSG_DONTWAIT,
            None,
        )
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

/// Fewest messages worth a GSO send.
pub const MIN_TRAIN: usize = 2;
/// Most datagrams the kernel cuts from one GSO send (`UDP_MAX_SEGMENTS`).
pub const MAX_TRAIN: usize = 64;
/// Most bytes in one GSO send (an IP datagram's payload, less the UDP header).
pub const MAX_TRAIN_BYTES: usize = 65_507;

/// How many messages from the start of `msgs` form a train: same destination, every one `len` bytes
/// long but the last, which may be shorter; at most [`MAX_TRAIN`] messages and [`MAX_TRAIN_BYTES`], and
/// segments of at most `max_segment` bytes.
pub fn train_len<E: PartialEq>(msgs: &[Transmit<E>], max_segment: usize) -> usize {
    let Some(first) = msgs.first() else { return 0 };
    let segment = first.data.len();
    if segment == 0 || segment > max_segment {
        return 1;
    }
    let mut total = 0usize;
    let mut n = 0;
    for t in msgs.iter().take(MAX_TRAIN) {
        let len = t.data.len();
        if t.to != first.to || len > segment || len == 0 || total + len > MAX_TRAIN_BYTES {
            break;
        }
        total += len;
        n += 1;
        if len < segment {
            break;
        }
    }
    n
}

/// Send state reused between batches.
pub struct SendBatch {
    /// Whether trains go out as GSO sends (cleared when the kernel cannot segment).
    gso: bool,
    /// Largest segment tried in a train (lowered when a path's MTU refuses one).
    max_segment: usize,
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
            gso: cfg!(target_os = "linux"),
            max_segment: MAX_TRAIN_BYTES,
            #[cfg(target_os = "linux")]
            headers: nix::sys::socket::MultiHeaders::preallocate(BATCH, None),
            #[cfg(target_os = "linux")]
            addrs: Vec::with_capacity(BATCH),
        }
    }

    /// Without GSO: every message is sent as its own datagram.
    pub fn without_gso() -> Self {
        Self { gso: false, ..Self::new() }
    }

    /// Whether trains go out as GSO sends.
    pub fn uses_gso(&self) -> bool {
        self.gso
    }

    /// Sends every message, in order, trains as GSO sends; a message the kernel refuses is logged and
    /// skipped.
    pub fn send(&mut self, socket: &UdpSocket, msgs: &[Transmit<SocketAddr>]) {
        let mut plain_from = 0;
        let mut i = 0;
        while let Some(rest) = msgs.get(i..).filter(|r| !r.is_empty()) {
            let n = if self.gso { train_len(rest, self.max_segment) } else { 1 };
            if n < MIN_TRAIN {
                i += 1;
                continue;
            }
            self.send_plain(socket, msgs.get(plain_from..i).unwrap_or(&[]));
            let train = rest.get(..n).unwrap_or(&[]);
            if !self.send_train(socket, train) {
                self.send_plain(socket, train);
            }
            i += n;
            plain_from = i;
        }
        self.send_plain(socket, msgs.get(plain_from..).unwrap_or(&[]));
    }

    /// Sends a train as one GSO send; false if it was not sent (GSO is then off for good when the kernel
    /// does not support it).
    #[cfg(target_os = "linux")]
    fn send_train(&mut self, socket: &UdpSocket, train: &[Transmit<SocketAddr>]) -> bool {
        use nix::errno::Errno;
        use nix::sys::socket::{sendmsg, ControlMessage, MsgFlags, SockaddrStorage};
        use std::io::IoSlice;
        use std::os::fd::AsRawFd;

        let Some(first) = train.first() else { return false };
        let Ok(segment) = u16::try_from(first.data.len()) else { return false };
        let mut it = train.iter();
        let iovs: [IoSlice<'_>; MAX_TRAIN] =
            std::array::from_fn(|_| IoSlice::new(it.next().map_or(&[][..], |t| t.data.as_slice())));
        let iovs = iovs.get(..train.len()).unwrap_or(&[]);
        let to = SockaddrStorage::from(first.to);
        let cmsgs = [ControlMessage::UdpGsoSegments(&segment)];
        match sendmsg(socket.as_raw_fd(), iovs, &cmsgs, MsgFlags::empty(), Some(&to)) {
            Ok(_) => true,
            // Linux 6.x says EMSGSIZE, older kernels EINVAL.
            Err(Errno::EMSGSIZE | Errno::EINVAL) => {
                tracing::debug!(peer = %first.to, segment, "GSO segment refused: trains kept below that size");
                self.max_segment = usize::from(segment).saturating_sub(1);
                false
            }
            Err(e @ (Errno::EIO | Errno::ENOPROTOOPT | Errno::EOPNOTSUPP)) => {
                tracing::info!("UDP segmentation offload refused ({e}): sending one datagram per system call");
                self.gso = false;
                false
            }
            Err(_) => false,
        }
    }

    #[cfg(not(target_os = "linux"))]
    fn send_train(&mut self, _socket: &UdpSocket, _train: &[Transmit<SocketAddr>]) -> bool {
        false
    }

    /// Sends every message as its own datagram; a message the kernel refuses is logged and skipped.
    fn send_plain(&mut self, socket: &UdpSocket, msgs: &[Transmit<SocketAddr>]) {
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

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Duration;

    fn msg(to: u8, len: usize, fill: u8) -> Transmit<u8> {
        Transmit { to, data: vec![fill; len] }
    }

    #[test]
    fn a_train_is_equal_sizes_to_one_peer_ending_with_a_shorter_one() {
        let msgs = [msg(1, 512, 0), msg(1, 512, 1), msg(1, 100, 2), msg(1, 512, 3)];
        assert_eq!(train_len(&msgs, MAX_TRAIN_BYTES), 3, "the shorter message ends the train");
        assert_eq!(train_len(&msgs, 511), 1, "segments above the known path limit");
        let msgs = [msg(1, 512, 0), msg(2, 512, 1)];
        assert_eq!(train_len(&msgs, MAX_TRAIN_BYTES), 1, "another peer");
        let msgs = [msg(1, 100, 0), msg(1, 512, 1)];
        assert_eq!(train_len(&msgs, MAX_TRAIN_BYTES), 1, "a longer message is not a segment");
        let many: Vec<_> = (0..100).map(|i| msg(1, 16, i)).collect();
        assert_eq!(train_len(&many, MAX_TRAIN_BYTES), MAX_TRAIN);
        let big: Vec<_> = (0..10).map(|i| msg(1, 30_000, i)).collect();
        assert_eq!(train_len(&big, MAX_TRAIN_BYTES), 2, "at most one IP datagram of bytes");
        assert_eq!(train_len::<u8>(&[], MAX_TRAIN_BYTES), 0);
        assert_eq!(train_len(&[msg(1, 0, 0), msg(1, 0, 0)], MAX_TRAIN_BYTES), 1);
    }

    /// A sender, a receiver (2 s read timeout) and the receiver's address.
    fn loopback_pair() -> (UdpSocket, UdpSocket, std::net::SocketAddr) {
        let receiver = UdpSocket::bind("127.0.0.1:0").unwrap();
        receiver.set_read_timeout(Some(Duration::from_secs(2))).unwrap();
        let to = receiver.local_addr().unwrap();
        (UdpSocket::bind("127.0.0.1:0").unwrap(), receiver, to)
    }

    /// Whatever goes out as trains, the peer receives exactly the datagrams, in order.
    #[test]
    fn trains_arrive_as_the_same_datagrams_in_order() {
        let (sender, receiver, to) = loopback_pair();
        let elsewhere = UdpSocket::bind("127.0.0.1:0").unwrap().local_addr().unwrap();
        let mut sizes = vec![512, 512, 512, 77, 512, 30, 30, 30, 30, 1200, 1200, 1200];
        sizes.extend(std::iter::repeat_n(16, 70));
        let mut msgs = Vec::new();
        for (i, len) in sizes.iter().enumerate() {
            let tag = u8::try_from(i).unwrap();
            msgs.push(Transmit { to, data: vec![tag; *len] });
            if i == 5 {
                msgs.push(Transmit { to: elsewhere, data: vec![0xEE; 30] });
            }
        }
        let mut gso_used = false;
        for mut batch in [SendBatch::new(), SendBatch::without_gso()] {
            batch.send(&sender, &msgs);
            let mut buf = [0u8; 2048];
            for (i, len) in sizes.iter().enumerate() {
                let (n, _) = receiver.recv_from(&mut buf).unwrap();
                assert_eq!(n, *len, "datagram {i}");
                assert!(buf[..n].iter().all(|b| usize::from(*b) == i), "datagram {i} bytes");
            }
            if cfg!(target_os = "linux") && batch.uses_gso() {
                gso_used = true;
            }
        }
        // Loopback supports UDP segmentation offload on every Linux since 4.18.
        assert_eq!(gso_used, cfg!(target_os = "linux"), "the trains went out as GSO sends");
    }

    /// Segments larger than the path MTU (run it in a namespace whose loopback has `mtu 1500` to see the
    /// refusal): the train still arrives, as plain datagrams the IP layer fragments.
    #[test]
    fn a_train_of_segments_above_the_path_mtu_still_arrives() {
        let (sender, receiver, to) = loopback_pair();
        let msgs: Vec<_> = (0..3u8).map(|i| Transmit { to, data: vec![i; 4000] }).collect();
        let mut batch = SendBatch::new();
        for _ in 0..2 {
            batch.send(&sender, &msgs);
            let mut buf = [0u8; 8192];
            for i in 0..3u8 {
                let (n, _) = receiver.recv_from(&mut buf).unwrap();
                assert_eq!(n, 4000);
                assert!(buf[..n].iter().all(|b| *b == i));
            }
        }
        assert_eq!(batch.uses_gso(), cfg!(target_os = "linux"), "a too large segment does not turn GSO off");
    }
    /// What the UDP shell relies on to skip the read that would find its queue empty: on the agent's
    /// unconnected socket, the ICMP "port unreachable" its sends to a closed peer earn set no pending error,
    /// so a batch comes back partial only when the queue is empty, never cut short with datagrams behind.
    #[test]
    fn a_closed_peer_does_not_cut_a_batch_short() {
        let (sender, agent, agent_addr) = loopback_pair();
        let gone = UdpSocket::bind("127.0.0.1:0").unwrap();
        let gone_addr = gone.local_addr().unwrap();
        drop(gone);
        let mut tx = SendBatch::new();
        let mut rx = RecvBatch::new(64);
        for round in 0..3u8 {
            tx.send(&agent, &[Transmit { to: gone_addr, data: vec![round; 8] }]);
            std::thread::sleep(Duration::from_millis(20));
            for i in 0..5u8 {
                sender.send_to(&[round, i], agent_addr).unwrap();
            }
            std::thread::sleep(Duration::from_millis(20));
            let n = rx.recv(&agent).unwrap();
            assert_eq!(n, if cfg!(target_os = "linux") { 5 } else { 1 }, "round {round}: the whole queue at once");
            assert_eq!(rx.get(0).map(|(_, b)| b.to_vec()), Some(vec![round, 0]));
            let rest = if cfg!(target_os = "linux") { 0 } else { 4 };
            for _ in 0..rest {
                rx.recv(&agent).unwrap();
            }
        }
    }
}
