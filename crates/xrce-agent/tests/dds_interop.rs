//! Interop through the real agent binary with the DDS middleware (the default `-m dds`): our XRCE client
//! (`xrce-client`, over UDP) on one side, Fast DDS 2.9 (`hello_fastdds`) and Cyclone DDS 11
//! (`hello_cyclone.py`, `keyed_cyclone.py`) on the other. Needs the peers built by `.ci/dds-peers.sh DIR`
//! and a loopback-only namespace:
//!
//!   .ci/dds-peers.sh target/dds-peers
//!   XRCE_DDS_PEERS=$PWD/target/dds-peers ../shared/dds-peers/netns.sh xdds \
//!       cargo test -p xrce-agent --test dds_interop -- --ignored --test-threads 1

mod netns;
use netns::AgentProcess;

use std::io::BufRead;
use std::path::PathBuf;
use std::process::{Child, Command, Stdio};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use xrce_client::prelude::*;

fn peers() -> PathBuf {
    PathBuf::from(
        std::env::var_os("XRCE_DDS_PEERS").expect("set XRCE_DDS_PEERS to the directory .ci/dds-peers.sh built"),
    )
}

fn python(script: &str, args: &[&str]) -> Command {
    venv_python(&peers().join(script), args)
}

fn venv_python(script: &std::path::Path, args: &[&str]) -> Command {
    let dir = peers();
    let mut c = Command::new(dir.join("venv/bin/python"));
    c.arg(script).args(args);
    c.env("CYCLONEDDS_URI", format!("file://{}", dir.join("cyclonedds-lo.xml").display()));
    c
}

