//! Test support: capture files, a core harness that plays well-behaved clients, owned decoding of the
//! agent's messages.
#![allow(dead_code)]

use std::collections::{BTreeMap, HashMap};
use std::path::PathBuf;
use std::sync::Arc;
use std::time::{Duration, Instant};

use xrce_agent::core::{AgentCore, CoreConfig, Transmit};
use xrce_agent::middleware::ced::Ced;
use xrce_agent::middleware::describe::FallbackProfiles;
use xrce_proto::submessage::AckNack;
use xrce_proto::{message, MessageHeader, StreamId, Submessage};

/// One packet of a capture.
#[derive(Debug, Clone)]
pub struct Packet {
    pub t: f64,
    pub to_agent: bool,
    pub port: u16,
    pub data: Vec<u8>,
}

pub fn captures_dir() -> PathBuf {
    PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../../tests/data/vectors/captures"))
}

/// Parses a `captures/*.txt` file.
pub fn load_capture(name: &str) -> Vec<Packet> {
    let text = std::fs::read_to_string(captures_dir().join(name)).expect("capture file");
    let mut out: Vec<Packet> = Vec::new();
    for line in text.lines() {
        let trimmed = line.trim();
        if trimmed.starts_with('#') || trimmed.is_empty() {
            continue;
        }
        let fields: Vec<&str> = trimmed.split_whitespace().collect();
        let is_header = fields.len() >= 4 && fields[3].starts_with("len=") && (fields[2].contains("->"));
        if is_header {
            let dir = fields[2];
            let to_agent = dir.starts_with('C');
            let port: u16 = dir.split(['(', ')']).nth(1).and_then(|p| p.parse().ok()).unwrap_or(0);
            out.push(Packet { t: fields[1].parse().unwrap_or(0.0), to_agent, port, data: Vec::new() });
        } else if let Some(last) = out.last_mut() {
            for byte in fields {
                last.data.push(u8::from_str_radix(byte, 16).expect("hex byte"));
            }
        }
    }
    out
}

/// An agent message decoded into owned values.
#[derive(Debug, Clone, PartialEq)]
pub enum Out {
    StatusAgent { status: u8 },
    Status { request: u16, object: u16, status: u8 },
    AckNack { first: u16, bitmap: u16, stream: u8 },
    Heartbeat { first: u16, last: u16, stream: u8 },
    Data { request: u16, object: u16, data: Vec<u8> },
    Info { implementation_status: u8, request: u16 },
    TimestampReply { originate: (i32, u32) },
    GetInfo,
    Other(u8),
}

/// A received agent message: header and its submessages.
#[derive(Debug, Clone)]
pub struct Received {
    pub header: MessageHeader,
    pub subs: Vec<Out>,
    pub raw: Vec<u8>,
}

pub fn decode_owned(bytes: &[u8]) -> (MessageHeader, Vec<Out>) {
    let (header, subs) = message::parse(bytes).expect("agent header");
    let mut out = Vec::new();
    for raw in subs {
        let raw = raw.expect("agent submessage framing");
        let sub = raw.decode().expect("agent submessage");
        out.push(match sub {
            Submessage::StatusAgent(s) => Out::StatusAgent { status: s.result.status.0 },
            Submessage::Status(s) => Out::Status {
                request: s.related_request.request_id.0,
                object: s.related_request.object_id.raw(),
                status: s.result.status.0,
            },
            Submessage::AckNack(a) => {
                Out::AckNack { first: a.first_unacked_seq_num, bitmap: a.bitmap(), stream: a.stream_id }
            }
            Submessage::Heartbeat(h) => {
                Out::Heartbeat { first: h.first_unacked_seq_nr, last: h.last_unacked_seq_nr, stream: h.stream_id }
            }
            Submessage::Data(d) => {
                Out::Data { request: d.request.request_id.0, object: d.request.object_id.raw(), data: d.data.to_vec() }
            }
            Submessage::Info(i) => Out::Info {
                implementation_status: i.reply.result.implementation_status,
                request: i.reply.related_request.request_id.0,
            },
            Submessage::TimestampReply(t) => {
                Out::TimestampReply { originate: (t.originate_timestamp.seconds, t.originate_timestamp.nanoseconds) }
            }
            Submessage::GetInfo(_) => Out::GetInfo,
            Submessage::Fragment { .. } => Out::Other(13),
            other => Out::Other(other.id()),
        });
    }
    (header, out)
}

