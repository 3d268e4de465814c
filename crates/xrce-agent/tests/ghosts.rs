//! No ghost clients and optional authentication (issue 13), end to end over UDP on loopback with `-m ced`:
//! a client killed with SIGKILL loses its datawriter within its timeout + 1 s while an idle client that runs
//! its session is kept; reconnecting with a new session id or a new key from the same endpoint leaves no
//! ghost; `--psk-file` admits our client with the key and refuses one without it. The DDS variant (`-m dds`,
//! ignored: it starts DDS participants) checks that a DDS peer loses the killed client's datareader:
//!
//!   ../shared/dds-peers/netns.sh xdds cargo test -p xrce-agent --test ghosts -- --ignored --test-threads 1

mod common;
mod netns;

use std::io::{BufRead, BufReader};
use std::net::{SocketAddr, UdpSocket};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use common::{create_client_msg, Client};
use xrce_agent::agent::{Agent, AgentHandle, AgentInstance};
use xrce_client::prelude::*;
use xrce_proto::{ClientKey, ObjectId, ObjectKind};

const CHILD_AGENT: &str = "XRCE_GHOSTS_CHILD_AGENT";
const CHILD_KEY: &str = "XRCE_GHOSTS_CHILD_KEY";
/// Set: the child creates a datareader on [`DDS_TOPIC`] instead of a datawriter.
const CHILD_READER: &str = "XRCE_GHOSTS_CHILD_READER";
const DDS_TOPIC: &str = "GhostsTopic";
const WRITER: ObjectId = ObjectId::new(1, ObjectKind::DataWriter);
const PARTICIPANT: ObjectId = ObjectId::new(1, ObjectKind::Participant);

fn start(args: &[&str]) -> (AgentInstance, Agent<SocketAddr>, SocketAddr) {
    let mut full = vec!["xrce-agent", "udp4", "-p", "0", "-m", "ced", "-v", "0"];
    full.extend_from_slice(args);
    let instance = AgentInstance::create(full).expect("agent starts");
    let port = instance.local_addr().expect("bound").port();
    let AgentHandle::Udp(agent) = instance.agent().clone() else { panic!("a UDP agent") };
    (instance, agent, SocketAddr::from(([127, 0, 0, 1], port)))
}

fn has(agent: &Agent<SocketAddr>, key: u32, id: ObjectId) -> bool {
    agent.core().with(move |c| c.has_object(ClientKey::from_u32(key), id))
}

fn has_client(agent: &Agent<SocketAddr>, key: u32) -> bool {
    agent.core().with(move |c| c.has_client(ClientKey::from_u32(key)))
}

/// Polls `pred` every 10 ms for up to `limit`; how long it took to hold, if it did.
fn time_until(limit: Duration, pred: impl Fn() -> bool) -> Option<Duration> {
    let start = Instant::now();
    while start.elapsed() <= limit {
        if pred() {
            return Some(start.elapsed());
        }
        std::thread::sleep(Duration::from_millis(10));
    }
    pred().then(|| start.elapsed())
}

/// Our client with a datawriter on topic `ghosts` (binary entities, reliable stream): the session of the
/// child process and of the authentication test.
fn client_with_writer<'a>(
    session: &mut Session<'a, UdpTransport, StdClock>,
    out_buf: &'a mut [u8],
    in_buf: &'a mut [u8],
) -> xrce_client::Result<()> {
    client_with_endpoint(session, out_buf, in_buf, false)
}