/// A Python script of this crate's `tests/dds_peers`, run with the peers' Cyclone venv.
fn own_python(script: &str, args: &[&str]) -> Command {
    venv_python(&PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/dds_peers").join(script), args)
}

fn fastdds(args: &[&str]) -> Command {
    let mut c = Command::new(peers().join("hello_fastdds"));
    c.args(args);
    c
}

fn spawn(mut c: Command) -> Child {
    c.stdout(Stdio::piped()).stderr(Stdio::piped()).spawn().expect("peer starts")
}

fn finish(c: Child, name: &str) -> (bool, String) {
    let out = c.wait_with_output().expect("peer runs");
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    println!("--- {name} (exit {:?})\n{stdout}{}", out.status.code(), String::from_utf8_lossy(&out.stderr));
    (out.status.success(), stdout)
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

fn hello_decode(b: &[u8]) -> Option<(u32, String)> {
    let index = u32::from_le_bytes(b.get(0..4)?.try_into().ok()?);
    let len = u32::from_le_bytes(b.get(4..8)?.try_into().ok()?) as usize;
    let s = b.get(8..8 + len.saturating_sub(1))?;
    Some((index, String::from_utf8_lossy(s).into_owned()))
}

const HISTORY: usize = 8;
const BUF: usize = 512 * HISTORY;
const PARTICIPANT_XML: &str =
    "<dds><participant><rtps><name>default_xrce_participant</name></rtps></participant></dds>";

/// An XRCE client publishing HelloWorld on `topic` (XML entities, as eProsima's PublishHelloWorld), one
/// sample every 100 ms with increasing index, until `stop`. Returns how many it wrote.
fn xrce_publisher(port: u16, topic: &'static str, keyed: bool, stop: Arc<AtomicBool>) -> JoinHandle<u32> {
    std::thread::spawn(move || {
        let transport = UdpTransport::new(IpProtocol::V4, "127.0.0.1", &port.to_string()).expect("udp");
        let mut out_buf = [0u8; BUF];
        let mut in_buf = [0u8; BUF];
        let mut session = Session::new(transport, 0xAAAA_BBBB);
        session.create_session().expect("session");
        let out = session.create_output_reliable_stream(&mut out_buf, HISTORY).expect("out stream");
        session.create_input_reliable_stream(&mut in_buf, HISTORY).expect("in stream");
        let kind = if keyed { "WITH_KEY" } else { "NO_KEY" };
        let p = object_id(1, ObjectKind::Participant);
        let t = object_id(1, ObjectKind::Topic);
        let publ = object_id(1, ObjectKind::Publisher);
        let dw = object_id(1, ObjectKind::DataWriter);
        let topic_xml =
            format!("<dds><topic><name>{topic}</name><dataType>HelloWorld</dataType><kind>{kind}</kind></topic></dds>");
        let dw_xml = format!(
            "<dds><data_writer><topic><kind>{kind}</kind><name>{topic}</name><dataType>HelloWorld</dataType></topic></data_writer></dds>"
        );
        let reqs = [
            session.buffer_create_participant_xml(out, p, 0, PARTICIPANT_XML, REPLACE).expect("p"),
            session.buffer_create_topic_xml(out, t, p, &topic_xml, REPLACE).expect("t"),
            session.buffer_create_publisher_xml(out, publ, p, "", REPLACE).expect("pub"),
            session.buffer_create_datawriter_xml(out, dw, publ, &dw_xml, REPLACE).expect("dw"),
        ];
        let mut status = [0u8; 4];
        assert!(session.run_session_until_all_status(3000, &reqs, &mut status).expect("run"), "create: {status:?}");
        let mut n = 0u32;
        while !stop.load(Ordering::Relaxed) && n < 600 {
            n += 1;
            session.buffer_topic(out, dw, &hello_body(n, "Hello from the Rust XRCE client")).expect("write");
            session.run_session_time(100).expect("run");
        }
        let _ = session.delete_session();
        n
    })
}

#[derive(Default)]
struct Collect {
    samples: Vec<(u32, String)>,
}

impl Callbacks for Collect {
    fn on_topic(&mut self, _: &mut Outputs<'_, '_>, _: ObjectId, _: u16, _: StreamId, data: &[u8]) {
        if let Some(s) = hello_decode(data) {
            println!("xrce client received index={} message={:?}", s.0, s.1);
            self.samples.push(s);
        }
    }
}

#[test]
#[ignore = "needs XRCE_DDS_PEERS=<dir> (.ci/dds-peers.sh) and shared/dds-peers/netns.sh"]
fn xrce_client_publishes_to_fastdds_and_cyclone() {
    let _agent = AgentProcess::start(18_901);
    let cyc = spawn(python("hello_cyclone.py", &["sub", "60", "10"]));
    let fdds = spawn(fastdds(&["sub", "60", "10"]));
    // The peers' participants first, then the agent's. Started within the same milliseconds, Fast DDS could
    // end up with the port pair of two participant ids (user unicast 7411 of id 0, metatraffic 7412 of id 1,
    // the agent's RustDDS participant holding 7410) and then received nothing in 60 s (1 run in 4 here).
    std::thread::sleep(Duration::from_secs(1));
    let stop = Arc::new(AtomicBool::new(false));
    let publisher = xrce_publisher(18_901, "HelloWorldTopic", false, stop.clone());
    let (ok_c, out_c) = finish(cyc, "cyclone sub");
    let (ok_f, out_f) = finish(fdds, "fastdds sub");
    stop.store(true, Ordering::Relaxed);
    let written = publisher.join().expect("publisher");
    println!("xrce client wrote {written} samples");
    // A peer stops once it holds 10 samples; Cyclone's script takes up to 10 at a time, so it may hold more.
    let total = |out: &str, prefix: &str| -> usize {
        out.lines().find_map(|l| l.strip_prefix(prefix)).and_then(|n| n.trim().parse().ok()).unwrap_or(0)
    };
    assert!(ok_c && total(&out_c, "cyclone-py received total") >= 10, "Cyclone got 10");
    assert!(out_c.contains("Hello from the Rust XRCE client"));
    assert!(ok_f && total(&out_f, "fastdds received total") >= 10, "Fast DDS got 10");
    assert!(out_f.contains("message='Hello from the Rust XRCE client'"));
}

#[test]
#[ignore = "needs XRCE_DDS_PEERS=<dir> (.ci/dds-peers.sh) and shared/dds-peers/netns.sh"]
fn fastdds_and_cyclone_publish_to_the_xrce_client() {
    let _agent = AgentProcess::start(18_902);
    let transport = UdpTransport::new(IpProtocol::V4, "127.0.0.1", "18902").expect("udp");
    let mut out_buf = [0u8; BUF];
    let mut in_buf = [0u8; BUF];
    let mut session = Session::new(transport, 0xCCCC_DDDD).with_callbacks(Collect::default());
    session.create_session().expect("session");
    let out = session.create_output_reliable_stream(&mut out_buf, HISTORY).expect("out stream");
    let input = session.create_input_reliable_stream(&mut in_buf, HISTORY).expect("in stream");
    let p = object_id(1, ObjectKind::Participant);
    let t = object_id(1, ObjectKind::Topic);
    let sub = object_id(1, ObjectKind::Subscriber);
    let dr = object_id(1, ObjectKind::DataReader);
    let topic_xml = "<dds><topic><name>HelloWorldTopic</name><dataType>HelloWorld</dataType></topic></dds>";
    // The peers are reliable KEEP_ALL; so is this reader, so that every sample is kept for the client.
    let dr_xml =
        "<dds><data_reader><topic><kind>NO_KEY</kind><name>HelloWorldTopic</name><dataType>HelloWorld</dataType>\
                  <historyQos><kind>KEEP_ALL</kind></historyQos></topic>\
                  <qos><reliability><kind>RELIABLE</kind></reliability></qos></data_reader></dds>";
    let reqs = [
        session.buffer_create_participant_xml(out, p, 0, PARTICIPANT_XML, REPLACE).expect("p"),
        session.buffer_create_topic_xml(out, t, p, topic_xml, REPLACE).expect("t"),
        session.buffer_create_subscriber_xml(out, sub, p, "", REPLACE).expect("sub"),
        session.buffer_create_datareader_xml(out, dr, sub, dr_xml, REPLACE).expect("dr"),
    ];
    let mut status = [0u8; 4];
    assert!(session.run_session_until_all_status(3000, &reqs, &mut status).expect("run"), "create: {status:?}");
    let control = DeliveryControl { max_samples: DeliveryControl::UNLIMITED, ..Default::default() };
    session.buffer_request_data(out, dr, input, Some(&control)).expect("read");
    session.run_session_time(100).expect("run");
    let cyc = spawn(python("hello_cyclone.py", &["pub", "5"]));
    let fdds = spawn(fastdds(&["pub", "5"]));
    let t0 = Instant::now();
    while session.callbacks().samples.len() < 10 && t0.elapsed() < Duration::from_secs(60) {
        session.run_session_until_data(500).expect("run");
    }
    let (ok_c, _) = finish(cyc, "cyclone pub");
    let (ok_f, _) = finish(fdds, "fastdds pub");
    let got = std::mem::take(&mut session.callbacks().samples);
    let _ = session.delete_session();
    assert!(ok_c && ok_f);
    let from_cyclone = got.iter().filter(|s| s.1 == "Hello from Cyclone DDS (python)").count();
    let from_fastdds = got.iter().filter(|s| s.1 == "Hello from Fast DDS 2.9").count();
    assert_eq!((from_cyclone, from_fastdds), (5, 5), "{got:?}");
}

#[test]
#[ignore = "needs XRCE_DDS_PEERS=<dir> (.ci/dds-peers.sh) and shared/dds-peers/netns.sh"]
fn keyed_samples_from_the_xrce_client_are_distinct_instances_for_cyclone() {
    let _agent = AgentProcess::start(18_903);
    let cyc = spawn(python("keyed_cyclone.py", &["60", "5"]));
    // The peer's participant first (see xrce_client_publishes_to_fastdds_and_cyclone).
    std::thread::sleep(Duration::from_secs(1));
    let stop = Arc::new(AtomicBool::new(false));
    let publisher = xrce_publisher(18_903, "HelloWorldKeyedTopic", true, stop.clone());
    let (_, out) = finish(cyc, "cyclone keyed sub");
    stop.store(true, Ordering::Relaxed);
    publisher.join().expect("publisher");
    assert!(out.contains("received total 5 distinct instances 5"), "five keys, five instances");
}

/// First contact (issue 11): a Cyclone DDS reader is already running when the client arrives, and the XRCE
/// publisher writes a burst right after its datawriter's STATUS OK, as a firmware does. The agent's default
/// DDS participant exists from the agent's start (`--eager-participant`), so it knows the reader when the
/// writer is created; the first-contact gate holds the burst until the writer has matched it. Without the
/// gate the first samples (written in the 20–35 ms before RustDDS matched the known reader) are skipped for
/// the reader: the writer is volatile, as micro-ROS's default. Run with `--participant-names off`, where the
/// client's writer lives in that default participant: with a participant per name, the new participant's
/// discovery with Cyclone sometimes outlasts the gate (1 run in ~10; docs/dds-engine.md, known limits).
/// The writer keeps the last 10 samples, as micro-ROS' default QoS: with the DDS default (keep-last 1) a
/// sample lost on the way may be replaced before the reader asks for it again (CI once lost 6, 7 and 8 of
/// the burst so, as eProsima's agent could with the same QoS). Even in the default participant Cyclone
/// sometimes learns of the new writer after the burst (the known limit in docs/dds-engine.md: 3 runs in 48
/// under two busy loops, 2 in 20 with a 2 s wait instead of 500 ms, so not discovery on our side), and its
/// volatile reader then skips all of it: a whole loss is tried once more.
#[test]
#[ignore = "needs XRCE_DDS_PEERS=<dir> (.ci/dds-peers.sh) and shared/dds-peers/netns.sh"]
fn burst_written_right_after_status_ok_reaches_a_running_cyclone_reader() {
    const COUNT: u32 = 10;
    // A burst lost whole is the known limit (docs/dds-engine.md): Cyclone learned of the writer after the burst
    // was written. One more try then; a partial or reordered burst, or a second whole loss, fails.
    let (confirmed, indices) = match burst_to_cyclone(18_904, COUNT) {
        (confirmed, indices) if !indices.is_empty() => (confirmed, indices),
        _ => {
            println!("Cyclone received none of the burst (it learned of the writer late): trying once more");
            burst_to_cyclone(18_907, COUNT)
        }
    };
    assert!(confirmed, "the agent acknowledged the burst");
    assert_eq!(indices, (1..=COUNT).collect::<Vec<_>>(), "every sample of the burst, in order");
}

/// One run of the burst test on `port`: whether the agent acknowledged the burst, and the indices Cyclone got.
fn burst_to_cyclone(port: u16, count: u32) -> (bool, Vec<u32>) {
    let _agent = AgentProcess::start_with(port, &["--participant-names", "off"]);
    let mut cyc = spawn(own_python("burst_reader.py", &["30", &count.to_string()]));
    // The reader is running once Cyclone has discovered the agent's participant (Python may take seconds to
    // start on a loaded machine: a fixed sleep was not enough); the agent's side of that discovery meanwhile.
    let mut lines = std::io::BufReader::new(cyc.stdout.take().expect("stdout")).lines();
    let ready = lines.next().and_then(Result::ok).unwrap_or_default();
    assert_eq!(ready, "ready", "the Cyclone reader saw the agent's participant");
    std::thread::sleep(Duration::from_millis(500));
    let transport = UdpTransport::new(IpProtocol::V4, "127.0.0.1", &port.to_string()).expect("udp");
    let mut out_buf = [0u8; BUF * 2];
    let mut in_buf = [0u8; BUF];
    let mut session = Session::new(transport, 0xAAAA_CCCC);
    session.create_session().expect("session");
    let out = session.create_output_reliable_stream(&mut out_buf, HISTORY * 2).expect("out stream");
    session.create_input_reliable_stream(&mut in_buf, HISTORY).expect("in stream");
    let p = object_id(1, ObjectKind::Participant);
    let t = object_id(1, ObjectKind::Topic);
    let publ = object_id(1, ObjectKind::Publisher);
    let dw = object_id(1, ObjectKind::DataWriter);
    let topic_xml = "<dds><topic><name>HelloWorldTopic</name><dataType>HelloWorld</dataType></topic></dds>";
    let dw_xml = "<dds><data_writer><topic><kind>NO_KEY</kind><name>HelloWorldTopic</name>\
                  <dataType>HelloWorld</dataType><historyQos><kind>KEEP_LAST</kind><depth>10</depth></historyQos>\
                  </topic><qos><reliability><kind>RELIABLE</kind></reliability>\
                  <durability><kind>VOLATILE</kind></durability></qos></data_writer></dds>";
    let reqs = [
        session.buffer_create_participant_xml(out, p, 0, PARTICIPANT_XML, REPLACE).expect("p"),
        session.buffer_create_topic_xml(out, t, p, topic_xml, REPLACE).expect("t"),
        session.buffer_create_publisher_xml(out, publ, p, "", REPLACE).expect("pub"),
        session.buffer_create_datawriter_xml(out, dw, publ, dw_xml, REPLACE).expect("dw"),
    ];
    let mut status = [0u8; 4];
    assert!(session.run_session_until_all_status(3000, &reqs, &mut status).expect("run"), "create: {status:?}");
    let t0 = Instant::now();
    for i in 1..=count {
        session.buffer_topic(out, dw, &hello_body(i, "first contact")).expect("write");
    }
    let confirmed = session.run_session_until_confirm_delivery(3000).expect("run");
    let held_ms = t0.elapsed().as_secs_f64() * 1e3;
    let rest: Vec<String> = lines.map_while(Result::ok).collect();
    finish(cyc, "cyclone sub");
    println!("{}", rest.join("\n"));
    let _ = session.delete_session();
    let indices: Vec<u32> =
        rest.iter().filter_map(|l| l.strip_prefix("received index=")?.trim().parse().ok()).collect();
    println!("burst confirmed={confirmed} in {held_ms:.1} ms; Cyclone received indices {indices:?}");
    (confirmed, indices)
}

/// The names of the DDS participants Cyclone discovers while two XRCE participants exist: one created by
/// XML (`<rtps><name>`, as PX4) and one in binary with its name as the QoS profile reference (as micro-ROS).
fn participant_names_seen(port: u16, extra: &[&str]) -> Vec<String> {
    let _agent = AgentProcess::start_with(port, extra);
    let transport = UdpTransport::new(IpProtocol::V4, "127.0.0.1", &port.to_string()).expect("udp");
    let mut out_buf = [0u8; BUF];
    let mut in_buf = [0u8; BUF];
    let mut session = Session::new(transport, 0xAAAA_DDDD);
    session.create_session().expect("session");
    let out = session.create_output_reliable_stream(&mut out_buf, HISTORY).expect("out stream");
    session.create_input_reliable_stream(&mut in_buf, HISTORY).expect("in stream");
    let reqs = [
        session
            .buffer_create_participant_xml(out, object_id(1, ObjectKind::Participant), 0, PARTICIPANT_XML, REPLACE)
            .expect("xml participant"),
        session
            .buffer_create_participant_bin(
                out,
                object_id(2, ObjectKind::Participant),
                0,
                Some("uros_named_node"),
                REPLACE,
            )
            .expect("binary participant"),
    ];
    let mut status = [0u8; 2];
    assert!(session.run_session_until_all_status(3000, &reqs, &mut status).expect("run"), "create: {status:?}");
    let (_, stdout) = finish(spawn(own_python("participant_names.py", &["2.5"])), "cyclone participants");
    let _ = session.delete_session();
    stdout.lines().filter_map(|l| l.strip_prefix("participant name=")).map(str::to_owned).collect()
}

/// As eProsima's agent, each XRCE participant name gets a DDS participant that announces it.
#[test]
#[ignore = "needs XRCE_DDS_PEERS=<dir> (.ci/dds-peers.sh) and shared/dds-peers/netns.sh"]
fn dds_participants_carry_the_xrce_participant_names() {
    let names = participant_names_seen(18_905, &[]);
    println!("participant names seen by Cyclone: {names:?}");
    if std::env::var("XRCE_DDS_ENGINE").as_deref() == Ok("rustdds") {
        // RustDDS 0.15.1 cannot announce a participant name: every XRCE participant shares one.
        assert!(!names.iter().any(|n| n == "default_xrce_participant" || n == "uros_named_node"), "{names:?}");
        return;
    }
    for expected in ["default_xrce_participant", "uros_named_node", "xrce-rs"] {
        assert!(names.iter().any(|n| n == expected), "{expected} among {names:?}");
    }
}

/// `--participant-names off`: every XRCE participant shares the default DDS participant, `xrce-rs`.
#[test]
#[ignore = "needs XRCE_DDS_PEERS=<dir> (.ci/dds-peers.sh) and shared/dds-peers/netns.sh"]
fn shared_participant_mode_announces_only_the_default_name() {
    let names = participant_names_seen(18_906, &["--participant-names", "off"]);
    println!("participant names seen by Cyclone: {names:?}");
    assert!(!names.iter().any(|n| n == "default_xrce_participant" || n == "uros_named_node"), "{names:?}");
}
