//! Our client's reconnection (on by default in the blocking `Session`) against our agent run in-process with
//! `-m ced`: the agent stopped and started again on the same port under a 1 kHz reliable publisher and a
//! subscriber; the link cut for 5 s by a proxy dropping everything; 100 clients coming back at once. None of the
//! client code here does anything about reconnection: it writes, retries on `WouldBlock`, runs the session.
//! Each test prints what it measured (`--nocapture`); docs/client-api.md quotes the figures.

use std::collections::HashMap;
use std::fs::File;
use std::io::{Read, Write};
use std::net::{SocketAddr, UdpSocket};
use std::os::fd::AsFd;
use std::sync::atomic::{AtomicBool, AtomicU32, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::{self, JoinHandle};
use std::time::{Duration, Instant};

use xrce_agent::agent::{AgentHandle, AgentInstance};
use xrce_agent::middleware::callbacks::CallbackKind;
use xrce_client::prelude::*;
use xrce_client::TransportError;

const HISTORY: usize = 16;
const BUF: usize = 512 * HISTORY;
const PARTICIPANT_XML: &str = "<dds><participant><rtps><name>reconnect</name></rtps></participant></dds>";
const TOPIC_XML: &str = "<dds><topic><name>ReconnectTopic</name><dataType>Counter</dataType></topic></dds>";
const WRITER_XML: &str = "<dds><data_writer><topic><kind>NO_KEY</kind><name>ReconnectTopic</name>\
                          <dataType>Counter</dataType></topic></data_writer></dds>";
const READER_XML: &str = "<dds><data_reader><topic><kind>NO_KEY</kind><name>ReconnectTopic</name>\
                          <dataType>Counter</dataType></topic></data_reader></dds>";

fn agent_on(port: u16) -> AgentInstance {
    agent_with(&["udp4", "-p", &port.to_string()])
}

/// An agent with `args` and `-m ced`; retried a while, as the port was maybe just freed by the previous one.
fn agent_with(args: &[&str]) -> AgentInstance {
    let mut full = vec!["xrce-agent"];
    full.extend_from_slice(args);
    full.extend_from_slice(&["-m", "ced", "-v", "0"]);
    for _ in 0..100 {
        if let Ok(a) = AgentInstance::create(full.iter().copied()) {
            return a;
        }
        thread::sleep(Duration::from_millis(20));
    }
    panic!("agent cannot start: {args:?}");
}

fn free_port() -> u16 {
    UdpSocket::bind("127.0.0.1:0").unwrap().local_addr().unwrap().port()
}

fn free_tcp_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0").unwrap().local_addr().unwrap().port()
}

