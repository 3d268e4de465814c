//! Reliable output stream (spec §9.3) and its fragmentation (§9.6), as eProsima's C client does them.
//!
//! The buffer is split into `history` slots; slot `seq mod history` holds message `seq`. A message can be
//! written only while its slot is inside the window (`seq - last_acknown <= history`); when it is not, writes
//! fail with [`Error::WouldBlock`] instead of stalling. An ACKNACK releases slots.
//!
//! Acknowledgement, retransmission and HEARTBEATs are the shared engine's ([`xrce_proto::reliable::Sender`],
//! the agent runs the same): selective repeat of the NACKed messages only, a repeat deferred until
//! `max(floor, srtt)` has passed since the last send (the floor defaults to [`DEFAULT_RETRANSMIT_FLOOR_NS`],
//! [`OutputReliable::set_retransmit_floor`]), and tail-loss probes: the C client's 100 ms HEARTBEAT period
//! until a round trip is known, then `max(2 × smallest round trip, PROBE_FLOOR_NS)` after the last send or
//! progress, doubling while unanswered up to the period. The C client instead resends its whole window on
//! every NACK (go-back-N, spec §9.3 step 4), which under loss plus reordering grew without bound; the wire is
//! unchanged, the agent sees ordinary, byte-identical resends.
//!
//! Each slot's 4-byte length word (not on the wire, as in the C client) holds the message length (2 bytes) and
//! 2 bytes of bookkeeping the engine reads through [`SendLog`]: whether the message ends with a FRAGMENT,
//! whether it was sent and retransmitted, and the time of its last transmission in milliseconds modulo 8192.
//! Slot capacity, and so the fragmentation layout, stay exactly the C client's.

use super::{copy_parts, parts_total, seq, slot_size, SLOT_LEN_WORD, SUBHEADER};
use crate::error::{Error, Result};
use xrce_proto::layout::submessage_offset;
use xrce_proto::reliable::{AckNackBits, Duration, FragmentPlan, Instant, SendLog, Sender, SeqNum};
use xrce_proto::view::FragmentHead;
use xrce_proto::{ClientKey, StreamId};

/// Heartbeat period of the C client (`UCLIENT_MIN_HEARTBEAT_TIME_INTERVAL`), in nanoseconds.
pub const HEARTBEAT_PERIOD_NS: i64 = 100_000_000;
const PERIOD: Duration = Duration::from_nanos(HEARTBEAT_PERIOD_NS);

/// Shortest probe timeout: a HEARTBEAT never follows a send sooner, however short the round trip.
pub const PROBE_FLOOR_NS: i64 = xrce_proto::reliable::PROBE_FLOOR.as_nanos();

/// Default floor of the interval between two retransmissions of one message, in nanoseconds.
pub const DEFAULT_RETRANSMIT_FLOOR_NS: i64 = xrce_proto::reliable::DEFAULT_RETRANSMIT_FLOOR.as_nanos();
/// Longest interval between two retransmissions of one message, whatever the round-trip estimate says.
pub const MAX_RETRANSMIT_INTERVAL_NS: i64 = xrce_proto::reliable::MAX_RETRANSMIT_INTERVAL.as_nanos();

/// Slot flag: the message ends with a FRAGMENT, so it is sent without trailing padding.
const ENDS_WITH_FRAGMENT: u16 = 0x01;
/// Slot flag: the message was sent; the time stamp is valid.
const SENT: u16 = 0x02;
/// Slot flag: the message was retransmitted at least once (no round-trip sample from its acknowledgement).
const RESENT: u16 = 0x04;
/// Slot bits holding the time of the last transmission, in milliseconds modulo 8192.
const STAMP_SHIFT: u16 = 3;
const STAMP_MASK: u16 = 0x1FFF;

/// Milliseconds modulo 8192 at `now`.
fn stamp_ms(now: Instant) -> u16 {
    // Masked to 13 bits: always fits.
    (xrce_proto::reliable::div_floor_pow1000(now.0, 1).0 & i64::from(STAMP_MASK)) as u16
}

