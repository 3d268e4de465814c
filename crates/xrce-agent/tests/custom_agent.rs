//! Custom agent transports (eProsima's `CustomAgent`, seed 004) against our client's custom transport
//! (`CustomTransport` over `CustomIo`): over an in-memory medium with one link per client, in packet and
//! stream (framed) mode, and over pseudoterminals in both modes. Each carries a publisher and a subscriber through
//! the agent (`-m ced`) on reliable streams, with a sample several times the MTU (FRAGMENTs both ways).
//! Two clients on two endpoints at once must each get their own answers, and the agent must survive a
//! failed `read`, a failed `open` and a restart.

use std::collections::HashMap;
use std::fs::File;
use std::io::{self, Read, Write};
use std::os::fd::AsFd;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::mpsc::{channel, Receiver, RecvTimeoutError, Sender};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use xrce_agent::custom_agent::CustomAgent;
use xrce_agent::middleware::callbacks::CallbackKind;
use xrce_agent::middleware::MiddlewareKind;
use xrce_agent::transport::custom::{CustomAgentError, CustomAgentIo, CustomCallbacks, Endpoint, EndpointDesc, Mode};
use xrce_client::prelude::*;
use xrce_client::TransportError;

const MTU: usize = 512;
const HISTORY: usize = 8;
const BUF: usize = MTU * HISTORY;
/// Six times the MTU: travels as FRAGMENTs to the agent and from it.
const BIG: usize = 3000;

fn io_error(e: impl std::error::Error + Send + Sync + 'static) -> io::Error {
    io::Error::other(e)
}

/// The agent's side of an in-memory medium: every client has a link (a number and a peer name, the
/// endpoint's two members); what clients write arrives on one queue, tagged with the link.
struct Hub {
    inbound: Mutex<Inbound>,
    to_hub: Sender<(u32, Vec<u8>)>,
    links: Mutex<HashMap<u32, Sender<Vec<u8>>>>,
    /// Messages (or stream chunks) written per link.
    written: Mutex<HashMap<u32, usize>>,
    /// The next `read` fails (a medium error: the agent must reopen).
    fail_next_read: AtomicBool,
    opens: AtomicUsize,
    closes: AtomicUsize,
    refuse_open: AtomicBool,
}

/// What clients wrote, and the rest of a chunk a stream-mode `read` took part of.
struct Inbound {
    rx: Receiver<(u32, Vec<u8>)>,
    pending: Vec<u8>,
    link: u32,
}

fn peer_name(link: u32) -> String {
    format!("client-{link}")
}

fn hub_endpoint() -> EndpointDesc {
    EndpointDesc::new().member_u32("link").member_string("peer")
}

impl Hub {
    fn new() -> Arc<Self> {
        let (to_hub, inbound) = channel();
        Arc::new(Self {
            inbound: Mutex::new(Inbound { rx: inbound, pending: Vec::new(), link: 0 }),
            to_hub,
            links: Mutex::new(HashMap::new()),
            written: Mutex::new(HashMap::new()),
            fail_next_read: AtomicBool::new(false),
            opens: AtomicUsize::new(0),
            closes: AtomicUsize::new(0),
            refuse_open: AtomicBool::new(false),
        })
    }

    /// A client's end of link `link`.
    fn connect(&self, link: u32) -> LinkEnd {
        let (tx, rx) = channel();
        self.links.lock().unwrap().insert(link, tx);
        LinkEnd { link, tx: self.to_hub.clone(), rx, pending: Vec::new() }
    }

    fn written_to(&self, link: u32) -> usize {
        self.written.lock().unwrap().get(&link).copied().unwrap_or(0)
    }
}

impl CustomAgentIo for Hub {
    fn open(&self) -> io::Result<()> {
        self.opens.fetch_add(1, Ordering::SeqCst);
        if self.refuse_open.load(Ordering::SeqCst) {
            return Err(io::Error::new(io::ErrorKind::NotFound, "no such medium"));
        }
        Ok(())
    }

    fn close(&self) -> io::Result<()> {
        self.closes.fetch_add(1, Ordering::SeqCst);
        Ok(())
    }

    fn write(&self, to: &Endpoint, bytes: &[u8]) -> io::Result<usize> {
        let link = to.get::<u32>("link").map_err(io_error)?;
        // Both members come back as `read` set them.
        if to.get_str("peer").map_err(io_error)? != peer_name(link) {
            return Err(io::Error::other("endpoint members mixed up"));
        }
        let links = self.links.lock().unwrap();
        let tx = links.get(&link).ok_or_else(|| io::Error::other(format!("no link {link}")))?;
        // Counted first: the client may act on the message before `send` returns.
        *self.written.lock().unwrap().entry(link).or_default() += 1;
        tx.send(bytes.to_vec()).map_err(io_error)?;
        Ok(bytes.len())
    }

    /// Hands out what the clients wrote, in pieces no larger than `buf` (a stream-mode read may take part
    /// of a chunk; a packet-mode one always fits).
    fn read(&self, from: &mut Endpoint, buf: &mut [u8], timeout: Duration) -> io::Result<usize> {
        if self.fail_next_read.swap(false, Ordering::SeqCst) {
            return Err(io::Error::new(io::ErrorKind::ConnectionReset, "medium reset"));
        }
        let mut guard = self.inbound.lock().unwrap();
        let Inbound { rx, pending, link } = &mut *guard;
        if pending.is_empty() {
            match rx.recv_timeout(timeout) {
                Ok((l, bytes)) => {
                    *link = l;
                    *pending = bytes;
                }
                Err(RecvTimeoutError::Timeout) => return Ok(0),
                Err(e) => return Err(io_error(e)),
            }
        }
        let n = pending.len().min(buf.len());
        buf[..n].copy_from_slice(&pending[..n]);
        pending.drain(..n);
        from.set("link", *link).map_err(io_error)?;
        from.set_str("peer", &peer_name(*link)).map_err(io_error)?;
        Ok(n)
    }
}

