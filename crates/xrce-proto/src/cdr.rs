//! XCDR version 1 (plain CDR) over byte slices, as Micro-CDR and Fast-CDR produce it.
//!
//! Alignment is computed from an *origin* chosen by the caller (spec §1.2): the message start for protocol
//! structures, the blob start for binary object representations, the payload start for user data.
//! 8-byte primitives align to 8 (XCDR v1).
//!
//! The [`Reader`] borrows from its input and bounds-checks every read. The [`Writer`] never fails mid-way:
//! once its buffer is exhausted it keeps counting, so [`Writer::finish`] can report the exact size needed.

use core::fmt;

/// Byte order of a CDR stream; chosen per submessage by its E flag.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum Endianness {
    /// E flag clear.
    Big,
    /// E flag set; what every usual target and the eProsima agent write.
    #[default]
    Little,
}

impl Endianness {
    /// The byte order of the machine we run on (what the C client sends).
    pub const NATIVE: Self = if cfg!(target_endian = "big") { Self::Big } else { Self::Little };

    /// Byte order selected by bit 0 of a submessage's flags.
    pub const fn from_flags(flags: u8) -> Self {
        if flags & 0x01 != 0 {
            Self::Little
        } else {
            Self::Big
        }
    }

    /// The E flag bit for this byte order.
    pub const fn flag(self) -> u8 {
        match self {
            Self::Little => 0x01,
            Self::Big => 0x00,
        }
    }
}

/// Why CDR data could not be read or written.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Error {
    /// The input ended before the value did.
    Truncated,
    /// A boolean byte other than 0 or 1.
    InvalidBool(u8),
    /// A string without its terminating NUL, or not UTF-8.
    InvalidString,
    /// A sequence count larger than what the remaining input could possibly hold.
    SequenceTooLong(u32),
    /// A union discriminator or enumeration value this implementation does not know.
    InvalidDiscriminator(u8),
    /// A length too large for its field (which one is said).
    TooLong(LengthField),
    /// The output buffer is too small; `needed` is the total size the encoding takes.
    BufferTooSmall {
        /// Bytes the complete encoding needs.
        needed: usize,
    },
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Truncated => f.write_str("input ends before the value does"),
            Self::InvalidBool(b) => write!(f, "invalid boolean byte {b:#04x}"),
            Self::InvalidString => f.write_str("string not NUL-terminated or not UTF-8"),
            Self::SequenceTooLong(n) => write!(f, "sequence count {n} exceeds the remaining input"),
            Self::InvalidDiscriminator(d) => write!(f, "unknown discriminator {d:#04x}"),
            Self::TooLong(field) => write!(f, "{} too long for its field", field.name()),
            Self::BufferTooSmall { needed } => write!(f, "output buffer too small, {needed} bytes needed"),
        }
    }
}

impl core::error::Error for Error {}

/// A length field a value did not fit ([`Error::TooLong`]). A fieldless enum rather than a name (`&str`, two
/// words): an [`Error`] is then 8 bytes, which made the C library's `.text` 972 B smaller on a Cortex-M4.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LengthField {
    /// A submessage's 16-bit length.
    Submessage,
    /// A sequence's 32-bit count.
    Sequence,
    /// A binary entity representation's 16-bit length.
    BinaryRepresentation,
}

impl LengthField {
    /// What the field is called in messages.
    pub const fn name(self) -> &'static str {
        match self {
            Self::Submessage => "submessage length",
            Self::Sequence => "sequence length",
            Self::BinaryRepresentation => "binary representation length",
        }
    }
}

/// Result of CDR operations.
pub type Result<T> = core::result::Result<T, Error>;

/// Padding needed to bring `offset` to a multiple of `align` (a power of two).
#[inline]
pub const fn padding(offset: usize, align: usize) -> usize {
    (align - (offset % align)) % align
}

/// A bounds-checked, zero-copy CDR reader.
#[derive(Debug, Clone, Copy)]
pub struct Reader<'a> {
    buf: &'a [u8],
    pos: usize,
    origin: usize,
    endian: Endianness,
}