/// When the session was lost and restored, as the callbacks saw it.
#[derive(Default, Clone)]
struct Timeline(Arc<Mutex<Vec<(Instant, &'static str)>>>);

impl Timeline {
    fn note(&self, what: &'static str) {
        self.0.lock().unwrap().push((Instant::now(), what));
    }
    fn events(&self) -> Vec<&'static str> {
        self.0.lock().unwrap().iter().map(|e| e.1).collect()
    }
    fn first(&self, what: &str, after: Instant) -> Option<Instant> {
        self.0.lock().unwrap().iter().find(|e| e.1 == what && e.0 >= after).map(|e| e.0)
    }
}

/// Callbacks: the timeline, plus the samples received (index, arrival) for a subscriber.
#[derive(Default, Clone)]
struct App {
    timeline: Timeline,
    samples: Arc<Mutex<Vec<(u32, Instant)>>>,
}

impl Callbacks for App {
    fn on_topic(&mut self, _: &mut Outputs<'_, '_>, _: ObjectId, _: u16, _: StreamId, data: &[u8]) {
        if let Some(index) = data.get(..4).map(|b| u32::from_le_bytes(b.try_into().unwrap())) {
            self.samples.lock().unwrap().push((index, Instant::now()));
        }
    }
    fn on_session_lost(&mut self) {
        self.timeline.note("lost");
    }
    fn on_session_restored(&mut self, recreated: bool) {
        self.timeline.note(if recreated { "recreated" } else { "resumed" });
    }
}

/// How a client reaches the agent.
#[derive(Debug)]
enum Link {
    Udp(SocketAddr),
    Tcp(SocketAddr),
    /// A custom transport, framed (eProsima's serial framing), over the master side of a pseudoterminal whose
    /// slave side the agent's serial transport opens.
    Pty(File),
}

/// Framed custom-transport callbacks over a pseudoterminal master (non-blocking: while no agent holds the
/// slave side, writes fail instead of filling the line and blocking).
struct PtyIo {
    master: File,
}

impl CustomIo for PtyIo {
    fn write(&mut self, buf: &[u8]) -> Result<usize, TransportError> {
        self.master.write(buf).map_err(|_| TransportError::Custom(1))
    }

    fn read(&mut self, buf: &mut [u8], timeout_ms: i32) -> Result<usize, TransportError> {
        use nix::poll::{poll, PollFd, PollFlags, PollTimeout};
        let ms = u16::try_from(timeout_ms.clamp(1, 1000)).unwrap_or(1000);
        let mut fds = [PollFd::new(self.master.as_fd(), PollFlags::POLLIN)];
        match poll(&mut fds, PollTimeout::from(ms)) {
            Ok(n) if n > 0 => match self.master.read(buf) {
                Ok(n) => Ok(n),
                Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => Ok(0),
                Err(_) => {
                    // No agent on the other side (EIO): fail, and do not spin on it.
                    thread::sleep(Duration::from_millis(u64::from(ms)));
                    Err(TransportError::Custom(2))
                }
            },
            _ => Ok(0),
        }
    }
}

/// The transport of a [`Link`].
enum Conn {
    Udp(UdpTransport),
    Tcp(Box<TcpTransport>),
    Pty(Box<CustomTransport<PtyIo, 512>>),
}

impl Transport for Conn {
    fn open(&mut self) -> Result<(), TransportError> {
        match self {
            Self::Udp(t) => t.open(),
            Self::Tcp(t) => t.open(),
            Self::Pty(t) => t.open(),
        }
    }
    fn send(&mut self, msg: &[u8]) -> Result<(), TransportError> {
        match self {
            Self::Udp(t) => t.send(msg),
            Self::Tcp(t) => t.send(msg),
            Self::Pty(t) => t.send(msg),
        }
    }
    fn recv(&mut self, buf: &mut [u8], timeout_ms: i32) -> Result<Option<usize>, TransportError> {
        match self {
            Self::Udp(t) => t.recv(buf, timeout_ms),
            Self::Tcp(t) => t.recv(buf, timeout_ms),
            Self::Pty(t) => t.recv(buf, timeout_ms),
        }
    }
}

impl Link {
    fn connect(self) -> Conn {
        match self {
            Self::Udp(a) => Conn::Udp(UdpTransport::connect(a).unwrap()),
            Self::Tcp(a) => Conn::Tcp(Box::new(TcpTransport::connect(a).unwrap())),
            Self::Pty(master) => Conn::Pty(Box::new(CustomTransport::new(PtyIo { master }, true).unwrap())),
        }
    }
}

/// A pseudoterminal: its non-blocking master, and the name of its slave for the agent's `--devs`.
fn pty() -> (File, String) {
    let p = nix::pty::openpty(None, None).unwrap();
    let name = nix::unistd::ttyname(&p.slave).unwrap().display().to_string();
    let master = File::from(p.master);
    let flags =
        nix::fcntl::OFlag::from_bits_truncate(nix::fcntl::fcntl(&master, nix::fcntl::FcntlArg::F_GETFL).unwrap());
    nix::fcntl::fcntl(&master, nix::fcntl::FcntlArg::F_SETFL(flags | nix::fcntl::OFlag::O_NONBLOCK)).unwrap();
    // The slave stays open here too (dropped with `p.slave` otherwise): the line survives the agent's restart.
    std::mem::forget(p.slave);
    (master, name)
}

type Client<'a> = Session<'a, Conn, StdClock, App, 1, 1, 1, 1, 512>;

/// Session, reliable streams and the participant/topic of a client.
fn setup<'a>(link: Link, key: u32, app: App, out: &'a mut [u8], inp: &'a mut [u8]) -> (Client<'a>, StreamId, StreamId) {
    let mut s: Client<'a> = Session::new(link.connect(), key).with_callbacks(app);
    s.create_session().unwrap();
    let rel_out = s.create_output_reliable_stream(out, HISTORY).unwrap();
    let rel_in = s.create_input_reliable_stream(inp, HISTORY).unwrap();
    let participant = object_id(1, ObjectKind::Participant);
    let reqs = [
        s.buffer_create_participant_xml(rel_out, participant, 0, PARTICIPANT_XML, REPLACE).unwrap(),
        s.buffer_create_topic_xml(rel_out, object_id(1, ObjectKind::Topic), participant, TOPIC_XML, REPLACE).unwrap(),
    ];
    let mut status = [0; 2];
    assert!(s.run_session_until_all_status(3000, &reqs, &mut status).unwrap(), "{status:?}");
    (s, rel_out, rel_in)
}

