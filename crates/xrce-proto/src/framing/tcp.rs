//! TCP framing of eProsima's TCP transport: each XRCE message is preceded by its length as a little-endian
//! `u16`. A zero length carries no message and is skipped.
//!
//! TCP delivers a byte stream, so a read may end inside the prefix or inside a message; [`TcpDecoder`] keeps
//! the partial message in a caller buffer and reports whole ones. A message larger than the buffer is
//! reported and its bytes skipped, so the stream stays in sync.

use core::fmt;

/// Size of the length prefix.
pub const PREFIX_LEN: usize = 2;
/// Largest message the 16-bit prefix can announce.
pub const MAX_MESSAGE_LEN: usize = u16::MAX as usize;

/// Errors of the TCP framing.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TcpError {
    /// The output buffer is too small; `needed` is prefix plus message.
    BufferTooSmall {
        /// Bytes the framed message needs.
        needed: usize,
    },
    /// The message does not fit the 16-bit prefix.
    MessageTooLarge {
        /// Length of the rejected message.
        len: usize,
    },
    /// A received prefix announces more than the decoder's buffer holds; that message is being skipped.
    Oversized {
        /// Announced message length.
        len: u16,
        /// Capacity of the decoder's buffer.
        capacity: usize,
    },
}

impl fmt::Display for TcpError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Self::BufferTooSmall { needed } => {
                write!(f, "output buffer too small: TCP-framed message needs {needed} bytes")
            }
            Self::MessageTooLarge { len } => {
                write!(f, "message of {len} bytes exceeds the TCP framing maximum of {MAX_MESSAGE_LEN}")
            }
            Self::Oversized { len, capacity } => {
                write!(f, "TCP length prefix announces {len} bytes, buffer holds {capacity}; message skipped")
            }
        }
    }
}

impl core::error::Error for TcpError {}

/// The length prefix for a message of `len` bytes, for senders that write prefix and message separately
/// (vectored writes) instead of copying the message.
///
/// # Errors
/// [`TcpError::MessageTooLarge`] if `len` exceeds [`MAX_MESSAGE_LEN`].
pub fn prefix(len: usize) -> Result<[u8; PREFIX_LEN], TcpError> {
    u16::try_from(len).map(u16::to_le_bytes).map_err(|_| TcpError::MessageTooLarge { len })
}

/// Writes the prefix and `msg` to the start of `out` and returns the number of bytes written.
///
/// # Errors
/// * [`TcpError::MessageTooLarge`] if `msg` exceeds [`MAX_MESSAGE_LEN`];
/// * [`TcpError::BufferTooSmall`] with the size needed if `out` is too short (nothing is written then).
pub fn encode(msg: &[u8], out: &mut [u8]) -> Result<usize, TcpError> {
    let head = prefix(msg.len())?;
    let needed = PREFIX_LEN + msg.len();
    let Some(framed) = out.get_mut(..needed) else {
        return Err(TcpError::BufferTooSmall { needed });
    };
    if let Some((head_out, body_out)) = framed.split_first_chunk_mut::<PREFIX_LEN>() {
        *head_out = head;
        crate::bytes::copy(body_out, msg);
    }
    Ok(needed)
}

/// What [`TcpDecoder::feed`] found.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TcpEvent<'a> {
    /// A whole message; borrows the decoder's buffer until the next call.
    Message(&'a [u8]),
    /// A message announced too large for the buffer ([`TcpError::Oversized`]); its bytes are skipped.
    Error(TcpError),
}

/// Counters a [`TcpDecoder`] keeps, for diagnostics. All wrap on overflow.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct TcpStats {
    /// Messages delivered.
    pub messages: u32,
    /// Zero-length prefixes skipped.
    pub empty: u32,
    /// Messages skipped because they did not fit the buffer.
    pub oversized: u32,
    /// Bytes of skipped messages.
    pub bytes_skipped: u32,
}

impl TcpStats {
    /// All counters zero.
    #[must_use]
    pub const fn new() -> Self {
        Self { messages: 0, empty: 0, oversized: 0, bytes_skipped: 0 }
    }
}

