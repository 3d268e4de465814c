//! Input and output streams of one client session (spec §9): best-effort ordering, and reliable windows
//! with HEARTBEAT/ACKNACK, retransmission and fragmentation on the shared engine ([`xrce_proto::reliable`]).
//! The agent keeps the messages in owned buffers; the engine keeps the counters and the policy.

use std::collections::VecDeque;

use xrce_proto::layout::submessage_offset;
use xrce_proto::reliable::{
    self, AckNackBits, Chunks, FragmentPlan, FragmentSink, InputWindow, Reassembler, Reassembly,
};
use xrce_proto::reliable::{SendLog, Sender, SeqNum};
use xrce_proto::submessage::{AckNack, Heartbeat};
use xrce_proto::view::FragmentHead;
use xrce_proto::MessageHeader;

use super::probe::{engine_duration, from_engine, to_engine};
use super::stats::bump;
pub use crate::bufpool::BufPool;

/// Best-effort input: newer messages only (spec §9.2).
#[derive(Debug, Clone)]
pub struct BestEffortIn {
    last: SeqNum,
    /// Messages accepted.
    pub messages: u64,
}

impl Default for BestEffortIn {
    fn default() -> Self {
        Self { last: SeqNum::INIT, messages: 0 }
    }
}

impl BestEffortIn {
    /// Whether a message with `seq` is accepted (and remembered as the newest).
    pub fn accept(&mut self, seq: u16) -> bool {
        if self.last.lt(SeqNum(seq)) {
            self.last = SeqNum(seq);
            bump(&mut self.messages);
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

/// Bytes of a message being joined from FRAGMENTs.
#[derive(Debug, Clone, Default)]
struct Joined(Vec<u8>);

impl FragmentSink for Joined {
    fn len(&self) -> usize {
        self.0.len()
    }
    fn extend(&mut self, data: &[u8]) -> bool {
        self.0.extend_from_slice(data);
        true
    }
    fn clear(&mut self) {
        self.0.clear();
    }
}

/// Reliable input stream (spec §9.5): window of `window` messages, in-order processing, FRAGMENT reassembly.
#[derive(Debug, Clone)]
pub struct ReliableIn {
    window: InputWindow,
    depth: u16,
    /// Slot `i` holds message `last_handled + 1 + i`.
    stored: VecDeque<Option<Vec<u8>>>,
    /// The message being joined from FRAGMENTs (boxed: rarely there).
    reassembly: Option<Box<(Reassembler, Joined)>>,
    /// Messages taken in the window (processed or stored for later).
    pub messages: u64,
}

impl ReliableIn {
    /// An empty stream expecting sequence number 0.
    pub fn new(window: u16) -> Self {
        Self {
            window: InputWindow::new(),
            depth: window.clamp(1, 16),
            stored: VecDeque::new(),
            reassembly: None,
            messages: 0,
        }
    }

    /// Messages stored ahead of a gap, and the window's size.
    pub fn window_use(&self) -> (usize, u16) {
        (self.stored.iter().flatten().count(), self.depth)
    }

    /// Bytes held (stored messages and partial reassembly), for the per-client bound.
    pub fn buffered(&self) -> usize {
        let stored: usize = self.stored.iter().flatten().map(Vec::len).sum();
        stored + self.reassembly.as_ref().map_or(0, |r| r.1.len())
    }

    fn is_stored(&self, seq: SeqNum) -> bool {
        matches!(self.stored.get(usize::from(self.window.next().distance(seq))), Some(Some(_)))
    }

    /// Classifies message `seq`; stores a copy when it is ahead and `room` allows.
    pub fn receive(&mut self, seq: u16, message: &[u8], room: usize) -> InAction {
        let seq = SeqNum(seq);
        if !self.window.on_message(seq, self.depth) {
            return InAction::Dropped;
        }
        let next = self.window.next();
        if seq == next && !self.is_stored(next) {
            bump(&mut self.messages);
            return InAction::Process;
        }
        let index = usize::from(next.distance(seq));
        while self.stored.len() <= index {
            self.stored.push_back(None);
        }
        match self.stored.get_mut(index) {
            Some(slot @ None) if message.len() <= room => {
                *slot = Some(message.to_vec());
                bump(&mut self.messages);
                InAction::Stored
            }
            Some(Some(_)) => InAction::Stored,
            _ => InAction::Dropped,
        }
    }

    /// Marks the next message handled (after [`InAction::Process`]).
    pub fn advance(&mut self) {
        self.window.last_handled = self.window.next();
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
        self.window.last_handled = self.window.last_handled.sub(1);
        self.stored.push_front(Some(message));
    }

    /// The start of the message being reassembled from FRAGMENTs (its first submessage header onwards).
    pub fn reassembly_start(&self) -> Option<&[u8]> {
        self.reassembly.as_ref().map(|r| r.0.body(&r.1 .0)).filter(|b| !b.is_empty())
    }

    /// The next stored message if it is the next in order; marks it handled.
    pub fn pop_ready(&mut self) -> Option<Vec<u8>> {
        if !self.is_stored(self.window.next()) {
            return None;
        }
        self.window.last_handled = self.window.next();
        let msg = self.stored.pop_front().flatten();
        self.trim();
        msg
    }

    /// A HEARTBEAT from the client: give up on messages it no longer holds (spec §9.5).
    pub fn on_heartbeat(&mut self, hb: &Heartbeat) {
        let skipped = self.window.give_up_before(SeqNum(hb.first_unacked_seq_nr));
        self.stored.drain(..usize::from(skipped).min(self.stored.len()));
        self.trim();
        self.window.on_heartbeat(SeqNum(hb.last_unacked_seq_nr));
    }

    /// The ACKNACK describing this stream's state; `stream_id` is the client's stream.
    pub fn acknack(&self, stream_id: u8) -> AckNack {
        let ack = self.window.acknack(self.window.next(), |s| !self.is_stored(s));
        AckNack { first_unacked_seq_num: ack.first_unacked.0, nack_bitmap: ack.nack_bitmap(), stream_id }
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
        let (state, joined) = &mut **self.reassembly.get_or_insert_with(Box::default);
        match state.push(joined, header, data, last, max) {
            Reassembly::Partial => Ok(None),
            Reassembly::Complete => Ok(self.reassembly.take().map(|r| r.1 .0)),
            Reassembly::TooLarge(size) => {
                self.reassembly = None;
                Err(size)
            }
        }
    }
}

/// Best-effort output: the sequence counter.
#[derive(Debug, Clone)]
pub struct BestEffortOut {
    last: SeqNum,
    /// Messages numbered for sending.
    pub messages: u64,
}

impl Default for BestEffortOut {
    fn default() -> Self {
        Self { last: SeqNum::INIT, messages: 0 }
    }
}

impl BestEffortOut {
    /// Sequence number for the next message.
    pub fn next_seq(&mut self) -> u16 {
        self.last = self.last.next();
        bump(&mut self.messages);
        self.last.0
    }
}

/// Floor of the interval before a message NACKed again is retransmitted again (the interval is the larger of
/// this and the smoothed round trip). Lower than the client's 20 ms: the agent has no timer for a deferred
/// resend (it goes with the next ACKNACK or flush), and a client whose input history is smaller than the
/// agent's window rejects, and so NACKs, whole runs of messages behind each gap. With 20 ms, reliable 1024 B
/// through `lossy-proxy --drop 0.05` fell from ~2,300 to ~550 samples/s; with 2 ms it stays at the former.
pub const RETRANSMIT_FLOOR: reliable::Duration = reliable::Duration::from_millis(2);

/// A message in flight, complete with header, and when it last left.
#[derive(Debug, Clone)]
struct Flight {
    msg: Vec<u8>,
    sent: reliable::Instant,
    resent: bool,
}

/// A length in a stream's counters (a queue holds far less than 4 GiB; saturates rather than wraps).
fn as_u32(len: usize) -> u32 {
    u32::try_from(len).unwrap_or(u32::MAX)
}

/// The messages in flight as the engine sees them: `first` is the oldest's sequence number.
struct FlightLog<'a> {
    first: SeqNum,
    msgs: &'a mut VecDeque<Flight>,
}

impl SendLog for FlightLog<'_> {
    fn since_sent(&self, seq: SeqNum, now: reliable::Instant) -> Option<(reliable::Duration, bool)> {
        let f = self.msgs.get(usize::from(self.first.distance(seq)))?;
        Some((now.since(f.sent), f.resent))
    }

    fn stamp(&mut self, seq: SeqNum, now: reliable::Instant, retransmission: bool) {
        if let Some(f) = self.msgs.get_mut(usize::from(self.first.distance(seq))) {
            f.sent = now;
            f.resent |= retransmission;
        }
    }
}

/// A submessage waiting for room in a reliable stream's window: whole, or cut into FRAGMENTs (spec §9.6)
/// one message at a time as they are built, each chunk copied once, straight into its message.
#[derive(Debug, Clone)]
struct Waiting {
    sub: Vec<u8>,
    /// The chunks still to send, when it is cut.
    cut: Option<Chunks>,
}

/// Reliable output stream (spec §9.5): up to `window` messages in flight, kept for retransmission until
/// acknowledged; more are queued (bounded) instead of being dropped as eProsima does. Acknowledgement,
/// retransmission (selective, a repeat deferred as the client does, see [`Sender`]) and tail-loss probes are
/// the shared engine's.
#[derive(Debug, Clone)]
pub struct ReliableOut {
    sender: Sender,
    window: u16,
    /// Messages in flight, `first_unacked + i`.
    in_flight: VecDeque<Flight>,
    /// Submessages waiting for room in the window.
    pending: VecDeque<Waiting>,
    /// Messages `pending` will take (a submessage cut into FRAGMENTs takes one per chunk left).
    pending_msgs: u32,
    /// Bytes in `pending` not yet sent.
    pending_bytes: u32,
    max_pending: u32,
    /// `first_unacked` when last checked with unacknowledged messages, and since when it has not moved.
    /// (The engine's instant: 8 bytes where an `Instant` takes 16.)
    watch: Option<(u16, reliable::Instant)>,
    /// The latest time seen, for messages sent without one.
    clock: reliable::Instant,
    /// New messages built (retransmissions not included).
    pub messages: u64,
    /// Messages sent again (NACKed, or probed by a HEARTBEAT that went unanswered).
    pub retransmissions: u64,
}

impl ReliableOut {
    /// An empty stream whose first message will be sequence 0.
    pub fn new(window: u16, max_pending: usize) -> Self {
        let mut sender = Sender::new();
        sender.set_retransmit_floor(RETRANSMIT_FLOOR);
        Self {
            sender,
            window: window.clamp(1, 16),
            in_flight: VecDeque::new(),
            pending: VecDeque::new(),
            pending_msgs: 0,
            pending_bytes: 0,
            max_pending: u32::try_from(max_pending).unwrap_or(u32::MAX),
            watch: None,
            clock: reliable::Instant(0),
            messages: 0,
            retransmissions: 0,
        }
    }

