//! The DDS middleware driven through the agent core (no sockets): XRCE clients on one side, a real DDS
//! domain (RustDDS participants of a separate bridge, over loopback) on the other.
//!
//! Every test starts DDS participants, so they are `#[ignore]`d and refuse to run outside a loopback-only
//! network namespace:
//!
//!   ../shared/dds-peers/netns.sh xdds cargo test -p xrce-agent --test dds -- --ignored --test-threads 1

mod netns;
use netns::require_loopback_namespace;

mod common;

use std::collections::{HashMap, HashSet};
use std::net::{IpAddr, Ipv4Addr};
use std::sync::Arc;
use std::time::{Duration, Instant};

use common::{create_client_msg, decode_owned, unlimited, Client, Out};
use xrce_agent::core::{AgentCore, CoreConfig, Transmit};
use xrce_agent::middleware::dds::Dds;
use xrce_agent::middleware::profiles::StoreProfiles;
use xrce_agent::middleware::Middleware;
use xrce_dds::{BridgeConfig, DdsBridge, EndpointQos, RawWriter, ReceivedSample, SampleQueue};
use xrce_proto::object::{
    BinaryObject, DataReaderBinary, DataReaderQos, DataWriterBinary, DataWriterQos, QosFlags, Representation,
};
use xrce_proto::submessage::{AckNack, Create, CreationMode};
use xrce_proto::Submessage;
use xrce_proto::{message, EntityVariant, MessageHeader, ObjectId, ObjectKind, ObjectVariant, StatusCode, StreamId};

fn loopback() -> BridgeConfig {
    BridgeConfig { only_networks: Some(vec![IpAddr::V4(Ipv4Addr::LOCALHOST)]), ..BridgeConfig::default() }
}

/// The "other side": a separate bridge, hence a separate DDS participant, in the same domain.
fn peer_bridge() -> DdsBridge {
    require_loopback_namespace();
    DdsBridge::new(loopback())
}

/// CDR body of `struct HelloWorld { unsigned long index; string message; }`.
fn hello_body(index: u32, msg: &str) -> Vec<u8> {
    let mut v = Vec::new();
    v.extend_from_slice(&index.to_le_bytes());
    v.extend_from_slice(&(msg.len() as u32 + 1).to_le_bytes());
    v.extend_from_slice(msg.as_bytes());
    v.push(0);
    v
}

fn index_of(body: &[u8]) -> u32 {
    u32::from_le_bytes(body[..4].try_into().unwrap())
}

const PARTICIPANT_XML: &str =
    "<dds><participant><rtps><name>default_xrce_participant</name></rtps></participant></dds>";

fn topic_xml(topic: &str, keyed: bool) -> String {
    let kind = if keyed { "WITH_KEY" } else { "NO_KEY" };
    format!("<dds><topic><name>{topic}</name><dataType>HelloWorld</dataType><kind>{kind}</kind></topic></dds>")
}

fn writer_xml(topic: &str, keyed: bool, extra_qos: &str) -> String {
    let kind = if keyed { "WITH_KEY" } else { "NO_KEY" };
    format!(
        "<dds><data_writer><topic><kind>{kind}</kind><name>{topic}</name><dataType>HelloWorld</dataType>\
         <historyQos><kind>KEEP_ALL</kind></historyQos></topic>{extra_qos}</data_writer></dds>"
    )
}

/// A core on the DDS middleware, with a client simulator that acknowledges every reliable message and
/// records what each port (client) receives.
struct DdsHarness {
    core: AgentCore<u16, Dds>,
    next_in: HashMap<(u16, u8), u16>,
    received: HashMap<u16, Vec<Out>>,
}

impl DdsHarness {
    fn new() -> Self {
        Self::with(|dds| dds)
    }

    /// A harness whose middleware `configure` adjusts.
    fn with(configure: impl FnOnce(Dds) -> Dds) -> Self {
        require_loopback_namespace();
        let profiles = Arc::new(StoreProfiles::new());
        let dds = configure(Dds::with_config(profiles, loopback()));
        Self { core: AgentCore::new(CoreConfig::default(), dds), next_in: HashMap::new(), received: HashMap::new() }
    }

    fn send(&mut self, port: u16, bytes: &[u8]) {
        self.core.handle_datagram(port, bytes, Instant::now());
        self.drain();
    }

    fn drain(&mut self) {
        loop {
            let mut acks = Vec::new();
            let mut buf = Vec::new();
            while let Some(t) =
                self.core.poll_transmit(Instant::now(), &mut buf).map(|to| Transmit { to, data: buf.clone() })
            {
                let (header, subs) = decode_owned(&t.data);
                if header.stream_id.is_reliable() {
                    let next = self.next_in.entry((t.to, header.stream_id.0)).or_insert(0);
                    if header.sequence_nr == *next {
                        *next = next.wrapping_add(1);
                        self.received.entry(t.to).or_default().extend(subs);
                    }
                    let ack =
                        AckNack { first_unacked_seq_num: *next, nack_bitmap: [0, 0], stream_id: header.stream_id.0 };
                    let h = MessageHeader { stream_id: StreamId::NONE, sequence_nr: 0, ..header };
                    let mut buf = [0u8; 32];
                    let n =
                        message::encode_single(&mut buf, &h, &Submessage::AckNack(ack), xrce_proto::Endianness::Little)
                            .unwrap();
                    acks.push((t.to, buf[..n].to_vec()));
                } else {
                    self.received.entry(t.to).or_default().extend(subs);
                }
            }
            // What a shell does once it has sent the turn's messages.
            self.core.after_send(Instant::now());
            if acks.is_empty() {
                return;
            }
            // One ack per (port, stream) is enough: the last one acknowledges everything before it.
            let mut last: HashMap<(u16, u8), Vec<u8>> = HashMap::new();
            for (port, a) in acks {
                let stream = a[a.len() - 1];
                last.insert((port, stream), a);
            }
            for ((port, _), a) in last {
                self.core.handle_datagram(port, &a, Instant::now());
            }
        }
    }