/// A fragmented submessage being written.
#[derive(Debug, Clone, Copy)]
struct Chain {
    /// Slot of the first FRAGMENT (for reconnection's take-out of unacknowledged messages).
    #[cfg(feature = "reconnect")]
    first: u16,
    /// Slot receiving bytes.
    seq: u16,
    /// Whether the FRAGMENT header of `seq` is written (it waits for the window otherwise).
    started: bool,
    /// Offset of that FRAGMENT header in the slot's message.
    sub_at: usize,
    /// Inner bytes still to write.
    remaining: usize,
}

/// The caller's buffer cut into `history` slots, each a 4-byte length word (message length, then the
/// bookkeeping flags and time stamp) and room for one message.
#[derive(Debug)]
struct Slots<'a> {
    buf: &'a mut [u8],
    history: u16,
    slot: usize,
    /// [`stamp_ms`] of the `now` the engine is being called with, computed once per call (firmware size).
    now_ms: u16,
}

impl Slots<'_> {
    fn word_at(&self, seq_nr: u16, half: usize) -> u16 {
        let at = usize::from(seq_nr & (self.history - 1)) * self.slot + half;
        self.buf.get(at..).and_then(<[u8]>::first_chunk::<2>).map_or(0, |w| u16::from_le_bytes(*w))
    }

    fn set_word(&mut self, seq_nr: u16, half: usize, v: u16) {
        let at = usize::from(seq_nr & (self.history - 1)) * self.slot + half;
        if let Some(dst) = self.buf.get_mut(at..).and_then(<[u8]>::first_chunk_mut::<2>) {
            *dst = v.to_le_bytes();
        }
    }

    // Inlined at its callers: 8 bytes less on a Cortex-M4.
    #[inline(always)]
    fn flags(&self, seq_nr: u16) -> u16 {
        self.word_at(seq_nr, 2)
    }

    /// Sets the message length and flags of slot `seq_nr`.
    fn set(&mut self, seq_nr: u16, len: usize, flags: u16) {
        let word = u32::from(u16::try_from(len).unwrap_or(0)) | u32::from(flags) << 16;
        let at = usize::from(seq_nr & (self.history - 1)) * self.slot;
        if let Some(dst) = self.buf.get_mut(at..).and_then(<[u8]>::first_chunk_mut::<SLOT_LEN_WORD>) {
            *dst = word.to_le_bytes();
        }
    }

    /// The message area of slot `seq_nr`.
    #[cfg(feature = "reconnect")]
    fn content(&self, seq_nr: u16) -> &[u8] {
        let at = usize::from(seq_nr & (self.history - 1)) * self.slot + SLOT_LEN_WORD;
        self.buf.get(at..at + self.slot - SLOT_LEN_WORD).unwrap_or(&[])
    }

    fn content_mut(&mut self, seq_nr: u16) -> &mut [u8] {
        let at = usize::from(seq_nr & (self.history - 1)) * self.slot + SLOT_LEN_WORD;
        self.buf.get_mut(at..at + self.slot - SLOT_LEN_WORD).unwrap_or(&mut [])
    }
}

// The engine passes on the `now` of the call `now_ms` was set for: both ignore it and read `now_ms`.
impl SendLog for Slots<'_> {
    // Inlined at its five callers: out of line it cost a Cortex-M4 114 more bytes (C library), 132 (Rust).
    #[inline(always)]
    fn since_sent(&self, seq: SeqNum, _now: Instant) -> Option<(Duration, bool)> {
        let flags = self.flags(seq.0);
        if flags & SENT == 0 {
            return None;
        }
        let elapsed = self.now_ms.wrapping_sub(flags >> STAMP_SHIFT) & STAMP_MASK;
        // Below 8192 ms: a 32-bit product, no saturation needed (firmware size).
        Some((Duration(i64::from(u32::from(elapsed) * 1000)), flags & RESENT != 0))
    }

    // Inlined at its two callers: out of line it cost a Cortex-M4 110 more bytes (C library), 92 (Rust).
    #[inline(always)]
    fn stamp(&mut self, seq: SeqNum, _now: Instant, retransmission: bool) {
        let old = self.flags(seq.0);
        let resent = if retransmission { RESENT } else { old & RESENT };
        self.set_word(seq.0, 2, (old & ENDS_WITH_FRAGMENT) | SENT | resent | (self.now_ms << STAMP_SHIFT));
    }

    fn release(&mut self, seq: SeqNum) {
        self.set(seq.0, 0, 0);
    }
}