macro_rules! read_prim {
    ($name:ident, $opt:ident, $t:ty, $n:expr) => {
        #[doc = concat!("Reads an aligned `", stringify!($t), "`.")]
        #[inline]
        pub fn $name(&mut self) -> Result<$t> {
            self.$opt().ok_or(Error::Truncated)
        }

        // The read proper returns an `Option`, which comes back in registers where a `Result` (12 bytes) goes
        // through memory at every call (firmware size).
        pub(crate) fn $opt(&mut self) -> Option<$t> {
            // Aligned and read under one bounds check (the position moves only when the value is there).
            let at = self.pos.saturating_add(padding(self.pos.wrapping_sub(self.origin), $n));
            let bytes = *self.buf.get(at..).and_then(<[u8]>::first_chunk::<$n>)?;
            self.pos = at + $n;
            Some(match self.endian {
                Endianness::Little => <$t>::from_le_bytes(bytes),
                Endianness::Big => <$t>::from_be_bytes(bytes),
            })
        }
    };
}

impl<'a> Reader<'a> {
    /// A reader over `buf` with origin and position at its first byte.
    pub const fn new(buf: &'a [u8], endian: Endianness) -> Self {
        Self { buf, pos: 0, origin: 0, endian }
    }

    /// A reader over `buf` positioned at `pos`, aligning relative to `origin` (which may be any index ≤ `pos`).
    pub const fn with_origin(buf: &'a [u8], pos: usize, origin: usize, endian: Endianness) -> Self {
        Self { buf, pos, origin, endian }
    }

    /// Byte order in force.
    pub const fn endianness(&self) -> Endianness {
        self.endian
    }

    /// Changes the byte order for what follows.
    pub fn set_endianness(&mut self, endian: Endianness) {
        self.endian = endian;
    }

    /// Position in the underlying buffer.
    pub const fn position(&self) -> usize {
        self.pos
    }

    /// Index of the alignment origin in the underlying buffer.
    pub const fn origin(&self) -> usize {
        self.origin
    }

    /// Bytes not read yet.
    pub fn remaining(&self) -> usize {
        self.buf.len().saturating_sub(self.pos)
    }

