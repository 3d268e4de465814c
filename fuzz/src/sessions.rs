//! The structure-aware agent target's vocabulary: what a client does ([`Step`]) and the datagrams that step
//! sends, built with xrce-proto's encoder from the client's model ([`Client`]: key, session, sequence numbers,
//! the last reliable messages for repeats).

use arbitrary::Arbitrary;
use xrce_proto::message::encode_single;
use xrce_proto::object::{BinaryObject, ClientRepresentation};
use xrce_proto::submessage::{
    AckNack, Create, CreationMode, DataFormat, DataPayload, GetInfo, Heartbeat, ReadData, ReadSpecification,
};
use xrce_proto::{
    BaseObjectRequest, ClientKey, Endianness, EntityVariant, MessageHeader, ObjectId, ObjectKind, ObjectVariant,
    Representation, RequestId, StreamId, Submessage,
};

/// Clients the sequences play with (one more than the agent's table holds, so eviction happens).
pub const CLIENTS: usize = 4;

/// A refs file the agent's profile store loads: references the fuzzer can name.
pub const REFS: &str = r#"<profiles>
<participant profile_name="p"><rtps><name>p</name></rtps></participant>
<topic profile_name="t"><name>t</name><dataType>T</dataType></topic>
<data_writer profile_name="w"><topic><kind>NO_KEY</kind><name>t</name><dataType>T</dataType></topic></data_writer>
<data_reader profile_name="r"><topic><kind>NO_KEY</kind><name>t</name><dataType>T</dataType></topic></data_reader>
<requester profile_name="q" service_name="s" request_type="A" reply_type="B"></requester>
<replier profile_name="y" service_name="s" request_type="A" reply_type="B"></replier>
</profiles>"#;

const XML: [&str; 7] = [
    "<dds><participant><rtps><name>p</name></rtps></participant></dds>",
    "<dds><topic><name>t</name><dataType>T</dataType></topic></dds>",
    "<dds><publisher/></dds>",
    "<dds><data_writer><topic><kind>NO_KEY</kind><name>t</name><dataType>T</dataType></topic></data_writer></dds>",
    "<dds><data_reader><topic><kind>NO_KEY</kind><name>t</name><dataType>T</dataType></topic></data_reader></dds>",
    r#"<dds><requester profile_name="q" service_name="s" request_type="A" reply_type="B"/></dds>"#,
    r#"<dds><replier profile_name="y"service_name="s"request_type="A"reply_type="B"/></dds>"#,
];

const REFERENCES: [&str; 8] = ["p", "t", "w", "r", "q", "y", "chatter__dw", "unknown"];

/// The entity kinds a client creates.
#[derive(Arbitrary, Debug, Clone, Copy)]
pub enum Kind {
    Participant,
    Topic,
    Publisher,
    Subscriber,
    DataWriter,
    DataReader,
    Requester,
    Replier,
}

impl Kind {
    fn object_kind(self) -> ObjectKind {
        match self {
            Self::Participant => ObjectKind::Participant,
            Self::Topic => ObjectKind::Topic,
            Self::Publisher => ObjectKind::Publisher,
            Self::Subscriber => ObjectKind::Subscriber,
            Self::DataWriter => ObjectKind::DataWriter,
            Self::DataReader => ObjectKind::DataReader,
            Self::Requester => ObjectKind::Requester,
            Self::Replier => ObjectKind::Replier,
        }
    }

    /// The kind of the parent: participant for topics, publishers, subscribers, services; else the group.
    fn parent_kind(self) -> ObjectKind {
        match self {
            Self::DataWriter => ObjectKind::Publisher,
            Self::DataReader => ObjectKind::Subscriber,
            _ => ObjectKind::Participant,
        }
    }
}

/// How an entity is described.
#[derive(Arbitrary, Debug, Clone)]
pub enum Description {
    /// One of the [`XML`] texts (modulo their number).
    Xml(u8),
    /// Any text as XML.
    AnyXml(String),
    /// One of the [`REFERENCES`].
    Reference(u8),
    /// Any text as a reference.
    AnyReference(String),
    /// The valid binary blob of the kind, naming topic `topic` for endpoints.
    Binary { topic: u8 },
    /// Any bytes as the blob.
    AnyBinary(Vec<u8>),
}