/// A client's end of a hub link.
struct LinkEnd {
    link: u32,
    tx: Sender<(u32, Vec<u8>)>,
    rx: Receiver<Vec<u8>>,
    pending: Vec<u8>,
}

impl CustomIo for LinkEnd {
    fn write(&mut self, buf: &[u8]) -> Result<usize, TransportError> {
        self.tx.send((self.link, buf.to_vec())).map_err(|_| TransportError::Closed)?;
        Ok(buf.len())
    }

    fn read(&mut self, buf: &mut [u8], timeout_ms: i32) -> Result<usize, TransportError> {
        if self.pending.is_empty() {
            let timeout = Duration::from_millis(u64::try_from(timeout_ms.max(1)).unwrap_or(1));
            match self.rx.recv_timeout(timeout) {
                Ok(bytes) => self.pending = bytes,
                Err(_) => return Ok(0),
            }
        }
        let n = self.pending.len().min(buf.len());
        buf[..n].copy_from_slice(&self.pending[..n]);
        self.pending.drain(..n);
        Ok(n)
    }
}

#[derive(Default)]
struct Samples(Vec<Vec<u8>>);

impl Callbacks for Samples {
    fn on_topic(&mut self, _: &mut Outputs<'_, '_>, _: ObjectId, _: u16, _: StreamId, data: &[u8]) {
        self.0.push(data.to_vec());
    }
}

fn blob(name: &str, kind: &str) -> String {
    format!(
        "<dds><{kind}><topic><kind>NO_KEY</kind><name>{name}</name><dataType>Blob</dataType></topic></{kind}></dds>"
    )
}

/// A subscriber session on `sub_io` and a publisher session on `pub_io`, both through the agent: the
/// publisher writes a small and a fragmented sample on `topic`, the subscriber must get both, whole and in
/// order.
fn pubsub_through<IO: CustomIo>(sub_io: IO, pub_io: IO, framing: bool, keys: (u32, u32), topic: &str) {
    let p = object_id(1, ObjectKind::Participant);
    let t = object_id(1, ObjectKind::Topic);
    let topic_xml = format!("<dds><topic><name>{topic}</name><dataType>Blob</dataType></topic></dds>");

    let (mut sub_out, mut sub_in) = ([0u8; BUF], [0u8; BUF * 2]);
    let transport = CustomTransport::<_, MTU>::new(sub_io, framing).expect("subscriber transport opens");
    let mut sub = Session::new(transport, keys.0).with_callbacks(Samples::default());
    sub.create_session().expect("subscriber session");
    let out = sub.create_output_reliable_stream(&mut sub_out, HISTORY).expect("stream");
    let input = sub.create_input_reliable_stream(&mut sub_in, HISTORY * 2).expect("stream");
    let (s, dr) = (object_id(1, ObjectKind::Subscriber), object_id(1, ObjectKind::DataReader));
    let reqs = [
        sub.buffer_create_participant_xml(out, p, 0, "<dds><participant/></dds>", REPLACE).expect("p"),
        sub.buffer_create_topic_xml(out, t, p, &topic_xml, REPLACE).expect("t"),
        sub.buffer_create_subscriber_xml(out, s, p, "", REPLACE).expect("s"),
        sub.buffer_create_datareader_xml(out, dr, s, &blob(topic, "data_reader"), REPLACE).expect("dr"),
    ];
    let mut status = [0u8; 4];
    assert!(sub.run_session_until_all_status(3000, &reqs, &mut status).expect("run"), "{status:?}");
    let control = DeliveryControl { max_samples: DeliveryControl::UNLIMITED, ..Default::default() };
    sub.buffer_request_data(out, dr, input, Some(&control)).expect("read");
    sub.run_session_time(100).expect("run");

    let (mut pub_out, mut pub_in) = ([0u8; BUF], [0u8; BUF]);
    let transport = CustomTransport::<_, MTU>::new(pub_io, framing).expect("publisher transport opens");
    let mut publ = Session::new(transport, keys.1);
    publ.create_session().expect("publisher session");
    let out = publ.create_output_reliable_stream(&mut pub_out, HISTORY).expect("stream");
    publ.create_input_reliable_stream(&mut pub_in, HISTORY).expect("stream");
    let (pb, dw) = (object_id(1, ObjectKind::Publisher), object_id(1, ObjectKind::DataWriter));
    let reqs = [
        publ.buffer_create_participant_xml(out, p, 0, "<dds><participant/></dds>", REPLACE).expect("p"),
        publ.buffer_create_topic_xml(out, t, p, &topic_xml, REPLACE).expect("t"),
        publ.buffer_create_publisher_xml(out, pb, p, "", REPLACE).expect("pub"),
        publ.buffer_create_datawriter_xml(out, dw, pb, &blob(topic, "data_writer"), REPLACE).expect("dw"),
    ];
    assert!(publ.run_session_until_all_status(3000, &reqs, &mut status).expect("run"), "{status:?}");
    let small = vec![7u8; 16];
    let big: Vec<u8> = (0..BIG).map(|i| (i % 251) as u8).collect();
    publ.buffer_topic(out, dw, &small).expect("small sample");
    publ.buffer_topic(out, dw, &big).expect("fragmented sample");
    assert!(publ.run_session_until_confirm_delivery(3000).expect("run"), "the agent acknowledged both");

    let t0 = Instant::now();
    while sub.callbacks().0.len() < 2 && t0.elapsed() < Duration::from_secs(5) {
        sub.run_session_until_data(200).expect("run");
    }
    assert_eq!(sub.callbacks().0, vec![small, big], "both samples, whole and in order");
    let _ = publ.delete_session();
    let _ = sub.delete_session();
}

