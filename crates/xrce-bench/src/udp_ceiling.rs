//! `udp-ceiling`: what the machine can do without any agent. One sender thread sends datagrams of the payload
//! size to one receiver thread on 127.0.0.1 as fast as it can, one way; then a ping-pong with a UDP echo thread
//! gives the bare round-trip time. Every agent figure can be read as a fraction of these.

use std::net::{SocketAddr, UdpSocket};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::{Duration, Instant};

use crate::client::recv_result;
use crate::{join, BenchError, Percentiles};

/// Parameters of a ceiling run.
#[derive(Debug, Clone)]
pub struct CeilingConfig {
    /// Datagram size.
    pub payload: usize,
    /// How long the sender sends.
    pub duration: Duration,
    /// Echo round trips measured.
    pub echo_samples: usize,
}

impl Default for CeilingConfig {
    fn default() -> Self {
        Self { payload: 16, duration: Duration::from_secs(5), echo_samples: 10_000 }
    }
}

/// What a ceiling run measured.
#[derive(Debug, Clone, Default, serde::Serialize)]
pub struct CeilingResult {
    /// `"udp-ceiling"`.
    pub bench: &'static str,
    /// Datagram size.
    pub payload: usize,
    /// Seconds the sender sent.
    pub duration_s: f64,
    /// Datagrams sent.
    pub sent: u64,
    /// Datagrams sent per second.
    pub sent_per_s: f64,
    /// Datagrams received per second.
    pub received_per_s: f64,
    /// Datagrams lost (receive buffer overflow), percent.
    pub loss_pct: f64,
    /// Echo round-trip times in µs.
    pub echo_rtt_us: Percentiles,
    /// How idle CPUs wait for work ([`cpu_idle_policy`]), which sets the cost of every wake-up.
    pub cpu_idle: Option<String>,
}

/// The machine's CPU idle policy as Linux reports it: the cpuidle driver and governor and, in a KVM guest
/// with the `haltpoll` driver, how long an idle vCPU polls before it halts (`guest_halt_poll_ns`; 0: every
/// wake-up of an idle vCPU costs an exit to the host, tens of µs). `None` where sysfs says nothing.
pub fn cpu_idle_policy() -> Option<String> {
    let read = |path: &str| std::fs::read_to_string(path).ok().map(|s| s.trim().to_owned());
    let driver = read("/sys/devices/system/cpu/cpuidle/current_driver")?;
    let mut policy = format!("cpuidle driver {driver}");
    if let Some(g) = read("/sys/devices/system/cpu/cpuidle/current_governor")
        .or_else(|| read("/sys/devices/system/cpu/cpuidle/current_governor_ro"))
    {
        policy.push_str(&format!(", governor {g}"));
    }
    if let Some(ns) = read("/sys/module/haltpoll/parameters/guest_halt_poll_ns") {
        policy.push_str(&format!(", guest_halt_poll_ns {ns}"));
    }
    Some(policy)
}

fn loopback_socket() -> std::io::Result<UdpSocket> {
    UdpSocket::bind(SocketAddr::from(([127, 0, 0, 1], 0)))
}

