//! Reliable output stream (spec §9.3) and its fragmentation (§9.6), as eProsima's C client does them.
//!
//! The buffer is split into `history` slots; slot `seq mod history` holds message `seq`. A message can be
//! written only while its slot is inside the window (`seq - last_acknown <= history`); when it is not, writes
//! fail with [`Error::WouldBlock`] instead of stalling. HEARTBEATs go out every 100 ms while something is
//! unacknowledged; an ACKNACK releases slots.
//!
//! Retransmission departs from the C client on purpose (the wire is unchanged, the agent sees ordinary,
//! byte-identical resends). The C client resends its whole unacknowledged window on every ACKNACK carrying a
//! NACK bit (go-back-N, spec §9.3 step 4). Agents send one ACKNACK per reliable message they receive, so under
//! loss plus reordering many ACKNACKs report the same gap, each one resent the whole window, each resend drew
//! more ACKNACKs, and retransmissions grew without bound. Here, as the agent does for its own output (§9.5):
//! * only the sequence numbers whose NACK bit is set are resent (selective repeat);
//! * a message already retransmitted is not retransmitted again before a minimum interval since its last
//!   transmission: `max(floor, srtt)` capped at [`MAX_RETRANSMIT_INTERVAL_NS`], where the round
//!   trip is estimated from ACKNACKs acknowledging messages sent once (Karn's rule) and the floor defaults to
//!   [`DEFAULT_RETRANSMIT_FLOOR_NS`] ([`OutputReliable::set_retransmit_floor`]); a first retransmission is
//!   immediate, as with the C client and the agent;
//! * an ACKNACK without NACK bits only releases slots, it never resends.
//!
//! Tail losses (the last messages sent, or the ACKNACK of a full window) are recovered by a HEARTBEAT, whose
//! answer names the gaps. The C client waits 100 ms for it; here, once an acknowledgement has given a
//! round-trip sample, the first HEARTBEAT after a send goes out a *probe timeout* later,
//! `max(2 × smallest round trip, PROBE_FLOOR_NS)` (not srtt: a sample that waited for a lost ACKNACK would
//! stretch it), doubling with every HEARTBEAT left unanswered by progress, up to the
//! C client's 100 ms (measured through a 20 % lossy link: see docs/benchmarks.md). Without an estimate yet
//! (the first messages of a session) the period is the C client's.
//!
//! Each slot's 4-byte length word (not on the wire, as in the C client) holds the message length (2 bytes) and
//! 2 bytes of bookkeeping: whether the message ends with a FRAGMENT, whether it was sent and retransmitted, and
//! the time of its last transmission in milliseconds modulo 8192. Slot capacity, and so the fragmentation
//! layout, stay exactly the C client's.

use super::{align4, seq, slot_size, Parts, SLOT_LEN_WORD, SUBHEADER};
use crate::error::{Error, Result};
use xrce_proto::view::FragmentHead;
use xrce_proto::{ClientKey, MessageHeader, StreamId};

/// Heartbeat period of the C client (`UCLIENT_MIN_HEARTBEAT_TIME_INTERVAL`), in nanoseconds.
pub const HEARTBEAT_PERIOD_NS: i64 = 100_000_000;

/// Shortest probe timeout: a HEARTBEAT never follows a send sooner, however short the round trip.
pub const PROBE_FLOOR_NS: i64 = 2_000_000;

/// Default floor of the interval between two retransmissions of one message, in nanoseconds.
pub const DEFAULT_RETRANSMIT_FLOOR_NS: i64 = 20_000_000;
/// Longest interval between two retransmissions of one message, whatever the round-trip estimate says.
pub const MAX_RETRANSMIT_INTERVAL_NS: i64 = 1_000_000_000;

/// Slot flag: the message ends with a FRAGMENT, so it is sent without trailing padding.
const ENDS_WITH_FRAGMENT: u16 = 0x01;
/// Slot flag: the message was sent; the time stamp is valid.
const SENT: u16 = 0x02;
/// Slot flag: the message was retransmitted at least once (no round-trip sample from its acknowledgement).
const RESENT: u16 = 0x04;
/// Slot bits holding the time of the last transmission, in milliseconds modulo 8192.
const STAMP_SHIFT: u16 = 3;
const STAMP_MASK: u16 = 0x1FFF;
const NS_PER_MS: i64 = 1_000_000;

