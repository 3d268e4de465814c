//! A connection's timers as one small table (quinn-proto's `timer.rs`): one optional deadline per kind,
//! so [`Connection::poll_timeout`](super::connection::Connection::poll_timeout) is a fold over a few fields
//! and a turn asks which kinds expired. Deadlines that belong to a stream or a read task (tail-loss probes,
//! paced reads) stay with their owner, which already keeps them per instance.

use std::time::Instant;

/// What a connection's timer is for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Timer {
    /// The periodic turn: HEARTBEATs of streams with messages in flight, back-pressure release of a dead or
    /// stalled reader.
    Heartbeat,
    /// The liveness turn ([`liveness`](super::liveness)): probes, then removal of a silent client.
    Liveness,
}

/// One deadline per [`Timer`].
#[derive(Debug, Default, Clone, Copy, PartialEq, Eq)]
pub(crate) struct TimerTable {
    heartbeat: Option<Instant>,
    liveness: Option<Instant>,
}

impl TimerTable {
    fn slot(&mut self, timer: Timer) -> &mut Option<Instant> {
        match timer {
            Timer::Heartbeat => &mut self.heartbeat,
            Timer::Liveness => &mut self.liveness,
        }
    }

    /// Arms `timer` at `at`, replacing its deadline.
    pub(crate) fn set(&mut self, timer: Timer, at: Instant) {
        *self.slot(timer) = Some(at);
    }

    /// Arms `timer` at `at` unless it is already armed.
    pub(crate) fn set_if_unset(&mut self, timer: Timer, at: Instant) {
        self.slot(timer).get_or_insert(at);
    }

    /// Sets or clears `timer`.
    pub(crate) fn set_opt(&mut self, timer: Timer, at: Option<Instant>) {
        *self.slot(timer) = at;
    }

    /// The deadline of `timer`.
    pub(crate) fn get(&self, timer: Timer) -> Option<Instant> {
        match timer {
            Timer::Heartbeat => self.heartbeat,
            Timer::Liveness => self.liveness,
        }
    }

    /// Disarms `timer`.
    pub(crate) fn stop(&mut self, timer: Timer) {
        *self.slot(timer) = None;
    }

    /// Whether `timer` is armed and due at `now`.
    pub(crate) fn is_expired(&self, timer: Timer, now: Instant) -> bool {
        self.get(timer).is_some_and(|due| due <= now)
    }

    /// Disarms `timer` if it is due at `now`; whether it was.
    pub(crate) fn take_expired(&mut self, timer: Timer, now: Instant) -> bool {
        let expired = self.is_expired(timer, now);
        if expired {
            self.stop(timer);
        }
        expired
    }

    /// The earliest deadline armed.
    pub(crate) fn next_timeout(&self) -> Option<Instant> {
        [self.heartbeat, self.liveness].into_iter().flatten().min()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Duration;

    #[test]
    fn the_table_keeps_one_deadline_per_kind_and_folds_to_the_earliest() {
        let t0 = Instant::now();
        let mut table = TimerTable::default();
        assert_eq!(table.next_timeout(), None);
        table.set(Timer::Liveness, t0 + Duration::from_secs(30));
        table.set_if_unset(Timer::Heartbeat, t0 + Duration::from_millis(200));
        table.set_if_unset(Timer::Heartbeat, t0 + Duration::from_secs(9));
        assert_eq!(table.get(Timer::Heartbeat), Some(t0 + Duration::from_millis(200)), "armed once");
        assert_eq!(table.next_timeout(), Some(t0 + Duration::from_millis(200)));
        assert!(!table.take_expired(Timer::Heartbeat, t0));
        assert!(table.take_expired(Timer::Heartbeat, t0 + Duration::from_millis(200)));
        assert_eq!(table.get(Timer::Heartbeat), None, "an expired timer taken is disarmed");
        assert_eq!(table.next_timeout(), Some(t0 + Duration::from_secs(30)));
        table.set_opt(Timer::Liveness, None);
        assert_eq!(table.next_timeout(), None);
    }
}
