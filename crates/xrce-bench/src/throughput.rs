//! `throughput`: P publishers → agent → S subscribers on one topic, as fast as the publishers can write (one
//! sample per datagram, as eProsima's measurements did), for a fixed duration.
//!
//! Every client is a session of its own over its own UDP socket, on its own thread; entities are created with
//! the binary representation, so any agent (CED or DDS middleware) runs the same test. Subscribers are set up
//! first, then publishers; the clock starts when every publisher is ready. After the publishers stop,
//! subscribers keep receiving until nothing more arrives (or everything expected has), bounded by `drain`.

use std::net::SocketAddr;
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::sync::{mpsc, Barrier};
use std::time::{Duration, Instant};

use xrce_client::{ObjectId, Outputs, StreamId, WriteAccessExt};

use crate::client::{self, buffer_endpoints, history_for, ids, request_all, Client, Endpoints, Handler, OnData};
use crate::procstat::{AgentUsage, Monitor};
use crate::{client_key, join, BenchError, SampleHeader};

/// Parameters of a throughput run.
#[derive(Debug, Clone)]
pub struct ThroughputConfig {
    /// The agent.
    pub agent: SocketAddr,
    /// Publishing clients.
    pub publishers: usize,
    /// Subscribing clients.
    pub subscribers: usize,
    /// Sample size in bytes (at least 16 carry the sequence header).
    pub payload: usize,
    /// Reliable streams and QoS (else best effort).
    pub reliable: bool,
    /// MTU of every client.
    pub mtu: usize,
    /// History of the reliable streams (raised on subscribers when a fragmented sample needs more).
    pub history: usize,
    /// How long the publishers write.
    pub duration: Duration,
    /// Longest wait for the last samples after the publishers stop.
    pub drain: Duration,
    /// The agent's PID, to measure its CPU and memory.
    pub agent_pid: Option<u32>,
    /// Samples per second per publisher (`None`: as fast as possible).
    pub rate: Option<f64>,
    /// Most samples written but not yet received by the slowest subscriber (`None`: no limit). Keeps the
    /// subscribers up with the publishers, e.g. so an agent's bounded topic history never overflows.
    pub window: Option<u64>,
    /// Subscribers ask the agent to pack several DATA per message (CREATE_CLIENT property `xrce_rs_pack`;
    /// honoured by our agent, ignored by eProsima's).
    pub pack: bool,
    /// Reliable samples larger than one message are written with the continuous fragmented API
    /// (`uxr_prepare_output_stream_fragmented`), whose fragments take every free slot of the history, instead
    /// of waiting until the whole sample fits (`uxr_buffer_topic`). Not the targets' method: a variant.
    pub continuous: bool,
    /// Run id: keys and the topic name derive from it.
    pub run: u32,
}

impl ThroughputConfig {
    /// Defaults for `agent`: 1 → 1, 16 B, reliable, MTU 512, history 8, 5 s.
    pub fn new(agent: SocketAddr) -> Self {
        Self {
            agent,
            publishers: 1,
            subscribers: 1,
            payload: 16,
            reliable: true,
            mtu: 512,
            history: 8,
            duration: Duration::from_secs(5),
            drain: Duration::from_secs(3),
            agent_pid: None,
            rate: None,
            window: None,
            pack: true,
            continuous: false,
            run: crate::run_id(),
        }
    }

    /// The mode as printed.
    pub const fn mode(&self) -> &'static str {
        match (self.reliable, self.continuous) {
            (true, false) => "reliable",
            (true, true) => "reliable-cont",
            (false, _) => "best-effort",
        }
    }
}

/// What a throughput run measured.
#[derive(Debug, Clone, Default, serde::Serialize)]
pub struct ThroughputResult {
    /// `"throughput"`.
    pub bench: &'static str,
    /// `"reliable"` or `"best-effort"`.
    pub mode: &'static str,
    /// Sample size.
    pub payload: usize,
    /// Publishers.
    pub publishers: usize,
    /// Subscribers.
    pub subscribers: usize,
    /// MTU.
    pub mtu: usize,
    /// History of the publishers' reliable stream.
    pub history: usize,
    /// History of the subscribers' reliable input stream.
    pub sub_history: usize,
    /// Seconds the publishers wrote.
    pub duration_s: f64,
    /// Samples written by all publishers.
    pub sent: u64,
    /// `sent` per second.
    pub sent_per_s: f64,
    /// Distinct samples received, summed over subscribers.
    pub received: u64,
    /// `received` per second (over the publishing time, or until the last sample when later).
    pub received_per_s: f64,
    /// Lost samples in percent of `sent × subscribers`.
    pub loss_pct: f64,
    /// Samples received twice.
    pub duplicates: u64,
    /// Samples older than one already received from the same publisher.
    pub out_of_order: u64,
    /// Writes refused because the reliable history was full.
    pub would_block: u64,
    /// Datagrams the publishers sent (data, heartbeats, retransmissions).
    pub datagrams_out: u64,
    /// Datagrams the subscribers received.
    pub datagrams_in: u64,
    /// Datagrams the subscribers sent (mostly ACKNACKs).
    pub sub_datagrams_out: u64,
    /// The agent's CPU and memory over the publishing time.
    pub agent: Option<AgentUsage>,
}

