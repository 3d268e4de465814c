//! `xrce-bench`: benchmarks any DDS-XRCE agent (ours or eProsima's) the same way, measures the UDP ceiling of
//! the machine, and runs a deterministic lossy proxy for fault injection. See `docs/benchmarks.md`.
#![forbid(unsafe_code)]
#![cfg_attr(not(test), deny(clippy::unwrap_used, clippy::expect_used, clippy::indexing_slicing, clippy::panic))]

use std::net::{SocketAddr, ToSocketAddrs};
use std::process::ExitCode;
use std::sync::atomic::AtomicBool;
use std::time::Duration;

use clap::{Args, Parser, Subcommand};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

use xrce_bench::latency::{self, LatencyConfig};
use xrce_bench::lossy::{LinkConfig, MILLIS};
use xrce_bench::proxy::{Direction, Proxy, ProxyConfig};
use xrce_bench::report::{self, Row};
use xrce_bench::ros::{self, RosConfig};
use xrce_bench::sessions::{self, SessionsConfig};
use xrce_bench::throughput::{self, ThroughputConfig};
use xrce_bench::udp_ceiling::{self, CeilingConfig};
use xrce_bench::{parse_duration, BenchError};

#[derive(Parser, Debug)]
#[command(name = "xrce-bench", version, about = "Benchmarks and fault injection for DDS-XRCE agents")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// P publishers → agent → S subscribers: sent/s, received/s, loss, agent CPU and memory.
    Throughput(ThroughputArgs),
    /// Ping-pong through the agent (an echo client answers on another topic): RTT percentiles.
    Latency(LatencyArgs),
    /// N concurrent clients each creating session, participant, topic, publisher, datawriter.
    Sessions(SessionsArgs),
    /// Raw UDP datagrams/s one way on 127.0.0.1 (one sender, one receiver) and UDP echo RTT.
    UdpCeiling(CeilingArgs),
    /// UDP proxy that drops, duplicates, reorders, delays and corrupts datagrams deterministically.
    LossyProxy(ProxyArgs),
    /// A serial line between two pseudoterminals (a firmware's and the agent's) that drops, corrupts and splits
    /// bytes at set rates; prints both devices, then the counters when done.
    SerialProxy(SerialProxyArgs),
    /// Client footprint: runs scripts/footprint.sh (no_std client sizes).
    Footprint(FootprintArgs),
    /// A micro-ROS-like node against a ROS 2 node through the agent: publishes stamped samples at a rate
    /// (latency measured by the ROS node) or receives them (latency measured here); agent CPU per sample.
    /// The ROS side: crates/xrce-agent/tests/ros2/ros_peer.py bench-sub / bench-pub; the whole matrix:
    /// scripts/ros2-shm-bench.py.
    Ros(RosArgs),
}

#[derive(Args, Debug)]
struct RosArgs {
    /// Agent address.
    #[arg(long, value_parser = parse_addr, default_value = "127.0.0.1:8888")]
    agent: SocketAddr,
    /// to-ros: this client publishes; from-ros: it subscribes.
    #[arg(long, value_enum)]
    direction: ros::Direction,
    /// ROS topic (`rt/<topic>` in DDS), std_msgs/msg/UInt8MultiArray.
    #[arg(long, default_value = "xrce_bench")]
    topic: String,
    /// Node (participant) name.
    #[arg(long, default_value = "xrce_bench")]
    node: String,
    /// DDS domain.
    #[arg(long, default_value_t = 0)]
    domain: u16,
    /// Samples per second.
    #[arg(long, default_value_t = 1000.0)]
    rate: f64,
    /// Bytes of `data` per sample (at least 16).
    #[arg(long, default_value_t = 1024)]
    payload: usize,
    /// Measured window: `rate × duration` samples.
    #[arg(long, default_value = "10s", value_parser = parse_duration)]
    duration: Duration,
    /// Shortest warm-up (to-ros).
    #[arg(long, default_value = "2s", value_parser = parse_duration)]
    warmup: Duration,
    /// From-ros: give up this long after the last sample when not all came.
    #[arg(long, default_value = "3s", value_parser = parse_duration)]
    idle_timeout: Duration,
    /// Longest run in all.
    #[arg(long, default_value = "120s", value_parser = parse_duration)]
    timeout: Duration,
    /// The agent's PID: its CPU time per sample.
    #[arg(long)]
    agent_pid: Option<u32>,
    /// Slots of each reliable stream of 512 bytes (default: micro-ROS' 4, or what one sample's fragments need).
    #[arg(long)]
    history: Option<usize>,
    /// From-ros: write every measured arrival to this file (`seq sent_ns arrival_ns` a line).
    #[arg(long)]
    dump: Option<std::path::PathBuf>,
    /// JSON line instead of a table.
    #[arg(long)]
    json: bool,
}

