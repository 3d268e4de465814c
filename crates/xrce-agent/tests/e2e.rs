//! End to end over real sockets on loopback with ephemeral ports: UDP (v4, v6) and TCP.

mod common;

use std::io::{Read, Write};
use std::net::{SocketAddr, TcpStream, UdpSocket};
use std::time::{Duration, Instant};

use common::{acknack_msg, create_client_msg, decode_owned, unlimited, Client, Out};
use xrce_agent::agent::{AgentHandle, AgentInstance};
use xrce_agent::middleware::callbacks::CallbackKind;
use xrce_proto::framing::tcp;
use xrce_proto::view::SubmessageId;
use xrce_proto::{ObjectId, ObjectKind};

fn start(args: &[&str]) -> (AgentInstance, SocketAddr) {
    let mut full = vec!["xrce-agent"];
    full.extend_from_slice(args);
    let instance = AgentInstance::create(full).expect("agent starts");
    let port = instance.local_addr().unwrap().port();
    let loopback = if args[0].ends_with('6') { "[::1]" } else { "127.0.0.1" };
    (instance, format!("{loopback}:{port}").parse().unwrap())
}

/// A UDP client that acknowledges everything it gets on stream 0x80 and collects the submessages.
struct UdpPeer {
    socket: UdpSocket,
    agent: SocketAddr,
    got: Vec<Out>,
    next_rel: u16,
}

impl UdpPeer {
    fn new(agent: SocketAddr) -> Self {
        let bind = if agent.is_ipv6() { "[::1]:0" } else { "127.0.0.1:0" };
        let socket = UdpSocket::bind(bind).unwrap();
        socket.set_read_timeout(Some(Duration::from_millis(50))).unwrap();
        Self { socket, agent, got: Vec::new(), next_rel: 0 }
    }

    fn send(&mut self, m: &[u8]) {
        self.socket.send_to(m, self.agent).unwrap();
        self.pump(Duration::from_millis(30));
    }

    fn pump(&mut self, d: Duration) {
        let end = Instant::now() + d;
        let mut buf = [0u8; 2048];
        while Instant::now() < end {
            let Ok((n, _)) = self.socket.recv_from(&mut buf) else { continue };
            let (h, subs) = decode_owned(&buf[..n]);
            if h.stream_id.0 == 0x80 {
                if h.sequence_nr == self.next_rel {
                    self.next_rel += 1;
                    self.got.extend(subs);
                }
                self.socket.send_to(&acknack_msg(self.next_rel), self.agent).unwrap();
            } else {
                self.got.extend(subs);
            }
        }
    }

    fn wait_for(&mut self, pred: impl Fn(&[Out]) -> bool) -> bool {
        let end = Instant::now() + Duration::from_secs(5);
        while Instant::now() < end {
            if pred(&self.got) {
                return true;
            }
            self.pump(Duration::from_millis(20));
        }
        pred(&self.got)
    }
}

fn data_count(outs: &[Out]) -> usize {
    outs.iter().filter(|o| matches!(o, Out::Data { .. })).count()
}