fn hub_agent(hub: &Arc<Hub>, mode: Mode) -> CustomAgent {
    let mut agent =
        CustomAgent::new("hub", hub_endpoint(), MiddlewareKind::Ced, mode, hub.clone()).expect("custom agent");
    agent.start().expect("starts");
    agent
}

fn pubsub_over_the_hub(mode: Mode) {
    let hub = Hub::new();
    let mut agent = hub_agent(&hub, mode);
    // The agent API of the built-in servers works here too.
    let writers = Arc::new(AtomicUsize::new(0));
    let seen = writers.clone();
    agent.agent().add_middleware_callback(CallbackKind::CreateDataWriter, move |_, _| {
        seen.fetch_add(1, Ordering::SeqCst);
    });
    pubsub_through(hub.connect(1), hub.connect(2), mode == Mode::Stream, (0x0D01_0001, 0x0D01_0002), "HubTopic");
    assert_eq!(writers.load(Ordering::SeqCst), 1, "the middleware callback fired");
    assert!(hub.written_to(1) > 0 && hub.written_to(2) > 0, "both links answered");
    agent.stop().expect("stops");
    assert_eq!((hub.opens.load(Ordering::SeqCst), hub.closes.load(Ordering::SeqCst)), (1, 1));
}

#[test]
fn packet_mode_over_an_in_memory_medium() {
    pubsub_over_the_hub(Mode::Packet);
}

#[test]
fn stream_mode_over_an_in_memory_medium() {
    pubsub_over_the_hub(Mode::Stream);
}

/// Two clients with the same session id on two links, at once and in stream mode (their byte runs
/// interleave on the agent's single `read`): each creates entities and publishes, and each must get its
/// own STATUS replies and acknowledgements. Answers sent to the wrong link would leave a client waiting,
/// and a link that saw the other's messages would fail its `write` (its `peer` member must match).
#[test]
fn two_clients_on_two_endpoints_are_answered_apart() {
    let hub = Hub::new();
    let mut agent = hub_agent(&hub, Mode::Stream);
    let clients: Vec<_> = [(1u32, 0x0D02_0001u32), (2, 0x0D02_0002)]
        .into_iter()
        .map(|(link, key)| {
            let io = hub.connect(link);
            std::thread::spawn(move || {
                let (mut out_buf, mut in_buf) = ([0u8; BUF], [0u8; BUF]);
                let transport = CustomTransport::<_, MTU>::new(io, true).expect("transport");
                let mut s = Session::new(transport, key);
                s.create_session().expect("session");
                let out = s.create_output_reliable_stream(&mut out_buf, HISTORY).expect("stream");
                s.create_input_reliable_stream(&mut in_buf, HISTORY).expect("stream");
                let p = object_id(1, ObjectKind::Participant);
                let t = object_id(1, ObjectKind::Topic);
                let (pb, dw) = (object_id(1, ObjectKind::Publisher), object_id(1, ObjectKind::DataWriter));
                let topic = format!("Apart{link}");
                let topic_xml = format!("<dds><topic><name>{topic}</name><dataType>Blob</dataType></topic></dds>");
                let mut status = [0u8; 4];
                for round in 0..5 {
                    let reqs = [
                        s.buffer_create_participant_xml(out, p, 0, "<dds><participant/></dds>", REPLACE).unwrap(),
                        s.buffer_create_topic_xml(out, t, p, &topic_xml, REPLACE).unwrap(),
                        s.buffer_create_publisher_xml(out, pb, p, "", REPLACE).unwrap(),
                        s.buffer_create_datawriter_xml(out, dw, pb, &blob(&topic, "data_writer"), REPLACE).unwrap(),
                    ];
                    assert!(
                        s.run_session_until_all_status(3000, &reqs, &mut status).unwrap(),
                        "link {link} round {round}: {status:?}"
                    );
                    assert_eq!(status, [0; 4], "link {link} round {round}: all OK");
                    let big = vec![link as u8; BIG];
                    s.buffer_topic(out, dw, &big).unwrap();
                    assert!(s.run_session_until_confirm_delivery(3000).unwrap(), "link {link} round {round} acked");
                }
                let _ = s.delete_session();
            })
        })
        .collect();
    for c in clients {
        c.join().expect("client passed");
    }
    assert!(hub.written_to(1) > 0 && hub.written_to(2) > 0);
    assert_eq!(hub.written.lock().unwrap().len(), 2, "nothing written to any other link");
    agent.stop().expect("stops");
}