/// A reliable publisher of `index` samples at `rate_hz` until `stop`; every sample is written (retried on
/// `WouldBlock`; after an outage the backlog goes as fast as the history allows). `published` counts them.
fn publisher(
    agent: Link,
    key: u32,
    rate_hz: u32,
    stop: Arc<AtomicBool>,
    published: Arc<AtomicU32>,
) -> (Timeline, JoinHandle<()>) {
    let app = App::default();
    let timeline = app.timeline.clone();
    let handle = thread::spawn(move || {
        let (mut out, mut inp) = (vec![0u8; BUF], vec![0u8; BUF]);
        let (mut s, rel_out, _) = setup(agent, key, app, &mut out, &mut inp);
        let publisher = object_id(1, ObjectKind::Publisher);
        let writer = object_id(1, ObjectKind::DataWriter);
        let participant = object_id(1, ObjectKind::Participant);
        let reqs = [
            s.buffer_create_publisher_xml(rel_out, publisher, participant, "", REPLACE).unwrap(),
            s.buffer_create_datawriter_xml(rel_out, writer, publisher, WRITER_XML, REPLACE).unwrap(),
        ];
        let mut status = [0; 2];
        assert!(s.run_session_until_all_status(3000, &reqs, &mut status).unwrap(), "{status:?}");
        let period = Duration::from_secs(1) / rate_hz;
        let mut next = Instant::now();
        let mut index = 0u32;
        let mut sample = [0u8; 32];
        while !stop.load(Ordering::Relaxed) {
            // Every sample due by now: a socket's 1 ms read timeout lasts a kernel tick (4 ms at 250 Hz), so
            // each run of the session writes a few.
            while Instant::now() >= next {
                sample[..4].copy_from_slice(&index.to_le_bytes());
                match s.buffer_topic(rel_out, writer, &sample) {
                    Ok(_) => {
                        index += 1;
                        published.store(index, Ordering::Relaxed);
                        next += period;
                    }
                    Err(Error::WouldBlock) => break,
                    Err(e) => panic!("{e}"),
                }
            }
            s.run_session_timeout(1).unwrap();
        }
        // Everything written reaches the agent before the publisher goes.
        s.run_session_until_confirm_delivery(10_000).unwrap();
    });
    (timeline, handle)
}

/// A subscriber asking for every sample on its reliable input stream, until `stop`.
fn subscriber(agent: Link, key: u32, stop: Arc<AtomicBool>) -> (App, JoinHandle<()>) {
    let app = App::default();
    let shared = app.clone();
    let handle = thread::spawn(move || {
        let (mut out, mut inp) = (vec![0u8; BUF], vec![0u8; BUF]);
        let (mut s, rel_out, rel_in) = setup(agent, key, app, &mut out, &mut inp);
        let subscriber = object_id(1, ObjectKind::Subscriber);
        let reader = object_id(1, ObjectKind::DataReader);
        let participant = object_id(1, ObjectKind::Participant);
        let reqs = [
            s.buffer_create_subscriber_xml(rel_out, subscriber, participant, "", REPLACE).unwrap(),
            s.buffer_create_datareader_xml(rel_out, reader, subscriber, READER_XML, REPLACE).unwrap(),
        ];
        let mut status = [0; 2];
        assert!(s.run_session_until_all_status(3000, &reqs, &mut status).unwrap(), "{status:?}");
        let control = DeliveryControl { max_samples: DeliveryControl::UNLIMITED, ..Default::default() };
        s.buffer_request_data(rel_out, reader, rel_in, Some(&control)).unwrap();
        while !stop.load(Ordering::Relaxed) {
            s.run_session_timeout(10).unwrap();
        }
    });
    (shared, handle)
}

