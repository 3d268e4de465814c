//! Round-trip estimate and tail-loss probes of a reliable output stream.
//!
//! When the last messages of a burst, or the ACKNACK for them, are lost, nothing tells the sender until its
//! next HEARTBEAT, which eProsima sends every 100 ms (client) or 200 ms (agent). Here, once an
//! acknowledgement has given a round trip, a HEARTBEAT goes `max(2 × smallest round trip, PROBE_FLOOR)`
//! after the stream last sent or made progress, doubling for every probe left unanswered, up to the period;
//! before any sample, the period. The smallest sample, not the average, is the base: a sample that waited for
//! a lost ACKNACK would stretch an average exactly when probes matter.
//!
//! The timer is lazy: sending or progress only moves `last_activity`; when the armed timer fires early it is
//! pushed to a timeout after that activity instead of probing. So a steady flow re-arms nothing.

use super::{Duration, Instant};

/// Shortest probe timeout, however short the round trip.
pub const PROBE_FLOOR: Duration = Duration::from_millis(2);
/// Most doublings of the probe timeout (the period caps it long before).
const MAX_BACKOFF: u8 = 16;

/// Round-trip estimate: smoothed (RFC 6298 gain 1/8) and smallest, in microseconds, 0 until sampled.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Rtt {
    srtt_us: u32,
    min_us: u32,
}

impl Rtt {
    /// No sample yet.
    pub const ZERO: Self = Self { srtt_us: 0, min_us: 0 };

    /// Folds in a sample.
    pub fn sample(&mut self, rtt: Duration) {
        let r = u32::try_from(rtt.0).unwrap_or(u32::MAX).max(1);
        self.srtt_us = if self.srtt_us == 0 { r } else { (self.srtt_us - self.srtt_us / 8 + r / 8).max(1) };
        self.min_us = if self.min_us == 0 { r } else { self.min_us.min(r) };
    }

    /// The smoothed round trip, once sampled.
    pub fn smoothed(&self) -> Option<Duration> {
        (self.srtt_us > 0).then_some(Duration(i64::from(self.srtt_us)))
    }

    /// The smallest round trip sampled.
    pub fn min(&self) -> Option<Duration> {
        (self.min_us > 0).then_some(Duration(i64::from(self.min_us)))
    }
}

/// Tail-loss probe state of one reliable output stream.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Probe {
    /// Round-trip estimate the timeout derives from.
    pub rtt: Rtt,
    /// When the armed probe fires ([`Instant::NEVER`]: unarmed).
    pub(super) due: Instant,
    /// The last send or progress: a probe goes a timeout after it.
    last_activity: Instant,
    /// Probes sent since the stream last made progress.
    backoff: u8,
}

impl Default for Probe {
    fn default() -> Self {
        Self::new()
    }
}

impl Probe {
    /// Unarmed, no estimate.
    pub const fn new() -> Self {
        Self { rtt: Rtt::ZERO, due: Instant::NEVER, last_activity: Instant(0), backoff: 0 }
    }

    /// A message left (first transmission).
    pub fn on_sent(&mut self, now: Instant) {
        self.last_activity = now;
    }

    /// The stream made progress (an ACKNACK released messages): ends a back-off. A probe armed further away
    /// than the timeout now (backed off, or armed before any round trip was known) is disarmed: the caller
    /// re-arms it, sooner.
    pub fn on_progress(&mut self, now: Instant, period: Duration) {
        self.backoff = 0;
        self.last_activity = now;
        if self.due > now + self.timeout(period) {
            self.due = Instant::NEVER;
        }
    }

    /// When the armed probe fires, if armed.
    pub const fn due(&self) -> Option<Instant> {
        self.due.armed()
    }

    /// Forgets the armed probe (nothing left to probe for).
    pub fn disarm(&mut self) {
        self.due = Instant::NEVER;
        self.backoff = 0;
    }

    /// The probe timeout now: `max(2 × min RTT, PROBE_FLOOR)` doubled per unanswered probe, at most
    /// `period`; `period` before any sample.
    // Out of line: inlined at some callers (firmware size).
    #[inline(never)]
    pub fn timeout(&self, period: Duration) -> Duration {
        let Some(rtt) = self.rtt.min() else { return period };
        Duration(rtt.0.saturating_mul(2).max(PROBE_FLOOR.0)).shl_saturating(self.backoff.min(MAX_BACKOFF)).min(period)
    }

