//! The blocking session: the sans-IO core driven over a [`Transport`] with a [`Clock`], and the `run_session_*`
//! family with the semantics the C API documents.

#[cfg(feature = "std")]
use super::replay::{Replay, Unacked};
use super::{
    millis, Callbacks, Outputs, PingState, Reconnect, SessionCore, SessionEvent, SessionState, TimeSample, MILLIS,
    SESSION_CONNECTION_INTERVAL_MS,
};
use crate::error::{Error, Result};
use crate::transport::{Transport, TransportError};
use crate::{WriteAccess, STATUS_NONE};
use xrce_proto::{ObjectId, SampleIdentity, StreamId};

/// A source of time in nanoseconds since the Unix epoch; it should not go backwards.
pub trait Clock {
    /// Current time.
    fn now_nanos(&mut self) -> i64;
}

impl<F: FnMut() -> i64> Clock for F {
    fn now_nanos(&mut self) -> i64 {
        self()
    }
}

/// The system clock read once, then advanced with a monotonic clock, so timers never jump.
#[cfg(feature = "std")]
#[derive(Debug, Clone, Copy)]
pub struct StdClock {
    base: i64,
    start: std::time::Instant,
}

#[cfg(feature = "std")]
impl Default for StdClock {
    fn default() -> Self {
        let base = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| i64::try_from(d.as_nanos()).unwrap_or(i64::MAX));
        Self { base, start: std::time::Instant::now() }
    }
}

#[cfg(feature = "std")]
impl Clock for StdClock {
    fn now_nanos(&mut self) -> i64 {
        self.base.saturating_add(i64::try_from(self.start.elapsed().as_nanos()).unwrap_or(i64::MAX))
    }
}

/// Transport, clock and the message buffer: what the loop needs besides the core and the callbacks. One buffer
/// serves both directions: a received message is fully handled (reliable input copies what it keeps into its
/// own stream buffer) before anything is built for sending.
#[derive(Debug)]
struct Io<T, K, const MTU: usize> {
    transport: T,
    clock: K,
    buf: [u8; MTU],
    /// The transport failed while reconnection is on: when to reopen it next ([`WORKING`] when it works).
    #[cfg(feature = "reconnect")]
    reopen_at: i64,
    /// The wait before the next reopening, in milliseconds; it grows with every failure until the session is
    /// back (0: no failure since), so a transport that fails right after each reopening (UDP to a dead port:
    /// every send meets the ICMP error of the previous one) is not reopened and retried in a tight loop.
    #[cfg(feature = "reconnect")]
    reopen_ms: u16,
    /// Entities and reads to create again after a re-creation (boxed: the session stays small on the stack).
    /// Recorded only while reconnection is on, and allocated then: a session without it (the C library's,
    /// as eProsima's) holds no heap memory, so one on a C program's stack leaks nothing when it goes.
    #[cfg(feature = "std")]
    replay: Option<Box<Replay>>,
}

impl<T: Transport, K: Clock, const MTU: usize> Io<T, K, MTU> {
    fn new(transport: T, clock: K) -> Self {
        Self {
            transport,
            clock,
            buf: [0; MTU],
            #[cfg(feature = "reconnect")]
            reopen_at: WORKING,
            #[cfg(feature = "reconnect")]
            reopen_ms: 0,
            #[cfg(feature = "std")]
            replay: None,
        }
    }

    fn send_pending<const A: usize, const B: usize, const C: usize, const D: usize>(
        &mut self,
        core: &mut SessionCore<'_, A, B, C, D>,
    ) -> Result<()> {
        let now = self.clock.now_nanos();
        while let Some(n) = core.poll_transmit(now, &mut self.buf) {
            let msg = self.buf.get(..n).unwrap_or(&[]);
            #[cfg(feature = "std")]
            if core.reconnect_config().is_some() {
                self.replay.get_or_insert_with(Box::default).observe(msg);
            }
            if self.broken() {
                continue;
            }
            if let Err(e) = self.transport.send(msg) {
                self.failed(core, e)?;
            }
        }
        Ok(())
    }

    /// A transport error: with reconnection on and a session to keep, the session counts as lost and the
    /// transport is reopened until it works; otherwise the error goes to the caller.
    #[cfg(feature = "reconnect")]
    fn failed<const A: usize, const B: usize, const C: usize, const D: usize>(
        &mut self,
        core: &mut SessionCore<'_, A, B, C, D>,
        e: TransportError,
    ) -> Result<()> {
        let Some(config) = core.reconnect_config() else { return Err(e.into()) };
        if core.state() != SessionState::Established && !core.is_reconnecting() {
            return Err(e.into());
        }
        let now = self.clock.now_nanos();
        if core.state() == SessionState::Established {
            core.reconnect(now);
        }
        if !self.broken() {
            // The first failure reopens at once (a TCP connection reset by a live agent); later ones back off.
            self.reopen_at = now + i64::from(self.reopen_ms) * MILLIS;
            self.reopen_ms =
                self.reopen_ms.saturating_mul(2).clamp(config.retry_min_ms.max(1), config.retry_max_ms.max(1));
        }
        Ok(())
    }