/// Per-client state of the simulated client: reliable input streams with reassembly.
#[derive(Debug, Default)]
struct SimStream {
    next: u16,
    stored: BTreeMap<u16, Vec<u8>>,
    fragments: Vec<u8>,
}

pub type TestCore = AgentCore<u16, Ced>;

pub fn new_core() -> TestCore {
    new_core_with(CoreConfig::default())
}

pub fn new_core_with(config: CoreConfig) -> TestCore {
    AgentCore::new(config, Ced::new(Arc::new(FallbackProfiles)))
}

/// Drives a core as well-behaved clients would: acknowledges the agent's reliable messages (unless told not
/// to), reassembles fragments, and records what each client receives in order.
pub struct Harness<M = Ced> {
    pub core: AgentCore<u16, M>,
    pub now: Instant,
    pub auto_ack: bool,
    streams: HashMap<(u16, u8), SimStream>,
    /// Everything each port received, in processing order (reliable messages in sequence order,
    /// fragmented ones reassembled).
    pub received: HashMap<u16, Vec<Received>>,
}

impl Harness {
    pub fn new() -> Self {
        Self::with_core(new_core())
    }
}

impl<M: xrce_agent::middleware::Middleware> Harness<M> {
    pub fn with_core(core: AgentCore<u16, M>) -> Self {
        Self { core, now: Instant::now(), auto_ack: true, streams: HashMap::new(), received: HashMap::new() }
    }

    /// Feeds one datagram from `port` and runs the exchange until quiet.
    pub fn send(&mut self, port: u16, bytes: &[u8]) {
        self.core.handle_datagram(port, bytes, self.now);
        self.drain();
    }

    /// Advances time by `d`, running timers.
    pub fn advance(&mut self, d: Duration) {
        let end = self.now + d;
        loop {
            match self.core.poll_timeout() {
                Some(t) if t <= end => {
                    self.now = t.max(self.now);
                    self.core.handle_timeout(self.now);
                    self.drain();
                }
                _ => break,
            }
        }
        self.now = end;
        self.core.handle_timeout(self.now);
        self.drain();
    }

    pub fn drain(&mut self) {
        let mut acks: Vec<(u16, Vec<u8>)> = Vec::new();
        let mut buf = Vec::new();
        while let Some(t) = self.core.poll_transmit(self.now, &mut buf).map(|to| Transmit { to, data: buf.clone() }) {
            let port = t.to;
            let (header, _) = decode_owned(&t.data);
            if header.stream_id.is_reliable() {
                let key = (port, header.stream_id.0);
                let s = self.streams.entry(key).or_default();
                let seq = header.sequence_nr;
                if seq.wrapping_sub(s.next) < 0x8000 {
                    s.stored.insert(seq, t.data.clone());
                }
                let mut ready = Vec::new();
                while let Some(msg) = s.stored.remove(&s.next) {
                    s.next = s.next.wrapping_add(1);
                    ready.push(msg);
                }
                for msg in ready {
                    self.deliver_reliable(port, header, msg);
                }
                if self.auto_ack {
                    let s = self.streams.get(&key).expect("stream");
                    let ack =
                        AckNack { first_unacked_seq_num: s.next, nack_bitmap: [0, 0], stream_id: header.stream_id.0 };
                    let h = MessageHeader { stream_id: StreamId::NONE, sequence_nr: 0, ..header };
                    let mut buf = [0u8; 32];
                    let n =
                        message::encode_single(&mut buf, &h, &Submessage::AckNack(ack), xrce_proto::Endianness::Little)
                            .expect("encode ack");
                    acks.push((port, buf[..n].to_vec()));
                }
            } else {
                let (header, subs) = decode_owned(&t.data);
                for sub in &subs {
                    if let (true, Out::Heartbeat { stream, .. }) = (self.auto_ack, sub) {
                        let next = self.streams.get(&(port, *stream)).map_or(0, |s| s.next);
                        let ack = AckNack { first_unacked_seq_num: next, nack_bitmap: [0, 0], stream_id: *stream };
                        let mut buf = [0u8; 32];
                        let n = message::encode_single(
                            &mut buf,
                            &header,
                            &Submessage::AckNack(ack),
                            xrce_proto::Endianness::Little,
                        )
                        .expect("encode ack");
                        acks.push((port, buf[..n].to_vec()));
                    }
                }
                self.received.entry(port).or_default().push(Received { header, subs, raw: t.data });
            }
            if self.core.pending_transmits() == 0 && !acks.is_empty() {
                for (port, ack) in acks.drain(..) {
                    self.core.handle_datagram(port, &ack, self.now);
                }
            }
        }
    }

