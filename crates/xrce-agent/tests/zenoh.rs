//! The zenoh middleware seen by a ROS 2 node on rmw_zenoh's conventions: `tests/zenoh/peer.py` (eclipse-zenoh,
//! following rmw_zenoh 0.2.x's keys, tokens and attachments) against a micro-ROS-like XRCE client
//! (crates/xrce-client), through the agent (`-m zenoh`) and a Zenoh router (`peer.py router`). Data both
//! ways, liveliness tokens and their withdrawal, services both ways, transient local for a late joiner, the
//! type-hash error, and an agent started before its router.
//!
//! Needs the `zenoh` feature, a venv with eclipse-zenoh and xxhash (`XRCE_ZENOH_VENV`), the Jazzy ROS venv
//! for the type hashes (`XRCE_ROS_VENV`, used as AMENT_PREFIX_PATH), and a loopback-only namespace;
//! `.ci/zenoh.sh` prepares both venvs and runs:
//!
//!   XRCE_ZENOH_VENV=target/zenoh-venv XRCE_ROS_VENV=target/ros2-venv ../shared/dds-peers/netns.sh xzenoh \
//!     cargo test -p xrce-agent --features zenoh --test zenoh -- --ignored
#![cfg(feature = "zenoh")]

mod netns;

use std::io::{BufRead, BufReader, Write};
use std::path::PathBuf;
use std::process::{Child, ChildStdin, Command, Stdio};
use std::sync::mpsc::{channel, Receiver};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use serde_json::Value;
use xrce_client::prelude::*;

const STRING: &str = "std_msgs::msg::dds_::String_";
const STRING_HASH: &str = "RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18";
const SET_BOOL: &str = "std_srvs::srv::dds_::SetBool_";
const SET_BOOL_HASH: &str = "RIHS01_abe9e4bb6b41b40e6789712c00ec8871923e089af3f667a79992a428cff2da0a";
const DIAGNOSTICS: &str = "diagnostic_msgs::msg::dds_::DiagnosticArray_";
const DIAGNOSTICS_HASH: &str = "RIHS01_5a8a36efb05fb25070fa0fb3810290c0e6cd4862b54a8fb975a1ee8dc55a333e";
/// How long any awaited event may take before the test reports it missing.
const WAIT: Duration = Duration::from_secs(20);

fn venv(var: &str) -> PathBuf {
    PathBuf::from(std::env::var_os(var).unwrap_or_else(|| panic!("set {var} (see .ci/zenoh.sh)")))
}

fn peer_script() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/zenoh/peer.py")
}

/// A ROS 2 string's CDR body (what an XRCE client writes).
fn ros_string(s: &str) -> Vec<u8> {
    let mut out = u32::try_from(s.len() + 1).unwrap().to_le_bytes().to_vec();
    out.extend_from_slice(s.as_bytes());
    out.push(0);
    out
}

/// A process killed with the test.
struct Killed(Child);

impl Drop for Killed {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// `peer.py node`: one command a line, one JSON answer a line.
struct Peer {
    _child: Killed,
    stdin: ChildStdin,
    lines: Receiver<String>,
}

impl Peer {
    fn start(endpoint: &str) -> Self {
        let mut child = Command::new(venv("XRCE_ZENOH_VENV").join("bin/python"))
            .arg(peer_script())
            .args(["node", endpoint])
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .spawn()
            .expect("peer.py starts");
        let stdin = child.stdin.take().unwrap();
        let stdout = child.stdout.take().unwrap();
        let (tx, lines) = channel();
        std::thread::spawn(move || {
            for line in BufReader::new(stdout).lines().map_while(Result::ok) {
                let _ = tx.send(line);
            }
        });
        let mut peer = Self { _child: Killed(child), stdin, lines };
        assert_eq!(peer.answer()["ready"], true);
        peer
    }

    fn answer(&mut self) -> Value {
        let line = self.lines.recv_timeout(WAIT * 3).expect("peer.py answers");
        serde_json::from_str(&line).expect("JSON line")
    }

