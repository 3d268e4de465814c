//! HDLC-like stream framing of eProsima's serial transport (and of custom transports created with framing).
//!
//! A frame on the wire is
//!
//! ```text
//! 0x7E | src_addr | dst_addr | len (u16 LE) | payload (len bytes) | crc (u16 LE)
//!      \____________________________ escaped _______________________________/
//! ```
//!
//! Every byte after the flag that equals `0x7E` (flag) or `0x7D` (escape) is sent as `0x7D, byte ^ 0x20`, so an
//! unescaped `0x7E` only ever starts a frame. The CRC is [CRC-16/ARC](super::crc) over the *unescaped payload
//! only* (not the addresses or the length). There is no closing flag: the length says where the frame ends.
//!
//! [`encode_frame`] writes one frame into a caller buffer; [`FrameBytes`] yields the same bytes one at a time
//! for senders without a buffer. [`FrameDecoder`] takes the received byte stream in chunks of any size and
//! reports whole frames and framing errors, resynchronising on the next flag after any error.

use core::fmt;

use super::crc::Crc16;

/// Starts every frame; never appears unescaped inside one.
pub const FLAG: u8 = 0x7E;
/// Announces that the next byte was xored with [`ESCAPE_XOR`].
pub const ESCAPE: u8 = 0x7D;
/// What an escaped byte was xored with.
pub const ESCAPE_XOR: u8 = 0x20;
/// Unescaped bytes between the flag and the payload: source and destination address, 2-byte length.
pub const HEADER_LEN: usize = 4;
/// Unescaped bytes after the payload: the CRC.
pub const CRC_LEN: usize = 2;
/// The length field is 16 bits wide, which bounds the payload.
pub const MAX_PAYLOAD_LEN: usize = u16::MAX as usize;

/// Errors of the serial framing, from both the encoder and the decoder.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FrameError {
    /// The output buffer is too small; `needed` is the exact encoded size of this frame.
    BufferTooSmall {
        /// Bytes the frame needs.
        needed: usize,
    },
    /// The payload does not fit the 16-bit length field.
    PayloadTooLarge {
        /// Length of the rejected payload.
        len: usize,
    },
    /// A received frame's checksum does not match its payload; the frame was dropped.
    Crc {
        /// CRC computed over the received payload.
        computed: u16,
        /// CRC carried by the frame.
        received: u16,
    },
    /// A received frame announces more payload than the decoder's buffer holds; the frame was dropped.
    Oversized {
        /// Announced payload length.
        len: u16,
        /// Capacity of the decoder's buffer.
        capacity: usize,
    },
    /// An unescaped flag arrived before the frame in progress was complete; that frame was dropped and a new
    /// one started at the flag.
    Interrupted,
}

impl fmt::Display for FrameError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Self::BufferTooSmall { needed } => write!(f, "output buffer too small: serial frame needs {needed} bytes"),
            Self::PayloadTooLarge { len } => {
                write!(f, "payload of {len} bytes exceeds the serial frame maximum of {MAX_PAYLOAD_LEN}")
            }
            Self::Crc { computed, received } => {
                write!(f, "serial frame CRC mismatch: computed {computed:#06x}, received {received:#06x}")
            }
            Self::Oversized { len, capacity } => {
                write!(f, "serial frame announces {len} payload bytes, buffer holds {capacity}")
            }
            Self::Interrupted => f.write_str("serial frame interrupted by a new frame flag"),
        }
    }
}

impl core::error::Error for FrameError {}

/// Whether a byte must be escaped after the flag.
const fn needs_escape(byte: u8) -> bool {
    byte == FLAG || byte == ESCAPE
}

/// Upper bound of the encoded size of a frame with `payload_len` payload bytes (every byte escaped), for
/// sizing buffers at compile time. Saturates instead of overflowing.
#[must_use]
pub const fn max_encoded_len(payload_len: usize) -> usize {
    let body = HEADER_LEN.saturating_add(payload_len).saturating_add(CRC_LEN);
    body.saturating_mul(2).saturating_add(1)
}

/// Exact encoded size of the frame [`encode_frame`] would write, escapes included.
///
/// # Errors
/// [`FrameError::PayloadTooLarge`] if `payload` exceeds [`MAX_PAYLOAD_LEN`].
pub fn encoded_len(src: u8, dst: u8, payload: &[u8]) -> Result<usize, FrameError> {
    Ok(FrameBytes::new(src, dst, payload)?.count())
}

/// Encodes one frame from `src` to `dst` carrying `payload` into the start of `out` and returns its length.
///
/// # Errors
/// * [`FrameError::PayloadTooLarge`] if `payload` exceeds [`MAX_PAYLOAD_LEN`];
/// * [`FrameError::BufferTooSmall`] with the exact size needed if `out` is too short (what was written to
///   `out` is then unspecified).
pub fn encode_frame(src: u8, dst: u8, payload: &[u8], out: &mut [u8]) -> Result<usize, FrameError> {
    let mut written = 0usize;
    for byte in FrameBytes::new(src, dst, payload)? {
        if let Some(slot) = out.get_mut(written) {
            *slot = byte;
        }
        // Keep counting past the end of `out` to report the size needed.
        written += 1;
    }
    if written > out.len() {
        Err(FrameError::BufferTooSmall { needed: written })
    } else {
        Ok(written)
    }
}