    fn deliver_reliable(&mut self, port: u16, header: MessageHeader, msg: Vec<u8>) {
        let h = header.size();
        let is_fragment = msg.get(h) == Some(&13);
        if is_fragment {
            let flags = msg[h + 1];
            let s = self.streams.get_mut(&(port, header.stream_id.0)).expect("stream");
            s.fragments.extend_from_slice(&msg[h + 4..]);
            if flags & 0x02 != 0 {
                let mut whole = msg[..h].to_vec();
                whole.append(&mut s.fragments);
                let (hh, subs) = decode_owned(&whole);
                self.received.entry(port).or_default().push(Received { header: hh, subs, raw: whole });
            }
            return;
        }
        let (hh, subs) = decode_owned(&msg);
        self.received.entry(port).or_default().push(Received { header: hh, subs, raw: msg });
    }

    /// All submessages `port` received.
    pub fn outs(&self, port: u16) -> Vec<Out> {
        self.received.get(&port).map(|v| v.iter().flat_map(|r| r.subs.clone()).collect()).unwrap_or_default()
    }

    /// STATUS replies `port` received: (request id, status).
    pub fn statuses(&self, port: u16) -> Vec<(u16, u8)> {
        self.outs(port)
            .into_iter()
            .filter_map(|o| match o {
                Out::Status { request, status, .. } => Some((request, status)),
                _ => None,
            })
            .collect()
    }

    /// DATA payloads `port` received.
    pub fn data(&self, port: u16) -> Vec<Vec<u8>> {
        self.outs(port)
            .into_iter()
            .filter_map(|o| match o {
                Out::Data { data, .. } => Some(data),
                _ => None,
            })
            .collect()
    }

    /// Replays every client packet of a capture in order; time follows the capture.
    pub fn replay(&mut self, packets: &[Packet]) {
        let start = self.now;
        for p in packets.iter().filter(|p| p.to_agent) {
            let at = start + Duration::from_secs_f64(p.t);
            if at > self.now {
                let d = at - self.now;
                self.advance(d);
            }
            self.send(p.port, &p.data);
        }
    }
}

/// A CREATE_CLIENT for `key`/`session` with mtu 508.
pub fn create_client_msg(key: u32, session: u8) -> Vec<u8> {
    let header = if session < 0x80 {
        MessageHeader::new(0x00, StreamId::NONE, 0, xrce_proto::ClientKey::from_u32(key))
    } else {
        MessageHeader::new(0x80, StreamId::NONE, 0, xrce_proto::ClientKey::INVALID)
    };
    let rep = xrce_proto::object::ClientRepresentation::new(xrce_proto::ClientKey::from_u32(key), session, 508);
    let mut buf = [0u8; 64];
    let n = message::encode_single(&mut buf, &header, &Submessage::CreateClient(rep), xrce_proto::Endianness::Little)
        .expect("encode");
    buf[..n].to_vec()
}

/// The bytes of a DATA or WRITE_DATA after its request ([`Out::Data`]'s `data`), to split with the layouts of
/// requests and replies.
pub fn data_payload(data: &[u8]) -> xrce_proto::submessage::DataPayload<'_> {
    use xrce_proto::submessage::{DataFormat, DataPayload};
    DataPayload { request: xrce_proto::BaseObjectRequest::default(), format: DataFormat::DATA, data }
}

/// An ACKNACK of session 0x81 for reliable stream 0x80 acknowledging everything before `next`.
pub fn acknack_msg(next: u16) -> Vec<u8> {
    let header = MessageHeader::new(0x81, StreamId::NONE, 0, xrce_proto::ClientKey::INVALID);
    let ack = AckNack { first_unacked_seq_num: next, nack_bitmap: [0, 0], stream_id: 0x80 };
    let mut buf = [0u8; 16];
    let n = message::encode_single(&mut buf, &header, &Submessage::AckNack(ack), xrce_proto::Endianness::Little)
        .expect("encode");
    buf[..n].to_vec()
}