    /// Polls the middleware until `done` or `secs` pass.
    fn run_until(&mut self, secs: u64, mut done: impl FnMut(&Self) -> bool) -> bool {
        let deadline = Instant::now() + Duration::from_secs(secs);
        loop {
            self.core.poll_middleware(Instant::now());
            self.core.handle_timeout(Instant::now());
            self.drain();
            if done(self) {
                return true;
            }
            if Instant::now() > deadline {
                return false;
            }
            std::thread::sleep(Duration::from_millis(2));
        }
    }

    fn statuses(&self, port: u16) -> Vec<(u16, u8)> {
        self.received
            .get(&port)
            .map(|v| {
                v.iter()
                    .filter_map(|o| match o {
                        Out::Status { request, status, .. } => Some((*request, *status)),
                        _ => None,
                    })
                    .collect()
            })
            .unwrap_or_default()
    }

    fn data(&self, port: u16) -> Vec<Vec<u8>> {
        self.received
            .get(&port)
            .map(|v| {
                v.iter()
                    .filter_map(|o| match o {
                        Out::Data { data, .. } => Some(data.clone()),
                        _ => None,
                    })
                    .collect()
            })
            .unwrap_or_default()
    }

    fn assert_all_ok(&self, port: u16, n: usize) {
        let st = self.statuses(port);
        assert_eq!(st.len(), n, "{st:?}");
        assert!(st.iter().all(|(_, s)| *s == 0), "every CREATE succeeds: {st:?}");
    }
}

fn create_mode(c: &mut Client, id: ObjectId, variant: EntityVariant<'_>, mode: CreationMode) -> Vec<u8> {
    let mut request = c.next_request();
    request.object_id = id;
    c.encode(true, &Submessage::Create(Create { request, mode, variant: ObjectVariant::Entity(variant) }))
}

const P1: ObjectId = ObjectId::new(1, ObjectKind::Participant);
const T1: ObjectId = ObjectId::new(1, ObjectKind::Topic);
const PUB1: ObjectId = ObjectId::new(1, ObjectKind::Publisher);
const SUB1: ObjectId = ObjectId::new(1, ObjectKind::Subscriber);
const DW1: ObjectId = ObjectId::new(1, ObjectKind::DataWriter);
const DR1: ObjectId = ObjectId::new(1, ObjectKind::DataReader);

/// Participant, topic, publisher and datawriter by XML, as eProsima's PublishHelloWorld does.
fn xml_publisher(h: &mut DdsHarness, port: u16, key: u32, topic: &str, keyed: bool) -> Client {
    let mut c = Client::new(key);
    h.send(port, &create_client_msg(key, 0x81));
    let msgs = vec![
        c.create(P1, EntityVariant::participant(Representation::Xml(PARTICIPANT_XML), 0)),
        c.create(T1, EntityVariant::child(ObjectKind::Topic, Representation::Xml(&topic_xml(topic, keyed)), P1)),
        c.create(PUB1, EntityVariant::child(ObjectKind::Publisher, Representation::Xml(""), P1)),
        c.create(
            DW1,
            EntityVariant::child(ObjectKind::DataWriter, Representation::Xml(&writer_xml(topic, keyed, "")), PUB1),
        ),
    ];
    for m in msgs {
        h.send(port, &m);
    }
    c
}

/// Participant, topic, subscriber and a reliable KEEP_ALL datareader, all binary.
fn binary_subscriber(h: &mut DdsHarness, port: u16, key: u32, topic: &str) -> Client {
    let mut c = Client::new(key);
    h.send(port, &create_client_msg(key, 0x81));
    let empty = BinaryObject::Raw(&[0, 0]);
    let topic_bin = BinaryObject::Topic(xrce_proto::object::TopicBinary {
        topic_name: topic,
        type_reference: None,
        type_name: Some("HelloWorld"),
    });
    let qos = DataReaderQos {
        base: xrce_proto::object::EndpointQos { qos_flags: QosFlags::RELIABLE, ..Default::default() },
        ..Default::default()
    };
    let reader = BinaryObject::DataReader(DataReaderBinary { topic_id: T1, qos: Some(qos) });
    let msgs = vec![
        c.create(P1, EntityVariant::participant(Representation::Binary(empty), 0)),
        c.create(T1, EntityVariant::child(ObjectKind::Topic, Representation::Binary(topic_bin), P1)),
        c.create(SUB1, EntityVariant::child(ObjectKind::Subscriber, Representation::Binary(empty), P1)),
        c.create(DR1, EntityVariant::child(ObjectKind::DataReader, Representation::Binary(reader), SUB1)),
    ];
    for m in msgs {
        h.send(port, &m);
    }
    c
}

fn wait_matched(w: &RawWriter, n: usize, secs: u64) {
    let t0 = Instant::now();
    while w.matched_readers() < n {
        assert!(t0.elapsed() < Duration::from_secs(secs), "writer matched {} of {n} readers", w.matched_readers());
        std::thread::sleep(Duration::from_millis(20));
    }
}

fn collect(q: &SampleQueue, n: usize, secs: u64) -> Vec<ReceivedSample> {
    let deadline = Instant::now() + Duration::from_secs(secs);
    let mut out = Vec::with_capacity(n);
    while out.len() < n && Instant::now() < deadline {
        if q.wait(deadline.saturating_duration_since(Instant::now())) {
            q.take_batch(n - out.len(), &mut out);
        }
    }
    out
}

