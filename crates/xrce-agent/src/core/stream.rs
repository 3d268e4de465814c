//! Input and output streams of one client session (spec §9): best-effort ordering, reliable windows with
//! HEARTBEAT/ACKNACK, and fragmentation both ways.

use std::collections::VecDeque;

use xrce_proto::submessage::{AckNack, Heartbeat};
use xrce_proto::view::{self, FragmentHead, SubmessageId};
use xrce_proto::MessageHeader;

pub use crate::bufpool::BufPool;

/// `a < b` in 16-bit serial arithmetic (spec §9.1).
pub const fn seq_lt(a: u16, b: u16) -> bool {
    a != b && b.wrapping_sub(a) < 0x8000
}

/// `a <= b` in 16-bit serial arithmetic.
pub const fn seq_le(a: u16, b: u16) -> bool {
    a == b || seq_lt(a, b)
}

/// Best-effort input: newer messages only (spec §9.2).
#[derive(Debug, Clone)]
pub struct BestEffortIn {
    last: u16,
}

impl Default for BestEffortIn {
    fn default() -> Self {
        Self { last: u16::MAX }
    }
}

impl BestEffortIn {
    /// Whether a message with `seq` is accepted (and remembered as the newest).
    pub fn accept(&mut self, seq: u16) -> bool {
        if seq_lt(self.last, seq) {
            self.last = seq;
            true
        } else {
            false
        }
    }
}

/// What a reliable input stream does with a message.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum InAction {
    /// It is the next one: process it now, then drain [`ReliableIn::pop_ready`].
    Process,
    /// Stored (or already stored) for later.
    Stored,
    /// Duplicate, outside the window, or no room: dropped.
    Dropped,
}

/// Reliable input stream (spec §9.5): window of `window` messages, in-order processing, FRAGMENT reassembly.
#[derive(Debug, Clone)]
pub struct ReliableIn {
    last_handled: u16,
    last_announced: u16,
    window: u16,
    /// Slot `i` holds message `last_handled + 1 + i`.
    stored: VecDeque<Option<Vec<u8>>>,
    /// Header of the first fragment and the concatenated fragment payloads (boxed: rarely there).
    reassembly: Option<Box<(Vec<u8>, Vec<u8>)>>,
}

impl ReliableIn {
    /// An empty stream expecting sequence number 0.
    pub fn new(window: u16) -> Self {
        Self {
            last_handled: u16::MAX,
            last_announced: u16::MAX,
            window: window.clamp(1, 16),
            stored: VecDeque::new(),
            reassembly: None,
        }
    }

    /// Bytes held (stored messages and partial reassembly), for the per-client bound.
    pub fn buffered(&self) -> usize {
        let stored: usize = self.stored.iter().flatten().map(Vec::len).sum();
        stored + self.reassembly.as_ref().map_or(0, |r| r.0.len() + r.1.len())
    }

    /// Classifies message `seq`; stores a copy when it is ahead and `room` allows.
    pub fn receive(&mut self, seq: u16, message: &[u8], room: usize) -> InAction {
        let next = self.last_handled.wrapping_add(1);
        if seq_lt(self.last_announced, seq) {
            self.last_announced = seq;
        }
        if !seq_le(next, seq) || !seq_lt(seq, next.wrapping_add(self.window)) {
            return InAction::Dropped;
        }
        if seq == next && !matches!(self.stored.front(), Some(Some(_))) {
            return InAction::Process;
        }
        let index = usize::from(seq.wrapping_sub(next));
        while self.stored.len() <= index {
            self.stored.push_back(None);
        }
        match self.stored.get_mut(index) {
            Some(slot @ None) if message.len() <= room => {
                *slot = Some(message.to_vec());
                InAction::Stored
            }
            Some(Some(_)) => InAction::Stored,
            _ => InAction::Dropped,
        }
    }

    /// Marks the next message handled (after [`InAction::Process`]).
    pub fn advance(&mut self) {
        self.last_handled = self.last_handled.wrapping_add(1);
        self.stored.pop_front();
        self.trim();
    }

