//! Helpers shared by the DDS tests. Every test that creates a DDS participant calls
//! [`require_loopback_namespace`] first: DDS discovery multicast must never leave the machine.
#![allow(dead_code)]

use std::net::{IpAddr, Ipv4Addr};
use std::time::{Duration, Instant};

use xrce_dds::{BridgeConfig, DdsBridge, RawWriter, ReceivedSample, SampleQueue};

/// Panics unless the only network interface is `lo` (i.e. we run under `netns.sh`).
pub fn require_loopback_namespace() {
    let ifaces: Vec<String> = std::fs::read_dir("/sys/class/net")
        .map(|d| d.filter_map(|e| e.ok()).map(|e| e.file_name().to_string_lossy().into_owned()).collect())
        .unwrap_or_default();
    assert!(
        ifaces == ["lo"],
        "DDS tests must run inside a loopback-only namespace (shared/dds-peers/netns.sh NAME cargo test ... -- --ignored); interfaces here: {ifaces:?}"
    );
}

/// A bridge bound to loopback.
pub fn bridge() -> DdsBridge {
    require_loopback_namespace();
    DdsBridge::new(BridgeConfig {
        only_networks: Some(vec![IpAddr::V4(Ipv4Addr::LOCALHOST)]),
        ..BridgeConfig::default()
    })
}

/// CDR body (no encapsulation) of `struct HelloWorld { unsigned long index; string message; }`.
pub fn hello_body(index: u32, msg: &str) -> Vec<u8> {
    let mut v = Vec::new();
    v.extend_from_slice(&index.to_le_bytes());
    v.extend_from_slice(&(msg.len() as u32 + 1).to_le_bytes());
    v.extend_from_slice(msg.as_bytes());
    v.push(0);
    v
}

/// Decodes a HelloWorld body.
pub fn hello_decode(b: &[u8]) -> Option<(u32, String)> {
    let index = u32::from_le_bytes(b.get(0..4)?.try_into().ok()?);
    let len = u32::from_le_bytes(b.get(4..8)?.try_into().ok()?) as usize;
    let s = b.get(8..8 + len.saturating_sub(1))?;
    Some((index, String::from_utf8_lossy(s).into_owned()))
}

/// Waits until `w` matched at least `n` readers.
pub fn wait_matched(w: &RawWriter, n: usize, secs: u64) {
    let t0 = Instant::now();
    while w.matched_readers() < n {
        assert!(t0.elapsed() < Duration::from_secs(secs), "writer matched {} of {n} readers", w.matched_readers());
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// Collects `n` samples (or what arrived before `secs`).
pub fn collect(q: &SampleQueue, n: usize, secs: u64) -> Vec<ReceivedSample> {
    let deadline = Instant::now() + Duration::from_secs(secs);
    let mut out = Vec::with_capacity(n);
    while out.len() < n {
        let now = Instant::now();
        if now >= deadline {
            break;
        }
        if q.wait(deadline - now) {
            q.take_batch(n - out.len(), &mut out);
        }
    }
    out
}