/// A failed `read` makes the agent close and reopen the transport (eProsima's `handle_error`), and it serves
/// on; a failed `open` is an error from `start`; a stopped agent starts again and keeps its clients.
#[test]
fn reopen_on_read_error_open_failure_and_restart() {
    let hub = Hub::new();
    hub.refuse_open.store(true, Ordering::SeqCst);
    let mut agent = CustomAgent::new("hub", hub_endpoint(), MiddlewareKind::Ced, false, hub.clone()).unwrap();
    let err = agent.start().expect_err("open refused");
    assert!(matches!(err, CustomAgentError::Open { .. }), "{err}");
    assert!(err.to_string().contains("no such medium"), "{err}");
    assert!(!agent.is_running());
    hub.refuse_open.store(false, Ordering::SeqCst);

    agent.start().expect("starts");
    assert!(matches!(agent.start(), Err(CustomAgentError::AlreadyRunning(_))));
    let (mut out_buf, mut in_buf) = ([0u8; BUF], [0u8; BUF]);
    let transport = CustomTransport::<_, MTU>::new(hub.connect(1), false).unwrap();
    let mut s = Session::new(transport, 0x0D03_0001);
    s.create_session().expect("session");
    let out = s.create_output_reliable_stream(&mut out_buf, HISTORY).unwrap();
    s.create_input_reliable_stream(&mut in_buf, HISTORY).unwrap();
    fn create<T: Transport>(s: &mut Session<'_, T, StdClock>, out: StreamId, what: &str) {
        let p = object_id(1, ObjectKind::Participant);
        let req = s.buffer_create_participant_xml(out, p, 0, "<dds><participant/></dds>", REPLACE).unwrap();
        let mut status = [0xFFu8];
        assert!(s.run_session_until_all_status(3000, &[req], &mut status).unwrap(), "{what}");
        assert_eq!(status, [0], "{what}");
    }
    create(&mut s, out, "first");

    hub.fail_next_read.store(true, Ordering::SeqCst);
    let deadline = Instant::now() + Duration::from_secs(5);
    while hub.opens.load(Ordering::SeqCst) < 3 && Instant::now() < deadline {
        std::thread::sleep(Duration::from_millis(10));
    }
    assert_eq!(hub.opens.load(Ordering::SeqCst), 3, "refused, started, reopened");
    assert_eq!(hub.closes.load(Ordering::SeqCst), 1, "closed before reopening");
    create(&mut s, out, "after the reopen");

    agent.stop().expect("stops");
    assert!(!agent.is_running());
    agent.start().expect("starts again");
    // A new client speaks first after the restart: it must not take over the first client's endpoint.
    let (mut out2, mut in2) = ([0u8; BUF], [0u8; BUF]);
    let mut s2 = Session::new(CustomTransport::<_, MTU>::new(hub.connect(2), false).unwrap(), 0x0D03_0002);
    s2.create_session().expect("second session");
    let out_2 = s2.create_output_reliable_stream(&mut out2, HISTORY).unwrap();
    s2.create_input_reliable_stream(&mut in2, HISTORY).unwrap();
    create(&mut s2, out_2, "second client after the restart");
    // Same session, no new CREATE_CLIENT: the agent kept the first client and its endpoint across the restart.
    create(&mut s, out, "after the restart");
    create(&mut s2, out_2, "second client again");
    drop(agent);
    assert_eq!(hub.closes.load(Ordering::SeqCst), 3, "closed by stop and by drop");
}

/// eProsima's callback style: the four operations as closures, over the same medium.
#[test]
fn closures_serve_like_a_trait() {
    let hub = Hub::new();
    let (h_write, h_read) = (hub.clone(), hub.clone());
    let callbacks = CustomCallbacks::new(
        || Ok(()),
        || Ok(()),
        move |to, bytes| h_write.write(to, bytes),
        move |from, buf, timeout| h_read.read(from, buf, timeout),
    );
    let mut agent = CustomAgent::new("closures", hub_endpoint(), MiddlewareKind::Ced, true, callbacks).unwrap();
    agent.start().unwrap();
    let transport = CustomTransport::<_, MTU>::new(hub.connect(7), true).unwrap();
    let mut s = Session::new(transport, 0x0D04_0001);
    s.create_session().expect("session over closures");
    assert!(hub.written_to(7) > 0);
    agent.stop().unwrap();
}

/// A `read` that leaves a member unset, or sets one of the wrong type, loses that message (logged) and
/// the agent goes on.
#[test]
fn an_incomplete_endpoint_drops_the_message_not_the_agent() {
    let hub = Hub::new();
    let first = Arc::new(AtomicUsize::new(0));
    let (h_write, h_read, count) = (hub.clone(), hub.clone(), first.clone());
    let callbacks = CustomCallbacks::new(
        || Ok(()),
        || Ok(()),
        move |to, bytes| h_write.write(to, bytes),
        move |from: &mut Endpoint, buf: &mut [u8], timeout| {
            let n = h_read.read(from, buf, timeout)?;
            if n > 0 && count.fetch_add(1, Ordering::SeqCst) < 2 {
                // The first two messages come back with `peer` unset (and a wrong-typed set refused).
                assert!(from.set("peer", 1u32).is_err());
                let link = from.get::<u32>("link").map_err(io_error)?;
                from.reset();
                from.set("link", link).map_err(io_error)?;
            }
            Ok(n)
        },
    );
    let mut agent = CustomAgent::new("incomplete", hub_endpoint(), MiddlewareKind::Ced, false, callbacks).unwrap();
    agent.start().unwrap();
    let transport = CustomTransport::<_, MTU>::new(hub.connect(3), false).unwrap();
    let mut s = Session::new(transport, 0x0D05_0001);
    s.create_session_retries(10).expect("a later attempt is answered");
    assert!(first.load(Ordering::SeqCst) > 2);
    agent.stop().unwrap();
}

