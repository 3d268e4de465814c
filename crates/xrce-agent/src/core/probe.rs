//! Tail-loss probe timers of the agent's reliable output streams, and the agent's clock as the shared
//! engine counts it.
//!
//! The probe algorithm is the engine's ([`xrce_proto::reliable::Probe`], the client runs the same one): once
//! an acknowledgement has given a round trip, a HEARTBEAT goes `max(2 × smallest round trip, PROBE_FLOOR)`
//! after the stream last sent or made progress, doubling for every probe left unanswered, up to the period
//! (eProsima's agent only has its 200 ms `heartbeat_period`). Without a round-trip sample the stream is left
//! to the periodic HEARTBEAT.
//!
//! The timers of all streams live in one heap ([`ProbeTimers`]); an entry whose stream was re-armed since is
//! stale and skipped when it comes due, so the heap holds at most one live entry per stream; stale entries are
//! purged when they outnumber the clients four to one (a re-arm needs an unanswered probe first, so at
//! most one per stream per 2 ms).

use std::cmp::Reverse;
use std::collections::BinaryHeap;
use std::sync::OnceLock;
use std::time::{Duration, Instant};

use xrce_proto::reliable;
use xrce_proto::ClientKey;

/// Shortest probe timeout, however short the round trip.
pub const PROBE_FLOOR: Duration = Duration::from_micros(reliable::PROBE_FLOOR.0.unsigned_abs());

/// The engine's epoch: the first time the agent asked for it. Earlier instants are negative.
fn epoch() -> Instant {
    static EPOCH: OnceLock<Instant> = OnceLock::new();
    *EPOCH.get_or_init(Instant::now)
}

/// `t` as the engine counts time (microseconds from [`epoch`]).
pub(crate) fn to_engine(t: Instant) -> reliable::Instant {
    let e = epoch();
    let micros = |d: Duration| i64::try_from(d.as_micros()).unwrap_or(i64::MAX);
    match t.checked_duration_since(e) {
        Some(after) => reliable::Instant(micros(after)),
        None => reliable::Instant(-micros(e.saturating_duration_since(t))),
    }
}

/// The engine's `t` as an `Instant` (exactly the one [`to_engine`] mapped to it).
pub(crate) fn from_engine(t: reliable::Instant) -> Instant {
    let e = epoch();
    let d = Duration::from_micros(t.0.unsigned_abs());
    let shifted = if t.0 >= 0 { e.checked_add(d) } else { e.checked_sub(d) };
    shifted.unwrap_or(e)
}

/// `d` for the engine (microseconds).
pub(crate) fn engine_duration(d: Duration) -> reliable::Duration {
    reliable::Duration(i64::try_from(d.as_micros()).unwrap_or(i64::MAX))
}

/// The probe timers of every stream, earliest first.
#[derive(Debug, Default)]
pub struct ProbeTimers {
    heap: BinaryHeap<Reverse<(Instant, ClientKey, u8)>>,
}

impl ProbeTimers {
    /// Capacity kept by an empty heap (a burst of sessions must not pin its peak).
    const KEEP: usize = 1024;

    /// Schedules the probe of `stream` of client `key` at `due`.
    pub fn push(&mut self, due: Instant, key: ClientKey, stream: u8) {
        self.heap.push(Reverse((due, key, stream)));
    }

    /// The earliest scheduled instant.
    pub fn next_due(&self) -> Option<Instant> {
        self.heap.peek().map(|Reverse((due, _, _))| *due)
    }

    /// Takes the earliest entry if it is due at `now`.
    pub fn pop_due(&mut self, now: Instant) -> Option<(Instant, ClientKey, u8)> {
        if self.next_due()? > now {
            return None;
        }
        let entry = self.heap.pop().map(|Reverse(e)| e);
        if self.heap.is_empty() && self.heap.capacity() > Self::KEEP {
            self.heap.shrink_to(Self::KEEP);
        }
        entry
    }

    /// Keeps only the entries `live` accepts (drops stale ones).
    pub fn retain(&mut self, mut live: impl FnMut(Instant, ClientKey, u8) -> bool) {
        self.heap.retain(|Reverse((due, key, stream))| live(*due, *key, *stream));
    }

    /// Entries held (live and stale).
    pub fn len(&self) -> usize {
        self.heap.len()
    }

    /// Whether no entry is held.
    pub fn is_empty(&self) -> bool {
        self.heap.is_empty()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const MS: Duration = Duration::from_millis(1);

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
        assert_eq!(PROBE_FLOOR, 2 * MS);
    }

    #[test]
    fn timers_come_out_earliest_first_when_due() {
        let t0 = Instant::now();
        let mut t = ProbeTimers::default();
        t.push(t0 + 3 * MS, ClientKey([0, 0, 0, 1]), 0x80);
        t.push(t0 + MS, ClientKey([0, 0, 0, 2]), 0x80);
        assert_eq!(t.next_due(), Some(t0 + MS));
        assert_eq!(t.pop_due(t0), None);
        assert_eq!(t.pop_due(t0 + 5 * MS).map(|e| e.1), Some(ClientKey([0, 0, 0, 2])));
        assert_eq!(t.pop_due(t0 + 5 * MS).map(|e| e.1), Some(ClientKey([0, 0, 0, 1])));
        assert!(t.is_empty());
        for i in 0..10u8 {
            t.push(t0 + u32::from(i) * MS, ClientKey([0, 0, 0, i]), 0x80);
        }
        t.retain(|_, key, _| key.0[3] % 2 == 0);
        assert_eq!(t.len(), 5);
    }
}