    fn cmd(&mut self, line: &str) -> Value {
        writeln!(self.stdin, "{line}").unwrap();
        self.answer()
    }

    /// The token containing `part`, once present.
    fn token(&mut self, part: &str) -> String {
        let v = self.cmd(&format!("wait_token {part} present"));
        assert_eq!(v["ok"], true, "no token with {part}: {v}");
        v["tokens"][0].as_str().unwrap().to_owned()
    }

    fn no_token(&mut self, part: &str) {
        let v = self.cmd(&format!("wait_token {part} absent"));
        assert_eq!(v["ok"], true, "token with {part} not withdrawn: {v}");
    }

    fn gid(&mut self, token: &str) -> String {
        self.cmd(&format!("gid {token}"))["gid"].as_str().unwrap().to_owned()
    }
}

/// A router, the agent (its log in a file) and the peer; `router_port` 0: no router.
struct Bed {
    peer: Option<Peer>,
    _agent: Killed,
    _router: Option<Killed>,
    log: PathBuf,
    endpoint: String,
    xrce_port: u16,
}

fn start_router(endpoint: &str) -> Killed {
    let mut child = Command::new(venv("XRCE_ZENOH_VENV").join("bin/python"))
        .arg(peer_script())
        .args(["router", endpoint])
        .stdout(Stdio::piped())
        .spawn()
        .expect("router starts");
    let mut first = String::new();
    BufReader::new(child.stdout.take().unwrap()).read_line(&mut first).unwrap();
    assert!(first.contains("router"), "router: {first}");
    Killed(child)
}

impl Bed {
    /// `config`: the agent's `--zenoh-config` connects to the router at `endpoint`; without it the agent
    /// runs rmw_zenoh's defaults (the router at tcp/localhost:7447).
    fn start(name: &str, endpoint: &str, xrce_port: u16, with_router: bool, config: bool, extra: &[&str]) -> Self {
        netns::require_loopback_namespace();
        let router = with_router.then(|| start_router(endpoint));
        let dir = std::env::temp_dir().join(format!("xrce-zenoh-{name}-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let log = dir.join("agent.log");
        let mut cmd = Command::new(env!("CARGO_BIN_EXE_xrce-agent"));
        cmd.args(["udp4", "-p", &xrce_port.to_string(), "-m", "zenoh", "-v", "4"])
            .env("AMENT_PREFIX_PATH", venv("XRCE_ROS_VENV"))
            .env_remove("ZENOH_SESSION_CONFIG_URI")
            .env_remove("ROS_DOMAIN_ID")
            .args(extra)
            .stdout(std::fs::File::create(&log).unwrap())
            .stderr(Stdio::null());
        if config {
            let file = dir.join("zenoh.json5");
            let text = format!(
                r#"{{ mode: "peer", connect: {{ endpoints: ["{endpoint}"] }}, listen: {{ endpoints: ["tcp/127.0.0.1:0"] }},
                    scouting: {{ multicast: {{ enabled: false }} }} }}"#
            );
            std::fs::write(&file, text).unwrap();
            cmd.arg("--zenoh-config").arg(&file);
        }
        let agent = Killed(cmd.spawn().expect("agent starts"));
        let peer = with_router.then(|| Peer::start(endpoint));
        Self { peer, _agent: agent, _router: router, log, endpoint: endpoint.to_owned(), xrce_port }
    }

    fn peer(&mut self) -> &mut Peer {
        self.peer.as_mut().expect("a peer")
    }