fn wait_for(mut cond: impl FnMut() -> bool, limit: Duration) -> bool {
    let start = Instant::now();
    while start.elapsed() < limit {
        if cond() {
            return true;
        }
        thread::sleep(Duration::from_millis(5));
    }
    cond()
}

/// Indices missing from `0..published` and indices received more than once.
fn lost_and_duplicated(samples: &[(u32, Instant)], range: std::ops::Range<u32>) -> (Vec<u32>, Vec<u32>) {
    let mut seen: HashMap<u32, usize> = HashMap::new();
    for (i, _) in samples {
        *seen.entry(*i).or_default() += 1;
    }
    let lost = range.filter(|i| !seen.contains_key(i)).collect();
    let mut dup: Vec<u32> = seen.iter().filter(|(_, n)| **n > 1).map(|(i, _)| *i).collect();
    dup.sort_unstable();
    (lost, dup)
}

/// The agent is stopped under a 1 kHz reliable flow and started again 3 s later on the same port: both clients
/// notice, re-create their sessions and entities, and delivery resumes without any application code.
#[test]
fn agent_restart_under_load() {
    let port = free_port();
    let addr: SocketAddr = format!("127.0.0.1:{port}").parse().unwrap();
    restart_under_load("udp", &["udp4", "-p", &port.to_string()], Link::Udp(addr), Link::Udp(addr));
}

/// The same over TCP: the connection breaks, the client connects again until the new agent accepts.
#[test]
fn agent_restart_under_load_over_tcp() {
    let port = free_tcp_port();
    let addr: SocketAddr = format!("127.0.0.1:{port}").parse().unwrap();
    restart_under_load("tcp", &["tcp4", "-p", &port.to_string()], Link::Tcp(addr), Link::Tcp(addr));
}

/// The same over serial lines (pseudoterminals), the clients on our framed custom transport.
#[test]
fn agent_restart_under_load_over_serial() {
    let ((sub_master, sub_dev), (pub_master, pub_dev)) = (pty(), pty());
    let devs = format!("{sub_dev} {pub_dev}");
    restart_under_load("serial", &["multiserial", "--devs", &devs], Link::Pty(sub_master), Link::Pty(pub_master));
}

fn restart_under_load(name: &str, args: &[&str], sub_link: Link, pub_link: Link) {
    let mut instance = agent_with(args);
    let stop_pub = Arc::new(AtomicBool::new(false));
    let stop_sub = Arc::new(AtomicBool::new(false));
    let published = Arc::new(AtomicU32::new(0));
    let (sub, sub_thread) = subscriber(sub_link, 0x5AB0_0001, stop_sub.clone());
    thread::sleep(Duration::from_millis(300));
    let (pub_timeline, pub_thread) = publisher(pub_link, 0x5AB0_0002, 1000, stop_pub.clone(), published.clone());
    assert!(
        wait_for(|| sub.samples.lock().unwrap().len() > 1000, Duration::from_secs(20)),
        "no flow before the restart"
    );

    let killed = Instant::now();
    instance.stop().unwrap();
    let before = sub.samples.lock().unwrap().len();
    thread::sleep(Duration::from_secs(3));
    let mut instance = agent_with(args);
    let restarted = Instant::now();
    let resumed =
        wait_for(|| sub.samples.lock().unwrap().iter().any(|(_, t)| *t >= restarted), Duration::from_secs(15));
    assert!(resumed, "no sample delivered after the agent restarted");
    let first = sub.samples.lock().unwrap().iter().find(|(_, t)| *t >= restarted).copied().unwrap();
    // Run on a while after the recovery, then let the publisher's last samples reach the subscriber.
    thread::sleep(Duration::from_secs(2));
    stop_pub.store(true, Ordering::Relaxed);
    pub_thread.join().unwrap();
    let total = published.load(Ordering::Relaxed);
    wait_for(|| sub.samples.lock().unwrap().iter().any(|(i, _)| *i == total - 1), Duration::from_secs(10));
    stop_sub.store(true, Ordering::Relaxed);
    sub_thread.join().unwrap();
    instance.stop().unwrap();

    let samples = sub.samples.lock().unwrap().clone();
    let (lost, dup) = lost_and_duplicated(&samples, 0..total);
    let lost_at = pub_timeline.first("lost", killed).map(|t| t - killed);
    let recreated_at = pub_timeline.first("recreated", restarted).map(|t| t - restarted);
    println!(
        "agent restart ({name}): {total} published, {} received ({before} before the stop); publisher lost after {lost_at:?}, \
         re-created {recreated_at:?} after the restart; first sample delivered {:?} after the restart (index {}); \
         {} lost, {} duplicated",
        samples.len(),
        first.1 - restarted,
        first.0,
        lost.len(),
        dup.len()
    );
    assert_eq!(pub_timeline.events(), ["lost", "recreated"], "publisher's callbacks");
    assert_eq!(sub.timeline.events(), ["lost", "recreated"], "subscriber's callbacks");
    // From the first sample after the restart on, nothing is missing: the flow really resumed.
    let after: Vec<u32> = lost.iter().copied().filter(|i| *i >= first.0).collect();
    assert!(after.is_empty(), "lost after the resumption: {after:?}");
}