/// Milliseconds modulo 8192 at `now`.
fn stamp_ms(now: i64) -> u16 {
    u16::try_from(now.div_euclid(NS_PER_MS) & i64::from(STAMP_MASK)).unwrap_or(0)
}

/// A fragmented submessage being written.
#[derive(Debug, Clone, Copy)]
struct Chain {
    /// Slot receiving bytes.
    seq: u16,
    /// Whether the FRAGMENT header of `seq` is written (it waits for the window otherwise).
    started: bool,
    /// Offset of that FRAGMENT header in the slot's message.
    sub_at: usize,
    /// Inner bytes still to write.
    remaining: usize,
}

/// A reliable output stream over a caller's buffer.
#[derive(Debug)]
pub struct OutputReliable<'a> {
    buf: &'a mut [u8],
    history: u16,
    slot: usize,
    header_size: usize,
    last_written: u16,
    last_sent: u16,
    last_acknown: u16,
    /// NACKed messages to resend now: bit i ↔ `last_acknown + 1 + i`.
    resend: u16,
    /// NACKed messages retransmitted too recently, to resend once their interval has passed (same bits).
    deferred: u16,
    /// When the first of `deferred` becomes due.
    deferred_at: Option<i64>,
    flush: bool,
    heartbeat_deadline: Option<i64>,
    chain: Option<Chain>,
    /// Smoothed round trip in microseconds (0: no sample yet).
    srtt_us: u32,
    /// Smallest round-trip sample in microseconds (0: none yet): the probe timeout's base, because a sample
    /// can include the wait for a lost acknowledgement and inflate `srtt`.
    min_rtt_us: u32,
    /// HEARTBEATs sent since the last acknowledgement that released something (backs the probe off).
    probes: u8,
    /// Floor of the interval between two retransmissions of one message, in microseconds.
    floor_us: u32,
}

impl<'a> OutputReliable<'a> {
    /// A stream over `buf` with `history` slots (a power of two dividing the buffer), for messages whose header
    /// takes `header_size` bytes.
    pub fn new(buf: &'a mut [u8], history: usize, header_size: usize) -> Result<Self> {
        let slot = slot_size(buf.len(), history).ok_or(Error::InvalidHistory)?;
        let history = u16::try_from(history).map_err(|_| Error::InvalidHistory)?;
        let mut s = Self {
            buf,
            history,
            slot,
            header_size,
            last_written: 0,
            last_sent: seq::INIT,
            last_acknown: seq::INIT,
            resend: 0,
            deferred: 0,
            deferred_at: None,
            flush: false,
            heartbeat_deadline: None,
            chain: None,
            srtt_us: 0,
            min_rtt_us: 0,
            probes: 0,
            floor_us: 0,
        };
        s.set_retransmit_floor(DEFAULT_RETRANSMIT_FLOOR_NS);
        s.reset();
        Ok(s)
    }

    /// Drops everything and restarts numbering (session (re)creation).
    pub fn reset(&mut self) {
        for i in 0..usize::from(self.history) {
            self.set_slot(i, 0, 0);
        }
        self.last_written = 0;
        self.last_sent = seq::INIT;
        self.last_acknown = seq::INIT;
        self.resend = 0;
        self.deferred = 0;
        self.deferred_at = None;
        self.flush = false;
        self.heartbeat_deadline = None;
        self.chain = None;
        self.srtt_us = 0;
        self.min_rtt_us = 0;
        self.probes = 0;
    }

    /// Sets the floor of the interval between two retransmissions of one message (nanoseconds; default
    /// [`DEFAULT_RETRANSMIT_FLOOR_NS`], capped at [`MAX_RETRANSMIT_INTERVAL_NS`]). The interval used is the
    /// larger of this floor and the round-trip estimate.
    pub fn set_retransmit_floor(&mut self, floor_ns: i64) {
        let us = floor_ns.clamp(0, MAX_RETRANSMIT_INTERVAL_NS) / 1000;
        self.floor_us = u32::try_from(us).unwrap_or(u32::MAX);
    }

    /// The smoothed round-trip estimate in nanoseconds, once an acknowledgement gave one.
    pub fn srtt(&self) -> Option<i64> {
        (self.srtt_us > 0).then(|| i64::from(self.srtt_us) * 1000)
    }