    fn log(&self) -> String {
        std::fs::read_to_string(&self.log).unwrap_or_default()
    }
}

/// What the XRCE client's callbacks received.
#[derive(Default)]
struct Got {
    data: Vec<Vec<u8>>,
    replies: Vec<Vec<u8>>,
}

/// Callbacks: records data and replies; a replier answers `[9, 9]` to every request.
#[derive(Default)]
struct Recorder {
    got: Arc<Mutex<Got>>,
    reply_on: Option<(StreamId, ObjectId)>,
}

impl Callbacks for Recorder {
    fn on_topic(&mut self, _: &mut Outputs<'_, '_>, _: ObjectId, _: u16, _: StreamId, data: &[u8]) {
        self.got.lock().unwrap().data.push(data.to_vec());
    }
    fn on_request(&mut self, out: &mut Outputs<'_, '_>, _: ObjectId, _: u16, id: &SampleIdentity, _: &[u8]) {
        if let Some((stream, replier)) = self.reply_on {
            out.buffer_reply(stream, replier, id, &[9, 9]).unwrap();
        }
    }
    fn on_reply(&mut self, _: &mut Outputs<'_, '_>, _: ObjectId, _: u16, _: u16, data: &[u8]) {
        self.got.lock().unwrap().replies.push(data.to_vec());
    }
}

const RELIABLE: QoS =
    QoS { reliability: Reliability::Reliable, durability: Durability::Volatile, history: History::KeepLast, depth: 10 };
const FLAGS: u8 = REUSE | REPLACE;

fn udp(port: u16) -> UdpTransport {
    UdpTransport::new(IpProtocol::V4, "127.0.0.1", &port.to_string()).expect("udp")
}

/// A session of client `key` with a reliable stream each way, as micro-ROS opens one.
fn xrce_session<'b>(
    port: u16,
    key: u32,
    out_buf: &'b mut [u8],
    in_buf: &'b mut [u8],
) -> (Session<'b, UdpTransport, StdClock>, StreamId, StreamId) {
    let mut s = Session::new(udp(port), key);
    s.create_session().expect("XRCE session");
    let out = s.create_output_reliable_stream(out_buf, 8).unwrap();
    let input = s.create_input_reliable_stream(in_buf, 8).unwrap();
    (s, out, input)
}

/// Runs `session` until `done` or [`WAIT`].
fn run_until<T: Transport, C: Callbacks>(s: &mut Session<'_, T, StdClock, C>, done: impl Fn() -> bool) -> bool {
    let start = Instant::now();
    while !done() && start.elapsed() < WAIT {
        s.run_session_time(20).unwrap();
    }
    done()
}