/// A UDP relay between clients and agent (one upstream socket per client, so the agent sees each client apart)
/// that drops everything while `cut` is set.
struct Proxy {
    addr: SocketAddr,
    cut: Arc<AtomicBool>,
    stop: Arc<AtomicBool>,
    handle: Option<JoinHandle<()>>,
}

impl Proxy {
    fn new(agent: SocketAddr) -> Self {
        let front = UdpSocket::bind("127.0.0.1:0").unwrap();
        front.set_nonblocking(true).unwrap();
        let addr = front.local_addr().unwrap();
        let cut = Arc::new(AtomicBool::new(false));
        let stop = Arc::new(AtomicBool::new(false));
        let (cut2, stop2) = (cut.clone(), stop.clone());
        let handle = thread::spawn(move || {
            let mut upstream: HashMap<SocketAddr, UdpSocket> = HashMap::new();
            let mut buf = [0u8; 2048];
            while !stop2.load(Ordering::Relaxed) {
                let mut busy = false;
                while let Ok((n, from)) = front.recv_from(&mut buf) {
                    busy = true;
                    let up = upstream.entry(from).or_insert_with(|| {
                        let s = UdpSocket::bind("127.0.0.1:0").unwrap();
                        s.connect(agent).unwrap();
                        s.set_nonblocking(true).unwrap();
                        s
                    });
                    if !cut2.load(Ordering::Relaxed) {
                        let _ = up.send(&buf[..n]);
                    }
                }
                for (client, up) in &upstream {
                    while let Ok(n) = up.recv(&mut buf) {
                        busy = true;
                        if !cut2.load(Ordering::Relaxed) {
                            let _ = front.send_to(&buf[..n], client);
                        }
                    }
                }
                if !busy {
                    thread::sleep(Duration::from_micros(200));
                }
            }
        });
        Self { addr, cut, stop, handle: Some(handle) }
    }
}

impl Drop for Proxy {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(h) = self.handle.take() {
            let _ = h.join();
        }
    }
}

