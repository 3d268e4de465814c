//! `--metrics ADDR:PORT`: the agent's snapshot as Prometheus metrics over HTTP, at `/metrics`.
//!
//! The server runs on its own thread and reads only the snapshot the loop publishes
//! ([`SnapshotBoard`]): it never touches the core, so a slow or hostile HTTP client cannot delay the XRCE
//! loop. Everything it holds is bounded ([`http`]): connections, request bytes, time per connection; the
//! rendered text is shared by the connections that send the same snapshot.

pub mod http;
pub mod render;

use std::io;
use std::net::SocketAddr;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::thread::JoinHandle;

use crate::core::SnapshotBoard;

/// A running metrics server; stops when dropped.
#[derive(Debug)]
pub struct MetricsServer {
    local: SocketAddr,
    stop: Arc<AtomicBool>,
    waker: Arc<mio::Waker>,
    thread: Option<JoinHandle<()>>,
}

impl MetricsServer {
    /// Binds `addr` (an error when it is taken) and serves the snapshots published on `board`.
    pub fn start(addr: SocketAddr, board: Arc<SnapshotBoard>) -> io::Result<Self> {
        Self::start_with(addr, board, http::Limits::default())
    }

    /// As [`Self::start`], with other bounds.
    pub fn start_with(addr: SocketAddr, board: Arc<SnapshotBoard>, limits: http::Limits) -> io::Result<Self> {
        let server = http::Server::bind_with(addr, board, limits)?;
        let local = server.local_addr()?;
        let waker = server.waker();
        let stop = Arc::new(AtomicBool::new(false));
        let stop2 = stop.clone();
        let thread = std::thread::Builder::new().name("xrce-metrics".into()).spawn(move || {
            if let Err(e) = server.run(&stop2) {
                tracing::error!("metrics server stopped: {e}");
            }
        })?;
        tracing::info!(%local, "metrics at http://{local}/metrics");
        Ok(Self { local, stop, waker, thread: Some(thread) })
    }

    /// The address it listens on.
    pub fn local_addr(&self) -> SocketAddr {
        self.local
    }
}

impl Drop for MetricsServer {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        // A failed wake-up only delays the stop to the server's next timeout (at most a second).
        let _ = self.waker.wake();
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}