/// The agent API reaches a custom agent's core: a refs file loaded through it (eProsima requires it before
/// `start`; here either order works) serves its clients' creations by reference.
#[test]
fn refs_loaded_through_the_agent_api_serve_creation_by_reference() {
    let refs = std::env::temp_dir().join(format!("custom_agent_refs_{}.xml", std::process::id()));
    std::fs::write(
        &refs,
        "<dds><profiles>\
           <participant profile_name=\"custom_participant\"><rtps><name>custom</name></rtps></participant>\
           <topic profile_name=\"custom_topic\"><name>RefTopic</name><dataType>Blob</dataType></topic>\
         </profiles></dds>",
    )
    .unwrap();
    let hub = Hub::new();
    let mut agent = CustomAgent::new("refs", hub_endpoint(), MiddlewareKind::Ced, true, hub.clone()).unwrap();
    agent.agent().set_verbose_level(0);
    assert_eq!(agent.agent().load_config_file(&refs).expect("refs load"), 2);
    std::fs::remove_file(&refs).ok();
    agent.start().unwrap();

    let (mut out_buf, mut in_buf) = ([0u8; BUF], [0u8; BUF]);
    let transport = CustomTransport::<_, MTU>::new(hub.connect(4), true).unwrap();
    let mut s = Session::new(transport, 0x0D09_0001);
    s.create_session().unwrap();
    let out = s.create_output_reliable_stream(&mut out_buf, HISTORY).unwrap();
    s.create_input_reliable_stream(&mut in_buf, HISTORY).unwrap();
    let p = object_id(1, ObjectKind::Participant);
    let reqs = [
        s.buffer_create_participant_ref(out, p, 0, "custom_participant", REPLACE).unwrap(),
        s.buffer_create_topic_ref(out, object_id(1, ObjectKind::Topic), p, "custom_topic", REPLACE).unwrap(),
    ];
    let mut status = [0xFFu8; 2];
    assert!(s.run_session_until_all_status(3000, &reqs, &mut status).unwrap());
    assert_eq!(status, [0, 0]);
    agent.stop().unwrap();
}

/// A duplicate member name is refused when the agent is built.
#[test]
fn a_duplicate_member_is_refused() {
    let desc = EndpointDesc::new().member_u32("ip").member_u16("ip");
    let err = CustomAgent::new("dup", desc, MiddlewareKind::Ced, false, Hub::new()).expect_err("refused");
    assert_eq!(err.to_string(), "custom transport `dup`: endpoint member `ip` is declared twice");
}

/// Stream mode over pseudoterminals: the agent's transport owns the master sides (endpoint member `line`),
/// each client opens a slave side in raw mode.
struct PtyAgentIo {
    masters: Vec<File>,
}

/// The first pty master with bytes to read within `timeout`, if any.
fn readable_line(masters: &[File], timeout: Duration) -> io::Result<Option<usize>> {
    use nix::poll::{poll, PollFd, PollFlags, PollTimeout};
    let mut fds: Vec<PollFd<'_>> = masters.iter().map(|m| PollFd::new(m.as_fd(), PollFlags::POLLIN)).collect();
    let ms = u16::try_from(timeout.as_millis()).unwrap_or(u16::MAX);
    if poll(&mut fds, PollTimeout::from(ms)).map_err(io::Error::from)? == 0 {
        return Ok(None);
    }
    Ok(fds.iter().position(|f| f.revents().is_some_and(|r| r.contains(PollFlags::POLLIN))))
}

impl CustomAgentIo for PtyAgentIo {
    fn write(&self, to: &Endpoint, bytes: &[u8]) -> io::Result<usize> {
        let line = to.get::<u8>("line").map_err(io_error)?;
        let mut master = self.masters.get(usize::from(line)).ok_or_else(|| io::Error::other("no such line"))?;
        master.write(bytes)
    }

    fn read(&self, from: &mut Endpoint, buf: &mut [u8], timeout: Duration) -> io::Result<usize> {
        let Some(line) = readable_line(&self.masters, timeout)? else { return Ok(0) };
        from.set("line", u8::try_from(line).map_err(io_error)?).map_err(io_error)?;
        let mut master = &self.masters[line];
        master.read(buf)
    }
}

/// A client on a pseudoterminal's slave side.
struct PtyClientIo {
    slave: File,
}

impl CustomIo for PtyClientIo {
    fn write(&mut self, buf: &[u8]) -> Result<usize, TransportError> {
        self.slave.write(buf).map_err(|_| TransportError::Custom(1))
    }

    fn read(&mut self, buf: &mut [u8], timeout_ms: i32) -> Result<usize, TransportError> {
        use nix::poll::{poll, PollFd, PollFlags, PollTimeout};
        let ms = u16::try_from(timeout_ms.clamp(1, 1000)).unwrap_or(1000);
        let mut fds = [PollFd::new(self.slave.as_fd(), PollFlags::POLLIN)];
        match poll(&mut fds, PollTimeout::from(ms)) {
            Ok(n) if n > 0 => self.slave.read(buf).map_err(|_| TransportError::Custom(2)),
            _ => Ok(0),
        }
    }
}

#[test]
fn stream_mode_over_pseudoterminals() {
    let (masters, slaves) = raw_ptys(2);
    let mut clients: Vec<PtyClientIo> = slaves.into_iter().map(|slave| PtyClientIo { slave }).collect();
    let desc = EndpointDesc::new().member_u8("line");
    let mut agent =
        CustomAgent::new("pty", desc, MiddlewareKind::Ced, Mode::Stream, PtyAgentIo { masters }).expect("agent");
    agent.start().expect("starts");
    let publ = clients.pop().unwrap();
    let sub = clients.pop().unwrap();
    pubsub_through(sub, publ, true, (0x0D06_0001, 0x0D06_0002), "PtyTopic");
    agent.stop().expect("stops");
}