/// Waits until the DDS side of the core has matched a peer reader: written samples then reach it.
fn settle() {
    std::thread::sleep(Duration::from_millis(1500));
}

#[test]
#[ignore = "starts DDS: run inside shared/dds-peers/netns.sh with --ignored"]
fn xrce_publisher_reaches_a_dds_reader_and_reuse_compares_qos() {
    let mut h = DdsHarness::new();
    let peer = peer_bridge();
    let pp = peer.participant(0, "").unwrap();
    let t = pp.topic("HelloWorldTopic", "HelloWorld", false).unwrap();
    let reader = pp.create_reader(&t, &EndpointQos::default()).unwrap();
    let mut c = xml_publisher(&mut h, 1, 0xAAAA_BBBB, "HelloWorldTopic", false);
    h.assert_all_ok(1, 4);
    assert_eq!(h.core.middleware().bridge().participant_count(), 1);
    settle();
    for i in 1..=10 {
        h.send(1, &c.write(true, DW1, &hello_body(i, "Hello DDS world!")));
    }
    let got = collect(reader.queue(), 10, 20);
    assert_eq!(got.len(), 10);
    for (i, s) in got.iter().enumerate() {
        let body = hello_body(i as u32 + 1, "Hello DDS world!");
        assert_eq!(&s.data[..body.len()], &body[..], "the client's CDR body, encapsulation stripped");
        assert_eq!(s.encapsulation, [0, 1]);
    }
    // REUSE: same description → OK_MATCHED; other QoS → MISMATCH; REUSE|REPLACE → replaced (OK).
    let reuse = CreationMode { reuse: true, replace: false };
    let same = writer_xml("HelloWorldTopic", false, "");
    let m =
        create_mode(&mut c, DW1, EntityVariant::child(ObjectKind::DataWriter, Representation::Xml(&same), PUB1), reuse);
    h.send(1, &m);
    assert_eq!(h.statuses(1).last().unwrap().1, StatusCode::OK_MATCHED.0);
    let other = writer_xml("HelloWorldTopic", false, "<qos><reliability><kind>BEST_EFFORT</kind></reliability></qos>");
    let m = create_mode(
        &mut c,
        DW1,
        EntityVariant::child(ObjectKind::DataWriter, Representation::Xml(&other), PUB1),
        reuse,
    );
    h.send(1, &m);
    assert_eq!(h.statuses(1).last().unwrap().1, StatusCode::ERR_MISMATCH.0);
    let m = create_mode(
        &mut c,
        DW1,
        EntityVariant::child(ObjectKind::DataWriter, Representation::Xml(&other), PUB1),
        CreationMode { reuse: true, replace: true },
    );
    h.send(1, &m);
    assert_eq!(h.statuses(1).last().unwrap().1, StatusCode::OK.0);
    // Deleting the participant deletes its children and releases the DDS participant.
    let mut request = c.next_request();
    request.object_id = P1;
    h.send(1, &c.encode(true, &Submessage::Delete(request)));
    assert_eq!(h.statuses(1).last().unwrap().1, StatusCode::OK.0);
    assert_eq!(h.core.middleware().entity_count(), 0);
    // The participant was a ROS 2 node (named in its XML): the graph holds the DDS participant until its
    // last ros_discovery_info sample (no node) is out, then lets it go.
    let deadline = Instant::now() + Duration::from_secs(2);
    while h.core.middleware().bridge().participant_count() != 0 && Instant::now() < deadline {
        std::thread::sleep(Duration::from_millis(10));
    }
    assert_eq!(h.core.middleware().bridge().participant_count(), 0);
}

#[test]
#[ignore = "starts DDS: run inside shared/dds-peers/netns.sh with --ignored"]
fn dds_writer_reaches_an_xrce_subscriber_with_delivery_control() {
    let mut h = DdsHarness::new();
    let mut c = binary_subscriber(&mut h, 2, 0xCCCC_DDDD, "HelloWorldTopic");
    h.assert_all_ok(2, 4);
    let peer = peer_bridge();
    let pp = peer.participant(0, "").unwrap();
    let t = pp.topic("HelloWorldTopic", "HelloWorld", false).unwrap();
    let w = pp.create_writer(&t, &EndpointQos::default()).unwrap();
    wait_matched(&w, 1, 20);
    // READ_DATA with max_samples 3: exactly three DATA, the rest waits in the reader.
    let control = xrce_proto::submessage::DataDeliveryControl { max_samples: 3, ..Default::default() };
    h.send(2, &c.read(DR1, 0x80, Some(control)));
    for i in 1..=5 {
        w.write(&hello_body(i, "from DDS")).unwrap();
    }
    assert!(h.run_until(20, |h| h.data(2).len() >= 3));
    std::thread::sleep(Duration::from_millis(300));
    h.run_until(0, |_| false);
    assert_eq!(h.data(2).len(), 3, "max_samples honoured");
    h.send(2, &c.read(DR1, 0x80, unlimited()));
    assert!(h.run_until(20, |h| h.data(2).len() >= 5));
    let data = h.data(2);
    let ids: Vec<u32> = data.iter().map(|d| index_of(d)).collect();
    assert_eq!(ids, vec![1, 2, 3, 4, 5]);
    assert_eq!(&data[0][..hello_body(1, "from DDS").len()], &hello_body(1, "from DDS")[..]);
}