/// Where the decoder is in the stream.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum State {
    /// Expecting the prefix's first byte.
    PrefixLo,
    /// Have the first prefix byte.
    PrefixHi(u8),
    /// Copying a message body: `pos` of `len` bytes done.
    Body { len: usize, pos: usize },
    /// Discarding `remaining` bytes of an oversized message.
    Skip { remaining: usize },
}

/// Incremental decoder of the TCP framing over a message buffer `B` (`[u8; N]`, `&mut [u8]`, ...), whose
/// length is the largest message accepted.
///
/// Feed it what each `read` returned (here: a 4-byte message split over reads, an empty prefix, a 1-byte
/// message), as in
///
/// ```
/// use xrce_proto::framing::tcp::{TcpDecoder, TcpEvent};
///
/// let mut decoder = TcpDecoder::new([0u8; 512]);
/// let mut messages = 0;
/// for read in [&[0x04, 0x00, 0x81][..], &[0x00, 0x00], &[0x00, 0x00, 0x00, 0x01, 0x00, 0xAB]] {
///     let mut input = read;
///     while !input.is_empty() {
///         let (used, event) = decoder.feed(input);
///         if let Some(TcpEvent::Message(msg)) = event {
///             assert!(msg == [0x81, 0x00, 0x00, 0x00] || msg == [0xAB]);
///             messages += 1;
///         }
///         input = &input[used..];
///     }
/// }
/// assert_eq!(messages, 2);
/// ```
#[derive(Debug, Clone)]
pub struct TcpDecoder<B> {
    buf: B,
    state: State,
    /// Diagnostics; may be read or reset freely.
    pub stats: TcpStats,
}

/// A decoder owning an `N`-byte array.
pub type ArrayTcpDecoder<const N: usize> = TcpDecoder<[u8; N]>;

/// Adds to a wrapping 32-bit counter.
fn add(counter: &mut u32, n: usize) {
    // Truncation is fine: the counters wrap by design.
    *counter = counter.wrapping_add(n as u32);
}

impl<B: AsRef<[u8]> + AsMut<[u8]>> TcpDecoder<B> {
    /// A decoder expecting a length prefix, keeping messages in `buf`.
    pub const fn new(buf: B) -> Self {
        Self { buf, state: State::PrefixLo, stats: TcpStats::new() }
    }

    /// Largest message accepted: the buffer's length.
    pub fn capacity(&self) -> usize {
        self.buf.as_ref().len()
    }

    /// Whether the decoder is between messages (a connection closing now loses nothing).
    pub fn is_idle(&self) -> bool {
        self.state == State::PrefixLo
    }

    /// Forgets any partial message, e.g. on a new connection.
    pub fn reset(&mut self) {
        self.state = State::PrefixLo;
    }

    /// Gives the buffer back.
    pub fn into_inner(self) -> B {
        self.buf
    }

    /// Takes bytes from the front of `input` up to the end of the first complete message or error, and
    /// returns how many it took with that event (or all of `input` and `None`). Call again with the rest.
    #[must_use = "the count says where the rest of `input` starts"]
    pub fn feed(&mut self, input: &[u8]) -> (usize, Option<TcpEvent<'_>>) {
        let mut used = 0usize;
        while let Some(rest) = input.get(used..).filter(|rest| !rest.is_empty()) {
            match self.state {
                State::PrefixLo => {
                    self.state = State::PrefixHi(rest.first().copied().unwrap_or(0));
                    used += 1;
                }
                State::PrefixHi(lo) => {
                    let len = u16::from_le_bytes([lo, rest.first().copied().unwrap_or(0)]);
                    used += 1;
                    let capacity = self.capacity();
                    if len == 0 {
                        add(&mut self.stats.empty, 1);
                        self.state = State::PrefixLo;
                    } else if usize::from(len) > capacity {
                        add(&mut self.stats.oversized, 1);
                        self.state = State::Skip { remaining: usize::from(len) };
                        return (used, Some(TcpEvent::Error(TcpError::Oversized { len, capacity })));
                    } else {
                        self.state = State::Body { len: usize::from(len), pos: 0 };
                    }
                }
                State::Body { len, pos } => {
                    let take = (len - pos).min(rest.len());
                    if let (Some(dst), Some(src)) = (self.buf.as_mut().get_mut(pos..pos + take), rest.get(..take)) {
                        crate::bytes::copy(dst, src);
                    }
                    used += take;
                    if pos + take == len {
                        self.state = State::PrefixLo;
                        add(&mut self.stats.messages, 1);
                        let msg = self.buf.as_ref().get(..len).unwrap_or(&[]);
                        return (used, Some(TcpEvent::Message(msg)));
                    }
                    self.state = State::Body { len, pos: pos + take };
                }
                State::Skip { remaining } => {
                    let take = remaining.min(rest.len());
                    add(&mut self.stats.bytes_skipped, take);
                    used += take;
                    self.state =
                        if take == remaining { State::PrefixLo } else { State::Skip { remaining: remaining - take } };
                }
            }
        }
        (used, None)
    }

