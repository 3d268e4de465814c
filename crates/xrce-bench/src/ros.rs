//! `ros`: one side of a latency run between an XRCE client and a ROS 2 node through the agent (`-m dds`).
//!
//! The client behaves as a micro-ROS node (Jazzy `rmw_microxrcedds`, binary creation): a participant named
//! after the node, topic `rt/<topic>` of type `std_msgs::msg::dds_::UInt8MultiArray_`, reliable volatile
//! keep-last 10, one reliable output and one reliable input stream, and every reliable write waits for the
//! agent's acknowledgement as `rmw_publish` does. Samples are `std_msgs/UInt8MultiArray` in CDR (without
//! encapsulation: the agent adds it) whose `data` starts with a [`Stamp`]; the ROS side
//! (`crates/xrce-agent/tests/ros2/ros_peer.py`, modes `bench-sub` and `bench-pub`) uses the same layout.
//!
//! * [`Direction::ToRos`]: publishes warm-up samples until the ROS reader acknowledges through the agent, then
//!   `rate × duration` measured samples at `rate`; the ROS node measures their latency.
//! * [`Direction::FromRos`]: subscribes and measures the latency of every measured sample the ROS node sends.
//!
//! Either way the agent's CPU time (`utime + stime` of `/proc/PID/stat`) over the measured window is divided by
//! the samples of that window.

use std::net::SocketAddr;
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use xrce_client::prelude::*;

use crate::procstat;
use crate::{BenchError, Percentiles};

/// Which way the samples go.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Direction {
    /// XRCE client → agent → ROS 2 node.
    ToRos,
    /// ROS 2 node → agent → XRCE client.
    FromRos,
}

/// The start of every sample's `data`: send time (`CLOCK_REALTIME`, ns since the epoch) and sequence number,
/// both `u64` little endian; warm-up samples have [`Stamp::WARMUP`] set in the sequence number.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Stamp {
    /// Send time, ns since the Unix epoch (comparable across processes of one machine).
    pub sent_ns: u64,
    /// Sequence number (with [`Stamp::WARMUP`] for warm-up samples).
    pub seq: u64,
}

impl Stamp {
    /// Bytes at the start of `data`.
    pub const SIZE: usize = 16;
    /// Flag of warm-up samples in [`Stamp::seq`].
    pub const WARMUP: u64 = 1 << 63;

    /// Whether this is a measured sample.
    pub const fn measured(&self) -> bool {
        self.seq & Self::WARMUP == 0
    }
}

/// Wall clock now, ns since the Unix epoch.
pub fn wall_ns() -> u64 {
    SystemTime::now().duration_since(UNIX_EPOCH).map_or(0, |d| u64::try_from(d.as_nanos()).unwrap_or(u64::MAX))
}

/// CDR offset of `data`'s bytes in a `std_msgs/UInt8MultiArray` with no dimensions: the empty `dim` sequence,
/// `data_offset`, then the length of `data`.
const DATA_AT: usize = 12;

/// A `std_msgs/UInt8MultiArray` (no dimensions) whose `data` is `len` bytes (at least [`Stamp::SIZE`]), zeros
/// after the stamp; [`stamp`] fills the stamp in place.
pub fn multi_array(len: usize) -> Vec<u8> {
    let len = len.max(Stamp::SIZE);
    let mut v = vec![0u8; DATA_AT + len];
    if let Some(n) = v.get_mut(8..12) {
        n.copy_from_slice(&u32::try_from(len).unwrap_or(u32::MAX).to_le_bytes());
    }
    v
}

/// Writes `s` at the start of the `data` of a sample made by [`multi_array`].
pub fn stamp(sample: &mut [u8], s: Stamp) {
    if let Some(b) = sample.get_mut(DATA_AT..DATA_AT + 8) {
        b.copy_from_slice(&s.sent_ns.to_le_bytes());
    }
    if let Some(b) = sample.get_mut(DATA_AT + 8..DATA_AT + 16) {
        b.copy_from_slice(&s.seq.to_le_bytes());
    }
}

/// The stamp of a `std_msgs/UInt8MultiArray` in CDR (any `dim`), or `None` when it is not one or too short.
pub fn read_stamp(b: &[u8]) -> Option<Stamp> {
    let u32_at = |i: usize| b.get(i..i + 4).and_then(|x| x.try_into().ok()).map(u32::from_le_bytes);
    let u64_at = |i: usize| b.get(i..i + 8).and_then(|x| x.try_into().ok()).map(u64::from_le_bytes);
    let align4 = |i: usize| (i + 3) & !3;
    let dims = u32_at(0)?;
    let mut at = 4;
    // MultiArrayDimension: string label, uint32 size, uint32 stride.
    for _ in 0..dims {
        let label = u32_at(at)? as usize;
        at = align4(at + 4 + label) + 8;
    }
    at += 4; // data_offset
    let len = u32_at(at)? as usize;
    at += 4;
    if len < Stamp::SIZE {
        return None;
    }
    Some(Stamp { sent_ns: u64_at(at)?, seq: u64_at(at + 8)? })
}