#[derive(Args, Debug, Clone, Copy)]
#[group(multiple = false)]
struct Reliability {
    /// Reliable streams and QoS.
    #[arg(long)]
    reliable: bool,
    /// Best-effort streams and QoS.
    #[arg(long)]
    best_effort: bool,
}

impl Reliability {
    fn reliable(self, default: bool) -> bool {
        if self.reliable {
            true
        } else if self.best_effort {
            false
        } else {
            default
        }
    }
}

#[derive(Args, Debug)]
struct ThroughputArgs {
    /// Agent address.
    #[arg(long, value_parser = parse_addr)]
    agent: SocketAddr,
    /// Publishing clients.
    #[arg(long, default_value_t = 1)]
    publishers: usize,
    /// Subscribing clients.
    #[arg(long, default_value_t = 1)]
    subscribers: usize,
    /// Sample sizes in bytes, comma separated (one run each); above one message = fragmented (reliable).
    #[arg(long, value_delimiter = ',', default_value = "16")]
    payload: Vec<usize>,
    #[command(flatten)]
    reliability: Reliability,
    /// MTU of the clients.
    #[arg(long, default_value_t = 512)]
    mtu: usize,
    /// History of the reliable streams (power of two).
    #[arg(long, default_value_t = 8)]
    history: usize,
    /// How long the publishers write (5s, 500ms, …).
    #[arg(long, default_value = "5s", value_parser = parse_duration)]
    duration: Duration,
    /// Longest wait for the last samples after the publishers stop.
    #[arg(long, default_value = "3s", value_parser = parse_duration)]
    drain: Duration,
    /// Samples per second per publisher (default: as fast as possible).
    #[arg(long)]
    rate: Option<f64>,
    /// Most samples in flight ahead of the slowest subscriber (default: no limit).
    #[arg(long)]
    window: Option<u64>,
    /// Subscribers do not ask the agent to pack several DATA per message (CREATE_CLIENT property
    /// `xrce_rs_pack`, honoured by our agent only, ignored by others).
    #[arg(long)]
    no_pack: bool,
    /// Reliable samples larger than one message use the continuous fragmented API (their fragments take
    /// every free history slot) instead of waiting until the whole sample fits; a variant, not the
    /// targets' method.
    #[arg(long)]
    continuous: bool,
    /// Repetitions of each configuration (the median run by received/s is marked).
    #[arg(long, default_value_t = 1)]
    runs: usize,
    /// The agent's PID: report its CPU % and peak RSS over the run.
    #[arg(long)]
    agent_pid: Option<u32>,
    /// JSON lines instead of a table.
    #[arg(long)]
    json: bool,
}

#[derive(Args, Debug)]
struct LatencyArgs {
    /// Agent address.
    #[arg(long, value_parser = parse_addr)]
    agent: SocketAddr,
    /// Round trips measured.
    #[arg(long, default_value_t = 10_000)]
    samples: usize,
    /// Round trips before measuring.
    #[arg(long, default_value_t = 200)]
    warmup: usize,
    /// Sample size in bytes (at least 16).
    #[arg(long, default_value_t = 16)]
    payload: usize,
    #[command(flatten)]
    reliability: Reliability,
    /// MTU of the clients.
    #[arg(long, default_value_t = 512)]
    mtu: usize,
    /// History of the reliable streams.
    #[arg(long, default_value_t = 8)]
    history: usize,
    /// Longest wait for one echo.
    #[arg(long, default_value = "500ms", value_parser = parse_duration)]
    timeout: Duration,
    /// Name the two clients' participants (`xrce_bench_ping`, `xrce_bench_echo`), as micro-ROS names its
    /// nodes: an agent that makes a DDS participant per name then carries each hop between two participants.
    #[arg(long)]
    named: bool,
    /// Repetitions (the median run by p50 is marked).
    #[arg(long, default_value_t = 1)]
    runs: usize,
    /// JSON lines instead of a table.
    #[arg(long)]
    json: bool,
}