    /// Everything not read yet, without consuming it.
    pub fn rest(&self) -> &'a [u8] {
        self.buf.get(self.pos..).unwrap_or(&[])
    }

    /// Consumes and returns everything not read yet.
    pub fn take_rest(&mut self) -> &'a [u8] {
        let rest = self.rest();
        self.pos = self.buf.len();
        rest
    }

    /// Skips the padding that brings the position to a multiple of `align` from the origin.
    #[inline]
    pub fn align(&mut self, align: usize) -> Result<()> {
        let pad = padding(self.pos.wrapping_sub(self.origin), align);
        self.skip(pad)
    }

    /// Skips `n` bytes.
    #[inline]
    pub fn skip(&mut self, n: usize) -> Result<()> {
        if n > self.remaining() {
            return Err(Error::Truncated);
        }
        self.pos += n;
        Ok(())
    }

    /// Reads `n` raw bytes (no alignment).
    #[inline]
    pub fn read_bytes(&mut self, n: usize) -> Result<&'a [u8]> {
        let end = self.pos.checked_add(n).ok_or(Error::Truncated)?;
        let bytes = self.buf.get(self.pos..end).ok_or(Error::Truncated)?;
        self.pos = end;
        Ok(bytes)
    }

    /// Reads a fixed-size raw byte array (no alignment).
    #[inline]
    pub fn read_array<const N: usize>(&mut self) -> Result<[u8; N]> {
        self.read_array_opt().ok_or(Error::Truncated)
    }

    /// [`read_array`](Self::read_array) returning an `Option`, for decoders that can only fail on truncation: an
    /// `Option` comes back in registers where a `Result` often goes through memory (firmware size).
    #[inline]
    pub(crate) fn read_array_opt<const N: usize>(&mut self) -> Option<[u8; N]> {
        let bytes = self.buf.get(self.pos..).and_then(<[u8]>::first_chunk::<N>)?;
        // `pos + N` is at most the buffer's length: no overflow.
        self.pos += N;
        Some(*bytes)
    }

    /// Reads one byte.
    #[inline]
    pub fn read_u8(&mut self) -> Result<u8> {
        let [b] = self.read_array::<1>()?;
        Ok(b)
    }

    /// Reads one signed byte.
    #[inline]
    pub fn read_i8(&mut self) -> Result<i8> {
        Ok(self.read_u8()? as i8)
    }

    /// Reads a boolean, rejecting bytes other than 0 and 1 (hostile input must not be silently accepted).
    // Always inlined: out of line, its `Result` went through memory at every call (120 bytes of firmware).
    #[inline(always)]
    pub fn read_bool(&mut self) -> Result<bool> {
        match self.read_u8()? {
            0 => Ok(false),
            1 => Ok(true),
            other => Err(Error::InvalidBool(other)),
        }
    }

    read_prim!(read_u16, read_u16_opt, u16, 2);
    read_prim!(read_u32, read_u32_opt, u32, 4);
    read_prim!(read_u64, read_u64_opt, u64, 8);

    // The signed reads share the unsigned ones' code (one instance less per width in a firmware).

    /// Reads an aligned `i16`.
    #[inline]
    pub fn read_i16(&mut self) -> Result<i16> {
        self.read_u16().map(|v| v as i16)
    }

    /// Reads an aligned `i32`.
    #[inline]
    pub fn read_i32(&mut self) -> Result<i32> {
        self.read_u32().map(|v| v as i32)
    }

    /// Reads an aligned `i64`.
    #[inline]
    pub fn read_i64(&mut self) -> Result<i64> {
        self.read_u64().map(|v| v as i64)
    }
    read_prim!(read_f32, read_f32_opt, f32, 4);
    read_prim!(read_f64, read_f64_opt, f64, 8);

    /// Reads a string: `u32` length including the NUL, the characters, the NUL.
    /// A length of 0 is accepted as the empty string (Fast-CDR does so).
    pub fn read_string(&mut self) -> Result<&'a str> {
        let len = self.read_u32()? as usize;
        if len == 0 {
            return Ok("");
        }
        let bytes = self.read_bytes(len)?;
        match bytes.split_last() {
            Some((0, text)) => core::str::from_utf8(text).map_err(|_| Error::InvalidString),
            _ => Err(Error::InvalidString),
        }
    }

    /// Reads a sequence count and checks that `count × min_element_size` bytes could follow,
    /// so that hostile counts are rejected before any work is done.
    pub fn read_seq_len(&mut self, min_element_size: usize) -> Result<u32> {
        let count = self.read_u32()?;
        let needed = (count as usize).checked_mul(min_element_size).ok_or(Error::SequenceTooLong(count))?;
        if needed > self.remaining() {
            return Err(Error::SequenceTooLong(count));
        }
        Ok(count)
    }

    /// Reads a `sequence<octet>`.
    pub fn read_octet_seq(&mut self) -> Result<&'a [u8]> {
        let len = self.read_seq_len(1)? as usize;
        self.read_bytes(len)
    }

    /// Reads an XRCE-style optional: a boolean and, when it is true, the value.
    pub fn read_optional<T>(&mut self, f: impl FnOnce(&mut Self) -> Result<T>) -> Result<Option<T>> {
        if self.read_bool()? {
            f(self).map(Some)
        } else {
            Ok(None)
        }
    }

    /// Decodes a value.
    // Always inlined: a forwarder whose out-of-line copy returned its `Result` through memory (firmware size).
    #[inline(always)]
    pub fn read<T: Decode<'a>>(&mut self) -> Result<T> {
        T::decode(self)
    }
}

/// A CDR writer into a caller's buffer that keeps counting past the end, so one pass yields the size needed.
#[derive(Debug)]
pub struct Writer<'b> {
    buf: &'b mut [u8],
    pos: usize,
    origin: usize,
    endian: Endianness,
    pad_byte: u8,
    error: Option<Error>,
}

macro_rules! write_prim {
    ($name:ident, $t:ty, $n:expr) => {
        #[doc = concat!("Writes an aligned `", stringify!($t), "`.")]
        #[inline]
        pub fn $name(&mut self, v: $t) {
            self.align($n);
            let bytes = match self.endian {
                Endianness::Little => v.to_le_bytes(),
                Endianness::Big => v.to_be_bytes(),
            };
            self.write_bytes(&bytes);
        }
    };
}