fn udp_pubsub(args: &[&str]) {
    let (mut instance, addr) = start(args);
    let AgentHandle::Udp(agent) = instance.agent().clone() else { panic!("udp") };
    let created = std::sync::Arc::new(std::sync::atomic::AtomicUsize::new(0));
    for kind in [CallbackKind::CreateParticipant, CallbackKind::CreateDataWriter, CallbackKind::CreateDataReader] {
        let c = created.clone();
        agent.add_middleware_callback(kind, move |_, _| {
            c.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        });
    }
    let mut sub = UdpPeer::new(addr);
    let mut publ = UdpPeer::new(addr);
    let (mut s, mut p) = (Client::new(0x0E0E_0001), Client::new(0x0E0E_0002));
    sub.send(&create_client_msg(s.key, 0x81));
    publ.send(&create_client_msg(p.key, 0x81));
    for m in s.pubsub_entities("e2e") {
        sub.send(&m);
    }
    for m in p.pubsub_entities("e2e") {
        publ.send(&m);
    }
    assert!(sub.wait_for(|o| o.iter().filter(|x| matches!(x, Out::Status { status: 0, .. })).count() == 6));
    sub.send(&s.read(ObjectId::new(1, ObjectKind::DataReader), 0x80, unlimited()));
    for i in 0..30u32 {
        publ.send(&p.write(false, ObjectId::new(1, ObjectKind::DataWriter), &i.to_le_bytes()));
    }
    assert!(sub.wait_for(|o| data_count(o) == 30), "got {}", data_count(&sub.got));
    // Ping out of session.
    let mut pinger = UdpPeer::new(addr);
    pinger.send(&[0x80, 0, 0, 0, 0x02, 0x01, 0x08, 0x00, 0x00, 0x0A, 0xFF, 0xFD, 0x02, 0, 0, 0]);
    assert!(pinger.wait_for(|o| o.iter().any(|x| matches!(x, Out::Info { .. }))));
    // Callbacks fired for participants, writers and readers of both clients.
    assert_eq!(created.load(std::sync::atomic::Ordering::Relaxed), 6);
    instance.stop().unwrap();
}

#[test]
fn udp4_pubsub_ping_and_callbacks() {
    udp_pubsub(&["udp4", "-p", "0", "-m", "ced", "-v", "0"]);
}

#[test]
fn udp6_pubsub() {
    if UdpSocket::bind("[::1]:0").is_err() {
        eprintln!("no IPv6 loopback; skipped");
        return;
    }
    udp_pubsub(&["udp6", "-p0", "-m", "ced"]);
}

fn tcp_frame(m: &[u8]) -> Vec<u8> {
    let mut v = vec![0u8; tcp::PREFIX_LEN + m.len()];
    tcp::encode(m, &mut v).unwrap();
    v
}

/// Takes the next whole length-prefixed message off the front of `pending`, if there is one.
fn next_frame(pending: &mut Vec<u8>) -> Option<Vec<u8>> {
    // A message is no longer than what is pending; a prefix announcing more reports `Oversized`: not yet.
    let mut decoder = tcp::TcpDecoder::new(vec![0u8; pending.len()]);
    let (used, event) = decoder.feed(pending);
    let Some(tcp::TcpEvent::Message(msg)) = event else { return None };
    let msg = msg.to_vec();
    pending.drain(..used);
    Some(msg)
}

/// Reads framed messages until `pred` holds or 5 s pass.
fn tcp_wait(stream: &mut TcpStream, got: &mut Vec<Out>, pending: &mut Vec<u8>, pred: impl Fn(&[Out]) -> bool) -> bool {
    let end = Instant::now() + Duration::from_secs(5);
    let mut buf = [0u8; 4096];
    while Instant::now() < end && !pred(got) {
        if let Ok(n) = stream.read(&mut buf) {
            if n == 0 {
                break;
            }
            pending.extend_from_slice(&buf[..n]);
        }
        while let Some(msg) = next_frame(pending) {
            let (h, subs) = decode_owned(&msg);
            if h.stream_id.0 == 0x80 {
                stream.write_all(&tcp_frame(&acknack_msg(h.sequence_nr + 1))).unwrap();
            }
            got.extend(subs);
        }
    }
    pred(got)
}

