//! The receiving side of a reliable stream: its window, what a HEARTBEAT tells it, and the ACKNACK it
//! answers with (spec §6.10, §9.4, §9.5). Storage stays with the caller, asked through closures.

use super::SeqNum;

/// The contents of an ACKNACK: the first sequence number not yet received in order, and which of the 16
/// following are missing (bit i ↔ `first_unacked + i`, the big-endian reading of the wire's two bytes).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct AckNackBits {
    /// Everything before it is acknowledged.
    pub first_unacked: SeqNum,
    /// NACK bitmap.
    pub bitmap: u16,
}

impl AckNackBits {
    /// From the wire's fields.
    pub const fn from_wire(first_unacked: u16, nack_bitmap: [u8; 2]) -> Self {
        Self { first_unacked: SeqNum(first_unacked), bitmap: u16::from_be_bytes(nack_bitmap) }
    }

    /// The wire's bitmap bytes.
    pub const fn nack_bitmap(self) -> [u8; 2] {
        self.bitmap.to_be_bytes()
    }

    /// The sequence numbers asked for again, in order.
    pub const fn nacked(self) -> Nacked {
        Nacked { first: self.first_unacked, bits: self.bitmap }
    }
}

/// Iterator over the sequence numbers an ACKNACK asks for again.
#[derive(Debug, Clone)]
pub struct Nacked {
    first: SeqNum,
    bits: u16,
}

impl Iterator for Nacked {
    type Item = SeqNum;
    fn next(&mut self) -> Option<SeqNum> {
        if self.bits == 0 {
            return None;
        }
        let i = self.bits.trailing_zeros();
        self.bits &= self.bits.wrapping_sub(1);
        // `i` < 16: the bitmap is a u16.
        Some(self.first.add(i as u16))
    }
}

/// Counters of a reliable input stream: the last message handled in order and the latest the peer said it
/// sent. The stream's depth and its stored messages are the caller's.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct InputWindow {
    /// Last message handled in order.
    pub last_handled: SeqNum,
    /// Latest sequence number seen or announced by a HEARTBEAT.
    pub last_announced: SeqNum,
}

impl Default for InputWindow {
    fn default() -> Self {
        Self::new()
    }
}

impl InputWindow {
    /// A stream expecting sequence number 0.
    pub const fn new() -> Self {
        Self { last_handled: SeqNum::INIT, last_announced: SeqNum::INIT }
    }

    /// The next message in order.
    pub const fn next(&self) -> SeqNum {
        self.last_handled.next()
    }

    /// Notes message `seq` (accepted or not): it exists, so what precedes it and is not stored is missing.
    /// Returns whether it falls in the window of `depth` messages.
    pub fn on_message(&mut self, seq: SeqNum, depth: u16) -> bool {
        self.last_announced = self.last_announced.max(seq);
        seq.in_window(self.last_handled, depth)
    }

    /// A HEARTBEAT's `last_unacked`: the peer sent up to it.
    pub fn on_heartbeat(&mut self, last_unacked: SeqNum) {
        self.last_announced = self.last_announced.max(last_unacked);
    }

    /// A HEARTBEAT's `first_unacked`: the peer no longer holds what precedes it, so waiting for it is vain
    /// (the agent's rule, spec §9.5). Returns how many messages were given up.
    pub fn give_up_before(&mut self, first_unacked: SeqNum) -> u16 {
        if !self.next().lt(first_unacked) {
            return 0;
        }
        let skipped = self.next().distance(first_unacked);
        self.last_handled = first_unacked.sub(1);
        skipped
    }

    /// The ACKNACK from `first` (the first message not received in order): bit i set while `first + i` has
    /// been announced and `missing` says so.
    pub fn acknack(&self, first: SeqNum, mut missing: impl FnMut(SeqNum) -> bool) -> AckNackBits {
        let mut bitmap = 0u16;
        let mut seq = first;
        for i in 0..16 {
            if self.last_announced.lt(seq) {
                break;
            }
            if missing(seq) {
                bitmap |= 1 << i;
            }
            seq = seq.next();
        }
        AckNackBits { first_unacked: first, bitmap }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn acknack_names_the_missing_announced_messages() {
        let mut w = InputWindow::new();
        assert!(w.on_message(SeqNum(2), 16));
        assert!(!w.on_message(SeqNum(20), 16), "outside the window");
        let ack = w.acknack(w.next(), |s| s != SeqNum(2));
        assert_eq!(ack.first_unacked, SeqNum(0));
        assert_eq!(ack.bitmap, 0xFFFB, "0, 1 and 3..=15 missing; 16.. beyond the bitmap");
        let nacked: [u16; 3] = [0, 1, 3];
        assert!(ack.nacked().map(|s| s.0).take(3).eq(nacked));
        assert_eq!(ack.nacked().count(), 15);
        assert_eq!(AckNackBits::from_wire(0, ack.nack_bitmap()), ack);
        // Nothing announced past the first: empty bitmap.
        let fresh = InputWindow::new();
        assert_eq!(fresh.acknack(fresh.next(), |_| true).bitmap, 0);
    }

    #[test]
    fn heartbeat_gives_up_on_what_the_peer_dropped() {
        let mut w = InputWindow::new();
        w.on_heartbeat(SeqNum(9));
        assert_eq!(w.give_up_before(SeqNum(5)), 5);
        assert_eq!(w.next(), SeqNum(5));
        assert_eq!(w.give_up_before(SeqNum(3)), 0, "never backwards");
        assert_eq!(w.acknack(w.next(), |_| true).bitmap, 0b11111);
    }
}