/// A core whose CED resolves references with the refs file `tests/data/vectors/agent.refs`.
pub fn new_core_with_refs() -> TestCore {
    let profiles = xrce_agent::middleware::profiles::StoreProfiles::new();
    profiles.load_file(captures_dir().join("../agent.refs")).expect("agent.refs");
    AgentCore::new(CoreConfig::default(), Ced::new(Arc::new(profiles)))
}

/// The client→agent byte stream of each TCP connection of a capture, in order.
pub fn tcp_streams(packets: &[Packet]) -> Vec<(u16, Vec<u8>)> {
    let mut order: Vec<u16> = Vec::new();
    let mut streams: HashMap<u16, Vec<u8>> = HashMap::new();
    for p in packets.iter().filter(|p| p.to_agent) {
        if !order.contains(&p.port) {
            order.push(p.port);
        }
        streams.entry(p.port).or_default().extend_from_slice(&p.data);
    }
    order.into_iter().map(|port| (port, streams.remove(&port).unwrap_or_default())).collect()
}

/// Builds the messages of a simple client with session 0x81 (no key in header).
pub struct Client {
    pub session: u8,
    pub key: u32,
    pub seq_rel: u16,
    pub seq_be: u16,
    pub request: u16,
}

use xrce_proto::object::{BinaryObject, Representation, RequesterBinary, TopicBinary};
use xrce_proto::submessage::{
    Create, CreationMode, DataDeliveryControl, DataFormat, DataPayload, ReadData, ReadSpecification,
};
use xrce_proto::{BaseObjectRequest, EntityVariant, ObjectId, ObjectKind, ObjectVariant, RequestId};

impl Client {
    pub fn new(key: u32) -> Self {
        Self { session: 0x81, key, seq_rel: 0, seq_be: 0, request: 10 }
    }

    fn header(&mut self, reliable: bool) -> MessageHeader {
        let (stream, seq) = if reliable {
            self.seq_rel = self.seq_rel.wrapping_add(1);
            (0x80, self.seq_rel.wrapping_sub(1))
        } else {
            self.seq_be = self.seq_be.wrapping_add(1);
            (0x01, self.seq_be.wrapping_sub(1))
        };
        MessageHeader::new(self.session, StreamId(stream), seq, xrce_proto::ClientKey::from_u32(self.key))
    }

    pub fn next_request(&mut self) -> BaseObjectRequest {
        self.request += 1;
        BaseObjectRequest { request_id: RequestId(self.request), object_id: ObjectId::INVALID }
    }

    pub fn encode(&mut self, reliable: bool, sub: &Submessage<'_>) -> Vec<u8> {
        let header = self.header(reliable);
        let mut buf = vec![0u8; 70_000];
        let n = message::encode_single(&mut buf, &header, sub, xrce_proto::Endianness::Little).expect("encode");
        buf.truncate(n);
        buf
    }