    /// Without reconnection a transport error goes to the caller.
    #[cfg(not(feature = "reconnect"))]
    #[allow(clippy::unused_self)]
    fn failed<const A: usize, const B: usize, const C: usize, const D: usize>(
        &mut self,
        _core: &mut SessionCore<'_, A, B, C, D>,
        e: TransportError,
    ) -> Result<()> {
        Err(e.into())
    }

    /// Reopens a failed transport when it is time.
    #[cfg(feature = "reconnect")]
    fn reopen<const A: usize, const B: usize, const C: usize, const D: usize>(
        &mut self,
        core: &mut SessionCore<'_, A, B, C, D>,
    ) {
        let now = self.clock.now_nanos();
        if !self.broken() || now < self.reopen_at {
            return;
        }
        let _ = self.transport.close();
        if self.transport.open().is_ok() {
            self.reopen_at = WORKING;
            // Try the agent at once rather than at the next attempt of the back-off.
            core.reconnect(now);
        } else {
            let max = core.reconnect_config().map_or(1000, |c| c.retry_max_ms.max(1));
            self.reopen_at = now + i64::from(self.reopen_ms) * MILLIS;
            self.reopen_ms = self.reopen_ms.saturating_mul(2).clamp(1, max);
        }
    }

    #[cfg(not(feature = "reconnect"))]
    #[allow(clippy::unused_self)]
    fn reopen<const A: usize, const B: usize, const C: usize, const D: usize>(
        &mut self,
        _core: &mut SessionCore<'_, A, B, C, D>,
    ) {
    }

    #[cfg(feature = "reconnect")]
    const fn broken(&self) -> bool {
        self.reopen_at != WORKING
    }

    #[cfg(not(feature = "reconnect"))]
    #[allow(clippy::unused_self)]
    const fn broken(&self) -> bool {
        false
    }

    /// How long until the failed transport is reopened, if it failed.
    #[cfg(feature = "reconnect")]
    fn until_reopen(&self, now: i64) -> Option<i64> {
        self.broken().then(|| (self.reopen_at - now).max(0))
    }

    #[cfg(not(feature = "reconnect"))]
    #[allow(clippy::unused_self)]
    const fn until_reopen(&self, _now: i64) -> Option<i64> {
        None
    }

    /// Reports what happened to the session and, after a re-creation, writes the entities, reads and
    /// unacknowledged messages again.
    fn service<H: Callbacks + ?Sized, const A: usize, const B: usize, const C: usize, const D: usize>(
        &mut self,
        core: &mut SessionCore<'_, A, B, C, D>,
        h: &mut H,
    ) -> Result<()> {
        while let Some(event) = core.poll_event() {
            match event {
                SessionEvent::Lost => h.on_session_lost(),
                SessionEvent::Restored { recreated } => {
                    #[cfg(feature = "reconnect")]
                    {
                        self.reopen_ms = 0;
                    }
                    #[cfg(feature = "std")]
                    if recreated {
                        self.start_replay(core);
                    }
                    h.on_session_restored(recreated);
                }
            }
        }
        #[cfg(feature = "std")]
        self.drain_replay(core, h)?;
        Ok(())
    }

    #[cfg(feature = "std")]
    fn start_replay<const A: usize, const B: usize, const C: usize, const D: usize>(
        &mut self,
        core: &mut SessionCore<'_, A, B, C, D>,
    ) {
        let streams: Vec<_> = core.reliable_output_streams().collect();
        let mut unacked = Unacked::default();
        for s in streams {
            let _ = core.take_reliable_output(s, |body, _| unacked.message(s, body));
        }
        self.replay.get_or_insert_with(Box::default).start(unacked.items);
    }