#[test]
#[ignore = "starts DDS: run inside shared/dds-peers/netns.sh with --ignored"]
fn xrce_requester_and_replier_talk_through_dds() {
    let mut h = DdsHarness::new();
    let mut req = Client::new(0xAAAA_BBBB);
    let mut rep = Client::new(0xCCCC_DDDD);
    h.send(1, &create_client_msg(req.key, 0x81));
    h.send(2, &create_client_msg(rep.key, 0x81));
    // XML as eProsima's RequestAdder/ReplyAdder send it (no spaces between attributes).
    let xml = |k: &str| {
        format!(
            r#"<dds><{k} profile_name="my_{k}"service_name="service_name"request_type="request_type"reply_type="reply_type"></{k}></dds>"#
        )
    };
    let requester = ObjectId::new(1, ObjectKind::Requester);
    let replier = ObjectId::new(1, ObjectKind::Replier);
    for (port, c, id, kind) in
        [(1, &mut req, requester, ObjectKind::Requester), (2, &mut rep, replier, ObjectKind::Replier)]
    {
        let name = if kind == ObjectKind::Requester { "requester" } else { "replier" };
        let x = xml(name);
        let msgs = vec![
            c.create(P1, EntityVariant::participant(Representation::Xml(PARTICIPANT_XML), 0)),
            c.create(id, EntityVariant::child(kind, Representation::Xml(&x), P1)),
        ];
        for m in msgs {
            h.send(port, &m);
        }
        h.assert_all_ok(port, 2);
    }
    h.send(1, &req.read(requester, 0x80, unlimited()));
    h.send(2, &rep.read(replier, 0x80, unlimited()));
    settle();
    // Requests: the WRITE_DATA request ids are remembered for the replies.
    let mut request_ids = Vec::new();
    for n in 1..=3u32 {
        request_ids.push(req.request + 1);
        let mut body = n.to_le_bytes().to_vec();
        body.extend_from_slice(&n.to_le_bytes());
        h.send(1, &req.write(true, requester, &body));
    }
    assert!(h.run_until(20, |h| h.data(2).len() >= 3), "replier got {:?}", h.data(2).len());
    // Replier DATA: SampleIdentity (24 bytes) + request. Answer with the same identity + sum.
    for d in h.data(2) {
        let (identity, body) = d.split_at(24);
        let a = u32::from_le_bytes(body[..4].try_into().unwrap());
        let b = u32::from_le_bytes(body[4..8].try_into().unwrap());
        let mut reply = identity.to_vec();
        reply.extend_from_slice(&(a + b).to_le_bytes());
        h.send(2, &rep.write(true, replier, &reply));
    }
    assert!(h.run_until(20, |h| h.data(1).len() >= 3), "requester got {:?}", h.data(1).len());
    // Requester DATA: BaseObjectRequest{request id of the WRITE_DATA, requester} + reply.
    let mut got = Vec::new();
    for d in h.data(1) {
        let rid = u16::from_be_bytes([d[0], d[1]]);
        let sum = u32::from_le_bytes(d[4..8].try_into().unwrap());
        got.push((rid, sum));
    }
    got.sort();
    assert_eq!(got, vec![(request_ids[0], 2), (request_ids[1], 4), (request_ids[2], 6)]);
}

#[test]
#[ignore = "starts DDS: run inside shared/dds-peers/netns.sh with --ignored"]
fn keyed_topic_from_xml_is_keyed_in_dds() {
    let mut h = DdsHarness::new();
    let peer = peer_bridge();
    let pp = peer.participant(0, "").unwrap();
    let t = pp.topic("HelloWorldKeyedTopic", "HelloWorld", true).unwrap();
    let reader = pp.create_reader(&t, &EndpointQos::default()).unwrap();
    let mut c = xml_publisher(&mut h, 1, 0x0102_0304, "HelloWorldKeyedTopic", true);
    h.assert_all_ok(1, 4);
    settle();
    for i in 1..=20 {
        h.send(1, &c.write(true, DW1, &hello_body(i, "keyed")));
    }
    let got = collect(reader.queue(), 20, 20);
    let ids: HashSet<u32> = got.iter().map(|s| index_of(&s.data)).collect();
    assert_eq!(ids.len(), 20, "every keyed sample arrives");
    // The same topic name with another key kind is refused (one type per topic and participant).
    let mut c2 = Client::new(0x0506_0708);
    h.send(3, &create_client_msg(c2.key, 0x81));
    let msgs = vec![
        c2.create(P1, EntityVariant::participant(Representation::Xml(PARTICIPANT_XML), 0)),
        c2.create(
            T1,
            EntityVariant::child(ObjectKind::Topic, Representation::Xml(&topic_xml("HelloWorldKeyedTopic", false)), P1),
        ),
    ];
    for m in msgs {
        h.send(3, &m);
    }
    assert_eq!(h.statuses(3).last().unwrap().1, StatusCode::ERR_DDS_ERROR.0);
}

#[test]
#[ignore = "starts DDS: run inside shared/dds-peers/netns.sh with --ignored"]
fn a_thousand_clients_each_with_a_datawriter_share_one_participant() {
    let mut h = DdsHarness::new();
    let peer = peer_bridge();
    let pp = peer.participant(0, "").unwrap();
    let t = pp.topic("ManyTopic", "HelloWorld", false).unwrap();
    let reader = pp.create_reader(&t, &EndpointQos::default()).unwrap();
    let t0 = Instant::now();
    let mut clients = Vec::new();
    for i in 0..1000u32 {
        let port = 1000 + i as u16;
        let c = xml_publisher(&mut h, port, 0x1000_0000 + i, "ManyTopic", false);
        h.assert_all_ok(port, 4);
        clients.push((port, c));
    }
    println!("1000 clients with a datawriter each created in {:.2} s", t0.elapsed().as_secs_f64());
    assert_eq!(h.core.middleware().bridge().participant_count(), 1, "one DDS participant for all");
    assert_eq!(h.core.middleware().entity_count(), 4000);
    settle();
    std::thread::sleep(Duration::from_secs(2));
    for (port, c) in &mut clients {
        let i = u32::from(*port);
        let m = c.write(true, DW1, &hello_body(i, "many"));
        h.send(*port, &m);
    }
    let got = collect(reader.queue(), 1000, 60);
    let ids: HashSet<u32> = got.iter().map(|s| index_of(&s.data)).collect();
    println!(
        "DDS reader got {} samples from {} distinct clients in {:.2} s",
        got.len(),
        ids.len(),
        t0.elapsed().as_secs_f64()
    );
    assert_eq!(ids.len(), 1000, "one sample from every client");
}