#[test]
#[ignore = "needs the zenoh venvs and a loopback-only namespace (.ci/zenoh.sh)"]
fn data_both_ways_with_rmw_zenoh_tokens_attachments_and_withdrawal() {
    let mut bed = Bed::start("data", "tcp/127.0.0.1:17447", 17888, true, true, &[]);
    let up_key = format!("0/chatter/{STRING}/{STRING_HASH}");
    let down_key = format!("0/cmd/{STRING}/{STRING_HASH}");
    // The ROS subscription exists before the client: the first sample written after STATUS OK must reach it.
    assert_eq!(bed.peer().cmd(&format!("sub up {up_key}"))["ok"], true);

    let (mut out_buf, mut in_buf) = ([0u8; 4096], [0u8; 4096]);
    let (mut s, out, input) = xrce_session(bed.xrce_port, 0x0A0B_0C01, &mut out_buf, &mut in_buf);
    let (part, t1, t2) =
        (object_id(1, ObjectKind::Participant), object_id(1, ObjectKind::Topic), object_id(2, ObjectKind::Topic));
    let (publ, subs) = (object_id(1, ObjectKind::Publisher), object_id(1, ObjectKind::Subscriber));
    let (w, r) = (object_id(1, ObjectKind::DataWriter), object_id(1, ObjectKind::DataReader));
    let reqs = [
        s.buffer_create_participant_bin(out, part, 0, Some("robot1/talker"), FLAGS).unwrap(),
        s.buffer_create_topic_bin(out, t1, part, "rt/chatter", STRING, FLAGS).unwrap(),
        s.buffer_create_publisher_bin(out, publ, part, FLAGS).unwrap(),
        s.buffer_create_datawriter_bin(out, w, publ, t1, RELIABLE, FLAGS).unwrap(),
        s.buffer_create_topic_bin(out, t2, part, "rt/cmd", STRING, FLAGS).unwrap(),
        s.buffer_create_subscriber_bin(out, subs, part, FLAGS).unwrap(),
        s.buffer_create_datareader_bin(out, r, subs, t2, RELIABLE, FLAGS).unwrap(),
    ];
    let mut status = [0u8; 7];
    assert!(s.run_session_until_all_status(5000, &reqs, &mut status).unwrap(), "create: {status:?}");
    for i in 1..=3 {
        s.buffer_topic(out, w, &ros_string(&format!("hello {i}"))).unwrap();
    }
    assert!(s.run_session_until_confirm_delivery(5000).unwrap());

    let peer = bed.peer();
    let node = peer.token("/NN/%/%robot1/talker");
    assert!(node.starts_with("@ros2_lv/0/"), "{node}");
    let pub_token = peer.token(&format!("/MP/%/%robot1/talker/%chatter/{STRING}/{STRING_HASH}/::,10:,:,:,,"));
    let sub_token = peer.token(&format!("/MS/%/%robot1/talker/%cmd/{STRING}/{STRING_HASH}/::,10:,:,:,,"));
    let zid = node.split('/').nth(2).unwrap();
    assert!(pub_token.starts_with(&format!("@ros2_lv/0/{zid}/")), "one session: {pub_token}");

    let up = peer.cmd("take up 3");
    assert_eq!(up["ok"], true, "samples up: {up}");
    // First contact, reported (not asserted): the agent's write of the first sample to its arrival at ROS.
    let first = &up["samples"][0];
    let (sent, received) = (first["attachment"]["ts"].as_i64().unwrap(), first["received_ns"].as_i64().unwrap());
    println!(
        "ZENOH-FIRST-CONTACT first sample after STATUS OK: {:.2} ms from the agent's put to the ROS subscription",
        (received - sent) as f64 / 1e6
    );
    let gid = peer.gid(&pub_token);
    for (i, sample) in up["samples"].as_array().unwrap().iter().enumerate() {
        let mut payload = vec![0, 1, 0, 0];
        payload.extend(ros_string(&format!("hello {}", i + 1)));
        assert_eq!(sample["payload"], hex(&payload), "{sample}");
        assert_eq!(sample["attachment"]["seq"], i + 1, "{sample}");
        assert_eq!(sample["attachment"]["gid"], gid.as_str(), "{sample}");
    }

    // ROS → XRCE.
    let peer_pub = format!(
        "@ros2_lv/0/{}/0/1/MP/%/%/zenoh_peer/%cmd/{STRING}/{STRING_HASH}/::,10:,:,:,,",
        peer.cmd("zid")["zid"].as_str().unwrap()
    );
    assert_eq!(peer.cmd(&format!("pub {down_key} {peer_pub} {}", hex(&ros_string("go")))).get("ok").unwrap(), true);
    let got = Arc::new(Mutex::new(Got::default()));
    let mut s = s.with_callbacks(Recorder { got: got.clone(), reply_on: None });
    let control = DeliveryControl { max_samples: DeliveryControl::UNLIMITED, ..Default::default() };
    s.buffer_request_data(out, r, input, Some(&control)).unwrap();
    assert!(run_until(&mut s, || !got.lock().unwrap().data.is_empty()), "no sample from ROS");
    assert_eq!(got.lock().unwrap().data[0], ros_string("go"));

    // Withdrawal: the writer's token with the writer, the node's and the reader's with the session.
    let del = s.buffer_delete_entity(out, w).unwrap();
    let mut st = [0u8; 1];
    assert!(s.run_session_until_all_status(5000, &[del], &mut st).unwrap());
    let peer = bed.peer();
    peer.no_token("/MP/%/%robot1/talker/");
    peer.token("/MS/%/%robot1/talker/");
    assert!(s.delete_session().unwrap());
    let peer = bed.peer();
    peer.no_token("/NN/%/%robot1/talker");
    peer.no_token(&sub_token);
}

