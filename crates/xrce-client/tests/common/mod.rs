//! Helpers shared by the integration tests: hex parsing, capture files, a collecting callback.
#![allow(dead_code)]

use xrce_client::{Callbacks, ObjectId, Outputs, SampleIdentity, StreamId};

/// Bytes from whitespace-separated hex.
pub fn hex(s: &str) -> Vec<u8> {
    s.split_whitespace().map(|b| u8::from_str_radix(b, 16).unwrap()).collect()
}

/// One packet of a capture.
#[derive(Debug, Clone)]
pub struct Packet {
    pub to_agent: bool,
    pub client_port: u16,
    pub time: f64,
    pub annotation: String,
    pub bytes: Vec<u8>,
}

/// Reads `tests/data/vectors/captures/<name>` (at the workspace root).
pub fn capture(name: &str) -> Vec<Packet> {
    let path = format!("{}/../../tests/data/vectors/captures/{name}", env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{path}: {e}"));
    let mut packets: Vec<Packet> = Vec::new();
    for line in text.lines() {
        if line.starts_with('#') || line.trim().is_empty() {
            continue;
        }
        let fields: Vec<&str> = line.split_whitespace().collect();
        let is_header = fields.len() > 3 && fields[2].contains("->") && fields[0].parse::<u32>().is_ok();
        if is_header {
            let dir = fields[2];
            let to_agent = dir.starts_with('C');
            let port: String = dir.chars().filter(|c| c.is_ascii_digit()).collect();
            let annotation = line.split('|').nth(1).unwrap_or("").trim().to_string();
            packets.push(Packet {
                to_agent,
                client_port: port.parse().unwrap_or(0),
                time: fields[1].parse().unwrap(),
                annotation,
                bytes: Vec::new(),
            });
        } else if let Some(p) = packets.last_mut() {
            p.bytes.extend(hex(line));
        }
    }
    packets
}

/// What the callbacks saw.
#[derive(Debug, Default)]
pub struct Collect {
    pub statuses: Vec<(ObjectId, u16, u8)>,
    pub topics: Vec<(ObjectId, u16, StreamId, Vec<u8>)>,
    pub requests: Vec<(ObjectId, u16, SampleIdentity, Vec<u8>)>,
    pub replies: Vec<(ObjectId, u16, u16, Vec<u8>)>,
}

impl Callbacks for Collect {
    fn on_status(&mut self, _: &mut Outputs<'_, '_>, object_id: ObjectId, request_id: u16, status: u8) {
        self.statuses.push((object_id, request_id, status));
    }
    fn on_topic(
        &mut self,
        _: &mut Outputs<'_, '_>,
        object_id: ObjectId,
        request_id: u16,
        stream_id: StreamId,
        data: &[u8],
    ) {
        self.topics.push((object_id, request_id, stream_id, data.to_vec()));
    }
    fn on_request(
        &mut self,
        _: &mut Outputs<'_, '_>,
        object_id: ObjectId,
        request_id: u16,
        sample_id: &SampleIdentity,
        data: &[u8],
    ) {
        self.requests.push((object_id, request_id, *sample_id, data.to_vec()));
    }
    fn on_reply(&mut self, _: &mut Outputs<'_, '_>, object_id: ObjectId, request_id: u16, reply_id: u16, data: &[u8]) {
        self.replies.push((object_id, request_id, reply_id, data.to_vec()));
    }
}