#[derive(Args, Debug)]
struct SessionsArgs {
    /// Agent address.
    #[arg(long, value_parser = parse_addr)]
    agent: SocketAddr,
    /// Clients to create.
    #[arg(long, default_value_t = 100)]
    clients: usize,
    /// Worker threads.
    #[arg(long, default_value_t = 2)]
    workers: usize,
    /// Clients in flight per worker.
    #[arg(long, default_value_t = 64)]
    window: usize,
    /// MTU of the clients.
    #[arg(long, default_value_t = 512)]
    mtu: usize,
    /// Longest time one client may take.
    #[arg(long, default_value = "10s", value_parser = parse_duration)]
    timeout: Duration,
    /// Leave the sessions in the agent (default: delete them at the end).
    #[arg(long)]
    keep: bool,
    /// Clients created before the agent's RSS is first sampled, so one-off costs (a DDS participant,
    /// pools) are not counted per client; the table shows both figures.
    #[arg(long, default_value_t = 1)]
    warmup: usize,
    /// How long the agent is left alone after the last client before its RSS is sampled (idle streams
    /// trimmed, expired first-contact gates dropped once a second).
    #[arg(long, default_value = "300ms", value_parser = parse_duration)]
    settle: Duration,
    /// The agent's PID: report its RSS growth per client.
    #[arg(long)]
    agent_pid: Option<u32>,
    /// Name every participant (`node_<key>`), as micro-ROS does (a ROS 2 node each with `-m dds`).
    #[arg(long)]
    named: bool,
    /// JSON lines instead of a table.
    #[arg(long)]
    json: bool,
}

#[derive(Args, Debug)]
struct CeilingArgs {
    /// Datagram sizes, comma separated.
    #[arg(long, value_delimiter = ',', default_value = "16,1024")]
    payload: Vec<usize>,
    /// How long the sender sends, per size.
    #[arg(long, default_value = "5s", value_parser = parse_duration)]
    duration: Duration,
    /// Echo round trips measured, per size.
    #[arg(long, default_value_t = 10_000)]
    echo_samples: usize,
    /// JSON lines instead of a table.
    #[arg(long)]
    json: bool,
}

#[derive(Args, Debug)]
struct ProxyArgs {
    /// Address clients send to.
    #[arg(long, value_parser = parse_addr, default_value = "127.0.0.1:9999")]
    listen: SocketAddr,
    /// Agent address.
    #[arg(long, value_parser = parse_addr)]
    agent: SocketAddr,
    /// Probability a datagram is lost.
    #[arg(long, default_value_t = 0.0)]
    drop: f64,
    /// Probability a datagram is delivered twice.
    #[arg(long, default_value_t = 0.0)]
    dup: f64,
    /// Probability a datagram is held back so later ones overtake it.
    #[arg(long, default_value_t = 0.0)]
    reorder: f64,
    /// Shortest hold-back of a reordered datagram.
    #[arg(long, default_value = "1ms", value_parser = parse_duration)]
    reorder_min: Duration,
    /// Longest hold-back of a reordered datagram.
    #[arg(long, default_value = "20ms", value_parser = parse_duration)]
    reorder_max: Duration,
    /// Delay of every datagram.
    #[arg(long, default_value = "0ms", value_parser = parse_duration)]
    delay: Duration,
    /// Random extra delay up to this.
    #[arg(long, default_value = "0ms", value_parser = parse_duration)]
    jitter: Duration,
    /// Probability a datagram gets one bit flipped.
    #[arg(long, default_value_t = 0.0)]
    corrupt: f64,
    /// PRNG seed.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Stop after this long (default: run until killed).
    #[arg(long, value_parser = parse_duration)]
    duration: Option<Duration>,
    /// Most clients served.
    #[arg(long, default_value_t = 1024)]
    max_clients: usize,
    /// Which directions are lossy.
    #[arg(long, value_enum, default_value = "both")]
    direction: Direction,
    /// Print the final counters as a JSON line.
    #[arg(long)]
    json: bool,
}