#[test]
#[ignore = "needs the zenoh venvs and a loopback-only namespace (.ci/zenoh.sh)"]
fn services_both_ways_matched_by_sequence_number_and_client_gid() {
    let mut bed = Bed::start("services", "tcp/127.0.0.1:17448", 17889, true, true, &[]);
    let remote_key = format!("0/remote_flag/{SET_BOOL}/{SET_BOOL_HASH}");
    let local_key = format!("0/set_flag/{SET_BOOL}/{SET_BOOL_HASH}");
    let peer_zid = bed.peer().cmd("zid")["zid"].as_str().unwrap().to_owned();
    let server_token =
        format!("@ros2_lv/0/{peer_zid}/0/2/SS/%/%/zenoh_peer/%remote_flag/{SET_BOOL}/{SET_BOOL_HASH}/::,10:,:,:,,");
    let client_token =
        format!("@ros2_lv/0/{peer_zid}/0/3/SC/%/%/zenoh_peer/%set_flag/{SET_BOOL}/{SET_BOOL_HASH}/::,10:,:,:,,");
    assert_eq!(bed.peer().cmd(&format!("serve {remote_key} {server_token}"))["ok"], true);

    let (mut out_buf, mut in_buf) = ([0u8; 4096], [0u8; 4096]);
    let (mut s, out, input) = xrce_session(bed.xrce_port, 0x0A0B_0C02, &mut out_buf, &mut in_buf);
    let part = object_id(1, ObjectKind::Participant);
    let (replier, requester) = (object_id(1, ObjectKind::Replier), object_id(1, ObjectKind::Requester));
    let names = |service: &'static str, rq: &'static str, rr: &'static str| ServiceNames {
        service_name: service,
        request_type: "std_srvs::srv::dds_::SetBool_Request_",
        reply_type: "std_srvs::srv::dds_::SetBool_Response_",
        request_topic_name: rq,
        reply_topic_name: rr,
    };
    let reqs = [
        s.buffer_create_participant_bin(out, part, 0, Some("flags"), FLAGS).unwrap(),
        s.buffer_create_replier_bin(
            out,
            replier,
            part,
            &names("set_flag", "rq/set_flagRequest", "rr/set_flagReply"),
            RELIABLE,
            FLAGS,
        )
        .unwrap(),
        s.buffer_create_requester_bin(
            out,
            requester,
            part,
            &names("remote_flag", "rq/remote_flagRequest", "rr/remote_flagReply"),
            RELIABLE,
            FLAGS,
        )
        .unwrap(),
    ];
    let mut status = [0u8; 3];
    assert!(s.run_session_until_all_status(5000, &reqs, &mut status).unwrap(), "create: {status:?}");
    let peer = bed.peer();
    let ss = peer.token(&format!("/SS/%/%/flags/%set_flag/{SET_BOOL}/{SET_BOOL_HASH}/"));
    let sc = peer.token(&format!("/SC/%/%/flags/%remote_flag/{SET_BOOL}/{SET_BOOL_HASH}/"));
    assert!(ss.ends_with("/::,10:,:,:,,") && sc.ends_with("/::,10:,:,:,,"), "{ss} {sc}");

    let got = Arc::new(Mutex::new(Got::default()));
    let mut s = s.with_callbacks(Recorder { got: got.clone(), reply_on: Some((out, replier)) });
    let control = DeliveryControl { max_samples: DeliveryControl::UNLIMITED, ..Default::default() };
    s.buffer_request_data(out, replier, input, Some(&control)).unwrap();
    s.buffer_request_data(out, requester, input, Some(&control)).unwrap();

    // XRCE client → ROS server: the reply comes back to the XRCE requester; the server saw our attachment.
    s.buffer_request(out, requester, &[1, 2, 3]).unwrap();
    assert!(run_until(&mut s, || !got.lock().unwrap().replies.is_empty()), "no reply from the ROS server");
    assert_eq!(got.lock().unwrap().replies[0], vec![3, 2, 1]);
    let peer = bed.peer();
    let served = peer.cmd("served 1");
    assert_eq!(served["requests"][0]["attachment"]["seq"], 1, "{served}");
    assert_eq!(served["requests"][0]["attachment"]["gid"], peer.gid(&sc).as_str(), "{served}");

    // ROS client → XRCE server: the peer's call is answered while the XRCE session runs.
    // As a ROS client waits for its service (the graph, i.e. the server's token) before it calls.
    let call = std::thread::spawn({
        let endpoint = bed.endpoint.clone();
        let (client_token, local_key, ss) = (client_token.clone(), local_key.clone(), ss.clone());
        move || {
            let mut client = Peer::start(&endpoint);
            client.token(&ss);
            client.cmd(&format!("call {local_key} {client_token} 7 0101"))
        }
    });
    assert!(run_until(&mut s, || call.is_finished()));
    let call = call.join().unwrap();
    assert_eq!(call["ok"], true, "{call}");
    let reply = &call["replies"][0];
    assert_eq!(reply["payload"], "000100000909", "{call}");
    assert_eq!(reply["attachment"]["seq"], 7, "{call}");
    assert_eq!(reply["attachment"]["gid"], bed.peer().gid(&client_token).as_str(), "{call}");

    // `--ros-diagnostics` (on by default): the agent's node publishes /diagnostics, one status per client.
    let peer = bed.peer();
    // Its node is `xrce_agent_<its zid>`, so that a fleet's agents do not share one node name.
    let token = peer.token(&format!("/%diagnostics/{DIAGNOSTICS}/{DIAGNOSTICS_HASH}/"));
    let zid = token.split('/').nth(2).unwrap();
    assert!(token.contains(&format!("/MP/%/%/xrce_agent_{zid}/%diagnostics/")), "{token}");
    assert_eq!(peer.cmd(&format!("sub diag 0/diagnostics/{DIAGNOSTICS}/{DIAGNOSTICS_HASH}"))["ok"], true);
    let diag = peer.cmd("take diag 1");
    assert_eq!(diag["ok"], true, "{diag}");
    assert!(diag["samples"][0]["payload"].as_str().unwrap().contains(&hex(b"flags")), "the client's node: {diag}");
}

