//! The sending side of a reliable stream: acknowledgement, selective retransmission with a deferred repeat
//! policy, round-trip sampling and HEARTBEATs (spec §9.3, §9.5). The caller stores the messages and, per
//! message, when it last left and whether it was retransmitted ([`SendLog`]).
//!
//! Retransmission policy (both sides):
//! * only the sequence numbers whose NACK bit is set are resent (selective repeat); an ACKNACK without NACK
//!   bits only releases;
//! * a first retransmission is immediate; a message already retransmitted is not retransmitted again before
//!   [`Sender::retransmit_interval`] since its last transmission, `max(floor, srtt)` capped at
//!   [`MAX_RETRANSMIT_INTERVAL`]. Peers send an ACKNACK per message received, so under loss plus reordering
//!   many report the same gap; resending on each one drew more ACKNACKs and grew without bound. A NACK
//!   arriving within the interval is kept and honoured when the interval ends ([`Sender::timeout`]), unless
//!   an acknowledgement comes first;
//! * round trips are sampled from the oldest message an ACKNACK releases, unless a retransmission was
//!   involved in the released range (Karn's rule).

use super::{AckNackBits, Duration, Instant, Probe, SeqNum};

/// Default floor of the interval between two retransmissions of one message.
pub const DEFAULT_RETRANSMIT_FLOOR: Duration = Duration::from_millis(20);
/// Longest interval between two retransmissions of one message, whatever the round-trip estimate says.
pub const MAX_RETRANSMIT_INTERVAL: Duration = Duration::from_millis(1000);

/// Per-message transmission records, kept by the caller next to the messages.
pub trait SendLog {
    /// Time since message `seq` last left and whether it was ever retransmitted; `None` when it is not held
    /// or was never sent.
    fn since_sent(&self, seq: SeqNum, now: Instant) -> Option<(Duration, bool)>;
    /// Records a transmission of the held message `seq`.
    fn stamp(&mut self, seq: SeqNum, now: Instant, retransmission: bool);
    /// Message `seq` was acknowledged: [`Sender::on_acknack`] calls this for each, oldest first, once done with
    /// its record. Nothing by default.
    fn release(&mut self, _seq: SeqNum) {}
}

/// Counters and timers of a reliable output stream.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Sender {
    last_acked: SeqNum,
    last_sent: SeqNum,
    /// NACKed messages to resend now: bit i ↔ `last_acked + 1 + i`.
    resend: u16,
    /// NACKed messages retransmitted too recently, resent once their interval has passed (same bits).
    deferred: u16,
    /// When the first of `deferred` becomes due ([`Instant::NEVER`]: none).
    deferred_at: Instant,
    /// Floor of the retransmission interval, in microseconds.
    floor_us: u32,
    /// Round trip and tail-loss probe.
    pub probe: Probe,
}

impl Default for Sender {
    fn default() -> Self {
        Self::new()
    }
}

impl Sender {
    /// A stream whose first message is sequence number 0.
    pub const fn new() -> Self {
        Self {
            last_acked: SeqNum::INIT,
            last_sent: SeqNum::INIT,
            resend: 0,
            deferred: 0,
            deferred_at: Instant::NEVER,
            floor_us: (DEFAULT_RETRANSMIT_FLOOR.0 as u32),
            probe: Probe::new(),
        }
    }

    /// Restarts numbering and forgets the estimate; keeps the configured floor.
    pub fn reset(&mut self) {
        *self = Self { floor_us: self.floor_us, ..Self::new() };
    }

    /// Last message acknowledged.
    pub const fn last_acked(&self) -> SeqNum {
        self.last_acked
    }

    /// Last message sent for the first time.
    pub const fn last_sent(&self) -> SeqNum {
        self.last_sent
    }

    /// Whether messages sent are unacknowledged.
    pub const fn unacked(&self) -> bool {
        self.last_acked.0 != self.last_sent.0
    }

    /// The HEARTBEAT contents `(first_unacked, last_unacked)`, if anything is unacknowledged.
    pub fn heartbeat(&self) -> Option<(SeqNum, SeqNum)> {
        self.unacked().then(|| (self.last_acked.next(), self.last_sent))
    }

    /// Sets the floor of the retransmission interval (clamped to `0..=MAX_RETRANSMIT_INTERVAL`).
    pub fn set_retransmit_floor(&mut self, floor: Duration) {
        self.floor_us = u32::try_from(floor.0.clamp(0, MAX_RETRANSMIT_INTERVAL.0)).unwrap_or(0);
    }