#[test]
fn tcp4_two_connections_pubsub_with_partial_writes() {
    let (mut instance, addr) = start(&["tcp4", "-p", "0", "-m", "ced"]);
    let mut sub = TcpStream::connect(addr).unwrap();
    let mut publ = TcpStream::connect(addr).unwrap();
    for s in [&sub, &publ] {
        s.set_read_timeout(Some(Duration::from_millis(20))).unwrap();
        s.set_nodelay(true).unwrap();
    }
    let (mut sc, mut pc) = (Client::new(0x7C90_0001), Client::new(0x7C90_0002));
    let (mut sgot, mut pgot, mut sbuf, mut pbuf) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    // The subscriber's CREATE_CLIENT one byte at a time, plus an empty frame.
    sub.write_all(&[0, 0]).unwrap();
    for b in tcp_frame(&create_client_msg(sc.key, 0x81)) {
        sub.write_all(&[b]).unwrap();
        sub.flush().unwrap();
    }
    assert!(tcp_wait(&mut sub, &mut sgot, &mut sbuf, |o| o.contains(&Out::StatusAgent { status: 0 })));
    publ.write_all(&tcp_frame(&create_client_msg(pc.key, 0x81))).unwrap();
    assert!(tcp_wait(&mut publ, &mut pgot, &mut pbuf, |o| o.contains(&Out::StatusAgent { status: 0 })));
    // All entity creations of a client glued into one write.
    let glued: Vec<u8> = sc.pubsub_entities("tcp").iter().flat_map(|m| tcp_frame(m)).collect();
    sub.write_all(&glued).unwrap();
    let glued: Vec<u8> = pc.pubsub_entities("tcp").iter().flat_map(|m| tcp_frame(m)).collect();
    publ.write_all(&glued).unwrap();
    let six_ok = |o: &[Out]| o.iter().filter(|x| matches!(x, Out::Status { status: 0, .. })).count() == 6;
    assert!(tcp_wait(&mut sub, &mut sgot, &mut sbuf, six_ok));
    assert!(tcp_wait(&mut publ, &mut pgot, &mut pbuf, six_ok));
    sub.write_all(&tcp_frame(&sc.read(ObjectId::new(1, ObjectKind::DataReader), 0x80, unlimited()))).unwrap();
    std::thread::sleep(Duration::from_millis(50));
    let big = vec![0x42u8; 3000]; // fragmented towards the subscriber (MTU 508)
    for _ in 0..3 {
        publ.write_all(&tcp_frame(&pc.write(true, ObjectId::new(1, ObjectKind::DataWriter), &big))).unwrap();
    }
    assert!(
        tcp_wait(&mut sub, &mut sgot, &mut sbuf, |o| o.iter().filter(|x| matches!(x, Out::Other(13))).count() >= 3 * 6),
        "fragments received: {}",
        sgot.iter().filter(|x| matches!(x, Out::Other(13))).count()
    );
    instance.stop().unwrap();
}

/// Connects a TCP client with session key `key`, creates a publisher and a subscriber on `topic` and, with
/// `read`, asks for the samples on best-effort stream 1 (pushed without acknowledgements).
fn tcp_pubsub_client(addr: SocketAddr, key: u32, topic: &str, read: bool) -> (TcpStream, Client) {
    let mut stream = TcpStream::connect(addr).unwrap();
    stream.set_read_timeout(Some(Duration::from_millis(20))).unwrap();
    stream.set_nodelay(true).unwrap();
    let mut c = Client::new(key);
    let (mut got, mut pending) = (Vec::new(), Vec::new());
    stream.write_all(&tcp_frame(&create_client_msg(key, 0x81))).unwrap();
    assert!(tcp_wait(&mut stream, &mut got, &mut pending, |o| o.contains(&Out::StatusAgent { status: 0 })));
    let glued: Vec<u8> = c.pubsub_entities(topic).iter().flat_map(|m| tcp_frame(m)).collect();
    stream.write_all(&glued).unwrap();
    let six_ok = |o: &[Out]| o.iter().filter(|x| matches!(x, Out::Status { status: 0, .. })).count() == 6;
    assert!(tcp_wait(&mut stream, &mut got, &mut pending, six_ok));
    if read {
        stream.write_all(&tcp_frame(&c.read(ObjectId::new(1, ObjectKind::DataReader), 0x01, unlimited()))).unwrap();
    }
    (stream, c)
}

