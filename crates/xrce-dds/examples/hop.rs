//! One hop through the bridge inside one process, as the agent's DDS middleware makes it, on one thread:
//! a write, which Fast DDS delivers to a reader of its own process inside the write, then the reader's queue
//! taken; and the same hop with the sample queued ahead (`RawReader::deliver_ahead`), taken, then written
//! (the reader drops Fast DDS' copy). Prints the median and 90th percentile of each step in ns.
//!
//!   cargo build --release -p xrce-dds --features fastdds --example hop
//!   ../shared/dds-peers/netns.sh xdds target/release/examples/hop [SAMPLES]

use std::net::{IpAddr, Ipv4Addr};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use xrce_dds::{BridgeConfig, DdsBridge, EndpointQos, History, Reliability};

fn main() {
    let ifaces: Vec<String> = std::fs::read_dir("/sys/class/net")
        .map(|d| d.filter_map(|e| e.ok()).map(|e| e.file_name().to_string_lossy().into_owned()).collect())
        .unwrap_or_default();
    if ifaces != ["lo"] {
        eprintln!("refusing to start DDS outside a loopback-only namespace (interfaces: {ifaces:?})");
        std::process::exit(2);
    }
    let n: usize = std::env::args().nth(1).and_then(|a| a.parse().ok()).unwrap_or(20_000);
    let cfg = BridgeConfig { only_networks: Some(vec![IpAddr::V4(Ipv4Addr::LOCALHOST)]), ..BridgeConfig::default() };
    let bridge = DdsBridge::new(cfg);
    let p = bridge.participant(0, "").expect("participant");
    let t = p.topic("hop", "Hop", false).expect("topic");
    // The latency benchmark's QoS: reliable, keep-last (depth 0 → 1), volatile; the writer never blocks.
    let wq = EndpointQos {
        reliability: Reliability::Reliable,
        history: History::KeepLast(1),
        max_blocking_time: Duration::ZERO,
        ..EndpointQos::default()
    };
    let rq =
        EndpointQos { reliability: Reliability::Reliable, history: History::KeepLast(1), ..EndpointQos::default() };
    let w = p.shared_writer(&t, &wq).expect("writer");
    let r = p.create_reader(&t, &rq).expect("reader");
    let wakes = Arc::new(AtomicU64::new(0));
    let wk = Arc::clone(&wakes);
    r.queue().set_waker(Some(Arc::new(move || {
        wk.fetch_add(1, Ordering::Relaxed);
    })));
    let t0 = Instant::now();
    while w.matched_readers() < 1 {
        assert!(t0.elapsed() < Duration::from_secs(10), "no match");
        std::thread::sleep(Duration::from_millis(5));
    }
    std::thread::sleep(Duration::from_millis(200));
    let body = [7u8; 16];
    let (mut write_ns, mut take_ns) = (Vec::with_capacity(n), Vec::with_capacity(n));
    let mut batch = Vec::with_capacity(64);
    let mut lost = 0;
    for i in 0..n + 1000 {
        let a = Instant::now();
        w.write(&body).expect("write");
        let b = Instant::now();
        batch.clear();
        if r.queue().take_batch(64, &mut batch) != 1 {
            lost += 1;
        }
        let c = Instant::now();
        if i >= 1000 {
            write_ns.push((b - a).as_nanos() as u64);
            take_ns.push((c - b).as_nanos() as u64);
        }
    }
    let pct = |v: &mut Vec<u64>, p: f64| {
        v.sort_unstable();
        v[((v.len() - 1) as f64 * p) as usize]
    };
    println!(
        "write+deliver p50 {} p90 {} ns; take p50 {} p90 {} ns; not delivered in the write: {lost}; wakes {}",
        pct(&mut write_ns, 0.5),
        pct(&mut write_ns, 0.9),
        pct(&mut take_ns, 0.5),
        pct(&mut take_ns, 0.9),
        wakes.load(Ordering::Relaxed)
    );
    // Ahead: queued at once and taken; the DDS write follows and its copy is dropped.
    let guid = w.guid();
    let (mut ahead_ns, mut after_ns) = (Vec::with_capacity(n), Vec::with_capacity(n));
    let (mut not_ahead, mut extra) = (0, 0);
    for i in 0..n + 1000 {
        let a = Instant::now();
        let queued = r.deliver_ahead(&guid, &body);
        batch.clear();
        let took = r.queue().take_batch(64, &mut batch);
        let b = Instant::now();
        w.write(&body).expect("write");
        let c = Instant::now();
        not_ahead += usize::from(!queued);
        batch.clear();
        extra += r.queue().take_batch(64, &mut batch) + took.saturating_sub(1);
        if i >= 1000 {
            ahead_ns.push((b - a).as_nanos() as u64);
            after_ns.push((c - b).as_nanos() as u64);
        }
    }
    println!(
        "ahead+take p50 {} p90 {} ns; write after (copy dropped) p50 {} p90 {} ns; not ahead: {not_ahead}; \
         duplicates: {extra}",
        pct(&mut ahead_ns, 0.5),
        pct(&mut ahead_ns, 0.9),
        pct(&mut after_ns, 0.5),
        pct(&mut after_ns, 0.9),
    );
}