/// What one subscriber saw.
#[derive(Debug, Default)]
struct Tracker {
    /// Last sequence number per publisher.
    last: Vec<Option<u32>>,
    received: u64,
    duplicates: u64,
    out_of_order: u64,
    foreign: u64,
    last_rx: Option<Instant>,
}

impl OnData for Tracker {
    fn on_data(&mut self, _: &mut Outputs<'_, '_>, _: ObjectId, data: &[u8]) {
        let Some(h) = SampleHeader::read(data) else {
            self.foreign += 1;
            return;
        };
        let Some(last) = usize::try_from(h.publisher).ok().and_then(|p| self.last.get_mut(p)) else {
            self.foreign += 1;
            return;
        };
        match *last {
            Some(l) if h.seq == l => self.duplicates += 1,
            Some(l) if h.seq < l => self.out_of_order += 1,
            _ => {
                *last = Some(h.seq);
                self.received += 1;
                self.last_rx = Some(Instant::now());
            }
        }
    }
}

#[derive(Debug, Default)]
struct SubResult {
    received: u64,
    duplicates: u64,
    out_of_order: u64,
    last_rx: Option<Instant>,
    datagrams: u64,
    datagrams_out: u64,
}

#[derive(Debug, Default)]
struct PubResult {
    sent: u64,
    would_block: u64,
    datagrams: u64,
    elapsed: Duration,
}

fn topic_name(run: u32) -> String {
    format!("xrce_bench_throughput_{run:08x}")
}

fn setup_subscriber<'a>(
    cfg: &ThroughputConfig,
    index: usize,
    sub_history: usize,
    out_buf: &'a mut [u8],
    in_buf: &'a mut [u8],
) -> Result<(Client<'a>, Handler<Tracker>), BenchError> {
    let key = client_key(cfg.run, 0x1000 + u32::try_from(index).unwrap_or(0));
    let mut c = Client::new(cfg.agent, key, cfg.mtu)?;
    c.sock().set_recv_buffer(8 << 20)?;
    c.core.set_packed_input(cfg.pack);
    c.create_session(5)?;
    let out = c.core.create_output_reliable_stream(out_buf, 4)?;
    let in_rel = c.core.create_input_reliable_stream(in_buf, sub_history)?;
    let in_be = c.core.create_input_best_effort_stream()?;
    let topic = topic_name(cfg.run);
    let ep = Endpoints { write: None, read: Some(&topic), reliable: cfg.reliable, depth: 0, participant_name: None };
    let reqs = buffer_endpoints(&mut c.core, out, &ep)?;
    let tracker = Tracker { last: vec![None; cfg.publishers], ..Tracker::default() };
    let mut h = Handler::new(tracker);
    c.wait_statuses(&mut h, &reqs, Duration::from_secs(5))?;
    request_all(&mut c.core, out, if cfg.reliable { in_rel } else { in_be })?;
    c.flush()?;
    Ok((c, h))
}

fn subscriber(
    cfg: &ThroughputConfig,
    index: usize,
    sub_history: usize,
    ready: &mpsc::Sender<Result<(), String>>,
    stop: &AtomicBool,
    counter: &AtomicU64,
) -> Result<SubResult, BenchError> {
    let mut out_buf = vec![0u8; cfg.mtu * 4];
    let mut in_buf = vec![0u8; cfg.mtu * sub_history];
    let (mut c, mut h) = match setup_subscriber(cfg, index, sub_history, &mut out_buf, &mut in_buf) {
        Ok(x) => {
            let _ = ready.send(Ok(()));
            x
        }
        Err(e) => {
            let _ = ready.send(Err(e.to_string()));
            return Err(e);
        }
    };
    while !stop.load(Ordering::Relaxed) {
        c.poll(&mut h, Some(Duration::from_millis(20)))?;
        counter.store(h.data.received, Ordering::Relaxed);
    }
    let t = &h.data;
    let result = SubResult {
        received: t.received,
        duplicates: t.duplicates,
        out_of_order: t.out_of_order,
        last_rx: t.last_rx,
        datagrams: c.datagrams_received,
        datagrams_out: c.datagrams_sent,
    };
    let _ = c.delete_session(Duration::from_millis(300));
    Ok(result)
}