impl<'b> Writer<'b> {
    /// A writer at the start of `buf`, origin at its first byte.
    pub fn new(buf: &'b mut [u8], endian: Endianness) -> Self {
        Self::with_origin(buf, 0, 0, endian)
    }

    /// A writer at `pos` of `buf`, aligning relative to `origin`.
    pub fn with_origin(buf: &'b mut [u8], pos: usize, origin: usize, endian: Endianness) -> Self {
        Self { buf, pos, origin, endian, pad_byte: 0, error: None }
    }

    /// Sets the byte written as padding (0 by default). Tests use it to find which bytes are padding.
    pub fn set_pad_byte(&mut self, pad: u8) {
        self.pad_byte = pad;
    }

    /// Byte order in force.
    pub const fn endianness(&self) -> Endianness {
        self.endian
    }

    /// Changes the byte order for what follows.
    pub fn set_endianness(&mut self, endian: Endianness) {
        self.endian = endian;
    }

    /// Moves the alignment origin (for example to the start of a user payload).
    pub fn set_origin(&mut self, origin: usize) {
        self.origin = origin;
    }

    /// Position reached, which may be past the end of the buffer.
    pub const fn position(&self) -> usize {
        self.pos
    }

    /// Index of the alignment origin.
    pub const fn origin(&self) -> usize {
        self.origin
    }

    /// Bytes written so far (only those that fitted).
    pub fn written(&self) -> &[u8] {
        self.buf.get(..self.pos).unwrap_or(self.buf)
    }

    /// Whether everything written so far fitted.
    pub fn fits(&self) -> bool {
        self.error.is_none() && self.pos <= self.buf.len()
    }

    /// Records a value error; the first one is reported by [`finish`](Self::finish).
    pub fn fail(&mut self, error: Error) {
        if self.error.is_none() {
            self.error = Some(error);
        }
    }

    /// Bytes written so far, or the first error: a value error, or [`Error::BufferTooSmall`] with the size needed.
    pub fn finish(self) -> Result<usize> {
        match self.error {
            Some(e) => Err(e),
            None if self.pos > self.buf.len() => Err(Error::BufferTooSmall { needed: self.pos }),
            None => Ok(self.pos),
        }
    }

    /// Writes padding up to a multiple of `align` from the origin.
    #[inline]
    pub fn align(&mut self, align: usize) {
        let pad = padding(self.pos.wrapping_sub(self.origin), align);
        for _ in 0..pad {
            let b = self.pad_byte;
            self.write_u8(b);
        }
    }

    /// Writes raw bytes.
    #[inline]
    pub fn write_bytes(&mut self, bytes: &[u8]) {
        let end = self.pos.saturating_add(bytes.len());
        if let Some(dst) = self.buf.get_mut(self.pos..end) {
            crate::bytes::copy(dst, bytes);
        }
        self.pos = end;
    }

    /// Writes one byte.
    #[inline]
    pub fn write_u8(&mut self, v: u8) {
        if let Some(slot) = self.buf.get_mut(self.pos) {
            *slot = v;
        }
        self.pos = self.pos.saturating_add(1);
    }

    /// Writes one signed byte.
    #[inline]
    pub fn write_i8(&mut self, v: i8) {
        self.write_u8(v as u8);
    }

    /// Writes a boolean as 0 or 1.
    #[inline]
    pub fn write_bool(&mut self, v: bool) {
        self.write_u8(u8::from(v));
    }

    write_prim!(write_u16, u16, 2);
    write_prim!(write_u32, u32, 4);
    write_prim!(write_u64, u64, 8);

    // The signed writes share the unsigned ones' code (one instance less per width in a firmware).

    /// Writes an aligned `i16`.
    #[inline]
    pub fn write_i16(&mut self, v: i16) {
        self.write_u16(v as u16);
    }

    /// Writes an aligned `i32`.
    #[inline]
    pub fn write_i32(&mut self, v: i32) {
        self.write_u32(v as u32);
    }

    /// Writes an aligned `i64`.
    #[inline]
    pub fn write_i64(&mut self, v: i64) {
        self.write_u64(v as u64);
    }
    write_prim!(write_f32, f32, 4);
    write_prim!(write_f64, f64, 8);