/// The link drops everything for 5 s under a 1 kHz reliable flow; the agent survives, so both sessions resume
/// as they were (no re-creation) and the subscriber gets every sample exactly once, in order.
#[test]
fn link_cut_for_five_seconds() {
    let mut instance = agent_on(0);
    let agent: SocketAddr = format!("127.0.0.1:{}", instance.local_addr().unwrap().port()).parse().unwrap();
    let proxy = Proxy::new(agent);
    let stop_pub = Arc::new(AtomicBool::new(false));
    let stop_sub = Arc::new(AtomicBool::new(false));
    let published = Arc::new(AtomicU32::new(0));
    let (sub, sub_thread) = subscriber(Link::Udp(proxy.addr), 0x5AB0_0011, stop_sub.clone());
    thread::sleep(Duration::from_millis(300));
    let (pub_timeline, pub_thread) =
        publisher(Link::Udp(proxy.addr), 0x5AB0_0012, 1000, stop_pub.clone(), published.clone());
    assert!(wait_for(|| sub.samples.lock().unwrap().len() > 1000, Duration::from_secs(20)), "no flow before the cut");
    let before = sub.samples.lock().unwrap().len();
    proxy.cut.store(true, Ordering::Relaxed);
    let cut_at = Instant::now();
    thread::sleep(Duration::from_secs(5));
    proxy.cut.store(false, Ordering::Relaxed);
    let healed = Instant::now();
    let resumed = wait_for(|| sub.samples.lock().unwrap().iter().any(|(_, t)| *t >= healed), Duration::from_secs(15));
    assert!(resumed, "no sample delivered after the link came back");
    let first = sub.samples.lock().unwrap().iter().find(|(_, t)| *t >= healed).map(|s| s.1 - healed).unwrap();
    thread::sleep(Duration::from_secs(2));
    stop_pub.store(true, Ordering::Relaxed);
    pub_thread.join().unwrap();
    let total = published.load(Ordering::Relaxed);
    wait_for(|| sub.samples.lock().unwrap().len() >= total as usize, Duration::from_secs(10));
    stop_sub.store(true, Ordering::Relaxed);
    sub_thread.join().unwrap();
    drop(proxy);
    instance.stop().unwrap();

    let samples = sub.samples.lock().unwrap().clone();
    let (lost, dup) = lost_and_duplicated(&samples, 0..total);
    println!(
        "link cut 5 s: {total} published, {} received ({before} before the cut), {} lost, {} duplicated; publisher \
         lost after {:?}, resumed {:?} after the link came back; first sample delivered {first:?} after it",
        samples.len(),
        lost.len(),
        dup.len(),
        pub_timeline.first("lost", cut_at).map(|t| t - cut_at),
        pub_timeline.first("resumed", healed).map(|t| t - healed),
    );
    assert!(lost.is_empty(), "lost: {lost:?}");
    assert!(dup.is_empty(), "duplicated: {dup:?}");
    let order: Vec<u32> = samples.iter().map(|s| s.0).collect();
    assert!(order.windows(2).all(|w| w[0] < w[1]), "out of order");
    assert_eq!(pub_timeline.events(), ["lost", "resumed"], "publisher's callbacks");
    assert_eq!(sub.timeline.events(), ["lost", "resumed"], "subscriber's callbacks");
}

/// 100 publishers lose the agent at once and all come back when it restarts: each gets its session and
/// datawriter created again (the new agent sees 100 datawriters) and a sample written afterwards acknowledged.
#[test]
fn hundred_clients_recover_after_agent_restart() {
    const CLIENTS: u32 = 100;
    let port = free_port();
    let agent: SocketAddr = format!("127.0.0.1:{port}").parse().unwrap();
    let mut instance = agent_on(port);
    let ready = Arc::new(AtomicUsize::new(0));
    let restarted_flag = Arc::new(AtomicBool::new(false));
    let restart_time: Arc<Mutex<Option<Instant>>> = Arc::default();
    let recovered: Arc<Mutex<Vec<Duration>>> = Arc::default();
    let mut threads = Vec::new();
    for n in 0..CLIENTS {
        let (ready, restarted_flag, restart_time, recovered) =
            (ready.clone(), restarted_flag.clone(), restart_time.clone(), recovered.clone());
        threads.push(thread::spawn(move || {
            let (mut out, mut inp) = (vec![0u8; 2048], vec![0u8; 2048]);
            let transport = UdpTransport::connect(agent).unwrap();
            let mut s: Session<'_, UdpTransport, StdClock, App> =
                Session::new(transport, 0x6000_0000 + n).with_callbacks(App::default());
            s.create_session_retries(30).unwrap();
            let rel_out = s.create_output_reliable_stream(&mut out, 4).unwrap();
            s.create_input_reliable_stream(&mut inp, 4).unwrap();
            let (p, t, pb, w) = (
                object_id(1, ObjectKind::Participant),
                object_id(1, ObjectKind::Topic),
                object_id(1, ObjectKind::Publisher),
                object_id(1, ObjectKind::DataWriter),
            );
            let reqs = [
                s.buffer_create_participant_xml(rel_out, p, 0, PARTICIPANT_XML, REPLACE).unwrap(),
                s.buffer_create_topic_xml(rel_out, t, p, TOPIC_XML, REPLACE).unwrap(),
                s.buffer_create_publisher_xml(rel_out, pb, p, "", REPLACE).unwrap(),
                s.buffer_create_datawriter_xml(rel_out, w, pb, WRITER_XML, REPLACE).unwrap(),
            ];
            let mut status = [0; 4];
            assert!(s.run_session_until_all_status(10_000, &reqs, &mut status).unwrap(), "{status:?}");
            ready.fetch_add(1, Ordering::Relaxed);
            // Publish every 100 ms; after the restart, stop at the first sample the new agent acknowledges.
            let mut index = 0u32;
            loop {
                let after_restart = restarted_flag.load(Ordering::Relaxed);
                if s.buffer_topic(rel_out, w, &index.to_le_bytes()).is_ok() {
                    index += 1;
                }
                let confirmed = s.run_session_until_confirm_delivery(100).unwrap();
                if after_restart && confirmed && s.callbacks().timeline.events().contains(&"recreated") {
                    let since = restart_time.lock().unwrap().map(|t| t.elapsed()).unwrap_or_default();
                    recovered.lock().unwrap().push(since);
                    break;
                }
                if let Some(t) = *restart_time.lock().unwrap() {
                    if t.elapsed() > Duration::from_secs(30) {
                        break;
                    }
                }
            }
            s.delete_session().unwrap();
        }));
    }
    assert!(wait_for(|| ready.load(Ordering::Relaxed) == CLIENTS as usize, Duration::from_secs(60)), "setup");
    instance.stop().unwrap();
    thread::sleep(Duration::from_secs(3));
    let mut instance = agent_on(port);
    *restart_time.lock().unwrap() = Some(Instant::now());
    restarted_flag.store(true, Ordering::Relaxed);
    let writers = Arc::new(AtomicUsize::new(0));
    let AgentHandle::Udp(handle) = instance.agent().clone() else { panic!("UDP agent") };
    let seen = writers.clone();
    handle.add_middleware_callback(CallbackKind::CreateDataWriter, move |_, _| {
        seen.fetch_add(1, Ordering::Relaxed);
    });
    for t in threads {
        t.join().unwrap();
    }
    instance.stop().unwrap();
    let mut times = recovered.lock().unwrap().clone();
    times.sort();
    println!(
        "100 clients: {} recovered; time from restart to a sample acknowledged by the new agent: median {:?}, max {:?}; \
         datawriters the new agent created: {}",
        times.len(),
        times.get(times.len() / 2),
        times.last(),
        writers.load(Ordering::Relaxed)
    );
    assert_eq!(times.len(), CLIENTS as usize, "clients recovered");
}

