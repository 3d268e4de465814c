//! CDR (XCDR version 1, plain CDR) serialization of user topic types through `serde`.
//!
//! This is the Rust counterpart of the `TOPIC_serialize_topic`, `TOPIC_deserialize_topic` and
//! `TOPIC_size_of_topic` functions that eProsima's code generator emits for Micro-CDR: a
//! `#[derive(Serialize, Deserialize)]` type laid out like the IDL type it mirrors produces the same bytes.
//!
//! ```
//! use serde::{Deserialize, Serialize};
//! use xrce_proto::serde_cdr;
//!
//! #[derive(Serialize, Deserialize, Debug, PartialEq)]
//! struct HelloWorld<'a> {
//!     index: u32,
//!     message: &'a str,
//! }
//!
//! let sample = HelloWorld { index: 1, message: "Hello DDS world!" };
//! let mut buf = [0u8; 64];
//! let n = serde_cdr::to_slice(&sample, &mut buf)?;
//! assert_eq!(n, 25);
//! assert_eq!(serde_cdr::serialized_size(&sample)?, 25);
//! let back: HelloWorld<'_> = serde_cdr::from_slice(&buf[..n])?;
//! assert_eq!(back, sample);
//! # Ok::<(), serde_cdr::Error>(())
//! ```
//!
//! # Mapping
//!
//! Alignment is relative to the first byte of the serialized sample (the start of the user payload), each
//! primitive aligned to its own size, 8-byte primitives to 8 (XCDR v1). Little endian unless another byte order
//! is chosen.
//!
//! | Rust / serde                                   | IDL                          | CDR                                        |
//! |------------------------------------------------|------------------------------|--------------------------------------------|
//! | `bool`                                         | `boolean`                    | 1 byte, 0 or 1 (anything else is rejected) |
//! | `u8`, `i8`                                     | `octet`, `uint8`, `int8`     | 1 byte                                     |
//! | `char`                                         | `char`                       | 1 byte, ISO 8859-1 (see below)             |
//! | `u16`, `i16`                                   | `unsigned short`, `short`    | 2 bytes, aligned 2                         |
//! | `u32`, `i32`, `f32`                            | `unsigned long`, `long`, `float` | 4 bytes, aligned 4                     |
//! | `u64`, `i64`, `f64`                            | `unsigned long long`, `long long`, `double` | 8 bytes, aligned 8          |
//! | `&str`, `String`, `heapless::String`           | `string`                     | `u32` length counting the NUL, bytes, NUL  |
//! | bytes (`serialize_bytes`, `&[u8]`, `Vec<u8>`)  | `sequence<octet>`            | `u32` count, bytes                         |
//! | sequences (`Vec<T>`, `&[T]`, `heapless::Vec`)  | `sequence<T>`                | `u32` count, elements                      |
//! | tuples, `[T; N]`, tuple structs                | `T[N]`, struct               | elements, no count                         |
//! | structs                                        | `struct`                     | fields in declaration order, no header     |
//! | newtype structs                                | the inner type               | the inner value                            |
//! | unit enums                                     | `enum`                       | `u32` variant index                        |
//! | enums with data                                | `union` with `long` discriminator | `u32` variant index, then the content |
//! | `Option<T>`                                    | XRCE-style optional          | 1-byte presence boolean, then the value    |
//! | maps                                           | `map<K, V>`                  | `u32` count, key, value, key, value…       |
//! | `()`, unit structs                             | —                            | nothing                                    |
//!
//! Notes:
//!
//! * `Option<T>` is *not* IDL `@optional` (that needs XCDR2 or parameter lists); it follows the convention of the
//!   XRCE protocol types (`boolean` presence flag followed by the value) so that both ends written with this
//!   module agree. A C peer needs hand-written code for such a member (write the flag, then the value only when
//!   the flag is true); eProsima's generator has no such mapping for XCDR v1.
//! * `char` is IDL `char`, an 8-bit ISO 8859-1 character: Rust chars `U+0000`–`U+00FF` are written as one byte,
//!   any other char is refused with [`Error::Unsupported`]; every byte decodes to the char of the same value.
//! * An enum is written with its *variant index* (0, 1, 2… in declaration order), which is what IDL enums and
//!   generated unions use by default. Rust discriminant values (`A = 5`) are ignored; use `serde_repr` with
//!   `#[repr(u32)]` for IDL enums with `@value`.
//! * `i128`/`u128`, sequences and maps whose length is not known up front, and `#[serde(skip_serializing_if)]`
//!   have no CDR encoding and are refused. Deserializing needs the type: `deserialize_any` (and so
//!   `#[serde(flatten)]`, untagged enums, `serde_json::Value`…) is refused, CDR is not self-describing.
//! * Strings may contain interior NUL characters; they round-trip here but a C peer would see them cut short.
//!
//! # Hostile input
//!
//! Decoding never panics and never does unbounded work: every read is bounds-checked, a sequence or map count is
//! rejected when it exceeds the bytes left, the total number of elements over the whole sample is bounded by
//! the input length (which only refuses sequences of zero-sized elements longer than what is left), and
//! nesting is limited to [`DEFAULT_MAX_DEPTH`] levels (recursive types). Trailing bytes after the value are
//! ignored, as Micro-CDR does (peers may pad samples); [`from_prefix_with`] tells how many bytes were used.