#[test]
#[ignore = "starts DDS: run inside shared/dds-peers/netns.sh with --ignored"]
fn reliable_burst_of_10000_both_ways() {
    let mut h = DdsHarness::new();
    // XRCE → DDS: XRCE writer (reliable keep-all from XML) → keep-all DDS reader.
    let peer = peer_bridge();
    let pp = peer.participant(0, "").unwrap();
    let t = pp.topic("BurstUp", "HelloWorld", false).unwrap();
    let reader = pp.create_reader(&t, &EndpointQos::default()).unwrap();
    let mut c = xml_publisher(&mut h, 1, 0x1111_1111, "BurstUp", false);
    h.assert_all_ok(1, 4);
    settle();
    let t0 = Instant::now();
    for i in 0..10_000u32 {
        let mut body = vec![0u8; 64];
        body[..4].copy_from_slice(&i.to_le_bytes());
        let m = c.write(true, DW1, &body);
        h.send(1, &m);
    }
    let got = collect(reader.queue(), 10_000, 60);
    println!("XRCE → DDS: {} of 10000 in {:.2} s", got.len(), t0.elapsed().as_secs_f64());
    let ids: Vec<u32> = got.iter().map(|s| index_of(&s.data)).collect();
    assert_eq!(ids, (0..10_000).collect::<Vec<_>>(), "complete and in order");

    // DDS → XRCE: keep-all DDS writer → reliable keep-all XRCE reader.
    let mut s = binary_subscriber(&mut h, 2, 0x2222_2222, "BurstDown");
    h.assert_all_ok(2, 4);
    let t = pp.topic("BurstDown", "HelloWorld", false).unwrap();
    let w = pp.create_writer(&t, &EndpointQos::default()).unwrap();
    wait_matched(&w, 1, 20);
    h.send(2, &s.read(DR1, 0x80, unlimited()));
    let t0 = Instant::now();
    for i in 0..10_000u32 {
        let mut body = vec![0u8; 64];
        body[..4].copy_from_slice(&i.to_le_bytes());
        let mut tries = 0;
        while w.write(&body).is_err() {
            tries += 1;
            assert!(tries < 100, "DDS writer blocked for 10 s");
        }
        if i % 256 == 0 {
            h.run_until(0, |_| false);
        }
    }
    assert!(h.run_until(60, |h| h.data(2).len() >= 10_000), "XRCE reader got {}", h.data(2).len());
    println!("DDS → XRCE: 10000 in {:.2} s", t0.elapsed().as_secs_f64());
    let ids: Vec<u32> = h.data(2).iter().map(|d| index_of(d)).collect();
    assert_eq!(ids, (0..10_000).collect::<Vec<_>>(), "complete and in order");
}

/// Participant, topic, subscriber and a datareader with the QoS bits `flags` (no history depth: KEEP_LAST
/// means depth 1, as eProsima's clients and our benchmark send it), all binary.
fn binary_subscriber_with(h: &mut DdsHarness, port: u16, key: u32, topic: &str, flags: u16) -> Client {
    let mut c = Client::new(key);
    h.send(port, &create_client_msg(key, 0x81));
    let empty = BinaryObject::Raw(&[0, 0]);
    let topic_bin = BinaryObject::Topic(xrce_proto::object::TopicBinary {
        topic_name: topic,
        type_reference: None,
        type_name: Some("HelloWorld"),
    });
    let qos = DataReaderQos {
        base: xrce_proto::object::EndpointQos { qos_flags: flags, ..Default::default() },
        ..Default::default()
    };
    let reader = BinaryObject::DataReader(DataReaderBinary { topic_id: T1, qos: Some(qos) });
    let msgs = vec![
        c.create(P1, EntityVariant::participant(Representation::Binary(empty), 0)),
        c.create(T1, EntityVariant::child(ObjectKind::Topic, Representation::Binary(topic_bin), P1)),
        c.create(SUB1, EntityVariant::child(ObjectKind::Subscriber, Representation::Binary(empty), P1)),
        c.create(DR1, EntityVariant::child(ObjectKind::DataReader, Representation::Binary(reader), SUB1)),
    ];
    for m in msgs {
        h.send(port, &m);
    }
    c
}

