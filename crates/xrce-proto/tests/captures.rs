//! Every XRCE message of every capture of eProsima traffic (`tests/data/vectors/captures/`) decodes, and encoding
//! what was decoded gives the same bytes, padding excepted (the C client leaves padding bytes uninitialised and
//! pads the end of its stream messages: spec §1.1, §3). Fragmented messages are reassembled and their inner
//! messages checked the same way. TCP captures go through the TCP framing decoder; the serial capture has its
//! own test (`serial_capture.rs`).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use xrce_proto::cdr::Writer;
use xrce_proto::framing::tcp::{TcpDecoder, TcpEvent};
use xrce_proto::message::parse;
use xrce_proto::object::BinaryObject;
use xrce_proto::submessage::Submessage;
use xrce_proto::{MessageHeader, ObjectVariant, Representation, StreamKind};

fn captures_dir() -> PathBuf {
    PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../../tests/data/vectors/captures"))
}

/// One transport payload of a capture.
struct Packet {
    number: u32,
    to_agent: bool,
    client_port: u16,
    bytes: Vec<u8>,
}

fn read_capture(path: &Path) -> (bool, Vec<Packet>) {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let tcp = text.lines().next().is_some_and(|l| l.contains("proto=tcp"));
    let mut packets: Vec<Packet> = Vec::new();
    for line in text.lines() {
        if line.starts_with('#') || line.trim().is_empty() {
            continue;
        }
        if line.starts_with("     ") {
            let bytes = line.split_whitespace().map(|h| u8::from_str_radix(h, 16).expect("hex byte"));
            packets.last_mut().expect("hex follows a record").bytes.extend(bytes);
            continue;
        }
        let mut cols = line.split_whitespace();
        let number = cols.next().expect("number").parse().expect("packet number");
        let dir = cols.nth(1).expect("direction");
        let (port, to_agent) = match dir.strip_prefix("C(") {
            Some(rest) => (rest.split(')').next().expect("port"), true),
            None => (dir.strip_prefix("A->C(").expect("direction").trim_end_matches(')'), false),
        };
        packets.push(Packet { number, to_agent, client_port: port.parse().expect("port"), bytes: Vec::new() });
    }
    (tcp, packets)
}

/// Splits TCP segments into XRCE messages per connection direction, with the framing decoder.
fn tcp_messages(packets: Vec<Packet>) -> Vec<Packet> {
    let mut decoders: BTreeMap<(u16, bool), TcpDecoder<Vec<u8>>> = BTreeMap::new();
    let mut out = Vec::new();
    for p in packets {
        let decoder = decoders.entry((p.client_port, p.to_agent)).or_insert_with(|| TcpDecoder::new(vec![0; 65535]));
        decoder.push(&p.bytes, |event| match event {
            TcpEvent::Message(m) => out.push(Packet { bytes: m.to_vec(), ..p }),
            TcpEvent::Error(e) => panic!("packet {}: TCP framing error {e}", p.number),
        });
    }
    out
}

/// Re-encodes a decoded message with the given padding byte.
fn reencode(msg: &[u8], pad: u8) -> Vec<u8> {
    let (header, subs) = parse(msg).expect("header");
    let mut buf = vec![0u8; msg.len() + 64];
    let header_len = header.encode(&mut buf).expect("header fits");
    let mut w = Writer::with_origin(&mut buf, header_len, 0, Default::default());
    w.set_pad_byte(pad);
    for raw in subs {
        let raw = raw.expect("submessage in bounds");
        let sub = raw.decode().expect("submessage decodes");
        w.set_endianness(raw.header.endianness());
        w.align(4);
        let sub = decode_blobs(sub, raw.header.endianness());
        sub.encode(&mut w);
    }
    let n = w.finish().expect("fits");
    buf.truncate(n);
    buf
}