    /// Minimum time between two retransmissions of one message now: `max(floor, srtt)`, capped. One round
    /// trip is how long ACKNACKs that left the peer before a retransmission reached it keep coming.
    pub fn retransmit_interval(&self) -> Duration {
        let srtt = self.probe.rtt.smoothed().unwrap_or(Duration::ZERO);
        srtt.max(Duration(i64::from(self.floor_us))).min(MAX_RETRANSMIT_INTERVAL)
    }

    /// Message `seq` (the one after [`last_sent`](Self::last_sent)) left for the first time.
    pub fn on_sent(&mut self, log: &mut impl SendLog, seq: SeqNum, now: Instant) {
        self.last_sent = seq;
        log.stamp(seq, now, false);
        self.probe.on_sent(now);
    }

    /// An ACKNACK: samples the round trip, schedules the resends it asks for (see the module) and returns how
    /// many messages it acknowledged, the oldest first from `last_acked + 1` as it was: the caller frees
    /// them *after* this call, or in [`SendLog::release`]. `period` is the HEARTBEAT period (it caps the probe timeout).
    pub fn on_acknack(&mut self, log: &mut impl SendLog, ack: AckNackBits, now: Instant, period: Duration) -> u16 {
        let acked = ack.first_unacked.sub(1);
        let mut released = 0;
        if self.last_acked.lt(acked) && acked.le(self.last_sent) {
            released = self.last_acked.distance(acked);
            // The oldest message's time since sent, unless a message released was retransmitted (or not sent).
            let mut rtt = None;
            let mut clean = true;
            let mut seq = self.last_acked;
            for i in 0..released {
                seq = seq.next();
                match log.since_sent(seq, now) {
                    Some((since, false)) => {
                        if i == 0 {
                            rtt = Some(since);
                        }
                    }
                    _ => clean = false,
                }
                log.release(seq);
            }
            if let (true, Some(rtt)) = (clean, rtt) {
                self.probe.rtt.sample(rtt);
            }
            self.last_acked = acked;
            self.probe.on_progress(now, period);
            // A u32 shift by at most 16 clears a u16 as `checked_shr` does past 15, in less code (firmware size).
            let shift = u32::from(released.min(16));
            self.resend = (u32::from(self.resend) >> shift) as u16;
            self.deferred = (u32::from(self.deferred) >> shift) as u16;
            if self.deferred == 0 {
                self.deferred_at = Instant::NEVER;
            }
        }
        let interval = self.retransmit_interval();
        let first_pending = self.last_acked.next();
        for seq in ack.nacked() {
            // A stale ACKNACK may name messages acknowledged since (their offset wraps past 32767), a bogus one
            // messages never sent.
            let offset = first_pending.distance(seq);
            if offset >= 16 || !seq.le(self.last_sent) {
                continue;
            }
            match log.since_sent(seq, now) {
                Some((since, true)) if since < interval => {
                    self.deferred |= 1 << offset;
                    self.defer_until(now + Duration(interval.0 - since.0));
                }
                _ => self.resend |= 1 << offset,
            }
        }
        self.deferred &= !self.resend;
        released
    }

    fn defer_until(&mut self, at: Instant) {
        self.deferred_at = self.deferred_at.min(at);
    }

    /// Moves the deferred resends whose interval has passed to the resend set; re-arms the timer for the rest.
    fn release_deferred(&mut self, log: &impl SendLog, now: Instant) {
        let interval = self.retransmit_interval();
        let first = self.last_acked.next();
        self.deferred_at = Instant::NEVER;
        for seq in (AckNackBits { first_unacked: first, bitmap: self.deferred }).nacked() {
            let bit = 1 << first.distance(seq);
            match log.since_sent(seq, now) {
                Some((since, _)) if since < interval && seq.le(self.last_sent) => {
                    self.defer_until(now + Duration(interval.0 - since.0));
                }
                _ => {
                    self.deferred &= !bit;
                    self.resend |= bit;
                }
            }
        }
    }

    /// The next message to retransmit now, if any; recorded as retransmitted at `now`.
    pub fn next_retransmission(&mut self, log: &mut impl SendLog, now: Instant) -> Option<SeqNum> {
        if now >= self.deferred_at {
            self.release_deferred(log, now);
        }
        while self.resend != 0 {
            // The lowest bit set (below 16: `resend` is a u16); without the `Nacked` iterator, less code.
            let seq = self.last_acked.next().add(self.resend.trailing_zeros() as u16);
            self.resend &= self.resend.wrapping_sub(1);
            if seq.le(self.last_sent) && log.since_sent(seq, now).is_some() {
                log.stamp(seq, now, true);
                return Some(seq);
            }
        }
        None
    }

