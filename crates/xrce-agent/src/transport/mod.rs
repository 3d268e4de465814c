//! Transport shells: they own the sockets and the clock, and move bytes between them and an
//! [`AgentCore`](crate::core::AgentCore). Every server is one thread running one `mio` event loop
//! ([`drive::EventLoop`]), which owns the core while it runs; the library API ([`crate::agent::Agent`])
//! reaches it through its [`SharedCore`] handle ([`home`]).

pub mod batch;
#[cfg(target_os = "linux")]
pub mod canfd;
pub mod custom;
pub mod discovery;
pub mod drive;
pub mod home;
pub mod multi;
#[cfg(target_os = "linux")]
pub mod serial;
pub mod tcp;
pub mod udp;

use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use crate::middleware::Middleware;

pub use home::{CoreInUse, SharedCore};

/// The middleware type the shells run: any middleware, boxed.
pub type DynMiddleware = Box<dyn Middleware + Send>;

/// Longest a shell blocks without checking its stop flag.
pub const MAX_BLOCK: Duration = Duration::from_millis(200);

/// `name` as a `&'static str`, for peer types that must be `Copy` yet name their device in log lines (serial
/// and CAN endpoints). Each distinct name is kept once for the life of the process: a few device paths and
/// interfaces, not one per client.
#[cfg(target_os = "linux")]
pub(crate) fn device_name(name: &str) -> &'static str {
    use std::collections::BTreeSet;
    use std::sync::Mutex;
    static NAMES: Mutex<BTreeSet<&'static str>> = Mutex::new(BTreeSet::new());
    let mut names = NAMES.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    if let Some(known) = names.get(name) {
        return known;
    }
    let leaked: &'static str = Box::leak(name.into());
    names.insert(leaked);
    leaked
}

/// Logs a message in hex at trace level (verbosity 6), as eProsima's agent does.
pub fn hexdump(direction: &str, peer: &dyn std::fmt::Debug, bytes: &[u8]) {
    if tracing::enabled!(tracing::Level::TRACE) {
        let hex: String = bytes.iter().map(|b| format!("{b:02X} ")).collect();
        tracing::trace!(target: "xrce_agent::hexdump", "{direction} {peer:?} [{} bytes] {}", bytes.len(), hex.trim_end());
    }
}