/// Parameters of one side of a run.
#[derive(Debug, Clone)]
pub struct RosConfig {
    /// The agent.
    pub agent: SocketAddr,
    /// Which way the samples go.
    pub direction: Direction,
    /// ROS topic name (`rt/<topic>` in DDS).
    pub topic: String,
    /// Node name (the participant's name).
    pub node: String,
    /// DDS domain of the participant.
    pub domain: u16,
    /// Samples per second (to-ros: this side's rate; from-ros: the ROS node's, for the expected count).
    pub rate: f64,
    /// Bytes of `data` per sample (at least 16).
    pub payload: usize,
    /// Measured samples (to-ros: written; from-ros: expected).
    pub count: u64,
    /// Shortest warm-up (to-ros): samples flagged as warm-up, written at `rate`, until this long has passed and
    /// the last one was acknowledged within one period.
    pub warmup: Duration,
    /// From-ros: stop this long after the last measured sample when not all came.
    pub idle_timeout: Duration,
    /// Longest run in all.
    pub timeout: Duration,
    /// The agent's PID, for its CPU time.
    pub agent_pid: Option<u32>,
    /// Slots of each reliable stream (a power of two); `None`: micro-ROS' 4 when a sample fits them, else the
    /// smallest power of two holding one sample's fragments.
    pub history: Option<usize>,
    /// Client key.
    pub key: u32,
    /// From-ros: write every measured arrival to this file, `seq sent_ns arrival_ns` a line.
    pub dump: Option<std::path::PathBuf>,
}

/// What one side measured.
#[derive(Debug, Clone, Default, serde::Serialize)]
pub struct RosResult {
    /// `"ros"`.
    pub bench: &'static str,
    /// Which way.
    pub direction: Option<Direction>,
    /// Bytes of `data` per sample.
    pub payload: usize,
    /// Nominal rate, samples/s.
    pub rate: f64,
    /// Slots of each reliable stream.
    pub history: usize,
    /// To-ros: warm-up samples written.
    pub warmup_written: u64,
    /// To-ros: measured samples written.
    pub written: u64,
    /// To-ros: writes not acknowledged within 1 s (`rmw_publish` would report an error; the sample stays queued).
    pub unconfirmed: u64,
    /// To-ros: writes refused because the history stayed full (lost, as with `rmw_publish`).
    pub dropped: u64,
    /// From-ros: measured samples received (distinct sequence numbers).
    pub received: u64,
    /// From-ros: measured samples received twice or more.
    pub duplicates: u64,
    /// From-ros: measured samples received after a higher sequence number.
    pub out_of_order: u64,
    /// From-ros: latency, µs (send time at the ROS node to arrival here).
    pub latency_us: Percentiles,
    /// Measured window, s (to-ros: first write to the last acknowledged; from-ros: first to last arrival).
    pub window_s: f64,
    /// Achieved rate over the window, samples/s.
    pub achieved_rate: f64,
    /// Agent CPU time over the window, s.
    pub agent_cpu_s: Option<f64>,
    /// Agent CPU time per sample of the window, µs.
    pub agent_cpu_us_per_sample: Option<f64>,
    /// To-ros: the longest write (into the stream and acknowledged by the agent), ms.
    pub max_write_ms: f64,
    /// From-ros: the longest time between two measured arrivals, ms, and the sequence number after it.
    pub max_arrival_gap_ms: f64,
    /// From-ros: the sequence number that ended [`RosResult::max_arrival_gap_ms`].
    pub max_arrival_gap_seq: u64,
}

/// micro-ROS' defaults: 4 slots of the UDP transport's 512-byte MTU per reliable stream.
const MICRO_ROS_HISTORY: usize = 4;
const SLOT: usize = 512;
/// How long `rmw_publish` waits for a reliable write to be acknowledged (`RMW_UXRCE_PUBLISH_RELIABLE_TIMEOUT`).
const CONFIRM_MS: i32 = 1000;

