//! The CDR serde layer (`xrce_proto::serde_cdr`): decoding arbitrary bytes into a type using every mapping
//! (primitives, chars, strings, bytes, sequences, arrays, tuples, options, enums with and without data, maps,
//! nesting) in both byte orders must never panic, and for arbitrary values decode(encode(x)) == x, the size
//! reported equals the bytes written, and a buffer one byte short is refused.
#![no_main]

use std::collections::BTreeMap;

use arbitrary::Arbitrary;
use libfuzzer_sys::fuzz_target;
use serde::{Deserialize, Serialize};
use xrce_proto::serde_cdr::{from_slice_with, serialized_size, to_slice_with, Endianness};

#[derive(Arbitrary, Serialize, Deserialize, Debug, PartialEq, Clone)]
enum Shape {
    Empty,
    Point(i16, u64),
    Named { name: String, tags: Vec<u8> },
    Wrapped(Box<Inner>),
}

#[derive(Arbitrary, Serialize, Deserialize, Debug, PartialEq, Clone)]
struct Inner {
    flag: bool,
    letter: char,
    small: i8,
    ratio: f32,
    values: Vec<i32>,
}

#[derive(Arbitrary, Serialize, Deserialize, Debug, PartialEq, Clone)]
struct Sample {
    id: u32,
    seconds: f64,
    text: String,
    #[serde(with = "serde_bytes_like")]
    blob: Vec<u8>,
    fixed: [u16; 3],
    pair: (u8, i64),
    maybe: Option<Inner>,
    shapes: Vec<Shape>,
    table: BTreeMap<u8, String>,
    unit: (),
}

/// `blob` through `serialize_bytes` (CDR `sequence<octet>`), as `serde_bytes` would.
mod serde_bytes_like {
    pub fn serialize<S: serde::Serializer>(v: &[u8], s: S) -> Result<S::Ok, S::Error> {
        s.serialize_bytes(v)
    }

    pub fn deserialize<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Vec<u8>, D::Error> {
        struct Bytes;
        impl<'de> serde::de::Visitor<'de> for Bytes {
            type Value = Vec<u8>;
            fn expecting(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
                f.write_str("bytes")
            }
            fn visit_bytes<E>(self, v: &[u8]) -> Result<Vec<u8>, E> {
                Ok(v.to_vec())
            }
            fn visit_seq<A: serde::de::SeqAccess<'de>>(self, mut seq: A) -> Result<Vec<u8>, A::Error> {
                let mut out = Vec::new();
                while let Some(b) = seq.next_element()? {
                    out.push(b);
                }
                Ok(out)
            }
        }
        d.deserialize_bytes(Bytes)
    }
}

#[derive(Arbitrary, Debug)]
struct Input {
    big_endian: bool,
    sample: Sample,
    bytes: Vec<u8>,
}

fuzz_target!(|input: Input| {
    let endian = if input.big_endian { Endianness::Big } else { Endianness::Little };
    // 1. Arbitrary bytes, several types.
    let _ = from_slice_with::<Sample>(&input.bytes, endian);
    let _ = from_slice_with::<Vec<Shape>>(&input.bytes, endian);
    let _ = from_slice_with::<(String, Option<char>, BTreeMap<u16, Vec<f64>>)>(&input.bytes, endian);
    // 2. Round trip of an arbitrary value (a char beyond U+00FF is refused, as documented).
    let sample = input.sample;
    let Ok(size) = serialized_size(&sample) else { return };
    let mut buf = vec![0u8; size];
    let n = to_slice_with(&sample, &mut buf, endian).expect("serialized_size bytes suffice");
    assert_eq!(n, size, "serialized_size disagrees with the bytes written");
    if size > 0 {
        assert!(to_slice_with(&sample, &mut vec![0u8; size - 1], endian).is_err(), "one byte short was accepted");
    }
    let back: Sample = from_slice_with(&buf, endian).expect("what was encoded decodes");
    // Debug equality treats NaN as equal to itself; the bytes catch a changed NaN payload.
    assert_eq!(format!("{back:?}"), format!("{sample:?}"));
    let mut again = vec![0u8; size];
    assert_eq!(to_slice_with(&back, &mut again, endian).ok(), Some(size));
    assert_eq!(again, buf);
});
