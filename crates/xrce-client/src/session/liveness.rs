//! Noticing a dead agent and coming back: the timers and the little state the core keeps for reconnection.
//!
//! While the session is established and something was heard from the agent within
//! [`Reconnect::probe_after_ms`], nothing is added on the wire. After that silence the core sends an in-session
//! GET_INFO every `probe_after_ms`; when the first of them stays unanswered for [`Reconnect::lost_after_ms`] (or
//! the agent answers that it does not know the session, or the application calls
//! [`SessionCore::reconnect`](super::SessionCore::reconnect)), the session is lost. It then sends, at growing
//! intervals, an in-session GET_INFO (answered only by an agent that still holds the session: the session
//! resumes as it was) followed by an out-of-session one (answered by any agent: the session is re-created with
//! the same key and id). Measuring from the first unanswered probe, not from the last message, keeps an
//! application that did not run its session for a while from counting the agent as dead.

/// Reconnection settings (times in milliseconds; 16 bits keep the session small on microcontrollers).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Reconnect {
    /// Silence from the agent after which it is probed with a GET_INFO, repeated at this period.
    pub probe_after_ms: u16,
    /// How long the first probe may stay unanswered before the session counts as lost.
    pub lost_after_ms: u16,
    /// First wait between two reconnection attempts; it doubles after each attempt.
    pub retry_min_ms: u16,
    /// Longest wait between two reconnection attempts.
    pub retry_max_ms: u16,
}

impl Default for Reconnect {
    /// Probes after 500 ms of silence, lost after 1.5 s without answer, attempts from 100 ms up to 1 s apart:
    /// an agent restarted within a second is back in use within about a second and a half.
    fn default() -> Self {
        Self { probe_after_ms: 500, lost_after_ms: 1500, retry_min_ms: 100, retry_max_ms: 1000 }
    }
}

impl Reconnect {
    #[cfg(feature = "reconnect")]
    const fn ns(ms: u16) -> i64 {
        ms as i64 * MILLIS
    }
}

/// What happened to the session, from [`SessionCore::poll_event`](super::SessionCore::poll_event).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SessionEvent {
    /// The agent stopped answering (or said it lost the session); reconnection attempts started.
    Lost,
    /// The session works again. `recreated`: the agent had lost it and it was created again (the agent's
    /// streams restarted, so entities and reads must be created again, which the blocking `Session` does);
    /// otherwise the agent kept it and nothing was lost.
    Restored {
        /// Whether the session was created again.
        recreated: bool,
    },
}

#[cfg(feature = "reconnect")]
impl SessionEvent {
    const fn code(self) -> u8 {
        match self {
            Self::Lost => 1,
            Self::Restored { recreated: false } => 2,
            Self::Restored { recreated: true } => 3,
        }
    }

    const fn from_code(code: u8) -> Option<Self> {
        match code {
            1 => Some(Self::Lost),
            2 => Some(Self::Restored { recreated: false }),
            3 => Some(Self::Restored { recreated: true }),
            _ => None,
        }
    }
}

/// Events not polled yet, oldest first (as codes, 0 = none); the oldest is dropped when full.
#[cfg(feature = "reconnect")]
const EVENTS: usize = 4;

/// "No probe unanswered", "no agent seen".
#[cfg(feature = "reconnect")]
const NONE: i64 = i64::MIN;

/// How long an in-session answer may follow an out-of-session one.
#[cfg(feature = "reconnect")]
const GRACE: i64 = 200 * MILLIS;

#[cfg(feature = "reconnect")]
#[derive(Debug)]
pub(super) struct Liveness {
    config: Option<Reconnect>,
    /// Established: when the next probe is due. Reconnecting: when the next attempt is.
    due: i64,
    /// Established: send time of the oldest unanswered probe. Reconnecting: when an agent answered outside the
    /// session (the session is created again only if no answer in the session follows within [`GRACE`]: an
    /// agent may answer outside the session sooner than inside, ours does, and re-creating a session the agent
    /// kept would restart its streams for nothing). [`NONE`] otherwise.
    since: i64,
    /// Wait after the next attempt, in milliseconds.
    retry_ms: u16,
    /// The out-of-session GET_INFO of the current attempt is still to be sent.
    second_ping_due: bool,
    /// A CREATE_CLIENT is under way as part of a reconnection.
    recreating: bool,
    /// The last input was only the answer to a probe: the blocking loop does not count it as a message (else
    /// `run_session_time`, which waits for a silence, would never end while probes are answered).
    probe_answer: bool,
    events: [u8; EVENTS],
}

#[cfg(feature = "reconnect")]
const MILLIS: i64 = super::MILLIS;

#[cfg(feature = "reconnect")]
impl Liveness {
    pub(super) const fn new() -> Self {
        Self {
            config: None,
            due: 0,
            since: NONE,
            retry_ms: 0,
            second_ping_due: false,
            recreating: false,
            probe_answer: false,
            events: [0; EVENTS],
        }
    }

    pub(super) const fn config(&self) -> Option<Reconnect> {
        self.config
    }
    pub(super) fn set_config(&mut self, config: Option<Reconnect>) {
        self.config = config;
    }
    pub(super) const fn recreating(&self) -> bool {
        self.recreating
    }
    pub(super) fn set_recreating(&mut self, on: bool) {
        self.recreating = on;
    }
    pub(super) fn take_recreating(&mut self) -> bool {
        core::mem::take(&mut self.recreating)
    }
    pub(super) const fn probe_answer(&self) -> bool {
        self.probe_answer
    }
    pub(super) fn set_probe_answer(&mut self, on: bool) {
        self.probe_answer = on;
    }
    pub(super) fn take_second_ping(&mut self) -> bool {
        core::mem::take(&mut self.second_ping_due)
    }

