//! Serial (HDLC-like) framing: the decoder must survive any byte stream cut anywhere with consistent
//! counters, and any payload must survive encode -> (garbage +) decode.
#![no_main]

use libfuzzer_sys::fuzz_target;
use xrce_proto::framing::serial::{self, AddressFilter, Event, FrameDecoder};

/// Chunk sizes 1..=16 taken from the input itself, so the fuzzer also explores the cut points.
fn chunks<'a>(data: &'a [u8], sizes: &'a [u8]) -> impl Iterator<Item = &'a [u8]> + 'a {
    let mut rest = data;
    let mut i = 0usize;
    core::iter::from_fn(move || {
        if rest.is_empty() {
            return None;
        }
        let size = sizes.get(i % sizes.len().max(1)).map_or(rest.len(), |&s| usize::from(s % 16) + 1);
        i += 1;
        let (head, tail) = rest.split_at(size.min(rest.len()));
        rest = tail;
        Some(head)
    })
}

/// Feeds `input` and checks the decoder's invariants; returns the frames it delivered.
fn decode_all<B: AsRef<[u8]> + AsMut<[u8]>>(
    decoder: &mut FrameDecoder<B>,
    input: &[u8],
    sizes: &[u8],
) -> Vec<(u8, u8, Vec<u8>)> {
    let capacity = decoder.capacity();
    let mut frames = Vec::new();
    for piece in chunks(input, sizes) {
        let mut rest = piece;
        while !rest.is_empty() {
            let (used, event) = decoder.feed(rest);
            assert!(used >= 1 && used <= rest.len());
            if let Some(Event::Frame { src, dst, payload }) = event {
                assert!(payload.len() <= capacity);
                frames.push((src, dst, payload.to_vec()));
            } else {
                assert!(event.is_some() || used == rest.len(), "feed stops early only on an event");
            }
            rest = &rest[used..];
        }
    }
    let s = decoder.stats;
    assert_eq!(
        s.bytes_received as usize,
        s.bytes_in_frames as usize + s.bytes_dropped as usize + decoder.pending_len()
    );
    assert_eq!(s.frames_ok as usize, frames.len());
    frames
}

fuzz_target!(|data: &[u8]| {
    let Some((&control, rest)) = data.split_first() else { return };
    let sizes = rest.get(..rest.len().min(8)).unwrap_or(&[]);

    // 1. Arbitrary bytes, arbitrary cuts, small and large buffers, both filters.
    let mut small = FrameDecoder::new([0u8; 16], AddressFilter::Only(control));
    decode_all(&mut small, rest, sizes);
    let mut large = FrameDecoder::new([0u8; 1024], AddressFilter::Any);
    decode_all(&mut large, rest, sizes);

    // 2. Round trip: the input after two address bytes is a payload.
    let (src, dst, payload) = match rest {
        [src, dst, payload @ ..] => (*src, *dst, &payload[..payload.len().min(1024)]),
        _ => return,
    };
    let mut wire = vec![0u8; serial::max_encoded_len(payload.len())];
    let n = serial::encode_frame(src, dst, payload, &mut wire).expect("buffer of max_encoded_len suffices");
    wire.truncate(n);
    assert_eq!(serial::encoded_len(src, dst, payload), Ok(n));
    assert!(serial::FrameBytes::new(src, dst, payload).expect("payload fits").eq(wire.iter().copied()));
    assert_eq!(wire.iter().filter(|&&b| b == serial::FLAG).count(), 1, "only the leading flag is unescaped");
    if n > 0 {
        let short = serial::encode_frame(src, dst, payload, &mut vec![0u8; n - 1]);
        assert_eq!(short, Err(serial::FrameError::BufferTooSmall { needed: n }));
    }

    // 3. The frame after arbitrary garbage (partial frames, stray escapes, flags) still decodes: its flag
    //    always restarts the decoder.
    let mut stream = rest.to_vec();
    stream.extend_from_slice(&wire);
    let filter = if control & 1 == 0 { AddressFilter::Any } else { AddressFilter::Only(dst) };
    let mut decoder = FrameDecoder::new([0u8; 1024], filter);
    let frames = decode_all(&mut decoder, &stream, sizes);
    assert_eq!(frames.last(), Some(&(src, dst, payload.to_vec())));
    assert_eq!(decoder.pending_len(), 0);
});
