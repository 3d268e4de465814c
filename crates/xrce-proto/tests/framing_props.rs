//! Property tests of the framings: round trips under arbitrary chunking, and decoders that survive any input
//! with consistent counters.

use proptest::prelude::*;
use xrce_proto::framing::serial::{AddressFilter, Event, FrameDecoder};
use xrce_proto::framing::tcp::{TcpDecoder, TcpEvent};
use xrce_proto::framing::{can, serial, tcp};

/// Splits `input` at the given cut sizes (cycled), feeding every piece to `f`.
fn in_chunks(input: &[u8], cuts: &[usize], mut f: impl FnMut(&[u8])) {
    let mut rest = input;
    let mut i = 0;
    while !rest.is_empty() {
        let n = cuts.get(i % cuts.len().max(1)).copied().unwrap_or(rest.len()).clamp(1, rest.len());
        f(&rest[..n]);
        rest = &rest[n..];
        i += 1;
    }
}

/// Frames as (src, dst, payload).
type Frames = Vec<(u8, u8, Vec<u8>)>;

/// Decodes `wire` with `decoder`, collecting frames and errors.
fn collect<B: AsRef<[u8]> + AsMut<[u8]>>(
    decoder: &mut FrameDecoder<B>,
    wire: &[u8],
    cuts: &[usize],
) -> (Frames, Vec<serial::FrameError>) {
    let mut frames = Vec::new();
    let mut errors = Vec::new();
    in_chunks(wire, cuts, |piece| {
        decoder.push(piece, |event| match event {
            Event::Frame { src, dst, payload } => frames.push((src, dst, payload.to_vec())),
            Event::Error(e) => errors.push(e),
        })
    });
    (frames, errors)
}

