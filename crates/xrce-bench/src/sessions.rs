//! `sessions`: N concurrent clients with distinct keys, each creating a session, a participant, a topic, a
//! publisher and a datawriter (binary representation). Measures the time to create them all, the failures and,
//! given the agent's PID, how much resident memory each client costs the agent.
//!
//! Each client is a sans-IO [`SessionCore`] with its own UDP socket (the agent tells keyless sessions apart by
//! address); a few worker threads drive them, each keeping a window of clients in flight, so 10,000 clients
//! need neither 10,000 threads nor much memory (2 KiB of stream buffers each). The sessions stay open until
//! the memory was measured, then are deleted (unless asked not to).

use std::net::{SocketAddr, UdpSocket};
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::sync::{Barrier, Mutex};
use std::time::{Duration, Instant};

use xrce_client::session::SessionState;
use xrce_client::Clock;
use xrce_client::{Callbacks, ObjectId, Outputs, SessionCore, StdClock};

use crate::client::{bind_for, buffer_endpoints, recv_result, status_ok, Endpoints};
use crate::procstat::{self, AgentUsage, Monitor};
use crate::{client_key, join, BenchError, Percentiles};

/// Parameters of a sessions run.
#[derive(Debug, Clone)]
pub struct SessionsConfig {
    /// The agent.
    pub agent: SocketAddr,
    /// Clients to create.
    pub clients: usize,
    /// Worker threads driving them.
    pub workers: usize,
    /// Clients in flight per worker.
    pub window: usize,
    /// MTU of the clients.
    pub mtu: usize,
    /// Longest time one client may take.
    pub timeout: Duration,
    /// The agent's PID, to measure its memory.
    pub agent_pid: Option<u32>,
    /// Clients created (and kept) before the first RSS sample, so one-off costs (a DDS participant, the
    /// shared topic, pools, code pages) are not counted per client; 0 counts everything.
    pub warmup: usize,
    /// How long the agent is left alone after the last client before its RSS is sampled: what an idle
    /// client costs once the agent's periodic work (trimming idle streams, dropping expired first-contact
    /// gates) has run.
    pub settle: Duration,
    /// Delete the sessions at the end.
    pub delete: bool,
    /// Name every participant (`node_<client key>`, all distinct), as micro-ROS does: with the DDS
    /// middleware each is then a ROS 2 node.
    pub named: bool,
    /// Run id.
    pub run: u32,
}

impl SessionsConfig {
    /// Defaults for `agent`: 100 clients, 2 workers of 64 in flight, MTU 512, 10 s each, deleted at the end.
    pub fn new(agent: SocketAddr) -> Self {
        Self {
            agent,
            clients: 100,
            workers: 2,
            window: 64,
            mtu: 512,
            timeout: Duration::from_secs(10),
            agent_pid: None,
            warmup: 1,
            settle: Duration::from_millis(300),
            delete: true,
            named: false,
            run: crate::run_id(),
        }
    }
}

