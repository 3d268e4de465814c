//! TCP framing against real traffic: eProsima's client and agent over TCP (ping plus ShapesDemo), every
//! connection direction reassembled from its segments, decoded in random-sized chunks and re-encoded.

use std::collections::BTreeMap;

use xrce_proto::framing::tcp::{encode, TcpDecoder, TcpEvent};

/// The capture, in the repository's vectors folder (`tests/data/vectors`).
const CAPTURE_PATH: &str =
    concat!(env!("CARGO_MANIFEST_DIR"), "/../../tests/data/vectors/captures/tcp_ping_and_shapes.txt");

fn capture() -> String {
    std::fs::read_to_string(CAPTURE_PATH).unwrap_or_else(|e| panic!("cannot read {CAPTURE_PATH}: {e}"))
}

/// Byte streams keyed by (client port, client-to-agent?), and how many segments each had.
fn parse_capture() -> BTreeMap<(u16, bool), (Vec<u8>, usize)> {
    let mut streams: BTreeMap<(u16, bool), (Vec<u8>, usize)> = BTreeMap::new();
    let mut current: Option<(u16, bool)> = None;
    for line in capture().lines() {
        if line.starts_with('#') || line.trim().is_empty() {
            continue;
        }
        if line.starts_with("     ") {
            let key = current.expect("hex follows a record");
            let bytes = line.split_whitespace().map(|h| u8::from_str_radix(h, 16).expect("hex byte"));
            streams.get_mut(&key).expect("record seen").0.extend(bytes);
            continue;
        }
        let dir = line.split_whitespace().nth(2).expect("direction column");
        let (port, to_agent) = if let Some(rest) = dir.strip_prefix("C(") {
            (rest.split(')').next().expect("port"), true)
        } else {
            let rest = dir.strip_prefix("A->C(").expect("A->C(port)");
            (rest.trim_end_matches(')'), false)
        };
        let key = (port.parse().expect("port number"), to_agent);
        streams.entry(key).or_default().1 += 1;
        current = Some(key);
    }
    streams
}

struct XorShift(u64);

impl XorShift {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }
}

/// Walks an XRCE message's submessages and checks they fill it (up to a last alignment padding).
fn check_xrce_structure(msg: &[u8]) {
    let header_len = if msg[0] >= 0x80 { 4 } else { 8 };
    let mut offset = header_len;
    loop {
        let Some(sub) = msg.get(offset..offset + 4) else { panic!("no submessage header at {offset} in {msg:02x?}") };
        let len =
            if sub[1] & 1 != 0 { u16::from_le_bytes([sub[2], sub[3]]) } else { u16::from_be_bytes([sub[2], sub[3]]) };
        let end = offset + 4 + usize::from(len);
        assert!(end <= msg.len(), "submessage overruns message {msg:02x?}");
        // The next submessage starts 4-aligned; the last one may be followed by that padding too.
        offset = (end + 3) & !3;
        if end == msg.len() || offset == msg.len() {
            return;
        }
    }
}

#[test]
fn tcp_capture_decodes_and_reencodes() {
    let streams = parse_capture();
    assert_eq!(streams.len(), 6, "three connections, two directions each");
    let mut total = 0;
    for ((port, to_agent), (stream, segments)) in &streams {
        for seed in 1..=20u64 {
            let mut rng = XorShift(seed.wrapping_mul(0x2545_F491_4F6C_DD1D));
            let mut decoder = TcpDecoder::new([0u8; 1024]);
            let mut messages: Vec<Vec<u8>> = Vec::new();
            let mut rest = &stream[..];
            while !rest.is_empty() {
                let n = ((rng.next() % 40) as usize + 1).min(rest.len());
                decoder.push(&rest[..n], |event| match event {
                    TcpEvent::Message(m) => messages.push(m.to_vec()),
                    TcpEvent::Error(e) => panic!("port {port}: {e}"),
                });
                rest = &rest[n..];
            }
            assert!(decoder.is_idle(), "port {port} to_agent {to_agent}: stream ends between messages");
            // Each message took at least one segment for its prefix or shared one; never more messages than bytes.
            assert!(!messages.is_empty() && messages.len() <= *segments);
            let mut reencoded = Vec::new();
            for m in &messages {
                check_xrce_structure(m);
                let mut out = vec![0u8; m.len() + 2];
                let n = encode(m, &mut out).expect("encodes");
                reencoded.extend_from_slice(&out[..n]);
            }
            assert_eq!(&reencoded, stream);
            if seed == 1 {
                total += messages.len();
            }
        }
    }
    println!("tcp capture: checked {total} messages in {} connection directions (x 20 chunkings)", streams.len());
}