    /// Frees the out-of-order storage once nothing is stored (idle sessions keep no buffers).
    fn trim(&mut self) {
        if self.stored.iter().all(Option::is_none) && self.stored.capacity() > 0 {
            self.stored = VecDeque::new();
        }
    }

    /// Keeps the next message (just classified [`InAction::Process`]) unprocessed: the middleware cannot take
    /// it yet. It counts as received (no NACK) but not handled (not acknowledged).
    pub fn hold(&mut self, message: &[u8]) {
        match self.stored.front_mut() {
            Some(slot) => *slot = Some(message.to_vec()),
            None => self.stored.push_back(Some(message.to_vec())),
        }
    }

    /// Puts back a message taken with [`Self::pop_ready`] (it could not be processed yet).
    pub fn unpop(&mut self, message: Vec<u8>) {
        self.last_handled = self.last_handled.wrapping_sub(1);
        self.stored.push_front(Some(message));
    }

    /// The start of the message being reassembled from FRAGMENTs (its first submessage header onwards).
    pub fn reassembly_start(&self) -> Option<&[u8]> {
        self.reassembly.as_ref().map(|r| r.1.as_slice()).filter(|b| !b.is_empty())
    }

    /// The next stored message if it is the next in order; marks it handled.
    pub fn pop_ready(&mut self) -> Option<Vec<u8>> {
        if !matches!(self.stored.front(), Some(Some(_))) {
            return None;
        }
        self.last_handled = self.last_handled.wrapping_add(1);
        let msg = self.stored.pop_front().flatten();
        self.trim();
        msg
    }

    /// A HEARTBEAT from the client: give up on messages it no longer holds (spec §9.5).
    pub fn on_heartbeat(&mut self, hb: &Heartbeat) {
        let first = hb.first_unacked_seq_nr;
        while seq_lt(self.last_handled.wrapping_add(1), first) {
            self.last_handled = self.last_handled.wrapping_add(1);
            self.stored.pop_front();
        }
        self.trim();
        if seq_lt(self.last_announced, hb.last_unacked_seq_nr) {
            self.last_announced = hb.last_unacked_seq_nr;
        }
    }

    /// The ACKNACK describing this stream's state; `stream_id` is the client's stream.
    pub fn acknack(&self, stream_id: u8) -> AckNack {
        let first = self.last_handled.wrapping_add(1);
        let mut bitmap = 0u16;
        for i in 0..16u16 {
            let seq = first.wrapping_add(i);
            if !seq_le(seq, self.last_announced) {
                break;
            }
            let stored = matches!(self.stored.get(usize::from(i)), Some(Some(_)));
            if !stored {
                bitmap |= 1 << i;
            }
        }
        AckNack { first_unacked_seq_num: first, nack_bitmap: bitmap.to_be_bytes(), stream_id }
    }

    /// Appends a FRAGMENT payload; returns the rebuilt message (header + payloads) when `last`, or an error
    /// when it would exceed `max` bytes (the partial message is dropped).
    pub fn push_fragment(
        &mut self,
        header: &[u8],
        data: &[u8],
        last: bool,
        max: usize,
    ) -> Result<Option<Vec<u8>>, usize> {
        let (head, body) = &mut **self.reassembly.get_or_insert_with(|| Box::new((header.to_vec(), Vec::new())));
        if head.len() + body.len() + data.len() > max {
            let size = head.len() + body.len() + data.len();
            self.reassembly = None;
            return Err(size);
        }
        body.extend_from_slice(data);
        if !last {
            return Ok(None);
        }
        Ok(self.reassembly.take().map(|r| {
            let (mut h, b) = *r;
            h.extend_from_slice(&b);
            h
        }))
    }
}

/// Best-effort output: the sequence counter.
#[derive(Debug, Clone)]
pub struct BestEffortOut {
    last: u16,
}

impl Default for BestEffortOut {
    fn default() -> Self {
        Self { last: u16::MAX }
    }
}

impl BestEffortOut {
    /// Sequence number for the next message.
    pub fn next_seq(&mut self) -> u16 {
        self.last = self.last.wrapping_add(1);
        self.last
    }
}