/// Raw pseudoterminals for `n` clients: the agent gets the masters, each client a slave.
fn raw_ptys(n: usize) -> (Vec<File>, Vec<File>) {
    use nix::sys::termios::{cfmakeraw, tcgetattr, tcsetattr, SetArg};
    let (mut masters, mut slaves) = (Vec::new(), Vec::new());
    for _ in 0..n {
        let pty = nix::pty::openpty(None, None).expect("pty");
        // Raw: no echo, no line discipline touching the messages' bytes.
        let mut t = tcgetattr(&pty.slave).expect("termios");
        cfmakeraw(&mut t);
        tcsetattr(&pty.slave, SetArg::TCSANOW, &t).expect("raw");
        masters.push(File::from(pty.master));
        slaves.push(File::from(pty.slave));
    }
    (masters, slaves)
}

/// Packet mode over pseudoterminals. A pty is a byte stream (two writes may come out of one read, a long
/// one in pieces), so the test's I/O on both sides delimits each message with a 2-byte little-endian length,
/// as a medium that keeps packet boundaries would (a radio, a CAN-like bus): every `read` hands the agent
/// and the client exactly one message, every `write` sends one, and the XRCE bytes are never framed.
/// The endpoint has three members of the three other integer sizes: the line (`u8`), a port (`u16`) and
/// a board id (`u64`), all checked when the agent hands them back to `write`.
struct PtyPacketAgentIo {
    masters: Vec<File>,
}

fn line_port(line: u8) -> u16 {
    7000 + u16::from(line)
}

fn line_board(line: u8) -> u64 {
    0xB0A2_D000_0000_0000 | u64::from(line)
}

/// Writes one message with its length in front, in one `write` where the pty takes it.
fn write_packet(mut to: &File, bytes: &[u8]) -> io::Result<usize> {
    let len = u16::try_from(bytes.len()).map_err(io_error)?;
    let mut packet = len.to_le_bytes().to_vec();
    packet.extend_from_slice(bytes);
    to.write_all(&packet)?;
    Ok(bytes.len())
}

/// Reads one length-delimited message into `buf` (the writer sent it whole, so it is all there soon).
fn read_packet(mut from: &File, buf: &mut [u8]) -> io::Result<usize> {
    let mut len = [0u8; 2];
    from.read_exact(&mut len)?;
    let len = usize::from(u16::from_le_bytes(len));
    let into = buf.get_mut(..len).ok_or_else(|| io::Error::other(format!("a {len}-byte message")))?;
    from.read_exact(into)?;
    Ok(len)
}

impl CustomAgentIo for PtyPacketAgentIo {
    fn write(&self, to: &Endpoint, bytes: &[u8]) -> io::Result<usize> {
        let line = to.get::<u8>("line").map_err(io_error)?;
        // The members come back as `read` set them.
        if to.get::<u16>("port").map_err(io_error)? != line_port(line)
            || to.get::<u64>("board").map_err(io_error)? != line_board(line)
        {
            return Err(io::Error::other("endpoint members mixed up"));
        }
        write_packet(self.masters.get(usize::from(line)).ok_or_else(|| io::Error::other("no such line"))?, bytes)
    }

    fn read(&self, from: &mut Endpoint, buf: &mut [u8], timeout: Duration) -> io::Result<usize> {
        let Some(index) = readable_line(&self.masters, timeout)? else { return Ok(0) };
        let line = u8::try_from(index).map_err(io_error)?;
        from.set("line", line).map_err(io_error)?;
        from.set("port", line_port(line)).map_err(io_error)?;
        from.set("board", line_board(line)).map_err(io_error)?;
        read_packet(&self.masters[index], buf)
    }
}

/// A packet-mode client on a pseudoterminal's slave side (see [`PtyPacketAgentIo`]).
struct PtyPacketClientIo {
    slave: File,
}

impl CustomIo for PtyPacketClientIo {
    fn write(&mut self, buf: &[u8]) -> Result<usize, TransportError> {
        write_packet(&self.slave, buf).map_err(|_| TransportError::Custom(1))
    }

    fn read(&mut self, buf: &mut [u8], timeout_ms: i32) -> Result<usize, TransportError> {
        use nix::poll::{poll, PollFd, PollFlags, PollTimeout};
        let ms = u16::try_from(timeout_ms.clamp(1, 1000)).unwrap_or(1000);
        let mut fds = [PollFd::new(self.slave.as_fd(), PollFlags::POLLIN)];
        match poll(&mut fds, PollTimeout::from(ms)) {
            Ok(n) if n > 0 => read_packet(&self.slave, buf).map_err(|_| TransportError::Custom(2)),
            _ => Ok(0),
        }
    }
}

/// Packet mode over pseudoterminals, a publisher and a subscriber with a fragmented sample (each FRAGMENT
/// its own packet), through endpoints of `u8`, `u16` and `u64` members.
#[test]
fn packet_mode_over_pseudoterminals() {
    let (masters, mut slaves) = raw_ptys(2);
    let desc = EndpointDesc::new().member_u8("line").member_u16("port").member_u64("board");
    let mut agent =
        CustomAgent::new("pty-packets", desc, MiddlewareKind::Ced, Mode::Packet, PtyPacketAgentIo { masters })
            .expect("agent");
    agent.start().expect("starts");
    let publ = PtyPacketClientIo { slave: slaves.pop().unwrap() };
    let sub = PtyPacketClientIo { slave: slaves.pop().unwrap() };
    pubsub_through(sub, publ, false, (0x0D07_0001, 0x0D07_0002), "PtyPacketTopic");
    agent.stop().expect("stops");
}