/// Back-pressure through DDS: a fast XRCE publisher and a slow XRCE subscriber of the same agent (it reads
/// ten samples per READ_DATA, a new READ_DATA every couple of milliseconds) exchange 5,000 reliable
/// samples through RustDDS without losing one. The subscriber's reader is KEEP_LAST 1 (its bridge queue and
/// RustDDS' topic cache are then the smallest: 1,024 samples), so without the write credit holding the
/// publisher's reliable stream the publisher runs thousands of samples ahead and RustDDS evicts them.
#[test]
#[ignore = "starts DDS: run inside shared/dds-peers/netns.sh with --ignored"]
fn slow_xrce_subscriber_holds_a_fast_xrce_publisher_back_without_loss() {
    const N: u32 = 5_000;
    /// Reliable messages the publisher keeps in flight (its history), as the benchmark's 8.
    const WINDOW: u16 = 8;
    const PER_READ: u16 = 10;
    let mut h = DdsHarness::new();
    let mut p = xml_publisher(&mut h, 1, 0x5151_0001, "SlowSubTopic", false);
    h.assert_all_ok(1, 4);
    let mut s = binary_subscriber_with(
        &mut h,
        2,
        0x5151_0002,
        "SlowSubTopic",
        QosFlags::RELIABLE | QosFlags::HISTORY_KEEP_LAST,
    );
    h.assert_all_ok(2, 4);
    settle();

    let data_count =
        |h: &DdsHarness| h.received.get(&2).map_or(0, |v| v.iter().filter(|o| matches!(o, Out::Data { .. })).count());
    // The agent's acknowledgement of the publisher's reliable stream: first sequence number not yet taken.
    let mut acked = p.seq_rel;
    let mut ack_scan = 0;
    let mut in_flight: Vec<(u16, Vec<u8>)> = Vec::new();
    let mut last_progress = Instant::now();
    let (mut written, mut requested, mut window_full) = (0u32, 0usize, 0u32);
    let control = xrce_proto::submessage::DataDeliveryControl { max_samples: PER_READ, ..Default::default() };
    let deadline = Instant::now() + Duration::from_secs(60);
    let t0 = Instant::now();
    let (mut last_got, mut got_at) = (0, Instant::now());
    let mut most_without_credit = 0;
    loop {
        // Publisher: as fast as its window allows (the agent acknowledges within `send`), up to 2,000
        // samples per round, ten times what the subscriber takes in one.
        let round_start = written;
        loop {
            if let Some(outs) = h.received.get(&1) {
                for o in &outs[ack_scan..] {
                    if let Out::AckNack { first, stream: 0x80, .. } = o {
                        if first.wrapping_sub(acked) as i16 > 0 {
                            acked = *first;
                            last_progress = Instant::now();
                        }
                    }
                }
                ack_scan = outs.len();
            }
            in_flight.retain(|(seq, _)| acked.wrapping_sub(*seq) as i16 <= 0);
            if written >= N || written - round_start >= 2_000 {
                break;
            }
            if p.seq_rel.wrapping_sub(acked) >= WINDOW {
                window_full += 1;
                break;
            }
            let seq = p.seq_rel;
            let m = p.write(true, DW1, &hello_body(written, "slow subscriber"));
            h.send(1, &m);
            in_flight.push((seq, m));
            written += 1;
        }
        // A client retransmits what stays unacknowledged (the agent never loses a held message, but a
        // retransmission also prompts it to retry).
        if last_progress.elapsed() > Duration::from_millis(200) {
            for (_, m) in in_flight.clone() {
                h.send(1, &m);
            }
            last_progress = Instant::now();
        }
        // Subscriber: a new READ_DATA of PER_READ samples once the previous one was served.
        let got = data_count(&h);
        if got >= requested && got < N as usize {
            h.send(2, &s.read(DR1, 0x80, Some(control)));
            requested = got + usize::from(PER_READ);
        }
        h.core.poll_middleware(Instant::now());
        h.core.handle_timeout(Instant::now());
        h.drain();
        let got = data_count(&h);
        if got > 0 {
            // The first-contact gate is open by now: what is counted is the slow reader holding the writer.
            let without_credit = h.core.snapshot(Instant::now()).middleware.writers_without_credit;
            most_without_credit = most_without_credit.max(without_credit);
        }
        if got != last_got {
            (last_got, got_at) = (got, Instant::now());
        }
        // Lost samples never come: stop once nothing arrived for 10 s.
        if got >= N as usize || Instant::now() > deadline || got_at.elapsed() > Duration::from_secs(10) {
            break;
        }
        std::thread::sleep(Duration::from_millis(2));
    }
    let ids: Vec<u32> = h.data(2).iter().map(|d| index_of(d)).collect();
    println!(
        "slow subscriber: {} of {N} samples in {:.2} s; publisher window full on {window_full} rounds",
        ids.len(),
        t0.elapsed().as_secs_f64()
    );
    assert_eq!(written, N, "the publisher wrote everything");
    assert_eq!(ids, (0..N).collect::<Vec<_>>(), "every sample, once, in order");
    assert!(window_full > 0, "the publisher was held back (its window filled)");
    // The snapshot's "writers without credit" shows the publisher's writer while it is held back, then not.
    assert_eq!(most_without_credit, 1, "the writer held back by the slow reader counted");
    let after = h.core.snapshot(Instant::now()).middleware.writers_without_credit;
    assert_eq!(after, 0, "no writer without credit once everything went");
}

/// Each XRCE participant name gets its own DDS participant, the same name shares it, and past the limit a new
/// name shares the default participant instead of creating another.
#[test]
#[ignore = "starts DDS: run inside shared/dds-peers/netns.sh with --ignored"]
fn participants_per_name_share_by_name_and_stop_at_the_limit() {
    let mut h = DdsHarness::with(|dds| dds.with_named_participant_limit(2));
    let named = |name: &'static str| {
        BinaryObject::Participant(xrce_proto::object::ParticipantBinary {
            domain_reference: None,
            qos_profile_reference: Some(name),
        })
    };
    for (port, key, name) in [(1, 0x7070_0001, "alpha"), (2, 0x7070_0002, "alpha"), (3, 0x7070_0003, "beta")] {
        let mut c = Client::new(key);
        h.send(port, &create_client_msg(key, 0x81));
        h.send(port, &c.create(P1, EntityVariant::participant(Representation::Binary(named(name)), 0)));
        h.assert_all_ok(port, 1);
    }
    let bridge = Arc::clone(h.core.middleware().bridge());
    let guid_of = |name: &str| bridge.existing_participant(0, name).map(|p| p.guid());
    let (alpha, beta) = (guid_of("alpha"), guid_of("beta"));
    if bridge.engine() == xrce_dds::Engine::RustDds {
        // RustDDS announces no names: every XRCE participant shares the default one.
        assert_eq!(bridge.participant_count(), 1);
        return;
    }
    assert!(alpha.is_some() && beta.is_some() && alpha != beta, "one DDS participant per name");
    assert_eq!(bridge.participant_count(), 2, "the second alpha shares the first one's");
    // A third name is past the limit (2 live): it gets the default participant.
    let mut c = Client::new(0x7070_0004);
    h.send(4, &create_client_msg(0x7070_0004, 0x81));
    h.send(4, &c.create(P1, EntityVariant::participant(Representation::Binary(named("gamma")), 0)));
    h.assert_all_ok(4, 1);
    assert!(guid_of("gamma").is_none(), "no participant for a name past the limit");
    assert!(guid_of("").is_some(), "the default participant serves it");
    assert_eq!(bridge.participant_count(), 3);
}