    /// Writes a sequence count, recording an error when it does not fit in a `u32`.
    pub fn write_seq_len(&mut self, len: usize) {
        match u32::try_from(len) {
            Ok(n) => self.write_u32(n),
            Err(_) => self.fail(Error::TooLong(LengthField::Sequence)),
        }
    }

    /// Writes a string with its length (NUL included) and terminating NUL.
    pub fn write_string(&mut self, s: &str) {
        self.write_seq_len(s.len().saturating_add(1));
        self.write_bytes(s.as_bytes());
        self.write_u8(0);
    }

    /// Writes a `sequence<octet>`.
    pub fn write_octet_seq(&mut self, bytes: &[u8]) {
        self.write_seq_len(bytes.len());
        self.write_bytes(bytes);
    }

    /// Writes an XRCE-style optional: a presence boolean and the value when present.
    pub fn write_optional<T>(&mut self, v: Option<&T>, f: impl FnOnce(&mut Self, &T)) {
        self.write_bool(v.is_some());
        if let Some(v) = v {
            f(self, v);
        }
    }

    /// Encodes a value.
    pub fn write<T: Encode + ?Sized>(&mut self, v: &T) {
        v.encode(self);
    }

    /// Overwrites four bytes at `at` with `v` in the writer's byte order (patches a length written before its data).
    pub fn patch_u32(&mut self, at: usize, v: u32) {
        let bytes = match self.endian {
            Endianness::Little => v.to_le_bytes(),
            Endianness::Big => v.to_be_bytes(),
        };
        if let Some(dst) = self.buf.get_mut(at..).and_then(<[u8]>::first_chunk_mut::<4>) {
            *dst = bytes;
        }
    }

    /// Overwrites two bytes at `at` with `v` little endian (used to patch lengths after the fact).
    pub fn patch_u16_le(&mut self, at: usize, v: u16) {
        if let Some(dst) = self.buf.get_mut(at..).and_then(<[u8]>::first_chunk_mut::<2>) {
            *dst = v.to_le_bytes();
        }
    }
}

/// A value that can be read from CDR, borrowing from the input.
pub trait Decode<'a>: Sized {
    /// Reads the value at the reader's position.
    fn decode(r: &mut Reader<'a>) -> Result<Self>;
}

/// A value that can be written as CDR. Encoding never fails mid-way; errors surface in [`Writer::finish`].
pub trait Encode {
    /// Writes the value at the writer's position.
    fn encode(&self, w: &mut Writer<'_>);

    /// Encoded size when written at `pos` with alignment origin `origin`.
    fn encoded_len_at(&self, pos: usize, origin: usize) -> usize {
        let mut w = Writer::with_origin(&mut [], pos, origin, Endianness::Little);
        self.encode(&mut w);
        w.position() - pos
    }
}

macro_rules! prim_codec {
    ($t:ty, $r:ident, $w:ident) => {
        impl<'a> Decode<'a> for $t {
            fn decode(r: &mut Reader<'a>) -> Result<Self> {
                r.$r()
            }
        }
        impl Encode for $t {
            fn encode(&self, w: &mut Writer<'_>) {
                w.$w(*self)
            }
        }
    };
}

prim_codec!(u8, read_u8, write_u8);
prim_codec!(i8, read_i8, write_i8);
prim_codec!(bool, read_bool, write_bool);
prim_codec!(u16, read_u16, write_u16);
prim_codec!(i16, read_i16, write_i16);
prim_codec!(u32, read_u32, write_u32);
prim_codec!(i32, read_i32, write_i32);
prim_codec!(u64, read_u64, write_u64);
prim_codec!(i64, read_i64, write_i64);
prim_codec!(f32, read_f32, write_f32);
prim_codec!(f64, read_f64, write_f64);

impl<'a> Decode<'a> for &'a str {
    fn decode(r: &mut Reader<'a>) -> Result<Self> {
        r.read_string()
    }
}

impl Encode for str {
    fn encode(&self, w: &mut Writer<'_>) {
        w.write_string(self)
    }
}

impl Encode for &str {
    fn encode(&self, w: &mut Writer<'_>) {
        w.write_string(self)
    }
}

impl<'a, const N: usize> Decode<'a> for [u8; N] {
    fn decode(r: &mut Reader<'a>) -> Result<Self> {
        r.read_array()
    }
}