/// The history a sample of `payload` bytes needs: micro-ROS' 4 slots when its fragments fit, else the
/// smallest power of two that holds them (each fragment carries ~480 bytes of a 512-byte message).
pub fn history_for(payload: usize) -> usize {
    let fragments = (DATA_AT + payload + 24).div_ceil(SLOT - 40);
    fragments.max(MICRO_ROS_HISTORY).next_power_of_two()
}

#[derive(Debug, Default)]
struct Rx {
    /// (arrival, stamp) of every measured sample.
    arrivals: Vec<(u64, Stamp)>,
    first_at: Option<Instant>,
    last_at: Option<Instant>,
    cpu_first: Option<u64>,
    agent_pid: Option<u32>,
    /// Measured samples expected: the agent's CPU time is read again when the last one arrives.
    count: u64,
    cpu_last: Option<u64>,
    warmup: u64,
}

impl Callbacks for Rx {
    fn on_topic(&mut self, _: &mut Outputs<'_, '_>, _: ObjectId, _: u16, _: StreamId, data: &[u8]) {
        let now = wall_ns();
        let Some(s) = read_stamp(data) else { return };
        if !s.measured() {
            self.warmup += 1;
            return;
        }
        if self.first_at.is_none() {
            self.first_at = Some(Instant::now());
            self.cpu_first = self.agent_pid.and_then(|p| procstat::sample(p).ok()).map(|s| s.cpu_ticks);
        }
        self.last_at = Some(Instant::now());
        self.arrivals.push((now, s));
        if self.arrivals.len() as u64 == self.count {
            self.cpu_last = self.agent_pid.and_then(|p| procstat::sample(p).ok()).map(|s| s.cpu_ticks);
        }
    }
}

type Udp<'a> = Session<'a, UdpTransport, StdClock, Rx>;

fn created(session: &mut Udp<'_>, request: u16, what: &'static str) -> Result<(), BenchError> {
    let mut status = [0u8; 1];
    if session.run_session_until_all_status(2000, &[request], &mut status)? {
        Ok(())
    } else if status[0] == STATUS_NONE {
        Err(BenchError::Timeout("no STATUS for an entity creation"))
    } else {
        Err(BenchError::Refused { what, status: status[0] })
    }
}

