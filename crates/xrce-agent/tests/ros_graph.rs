//! The ROS 2 graph of the DDS middleware seen by a real ROS 2 node: a micro-ROS-like XRCE client (binary
//! participant named `talker`, a datawriter on `rt/chatter` and a datareader on `rt/cmd`) must appear in
//! rclpy's `get_node_names_and_namespaces()`, with its publisher and subscription by node, and disappear
//! within a second of its session's deletion.
//!
//! Needs rclpy (ROS 2 Jazzy, rmw_fastrtps_cpp) in the venv named by `XRCE_ROS_VENV`, and a loopback-only
//! network namespace:
//!
//!   XRCE_ROS_VENV=/work/ros/venv ../shared/dds-peers/netns.sh xros \
//!     cargo test -p xrce-agent --test ros_graph -- --ignored --nocapture

use std::io::{BufRead, BufReader};
use std::process::{Child, Command, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use xrce_agent::agent::AgentInstance;
use xrce_client::prelude::*;

fn require_loopback_namespace() {
    let ifaces: Vec<String> = std::fs::read_dir("/sys/class/net")
        .map(|d| d.filter_map(|e| e.ok()).map(|e| e.file_name().to_string_lossy().into_owned()).collect())
        .unwrap_or_default();
    assert!(ifaces == ["lo"], "ROS 2 tests must run inside a loopback-only namespace; interfaces here: {ifaces:?}");
}

/// Prints the graph as one JSON line whenever it changes, for `argv[1]` seconds.
const PROBE: &str = r#"
import json, sys, time
import rclpy
rclpy.init()
node = rclpy.create_node('graph_probe')
deadline = time.time() + float(sys.argv[1])
last = None
while time.time() < deadline:
    rclpy.spin_once(node, timeout_sec=0.02)
    nodes = sorted([n, ns] for n, ns in node.get_node_names_and_namespaces())
    topics = sorted([t, ty] for t, ty in node.get_topic_names_and_types())
    pubs, subs = [], []
    if ['talker', '/'] in nodes:
        try:
            pubs = sorted([t, ty] for t, ty in node.get_publisher_names_and_types_by_node('talker', '/'))
            subs = sorted([t, ty] for t, ty in node.get_subscriber_names_and_types_by_node('talker', '/'))
        except Exception as e:
            pubs = ['error: %s' % e]
    state = {'nodes': nodes, 'topics': topics, 'talker_pubs': pubs, 'talker_subs': subs}
    if state != last:
        print(json.dumps(dict(t=time.time(), **state)), flush=True)
        last = state
node.destroy_node()
rclpy.shutdown()
"#;

fn start_probe(venv: &str, secs: u32) -> (Child, mpsc::Receiver<String>) {
    let mut child = Command::new(format!("{venv}/bin/python"))
        .args(["-c", PROBE, &secs.to_string()])
        .env("LD_LIBRARY_PATH", format!("{venv}/lib"))
        .env("AMENT_PREFIX_PATH", venv)
        .env("RMW_IMPLEMENTATION", "rmw_fastrtps_cpp")
        .env("FASTDDS_BUILTIN_TRANSPORTS", "UDPv4")
        .stdout(Stdio::piped())
        .spawn()
        .expect("start rclpy");
    let out = child.stdout.take().expect("stdout");
    let (tx, rx) = mpsc::channel();
    std::thread::spawn(move || {
        for line in BufReader::new(out).lines().map_while(Result::ok) {
            if tx.send(line).is_err() {
                break;
            }
        }
    });
    (child, rx)
}

fn now_secs() -> f64 {
    SystemTime::now().duration_since(UNIX_EPOCH).map(|d| d.as_secs_f64()).unwrap_or(0.0)
}

/// Waits for a probe line satisfying `pred`; returns it with its JSON.
fn wait_line(rx: &mpsc::Receiver<String>, secs: u64, pred: impl Fn(&str) -> bool) -> Option<String> {
    let deadline = Instant::now() + Duration::from_secs(secs);
    while let Some(left) = deadline.checked_duration_since(Instant::now()) {
        match rx.recv_timeout(left) {
            Ok(line) => {
                println!("rclpy: {line}");
                if pred(&line) {
                    return Some(line);
                }
            }
            Err(_) => return None,
        }
    }
    None
}

fn line_time(line: &str) -> f64 {
    let rest = line.split("\"t\": ").nth(1).unwrap_or("0");
    rest.split([',', '}']).next().and_then(|s| s.trim().parse().ok()).unwrap_or(0.0)
}

/// A micro-ROS-like client: binary participant named `talker`, `rt/chatter` writer, `rt/cmd` reader, QoS
/// reliable, volatile, keep-last 10; deletes its session when `stop` says so and reports when.
fn talker(port: u16, stop: mpsc::Receiver<()>, deleted: mpsc::Sender<f64>) {
    let transport = UdpTransport::new(IpProtocol::V4, "127.0.0.1", &port.to_string()).expect("udp");
    let (mut out_buf, mut in_buf) = ([0u8; 4096], [0u8; 4096]);
    let mut s = Session::new(transport, 0x7A1C_0001);
    s.create_session().expect("session");
    let out = s.create_output_reliable_stream(&mut out_buf, 8).expect("out");
    let _in = s.create_input_reliable_stream(&mut in_buf, 8).expect("in");
    let part = object_id(1, ObjectKind::Participant);
    let qos = QoS {
        reliability: Reliability::Reliable,
        durability: Durability::Volatile,
        history: History::KeepLast,
        depth: 10,
    };
    let (tw, pubr, w) =
        (object_id(1, ObjectKind::Topic), object_id(1, ObjectKind::Publisher), object_id(1, ObjectKind::DataWriter));
    let (tr, subr, r) =
        (object_id(2, ObjectKind::Topic), object_id(1, ObjectKind::Subscriber), object_id(1, ObjectKind::DataReader));
    let flags = REUSE | REPLACE;
    let reqs = [
        s.buffer_create_participant_bin(out, part, 0, Some("talker"), flags).unwrap(),
        s.buffer_create_topic_bin(out, tw, part, "rt/chatter", "std_msgs::msg::dds_::String_", flags).unwrap(),
        s.buffer_create_publisher_bin(out, pubr, part, flags).unwrap(),
        s.buffer_create_datawriter_bin(out, w, pubr, tw, qos, flags).unwrap(),
        s.buffer_create_topic_bin(out, tr, part, "rt/cmd", "std_msgs::msg::dds_::String_", flags).unwrap(),
        s.buffer_create_subscriber_bin(out, subr, part, flags).unwrap(),
        s.buffer_create_datareader_bin(out, r, subr, tr, qos, flags).unwrap(),
    ];
    let mut status = [0u8; 7];
    assert!(s.run_session_until_all_status(2000, &reqs, &mut status).unwrap(), "create: {status:?}");
    while stop.try_recv().is_err() {
        s.run_session_time(20).unwrap();
    }
    let t = now_secs();
    s.delete_session().unwrap();
    deleted.send(t).unwrap();
}

#[test]
#[ignore = "starts DDS and rclpy: run inside shared/dds-peers/netns.sh with XRCE_ROS_VENV and --ignored"]
fn micro_ros_like_client_is_a_ros_node_until_deleted() {
    require_loopback_namespace();
    let venv = std::env::var("XRCE_ROS_VENV").expect("XRCE_ROS_VENV: a venv with rclpy (ROS 2 Jazzy)");
    let mut agent = AgentInstance::create(["xrce-agent", "udp4", "-p", "0", "-m", "dds"]).expect("agent");
    let port = agent.local_addr().expect("udp address").port();
    let (mut probe, lines) = start_probe(&venv, 30);
    // The probe's own node first: rclpy is up and discovering.
    wait_line(&lines, 15, |l| l.contains("graph_probe")).expect("rclpy probe started");

    let (stop_tx, stop_rx) = mpsc::channel();
    let (del_tx, del_rx) = mpsc::channel();
    let client = std::thread::spawn(move || talker(port, stop_rx, del_tx));
    let seen = wait_line(&lines, 10, |l| {
        l.contains(r#"["talker", "/"]"#)
            && l.contains(r#""talker_pubs": [["/chatter", ["std_msgs/msg/String"]]]"#)
            && l.contains(r#""talker_subs": [["/cmd", ["std_msgs/msg/String"]]]"#)
    });
    assert!(seen.is_some(), "node talker with /chatter and /cmd never appeared");

    stop_tx.send(()).unwrap();
    let deleted_at = del_rx.recv_timeout(Duration::from_secs(5)).expect("session deleted");
    let gone = wait_line(&lines, 5, |l| !l.contains(r#"["talker", "/"]"#)).expect("node talker never disappeared");
    let after = line_time(&gone) - deleted_at;
    println!("node gone {:.0} ms after the session's deletion", after * 1000.0);
    assert!(after < 1.0, "node disappeared {after:.3} s after deletion");
    // Not asserted: the endpoints' own disappearance is up to the DDS engine's disposal messages (see the
    // report of issue 11); printed so a run shows it.
    match wait_line(&lines, 3, |l| !l.contains("/chatter")) {
        Some(l) => println!("/chatter gone {:.0} ms after the deletion", (line_time(&l) - deleted_at) * 1000.0),
        None => println!("/chatter still listed 3 s after the deletion"),
    }
    client.join().unwrap();
    let _ = probe.kill();
    let _ = probe.wait();
    agent.stop().unwrap();
}
