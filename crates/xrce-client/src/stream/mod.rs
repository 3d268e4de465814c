//! Streams (spec §9): best-effort and reliable, input and output, over caller-provided buffers.
//!
//! Each stream keeps only counters and a borrowed buffer, so a session never allocates. Reliable streams split
//! their buffer into `history` slots exactly as eProsima's C client does (a 4-byte length word per slot, the
//! rest for one message), which keeps our fragmentation byte-identical to the C client's (spec §17.12).

mod input_best_effort;
mod input_reliable;
mod output_best_effort;
mod output_reliable;

pub use input_best_effort::InputBestEffort;
pub(crate) use input_reliable::Ready as input_reliable_ready;
pub use input_reliable::{InputReliable, Ready, Received};
pub use output_best_effort::OutputBestEffort;
pub use output_reliable::{
    OutputReliable, DEFAULT_RETRANSMIT_FLOOR_NS, HEARTBEAT_PERIOD_NS, MAX_RETRANSMIT_INTERVAL_NS, PROBE_FLOOR_NS,
};

use xrce_proto::reliable::StoredFragment;
use xrce_proto::{ClientKey, MessageHeader, StreamId};

/// Serial-number arithmetic on 16-bit sequence numbers (spec §9.1), over the engine's
/// [`SeqNum`](xrce_proto::reliable::SeqNum).
pub mod seq {
    use xrce_proto::reliable::SeqNum;

    /// `a < b` in serial arithmetic: `b` is 1..=32767 ahead of `a`.
    pub const fn lt(a: u16, b: u16) -> bool {
        SeqNum(a).lt(SeqNum(b))
    }

    /// `a <= b` in serial arithmetic.
    pub const fn le(a: u16, b: u16) -> bool {
        SeqNum(a).le(SeqNum(b))
    }

    /// The later of two sequence numbers.
    pub const fn max(a: u16, b: u16) -> u16 {
        SeqNum(a).max(SeqNum(b)).0
    }

    /// Initial value of every "last" counter: the first number used is therefore 0.
    pub const INIT: u16 = SeqNum::INIT.0;
}

/// Bytes of every slot used for the length word (not on the wire), as in the C client.
pub(crate) const SLOT_LEN_WORD: usize = 4;
/// Largest submessage header.
pub(crate) const SUBHEADER: usize = xrce_proto::SubmessageHeader::SIZE;

/// Checks the history rules of the C API: a power of two that divides the buffer, each slot big enough to
/// hold a header, a submessage header and some data. Returns the slot size.
pub(crate) fn slot_size(buffer_len: usize, history: usize) -> Option<usize> {
    if history == 0 || !history.is_power_of_two() || history > 0x4000 || !buffer_len.is_multiple_of(history) {
        return None;
    }
    let slot = buffer_len / history;
    (slot >= SLOT_LEN_WORD + MessageHeader::MAX_SIZE + SUBHEADER + 4).then_some(slot)
}

/// Total length of all parts of a submessage.
pub(crate) fn parts_total(parts: &[&[u8]]) -> usize {
    parts.iter().map(|p| p.len()).sum()
}

/// Copies `parts` one after the other to the start of `dst` (as long as it holds them).
pub(crate) fn copy_parts(dst: &mut [u8], parts: &[&[u8]]) {
    let mut at = 0;
    for p in parts {
        if let Some(d) = dst.get_mut(at..at + p.len()) {
            xrce_proto::bytes::copy(d, p);
        }
        at += p.len();
    }
}

/// Writes a stored message to `out`: the header of message `seq_nr`, the stored bytes `body[hs..len]` after
/// the header's room, then zeros up to `padded`; returns `padded`. Shared by the output streams, whose
/// `poll_transmit`s are inlined into the session's (firmware size).
#[allow(clippy::too_many_arguments)]
pub(crate) fn emit(
    out: &mut [u8],
    session_id: u8,
    key: ClientKey,
    stream: StreamId,
    seq_nr: u16,
    body: &[u8],
    len: usize,
    padded: usize,
) -> Option<usize> {
    let dst = out.get_mut(..padded)?;
    let hs = MessageHeader::new(session_id, stream, seq_nr, key).encode(dst).ok()?;
    xrce_proto::bytes::copy(dst.get_mut(hs..len)?, body.get(hs..len)?);
    dst.get_mut(len..padded)?.fill(0);
    Some(padded)
}

/// Whether a stored message is fragmented and, if so, whether it carries the last fragment: the C client looks
/// only at the first submessage after the header (spec §9.4).
pub(crate) fn fragment_info(msg: &[u8]) -> Option<bool> {
    StoredFragment::parse(msg).map(|f| f.last)
}

#[cfg(test)]
mod tests {
    use super::seq;

    #[test]
    fn serial_arithmetic_wraps() {
        assert!(seq::lt(0xFFFF, 0));
        assert!(seq::lt(10, 11));
        assert!(!seq::lt(11, 10));
        assert!(seq::lt(0xFFF0, 0x0010));
        assert!(!seq::lt(5, 5));
        assert_eq!(seq::max(0xFFFF, 3), 3);
    }

    #[test]
    fn history_must_be_power_of_two_dividing_the_buffer() {
        assert_eq!(super::slot_size(4096, 8), Some(512));
        assert_eq!(super::slot_size(4096, 3), None);
        assert_eq!(super::slot_size(100, 8), None);
        assert_eq!(super::slot_size(4096, 0), None);
    }
}