/// One thing a client (or time) does.
#[derive(Arbitrary, Debug, Clone)]
pub enum Step {
    /// CREATE_CLIENT (again: a reconnection, or a reboot with a new session id).
    CreateSession { client: u8, keyed: bool, session_low: u8, mtu: u16 },
    /// CREATE of an entity numbered `number`, under parent `parent`.
    Create { client: u8, kind: Kind, number: u8, parent: u8, what: Description, reuse: bool, replace: bool },
    /// DELETE of an entity, or of the session itself (`kind` None).
    Delete { client: u8, kind: Option<Kind>, number: u8 },
    /// WRITE_DATA from writer `number`.
    Write { client: u8, number: u8, reliable: bool, sample: Vec<u8> },
    /// WRITE_DATA in FRAGMENTs of `piece` bytes on the reliable stream.
    WriteFragmented { client: u8, number: u8, sample: Vec<u8>, piece: u8 },
    /// READ_DATA on reader `number`, the samples delivered on `stream`.
    Read { client: u8, number: u8, stream: u8, max_samples: Option<u16> },
    /// HEARTBEAT for the client's reliable output stream (arbitrary range).
    Heartbeat { client: u8, first: u16, last: u16, stream: u8 },
    /// ACKNACK for the agent's reliable stream: arbitrary, or everything seen so far (`honest`).
    AckNack { client: u8, first: u16, bitmap: u16, stream: u8, honest: bool },
    /// The client's reliable sequence number jumps (messages lost on the way).
    Lose { client: u8, messages: u8 },
    /// The `back`-th last reliable message is sent again (a duplicate or a retransmission).
    Repeat { client: u8, back: u8 },
    /// GET_INFO outside and inside the session.
    GetInfo { client: u8, in_session: bool },
    /// Any bytes after the session's header (`stream`, `seq`), or any datagram at all.
    Raw { client: u8, header: Option<(u8, u16)>, bytes: Vec<u8> },
    /// The client moves to another address (NAT rebinding).
    Move { client: u8 },
    /// Time passes.
    Time { millis: u16 },
    /// The transport forgets the client's endpoint (a closed TCP connection) and the client its state.
    Vanish { client: u8 },
}

/// What the fuzz target knows of one client.
#[derive(Debug, Clone)]
pub struct Client {
    pub key: ClientKey,
    pub endpoint: u8,
    session_id: u8,
    reliable_seq: u16,
    best_effort_seq: u16,
    request: u16,
    /// The last reliable messages sent, for [`Step::Repeat`].
    sent: Vec<Vec<u8>>,
    /// Highest sequence number of the agent's reliable stream 0x80 seen (for honest ACKNACKs).
    agent_seq: Option<u16>,
}

impl Client {
    pub fn new(index: usize) -> Self {
        let key = ClientKey::from_u32(0xC0DE_0000 + index as u32);
        Self {
            key,
            endpoint: index as u8,
            session_id: 0x81,
            reliable_seq: 0,
            best_effort_seq: 0,
            request: 0,
            sent: Vec::new(),
            agent_seq: None,
        }
    }

    /// Forgets the session state (a client that rebooted).
    pub fn vanish(&mut self) {
        *self = Self { endpoint: self.endpoint, ..Self::new(usize::from(self.endpoint % CLIENTS as u8)) };
    }

    /// Notes the agent's reliable sequence numbers in a message it sent to this client.
    pub fn observe(&mut self, message: &[u8]) {
        if let Ok((header, _)) = xrce_proto::message::parse(message) {
            if header.stream_id.0 >= 0x80 {
                self.agent_seq = Some(header.sequence_nr);
            }
        }
    }

    fn header(&self, stream: u8, seq: u16) -> MessageHeader {
        let key = if self.session_id < 0x80 { self.key } else { ClientKey::INVALID };
        MessageHeader::new(self.session_id, StreamId(stream), seq, key)
    }

    fn next_request(&mut self) -> RequestId {
        self.request = self.request.wrapping_add(1);
        RequestId(self.request)
    }