/// As [`client_with_writer`], or with a datareader on [`DDS_TOPIC`] (type `HelloWorld`).
fn client_with_endpoint<'a>(
    session: &mut Session<'a, UdpTransport, StdClock>,
    out_buf: &'a mut [u8],
    in_buf: &'a mut [u8],
    reader: bool,
) -> xrce_client::Result<()> {
    let out = session.create_output_reliable_stream(out_buf, 4)?;
    session.create_input_reliable_stream(in_buf, 4)?;
    let p = object_id(1, ObjectKind::Participant);
    let t = object_id(1, ObjectKind::Topic);
    let (publ, sub) = (object_id(1, ObjectKind::Publisher), object_id(1, ObjectKind::Subscriber));
    let (dw, dr) = (object_id(1, ObjectKind::DataWriter), object_id(1, ObjectKind::DataReader));
    let (topic, type_name) = if reader { (DDS_TOPIC, "HelloWorld") } else { ("ghosts", "G") };
    let mut requests = [
        session.buffer_create_participant_bin(out, p, 0, None, REPLACE)?,
        session.buffer_create_topic_bin(out, t, p, topic, type_name, REPLACE)?,
        0,
        0,
    ];
    if reader {
        requests[2] = session.buffer_create_subscriber_bin(out, sub, p, REPLACE)?;
        requests[3] = session.buffer_create_datareader_bin(out, dr, sub, t, QoS::default(), REPLACE)?;
    } else {
        requests[2] = session.buffer_create_publisher_bin(out, publ, p, REPLACE)?;
        requests[3] = session.buffer_create_datawriter_bin(out, dw, publ, t, QoS::default(), REPLACE)?;
    }
    let mut status = [0u8; 4];
    assert!(session.run_session_until_all_status(2000, &requests, &mut status)?, "entities: {status:?}");
    Ok(())
}

/// Not a test of its own: the child process of the SIGKILL test (this binary run again with this name). It
/// creates a datawriter, says READY, then idles, running its session as an application's loop does.
#[test]
fn ghost_child_process() {
    let (Ok(agent), Ok(key)) = (std::env::var(CHILD_AGENT), std::env::var(CHILD_KEY)) else { return };
    let agent: SocketAddr = agent.parse().expect("agent address");
    let key: u32 = key.parse().expect("key");
    let mut session = Session::new(UdpTransport::connect(agent).expect("socket"), key).with_session_id(0x01);
    session.create_session().expect("session");
    let (mut out_buf, mut in_buf) = ([0u8; 2048], [0u8; 2048]);
    let reader = std::env::var_os(CHILD_READER).is_some();
    client_with_endpoint(&mut session, &mut out_buf, &mut in_buf, reader).expect("entities");
    println!("READY");
    loop {
        let _ = session.run_session_time(100);
    }
}

/// The child process, killed (SIGKILL) however the test ends.
struct KillOnDrop(std::process::Child);

