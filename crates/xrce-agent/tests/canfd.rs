//! CAN FD end to end without a CAN interface (this machine has no `vcan`): our agent's CAN FD server and our
//! clients' `CanTransport` on one in-process bus (`xrce_client::transport::MemoryBus`), `-m ced`. Sessions,
//! entities, publish and subscribe with samples fragmented over 63-byte frames, a bus that loses every fifth
//! frame, two clients answered each on its own identifier, and frames no client would send.

#![cfg(target_os = "linux")]

use std::collections::{BTreeMap, BTreeSet};
use std::os::fd::{AsRawFd, RawFd};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{mpsc, Arc};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use xrce_agent::agent::{Agent, AgentError, AgentInstance};
use xrce_agent::middleware::MiddlewareKind;
use xrce_agent::transport::canfd::{self, CanBus, CanEndpoint, CanServer};
use xrce_client::prelude::*;
use xrce_client::transport::can::CAN_MTU;
use xrce_client::transport::{BusNode, MemoryBus};
use xrce_proto::framing::can::Frame;

const HISTORY: usize = 16;
/// Output slots of one frame's message, as eProsima's CAN examples size them (MTU × history).
const OUT_BUF: usize = CAN_MTU * HISTORY;
/// Input slots hold a message and its length word; 128 bytes leave room for any frame.
const IN_BUF: usize = 128 * HISTORY;
/// Larger than a frame: travels as FRAGMENTs, about six frames each way.
const BIG: usize = 300;

/// The agent's side of the bus. Its first `failed_reads` reads fail as on a socket whose interface went
/// down; its first `refused_sends` sends are refused with `ENOBUFS`, as by an interface whose queue is full.
struct AgentPort {
    node: BusNode,
    failed_reads: AtomicUsize,
    refused_sends: AtomicUsize,
}

impl AgentPort {
    fn new(node: BusNode, failed_reads: usize, refused_sends: usize) -> Self {
        Self { node, failed_reads: AtomicUsize::new(failed_reads), refused_sends: AtomicUsize::new(refused_sends) }
    }
}

/// Takes one from `n` if it is not zero yet.
fn take_one(n: &AtomicUsize) -> bool {
    n.fetch_update(Ordering::Relaxed, Ordering::Relaxed, |n| n.checked_sub(1)).is_ok()
}

impl AsRawFd for AgentPort {
    fn as_raw_fd(&self) -> RawFd {
        self.node.as_raw_fd()
    }
}

impl CanBus for AgentPort {
    fn send(&self, frame: &Frame) -> std::io::Result<()> {
        if take_one(&self.refused_sends) {
            return Err(std::io::Error::from_raw_os_error(nix::errno::Errno::ENOBUFS as i32));
        }
        self.node.send(frame)
    }
    fn try_recv(&self) -> std::io::Result<Option<Frame>> {
        if take_one(&self.failed_reads) {
            return Err(std::io::Error::from_raw_os_error(nix::errno::Errno::ENETDOWN as i32));
        }
        self.node.try_recv()
    }
}

/// A CED agent serving `bus` on its own thread until dropped.
struct RunningAgent {
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<std::io::Result<()>>>,
}

impl RunningAgent {
    fn on(bus: &MemoryBus) -> Self {
        Self::with_port(AgentPort::new(bus.node().expect("node"), 0, 0))
    }

    fn with_port(port: AgentPort) -> Self {
        let agent = Agent::<CanEndpoint>::new(MiddlewareKind::Ced, canfd::core_config()).expect("CED agent");
        let server = CanServer::new(port, "memory bus", agent.core()).expect("server");
        let stop = Arc::new(AtomicBool::new(false));
        let stop2 = stop.clone();
        let thread = std::thread::spawn(move || server.run(&stop2));
        Self { stop, thread: Some(thread) }
    }
}

impl Drop for RunningAgent {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            let result = t.join().expect("agent thread");
            if !std::thread::panicking() {
                result.expect("agent ran without error");
            }
        }
    }
}

fn transport(bus: &MemoryBus, can_id: u32) -> CanTransport<BusNode> {
    CanTransport::with_socket(bus.node().expect("node"), can_id).expect("transport")
}

/// A CAN transport that tells the session another MTU (a client built with the wrong one).
struct Claimed(CanTransport<BusNode>, usize);