/// What a sessions run measured.
#[derive(Debug, Clone, Default, serde::Serialize)]
pub struct SessionsResult {
    /// `"sessions"`.
    pub bench: &'static str,
    /// Clients asked for.
    pub clients: usize,
    /// Clients with session and four entities created.
    pub ok: usize,
    /// Clients that failed.
    pub failed: usize,
    /// Failures by reason.
    pub failures: std::collections::BTreeMap<String, usize>,
    /// Seconds from the first CREATE_CLIENT to the last entity status.
    pub elapsed_s: f64,
    /// Clients completed per second.
    pub clients_per_s: f64,
    /// Time each client took, ms.
    pub create_ms: Percentiles,
    /// Warm-up clients created before `agent_rss_before_kib` was sampled (not in `clients`).
    pub warmup: usize,
    /// The agent's `VmRSS` before any client (warm-up included), KiB.
    pub agent_rss_start_kib: Option<u64>,
    /// The agent's `VmRSS` after the warm-up clients, before the first measured client, KiB.
    pub agent_rss_before_kib: Option<u64>,
    /// The agent's `VmRSS` with every client alive, KiB.
    pub agent_rss_after_kib: Option<u64>,
    /// RSS growth per successful client after the warm-up, bytes (the marginal cost of a client).
    pub agent_rss_per_client_b: Option<f64>,
    /// RSS growth from the start, warm-up included, per client (warm-up clients counted), bytes.
    pub agent_rss_per_client_total_b: Option<f64>,
    /// The agent's CPU and peak memory while the clients were created.
    pub agent: Option<AgentUsage>,
    /// Sessions whose deletion the agent confirmed.
    pub deleted: usize,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Stage {
    Creating,
    Entities,
    Done,
    Failed(&'static str),
}

/// Records the statuses of the four creation requests.
#[derive(Debug, Default)]
struct Track {
    requests: [u16; 4],
    statuses: [Option<u8>; 4],
}

impl Callbacks for Track {
    fn on_status(&mut self, _: &mut Outputs<'_, '_>, _: ObjectId, request_id: u16, status: u8) {
        for (r, s) in self.requests.iter().zip(self.statuses.iter_mut()) {
            if *r == request_id {
                *s = Some(status);
            }
        }
    }
}

struct Slot<'a> {
    core: SessionCore<'a>,
    sock: UdpSocket,
    stage: Stage,
    start: Instant,
    took: Duration,
    track: Track,
    out: xrce_client::StreamId,
    name: Option<String>,
}

/// Per-worker outcome.
#[derive(Debug, Default)]
struct WorkerResult {
    ok: usize,
    failures: Vec<&'static str>,
    times_ms: Vec<f64>,
    deleted: usize,
}

const OUT_HISTORY: usize = 2;
const IN_HISTORY: usize = 2;

fn new_slot<'a>(cfg: &SessionsConfig, key: u32, buf: &'a mut [u8], now: i64) -> Result<Slot<'a>, BenchError> {
    let sock = bind_for(cfg.agent)?;
    sock.connect(cfg.agent)?;
    sock.set_nonblocking(true)?;
    let (out_buf, in_buf) = buf.split_at_mut(cfg.mtu * OUT_HISTORY);
    let mut core = SessionCore::new(xrce_client::session::DEFAULT_SESSION_ID, key, cfg.mtu);
    let out = core.create_output_reliable_stream(out_buf, OUT_HISTORY)?;
    core.create_input_reliable_stream(in_buf, IN_HISTORY)?;
    core.create_session_retries(3, now);
    Ok(Slot {
        core,
        sock,
        stage: Stage::Creating,
        start: Instant::now(),
        took: Duration::ZERO,
        track: Track::default(),
        out,
        name: cfg.named.then(|| format!("node_{key:08x}")),
    })
}

