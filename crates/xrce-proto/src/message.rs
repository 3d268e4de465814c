//! Whole messages: a builder that packs submessages with eProsima's 4-byte alignment, and an iterator over
//! the submessages of a received message.

use crate::cdr::{padding, Endianness, Error, Result, Writer};
use crate::header::MessageHeader;
use crate::submessage::{id, write_submessage, FromAgent, Submessage, SubmessageHeader};
use crate::view::SubmessageId;

/// Parses the header of `buf` and returns it with an iterator over the submessages that follow.
pub fn parse(buf: &[u8]) -> Result<(MessageHeader, Submessages<'_>)> {
    let (header, size) = MessageHeader::decode(buf)?;
    Ok((header, Submessages { buf, pos: size, done: false }))
}

/// A submessage located in a message, not decoded yet.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RawSubmessage<'a> {
    /// Its header.
    pub header: SubmessageHeader,
    /// The whole message (alignment origin).
    pub message: &'a [u8],
    /// Payload start in `message`.
    pub start: usize,
    /// Payload end in `message`.
    pub end: usize,
}

impl<'a> RawSubmessage<'a> {
    /// Payload bytes.
    pub fn payload(&self) -> &'a [u8] {
        self.message.get(self.start..self.end).unwrap_or(&[])
    }

    /// Decodes the payload.
    pub fn decode(&self) -> Result<Submessage<'a>> {
        Submessage::decode(self.header, self.message, self.start, self.end)
    }

    /// Decodes what a client reads of the payload ([`FromAgent`]).
    pub fn decode_from_agent(&self) -> Result<FromAgent<'a>> {
        FromAgent::decode(self.header, self.message, self.start, self.end)
    }
}

impl<'a> RawSubmessage<'a> {
    /// The whole submessage: its header, then the payload.
    pub fn bytes(&self) -> &'a [u8] {
        self.message.get(self.start.saturating_sub(SubmessageHeader::SIZE)..self.end).unwrap_or(&[])
    }

    /// Its id, if known.
    pub const fn id(&self) -> Option<SubmessageId> {
        SubmessageId::from_u8(self.header.id)
    }

    /// For a FRAGMENT, whether it completes the inner message (its LAST flag); `None` for other submessages.
    pub const fn fragment_last(&self) -> Option<bool> {
        match crate::view::FragmentHead::from_header(self.header) {
            Some(head) => Some(head.last),
            None => None,
        }
    }
}

/// Iterator over the submessages of a message, advancing by `submessageLength` and 4-byte padding.
///
/// It stops when fewer than 4 bytes remain (trailing padding), and after the first error (a length past the
/// end of the message). A WRITE_DATA of length 0 extends to the end of the message (eProsima's write-limit tweak
/// for payloads over 65535 bytes).
#[derive(Debug, Clone)]
pub struct Submessages<'a> {
    buf: &'a [u8],
    pos: usize,
    done: bool,
}

impl<'a> Submessages<'a> {
    /// Iterates over the submessages of `buf` starting at `pos` (after the header).
    pub const fn new(buf: &'a [u8], pos: usize) -> Self {
        Self { buf, pos, done: false }
    }
}

impl<'a> Iterator for Submessages<'a> {
    type Item = Result<RawSubmessage<'a>>;

    fn next(&mut self) -> Option<Self::Item> {
        if self.done {
            return None;
        }
        let pos = self.pos + padding(self.pos, 4);
        let Some(&header) = self.buf.get(pos..).and_then(|b| b.first_chunk::<4>()) else {
            self.done = true;
            return None;
        };
        let header = SubmessageHeader::from_bytes(header);
        let start = pos + SubmessageHeader::SIZE;
        let end = if header.id == id::WRITE_DATA && header.length == 0 {
            self.buf.len()
        } else {
            start + usize::from(header.length)
        };
        if end > self.buf.len() {
            self.done = true;
            return Some(Err(Error::Truncated));
        }
        self.pos = end;
        Some(Ok(RawSubmessage { header, message: self.buf, start, end }))
    }
}

/// Packs submessages into a caller's buffer after a message header.
#[derive(Debug)]
pub struct MessageBuilder<'b> {
    buf: &'b mut [u8],
    len: usize,
    header_len: usize,
    submessages: usize,
}

impl<'b> MessageBuilder<'b> {
    /// Starts a message with `header` in `buf`.
    pub fn new(buf: &'b mut [u8], header: &MessageHeader) -> Result<Self> {
        let len = header.encode(buf)?;
        Ok(Self { buf, len, header_len: len, submessages: 0 })
    }