impl<const N: usize> Encode for [u8; N] {
    fn encode(&self, w: &mut Writer<'_>) {
        w.write_bytes(self)
    }
}

/// Smallest number of bytes one element of a sequence can take; bounds hostile sequence counts.
pub trait MinSize {
    /// A lower bound of the encoded size of any value of the type.
    const MIN_SIZE: usize;
}

impl MinSize for &str {
    const MIN_SIZE: usize = 4;
}

/// A CDR `sequence<T>` that is either decoded lazily from the input (zero-copy) or given as a slice to encode.
///
/// Decoding validates every element once, so iterating a decoded sequence afterwards cannot fail.
#[derive(Clone, Copy)]
pub enum Seq<'a, T> {
    /// Elements supplied by the caller, for encoding.
    Items(&'a [T]),
    /// Elements still in the input buffer, read on iteration.
    Wire {
        /// Reader positioned at the first element.
        reader: Reader<'a>,
        /// Element count.
        count: u32,
    },
}

impl<'a, T> Seq<'a, T> {
    /// The empty sequence.
    pub const EMPTY: Self = Seq::Items(&[]);

    /// Number of elements.
    pub fn len(&self) -> usize {
        match self {
            Seq::Items(items) => items.len(),
            Seq::Wire { count, .. } => *count as usize,
        }
    }

    /// Whether there are no elements.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

impl<'a, T: Decode<'a> + Clone> Seq<'a, T> {
    /// Iterates over the elements (decoded copies for a wire sequence).
    pub fn iter(&self) -> SeqIter<'a, '_, T> {
        match self {
            Seq::Items(items) => SeqIter::Items(items.iter()),
            Seq::Wire { reader, count } => SeqIter::Wire { reader: *reader, left: *count },
        }
    }
}

impl<'a, T: Decode<'a> + MinSize> Decode<'a> for Seq<'a, T> {
    fn decode(r: &mut Reader<'a>) -> Result<Self> {
        let count = r.read_seq_len(T::MIN_SIZE)?;
        let start = *r;
        for _ in 0..count {
            T::decode(r)?;
        }
        Ok(Seq::Wire { reader: start, count })
    }
}

impl<'a, T: Decode<'a> + Encode + Clone> Encode for Seq<'a, T> {
    fn encode(&self, w: &mut Writer<'_>) {
        match self {
            Seq::Items(items) => write_seq(w, items),
            Seq::Wire { .. } => {
                w.write_seq_len(self.len());
                for item in self.iter() {
                    item.encode(w);
                }
            }
        }
    }
}

/// Writes `items` as a CDR `sequence<T>`, linking no decoder of `T` (as encoding a [`Seq`] does).
pub fn write_seq<T: Encode>(w: &mut Writer<'_>, items: &[T]) {
    w.write_seq_len(items.len());
    for item in items {
        item.encode(w);
    }
}

impl<'a, T: Decode<'a> + Clone + PartialEq> PartialEq for Seq<'a, T> {
    fn eq(&self, other: &Self) -> bool {
        self.len() == other.len() && self.iter().zip(other.iter()).all(|(a, b)| a == b)
    }
}

impl<'a, T: Decode<'a> + Clone + fmt::Debug> fmt::Debug for Seq<'a, T> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_list().entries(self.iter()).finish()
    }
}

