//! The event loop every shell runs, and the one place shells call into the core.
//!
//! A shell (UDP, TCP, serial) is an [`Io`]: it registers its sockets or lines with the loop's `mio` poll,
//! notes their readiness, reads without blocking and sends or queues what the core produced. An
//! [`EventLoop`] waits for readiness, the core's next timer or the middleware's waker (a `mio::Waker` behind
//! a [`WakeFlag`]), answers the `-d` discovery responder if the server has one, then [`Driver::drive`] runs one
//! turn: take back the buffers sent last turn, hand the input to the core, send the ACKNACKs owed at once
//! (UDP); if the shell already holds more input, end the turn there, a few times in a row at most
//! ([`MAX_DEFERRED_SENDS`]); else run the library API's jobs, poll the middleware if it woke, run due timers,
//! take every message to send (written by the core into the driver's spare buffers), send them.
//!
//! A middleware may call its waker on the loop's own thread, inside a turn: Fast DDS hands a sample written
//! by one client to a reader of the same process within the write. That call only raises the flag (no
//! `mio::Waker` system call, no extra turn): the turn reads the flag after its input, before it polls the
//! middleware, and the loop does not block while the flag is up ([`LOOP_FLAG`]). The loop owns the core while it runs ([`SharedCore::lend`]): no lock per turn.

use std::cell::Cell;
use std::fmt::Debug;
use std::hash::Hash;
use std::io;
use std::panic::AssertUnwindSafe;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::Receiver;
use std::sync::{Arc, Mutex, PoisonError};
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use std::os::fd::AsRawFd;

use mio::event::Event;
use mio::unix::SourceFd;
use mio::{Events, Interest, Poll, Registry, Token};

use super::discovery::DiscoveryServer;
use super::home::{Core, Job};
use super::{hexdump, SharedCore, WakeFlag, MAX_BLOCK};
use crate::core::Transmit;

/// The middleware waker's token in every shell's poll; shells number their sources from 1.
pub const WAKER: Token = Token(0);

thread_local! {
    /// The wake flag of the loop running on this thread (null when none): a waker called on that thread
    /// only raises the flag, which the loop reads before blocking, instead of waking the loop's poll.
    static LOOP_FLAG: Cell<*const WakeFlag> = const { Cell::new(std::ptr::null()) };
}

/// Marks this thread as running the loop of `flag` until dropped.
struct LoopThread;

impl LoopThread {
    fn enter(flag: &WakeFlag) -> Self {
        LOOP_FLAG.with(|f| f.set(flag));
        LoopThread
    }
}

impl Drop for LoopThread {
    fn drop(&mut self) {
        LOOP_FLAG.with(|f| f.set(std::ptr::null()));
    }
}

/// Whether this thread runs the loop of `flag` (a waker then needs no system call).
fn on_loop_thread(flag: &WakeFlag) -> bool {
    LOOP_FLAG.with(|f| std::ptr::eq(f.get(), flag))
}

/// A shell's range of `mio` tokens. Alone on its loop a shell numbers its sources from 1 ([`Tokens::ALONE`]);
/// shells sharing one loop ([`super::multi`]) each get a range of their own, in the token's top byte, so each
/// readiness event reaches the shell that registered the source.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Tokens {
    base: usize,
}

/// Bits of a token left to the shell: all but the top byte.
const LOCAL_BITS: u32 = usize::BITS - 8;
const LOCAL_MASK: usize = (1 << LOCAL_BITS) - 1;

impl Tokens {
    /// The range of a shell alone on its loop.
    pub const ALONE: Self = Self { base: 0 };
    /// Most shells one loop serves (the top byte, less 0 for [`Self::ALONE`] and 255 for the loop's own).
    pub const MAX_SHARED: usize = 254;

    /// The range of shell `index` of a shared loop; none past [`Self::MAX_SHARED`].
    pub fn shared(index: usize) -> Option<Self> {
        (index < Self::MAX_SHARED).then(|| Self { base: (index + 1) << LOCAL_BITS })
    }

    /// The shell's token number `n` (kept below the top byte).
    pub fn token(self, n: usize) -> Token {
        Token(self.base | (n & LOCAL_MASK))
    }

    /// The shell's number of `token`, if the token is in its range.
    pub fn local(self, token: Token) -> Option<usize> {
        (token.0 & !LOCAL_MASK == self.base).then_some(token.0 & LOCAL_MASK)
    }

    /// Which shell of a shared loop `token` belongs to.
    pub fn shell_of(token: Token) -> Option<usize> {
        (token.0 >> LOCAL_BITS).checked_sub(1)
    }
}

