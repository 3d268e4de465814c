//! Transport shells: they own the sockets and the clock, and move bytes between them and a shared
//! [`AgentCore`](crate::core::AgentCore). The core sits behind a mutex so the library API
//! ([`crate::agent::Agent`]) can act on it while a server runs; each lock is held for one datagram or one
//! timer run.

pub mod batch;
pub mod discovery;
#[cfg(target_os = "linux")]
pub mod serial;
pub mod tcp;
pub mod udp;

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Condvar, Mutex, MutexGuard};
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use crate::core::AgentCore;
use crate::middleware::{Middleware, Waker};

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

/// The work a shell's turn owes the core besides input: polls the middleware if its waker fired, runs the
/// timers that are due.
pub fn run_due<E, M>(core: &mut AgentCore<E, M>, woken: bool, now: Instant)
where
    E: Copy + Eq + std::hash::Hash + std::fmt::Debug,
    M: Middleware,
{
    if woken {
        core.poll_middleware(now);
    }
    if core.poll_timeout().is_some_and(|t| t <= now) {
        core.handle_timeout(now);
    }
}

/// Logs a message in hex at trace level (verbosity 6), as eProsima's agent does.
pub fn hexdump(direction: &str, peer: &dyn std::fmt::Debug, bytes: &[u8]) {
    if tracing::enabled!(tracing::Level::TRACE) {
        let hex: String = bytes.iter().map(|b| format!("{b:02X} ")).collect();
        tracing::trace!(target: "xrce_agent::hexdump", "{direction} {peer:?} [{} bytes] {}", bytes.len(), hex.trim_end());
    }
}

/// A flag a threaded middleware raises (through its [`Waker`]) when samples arrived; the shell clears it and
/// runs [`AgentCore::poll_middleware`]. Many wakes between two polls cost one poll.
#[derive(Debug, Default)]
pub struct WakeFlag {
    pending: AtomicBool,
}

impl WakeFlag {
    /// Raises the flag; true when it was down (the caller then unblocks the shell's loop).
    pub fn raise(&self) -> bool {
        !self.pending.swap(true, Ordering::AcqRel)
    }

    /// Lowers the flag; true when it was up (the shell then polls the middleware).
    pub fn take(&self) -> bool {
        self.pending.swap(false, Ordering::AcqRel)
    }
}

/// Installs a waker that raises `flag` and unblocks a UDP shell blocked on `server` by sending an empty
/// datagram from a loopback socket to it. Returns the waker socket's address (its datagrams are not XRCE).
pub fn install_udp_waker<E, M>(
    core: &mut AgentCore<E, M>,
    server: std::net::SocketAddr,
    flag: Arc<WakeFlag>,
) -> std::io::Result<std::net::SocketAddr>
where
    E: Copy + Eq + std::hash::Hash + std::fmt::Debug,
    M: Middleware,
{
    use std::net::{IpAddr, Ipv4Addr, Ipv6Addr, SocketAddr, UdpSocket};
    let loopback: IpAddr = if server.is_ipv4() { Ipv4Addr::LOCALHOST.into() } else { Ipv6Addr::LOCALHOST.into() };
    let target = if server.ip().is_unspecified() { SocketAddr::new(loopback, server.port()) } else { server };
    let socket = UdpSocket::bind(SocketAddr::new(if target.ip().is_loopback() { loopback } else { target.ip() }, 0))?;
    let local = socket.local_addr()?;
    let waker: Waker = Arc::new(move || {
        if flag.raise() {
            // A lost wake-up datagram only delays the poll to the shell's next turn (at most MAX_BLOCK).
            let _ = socket.send_to(&[], target);
        }
    });
    core.middleware_mut().set_waker(waker);
    Ok(local)
}

/// A flag with a condition variable, for shells whose loop can wait on it (the TCP timer thread).
#[derive(Debug, Default)]
pub struct WakeSignal {
    pending: Mutex<bool>,
    cond: Condvar,
}

impl WakeSignal {
    /// Raises the signal and wakes the waiter.
    pub fn raise(&self) {
        *self.pending.lock().unwrap_or_else(std::sync::PoisonError::into_inner) = true;
        self.cond.notify_one();
    }

    /// Waits up to `timeout` for the signal; true (and lowered) when it was raised.
    pub fn wait(&self, timeout: Duration) -> bool {
        let guard = self.pending.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        let (mut guard, _) =
            self.cond.wait_timeout_while(guard, timeout, |p| !*p).unwrap_or_else(std::sync::PoisonError::into_inner);
        std::mem::replace(&mut *guard, false)
    }