impl Drop for KillOnDrop {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// Starts the child client process; returns once it created its entities.
fn spawn_child(addr: SocketAddr, key: u32, reader: bool) -> KillOnDrop {
    let mut command = Command::new(std::env::current_exe().expect("test binary"));
    command
        .args(["--exact", "ghost_child_process", "--nocapture", "--test-threads", "1"])
        .env(CHILD_AGENT, addr.to_string())
        .env(CHILD_KEY, key.to_string())
        .stdout(Stdio::piped());
    if reader {
        command.env(CHILD_READER, "1");
    }
    let mut child = KillOnDrop(command.spawn().expect("child client"));
    let stdout = child.0.stdout.take().expect("child stdout");
    // libtest prints "test ghost_child_process ... " before it on the same line.
    let ready = BufReader::new(stdout).lines().map_while(Result::ok).any(|line| line.trim_end().ends_with("READY"));
    assert!(ready, "the child client created its entities");
    child
}

#[test]
fn a_client_killed_with_sigkill_loses_its_writer_within_its_timeout_and_an_idle_one_is_kept() {
    const TIMEOUT: Duration = Duration::from_secs(2);
    let (_instance, agent, addr) = start(&["--client-timeout", "2"]);
    let key = 0x6400_0000 | (std::process::id() & 0xFFFF);
    let mut child = spawn_child(addr, key, false);
    assert!(has(&agent, key, WRITER));
    // Idle (it sends nothing of its own) but running its session: it answers the probes and stays.
    std::thread::sleep(3 * TIMEOUT);
    assert!(has(&agent, key, WRITER), "an idle client that answers probes is kept past 3 timeouts");
    child.0.kill().expect("SIGKILL");
    let killed = Instant::now();
    let _ = child.0.wait();
    let gone = time_until(TIMEOUT + Duration::from_secs(2), || !has(&agent, key, WRITER));
    let after = gone.map(|_| killed.elapsed());
    println!("writer deleted {after:?} after SIGKILL (timeout {TIMEOUT:?})");
    let after = after.expect("the writer of the killed client is deleted");
    assert!(after <= TIMEOUT + Duration::from_secs(1), "{after:?}");
    assert!(!has_client(&agent, key));
}

#[test]
fn reconnecting_with_a_new_session_id_or_a_new_key_from_the_same_endpoint_leaves_no_ghost() {
    let (_instance, agent, addr) = start(&[]);
    let socket = UdpSocket::bind("127.0.0.1:0").expect("socket");
    let send = |m: &[u8]| {
        socket.send_to(m, addr).expect("send");
    };
    let created = |key: u32| time_until(Duration::from_secs(5), || has(&agent, key, PARTICIPANT)).is_some();
    let participant = |key: u32, session: u8| {
        let mut c = Client::new(key);
        c.session = session;
        let p = c.pubsub_entities("ghost");
        send(&create_client_msg(key, session));
        send(&p[0]);
    };
    let (a, b) = (0x0A0A_0001, 0x0B0B_0002);
    participant(a, 0x01);
    assert!(created(a));
    // The same client, new session id (eProsima deletes the old session's entities too).
    send(&create_client_msg(a, 0x02));
    assert!(time_until(Duration::from_secs(5), || has_client(&agent, a) && !has(&agent, a, PARTICIPANT)).is_some());
    participant(a, 0x02);
    assert!(created(a));
    // A reboot: a new key from the same address and port. The old session does not answer (nobody reads the
    // socket here), so it goes within the 1 s grace.
    participant(b, 0x01);
    assert!(created(b));
    let gone = time_until(Duration::from_secs(3), || !has_client(&agent, a));
    println!("old key removed {gone:?} after the new key's session");
    assert!(gone.is_some(), "the ghost of the old key is removed");
    assert!(has(&agent, b, PARTICIPANT));
}

#[test]
fn a_pre_shared_key_admits_our_client_and_refuses_one_without_it() {
    let dir = std::env::temp_dir().join(format!("xrce-ghosts-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("dir");
    let file = dir.join("psk");
    std::fs::write(&file, "f00dfeedf00dfeedf00dfeedf00dfeed\n").expect("psk file");
    let (_instance, agent, addr) = start(&["--psk-file", file.to_str().expect("path")]);
    let transport = || UdpTransport::connect(addr).expect("socket");

    // Without a token (what eProsima's C client sends): STATUS_ERR_DENIED.
    let mut plain = Session::new(transport(), 0x5EC0_0001);
    match plain.create_session_retries(2) {
        Err(Error::Refused(status)) => assert_eq!(status, 0x83, "STATUS_ERR_DENIED"),
        other => panic!("expected a refusal, got {other:?}"),
    }
    // With a token made with another key: refused too.
    let mut wrong = Session::new(transport(), 0x5EC0_0002).with_pre_shared_key(b"0123456789abcdef0123456789abcdef");
    assert!(matches!(wrong.create_session_retries(2), Err(Error::Refused(0x83))));
    // With the key: a session and entities.
    let mut good = Session::new(transport(), 0x5EC0_0003).with_pre_shared_key(b"f00dfeedf00dfeedf00dfeedf00dfeed");
    good.create_session().expect("admitted");
    let (mut out_buf, mut in_buf) = ([0u8; 2048], [0u8; 2048]);
    client_with_writer(&mut good, &mut out_buf, &mut in_buf).expect("writer");
    assert!(has(&agent, 0x5EC0_0003, WRITER));
    assert!(!has_client(&agent, 0x5EC0_0001) && !has_client(&agent, 0x5EC0_0002));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
#[ignore = "starts DDS: run inside shared/dds-peers/netns.sh with --ignored"]
fn a_dds_peer_loses_the_reader_and_the_writer_of_a_client_killed_with_sigkill_within_its_timeout() {
    const TIMEOUT: Duration = Duration::from_secs(2);
    netns::require_loopback_namespace();
    // The default engine (Fast DDS). On the RustDDS fallback the peer never sees the deleted reader go (the
    // agent deletes it; RustDDS 0.15.1 does not announce it here): a known limit, docs/dds-engine.md.
    let args = ["xrce-agent", "udp4", "-p", "0", "-m", "dds", "--dds-engine", "fastdds", "-v", "0"];
    let instance = AgentInstance::create(args.into_iter().chain(["--client-timeout", "2"])).expect("agent starts");
    let addr = SocketAddr::from(([127, 0, 0, 1], instance.local_addr().expect("bound").port()));
    // A RustDDS peer: it lists the writers it discovered (Fast DDS' API here does not).
    let peer = xrce_dds::DdsBridge::new(xrce_dds::BridgeConfig {
        engine: xrce_dds::Engine::RustDds,
        only_networks: Some(vec![std::net::IpAddr::V4(std::net::Ipv4Addr::LOCALHOST)]),
        ..Default::default()
    });
    let participant = peer.participant(0, "").expect("DDS participant");
    let topic = participant.topic(DDS_TOPIC, "HelloWorld", false).expect("topic");
    let writer = participant.create_writer(&topic, &xrce_dds::EndpointQos::default()).expect("DDS writer");
    let key = 0x6500_0000 | (std::process::id() & 0xFFFF);
    let mut child = spawn_child(addr, key, true);
    let matched = time_until(Duration::from_secs(20), || writer.matched_readers() == 1);
    assert!(matched.is_some(), "the peer sees the reader");
    std::thread::sleep(3 * TIMEOUT);
    assert_eq!(writer.matched_readers(), 1, "an idle client answering probes keeps its reader");
    child.0.kill().expect("SIGKILL");
    let killed = Instant::now();
    let _ = child.0.wait();
    let gone = time_until(TIMEOUT + Duration::from_secs(3), || writer.matched_readers() == 0).map(|_| killed.elapsed());
    println!("the DDS peer lost the reader {gone:?} after SIGKILL (timeout {TIMEOUT:?})");
    let gone = gone.expect("the DDS peer loses the killed client's reader");
    assert!(gone <= TIMEOUT + Duration::from_secs(1), "{gone:?}");

    // The same for a client's datawriter (topic `ghosts`): the peer's participant stops listing it.
    let key = key ^ 0x0001_0000;
    let ghosts = participant.topic("ghosts", "G", false).expect("topic");
    let _reader = participant.create_reader(&ghosts, &xrce_dds::EndpointQos::default()).expect("DDS reader");
    let mut child = spawn_child(addr, key, false);
    let writers = || participant.discovered_writers("ghosts");
    assert!(time_until(Duration::from_secs(20), || writers() == Some(1)).is_some(), "the peer sees the writer");
    child.0.kill().expect("SIGKILL");
    let killed = Instant::now();
    let _ = child.0.wait();
    let gone = time_until(TIMEOUT + Duration::from_secs(3), || writers() == Some(0)).map(|_| killed.elapsed());
    println!("the DDS peer lost the writer {gone:?} after SIGKILL (timeout {TIMEOUT:?})");
    let gone = gone.expect("the DDS peer loses the killed client's writer");
    assert!(gone <= TIMEOUT + Duration::from_secs(1), "{gone:?}");
}