/// A shell's sources, as one [`Driver::drive`] turn sees them.
pub trait Io<E> {
    /// Whether the ACKNACKs owed go out in their own send before the batch's samples are delivered, so a
    /// publisher blocked on a full history gets its slots back sooner (UDP: +15-30 % reliable throughput).
    const EARLY_ACKNACKS: bool = false;

    /// Notes the readiness of one of the shell's sources (never the waker's).
    fn ready(&mut self, event: &Event);

    /// The loop woke without any event (its timer): a shell that skips reads it believes would find
    /// nothing reads anyway, so a wrong belief costs at most one timer period.
    fn idle(&mut self) {}

    /// Called before the loop blocks: takes, without blocking, input likely to be waiting already (UDP: more
    /// datagrams after a batch); true when it got some, and the next turn then runs at once. This saves a
    /// readiness poll per turn under load.
    fn prefetch(&mut self) -> io::Result<bool> {
        Ok(false)
    }

    /// Reads what arrived, without blocking, and hands every message to `inbox`. An error stops the server.
    fn receive(&mut self, inbox: &mut Inbox<'_, E>) -> io::Result<()>;

    /// Sends or queues every message of `out`, draining it; gives the buffers it is done with (now or
    /// later) and the endpoints it closed to `spent`.
    fn send(&mut self, out: &mut Vec<Transmit<E>>, spent: &mut Spent<E>);
}

/// Where a shell's received messages go: the core itself, or (several transports on one core,
/// [`super::multi`]) the core behind a tag naming the transport. A dynamic call per message, ~2 ns, is the
/// price of one shell type serving both.
pub trait Sink<E> {
    /// Hands one message from `from` to the core.
    fn deliver(&mut self, from: E, bytes: &[u8], now: Instant);
    /// Forgets an endpoint that is gone.
    fn forget(&mut self, endpoint: E);
}

impl<E: Copy + Eq + Hash + Debug> Sink<E> for Core<E> {
    fn deliver(&mut self, from: E, bytes: &[u8], now: Instant) {
        self.handle_datagram(from, bytes, now);
    }

    fn forget(&mut self, endpoint: E) {
        self.forget_endpoint(endpoint);
    }
}

/// The core as [`Io::receive`] sees it.
pub struct Inbox<'a, E> {
    core: &'a mut dyn Sink<E>,
    now: Instant,
    hex: bool,
    /// Messages handed to the core this turn.
    delivered: usize,
}

impl<'a, E: Debug> Inbox<'a, E> {
    /// An inbox on `core` for a turn at `now`; `hex`: dump every message (verbosity 6).
    pub fn new(core: &'a mut dyn Sink<E>, now: Instant, hex: bool) -> Self {
        Self { core, now, hex, delivered: 0 }
    }

    /// Hands one received message from `from` to the core.
    pub fn deliver(&mut self, from: E, bytes: &[u8]) {
        if self.hex {
            hexdump("recv", &from, bytes);
        }
        self.core.deliver(from, bytes, self.now);
        self.delivered += 1;
    }

    /// Forgets an endpoint that is gone (a closed TCP connection).
    pub fn forget(&mut self, endpoint: E) {
        self.core.forget(endpoint);
    }

    /// The turn's time.
    pub fn now(&self) -> Instant {
        self.now
    }
}

/// What a shell hands back after sending; returned to the core at the start of the next turn.
#[derive(Debug)]
pub struct Spent<E> {
    /// Message buffers sent or dropped, for the core's pool (no allocation per message once warm).
    pub buffers: Vec<Vec<u8>>,
    /// Endpoints closed while sending.
    pub gone: Vec<E>,
}

/// Spare buffers a driver keeps for the core to write messages into; more go to the core's pool.
const MAX_SPARE: usize = 256;

/// Turns in a row that may take more input before building and sending what the input produced, while the
/// shell already holds more ([`Io::prefetch`]). Under load this makes each send carry more: a best-effort
/// message packs the samples of several reads, and the system calls per turn are shared by more samples. The
/// core got cheap enough that a turn ran on a handful of datagrams, and its fixed `recvmmsg` + `sendmmsg`
/// made the kernel's share grow. Idle, or when a read comes back empty, nothing waits. ACKNACKs still leave
/// every turn, and a turn that got one message is not held back (the read that looks for more would delay
/// its answer: +3.9 µs on the round trip when it was). Against not deferring, alternating (4 rounds,
/// medians): best effort 16 B 233k → 271k/s, reliable 16 B 186k → 202k/s, 1024 B 39.7k → 45.0k/s; 3 and 5
/// did as well, 8 lost at best effort.
const MAX_DEFERRED_SENDS: u8 = 4;