    /// One message carrying several submessages.
    pub fn encode_many(&mut self, reliable: bool, subs: &[Submessage<'_>]) -> Vec<u8> {
        let header = self.header(reliable);
        let mut buf = vec![0u8; 70_000];
        let mut m = message::MessageBuilder::new(&mut buf, &header).expect("header");
        for sub in subs {
            m.push(sub, xrce_proto::Endianness::Little).expect("submessage");
        }
        let n = m.len();
        buf.truncate(n);
        buf
    }

    /// A WRITE_DATA to `object` cut into `parts` FRAGMENT messages on the reliable stream.
    pub fn write_fragmented(&mut self, object: ObjectId, data: &[u8], parts: usize) -> Vec<Vec<u8>> {
        let mut request = self.next_request();
        request.object_id = object;
        let whole = Submessage::WriteData(DataPayload { request, format: DataFormat::DATA, data });
        let mut buf = vec![0u8; 70_000];
        let header = MessageHeader::new(self.session, StreamId(0x80), 0, xrce_proto::ClientKey::from_u32(self.key));
        let n = message::encode_single(&mut buf, &header, &whole, xrce_proto::Endianness::Little).expect("encode");
        let body = &buf[header.size()..n];
        let chunk = body.len().div_ceil(parts);
        let pieces: Vec<&[u8]> = body.chunks(chunk).collect();
        let last = pieces.len() - 1;
        pieces
            .iter()
            .enumerate()
            .map(|(i, piece)| self.encode(true, &Submessage::Fragment { last: i == last, data: piece }))
            .collect()
    }

    pub fn create(&mut self, id: ObjectId, variant: EntityVariant<'_>) -> Vec<u8> {
        let mut request = self.next_request();
        request.object_id = id;
        let c = Create {
            request,
            mode: CreationMode { reuse: false, replace: true },
            variant: ObjectVariant::Entity(variant),
        };
        self.encode(true, &Submessage::Create(c))
    }

    /// Participant #1, topic #1 (`topic`), publisher #1, subscriber #1, writer #1, reader #1: binary.
    pub fn pubsub_entities(&mut self, topic: &str) -> Vec<Vec<u8>> {
        let p = ObjectId::new(1, ObjectKind::Participant);
        let t = ObjectId::new(1, ObjectKind::Topic);
        let publ = ObjectId::new(1, ObjectKind::Publisher);
        let sub = ObjectId::new(1, ObjectKind::Subscriber);
        let topic_bin =
            BinaryObject::Topic(TopicBinary { topic_name: topic, type_reference: None, type_name: Some("T") });
        let writer = BinaryObject::DataWriter(xrce_proto::object::DataWriterBinary { topic_id: t, qos: None });
        let reader = BinaryObject::DataReader(xrce_proto::object::DataReaderBinary { topic_id: t, qos: None });
        let empty = BinaryObject::Raw(&[0, 0]);
        vec![
            self.create(p, EntityVariant::participant(Representation::Binary(empty), 0)),
            self.create(t, EntityVariant::child(ObjectKind::Topic, Representation::Binary(topic_bin), p)),
            self.create(publ, EntityVariant::child(ObjectKind::Publisher, Representation::Binary(empty), p)),
            self.create(sub, EntityVariant::child(ObjectKind::Subscriber, Representation::Binary(empty), p)),
            self.create(
                ObjectId::new(1, ObjectKind::DataWriter),
                EntityVariant::child(ObjectKind::DataWriter, Representation::Binary(writer), publ),
            ),
            self.create(
                ObjectId::new(1, ObjectKind::DataReader),
                EntityVariant::child(ObjectKind::DataReader, Representation::Binary(reader), sub),
            ),
        ]
    }

    /// Participant #1 and a requester or replier #1 of `service`.
    pub fn service_entities(&mut self, service: &str, kind: ObjectKind) -> Vec<Vec<u8>> {
        let p = ObjectId::new(1, ObjectKind::Participant);
        let bin = RequesterBinary {
            service_name: service,
            request_type: "Req",
            reply_type: "Rep",
            request_topic_name: None,
            reply_topic_name: None,
        };
        let blob =
            if kind == ObjectKind::Requester { BinaryObject::Requester(bin) } else { BinaryObject::Replier(bin) };
        let empty = BinaryObject::Raw(&[0, 0]);
        vec![
            self.create(p, EntityVariant::participant(Representation::Binary(empty), 0)),
            self.create(ObjectId::new(1, kind), EntityVariant::child(kind, Representation::Binary(blob), p)),
        ]
    }

    pub fn write(&mut self, reliable: bool, object: ObjectId, data: &[u8]) -> Vec<u8> {
        let mut request = self.next_request();
        request.object_id = object;
        self.encode(reliable, &Submessage::WriteData(DataPayload { request, format: DataFormat::DATA, data }))
    }

    pub fn read(&mut self, object: ObjectId, stream: u8, control: Option<DataDeliveryControl>) -> Vec<u8> {
        let mut request = self.next_request();
        request.object_id = object;
        let spec = ReadSpecification {
            preferred_stream_id: stream,
            data_format: 0,
            content_filter_expression: None,
            delivery_control: control,
        };
        self.encode(true, &Submessage::ReadData(ReadData { request, spec }))
    }
}

pub fn unlimited() -> Option<DataDeliveryControl> {
    Some(DataDeliveryControl { max_samples: 0xFFFF, ..Default::default() })
}