/// The default participant created at start is retired once a participant created for a name has run
/// long enough (here 2 s: its discovery is done), one participant fewer in discovery (issue 21), and first
/// contact holds: the first sample of a named client created after that, written right after STATUS OK,
/// reaches a DDS reader that was running before (its writer's gate asks the oldest named participant, which
/// knows the reader). The reader is in this process, which the gate does not wait for as a peer in
/// discovery: retired at once, before the named participant knew the reader, the sample was lost in 3 of 6
/// runs.
#[test]
#[ignore = "starts DDS: run inside shared/dds-peers/netns.sh with --ignored"]
fn the_default_participant_retires_and_first_contact_holds() {
    const TOPIC: &str = "RetireTopic";
    let mut h = DdsHarness::with(|dds| {
        dds.with_default_participant_retire_after(Duration::from_secs(2)).with_eager_participant(true)
    });
    let bridge = Arc::clone(h.core.middleware().bridge());
    if bridge.engine() == xrce_dds::Engine::RustDds {
        return; // every name shares the default participant there: nothing to retire
    }
    assert!(bridge.existing_participant(0, "").is_some(), "the default participant is created at start");
    let peer = peer_bridge();
    let pp = peer.participant(0, "").unwrap();
    let t = pp.topic(TOPIC, "HelloWorld", false).unwrap();
    let remote = pp.create_reader(&t, &EndpointQos::default()).unwrap();
    settle();
    let named = |name: &'static str| {
        BinaryObject::Participant(xrce_proto::object::ParticipantBinary {
            domain_reference: None,
            qos_profile_reference: Some(name),
        })
    };
    let mut first = Client::new(0x5E71_0001);
    h.send(1, &create_client_msg(0x5E71_0001, 0x81));
    h.send(1, &first.create(P1, EntityVariant::participant(Representation::Binary(named("first_node")), 0)));
    h.assert_all_ok(1, 1);
    assert!(h.run_until(8, |_| bridge.existing_participant(0, "").is_none()), "the default participant retires");
    let flags = QosFlags::RELIABLE | QosFlags::HISTORY_KEEP_LAST;
    let mut second = binary_publisher_of(&mut h, 2, 0x5E71_0002, TOPIC, flags, named("second_node"));
    h.assert_all_ok(2, 4);
    h.send(2, &second.write(true, DW1, &hello_body(1, "first contact")));
    // The core holds the write while the gate is closed and retries it when polled.
    let mut got = Vec::new();
    h.run_until(10, |_| {
        remote.queue().take_batch(1, &mut got);
        !got.is_empty()
    });
    assert_eq!(got.first().map(|s| index_of(&s.data)), Some(1), "the first sample reaches the running reader");
    assert!(bridge.existing_participant(0, "").is_none(), "not created again while named ones live");
}

/// Participant, topic, publisher and a datawriter with the QoS bits `flags` (KEEP_LAST without a depth: 1, as
/// micro-ROS and our benchmark send it), all binary.
fn binary_publisher_with(h: &mut DdsHarness, port: u16, key: u32, topic: &str, flags: u16) -> Client {
    binary_publisher_of(h, port, key, topic, flags, BinaryObject::Raw(&[0, 0]))
}

/// [`binary_publisher_with`] under the binary participant `participant` (a name, say).
fn binary_publisher_of(
    h: &mut DdsHarness,
    port: u16,
    key: u32,
    topic: &str,
    flags: u16,
    participant: BinaryObject<'_>,
) -> Client {
    let mut c = Client::new(key);
    h.send(port, &create_client_msg(key, 0x81));
    let empty = BinaryObject::Raw(&[0, 0]);
    let topic_bin = BinaryObject::Topic(xrce_proto::object::TopicBinary {
        topic_name: topic,
        type_reference: None,
        type_name: Some("HelloWorld"),
    });
    let qos = DataWriterQos {
        base: xrce_proto::object::EndpointQos { qos_flags: flags, ..Default::default() },
        ..Default::default()
    };
    let writer = BinaryObject::DataWriter(DataWriterBinary { topic_id: T1, qos: Some(qos) });
    let msgs = vec![
        c.create(P1, EntityVariant::participant(Representation::Binary(participant), 0)),
        c.create(T1, EntityVariant::child(ObjectKind::Topic, Representation::Binary(topic_bin), P1)),
        c.create(PUB1, EntityVariant::child(ObjectKind::Publisher, Representation::Binary(empty), P1)),
        c.create(DW1, EntityVariant::child(ObjectKind::DataWriter, Representation::Binary(writer), PUB1)),
    ];
    for m in msgs {
        h.send(port, &m);
    }
    c
}

