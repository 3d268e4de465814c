//! Every DATA and WRITE_DATA of the UDP captures of eProsima traffic (`tests/data/vectors/captures/`), written
//! again with `layout::DataSubmessage::emit_into` from its decoded parts, gives the captured bytes: plain
//! samples, requests delivered to a replier (sample identity first), replies delivered to a requester
//! (related request first) and replies written by a replier. Also: every submessage of those messages starts
//! where `layout::submessage_offset` says.

use std::path::PathBuf;

use xrce_proto::layout::{submessage_offset, DataSubmessage, SampleBody};
use xrce_proto::message::parse;
use xrce_proto::submessage::{DataFormat, DataPayload};
use xrce_proto::{ObjectKind, Submessage};

fn captures_dir() -> PathBuf {
    PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../../tests/data/vectors/captures"))
}

/// The UDP payloads of a capture (none for a TCP capture or the serial hexdump).
fn udp_messages(name: &str) -> Vec<Vec<u8>> {
    let text = std::fs::read_to_string(captures_dir().join(name)).unwrap();
    if !text.lines().next().is_some_and(|l| l.contains("proto=udp")) {
        return Vec::new();
    }
    let mut messages: Vec<Vec<u8>> = Vec::new();
    for line in text.lines().filter(|l| !l.starts_with('#') && !l.trim().is_empty()) {
        if line.starts_with("     ") {
            let bytes = line.split_whitespace().map(|h| u8::from_str_radix(h, 16).unwrap());
            messages.last_mut().unwrap().extend(bytes);
        } else {
            messages.push(Vec::new());
        }
    }
    messages
}

/// The body layout of a FORMAT_DATA payload, told by the object it is for and the direction.
fn body_of<'a>(payload: &DataPayload<'a>, to_client: bool) -> SampleBody<'a> {
    match (payload.request.object_id.kind(), to_client) {
        (ObjectKind::Replier, _) => {
            let (identity, data) = payload.split_sample_identity().unwrap();
            SampleBody::WithIdentity { identity, data }
        }
        (ObjectKind::Requester, true) => {
            let (related, data) = payload.split_base_request().unwrap();
            SampleBody::Reply { related, data }
        }
        _ => SampleBody::Plain(payload.data),
    }
}

#[test]
fn data_and_write_data_of_the_captures_emit_their_bytes() {
    let mut seen = [0usize; 3];
    let mut files = std::fs::read_dir(captures_dir()).unwrap().map(|e| e.unwrap().file_name()).collect::<Vec<_>>();
    files.sort();
    for name in files.iter().filter_map(|f| f.to_str()) {
        for msg in udp_messages(name) {
            let (header, subs) = parse(&msg).unwrap();
            let mut end = header.size();
            for raw in subs.map(Result::unwrap) {
                let start = raw.start - xrce_proto::SubmessageHeader::SIZE;
                assert_eq!(start, submessage_offset(end), "{name}");
                end = raw.end;
                let (payload, to_client) = match raw.decode().unwrap() {
                    Submessage::Data(d) => (d, true),
                    // Length 0: a WRITE_DATA that only travels fragmented.
                    Submessage::WriteData(d) if raw.header.length != 0 => (d, false),
                    _ => continue,
                };
                if payload.format != DataFormat::DATA {
                    continue;
                }
                let body = body_of(&payload, to_client);
                seen[match body {
                    SampleBody::Plain(_) => 0,
                    SampleBody::WithIdentity { .. } => 1,
                    SampleBody::Reply { .. } => 2,
                }] += 1;
                let sub = DataSubmessage {
                    id: xrce_proto::view::submessage_id(&msg[start..]).unwrap(),
                    request: payload.request,
                    body,
                };
                let mut out = vec![0xEE; sub.encoded_len()];
                assert_eq!(sub.emit_into(&mut out), Ok(raw.end - start), "{name}");
                assert_eq!(out, msg[start..raw.end], "{name}");
            }
        }
    }
    assert!(seen.iter().all(|&n| n > 0), "every layout met: {seen:?}");
}