/// A flag a threaded middleware raises (through its [`Waker`](crate::middleware::Waker)) when samples
/// arrived; the shell clears it and runs [`AgentCore::poll_middleware`]. Many wakes between two polls cost
/// one poll.
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

    /// Whether the flag is up, without lowering it.
    pub fn is_raised(&self) -> bool {
        self.pending.load(Ordering::Acquire)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::core::AgentCore;
    use crate::middleware::ced::Ced;
    use crate::middleware::describe::FallbackProfiles;
    use crate::middleware::{Creation, EntityRef, MiddlewareError, SampleVisitor, Waker, WriteOutcome};
    use std::sync::{Arc, Mutex};
    use std::time::Instant;
    use xrce_proto::{ClientKey, RequestId, SampleIdentity};

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

    trait Endpoint: Copy + Eq + std::hash::Hash + std::fmt::Debug + Send + 'static {}
    impl<E: Copy + Eq + std::hash::Hash + std::fmt::Debug + Send + 'static> Endpoint for E {}

    fn spy_core<E: Endpoint>() -> (SharedCore<E>, Arc<Mutex<Option<Waker>>>) {
        let waker = Arc::new(Mutex::new(None));
        let spy = Spy { inner: Ced::new(Arc::new(FallbackProfiles)), waker: waker.clone() };
        let core = AgentCore::new(crate::core::CoreConfig::default(), Box::new(spy) as DynMiddleware);
        (SharedCore::new(core), waker)
    }

    fn wait_for_polls<E: Endpoint>(core: &SharedCore<E>, n: u64) -> bool {
        let deadline = Instant::now() + Duration::from_secs(5);
        while Instant::now() < deadline {
            if core.with(|c| c.stats().middleware_polls) >= n {
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

    /// Fires `waker` `times` times; each must make the running server poll the middleware within `within`
    /// (far below the loop's longest block: a timeout turn would have come up to MAX_BLOCK later).
    fn assert_wakes<E: Endpoint>(core: &SharedCore<E>, waker: &Waker, times: u64, within: Duration) {
        std::thread::sleep(Duration::from_millis(50));
        let before = core.with(|c| c.stats().middleware_polls);
        for n in 1..=times {
            let started = Instant::now();
            waker();
            assert!(wait_for_polls(core, before + n), "no poll after wake-up {n}");
            assert!(started.elapsed() < within, "wake-up {n} waited for a timeout");
        }
    }

    /// The wake-up reaches the UDP loop without any datagram: the server's socket is connected to a peer that
    /// never sends, so the kernel drops whatever else is sent to its port, and nothing reaches the core.
    #[test]
    fn a_wake_reaches_the_udp_loop_without_a_datagram() {
        let (core, waker) = spy_core();
        let socket = udp::bind_socket("127.0.0.1:0".parse().unwrap()).unwrap();
        let silent = std::net::UdpSocket::bind("127.0.0.1:0").unwrap();
        socket.connect(silent.local_addr().unwrap()).unwrap();
        let server = udp::UdpServer::from_socket(socket, core.clone()).unwrap();
        let waker = waker.lock().unwrap().clone().expect("the shell installs a waker");
        let stop = Arc::new(AtomicBool::new(false));
        let s2 = stop.clone();
        let t = std::thread::spawn(move || server.run(&s2));
        assert_wakes(&core, &waker, 3, MAX_BLOCK / 4);
        assert_eq!(core.with(|c| c.stats().datagrams_in), 0);
        stop.store(true, Ordering::Relaxed);
        t.join().unwrap().unwrap();
    }

    #[test]
    fn serial_shell_polls_the_middleware_when_its_waker_fires() {
        let (core, slot) = spy_core();
        let server = serial::SerialServer::new(vec![serial::Line::pseudoterminal(115_200).unwrap()], core.clone());
        let stop = Arc::new(AtomicBool::new(false));
        let s2 = stop.clone();
        let t = std::thread::spawn(move || server.run(&s2));
        // The serial server installs its waker when it starts running.
        let deadline = Instant::now() + Duration::from_secs(5);
        let waker = loop {
            if let Some(w) = slot.lock().unwrap().clone() {
                break w;
            }
            assert!(Instant::now() < deadline, "the shell installs a waker");
            std::thread::sleep(Duration::from_millis(5));
        };
        assert_wakes(&core, &waker, 3, MAX_BLOCK / 4);
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
    /// While a server runs, its loop owns the core: the library API's calls run in its turns, and the core
    /// comes back to the handle, with what they did, when the server stops.
    #[test]
    fn api_calls_reach_the_core_a_running_server_owns() {
        let (core, _) = spy_core::<std::net::SocketAddr>();
        let server = udp::UdpServer::bind("127.0.0.1:0".parse().unwrap(), core.clone()).unwrap();
        let stop = Arc::new(AtomicBool::new(false));
        let s2 = stop.clone();
        let t = std::thread::spawn(move || server.run(&s2));
        std::thread::sleep(Duration::from_millis(50));
        assert!(format!("{core:?}").contains("running server"), "the loop took the core");
        let key = ClientKey::from_u32(0x0102_0304);
        let status = core.with(move |c| c.create_client(key, 0x81, 512, Instant::now()));
        assert!(status.is_ok(), "{status:?}");
        let second = udp::UdpServer::bind("127.0.0.1:0".parse().unwrap(), core.clone()).unwrap();
        let refused = second.run(&AtomicBool::new(false)).unwrap_err();
        assert!(refused.to_string().contains("another server"), "{refused}");
        stop.store(true, Ordering::Relaxed);
        t.join().unwrap().unwrap();
        assert!(format!("{core:?}").contains("parked"));
        assert!(core.with(move |c| c.has_client(key)), "the client created through the loop is in the core");
    }
}