/// Reliable output stream (spec §9.5): up to `window` messages in flight, kept for retransmission until
/// acknowledged; more are queued (bounded) instead of being dropped as eProsima does.
#[derive(Debug, Clone)]
pub struct ReliableOut {
    first_unacked: u16,
    /// Sequence number of the next message put in flight.
    next_seq: u16,
    window: u16,
    /// Messages in flight, `first_unacked + i`, complete with header.
    in_flight: VecDeque<Vec<u8>>,
    /// Message bodies (submessages without header) waiting for room in the window.
    pending: VecDeque<Vec<u8>>,
    /// Bytes in `pending`.
    pending_bytes: usize,
    max_pending: usize,
    /// `first_unacked` when last checked with unacknowledged messages, and since when it has not moved.
    watch: Option<(u16, std::time::Instant)>,
    /// Round-trip timing and tail-loss probe.
    probe: super::probe::Probe,
}

impl ReliableOut {
    /// An empty stream whose first message will be sequence 0.
    pub fn new(window: u16, max_pending: usize) -> Self {
        Self {
            first_unacked: 0,
            next_seq: 0,
            window: window.clamp(1, 16),
            in_flight: VecDeque::new(),
            pending: VecDeque::new(),
            pending_bytes: 0,
            max_pending,
            watch: None,
            probe: super::probe::Probe::default(),
        }
    }

    /// Bodies that can still be queued.
    pub fn room(&self) -> usize {
        self.max_pending.saturating_sub(self.pending.len())
    }

    /// Whether another message may go in flight.
    pub fn has_window_room(&self) -> bool {
        self.in_flight.len() < usize::from(self.window)
    }

    /// Bytes queued behind the window.
    pub fn pending_bytes(&self) -> usize {
        self.pending_bytes
    }

    /// Whether another sample may be queued: the window has room and less than a message of `mtu` bytes
    /// waits (what waits is packed into one message by [`Self::flush`]).
    pub fn can_take(&self, mtu: usize) -> bool {
        self.has_window_room() && (self.pending.is_empty() || self.pending_bytes < mtu)
    }

    /// Frees the buffers of an idle stream (nothing in flight or queued), so idle sessions cost little.
    pub fn trim(&mut self) {
        if self.in_flight.is_empty() && self.in_flight.capacity() > 0 {
            self.in_flight = VecDeque::new();
        }
        if self.pending.is_empty() && self.pending.capacity() > 0 {
            self.pending = VecDeque::new();
        }
    }

    /// Whether messages are unacknowledged (heartbeats are due).
    pub fn has_unacked(&self) -> bool {
        !self.in_flight.is_empty()
    }

    /// Queues one message body. Returns false when there is no room.
    pub fn queue_one(&mut self, body: Vec<u8>) -> bool {
        if self.room() == 0 {
            return false;
        }
        self.pending_bytes += body.len();
        self.pending.push_back(body);
        true
    }

    /// Queues message bodies; all or nothing. Returns false when there is no room.
    pub fn queue(&mut self, bodies: Vec<Vec<u8>>) -> bool {
        if bodies.len() > self.room() {
            return false;
        }
        self.pending_bytes += bodies.iter().map(Vec::len).sum::<usize>();
        self.pending.extend(bodies);
        true
    }

    /// Moves queued bodies into the window, stamping `header` with their sequence numbers (and timing one
    /// for the round trip when `now` is known); `send` gets
    /// each complete message. Consecutive bodies that are not FRAGMENTs share a message up to `mtu` bytes
    /// (each submessage 4-aligned, as every client reads them); a FRAGMENT always travels alone (spec §9.6).
    pub fn flush(
        &mut self,
        header: &MessageHeader,
        mtu: usize,
        now: Option<std::time::Instant>,
        pool: &mut BufPool,
        mut send: impl FnMut(Vec<u8>),
    ) {
        while self.in_flight.len() < usize::from(self.window) {
            let Some(body) = self.pending.pop_front() else { break };
            self.pending_bytes = self.pending_bytes.saturating_sub(body.len());
            let h = MessageHeader { sequence_nr: self.next_seq, ..*header };
            let mut msg = pool.get();
            msg.resize(h.size(), 0);
            if h.encode(&mut msg).is_err() {
                continue;
            }
            let packable = |b: &[u8]| view::submessage_id(b) != Some(SubmessageId::Fragment);
            let pack = packable(&body);
            msg.extend_from_slice(&body);
            pool.put(body);
            while let Some(next) = self.pending.front() {
                let pad = (4 - msg.len() % 4) % 4;
                if !pack || !packable(next) || msg.len() + pad + next.len() > mtu {
                    break;
                }
                let Some(next) = self.pending.pop_front() else { break };
                self.pending_bytes = self.pending_bytes.saturating_sub(next.len());
                msg.resize(msg.len() + pad, 0);
                msg.extend_from_slice(&next);
                pool.put(next);
            }
            if let Some(now) = now {
                self.probe.on_sent(self.next_seq, now);
            }
            self.next_seq = self.next_seq.wrapping_add(1);
            send(pool.copy_of(&msg));
            self.in_flight.push_back(msg);
        }
    }

