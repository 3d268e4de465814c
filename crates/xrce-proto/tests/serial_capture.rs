//! Serial framing against real traffic: the bytes eProsima's client and agent exchanged over a pty pair
//! (socat hexdump), decoded in random-sized chunks and re-encoded byte for byte.

use xrce_proto::framing::serial::{encode_frame, max_encoded_len, AddressFilter, Event, FrameDecoder};

/// The capture, in the repository's vectors folder (`tests/data/vectors`).
const CAPTURE_PATH: &str =
    concat!(env!("CARGO_MANIFEST_DIR"), "/../../tests/data/vectors/captures/serial_ping_agent_socat_hexdump.txt");

fn capture() -> String {
    std::fs::read_to_string(CAPTURE_PATH).unwrap_or_else(|e| panic!("cannot read {CAPTURE_PATH}: {e}"))
}

/// Client and agent addresses in the capture.
const CLIENT: u8 = 1;
const AGENT: u8 = 0;

/// One direction of the capture: the records as socat wrote them, and all bytes in order.
#[derive(Default)]
struct Direction {
    records: Vec<Vec<u8>>,
    stream: Vec<u8>,
}

/// Splits the hexdump into client→agent (`<`) and agent→client (`>`) bytes.
fn parse_capture() -> (Direction, Direction) {
    let mut to_agent = Direction::default();
    let mut to_client = Direction::default();
    let text = capture();
    let mut lines = text.lines();
    while let Some(line) = lines.next() {
        let dir = match line.chars().next() {
            Some('<') => &mut to_agent,
            Some('>') => &mut to_client,
            _ => continue,
        };
        let hex = lines.next().expect("a hex line follows each record header");
        let bytes: Vec<u8> = hex.split_whitespace().map(|h| u8::from_str_radix(h, 16).expect("hex byte")).collect();
        // socat's header announces the record length.
        let announced: usize = line
            .split_whitespace()
            .find_map(|w| w.strip_prefix("length="))
            .expect("length= in record header")
            .parse()
            .expect("decimal length");
        assert_eq!(bytes.len(), announced, "record {line}");
        dir.stream.extend_from_slice(&bytes);
        dir.records.push(bytes);
    }
    (to_agent, to_client)
}

/// Small deterministic generator for chunk sizes.
struct XorShift(u64);

impl XorShift {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }

    /// A chunk length in 1..=7.
    fn chunk(&mut self) -> usize {
        (self.next() % 7) as usize + 1
    }
}

/// A frame found in the stream: its addresses, payload and raw bytes.
struct Found {
    src: u8,
    dst: u8,
    payload: Vec<u8>,
    raw: Vec<u8>,
}

/// Decodes `stream` fed in random chunks of 1..=7 bytes, failing on any framing error.
fn decode_stream(stream: &[u8], local: u8, seed: u64) -> Vec<Found> {
    let mut decoder = FrameDecoder::new([0u8; 512], AddressFilter::Only(local));
    let mut rng = XorShift(seed);
    let mut found = Vec::new();
    let mut offset = 0;
    while offset < stream.len() {
        let end = (offset + rng.chunk()).min(stream.len());
        let mut chunk = &stream[offset..end];
        let mut chunk_start = offset;
        while !chunk.is_empty() {
            let before = decoder.stats.bytes_in_frames as usize;
            let (used, event) = decoder.feed(chunk);
            match event {
                Some(Event::Frame { src, dst, payload }) => {
                    let payload = payload.to_vec();
                    // The frame's raw bytes end at the byte that completed it.
                    let frame_end = chunk_start + used;
                    let raw_len = decoder.stats.bytes_in_frames as usize - before;
                    found.push(Found { src, dst, payload, raw: stream[frame_end - raw_len..frame_end].to_vec() });
                }
                Some(Event::Error(e)) => panic!("framing error at byte {}: {e}", chunk_start + used),
                None => {}
            }
            chunk = &chunk[used..];
            chunk_start += used;
        }
        offset = end;
    }
    let s = decoder.stats;
    assert_eq!((s.crc_errors, s.oversized, s.interrupted, s.filtered, s.bytes_dropped), (0, 0, 0, 0, 0));
    assert_eq!(decoder.pending_len(), 0, "stream ends on a frame boundary");
    assert_eq!(s.bytes_received as usize, stream.len());
    assert_eq!(s.frames_ok as usize, found.len());
    found
}

