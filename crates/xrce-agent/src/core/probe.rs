//! Tail-loss probes for the agent's reliable output streams.
//!
//! When the last messages of a burst, or the client's ACKNACK for them, are lost, nothing tells the agent
//! until its next HEARTBEAT, which eProsima's agent sends every 200 ms (`heartbeat_period`). Here each
//! stream with messages in flight also arms a *probe*: once an acknowledgement has given a round trip,
//! a HEARTBEAT goes `max(2 × smallest round trip, PROBE_FLOOR)` after the stream last sent or made
//! progress, doubling for every probe left unanswered, up to the period. Without a round-trip sample the probe
//! is left to the periodic HEARTBEAT, as before. The smallest sample, not an average, is the base: a sample that
//! waited for a lost ACKNACK would stretch an average exactly when probes matter.
//!
//! Round trips are timed on one message at a time, never on a retransmitted one (Karn's rule). The timers
//! of a client's streams are part of its connection's timer ([`Connection::poll_timeout`](super::connection::Connection::poll_timeout)).

use std::time::{Duration, Instant};

use super::stream::seq_lt;

/// Shortest probe timeout, however short the round trip.
pub const PROBE_FLOOR: Duration = Duration::from_millis(2);
/// Most doublings of the probe timeout (the period caps it long before).
const MAX_BACKOFF: u8 = 16;

/// Probe state of one reliable output stream.
#[derive(Debug, Clone, Default)]
pub struct Probe {
    /// The message being timed and when it left.
    timed: Option<(u16, Instant)>,
    /// Smallest round trip sampled.
    min_rtt: Option<Duration>,
    /// When the armed probe fires.
    due: Option<Instant>,
    /// The last send or progress: a probe goes a timeout after it.
    last_activity: Option<Instant>,
    /// Probes sent since the stream last made progress.
    backoff: u8,
}

impl Probe {
    /// Message `seq` left for the first time.
    pub fn on_sent(&mut self, seq: u16, now: Instant) {
        if self.timed.is_none() {
            self.timed = Some((seq, now));
        }
        self.last_activity = Some(now);
    }

    /// Message `seq` was retransmitted: its acknowledgement no longer times a round trip.
    pub fn on_resent(&mut self, seq: u16) {
        if self.timed.is_some_and(|(s, _)| s == seq) {
            self.timed = None;
        }
    }

    /// The stream's first unacknowledged message is now `first`: samples the round trip if the timed
    /// message is acknowledged and ends a back-off. A probe armed further away than the timeout now (backed
    /// off, or armed before any round trip was known) is disarmed: the caller re-arms it, sooner.
    pub fn on_progress(&mut self, first: u16, now: Instant, period: Duration) {
        if let Some((s, at)) = self.timed {
            if seq_lt(s, first) {
                let rtt = now.saturating_duration_since(at);
                self.min_rtt = Some(self.min_rtt.map_or(rtt, |m| m.min(rtt)));
                self.timed = None;
            }
        }
        self.backoff = 0;
        self.last_activity = Some(now);
        let limit = now.checked_add(self.timeout(period)).unwrap_or(now);
        if self.due.is_some_and(|d| d > limit) {
            self.due = None;
        }
    }

    /// When the armed probe fires, if armed.
    pub fn due(&self) -> Option<Instant> {
        self.due
    }

    /// The smallest round trip sampled so far.
    #[cfg(test)]
    pub fn min_rtt(&self) -> Option<Duration> {
        self.min_rtt
    }

    /// The probe timeout now: `max(2 × min RTT, PROBE_FLOOR)` doubled per unanswered probe, at most
    /// `period`; `period` before any sample.
    pub fn timeout(&self, period: Duration) -> Duration {
        let Some(rtt) = self.min_rtt else { return period };
        let base = rtt.saturating_mul(2).max(PROBE_FLOOR);
        base.saturating_mul(1 << self.backoff.min(MAX_BACKOFF)).min(period)
    }

    /// Arms the probe unless it is armed, or no round trip is known yet (the periodic HEARTBEAT covers
    /// that case, and idle sessions then hold no timer); the instant to schedule, if it was armed now.
    pub fn arm(&mut self, now: Instant, period: Duration) -> Option<Instant> {
        if self.due.is_some() || self.min_rtt.is_none() {
            return None;
        }
        let due = now.checked_add(self.timeout(period)).unwrap_or(now);
        self.due = Some(due);
        Some(due)
    }