    /// WRITE_DATA of `data` by `writer`, with the next request id.
    fn write_data<'a>(&mut self, writer: ObjectId, data: &'a [u8]) -> Submessage<'a> {
        let request = BaseObjectRequest { request_id: self.next_request(), object_id: writer };
        Submessage::WriteData(DataPayload { request, format: DataFormat::DATA, data })
    }

    /// READ_DATA on `reader`, its samples on `stream`, at most `max_samples` of them (none: one sample, as
    /// eProsima's agent reads without delivery control; `0xFFFF`: unlimited), with the next request id.
    fn read_data(&mut self, reader: ObjectId, stream: u8, max_samples: Option<u16>) -> Submessage<'static> {
        let delivery_control = max_samples.map(|max_samples| xrce_proto::submessage::DataDeliveryControl {
            max_samples,
            max_elapsed_time: 0,
            max_bytes_per_second: 0,
            min_pace_period: 0,
        });
        let spec = ReadSpecification {
            preferred_stream_id: stream,
            data_format: 0,
            content_filter_expression: None,
            delivery_control,
        };
        let request = BaseObjectRequest { request_id: self.next_request(), object_id: reader };
        Submessage::ReadData(ReadData { request, spec })
    }

    /// A reliable message (stream 0x80) carrying `sub`, remembered for repeats.
    fn reliable(&mut self, sub: &Submessage<'_>) -> Option<Vec<u8>> {
        let message = encode(&self.header(0x80, self.reliable_seq), sub)?;
        self.reliable_seq = self.reliable_seq.wrapping_add(1);
        if self.sent.len() >= 8 {
            self.sent.remove(0);
        }
        self.sent.push(message.clone());
        Some(message)
    }
}

fn encode(header: &MessageHeader, sub: &Submessage<'_>) -> Option<Vec<u8>> {
    let mut buf = vec![0u8; 8192];
    let n = encode_single(&mut buf, header, sub, Endianness::Little).ok()?;
    buf.truncate(n);
    Some(buf)
}

/// The valid binary blob of `kind` (the layout of eProsima's `*_bin` calls).
fn binary_blob(kind: Kind, topic: u8) -> Vec<u8> {
    match kind {
        Kind::Topic => {
            let mut b = vec![2, 0, 0, 0, b't', 0, 0, 0, 2, 0, 0, 0, b'T', 0];
            b[4] = b't' + topic % 2;
            b
        }
        Kind::DataWriter | Kind::DataReader => {
            let id = ObjectId::new(u16::from(topic), ObjectKind::Topic).0;
            vec![id[0], id[1], 0]
        }
        Kind::Requester | Kind::Replier => {
            let mut b = Vec::new();
            for s in ["s\0", "A\0", "B\0"] {
                while b.len() % 4 != 0 {
                    b.push(0);
                }
                b.extend_from_slice(&(s.len() as u32).to_le_bytes());
                b.extend_from_slice(s.as_bytes());
            }
            b.extend_from_slice(&[0, 0]);
            b
        }
        _ => vec![0, 0],
    }
}

fn create<'a>(
    kind: Kind,
    number: u8,
    parent: u8,
    what: &'a Description,
    blob: &'a [u8],
    request: RequestId,
    mode: CreationMode,
) -> Submessage<'a> {
    let representation = match what {
        Description::Xml(i) => Representation::Xml(XML[usize::from(*i) % XML.len()]),
        Description::AnyXml(s) => Representation::Xml(s),
        Description::Reference(i) => Representation::Reference(REFERENCES[usize::from(*i) % REFERENCES.len()]),
        Description::AnyReference(s) => Representation::Reference(s),
        Description::Binary { .. } | Description::AnyBinary(_) => Representation::Binary(BinaryObject::Raw(blob)),
    };
    let variant = match kind {
        Kind::Participant => EntityVariant::participant(representation, i16::from(parent % 3) - 1),
        _ => EntityVariant::child(
            kind.object_kind(),
            representation,
            ObjectId::new(u16::from(parent % 4), kind.parent_kind()),
        ),
    };
    let object_id = ObjectId::new(u16::from(number % 4), kind.object_kind());
    Submessage::Create(Create {
        request: BaseObjectRequest { request_id: request, object_id },
        mode,
        variant: ObjectVariant::Entity(variant),
    })
}