#[test]
#[ignore = "needs the zenoh venvs and a loopback-only namespace (.ci/zenoh.sh)"]
fn transient_local_reaches_a_late_joiner_and_an_unknown_type_is_refused_by_name() {
    let mut bed = Bed::start("latched", "tcp/127.0.0.1:17449", 17890, true, true, &[]);
    let (mut out_buf, mut in_buf) = ([0u8; 4096], [0u8; 4096]);
    let (mut s, out, _in) = xrce_session(bed.xrce_port, 0x0A0B_0C03, &mut out_buf, &mut in_buf);
    let (part, t1, t2) =
        (object_id(1, ObjectKind::Participant), object_id(1, ObjectKind::Topic), object_id(2, ObjectKind::Topic));
    let (publ, w) = (object_id(1, ObjectKind::Publisher), object_id(1, ObjectKind::DataWriter));
    let latched = QoS { durability: Durability::TransientLocal, depth: 5, ..RELIABLE };
    let reqs = [
        s.buffer_create_participant_bin(out, part, 0, Some("latcher"), FLAGS).unwrap(),
        s.buffer_create_topic_bin(out, t1, part, "rt/map", STRING, FLAGS).unwrap(),
        s.buffer_create_publisher_bin(out, publ, part, FLAGS).unwrap(),
        s.buffer_create_datawriter_bin(out, w, publ, t1, latched, FLAGS).unwrap(),
    ];
    let mut status = [0u8; 4];
    assert!(s.run_session_until_all_status(5000, &reqs, &mut status).unwrap(), "create: {status:?}");
    for i in 1..=3 {
        s.buffer_topic(out, w, &ros_string(&format!("map {i}"))).unwrap();
    }
    assert!(s.run_session_until_confirm_delivery(5000).unwrap());

    // The subscription joins after the samples were written, as a transient local one rmw_zenoh declares.
    let peer = bed.peer();
    let token = peer.token(&format!("/MP/%/%/latcher/%map/{STRING}/{STRING_HASH}/:1:,5:,:,:,,"));
    let key = format!("0/map/{STRING}/{STRING_HASH}");
    assert_eq!(peer.cmd(&format!("sub late {key} transient_local 5"))["ok"], true);
    let late = peer.cmd("take late 3");
    assert_eq!(late["ok"], true, "late joiner: {late}");
    let gid = peer.gid(&token);
    for (i, sample) in late["samples"].as_array().unwrap().iter().take(3).enumerate() {
        assert!(sample["payload"].as_str().unwrap().ends_with(&hex(format!("map {}\0", i + 1).as_bytes())));
        assert_eq!(sample["attachment"]["gid"], gid.as_str());
    }

    // A type ROS has no description of: refused at creation, the log names it and the fix.
    let missing = "px4_msgs::msg::dds_::NoSuchThing_";
    let req = s.buffer_create_topic_bin(out, t2, part, "rt/fmu/out/thing", missing, FLAGS).unwrap();
    let mut st = [0u8; 1];
    s.run_session_until_all_status(5000, &[req], &mut st).unwrap();
    assert_ne!(st[0], 0, "STATUS OK for a type without hash");
    let log = bed.log();
    assert!(log.contains(missing) && log.contains("AMENT_PREFIX_PATH") && log.contains("setup.bash"), "{log}");
}