    /// Minimum time between two retransmissions of one message now: `max(floor, srtt)`, capped. One round
    /// trip is how long ACKNACKs that left the agent before a retransmission reached it keep coming; a NACK
    /// arriving later is evidence that the retransmission was lost. (ACKNACKs delayed further by reordering
    /// cost at most one extra retransmission per interval, never a cascade.)
    pub fn retransmit_interval(&self) -> i64 {
        (i64::from(self.srtt_us).max(i64::from(self.floor_us)) * 1000).min(MAX_RETRANSMIT_INTERVAL_NS)
    }

    /// How long after a send (or the last HEARTBEAT) the next HEARTBEAT goes out: `max(2 × smallest round
    /// trip, PROBE_FLOOR_NS)` doubled per unanswered HEARTBEAT, at most [`HEARTBEAT_PERIOD_NS`]; that period
    /// until a round trip has been sampled.
    pub fn probe_timeout(&self) -> i64 {
        if self.min_rtt_us == 0 {
            return HEARTBEAT_PERIOD_NS;
        }
        let base = (i64::from(self.min_rtt_us) * 2000).max(PROBE_FLOOR_NS);
        // Past 16 doublings any base is over the period; shifting further would overflow.
        base.saturating_mul(1 << self.probes.min(16)).min(HEARTBEAT_PERIOD_NS)
    }

    /// Folds a round-trip sample into the estimate (exponential average, gain 1/8 as in RFC 6298).
    fn rtt_sample(&mut self, sample_us: u32) {
        let r = sample_us.max(1);
        self.srtt_us = if self.srtt_us == 0 { r } else { (self.srtt_us - self.srtt_us / 8 + r / 8).max(1) };
        self.min_rtt_us = if self.min_rtt_us == 0 { r } else { self.min_rtt_us.min(r) };
    }

    /// Bytes of message a slot holds (header included): the slot minus its length word.
    pub const fn slot_capacity(&self) -> usize {
        self.slot - SLOT_LEN_WORD
    }

    /// Largest submessage (header included) that fits one message.
    pub const fn max_unfragmented(&self) -> usize {
        self.slot_capacity() - self.header_size
    }

    fn index(&self, seq_nr: u16) -> usize {
        usize::from(seq_nr & (self.history - 1))
    }

    /// Length of message `seq_nr`; 0 outside the window, where the slot still belongs to an older message.
    fn len_of(&self, seq_nr: u16) -> usize {
        if !self.window_ok(seq_nr) {
            return 0;
        }
        let at = self.index(seq_nr) * self.slot;
        match self.buf.get(at..at + 2) {
            Some(&[lo, hi]) => usize::from(u16::from_le_bytes([lo, hi])),
            _ => 0,
        }
    }

    /// The bookkeeping half of the slot's length word.
    fn flags_of(&self, seq_nr: u16) -> u16 {
        let at = self.index(seq_nr) * self.slot + 2;
        match self.buf.get(at..at + 2) {
            Some(&[lo, hi]) => u16::from_le_bytes([lo, hi]),
            _ => 0,
        }
    }

    fn set_flags(&mut self, seq_nr: u16, flags: u16) {
        let at = self.index(seq_nr) * self.slot + 2;
        if let Some(dst) = self.buf.get_mut(at..at + 2) {
            dst.copy_from_slice(&flags.to_le_bytes());
        }
    }

    fn set_slot(&mut self, index: usize, len: usize, flags: u16) {
        let at = index * self.slot;
        let len = u16::try_from(len).unwrap_or(0).to_le_bytes();
        let flags = flags.to_le_bytes();
        if let Some(dst) = self.buf.get_mut(at..at + SLOT_LEN_WORD) {
            dst.copy_from_slice(&[len[0], len[1], flags[0], flags[1]]);
        }
    }

    fn set_len(&mut self, seq_nr: u16, len: usize, flags: u16) {
        self.set_slot(self.index(seq_nr), len, flags);
    }

    /// Records a transmission of message `seq_nr` at `now`.
    fn stamp(&mut self, seq_nr: u16, now: i64, retransmission: bool) {
        let old = self.flags_of(seq_nr);
        let resent = if retransmission { RESENT } else { old & RESENT };
        let flags = (old & ENDS_WITH_FRAGMENT) | SENT | resent | (stamp_ms(now) << STAMP_SHIFT);
        self.set_flags(seq_nr, flags);
    }