/// Iterator over a [`Seq`].
pub enum SeqIter<'a, 's, T> {
    /// Over caller-supplied items.
    Items(core::slice::Iter<'s, T>),
    /// Over elements still in the input.
    Wire {
        /// Reader at the next element.
        reader: Reader<'a>,
        /// Elements left.
        left: u32,
    },
}

impl<'a, T: Decode<'a> + Clone> Iterator for SeqIter<'a, '_, T> {
    type Item = T;
    fn next(&mut self) -> Option<T> {
        match self {
            SeqIter::Items(it) => it.next().cloned(),
            SeqIter::Wire { reader, left } => {
                if *left == 0 {
                    return None;
                }
                *left -= 1;
                // Validated when the sequence was decoded, so this cannot fail.
                T::decode(reader).ok()
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_truncated_primitive_leaves_the_position() {
        // Padding fits, the value does not: an error, and the reader stays where it was.
        let buf = [1u8, 0xAA, 2, 3, 4, 5];
        let mut r = Reader::new(&buf, Endianness::Little);
        assert_eq!(r.read_u8(), Ok(1));
        assert_eq!(r.read_u32(), Err(Error::Truncated));
        assert_eq!(r.position(), 1);
        assert_eq!(r.read_u16(), Ok(0x0302));
        assert_eq!(r.read_u32(), Err(Error::Truncated));
        assert_eq!(r.position(), 4);
        assert_eq!(r.read_u16(), Ok(0x0504));
        assert_eq!(r.position(), 6);
    }

    #[test]
    fn alignment_is_relative_to_origin() {
        let mut buf = [0xAAu8; 16];
        let mut w = Writer::with_origin(&mut buf, 5, 4, Endianness::Little);
        w.write_u8(1);
        w.write_u32(0x0102_0304);
        assert_eq!(w.finish(), Ok(12));
        assert_eq!(&buf[5..12], &[1, 0, 0, 4, 3, 2, 1]);
        let mut r = Reader::with_origin(&buf, 5, 4, Endianness::Little);
        assert_eq!(r.read_u8(), Ok(1));
        assert_eq!(r.read_u32(), Ok(0x0102_0304));
    }

    #[test]
    fn eight_byte_types_align_to_eight() {
        let mut buf = [0u8; 16];
        let mut w = Writer::new(&mut buf, Endianness::Big);
        w.write_u8(7);
        w.write_u64(1);
        assert_eq!(w.finish(), Ok(16));
        assert_eq!(buf[15], 1);
    }

    #[test]
    fn writer_reports_size_needed() {
        let mut buf = [0u8; 4];
        let mut w = Writer::new(&mut buf, Endianness::Little);
        w.write_string("Hello");
        assert_eq!(w.finish(), Err(Error::BufferTooSmall { needed: 10 }));
    }

    #[test]
    fn strings_round_trip_and_reject_missing_nul() {
        let mut buf = [0u8; 16];
        let mut w = Writer::new(&mut buf, Endianness::Little);
        w.write_string("");
        w.write_string("ab");
        let n = w.finish().unwrap();
        assert_eq!(&buf[..n], &[1, 0, 0, 0, 0, 0, 0, 0, 3, 0, 0, 0, b'a', b'b', 0]);
        let mut r = Reader::new(&buf[..n], Endianness::Little);
        assert_eq!(r.read_string(), Ok(""));
        assert_eq!(r.read_string(), Ok("ab"));
        let bad = [2, 0, 0, 0, b'a', b'b'];
        assert_eq!(Reader::new(&bad, Endianness::Little).read_string(), Err(Error::InvalidString));
    }

    #[test]
    fn hostile_counts_are_rejected() {
        let bytes = [0xFF, 0xFF, 0xFF, 0xFF, 1, 2];
        assert_eq!(Reader::new(&bytes, Endianness::Little).read_octet_seq(), Err(Error::SequenceTooLong(u32::MAX)));
        assert_eq!(Reader::new(&[2], Endianness::Little).read_bool(), Err(Error::InvalidBool(2)));
        assert_eq!(Reader::new(&[1, 2, 3], Endianness::Little).read_u32(), Err(Error::Truncated));
    }

    #[test]
    fn lazy_sequences_iterate_and_compare() {
        let names = ["a", "bc"];
        let seq: Seq<'_, &str> = Seq::Items(&names);
        let mut buf = [0u8; 32];
        let mut w = Writer::new(&mut buf, Endianness::Big);
        seq.encode(&mut w);
        let n = w.finish().unwrap();
        let mut r = Reader::new(&buf[..n], Endianness::Big);
        let decoded: Seq<'_, &str> = r.read().unwrap();
        assert_eq!(decoded, seq);
        assert_eq!(decoded.iter().collect::<heapless_vec::V>().0, 2);
    }

    mod heapless_vec {
        pub struct V(pub usize);
        impl<T> FromIterator<T> for V {
            fn from_iter<I: IntoIterator<Item = T>>(it: I) -> Self {
                V(it.into_iter().count())
            }
        }
    }
}