/// A shell's turn state: the messages of the turn, what comes back from sending them, and the buffers the
/// core writes the next ones into.
#[derive(Debug)]
pub struct Driver<E> {
    out: Vec<Transmit<E>>,
    early: Vec<Transmit<E>>,
    spent: Spent<E>,
    spare: Vec<Vec<u8>>,
    /// Turns since the last send that took input and deferred the rest ([`MAX_DEFERRED_SENDS`]).
    deferred: u8,
}

impl<E: Copy + Eq + Hash + Debug> Default for Driver<E> {
    fn default() -> Self {
        Self {
            out: Vec::new(),
            early: Vec::new(),
            spent: Spent { buffers: Vec::new(), gone: Vec::new() },
            spare: Vec::new(),
            deferred: 0,
        }
    }
}

impl<E: Copy + Eq + Hash + Debug> Driver<E> {
    /// One turn (see the module documentation); `wake`: raised when the middleware's waker fired (read once
    /// the input is in, so samples the input itself delivered are served in this turn); `jobs`: the library
    /// API's calls waiting for the core. Returns how long the loop may block before the next turn: zero
    /// while `wake` is up.
    pub fn drive<I: Io<E>>(
        &mut self,
        c: &mut Core<E>,
        jobs: &Receiver<Job<E>>,
        wake: &WakeFlag,
        io: &mut I,
    ) -> io::Result<Duration> {
        let hex = tracing::enabled!(target: "xrce_agent::hexdump", tracing::Level::TRACE);
        let now = Instant::now();
        self.give_back(c);
        let mut inbox = Inbox::new(&mut *c, now, hex);
        io.receive(&mut inbox)?;
        let delivered = inbox.delivered;
        if I::EARLY_ACKNACKS {
            loop {
                let mut data = self.spare.pop().unwrap_or_default();
                let Some(to) = c.poll_acknack(&mut data) else {
                    self.spare.push(data);
                    break;
                };
                self.early.push(Transmit { to, data });
            }
            if !self.early.is_empty() {
                dump_sent(hex, &self.early);
                io.send(&mut self.early, &mut self.spent);
                self.give_back(c);
            }
        }
        // A turn on one message (a ping, a request) is not held back: looking for more would cost a read
        // before its answer leaves.
        if delivered > 1 && self.deferred < MAX_DEFERRED_SENDS && io.prefetch()? {
            // More input is here already: take it first, and send what both produced together.
            self.deferred += 1;
            return Ok(Duration::ZERO);
        }
        self.deferred = 0;
        run_jobs(c, jobs);
        if wake.take() {
            c.poll_middleware(now);
        }
        if c.poll_timeout().is_some_and(|t| t <= now) {
            c.handle_timeout(now);
        }
        loop {
            let mut data = self.spare.pop().unwrap_or_default();
            let Some(to) = c.poll_transmit(now, &mut data) else {
                self.spare.push(data);
                break;
            };
            self.out.push(Transmit { to, data });
        }
        dump_sent(hex, &self.out);
        io.send(&mut self.out, &mut self.spent);
        c.after_send(now);
        let wait = block_for(c.poll_timeout(), now);
        // Raised on this thread after the poll above (a drained queue resumed): no wake-up will come.
        Ok(if wake.is_raised() { Duration::ZERO } else { wait })
    }

    /// Takes back the buffers of the last turn (sent, dropped or left unsent) as spares, and tells the core
    /// of the endpoints closed while sending.
    fn give_back(&mut self, core: &mut Core<E>) {
        let unsent = self.out.drain(..).chain(self.early.drain(..)).map(|t| t.data);
        for data in self.spent.buffers.drain(..).chain(unsent) {
            if self.spare.len() < MAX_SPARE {
                self.spare.push(data);
            } else {
                core.recycle(data);
            }
        }
        for endpoint in self.spent.gone.drain(..) {
            core.forget_endpoint(endpoint);
        }
    }
}

/// Runs the library API's calls. One that panics is logged and the server goes on (its caller gets the
/// panic, see [`SharedCore::with`]), as a panicking call on a locked core did.
fn run_jobs<E>(core: &mut Core<E>, jobs: &Receiver<Job<E>>) {
    while let Ok(job) = jobs.try_recv() {
        if std::panic::catch_unwind(AssertUnwindSafe(|| job(core))).is_err() {
            tracing::error!("an agent API call panicked inside the server's turn; the server goes on");
        }
    }
}

