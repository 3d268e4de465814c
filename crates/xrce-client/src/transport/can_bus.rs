//! An in-process CAN bus for tests where no `vcan` interface can be created: every frame a node sends
//! reaches every other node, as on a bus where every controller accepts everything (filters are the
//! receivers' business). A node is one end of a Unix `SOCK_SEQPACKET` pair, so it has a real file
//! descriptor an event loop can wait on; the bus holds the other ends. A frame travels as a fixed 69-byte
//! record: `can_id` (4 bytes, little endian), length (1) and the whole 64-byte data field, as `vcan` moves it.
//!
//! The bus can lose frames on purpose ([`MemoryBus::drop_every`]), like a disturbed bus whose frames no node
//! acknowledges. A node whose queue is full loses the frame (an overrun), counted in [`BusStats`].

use std::io;
use std::os::fd::{AsFd, AsRawFd, BorrowedFd, RawFd};
use std::sync::{Arc, Mutex, MutexGuard, PoisonError};
use std::time::Duration;

use socket2::{Domain, Socket, Type};
use xrce_proto::framing::can::{Frame, MAX_FRAME_LEN};

use super::can::CanSocket;

/// Bytes of a frame record: `can_id`, length, data field.
const RECORD: usize = 4 + 1 + MAX_FRAME_LEN;
/// Requested send buffer of the bus side of each node (queued records cost far more than 69 bytes each).
const QUEUE_BYTES: usize = 1 << 20;

/// Counters of a [`MemoryBus`].
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct BusStats {
    /// Frames put on the bus.
    pub frames: u64,
    /// Frames lost on purpose ([`MemoryBus::drop_every`]): no node got them.
    pub lost: u64,
    /// Deliveries dropped because a node's queue was full.
    pub overruns: u64,
}

#[derive(Debug, Default)]
struct BusState {
    /// The bus side of each node's pair, by node index.
    ports: Vec<Socket>,
    drop_every: Option<u64>,
    stats: BusStats,
}

/// A bus joining [`BusNode`]s.
#[derive(Debug, Clone, Default)]
pub struct MemoryBus {
    state: Arc<Mutex<BusState>>,
}

fn lock(state: &Mutex<BusState>) -> MutexGuard<'_, BusState> {
    state.lock().unwrap_or_else(PoisonError::into_inner)
}

impl MemoryBus {
    /// An empty bus.
    pub fn new() -> Self {
        Self::default()
    }

    /// Loses every `n`-th frame put on the bus from now on (`0`: none).
    pub fn drop_every(&self, n: u64) {
        lock(&self.state).drop_every = (n > 0).then_some(n);
    }

    /// The bus's counters.
    pub fn stats(&self) -> BusStats {
        lock(&self.state).stats
    }

    /// Connects a new node.
    pub fn node(&self) -> io::Result<BusNode> {
        let (node, port) = Socket::pair(Domain::UNIX, Type::SEQPACKET, None)?;
        port.set_nonblocking(true)?;
        // A wish: the kernel caps it at `net.core.wmem_max`, and the default still queues hundreds of frames.
        let _ = port.set_send_buffer_size(QUEUE_BYTES);
        let mut state = lock(&self.state);
        let index = state.ports.len();
        state.ports.push(port);
        Ok(BusNode { socket: node, index, bus: self.state.clone(), nonblocking: Mutex::new(false) })
    }
}

/// One node on a [`MemoryBus`].
#[derive(Debug)]
pub struct BusNode {
    socket: Socket,
    index: usize,
    bus: Arc<Mutex<BusState>>,
    /// The socket's mode: waiting receives block with a timeout, [`BusNode::try_recv`] does not block.
    nonblocking: Mutex<bool>,
}

impl BusNode {
    /// Puts `frame` on the bus: every other node gets it, unless the bus loses it.
    pub fn send(&self, frame: &Frame) -> io::Result<()> {
        let mut record = [0u8; RECORD];
        let (head, data) = record.split_at_mut(5);
        let (id, len) = head.split_at_mut(4);
        xrce_proto::bytes::copy(id, &frame.can_id.to_le_bytes());
        len.fill(frame.len);
        xrce_proto::bytes::copy(data, &frame.data);
        let mut guard = lock(&self.bus);
        let state = &mut *guard;
        state.stats.frames += 1;
        if state.drop_every.is_some_and(|n| state.stats.frames.is_multiple_of(n)) {
            state.stats.lost += 1;
            return Ok(());
        }
        for (index, port) in state.ports.iter().enumerate() {
            if index == self.index {
                continue;
            }
            match port.send(&record) {
                Ok(_) => {}
                Err(e) if e.kind() == io::ErrorKind::WouldBlock => state.stats.overruns += 1,
                // A node that is gone (its end closed) receives nothing.
                Err(e) if e.kind() == io::ErrorKind::BrokenPipe => {}
                Err(e) => return Err(e),
            }
        }
        Ok(())
    }