/// Bytes of a WRITE_DATA message besides the sample: header (up to 8), submessage header, object id and
/// request id.
const MESSAGE_OVERHEAD: usize = 16;

/// Writes one sample as a continuous fragmented WRITE_DATA (a sample larger than the whole history).
fn write_fragmented(c: &mut Client<'_>, stream: StreamId, data: &[u8], give_up: Instant) -> Result<bool, BenchError> {
    let mut h = client::status_only();
    loop {
        match c.core.outputs().begin_fragmented(stream, ids::WRITER, data.len()) {
            Ok(_) => break,
            Err(xrce_client::Error::WouldBlock) => {
                if Instant::now() >= give_up {
                    return Ok(false);
                }
                c.poll(&mut h, Some(Duration::from_millis(2)))?;
            }
            Err(e) => return Err(e.into()),
        }
    }
    let mut rest = data;
    // Once started the chain must be completed (the agent expects every announced byte); bounded by give_up
    // plus a grace period.
    let hard = give_up + Duration::from_secs(2);
    while !rest.is_empty() {
        let n = c.core.outputs().push_fragmented(stream, rest)?;
        rest = rest.get(n..).unwrap_or(&[]);
        c.flush()?;
        if !rest.is_empty() {
            if Instant::now() >= hard {
                return Err(BenchError::Timeout("fragmented sample not acknowledged"));
            }
            c.poll(&mut h, Some(Duration::from_millis(2)))?;
        }
    }
    Ok(true)
}

fn setup_publisher<'a>(
    cfg: &ThroughputConfig,
    index: usize,
    rel_buf: &'a mut [u8],
    be_buf: &'a mut [u8],
    in_buf: &'a mut [u8],
) -> Result<(Client<'a>, StreamId), BenchError> {
    let key = client_key(cfg.run, u32::try_from(index).unwrap_or(0));
    let mut c = Client::new(cfg.agent, key, cfg.mtu)?;
    c.sock().set_recv_buffer(1 << 20)?;
    c.create_session(5)?;
    let rel = c.core.create_output_reliable_stream(rel_buf, cfg.history)?;
    let be = c.core.create_output_best_effort_stream(be_buf)?;
    c.core.create_input_reliable_stream(in_buf, 4)?;
    let topic = topic_name(cfg.run);
    let ep = Endpoints { write: Some(&topic), read: None, reliable: cfg.reliable, depth: 0, participant_name: None };
    let reqs = buffer_endpoints(&mut c.core, rel, &ep)?;
    let mut h = client::status_only();
    c.wait_statuses(&mut h, &reqs, Duration::from_secs(5))?;
    Ok((c, if cfg.reliable { rel } else { be }))
}

/// What publishers share: the first one's progress, everybody's total, the subscribers' counters (for
/// [`ThroughputConfig::window`]).
struct Shared<'s> {
    progress: &'s AtomicU64,
    total_sent: &'s AtomicU64,
    received: &'s [AtomicU64],
}

impl Shared<'_> {
    /// Whether the slowest subscriber is `window` samples or more behind everything written.
    fn too_far_ahead(&self, window: Option<u64>) -> bool {
        let Some(w) = window else { return false };
        let slowest = self.received.iter().map(|c| c.load(Ordering::Relaxed)).min().unwrap_or(0);
        self.total_sent.load(Ordering::Relaxed).saturating_sub(slowest) >= w
    }
}