/// Counts the DATA submessages arriving on `stream` until `until`; returns them and the longest wait between two.
fn count_data(mut stream: TcpStream, until: Instant) -> (u64, Duration) {
    let (mut samples, mut pending, mut buf) = (0u64, Vec::new(), vec![0u8; 64 * 1024]);
    let (mut last, mut worst_gap) = (Instant::now(), Duration::ZERO);
    while Instant::now() < until {
        let n = match stream.read(&mut buf) {
            Ok(0) => break,
            Ok(n) => n,
            Err(_) => continue,
        };
        pending.extend_from_slice(&buf[..n]);
        while let Some(msg) = next_frame(&mut pending) {
            let (_, subs) = decode_owned(&msg);
            let data = subs.iter().filter(|o| matches!(o, Out::Data { .. })).count() as u64;
            if data > 0 {
                worst_gap = worst_gap.max(last.elapsed());
                last = Instant::now();
                samples += data;
            }
        }
    }
    (samples, worst_gap)
}

/// A TCP subscriber that stops reading must not hold up another one: the agent keeps the stalled client's
/// messages in that client's own outbox (and closes it once the outbox is full or stuck for the write
/// timeout) while the healthy subscriber keeps receiving. Before the per-connection outboxes, every write
/// waited for the stalled socket for up to the 2 s write timeout, so the healthy subscriber saw a 2 s gap.
#[test]
fn tcp_client_that_stops_reading_does_not_hold_up_another() {
    const SAMPLE: usize = 400; // one best-effort DATA within the agent's TCP MTU
    const PER_MS: u32 = 8; // ~3.2 MB/s: fills the stalled client's socket buffers within seconds
    const RUN: Duration = Duration::from_secs(5);
    let (mut instance, addr) = start(&["tcp4", "-p", "0", "-m", "ced", "-v", "0"]);
    let (mut stalled, _) = tcp_pubsub_client(addr, 0x7D00_0001, "stall", true);
    let (healthy, _) = tcp_pubsub_client(addr, 0x7D00_0002, "stall", true);
    let (mut publ, mut p) = tcp_pubsub_client(addr, 0x7D00_0003, "stall", false);
    std::thread::sleep(Duration::from_millis(50));
    // From here on `stalled` is never read.
    let counter = std::thread::spawn(move || count_data(healthy, Instant::now() + RUN + Duration::from_secs(1)));
    let writer = ObjectId::new(1, ObjectKind::DataWriter);
    let sample = vec![0x5Au8; SAMPLE];
    let started = Instant::now();
    let mut sent = 0u64;
    while started.elapsed() < RUN {
        for _ in 0..PER_MS {
            publ.write_all(&tcp_frame(&p.write(false, writer, &sample))).unwrap();
            sent += 1;
        }
        std::thread::sleep(Duration::from_millis(1));
    }
    let secs = started.elapsed().as_secs_f64();
    let (received, worst_gap) = counter.join().unwrap();
    let mut probe = [0u8; 1];
    stalled.set_read_timeout(Some(Duration::from_millis(200))).unwrap();
    let stalled_state = match stalled.read(&mut probe) {
        Ok(0) => "closed by the agent",
        Ok(_) => "open, data waiting",
        Err(_) => "open",
    };
    println!(
        "published {sent} samples of {SAMPLE} B in {secs:.2} s ({:.0}/s); the healthy subscriber received {received} \
         ({:.0}/s), worst gap {worst_gap:?}; the stalled one read nothing (its connection: {stalled_state})",
        sent as f64 / secs,
        received as f64 / secs,
    );
    assert!(received * 100 >= sent * 95, "the healthy subscriber got {received} of {sent}");
    assert!(worst_gap < Duration::from_secs(1), "the healthy subscriber waited {worst_gap:?} at once");
    instance.stop().unwrap();
}