/// The datagrams (endpoint, bytes) a step sends; empty for steps handled by the target itself.
pub fn datagrams(step: &Step, clients: &mut [Client; CLIENTS]) -> Vec<(u8, Vec<u8>)> {
    let pick = |c: u8| usize::from(c) % CLIENTS;
    let mut out = Vec::new();
    match step {
        Step::CreateSession { client, keyed, session_low, mtu } => {
            let c = &mut clients[pick(*client)];
            c.session_id = if *keyed { session_low % 0x80 } else { 0x80 | session_low };
            (c.reliable_seq, c.best_effort_seq, c.agent_seq) = (0, 0, None);
            c.sent.clear();
            let rep = ClientRepresentation::new(c.key, c.session_id, *mtu);
            let header = MessageHeader::new(0x80, StreamId::NONE, 0, ClientKey::INVALID);
            out.extend(encode(&header, &Submessage::CreateClient(rep)).map(|m| (c.endpoint, m)));
        }
        Step::Create { client, kind, number, parent, what, reuse, replace } => {
            let c = &mut clients[pick(*client)];
            let blob = match what {
                Description::Binary { topic } => binary_blob(*kind, *topic),
                Description::AnyBinary(b) => b.clone(),
                _ => Vec::new(),
            };
            let mode = CreationMode { reuse: *reuse, replace: *replace };
            let request = c.next_request();
            let sub = create(*kind, *number, *parent, what, &blob, request, mode);
            out.extend(c.reliable(&sub).map(|m| (c.endpoint, m)));
        }
        Step::Delete { client, kind, number } => {
            let c = &mut clients[pick(*client)];
            let object_id = match kind {
                Some(k) => ObjectId::new(u16::from(number % 4), k.object_kind()),
                None => ObjectId::new(0xFFF, ObjectKind::Client),
            };
            let request = BaseObjectRequest { request_id: c.next_request(), object_id };
            let sub = Submessage::Delete(request);
            let message = if kind.is_some() { c.reliable(&sub) } else { encode(&c.header(0, 0), &sub) };
            out.extend(message.map(|m| (c.endpoint, m)));
        }
        Step::Write { client, number, reliable, sample } => {
            let c = &mut clients[pick(*client)];
            let sub = c.write_data(ObjectId::new(u16::from(number % 4), ObjectKind::DataWriter), sample);
            let message = if *reliable {
                c.reliable(&sub)
            } else {
                c.best_effort_seq = c.best_effort_seq.wrapping_add(1);
                encode(&c.header(0x01, c.best_effort_seq), &sub)
            };
            out.extend(message.map(|m| (c.endpoint, m)));
        }
        Step::WriteFragmented { client, number, sample, piece } => {
            let c = &mut clients[pick(*client)];
            let sub = c.write_data(ObjectId::new(u16::from(number % 4), ObjectKind::DataWriter), sample);
            // The inner message is the submessage alone: the bytes after a keyless header.
            let Some(inner) = encode(&MessageHeader::new(0x81, StreamId(0x80), 0, ClientKey::INVALID), &sub) else {
                return out;
            };
            let body = inner.get(4..).unwrap_or(&[]);
            let piece = usize::from(*piece).max(1);
            let count = body.len().div_ceil(piece);
            for (i, slice) in body.chunks(piece).enumerate() {
                let fragment = Submessage::Fragment { last: i + 1 == count, data: slice };
                out.extend(c.reliable(&fragment).map(|m| (c.endpoint, m)));
            }
        }
        Step::Read { client, number, stream, max_samples } => {
            let c = &mut clients[pick(*client)];
            let sub = c.read_data(ObjectId::new(u16::from(number % 4), ObjectKind::DataReader), *stream, *max_samples);
            out.extend(c.reliable(&sub).map(|m| (c.endpoint, m)));
        }
        Step::Heartbeat { client, first, last, stream } => {
            let c = &clients[pick(*client)];
            let hb = Heartbeat { first_unacked_seq_nr: *first, last_unacked_seq_nr: *last, stream_id: *stream };
            out.extend(encode(&c.header(0, 0), &Submessage::Heartbeat(hb)).map(|m| (c.endpoint, m)));
        }
        Step::AckNack { client, first, bitmap, stream, honest } => {
            let c = &clients[pick(*client)];
            let ack = if *honest {
                let next = c.agent_seq.map_or(0, |s| s.wrapping_add(1));
                AckNack { first_unacked_seq_num: next, nack_bitmap: [0, 0], stream_id: 0x80 }
            } else {
                AckNack { first_unacked_seq_num: *first, nack_bitmap: bitmap.to_be_bytes(), stream_id: *stream }
            };
            out.extend(encode(&c.header(0, 0), &Submessage::AckNack(ack)).map(|m| (c.endpoint, m)));
        }
        Step::Lose { client, messages } => {
            let c = &mut clients[pick(*client)];
            c.reliable_seq = c.reliable_seq.wrapping_add(u16::from(*messages));
        }
        Step::Repeat { client, back } => {
            let c = &clients[pick(*client)];
            let n = c.sent.len();
            if n > 0 {
                let i = n - 1 - usize::from(*back) % n;
                out.extend(c.sent.get(i).map(|m| (c.endpoint, m.clone())));
            }
        }
        Step::GetInfo { client, in_session } => {
            let c = &mut clients[pick(*client)];
            let object_id = ObjectId::new(0, ObjectKind::Agent);
            let request = BaseObjectRequest { request_id: c.next_request(), object_id };
            let sub = Submessage::GetInfo(GetInfo { request, info_mask: 0xFFFF_FFFF });
            let header = if *in_session {
                c.header(0, 0)
            } else {
                MessageHeader::new(0x80, StreamId::NONE, 0, ClientKey::INVALID)
            };
            out.extend(encode(&header, &sub).map(|m| (c.endpoint, m)));
        }
        Step::Raw { client, header, bytes } => {
            let c = &clients[pick(*client)];
            let mut m = Vec::new();
            if let Some((stream, seq)) = header {
                let mut h = vec![0u8; 8];
                let n = c.header(*stream, *seq).encode(&mut h).unwrap_or(0);
                m.extend_from_slice(h.get(..n).unwrap_or(&[]));
            }
            m.extend_from_slice(bytes);
            out.push((c.endpoint, m));
        }
        Step::Move { client } => {
            let c = &mut clients[pick(*client)];
            c.endpoint = c.endpoint.wrapping_add(CLIENTS as u8);
        }
        Step::Time { .. } | Step::Vanish { .. } => {}
    }
    out
}