    /// Milliseconds since the last transmission of message `seq_nr` (modulo 8192), and whether it was
    /// retransmitted; `None` if it was never sent.
    fn since_sent(&self, seq_nr: u16, now: i64) -> Option<(i64, bool)> {
        let flags = self.flags_of(seq_nr);
        if flags & SENT == 0 {
            return None;
        }
        let elapsed = stamp_ms(now).wrapping_sub(flags >> STAMP_SHIFT) & STAMP_MASK;
        Some((i64::from(elapsed), flags & RESENT != 0))
    }

    /// The message area of slot `seq_nr`.
    fn content_mut(&mut self, seq_nr: u16) -> &mut [u8] {
        let at = self.index(seq_nr) * self.slot + SLOT_LEN_WORD;
        let end = at + self.slot_capacity();
        self.buf.get_mut(at..end).unwrap_or(&mut [])
    }

    fn content(&self, seq_nr: u16) -> &[u8] {
        let at = self.index(seq_nr) * self.slot + SLOT_LEN_WORD;
        let end = at + self.slot_capacity();
        self.buf.get(at..end).unwrap_or(&[])
    }

    /// Whether message `seq_nr` may be written: its slot no longer holds an unacknowledged message.
    fn window_ok(&self, seq_nr: u16) -> bool {
        let d = seq_nr.wrapping_sub(self.last_acknown);
        d != 0 && d <= self.history
    }

    /// Where the next message would start: (slot, offset) in the current slot when `fits` says so, else the next.
    fn next_slot(&self) -> u16 {
        if self.len_of(self.last_written) == 0 {
            self.last_written
        } else {
            self.last_written.wrapping_add(1)
        }
    }

    /// Reserves `total` bytes (submessage header included) in one message and returns them zero-filled, or
    /// `None` when the submessage needs fragmenting.
    pub fn reserve(&mut self, total: usize) -> Result<Option<&mut [u8]>> {
        if self.chain.is_some() {
            return Err(Error::Busy);
        }
        let cap = self.slot_capacity();
        let cur = self.last_written;
        let cur_len = self.len_of(cur);
        let (target, at) = if cur_len > 0 && align4(cur_len) + total <= cap {
            (cur, align4(cur_len))
        } else if self.header_size + total <= cap {
            let next = self.next_slot();
            if !self.window_ok(next) {
                return Err(Error::WouldBlock);
            }
            (next, self.header_size)
        } else {
            return Ok(None);
        };
        self.last_written = target;
        let old = self.len_of(target);
        self.set_len(target, at + total, 0);
        let content = self.content_mut(target);
        let from = old.min(at);
        if let Some(pad) = content.get_mut(from..at) {
            pad.fill(0);
        }
        let region = content.get_mut(at..at + total).ok_or(Error::TooLarge)?;
        region.fill(0);
        Ok(Some(region))
    }

    /// Writes a submessage made of `parts` (its 4-byte header first), fragmenting it over several messages when
    /// it does not fit one (spec §9.6). All or nothing: [`Error::WouldBlock`] when the window lacks slots now,
    /// [`Error::TooLarge`] when the whole history could never hold it.
    pub fn write_parts(&mut self, parts: &[&[u8]]) -> Result<()> {
        let total = Parts::total(parts);
        if let Some(region) = self.reserve(total)? {
            Parts::new(parts).read_into(region);
            return Ok(());
        }
        let (first, first_off) = self.first_fragment_place(1);
        let cap = self.slot_capacity();
        let first_chunk = cap - first_off - SUBHEADER;
        let block = cap - self.header_size - SUBHEADER;
        let rest = total.saturating_sub(first_chunk);
        let extra = rest.div_ceil(block);
        if extra >= usize::from(self.history) {
            return Err(Error::TooLarge);
        }
        let last = first.wrapping_add(u16::try_from(extra).map_err(|_| Error::TooLarge)?);
        if !self.window_ok(first) || !self.window_ok(last) {
            return Err(Error::WouldBlock);
        }
        self.start_chain(first, first_off, total);
        let mut reader = Parts::new(parts);
        let mut scratch = [0u8; 64];
        let mut left = total;
        while left > 0 {
            let n = reader.read_into(scratch.get_mut(..left.min(64)).unwrap_or(&mut []));
            if n == 0 {
                break;
            }
            let pushed = self.push(scratch.get(..n).unwrap_or(&[]));
            left -= pushed;
            if pushed < n {
                // Cannot happen: the window was checked for every slot of the chain.
                return Err(Error::WouldBlock);
            }
        }
        Ok(())
    }