    fn log(&mut self) -> (&mut Sender, FlightLog<'_>) {
        let first = self.sender.last_acked().next();
        (&mut self.sender, FlightLog { first, msgs: &mut self.in_flight })
    }

    /// Messages that can still be queued.
    pub fn room(&self) -> usize {
        self.max_pending.saturating_sub(self.pending_msgs) as usize
    }

    /// Messages in flight (unacknowledged), and the window's size.
    pub fn window_use(&self) -> (usize, u16) {
        (self.in_flight.len(), self.window)
    }

    /// Whether another message may go in flight.
    pub fn has_window_room(&self) -> bool {
        self.in_flight.len() < usize::from(self.window)
    }

    /// Whether another sample may be queued: what waits still fits the window's free messages (one
    /// message per body without packing, `mtu` bytes each with it). Messages are built only when the
    /// endpoint asks for the client's next one ([`Self::build_next`] then packs what waits), so this is what
    /// bounds a read task's samples per turn.
    pub fn can_take(&self, mtu: usize) -> bool {
        let free = usize::from(self.window).saturating_sub(self.in_flight.len());
        if mtu == 0 {
            (self.pending_msgs as usize) < free
        } else {
            (self.pending_bytes as usize) < free.saturating_mul(mtu)
        }
    }

    /// Whether [`Self::build_next`] would build a message now: a retransmission an ACKNACK asked for, or a new
    /// message the window has room for. (A deferred retransmission goes with the next build or ACKNACK.)
    pub fn has_buildable(&self) -> bool {
        self.sender.has_retransmission() || (!self.pending.is_empty() && self.has_window_room())
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

    /// Queues one submessage (header included) that fits a message. Returns false when there is no room.
    pub fn queue_one(&mut self, sub: Vec<u8>) -> bool {
        if self.room() == 0 {
            return false;
        }
        self.pending_msgs = self.pending_msgs.saturating_add(1);
        self.pending_bytes = self.pending_bytes.saturating_add(as_u32(sub.len()));
        self.pending.push_back(Waiting { sub, cut: None });
        true
    }

    /// Queues a submessage too large for one message, to be cut into FRAGMENTs as `plan` says (all of them
    /// or none). Returns false when there is no room.
    pub fn queue_cut(&mut self, sub: Vec<u8>, plan: FragmentPlan) -> bool {
        let count = plan.count(sub.len());
        if count > self.room() {
            return false;
        }
        // `count` ≤ `room()`, itself a u32.
        self.pending_msgs = self.pending_msgs.saturating_add(u32::try_from(count).unwrap_or(u32::MAX));
        self.pending_bytes = self.pending_bytes.saturating_add(as_u32(sub.len()));
        self.pending.push_back(Waiting { cut: Some(plan.chunks(sub.len())), sub });
        true
    }

    /// Writes this stream's next message into `buf` (replacing its content), built now: a retransmission
    /// due at `now` first (see [`Sender`]), else queued bodies the window has room for, stamped with `header`
    /// and the next sequence number, a copy kept in flight. Consecutive bodies that are not FRAGMENTs share a
    /// message up to `mtu` bytes (each submessage 4-aligned, as every client reads them); a FRAGMENT always
    /// travels alone (spec §9.6). False when there is nothing to send.
    pub fn build_next(
        &mut self,
        header: &MessageHeader,
        mtu: usize,
        now: std::time::Instant,
        pool: &mut BufPool,
        buf: &mut Vec<u8>,
    ) -> bool {
        self.clock = to_engine(now);
        let clock = self.clock;
        let (sender, mut log) = self.log();
        let mut resent = false;
        while let Some(seq) = sender.next_retransmission(&mut log, clock) {
            if let Some(f) = log.msgs.get(usize::from(log.first.distance(seq))) {
                buf.clear();
                buf.extend_from_slice(&f.msg);
                resent = true;
                break;
            }
        }
        if resent {
            bump(&mut self.retransmissions);
            return true;
        }
        if self.in_flight.len() >= usize::from(self.window) {
            return false;
        }
        let seq = self.sender.last_sent().next();
        let h = MessageHeader { sequence_nr: seq.0, ..*header };
        buf.clear();
        buf.resize(h.size(), 0);
        if h.encode(buf).is_err() {
            return false;
        }
        let Some(first) = self.pending.front_mut() else { return false };
        if let Some(chunks) = &mut first.cut {
            // The next FRAGMENT of a cut submessage, alone in its message.
            let Some(c) = chunks.next() else {
                // Nothing to cut (never queued so): dropped rather than left in the way.
                if let Some(empty) = self.pending.pop_front() {
                    self.pending_msgs = self.pending_msgs.saturating_sub(1);
                    pool.put(empty.sub);
                }
                return false;
            };
            let part = first.sub.get(c.offset..c.offset + c.len).unwrap_or(&[]);
            // A chunk never exceeds the MTU, itself a u16.
            let head = FragmentHead { last: c.last, chunk_len: u16::try_from(part.len()).unwrap_or(u16::MAX) };
            buf.extend_from_slice(&head.to_bytes());
            buf.extend_from_slice(part);
            self.pending_msgs = self.pending_msgs.saturating_sub(1);
            self.pending_bytes = self.pending_bytes.saturating_sub(as_u32(c.len));
            if c.last {
                if let Some(done) = self.pending.pop_front() {
                    pool.put(done.sub);
                }
            }
        } else {
            // The first whole submessage, then as many more as fit `mtu` when packing.
            let mut first = true;
            while let Some(next) = self.pending.front() {
                let at = submessage_offset(buf.len());
                if !first && (next.cut.is_some() || at + next.sub.len() > mtu) {
                    break;
                }
                first = false;
                let Some(next) = self.pending.pop_front() else { break };
                self.pending_msgs = self.pending_msgs.saturating_sub(1);
                self.pending_bytes = self.pending_bytes.saturating_sub(as_u32(next.sub.len()));
                buf.resize(at, 0);
                buf.extend_from_slice(&next.sub);
                pool.put(next.sub);
            }
        }
        // Fitted: a message stays here until acknowledged, and thousands of clients each holding a small
        // STATUS in a 256-byte buffer after a connection burst leave that much heap in holes once freed.
        let msg = pool.copy_fitted(buf);
        self.in_flight.push_back(Flight { msg, sent: clock, resent: false });
        bump(&mut self.messages);
        let (sender, mut log) = self.log();
        sender.on_sent(&mut log, seq, clock);
        true
    }

    /// An ACKNACK from the client: release what it has, schedule what it misses for the next
    /// [`Self::build_next`] (selective repeat, a repeat deferred until the retransmission interval has passed), so
    /// retransmissions are copied out when the endpoint asks for the client's next message, not here.
    /// `period` is the HEARTBEAT period (it caps the probe timeout).
    pub fn on_acknack(
        &mut self,
        ack: &AckNack,
        now: std::time::Instant,
        period: std::time::Duration,
        pool: &mut BufPool,
    ) {
        self.clock = to_engine(now);
        let bits = AckNackBits::from_wire(ack.first_unacked_seq_num, ack.nack_bitmap);
        let (sender, mut log) = self.log();
        let released = sender.on_acknack(&mut log, bits, to_engine(now), engine_duration(period));
        for done in self.in_flight.drain(..usize::from(released).min(self.in_flight.len())) {
            pool.put(done.msg);
        }
    }

    /// First unacknowledged sequence number.
    pub fn first_unacked(&self) -> u16 {
        self.sender.last_acked().next().0
    }

    /// How long messages have been in flight without any being acknowledged (zero when none are), as seen
    /// by successive calls.
    pub fn stalled_for(&mut self, now: std::time::Instant) -> std::time::Duration {
        if !self.has_unacked() {
            self.watch = None;
            return std::time::Duration::ZERO;
        }
        let first = self.first_unacked();
        match self.watch {
            Some((f, since)) if f == first => now.saturating_duration_since(from_engine(since)),
            _ => {
                self.watch = Some((first, to_engine(now)));
                std::time::Duration::ZERO
            }
        }
    }

    /// Arms the tail-loss probe if messages are in flight, a round trip is known (before, the periodic
    /// HEARTBEAT covers the stream and idle sessions hold no timer) and it is not armed: the instant to
    /// schedule.
    pub fn arm_probe(&mut self, now: std::time::Instant, period: std::time::Duration) -> Option<std::time::Instant> {
        if !self.has_unacked() || self.sender.probe.rtt.min().is_none() {
            return None;
        }
        self.sender.probe.arm(to_engine(now), engine_duration(period)).map(from_engine)
    }

    /// The probe timer entry `due` came due: the HEARTBEAT to send, if one is owed, and the instant to
    /// schedule next, if any (see [`xrce_proto::reliable::Probe::fire`]).
    pub fn fire_probe(
        &mut self,
        stream_id: u8,
        due: std::time::Instant,
        now: std::time::Instant,
        period: std::time::Duration,
    ) -> (Option<Heartbeat>, Option<std::time::Instant>) {
        let unacked = self.has_unacked();
        match self.sender.probe.fire(to_engine(due), unacked, to_engine(now), engine_duration(period)) {
            Some((beat, next)) => (if beat { self.heartbeat(stream_id) } else { None }, next.map(from_engine)),
            None => (None, None),
        }
    }

    /// When this stream's tail-loss probe fires, if armed.
    pub fn probe_due(&self) -> Option<std::time::Instant> {
        self.sender.probe.due().map(from_engine)
    }

    /// The HEARTBEAT to send for this stream, if anything is unacknowledged.
    pub fn heartbeat(&self, stream_id: u8) -> Option<Heartbeat> {
        self.sender.heartbeat().map(|(first, last)| Heartbeat {
            first_unacked_seq_nr: first.0,
            last_unacked_seq_nr: last.0,
            stream_id,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use xrce_proto::{ClientKey, StreamId};

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
        let mut out = ReliableOut::new(16, 100);
        assert!((0..20u8).all(|i| out.queue_one(vec![i])));
        let mut sent = Vec::new();
        let mut pool = BufPool::default();
        sent.extend(flush_all(&mut out, 5, now, &mut pool));
        assert_eq!(sent.len(), 16);
        assert_eq!(out.heartbeat(0x80).map(|h| (h.first_unacked_seq_nr, h.last_unacked_seq_nr)), Some((0, 15)));
        sent.clear();
        let ack = AckNack { first_unacked_seq_num: 4, nack_bitmap: [0, 1], stream_id: 0x80 };
        out.on_acknack(&ack, now, std::time::Duration::from_millis(200), &mut pool);
        assert!(out.has_buildable(), "the NACKed message waits to be built");
        // The retransmission first, then the 4 new messages the window now has room for.
        sent.extend(flush_all(&mut out, 5, now, &mut pool));
        assert_eq!(sent.len(), 5);
        assert_eq!(sent[0], vec![0x81, 0x80, 4, 0, 4]);
        assert_eq!(sent.iter().skip(1).map(|m| seq_of(m)).collect::<Vec<_>>(), [16, 17, 18, 19]);
        sent.clear();
        sent.extend(flush_all(&mut out, 5, now, &mut pool));
        assert!(sent.is_empty(), "a retransmission goes once");
    }

    /// Builds every message the stream would send now.
    fn flush_all(out: &mut ReliableOut, mtu: usize, now: std::time::Instant, pool: &mut BufPool) -> Vec<Vec<u8>> {
        let header = MessageHeader::new(0x81, StreamId(0x80), 0, ClientKey::INVALID);
        let mut sent = Vec::new();
        let mut buf = Vec::new();
        while out.build_next(&header, mtu, now, pool, &mut buf) {
            sent.push(buf.clone());
        }
        sent
    }

    /// The sequence number of a message.
    fn seq_of(msg: &[u8]) -> u16 {
        MessageHeader::decode(msg).unwrap().0.sequence_nr
    }

    #[test]
    fn a_repeated_nack_waits_for_the_retransmission_interval() {
        // The engine counts microseconds: a whole one, so the instants below map exactly.
        let t0 = from_engine(to_engine(std::time::Instant::now()));
        let ms = std::time::Duration::from_millis(1);
        let period = 200 * ms;
        let mut out = ReliableOut::new(16, 100);
        let mut pool = BufPool::default();
        let mut sent = Vec::new();
        assert!((0..3u8).all(|i| out.queue_one(vec![i])));
        sent.extend(flush_all(&mut out, 5, t0, &mut pool));
        assert_eq!(sent.len(), 3);
        assert_eq!(out.arm_probe(t0, period), None, "no round trip known: the periodic HEARTBEAT covers it");
        let nack1 = AckNack { first_unacked_seq_num: 1, nack_bitmap: [0, 1], stream_id: 0x80 };
        let mut resent = Vec::new();
        // Seq 0 acknowledged after 4 ms (the round trip), seq 1 NACKed: resent with the next flush.
        out.on_acknack(&nack1, t0 + 4 * ms, period, &mut pool);
        assert!(resent.is_empty(), "built when asked, not when the ACKNACK arrives");
        resent.extend(flush_all(&mut out, 5, t0 + 4 * ms, &mut pool).iter().map(|m| seq_of(m)));
        assert_eq!(resent, [1]);
        // The same gap reported again by ACKNACKs already on their way: not again within the interval, the
        // 4 ms round trip (over the 2 ms floor).
        out.on_acknack(&nack1, t0 + 5 * ms, period, &mut pool);
        assert!(!out.has_buildable(), "a repeat within the interval is deferred");
        resent.extend(flush_all(&mut out, 5, t0 + 7 * ms, &mut pool).iter().map(|m| seq_of(m)));
        assert_eq!(resent, [1]);
        // Unacknowledged when the interval has passed: it goes again with the next flush.
        resent.extend(flush_all(&mut out, 5, t0 + 8 * ms, &mut pool).iter().map(|m| seq_of(m)));
        assert_eq!(resent, [1, 1]);
        // The probe: twice the 4 ms round trip after arming.
        assert_eq!(out.arm_probe(t0 + 8 * ms, period), Some(t0 + 16 * ms));
        let (beat, next) = out.fire_probe(0x80, t0 + 16 * ms, t0 + 16 * ms, period);
        assert_eq!(beat.map(|h| (h.first_unacked_seq_nr, h.last_unacked_seq_nr)), Some((1, 2)));
        assert_eq!(next, Some(t0 + 32 * ms), "backed off");
        assert_eq!(out.probe_due(), next);
    }

    #[test]
    fn heartbeat_gives_up_and_fragments_are_joined() {
        let mut s = ReliableIn::new(16);
        assert_eq!(s.receive(3, b"three", 100), InAction::Stored);
        s.on_heartbeat(&Heartbeat { first_unacked_seq_nr: 3, last_unacked_seq_nr: 5, stream_id: 0x80 });
        assert_eq!(s.pop_ready().as_deref(), Some(&b"three"[..]));
        let ack = s.acknack(0x80);
        assert_eq!((ack.first_unacked_seq_num, ack.bitmap()), (4, 0b11));
        assert_eq!(s.push_fragment(b"HD", b"ab", false, 10), Ok(None));
        assert_eq!(s.reassembly_start(), Some(&b"ab"[..]));
        assert_eq!(s.buffered(), 4);
        assert_eq!(s.push_fragment(b"xx", b"cd", true, 10), Ok(Some(b"HDabcd".to_vec())));
        assert_eq!(s.push_fragment(b"HD", b"0123456789", true, 10), Err(12));
        assert_eq!(s.buffered(), 0);
    }

    #[test]
    fn fragments_are_cut_as_built_and_fit_the_mtu() {
        let now = std::time::Instant::now();
        let mut out = ReliableOut::new(16, 100);
        let mut pool = BufPool::default();
        let sub: Vec<u8> = (0..1000u32).map(|i| i as u8).collect();
        assert!(out.queue_one(vec![1, 2, 3]));
        assert!(out.queue_cut(sub.clone(), FragmentPlan::for_mtu(508, 4)));
        assert!(out.queue_one(vec![4, 5, 6]));
        assert_eq!(out.room(), 96, "the cut submessage counts one message per FRAGMENT");
        let msgs = flush_all(&mut out, 508, now, &mut pool);
        assert_eq!(msgs.len(), 4, "the FRAGMENTs travel alone, nothing joins them");
        assert!(msgs.iter().all(|m| m.len() <= 508));
        let heads: Vec<_> =
            msgs[1..3].iter().map(|m| FragmentHead::parse(&m[4..]).map(|h| (h.last, h.chunk_len))).collect();
        assert_eq!(heads, [Some((false, 500)), Some((true, 500))]);
        let joined: Vec<u8> = msgs[1..3].iter().flat_map(|m| m[4 + FragmentHead::SIZE..].to_vec()).collect();
        assert_eq!(joined, sub);
        assert_eq!(msgs[3][4..], [4, 5, 6]);
        assert_eq!(out.room(), 100);
    }
}