impl Transport for Claimed {
    fn mtu(&self) -> usize {
        self.1
    }
    fn send(&mut self, msg: &[u8]) -> Result<(), xrce_client::TransportError> {
        self.0.send(msg)
    }
    fn recv(&mut self, buf: &mut [u8], timeout_ms: i32) -> Result<Option<usize>, xrce_client::TransportError> {
        self.0.recv(buf, timeout_ms)
    }
}

#[derive(Default)]
struct Samples(Vec<Vec<u8>>);

impl Callbacks for Samples {
    fn on_topic(&mut self, _: &mut Outputs<'_, '_>, _: ObjectId, _: u16, _: StreamId, data: &[u8]) {
        self.0.push(data.to_vec());
    }
}

/// Sample `i`: every third one larger than a frame; its index first, so order and integrity show.
fn sample(i: u32) -> Vec<u8> {
    let len = if i.is_multiple_of(3) { BIG } else { 12 };
    let mut v = i.to_le_bytes().to_vec();
    v.extend((0..len).map(|k| (k as u32 * 7 + i) as u8));
    v
}

const TOPIC: &str = "<dds><topic><name>CanTopic</name><dataType>Blob</dataType></topic></dds>";
const READER: &str = "<dds><data_reader><topic><kind>NO_KEY</kind><name>CanTopic</name><dataType>Blob</dataType>\
                      </topic></data_reader></dds>";
const WRITER: &str = "<dds><data_writer><topic><kind>NO_KEY</kind><name>CanTopic</name><dataType>Blob</dataType>\
                      </topic></data_writer></dds>";

/// A subscriber (CAN id 0x101, telling its session an MTU of `sub_mtu`) and a publisher (CAN id 0x102) on
/// `bus`, each on its own thread, through an agent: the publisher writes `n` samples, each confirmed before
/// the next; returns what the subscriber got.
fn pubsub(bus: &MemoryBus, n: u32, sub_mtu: usize) -> Vec<Vec<u8>> {
    let _agent = RunningAgent::on(bus);
    // A channel, not a barrier: a subscriber that fails before it is ready must fail the test, not hang it.
    let (ready_tx, ready_rx) = mpsc::channel::<()>();
    let p = object_id(1, ObjectKind::Participant);
    let t = object_id(1, ObjectKind::Topic);
    std::thread::scope(|scope| {
        let subscriber = scope.spawn(|| {
            let (mut out_buf, mut in_buf) = ([0u8; OUT_BUF], [0u8; IN_BUF]);
            let mut sub =
                Session::new(Claimed(transport(bus, 0x101), sub_mtu), 0x0CA0_0001).with_callbacks(Samples::default());
            sub.create_session().expect("subscriber session");
            let out = sub.create_output_reliable_stream(&mut out_buf, HISTORY).expect("stream");
            let input = sub.create_input_reliable_stream(&mut in_buf, HISTORY).expect("stream");
            let (s, dr) = (object_id(1, ObjectKind::Subscriber), object_id(1, ObjectKind::DataReader));
            let reqs = [
                sub.buffer_create_participant_xml(out, p, 0, "<dds><participant/></dds>", REPLACE).expect("p"),
                sub.buffer_create_topic_xml(out, t, p, TOPIC, REPLACE).expect("t"),
                sub.buffer_create_subscriber_xml(out, s, p, "", REPLACE).expect("s"),
                sub.buffer_create_datareader_xml(out, dr, s, READER, REPLACE).expect("dr"),
            ];
            let mut status = [0u8; 4];
            assert!(sub.run_session_until_all_status(10_000, &reqs, &mut status).expect("run"), "{status:?}");
            let control = DeliveryControl { max_samples: DeliveryControl::UNLIMITED, ..Default::default() };
            sub.buffer_request_data(out, dr, input, Some(&control)).expect("read");
            assert!(sub.run_session_until_confirm_delivery(10_000).expect("run"), "READ_DATA acknowledged");
            let _ = ready_tx.send(());
            let deadline = Instant::now() + Duration::from_secs(60);
            while sub.callbacks().0.len() < n as usize && Instant::now() < deadline {
                sub.run_session_until_data(200).expect("run");
            }
            let _ = sub.delete_session_retries(2);
            std::mem::take(&mut sub.callbacks().0)
        });
        let (mut out_buf, mut in_buf) = ([0u8; OUT_BUF], [0u8; IN_BUF]);
        let mut publ = Session::new(transport(bus, 0x102), 0x0CA0_0002);
        publ.create_session().expect("publisher session");
        let out = publ.create_output_reliable_stream(&mut out_buf, HISTORY).expect("stream");
        publ.create_input_reliable_stream(&mut in_buf, HISTORY).expect("stream");
        let (pb, dw) = (object_id(1, ObjectKind::Publisher), object_id(1, ObjectKind::DataWriter));
        let reqs = [
            publ.buffer_create_participant_xml(out, p, 0, "<dds><participant/></dds>", REPLACE).expect("p"),
            publ.buffer_create_topic_xml(out, t, p, TOPIC, REPLACE).expect("t"),
            publ.buffer_create_publisher_xml(out, pb, p, "", REPLACE).expect("pub"),
            publ.buffer_create_datawriter_xml(out, dw, pb, WRITER, REPLACE).expect("dw"),
        ];
        let mut status = [0u8; 4];
        assert!(publ.run_session_until_all_status(10_000, &reqs, &mut status).expect("run"), "{status:?}");
        if ready_rx.recv_timeout(Duration::from_secs(60)).is_err() {
            // The subscriber stopped (or stalled) before it was ready: its panic is the test's failure.
            match subscriber.join() {
                Err(panic) => std::panic::resume_unwind(panic),
                Ok(_) => panic!("the subscriber never got ready"),
            }
        }
        for i in 0..n {
            publ.buffer_topic(out, dw, &sample(i)).expect("sample fits the stream");
            assert!(publ.run_session_until_confirm_delivery(10_000).expect("run"), "sample {i} acknowledged");
        }
        let got = subscriber.join().expect("subscriber thread");
        let _ = publ.delete_session_retries(2);
        got
    })
}