/// The bytes of one encoded frame, produced one at a time, for senders that write straight to a UART or
/// FIFO without an intermediate buffer. Yields exactly what [`encode_frame`] writes.
#[derive(Debug, Clone)]
pub struct FrameBytes<'a> {
    header: [u8; HEADER_LEN],
    payload: &'a [u8],
    crc: [u8; CRC_LEN],
    /// Index of the next unescaped byte: 0 is the flag, then header, payload, CRC.
    next: usize,
    /// Second byte of an escape sequence still to be yielded.
    pending: Option<u8>,
}

impl<'a> FrameBytes<'a> {
    /// Prepares the frame; computes the CRC up front.
    ///
    /// # Errors
    /// [`FrameError::PayloadTooLarge`] if `payload` exceeds [`MAX_PAYLOAD_LEN`].
    pub fn new(src: u8, dst: u8, payload: &'a [u8]) -> Result<Self, FrameError> {
        let len = u16::try_from(payload.len()).map_err(|_| FrameError::PayloadTooLarge { len: payload.len() })?;
        let [len_lo, len_hi] = len.to_le_bytes();
        let crc = Crc16::new().update(payload).finish();
        Ok(Self { header: [src, dst, len_lo, len_hi], payload, crc: crc.to_le_bytes(), next: 0, pending: None })
    }

    /// The unescaped byte at `index` counted from the flag, or `None` past the end.
    fn unescaped(&self, index: usize) -> Option<u8> {
        let body = index.checked_sub(1)?;
        if let Some(&b) = self.header.get(body) {
            return Some(b);
        }
        let in_payload = body - HEADER_LEN;
        if let Some(&b) = self.payload.get(in_payload) {
            return Some(b);
        }
        self.crc.get(in_payload - self.payload.len()).copied()
    }
}

impl Iterator for FrameBytes<'_> {
    type Item = u8;

    fn next(&mut self) -> Option<u8> {
        if let Some(b) = self.pending.take() {
            return Some(b);
        }
        if self.next == 0 {
            self.next = 1;
            return Some(FLAG);
        }
        let byte = self.unescaped(self.next)?;
        self.next += 1;
        if needs_escape(byte) {
            self.pending = Some(byte ^ ESCAPE_XOR);
            Some(ESCAPE)
        } else {
            Some(byte)
        }
    }

    fn size_hint(&self) -> (usize, Option<usize>) {
        let total = 1 + HEADER_LEN + self.payload.len() + CRC_LEN;
        let left = total.saturating_sub(self.next) + usize::from(self.pending.is_some());
        (left, Some(left.saturating_mul(2)))
    }
}

impl core::iter::FusedIterator for FrameBytes<'_> {}

/// Which destination addresses a [`FrameDecoder`] delivers.
///
/// On a shared line (RS-485, multiserial) every node sees every frame; eProsima drops frames addressed
/// elsewhere right after reading the destination byte, and so does the decoder with [`Only`](Self::Only).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AddressFilter {
    /// Deliver frames whatever their destination (sniffers, point-to-point links, tests).
    Any,
    /// Deliver only frames whose destination is this local address.
    Only(u8),
}

impl AddressFilter {
    /// Whether a frame sent to `dst` passes.
    #[must_use]
    pub const fn accepts(self, dst: u8) -> bool {
        match self {
            Self::Any => true,
            Self::Only(local) => local == dst,
        }
    }
}

/// What [`FrameDecoder::feed`] found.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Event<'a> {
    /// A complete frame with a good CRC; `payload` borrows the decoder's buffer until the next call.
    Frame {
        /// Sender's address.
        src: u8,
        /// Receiver's address (the local one, unless the filter is [`AddressFilter::Any`]).
        dst: u8,
        /// The unescaped payload: one XRCE message.
        payload: &'a [u8],
    },
    /// A frame was dropped ([`FrameError::Crc`], [`FrameError::Oversized`] or [`FrameError::Interrupted`]);
    /// the decoder is already hunting for the next one.
    Error(FrameError),
}

/// Counters a [`FrameDecoder`] keeps, for link diagnostics. All wrap on overflow.
///
/// Every byte fed is counted once in `bytes_received` and ends up either in `bytes_in_frames`, in
/// `bytes_dropped` or in the frame still in progress ([`FrameDecoder::pending_len`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct SerialStats {
    /// Raw bytes fed to the decoder.
    pub bytes_received: u32,
    /// Raw bytes (flag and escapes included) of frames delivered.
    pub bytes_in_frames: u32,
    /// Raw bytes discarded: garbage between frames, frames rejected or addressed elsewhere.
    pub bytes_dropped: u32,
    /// Frames delivered.
    pub frames_ok: u32,
    /// Frames dropped for a CRC mismatch.
    pub crc_errors: u32,
    /// Frames dropped because their payload would not fit the buffer.
    pub oversized: u32,
    /// Frames cut short by a new flag.
    pub interrupted: u32,
    /// Frames ignored because of their destination address.
    pub filtered: u32,
}

impl SerialStats {
    /// All counters zero.
    #[must_use]
    pub const fn new() -> Self {
        Self {
            bytes_received: 0,
            bytes_in_frames: 0,
            bytes_dropped: 0,
            frames_ok: 0,
            crc_errors: 0,
            oversized: 0,
            interrupted: 0,
            filtered: 0,
        }
    }
}