fn dump_sent<E: Debug>(hex: bool, msgs: &[Transmit<E>]) {
    if hex {
        for t in msgs {
            hexdump("send", &t.to, &t.data);
        }
    }
}

/// How long to block waiting for input given the core's next timer.
pub fn block_for(next: Option<Instant>, now: Instant) -> Duration {
    next.map_or(MAX_BLOCK, |t| t.saturating_duration_since(now)).clamp(Duration::from_millis(1), MAX_BLOCK)
}

/// Prepares `core` for a loop polled by `poll`: anchors its TIMESTAMP_REPLY clock to the system clock and
/// gives its middleware a waker that raises the returned flag and wakes the poll ([`WAKER`]). Many wakes
/// between two turns cost one system call and one middleware poll. The poll's waker is returned too, for
/// the library API's jobs.
fn attach<E: Copy + Eq + Hash + Debug + Send + 'static>(
    core: &SharedCore<E>,
    poll: &Poll,
) -> io::Result<(Arc<WakeFlag>, Arc<mio::Waker>)> {
    let waker = Arc::new(mio::Waker::new(poll.registry(), WAKER)?);
    let flag = Arc::new(WakeFlag::default());
    let (raised, wakes) = (flag.clone(), waker.clone());
    let since_epoch = SystemTime::now().duration_since(UNIX_EPOCH).unwrap_or_default();
    core.with(move |c| {
        c.set_wall_clock(Instant::now(), since_epoch);
        c.middleware_mut().set_waker(Arc::new(move || {
            // On the loop's own thread the loop sees the flag before it blocks (`LOOP_FLAG`).
            if raised.raise() && !on_loop_thread(&raised) {
                // A failed wake-up only delays the poll to the loop's next turn (at most MAX_BLOCK).
                let _ = wakes.wake();
            }
        }));
    });
    Ok((flag, waker))
}

/// What a server keeps for its loop: the core, the middleware's wake flag, the poll (made with the server, so
/// the middleware's waker exists before the loop runs) and its waker, and the `-d` responder the loop answers.
#[derive(Debug)]
pub struct EventLoop<E> {
    core: SharedCore<E>,
    wake: Arc<WakeFlag>,
    waker: Arc<mio::Waker>,
    poll: Mutex<Option<Poll>>,
    discovery: Option<DiscoveryServer>,
}

impl<E: Copy + Eq + Hash + Debug + Send + 'static> EventLoop<E> {
    /// A loop for `core`; gives its middleware a waker that wakes this loop.
    pub fn new(core: SharedCore<E>) -> io::Result<Self> {
        let poll = Poll::new()?;
        let (wake, waker) = attach(&core, &poll)?;
        Ok(Self { core, wake, waker, poll: Mutex::new(Some(poll)), discovery: None })
    }

    /// Answers discovery requests from this loop.
    pub fn set_discovery(&mut self, discovery: DiscoveryServer) {
        self.discovery = Some(discovery);
    }

    /// Runs until `stop` is set: `setup` registers the shell's sources and builds its [`Io`], which is
    /// handed back when the loop ends. `server` names the server in the error when it already runs.
    pub fn run<I: Io<E>>(
        &self,
        server: &str,
        stop: &AtomicBool,
        setup: impl FnOnce(&Registry) -> io::Result<I>,
    ) -> io::Result<I> {
        let mut poll = self
            .poll
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .take()
            .ok_or_else(|| io::Error::other(format!("{server} is already running")))?;
        let mut io = setup(poll.registry())?;
        let waker = self.waker.clone();
        let (core, jobs) = self.core.lend(Arc::new(move || drop(waker.wake()))).map_err(io::Error::other)?;
        let mut lent = Lent { home: &self.core, core: Some(core), jobs: Some(jobs) };
        if let Lent { core: Some(core), jobs: Some(jobs), .. } = &mut lent {
            serve(core, jobs, &mut poll, &self.wake, &mut io, self.discovery.as_ref(), stop)?;
        }
        Ok(io)
    }
}

/// The core while a loop owns it; given back to its handle when the loop ends, however it ends.
struct Lent<'a, E: Send + 'static> {
    home: &'a SharedCore<E>,
    core: Option<Box<Core<E>>>,
    jobs: Option<Receiver<Job<E>>>,
}

impl<E: Send + 'static> Drop for Lent<'_, E> {
    fn drop(&mut self) {
        if let (Some(core), Some(jobs)) = (self.core.take(), self.jobs.take()) {
            self.home.park(core, jobs);
        }
    }
}