/// Advances one client: input, stage changes, output. Whether anything happened.
fn step(
    cfg: &SessionsConfig,
    slot: &mut Slot<'_>,
    topic: &str,
    clock: &mut StdClock,
    rx: &mut [u8],
    tx: &mut [u8],
) -> bool {
    let mut progress = false;
    // Input (bounded per call).
    for _ in 0..16 {
        match recv_result(slot.sock.recv(rx)) {
            Ok(Some(n)) => {
                slot.core.handle_input(rx.get(..n).unwrap_or(&[]), clock.now_nanos(), &mut slot.track);
                progress = true;
            }
            Ok(None) => break,
            Err(_) => {
                slot.stage = Stage::Failed("socket error");
                return true;
            }
        }
    }
    match (slot.stage, slot.core.state()) {
        (Stage::Creating, SessionState::Established) => {
            let ep = Endpoints {
                write: Some(topic),
                read: None,
                reliable: true,
                depth: 0,
                participant_name: slot.name.as_deref(),
            };
            match buffer_endpoints(&mut slot.core, slot.out, &ep) {
                Ok(reqs) => {
                    for (dst, (_, r)) in slot.track.requests.iter_mut().zip(reqs) {
                        *dst = r;
                    }
                    slot.core.flash_output_streams();
                    slot.stage = Stage::Entities;
                }
                Err(_) => slot.stage = Stage::Failed("buffering entities"),
            }
            progress = true;
        }
        (Stage::Creating, SessionState::Refused(_)) => slot.stage = Stage::Failed("session refused"),
        (Stage::Creating, SessionState::CreateTimedOut) => slot.stage = Stage::Failed("session timeout"),
        (Stage::Entities, _) if slot.track.statuses.iter().all(Option::is_some) => {
            slot.stage = if slot.track.statuses.iter().flatten().all(|&s| status_ok(s)) {
                Stage::Done
            } else {
                Stage::Failed("entity refused")
            };
            progress = true;
        }
        _ => {}
    }
    if matches!(slot.stage, Stage::Creating | Stage::Entities) && slot.start.elapsed() > cfg.timeout {
        slot.stage = if slot.stage == Stage::Creating {
            Stage::Failed("session timeout")
        } else {
            Stage::Failed("entity timeout")
        };
    }
    if matches!(slot.stage, Stage::Done | Stage::Failed(_)) {
        slot.took = slot.start.elapsed();
        return true;
    }
    let now = clock.now_nanos();
    while let Some(n) = slot.core.poll_transmit(now, tx) {
        if slot.sock.send(tx.get(..n).unwrap_or(&[])).is_err() {
            // Full send buffer or ICMP error: the core retries on its timers.
            break;
        }
        progress = true;
    }
    progress
}

/// Hands every datagram waiting on a finished client's socket to its session; whether there was any.
fn receive_all(slot: &mut Slot<'_>, now: i64, rx: &mut [u8]) -> bool {
    let mut any = false;
    while let Ok(Some(n)) = recv_result(slot.sock.recv(rx)) {
        slot.core.handle_input(rx.get(..n).unwrap_or(&[]), now, &mut slot.track);
        any = true;
    }
    any
}