#[derive(Args, Debug)]
struct SerialProxyArgs {
    /// Probability a byte is lost.
    #[arg(long, default_value_t = 0.0)]
    drop: f64,
    /// Probability a byte gets one bit flipped.
    #[arg(long, default_value_t = 0.0)]
    corrupt: f64,
    /// Largest piece a run of bytes is split into (0: runs pass as read).
    #[arg(long, default_value_t = 0)]
    split: usize,
    /// Pause between two pieces of a split run.
    #[arg(long, default_value = "1ms", value_parser = parse_duration)]
    gap: Duration,
    /// PRNG seed (the other direction uses seed + 1).
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Stop after this long (default: run until killed, or until --stop-file exists).
    #[arg(long, value_parser = parse_duration)]
    duration: Option<Duration>,
    /// Stop (and print the counters) once this file exists.
    #[arg(long)]
    stop_file: Option<std::path::PathBuf>,
    /// Print the final counters as a JSON line.
    #[arg(long)]
    json: bool,
}

#[derive(Args, Debug)]
struct FootprintArgs {
    /// The script to run.
    #[arg(long, default_value = "scripts/footprint.sh")]
    script: String,
    /// Arguments passed to the script.
    #[arg(trailing_var_arg = true)]
    args: Vec<String>,
}

fn parse_addr(s: &str) -> Result<SocketAddr, String> {
    s.to_socket_addrs().map_err(|e| format!("{s}: {e}"))?.next().ok_or_else(|| format!("{s}: no address"))
}

fn probability(p: f64, what: &str) -> Result<f64, BenchError> {
    if (0.0..=1.0).contains(&p) {
        Ok(p)
    } else {
        Err(BenchError::Config(format!("--{what} must be between 0 and 1")))
    }
}

fn nanos(d: Duration) -> i64 {
    i64::try_from(d.as_nanos()).unwrap_or(i64::MAX)
}

/// A progress bar on stderr when it is a terminal and the run is long enough to want one.
fn bar(show: bool, message: String) -> ProgressBar {
    if !show {
        return ProgressBar::hidden();
    }
    let pb = ProgressBar::with_draw_target(Some(1000), ProgressDrawTarget::stderr());
    if let Ok(style) = ProgressStyle::with_template("{msg} [{bar:30}] {percent}% {elapsed}") {
        pb.set_style(style.progress_chars("=> "));
    }
    pb.set_message(message);
    pb
}

fn set(pb: &ProgressBar) -> impl Fn(f64) + Sync + '_ {
    move |f: f64| pb.set_position((f.clamp(0.0, 1.0) * 1000.0) as u64)
}

/// Prints results (table or JSON lines), marking the median run when there are several.
fn print<R: Row + serde::Serialize>(results: &[R], json: bool, median: Option<usize>) {
    if json {
        for r in results {
            println!("{}", report::json_line(r));
        }
        return;
    }
    let mut headers = R::headers();
    let mut cells: Vec<Vec<String>> = results.iter().map(Row::cells).collect();
    if results.len() > 1 {
        headers.push("");
        for (i, c) in cells.iter_mut().enumerate() {
            c.push(if Some(i) == median { "median".into() } else { String::new() });
        }
    }
    print!("{}", report::table(&headers, &cells));
}

fn median_index(values: &[f64]) -> Option<usize> {
    let mut idx: Vec<usize> = (0..values.len()).collect();
    idx.sort_by(|&a, &b| values.get(a).unwrap_or(&0.0).total_cmp(values.get(b).unwrap_or(&0.0)));
    idx.get(values.len() / 2).copied()
}