/// The discovery responder's token in a shell's poll.
const DISCOVERY: Token = Token(usize::MAX);

/// Runs a shell until `stop` is set (checked at least every [`MAX_BLOCK`]): waits for readiness, the core's
/// next timer or the waker, then drives a turn. A `-d` discovery responder, if any, is answered from the
/// same loop.
fn serve<E, I>(
    core: &mut Core<E>,
    jobs: &Receiver<Job<E>>,
    poll: &mut Poll,
    wake: &WakeFlag,
    io: &mut I,
    discovery: Option<&DiscoveryServer>,
    stop: &AtomicBool,
) -> io::Result<()>
where
    E: Copy + Eq + Hash + Debug,
    I: Io<E>,
{
    let discovery_fd = discovery.map(|d| d.socket().as_raw_fd());
    if let (Some(d), Some(fd)) = (discovery, &discovery_fd) {
        d.set_nonblocking()?;
        poll.registry().register(&mut SourceFd(fd), DISCOVERY, Interest::READABLE)?;
    }
    let mut driver = Driver::default();
    let mut events = Events::with_capacity(256);
    let mut wait = Duration::ZERO;
    let _loop_thread = LoopThread::enter(wake);
    while !stop.load(Ordering::Relaxed) {
        if !io.prefetch()? {
            if let Err(e) = poll.poll(&mut events, Some(wait)) {
                if e.kind() != io::ErrorKind::Interrupted {
                    return Err(e);
                }
            }
            if events.is_empty() {
                io.idle();
            }
            for event in &events {
                match event.token() {
                    WAKER => {}
                    DISCOVERY => answer_discovery(discovery),
                    _ => io.ready(event),
                }
            }
        }
        wait = driver.drive(core, jobs, wake, io)?;
    }
    Ok(())
}

fn answer_discovery(discovery: Option<&DiscoveryServer>) {
    if let Some(Err(e)) = discovery.map(DiscoveryServer::answer_queued) {
        // The agent keeps serving its clients.
        tracing::warn!(port = ?discovery.and_then(|d| d.local_addr().ok()), "discovery socket failed: {e}");
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::core::{AgentCore, CoreConfig};
    use crate::middleware::ced::Ced;
    use crate::middleware::describe::FallbackProfiles;

    /// A shell that has `more` reads of input waiting, `per_read` messages each, and counts its sends.
    struct Busy {
        more: usize,
        per_read: u16,
        sends: usize,
    }

    impl Io<u16> for Busy {
        fn ready(&mut self, _: &Event) {}
        fn prefetch(&mut self) -> io::Result<bool> {
            Ok(self.more > 0)
        }
        fn receive(&mut self, inbox: &mut Inbox<'_, u16>) -> io::Result<()> {
            self.more = self.more.saturating_sub(1);
            // Unknown peers' garbage: counted as received, dropped by the core.
            for peer in 0..self.per_read {
                inbox.deliver(peer, &[0xFF]);
            }
            Ok(())
        }
        fn send(&mut self, out: &mut Vec<Transmit<u16>>, spent: &mut Spent<u16>) {
            self.sends += 1;
            spent.buffers.extend(out.drain(..).map(|t| t.data));
        }
    }

    #[test]
    fn sends_wait_for_input_already_here_a_bounded_number_of_turns() {
        let mut core: Core<u16> = AgentCore::new(CoreConfig::default(), Box::new(Ced::new(Arc::new(FallbackProfiles))));
        let (_tx, jobs) = std::sync::mpsc::channel();
        let mut driver = Driver::default();
        let turns = 3 * (usize::from(MAX_DEFERRED_SENDS) + 1);
        let mut io = Busy { more: usize::MAX, per_read: 2, sends: 0 };
        for _ in 0..turns {
            driver.drive(&mut core, &jobs, &WakeFlag::default(), &mut io).unwrap();
        }
        assert_eq!(io.sends, 3, "one send per {} turns while input keeps coming", MAX_DEFERRED_SENDS + 1);
        let mut io = Busy { more: 0, per_read: 2, sends: 0 };
        for _ in 0..4 {
            driver.drive(&mut core, &jobs, &WakeFlag::default(), &mut io).unwrap();
        }
        assert_eq!(io.sends, 4, "nothing waits when no input does");
        let mut io = Busy { more: usize::MAX, per_read: 1, sends: 0 };
        for _ in 0..4 {
            driver.drive(&mut core, &jobs, &WakeFlag::default(), &mut io).unwrap();
        }
        assert_eq!(io.sends, 4, "a turn on one message answers at once");
    }
}