/// Runs one side: creates the session and entities, then publishes or receives.
pub fn run(cfg: &RosConfig) -> Result<RosResult, BenchError> {
    if cfg.rate <= 0.0 || !cfg.rate.is_finite() {
        return Err(BenchError::Config("--rate must be positive".into()));
    }
    let history = cfg.history.unwrap_or_else(|| history_for(cfg.payload));
    if !history.is_power_of_two() {
        return Err(BenchError::Config("--history must be a power of two".into()));
    }
    let transport = UdpTransport::new(IpProtocol::V4, &cfg.agent.ip().to_string(), &cfg.agent.port().to_string())
        .map_err(|e| BenchError::Config(format!("UDP transport to {}: {e}", cfg.agent)))?;
    let (mut out_buf, mut in_buf) = (vec![0u8; SLOT * history], vec![0u8; SLOT * history]);
    let rx = Rx { agent_pid: cfg.agent_pid, count: cfg.count, ..Rx::default() };
    let mut session: Udp<'_> = Session::new(transport, cfg.key).with_reconnect(None).with_callbacks(rx);
    session.create_session()?;
    let out = session.create_output_reliable_stream(&mut out_buf, history)?;
    let input = session.create_input_reliable_stream(&mut in_buf, history)?;
    let mode = REUSE | REPLACE;
    let qos = QoS {
        reliability: Reliability::Reliable,
        durability: Durability::Volatile,
        history: History::KeepLast,
        depth: 10,
    };
    let type_name = "std_msgs::msg::dds_::UInt8MultiArray_";
    let topic_name = format!("rt/{}", cfg.topic.trim_start_matches('/'));

    let participant = object_id(1, ObjectKind::Participant);
    let r = session.buffer_create_participant_bin(out, participant, cfg.domain, Some(&cfg.node), mode)?;
    created(&mut session, r, "participant")?;
    let topic = object_id(1, ObjectKind::Topic);
    let r = session.buffer_create_topic_bin(out, topic, participant, &topic_name, type_name, mode)?;
    created(&mut session, r, "topic")?;
    let mut result = RosResult {
        bench: "ros",
        direction: Some(cfg.direction),
        payload: cfg.payload,
        rate: cfg.rate,
        history,
        ..RosResult::default()
    };
    let ticks = procstat::clock_ticks() as f64;
    let cpu_now = |pid: Option<u32>| pid.and_then(|p| procstat::sample(p).ok()).map(|s| s.cpu_ticks);
    let period = Duration::from_secs_f64(1.0 / cfg.rate);
    match cfg.direction {
        Direction::ToRos => {
            let publisher = object_id(1, ObjectKind::Publisher);
            let r = session.buffer_create_publisher_bin(out, publisher, participant, mode)?;
            created(&mut session, r, "publisher")?;
            let writer = object_id(1, ObjectKind::DataWriter);
            let r = session.buffer_create_datawriter_bin(out, writer, publisher, topic, qos, mode)?;
            created(&mut session, r, "datawriter")?;
            eprintln!("xrce-bench ros: ready");
            let mut sample = multi_array(cfg.payload);
            let started = Instant::now();
            // Warm-up: the agent holds the first samples until the ROS node's discovery is done; measuring
            // starts once a write is acknowledged within one period after the shortest warm-up.
            let mut next = Instant::now();
            loop {
                pace(&mut next, period);
                stamp(&mut sample, Stamp { sent_ns: wall_ns(), seq: Stamp::WARMUP | result.warmup_written });
                let t = Instant::now();
                let w = write(&mut session, out, writer, &sample)?;
                result.warmup_written += 1;
                if started.elapsed() >= cfg.warmup && w == Written::Confirmed && t.elapsed() < period {
                    break;
                }
                if started.elapsed() > cfg.timeout {
                    return Err(BenchError::Timeout("warm-up writes never acknowledged in time"));
                }
            }
            let cpu0 = cpu_now(cfg.agent_pid);
            let t0 = Instant::now();
            let mut next = t0;
            for seq in 0..cfg.count {
                pace(&mut next, period);
                stamp(&mut sample, Stamp { sent_ns: wall_ns(), seq });
                let t = Instant::now();
                let w = write(&mut session, out, writer, &sample)?;
                result.max_write_ms = result.max_write_ms.max(t.elapsed().as_secs_f64() * 1e3);
                match w {
                    Written::Confirmed => {}
                    Written::Unconfirmed => result.unconfirmed += 1,
                    Written::Dropped => result.dropped += 1,
                }
                result.written += 1;
            }
            let window = t0.elapsed().as_secs_f64();
            let cpu1 = cpu_now(cfg.agent_pid);
            result.window_s = window;
            result.achieved_rate = result.written as f64 / window.max(1e-9);
            if let (Some(a), Some(b)) = (cpu0, cpu1) {
                let cpu = b.saturating_sub(a) as f64 / ticks;
                result.agent_cpu_s = Some(cpu);
                result.agent_cpu_us_per_sample = Some(cpu * 1e6 / result.written.max(1) as f64);
            }
            // Let the ROS node take the last samples before this participant goes.
            session.run_session_timeout(500)?;
        }
        Direction::FromRos => {
            let subscriber = object_id(1, ObjectKind::Subscriber);
            let r = session.buffer_create_subscriber_bin(out, subscriber, participant, mode)?;
            created(&mut session, r, "subscriber")?;
            let reader = object_id(1, ObjectKind::DataReader);
            let r = session.buffer_create_datareader_bin(out, reader, subscriber, topic, qos, mode)?;
            created(&mut session, r, "datareader")?;
            let all = DeliveryControl { max_samples: DeliveryControl::UNLIMITED, ..Default::default() };
            session.buffer_request_data(out, reader, input, Some(&all))?;
            session.run_session_until_confirm_delivery(CONFIRM_MS)?;
            eprintln!("xrce-bench ros: ready");
            let started = Instant::now();
            loop {
                session.run_session_timeout(20)?;
                let rx = session.callbacks();
                let distinct = rx.arrivals.len() as u64;
                if distinct >= cfg.count {
                    break;
                }
                if rx.last_at.is_some_and(|t| t.elapsed() > cfg.idle_timeout) || started.elapsed() > cfg.timeout {
                    break;
                }
            }
            // Not all came: the window then ends now, idle time included.
            let cpu_end = cpu_now(cfg.agent_pid);
            let rx = session.callbacks();
            let cpu1 = rx.cpu_last.or(cpu_end);
            let window = match (rx.first_at, rx.last_at) {
                (Some(a), Some(b)) => b.saturating_duration_since(a).as_secs_f64(),
                _ => 0.0,
            };
            let mut seen = std::collections::HashSet::new();
            let mut highest = None;
            let mut latencies = Vec::with_capacity(rx.arrivals.len());
            let mut previous = None;
            for &(at, s) in &rx.arrivals {
                if let Some(p) = previous {
                    let gap = at.saturating_sub(p) as f64 / 1e6;
                    if gap > result.max_arrival_gap_ms {
                        result.max_arrival_gap_ms = gap;
                        result.max_arrival_gap_seq = s.seq;
                    }
                }
                previous = Some(at);
                if !seen.insert(s.seq) {
                    result.duplicates += 1;
                    continue;
                }
                if highest.is_some_and(|h| s.seq < h) {
                    result.out_of_order += 1;
                }
                highest = highest.max(Some(s.seq));
                latencies.push(at.saturating_sub(s.sent_ns) as f64 / 1e3);
            }
            if let Some(path) = &cfg.dump {
                use std::io::Write as _;
                let mut f = std::io::BufWriter::new(std::fs::File::create(path)?);
                for &(at, s) in &rx.arrivals {
                    writeln!(f, "{} {} {}", s.seq, s.sent_ns, at)?;
                }
                f.flush()?;
            }
            result.received = seen.len() as u64;
            result.latency_us = Percentiles::of(&mut latencies);
            result.window_s = window;
            result.achieved_rate = result.received.saturating_sub(1) as f64 / window.max(1e-9);
            if let (Some(a), Some(b)) = (rx.cpu_first, cpu1) {
                let cpu = b.saturating_sub(a) as f64 / ticks;
                result.agent_cpu_s = Some(cpu);
                result.agent_cpu_us_per_sample = Some(cpu * 1e6 / result.received.max(1) as f64);
            }
        }
    }
    let _ = session.delete_session_retries(1);
    Ok(result)
}