#[allow(clippy::too_many_arguments)]
fn worker(
    cfg: &SessionsConfig,
    first: usize,
    count: usize,
    topic: &str,
    done: &AtomicU64,
    finished: &AtomicUsize,
    measured: &AtomicBool,
    barrier: &Barrier,
    out: &Mutex<Vec<WorkerResult>>,
) {
    let per = cfg.mtu * (OUT_HISTORY + IN_HISTORY);
    let mut pool = vec![0u8; per * count];
    let mut chunks = pool.chunks_mut(per);
    let mut clock = StdClock::default();
    let (mut rx, mut tx) = (vec![0u8; 65_536], vec![0u8; cfg.mtu]);
    let mut slots: Vec<Slot<'_>> = Vec::with_capacity(count);
    let mut active: Vec<usize> = Vec::with_capacity(cfg.window);
    let mut result = WorkerResult::default();
    // Bounded: every client ends within its timeout; the loop ends when all have.
    let mut started = 0;
    while started < count || !active.is_empty() {
        while active.len() < cfg.window.max(1) && started < count {
            let Some(buf) = chunks.next() else { break };
            let key = client_key(cfg.run, u32::try_from(first + started).unwrap_or(u32::MAX));
            match new_slot(cfg, key, buf, clock.now_nanos()) {
                Ok(s) => {
                    active.push(slots.len());
                    slots.push(s);
                }
                Err(_) => {
                    result.failures.push("socket");
                    done.fetch_add(1, Ordering::Relaxed);
                }
            }
            started += 1;
        }
        let mut progress = false;
        let mut i = 0;
        while let Some(&index) = active.get(i) {
            let Some(slot) = slots.get_mut(index) else { break };
            progress |= step(cfg, slot, topic, &mut clock, &mut rx, &mut tx);
            match slot.stage {
                Stage::Done => {
                    result.ok += 1;
                    result.times_ms.push(slot.took.as_secs_f64() * 1e3);
                }
                Stage::Failed(why) => result.failures.push(why),
                _ => {
                    i += 1;
                    continue;
                }
            }
            done.fetch_add(1, Ordering::Relaxed);
            active.swap_remove(i);
        }
        if !progress {
            std::thread::sleep(Duration::from_micros(200));
        }
    }
    finished.fetch_add(1, Ordering::Relaxed);
    // Keep every session open, and alive as an idle micro-ROS node keeps it (its executor spinning: the
    // agent's heartbeats answered, so it can let go of what it kept for retransmission), while the main
    // thread measures the agent.
    while !measured.load(Ordering::Relaxed) {
        let now = clock.now_nanos();
        for slot in slots.iter_mut().filter(|s| s.stage == Stage::Done) {
            receive_all(slot, now, &mut rx);
            while let Some(n) = slot.core.poll_transmit(now, &mut tx) {
                let _ = slot.sock.send(tx.get(..n).unwrap_or(&[]));
            }
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    barrier.wait();
    barrier.wait();
    if cfg.delete {
        let now = clock.now_nanos();
        let mut deleting: Vec<usize> = Vec::new();
        for (i, slot) in slots.iter_mut().enumerate() {
            if slot.stage == Stage::Done {
                slot.core.delete_session_retries(1, now);
                while let Some(n) = slot.core.poll_transmit(now, &mut tx) {
                    let _ = slot.sock.send(tx.get(..n).unwrap_or(&[]));
                }
                deleting.push(i);
            }
        }
        let give_up = Instant::now() + Duration::from_secs(3);
        while !deleting.is_empty() && Instant::now() < give_up {
            let mut progress = false;
            deleting.retain(|&i| {
                let Some(slot) = slots.get_mut(i) else { return false };
                progress |= receive_all(slot, clock.now_nanos(), &mut rx);
                if slot.core.state() == SessionState::Deleted {
                    result.deleted += 1;
                    false
                } else {
                    true
                }
            });
            if !progress {
                std::thread::sleep(Duration::from_millis(1));
            }
        }
    }
    if let Ok(mut v) = out.lock() {
        v.push(result);
    }
}

/// Runs the sessions benchmark; `on_progress(fraction)` while clients are created.
pub fn run(cfg: &SessionsConfig, on_progress: &(dyn Fn(f64) + Sync)) -> Result<SessionsResult, BenchError> {
    if cfg.clients == 0 || cfg.workers == 0 {
        return Err(BenchError::Config("at least one client and one worker".into()));
    }
    let topic = format!("xrce_bench_sessions_{:08x}", cfg.run);
    let start_rss = cfg.agent_pid.map(procstat::sample).transpose()?;
    let warmup = cfg.warmup;
    let workers = cfg.workers.min(cfg.clients);
    let done = AtomicU64::new(0);
    let finished = AtomicUsize::new(0);
    let measured = AtomicBool::new(false);
    let warm_done = AtomicU64::new(0);
    let warm_finished = AtomicUsize::new(0);
    let warm_results = Mutex::new(Vec::new());
    let barrier = Barrier::new(workers + 1 + usize::from(warmup > 0));
    let results = Mutex::new(Vec::new());
    let (elapsed, before, after, agent) = std::thread::scope(|s| {
        // Warm-up clients (indices after the measured ones) first, kept alive like the others.
        let warm = (warmup > 0).then(|| {
            let (topic, done, finished, measured, barrier, results) =
                (&topic, &warm_done, &warm_finished, &measured, &barrier, &warm_results);
            s.spawn(move || worker(cfg, cfg.clients, warmup, topic, done, finished, measured, barrier, results))
        });
        let warm_until = Instant::now() + cfg.timeout + Duration::from_secs(1);
        while warm.is_some() && warm_finished.load(Ordering::Relaxed) == 0 && Instant::now() < warm_until {
            std::thread::sleep(Duration::from_millis(5));
        }
        let before = match cfg.agent_pid {
            Some(pid) => {
                // Let the agent settle (a DDS participant's first discovery rounds) before the sample.
                std::thread::sleep(Duration::from_millis(if warmup > 0 { 300 } else { 0 }));
                Some(procstat::sample(pid))
            }
            None => None,
        };
        let monitor = cfg.agent_pid.map(|pid| Monitor::start(pid, Duration::from_millis(100)));
        let start = Instant::now();
        let handles: Vec<_> = (0..workers)
            .map(|w| {
                let first = cfg.clients * w / workers;
                let count = cfg.clients * (w + 1) / workers - first;
                let (topic, done, finished, measured, barrier, results) =
                    (&topic, &done, &finished, &measured, &barrier, &results);
                s.spawn(move || worker(cfg, first, count, topic, done, finished, measured, barrier, results))
            })
            .collect();
        // Workers never fail before the barrier: each client failure is counted, not returned.
        while finished.load(Ordering::Relaxed) < workers {
            std::thread::sleep(Duration::from_millis(50));
            on_progress(done.load(Ordering::Relaxed) as f64 / cfg.clients as f64);
            if handles.iter().any(|h| h.is_finished()) && finished.load(Ordering::Relaxed) < workers {
                // Only a panicking worker ends early; the barrier would then never open.
                return Err(BenchError::Thread("sessions worker panicked".into()));
            }
        }
        let elapsed = start.elapsed();
        let after = cfg.agent_pid.map(|pid| {
            std::thread::sleep(cfg.settle);
            procstat::sample(pid)
        });
        let agent = monitor.map(|m| m.and_then(Monitor::stop));
        measured.store(true, Ordering::Relaxed);
        barrier.wait();
        barrier.wait();
        for h in handles.into_iter().chain(warm) {
            join(h.join().map(Ok), "sessions worker")?;
        }
        Ok((elapsed, before.transpose()?, after.transpose()?, agent.transpose()?))
    })?;
    let warm_ok: usize = warm_results.into_inner().map_or(0, |v| v.iter().map(|r| r.ok).sum());

    let results = results.into_inner().map_err(|_| BenchError::Thread("results lock poisoned".into()))?;
    let mut failures = std::collections::BTreeMap::new();
    let mut times = Vec::new();
    let (mut ok, mut deleted) = (0, 0);
    for r in results {
        ok += r.ok;
        deleted += r.deleted;
        times.extend(r.times_ms);
        for f in r.failures {
            *failures.entry(f.to_string()).or_insert(0) += 1;
        }
    }
    let failed = failures.values().sum();
    let secs = elapsed.as_secs_f64().max(1e-9);
    let rss_start = start_rss.map(|b| b.rss_kib);
    let rss_before = before.map(|b| b.rss_kib);
    let rss_after = after.map(|a| a.rss_kib);
    let growth = |from: Option<u64>, n: usize| match (from, rss_after) {
        (Some(b), Some(a)) if n > 0 => Some((a as f64 - b as f64) * 1024.0 / n as f64),
        _ => None,
    };
    Ok(SessionsResult {
        bench: "sessions",
        clients: cfg.clients,
        ok,
        failed,
        failures,
        elapsed_s: secs,
        clients_per_s: ok as f64 / secs,
        create_ms: Percentiles::of(&mut times),
        warmup: warm_ok,
        agent_rss_start_kib: rss_start,
        agent_rss_before_kib: rss_before,
        agent_rss_after_kib: rss_after,
        agent_rss_per_client_b: growth(rss_before, ok),
        agent_rss_per_client_total_b: growth(rss_start, ok + warm_ok),
        agent,
        deleted,
    })
}
