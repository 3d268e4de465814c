//! TCP length-prefix framing: the decoder must survive any byte stream cut anywhere, and any sequence of
//! messages must survive encode -> decode, with oversized ones reported and skipped without losing sync.
#![no_main]

use libfuzzer_sys::fuzz_target;
use xrce_proto::framing::tcp::{self, TcpDecoder, TcpEvent};

/// Chunk sizes 1..=32 taken from the input itself.
fn chunks<'a>(data: &'a [u8], sizes: &'a [u8]) -> impl Iterator<Item = &'a [u8]> + 'a {
    let mut rest = data;
    let mut i = 0usize;
    core::iter::from_fn(move || {
        if rest.is_empty() {
            return None;
        }
        let size = sizes.get(i % sizes.len().max(1)).map_or(rest.len(), |&s| usize::from(s % 32) + 1);
        i += 1;
        let (head, tail) = rest.split_at(size.min(rest.len()));
        rest = tail;
        Some(head)
    })
}

/// Feeds `input`, returning the messages and the number of errors.
fn decode_all<B: AsRef<[u8]> + AsMut<[u8]>>(
    decoder: &mut TcpDecoder<B>,
    input: &[u8],
    sizes: &[u8],
) -> (Vec<Vec<u8>>, usize) {
    let capacity = decoder.capacity();
    let mut messages = Vec::new();
    let mut errors = 0;
    for piece in chunks(input, sizes) {
        let mut rest = piece;
        while !rest.is_empty() {
            let (used, event) = decoder.feed(rest);
            assert!(used <= rest.len() && (used > 0 || event.is_some()));
            match event {
                Some(TcpEvent::Message(m)) => {
                    assert!(!m.is_empty() && m.len() <= capacity);
                    messages.push(m.to_vec());
                }
                Some(TcpEvent::Error(_)) => errors += 1,
                None => assert_eq!(used, rest.len(), "feed stops early only on an event"),
            }
            rest = &rest[used..];
        }
    }
    assert_eq!(decoder.stats.messages as usize, messages.len());
    (messages, errors)
}

fuzz_target!(|data: &[u8]| {
    let Some((&control, rest)) = data.split_first() else { return };
    let sizes = rest.get(..rest.len().min(8)).unwrap_or(&[]);
    let capacity = usize::from(control) % 96;

    // 1. Arbitrary bytes.
    let mut storage = vec![0u8; capacity];
    decode_all(&mut TcpDecoder::new(&mut storage[..]), rest, sizes);

    // 2. Round trip: cut the input into messages whose lengths come from its bytes.
    let mut messages: Vec<&[u8]> = Vec::new();
    let mut body = rest;
    while let Some((&len, tail)) = body.split_first() {
        let len = usize::from(len).min(tail.len());
        messages.push(&tail[..len]);
        body = &tail[len..];
    }
    let mut wire = Vec::new();
    for m in &messages {
        let mut out = vec![0u8; m.len() + tcp::PREFIX_LEN];
        let n = tcp::encode(m, &mut out).expect("fits");
        assert_eq!(n, m.len() + tcp::PREFIX_LEN);
        if n > 0 {
            assert_eq!(tcp::encode(m, &mut out[..n - 1]), Err(tcp::TcpError::BufferTooSmall { needed: n }));
        }
        wire.extend_from_slice(&out[..n]);
    }
    let mut storage = vec![0u8; capacity];
    let mut decoder = TcpDecoder::new(&mut storage[..]);
    let (got, errors) = decode_all(&mut decoder, &wire, sizes);
    let expected: Vec<Vec<u8>> =
        messages.iter().filter(|m| !m.is_empty() && m.len() <= capacity).map(|m| m.to_vec()).collect();
    let oversized = messages.iter().filter(|m| m.len() > capacity).count();
    assert_eq!(got, expected);
    assert_eq!(errors, oversized);
    assert!(decoder.is_idle());
});
