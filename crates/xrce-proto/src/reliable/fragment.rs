//! Fragmentation (spec §9.6): how a submessage too large for one message is cut into FRAGMENT chunks, and
//! how the receiver joins them again into storage the caller provides.

/// How a submessage of `total` bytes is cut: a first chunk of `first` bytes (what is left in the message
/// being filled), then chunks of `block` bytes (a whole message minus its header and the FRAGMENT header),
/// the last one taking the remainder.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FragmentPlan {
    /// Bytes in the first chunk.
    pub first: usize,
    /// Bytes in every following chunk but the last.
    pub block: usize,
}

/// One FRAGMENT's share of the submessage.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Chunk {
    /// Where it starts in the submessage.
    pub offset: usize,
    /// Its length.
    pub len: usize,
    /// Whether it is the last one (the FRAGMENT's LAST flag).
    pub last: bool,
}

impl FragmentPlan {
    /// Every chunk in its own message of at most `mtu` bytes with a header of `header_len` bytes (the agent's
    /// layout: no padding, nothing else in the message).
    pub const fn for_mtu(mtu: usize, header_len: usize) -> Self {
        let block = mtu.saturating_sub(header_len + super::FRAGMENT_HEADER);
        let block = if block == 0 { 1 } else { block };
        Self { first: block, block }
    }

    /// How many chunks `total` bytes take.
    pub const fn count(&self, total: usize) -> usize {
        if total <= self.first {
            return 1;
        }
        1 + (total - self.first).div_ceil(if self.block == 0 { 1 } else { self.block })
    }

    /// The chunks of `total` bytes, in order.
    pub const fn chunks(&self, total: usize) -> Chunks {
        Chunks { plan: *self, total, offset: 0 }
    }
}

/// Iterator over the chunks of a [`FragmentPlan`].
#[derive(Debug, Clone)]
pub struct Chunks {
    plan: FragmentPlan,
    total: usize,
    offset: usize,
}

impl Iterator for Chunks {
    type Item = Chunk;
    fn next(&mut self) -> Option<Chunk> {
        if self.offset >= self.total {
            return None;
        }
        let size = if self.offset == 0 { self.plan.first } else { self.plan.block }.max(1);
        let len = size.min(self.total - self.offset);
        let chunk = Chunk { offset: self.offset, len, last: self.offset + len == self.total };
        self.offset += len;
        Some(chunk)
    }
}

/// Where a [`Reassembler`] puts the bytes it joins.
pub trait FragmentSink {
    /// Bytes held.
    fn len(&self) -> usize;
    /// Whether nothing is held.
    fn is_empty(&self) -> bool {
        self.len() == 0
    }
    /// Appends `data`; false (nothing appended) when there is no room.
    fn extend(&mut self, data: &[u8]) -> bool;
    /// Drops everything held.
    fn clear(&mut self);
}

/// A [`FragmentSink`] over a caller's byte slice.
#[derive(Debug)]
pub struct SliceSink<'a> {
    buf: &'a mut [u8],
    len: usize,
}

impl<'a> SliceSink<'a> {
    /// An empty sink over `buf`.
    pub fn new(buf: &'a mut [u8]) -> Self {
        Self { buf, len: 0 }
    }

    /// The bytes held.
    pub fn as_slice(&self) -> &[u8] {
        self.buf.get(..self.len).unwrap_or(&[])
    }
}

impl FragmentSink for SliceSink<'_> {
    fn len(&self) -> usize {
        self.len
    }
    fn extend(&mut self, data: &[u8]) -> bool {
        match self.buf.get_mut(self.len..self.len + data.len()) {
            Some(dst) => {
                crate::bytes::copy(dst, data);
                self.len += data.len();
                true
            }
            None => false,
        }
    }
    fn clear(&mut self) {
        self.len = 0;
    }
}

/// What a FRAGMENT did to the message being reassembled.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Reassembly {
    /// More fragments are expected.
    Partial,
    /// The message is whole: the sink holds the first fragment's message header, then the joined chunks.
    Complete,
    /// The message would exceed the limit (or the sink's room): dropped; how big it would have become.
    TooLarge(usize),
}

/// Joins the chunks of consecutive FRAGMENTs of one stream, in order (the reliable stream orders them).
/// Like eProsima's agent, the rebuilt message is the first fragment's message header followed by the chunks,
/// to be parsed as a new message.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Reassembler {
    /// Length of the message header at the start of the sink, while a message is being joined.
    head: Option<usize>,
}

impl Reassembler {
    /// Whether a message is partly joined.
    pub const fn in_progress(&self) -> bool {
        self.head.is_some()
    }

    /// The joined chunks so far (after the message header), out of the sink's bytes `held`.
    pub fn body<'s>(&self, held: &'s [u8]) -> &'s [u8] {
        held.get(self.head.unwrap_or(0)..).unwrap_or(&[])
    }

    /// Takes a FRAGMENT's `chunk`; `header` is its message's header (kept from the first fragment). The
    /// whole message may take at most `limit` bytes. After [`Reassembly::Complete`] the caller takes the
    /// sink's bytes and clears it.
    pub fn push(
        &mut self,
        sink: &mut impl FragmentSink,
        header: &[u8],
        chunk: &[u8],
        last: bool,
        limit: usize,
    ) -> Reassembly {
        if self.head.is_none() {
            sink.clear();
            if !sink.extend(header) {
                return Reassembly::TooLarge(header.len() + chunk.len());
            }
            self.head = Some(header.len());
        }
        let size = sink.len() + chunk.len();
        if size > limit || !sink.extend(chunk) {
            self.abort(sink);
            return Reassembly::TooLarge(size);
        }
        if last {
            self.head = None;
            return Reassembly::Complete;
        }
        Reassembly::Partial
    }

    /// Drops the partly joined message.
    pub fn abort(&mut self, sink: &mut impl FragmentSink) {
        self.head = None;
        sink.clear();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn plan_cuts_to_the_mtu_and_the_first_chunk_fills_the_current_message() {
        let plan = FragmentPlan::for_mtu(508, 4);
        assert_eq!(plan.block, 500);
        assert_eq!(plan.count(1000), 2);
        assert_eq!(plan.count(1001), 3);
        let lens: [usize; 3] = [500, 500, 1];
        assert!(plan.chunks(1001).map(|c| c.len).eq(lens));
        assert!(plan.chunks(1001).last().is_some_and(|c| c.last && c.offset == 1000));
        let c_client = FragmentPlan { first: 40, block: 100 };
        assert_eq!(c_client.count(40), 1);
        assert_eq!(c_client.count(240), 3, "40 + 100 + 100: an exact multiple ends with a full block");
        assert_eq!(FragmentPlan::for_mtu(4, 8).block, 1, "never a zero chunk");
    }

    #[test]
    fn reassembler_joins_and_bounds() {
        let mut buf = [0u8; 16];
        let mut sink = SliceSink::new(&mut buf);
        let mut r = Reassembler::default();
        assert_eq!(r.push(&mut sink, b"HD", b"abc", false, 16), Reassembly::Partial);
        assert!(r.in_progress());
        assert_eq!(r.body(sink.as_slice()), b"abc");
        assert_eq!(r.push(&mut sink, b"xx", b"de", true, 16), Reassembly::Complete);
        assert_eq!(sink.as_slice(), b"HDabcde");
        assert_eq!(r.push(&mut sink, b"HD", b"0123456789", false, 16), Reassembly::Partial);
        assert_eq!(r.push(&mut sink, b"HD", b"0123456789", true, 16), Reassembly::TooLarge(22));
        assert!(!r.in_progress() && sink.is_empty());
    }
}
