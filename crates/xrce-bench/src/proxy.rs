//! `lossy-proxy`: a UDP proxy between clients and an agent that passes every datagram through a
//! [`LossyLink`](crate::lossy::LossyLink) in each direction.
//!
//! Each client source address gets its own upstream socket (so the agent still sees one address per client)
//! and its own pair of links, seeded from the proxy's seed and the order in which clients first appeared, so a
//! run with one client is reproducible datagram for datagram.

use std::collections::HashMap;
use std::net::{SocketAddr, UdpSocket};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use crate::client::{bind_for, recv_result};
use crate::lossy::{LinkConfig, LinkStats, Pipe};
use crate::BenchError;

/// Parameters of the proxy.
#[derive(Debug, Clone)]
pub struct ProxyConfig {
    /// Where clients send.
    pub listen: SocketAddr,
    /// The agent.
    pub agent: SocketAddr,
    /// What the links do (the seed is mixed with each client's number and the direction).
    pub link: LinkConfig,
    /// Most clients served at once (new source addresses beyond are ignored).
    pub max_clients: usize,
    /// Which directions are lossy (the other one is a perfect link).
    pub direction: Direction,
}

/// Which way a proxy's faults apply.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, clap::ValueEnum)]
pub enum Direction {
    /// Client → agent and agent → client.
    #[default]
    Both,
    /// Client → agent only.
    Up,
    /// Agent → client only.
    Down,
}

/// Counters of a proxy run.
#[derive(Debug, Clone, Default, serde::Serialize)]
pub struct ProxyStats {
    /// `"lossy-proxy"`.
    pub bench: &'static str,
    /// Clients seen.
    pub clients: usize,
    /// Client → agent, summed over clients.
    pub upstream: LinkStats,
    /// Agent → client, summed over clients.
    pub downstream: LinkStats,
}

struct Peer {
    addr: SocketAddr,
    socket: UdpSocket,
    up: Pipe,
    down: Pipe,
}

/// Seed of link `direction` (0 up, 1 down) of client number `client`.
pub fn link_seed(seed: u64, client: usize, direction: u64) -> u64 {
    seed ^ (client as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ direction.wrapping_mul(0xD1B5_4A32_D192_ED03)
}

/// A bound proxy, ready to [`run`](Proxy::run).
#[derive(Debug)]
pub struct Proxy {
    cfg: ProxyConfig,
    listen: UdpSocket,
}

impl Proxy {
    /// Binds the listening socket (port 0 picks one: see [`local_addr`](Self::local_addr)).
    pub fn bind(cfg: ProxyConfig) -> Result<Self, BenchError> {
        let listen = UdpSocket::bind(cfg.listen)?;
        listen.set_nonblocking(true)?;
        socket2::SockRef::from(&listen).set_recv_buffer_size(4 << 20)?;
        Ok(Self { cfg, listen })
    }

    /// The address clients should use.
    pub fn local_addr(&self) -> Result<SocketAddr, BenchError> {
        Ok(self.listen.local_addr()?)
    }

    /// Forwards until `stop` is set or `duration` (if any) has passed.
    pub fn run(&self, stop: &AtomicBool, duration: Option<Duration>) -> Result<ProxyStats, BenchError> {
        let start = Instant::now();
        let now_ns = || i64::try_from(start.elapsed().as_nanos()).unwrap_or(i64::MAX);
        let mut peers: Vec<Peer> = Vec::new();
        let mut by_addr: HashMap<SocketAddr, usize> = HashMap::new();
        let mut buf = vec![0u8; 65_536];
        while !stop.load(Ordering::Relaxed) && duration.is_none_or(|d| start.elapsed() < d) {
            let mut busy = false;
            // Clients → links up.
            for _ in 0..256 {
                let (n, from) = match self.listen.recv_from(&mut buf) {
                    Ok(x) => x,
                    Err(e) => {
                        recv_result(Err(e))?;
                        break;
                    }
                };
                busy = true;
                let index = match by_addr.get(&from) {
                    Some(&i) => i,
                    None if peers.len() < self.cfg.max_clients => {
                        let socket = bind_for(self.cfg.agent)?;
                        socket.connect(self.cfg.agent)?;
                        socket.set_nonblocking(true)?;
                        let i = peers.len();
                        let lossy = |d: u64| match (self.cfg.direction, d) {
                            (Direction::Both, _) | (Direction::Up, 0) | (Direction::Down, 1) => self.cfg.link,
                            _ => LinkConfig::default(),
                        };
                        let link = |d| LinkConfig { seed: link_seed(self.cfg.link.seed, i, d), ..lossy(d) };
                        peers.push(Peer { addr: from, socket, up: Pipe::new(link(0)), down: Pipe::new(link(1)) });
                        by_addr.insert(from, i);
                        i
                    }
                    None => continue,
                };
                if let Some(p) = peers.get_mut(index) {
                    p.up.send(buf.get(..n).unwrap_or(&[]), now_ns());
                }
            }
            // Agent → links down; then whatever is due, both ways.
            for p in &mut peers {
                for _ in 0..256 {
                    match recv_result(p.socket.recv(&mut buf))? {
                        Some(n) => {
                            busy = true;
                            p.down.send(buf.get(..n).unwrap_or(&[]), now_ns());
                        }
                        None => break,
                    }
                }
                let now = now_ns();
                while let Some(d) = p.up.pop_due(now) {
                    busy = true;
                    let _ = p.socket.send(&d);
                }
                while let Some(d) = p.down.pop_due(now) {
                    busy = true;
                    let _ = self.listen.send_to(&d, p.addr);
                }
            }
            if !busy {
                std::thread::sleep(Duration::from_micros(100));
            }
        }
        let mut stats = ProxyStats { bench: "lossy-proxy", clients: peers.len(), ..ProxyStats::default() };
        for p in &peers {
            add(&mut stats.upstream, &p.up.link.stats());
            add(&mut stats.downstream, &p.down.link.stats());
        }
        Ok(stats)
    }
}

fn add(a: &mut LinkStats, b: &LinkStats) {
    a.sent += b.sent;
    a.dropped += b.dropped;
    a.duplicated += b.duplicated;
    a.reordered += b.reordered;
    a.corrupted += b.corrupted;
    a.delivered += b.delivered;
}