/// Walks an XRCE message's submessages and checks they fill it (up to a last alignment padding).
fn check_xrce_structure(msg: &[u8]) {
    let header_len = if msg[0] >= 0x80 { 4 } else { 8 };
    let mut offset = header_len;
    loop {
        let sub = &msg[offset..offset + 4];
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

/// Expected payload starts, in order, per direction: message header and first submessage header.
const TO_AGENT: [&[u8]; 3] = [
    // GET_INFO outside a session (ping).
    &[0x80, 0x00, 0x00, 0x00, 0x02, 0x01, 0x08, 0x00],
    // CREATE_CLIENT with the 'XRCE' cookie.
    &[0x80, 0x00, 0x00, 0x00, 0x00, 0x01, 0x10, 0x00, 0x58, 0x52, 0x43, 0x45],
    // GET_INFO in session 0x81.
    &[0x81, 0x00, 0x00, 0x00, 0x02, 0x01, 0x08, 0x00],
];
const TO_CLIENT: [&[u8]; 3] = [
    // INFO answering the ping.
    &[0x80, 0x00, 0x00, 0x00, 0x06, 0x01, 0x1C, 0x00],
    // STATUS_AGENT.
    &[0x81, 0x00, 0x00, 0x00, 0x04, 0x01, 0x0B, 0x00, 0x00, 0x00, 0x58, 0x52, 0x43, 0x45],
    // INFO in session 0x81.
    &[0x81, 0x00, 0x00, 0x00, 0x06, 0x01, 0x1C, 0x00],
];

fn check_direction(dir: &Direction, src: u8, dst: u8, expected: &[&[u8]]) -> usize {
    let mut checked = 0;
    for seed in 1..=50u64 {
        let found = decode_stream(&dir.stream, dst, seed.wrapping_mul(0x9E37_79B9_7F4A_7C15));
        assert_eq!(found.len(), expected.len());
        assert_eq!(found.len(), dir.records.len());
        let mut reencoded_stream = Vec::new();
        for ((frame, start), record) in found.iter().zip(expected).zip(&dir.records) {
            assert_eq!((frame.src, frame.dst), (src, dst));
            assert!(frame.payload.starts_with(start), "payload {:02x?} should start {start:02x?}", frame.payload);
            check_xrce_structure(&frame.payload);
            // socat logged one record per frame: the raw bytes are that record.
            assert_eq!(&frame.raw, record);
            let mut out = vec![0u8; max_encoded_len(frame.payload.len())];
            let n = encode_frame(src, dst, &frame.payload, &mut out).expect("encodes");
            assert_eq!(&out[..n], &frame.raw[..], "re-encoding gives the captured frame");
            reencoded_stream.extend_from_slice(&out[..n]);
            checked += 1;
        }
        assert_eq!(reencoded_stream, dir.stream);
    }
    checked
}

#[test]
fn serial_capture_decodes_and_reencodes() {
    let (to_agent, to_client) = parse_capture();
    assert_eq!(&to_agent.stream[..9], &[0x7E, 0x01, 0x00, 0x10, 0x00, 0x80, 0x00, 0x00, 0x00]);
    let frames_to_agent = check_direction(&to_agent, CLIENT, AGENT, &TO_AGENT);
    let frames_to_client = check_direction(&to_client, AGENT, CLIENT, &TO_CLIENT);
    println!(
        "serial capture: checked {} frames ({} client->agent, {} agent->client), each decoded under 50 random \
         chunkings and re-encoded: {} frame checks",
        to_agent.records.len() + to_client.records.len(),
        to_agent.records.len(),
        to_client.records.len(),
        frames_to_agent + frames_to_client
    );
}

#[test]
fn serial_capture_last_frame_has_escaped_crc() {
    let (_, to_client) = parse_capture();
    let last = to_client.records.last().expect("agent frames");
    assert_eq!(&last[last.len() - 3..], &[0x9B, 0x7D, 0x5E]);
    let found = decode_stream(last, CLIENT, 7);
    assert_eq!(found.len(), 1);
    assert_eq!(xrce_proto::framing::crc16(&found[0].payload), 0x7E9B);
}

#[test]
fn serial_capture_both_directions_interleaved_with_any_filter() {
    // A sniffer on the line sees both directions; with AddressFilter::Any it gets all six frames in order.
    let mut line = Vec::new();
    for l in capture().lines().filter(|l| l.starts_with(' ')) {
        line.extend(l.split_whitespace().map(|h| u8::from_str_radix(h, 16).expect("hex")));
    }
    // Noise before the first frame and between two frames.
    let mut noisy = vec![0x00, 0x55, 0xFF, 0x7D];
    noisy.extend_from_slice(&line[..23]);
    noisy.extend_from_slice(&[0x13, 0x37]);
    noisy.extend_from_slice(&line[23..]);
    let mut decoder = FrameDecoder::new([0u8; 64], AddressFilter::Any);
    let mut seen = Vec::new();
    let mut rng = XorShift(42);
    let mut rest = &noisy[..];
    while !rest.is_empty() {
        let n = rng.chunk().min(rest.len());
        decoder.push(&rest[..n], |event| match event {
            Event::Frame { src, dst, payload } => seen.push((src, dst, payload[0])),
            Event::Error(e) => panic!("{e}"),
        });
        rest = &rest[n..];
    }
    assert_eq!(seen, [(1, 0, 0x80), (0, 1, 0x80), (1, 0, 0x80), (0, 1, 0x81), (1, 0, 0x81), (0, 1, 0x81)]);
    assert_eq!(decoder.stats.bytes_dropped, 6);
}