fn throughput_cmd(a: &ThroughputArgs) -> Result<(), BenchError> {
    let reliable = a.reliability.reliable(true);
    let mut results = Vec::new();
    for &payload in &a.payload {
        let mut runs = Vec::new();
        for run in 0..a.runs.max(1) {
            let mut cfg = ThroughputConfig::new(a.agent);
            cfg.publishers = a.publishers;
            cfg.subscribers = a.subscribers;
            cfg.payload = payload;
            cfg.reliable = reliable;
            cfg.mtu = a.mtu;
            cfg.history = a.history;
            cfg.duration = a.duration;
            cfg.drain = a.drain;
            cfg.agent_pid = a.agent_pid;
            cfg.rate = a.rate;
            cfg.window = a.window;
            cfg.pack = !a.no_pack;
            cfg.continuous = a.continuous;
            let pb = bar(a.duration >= Duration::from_secs(2), format!("{} {payload} B run {}", cfg.mode(), run + 1));
            let r = throughput::run(&cfg, &set(&pb));
            pb.finish_and_clear();
            runs.push(r?);
        }
        let median = median_index(&runs.iter().map(|r| r.received_per_s).collect::<Vec<_>>());
        if a.runs > 1 && !a.json {
            print(&runs, false, median);
            println!();
        }
        if a.runs > 1 {
            if let Some(m) = median.and_then(|m| runs.get(m)) {
                results.push(m.clone());
            }
            if a.json {
                for r in &runs {
                    println!("{}", report::json_line(r));
                }
            }
        } else {
            results.extend(runs);
        }
    }
    if a.runs > 1 && !a.json {
        println!("medians:");
    }
    if !(a.runs > 1 && a.json) {
        print(&results, a.json, None);
    }
    Ok(())
}

fn latency_cmd(a: &LatencyArgs) -> Result<(), BenchError> {
    let mut runs = Vec::new();
    for run in 0..a.runs.max(1) {
        let mut cfg = LatencyConfig::new(a.agent);
        cfg.samples = a.samples;
        cfg.warmup = a.warmup;
        cfg.payload = a.payload;
        cfg.reliable = a.reliability.reliable(false);
        cfg.mtu = a.mtu;
        cfg.history = a.history;
        cfg.timeout = a.timeout;
        cfg.named = a.named;
        let pb = bar(a.samples >= 5_000, format!("latency run {}", run + 1));
        let r = latency::run(&cfg, &set(&pb));
        pb.finish_and_clear();
        runs.push(r?);
    }
    let median = median_index(&runs.iter().map(|r| r.rtt_us.p50).collect::<Vec<_>>());
    print(&runs, a.json, median);
    Ok(())
}

fn sessions_cmd(a: &SessionsArgs) -> Result<(), BenchError> {
    let mut cfg = SessionsConfig::new(a.agent);
    cfg.clients = a.clients;
    cfg.workers = a.workers;
    cfg.window = a.window;
    cfg.mtu = a.mtu;
    cfg.timeout = a.timeout;
    cfg.agent_pid = a.agent_pid;
    cfg.settle = a.settle;
    cfg.delete = !a.keep;
    cfg.warmup = a.warmup;
    cfg.named = a.named;
    let pb = bar(a.clients >= 500, format!("{} sessions", a.clients));
    let r = sessions::run(&cfg, &set(&pb));
    pb.finish_and_clear();
    let r = r?;
    print(std::slice::from_ref(&r), a.json, None);
    if !a.json && !r.failures.is_empty() {
        println!("failures: {:?}", r.failures);
    }
    Ok(())
}

fn ceiling_cmd(a: &CeilingArgs) -> Result<(), BenchError> {
    let mut results = Vec::new();
    for &payload in &a.payload {
        let cfg = CeilingConfig { payload, duration: a.duration, echo_samples: a.echo_samples };
        let pb = bar(a.duration >= Duration::from_secs(2), format!("udp {payload} B"));
        let r = udp_ceiling::run(&cfg, &set(&pb));
        pb.finish_and_clear();
        results.push(r?);
    }
    print(&results, a.json, None);
    if let (false, Some(idle)) = (a.json, udp_ceiling::cpu_idle_policy()) {
        println!("cpu idle: {idle}");
    }
    Ok(())
}

fn proxy_cmd(a: &ProxyArgs) -> Result<(), BenchError> {
    let link = LinkConfig {
        drop: probability(a.drop, "drop")?,
        duplicate: probability(a.dup, "dup")?,
        reorder: probability(a.reorder, "reorder")?,
        reorder_min: nanos(a.reorder_min),
        reorder_max: nanos(a.reorder_max).max(nanos(a.reorder_min)),
        delay: nanos(a.delay),
        jitter: nanos(a.jitter),
        corrupt: probability(a.corrupt, "corrupt")?,
        seed: a.seed,
    };
    let proxy = Proxy::bind(ProxyConfig {
        listen: a.listen,
        agent: a.agent,
        link,
        max_clients: a.max_clients,
        direction: a.direction,
    })?;
    eprintln!(
        "lossy-proxy {} -> {} (drop {}, dup {}, reorder {} for {}-{} ms, corrupt {}, seed {})",
        proxy.local_addr()?,
        a.agent,
        link.drop,
        link.duplicate,
        link.reorder,
        link.reorder_min / MILLIS,
        link.reorder_max / MILLIS,
        link.corrupt,
        link.seed
    );
    let stop = AtomicBool::new(false);
    let stats = proxy.run(&stop, a.duration)?;
    if a.json {
        println!("{}", report::json_line(&stats));
    } else {
        println!("clients {}; up {:?}; down {:?}", stats.clients, stats.upstream, stats.downstream);
    }
    Ok(())
}