#[test]
#[ignore = "needs the zenoh venvs and a loopback-only namespace (.ci/zenoh.sh)"]
fn without_a_router_the_agent_serves_says_how_to_start_one_and_joins_it_later() {
    // rmw_zenoh's defaults: the router at tcp/localhost:7447, not running yet.
    let mut bed = Bed::start("norouter", "tcp/localhost:7447", 17891, false, false, &["--metrics", "127.0.0.1:19464"]);
    let (mut out_buf, mut in_buf) = ([0u8; 4096], [0u8; 4096]);
    let (mut s, out, _in) = xrce_session(bed.xrce_port, 0x0A0B_0C04, &mut out_buf, &mut in_buf);
    let part = object_id(1, ObjectKind::Participant);
    let req = s.buffer_create_participant_bin(out, part, 0, Some("early_bird"), FLAGS).unwrap();
    let mut st = [0u8; 1];
    assert!(s.run_session_until_all_status(5000, &[req], &mut st).unwrap(), "create: {st:?}");
    let start = Instant::now();
    while !bed.log().contains("rmw_zenohd") && start.elapsed() < WAIT {
        s.run_session_time(100).unwrap();
    }
    let log = bed.log();
    assert_eq!(log.matches("no Zenoh router reachable").count(), 1, "{log}");
    assert!(log.contains("ros2 run rmw_zenoh_cpp rmw_zenohd"), "{log}");
    // `--metrics` on Zenoh: the client and its participant, from the snapshots the core publishes.
    let metrics = |s: &mut Session<'_, UdpTransport, StdClock>| {
        let start = Instant::now();
        loop {
            let text = http_get("127.0.0.1:19464", "/metrics");
            if text.contains("xrce_agent_middleware_participants 1") || start.elapsed() > WAIT {
                return text;
            }
            s.run_session_time(100).unwrap();
        }
    };
    let text = metrics(&mut s);
    assert!(text.contains("xrce_agent_clients 1") && text.contains("xrce_agent_middleware_participants 1"), "{text}");

    bed._router = Some(start_router(&bed.endpoint));
    bed.peer = Some(Peer::start(&bed.endpoint));
    bed.peer().token("/NN/%/%/early_bird");
}

/// The body of `GET path` (empty when the server does not answer).
fn http_get(addr: &str, path: &str) -> String {
    use std::io::Read;
    let Ok(mut stream) = std::net::TcpStream::connect(addr) else { return String::new() };
    stream.set_read_timeout(Some(WAIT)).unwrap();
    write!(stream, "GET {path} HTTP/1.1\r\nHost: test\r\n\r\n").unwrap();
    let mut answer = String::new();
    let _ = stream.read_to_string(&mut answer);
    answer
}

fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}