    /// Where a FRAGMENT chain would start: after the content of the current slot if at least `min_first` inner
    /// bytes still fit there, else at the start of the next slot.
    fn first_fragment_place(&self, min_first: usize) -> (u16, usize) {
        let cur = self.last_written;
        let cur_len = self.len_of(cur);
        if cur_len > 0 && align4(cur_len) + SUBHEADER + min_first <= self.slot_capacity() {
            (cur, align4(cur_len))
        } else {
            (self.next_slot(), self.header_size)
        }
    }

    fn start_chain(&mut self, first: u16, at: usize, total: usize) {
        let old = self.len_of(first);
        self.last_written = first;
        let content = self.content_mut(first);
        if let Some(pad) = content.get_mut(old.min(at)..at) {
            pad.fill(0);
        }
        if let Some(h) = content.get_mut(at..) {
            FragmentHead { last: false, chunk_len: 0 }.set_in(h);
        }
        self.set_len(first, at + SUBHEADER, ENDS_WITH_FRAGMENT);
        self.chain = Some(Chain { seq: first, started: true, sub_at: at, remaining: total });
    }

    /// Starts a continuous fragmented submessage of `inner_total` bytes whose first bytes are `head` (the inner
    /// submessage header and request); the rest comes through [`push`](Self::push). Used by
    /// `prepare_output_stream_fragmented`.
    pub fn begin_chain(&mut self, head: &[u8], inner_total: usize) -> Result<()> {
        if self.chain.is_some() {
            return Err(Error::Busy);
        }
        if self.slot_capacity() < self.header_size + SUBHEADER + head.len() {
            return Err(Error::TooLarge);
        }
        let (first, at) = self.first_fragment_place(head.len());
        if !self.window_ok(first) {
            return Err(Error::WouldBlock);
        }
        self.start_chain(first, at, inner_total);
        let pushed = self.push(head);
        debug_assert_eq!(pushed, head.len());
        Ok(())
    }

    /// Whether a fragmented submessage is being written.
    pub const fn chain_in_progress(&self) -> bool {
        self.chain.is_some()
    }

    /// Inner bytes still expected by the fragmented submessage being written.
    pub fn chain_remaining(&self) -> usize {
        self.chain.map_or(0, |c| c.remaining)
    }

    /// Appends bytes to the fragmented submessage being written; returns how many were taken (fewer than given
    /// when the window is full: run the session and push the rest).
    pub fn push(&mut self, mut data: &[u8]) -> usize {
        let cap = self.slot_capacity();
        let hs = self.header_size;
        let mut taken = 0;
        while let Some(mut c) = self.chain {
            if c.remaining == 0 || data.is_empty() {
                break;
            }
            if !c.started {
                if !self.window_ok(c.seq) {
                    break;
                }
                if let Some(h) = self.content_mut(c.seq).get_mut(hs..) {
                    FragmentHead { last: false, chunk_len: 0 }.set_in(h);
                }
                self.set_len(c.seq, hs + SUBHEADER, ENDS_WITH_FRAGMENT);
                c.started = true;
                c.sub_at = hs;
            }
            let len = self.len_of(c.seq);
            let n = (cap - len).min(c.remaining).min(data.len());
            let (now, later) = data.split_at(n);
            if let Some(dst) = self.content_mut(c.seq).get_mut(len..len + n) {
                dst.copy_from_slice(now);
            }
            data = later;
            taken += n;
            c.remaining -= n;
            let len = len + n;
            self.set_len(c.seq, len, ENDS_WITH_FRAGMENT);
            let chunk_len = u16::try_from(len - c.sub_at - SUBHEADER).unwrap_or(0);
            if c.remaining == 0 {
                let sub_at = c.sub_at;
                if let Some(h) = self.content_mut(c.seq).get_mut(sub_at..) {
                    FragmentHead { last: true, chunk_len }.set_in(h);
                }
                // Seal the slot: nothing is appended after a FRAGMENT.
                self.last_written = c.seq.wrapping_add(1);
                self.chain = None;
                return taken;
            }
            if len == cap {
                let sub_at = c.sub_at;
                if let Some(h) = self.content_mut(c.seq).get_mut(sub_at..) {
                    FragmentHead { last: false, chunk_len }.set_in(h);
                }
                c.seq = c.seq.wrapping_add(1);
                c.started = false;
                self.last_written = c.seq;
            }
            self.chain = Some(c);
        }
        taken
    }