mod de;
mod ser;

use core::fmt;

pub use self::de::{Deserializer, DEFAULT_MAX_DEPTH};
pub use self::ser::{Compound, Serializer};
pub use crate::cdr::Endianness;
use crate::cdr::{self, Reader, Writer};

/// Capacity of a [`Message`] in bytes.
pub const MESSAGE_CAPACITY: usize = 64;

/// A short error text kept without allocation: at most [`MESSAGE_CAPACITY`] bytes, cut at a char boundary.
#[derive(Clone, Copy, PartialEq, Eq)]
pub struct Message {
    buf: [u8; MESSAGE_CAPACITY],
    len: usize,
}

impl Message {
    /// Formats `value`, keeping what fits.
    pub fn new(value: &dyn fmt::Display) -> Self {
        let mut msg = Self { buf: [0; MESSAGE_CAPACITY], len: 0 };
        // A full buffer stops formatting with an error; what fitted is kept.
        let _ = fmt::write(&mut msg, format_args!("{value}"));
        msg
    }

    /// The text.
    pub fn as_str(&self) -> &str {
        self.buf.get(..self.len).and_then(|b| core::str::from_utf8(b).ok()).unwrap_or("")
    }
}

impl fmt::Write for Message {
    fn write_str(&mut self, s: &str) -> fmt::Result {
        let room = MESSAGE_CAPACITY.saturating_sub(self.len);
        let mut n = s.len().min(room);
        while !s.is_char_boundary(n) {
            n = n.saturating_sub(1);
        }
        let end = self.len.saturating_add(n);
        if let (Some(dst), Some(src)) = (self.buf.get_mut(self.len..end), s.as_bytes().get(..n)) {
            crate::bytes::copy(dst, src);
            self.len = end;
        }
        if n == s.len() {
            Ok(())
        } else {
            Err(fmt::Error)
        }
    }
}

impl fmt::Debug for Message {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        fmt::Debug::fmt(self.as_str(), f)
    }
}

impl fmt::Display for Message {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

/// Why a value could not be serialized or deserialized.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Error {
    /// Malformed input (truncated, bad boolean, bad string, hostile count…) or a value the CDR writer refused
    /// (a length beyond `u32`). Never holds [`cdr::Error::BufferTooSmall`]: that becomes [`Error::BufferTooSmall`].
    Cdr(cdr::Error),
    /// The output buffer is too small; `needed` is the size of the complete encoding.
    BufferTooSmall {
        /// Bytes the complete encoding needs.
        needed: usize,
    },
    /// A serde construct with no CDR encoding (the text says which).
    Unsupported(&'static str),
    /// A `Serialize` implementation announced a different number of sequence or map elements than it gave, or a
    /// `Visitor` left some unread.
    LengthMismatch,
    /// Nesting deeper than the deserializer's limit ([`DEFAULT_MAX_DEPTH`] by default).
    TooDeep,
    /// An error raised by a `Serialize`/`Deserialize` implementation (for example a wrong sequence length for
    /// an array), its text truncated to [`MESSAGE_CAPACITY`] bytes.
    Custom(Message),
}

impl Error {
    /// The size the encoding needs, when that is why it failed.
    pub fn needed(&self) -> Option<usize> {
        match self {
            Self::BufferTooSmall { needed } => Some(*needed),
            _ => None,
        }
    }
}

impl From<cdr::Error> for Error {
    fn from(e: cdr::Error) -> Self {
        match e {
            cdr::Error::BufferTooSmall { needed } => Self::BufferTooSmall { needed },
            other => Self::Cdr(other),
        }
    }
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Cdr(e) => fmt::Display::fmt(e, f),
            Self::BufferTooSmall { needed } => {
                write!(f, "output buffer too small, {needed} bytes needed")
            }
            Self::Unsupported(what) => write!(f, "not supported by CDR: {what}"),
            Self::LengthMismatch => f.write_str("sequence or map length differs from its element count"),
            Self::TooDeep => f.write_str("nesting too deep"),
            Self::Custom(msg) => f.write_str(msg.as_str()),
        }
    }
}