proptest! {
    #[test]
    fn serial_round_trip(
        frames in prop::collection::vec((any::<u8>(), any::<u8>(), prop::collection::vec(any::<u8>(), 0..300)), 1..6),
        garbage in prop::collection::vec(any::<u8>().prop_filter("no flag", |b| *b != serial::FLAG), 0..20),
        cuts in prop::collection::vec(1usize..40, 1..10),
    ) {
        let mut wire = garbage.clone();
        for (src, dst, payload) in &frames {
            let mut out = vec![0u8; serial::max_encoded_len(payload.len())];
            let n = serial::encode_frame(*src, *dst, payload, &mut out).unwrap();
            prop_assert_eq!(serial::encoded_len(*src, *dst, payload), Ok(n));
            prop_assert!(serial::FrameBytes::new(*src, *dst, payload).unwrap().eq(out[..n].iter().copied()));
            // Only the flag is an unescaped 0x7E.
            prop_assert_eq!(out[..n].iter().filter(|&&b| b == serial::FLAG).count(), 1);
            wire.extend_from_slice(&out[..n]);
        }
        let mut decoder = FrameDecoder::new([0u8; 300], AddressFilter::Any);
        let (got, errors) = collect(&mut decoder, &wire, &cuts);
        prop_assert!(errors.is_empty());
        prop_assert_eq!(&got, &frames);
        let s = decoder.stats;
        prop_assert_eq!(s.bytes_dropped as usize, garbage.len());
        prop_assert_eq!(s.bytes_in_frames as usize + garbage.len(), wire.len());
    }

    #[test]
    fn serial_filter_keeps_only_local(
        frames in prop::collection::vec((0u8..4, 0u8..4, prop::collection::vec(any::<u8>(), 0..40)), 1..8),
        local in 0u8..4,
    ) {
        let mut wire = Vec::new();
        for (src, dst, payload) in &frames {
            let mut out = vec![0u8; serial::max_encoded_len(payload.len())];
            let n = serial::encode_frame(*src, *dst, payload, &mut out).unwrap();
            wire.extend_from_slice(&out[..n]);
        }
        let mut decoder = FrameDecoder::new([0u8; 64], AddressFilter::Only(local));
        let (got, errors) = collect(&mut decoder, &wire, &[3]);
        prop_assert!(errors.is_empty());
        let expected: Vec<_> = frames.iter().filter(|f| f.1 == local).cloned().collect();
        prop_assert_eq!(decoder.stats.filtered as usize, frames.len() - expected.len());
        prop_assert_eq!(got, expected);
    }

    #[test]
    fn serial_decoder_survives_anything(
        input in prop::collection::vec(prop_oneof![Just(0x7Eu8), Just(0x7D), Just(0x00), any::<u8>()], 0..600),
        cuts in prop::collection::vec(1usize..20, 1..5),
        capacity in 0usize..64,
    ) {
        let mut storage = vec![0u8; capacity];
        let mut decoder = FrameDecoder::new(&mut storage[..], AddressFilter::Any);
        let (frames, _) = collect(&mut decoder, &input, &cuts);
        let s = decoder.stats;
        prop_assert_eq!(s.bytes_received as usize, input.len());
        prop_assert_eq!(
            s.bytes_received as usize,
            s.bytes_in_frames as usize + s.bytes_dropped as usize + decoder.pending_len()
        );
        prop_assert_eq!(s.frames_ok as usize, frames.len());
        prop_assert!(frames.iter().all(|(_, _, p)| p.len() <= capacity));
    }

    #[test]
    fn serial_single_byte_corruption_is_caught(
        payload in prop::collection::vec(any::<u8>(), 1..100),
        at in any::<prop::sample::Index>(),
        flip in 1u8..=255,
    ) {
        let mut out = vec![0u8; serial::max_encoded_len(payload.len())];
        let n = serial::encode_frame(1, 0, &payload, &mut out).unwrap();
        let i = at.index(n - 1) + 1;
        out[i] ^= flip;
        let mut decoder = FrameDecoder::new([0u8; 128], AddressFilter::Any);
        let (frames, _) = collect(&mut decoder, &out[..n], &[n]);
        // Whatever byte is hit (addresses, length, escapes, payload, CRC), the original frame is not what
        // comes out: the CRC or the framing catches it.
        for (src, dst, p) in &frames {
            prop_assert!((*src, *dst, p) != (1, 0, &payload), "corruption at raw byte {} went unnoticed", i);
        }
    }

    #[test]
    fn tcp_round_trip(
        messages in prop::collection::vec(prop::collection::vec(any::<u8>(), 0..200), 1..8),
        cuts in prop::collection::vec(1usize..50, 1..10),
    ) {
        let mut wire = Vec::new();
        for m in &messages {
            let mut out = vec![0u8; m.len() + tcp::PREFIX_LEN];
            let n = tcp::encode(m, &mut out).unwrap();
            wire.extend_from_slice(&out[..n]);
        }
        let mut decoder = TcpDecoder::new([0u8; 200]);
        let mut got = Vec::new();
        in_chunks(&wire, &cuts, |piece| {
            decoder.push(piece, |event| match event {
                TcpEvent::Message(m) => got.push(m.to_vec()),
                TcpEvent::Error(e) => panic!("{e}"),
            })
        });
        let expected: Vec<_> = messages.iter().filter(|m| !m.is_empty()).cloned().collect();
        prop_assert_eq!(got, expected);
        prop_assert!(decoder.is_idle());
    }

    #[test]
    fn tcp_oversized_keeps_sync(
        messages in prop::collection::vec(prop::collection::vec(any::<u8>(), 1..100), 1..8),
        capacity in 1usize..100,
        cuts in prop::collection::vec(1usize..50, 1..10),
    ) {
        let mut wire = Vec::new();
        for m in &messages {
            wire.extend_from_slice(&tcp::prefix(m.len()).unwrap());
            wire.extend_from_slice(m);
        }
        let mut storage = vec![0u8; capacity];
        let mut decoder = TcpDecoder::new(&mut storage[..]);
        let mut got = Vec::new();
        let mut errors = 0;
        in_chunks(&wire, &cuts, |piece| {
            decoder.push(piece, |event| match event {
                TcpEvent::Message(m) => got.push(m.to_vec()),
                TcpEvent::Error(_) => errors += 1,
            })
        });
        let fitting: Vec<_> = messages.iter().filter(|m| m.len() <= capacity).cloned().collect();
        prop_assert_eq!(errors, messages.len() - fitting.len());
        prop_assert_eq!(got, fitting);
    }

    #[test]
    fn tcp_decoder_survives_anything(
        input in prop::collection::vec(any::<u8>(), 0..600),
        cuts in prop::collection::vec(1usize..20, 1..5),
        capacity in 0usize..64,
    ) {
        let mut storage = vec![0u8; capacity];
        let mut decoder = TcpDecoder::new(&mut storage[..]);
        in_chunks(&input, &cuts, |piece| decoder.push(piece, |_| {}));
    }

    #[test]
    fn can_round_trip(msg in prop::collection::vec(any::<u8>(), 0..=63), pad in any::<u8>()) {
        let mut data = [pad; 64];
        let len = can::encode(&msg, &mut data).unwrap();
        prop_assert_eq!(len, msg.len() + 1);
        let padded = can::padded_len(len).unwrap();
        prop_assert!(padded >= len);
        prop_assert_eq!(can::decode(&data[..padded]), Ok(&msg[..]));
        let (zeroed, padded2) = can::encode_padded(&msg).unwrap();
        prop_assert_eq!(padded2, padded);
        prop_assert_eq!(can::decode(&zeroed[..padded2]), Ok(&msg[..]));
    }

    #[test]
    fn can_frame_round_trip_and_any_received_frame(
        id in 0u32..=can::EFF_MASK,
        msg in prop::collection::vec(any::<u8>(), 0..=63),
        can_id in any::<u32>(),
        bytes in prop::collection::vec(any::<u8>(), 0..80),
    ) {
        let frame = can::Frame::with_message(id, &msg).unwrap();
        prop_assert_eq!((frame.id(), frame.message()), (Some(id), Ok(&msg[..])));
        prop_assert_eq!(usize::from(frame.len), msg.len() + 1);
        // Anything off the bus: at most 64 bytes kept, a message of at most 63 or an error, no panic.
        let received = can::Frame::from_parts(can_id, &bytes);
        prop_assert_eq!(received.bytes(), &bytes[..bytes.len().min(64)]);
        if let Ok(m) = received.message() {
            prop_assert!(m.len() <= can::MAX_MESSAGE_LEN);
        }
    }

    #[test]
    fn can_decode_never_overreads(data in prop::collection::vec(any::<u8>(), 0..80)) {
        if let Ok(msg) = can::decode(&data) {
            prop_assert_eq!(msg.len(), usize::from(data[0]));
            prop_assert!(msg.len() <= can::MAX_MESSAGE_LEN);
        }
    }
}