    /// Feeds all of `input`, calling `on_event` for every message and error on the way.
    pub fn push(&mut self, mut input: &[u8], mut on_event: impl FnMut(TcpEvent<'_>)) {
        while !input.is_empty() {
            let (used, event) = self.feed(input);
            if let Some(event) = event {
                on_event(event);
            }
            input = input.get(used..).unwrap_or(&[]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const GET_INFO: [u8; 16] =
        [0x80, 0x00, 0x00, 0x00, 0x02, 0x01, 0x08, 0x00, 0x00, 0x0a, 0xff, 0xfd, 0x02, 0x00, 0x00, 0x00];

    #[derive(Debug, Clone, Copy, PartialEq, Eq)]
    enum Seen {
        Message { len: usize, first: u8, last: u8 },
        Error(TcpError),
    }

    fn run<B: AsRef<[u8]> + AsMut<[u8]>>(
        decoder: &mut TcpDecoder<B>,
        input: &[u8],
        chunk: usize,
    ) -> ([Option<Seen>; 8], usize) {
        let mut seen = [None; 8];
        let mut count = 0;
        for piece in input.chunks(chunk) {
            decoder.push(piece, |event| {
                seen[count] = Some(match event {
                    TcpEvent::Message(m) => Seen::Message {
                        len: m.len(),
                        first: m.first().copied().unwrap_or(0),
                        last: m.last().copied().unwrap_or(0),
                    },
                    TcpEvent::Error(e) => Seen::Error(e),
                });
                count += 1;
            });
        }
        (seen, count)
    }

    #[test]
    fn encode_get_info() {
        let mut out = [0u8; 32];
        assert_eq!(encode(&GET_INFO, &mut out), Ok(18));
        assert_eq!(&out[..2], &[0x10, 0x00]);
        assert_eq!(&out[2..18], &GET_INFO);
        assert_eq!(prefix(0x1234), Ok([0x34, 0x12]));
    }

    #[test]
    fn encode_errors() {
        let mut out = [0u8; 17];
        assert_eq!(encode(&GET_INFO, &mut out), Err(TcpError::BufferTooSmall { needed: 18 }));
        assert_eq!(out, [0u8; 17]);
        static BIG: [u8; MAX_MESSAGE_LEN + 1] = [0; MAX_MESSAGE_LEN + 1];
        assert_eq!(encode(&BIG, &mut out), Err(TcpError::MessageTooLarge { len: 65536 }));
        assert_eq!(prefix(65536), Err(TcpError::MessageTooLarge { len: 65536 }));
        assert_eq!(prefix(65535), Ok([0xFF, 0xFF]));
    }

    #[test]
    fn partial_reads_any_split() {
        let mut wire = [0u8; 36];
        encode(&GET_INFO, &mut wire).unwrap();
        encode(&GET_INFO, &mut wire[18..]).unwrap();
        for chunk in 1..=wire.len() {
            let mut decoder = TcpDecoder::new([0u8; 16]);
            let (seen, count) = run(&mut decoder, &wire, chunk);
            assert_eq!(count, 2, "chunk {chunk}");
            for s in &seen[..2] {
                assert_eq!(*s, Some(Seen::Message { len: 16, first: 0x80, last: 0x00 }));
            }
            assert!(decoder.is_idle());
            assert_eq!(decoder.stats.messages, 2);
        }
    }

    #[test]
    fn prefix_split_then_body_in_many_reads() {
        let mut decoder = TcpDecoder::new([0u8; 64]);
        assert_eq!(decoder.feed(&[0x10]), (1, None));
        assert!(!decoder.is_idle());
        assert_eq!(decoder.feed(&[0x00]), (1, None));
        for (i, b) in GET_INFO[..15].iter().enumerate() {
            assert_eq!(decoder.feed(core::slice::from_ref(b)), (1, None), "byte {i}");
        }
        assert_eq!(decoder.feed(&GET_INFO[15..]), (1, Some(TcpEvent::Message(&GET_INFO))));
    }

    #[test]
    fn feed_stops_after_each_message() {
        let mut wire = [0u8; 40];
        let a = encode(&[1, 2, 3], &mut wire).unwrap();
        let b = encode(&[4], &mut wire[a..]).unwrap();
        let mut decoder = TcpDecoder::new([0u8; 8]);
        assert_eq!(decoder.feed(&wire[..a + b]), (a, Some(TcpEvent::Message(&[1, 2, 3]))));
        assert_eq!(decoder.feed(&wire[a..a + b]), (b, Some(TcpEvent::Message(&[4]))));
    }

    #[test]
    fn zero_length_is_skipped() {
        let wire = [0x00, 0x00, 0x00, 0x00, 0x01, 0x00, 0x7E, 0x00, 0x00];
        for chunk in 1..=wire.len() {
            let mut decoder = TcpDecoder::new([0u8; 4]);
            let (seen, count) = run(&mut decoder, &wire, chunk);
            assert_eq!(count, 1);
            assert_eq!(seen[0], Some(Seen::Message { len: 1, first: 0x7E, last: 0x7E }));
            assert_eq!(decoder.stats.empty, 3);
            assert!(decoder.is_idle());
        }
    }

    #[test]
    fn oversized_is_reported_and_skipped() {
        // 16-byte message into an 8-byte buffer, then a 3-byte one that fits.
        let mut wire = [0u8; 23];
        encode(&GET_INFO, &mut wire).unwrap();
        encode(&[9, 8, 7], &mut wire[18..]).unwrap();
        for chunk in 1..=wire.len() {
            let mut decoder = TcpDecoder::new([0u8; 8]);
            let (seen, count) = run(&mut decoder, &wire, chunk);
            assert_eq!(count, 2);
            assert_eq!(seen[0], Some(Seen::Error(TcpError::Oversized { len: 16, capacity: 8 })));
            assert_eq!(seen[1], Some(Seen::Message { len: 3, first: 9, last: 7 }));
            assert_eq!(decoder.stats.oversized, 1);
            assert_eq!(decoder.stats.bytes_skipped, 16);
        }
    }

    #[test]
    fn slice_buffer_reset_and_alias() {
        let mut storage = [0u8; 20];
        let mut decoder = TcpDecoder::new(&mut storage[..]);
        assert_eq!(decoder.capacity(), 20);
        assert_eq!(decoder.feed(&[0x05, 0x00, 1, 2]), (4, None));
        decoder.reset();
        assert!(decoder.is_idle());
        assert_eq!(decoder.feed(&[0x01, 0x00, 0x42]), (3, Some(TcpEvent::Message(&[0x42]))));
        assert_eq!(decoder.into_inner()[0], 0x42);
        let decoder: ArrayTcpDecoder<4> = TcpDecoder::new([0; 4]);
        assert_eq!(decoder.capacity(), 4);
    }

    #[test]
    fn display_is_nonempty() {
        use core::fmt::Write;
        struct Len(usize);
        impl Write for Len {
            fn write_str(&mut self, s: &str) -> fmt::Result {
                self.0 += s.len();
                Ok(())
            }
        }
        for e in [
            TcpError::BufferTooSmall { needed: 1 },
            TcpError::MessageTooLarge { len: 70000 },
            TcpError::Oversized { len: 9, capacity: 8 },
        ] {
            let mut l = Len(0);
            write!(l, "{e}").unwrap();
            assert!(l.0 > 20);
        }
    }
}