fn publisher(
    cfg: &ThroughputConfig,
    index: usize,
    barrier: &Barrier,
    shared: &Shared<'_>,
) -> Result<PubResult, BenchError> {
    let mut rel_buf = vec![0u8; cfg.mtu * cfg.history];
    let mut be_buf = vec![0u8; cfg.mtu];
    let mut in_buf = vec![0u8; cfg.mtu * 4];
    let setup = setup_publisher(cfg, index, &mut rel_buf, &mut be_buf, &mut in_buf);
    // Everybody meets twice (setup done, go) whatever happened, so nobody waits forever.
    barrier.wait();
    barrier.wait();
    let (mut c, stream) = setup?;

    let start = Instant::now();
    let end = start + cfg.duration;
    let mut r = PubResult::default();
    let mut sample = vec![0u8; cfg.payload.max(1)];
    let publisher = u32::try_from(index).unwrap_or(u32::MAX);
    let mut h = client::status_only();
    // Samples that do not fit one message go through the continuous API from the start when asked to.
    let mut fragmented = cfg.continuous && cfg.reliable && cfg.payload + MESSAGE_OVERHEAD > cfg.mtu;
    let mut seq: u32 = 0;
    let mut now = start;
    while now < end {
        // Pacing: a fixed rate, or a bounded lead over the slowest subscriber.
        if let Some(rate) = cfg.rate.filter(|&r| r > 0.0) {
            let due = start + Duration::from_secs_f64(r.sent as f64 / rate);
            if due > now {
                c.poll(&mut h, Some((due - now).min(Duration::from_millis(5))))?;
                now = Instant::now();
                continue;
            }
        }
        if shared.too_far_ahead(cfg.window) {
            c.poll(&mut h, Some(Duration::from_millis(1)))?;
            now = Instant::now();
            continue;
        }
        SampleHeader { publisher, seq, sent_ns: 0 }.write(&mut sample);
        let written = if fragmented {
            write_fragmented(&mut c, stream, &sample, end)?
        } else {
            match c.core.buffer_topic(stream, ids::WRITER, &sample) {
                Ok(_) => true,
                Err(xrce_client::Error::WouldBlock) => {
                    r.would_block += 1;
                    c.poll(&mut h, Some(Duration::from_millis(2)))?;
                    false
                }
                Err(xrce_client::Error::TooLarge) if cfg.reliable => {
                    fragmented = true;
                    false
                }
                Err(xrce_client::Error::TooLarge) => {
                    return Err(BenchError::Config(format!(
                        "a best-effort sample of {} B does not fit one {} B message",
                        cfg.payload, cfg.mtu
                    )))
                }
                Err(e) => return Err(e.into()),
            }
        };
        if written {
            r.sent += 1;
            shared.total_sent.fetch_add(1, Ordering::Relaxed);
            seq = seq.wrapping_add(1);
            // One sample per datagram. Acknowledgements are read when the history is full (the WouldBlock
            // arm waits for the next one, or takes those already queued at once): ACKNACKs are cumulative,
            // so reading them late loses nothing, and a read per sample would mostly find the socket empty.
            c.flush()?;
            if r.sent % 256 == 0 {
                c.poll(&mut h, None)?;
            }
            if index == 0 && r.sent % 1024 == 0 {
                shared.progress.store(r.sent, Ordering::Relaxed);
            }
        }
        now = Instant::now();
    }
    r.elapsed = start.elapsed();
    // Let the agent acknowledge everything (reliable), bounded by the drain time.
    let give_up = Instant::now() + cfg.drain;
    while cfg.reliable && !c.core.output_streams_confirmed() && Instant::now() < give_up {
        c.poll(&mut h, Some(Duration::from_millis(10)))?;
    }
    r.datagrams = c.datagrams_sent;
    let _ = c.delete_session(Duration::from_millis(300));
    Ok(r)
}