/// Sleeps until `next`, then moves it one period on; after a stall of more than five periods the schedule
/// starts again from now instead of writing the missed samples back to back.
fn pace(next: &mut Instant, period: Duration) {
    let now = Instant::now();
    if *next > now {
        std::thread::sleep(*next - now);
    } else if now - *next > period * 5 {
        *next = now;
    }
    *next += period;
}

/// How a write went, as `rmw_publish` of micro-ROS reports it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Written {
    /// In the stream and acknowledged by the agent within [`CONFIRM_MS`].
    Confirmed,
    /// In the stream, not acknowledged in time.
    Unconfirmed,
    /// Not written: the history stayed full.
    Dropped,
}

/// Writes one sample as `rmw_publish` does on a reliable stream: into the stream (waiting up to [`CONFIRM_MS`]
/// for room when the history is full), then up to [`CONFIRM_MS`] for the agent's acknowledgement.
fn write(session: &mut Udp<'_>, stream: StreamId, writer: ObjectId, data: &[u8]) -> Result<Written, BenchError> {
    match session.buffer_topic(stream, writer, data) {
        Ok(_) => {}
        Err(Error::WouldBlock) => {
            session.run_session_until_confirm_delivery(CONFIRM_MS)?;
            match session.buffer_topic(stream, writer, data) {
                Ok(_) => {}
                Err(Error::WouldBlock) => return Ok(Written::Dropped),
                Err(e) => return Err(e.into()),
            }
        }
        Err(e) => return Err(e.into()),
    }
    Ok(if session.run_session_until_confirm_delivery(CONFIRM_MS)? { Written::Confirmed } else { Written::Unconfirmed })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stamp_round_trips_through_the_cdr_layout() {
        let mut m = multi_array(1024);
        assert_eq!(m.len(), 12 + 1024);
        stamp(&mut m, Stamp { sent_ns: 0x0102_0304_0506_0708, seq: 42 });
        assert_eq!(read_stamp(&m), Some(Stamp { sent_ns: 0x0102_0304_0506_0708, seq: 42 }));
        assert!(read_stamp(&m).is_some_and(|s| s.measured()));
        // A dimension before the data: label "x" (len 2, padded to 4), size, stride.
        let mut d = vec![1, 0, 0, 0, 2, 0, 0, 0, b'x', 0, 0, 0, 3, 0, 0, 0, 3, 0, 0, 0];
        d.extend_from_slice(&[0, 0, 0, 0, 16, 0, 0, 0]);
        d.extend_from_slice(&7u64.to_le_bytes());
        d.extend_from_slice(&(Stamp::WARMUP | 1).to_le_bytes());
        let s = read_stamp(&d);
        assert_eq!(s, Some(Stamp { sent_ns: 7, seq: Stamp::WARMUP | 1 }));
        assert!(s.is_some_and(|s| !s.measured()));
        assert_eq!(read_stamp(&m[..20]), None);
    }

    #[test]
    fn history_fits_one_sample() {
        assert_eq!(history_for(1024), 4);
        assert_eq!(history_for(32 * 1024), 128);
        assert!(history_for(32 * 1024) * (SLOT - 40) >= 32 * 1024 + 36);
    }
}