    /// An ACKNACK from the client: release what it has, resend what it misses (selective repeat). `period`
    /// is the HEARTBEAT period (it caps the probe timeout).
    pub fn on_acknack(
        &mut self,
        ack: &AckNack,
        now: std::time::Instant,
        period: std::time::Duration,
        pool: &mut BufPool,
        mut send: impl FnMut(Vec<u8>),
    ) {
        let first = ack.first_unacked_seq_num;
        // Only acknowledge what was sent: an ACKNACK beyond next_seq is bogus.
        if seq_le(first, self.next_seq) {
            let before = self.first_unacked;
            while seq_lt(self.first_unacked, first) {
                let Some(done) = self.in_flight.pop_front() else { break };
                pool.put(done);
                self.first_unacked = self.first_unacked.wrapping_add(1);
            }
            if self.first_unacked != before {
                self.probe.on_progress(self.first_unacked, now, period);
            }
        }
        let bitmap = ack.bitmap();
        for i in 0..16u16 {
            if bitmap & (1 << i) == 0 {
                continue;
            }
            let seq = first.wrapping_add(i);
            if !seq_le(self.first_unacked, seq) {
                continue;
            }
            if let Some(msg) = self.in_flight.get(usize::from(seq.wrapping_sub(self.first_unacked))) {
                self.probe.on_resent(seq);
                send(pool.copy_of(msg));
            }
        }
    }

    /// First unacknowledged sequence number.
    pub fn first_unacked(&self) -> u16 {
        self.first_unacked
    }

    /// How long messages have been in flight without any being acknowledged (zero when none are), as seen
    /// by successive calls.
    pub fn stalled_for(&mut self, now: std::time::Instant) -> std::time::Duration {
        if !self.has_unacked() {
            self.watch = None;
            return std::time::Duration::ZERO;
        }
        match self.watch {
            Some((first, since)) if first == self.first_unacked => now.saturating_duration_since(since),
            _ => {
                self.watch = Some((self.first_unacked, now));
                std::time::Duration::ZERO
            }
        }
    }

    /// Arms the tail-loss probe if messages are in flight and it is not armed: the instant to schedule.
    pub fn arm_probe(&mut self, now: std::time::Instant, period: std::time::Duration) -> Option<std::time::Instant> {
        if !self.has_unacked() {
            return None;
        }
        self.probe.arm(now, period)
    }

    /// The probe timer entry `due` came due: the HEARTBEAT to send, if one is owed, and the instant to
    /// schedule next, if any (see [`super::probe::Probe::fire`]).
    pub fn fire_probe(
        &mut self,
        stream_id: u8,
        due: std::time::Instant,
        now: std::time::Instant,
        period: std::time::Duration,
    ) -> (Option<Heartbeat>, Option<std::time::Instant>) {
        match self.probe.fire(due, self.has_unacked(), now, period) {
            Some((beat, next)) => (if beat { self.heartbeat(stream_id) } else { None }, next),
            None => (None, None),
        }
    }

    /// When this stream's tail-loss probe fires, if armed.
    pub fn probe_due(&self) -> Option<std::time::Instant> {
        self.probe.due()
    }

