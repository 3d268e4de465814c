//! `latency`: ping-pong through the agent. The pinger writes a sample on topic `ping`; an echo client reads
//! `ping` and writes every sample back on topic `pong`, which the pinger reads. One sample outstanding at a
//! time; the round trip is four datagram hops (pinger → agent → echo → agent → pinger).

use std::net::SocketAddr;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use xrce_client::{ObjectId, Outputs, StreamId, WriteAccessExt};

use crate::client::{buffer_endpoints, ids, request_all, Client, Endpoints, Handler, OnData};
use crate::{client_key, join, BenchError, Percentiles, SampleHeader};

/// Parameters of a latency run.
#[derive(Debug, Clone)]
pub struct LatencyConfig {
    /// The agent.
    pub agent: SocketAddr,
    /// Round trips measured.
    pub samples: usize,
    /// Round trips before measuring (not counted).
    pub warmup: usize,
    /// Sample size in bytes.
    pub payload: usize,
    /// Reliable streams and QoS (else best effort).
    pub reliable: bool,
    /// MTU of both clients.
    pub mtu: usize,
    /// History of the reliable streams.
    pub history: usize,
    /// Longest wait for one echo before counting it lost.
    pub timeout: Duration,
    /// Participants named `xrce_bench_ping` and `xrce_bench_echo` (else unnamed).
    pub named: bool,
    /// Run id.
    pub run: u32,
}

impl LatencyConfig {
    /// Defaults for `agent`: 10,000 samples of 16 B, best effort, MTU 512.
    pub fn new(agent: SocketAddr) -> Self {
        Self {
            agent,
            samples: 10_000,
            warmup: 200,
            payload: 16,
            reliable: false,
            mtu: 512,
            history: 8,
            timeout: Duration::from_millis(500),
            named: false,
            run: crate::run_id(),
        }
    }
}

/// What a latency run measured.
#[derive(Debug, Clone, Default, serde::Serialize)]
pub struct LatencyResult {
    /// `"latency"`.
    pub bench: &'static str,
    /// `"reliable"` or `"best-effort"`.
    pub mode: &'static str,
    /// Sample size.
    pub payload: usize,
    /// Round trips measured.
    pub samples: usize,
    /// Pings without an echo within the timeout.
    pub lost: usize,
    /// Round-trip times in µs.
    pub rtt_us: Percentiles,
}

/// Echo: writes every sample it reads back on its own writer.
struct Echo {
    stream: StreamId,
    echoed: u64,
}

impl OnData for Echo {
    fn on_data(&mut self, out: &mut Outputs<'_, '_>, _: ObjectId, data: &[u8]) {
        if out.buffer_topic(self.stream, ids::WRITER, data).is_ok() {
            self.echoed += 1;
        }
    }
}

/// Pinger: remembers the newest sequence number echoed.
#[derive(Default)]
struct Pong {
    last: Option<u32>,
}

impl OnData for Pong {
    fn on_data(&mut self, _: &mut Outputs<'_, '_>, _: ObjectId, data: &[u8]) {
        if let Some(h) = SampleHeader::read(data) {
            self.last = Some(h.seq);
        }
    }
}

struct Streams {
    out: StreamId,
    data_out: StreamId,
    data_in: StreamId,
}

fn setup<'a, D: OnData>(
    c: &mut Client<'a>,
    cfg: &LatencyConfig,
    bufs: (&'a mut [u8], &'a mut [u8], &'a mut [u8]),
    write: &str,
    read: &str,
    name: &str,
    h: &mut Handler<D>,
) -> Result<Streams, BenchError> {
    let (rel_out, be_out, rel_in) = bufs;
    c.create_session(5)?;
    let rel = c.core.create_output_reliable_stream(rel_out, cfg.history)?;
    let be = c.core.create_output_best_effort_stream(be_out)?;
    let in_rel = c.core.create_input_reliable_stream(rel_in, cfg.history)?;
    let in_be = c.core.create_input_best_effort_stream()?;
    let participant_name = cfg.named.then_some(name);
    let ep = Endpoints { write: Some(write), read: Some(read), reliable: cfg.reliable, depth: 0, participant_name };
    let reqs = buffer_endpoints(&mut c.core, rel, &ep)?;
    c.wait_statuses(h, &reqs, Duration::from_secs(5))?;
    let s = if cfg.reliable {
        Streams { out: rel, data_out: rel, data_in: in_rel }
    } else {
        Streams { out: rel, data_out: be, data_in: in_be }
    };
    request_all(&mut c.core, s.out, s.data_in)?;
    c.flush()?;
    Ok(s)
}