    /// Takes one frame if one is queued, without blocking.
    pub fn try_recv(&self) -> io::Result<Option<Frame>> {
        self.set_mode(true)?;
        self.take()
    }

    /// Waits up to `timeout` (`None`: no limit) for one frame.
    pub fn recv_timeout(&self, timeout: Option<Duration>) -> io::Result<Option<Frame>> {
        match timeout {
            Some(t) if t.is_zero() => self.try_recv(),
            _ => {
                self.set_mode(false)?;
                self.socket.set_read_timeout(timeout)?;
                self.take()
            }
        }
    }

    fn set_mode(&self, nonblocking: bool) -> io::Result<()> {
        let mut mode = self.nonblocking.lock().unwrap_or_else(PoisonError::into_inner);
        if *mode != nonblocking {
            self.socket.set_nonblocking(nonblocking)?;
            *mode = nonblocking;
        }
        Ok(())
    }

    fn take(&self) -> io::Result<Option<Frame>> {
        let mut record = [0u8; RECORD];
        loop {
            match io::Read::read(&mut &self.socket, &mut record) {
                Ok(RECORD) => return Ok(Some(from_record(&record))),
                // The bus is gone.
                Ok(0) => return Ok(None),
                // Not a record of this bus: skipped.
                Ok(_) => {}
                Err(e) if matches!(e.kind(), io::ErrorKind::WouldBlock | io::ErrorKind::TimedOut) => return Ok(None),
                Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
                Err(e) => return Err(e),
            }
        }
    }
}

fn from_record(record: &[u8; RECORD]) -> Frame {
    let (head, data) = record.split_at(5);
    let mut id = [0u8; 4];
    xrce_proto::bytes::copy(&mut id, head.get(..4).unwrap_or(&[0; 4]));
    let mut frame = Frame::from_parts(u32::from_le_bytes(id), data);
    frame.len = head.get(4).copied().unwrap_or(0).min(64);
    frame
}

impl AsRawFd for BusNode {
    fn as_raw_fd(&self) -> RawFd {
        self.socket.as_raw_fd()
    }
}

impl AsFd for BusNode {
    fn as_fd(&self) -> BorrowedFd<'_> {
        self.socket.as_fd()
    }
}

impl CanSocket for BusNode {
    fn send(&mut self, frame: &Frame) -> io::Result<()> {
        BusNode::send(self, frame)
    }

    fn recv(&mut self, timeout: Option<Duration>) -> io::Result<Option<Frame>> {
        self.recv_timeout(timeout)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_other_node_gets_each_frame_whole() {
        let bus = MemoryBus::new();
        let (a, b, c) = (bus.node().unwrap(), bus.node().unwrap(), bus.node().unwrap());
        let mut frame = Frame::with_message(0x42, b"hello").unwrap();
        frame.data[40] = 0x99; // padding travels too, as on vcan
        a.send(&frame).unwrap();
        assert_eq!(b.try_recv().unwrap(), Some(frame));
        assert_eq!(c.recv_timeout(Some(Duration::from_secs(1))).unwrap(), Some(frame));
        assert_eq!(a.try_recv().unwrap(), None, "a node does not hear itself");
        assert_eq!(b.try_recv().unwrap(), None);
        assert_eq!(c.recv_timeout(Some(Duration::from_millis(10))).unwrap(), None);
        assert_eq!(bus.stats(), BusStats { frames: 1, lost: 0, overruns: 0 });
    }

    #[test]
    fn the_bus_loses_every_nth_frame() {
        let bus = MemoryBus::new();
        let (a, b) = (bus.node().unwrap(), bus.node().unwrap());
        bus.drop_every(3);
        for i in 1..=9u8 {
            a.send(&Frame::with_message(1, &[i]).unwrap()).unwrap();
        }
        let mut got = Vec::new();
        while let Some(f) = b.try_recv().unwrap() {
            got.push(f.message().unwrap()[0]);
        }
        assert_eq!(got, [1, 2, 4, 5, 7, 8]);
        assert_eq!(bus.stats(), BusStats { frames: 9, lost: 3, overruns: 0 });
    }

    #[test]
    fn a_full_node_overruns_instead_of_blocking_the_sender() {
        let bus = MemoryBus::new();
        let (a, _deaf) = (bus.node().unwrap(), bus.node().unwrap());
        for _ in 0..100_000 {
            a.send(&Frame::with_message(1, &[0; 63]).unwrap()).unwrap();
            if bus.stats().overruns > 0 {
                break;
            }
        }
        assert!(bus.stats().overruns > 0, "a node nobody reads fills up");
    }
}
