//! Instruments that measure any DDS-XRCE agent the same way (ours or eProsima's): throughput, latency,
//! sessions, the UDP ceiling of the machine, and a deterministic lossy link for fault injection.
//!
//! Every subcommand of the `xrce-bench` binary is a function here taking a config and returning a result
//! struct, so tests and other tools can run them without the CLI.
#![forbid(unsafe_code)]
#![warn(missing_docs)]
#![cfg_attr(not(test), deny(clippy::unwrap_used, clippy::expect_used, clippy::indexing_slicing, clippy::panic))]

pub mod client;
pub mod latency;
pub mod lossy;
pub mod procstat;
pub mod proxy;
pub mod report;
pub mod ros;
pub mod serial_proxy;
pub mod sessions;
pub mod throughput;
pub mod udp_ceiling;

use std::time::Duration;

/// Why a benchmark failed.
#[derive(Debug, thiserror::Error)]
pub enum BenchError {
    /// A socket or `/proc` operation failed.
    #[error("I/O: {0}")]
    Io(#[from] std::io::Error),
    /// The client library refused an operation.
    #[error("client: {0}")]
    Client(#[from] xrce_client::Error),
    /// The agent answered a creation with an error status.
    #[error("agent refused {what} with status {status:#04x}")]
    Refused {
        /// What was being created.
        what: &'static str,
        /// The status.
        status: u8,
    },
    /// No answer in time.
    #[error("timeout: {0}")]
    Timeout(&'static str),
    /// A worker thread panicked or vanished.
    #[error("worker thread failed: {0}")]
    Thread(String),
    /// Invalid parameters.
    #[error("invalid configuration: {0}")]
    Config(String),
}

/// Parses a duration such as `5s`, `500ms`, `250us`, `2m`, `1.5s` or a bare number of seconds.
pub fn parse_duration(s: &str) -> Result<Duration, String> {
    let s = s.trim();
    let split = s.find(|c: char| !(c.is_ascii_digit() || c == '.')).unwrap_or(s.len());
    let (num, unit) = s.split_at(split);
    let value: f64 = num.parse().map_err(|_| format!("bad duration {s:?}"))?;
    let secs = match unit.trim() {
        "" | "s" => value,
        "ms" => value / 1e3,
        "us" | "µs" => value / 1e6,
        "ns" => value / 1e9,
        "m" | "min" => value * 60.0,
        "h" => value * 3600.0,
        u => return Err(format!("unknown duration unit {u:?} (use ns, us, ms, s, m, h)")),
    };
    Duration::try_from_secs_f64(secs).map_err(|e| format!("bad duration {s:?}: {e}"))
}

/// A run identifier: changes every run, so keys and topic names of two runs against the same agent differ.
pub fn run_id() -> u32 {
    let nanos = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.subsec_nanos());
    let secs = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.as_secs());
    (std::process::id() << 12) ^ nanos ^ (secs as u32).rotate_left(20)
}

/// Client key number `i` of run `run` (never 0).
pub fn client_key(run: u32, i: u32) -> u32 {
    let k = run.wrapping_mul(0x9E37_79B1).wrapping_add(i.wrapping_mul(0x85EB_CA6B)) ^ i;
    if k == 0 {
        1
    } else {
        k
    }
}

/// The benchmark sample: `publisher (u32) | sequence (u32) | send time (u64 ns)`, little endian, padded with
/// zeros to the payload size (at least 16 bytes are always written; a smaller payload truncates).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SampleHeader {
    /// Publisher number.
    pub publisher: u32,
    /// Sequence number within the publisher, from 0.
    pub seq: u32,
    /// Send time, ns on the sender's monotonic clock.
    pub sent_ns: u64,
}

impl SampleHeader {
    /// Size of the encoded header.
    pub const SIZE: usize = 16;

    /// Writes the header at the start of `buf` (as much as fits).
    pub fn write(&self, buf: &mut [u8]) {
        let mut h = [0u8; Self::SIZE];
        h[..4].copy_from_slice(&self.publisher.to_le_bytes());
        h[4..8].copy_from_slice(&self.seq.to_le_bytes());
        h[8..].copy_from_slice(&self.sent_ns.to_le_bytes());
        let n = buf.len().min(Self::SIZE);
        if let (Some(dst), Some(src)) = (buf.get_mut(..n), h.get(..n)) {
            dst.copy_from_slice(src);
        }
    }

    /// Reads the header of a sample, if it is long enough.
    pub fn read(buf: &[u8]) -> Option<Self> {
        let u32_at = |i: usize| buf.get(i..i + 4).and_then(|b| b.try_into().ok()).map(u32::from_le_bytes);
        let u64_at = |i: usize| buf.get(i..i + 8).and_then(|b| b.try_into().ok()).map(u64::from_le_bytes);
        Some(Self { publisher: u32_at(0)?, seq: u32_at(4)?, sent_ns: u64_at(8)? })
    }
}

/// Percentiles of a set of values (nearest rank).
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize)]
pub struct Percentiles {
    /// Values.
    pub count: usize,
    /// Smallest.
    pub min: f64,
    /// Median.
    pub p50: f64,
    /// 90th percentile.
    pub p90: f64,
    /// 99th percentile.
    pub p99: f64,
    /// Largest.
    pub max: f64,
    /// Mean.
    pub mean: f64,
}

impl Percentiles {
    /// Percentiles of `values` (sorted in place); all zero when empty.
    pub fn of(values: &mut [f64]) -> Self {
        values.sort_by(f64::total_cmp);
        let n = values.len();
        if n == 0 {
            return Self::default();
        }
        let at = |p: f64| {
            let rank = ((p / 100.0) * n as f64).ceil() as usize;
            values.get(rank.clamp(1, n) - 1).copied().unwrap_or(0.0)
        };
        Self {
            count: n,
            min: values.first().copied().unwrap_or(0.0),
            p50: at(50.0),
            p90: at(90.0),
            p99: at(99.0),
            max: values.last().copied().unwrap_or(0.0),
            mean: values.iter().sum::<f64>() / n as f64,
        }
    }
}

/// Joins a scoped or plain thread's result, turning a panic into [`BenchError::Thread`].
pub fn join<T>(r: std::thread::Result<Result<T, BenchError>>, what: &str) -> Result<T, BenchError> {
    r.map_err(|_| BenchError::Thread(format!("{what} panicked")))?
}
