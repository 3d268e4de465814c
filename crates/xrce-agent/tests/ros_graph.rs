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

mod netns;
use netns::require_loopback_namespace;

use std::io::{BufRead, BufReader};
use std::process::{Child, Command, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use xrce_agent::agent::AgentInstance;
use xrce_client::prelude::*;

/// Prints the graph as one compact JSON line whenever it changes, for `argv[1]` seconds: the nodes and, per
/// node other than the probe (key `namespace|name`), its publishers, subscriptions and services.
const PROBE: &str = r#"
import json, sys, time
import rclpy
rclpy.init()
node = rclpy.create_node('graph_probe')
deadline = time.time() + float(sys.argv[1])
last = None
def pairs(l):
    return sorted([n, sorted(t)] for n, t in l)
while time.time() < deadline:
    rclpy.spin_once(node, timeout_sec=0.02)
    nodes = sorted([ns, n] for n, ns in node.get_node_names_and_namespaces())
    by_node = {}
    for ns, n in nodes:
        if n == 'graph_probe':
            continue
        try:
            by_node[ns + '|' + n] = {
                'pubs': pairs(node.get_publisher_names_and_types_by_node(n, ns)),
                'subs': pairs(node.get_subscriber_names_and_types_by_node(n, ns)),
                'srvs': pairs(node.get_service_names_and_types_by_node(n, ns)),
            }
        except Exception as e:
            by_node[ns + '|' + n] = 'error: %s' % e
    state = {'nodes': nodes, 'by_node': by_node}
    if state != last:
        print(json.dumps(dict(t=time.time(), **state), sort_keys=True, separators=(',', ':')), flush=True)
        last = state
node.destroy_node()
rclpy.shutdown()
"#;

fn start_probe(venv: &str, secs: u32) -> (Child, mpsc::Receiver<String>) {
    let mut cmd = Command::new(format!("{venv}/bin/python"));
    netns::ros_node_transports(&mut cmd);
    let mut child = cmd
        .args(["-c", PROBE, &secs.to_string()])
        .env("LD_LIBRARY_PATH", format!("{venv}/lib"))
        .env("AMENT_PREFIX_PATH", venv)
        .env("RMW_IMPLEMENTATION", "rmw_fastrtps_cpp")
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
    let rest = line.split("\"t\":").nth(1).unwrap_or("0");
    rest.split([',', '}']).next().and_then(|s| s.trim().parse().ok()).unwrap_or(0.0)
}

/// The clients of the test, as micro-ROS and PX4 create their entities.
#[derive(Clone, Copy)]
enum Kind {
    /// micro-ROS: binary participant `talker`, `rt/chatter` writer and `rt/cmd` reader (reliable,
    /// volatile, keep-last 10).
    Talker,
    /// PX4: XML participant `px4_micro_xrce_dds`, binary best-effort transient-local depth-0 writer.
    Px4,
    /// micro-ROS service server in a namespace: participant `/robot1/adder`, replier `/robot1/set_flag`.
    Adder,
}

/// Runs one client of `kind` until `stop` says so, then deletes its session and reports when.
fn client(kind: Kind, port: u16, key: u32, stop: mpsc::Receiver<()>, deleted: mpsc::Sender<f64>) {
    let transport = UdpTransport::new(IpProtocol::V4, "127.0.0.1", &port.to_string()).expect("udp");
    let (mut out_buf, mut in_buf) = ([0u8; 4096], [0u8; 4096]);
    let mut s = Session::new(transport, key);
    s.create_session().expect("session");
    let out = s.create_output_reliable_stream(&mut out_buf, 8).expect("out");
    let _in = s.create_input_reliable_stream(&mut in_buf, 8).expect("in");
    let part = object_id(1, ObjectKind::Participant);
    let flags = REUSE | REPLACE;
    let reliable = QoS {
        reliability: Reliability::Reliable,
        durability: Durability::Volatile,
        history: History::KeepLast,
        depth: 10,
    };
    let (t1, t2) = (object_id(1, ObjectKind::Topic), object_id(2, ObjectKind::Topic));
    let (publ, subs) = (object_id(1, ObjectKind::Publisher), object_id(1, ObjectKind::Subscriber));
    let (w, r) = (object_id(1, ObjectKind::DataWriter), object_id(1, ObjectKind::DataReader));
    let string = "std_msgs::msg::dds_::String_";
    let reqs: Vec<u16> = match kind {
        Kind::Talker => vec![
            s.buffer_create_participant_bin(out, part, 0, Some("talker"), flags).unwrap(),
            s.buffer_create_topic_bin(out, t1, part, "rt/chatter", string, flags).unwrap(),
            s.buffer_create_publisher_bin(out, publ, part, flags).unwrap(),
            s.buffer_create_datawriter_bin(out, w, publ, t1, reliable, flags).unwrap(),
            s.buffer_create_topic_bin(out, t2, part, "rt/cmd", string, flags).unwrap(),
            s.buffer_create_subscriber_bin(out, subs, part, flags).unwrap(),
            s.buffer_create_datareader_bin(out, r, subs, t2, reliable, flags).unwrap(),
        ],
        Kind::Px4 => {
            let xml = "<dds><participant><rtps><name>px4_micro_xrce_dds</name></rtps></participant></dds>";
            let be = QoS {
                reliability: Reliability::BestEffort,
                durability: Durability::TransientLocal,
                history: History::KeepLast,
                depth: 0,
            };
            let ty = "px4_msgs::msg::dds_::VehicleStatus_";
            vec![
                s.buffer_create_participant_xml(out, part, 0, xml, flags).unwrap(),
                s.buffer_create_topic_bin(out, t1, part, "rt/fmu/out/vehicle_status", ty, flags).unwrap(),
                s.buffer_create_publisher_bin(out, publ, part, flags).unwrap(),
                s.buffer_create_datawriter_bin(out, w, publ, t1, be, flags).unwrap(),
            ]
        }
        Kind::Adder => {
            let names = ServiceNames {
                service_name: "robot1/set_flag",
                request_type: "std_srvs::srv::dds_::SetBool_Request_",
                reply_type: "std_srvs::srv::dds_::SetBool_Response_",
                request_topic_name: "rq/robot1/set_flagRequest",
                reply_topic_name: "rr/robot1/set_flagReply",
            };
            let replier = object_id(1, ObjectKind::Replier);
            vec![
                s.buffer_create_participant_bin(out, part, 0, Some("/robot1/adder"), flags).unwrap(),
                s.buffer_create_replier_bin(out, replier, part, &names, reliable, flags).unwrap(),
            ]
        }
    };
    let mut status = vec![0u8; reqs.len()];
    assert!(s.run_session_until_all_status(2000, &reqs, &mut status).unwrap(), "create: {status:?}");
    while stop.try_recv().is_err() {
        // Errors once the agent is gone (end of the test).
        if s.run_session_time(20).is_err() {
            std::thread::sleep(Duration::from_millis(20));
        }
    }
    let t = now_secs();
    // Fails once the agent is gone (end of the test): nothing to check then.
    let _ = s.delete_session_retries(2);
    deleted.send(t).unwrap();
}

struct Running {
    stop: mpsc::Sender<()>,
    deleted: mpsc::Receiver<f64>,
    thread: std::thread::JoinHandle<()>,
}

fn start(kind: Kind, port: u16, key: u32) -> Running {
    let (stop, stop_rx) = mpsc::channel();
    let (del_tx, deleted) = mpsc::channel();
    let thread = std::thread::spawn(move || client(kind, port, key, stop_rx, del_tx));
    Running { stop, deleted, thread }
}

impl Running {
    /// Deletes the client's session; returns when (Unix time, seconds).
    fn delete(self) -> f64 {
        self.stop.send(()).unwrap();
        let t = self.deleted.recv_timeout(Duration::from_secs(10)).expect("session deleted");
        self.thread.join().unwrap();
        t
    }
}

const TALKER: &str =
    r#""/|talker":{"pubs":[["/chatter",["std_msgs/msg/String"]]],"srvs":[],"subs":[["/cmd",["std_msgs/msg/String"]]]}"#;
const PX4: &str = r#""/|px4_micro_xrce_dds":{"pubs":[["/fmu/out/vehicle_status",["px4_msgs/msg/VehicleStatus"]]]"#;
const ADDER: &str = r#""/robot1|adder":{"pubs":[],"srvs":[["/robot1/set_flag",["std_srvs/srv/SetBool"]]]"#;

#[test]
#[ignore = "starts DDS and rclpy: run inside shared/dds-peers/netns.sh with XRCE_ROS_VENV and --ignored"]
fn micro_ros_and_px4_like_clients_are_ros_nodes_until_deleted() {
    require_loopback_namespace();
    let venv = std::env::var("XRCE_ROS_VENV").expect("XRCE_ROS_VENV: a venv with rclpy (ROS 2 Jazzy)");
    let mut agent = AgentInstance::create(["xrce-agent", "udp4", "-p", "0", "-m", "dds"]).expect("agent");
    let port = agent.local_addr().expect("udp address").port();
    let (mut probe, lines) = start_probe(&venv, 30);
    // The probe's own node first: rclpy is up and discovering.
    wait_line(&lines, 15, |l| l.contains("graph_probe")).expect("rclpy probe started");

    let talker = start(Kind::Talker, port, 0x7A1C_0001);
    let px4 = start(Kind::Px4, port, 0x7A1C_0002);
    let adder = start(Kind::Adder, port, 0x7A1C_0003);
    let seen = wait_line(&lines, 10, |l| l.contains(TALKER) && l.contains(PX4) && l.contains(ADDER));
    assert!(seen.is_some(), "the three nodes never appeared with their endpoints");

    let deleted_at = talker.delete();
    let gone = wait_line(&lines, 5, |l| !l.contains(r#""/|talker""#)).expect("node talker never disappeared");
    let after = line_time(&gone) - deleted_at;
    println!("node talker gone {:.0} ms after its session's deletion", after * 1000.0);
    assert!(after < 1.0, "node disappeared {after:.3} s after deletion");
    assert!(gone.contains(PX4) && gone.contains(ADDER), "the other nodes stay: {gone}");
    // Not asserted: the endpoints' own disappearance is up to the DDS engine's disposal messages (see the
    // report of issue 11); printed so a run shows it.
    match wait_line(&lines, 3, |l| !l.contains("/chatter")) {
        Some(l) => println!("/chatter gone {:.0} ms after the deletion", (line_time(&l) - deleted_at) * 1000.0),
        None => println!("/chatter still listed 3 s after the deletion"),
    }
    // The agent stops with clients still connected: their nodes go with it.
    let stopped_at = now_secs();
    agent.stop().unwrap();
    drop(agent);
    let empty = wait_line(&lines, 5, |l| l.contains(r#""by_node":{}"#)).expect("nodes outlived the agent");
    let after = line_time(&empty) - stopped_at;
    println!("px4_micro_xrce_dds and /robot1/adder gone {:.0} ms after the agent stopped", after * 1000.0);
    assert!(after < 1.0, "nodes disappeared {after:.3} s after the agent stopped");
    px4.delete();
    adder.delete();
    let _ = probe.kill();
    let _ = probe.wait();
}