/// Samples from one client to another of the same agent go ahead of the DDS write (Fast DDS engine: queued
/// at the reliable reader at once, the DDS write made after the shell's sends) and every reader still gets
/// each sample once, per writer in order: the XRCE subscriber reading on a reliable stream (ahead), one
/// reading on a best-effort stream (through DDS, in the write), and a DDS reader outside the agent. Two XRCE
/// publishers share the agent's DDS writer and write interleaved.
#[test]
#[ignore = "starts DDS: run inside shared/dds-peers/netns.sh with --ignored"]
fn samples_between_clients_go_ahead_of_the_dds_write_once_and_in_order() {
    const N: u32 = 3_000;
    const TOPIC: &str = "AheadTopic";
    let keep_last = QosFlags::RELIABLE | QosFlags::HISTORY_KEEP_LAST;
    let mut h = DdsHarness::new();
    if h.core.middleware().bridge().engine() == xrce_dds::Engine::RustDds {
        // The ahead path is the Fast DDS engine's (it delivers to the agent's own readers inside the write).
        // On RustDDS this burst stalls after a few hundred samples: the raw harness never resends what the
        // core leaves unacknowledged, as a client does.
        println!("RustDDS engine: no ahead path to check");
        return;
    }
    let peer = peer_bridge();
    let pp = peer.participant(0, "").unwrap();
    let t = pp.topic(TOPIC, "HelloWorld", false).unwrap();
    let remote = pp.create_reader(&t, &EndpointQos::default()).unwrap();
    let mut p1 = binary_publisher_with(&mut h, 1, 0xA4EA_0001, TOPIC, keep_last);
    let mut p2 = binary_publisher_with(&mut h, 2, 0xA4EA_0002, TOPIC, keep_last);
    let mut s = binary_subscriber(&mut h, 3, 0xA4EA_0003, TOPIC);
    let mut b = binary_subscriber(&mut h, 4, 0xA4EA_0004, TOPIC);
    for port in 1..=4 {
        h.assert_all_ok(port, 4);
    }
    settle();
    h.send(3, &s.read(DR1, 0x80, unlimited()));
    h.send(4, &b.read(DR1, 0x01, unlimited()));
    let body = |i: u32| hello_body(i, "ahead");
    // The first sample of each publisher reaches the readers through DDS (the agent's readers have not
    // received from the DDS writer yet).
    h.send(1, &p1.write(true, DW1, &body(0)));
    h.send(2, &p2.write(true, DW1, &body(N)));
    assert!(h.run_until(10, |h| h.data(3).len() == 2), "first samples: {}", h.data(3).len());
    // The next one goes ahead: its DATA leaves before the DDS write, which then waits for `after_send`.
    let at = Instant::now();
    h.core.handle_datagram(1, &p1.write(true, DW1, &body(1)), at);
    let mut buf = Vec::new();
    let mut to_subscriber = false;
    while let Some(to) = h.core.poll_transmit(at, &mut buf) {
        let (header, subs) = decode_owned(&buf);
        if to == 3 && header.stream_id.0 == 0x80 && subs.iter().any(|o| matches!(o, Out::Data { .. })) {
            // Taken in as the harness does (the next drain acknowledges it).
            let next = h.next_in.entry((3, 0x80)).or_insert(0);
            assert_eq!(header.sequence_nr, *next);
            *next = next.wrapping_add(1);
            h.received.entry(3).or_default().extend(subs);
            to_subscriber = true;
        }
    }
    if to_subscriber {
        assert!(h.core.middleware().flush_due().is_some(), "the DDS write waits for the shell's sends");
        h.core.after_send(at);
        assert_eq!(h.core.middleware().flush_due(), None);
    } else {
        // Not ahead this time: on a loaded machine the first-contact gate may still hold the writer (its
        // remote DDS reader has not acknowledged yet; CI saw it once). The sample then goes through DDS once
        // the gate opens, and what follows still checks every sample once and in order.
        println!("ahead path not taken for sample 1 (writer still at its first-contact gate)");
        h.core.after_send(at);
        assert!(h.run_until(10, |h| h.data(3).len() == 3), "sample 1 through DDS: {}", h.data(3).len());
    }
    // Then bursts from both publishers, interleaved.
    for i in 2..N {
        h.core.handle_datagram(1, &p1.write(true, DW1, &body(i)), Instant::now());
        h.core.handle_datagram(2, &p2.write(true, DW1, &body(N + i - 1)), Instant::now());
        if i % 16 == 0 {
            h.drain();
        }
    }
    h.send(2, &p2.write(true, DW1, &body(2 * N - 1)));
    let all = 2 * N as usize;
    assert!(
        h.run_until(30, |h| h.data(3).len() >= all && h.data(4).len() >= all),
        "{} / {}",
        h.data(3).len(),
        h.data(4).len()
    );
    let from_dds: Vec<u32> = collect(remote.queue(), all, 30).iter().map(|s| index_of(&s.data)).collect();
    for (who, got) in [
        ("reliable subscriber", h.data(3).iter().map(|d| index_of(d)).collect::<Vec<_>>()),
        ("best-effort-stream subscriber", h.data(4).iter().map(|d| index_of(d)).collect()),
        ("DDS reader", from_dds),
    ] {
        assert_eq!(got.len(), all, "{who}: every sample once");
        let first: Vec<u32> = got.iter().copied().filter(|i| *i < N).collect();
        let second: Vec<u32> = got.iter().copied().filter(|i| *i >= N).collect();
        assert_eq!(first, (0..N).collect::<Vec<_>>(), "{who}: the first publisher's samples in order");
        assert_eq!(second, (N..2 * N).collect::<Vec<_>>(), "{who}: the second publisher's samples in order");
    }
}