impl core::error::Error for Error {
    fn source(&self) -> Option<&(dyn core::error::Error + 'static)> {
        match self {
            Self::Cdr(e) => Some(e),
            _ => None,
        }
    }
}

impl serde::ser::Error for Error {
    fn custom<T: fmt::Display>(msg: T) -> Self {
        Self::Custom(Message::new(&msg))
    }
}

impl serde::de::Error for Error {
    fn custom<T: fmt::Display>(msg: T) -> Self {
        Self::Custom(Message::new(&msg))
    }
}

/// Result of this module's operations.
pub type Result<T> = core::result::Result<T, Error>;

/// Serializes `value` little endian into `out`; returns the bytes written.
///
/// On a buffer too small, returns [`Error::BufferTooSmall`] with the size the whole encoding needs.
pub fn to_slice<T: serde::Serialize + ?Sized>(value: &T, out: &mut [u8]) -> Result<usize> {
    to_slice_with(value, out, Endianness::Little)
}

/// Serializes `value` in byte order `endian` into `out`; returns the bytes written.
///
/// On a buffer too small, returns [`Error::BufferTooSmall`] with the size the whole encoding needs.
pub fn to_slice_with<T: serde::Serialize + ?Sized>(value: &T, out: &mut [u8], endian: Endianness) -> Result<usize> {
    let mut w = Writer::new(out, endian);
    to_writer(value, &mut w)?;
    Ok(w.finish()?)
}

/// Serializes `value` at the writer's position, aligning relative to the writer's origin (set it to the first
/// byte of the payload). Serde errors are returned; buffer exhaustion and length overflows are recorded in the
/// writer and reported by [`Writer::finish`].
pub fn to_writer<T: serde::Serialize + ?Sized>(value: &T, writer: &mut Writer<'_>) -> Result<()> {
    value.serialize(&mut Serializer::new(writer))
}

/// The size of `value`'s encoding (the same in both byte orders); the `size_of_topic` counterpart.
pub fn serialized_size<T: serde::Serialize + ?Sized>(value: &T) -> Result<usize> {
    match to_slice(value, &mut []) {
        Err(Error::BufferTooSmall { needed }) => Ok(needed),
        other => other,
    }
}

/// Deserializes a little-endian value from the start of `bytes`, borrowing strings and byte sequences from it.
/// Trailing bytes are ignored.
pub fn from_slice<'de, T: serde::Deserialize<'de>>(bytes: &'de [u8]) -> Result<T> {
    from_slice_with(bytes, Endianness::Little)
}

/// Deserializes a value in byte order `endian` from the start of `bytes`. Trailing bytes are ignored.
pub fn from_slice_with<'de, T: serde::Deserialize<'de>>(bytes: &'de [u8], endian: Endianness) -> Result<T> {
    from_prefix_with(bytes, endian).map(|(value, _)| value)
}

/// Deserializes a value in byte order `endian` from the start of `bytes`; also returns how many bytes it took.
pub fn from_prefix_with<'de, T: serde::Deserialize<'de>>(bytes: &'de [u8], endian: Endianness) -> Result<(T, usize)> {
    let mut r = Reader::new(bytes, endian);
    let value = from_reader(&mut r)?;
    Ok((value, r.position()))
}

/// Deserializes a value at the reader's position, aligning relative to the reader's origin, with the default
/// limits (element budget = bytes left in the reader, [`DEFAULT_MAX_DEPTH`]).
pub fn from_reader<'de, T: serde::Deserialize<'de>>(reader: &mut Reader<'de>) -> Result<T> {
    T::deserialize(&mut Deserializer::new(reader))
}

#[cfg(test)]
mod tests {
    extern crate std;

    use std::collections::BTreeMap;
    use std::string::{String, ToString};
    use std::vec;
    use std::vec::Vec;

    use proptest::prelude::*;
    use serde::{Deserialize, Serialize};

    use super::*;

    const ENDIANS: [Endianness; 2] = [Endianness::Little, Endianness::Big];

    fn encode<T: Serialize + ?Sized>(value: &T, endian: Endianness) -> Vec<u8> {
        let needed = serialized_size(value).unwrap();
        let mut buf = vec![0xEEu8; needed];
        assert_eq!(to_slice_with(value, &mut buf, endian), Ok(needed));
        buf
    }

    #[derive(Serialize, Deserialize, Debug, PartialEq)]
    struct HelloWorld {
        index: u32,
        message: String,
    }