/// Decodes binary blobs into their typed form so re-encoding exercises the typed encoders too.
fn decode_blobs(sub: Submessage<'_>, endian: xrce_proto::Endianness) -> Submessage<'_> {
    let Submessage::Create(mut create) = sub else { return sub };
    if let ObjectVariant::Entity(mut entity) = create.variant {
        if let Representation::Binary(blob) = entity.representation {
            let typed = blob.decode_as(entity.kind, endian).expect("binary representation decodes");
            assert!(!matches!(typed, BinaryObject::Raw(_)));
            entity.representation = Representation::Binary(typed);
            create.variant = ObjectVariant::Entity(entity);
        }
    }
    Submessage::Create(create)
}

/// Checks one message; returns the number of submessages and the FRAGMENT slices it carries.
fn check_message(name: &str, number: u32, msg: &[u8]) -> (usize, Option<(MessageHeader, bool, Vec<u8>)>) {
    let (header, subs) = parse(msg).unwrap_or_else(|e| panic!("{name} #{number}: header: {e}"));
    let mut count = 0;
    let mut fragment = None;
    for raw in subs {
        let raw = raw.unwrap_or_else(|e| panic!("{name} #{number}: {e}"));
        let sub = raw.decode().unwrap_or_else(|e| panic!("{name} #{number}: submessage {}: {e}", raw.header.id));
        assert!(!matches!(sub, Submessage::Unknown { .. }), "{name} #{number}: unknown submessage");
        if let Submessage::Fragment { last, data } = sub {
            fragment = Some((header, last, data.to_vec()));
        }
        count += 1;
    }
    let zeros = reencode(msg, 0x00);
    let ones = reencode(msg, 0xFF);
    assert_eq!(zeros.len(), ones.len());
    // The C client pads stream messages to a multiple of 4; nothing else may be left over.
    let trailing = msg.len() - zeros.len().min(msg.len());
    assert!(msg.len() >= zeros.len() && trailing < 4, "{name} #{number}: length {} vs {}", msg.len(), zeros.len());
    if trailing > 0 {
        assert_ne!(header.stream_id.kind(), StreamKind::None, "{name} #{number}: padding on stream 0");
    }
    for (i, (&a, &b)) in zeros.iter().zip(&ones).enumerate() {
        if a == b {
            assert_eq!(msg[i], a, "{name} #{number}: byte {i} differs after re-encoding");
        }
    }
    (count, fragment)
}

/// Checks one capture file; returns (messages, submessages, messages reassembled from fragments).
fn check_file(name: &str) -> (usize, usize, usize) {
    let path = captures_dir().join(name);
    let (tcp, packets) = read_capture(&path);
    let messages = if tcp { tcp_messages(packets) } else { packets };
    assert!(!messages.is_empty(), "{name}: no messages");
    // Reassembly buffers per (direction, client, stream).
    let mut reassembly: BTreeMap<(bool, u16, u8), (MessageHeader, Vec<u8>)> = BTreeMap::new();
    let (mut subs_total, mut inner) = (0, 0);
    for m in &messages {
        let (subs, fragment) = check_message(name, m.number, &m.bytes);
        subs_total += subs;
        if let Some((header, last, data)) = fragment {
            let key = (m.to_agent, m.client_port, header.stream_id.0);
            let entry = reassembly.entry(key).or_insert_with(|| (header, Vec::new()));
            entry.1.extend_from_slice(&data);
            if last {
                let (header, body) = reassembly.remove(&key).expect("entry");
                let mut whole = vec![0u8; header.size()];
                header.encode(&mut whole).expect("header");
                whole.extend_from_slice(&body);
                subs_total += check_message(name, m.number, &whole).0;
                inner += 1;
            }
        }
    }
    println!("{name}: {} messages, {subs_total} submessages, {inner} reassembled from fragments", messages.len());
    (messages.len(), subs_total, inner)
}

/// One test per capture file, so the test list itself shows every file covered.
macro_rules! capture_tests {
    ($($test:ident => $file:literal,)*) => {
        $(
            #[test]
            fn $test() {
                check_file($file);
            }
        )*

        const COVERED: &[&str] = &[$($file),*];
    };
}

capture_tests! {
    big_hello_world_pubsub_udp => "big_hello_world_pubsub_udp.txt",
    binary_entity_creation_ced_agentv2_3_0_udp => "binary_entity_creation_ced_agentv2.3.0_udp.txt",
    binary_entity_creation_ced_agentv3_0_1_udp => "binary_entity_creation_ced_agentv3.0.1_udp.txt",
    binary_entity_creation_udp => "binary_entity_creation_udp.txt",
    discovery_unicast_7400_udp => "discovery_unicast_7400_udp.txt",
    hello_world_besteffort_pubsub_udp => "hello_world_besteffort_pubsub_udp.txt",
    hello_world_pubsub_udp_all => "hello_world_pubsub_udp.all.txt",
    ping_agent_udp => "ping_agent_udp.txt",
    publish_hello_world_alone_udp => "publish_hello_world_alone_udp.txt",
    publish_hello_world_udp => "publish_hello_world_udp.txt",
    request_reply_adder_udp => "request_reply_adder_udp.txt",
    subscribe_hello_world_udp => "subscribe_hello_world_udp.txt",
    tcp_ping_and_shapes => "tcp_ping_and_shapes.txt",
    timesync_udp => "timesync_udp.txt",
}

/// Every decoded-message capture in the folder has its test above (the serial hexdump has `serial_capture.rs`),
/// and the totals are printed (visible with `-- --nocapture`).
#[test]
fn every_capture_file_is_covered() {
    let mut files: Vec<String> = std::fs::read_dir(captures_dir())
        .expect("captures folder")
        .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".txt") && !n.contains("hexdump"))
        .collect();
    files.sort();
    let missing: Vec<&String> = files.iter().filter(|f| !COVERED.contains(&f.as_str())).collect();
    assert!(missing.is_empty(), "capture files without a test: {missing:?}");
    let (mut messages, mut subs, mut inner) = (0, 0, 0);
    for file in COVERED {
        let (m, s, i) = check_file(file);
        messages += m;
        subs += s;
        inner += i;
    }
    println!(
        "checked {messages} messages ({subs} submessages, {inner} reassembled) in {} capture files",
        COVERED.len()
    );
}