/// Runs the throughput benchmark. `on_progress(elapsed fraction)` is called a few times a second while the
/// publishers write.
pub fn run(cfg: &ThroughputConfig, on_progress: &(dyn Fn(f64) + Sync)) -> Result<ThroughputResult, BenchError> {
    if cfg.publishers == 0 || cfg.subscribers == 0 {
        return Err(BenchError::Config("at least one publisher and one subscriber".into()));
    }
    if !cfg.history.is_power_of_two() || cfg.mtu < 64 {
        return Err(BenchError::Config("history must be a power of two, MTU at least 64".into()));
    }
    let sub_history = if cfg.reliable { history_for(cfg.payload, cfg.mtu, cfg.history) } else { cfg.history };
    let stop = AtomicBool::new(false);
    let counters: Vec<AtomicU64> = (0..cfg.subscribers).map(|_| AtomicU64::new(0)).collect();
    let barrier = Barrier::new(cfg.publishers + 1);
    let progress = AtomicU64::new(0);
    let finished = AtomicUsize::new(0);
    let total_sent = AtomicU64::new(0);
    let shared = Shared { progress: &progress, total_sent: &total_sent, received: &counters };

    std::thread::scope(|s| {
        let (tx, rx) = mpsc::channel();
        let subs: Vec<_> = counters
            .iter()
            .enumerate()
            .map(|(i, counter)| {
                let tx = tx.clone();
                let stop = &stop;
                s.spawn(move || subscriber(cfg, i, sub_history, &tx, stop, counter))
            })
            .collect();
        drop(tx);
        let mut setup_error = None;
        for _ in 0..cfg.subscribers {
            match rx.recv_timeout(Duration::from_secs(15)) {
                Ok(Ok(())) => {}
                Ok(Err(e)) => setup_error = Some(BenchError::Config(format!("subscriber setup: {e}"))),
                Err(_) => setup_error = Some(BenchError::Timeout("subscriber setup")),
            }
        }
        if let Some(e) = setup_error {
            stop.store(true, Ordering::Relaxed);
            for h in subs {
                let _ = h.join();
            }
            return Err(e);
        }

        let pubs: Vec<_> = (0..cfg.publishers)
            .map(|i| {
                let (barrier, shared, finished) = (&barrier, &shared, &finished);
                s.spawn(move || {
                    let r = publisher(cfg, i, barrier, shared);
                    finished.fetch_add(1, Ordering::Relaxed);
                    r
                })
            })
            .collect();
        barrier.wait();
        let monitor = cfg.agent_pid.map(|pid| Monitor::start(pid, Duration::from_millis(100))).transpose()?;
        barrier.wait();
        let start = Instant::now();
        while finished.load(Ordering::Relaxed) < cfg.publishers {
            std::thread::sleep(Duration::from_millis(100));
            on_progress((start.elapsed().as_secs_f64() / cfg.duration.as_secs_f64().max(1e-9)).min(1.0));
        }
        let agent = monitor.map(Monitor::stop).transpose()?;
        let mut pub_results = Vec::new();
        let mut first_error = None;
        for h in pubs {
            match join(h.join(), "publisher") {
                Ok(r) => pub_results.push(r),
                Err(e) => {
                    first_error.get_or_insert(e);
                }
            }
        }
        let sent: u64 = pub_results.iter().map(|r| r.sent).sum();
        // Drain: until every subscriber has everything, or nothing arrived for a while, or the drain time.
        let expected = sent;
        let drain_end = Instant::now() + cfg.drain;
        let quiet = if cfg.reliable { Duration::from_millis(1000) } else { Duration::from_millis(300) };
        let total = || counters.iter().map(|c| c.load(Ordering::Relaxed)).sum::<u64>();
        let mut last_total = total();
        let mut last_change = Instant::now();
        while Instant::now() < drain_end && first_error.is_none() {
            if counters.iter().all(|c| c.load(Ordering::Relaxed) >= expected) {
                break;
            }
            std::thread::sleep(Duration::from_millis(20));
            let t = total();
            if t != last_total {
                last_total = t;
                last_change = Instant::now();
            } else if last_change.elapsed() >= quiet {
                break;
            }
        }
        stop.store(true, Ordering::Relaxed);
        let mut sub_results = Vec::new();
        for h in subs {
            match join(h.join(), "subscriber") {
                Ok(r) => sub_results.push(r),
                Err(e) => {
                    first_error.get_or_insert(e);
                }
            }
        }
        if let Some(e) = first_error {
            return Err(e);
        }

        let elapsed = pub_results.iter().map(|r| r.elapsed).max().unwrap_or_default().as_secs_f64().max(1e-9);
        let received: u64 = sub_results.iter().map(|r| r.received).sum();
        let last_rx = sub_results.iter().filter_map(|r| r.last_rx).max();
        let window = last_rx.map_or(elapsed, |t| t.saturating_duration_since(start).as_secs_f64().max(elapsed));
        let expected_all = sent.saturating_mul(cfg.subscribers as u64);
        let loss_pct = if expected_all > 0 {
            100.0 * expected_all.saturating_sub(received) as f64 / expected_all as f64
        } else {
            0.0
        };
        Ok(ThroughputResult {
            bench: "throughput",
            mode: cfg.mode(),
            payload: cfg.payload,
            publishers: cfg.publishers,
            subscribers: cfg.subscribers,
            mtu: cfg.mtu,
            history: cfg.history,
            sub_history,
            duration_s: elapsed,
            sent,
            sent_per_s: sent as f64 / elapsed,
            received,
            received_per_s: received as f64 / window,
            loss_pct,
            duplicates: sub_results.iter().map(|r| r.duplicates).sum(),
            out_of_order: sub_results.iter().map(|r| r.out_of_order).sum(),
            would_block: pub_results.iter().map(|r| r.would_block).sum(),
            datagrams_out: pub_results.iter().map(|r| r.datagrams).sum(),
            datagrams_in: sub_results.iter().map(|r| r.datagrams).sum(),
            sub_datagrams_out: sub_results.iter().map(|r| r.datagrams_out).sum(),
            agent,
        })
    })
}