    /// Installs a waker raising this signal.
    pub fn install<E, M>(self: &Arc<Self>, core: &mut AgentCore<E, M>)
    where
        E: Copy + Eq + std::hash::Hash + std::fmt::Debug,
        M: Middleware,
    {
        let me = self.clone();
        core.middleware_mut().set_waker(Arc::new(move || me.raise()));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::middleware::ced::Ced;
    use crate::middleware::describe::FallbackProfiles;
    use crate::middleware::{Creation, EntityRef, MiddlewareError, SampleVisitor, WriteOutcome};
    use xrce_proto::{RequestId, SampleIdentity};

    /// CED that hands its waker to the test.
    struct Spy {
        inner: Ced,
        waker: Arc<Mutex<Option<Waker>>>,
    }

    impl Middleware for Spy {
        fn create(&mut self, c: &Creation<'_>) -> Result<(), MiddlewareError> {
            self.inner.create(c)
        }
        fn matches(&self, c: &Creation<'_>) -> bool {
            self.inner.matches(c)
        }
        fn delete(&mut self, e: EntityRef) -> Result<(), MiddlewareError> {
            self.inner.delete(e)
        }
        fn write_data(&mut self, w: EntityRef, d: &[u8], now: Instant) -> Result<WriteOutcome, MiddlewareError> {
            self.inner.write_data(w, d, now)
        }
        fn write_request(
            &mut self,
            r: EntityRef,
            id: RequestId,
            d: &[u8],
            now: Instant,
        ) -> Result<WriteOutcome, MiddlewareError> {
            self.inner.write_request(r, id, d, now)
        }
        fn write_reply(
            &mut self,
            r: EntityRef,
            i: &SampleIdentity,
            d: &[u8],
            now: Instant,
        ) -> Result<WriteOutcome, MiddlewareError> {
            self.inner.write_reply(r, i, d, now)
        }
        fn start_reading(&mut self, r: EntityRef) -> Result<(), MiddlewareError> {
            self.inner.start_reading(r)
        }
        fn poll_sample(&mut self, r: EntityRef, visit: &mut SampleVisitor<'_>) -> Option<bool> {
            self.inner.poll_sample(r, visit)
        }
        fn set_waker(&mut self, waker: Waker) {
            *self.waker.lock().unwrap() = Some(waker);
        }
    }

    fn spy_core<E: Copy + Eq + std::hash::Hash + std::fmt::Debug>() -> (SharedCore<E>, Arc<Mutex<Option<Waker>>>) {
        let waker = Arc::new(Mutex::new(None));
        let spy = Spy { inner: Ced::new(Arc::new(FallbackProfiles)), waker: waker.clone() };
        let core = AgentCore::new(crate::core::CoreConfig::default(), Box::new(spy) as DynMiddleware);
        (Arc::new(Mutex::new(core)), waker)
    }

    fn wait_for_polls<E: Copy + Eq + std::hash::Hash + std::fmt::Debug>(core: &SharedCore<E>, n: u64) -> bool {
        let deadline = Instant::now() + Duration::from_secs(5);
        while Instant::now() < deadline {
            if lock(core).stats().middleware_polls >= n {
                return true;
            }
            std::thread::sleep(Duration::from_millis(2));
        }
        false
    }

    #[test]
    fn udp_shell_polls_the_middleware_when_its_waker_fires() {
        let (core, waker) = spy_core();
        let server = udp::UdpServer::bind("127.0.0.1:0".parse().unwrap(), core.clone()).unwrap();
        let waker = waker.lock().unwrap().clone().expect("the shell installs a waker");
        let stop = Arc::new(AtomicBool::new(false));
        let s2 = stop.clone();
        let t = std::thread::spawn(move || server.run(&s2));
        // Well under MAX_BLOCK: the wake-up, not a timeout, runs the poll.
        std::thread::sleep(Duration::from_millis(50));
        let started = Instant::now();
        waker();
        assert!(wait_for_polls(&core, 1), "no poll after the wake-up");
        assert!(started.elapsed() < MAX_BLOCK, "woken by the wake-up datagram");
        waker();
        assert!(wait_for_polls(&core, 2));
        stop.store(true, Ordering::Relaxed);
        t.join().unwrap().unwrap();
    }

    #[test]
    fn tcp_shell_polls_the_middleware_when_its_waker_fires() {
        let (core, waker) = spy_core();
        let server = tcp::TcpServer::bind("127.0.0.1:0".parse().unwrap(), core.clone()).unwrap();
        let waker = waker.lock().unwrap().clone().expect("the shell installs a waker");
        let stop = Arc::new(AtomicBool::new(false));
        let s2 = stop.clone();
        let t = std::thread::spawn(move || server.run(&s2));
        std::thread::sleep(Duration::from_millis(50));
        let started = Instant::now();
        waker();
        assert!(wait_for_polls(&core, 1));
        assert!(started.elapsed() < MAX_BLOCK);
        stop.store(true, Ordering::Relaxed);
        t.join().unwrap().unwrap();
    }
}