    /// Marks the message being filled for sending (`flash`).
    pub fn flush(&mut self) {
        self.flush = true;
    }

    /// The next message to send (a retransmission or a new one), written to `out` with its header; its length.
    pub fn poll_transmit(
        &mut self,
        session_id: u8,
        key: ClientKey,
        stream: StreamId,
        now: i64,
        out: &mut [u8],
    ) -> Option<usize> {
        let seq_nr = self.next_to_send(now)?;
        let len = self.len_of(seq_nr);
        let padded = if self.flags_of(seq_nr) & ENDS_WITH_FRAGMENT != 0 { len } else { align4(len) };
        let dst = out.get_mut(..padded)?;
        let hs = MessageHeader::new(session_id, stream, seq_nr, key).encode(dst).ok()?;
        dst.get_mut(hs..len)?.copy_from_slice(self.content(seq_nr).get(hs..len)?);
        dst.get_mut(len..padded)?.fill(0);
        Some(padded)
    }

    fn next_to_send(&mut self, now: i64) -> Option<u16> {
        if self.deferred_at.is_some_and(|at| now >= at) {
            self.release_deferred(now);
        }
        while self.resend != 0 {
            let offset = self.resend.trailing_zeros();
            self.resend &= !(1 << offset);
            let r = self.last_acknown.wrapping_add(1).wrapping_add(u16::try_from(offset).unwrap_or(0));
            if seq::le(r, self.last_sent) && self.len_of(r) > 0 {
                self.stamp(r, now, true);
                return Some(r);
            }
        }
        let s = self.last_sent.wrapping_add(1);
        if self.len_of(s) == 0 {
            if s == self.last_written {
                self.flush = false;
            }
            return None;
        }
        if s == self.last_written {
            let filling = self.chain.is_some_and(|c| c.seq == s);
            if !self.flush || filling {
                return None;
            }
            self.flush = false;
            self.last_written = s.wrapping_add(1);
        } else if !seq::lt(s, self.last_written) {
            return None;
        }
        self.last_sent = s;
        self.stamp(s, now, false);
        if self.heartbeat_deadline.is_none() {
            self.heartbeat_deadline = Some(now + self.probe_timeout());
        }
        Some(s)
    }

    /// A HEARTBEAT `(first_unacked, last_unacked)` when one is due.
    pub fn poll_heartbeat(&mut self, now: i64) -> Option<(u16, u16)> {
        if self.last_acknown == self.last_sent {
            self.heartbeat_deadline = None;
            return None;
        }
        match self.heartbeat_deadline {
            None => {
                self.heartbeat_deadline = Some(now + self.probe_timeout());
                None
            }
            Some(d) if now >= d => {
                self.probes = self.probes.saturating_add(1);
                self.heartbeat_deadline = Some(now + self.probe_timeout());
                Some((self.last_acknown.wrapping_add(1), self.last_sent))
            }
            Some(_) => None,
        }
    }

    /// When the next HEARTBEAT is due, if any.
    pub const fn heartbeat_deadline(&self) -> Option<i64> {
        self.heartbeat_deadline
    }

