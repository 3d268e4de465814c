//! A small driver of the sans-IO [`SessionCore`] over one UDP socket, tuned for benchmarks: non-blocking
//! drains, waits bounded by the core's timers, entity creation with the binary representation.

use std::io;
use std::net::{SocketAddr, UdpSocket};
use std::time::{Duration, Instant};

use xrce_client::session::SessionState;
use xrce_client::{
    object_id, Callbacks, Clock, DeliveryControl, Durability, History, ObjectId, ObjectKind, Outputs, QoS, Reliability,
    SessionCore, StdClock, StreamId, WriteAccessExt, REPLACE, STATUS_OK, STATUS_OK_MATCHED,
};

use crate::BenchError;

/// Largest datagram the driver accepts.
pub const RX_SIZE: usize = 65_536;

/// A UDP socket connected to the agent. It stays in blocking mode with a receive timeout (re-armed only when
/// the wait changes); a read that must not wait uses `MSG_DONTWAIT` on Linux, so polling costs one system call
/// (elsewhere the socket switches between non-blocking and timed reads only when needed).
#[derive(Debug)]
pub struct Sock {
    socket: UdpSocket,
    nonblocking: bool,
    timeout: Option<Duration>,
}

impl Sock {
    /// A socket bound to an ephemeral port on the address family of `agent`, connected to it.
    pub fn connect(agent: SocketAddr) -> io::Result<Self> {
        let socket = bind_for(agent)?;
        socket.connect(agent)?;
        Ok(Self { socket, nonblocking: false, timeout: None })
    }

    /// Asks for a receive buffer of `bytes` (the kernel caps it at `net.core.rmem_max`).
    pub fn set_recv_buffer(&self, bytes: usize) -> io::Result<()> {
        socket2::SockRef::from(&self.socket).set_recv_buffer_size(bytes)
    }

    /// The local address.
    pub fn local_addr(&self) -> io::Result<SocketAddr> {
        self.socket.local_addr()
    }

    /// Sends one datagram. A refused send (nobody listening yet) counts as sent: UDP may lose it anyway.
    pub fn send(&self, msg: &[u8]) -> io::Result<()> {
        match self.socket.send(msg) {
            Ok(_) => Ok(()),
            Err(e) if e.kind() == io::ErrorKind::ConnectionRefused => Ok(()),
            Err(e) => Err(e),
        }
    }

    fn set_nonblocking(&mut self, nb: bool) -> io::Result<()> {
        if self.nonblocking != nb {
            self.socket.set_nonblocking(nb)?;
            self.nonblocking = nb;
        }
        Ok(())
    }

    /// A datagram if one is queued, without waiting.
    #[cfg(target_os = "linux")]
    pub fn try_recv(&mut self, buf: &mut [u8]) -> io::Result<Option<usize>> {
        use nix::sys::socket::{recv, MsgFlags};
        use std::os::fd::AsRawFd;
        loop {
            match recv(self.socket.as_raw_fd(), buf, MsgFlags::MSG_DONTWAIT) {
                Ok(n) => return Ok(Some(n)),
                Err(nix::errno::Errno::EINTR) => {}
                Err(e) => return recv_result(Err(io::Error::from(e))),
            }
        }
    }

    /// A datagram if one is queued, without waiting.
    #[cfg(not(target_os = "linux"))]
    pub fn try_recv(&mut self, buf: &mut [u8]) -> io::Result<Option<usize>> {
        self.set_nonblocking(true)?;
        recv_result(self.socket.recv(buf))
    }

    /// A datagram, waiting up to `wait` (at least 1 µs).
    pub fn recv_timeout(&mut self, buf: &mut [u8], wait: Duration) -> io::Result<Option<usize>> {
        self.set_nonblocking(false)?;
        let wait = wait.max(Duration::from_micros(1));
        if self.timeout != Some(wait) {
            self.socket.set_read_timeout(Some(wait))?;
            self.timeout = Some(wait);
        }
        recv_result(self.socket.recv(buf))
    }
}

/// A socket bound to an ephemeral port of the family of `peer` (loopback when the peer is loopback).
pub fn bind_for(peer: SocketAddr) -> io::Result<UdpSocket> {
    let local: SocketAddr = match peer {
        SocketAddr::V4(a) if a.ip().is_loopback() => ([127, 0, 0, 1], 0).into(),
        SocketAddr::V4(_) => ([0, 0, 0, 0], 0).into(),
        SocketAddr::V6(a) if a.ip().is_loopback() => (std::net::Ipv6Addr::LOCALHOST, 0).into(),
        SocketAddr::V6(_) => (std::net::Ipv6Addr::UNSPECIFIED, 0).into(),
    };
    UdpSocket::bind(local)
}