/// Runs the one-way test then the echo test; `on_progress(fraction)` is called a few times a second.
pub fn run(cfg: &CeilingConfig, on_progress: &(dyn Fn(f64) + Sync)) -> Result<CeilingResult, BenchError> {
    let receiver = loopback_socket()?;
    socket2::SockRef::from(&receiver).set_recv_buffer_size(8 << 20)?;
    receiver.set_read_timeout(Some(Duration::from_millis(50)))?;
    let sender = loopback_socket()?;
    sender.connect(receiver.local_addr()?)?;
    let received = AtomicU64::new(0);
    let stop = AtomicBool::new(false);
    let (sent, elapsed, got) = std::thread::scope(|s| {
        let rx = s.spawn(|| -> Result<u64, BenchError> {
            let mut buf = vec![0u8; cfg.payload.max(1) + 64];
            let mut n = 0u64;
            loop {
                match recv_result(receiver.recv(&mut buf))? {
                    Some(_) => {
                        n += 1;
                        if n.is_multiple_of(1024) {
                            received.store(n, Ordering::Relaxed);
                        }
                    }
                    None if stop.load(Ordering::Relaxed) => return Ok(n),
                    None => {}
                }
            }
        });
        let datagram = vec![0xA5u8; cfg.payload];
        let start = Instant::now();
        let mut sent = 0u64;
        let mut last_report = start;
        let send_result = (|| -> Result<(), BenchError> {
            while start.elapsed() < cfg.duration {
                for _ in 0..64 {
                    match sender.send(&datagram) {
                        Ok(_) => sent += 1,
                        // The receiver's buffer is full (ICMP-less loopback drops silently, but a full send
                        // buffer may say so): count the attempt, go on.
                        Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => {}
                        Err(e) => return Err(e.into()),
                    }
                }
                if last_report.elapsed() >= Duration::from_millis(200) {
                    last_report = Instant::now();
                    on_progress(0.8 * start.elapsed().as_secs_f64() / cfg.duration.as_secs_f64().max(1e-9));
                }
            }
            Ok(())
        })();
        let elapsed = start.elapsed();
        // Give the receiver what is in flight, then stop it.
        std::thread::sleep(Duration::from_millis(100));
        stop.store(true, Ordering::Relaxed);
        let got = join(rx.join(), "receiver");
        send_result.and(got.map(|g| (sent, elapsed, g)))
    })?;

    let echo_rtt_us = echo(cfg.payload, cfg.echo_samples)?;
    on_progress(1.0);
    let secs = elapsed.as_secs_f64().max(1e-9);
    Ok(CeilingResult {
        bench: "udp-ceiling",
        payload: cfg.payload,
        duration_s: secs,
        sent,
        sent_per_s: sent as f64 / secs,
        received_per_s: got as f64 / secs,
        loss_pct: if sent > 0 { 100.0 * sent.saturating_sub(got) as f64 / sent as f64 } else { 0.0 },
        echo_rtt_us,
        cpu_idle: cpu_idle_policy(),
    })
}

/// UDP echo round trips through a second thread, one outstanding; percentiles in µs.
pub fn echo(payload: usize, samples: usize) -> Result<Percentiles, BenchError> {
    let echo = loopback_socket()?;
    echo.set_read_timeout(Some(Duration::from_millis(50)))?;
    let client = loopback_socket()?;
    client.connect(echo.local_addr()?)?;
    client.set_read_timeout(Some(Duration::from_millis(500)))?;
    let stop = AtomicBool::new(false);
    std::thread::scope(|s| {
        let t = s.spawn(|| -> Result<(), BenchError> {
            let mut buf = vec![0u8; payload.max(1) + 64];
            while !stop.load(Ordering::Relaxed) {
                match echo.recv_from(&mut buf) {
                    Ok((n, from)) => {
                        echo.send_to(buf.get(..n).unwrap_or(&[]), from)?;
                    }
                    Err(e) => {
                        recv_result(Err(e))?;
                    }
                }
            }
            Ok(())
        });
        let mut rtts = Vec::with_capacity(samples);
        let mut buf = vec![0u8; payload.max(1) + 64];
        let datagram = vec![0x5Au8; payload];
        let result = (|| -> Result<(), BenchError> {
            for i in 0..samples + samples / 10 {
                let t0 = Instant::now();
                client.send(&datagram)?;
                if recv_result(client.recv(&mut buf))?.is_some() && i >= samples / 10 {
                    rtts.push(t0.elapsed().as_secs_f64() * 1e6);
                }
            }
            Ok(())
        })();
        stop.store(true, Ordering::Relaxed);
        join(t.join(), "echo")?;
        result?;
        Ok(Percentiles::of(&mut rtts))
    })
}
