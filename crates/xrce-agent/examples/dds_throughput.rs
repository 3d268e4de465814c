//! Throughput from an XRCE publisher through the agent (DDS middleware, UDP) to a DDS subscriber:
//! 64-byte samples, reliable (reliable stream, reliable KEEP_ALL writer and reader) and best effort.
//!
//! The agent runs in-process on an ephemeral UDP port; the XRCE client is `xrce-client` over UDP; the DDS
//! subscriber is a separate `xrce-dds` bridge (its own DDS participant) in the same domain. Starts DDS, so it
//! refuses to run outside a loopback-only namespace:
//!
//!   cargo build --release -p xrce-agent --example dds_throughput
//!   ../shared/dds-peers/netns.sh xdds target/release/examples/dds_throughput [SECONDS]

use std::net::{IpAddr, Ipv4Addr};
use std::time::{Duration, Instant};

use xrce_agent::agent::AgentInstance;
use xrce_client::prelude::*;
use xrce_dds::{BridgeConfig, DdsBridge, EndpointQos};

const PAYLOAD: usize = 64;
const HISTORY: usize = 16;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let ifaces: Vec<String> = std::fs::read_dir("/sys/class/net")
        .map(|d| d.filter_map(|e| e.ok()).map(|e| e.file_name().to_string_lossy().into_owned()).collect())
        .unwrap_or_default();
    if ifaces != ["lo"] {
        eprintln!("refusing to start DDS outside a loopback-only namespace (interfaces: {ifaces:?})");
        std::process::exit(2);
    }
    let secs: u64 = std::env::args().nth(1).and_then(|a| a.parse().ok()).unwrap_or(5);
    let mut agent = AgentInstance::create(["xrce-agent", "udp4", "-p", "0", "-v", "0"])?;
    let port = agent.local_addr().map(|a| a.port()).ok_or("no agent address")?;
    for reliable in [true, false] {
        run(port, reliable, Duration::from_secs(secs))?;
    }
    agent.stop()?;
    Ok(())
}

fn run(port: u16, reliable: bool, duration: Duration) -> Result<(), Box<dyn std::error::Error>> {
    let name = if reliable { "reliable" } else { "best-effort" };
    let topic = format!("Throughput_{name}");
    // DDS subscriber: reliable KEEP_ALL, or best effort KEEP_LAST 1000.
    let cfg = BridgeConfig { only_networks: Some(vec![IpAddr::V4(Ipv4Addr::LOCALHOST)]), ..BridgeConfig::default() };
    let bridge = DdsBridge::new(cfg);
    let p = bridge.participant(0, "")?;
    let t = p.topic(&topic, "Perf", false)?;
    let qos = if reliable { EndpointQos::reliable() } else { EndpointQos::best_effort(1000) };
    let reader = p.create_reader(&t, &qos)?;

    // XRCE publisher, binary entities.
    let transport = UdpTransport::new(IpProtocol::V4, "127.0.0.1", &port.to_string())?;
    let mut rel_buf = vec![0u8; 512 * HISTORY];
    let mut be_buf = vec![0u8; 512];
    let mut in_buf = vec![0u8; 512 * 4];
    let mut session = Session::new(transport, if reliable { 0x7777_0001 } else { 0x7777_0002 });
    session.create_session()?;
    let rel = session.create_output_reliable_stream(&mut rel_buf, HISTORY)?;
    let be = session.create_output_best_effort_stream(&mut be_buf)?;
    session.create_input_reliable_stream(&mut in_buf, 4)?;
    let pid = object_id(1, ObjectKind::Participant);
    let tid = object_id(1, ObjectKind::Topic);
    let pubid = object_id(1, ObjectKind::Publisher);
    let dw = object_id(1, ObjectKind::DataWriter);
    let wqos = QoS {
        durability: Durability::Volatile,
        reliability: if reliable { Reliability::Reliable } else { Reliability::BestEffort },
        history: if reliable { History::KeepAll } else { History::KeepLast },
        depth: if reliable { 0 } else { 1 },
    };
    let reqs = [
        session.buffer_create_participant_bin(rel, pid, 0, None, REPLACE)?,
        session.buffer_create_topic_bin(rel, tid, pid, &topic, "Perf", REPLACE)?,
        session.buffer_create_publisher_bin(rel, pubid, pid, REPLACE)?,
        session.buffer_create_datawriter_bin(rel, dw, pubid, tid, wqos, REPLACE)?,
    ];
    let mut status = [0u8; 4];
    if !session.run_session_until_all_status(3000, &reqs, &mut status)? {
        return Err(format!("entity creation failed: {status:?}").into());
    }
    std::thread::sleep(Duration::from_secs(2)); // discovery between the agent's and the subscriber's participants
    let stream = if reliable { rel } else { be };
    let mut sample = [0u8; PAYLOAD];
    let mut sent = 0u64;
    let mut blocked = 0u64;
    let mut received = 0usize;
    let mut batch = Vec::new();
    let start = Instant::now();
    while start.elapsed() < duration {
        sample[..8].copy_from_slice(&sent.to_le_bytes());
        match session.buffer_topic(stream, dw, &sample) {
            Ok(_) => {
                sent += 1;
                // One sample per datagram; acknowledgements are read when the history is full.
                session.flash_output_streams()?;
            }
            Err(Error::WouldBlock) => {
                blocked += 1;
                session.run_session_until_confirm_delivery(5)?;
            }
            Err(e) => return Err(e.into()),
        }
        received += reader.queue().take_batch(usize::MAX, &mut batch);
        batch.clear();
    }
    let write_time = start.elapsed();
    // Drain: the reliable ones still in flight.
    let drain_end = Instant::now() + Duration::from_secs(3);
    while Instant::now() < drain_end && (received as u64) < sent {
        session.run_session_time(1)?;
        if reader.queue().wait(Duration::from_millis(10)) {
            received += reader.queue().take_batch(usize::MAX, &mut batch);
            batch.clear();
        }
    }
    let _ = session.delete_session();
    let s = write_time.as_secs_f64();
    println!(
        "{name:11} {PAYLOAD} B: XRCE sent {sent} ({:.0}/s, {blocked} would-block), DDS subscriber received {received} ({:.0}/s over the write time), loss {:.2} %",
        sent as f64 / s,
        received as f64 / s,
        100.0 * (1.0 - received as f64 / sent.max(1) as f64)
    );
    Ok(())
}