/// `Ok(None)` for "nothing now" (would block, timed out, ICMP refused), the length otherwise.
pub fn recv_result(r: io::Result<usize>) -> io::Result<Option<usize>> {
    match r {
        Ok(n) => Ok(Some(n)),
        Err(e)
            if matches!(
                e.kind(),
                io::ErrorKind::WouldBlock
                    | io::ErrorKind::TimedOut
                    | io::ErrorKind::ConnectionRefused
                    | io::ErrorKind::Interrupted
            ) =>
        {
            Ok(None)
        }
        Err(e) => Err(e),
    }
}

/// What to do with each sample a session receives.
pub trait OnData {
    /// A sample for `reader`; `out` lets the handler answer (an echo writes into it).
    fn on_data(&mut self, out: &mut Outputs<'_, '_>, reader: ObjectId, data: &[u8]);
}

impl OnData for () {
    fn on_data(&mut self, _: &mut Outputs<'_, '_>, _: ObjectId, _: &[u8]) {}
}

/// Statuses of requests as they come (`on_status`), and samples handed to an [`OnData`].
#[derive(Debug, Default)]
pub struct Handler<D> {
    /// `(request id, status)` pairs received, oldest first (capped to the last 256).
    pub statuses: Vec<(u16, u8)>,
    /// What handles the samples.
    pub data: D,
}

impl<D> Handler<D> {
    /// A handler giving samples to `data`.
    pub const fn new(data: D) -> Self {
        Self { statuses: Vec::new(), data }
    }

    /// The status received for `request`, if any.
    pub fn status_of(&self, request: u16) -> Option<u8> {
        self.statuses.iter().rev().find(|(r, _)| *r == request).map(|&(_, s)| s)
    }
}

/// A handler that only records statuses.
pub const fn status_only() -> Handler<()> {
    Handler::new(())
}

impl<D: OnData> Callbacks for Handler<D> {
    fn on_status(&mut self, _: &mut Outputs<'_, '_>, _: ObjectId, request_id: u16, status: u8) {
        if self.statuses.len() >= 256 {
            self.statuses.remove(0);
        }
        self.statuses.push((request_id, status));
    }

    fn on_topic(&mut self, out: &mut Outputs<'_, '_>, object_id: ObjectId, _: u16, _: StreamId, data: &[u8]) {
        self.data.on_data(out, object_id, data);
    }
}

/// Whether a status means success.
pub const fn status_ok(status: u8) -> bool {
    status == STATUS_OK || status == STATUS_OK_MATCHED
}

/// A session over its own UDP socket.
#[derive(Debug)]
pub struct Client<'a> {
    /// The sans-IO core.
    pub core: SessionCore<'a>,
    sock: Sock,
    clock: StdClock,
    tx: Vec<u8>,
    rx: Vec<u8>,
    /// Datagrams sent.
    pub datagrams_sent: u64,
    /// Datagrams received.
    pub datagrams_received: u64,
}

impl<'a> Client<'a> {
    /// A client `key` (session 0x81, no key in the headers) for the agent at `agent`, building messages of
    /// at most `mtu` bytes.
    pub fn new(agent: SocketAddr, key: u32, mtu: usize) -> Result<Self, BenchError> {
        let sock = Sock::connect(agent)?;
        Ok(Self {
            core: SessionCore::new(xrce_client::session::DEFAULT_SESSION_ID, key, mtu),
            sock,
            clock: StdClock::default(),
            tx: vec![0; mtu.max(64)],
            rx: vec![0; RX_SIZE],
            datagrams_sent: 0,
            datagrams_received: 0,
        })
    }

    /// The socket.
    pub fn sock(&mut self) -> &mut Sock {
        &mut self.sock
    }

    /// Now, in the core's clock (ns since the epoch, monotonic).
    pub fn now(&mut self) -> i64 {
        self.clock.now_nanos()
    }

    /// Sends everything the core has to send now; how many datagrams.
    pub fn transmit(&mut self) -> Result<usize, BenchError> {
        let now = self.clock.now_nanos();
        let mut n = 0;
        while let Some(len) = self.core.poll_transmit(now, &mut self.tx) {
            self.sock.send(self.tx.get(..len).unwrap_or(&[]))?;
            n += 1;
        }
        self.datagrams_sent += n as u64;
        Ok(n)
    }

    /// Flushes the output streams and sends.
    pub fn flush(&mut self) -> Result<usize, BenchError> {
        self.core.flash_output_streams();
        self.transmit()
    }