/// First throughput figure: 64-byte samples, best effort, one publisher to one subscriber through CED over
/// UDP loopback. Run with `cargo test --release -p xrce-agent --test e2e throughput -- --ignored --nocapture`.
#[test]
#[ignore]
fn throughput_udp_best_effort_64b() {
    let (mut instance, addr) = start(&["udp4", "-p", "0", "-m", "ced", "-v", "0"]);
    let mut sub = UdpPeer::new(addr);
    let mut publ = UdpPeer::new(addr);
    let (mut s, mut p) = (Client::new(0x7B00_0001), Client::new(0x7B00_0002));
    sub.send(&create_client_msg(s.key, 0x81));
    publ.send(&create_client_msg(p.key, 0x81));
    for m in s.pubsub_entities("bench") {
        sub.send(&m);
    }
    for m in p.pubsub_entities("bench") {
        publ.send(&m);
    }
    sub.send(&s.read(ObjectId::new(1, ObjectKind::DataReader), 0x01, unlimited()));
    let sample = [0x5Au8; 64];
    let counter = std::sync::Arc::new(std::sync::atomic::AtomicU64::new(0));
    let rx = {
        let socket = sub.socket.try_clone().unwrap();
        let counter = counter.clone();
        std::thread::spawn(move || {
            let mut buf = [0u8; 2048];
            let end = Instant::now() + Duration::from_secs(7);
            while Instant::now() < end {
                if let Ok(n) = socket.recv(&mut buf) {
                    let first = xrce_proto::message::parse(&buf[..n]).ok().and_then(|(_, mut subs)| subs.next());
                    if first.and_then(Result::ok).and_then(|s| SubmessageId::from_u8(s.header.id))
                        == Some(SubmessageId::Data)
                    {
                        counter.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                    }
                }
            }
        })
    };
    let start_t = Instant::now();
    let mut sent = 0u64;
    while start_t.elapsed() < Duration::from_secs(5) {
        let m = p.write(false, ObjectId::new(1, ObjectKind::DataWriter), &sample);
        publ.socket.send_to(&m, addr).unwrap();
        sent += 1;
    }
    let elapsed = start_t.elapsed().as_secs_f64();
    rx.join().unwrap();
    let got = counter.load(std::sync::atomic::Ordering::Relaxed);
    println!(
        "sent {sent} ({:.0}/s), delivered {got} ({:.0} samples/s over {elapsed:.1} s)",
        sent as f64 / elapsed,
        got as f64 / elapsed
    );
    instance.stop().unwrap();
}

/// Errors name what could not be opened: a busy port, a missing serial device.
#[test]
fn errors_name_the_port_or_device() {
    let fails = |args: &[&str]| match AgentInstance::create(args.iter().copied()) {
        Ok(_) => panic!("{args:?} started"),
        Err(e) => e.to_string(),
    };
    let busy = UdpSocket::bind("0.0.0.0:0").unwrap();
    let port = busy.local_addr().unwrap().port().to_string();
    let err = fails(&["xrce-agent", "udp4", "-p", &port, "-m", "ced"]);
    assert!(err.contains(&format!("UDP port 0.0.0.0:{port}")), "{err}");
    let err = fails(&["xrce-agent", "serial", "--dev", "/nonexistent/ttyXRCE", "-m", "ced"]);
    assert!(err.contains("serial device /nonexistent/ttyXRCE"), "{err}");
}

/// eProsima's `-P` (agent-to-agent bridging) is refused with a reason, not accepted and ignored.
#[test]
fn p2p_is_refused_with_a_reason() {
    let err = match AgentInstance::create(["xrce-agent", "udp4", "-p", "0", "-m", "ced", "-P", "2019"]) {
        Ok(_) => panic!("-P started"),
        Err(e) => e.to_string(),
    };
    assert!(err.contains("-P/--p2p 2019") && err.contains("not supported"), "{err}");
}