/// Round trips (a session ping: GET_INFO and its INFO) through the agent over `io`: median and 99th
/// percentile. A measurement, not a check: `cargo test --release -p xrce-agent --test custom_agent --
/// --ignored --nocapture round_trip`.
fn round_trip<IO: CustomIo>(io: IO, framing: bool, count: usize) -> (Duration, Duration) {
    let transport = CustomTransport::<_, MTU>::new(io, framing).unwrap();
    let mut s = Session::new(transport, 0x0D07_0001);
    s.create_session().unwrap();
    let mut times: Vec<Duration> = (0..count)
        .map(|_| {
            let started = Instant::now();
            assert!(s.ping_agent_session(1000, 1).unwrap(), "answered");
            started.elapsed()
        })
        .collect();
    times.sort();
    let _ = s.delete_session();
    (times[count / 2], times[count * 99 / 100])
}

/// Samples per second from a publisher to a subscriber through the agent (reliable streams), over `ios`
/// (subscriber's, publisher's). A measurement, not a check (`--ignored --nocapture throughput`).
fn throughput<IO: CustomIo + Send + 'static>(ios: (IO, IO), framing: bool, size: usize, count: usize) -> f64 {
    let topic_xml = "<dds><topic><name>Rate</name><dataType>Blob</dataType></topic></dds>";
    let p = object_id(1, ObjectKind::Participant);
    let t = object_id(1, ObjectKind::Topic);
    let (ready_tx, ready_rx) = channel();
    let (sub_io, pub_io) = ios;
    let sub = std::thread::spawn(move || {
        let (mut sub_out, mut sub_in) = ([0u8; BUF], [0u8; BUF * 4]);
        let transport = CustomTransport::<_, MTU>::new(sub_io, framing).unwrap();
        let mut sub = Session::new(transport, 0x0D08_0001).with_callbacks(Samples::default());
        sub.create_session().unwrap();
        let out = sub.create_output_reliable_stream(&mut sub_out, HISTORY).unwrap();
        let input = sub.create_input_reliable_stream(&mut sub_in, HISTORY * 4).unwrap();
        let (s, dr) = (object_id(1, ObjectKind::Subscriber), object_id(1, ObjectKind::DataReader));
        let reqs = [
            sub.buffer_create_participant_xml(out, p, 0, "<dds><participant/></dds>", REPLACE).unwrap(),
            sub.buffer_create_topic_xml(out, t, p, topic_xml, REPLACE).unwrap(),
            sub.buffer_create_subscriber_xml(out, s, p, "", REPLACE).unwrap(),
            sub.buffer_create_datareader_xml(out, dr, s, &blob("Rate", "data_reader"), REPLACE).unwrap(),
        ];
        let mut status = [0u8; 4];
        assert!(sub.run_session_until_all_status(3000, &reqs, &mut status).unwrap());
        let control = DeliveryControl { max_samples: DeliveryControl::UNLIMITED, ..Default::default() };
        sub.buffer_request_data(out, dr, input, Some(&control)).unwrap();
        sub.run_session_time(100).unwrap();
        ready_tx.send(()).unwrap();
        let deadline = Instant::now() + Duration::from_secs(60);
        while sub.callbacks().0.len() < count && Instant::now() < deadline {
            sub.run_session_until_data(100).unwrap();
            // Only the count matters: keep no payloads.
            let got = sub.callbacks().0.len();
            sub.callbacks().0.clear();
            sub.callbacks().0.resize(got, Vec::new());
        }
        sub.callbacks().0.len()
    });
    ready_rx.recv().unwrap();
    let (mut pub_out, mut pub_in) = ([0u8; BUF], [0u8; BUF]);
    let transport = CustomTransport::<_, MTU>::new(pub_io, framing).unwrap();
    let mut publ = Session::new(transport, 0x0D08_0002);
    publ.create_session().unwrap();
    let out = publ.create_output_reliable_stream(&mut pub_out, HISTORY).unwrap();
    publ.create_input_reliable_stream(&mut pub_in, HISTORY).unwrap();
    let (pb, dw) = (object_id(1, ObjectKind::Publisher), object_id(1, ObjectKind::DataWriter));
    let reqs = [
        publ.buffer_create_participant_xml(out, p, 0, "<dds><participant/></dds>", REPLACE).unwrap(),
        publ.buffer_create_topic_xml(out, t, p, topic_xml, REPLACE).unwrap(),
        publ.buffer_create_publisher_xml(out, pb, p, "", REPLACE).unwrap(),
        publ.buffer_create_datawriter_xml(out, dw, pb, &blob("Rate", "data_writer"), REPLACE).unwrap(),
    ];
    let mut status = [0u8; 4];
    assert!(publ.run_session_until_all_status(3000, &reqs, &mut status).unwrap());
    let sample = vec![0x5Au8; size];
    let started = Instant::now();
    let mut sent = 0;
    while sent < count {
        match publ.buffer_topic(out, dw, &sample) {
            Ok(_) => {
                sent += 1;
                publ.flash_output_streams().unwrap();
            }
            // History full: wait for the agent's acknowledgement.
            Err(xrce_client::Error::WouldBlock) => {
                publ.run_session_time(1).unwrap();
            }
            Err(e) => panic!("{e}"),
        }
    }
    let got = sub.join().unwrap();
    let rate = got as f64 / started.elapsed().as_secs_f64();
    let _ = publ.delete_session();
    assert_eq!(got, count, "every sample arrived");
    rate
}