    /// Receives what is queued (after waiting up to `wait` for the first datagram, capped by the core's next
    /// timer), handles it with `cb`, then flushes and sends what became due. How many datagrams were handled.
    pub fn poll<C: Callbacks>(&mut self, cb: &mut C, wait: Option<Duration>) -> Result<usize, BenchError> {
        let mut handled = 0;
        let first = match wait {
            Some(w) => {
                let now = self.clock.now_nanos();
                let timer = self.core.poll_timeout().map(|t| Duration::from_nanos(u64::try_from(t - now).unwrap_or(0)));
                let w = timer.map_or(w, |t| t.min(w));
                if w.is_zero() {
                    self.sock.try_recv(&mut self.rx)?
                } else {
                    self.sock.recv_timeout(&mut self.rx, w)?
                }
            }
            None => self.sock.try_recv(&mut self.rx)?,
        };
        let mut next = first;
        // Bounded: at most 1024 datagrams per call, so a flood cannot starve the caller.
        while let Some(n) = next {
            let now = self.clock.now_nanos();
            self.core.handle_input(self.rx.get(..n).unwrap_or(&[]), now, cb);
            handled += 1;
            if handled >= 1024 {
                break;
            }
            next = self.sock.try_recv(&mut self.rx)?;
        }
        self.datagrams_received += handled as u64;
        self.flush()?;
        Ok(handled)
    }

    /// `uxr_create_session` with `attempts` CREATE_CLIENT one second apart.
    pub fn create_session(&mut self, attempts: usize) -> Result<(), BenchError> {
        let now = self.now();
        self.core.create_session_retries(attempts, now);
        let mut cb = status_only();
        // Bounded by the retries: each attempt waits one second at most.
        let deadline = Instant::now() + Duration::from_secs(attempts as u64 + 1);
        while self.core.state() == SessionState::Creating && Instant::now() < deadline {
            self.transmit()?;
            self.poll(&mut cb, Some(Duration::from_millis(50)))?;
        }
        match self.core.state() {
            SessionState::Established => Ok(()),
            SessionState::Refused(s) => Err(BenchError::Refused { what: "session", status: s }),
            _ => Err(BenchError::Timeout("no STATUS_AGENT for CREATE_CLIENT")),
        }
    }

    /// Sends DELETE for the session, waiting up to `timeout` for the confirmation; whether it came.
    pub fn delete_session(&mut self, timeout: Duration) -> Result<bool, BenchError> {
        let now = self.now();
        self.core.delete_session_retries(3, now);
        let deadline = Instant::now() + timeout;
        let mut cb = status_only();
        while self.core.state() == SessionState::Deleting && Instant::now() < deadline {
            self.transmit()?;
            self.poll(&mut cb, Some(Duration::from_millis(20)))?;
        }
        Ok(self.core.state() == SessionState::Deleted)
    }

    /// Runs the session with `cb` until `done(cb)` or `timeout`; whether `done` became true.
    pub fn run_until<C: Callbacks>(
        &mut self,
        cb: &mut C,
        timeout: Duration,
        mut done: impl FnMut(&C) -> bool,
    ) -> Result<bool, BenchError> {
        let deadline = Instant::now() + timeout;
        self.flush()?;
        loop {
            if done(cb) {
                return Ok(true);
            }
            let now = Instant::now();
            if now >= deadline {
                return Ok(false);
            }
            self.poll(cb, Some((deadline - now).min(Duration::from_millis(20))))?;
        }
    }

