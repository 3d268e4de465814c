//! What a side that keeps its messages in eProsima's slot layout needs from the engine (the client: one caller
//! buffer cut into `history` slots, each a length word and room for one whole message, header included):
//!
//! * [`FragmentPlan::continuing`]: the cut of a FRAGMENT chain whose first chunk goes in the message being
//!   filled, the others in a message each (spec §9.6, the C client's layout);
//! * [`StoredFragment`]: the FRAGMENT a stored message carries after its header (the only submessage the C
//!   client looks at in a fragment message);
//! * [`InPlaceJoin`]: the chunks of a run of such messages joined at the start of the very buffer that holds
//!   them, with no memory beyond it (where [`Reassembler`](super::Reassembler) copies into a separate sink).

use core::ops::Range;

use super::{FragmentPlan, FRAGMENT_HEADER};
use crate::view::FragmentHead;
use crate::MessageHeader;

impl FragmentPlan {
    /// Messages of at most `capacity` bytes with a header of `header_len` bytes, the first FRAGMENT header at
    /// offset `first_at` of the message being filled (after what it already holds, 4-aligned), every later
    /// chunk in a message of its own, right after the header.
    pub const fn continuing(capacity: usize, header_len: usize, first_at: usize) -> Self {
        let first = capacity.saturating_sub(first_at + FRAGMENT_HEADER);
        Self { first, block: Self::for_mtu(capacity, header_len).block }
    }
}

/// The FRAGMENT a whole stored message (header included) carries right after its header.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct StoredFragment {
    /// Its LAST flag: the chunk completes the inner message.
    pub last: bool,
    /// Where its chunk lies in the message, cut to the bytes present.
    pub chunk: Range<usize>,
}

impl StoredFragment {
    /// The FRAGMENT `message` starts with after its header; `None` when it starts with another submessage.
    pub fn parse(message: &[u8]) -> Option<Self> {
        let start = MessageHeader::size_of_message(message)?;
        let head = FragmentHead::parse(message.get(start..)?)?;
        let start = start + FragmentHead::SIZE;
        let end = (start + usize::from(head.chunk_len)).min(message.len());
        Some(Self { last: head.last, chunk: start..end })
    }
}

/// Joins the chunks of FRAGMENT messages held in a buffer at the start of that same buffer, in order: each
/// message must lie at or after the bytes joined before it (the C client rotates its slots so the run starts
/// at slot 0; every chunk is smaller than its slot, so the joined bytes never reach the next message). The
/// result is the inner submessages, to be parsed from offset 0.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct InPlaceJoin {
    len: usize,
}

impl InPlaceJoin {
    /// Nothing joined yet.
    pub const fn new() -> Self {
        Self { len: 0 }
    }

    /// Bytes joined so far, at the start of the buffer.
    pub const fn len(&self) -> usize {
        self.len
    }

    /// Whether nothing was joined.
    pub const fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Appends the chunk of the FRAGMENT message held at `message` in `buf`; returns its LAST flag. Nothing is
    /// appended (`None`) when `message` is not inside `buf`, does not start with a FRAGMENT after its header,
    /// or starts before the end of the bytes joined so far (they overwrote it).
    pub fn push(&mut self, buf: &mut [u8], message: Range<usize>) -> Option<bool> {
        if message.start < self.len {
            return None;
        }
        let at = message.start;
        let fragment = StoredFragment::parse(buf.get(message)?)?;
        let chunk = at + fragment.chunk.start..at + fragment.chunk.end;
        let n = chunk.len();
        // In bounds: `chunk` lies in `message`, checked above. Forwards only, as `self.len <= chunk.start`: each
        // byte is read before it is overwritten (less code than the two-way `bytes::copy_within`, firmware size).
        for i in 0..n {
            if let Some(&b) = buf.get(chunk.start + i) {
                if let Some(d) = buf.get_mut(self.len + i) {
                    *d = b;
                }
            }
        }
        self.len += n;
        Some(fragment.last)
    }

    /// The bytes joined, out of the buffer they were joined in.
    pub fn joined<'b>(&self, buf: &'b [u8]) -> &'b [u8] {
        buf.get(..self.len).unwrap_or(&[])
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{ClientKey, StreamId};

    /// A message with a FRAGMENT of `chunk` (length field `declared`) in `buf` at `at`; its length.
    fn put(buf: &mut [u8], at: usize, session_id: u8, chunk: &[u8], declared: u16, last: bool) -> usize {
        let header = MessageHeader::new(session_id, StreamId(0x80), 0, ClientKey::from_u32(0xAABB_CCDD));
        let hs = header.encode(&mut buf[at..]).unwrap();
        FragmentHead { last, chunk_len: declared }.set_in(&mut buf[at + hs..]);
        let start = at + hs + FragmentHead::SIZE;
        buf[start..start + chunk.len()].copy_from_slice(chunk);
        hs + FragmentHead::SIZE + chunk.len()
    }

    #[test]
    fn continuing_plan_is_the_c_clients_cut() {
        // 512-byte slots (508 of message), a 4-byte header, a chain starting after 40 bytes of message.
        let plan = FragmentPlan::continuing(508, 4, 40);
        assert_eq!(plan, FragmentPlan { first: 464, block: 500 });
        assert_eq!(plan.count(464 + 500 + 1), 3);
        assert_eq!(FragmentPlan::continuing(508, 8, 8).first, 496, "a chain in a fresh message");
        assert_eq!(FragmentPlan::continuing(8, 4, 8).first, 0, "never below zero");
    }

    #[test]
    fn stored_fragment_reads_either_header_size_and_cuts_the_chunk() {
        let mut buf = [0u8; 32];
        let n = put(&mut buf, 0, 0x81, b"abc", 3, true);
        assert_eq!(StoredFragment::parse(&buf[..n]), Some(StoredFragment { last: true, chunk: 8..11 }));
        let n = put(&mut buf, 0, 0x01, b"abc", 200, false);
        assert_eq!(StoredFragment::parse(&buf[..n]), Some(StoredFragment { last: false, chunk: 12..15 }));
        buf[8] = crate::submessage::id::DATA;
        assert_eq!(StoredFragment::parse(&buf[..n]), None, "not a FRAGMENT");
        assert_eq!(StoredFragment::parse(&[]), None);
    }

    #[test]
    fn join_moves_the_chunks_of_a_slot_run_to_the_start() {
        // Three 24-byte slots: a 4-byte length word (left alone here), then the message.
        let mut buf = [0xEEu8; 72];
        let a = put(&mut buf, 4, 0x81, b"0123456789", 10, false);
        let b = put(&mut buf, 28, 0x01, b"abcdefg", 7, false);
        let c = put(&mut buf, 52, 0x81, b"XY", 2, true);
        let mut join = InPlaceJoin::new();
        assert_eq!(join.push(&mut buf, 4..4 + a), Some(false));
        assert_eq!(join.push(&mut buf, 28..28 + b), Some(false));
        assert_eq!(join.push(&mut buf, 52..52 + c), Some(true));
        assert_eq!(join.joined(&buf), b"0123456789abcdefgXY");
        assert_eq!(join.len(), 19);
        // A message the joined bytes already overwrote, or outside the buffer: nothing appended.
        assert_eq!(join.push(&mut buf, 4..4 + a), None);
        assert_eq!(join.push(&mut buf, 60..80), None);
        assert_eq!(join.len(), 19);
        assert!(InPlaceJoin::new().is_empty());
    }
}