    /// Writes what the replay still holds, running the session while the histories are full, until all is
    /// written or the session is lost again (the rest waits for the next re-creation or resumption).
    #[cfg(feature = "std")]
    fn drain_replay<H: Callbacks + ?Sized, const A: usize, const B: usize, const C: usize, const D: usize>(
        &mut self,
        core: &mut SessionCore<'_, A, B, C, D>,
        h: &mut H,
    ) -> Result<()> {
        loop {
            let Some(replay) = self.replay.as_deref_mut() else { return Ok(()) };
            if replay.pending.is_empty() || core.state() != SessionState::Established {
                break;
            }
            while let Some(item) = replay.pending.front() {
                let written = core.outputs().write_parts(item.stream, &[&item.bytes]);
                if written == Err(Error::WouldBlock) {
                    break;
                }
                // Written, or never writable (a stream gone): either way done with it.
                replay.pending.pop_front();
            }
            core.flash_output_streams();
            if replay.pending.is_empty() {
                break;
            }
            self.send_pending(core)?;
            let now = self.clock.now_nanos();
            let wait = core.poll_timeout().map_or(100, |t| millis((t - now).max(0) + MILLIS - 1)).min(100);
            match self.transport.recv(&mut self.buf, i32::try_from(wait).unwrap_or(100)) {
                Ok(Some(n)) => {
                    let now = self.clock.now_nanos();
                    core.handle_input(self.buf.get(..n).unwrap_or(&[]), now, h);
                }
                Ok(None) => {}
                Err(e) => self.failed(core, e)?,
            }
        }
        Ok(())
    }

    /// Listens for one message up to `timeout_ms` (negative: forever), sending heartbeats and retries while
    /// waiting; whether one arrived. The C client's `listen_message_reliably`.
    fn listen<H: Callbacks + ?Sized, const A: usize, const B: usize, const C: usize, const D: usize>(
        &mut self,
        core: &mut SessionCore<'_, A, B, C, D>,
        timeout_ms: i32,
        h: &mut H,
    ) -> Result<bool> {
        let start = self.clock.now_nanos();
        let deadline = (timeout_ms >= 0).then(|| start + i64::from(timeout_ms) * MILLIS);
        loop {
            self.reopen(core);
            self.service(core, h)?;
            self.send_pending(core)?;
            let now = self.clock.now_nanos();
            // The earlier of the deadline and the next timer, i64::MAX for neither (firmware size: one
            // subtraction, no arithmetic on `Option<i64>`).
            let until = deadline.unwrap_or(i64::MAX).min(core.poll_timeout().unwrap_or(i64::MAX));
            let mut wait = (until != i64::MAX).then(|| (until - now).max(0));
            if let Some(reopen) = self.until_reopen(now) {
                wait = Some(wait.map_or(reopen, |w| w.min(reopen)));
            }
            let wait_ms = wait.map_or(-1, |ns| i32::try_from(millis(ns + MILLIS - 1)).unwrap_or(i32::MAX));
            if self.broken() {
                // Nothing to read from a failed transport: wait for the next reopen or timer.
                pause(wait_ms);
            } else {
                match self.transport.recv(&mut self.buf, wait_ms) {
                    Ok(Some(n)) => {
                        let now = self.clock.now_nanos();
                        let written = core.last_request_id();
                        core.handle_input(self.buf.get(..n).unwrap_or(&[]), now, h);
                        if core.last_request_id() != written {
                            // A callback wrote (a replier's reply, say): send it now rather than at the next run, so
                            // `run_session_time` and friends do not end with it unsent (the C client waits for the
                            // next `uxr_run_session_*` call, a full timeout later).
                            core.flash_output_streams();
                        }
                        self.service(core, h)?;
                        self.send_pending(core)?;
                        if !core.last_input_was_probe_answer() {
                            return Ok(true);
                        }
                    }
                    Ok(None) => {}
                    Err(e) => self.failed(core, e)?,
                }
            }
            if deadline.is_some_and(|d| d <= now || self.clock.now_nanos() >= d) {
                return Ok(false);
            }
        }
    }
}

/// `reopen_at` of a transport that works.
#[cfg(feature = "reconnect")]
const WORKING: i64 = i64::MIN;

/// Sleeps while the transport is down (without `std` there is no way to sleep: the loop polls the clock).
#[cfg(feature = "std")]
fn pause(ms: i32) {
    let ms = u64::try_from(ms.clamp(0, 100)).unwrap_or(100);
    std::thread::sleep(std::time::Duration::from_millis(ms));
}

#[cfg(not(feature = "std"))]
const fn pause(_ms: i32) {}

/// Wraps the user's callbacks to record statuses of awaited requests and whether data arrived.
struct Tracker<'c, C: ?Sized> {
    inner: &'c mut C,
    requests: &'c [u16],
    statuses: &'c mut [u8],
    data: bool,
}