#[cfg(target_os = "linux")]
fn serial_proxy_cmd(a: &SerialProxyArgs) -> Result<(), BenchError> {
    use std::io::Write;
    use std::sync::Arc;
    use xrce_bench::serial_proxy::{self, ByteFaultConfig, SerialProxy};
    let cfg = ByteFaultConfig {
        drop: probability(a.drop, "drop")?,
        corrupt: probability(a.corrupt, "corrupt")?,
        split: a.split,
        seed: a.seed,
    };
    let proxy = SerialProxy::open()?;
    let (dev_a, dev_b) = proxy.devices();
    println!("A {dev_a}");
    println!("B {dev_b}");
    std::io::stdout().flush()?;
    eprintln!(
        "serial-proxy {dev_a} <-> {dev_b} (drop {}, corrupt {}, split {}, gap {:?}, seed {})",
        cfg.drop, cfg.corrupt, cfg.split, a.gap, cfg.seed
    );
    let stop = Arc::new(AtomicBool::new(false));
    if let Some(file) = a.stop_file.clone() {
        let stop = Arc::clone(&stop);
        std::thread::spawn(move || {
            while !file.exists() {
                std::thread::sleep(Duration::from_millis(20));
            }
            stop.store(true, std::sync::atomic::Ordering::Relaxed);
        });
    }
    let stats = serial_proxy::run(proxy, cfg, a.gap, &stop, a.duration)?;
    if a.json {
        println!("{}", report::json_line(&stats));
    } else {
        println!("A->B {:?}; B->A {:?}", stats.a_to_b, stats.b_to_a);
    }
    Ok(())
}

#[cfg(not(target_os = "linux"))]
fn serial_proxy_cmd(_: &SerialProxyArgs) -> Result<(), BenchError> {
    Err(BenchError::Config("serial-proxy needs Linux pseudoterminals".into()))
}

fn ros_cmd(a: &RosArgs) -> Result<(), BenchError> {
    let count = (a.rate * a.duration.as_secs_f64()).round() as u64;
    let cfg = RosConfig {
        agent: a.agent,
        direction: a.direction,
        topic: a.topic.clone(),
        node: a.node.clone(),
        domain: a.domain,
        rate: a.rate,
        payload: a.payload,
        count,
        warmup: a.warmup,
        idle_timeout: a.idle_timeout,
        timeout: a.timeout,
        agent_pid: a.agent_pid,
        history: a.history,
        key: xrce_bench::client_key(xrce_bench::run_id(), 1),
        dump: a.dump.clone(),
    };
    let r = ros::run(&cfg)?;
    print(std::slice::from_ref(&r), a.json, None);
    Ok(())
}

fn footprint_cmd(a: &FootprintArgs) -> Result<(), BenchError> {
    if !std::path::Path::new(&a.script).exists() {
        return Err(BenchError::Config(format!("{} not found (run from the workspace root)", a.script)));
    }
    let status = std::process::Command::new("bash").arg(&a.script).args(&a.args).status()?;
    if status.success() {
        Ok(())
    } else {
        Err(BenchError::Config(format!("{} failed: {status}", a.script)))
    }
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match &cli.command {
        Command::Throughput(a) => throughput_cmd(a),
        Command::Latency(a) => latency_cmd(a),
        Command::Sessions(a) => sessions_cmd(a),
        Command::UdpCeiling(a) => ceiling_cmd(a),
        Command::LossyProxy(a) => proxy_cmd(a),
        Command::SerialProxy(a) => serial_proxy_cmd(a),
        Command::Footprint(a) => footprint_cmd(a),
        Command::Ros(a) => ros_cmd(a),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("xrce-bench: {e}");
            ExitCode::FAILURE
        }
    }
}
