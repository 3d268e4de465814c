//! Throughput of the bridge: bridge writer → DDS (loopback) → bridge reader, 64-byte samples, reliable
//! KEEP_ALL and best-effort KEEP_LAST. Starts DDS participants, so it refuses to run outside a
//! loopback-only namespace:
//!
//!   cargo build --release -p xrce-dds --example throughput
//!   ../shared/dds-peers/netns.sh xdds target/release/examples/throughput [SAMPLES]

use std::net::{IpAddr, Ipv4Addr};
use std::time::{Duration, Instant};

use xrce_dds::{BridgeConfig, DdsBridge, EndpointQos};

fn main() {
    let ifaces: Vec<String> = std::fs::read_dir("/sys/class/net")
        .map(|d| d.filter_map(|e| e.ok()).map(|e| e.file_name().to_string_lossy().into_owned()).collect())
        .unwrap_or_default();
    if ifaces != ["lo"] {
        eprintln!("refusing to start DDS outside a loopback-only namespace (interfaces: {ifaces:?})");
        std::process::exit(2);
    }
    let n: u32 = std::env::args().nth(1).and_then(|a| a.parse().ok()).unwrap_or(100_000);
    for (name, qos) in
        [("reliable keep-all", EndpointQos::reliable()), ("best-effort keep-last 1000", EndpointQos::best_effort(1000))]
    {
        run(name, &qos, n);
    }
}

fn run(name: &str, qos: &EndpointQos, n: u32) {
    let cfg = BridgeConfig { only_networks: Some(vec![IpAddr::V4(Ipv4Addr::LOCALHOST)]), ..BridgeConfig::default() };
    let (a, b) = (DdsBridge::new(cfg.clone()), DdsBridge::new(cfg));
    let (pa, pb) = match (a.participant(0, ""), b.participant(0, "")) {
        (Ok(x), Ok(y)) => (x, y),
        (Err(e), _) | (_, Err(e)) => return eprintln!("participant: {e}"),
    };
    let topic = format!("Perf_{}", name.split(' ').next().unwrap_or("x"));
    let (Ok(ta), Ok(tb)) = (pa.topic(&topic, "Perf", false), pb.topic(&topic, "Perf", false)) else {
        return eprintln!("topic failed");
    };
    let (Ok(r), Ok(w)) = (pb.create_reader(&tb, qos), pa.create_writer(&ta, qos)) else {
        return eprintln!("endpoint failed");
    };
    let t0 = Instant::now();
    while w.matched_readers() < 1 {
        if t0.elapsed() > Duration::from_secs(20) {
            return eprintln!("{name}: no match");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    std::thread::sleep(Duration::from_millis(300));
    let receiver = std::thread::spawn(move || {
        let q = r.queue();
        let mut got = 0u64;
        let mut batch = Vec::with_capacity(4096);
        let mut last = Instant::now();
        while got < u64::from(n) {
            if q.wait(Duration::from_secs(3)) {
                batch.clear();
                got += q.take_batch(4096, &mut batch) as u64;
                last = Instant::now();
            } else {
                break; // idle for 3 s: the rest is lost
            }
        }
        (got, last)
    });
    let start = Instant::now();
    let mut body = [0u8; 64];
    let mut write_errors = 0u64;
    for i in 0..n {
        body[..4].copy_from_slice(&i.to_le_bytes());
        while w.write(&body).is_err() {
            write_errors += 1; // reliable send window full: back-pressure, retry
            if write_errors > 1_000_000 {
                break;
            }
        }
    }
    let wrote = start.elapsed();
    let Ok((got, last)) = receiver.join() else { return eprintln!("receiver panicked") };
    let secs = last.duration_since(start).as_secs_f64().max(1e-9);
    println!(
        "{name}: wrote {n} x 64 B in {:.2} s ({:.0}/s, {write_errors} blocked writes); received {got} ({:.1} %) = {:.0} samples/s end to end",
        wrote.as_secs_f64(),
        f64::from(n) / wrote.as_secs_f64().max(1e-9),
        100.0 * got as f64 / f64::from(n),
        got as f64 / secs
    );
}