/// A reliable output stream over a caller's buffer.
#[derive(Debug)]
pub struct OutputReliable<'a> {
    slots: Slots<'a>,
    /// Message header size (4 or 8; a byte keeps the session small).
    header_size: u8,
    last_written: u16,
    /// Acknowledgement, retransmission and probe state (the shared engine).
    sender: Sender,
    flush: bool,
    chain: Option<Chain>,
}

impl<'a> OutputReliable<'a> {
    /// A stream over `buf` with `history` slots (a power of two dividing the buffer), for messages whose header
    /// takes `header_size` bytes.
    pub fn new(buf: &'a mut [u8], history: usize, header_size: usize) -> Result<Self> {
        let slot = slot_size(buf.len(), history).ok_or(Error::InvalidHistory)?;
        let history = u16::try_from(history).map_err(|_| Error::InvalidHistory)?;
        let header_size = u8::try_from(header_size).map_err(|_| Error::InvalidHistory)?;
        let mut s = Self {
            slots: Slots { buf, history, slot, now_ms: 0 },
            header_size,
            last_written: 0,
            sender: Sender::new(),
            flush: false,
            chain: None,
        };
        s.reset();
        Ok(s)
    }

    /// Drops everything and restarts numbering (session (re)creation).
    pub fn reset(&mut self) {
        // Zeroing the whole buffer (one memset) clears every length word in less code than a loop over them.
        self.slots.buf.fill(0);
        self.last_written = 0;
        self.sender.reset();
        self.flush = false;
        self.chain = None;
    }

    /// Renumbers what is not acknowledged from sequence number 0, for a session the agent re-created (its
    /// streams restart at 0): the slots rotate in place so the first unacknowledged message takes slot 0, and
    /// every message counts as never sent. Nothing is lost and the order is kept; a fragmented write in progress
    /// goes on where it was.
    pub fn rebase(&mut self) {
        let first = self.sender.last_acked().next().0;
        let history = self.slots.history;
        let shift = usize::from(first & (history - 1)) * self.slots.slot;
        xrce_proto::bytes::rotate_left(self.slots.buf, shift);
        self.last_written = self.last_written.wrapping_sub(first);
        if let Some(c) = self.chain.as_mut() {
            #[cfg(feature = "reconnect")]
            {
                c.first = c.first.wrapping_sub(first);
            }
            c.seq = c.seq.wrapping_sub(first);
        }
        for seq_nr in 0..history {
            let flags = self.slots.flags(seq_nr);
            self.slots.set_word(seq_nr, 2, flags & ENDS_WITH_FRAGMENT);
        }
        self.sender.reset();
    }

    /// Hands every message not acknowledged yet (written, sent or not) to `visit` in order, as its bytes after
    /// the message header and whether it ends with a FRAGMENT, then resets the stream. With
    /// [`restore_message`](Self::restore_message) this lets a caller put other messages in front of them. A
    /// fragmented write in progress is abandoned with all its fragments (its later pushes take nothing).
    #[cfg(feature = "reconnect")]
    pub fn take_messages(&mut self, mut visit: impl FnMut(&[u8], bool)) {
        let hs = self.header_len();
        let mut seq_nr = self.sender.last_acked().next().0;
        loop {
            let len = self.len_of(seq_nr);
            if len == 0 || self.chain.is_some_and(|c| c.first == seq_nr) {
                break;
            }
            let ends_with_fragment = self.slots.flags(seq_nr) & ENDS_WITH_FRAGMENT != 0;
            visit(self.slots.content(seq_nr).get(hs..len).unwrap_or(&[]), ends_with_fragment);
            if seq_nr == self.last_written {
                break;
            }
            seq_nr = seq_nr.wrapping_add(1);
        }
        self.reset();
    }