fn assert_all_in_order(got: &[Vec<u8>], n: u32) {
    assert_eq!(got.len(), n as usize, "every sample exactly once");
    for (i, s) in got.iter().enumerate() {
        assert_eq!(s, &sample(i as u32), "sample {i} whole and in order");
    }
}

#[test]
fn publish_and_subscribe_with_fragmented_samples() {
    let bus = MemoryBus::new();
    let got = pubsub(&bus, 12, CAN_MTU);
    assert_all_in_order(&got, 12);
    let stats = bus.stats();
    assert_eq!((stats.lost, stats.overruns), (0, 0), "{stats:?}");
    eprintln!("lossless bus: {stats:?}");
}

#[test]
fn reliable_streams_recover_when_every_fifth_frame_is_lost() {
    let bus = MemoryBus::new();
    bus.drop_every(5);
    let got = pubsub(&bus, 24, CAN_MTU);
    assert_all_in_order(&got, 24);
    let stats = bus.stats();
    assert!(stats.lost >= stats.frames / 5 - 1 && stats.lost > 20, "the bus did lose frames: {stats:?}");
    eprintln!("lossy bus: {stats:?}");
}

/// A subscriber whose session announces 508 (a client built with the UDP MTU) still gets every sample: the
/// agent never builds a message larger than a frame.
#[test]
fn a_client_announcing_a_larger_mtu_is_answered_in_frames() {
    let bus = MemoryBus::new();
    assert_all_in_order(&pubsub(&bus, 6, 512), 6);
}

/// Records every frame of the bus: (CAN id, XRCE session id of the message).
fn sniff(node: &BusNode) -> Vec<(u32, u8)> {
    let mut seen = Vec::new();
    while let Some(frame) = node.try_recv().expect("sniffer") {
        if let (Some(id), Ok(msg)) = (frame.id(), frame.message()) {
            seen.push((id, msg.first().copied().unwrap_or(0)));
        }
    }
    seen
}