    /// Bytes of the message so far.
    pub const fn len(&self) -> usize {
        self.len
    }

    /// Whether no submessage was added.
    pub const fn is_empty(&self) -> bool {
        self.submessages == 0
    }

    /// Size of the header.
    pub const fn header_len(&self) -> usize {
        self.header_len
    }

    /// Largest payload a submessage appended now could have.
    pub fn available_payload(&self) -> usize {
        let start = self.len + padding(self.len, 4) + SubmessageHeader::SIZE;
        self.buf.len().saturating_sub(start)
    }

    /// Appends a submessage with its payload in `endian`. On error nothing is appended; a too-small buffer
    /// reports the total message size that would have been needed.
    pub fn push(&mut self, submessage: &Submessage<'_>, endian: Endianness) -> Result<()> {
        self.push_with(endian, |w| submessage.encode(w))
    }

    /// Appends a submessage written by `f` (header included) at a 4-aligned position: the way to serialize
    /// a payload in place. `f` must write a complete submessage, as [`Submessage::encode`] does.
    pub fn push_with(&mut self, endian: Endianness, f: impl FnOnce(&mut Writer<'_>)) -> Result<()> {
        let start = self.len + padding(self.len, 4);
        let mut w = Writer::with_origin(self.buf, self.len, 0, endian);
        w.align(4);
        debug_assert_eq!(w.position(), start);
        f(&mut w);
        let end = w.finish()?;
        self.len = end;
        self.submessages += 1;
        Ok(())
    }

    /// The message built.
    pub fn as_bytes(&self) -> &[u8] {
        self.buf.get(..self.len).unwrap_or(&[])
    }

    /// Ends the message; returns its length.
    pub const fn finish(self) -> usize {
        self.len
    }
}

/// Encodes a message made of `header` and one little-endian submessage `id` whose payload `payload` writes
/// into `out`; returns its length. Links only that payload's encoder ([`write_submessage`]).
pub fn encode_single_kind(
    out: &mut [u8],
    header: &MessageHeader,
    id: u8,
    payload: impl FnOnce(&mut Writer<'_>),
) -> Result<usize> {
    // What `MessageBuilder` does for one submessage, without its bookkeeping (firmware size): a header's 4 or 8
    // bytes leave the submessage aligned.
    let hs = header.encode(out)?;
    let mut w = Writer::with_origin(out, hs, 0, Endianness::Little);
    write_submessage(&mut w, id, 0, payload);
    w.finish()
}

/// Encodes a message made of `header` and one little-endian submessage `id` whose payload is `payload`, already
/// in its wire form (a payload starts 4-aligned); returns its length, or the size needed when `out` is too
/// small. One body for every fixed-size kind, without a CDR writer (firmware size).
pub fn encode_single_bytes(out: &mut [u8], header: &MessageHeader, id: u8, payload: &[u8]) -> Result<usize> {
    encode_single_bytes_opt(out, header, id, payload).ok_or_else(|| match u16::try_from(payload.len()) {
        Ok(_) => Error::BufferTooSmall { needed: header.size() + SubmessageHeader::SIZE + payload.len() },
        Err(_) => Error::TooLong(crate::cdr::LengthField::Submessage),
    })
}

/// [`encode_single_bytes`] returning an `Option`: it comes back in registers where the `Result` goes through
/// memory (firmware size).
pub fn encode_single_bytes_opt(out: &mut [u8], header: &MessageHeader, id: u8, payload: &[u8]) -> Option<usize> {
    let length = u16::try_from(payload.len()).ok()?;
    let start = header.size() + SubmessageHeader::SIZE;
    let end = start + payload.len();
    let dst = out.get_mut(..end)?;
    let hs = header.encode(dst).ok()?;
    let sub = SubmessageHeader { id, flags: Endianness::Little.flag(), length }.to_bytes();
    if let Some(d) = dst.get_mut(hs..) {
        crate::bytes::copy(d, &sub);
    }
    if let Some(d) = dst.get_mut(start..) {
        crate::bytes::copy(d, payload);
    }
    Some(end)
}

/// Encodes a message made of `header` and one submessage into `out`; returns its length.
pub fn encode_single(
    out: &mut [u8],
    header: &MessageHeader,
    submessage: &Submessage<'_>,
    endian: Endianness,
) -> Result<usize> {
    let mut b = MessageBuilder::new(out, header)?;
    b.push(submessage, endian)?;
    Ok(b.finish())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::submessage::Heartbeat;
    use crate::types::{ClientKey, StreamId};

    #[test]
    fn builder_pads_between_submessages_and_iterator_skips_padding() {
        let mut buf = [0xEEu8; 64];
        let header = MessageHeader::new(0x81, StreamId(0), 0, ClientKey::INVALID);
        let mut b = MessageBuilder::new(&mut buf, &header).unwrap();
        let hb = Submessage::Heartbeat(Heartbeat { first_unacked_seq_nr: 0, last_unacked_seq_nr: 1, stream_id: 0x80 });
        b.push(&hb, Endianness::Little).unwrap();
        b.push(&hb, Endianness::Big).unwrap();
        let n = b.finish();
        assert_eq!(n, 4 + 9 + 3 + 9);
        assert_eq!(&buf[..13], &[0x81, 0, 0, 0, 0x0B, 0x01, 0x05, 0x00, 0x00, 0x00, 0x01, 0x00, 0x80]);
        assert_eq!(&buf[13..16], &[0, 0, 0]);
        let (_, subs) = parse(&buf[..n]).unwrap();
        let decoded: [Submessage<'_>; 2] = {
            let mut it = subs.map(|s| s.unwrap().decode().unwrap());
            [it.next().unwrap(), it.next().unwrap()]
        };
        assert_eq!(decoded, [hb, hb]);
    }

    #[test]
    fn raw_submessage_views_and_alignment() {
        assert_eq!([0, 1, 4, 5, 8].map(crate::layout::submessage_offset), [0, 4, 4, 8, 8]);
        // A HEARTBEAT, padding, then a last FRAGMENT of 2 bytes.
        let msg = [0x81, 0x80, 0, 0, 0x0B, 0x01, 5, 0, 0, 0, 1, 0, 0x80, 0, 0, 0, 0x0D, 0x03, 2, 0, 7, 8];
        let (_, mut subs) = parse(&msg).unwrap();
        let hb = subs.next().unwrap().unwrap();
        assert_eq!((hb.id(), hb.fragment_last()), (Some(SubmessageId::Heartbeat), None));
        assert_eq!(hb.bytes(), &msg[4..13]);
        let frag = subs.next().unwrap().unwrap();
        assert_eq!((frag.id(), frag.fragment_last()), (Some(SubmessageId::Fragment), Some(true)));
        assert_eq!(frag.bytes(), &msg[16..]);
        assert_eq!(frag.payload(), &[7, 8]);
    }

    #[test]
    fn too_small_buffer_reports_needed_and_keeps_message() {
        let mut buf = [0u8; 10];
        let header = MessageHeader::new(0x81, StreamId(0), 0, ClientKey::INVALID);
        let mut b = MessageBuilder::new(&mut buf, &header).unwrap();
        let hb = Submessage::Heartbeat(Heartbeat::default());
        assert_eq!(b.push(&hb, Endianness::Little), Err(Error::BufferTooSmall { needed: 13 }));
        assert_eq!(b.len(), 4);
    }

    #[test]
    fn single_bytes_is_single_kind() {
        let hb = Heartbeat { first_unacked_seq_nr: 3, last_unacked_seq_nr: 0x0102, stream_id: 0x80 };
        for session_id in [0x81, 0x01] {
            let header = MessageHeader::new(session_id, StreamId(0), 0, ClientKey([1, 2, 3, 4]));
            let (mut a, mut b) = ([0u8; 32], [0u8; 32]);
            let n = encode_single_kind(&mut a, &header, id::HEARTBEAT, |w| crate::cdr::Encode::encode(&hb, w));
            assert_eq!(encode_single_bytes(&mut b, &header, id::HEARTBEAT, &hb.to_le_bytes()), n);
            assert_eq!(a, b);
            let short = n.unwrap() - 1;
            assert_eq!(
                encode_single_bytes(&mut b[..short], &header, id::HEARTBEAT, &hb.to_le_bytes()),
                Err(Error::BufferTooSmall { needed: short + 1 })
            );
        }
    }

    #[test]
    fn length_past_end_is_an_error() {
        let msg = [0x81, 0, 0, 0, 0x0B, 0x01, 0x09, 0x00, 0, 0, 0, 0, 0];
        let (_, mut subs) = parse(&msg).unwrap();
        assert_eq!(subs.next(), Some(Err(Error::Truncated)));
        assert_eq!(subs.next(), None);
    }
}