    /// Appends one whole message (its bytes after the header, as [`take_messages`](Self::take_messages) gave
    /// them) in a slot of its own, marked for sending. [`Error::WouldBlock`] when the window has no free slot.
    #[cfg(feature = "reconnect")]
    pub fn restore_message(&mut self, body: &[u8], ends_with_fragment: bool) -> Result<()> {
        if self.chain.is_some() {
            return Err(Error::Busy);
        }
        let hs = self.header_len();
        if hs + body.len() > self.slot_capacity() {
            return Err(Error::TooLarge);
        }
        let target = Self::next_after(self.last_written, self.len_of(self.last_written));
        if !self.window_ok(target) {
            return Err(Error::WouldBlock);
        }
        if let Some(dst) = self.content_mut(target).get_mut(hs..hs + body.len()) {
            xrce_proto::bytes::copy(dst, body);
        }
        self.set_len(target, hs + body.len(), if ends_with_fragment { ENDS_WITH_FRAGMENT } else { 0 });
        // Nothing is appended after a FRAGMENT; a plain message may take more submessages.
        self.last_written = if ends_with_fragment { target.wrapping_add(1) } else { target };
        self.flush = true;
        Ok(())
    }

    /// Sets the floor of the interval between two retransmissions of one message (nanoseconds; default
    /// [`DEFAULT_RETRANSMIT_FLOOR_NS`], capped at [`MAX_RETRANSMIT_INTERVAL_NS`]). The interval used is the
    /// larger of this floor and the round-trip estimate.
    pub fn set_retransmit_floor(&mut self, floor_ns: i64) {
        self.sender.set_retransmit_floor(Duration::from_nanos(floor_ns));
    }

    /// The smoothed round-trip estimate in nanoseconds, once an acknowledgement gave one.
    pub fn srtt(&self) -> Option<i64> {
        self.sender.probe.rtt.smoothed().map(Duration::as_nanos)
    }

    /// Minimum time between two retransmissions of one message now (nanoseconds): `max(floor, srtt)`, capped.
    pub fn retransmit_interval(&self) -> i64 {
        self.sender.retransmit_interval().as_nanos()
    }

    /// How long after a send (or the last HEARTBEAT) the next HEARTBEAT goes out: `max(2 × smallest round
    /// trip, PROBE_FLOOR_NS)` doubled per unanswered HEARTBEAT, at most [`HEARTBEAT_PERIOD_NS`]; that period
    /// until a round trip has been sampled.
    pub fn probe_timeout(&self) -> i64 {
        self.sender.probe.timeout(PERIOD).as_nanos()
    }

    const fn header_len(&self) -> usize {
        self.header_size as usize
    }

    /// Bytes of message a slot holds (header included): the slot minus its length word.
    pub const fn slot_capacity(&self) -> usize {
        self.slots.slot - SLOT_LEN_WORD
    }

    /// Largest submessage (header included) that fits one message.
    pub const fn max_unfragmented(&self) -> usize {
        self.slot_capacity() - self.header_len()
    }

    /// Length of message `seq_nr`; 0 outside the window, where the slot still belongs to an older message.
    fn len_of(&self, seq_nr: u16) -> usize {
        if !self.window_ok(seq_nr) {
            return 0;
        }
        usize::from(self.slots.word_at(seq_nr, 0))
    }

    fn set_len(&mut self, seq_nr: u16, len: usize, flags: u16) {
        self.slots.set(seq_nr, len, flags);
    }

    fn content_mut(&mut self, seq_nr: u16) -> &mut [u8] {
        self.slots.content_mut(seq_nr)
    }

    /// Whether message `seq_nr` may be written: its slot no longer holds an unacknowledged message.
    fn window_ok(&self, seq_nr: u16) -> bool {
        SeqNum(seq_nr).in_window(self.sender.last_acked(), self.slots.history)
    }