    /// Arms the probe unless armed; the instant to schedule, if it was armed now.
    // Inlined at its three callers: out of line it cost a Cortex-M4 70 more bytes.
    #[inline(always)]
    pub fn arm(&mut self, now: Instant, period: Duration) -> Option<Instant> {
        if self.due != Instant::NEVER {
            return None;
        }
        self.due = now + self.timeout(period);
        self.due.armed()
    }

    /// A timer set for `due` came due. `None` if it is stale (re-armed since); otherwise whether to send a
    /// HEARTBEAT (a timeout has passed since the last activity) and the instant to schedule next, if the
    /// stream still has messages in flight (`unacked`).
    pub fn fire(
        &mut self,
        due: Instant,
        unacked: bool,
        now: Instant,
        period: Duration,
    ) -> Option<(bool, Option<Instant>)> {
        if self.due != due || due == Instant::NEVER {
            return None;
        }
        self.due = Instant::NEVER;
        if !unacked {
            self.backoff = 0;
            return Some((false, None));
        }
        let quiet_until = self.last_activity + self.timeout(period);
        if quiet_until > now {
            // Sent or acknowledged since it was armed: wait a whole timeout from then.
            self.due = quiet_until;
            return Some((false, quiet_until.armed()));
        }
        self.backoff = self.backoff.saturating_add(1).min(MAX_BACKOFF);
        Some((true, self.arm(now, period)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const PERIOD: Duration = Duration::from_millis(200);
    const fn ms(n: i64) -> Duration {
        Duration::from_millis(n)
    }
    const T0: Instant = Instant(1_000_000);

    #[test]
    fn timeout_is_twice_the_smallest_round_trip_then_backs_off_to_the_period() {
        let mut p = Probe::default();
        assert_eq!(p.timeout(PERIOD), PERIOD, "no sample yet");
        p.rtt.sample(ms(5));
        p.rtt.sample(ms(150));
        assert_eq!(p.rtt.min(), Some(ms(5)));
        assert!(p.rtt.smoothed().is_some_and(|s| s > ms(5)));
        assert_eq!(p.timeout(PERIOD), ms(10));
        p.on_sent(T0);
        let mut due = p.arm(T0, PERIOD).unwrap_or(T0);
        assert_eq!(due, T0 + ms(10));
        assert_eq!(p.arm(T0, PERIOD), None, "armed once");
        let mut gaps = [0i64; 6];
        for gap in &mut gaps {
            let (beat, next) = p.fire(due, true, due, PERIOD).unwrap_or_default();
            assert!(beat);
            let next = next.unwrap_or(due);
            *gap = next.since(due).0 / 1000;
            due = next;
        }
        assert_eq!(gaps, [20, 40, 80, 160, 200, 200]);
        // Progress well before the backed-off probe: it is disarmed, the next one is 10 ms away again.
        let at = Instant(due.0 - 100_000);
        p.on_progress(at, PERIOD);
        assert!(p.fire(due, true, due, PERIOD).is_none(), "stale");
        let again = p.arm(at, PERIOD).unwrap_or(at);
        assert_eq!(again.since(at), ms(10));
        // A send 4 ms later: the timer fires without a probe and moves a timeout after that send.
        p.on_sent(at + ms(4));
        assert_eq!(p.fire(again, true, again, PERIOD), Some((false, Some(at + ms(14)))));
        // Nothing in flight: disarmed.
        assert_eq!(p.fire(at + ms(14), false, at + ms(14), PERIOD), Some((false, None)));
        assert_eq!(p.due(), None);
    }

    #[test]
    fn never_under_the_floor_and_never_overflowing() {
        let mut p = Probe::default();
        p.rtt.sample(Duration(1));
        assert_eq!(p.timeout(PERIOD), PROBE_FLOOR);
        let mut now = T0;
        p.arm(now, PERIOD);
        for _ in 0..100 {
            let due = p.due().unwrap_or(now);
            now = due;
            let (_, next) = p.fire(due, true, now, PERIOD).unwrap_or_default();
            assert!(next.is_some_and(|n| n > now && n.since(now) <= PERIOD));
        }
        assert_eq!(p.timeout(PERIOD), PERIOD);
    }
}