/// The topic the clean-link epilogue writes and reads: no XML of the vocabulary names it.
const CLEAN_TOPIC: &str = "clean-link-epilogue";
/// Samples the epilogue writes.
pub const CLEAN_SAMPLES: u8 = 8;

/// The end of every sequence: one client, on a link that now loses nothing, opens a new session, creates a
/// writer and a reader of its own topic, asks for every sample on its reliable stream and writes
/// [`CLEAN_SAMPLES`] samples reliably, acknowledging what it received. Whatever the sequence left behind, each
/// sample must arrive once, in order (the client's reliable input stream: repeats dropped, early messages held).
#[derive(Debug, Default)]
pub struct CleanLink {
    /// STATUS_AGENT's code, once the session answer came.
    pub session_status: Option<u8>,
    /// The next sequence number of the agent's reliable stream 0x80 to deliver.
    next: u16,
    /// Messages of that stream that came early, by sequence number.
    early: std::collections::BTreeMap<u16, Vec<u8>>,
    /// The samples delivered to the reader, in delivery order.
    pub delivered: Vec<Vec<u8>>,
}

impl CleanLink {
    /// The reader's object id.
    const READER: u16 = 0xE;

    /// The session's CREATE_CLIENT (keyed), then the entities and the READ_DATA, as `client`'s datagrams.
    pub fn setup(client: &mut Client) -> Vec<Vec<u8>> {
        client.session_id = 0x7E;
        (client.reliable_seq, client.best_effort_seq, client.agent_seq) = (0, 0, None);
        client.sent.clear();
        let rep = ClientRepresentation::new(client.key, client.session_id, 512);
        let header = MessageHeader::new(0x80, StreamId::NONE, 0, ClientKey::INVALID);
        let mut out: Vec<Vec<u8>> = encode(&header, &Submessage::CreateClient(rep)).into_iter().collect();
        let topic = format!("<dds><topic><name>{CLEAN_TOPIC}</name><dataType>T</dataType></topic></dds>");
        let endpoint = |tag: &str| {
            format!(
                "<dds><{tag}><topic><kind>NO_KEY</kind><name>{CLEAN_TOPIC}</name><dataType>T</dataType></topic></{tag}></dds>"
            )
        };
        let (writer, reader) = (endpoint("data_writer"), endpoint("data_reader"));
        let entities: [(ObjectKind, u16, ObjectKind, &str); 6] = [
            (ObjectKind::Participant, 0xE, ObjectKind::Participant, XML[0]),
            (ObjectKind::Topic, 0xE, ObjectKind::Participant, &topic),
            (ObjectKind::Publisher, 0xE, ObjectKind::Participant, "<dds><publisher/></dds>"),
            (ObjectKind::DataWriter, 0xE, ObjectKind::Publisher, &writer),
            (ObjectKind::Subscriber, 0xE, ObjectKind::Participant, "<dds><subscriber/></dds>"),
            (ObjectKind::DataReader, Self::READER, ObjectKind::Subscriber, &reader),
        ];
        for (kind, number, parent_kind, xml) in entities {
            let variant = if kind == ObjectKind::Participant {
                EntityVariant::participant(Representation::Xml(xml), 0)
            } else {
                EntityVariant::child(kind, Representation::Xml(xml), ObjectId::new(0xE, parent_kind))
            };
            let request =
                BaseObjectRequest { request_id: client.next_request(), object_id: ObjectId::new(number, kind) };
            let mode = CreationMode { reuse: false, replace: true };
            let sub = Submessage::Create(Create { request, mode, variant: ObjectVariant::Entity(variant) });
            out.extend(client.reliable(&sub));
        }
        let read = client.read_data(ObjectId::new(Self::READER, ObjectKind::DataReader), 0x80, Some(0xFFFF));
        out.extend(client.reliable(&read));
        out
    }