impl<C: Callbacks + ?Sized> Callbacks for Tracker<'_, C> {
    fn on_status(&mut self, out: &mut Outputs<'_, '_>, object_id: ObjectId, request_id: u16, status: u8) {
        self.inner.on_status(out, object_id, request_id, status);
    }
    fn on_topic(
        &mut self,
        out: &mut Outputs<'_, '_>,
        object_id: ObjectId,
        request_id: u16,
        stream_id: StreamId,
        data: &[u8],
    ) {
        self.data = true;
        self.inner.on_topic(out, object_id, request_id, stream_id, data);
    }
    fn on_request(
        &mut self,
        out: &mut Outputs<'_, '_>,
        object_id: ObjectId,
        request_id: u16,
        sample_id: &SampleIdentity,
        data: &[u8],
    ) {
        self.data = true;
        self.inner.on_request(out, object_id, request_id, sample_id, data);
    }
    fn on_reply(
        &mut self,
        out: &mut Outputs<'_, '_>,
        object_id: ObjectId,
        request_id: u16,
        reply_id: u16,
        data: &[u8],
    ) {
        self.data = true;
        self.inner.on_reply(out, object_id, request_id, reply_id, data);
    }
    fn on_time(&mut self, sample: &TimeSample) -> bool {
        self.inner.on_time(sample)
    }
    fn on_pong(&mut self, in_session: bool) {
        self.inner.on_pong(in_session);
    }
    fn on_request_status(&mut self, request_id: u16, status: u8) {
        for (r, s) in self.requests.iter().zip(self.statuses.iter_mut()) {
            if *r == request_id {
                *s = status;
            }
        }
        self.inner.on_request_status(request_id, status);
    }
    fn on_session_lost(&mut self) {
        self.inner.on_session_lost();
    }
    fn on_session_restored(&mut self, recreated: bool) {
        self.inner.on_session_restored(recreated);
    }
}

/// A session over a transport: the C API's `uxrSession` with its `uxrCommunication`.
///
/// `C` receives what the agent sends (see [`Callbacks`]); the const parameters bound the streams of each kind
/// (output best effort, output reliable, input best effort, input reliable) and size the message buffers.
#[derive(Debug)]
pub struct Session<
    'a,
    T,
    K,
    C = (),
    const OBE: usize = 1,
    const ORE: usize = 1,
    const IBE: usize = 1,
    const IRE: usize = 1,
    const MTU: usize = 512,
> {
    core: SessionCore<'a, OBE, ORE, IBE, IRE>,
    io: Io<T, K, MTU>,
    callbacks: C,
}

#[cfg(feature = "std")]
impl<'a, T: Transport> Session<'a, T, StdClock> {
    /// `uxr_init_session`: session 0x81 for client `key` over `transport`, with the system clock, one stream of
    /// each kind at most and 512-byte messages.
    pub fn new(transport: T, key: u32) -> Self {
        Self::with_clock(transport, StdClock::default(), key)
    }
}