    /// Flushes and waits until every request of `requests` has a successful status; an error naming the first
    /// failure otherwise.
    pub fn wait_statuses<D: OnData>(
        &mut self,
        cb: &mut Handler<D>,
        requests: &[(&'static str, u16)],
        timeout: Duration,
    ) -> Result<(), BenchError> {
        let all = |h: &Handler<D>| requests.iter().all(|(_, r)| h.status_of(*r).is_some());
        self.run_until(cb, timeout, all)?;
        for &(what, r) in requests {
            match cb.status_of(r) {
                Some(s) if status_ok(s) => {}
                Some(status) => return Err(BenchError::Refused { what, status }),
                None => return Err(BenchError::Timeout(what)),
            }
        }
        Ok(())
    }
}

/// The QoS of a benchmark endpoint.
pub const fn qos(reliable: bool, depth: u16) -> QoS {
    QoS {
        durability: Durability::Volatile,
        reliability: if reliable { Reliability::Reliable } else { Reliability::BestEffort },
        history: History::KeepLast,
        depth,
    }
}

/// Object ids of the endpoints [`buffer_endpoints`] creates: participant, topics, publisher, subscriber,
/// writer and reader all use number 1, the second topic number 2.
pub mod ids {
    use super::{object_id, ObjectId, ObjectKind};
    /// The participant.
    pub const PARTICIPANT: ObjectId = object_id(1, ObjectKind::Participant);
    /// The topic written.
    pub const TOPIC_OUT: ObjectId = object_id(1, ObjectKind::Topic);
    /// The topic read.
    pub const TOPIC_IN: ObjectId = object_id(2, ObjectKind::Topic);
    /// The publisher.
    pub const PUBLISHER: ObjectId = object_id(1, ObjectKind::Publisher);
    /// The subscriber.
    pub const SUBSCRIBER: ObjectId = object_id(1, ObjectKind::Subscriber);
    /// The datawriter.
    pub const WRITER: ObjectId = object_id(1, ObjectKind::DataWriter);
    /// The datareader.
    pub const READER: ObjectId = object_id(1, ObjectKind::DataReader);
}

/// Type name of every benchmark topic.
pub const TYPE_NAME: &str = "xrce_bench::Sample";

/// What a client should create.
#[derive(Debug, Clone, Copy)]
pub struct Endpoints<'n> {
    /// Topic of the datawriter, if any.
    pub write: Option<&'n str>,
    /// Topic of the datareader, if any.
    pub read: Option<&'n str>,
    /// Reliable QoS (else best effort).
    pub reliable: bool,
    /// History depth in the QoS.
    pub depth: u16,
    /// Participant name (micro-ROS puts its node name there; our agent's DDS middleware makes it a ROS 2 node).
    pub participant_name: Option<&'n str>,
}

/// Buffers (binary representation, REPLACE) a participant in domain 0 and what `ep` asks for on `stream`;
/// the `(entity, request id)` pairs to wait for.
pub fn buffer_endpoints<'a, W: WriteAccessExt<'a> + ?Sized>(
    w: &mut W,
    stream: StreamId,
    ep: &Endpoints<'_>,
) -> Result<Vec<(&'static str, u16)>, BenchError> {
    let q = qos(ep.reliable, ep.depth);
    let mut reqs = vec![(
        "participant",
        w.buffer_create_participant_bin(stream, ids::PARTICIPANT, 0, ep.participant_name, REPLACE)?,
    )];
    if let Some(topic) = ep.write {
        reqs.push((
            "topic",
            w.buffer_create_topic_bin(stream, ids::TOPIC_OUT, ids::PARTICIPANT, topic, TYPE_NAME, REPLACE)?,
        ));
        reqs.push(("publisher", w.buffer_create_publisher_bin(stream, ids::PUBLISHER, ids::PARTICIPANT, REPLACE)?));
        reqs.push((
            "datawriter",
            w.buffer_create_datawriter_bin(stream, ids::WRITER, ids::PUBLISHER, ids::TOPIC_OUT, q, REPLACE)?,
        ));
    }
    if let Some(topic) = ep.read {
        reqs.push((
            "topic",
            w.buffer_create_topic_bin(stream, ids::TOPIC_IN, ids::PARTICIPANT, topic, TYPE_NAME, REPLACE)?,
        ));
        reqs.push(("subscriber", w.buffer_create_subscriber_bin(stream, ids::SUBSCRIBER, ids::PARTICIPANT, REPLACE)?));
        reqs.push((
            "datareader",
            w.buffer_create_datareader_bin(stream, ids::READER, ids::SUBSCRIBER, ids::TOPIC_IN, q, REPLACE)?,
        ));
    }
    Ok(reqs)
}

/// Asks the datareader for every sample, delivered on `data_stream`.
pub fn request_all<'a, W: WriteAccessExt<'a> + ?Sized>(
    w: &mut W,
    stream: StreamId,
    data_stream: StreamId,
) -> Result<u16, BenchError> {
    let control = DeliveryControl { max_samples: DeliveryControl::UNLIMITED, ..Default::default() };
    Ok(w.buffer_request_data(stream, ids::READER, data_stream, Some(&control))?)
}

/// Smallest power of two ≥ `n` (1 for 0).
pub const fn pow2_at_least(n: usize) -> usize {
    n.next_power_of_two()
}

/// Reliable history needed to hold a `payload`-byte sample fragmented into `mtu`-byte messages (the input
/// stream reassembles in place), at least `history`.
pub fn history_for(payload: usize, mtu: usize, history: usize) -> usize {
    // Per message: header (≤ 8), FRAGMENT subheader (4), slot length word; the inner WRITE_DATA adds 8.
    let per = mtu.saturating_sub(24).max(1);
    let needed = (payload + 8).div_ceil(per) + 1;
    pow2_at_least(needed.max(history).max(1))
}