/// Position of the decoder inside a frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum State {
    /// Outside a frame, waiting for a flag.
    Hunting,
    Src,
    Dst,
    LenLo,
    LenHi,
    Payload,
    CrcLo,
    CrcHi,
}

/// What one byte did to a [`FrameParser`].
#[derive(Debug, Clone, Copy)]
enum Step {
    /// Skipped while hunting for a flag.
    Skip,
    /// A flag: a frame starts; `interrupted` if one was in progress past its flag.
    Start { interrupted: bool },
    /// Taken into the frame in progress.
    Byte,
    /// The frame's destination is not the filter's: dropped.
    Filtered,
    /// The frame announces more payload than the buffer holds: dropped.
    Oversized { len: u16, capacity: usize },
    /// The frame's CRC does not match: dropped.
    Crc { computed: u16, received: u16 },
    /// A whole frame with a good CRC, its payload this long.
    Frame(usize),
}

/// The serial framing's state machine alone: no counters and no error reports (bad frames are dropped, and
/// parsing resumes at the next flag, as in [`FrameDecoder`]). For transports that only want the frames, one
/// byte at a time (firmware size).
///
/// ```
/// use xrce_proto::framing::serial::{encode_frame, AddressFilter, FrameParser};
///
/// let mut wire = [0u8; 64];
/// let n = encode_frame(1, 0, &[0x80, 0x00, 0x00, 0x00], &mut wire).unwrap();
/// let mut parser = FrameParser::new([0u8; 512], AddressFilter::Only(0));
/// let mut frames = 0;
/// for &b in &wire[..n] {
///     if let Some((src, payload)) = parser.push_byte(b) {
///         assert_eq!((src, payload), (1, &[0x80, 0x00, 0x00, 0x00][..]));
///         frames += 1;
///     }
/// }
/// assert_eq!(frames, 1);
/// ```
#[derive(Debug, Clone)]
pub struct FrameParser<B> {
    buf: B,
    filter: AddressFilter,
    state: State,
    /// The previous byte was an escape.
    escaped: bool,
    src: u8,
    dst: u8,
    len: u16,
    pos: usize,
    crc: Crc16,
    crc_lo: u8,
}

impl<B: AsRef<[u8]> + AsMut<[u8]>> FrameParser<B> {
    /// A parser hunting for its first flag, storing payloads in `buf` (the largest payload accepted) and
    /// delivering frames that pass `filter`.
    pub const fn new(buf: B, filter: AddressFilter) -> Self {
        Self {
            buf,
            filter,
            state: State::Hunting,
            escaped: false,
            src: 0,
            dst: 0,
            len: 0,
            pos: 0,
            crc: Crc16::new(),
            crc_lo: 0,
        }
    }

    /// Takes one raw byte; the sender's address and the payload when it completes a good frame (the payload
    /// borrows the parser's buffer until the next byte).
    pub fn push_byte(&mut self, raw: u8) -> Option<(u8, &[u8])> {
        match self.step(raw) {
            Step::Frame(len) => Some((self.src, self.buf.as_ref().get(..len).unwrap_or(&[]))),
            _ => None,
        }
    }

    /// Forgets any frame in progress and hunts for the next flag.
    pub fn reset(&mut self) {
        self.state = State::Hunting;
        self.escaped = false;
    }

    /// Processes one raw byte.
    fn step(&mut self, raw: u8) -> Step {
        if raw == FLAG {
            // Anything after a previous flag is lost; only report it if there was more than that flag (a
            // frame still at its source byte has taken nothing else, unless an escape).
            let interrupted = self.state != State::Hunting && (self.state != State::Src || self.escaped);
            self.state = State::Src;
            self.escaped = false;
            self.pos = 0;
            self.crc = Crc16::new();
            return Step::Start { interrupted };
        }
        if self.state == State::Hunting {
            return Step::Skip;
        }
        if raw == ESCAPE && !self.escaped {
            self.escaped = true;
            return Step::Byte;
        }
        // Like eProsima, any byte after an escape is unescaped by the xor, not only 0x5E and 0x5D.
        let byte = if self.escaped { raw ^ ESCAPE_XOR } else { raw };
        self.escaped = false;
        match self.state {
            State::Hunting => {}
            State::Src => {
                self.src = byte;
                self.state = State::Dst;
            }
            State::Dst => {
                self.dst = byte;
                if !self.filter.accepts(byte) {
                    self.state = State::Hunting;
                    return Step::Filtered;
                }
                self.state = State::LenLo;
            }
            State::LenLo => {
                self.len = u16::from(byte);
                self.state = State::LenHi;
            }
            State::LenHi => {
                self.len |= u16::from(byte) << 8;
                let capacity = self.buf.as_ref().len();
                if usize::from(self.len) > capacity {
                    self.state = State::Hunting;
                    return Step::Oversized { len: self.len, capacity };
                }
                self.state = if self.len == 0 { State::CrcLo } else { State::Payload };
            }
            State::Payload => {
                if let Some(slot) = self.buf.as_mut().get_mut(self.pos) {
                    *slot = byte;
                }
                self.crc.update_byte(byte);
                self.pos += 1;
                if self.pos >= usize::from(self.len) {
                    self.state = State::CrcLo;
                }
            }
            State::CrcLo => {
                self.crc_lo = byte;
                self.state = State::CrcHi;
            }
            State::CrcHi => {
                self.state = State::Hunting;
                let received = u16::from_le_bytes([self.crc_lo, byte]);
                let computed = self.crc.finish();
                if received != computed {
                    return Step::Crc { computed, received };
                }
                return Step::Frame(usize::from(self.len));
            }
        }
        Step::Byte
    }
}