    /// The message after `cur`, of length `cur_len`: itself while empty.
    const fn next_after(cur: u16, cur_len: usize) -> u16 {
        if cur_len == 0 {
            cur
        } else {
            cur.wrapping_add(1)
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
        let (target, at) = if cur_len > 0 && submessage_offset(cur_len) + total <= cap {
            (cur, submessage_offset(cur_len))
        } else if self.header_len() + total <= cap {
            let next = Self::next_after(cur, cur_len);
            if !self.window_ok(next) {
                return Err(Error::WouldBlock);
            }
            (next, self.header_len())
        } else {
            return Ok(None);
        };
        self.last_written = target;
        self.set_len(target, at + total, 0);
        let content = self.content_mut(target);
        // From the end of the current message: in the next one (`cur_len` past its header) there is nothing to pad.
        if let Some(pad) = content.get_mut(cur_len.min(at)..at) {
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
        let total = parts_total(parts);
        if let Some(region) = self.reserve(total)? {
            copy_parts(region, parts);
            return Ok(());
        }
        let (first, first_off) = self.whole_chain_place(1, total)?;
        self.start_chain(first, first_off, total);
        for p in parts {
            if self.push(p) < p.len() {
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
        if cur_len > 0 && submessage_offset(cur_len) + SUBHEADER + min_first <= self.slot_capacity() {
            (cur, submessage_offset(cur_len))
        } else {
            (Self::next_after(cur, cur_len), self.header_len())
        }
    }

    /// [`first_fragment_place`](Self::first_fragment_place) for a chain of `total` inner bytes that must fit the
    /// free history whole: [`Error::WouldBlock`] when the window lacks slots now, [`Error::TooLarge`] when the
    /// history could never hold it.
    fn whole_chain_place(&self, min_first: usize, total: usize) -> Result<(u16, usize)> {
        let (first, first_off) = self.first_fragment_place(min_first);
        let plan = FragmentPlan::continuing(self.slot_capacity(), self.header_len(), first_off);
        let extra = plan.count(total) - 1;
        if extra >= usize::from(self.slots.history) {
            return Err(Error::TooLarge);
        }
        let last = first.wrapping_add(u16::try_from(extra).map_err(|_| Error::TooLarge)?);
        if !self.window_ok(first) || !self.window_ok(last) {
            return Err(Error::WouldBlock);
        }
        Ok((first, first_off))
    }

    /// Writes an empty FRAGMENT header at `at` in message `seq_nr` (after zero padding from its content).
    fn open_fragment(&mut self, seq_nr: u16, at: usize) {
        let old = self.len_of(seq_nr);
        let content = self.content_mut(seq_nr);
        if let Some(pad) = content.get_mut(old.min(at)..at) {
            pad.fill(0);
        }
        if let Some(h) = content.get_mut(at..) {
            FragmentHead { last: false, chunk_len: 0 }.set_in(h);
        }
        self.set_len(seq_nr, at + SUBHEADER, ENDS_WITH_FRAGMENT);
    }

    fn start_chain(&mut self, first: u16, at: usize, total: usize) {
        self.last_written = first;
        self.open_fragment(first, at);
        self.chain = Some(Chain {
            #[cfg(feature = "reconnect")]
            first,
            seq: first,
            started: true,
            sub_at: at,
            remaining: total,
        });
    }

    /// Starts a continuous fragmented submessage of `inner_total` bytes whose first bytes are `head` (the inner
    /// submessage header and request); the rest comes through [`push`](Self::push). Used by
    /// `prepare_output_stream_fragmented`.
    pub fn begin_chain(&mut self, head: &[u8], inner_total: usize) -> Result<()> {
        if self.chain.is_some() {
            return Err(Error::Busy);
        }
        if self.slot_capacity() < self.header_len() + SUBHEADER + head.len() {
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

    /// [`begin_chain`](Self::begin_chain) for a submessage that must fit the free history whole, as
    /// `write_parts` checks it: [`Error::WouldBlock`] when the window lacks slots now, [`Error::TooLarge`]
    /// when the history could never hold it. Pushing its `inner_total` bytes then never blocks. Used by
    /// `uxr_prepare_output_stream` of the C library for a sample larger than a message.
    pub fn begin_chain_whole(&mut self, head: &[u8], inner_total: usize) -> Result<()> {
        if self.chain.is_some() {
            return Err(Error::Busy);
        }
        self.whole_chain_place(head.len(), inner_total)?;
        self.begin_chain(head, inner_total)
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
        let hs = self.header_len();
        let mut taken = 0;
        while let Some(mut c) = self.chain {
            if c.remaining == 0 || data.is_empty() {
                break;
            }
            if !c.started {
                if !self.window_ok(c.seq) {
                    break;
                }
                // A fresh slot: the padding only zeroes its header's place, never sent from here.
                self.open_fragment(c.seq, hs);
                c.started = true;
                c.sub_at = hs;
            }
            let len = self.len_of(c.seq);
            let n = (cap - len).min(c.remaining).min(data.len());
            let (now, later) = data.split_at(n);
            if let Some(dst) = self.content_mut(c.seq).get_mut(len..len + n) {
                xrce_proto::bytes::copy(dst, now);
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
        let seq_nr = self.next_to_send(Instant::from_nanos(now))?;
        let len = self.len_of(seq_nr);
        let padded = if self.slots.flags(seq_nr) & ENDS_WITH_FRAGMENT != 0 { len } else { submessage_offset(len) };
        // Through the out-of-line `content_mut`: less code than `content` inlined here (firmware size).
        super::emit(out, session_id, key, stream, seq_nr, self.content_mut(seq_nr), len, padded)
    }

    fn next_to_send(&mut self, now: Instant) -> Option<u16> {
        self.slots.now_ms = stamp_ms(now);
        if let Some(r) = self.sender.next_retransmission(&mut self.slots, now) {
            return Some(r.0);
        }
        let s = self.sender.last_sent().next().0;
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
        self.sender.on_sent(&mut self.slots, SeqNum(s), now);
        self.sender.probe.arm(now, PERIOD);
        Some(s)
    }

    /// A HEARTBEAT `(first_unacked, last_unacked)` when one is due.
    pub fn poll_heartbeat(&mut self, now: i64) -> Option<(u16, u16)> {
        self.sender.poll_heartbeat(Instant::from_nanos(now), PERIOD).map(|(f, l)| (f.0, l.0))
    }

    /// When the next HEARTBEAT is due, if any.
    pub const fn heartbeat_deadline(&self) -> Option<i64> {
        match self.sender.probe.due() {
            Some(due) => Some(due.as_nanos()),
            None => None,
        }
    }

    /// An ACKNACK for this stream: release what is acknowledged, then schedule a resend of each NACKed message
    /// (bit i ↔ `first_unacked + i`) that is still unacknowledged and was not retransmitted within
    /// [`retransmit_interval`](Self::retransmit_interval). Without NACK bits nothing is resent.
    // Out of line: inlined into the session's submessage loop it cost a Cortex-M4 52 more bytes (registers).
    #[inline(never)]
    pub fn on_acknack(&mut self, first_unacked: u16, bitmap: u16, now: i64) {
        let ack = AckNackBits { first_unacked: SeqNum(first_unacked), bitmap };
        let now = Instant::from_nanos(now);
        self.slots.now_ms = stamp_ms(now);
        // The engine frees the acknowledged slots (`SendLog::release`).
        self.sender.on_acknack(&mut self.slots, ack, now, PERIOD);
    }

    /// The earliest time this stream has something to do without new input: a HEARTBEAT or a deferred
    /// retransmission.
    pub fn timeout(&self) -> Option<i64> {
        self.sender.timeout().map(Instant::as_nanos)
    }

    /// Whether everything that can be sent was sent and acknowledged. During a continuous fragmented write the
    /// slot being filled cannot leave before more bytes come, so it does not count: the flush callback of
    /// `prepare_output_stream_fragmented` waits for exactly this.
    pub fn confirmed(&self) -> bool {
        let next = self.sender.last_sent().next().0;
        !self.sender.unacked()
            && match self.chain {
                Some(c) => next == c.seq,
                None => next == self.last_written && self.len_of(self.last_written) == 0,
            }
    }

    /// Whether a message waits to be (re)sent now.
    pub fn has_pending(&self) -> bool {
        let s = self.sender.last_sent().next().0;
        self.sender.has_retransmission() || (self.len_of(s) > 0 && (seq::lt(s, self.last_written) || self.flush))
    }
}