    /// Whether a retransmission waits to go now.
    pub const fn has_retransmission(&self) -> bool {
        self.resend != 0
    }

    /// For a caller that polls: the HEARTBEAT to send now, if the probe is due (see [`Probe`]); arms the probe
    /// while messages are unacknowledged, disarms it otherwise.
    pub fn poll_heartbeat(&mut self, now: Instant, period: Duration) -> Option<(SeqNum, SeqNum)> {
        if !self.unacked() {
            self.probe.disarm();
            return None;
        }
        let Some(due) = self.probe.due() else {
            self.probe.arm(now, period);
            return None;
        };
        if now < due {
            return None;
        }
        match self.probe.fire(due, true, now, period) {
            Some((true, _)) => self.heartbeat(),
            _ => None,
        }
    }

    /// The earliest time something is due without new input: the probe or a deferred retransmission.
    pub fn timeout(&self) -> Option<Instant> {
        self.probe.due.min(self.deferred_at).armed()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Send times of up to 16 messages from sequence number 0, none acknowledged.
    #[derive(Default)]
    struct Log([Option<(Instant, bool)>; 16]);

    impl SendLog for Log {
        fn since_sent(&self, seq: SeqNum, now: Instant) -> Option<(Duration, bool)> {
            let (at, resent) = (*self.0.get(usize::from(seq.0))?)?;
            Some((now.since(at), resent))
        }
        fn stamp(&mut self, seq: SeqNum, now: Instant, retransmission: bool) {
            if let Some(e) = self.0.get_mut(usize::from(seq.0)) {
                *e = Some((now, e.is_some_and(|(_, r)| r) || retransmission));
            }
        }
    }

    const PERIOD: Duration = Duration::from_millis(100);
    const fn at(ms: i64) -> Instant {
        Instant(ms * 1000)
    }
    const fn ack(first: u16, bitmap: u16) -> AckNackBits {
        AckNackBits { first_unacked: SeqNum(first), bitmap }
    }

    #[test]
    fn a_repeated_nack_waits_an_interval_and_an_acknowledgement_cancels_it() {
        let (mut s, mut log) = (Sender::new(), Log::default());
        for i in 0..4 {
            s.on_sent(&mut log, SeqNum(i), at(0));
        }
        // Seq 0 acknowledged after 5 ms (a round-trip sample), 1 and 3 NACKed: both go at once.
        assert_eq!(s.on_acknack(&mut log, ack(1, 0b101), at(5), PERIOD), 1);
        assert_eq!(s.probe.rtt.min(), Some(Duration::from_millis(5)));
        assert_eq!(s.next_retransmission(&mut log, at(5)), Some(SeqNum(1)));
        assert_eq!(s.next_retransmission(&mut log, at(5)), Some(SeqNum(3)));
        assert_eq!(s.next_retransmission(&mut log, at(5)), None);
        // NACKed again 2 ms later: deferred to 20 ms after the resend.
        assert_eq!(s.on_acknack(&mut log, ack(1, 0b101), at(7), PERIOD), 0);
        assert_eq!(s.next_retransmission(&mut log, at(7)), None);
        assert_eq!(s.timeout(), Some(at(25)), "the probe is not armed: only the deferred resend");
        // Seq 1 acknowledged meanwhile: only 3 goes when the interval ends.
        assert_eq!(s.on_acknack(&mut log, ack(3, 0), at(10), PERIOD), 2);
        assert_eq!(s.next_retransmission(&mut log, at(24)), None);
        assert_eq!(s.next_retransmission(&mut log, at(25)), Some(SeqNum(3)));
        // Stale (already acknowledged) and bogus (never sent) NACKs are ignored; no resend, no release.
        assert_eq!(s.on_acknack(&mut log, ack(0, 0b1), at(30), PERIOD), 0);
        assert_eq!(s.on_acknack(&mut log, ack(9, 0b1), at(30), PERIOD), 0);
        assert!(!s.has_retransmission());
        assert_eq!(s.heartbeat(), Some((SeqNum(3), SeqNum(3))));
        // Released after a retransmission: no round-trip sample (Karn).
        assert_eq!(s.on_acknack(&mut log, ack(4, 0), at(90), PERIOD), 1);
        assert_eq!(s.probe.rtt.min(), Some(Duration::from_millis(5)));
        assert!(!s.unacked() && s.poll_heartbeat(at(200), PERIOD).is_none());
    }
}