    /// The HEARTBEAT to send for this stream, if anything is unacknowledged.
    pub fn heartbeat(&self, stream_id: u8) -> Option<Heartbeat> {
        self.has_unacked().then(|| Heartbeat {
            first_unacked_seq_nr: self.first_unacked,
            last_unacked_seq_nr: self.next_seq.wrapping_sub(1),
            stream_id,
        })
    }
}

/// Cuts one submessage (header included) into FRAGMENT bodies that fit messages of `mtu` bytes with a
/// header of `header_len` bytes (spec §9.6). No padding anywhere: the C client glues what follows the
/// FRAGMENT header into its reassembly buffer.
pub fn fragment(submessage: &[u8], mtu: usize, header_len: usize) -> Vec<Vec<u8>> {
    let chunk = mtu.saturating_sub(header_len + FragmentHead::SIZE).max(1);
    let count = submessage.len().div_ceil(chunk);
    submessage
        .chunks(chunk)
        .enumerate()
        .map(|(i, part)| {
            // A chunk never exceeds `mtu`, itself a u16.
            let head = FragmentHead { last: i + 1 == count, chunk_len: u16::try_from(part.len()).unwrap_or(u16::MAX) };
            let mut body = Vec::with_capacity(FragmentHead::SIZE + part.len());
            body.extend_from_slice(&head.to_bytes());
            body.extend_from_slice(part);
            body
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use xrce_proto::{ClientKey, StreamId};

    #[test]
    fn serial_arithmetic_wraps() {
        assert!(seq_lt(0xFFFF, 0));
        assert!(seq_lt(1, 2));
        assert!(!seq_lt(2, 2));
        assert!(!seq_lt(0x8001, 1) || seq_lt(0x8001, 1));
    }

    #[test]
    fn reliable_in_orders_and_acknacks() {
        let mut s = ReliableIn::new(16);
        assert_eq!(s.receive(1, b"one", 100), InAction::Stored);
        let ack = s.acknack(0x80);
        assert_eq!(ack.first_unacked_seq_num, 0);
        assert_eq!(ack.bitmap(), 0b01);
        assert_eq!(s.receive(0, b"zero", 100), InAction::Process);
        s.advance();
        assert_eq!(s.pop_ready().as_deref(), Some(&b"one"[..]));
        assert_eq!(s.pop_ready(), None);
        assert_eq!(s.acknack(0x80).first_unacked_seq_num, 2);
        assert_eq!(s.receive(1, b"one", 100), InAction::Dropped);
        assert_eq!(s.receive(40, b"far", 100), InAction::Dropped);
    }

    #[test]
    fn reliable_out_window_and_retransmission() {
        let now = std::time::Instant::now();
        let header = MessageHeader::new(0x81, StreamId(0x80), 0, ClientKey::INVALID);
        let mut out = ReliableOut::new(16, 100);
        assert!(out.queue((0..20u8).map(|i| vec![i]).collect()));
        let mut sent = Vec::new();
        let mut pool = BufPool::default();
        out.flush(&header, 5, Some(now), &mut pool, |m| sent.push(m));
        assert_eq!(sent.len(), 16);
        assert_eq!(out.heartbeat(0x80).map(|h| (h.first_unacked_seq_nr, h.last_unacked_seq_nr)), Some((0, 15)));
        sent.clear();
        let ack = AckNack { first_unacked_seq_num: 4, nack_bitmap: [0, 1], stream_id: 0x80 };
        out.on_acknack(&ack, now, std::time::Duration::from_millis(200), &mut pool, |m| sent.push(m));
        assert_eq!(sent, vec![vec![0x81, 0x80, 4, 0, 4]]);
        sent.clear();
        out.flush(&header, 5, Some(now), &mut pool, |m| sent.push(m));
        assert_eq!(sent.len(), 4);
    }

    #[test]
    fn fragments_fit_the_mtu() {
        let sub = vec![7u8; 1000];
        let frags = fragment(&sub, 508, 4);
        assert_eq!(frags.len(), 2);
        assert!(frags.iter().all(|f| f.len() + 4 <= 508));
        assert_eq!(frags[1][1], 0x03);
        assert_eq!(frags[0][1], 0x01);
    }
}