/// A UDP transport counting the messages it sends.
struct Counting {
    inner: UdpTransport,
    sent: Arc<AtomicUsize>,
}

impl Transport for Counting {
    fn send(&mut self, msg: &[u8]) -> Result<(), TransportError> {
        self.sent.fetch_add(1, Ordering::Relaxed);
        self.inner.send(msg)
    }
    fn recv(&mut self, buf: &mut [u8], timeout_ms: i32) -> Result<Option<usize>, TransportError> {
        self.inner.recv(buf, timeout_ms)
    }
}

/// While the agent is gone, a UDP client's sends meet the ICMP "port unreachable" of the previous ones: each is a
/// transport error, yet the client retries on its back-off, not in a loop (a few dozen messages in 4 s).
#[test]
fn a_dead_udp_port_is_retried_on_the_back_off() {
    let mut instance = agent_on(0);
    let agent: SocketAddr = format!("127.0.0.1:{}", instance.local_addr().unwrap().port()).parse().unwrap();
    let sent = Arc::new(AtomicUsize::new(0));
    let transport = Counting { inner: UdpTransport::connect(agent).unwrap(), sent: sent.clone() };
    let mut s: Session<'_, Counting, StdClock, App> =
        Session::new(transport, 0x5AB0_0031).with_callbacks(App::default());
    s.create_session().unwrap();
    instance.stop().unwrap();
    let before = sent.load(Ordering::Relaxed);
    s.run_session_timeout(4000).unwrap();
    let during = sent.load(Ordering::Relaxed) - before;
    println!("dead UDP port: {during} messages sent in 4 s");
    assert_eq!(s.callbacks().timeline.events(), ["lost"]);
    assert!(during < 60, "{during} messages in 4 s");
}

/// A TCP relay between clients and agent (a connection upstream per client connection) whose connections can
/// be broken on demand; new connections go through afterwards.
struct TcpRelay {
    addr: SocketAddr,
    open: Arc<Mutex<Vec<std::net::TcpStream>>>,
    stop: Arc<AtomicBool>,
}

