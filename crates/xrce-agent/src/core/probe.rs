//! Tail-loss probes of the agent's reliable output streams, and the agent's clock as the shared engine
//! counts it.
//!
//! The probe algorithm is the engine's ([`xrce_proto::reliable::Probe`], the client runs the same one): once
//! an acknowledgement has given a round trip, a HEARTBEAT goes `max(2 × smallest round trip, PROBE_FLOOR)`
//! after the stream last sent or made progress, doubling for every probe left unanswered, up to the period
//! (eProsima's agent only has its 200 ms `heartbeat_period`). Without a round-trip sample the stream is left
//! to the periodic HEARTBEAT.
//!
//! The timers of a client's streams are part of its connection's timer
//! ([`Connection::poll_timeout`](super::connection::Connection::poll_timeout)).

use std::sync::OnceLock;
use std::time::{Duration, Instant};

use xrce_proto::reliable;

/// The engine's epoch: the first time the agent asked for it. Earlier instants are negative.
fn epoch() -> Instant {
    static EPOCH: OnceLock<Instant> = OnceLock::new();
    *EPOCH.get_or_init(Instant::now)
}

/// `t` counted from [`epoch`] in the unit `count` gives (negative before it), saturating.
fn since_epoch(t: Instant, count: fn(Duration) -> u128) -> i64 {
    let e = epoch();
    let units = |d: Duration| i64::try_from(count(d)).unwrap_or(i64::MAX);
    match t.checked_duration_since(e) {
        Some(after) => units(after),
        None => -units(e.saturating_duration_since(t)),
    }
}

/// The instant `units` (of the unit `unit` makes a `Duration` of) from [`epoch`]: the inverse of
/// [`since_epoch`].
fn at_epoch_offset(units: i64, unit: fn(u64) -> Duration) -> Instant {
    let e = epoch();
    let d = unit(units.unsigned_abs());
    let shifted = if units >= 0 { e.checked_add(d) } else { e.checked_sub(d) };
    shifted.unwrap_or(e)
}

/// `t` as the engine counts time (microseconds from [`epoch`]).
pub(crate) fn to_engine(t: Instant) -> reliable::Instant {
    reliable::Instant(since_epoch(t, |d| d.as_micros()))
}

/// The engine's `t` as an `Instant` (exactly the one [`to_engine`] mapped to it).
pub(crate) fn from_engine(t: reliable::Instant) -> Instant {
    at_epoch_offset(t.0, Duration::from_micros)
}

/// An instant in the core's timer queue: nanoseconds from [`epoch`] (exact, as `Instant` counts on Linux;
/// ±292 years), in 8 bytes where an `Instant` takes 16: the queue holds an entry per client.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub(crate) struct TimerTick(i64);

impl TimerTick {
    /// `t` as a tick.
    pub(crate) fn of(t: Instant) -> Self {
        Self(since_epoch(t, |d| d.as_nanos()))
    }

    /// The instant it stands for.
    pub(crate) fn instant(self) -> Instant {
        at_epoch_offset(self.0, Duration::from_nanos)
    }

    /// Whether it is `queued`, the instant a client's entry was queued at.
    pub(crate) fn matches(self, queued: Option<Instant>) -> bool {
        queued.is_some_and(|q| Self::of(q) == self)
    }
}

/// `d` for the engine (microseconds).
pub(crate) fn engine_duration(d: Duration) -> reliable::Duration {
    reliable::Duration(i64::try_from(d.as_micros()).unwrap_or(i64::MAX))
}

#[cfg(test)]
mod tests {
    use super::*;

    const MS: Duration = Duration::from_millis(1);

    #[test]
    fn a_timer_tick_is_its_instant_exactly_before_and_after_the_epoch() {
        let now = Instant::now();
        for t in [now, now + Duration::from_nanos(1), now + 3_600 * 1_000 * MS, now - Duration::from_nanos(7)] {
            assert_eq!(TimerTick::of(t).instant(), t);
            assert!(TimerTick::of(t).matches(Some(t)));
        }
        assert!(TimerTick::of(now) < TimerTick::of(now + Duration::from_nanos(1)), "ordered as the instants");
        assert!(!TimerTick::of(now).matches(Some(now + Duration::from_nanos(1))));
        assert!(!TimerTick::of(now).matches(None));
    }

    #[test]
    fn engine_time_round_trips_on_both_sides_of_the_epoch() {
        let e = epoch();
        for t in [e, e + 3 * MS, e + Duration::from_nanos(1500)] {
            let back = from_engine(to_engine(t));
            assert!(back <= t && t - back < Duration::from_micros(1), "{t:?} -> {back:?}");
            assert_eq!(from_engine(to_engine(back)), back);
        }
        if let Some(before) = e.checked_sub(5 * MS) {
            assert_eq!(to_engine(before), reliable::Instant(-5000));
            assert_eq!(from_engine(reliable::Instant(-5000)), before);
        }
        assert_eq!(engine_duration(5 * MS), reliable::Duration::from_millis(5));
    }
}