/// What one byte completed, before it is turned into a borrowing [`Event`].
enum Outcome {
    Frame(usize),
    Error(FrameError),
}

/// Incremental decoder of the serial framing over a payload buffer `B` (`[u8; N]`, `&mut [u8]`, ...), so it
/// allocates nothing. The buffer's length is the largest payload it accepts.
///
/// Bytes go in as they arrive, in chunks of any size, through [`feed`](Self::feed) (one event at a time, for
/// a loop) or [`push`](Self::push) (a callback per event). Garbage before a flag is skipped, an unescaped flag
/// anywhere restarts the frame, and after any error the decoder hunts for the next flag. A [`FrameParser`]
/// that also reports errors and keeps counters.
///
/// ```
/// use xrce_proto::framing::serial::{encode_frame, AddressFilter, Event, FrameDecoder};
///
/// let mut wire = [0u8; 64];
/// let n = encode_frame(1, 0, &[0x80, 0x00, 0x00, 0x00], &mut wire).unwrap();
/// let mut decoder = FrameDecoder::new([0u8; 512], AddressFilter::Only(0));
/// let mut input = &wire[..n];
/// while !input.is_empty() {
///     let (used, event) = decoder.feed(input);
///     if let Some(Event::Frame { src, payload, .. }) = event {
///         assert_eq!((src, payload), (1, &[0x80, 0x00, 0x00, 0x00][..]));
///     }
///     input = &input[used..];
/// }
/// assert_eq!(decoder.stats.frames_ok, 1);
/// ```
#[derive(Debug, Clone)]
pub struct FrameDecoder<B> {
    parser: FrameParser<B>,
    /// Raw bytes of the frame in progress, flag included.
    raw_in_frame: usize,
    /// Diagnostics; may be read or reset freely.
    pub stats: SerialStats,
}

/// A decoder owning an `N`-byte array.
pub type ArrayFrameDecoder<const N: usize> = FrameDecoder<[u8; N]>;

/// Adds a byte count to a wrapping 32-bit counter.
fn add(counter: &mut u32, n: usize) {
    // Truncation is fine: the counters wrap by design.
    *counter = counter.wrapping_add(n as u32);
}

impl<B: AsRef<[u8]> + AsMut<[u8]>> FrameDecoder<B> {
    /// A decoder hunting for its first flag, storing payloads in `buf` and delivering frames that pass
    /// `filter`.
    pub const fn new(buf: B, filter: AddressFilter) -> Self {
        Self { parser: FrameParser::new(buf, filter), raw_in_frame: 0, stats: SerialStats::new() }
    }

    /// Largest payload accepted: the buffer's length.
    pub fn capacity(&self) -> usize {
        self.parser.buf.as_ref().len()
    }

    /// The destination filter in use.
    pub const fn filter(&self) -> AddressFilter {
        self.parser.filter
    }

    /// Changes the destination filter; applies from the next frame's destination byte on.
    pub fn set_filter(&mut self, filter: AddressFilter) {
        self.parser.filter = filter;
    }

    /// Raw bytes of an incomplete frame held back (0 when between frames).
    pub const fn pending_len(&self) -> usize {
        self.raw_in_frame
    }

    /// Forgets any frame in progress (counting its bytes as dropped) and hunts for the next flag, e.g. after
    /// the port was reopened.
    pub fn reset(&mut self) {
        self.drop_frame();
        self.parser.reset();
    }

    /// Gives the buffer back.
    pub fn into_inner(self) -> B {
        self.parser.buf
    }

    /// Takes bytes from the front of `input` up to the first one that completes an event, and returns how
    /// many it took with that event (or all of `input` and `None`). Call again with the rest of `input` until
    /// it is empty; incomplete frames carry over to the next call.
    #[must_use = "the count says where the rest of `input` starts"]
    pub fn feed(&mut self, input: &[u8]) -> (usize, Option<Event<'_>>) {
        for (i, &raw) in input.iter().enumerate() {
            if let Some(outcome) = self.step(raw) {
                let event = match outcome {
                    Outcome::Frame(len) => {
                        let p = &self.parser;
                        Event::Frame { src: p.src, dst: p.dst, payload: p.buf.as_ref().get(..len).unwrap_or(&[]) }
                    }
                    Outcome::Error(error) => Event::Error(error),
                };
                return (i + 1, Some(event));
            }
        }
        (input.len(), None)
    }