impl TcpRelay {
    fn new(agent: SocketAddr) -> Self {
        let listener = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
        listener.set_nonblocking(true).unwrap();
        let addr = listener.local_addr().unwrap();
        let open: Arc<Mutex<Vec<std::net::TcpStream>>> = Arc::default();
        let stop = Arc::new(AtomicBool::new(false));
        let (open2, stop2) = (open.clone(), stop.clone());
        thread::spawn(move || {
            while !stop2.load(Ordering::Relaxed) {
                let Ok((client, _)) = listener.accept() else {
                    thread::sleep(Duration::from_millis(5));
                    continue;
                };
                client.set_nonblocking(false).unwrap();
                let Ok(upstream) = std::net::TcpStream::connect(agent) else { continue };
                let pump = |mut from: std::net::TcpStream, mut to: std::net::TcpStream| {
                    thread::spawn(move || {
                        let _ = std::io::copy(&mut from, &mut to);
                        let _ = to.shutdown(std::net::Shutdown::Both);
                    })
                };
                let mut list = open2.lock().unwrap();
                list.push(client.try_clone().unwrap());
                list.push(upstream.try_clone().unwrap());
                pump(client.try_clone().unwrap(), upstream.try_clone().unwrap());
                pump(upstream, client);
            }
        });
        Self { addr, open, stop }
    }

    /// Breaks every connection open now (both sides see it closed).
    fn cut(&self) {
        for s in self.open.lock().unwrap().drain(..) {
            let _ = s.shutdown(std::net::Shutdown::Both);
        }
    }
}

impl Drop for TcpRelay {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        self.cut();
    }
}

/// The publisher's TCP connection breaks under a 1 kHz reliable flow while the agent lives on: the client
/// connects again and re-creates its session with the resume property, the agent keeps the session's streams
/// (`STATUS_OK_MATCHED`), and the subscriber gets every sample exactly once, in order.
#[test]
fn a_broken_tcp_connection_resumes_the_session_without_duplicates() {
    let port = free_tcp_port();
    let agent: SocketAddr = format!("127.0.0.1:{port}").parse().unwrap();
    let mut instance = agent_with(&["tcp4", "-p", &port.to_string()]);
    let relay = TcpRelay::new(agent);
    let stop_pub = Arc::new(AtomicBool::new(false));
    let stop_sub = Arc::new(AtomicBool::new(false));
    let published = Arc::new(AtomicU32::new(0));
    let (sub, sub_thread) = subscriber(Link::Tcp(agent), 0x5AB0_0021, stop_sub.clone());
    thread::sleep(Duration::from_millis(300));
    let (pub_timeline, pub_thread) =
        publisher(Link::Tcp(relay.addr), 0x5AB0_0022, 1000, stop_pub.clone(), published.clone());
    assert!(wait_for(|| sub.samples.lock().unwrap().len() > 1000, Duration::from_secs(20)), "no flow before the cut");
    let cut_at = Instant::now();
    relay.cut();
    let resumed = wait_for(
        || sub.samples.lock().unwrap().iter().any(|(_, t)| *t >= cut_at + Duration::from_millis(50)),
        Duration::from_secs(15),
    );
    assert!(resumed, "no sample delivered after the connection broke");
    thread::sleep(Duration::from_secs(2));
    stop_pub.store(true, Ordering::Relaxed);
    pub_thread.join().unwrap();
    let total = published.load(Ordering::Relaxed);
    wait_for(|| sub.samples.lock().unwrap().len() >= total as usize, Duration::from_secs(10));
    stop_sub.store(true, Ordering::Relaxed);
    sub_thread.join().unwrap();
    drop(relay);
    instance.stop().unwrap();

    let samples = sub.samples.lock().unwrap().clone();
    let (lost, dup) = lost_and_duplicated(&samples, 0..total);
    println!(
        "TCP connection broken: {total} published, {} received, {} lost, {} duplicated; publisher callbacks {:?}, \
         back {:?} after the cut",
        samples.len(),
        lost.len(),
        dup.len(),
        pub_timeline.events(),
        pub_timeline.first("resumed", cut_at).map(|t| t - cut_at),
    );
    assert!(lost.is_empty(), "lost: {lost:?}");
    assert!(dup.is_empty(), "duplicated: {dup:?}");
    let order: Vec<u32> = samples.iter().map(|s| s.0).collect();
    assert!(order.windows(2).all(|w| w[0] < w[1]), "out of order");
    assert_eq!(pub_timeline.events(), ["lost", "resumed"], "the agent kept the session: resumed, not re-created");
}
