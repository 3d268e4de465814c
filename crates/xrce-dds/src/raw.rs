//! The opaque sample type and its RustDDS (de)serializer adapters.
//!
//! The agent never knows the Rust type of a topic: it carries the XRCE client's bytes, which are the CDR body
//! of the sample. eProsima's agent prepends the encapsulation `00 01 00 00` (CDR little endian, options 0)
//! when publishing and strips the first 4 bytes of whatever it receives (spec §8.4). RustDDS already writes
//! the 4-byte encapsulation itself from [`SerializerAdapter::output_encoding`] and hands the decoder only the
//! bytes after it, so the adapters below pass the body through untouched: the header is neither doubled on
//! publish nor left in on receive.

use std::io;

use rustdds::bytes::Bytes;
use rustdds::no_key::{Decode, DefaultDecoder, DeserializerAdapter, SerializerAdapter};
use rustdds::RepresentationIdentifier;

/// One sample as opaque bytes: the CDR body (no encapsulation header) and, on receive, the encapsulation
/// identifier the writer used.
#[derive(Clone, Debug)]
pub(crate) struct RawSample {
    /// CDR body, without the 4-byte encapsulation header.
    pub body: Bytes,
    /// Representation identifier of the received sample (`[0, 1]` = CDR_LE). Always CDR_LE on publish.
    pub encapsulation: [u8; 2],
}

/// Pass-through adapter: RustDDS calls it to turn a [`RawSample`] into payload bytes and back.
pub(crate) struct RawAdapter;

impl SerializerAdapter<RawSample> for RawAdapter {
    type Error = io::Error;

    // RustDDS takes the encapsulation from this static function, so every sample we publish says CDR_LE,
    // which is what eProsima's agent writes regardless of the client's byte order (spec §8.4).
    fn output_encoding() -> RepresentationIdentifier {
        RepresentationIdentifier::CDR_LE
    }

    fn to_bytes(value: &RawSample) -> Result<Bytes, io::Error> {
        // Cheap: `Bytes` is reference counted. RustDDS prepends the 4-byte header itself.
        Ok(value.body.clone())
    }
}

impl DeserializerAdapter<RawSample> for RawAdapter {
    type Error = io::Error;
    type Decoded = RawSample;

    // Everything a peer may send is accepted and stripped, as eProsima does; the identifier is kept in the
    // sample so the caller can tell a big-endian or XCDR2 body from the usual CDR_LE one.
    fn supported_encodings() -> &'static [RepresentationIdentifier] {
        &[
            RepresentationIdentifier::CDR_LE,
            RepresentationIdentifier::CDR_BE,
            RepresentationIdentifier::PL_CDR_LE,
            RepresentationIdentifier::PL_CDR_BE,
            RepresentationIdentifier::CDR2_LE,
            RepresentationIdentifier::CDR2_BE,
            RepresentationIdentifier::D_CDR2_LE,
            RepresentationIdentifier::D_CDR2_BE,
            RepresentationIdentifier::PL_CDR2_LE,
            RepresentationIdentifier::PL_CDR2_BE,
        ]
    }

    fn transform_decoded(decoded: RawSample) -> RawSample {
        decoded
    }
}

/// Decoder handed to RustDDS: `input` is already the body after the encapsulation header.
#[derive(Clone)]
pub(crate) struct RawDecoder;

impl<'de> Decode<'de, RawSample> for RawDecoder {
    type Error = io::Error;

    fn decode_bytes(self, input: &'de [u8], enc: RepresentationIdentifier) -> Result<RawSample, io::Error> {
        Ok(RawSample { body: Bytes::copy_from_slice(input), encapsulation: enc.to_bytes() })
    }
}

impl DefaultDecoder<RawSample> for RawAdapter {
    type Decoder = RawDecoder;
    const DECODER: RawDecoder = RawDecoder;
}

// ---- keyed topics
//
// The agent cannot compute a key from opaque bytes, so every raw sample has the same constant key. Typed
// peers compute the real key from the payload (RustDDS sends no PID_KEY_HASH with ordinary DATA), so a
// Cyclone or Fast DDS reader still sees distinct instances. On our side all samples of a keyed topic fall in
// one RustDDS instance, which is why keyed readers are always created KEEP_ALL locally (see `reader.rs`):
// a per-instance KEEP_LAST would otherwise overwrite samples of different real instances.

impl rustdds::Keyed for RawSample {
    type K = u8;
    fn key(&self) -> u8 {
        0
    }
}

impl rustdds::with_key::SerializerAdapter<RawSample> for RawAdapter {
    fn key_to_bytes(_key: &u8) -> Result<Bytes, io::Error> {
        Ok(Bytes::from_static(&[0]))
    }
}

impl rustdds::with_key::DeserializerAdapter<RawSample> for RawAdapter {
    type DecodedKey = u8;
    fn transform_decoded_key(key: u8) -> u8 {
        key
    }
}

impl<'de> rustdds::with_key::Decode<'de, RawSample, u8> for RawDecoder {
    fn decode_key_bytes(self, _bytes: &'de [u8], _enc: RepresentationIdentifier) -> Result<u8, io::Error> {
        Ok(0)
    }
}

impl rustdds::with_key::DefaultDecoder<RawSample> for RawAdapter {
    type Decoder = RawDecoder;
    const DECODER: RawDecoder = RawDecoder;
}