    /// Something came from the agent for this session.
    pub(super) fn heard(&mut self, now: i64) {
        self.since = NONE;
        if let Some(c) = self.config {
            self.due = now + Reconnect::ns(c.probe_after_ms);
        }
    }

    /// While established: whether the session is lost now.
    pub(super) fn lost(&self, now: i64) -> bool {
        match self.config {
            Some(c) if self.since != NONE => now - self.since >= Reconnect::ns(c.lost_after_ms),
            _ => false,
        }
    }

    /// While established: whether a probe is due now (and, if so, counts it as sent).
    pub(super) fn probe_due(&mut self, now: i64) -> bool {
        let Some(c) = self.config else { return false };
        if now < self.due {
            return false;
        }
        if self.since == NONE {
            self.since = now;
        }
        self.due = now + Reconnect::ns(c.probe_after_ms);
        true
    }

    /// Starts reconnection attempts, the first right now.
    pub(super) fn start_attempts(&mut self, now: i64) {
        self.retry_ms = self.config.map_or(100, |c| c.retry_min_ms.max(1));
        self.due = now;
        self.since = NONE;
        self.recreating = false;
        self.second_ping_due = false;
    }

    /// While reconnecting: an agent answered outside the session.
    pub(super) fn agent_seen(&mut self, now: i64) {
        if self.since == NONE {
            self.since = now;
        }
    }

    /// While reconnecting: whether the agent seen outside the session stayed silent inside it for [`GRACE`].
    pub(super) fn recreate_due(&self, now: i64) -> bool {
        self.since != NONE && now - self.since >= GRACE
    }

    /// While reconnecting: whether an attempt is due now (and, if so, schedules the next one).
    pub(super) fn attempt_due(&mut self, now: i64) -> bool {
        if now < self.due {
            return false;
        }
        let max = self.config.map_or(1000, |c| c.retry_max_ms.max(1));
        self.due = now + Reconnect::ns(self.retry_ms);
        self.retry_ms = self.retry_ms.saturating_mul(2).min(max);
        self.second_ping_due = true;
        true
    }

    /// The earliest time something is due: a probe, the loss deadline, or an attempt.
    pub(super) fn timeout(&self, established: bool, reconnecting: bool) -> Option<i64> {
        let c = self.config?;
        if reconnecting {
            let seen = if self.since == NONE { i64::MAX } else { self.since + GRACE };
            return Some(self.due.min(seen));
        }
        if !established {
            return None;
        }
        let lost = if self.since == NONE { i64::MAX } else { self.since + Reconnect::ns(c.lost_after_ms) };
        Some(self.due.min(lost))
    }

    pub(super) fn push(&mut self, event: SessionEvent) {
        if self.events.iter().all(|&e| e != 0) {
            xrce_proto::bytes::rotate_left(&mut self.events, 1);
            if let Some(last) = self.events.last_mut() {
                *last = 0;
            }
        }
        if let Some(slot) = self.events.iter_mut().find(|e| **e == 0) {
            *slot = event.code();
        }
    }

    pub(super) fn pop(&mut self) -> Option<SessionEvent> {
        let first = core::mem::take(self.events.first_mut()?);
        xrce_proto::bytes::rotate_left(&mut self.events, 1);
        SessionEvent::from_code(first)
    }
}

/// Without the `reconnect` feature (the footprint build): nothing is kept and nothing is ever due, so the
/// reconnection paths of the session fold away and the session core stays as small as before.
#[cfg(not(feature = "reconnect"))]
#[derive(Debug)]
pub(super) struct Liveness;

#[cfg(not(feature = "reconnect"))]
#[allow(clippy::unused_self)]
impl Liveness {
    pub(super) const fn new() -> Self {
        Self
    }
    pub(super) const fn config(&self) -> Option<Reconnect> {
        None
    }
    pub(super) fn set_config(&mut self, _config: Option<Reconnect>) {}
    pub(super) const fn recreating(&self) -> bool {
        false
    }
    pub(super) fn set_recreating(&mut self, _on: bool) {}
    pub(super) fn take_recreating(&mut self) -> bool {
        false
    }
    pub(super) const fn probe_answer(&self) -> bool {
        false
    }
    pub(super) fn set_probe_answer(&mut self, _on: bool) {}
    pub(super) fn take_second_ping(&mut self) -> bool {
        false
    }
    pub(super) fn heard(&mut self, _now: i64) {}
    pub(super) fn lost(&self, _now: i64) -> bool {
        false
    }
    pub(super) fn probe_due(&mut self, _now: i64) -> bool {
        false
    }
    pub(super) fn start_attempts(&mut self, _now: i64) {}
    pub(super) fn agent_seen(&mut self, _now: i64) {}
    pub(super) fn recreate_due(&self, _now: i64) -> bool {
        false
    }
    pub(super) fn attempt_due(&mut self, _now: i64) -> bool {
        false
    }
    pub(super) fn timeout(&self, _established: bool, _reconnecting: bool) -> Option<i64> {
        None
    }
    pub(super) fn push(&mut self, _event: SessionEvent) {}
    pub(super) fn pop(&mut self) -> Option<SessionEvent> {
        None
    }
}
