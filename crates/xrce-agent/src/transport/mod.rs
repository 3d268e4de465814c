//! Transport shells: they own the sockets and the clock, and move bytes between them and a shared
//! [`AgentCore`](crate::core::AgentCore). The core sits behind a mutex so the library API
//! ([`crate::agent::Agent`]) can act on it while a server runs; each lock is held for one datagram or one
//! timer run.

pub mod tcp;
pub mod udp;

use std::sync::{Arc, Mutex, MutexGuard};
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use crate::core::AgentCore;
use crate::middleware::Middleware;

/// The middleware type the shells run: any middleware, boxed.
pub type DynMiddleware = Box<dyn Middleware + Send>;

/// A core shared between a transport shell and the library API.
pub type SharedCore<E> = Arc<Mutex<AgentCore<E, DynMiddleware>>>;

/// Longest a shell blocks without checking its stop flag.
pub const MAX_BLOCK: Duration = Duration::from_millis(200);

/// Locks the core, recovering from a poisoned lock (a panic elsewhere must not stop the agent).
pub fn lock<E>(core: &SharedCore<E>) -> MutexGuard<'_, AgentCore<E, DynMiddleware>> {
    core.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
}

/// Anchors the core's TIMESTAMP_REPLY clock to the system clock.
pub fn anchor_wall_clock<E, M>(core: &mut AgentCore<E, M>)
where
    E: Copy + Eq + std::hash::Hash + std::fmt::Debug,
    M: Middleware,
{
    let since_epoch = SystemTime::now().duration_since(UNIX_EPOCH).unwrap_or_default();
    core.set_wall_clock(Instant::now(), since_epoch);
}

/// How long to block waiting for input given the core's next timer.
pub fn block_for(next: Option<Instant>, now: Instant) -> Duration {
    next.map_or(MAX_BLOCK, |t| t.saturating_duration_since(now)).clamp(Duration::from_millis(1), MAX_BLOCK)
}

/// Logs a message in hex at trace level (verbosity 6), as eProsima's agent does.
pub fn hexdump(direction: &str, peer: &dyn std::fmt::Debug, bytes: &[u8]) {
    if tracing::enabled!(tracing::Level::TRACE) {
        let hex: String = bytes.iter().map(|b| format!("{b:02X} ")).collect();
        tracing::trace!(target: "xrce_agent::hexdump", "{direction} {peer:?} [{} bytes] {}", bytes.len(), hex.trim_end());
    }
}