#[test]
#[ignore = "a measurement; run with --ignored --nocapture"]
fn throughput_report() {
    for (size, count) in [(64, 20_000), (3000, 2_000)] {
        for mode in [Mode::Packet, Mode::Stream] {
            let hub = Hub::new();
            let agent = hub_agent(&hub, mode);
            let rate = throughput((hub.connect(1), hub.connect(2)), mode == Mode::Stream, size, count);
            println!("custom agent, in-memory medium, {mode:?} mode, {size} B reliable: {rate:.0} samples/s");
            drop(agent);
        }
        let mut agent =
            xrce_agent::agent::AgentInstance::create(["xrce-agent", "udp4", "-p", "0", "-m", "ced", "-v", "0"])
                .expect("agent");
        let port = agent.local_addr().unwrap().port();
        let io = || {
            let socket = std::net::UdpSocket::bind("127.0.0.1:0").unwrap();
            socket.connect(("127.0.0.1", port)).unwrap();
            UdpClientIo { socket }
        };
        let rate = throughput((io(), io()), false, size, count);
        println!("built-in UDP agent, loopback, {size} B reliable: {rate:.0} samples/s");
        agent.stop().unwrap();
    }
}

#[test]
#[ignore = "a measurement; run with --ignored --nocapture"]
fn round_trip_report() {
    for mode in [Mode::Packet, Mode::Stream] {
        let hub = Hub::new();
        let agent = hub_agent(&hub, mode);
        let (median, p99) = round_trip(hub.connect(1), mode == Mode::Stream, 5000);
        println!("custom agent, in-memory medium, {mode:?} mode: round trip median {median:?}, p99 {p99:?}");
        drop(agent);
    }
}

/// The built-in UDP server, for comparison: packet callbacks over a loopback socket.
struct UdpClientIo {
    socket: std::net::UdpSocket,
}

impl CustomIo for UdpClientIo {
    fn write(&mut self, buf: &[u8]) -> Result<usize, TransportError> {
        self.socket.send(buf).map_err(|_| TransportError::Custom(1))
    }

    fn read(&mut self, buf: &mut [u8], timeout_ms: i32) -> Result<usize, TransportError> {
        let timeout = Duration::from_millis(u64::try_from(timeout_ms.max(1)).unwrap_or(1));
        self.socket.set_read_timeout(Some(timeout)).map_err(|_| TransportError::Custom(2))?;
        Ok(self.socket.recv(buf).unwrap_or(0))
    }
}

#[test]
#[ignore = "a measurement; run with --ignored --nocapture"]
fn round_trip_report_udp_reference() {
    let mut agent = xrce_agent::agent::AgentInstance::create(["xrce-agent", "udp4", "-p", "0", "-m", "ced", "-v", "0"])
        .expect("agent");
    let port = agent.local_addr().unwrap().port();
    let socket = std::net::UdpSocket::bind("127.0.0.1:0").unwrap();
    socket.connect(("127.0.0.1", port)).unwrap();
    let (median, p99) = round_trip(UdpClientIo { socket }, false, 5000);
    println!("built-in UDP agent, loopback: round trip median {median:?}, p99 {p99:?}");
    agent.stop().unwrap();
}

/// Custom transports among others in one server (issue 24, `MultiServer::add_custom`): two in-memory media
/// beside a UDP socket, the subscriber on one and the publisher on the other; each medium opened once when
/// added and closed once when the server stops.
#[test]
fn custom_transports_share_one_core_with_the_others() {
    use xrce_agent::agent::Agent;
    use xrce_agent::core::CoreConfig;
    use xrce_agent::transport::custom::CustomOptions;
    use xrce_agent::transport::multi::{AnyEndpoint, MultiServer};
    let (a, b) = (Hub::new(), Hub::new());
    let agent = Agent::<AnyEndpoint>::new(MiddlewareKind::Ced, CoreConfig::default()).expect("ced");
    let mut server = MultiServer::new(agent.core()).expect("server");
    let udp = xrce_agent::transport::udp::bind_socket("127.0.0.1:0".parse().unwrap()).expect("udp");
    server.add_udp(udp).expect("udp added");
    for (name, hub) in [("hub-a", &a), ("hub-b", &b)] {
        server.add_custom(name, hub_endpoint(), Mode::Packet, hub.clone(), CustomOptions::default()).expect("added");
    }
    let names = server.names();
    assert!(names[0].starts_with("UDP 127.0.0.1:"), "{names:?}");
    assert_eq!(names[1..], ["custom hub-a", "custom hub-b"]);
    let stop = Arc::new(AtomicBool::new(false));
    let stop2 = stop.clone();
    let thread = std::thread::spawn(move || server.run(&stop2));
    pubsub_through(a.connect(1), b.connect(1), false, (0x0D05_0001, 0x0D05_0002), "AcrossMedia");
    assert!(a.written_to(1) > 0 && b.written_to(1) > 0, "both media answered");
    stop.store(true, Ordering::Relaxed);
    thread.join().expect("server thread").expect("server ran");
    for hub in [&a, &b] {
        assert_eq!((hub.opens.load(Ordering::SeqCst), hub.closes.load(Ordering::SeqCst)), (1, 1));
    }
}