    /// An ACKNACK for this stream: release what is acknowledged, then schedule a resend of each NACKed message
    /// (bit i ↔ `first_unacked + i`) that is still unacknowledged and was not retransmitted within
    /// [`retransmit_interval`](Self::retransmit_interval). Without NACK bits nothing is resent.
    pub fn on_acknack(&mut self, first_unacked: u16, bitmap: u16, now: i64) {
        let acked = first_unacked.wrapping_sub(1);
        if seq::lt(self.last_acknown, acked) && seq::le(acked, self.last_sent) {
            // The oldest message released gives a round-trip sample (the ones after it may have waited for it),
            // unless a retransmission was involved in the range (Karn's rule).
            let sample = self.since_sent(self.last_acknown.wrapping_add(1), now);
            let released = acked.wrapping_sub(self.last_acknown);
            let mut clean = true;
            let mut s = self.last_acknown.wrapping_add(1);
            loop {
                clean &= self.flags_of(s) & RESENT == 0;
                self.set_len(s, 0, 0);
                if s == acked {
                    break;
                }
                s = s.wrapping_add(1);
            }
            if let (true, Some((ms, false))) = (clean, sample) {
                self.rtt_sample(u32::try_from(ms * 1000).unwrap_or(u32::MAX));
            }
            self.last_acknown = acked;
            self.probes = 0;
            self.resend = self.resend.checked_shr(u32::from(released)).unwrap_or(0);
            self.deferred = self.deferred.checked_shr(u32::from(released)).unwrap_or(0);
            if self.deferred == 0 {
                self.deferred_at = None;
            }
        }
        if bitmap != 0 {
            let interval = self.retransmit_interval();
            let first_pending = self.last_acknown.wrapping_add(1);
            for i in 0..16u16 {
                if bitmap & (1 << i) == 0 {
                    continue;
                }
                let s = first_unacked.wrapping_add(i);
                // A stale ACKNACK may name messages acknowledged since, a bogus one messages never sent.
                if !seq::le(first_pending, s) || !seq::le(s, self.last_sent) {
                    continue;
                }
                let offset = s.wrapping_sub(first_pending);
                if offset >= 16 {
                    continue;
                }
                // ACKNACKs answering messages that left before the retransmission reached the agent still
                // name it: a retransmitted message waits for the interval before going again. If no ACKNACK
                // acknowledges it meanwhile, the retransmission was lost: it goes when the interval ends.
                match self.since_sent(s, now) {
                    Some((ms, true)) if ms * NS_PER_MS < interval => {
                        self.deferred |= 1 << offset;
                        let at = now + interval - ms * NS_PER_MS;
                        self.deferred_at = Some(self.deferred_at.map_or(at, |d| d.min(at)));
                    }
                    _ => self.resend |= 1 << offset,
                }
            }
            self.deferred &= !self.resend;
        }
        let unacked = self.last_acknown != self.last_sent;
        self.heartbeat_deadline = unacked.then(|| now + self.probe_timeout());
    }

    /// Moves the deferred resends whose interval has passed to the resend set; re-arms the timer for the rest.
    fn release_deferred(&mut self, now: i64) {
        let interval = self.retransmit_interval();
        let first = self.last_acknown.wrapping_add(1);
        let mut next: Option<i64> = None;
        for offset in 0..16u16 {
            if self.deferred & (1 << offset) == 0 {
                continue;
            }
            let s = first.wrapping_add(offset);
            match self.since_sent(s, now) {
                Some((ms, _)) if ms * NS_PER_MS < interval && seq::le(s, self.last_sent) => {
                    let at = now + interval - ms * NS_PER_MS;
                    next = Some(next.map_or(at, |n| n.min(at)));
                }
                _ => {
                    self.deferred &= !(1 << offset);
                    self.resend |= 1 << offset;
                }
            }
        }
        self.deferred_at = next;
    }

    /// The earliest time this stream has something to do without new input: a HEARTBEAT or a deferred
    /// retransmission.
    pub fn timeout(&self) -> Option<i64> {
        match (self.heartbeat_deadline, self.deferred_at) {
            (Some(a), Some(b)) => Some(a.min(b)),
            (a, b) => a.or(b),
        }
    }

    /// Whether everything that can be sent was sent and acknowledged. During a continuous fragmented write the
    /// slot being filled cannot leave before more bytes come, so it does not count: the flush callback of
    /// `prepare_output_stream_fragmented` waits for exactly this.
    pub fn confirmed(&self) -> bool {
        let next = self.last_sent.wrapping_add(1);
        self.last_acknown == self.last_sent
            && match self.chain {
                Some(c) => next == c.seq,
                None => next == self.last_written && self.len_of(self.last_written) == 0,
            }
    }

    /// Whether a message waits to be (re)sent now.
    pub fn has_pending(&self) -> bool {
        let s = self.last_sent.wrapping_add(1);
        self.resend != 0 || (self.len_of(s) > 0 && (seq::lt(s, self.last_written) || self.flush))
    }
}