impl<
        'a,
        T: Transport,
        K: Clock,
        C: Callbacks,
        const OBE: usize,
        const ORE: usize,
        const IBE: usize,
        const IRE: usize,
        const MTU: usize,
    > Session<'a, T, K, C, OBE, ORE, IBE, IRE, MTU>
{
    /// `uxr_init_session` with an explicit clock: session 0x81 for client `key`.
    pub fn with_clock(transport: T, clock: K, key: u32) -> Self
    where
        C: Default,
    {
        let mtu = transport.mtu().min(MTU);
        let mut core = SessionCore::new(super::DEFAULT_SESSION_ID, key, mtu);
        core.set_reconnect(Some(Reconnect::default()));
        Self { core, io: Io::new(transport, clock), callbacks: C::default() }
    }

    /// Sets automatic reconnection: on by default with [`Reconnect::default`]; `None` turns it off (transport
    /// errors then end the `run_session_*` call, as before, and a dead agent goes unnoticed).
    ///
    /// With it on, a dead agent (probes unanswered, the agent saying it does not know the session, or a
    /// transport error) is reported to [`Callbacks::on_session_lost`]; the session then tries again and again
    /// (reopening a failed transport) and, once back, reports [`Callbacks::on_session_restored`]. If the agent
    /// had lost the session it is created again with the same key and id, every entity and continuous read sent
    /// so far is created again (with REUSE), and then the reliable output the agent had not acknowledged is sent
    /// again, in order. docs/client-api.md says what this guarantees.
    #[must_use]
    pub fn with_reconnect(mut self, config: Option<Reconnect>) -> Self {
        self.core.set_reconnect(config);
        self
    }

    /// As [`with_reconnect`](Self::with_reconnect), on a session in use. The entities a re-creation makes
    /// again are those created while reconnection was on (with `std`): turned on later, it records from then.
    pub fn set_reconnect(&mut self, config: Option<Reconnect>) {
        self.core.set_reconnect(config);
    }

    /// How many entities the session would create again after a re-creation (those created and not deleted).
    #[cfg(feature = "std")]
    pub fn recorded_entities(&self) -> usize {
        self.io.replay.as_ref().map_or(0, |r| r.entity_count())
    }

    /// Counts the session as lost now and starts reconnecting (the application knows the link went down).
    pub fn reconnect(&mut self) {
        let now = self.now();
        self.core.reconnect(now);
    }

    /// Uses session id `session_id` (below 0x80 the client key travels in every header). Call before creating
    /// streams: they are dropped.
    #[must_use]
    pub fn with_session_id(mut self, session_id: u8) -> Self {
        let key = self.core.client_key().to_u32();
        let reconnect = self.core.reconnect_config();
        self.core = SessionCore::new(session_id, key, self.core.mtu());
        self.core.set_reconnect(reconnect);
        self
    }

    /// Proves to an agent run with `--psk-file` that this client holds `psk` (see
    /// [`SessionCore::set_pre_shared_key`]), with nonces starting from the system clock mixed with a random
    /// hash seed, so they do not repeat across restarts.
    #[cfg(all(feature = "psk", feature = "std"))]
    #[must_use]
    pub fn with_pre_shared_key(mut self, psk: &'a [u8]) -> Self {
        use std::hash::{BuildHasher, Hasher};
        let nanos = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| u64::try_from(d.as_nanos()).unwrap_or(u64::MAX));
        let mut h = std::collections::hash_map::RandomState::new().build_hasher();
        h.write_u64(nanos);
        // The high half keeps the clock (increasing across restarts), the low half is random.
        let nonce = (nanos & !0xFFFF_FFFF) | (h.finish() & 0xFFFF_FFFF);
        self.core.set_pre_shared_key(psk, nonce);
        self
    }

    /// Installs the callbacks (`uxr_set_status_callback`, `uxr_set_topic_callback`, `uxr_set_time_callback`,
    /// `uxr_set_request_callback`, `uxr_set_reply_callback`, all at once).
    pub fn with_callbacks<C2: Callbacks>(self, callbacks: C2) -> Session<'a, T, K, C2, OBE, ORE, IBE, IRE, MTU> {
        Session { core: self.core, io: self.io, callbacks }
    }

    /// The callbacks, to read what they gathered.
    pub fn callbacks(&mut self) -> &mut C {
        &mut self.callbacks
    }

    /// The sans-IO core.
    pub fn core(&mut self) -> &mut SessionCore<'a, OBE, ORE, IBE, IRE> {
        &mut self.core
    }

    /// The transport.
    pub fn transport(&mut self) -> &mut T {
        &mut self.io.transport
    }

    /// Gives the transport back (`uxr_close_*_transport` is then the transport's business).
    pub fn into_transport(self) -> T {
        self.io.transport
    }

    fn now(&mut self) -> i64 {
        self.io.clock.now_nanos()
    }

    // ---- session life ----------------------------------------------------------------------------------

    /// `uxr_create_session`: up to 10 CREATE_CLIENT one second apart.
    pub fn create_session(&mut self) -> Result<()> {
        self.create_session_retries(super::CREATE_SESSION_ATTEMPTS)
    }

    /// `uxr_create_session_retries`.
    pub fn create_session_retries(&mut self, attempts: usize) -> Result<()> {
        #[cfg(feature = "std")]
        if let Some(replay) = self.io.replay.as_deref_mut() {
            replay.clear();
        }
        let now = self.now();
        self.core.create_session_retries(attempts, now);
        while self.core.state() == SessionState::Creating {
            self.listen(SESSION_CONNECTION_INTERVAL_MS as i32)?;
        }
        match self.core.state() {
            SessionState::Established => Ok(()),
            SessionState::Refused(s) => Err(Error::Refused(s)),
            _ => Err(Error::Timeout),
        }
    }

    /// `uxr_delete_session`: up to 10 DELETE one second apart; `Ok(true)` when the agent confirmed.
    pub fn delete_session(&mut self) -> Result<bool> {
        self.delete_session_retries(super::CREATE_SESSION_ATTEMPTS)
    }

    /// `uxr_delete_session_retries`.
    pub fn delete_session_retries(&mut self, attempts: usize) -> Result<bool> {
        // Nothing to create again once deleted: the record's memory goes too.
        #[cfg(feature = "std")]
        {
            self.io.replay = None;
        }
        let now = self.now();
        self.core.delete_session_retries(attempts, now);
        let mut confirmed = false;
        while self.core.state() == SessionState::Deleting {
            confirmed =
                self.listen(SESSION_CONNECTION_INTERVAL_MS as i32)? && self.core.state() == SessionState::Deleted;
        }
        Ok(confirmed)
    }

    // ---- streams ---------------------------------------------------------------------------------------

    /// `uxr_create_output_best_effort_stream`.
    pub fn create_output_best_effort_stream(&mut self, buffer: &'a mut [u8]) -> Result<StreamId> {
        self.core.create_output_best_effort_stream(buffer)
    }

    /// `uxr_create_output_reliable_stream`.
    pub fn create_output_reliable_stream(&mut self, buffer: &'a mut [u8], history: usize) -> Result<StreamId> {
        self.core.create_output_reliable_stream(buffer, history)
    }

    /// `uxr_create_input_best_effort_stream`.
    pub fn create_input_best_effort_stream(&mut self) -> Result<StreamId> {
        self.core.create_input_best_effort_stream()
    }

    /// `uxr_create_input_reliable_stream`.
    pub fn create_input_reliable_stream(&mut self, buffer: &'a mut [u8], history: usize) -> Result<StreamId> {
        self.core.create_input_reliable_stream(buffer, history)
    }

    /// `uxr_flash_output_streams`: sends everything written.
    pub fn flash_output_streams(&mut self) -> Result<()> {
        self.core.flash_output_streams();
        self.io.send_pending(&mut self.core)
    }

    // ---- run_session family ----------------------------------------------------------------------------

    fn remaining(&mut self, start: i64, timeout_ms: i32) -> Option<i32> {
        if timeout_ms < 0 {
            return Some(-1);
        }
        let elapsed = millis(self.now() - start);
        let left = i64::from(timeout_ms) - elapsed;
        (left > 0).then(|| i32::try_from(left).unwrap_or(i32::MAX))
    }

    /// Listens once (see [`Io::listen`]) with the session's callbacks. They go through a [`Tracker`] with
    /// nothing to track, as in [`run_until`](Self::run_until): the receive path (`listen`, `handle_input` and
    /// the submessage dispatch behind it) is then compiled once per session type instead of twice, which is
    /// ~2.5 KB of `.text` in a firmware build (docs/client-footprint.md).
    fn listen(&mut self, timeout_ms: i32) -> Result<bool> {
        let mut tracker = Tracker { inner: &mut self.callbacks, requests: &[], statuses: &mut [], data: false };
        self.io.listen(&mut self.core, timeout_ms, &mut tracker)
    }

    /// `uxr_run_session_time`: flushes, then listens until no message comes for `timeout_ms` (the wait restarts
    /// with every message). Whether all reliable output is acknowledged.
    pub fn run_session_time(&mut self, timeout_ms: i32) -> Result<bool> {
        self.flash_output_streams()?;
        while self.listen(timeout_ms)? {}
        Ok(self.core.output_streams_confirmed())
    }

    /// `uxr_run_session_timeout`: flushes, then listens for `timeout_ms` in total. Whether all reliable output
    /// is acknowledged.
    pub fn run_session_timeout(&mut self, timeout_ms: i32) -> Result<bool> {
        self.flash_output_streams()?;
        let start = self.now();
        while let Some(left) = self.remaining(start, timeout_ms) {
            self.listen(left)?;
        }
        Ok(self.core.output_streams_confirmed())
    }

    /// `uxr_run_session_until_timeout`: flushes, then listens until one message arrives or `timeout_ms` passes.
    /// Whether a message arrived.
    pub fn run_session_until_timeout(&mut self, timeout_ms: i32) -> Result<bool> {
        self.flash_output_streams()?;
        self.listen(timeout_ms)
    }

    /// `uxr_run_session_until_confirm_delivery`: flushes, then listens until every reliable output message is
    /// acknowledged or `timeout_ms` passes in total. Whether everything was acknowledged.
    pub fn run_session_until_confirm_delivery(&mut self, timeout_ms: i32) -> Result<bool> {
        self.flash_output_streams()?;
        let start = self.now();
        while !self.core.output_streams_confirmed() {
            let Some(left) = self.remaining(start, timeout_ms) else { break };
            self.listen(left)?;
        }
        Ok(self.core.output_streams_confirmed())
    }

    fn run_until(
        &mut self,
        timeout_ms: i32,
        requests: &[u16],
        statuses: &mut [u8],
        mut done: impl FnMut(&[u8], bool) -> bool,
    ) -> Result<bool> {
        self.flash_output_streams()?;
        statuses.fill(STATUS_NONE);
        let start = self.now();
        let mut tracker = Tracker { inner: &mut self.callbacks, requests, statuses, data: false };
        loop {
            if done(tracker.statuses, tracker.data) {
                return Ok(true);
            }
            let left = if timeout_ms < 0 {
                -1
            } else {
                let elapsed = millis(self.io.clock.now_nanos() - start);
                match i64::from(timeout_ms) - elapsed {
                    l if l > 0 => i32::try_from(l).unwrap_or(i32::MAX),
                    _ => return Ok(false),
                }
            };
            self.io.listen(&mut self.core, left, &mut tracker)?;
        }
    }

    /// `uxr_run_session_until_all_status`: flushes, then listens until every request of `requests` has a
    /// status (written at the same position of `statuses`, [`STATUS_NONE`] when none came) or `timeout_ms` passes
    /// in total. Whether all came and all are `STATUS_OK` or `STATUS_OK_MATCHED`.
    pub fn run_session_until_all_status(
        &mut self,
        timeout_ms: i32,
        requests: &[u16],
        statuses: &mut [u8],
    ) -> Result<bool> {
        let n = requests.len().min(statuses.len());
        let statuses = statuses.get_mut(..n).unwrap_or(&mut []);
        self.run_until(timeout_ms, requests, statuses, |s, _| s.iter().all(|&x| x != STATUS_NONE))?;
        Ok(statuses.iter().all(|&s| s == crate::STATUS_OK || s == crate::STATUS_OK_MATCHED))
    }

    /// `uxr_run_session_until_one_status`: as [`run_session_until_all_status`](Self::run_session_until_all_status)
    /// but stops at the first status; whether it is `STATUS_OK` or `STATUS_OK_MATCHED`.
    pub fn run_session_until_one_status(
        &mut self,
        timeout_ms: i32,
        requests: &[u16],
        statuses: &mut [u8],
    ) -> Result<bool> {
        let n = requests.len().min(statuses.len());
        let statuses = statuses.get_mut(..n).unwrap_or(&mut []);
        self.run_until(timeout_ms, requests, statuses, |s, _| s.iter().any(|&x| x != STATUS_NONE))?;
        Ok(statuses.iter().any(|&s| s == crate::STATUS_OK || s == crate::STATUS_OK_MATCHED))
    }

    /// `uxr_run_session_until_data`: flushes, then listens until a sample, request or reply arrives or
    /// `timeout_ms` passes in total. Whether one arrived.
    pub fn run_session_until_data(&mut self, timeout_ms: i32) -> Result<bool> {
        self.run_until(timeout_ms, &[], &mut [], |_, data| data)
    }

    // ---- time and ping ---------------------------------------------------------------------------------

    /// `uxr_sync_session`: NTP-like exchange with the agent; whether an answer came within `timeout_ms`.
    pub fn sync_session(&mut self, timeout_ms: i32) -> Result<bool> {
        self.core.sync();
        let start = self.now();
        while !self.core.synced() {
            let Some(left) = self.remaining(start, timeout_ms) else { break };
            self.listen(left)?;
        }
        Ok(self.core.synced())
    }

    /// `uxr_epoch_millis`: milliseconds since the epoch on the agent's clock (after [`sync_session`](Self::sync_session)).
    pub fn epoch_millis(&mut self) -> i64 {
        let now = self.now();
        self.core.epoch_millis(now)
    }

    /// `uxr_epoch_nanos`.
    pub fn epoch_nanos(&mut self) -> i64 {
        let now = self.now();
        self.core.epoch_nanos(now)
    }

    /// `uxr_ping_agent_session`: GET_INFO in the session up to `attempts` times, `timeout_ms` apart; whether the
    /// agent answered and knows the session. Works with every session id, with or without key.
    /// It returns after `attempts` × `timeout_ms` at most, as eProsima's client does.
    pub fn ping_agent_session(&mut self, timeout_ms: i32, attempts: u8) -> Result<bool> {
        let start = self.now();
        let period = i64::from(timeout_ms.max(1));
        self.core.ping(period, usize::from(attempts), start);
        let deadline = start.saturating_add(period.saturating_mul(MILLIS).saturating_mul(i64::from(attempts.max(1))));
        while self.core.ping_state() == PingState::Pending {
            let left_ms = millis(deadline - self.now() + MILLIS - 1);
            if left_ms <= 0 {
                break;
            }
            self.listen(i32::try_from(left_ms).unwrap_or(i32::MAX))?;
        }
        Ok(self.core.ping_state() == PingState::Answered)
    }

    // ---- continuous fragmentation ----------------------------------------------------------------------

    /// `uxr_prepare_output_stream_fragmented`: starts a WRITE_DATA of `size` bytes for `entity` on reliable
    /// `stream` that may be larger than the whole history. Write it through the returned writer; whenever the
    /// history is full the writer calls `flush` (which should run the session, e.g.
    /// `run_session_until_confirm_delivery`) and goes on while it returns `true`.
    pub fn prepare_output_stream_fragmented<F>(
        &mut self,
        stream: StreamId,
        entity: ObjectId,
        size: usize,
        flush: F,
    ) -> Result<FragmentedWriter<'_, Self, F>>
    where
        F: FnMut(&mut Self) -> bool,
    {
        let request_id = self.core.outputs().begin_fragmented(stream, entity, size)?;
        Ok(FragmentedWriter { session: self, stream, flush, request_id, size, written: 0 })
    }
}