#[test]
fn two_clients_with_different_ids_are_answered_each_on_its_own() {
    let bus = MemoryBus::new();
    let sniffer = bus.node().expect("node");
    let _agent = RunningAgent::on(&bus);
    // Different session ids, so a reply on the wrong identifier would be refused by the client it reached.
    let clients = [(0x0000_0100u32, 0x81u8, 0x0CA0_0010u32), (0x1ABC_DEF0, 0x82, 0x0CA0_0020)];
    let mut sessions: Vec<_> = clients
        .iter()
        .map(|&(id, session, key)| Session::new(transport(&bus, id), key).with_session_id(session))
        .collect();
    for s in &mut sessions {
        s.create_session().expect("session");
    }
    // Interleaved: each pings the agent in its session and gets its own answer.
    for _ in 0..3 {
        for s in &mut sessions {
            assert!(s.ping_agent_session(1000, 3).expect("ping"), "answered");
        }
    }
    let seen = sniff(&sniffer);
    let mut ids_of_session: BTreeMap<u8, BTreeSet<u32>> = BTreeMap::new();
    for &(id, session) in &seen {
        ids_of_session.entry(session).or_default().insert(id);
    }
    let mut expected: BTreeMap<u8, BTreeSet<u32>> =
        clients.iter().map(|&(id, session, _)| (session, BTreeSet::from([id]))).collect();
    // CREATE_CLIENT and its STATUS_AGENT travel with session id 0x80, whatever the session.
    expected.insert(0x80, clients.iter().map(|&(id, _, _)| id).collect());
    assert_eq!(ids_of_session, expected, "each session's traffic, both ways, on its client's identifier only");
    // Both directions: a request and an answer per ping at least, and the CREATE_CLIENT exchange.
    for &(id, _, _) in &clients {
        assert!(seen.iter().filter(|(i, _)| *i == id).count() >= 8, "{seen:?}");
    }
    for s in &mut sessions {
        let _ = s.delete_session_retries(2);
    }
}

#[test]
fn frames_no_client_sends_are_ignored() {
    let bus = MemoryBus::new();
    let _agent = RunningAgent::on(&bus);
    let noise = bus.node().expect("node");
    let mut bad_length = [0u8; 64];
    bad_length[0] = 64;
    let mut junk = Frame::with_message(0x55, &[0xFF; 63]).expect("frame");
    junk.len = 64;
    for frame in [
        Frame::from_parts(0x123, &[4, 0x80, 0, 0, 0]),      // standard id
        Frame::from_parts(0x8000_0077, &[]),                // no length byte
        Frame::from_parts(0x8000_0077, &bad_length),        // length above 63
        junk,                                               // not XRCE
        Frame::with_message(0x77, &[0x81]).expect("frame"), // a message cut short
    ] {
        noise.send(&frame).expect("send");
    }
    let mut client = Session::new(transport(&bus, 0x77), 0x0CA0_0030);
    client.create_session().expect("the agent still serves clients");
    assert!(client.ping_agent_session(1000, 3).expect("ping"));
}

#[test]
fn ping_agent_out_of_session() {
    let bus = MemoryBus::new();
    let _agent = RunningAgent::on(&bus);
    // GET_INFO without a session: the INFO answer must fit one frame too.
    assert!(ping_agent_attempts(&mut transport(&bus, 0x79), 1000, 3).expect("ping"), "the agent answers");
}

#[test]
fn a_receive_error_does_not_stop_the_agent() {
    let bus = MemoryBus::new();
    let _agent = RunningAgent::with_port(AgentPort::new(bus.node().expect("node"), 3, 0));
    let mut client = Session::new(transport(&bus, 0x78), 0x0CA0_0040);
    client.create_session().expect("the agent read past the errors");
    for _ in 0..3 {
        assert!(client.ping_agent_session(1000, 3).expect("ping"));
    }
}

/// 2000 refusals at 100 µs apiece outlast several turns' retry budgets: frames wait, in order, none lost.
#[test]
fn frames_the_interface_refuses_wait_for_it() {
    let bus = MemoryBus::new();
    let _agent = RunningAgent::with_port(AgentPort::new(bus.node().expect("node"), 0, 2000));
    let mut client = Session::new(transport(&bus, 0x7A), 0x0CA0_0050);
    client.create_session().expect("the STATUS_AGENT went out once the interface took it");
    for _ in 0..3 {
        assert!(client.ping_agent_session(1000, 3).expect("ping"));
    }
    assert_eq!(bus.stats().lost, 0);
}

#[test]
fn the_command_line_opens_the_interface() {
    match AgentInstance::create(["xrce-agent", "canfd", "-D", "xrcenocan0", "-I", "0x1ABC", "-m", "ced", "-v", "0"]) {
        Err(AgentError::Open { what, .. }) => assert_eq!(what, "CAN interface xrcenocan0"),
        other => panic!("expected an open error for a missing interface, got {other:?}"),
    }
}