    /// The `index`-th sample.
    pub fn sample(index: u8) -> Vec<u8> {
        vec![0xC1, 0xEA, index, 0x5A]
    }

    /// WRITE_DATA of the `index`-th sample on the reliable stream.
    pub fn write(client: &mut Client, index: u8) -> Option<Vec<u8>> {
        let data = Self::sample(index);
        let sub = client.write_data(ObjectId::new(0xE, ObjectKind::DataWriter), &data);
        client.reliable(&sub)
    }

    /// ACKNACK of everything delivered so far, missing messages nacked.
    pub fn acknack(&self, client: &Client) -> Option<Vec<u8>> {
        let mut bitmap = 0u16;
        for seq in self.early.keys() {
            let gap = seq.wrapping_sub(self.next);
            if (1..16).contains(&gap) {
                for missing in 0..gap {
                    if !self.early.contains_key(&self.next.wrapping_add(missing)) {
                        bitmap |= 1 << missing;
                    }
                }
            }
        }
        let ack = AckNack { first_unacked_seq_num: self.next, nack_bitmap: bitmap.to_be_bytes(), stream_id: 0x80 };
        encode(&client.header(0, 0), &Submessage::AckNack(ack))
    }

    /// A message the agent sent the client.
    pub fn observe(&mut self, message: &[u8]) {
        let Ok((header, _)) = xrce_proto::message::parse(message) else { return };
        if header.stream_id == StreamId::NONE {
            self.submessages(message);
        } else if header.stream_id.0 == 0x80 {
            let ahead = header.sequence_nr.wrapping_sub(self.next);
            if ahead == 0 {
                self.submessages(message);
                self.next = self.next.wrapping_add(1);
                while let Some(m) = self.early.remove(&self.next) {
                    self.submessages(&m);
                    self.next = self.next.wrapping_add(1);
                }
            } else if ahead < 0x8000 {
                self.early.insert(header.sequence_nr, message.to_vec());
            }
        }
    }

    fn submessages(&mut self, message: &[u8]) {
        let Ok((_, subs)) = xrce_proto::message::parse(message) else { return };
        for raw in subs.flatten() {
            match raw.decode_from_agent() {
                Ok(xrce_proto::submessage::FromAgent::StatusAgent(result)) => {
                    self.session_status = Some(result.status.0);
                }
                Ok(xrce_proto::submessage::FromAgent::Data(d))
                    if d.request.object_id == ObjectId::new(Self::READER, ObjectKind::DataReader) =>
                {
                    self.delivered.push(d.data.to_vec());
                }
                _ => {}
            }
        }
    }
}