    #[derive(Serialize, Deserialize, Debug, PartialEq)]
    struct ShapeType {
        color: String,
        x: i32,
        y: i32,
        shapesize: i32,
    }

    const HELLO_BYTES: [u8; 25] = [
        0x01, 0x00, 0x00, 0x00, 0x11, 0x00, 0x00, 0x00, 0x48, 0x65, 0x6C, 0x6C, 0x6F, 0x20, 0x44, 0x44, 0x53, 0x20,
        0x77, 0x6F, 0x72, 0x6C, 0x64, 0x21, 0x00,
    ];

    #[test]
    fn hello_world_matches_micro_cdr() {
        let sample = HelloWorld { index: 1, message: "Hello DDS world!".into() };
        let mut buf = [0u8; 64];
        let n = to_slice(&sample, &mut buf).unwrap();
        assert_eq!(&buf[..n], &HELLO_BYTES);
        assert_eq!(serialized_size(&sample), Ok(25));
        assert_eq!(from_slice::<HelloWorld>(&HELLO_BYTES), Ok(sample));
    }

    #[test]
    fn hello_world_borrows_from_input() {
        #[derive(Serialize, Deserialize, Debug, PartialEq)]
        struct HelloRef<'a> {
            index: u32,
            message: &'a str,
        }
        let back: HelloRef<'_> = from_slice(&HELLO_BYTES).unwrap();
        assert_eq!(back, HelloRef { index: 1, message: "Hello DDS world!" });
        assert!(HELLO_BYTES.as_ptr_range().contains(&back.message.as_ptr()));
        assert_eq!(encode(&back, Endianness::Little), HELLO_BYTES);
    }

    #[test]
    fn shape_type_matches_micro_cdr() {
        let shape = ShapeType { color: "RED".into(), x: 10, y: 20, shapesize: 30 };
        let expected = [
            0x04, 0x00, 0x00, 0x00, 0x52, 0x45, 0x44, 0x00, 0x0A, 0x00, 0x00, 0x00, 0x14, 0x00, 0x00, 0x00, 0x1E, 0x00,
            0x00, 0x00,
        ];
        assert_eq!(encode(&shape, Endianness::Little), expected);
        assert_eq!(from_slice::<ShapeType>(&expected), Ok(shape));
        // Big endian: the same layout, numbers reversed.
        let shape = ShapeType { color: "RED".into(), x: 10, y: 20, shapesize: 30 };
        let big = [0, 0, 0, 4, b'R', b'E', b'D', 0, 0, 0, 0, 10, 0, 0, 0, 20, 0, 0, 0, 30];
        assert_eq!(encode(&shape, Endianness::Big), big);
        assert_eq!(from_slice_with::<ShapeType>(&big, Endianness::Big), Ok(shape));
    }

    #[test]
    fn alignment_and_padding_in_both_byte_orders() {
        #[derive(Serialize, Deserialize, Debug, PartialEq)]
        struct Wide {
            a: u8,
            b: u64,
        }
        #[derive(Serialize, Deserialize, Debug, PartialEq)]
        struct Narrow {
            a: u8,
            b: u16,
            c: u8,
            d: f32,
        }
        let wide = Wide { a: 0xAB, b: 0x0102_0304_0506_0708 };
        let le = encode(&wide, Endianness::Little);
        assert_eq!(le, [0xAB, 0, 0, 0, 0, 0, 0, 0, 8, 7, 6, 5, 4, 3, 2, 1]);
        let be = encode(&wide, Endianness::Big);
        assert_eq!(be, [0xAB, 0, 0, 0, 0, 0, 0, 0, 1, 2, 3, 4, 5, 6, 7, 8]);
        assert_eq!(from_slice_with::<Wide>(&le, Endianness::Little), Ok(Wide { a: 0xAB, b: 0x0102_0304_0506_0708 }));
        assert_eq!(from_slice_with::<Wide>(&be, Endianness::Big), Ok(Wide { a: 0xAB, b: 0x0102_0304_0506_0708 }));

        let narrow = Narrow { a: 1, b: 0x0203, c: 4, d: 1.0 };
        let le = encode(&narrow, Endianness::Little);
        assert_eq!(le, [1, 0, 3, 2, 4, 0, 0, 0, 0x00, 0x00, 0x80, 0x3F]);
        let be = encode(&narrow, Endianness::Big);
        assert_eq!(be, [1, 0, 2, 3, 4, 0, 0, 0, 0x3F, 0x80, 0x00, 0x00]);
        assert_eq!(from_slice_with::<Narrow>(&le, Endianness::Little), Ok(Narrow { a: 1, b: 0x0203, c: 4, d: 1.0 }));
        assert_eq!(from_slice_with::<Narrow>(&be, Endianness::Big), Ok(Narrow { a: 1, b: 0x0203, c: 4, d: 1.0 }));
    }

    #[test]
    fn alignment_is_relative_to_the_payload_origin() {
        // A payload placed after a 4-byte header: the u64 aligns from the payload start, not the buffer start.
        let mut buf = [0xEEu8; 32];
        let mut w = Writer::with_origin(&mut buf, 4, 4, Endianness::Little);
        to_writer(&(1u8, 2u64), &mut w).unwrap();
        assert_eq!(w.finish(), Ok(20));
        assert_eq!(&buf[4..20], &[1, 0, 0, 0, 0, 0, 0, 0, 2, 0, 0, 0, 0, 0, 0, 0]);
        let mut r = Reader::with_origin(&buf, 4, 4, Endianness::Little);
        assert_eq!(from_reader::<(u8, u64)>(&mut r), Ok((1, 2)));
        assert_eq!(r.position(), 20);
    }

    #[test]
    fn sequences_arrays_options_enums_maps() {
        #[derive(Serialize, Deserialize, Debug, PartialEq)]
        enum Color {
            Red,
            Green,
            Blue,
        }
        #[derive(Serialize, Deserialize, Debug, PartialEq)]
        enum Union {
            A(u8),
            B { x: u16 },
        }
        #[derive(Serialize, Deserialize, Debug, PartialEq)]
        struct Meters(f64);
        #[derive(Serialize, Deserialize, Debug, PartialEq)]
        struct Unit;

        let le = Endianness::Little;
        assert_eq!(encode(&vec![1u16, 2, 3], le), [3, 0, 0, 0, 1, 0, 2, 0, 3, 0]);
        assert_eq!(encode(&[1u16, 2, 3], le), [1, 0, 2, 0, 3, 0]);
        assert_eq!(encode(&(1u8, 2u16), le), [1, 0, 2, 0]);
        assert_eq!(encode(&Some(7u32), le), [1, 0, 0, 0, 7, 0, 0, 0]);
        assert_eq!(encode(&None::<u32>, le), [0]);
        assert_eq!(encode(&Color::Blue, le), [2, 0, 0, 0]);
        assert_eq!(encode(&Union::A(9), le), [0, 0, 0, 0, 9]);
        assert_eq!(encode(&Union::B { x: 9 }, Endianness::Big), [0, 0, 0, 1, 0, 9]);
        assert_eq!(encode(&Meters(1.0), Endianness::Big), 1.0f64.to_be_bytes());
        assert_eq!(encode(&Unit, le), [] as [u8; 0]);
        assert_eq!(encode(&(), le), [] as [u8; 0]);
        let map: BTreeMap<u8, u16> = [(1, 2), (3, 4)].into_iter().collect();
        assert_eq!(encode(&map, le), [2, 0, 0, 0, 1, 0, 2, 0, 3, 0, 4, 0]);
        assert_eq!(encode(&'é', le), [0xE9]);
        assert_eq!(encode("", le), [1, 0, 0, 0, 0]);

        assert_eq!(from_slice::<Color>(&[1, 0, 0, 0]), Ok(Color::Green));
        assert_eq!(from_slice::<Union>(&[1, 0, 0, 0, 9, 0]), Ok(Union::B { x: 9 }));
        assert_eq!(from_slice::<BTreeMap<u8, u16>>(&[2, 0, 0, 0, 1, 0, 2, 0, 3, 0, 4, 0]), Ok(map));
        assert_eq!(from_slice::<char>(&[0xE9]), Ok('é'));
        // A zero length is read as the empty string, as Fast-CDR does.
        assert_eq!(from_slice::<&str>(&[0, 0, 0, 0]), Ok(""));
        assert!(matches!(from_slice::<Color>(&[3, 0, 0, 0]), Err(Error::Custom(_))));
    }

    #[test]
    fn bytes_are_octet_sequences_and_borrow() {
        struct Raw<'a>(&'a [u8]);
        impl Serialize for Raw<'_> {
            fn serialize<S: serde::Serializer>(&self, s: S) -> core::result::Result<S::Ok, S::Error> {
                s.serialize_bytes(self.0)
            }
        }
        let data = [1u8, 2, 3];
        let via_bytes = encode(&Raw(&data), Endianness::Big);
        let via_seq = encode(&data[..], Endianness::Big);
        let via_vec = encode(&data.to_vec(), Endianness::Big);
        assert_eq!(via_bytes, [0, 0, 0, 3, 1, 2, 3]);
        assert_eq!(via_seq, via_bytes);
        assert_eq!(via_vec, via_bytes);
        let borrowed: &[u8] = from_slice_with(&via_bytes, Endianness::Big).unwrap();
        assert_eq!(borrowed, &data);
        assert!(via_bytes.as_ptr_range().contains(&borrowed.as_ptr()));
        assert_eq!(from_slice_with::<Vec<u8>>(&via_bytes, Endianness::Big), Ok(data.to_vec()));
    }

    #[test]
    fn collect_str_writes_a_string() {
        struct Shown(u32);
        impl Serialize for Shown {
            fn serialize<S: serde::Serializer>(&self, s: S) -> core::result::Result<S::Ok, S::Error> {
                s.collect_str(&format_args!("n={}", self.0))
            }
        }
        let bytes = encode(&Shown(42), Endianness::Little);
        assert_eq!(bytes, [5, 0, 0, 0, b'n', b'=', b'4', b'2', 0]);
        assert_eq!(from_slice::<String>(&bytes), Ok("n=42".to_string()));
    }

    #[test]
    fn truncated_input_is_an_error_at_every_length() {
        for n in 0..HELLO_BYTES.len() {
            let got = from_slice::<HelloWorld>(&HELLO_BYTES[..n]);
            assert!(matches!(got, Err(Error::Cdr(cdr::Error::Truncated))), "{n}: {got:?}");
        }
        // Trailing bytes are left alone, and reported by from_prefix_with.
        let mut longer = HELLO_BYTES.to_vec();
        longer.extend_from_slice(&[0, 0, 0]);
        let (_, used) = from_prefix_with::<HelloWorld>(&longer, Endianness::Little).unwrap();
        assert_eq!(used, 25);
    }

    #[test]
    fn malformed_values_are_rejected() {
        assert_eq!(from_slice::<bool>(&[2]), Err(Error::Cdr(cdr::Error::InvalidBool(2))));
        assert_eq!(from_slice::<Option<u8>>(&[5, 1]), Err(Error::Cdr(cdr::Error::InvalidBool(5))));
        assert_eq!(from_slice::<&str>(&[2, 0, 0, 0, b'a', b'b']), Err(Error::Cdr(cdr::Error::InvalidString)));
        assert_eq!(from_slice::<&str>(&[2, 0, 0, 0, 0xFF, 0]), Err(Error::Cdr(cdr::Error::InvalidString)));
        assert!(matches!(from_slice::<u128>(&[0; 16]), Err(Error::Unsupported(_))));
        assert!(matches!(from_slice::<serde::de::IgnoredAny>(&[0; 16]), Err(Error::Unsupported(_))));
        // An array read from a sequence-shaped input of the wrong length.
        assert!(matches!(from_slice::<[u8; 2]>(&[1]), Err(Error::Cdr(cdr::Error::Truncated))));
    }

    #[test]
    fn hostile_counts_are_rejected_before_any_work() {
        let huge = [0xFF, 0xFF, 0xFF, 0xFF, 1, 2, 3];
        assert_eq!(from_slice::<Vec<u8>>(&huge), Err(Error::Cdr(cdr::Error::SequenceTooLong(u32::MAX))));
        assert_eq!(from_slice::<&[u8]>(&huge), Err(Error::Cdr(cdr::Error::SequenceTooLong(u32::MAX))));
        assert_eq!(from_slice::<Vec<u64>>(&huge), Err(Error::Cdr(cdr::Error::SequenceTooLong(u32::MAX))));
        assert_eq!(from_slice::<BTreeMap<u8, u8>>(&huge), Err(Error::Cdr(cdr::Error::SequenceTooLong(u32::MAX))));
        assert_eq!(from_slice::<&str>(&huge), Err(Error::Cdr(cdr::Error::Truncated)));
        // Zero-sized elements take no bytes: the element budget (input length) still bounds them.
        assert_eq!(from_slice::<Vec<()>>(&[3, 0, 0, 0, 9, 9, 9]), Ok(vec![(), (), ()]));
        assert_eq!(from_slice::<Vec<()>>(&[4, 0, 0, 0, 9, 9, 9]), Err(Error::Cdr(cdr::Error::SequenceTooLong(4))));
        // Nested sequences of zero-sized elements cannot square the work either.
        let mut nested = vec![16, 0, 0, 0];
        for _ in 0..16 {
            nested.extend_from_slice(&[40, 0, 0, 0]);
        }
        nested.resize(nested.len() + 40, 0);
        assert!(matches!(from_slice::<Vec<Vec<()>>>(&nested), Err(Error::Cdr(cdr::Error::SequenceTooLong(_)))));
    }

    #[test]
    fn recursion_is_bounded() {
        #[derive(Serialize, Deserialize, Debug)]
        struct Node {
            next: Option<std::boxed::Box<Node>>,
        }
        let deep = [1u8; 10_000];
        assert!(matches!(from_slice::<Node>(&deep), Err(Error::TooDeep)));
        let mut shallow = [1u8; 10];
        shallow[9] = 0;
        assert!(from_slice::<Node>(&shallow).is_ok());
    }

    #[test]
    fn small_buffer_reports_the_size_needed() {
        let sample = HelloWorld { index: 1, message: "Hello DDS world!".into() };
        let mut buf = [0u8; 10];
        let err = to_slice(&sample, &mut buf).unwrap_err();
        assert_eq!(err, Error::BufferTooSmall { needed: 25 });
        assert_eq!(err.needed(), Some(25));
        assert_eq!(to_slice(&sample, &mut []), Err(Error::BufferTooSmall { needed: 25 }));
        let mut exact = [0u8; 25];
        assert_eq!(to_slice(&sample, &mut exact), Ok(25));
    }

    #[test]
    fn values_without_cdr_encoding_are_refused() {
        struct Unsized;
        impl Serialize for Unsized {
            fn serialize<S: serde::Serializer>(&self, s: S) -> core::result::Result<S::Ok, S::Error> {
                s.collect_seq([1u8, 2, 3].iter().filter(|b| **b > 1))
            }
        }
        struct Liar;
        impl Serialize for Liar {
            fn serialize<S: serde::Serializer>(&self, s: S) -> core::result::Result<S::Ok, S::Error> {
                use serde::ser::SerializeSeq;
                let mut seq = s.serialize_seq(Some(2))?;
                seq.serialize_element(&1u8)?;
                seq.end()
            }
        }
        #[derive(Serialize)]
        struct Skipping {
            #[serde(skip_serializing_if = "Option::is_none")]
            a: Option<u8>,
        }
        let mut buf = [0u8; 32];
        assert!(matches!(to_slice(&Unsized, &mut buf), Err(Error::Unsupported(_))));
        assert_eq!(to_slice(&Liar, &mut buf), Err(Error::LengthMismatch));
        assert!(matches!(to_slice(&'€', &mut buf), Err(Error::Unsupported(_))));
        assert!(matches!(to_slice(&1u128, &mut buf), Err(Error::Unsupported(_))));
        assert!(matches!(to_slice(&Skipping { a: None }, &mut buf), Err(Error::Unsupported(_))));
        assert_eq!(to_slice(&Skipping { a: Some(1) }, &mut buf), Ok(2));
    }

    #[test]
    fn custom_messages_are_truncated_at_a_char_boundary() {
        use serde::de::Error as _;
        let long = "é".repeat(100);
        let Error::Custom(msg) = Error::custom(&long) else { panic!("not custom") };
        assert_eq!(msg.as_str().len(), 64);
        assert!(long.starts_with(msg.as_str()));
        let Error::Custom(msg) = Error::custom(format_args!("{}x", "é".repeat(31))) else { panic!("not custom") };
        assert_eq!(msg.as_str(), "é".repeat(31) + "x");
        assert_eq!(Error::custom("short").to_string(), "short");
        let e: &dyn core::error::Error = &Error::Cdr(cdr::Error::Truncated);
        assert!(e.source().is_some());
    }

    #[derive(Serialize, Deserialize, Debug, Clone, PartialEq)]
    enum Kind {
        Empty,
        Number(i64),
        Pair(u8, f32),
        Named { text: String, flag: bool },
    }

    #[derive(Serialize, Deserialize, Debug, Clone, PartialEq)]
    enum Level {
        Low,
        Mid,
        High,
    }

    #[derive(Serialize, Deserialize, Debug, Clone, PartialEq)]
    struct Id(u16);

    #[derive(Serialize, Deserialize, Debug, Clone, PartialEq)]
    struct Marker;

    #[derive(Serialize, Deserialize, Debug, Clone, PartialEq)]
    struct Inner {
        tag: u8,
        value: f64,
    }

    #[derive(Serialize, Deserialize, Debug, Clone, PartialEq)]
    struct Everything {
        b: bool,
        u8_: u8,
        i8_: i8,
        u16_: u16,
        i16_: i16,
        u32_: u32,
        i32_: i32,
        u64_: u64,
        i64_: i64,
        f32_: f32,
        f64_: f64,
        c: char,
        s: String,
        octets: Vec<u8>,
        shorts: Vec<i16>,
        names: Vec<String>,
        array: [u32; 3],
        tuple: (u8, u64, bool),
        opt_small: Option<u16>,
        opt_text: Option<String>,
        level: Level,
        kinds: Vec<Kind>,
        id: Id,
        marker: Marker,
        unit: (),
        map: BTreeMap<u16, String>,
        inners: Vec<Inner>,
        grid: [[i8; 2]; 2],
    }

    fn finite_f32() -> impl Strategy<Value = f32> {
        prop::num::f32::NORMAL | prop::num::f32::SUBNORMAL | prop::num::f32::ZERO | prop::num::f32::INFINITE
    }

    fn finite_f64() -> impl Strategy<Value = f64> {
        prop::num::f64::NORMAL | prop::num::f64::SUBNORMAL | prop::num::f64::ZERO | prop::num::f64::INFINITE
    }

    fn kind() -> impl Strategy<Value = Kind> {
        prop_oneof![
            Just(Kind::Empty),
            any::<i64>().prop_map(Kind::Number),
            (any::<u8>(), finite_f32()).prop_map(|(a, b)| Kind::Pair(a, b)),
            (".{0,8}", any::<bool>()).prop_map(|(text, flag)| Kind::Named { text, flag }),
        ]
    }

    fn everything() -> impl Strategy<Value = Everything> {
        let numbers = (
            any::<bool>(),
            any::<u8>(),
            any::<i8>(),
            any::<u16>(),
            any::<i16>(),
            any::<u32>(),
            any::<i32>(),
            any::<u64>(),
            any::<i64>(),
            finite_f32(),
            finite_f64(),
            any::<u8>().prop_map(char::from),
        );
        let texts = (
            ".{0,12}",
            prop::collection::vec(any::<u8>(), 0..9),
            prop::collection::vec(any::<i16>(), 0..5),
            prop::collection::vec(".{0,4}", 0..4),
            any::<[u32; 3]>(),
            (any::<u8>(), any::<u64>(), any::<bool>()),
            any::<Option<u16>>(),
            prop::option::of(".{0,5}"),
            prop_oneof![Just(Level::Low), Just(Level::Mid), Just(Level::High)],
            prop::collection::vec(kind(), 0..4),
            any::<u16>().prop_map(Id),
        );
        let rest = (
            prop::collection::btree_map(any::<u16>(), ".{0,4}", 0..4),
            prop::collection::vec((any::<u8>(), finite_f64()).prop_map(|(tag, value)| Inner { tag, value }), 0..3),
            any::<[[i8; 2]; 2]>(),
        );
        (numbers, texts, rest).prop_map(
            |(
                (b, u8_, i8_, u16_, i16_, u32_, i32_, u64_, i64_, f32_, f64_, c),
                (s, octets, shorts, names, array, tuple, opt_small, opt_text, level, kinds, id),
                (map, inners, grid),
            )| Everything {
                b,
                u8_,
                i8_,
                u16_,
                i16_,
                u32_,
                i32_,
                u64_,
                i64_,
                f32_,
                f64_,
                c,
                s,
                octets,
                shorts,
                names,
                array,
                tuple,
                opt_small,
                opt_text,
                level,
                kinds,
                id,
                marker: Marker,
                unit: (),
                map,
                inners,
                grid,
            },
        )
    }

    proptest! {
        #[test]
        fn everything_round_trips_in_both_byte_orders(value in everything()) {
            let size = serialized_size(&value).unwrap();
            for endian in ENDIANS {
                let bytes = encode(&value, endian);
                prop_assert_eq!(bytes.len(), size);
                let (back, used) = from_prefix_with::<Everything>(&bytes, endian).unwrap();
                prop_assert_eq!(used, size);
                prop_assert_eq!(&back, &value);
                // Every shorter buffer reports the full size; every prefix fails to decode.
                let mut short = vec![0u8; size / 2];
                prop_assert_eq!(to_slice_with(&value, &mut short, endian), Err(Error::BufferTooSmall { needed: size }));
                prop_assert!(from_slice_with::<Everything>(&bytes[..size / 2], endian).is_err());
            }
        }

        #[test]
        fn garbage_never_panics(bytes in prop::collection::vec(any::<u8>(), 0..256), big in any::<bool>()) {
            let endian = if big { Endianness::Big } else { Endianness::Little };
            let _ = from_slice_with::<Everything>(&bytes, endian);
            let _ = from_slice_with::<Vec<Kind>>(&bytes, endian);
            let _ = from_slice_with::<BTreeMap<String, Vec<Option<u64>>>>(&bytes, endian);
        }
    }
}