    /// Feeds all of `input`, calling `on_event` for every frame and error on the way.
    pub fn push(&mut self, mut input: &[u8], mut on_event: impl FnMut(Event<'_>)) {
        while !input.is_empty() {
            let (used, event) = self.feed(input);
            if let Some(event) = event {
                on_event(event);
            }
            input = input.get(used..).unwrap_or(&[]);
        }
    }

    /// Counts the bytes of the frame in progress as dropped.
    fn drop_frame(&mut self) {
        add(&mut self.stats.bytes_dropped, self.raw_in_frame);
        self.raw_in_frame = 0;
    }

    /// Processes one raw byte: the parser's step, counted.
    fn step(&mut self, raw: u8) -> Option<Outcome> {
        add(&mut self.stats.bytes_received, 1);
        let step = self.parser.step(raw);
        if !matches!(step, Step::Skip | Step::Start { .. }) {
            self.raw_in_frame += 1;
        }
        let (counter, outcome) = match step {
            Step::Byte => return None,
            Step::Skip => {
                add(&mut self.stats.bytes_dropped, 1);
                return None;
            }
            Step::Start { interrupted } => {
                self.drop_frame();
                self.raw_in_frame = 1;
                if !interrupted {
                    return None;
                }
                (&mut self.stats.interrupted, Outcome::Error(FrameError::Interrupted))
            }
            Step::Filtered => {
                add(&mut self.stats.filtered, 1);
                self.drop_frame();
                return None;
            }
            Step::Oversized { len, capacity } => {
                self.drop_frame();
                (&mut self.stats.oversized, Outcome::Error(FrameError::Oversized { len, capacity }))
            }
            Step::Crc { computed, received } => {
                self.drop_frame();
                (&mut self.stats.crc_errors, Outcome::Error(FrameError::Crc { computed, received }))
            }
            Step::Frame(len) => {
                add(&mut self.stats.bytes_in_frames, self.raw_in_frame);
                self.raw_in_frame = 0;
                (&mut self.stats.frames_ok, Outcome::Frame(len))
            }
        };
        add(counter, 1);
        Some(outcome)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const CREATE_CLIENT: [u8; 24] = [
        0x80, 0x00, 0x00, 0x00, 0x00, 0x01, 0x10, 0x00, 0x58, 0x52, 0x43, 0x45, 0x01, 0x00, 0x01, 0x0F, 0xAA, 0xBB,
        0xCC, 0xDD, 0x81, 0x00, 0xFC, 0x01,
    ];
    const CREATE_CLIENT_FRAME: [u8; 31] = [
        0x7E, 0x00, 0x00, 0x18, 0x00, 0x80, 0x00, 0x00, 0x00, 0x00, 0x01, 0x10, 0x00, 0x58, 0x52, 0x43, 0x45, 0x01,
        0x00, 0x01, 0x0F, 0xAA, 0xBB, 0xCC, 0xDD, 0x81, 0x00, 0xFC, 0x01, 0x3E, 0x8F,
    ];
    const ESCAPED_PAYLOAD: [u8; 8] = [0x81, 0x00, 0x00, 0x00, 0x7E, 0x7D, 0x20, 0x00];
    const ESCAPED_FRAME: [u8; 17] =
        [0x7E, 0x00, 0x00, 0x08, 0x00, 0x81, 0x00, 0x00, 0x00, 0x7D, 0x5E, 0x7D, 0x5D, 0x20, 0x00, 0x58, 0x5C];

    /// What a test saw, copied out of the decoder.
    #[derive(Debug, Clone, Copy, PartialEq, Eq)]
    enum Seen {
        Frame { src: u8, dst: u8, len: usize, first: u8 },
        Error(FrameError),
    }

    /// Feeds `input` in chunks of `chunk` bytes and records up to 8 events.
    fn run<B: AsRef<[u8]> + AsMut<[u8]>>(
        decoder: &mut FrameDecoder<B>,
        input: &[u8],
        chunk: usize,
    ) -> ([Option<Seen>; 8], usize) {
        let mut seen = [None; 8];
        let mut count = 0;
        for piece in input.chunks(chunk) {
            decoder.push(piece, |event| {
                let s = match event {
                    Event::Frame { src, dst, payload } => {
                        Seen::Frame { src, dst, len: payload.len(), first: payload.first().copied().unwrap_or(0) }
                    }
                    Event::Error(e) => Seen::Error(e),
                };
                seen[count] = Some(s);
                count += 1;
            });
        }
        (seen, count)
    }

    fn check_invariant<B: AsRef<[u8]> + AsMut<[u8]>>(decoder: &FrameDecoder<B>) {
        let s = decoder.stats;
        assert_eq!(
            s.bytes_received as usize,
            s.bytes_in_frames as usize + s.bytes_dropped as usize + decoder.pending_len()
        );
    }

    #[test]
    fn encode_create_client_vector() {
        let mut out = [0u8; 64];
        let n = encode_frame(0, 0, &CREATE_CLIENT, &mut out).unwrap();
        assert_eq!(&out[..n], &CREATE_CLIENT_FRAME);
        assert_eq!(encoded_len(0, 0, &CREATE_CLIENT), Ok(31));
        assert!(FrameBytes::new(0, 0, &CREATE_CLIENT).unwrap().eq(CREATE_CLIENT_FRAME.iter().copied()));
    }

    #[test]
    fn encode_escaped_vector() {
        let mut out = [0u8; 64];
        let n = encode_frame(0, 0, &ESCAPED_PAYLOAD, &mut out).unwrap();
        assert_eq!(&out[..n], &ESCAPED_FRAME);
    }

    #[test]
    fn encode_reports_needed_size() {
        let mut small = [0u8; 16];
        assert_eq!(encode_frame(0, 0, &ESCAPED_PAYLOAD, &mut small), Err(FrameError::BufferTooSmall { needed: 17 }));
        let mut exact = [0u8; 17];
        assert_eq!(encode_frame(0, 0, &ESCAPED_PAYLOAD, &mut exact), Ok(17));
        assert_eq!(encode_frame(0, 0, &[], &mut [0u8; 0]), Err(FrameError::BufferTooSmall { needed: 7 }));
    }

    #[test]
    fn encode_rejects_payload_over_u16() {
        static BIG: [u8; MAX_PAYLOAD_LEN + 1] = [0; MAX_PAYLOAD_LEN + 1];
        assert_eq!(encode_frame(0, 0, &BIG, &mut [0u8; 8]), Err(FrameError::PayloadTooLarge { len: 65536 }));
        assert_eq!(encoded_len(0, 0, &BIG), Err(FrameError::PayloadTooLarge { len: 65536 }));
        assert!(encoded_len(0, 0, &BIG[..MAX_PAYLOAD_LEN]).is_ok());
    }

    #[test]
    fn max_encoded_len_bounds() {
        assert_eq!(max_encoded_len(0), 13);
        let all_flags = [FLAG; 10];
        // Addresses, length and CRC of this frame are all escaped too.
        let n = encoded_len(FLAG, ESCAPE, &all_flags).unwrap();
        assert!(n <= max_encoded_len(10));
        assert_eq!(max_encoded_len(usize::MAX), usize::MAX);
    }

    #[test]
    fn decode_vectors_any_chunking() {
        for chunk in 1..=CREATE_CLIENT_FRAME.len() {
            let mut decoder = FrameDecoder::new([0u8; 64], AddressFilter::Only(0));
            let (seen, count) = run(&mut decoder, &CREATE_CLIENT_FRAME, chunk);
            assert_eq!(count, 1);
            assert_eq!(seen[0], Some(Seen::Frame { src: 0, dst: 0, len: 24, first: 0x80 }));
            check_invariant(&decoder);
        }
        let mut decoder = FrameDecoder::new([0u8; 8], AddressFilter::Any);
        let (used, event) = decoder.feed(&ESCAPED_FRAME);
        assert_eq!(used, ESCAPED_FRAME.len());
        assert_eq!(event, Some(Event::Frame { src: 0, dst: 0, payload: &ESCAPED_PAYLOAD }));
    }

    #[test]
    fn parser_drops_bad_frames_silently() {
        // A frame cut by a flag, one with a bad CRC, one for another address, then a good one.
        let mut bad = CREATE_CLIENT_FRAME;
        bad[10] ^= 0x01;
        let mut other = [0u8; 64];
        let n = encode_frame(0, 1, &CREATE_CLIENT, &mut other).unwrap();
        let mut wire = [0u8; 160];
        wire[..12].copy_from_slice(&CREATE_CLIENT_FRAME[..12]);
        wire[12..43].copy_from_slice(&bad);
        wire[43..43 + n].copy_from_slice(&other[..n]);
        wire[43 + n..74 + n].copy_from_slice(&CREATE_CLIENT_FRAME);
        let mut parser = FrameParser::new([0u8; 64], AddressFilter::Only(0));
        let mut frames = 0;
        for &b in &wire[..74 + n] {
            if let Some((src, payload)) = parser.push_byte(b) {
                assert_eq!((src, payload), (0, &CREATE_CLIENT[..]));
                frames += 1;
            }
        }
        assert_eq!(frames, 1);
        let mut small = FrameParser::new([0u8; 16], AddressFilter::Any);
        assert!(CREATE_CLIENT_FRAME.iter().all(|&b| small.push_byte(b).is_none()));
        let frame = ESCAPED_FRAME.iter().filter_map(|&b| small.push_byte(b).map(|(_, p)| p.len())).next();
        assert_eq!(frame, Some(8));
        small.push_byte(FLAG);
        small.reset();
        assert!(ESCAPED_FRAME[1..].iter().all(|&b| small.push_byte(b).is_none()));
    }

    #[test]
    fn feed_stops_at_each_event() {
        let mut wire = [0u8; 62];
        wire[..31].copy_from_slice(&CREATE_CLIENT_FRAME);
        wire[31..].copy_from_slice(&CREATE_CLIENT_FRAME);
        let mut decoder = FrameDecoder::new([0u8; 32], AddressFilter::Any);
        let (used, event) = decoder.feed(&wire);
        assert_eq!(used, 31);
        assert!(matches!(event, Some(Event::Frame { payload, .. }) if payload == CREATE_CLIENT));
        let (used, event) = decoder.feed(&wire[31..]);
        assert_eq!(used, 31);
        assert!(event.is_some());
        assert_eq!(decoder.feed(&[]), (0, None));
        assert_eq!(decoder.stats.frames_ok, 2);
        assert_eq!(decoder.stats.bytes_in_frames, 62);
    }

    #[test]
    fn garbage_before_flag_is_skipped() {
        let mut wire = [0u8; 40];
        let garbage = [0x00, 0x55, 0x7D, 0xFF, 0x18, 0x7D, 0x5E];
        wire[..7].copy_from_slice(&garbage);
        wire[7..38].copy_from_slice(&CREATE_CLIENT_FRAME);
        for chunk in [1, 3, 40] {
            let mut decoder = FrameDecoder::new([0u8; 64], AddressFilter::Only(0));
            let (seen, count) = run(&mut decoder, &wire[..38], chunk);
            assert_eq!(count, 1);
            assert_eq!(seen[0], Some(Seen::Frame { src: 0, dst: 0, len: 24, first: 0x80 }));
            assert_eq!(decoder.stats.bytes_dropped, 7);
            check_invariant(&decoder);
        }
    }

    #[test]
    fn crc_error_is_reported_and_decoder_resyncs() {
        let mut bad = CREATE_CLIENT_FRAME;
        bad[10] ^= 0x01;
        let mut wire = [0u8; 62];
        wire[..31].copy_from_slice(&bad);
        wire[31..].copy_from_slice(&CREATE_CLIENT_FRAME);
        let mut decoder = FrameDecoder::new([0u8; 64], AddressFilter::Any);
        let (seen, count) = run(&mut decoder, &wire, 5);
        assert_eq!(count, 2);
        assert_eq!(seen[0], Some(Seen::Error(FrameError::Crc { computed: crc16_of(&bad[5..29]), received: 0x8F3E })));
        assert_eq!(seen[1], Some(Seen::Frame { src: 0, dst: 0, len: 24, first: 0x80 }));
        assert_eq!(decoder.stats.crc_errors, 1);
        assert_eq!(decoder.stats.frames_ok, 1);
        assert_eq!(decoder.stats.bytes_dropped, 31);
        check_invariant(&decoder);
    }

    fn crc16_of(bytes: &[u8]) -> u16 {
        super::super::crc::crc16(bytes)
    }

    #[test]
    fn flag_inside_frame_restarts_it() {
        // A frame cut after 12 bytes by the start of a complete one.
        let mut wire = [0u8; 43];
        wire[..12].copy_from_slice(&CREATE_CLIENT_FRAME[..12]);
        wire[12..].copy_from_slice(&CREATE_CLIENT_FRAME);
        for chunk in [1, 2, 7, 43] {
            let mut decoder = FrameDecoder::new([0u8; 64], AddressFilter::Any);
            let (seen, count) = run(&mut decoder, &wire, chunk);
            assert_eq!(count, 2);
            assert_eq!(seen[0], Some(Seen::Error(FrameError::Interrupted)));
            assert_eq!(seen[1], Some(Seen::Frame { src: 0, dst: 0, len: 24, first: 0x80 }));
            assert_eq!(decoder.stats.interrupted, 1);
            assert_eq!(decoder.stats.bytes_dropped, 12);
            check_invariant(&decoder);
        }
    }

    #[test]
    fn flag_right_after_escape_restarts() {
        let mut wire = [0u8; 34];
        wire[..3].copy_from_slice(&[0x7E, 0x01, 0x7D]);
        wire[3..].copy_from_slice(&CREATE_CLIENT_FRAME);
        let mut decoder = FrameDecoder::new([0u8; 64], AddressFilter::Any);
        let (seen, count) = run(&mut decoder, &wire, 1);
        assert_eq!(count, 2);
        assert_eq!(seen[0], Some(Seen::Error(FrameError::Interrupted)));
        assert_eq!(seen[1], Some(Seen::Frame { src: 0, dst: 0, len: 24, first: 0x80 }));
    }

    #[test]
    fn repeated_flags_are_not_errors() {
        let mut wire = [0u8; 34];
        wire[..3].copy_from_slice(&[0x7E, 0x7E, 0x7E]);
        wire[3..].copy_from_slice(&CREATE_CLIENT_FRAME);
        let mut decoder = FrameDecoder::new([0u8; 64], AddressFilter::Any);
        let (seen, count) = run(&mut decoder, &wire, 1);
        assert_eq!(count, 1);
        assert!(matches!(seen[0], Some(Seen::Frame { len: 24, .. })));
        assert_eq!(decoder.stats.bytes_dropped, 3);
        check_invariant(&decoder);
    }

    #[test]
    fn oversized_length_is_dropped_and_hunted_past() {
        // Buffer of 16 bytes: the 24-byte CREATE_CLIENT is too big, the 8-byte one fits.
        let mut wire = [0u8; 48];
        wire[..31].copy_from_slice(&CREATE_CLIENT_FRAME);
        wire[31..].copy_from_slice(&ESCAPED_FRAME);
        for chunk in [1, 4, 48] {
            let mut decoder = FrameDecoder::new([0u8; 16], AddressFilter::Any);
            let (seen, count) = run(&mut decoder, &wire, chunk);
            assert_eq!(count, 2);
            assert_eq!(seen[0], Some(Seen::Error(FrameError::Oversized { len: 24, capacity: 16 })));
            assert_eq!(seen[1], Some(Seen::Frame { src: 0, dst: 0, len: 8, first: 0x81 }));
            assert_eq!(decoder.stats.oversized, 1);
            assert_eq!(decoder.stats.bytes_dropped, 31);
            check_invariant(&decoder);
        }
    }

    #[test]
    fn escaped_length_and_crc() {
        // 126 = 0x7E payload bytes: the length's low byte is escaped.
        let mut payload = [0u8; 126];
        for (i, b) in payload.iter_mut().enumerate() {
            *b = i as u8;
        }
        let mut out = [0u8; max_encoded_len(126)];
        let n = encode_frame(1, 0, &payload, &mut out).unwrap();
        assert_eq!(&out[..6], &[0x7E, 0x01, 0x00, 0x7D, 0x5E, 0x00]);
        let mut decoder = FrameDecoder::new([0u8; 200], AddressFilter::Only(0));
        let (used, event) = decoder.feed(&out[..n]);
        assert_eq!(used, n);
        assert_eq!(event, Some(Event::Frame { src: 1, dst: 0, payload: &payload }));

        // A payload whose CRC has a 0x7E byte: find one by varying the last byte.
        let mut p = [0x81, 0x00, 0x00, 0x00, 0x00];
        let mut found = false;
        for last in 0..=255u8 {
            p[4] = last;
            let crc = crc16_of(&p).to_le_bytes();
            if crc.contains(&FLAG) || crc.contains(&ESCAPE) {
                found = true;
                break;
            }
        }
        assert!(found);
        let n = encode_frame(0, 1, &p, &mut out).unwrap();
        assert!(n > 1 + HEADER_LEN + p.len() + CRC_LEN, "one CRC byte at least is escaped");
        let mut decoder = FrameDecoder::new([0u8; 8], AddressFilter::Only(1));
        for chunk in 1..n {
            let (seen, count) = run(&mut decoder, &out[..n], chunk);
            assert_eq!(count, 1);
            assert_eq!(seen[0], Some(Seen::Frame { src: 0, dst: 1, len: 5, first: 0x81 }));
        }
    }

    #[test]
    fn escaped_addresses() {
        let mut out = [0u8; 32];
        let n = encode_frame(FLAG, ESCAPE, &[1, 2, 3], &mut out).unwrap();
        assert_eq!(&out[..5], &[0x7E, 0x7D, 0x5E, 0x7D, 0x5D]);
        let mut decoder = FrameDecoder::new([0u8; 8], AddressFilter::Only(ESCAPE));
        let (_, event) = decoder.feed(&out[..n]);
        assert_eq!(event, Some(Event::Frame { src: FLAG, dst: ESCAPE, payload: &[1, 2, 3] }));
    }

    #[test]
    fn address_filter() {
        let mut out = [0u8; 64];
        let n = encode_frame(0, 1, &CREATE_CLIENT, &mut out).unwrap();
        let mut decoder = FrameDecoder::new([0u8; 64], AddressFilter::Only(0));
        let (seen, count) = run(&mut decoder, &out[..n], 3);
        assert_eq!(count, 0);
        assert_eq!(seen[0], None);
        assert_eq!(decoder.stats.filtered, 1);
        assert_eq!(decoder.stats.bytes_dropped as usize, n);
        check_invariant(&decoder);
        decoder.set_filter(AddressFilter::Only(1));
        assert_eq!(decoder.filter(), AddressFilter::Only(1));
        let (_, count) = run(&mut decoder, &out[..n], 3);
        assert_eq!(count, 1);
        assert!(AddressFilter::Any.accepts(200));
    }

    #[test]
    fn empty_payload() {
        let mut out = [0u8; 16];
        let n = encode_frame(2, 3, &[], &mut out).unwrap();
        assert_eq!(&out[..n], &[0x7E, 0x02, 0x03, 0x00, 0x00, 0x00, 0x00]);
        let mut decoder = FrameDecoder::new([0u8; 0], AddressFilter::Any);
        assert_eq!(decoder.feed(&out[..n]), (n, Some(Event::Frame { src: 2, dst: 3, payload: &[] })));
    }

    #[test]
    fn slice_buffer_and_reset() {
        let mut storage = [0u8; 32];
        let mut decoder = FrameDecoder::new(&mut storage[..], AddressFilter::Any);
        assert_eq!(decoder.capacity(), 32);
        assert_eq!(decoder.feed(&CREATE_CLIENT_FRAME[..10]), (10, None));
        assert_eq!(decoder.pending_len(), 10);
        decoder.reset();
        assert_eq!(decoder.pending_len(), 0);
        assert_eq!(decoder.feed(&CREATE_CLIENT_FRAME[10..]), (21, None));
        check_invariant(&decoder);
        let (used, event) = decoder.feed(&CREATE_CLIENT_FRAME);
        assert_eq!(used, 31);
        assert!(event.is_some());
        let buf = decoder.into_inner();
        assert_eq!(&buf[..24], &CREATE_CLIENT);
    }

    #[test]
    fn array_alias_and_size_hint() {
        let decoder: ArrayFrameDecoder<64> = FrameDecoder::new([0; 64], AddressFilter::Any);
        assert_eq!(decoder.capacity(), 64);
        let bytes = FrameBytes::new(0, 0, &ESCAPED_PAYLOAD).unwrap();
        let (lo, hi) = bytes.size_hint();
        assert!(lo <= ESCAPED_FRAME.len() && ESCAPED_FRAME.len() <= hi.unwrap());
        assert_eq!(bytes.count(), ESCAPED_FRAME.len());
    }

    #[test]
    fn display_messages() {
        use core::fmt::Write;
        struct Buf([u8; 128], usize);
        impl Write for Buf {
            fn write_str(&mut self, s: &str) -> fmt::Result {
                let end = self.1 + s.len();
                self.0.get_mut(self.1..end).ok_or(fmt::Error)?.copy_from_slice(s.as_bytes());
                self.1 = end;
                Ok(())
            }
        }
        let mut b = Buf([0; 128], 0);
        write!(b, "{}", FrameError::Crc { computed: 0x1234, received: 0x7e00 }).unwrap();
        assert_eq!(&b.0[..b.1], b"serial frame CRC mismatch: computed 0x1234, received 0x7e00");
        for e in [
            FrameError::BufferTooSmall { needed: 3 },
            FrameError::PayloadTooLarge { len: 70000 },
            FrameError::Oversized { len: 9, capacity: 8 },
            FrameError::Interrupted,
        ] {
            b.1 = 0;
            write!(b, "{e}").unwrap();
            assert!(b.1 > 10);
        }
    }
}