    /// A timer entry for `due` came due. `None` if it is stale; otherwise whether to send a HEARTBEAT (a
    /// timeout has passed since the last send or progress) and the instant to schedule next, if the stream
    /// still has messages in flight.
    pub fn fire(
        &mut self,
        due: Instant,
        unacked: bool,
        now: Instant,
        period: Duration,
    ) -> Option<(bool, Option<Instant>)> {
        if self.due != Some(due) {
            return None;
        }
        self.due = None;
        if !unacked {
            self.backoff = 0;
            return Some((false, None));
        }
        let quiet_until = self.last_activity.and_then(|t| t.checked_add(self.timeout(period))).unwrap_or(now);
        if quiet_until > now {
            // Sent or acknowledged since it was armed: wait a whole timeout from then.
            self.due = Some(quiet_until);
            return Some((false, Some(quiet_until)));
        }
        self.backoff = self.backoff.saturating_add(1).min(MAX_BACKOFF);
        Some((true, self.arm(now, period)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const PERIOD: Duration = Duration::from_millis(200);
    const MS: Duration = Duration::from_millis(1);

    #[test]
    fn no_probe_until_a_round_trip_is_known_then_twice_the_smallest_one() {
        let t0 = Instant::now();
        let mut p = Probe::default();
        p.on_sent(0, t0);
        assert_eq!(p.arm(t0, PERIOD), None, "the periodic HEARTBEAT covers it");
        p.on_sent(1, t0 + MS);
        p.on_progress(1, t0 + 5 * MS, PERIOD);
        assert_eq!(p.min_rtt(), Some(5 * MS));
        assert_eq!(p.timeout(PERIOD), 10 * MS);
        assert_eq!(p.arm(t0 + 5 * MS, PERIOD), Some(t0 + 15 * MS));
        assert_eq!(p.arm(t0 + 5 * MS, PERIOD), None, "armed once");
        // A later, longer sample (it waited for a lost ACKNACK) does not stretch the timeout.
        p.on_sent(1, t0 + 6 * MS);
        p.on_progress(2, t0 + 150 * MS, PERIOD);
        assert_eq!(p.timeout(PERIOD), 10 * MS);
        // A retransmitted message gives no sample.
        let mut q = Probe::default();
        q.on_sent(0, t0);
        q.on_resent(0);
        q.on_progress(1, t0 + MS, PERIOD);
        assert_eq!(q.min_rtt(), None);
        // Never under the floor.
        q.on_sent(1, t0);
        q.on_progress(2, t0, PERIOD);
        assert_eq!(q.timeout(PERIOD), PROBE_FLOOR);
    }

    #[test]
    fn unanswered_probes_back_off_to_the_period_and_progress_starts_over() {
        let t0 = Instant::now();
        let mut p = Probe::default();
        p.on_sent(0, t0);
        p.on_progress(1, t0 + 5 * MS, PERIOD);
        p.on_sent(1, t0 + 5 * MS);
        let mut due = p.arm(t0 + 5 * MS, PERIOD).unwrap();
        assert_eq!(due, t0 + 15 * MS);
        let mut gaps = Vec::new();
        for _ in 0..6 {
            let (beat, next) = p.fire(due, true, due, PERIOD).unwrap();
            assert!(beat);
            let next = next.unwrap();
            gaps.push((next - due).as_millis());
            due = next;
        }
        assert_eq!(gaps, [20, 40, 80, 160, 200, 200]);
        // Progress 100 ms before the backed-off probe: it goes stale, the next one is 10 ms away again.
        let at = due - 100 * MS;
        p.on_progress(2, at, PERIOD);
        assert!(p.fire(due, true, due, PERIOD).is_none(), "stale");
        let again = p.arm(at, PERIOD).unwrap();
        assert_eq!(again - at, 10 * MS);
        // A send 4 ms later: the entry fires, sends nothing, re-arms a timeout after that send.
        p.on_sent(2, at + 4 * MS);
        let (beat, next) = p.fire(again, true, again, PERIOD).unwrap();
        assert!(!beat);
        assert_eq!(next, Some(at + 14 * MS));
        // Nothing in flight: disarmed.
        assert_eq!(p.fire(at + 14 * MS, false, at + 14 * MS, PERIOD), Some((false, None)));
    }

    #[test]
    fn a_backed_off_probe_is_brought_forward_by_progress_but_not_a_steady_one() {
        let t0 = Instant::now();
        let mut p = Probe::default();
        p.on_sent(0, t0);
        p.on_progress(1, t0 + MS, PERIOD);
        assert_eq!(p.arm(t0 + MS, PERIOD), Some(t0 + 3 * MS), "2 × 1 ms");
        // Steady flow: a probe due within the timeout stays armed.
        p.on_progress(2, t0 + 2 * MS, PERIOD);
        assert_eq!(p.arm(t0 + 2 * MS, PERIOD), None);
    }
}