impl<
        'a,
        T: Transport,
        K: Clock,
        C: Callbacks,
        const OBE: usize,
        const ORE: usize,
        const IBE: usize,
        const IRE: usize,
        const MTU: usize,
    > WriteAccess<'a> for Session<'a, T, K, C, OBE, ORE, IBE, IRE, MTU>
{
    fn outputs(&mut self) -> Outputs<'_, 'a> {
        self.core.outputs()
    }
}

/// What a [`FragmentedWriter`] needs from its session.
pub trait FragmentTarget {
    /// Appends bytes to the fragmented write of `stream`; how many were taken.
    fn push_fragment(&mut self, stream: StreamId, data: &[u8]) -> Result<usize>;
}

impl<
        'a,
        T: Transport,
        K: Clock,
        C: Callbacks,
        const OBE: usize,
        const ORE: usize,
        const IBE: usize,
        const IRE: usize,
        const MTU: usize,
    > FragmentTarget for Session<'a, T, K, C, OBE, ORE, IBE, IRE, MTU>
{
    fn push_fragment(&mut self, stream: StreamId, data: &[u8]) -> Result<usize> {
        self.core.outputs().push_fragmented(stream, data)
    }
}

/// Writer of a continuous fragmented sample (`uxr_prepare_output_stream_fragmented`): CDR primitives aligned
/// from the first byte of the sample, spread over as many messages as needed. Unwritten bytes are sent as zeros.
#[derive(Debug)]
pub struct FragmentedWriter<'s, S: FragmentTarget, F: FnMut(&mut S) -> bool> {
    session: &'s mut S,
    stream: StreamId,
    flush: F,
    /// Request id of the WRITE_DATA.
    pub request_id: u16,
    size: usize,
    written: usize,
}