fn echo(
    cfg: &LatencyConfig,
    ping: &str,
    pong: &str,
    ready: &mpsc::Sender<Result<(), String>>,
    stop: &AtomicBool,
) -> Result<u64, BenchError> {
    let (mut a, mut b, mut i) =
        (vec![0u8; cfg.mtu * cfg.history], vec![0u8; cfg.mtu], vec![0u8; cfg.mtu * cfg.history]);
    let mut c = Client::new(cfg.agent, client_key(cfg.run, 0x2001), cfg.mtu)?;
    let mut h = Handler::new(Echo { stream: StreamId::NONE, echoed: 0 });
    match setup(&mut c, cfg, (&mut a, &mut b, &mut i), pong, ping, "xrce_bench_echo", &mut h) {
        Ok(s) => {
            h.data.stream = s.data_out;
            let _ = ready.send(Ok(()));
        }
        Err(e) => {
            let _ = ready.send(Err(e.to_string()));
            return Err(e);
        }
    }
    while !stop.load(Ordering::Relaxed) {
        // `poll` flushes after handling, so each echo leaves as soon as its ping was read.
        c.poll(&mut h, Some(Duration::from_millis(20)))?;
    }
    let _ = c.delete_session(Duration::from_millis(300));
    Ok(h.data.echoed)
}

/// Runs the latency benchmark; `on_progress(fraction done)` is called every few hundred samples.
pub fn run(cfg: &LatencyConfig, on_progress: &(dyn Fn(f64) + Sync)) -> Result<LatencyResult, BenchError> {
    if cfg.payload < SampleHeader::SIZE {
        return Err(BenchError::Config(format!("latency needs a payload of at least {} B", SampleHeader::SIZE)));
    }
    let ping = format!("xrce_bench_ping_{:08x}", cfg.run);
    let pong = format!("xrce_bench_pong_{:08x}", cfg.run);
    let stop = AtomicBool::new(false);
    std::thread::scope(|s| {
        let (tx, rx) = mpsc::channel();
        let (ping, pong, stop) = (&ping, &pong, &stop);
        let echo_thread = s.spawn(move || echo(cfg, ping, pong, &tx, stop));
        let ready = rx.recv_timeout(Duration::from_secs(15));
        let result = match ready {
            Ok(Ok(())) => pinger(cfg, ping, pong, on_progress),
            Ok(Err(e)) => Err(BenchError::Config(format!("echo setup: {e}"))),
            Err(_) => Err(BenchError::Timeout("echo setup")),
        };
        stop.store(true, Ordering::Relaxed);
        let echoed = join(echo_thread.join(), "echo");
        // A failure of the pinger says more than the echo's (which follows from it).
        let r = result?;
        echoed?;
        Ok(r)
    })
}

fn pinger(
    cfg: &LatencyConfig,
    ping: &str,
    pong: &str,
    on_progress: &(dyn Fn(f64) + Sync),
) -> Result<LatencyResult, BenchError> {
    let (mut a, mut b, mut i) =
        (vec![0u8; cfg.mtu * cfg.history], vec![0u8; cfg.mtu], vec![0u8; cfg.mtu * cfg.history]);
    let mut c = Client::new(cfg.agent, client_key(cfg.run, 0x2000), cfg.mtu)?;
    let mut h = Handler::new(Pong::default());
    let streams = setup(&mut c, cfg, (&mut a, &mut b, &mut i), ping, pong, "xrce_bench_ping", &mut h)?;
    let mut sample = vec![0u8; cfg.payload];
    let mut rtts = Vec::with_capacity(cfg.samples);
    let mut lost = 0;
    let total = cfg.warmup + cfg.samples;
    for n in 0..total {
        let seq = u32::try_from(n).unwrap_or(u32::MAX);
        SampleHeader { publisher: 0, seq, sent_ns: 0 }.write(&mut sample);
        let t0 = Instant::now();
        // A reliable history may be full of unacknowledged messages: run until there is room. Still full
        // after the timeout (a long loss burst on a lossy link): this ping counts as lost, the run goes on.
        let mut written = false;
        while !written && t0.elapsed() < cfg.timeout {
            match c.core.buffer_topic(streams.data_out, ids::WRITER, &sample) {
                Ok(_) => written = true,
                Err(xrce_client::Error::WouldBlock) => {
                    c.poll(&mut h, Some(Duration::from_millis(1)))?;
                }
                Err(e) => return Err(e.into()),
            }
        }
        if !written {
            if n >= cfg.warmup {
                lost += 1;
            }
            continue;
        }
        c.flush()?;
        let deadline = t0 + cfg.timeout;
        let mut got = false;
        while Instant::now() < deadline {
            c.poll(&mut h, Some(deadline.saturating_duration_since(Instant::now())))?;
            if h.data.last == Some(seq) {
                got = true;
                break;
            }
        }
        let rtt = t0.elapsed();
        if n >= cfg.warmup {
            if got {
                rtts.push(rtt.as_secs_f64() * 1e6);
            } else {
                lost += 1;
            }
        }
        if n % 256 == 0 {
            on_progress(n as f64 / total as f64);
        }
    }
    let _ = c.delete_session(Duration::from_millis(300));
    Ok(LatencyResult {
        bench: "latency",
        mode: if cfg.reliable { "reliable" } else { "best-effort" },
        payload: cfg.payload,
        samples: cfg.samples,
        lost,
        rtt_us: Percentiles::of(&mut rtts),
    })
}