impl<S: FragmentTarget, F: FnMut(&mut S) -> bool> FragmentedWriter<'_, S, F> {
    /// Bytes written so far.
    pub const fn position(&self) -> usize {
        self.written
    }

    /// Writes raw bytes, flushing through the callback whenever the history is full.
    pub fn write_bytes(&mut self, mut data: &[u8]) -> Result<()> {
        if self.written + data.len() > self.size {
            return Err(Error::TooLarge);
        }
        while !data.is_empty() {
            let n = self.session.push_fragment(self.stream, data)?;
            self.written += n;
            data = data.get(n..).unwrap_or(&[]);
            if !data.is_empty() && !(self.flush)(self.session) {
                return Err(Error::WouldBlock);
            }
        }
        Ok(())
    }

    /// Pads with zeros to a multiple of `align` from the start of the sample.
    pub fn align(&mut self, align: usize) -> Result<()> {
        let pad = xrce_proto::cdr::padding(self.written, align);
        self.write_bytes([0u8; 8].get(..pad).unwrap_or(&[]))
    }

    /// Writes a little-endian `u32`, aligned.
    pub fn write_u32(&mut self, v: u32) -> Result<()> {
        self.align(4)?;
        self.write_bytes(&v.to_le_bytes())
    }

    /// Writes a little-endian `u16`, aligned.
    pub fn write_u16(&mut self, v: u16) -> Result<()> {
        self.align(2)?;
        self.write_bytes(&v.to_le_bytes())
    }

    /// Writes a little-endian `u64`, aligned to 8.
    pub fn write_u64(&mut self, v: u64) -> Result<()> {
        self.align(8)?;
        self.write_bytes(&v.to_le_bytes())
    }

    /// Writes a CDR string (length with NUL, bytes, NUL).
    pub fn write_string(&mut self, s: &str) -> Result<()> {
        self.write_u32(u32::try_from(s.len() + 1).map_err(|_| Error::TooLarge)?)?;
        self.write_bytes(s.as_bytes())?;
        self.write_bytes(&[0])
    }

    /// Writes a CDR `sequence<octet>`.
    pub fn write_octet_seq(&mut self, data: &[u8]) -> Result<()> {
        self.write_u32(u32::try_from(data.len()).map_err(|_| Error::TooLarge)?)?;
        self.write_bytes(data)
    }

    /// Pads the rest of the announced size with zeros (also done on drop).
    pub fn finish(mut self) -> Result<()> {
        self.pad_rest()
    }

    fn pad_rest(&mut self) -> Result<()> {
        while self.written < self.size {
            let n = (self.size - self.written).min(64);
            self.write_bytes([0u8; 64].get(..n).unwrap_or(&[]))?;
        }
        Ok(())
    }
}

impl<S: FragmentTarget, F: FnMut(&mut S) -> bool> Drop for FragmentedWriter<'_, S, F> {
    fn drop(&mut self) {
        // The agent expects every announced byte; a failure here leaves the stream busy until re-created.
        let _ = self.pad_rest();
    }
}
