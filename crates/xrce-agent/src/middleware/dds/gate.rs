//! The first-contact gate's timer: while a write is held at a gate, a small thread wakes the core every
//! [`GATE_RECHECK`] so that it retries (see the parent module's documentation); it idles otherwise. And the
//! best-effort samples a gate holds ([`HeldSamples`]).

use std::collections::VecDeque;
use std::sync::{Arc, Condvar, Mutex, PoisonError};
use std::time::Instant;

use super::{GATE_RECHECK, HELD_AT_GATE, HELD_AT_GATE_BYTES};
use crate::middleware::Waker;

/// What the gate timer thread does: wake the core every [`GATE_RECHECK`] until `until`, then once more.
#[derive(Default)]
struct TimerState {
    until: Option<Instant>,
    waker: Option<Waker>,
    stop: bool,
}

/// Wakes the core while a write is held at a first-contact gate: the gate opens on a DDS event (a match)
/// or a deadline, neither of which reaches the core otherwise. Its thread starts with the first held
/// write and sleeps on a condition variable when no write is held.
#[derive(Default)]
pub(super) struct GateTimer {
    shared: Arc<(Mutex<TimerState>, Condvar)>,
    thread: Option<std::thread::JoinHandle<()>>,
}

impl GateTimer {
    /// Keeps waking `waker` until `until` (the latest deadline asked for wins).
    pub(super) fn arm(&mut self, until: Instant, waker: Option<&Waker>) {
        let Some(waker) = waker else { return }; // no shell to wake: the core retries on its next turn
        {
            let (m, c) = &*self.shared;
            let mut st = m.lock().unwrap_or_else(PoisonError::into_inner);
            st.until = Some(st.until.map_or(until, |u| u.max(until)));
            st.waker = Some(Arc::clone(waker));
            c.notify_one();
        }
        if self.thread.is_none() {
            let shared = Arc::clone(&self.shared);
            match std::thread::Builder::new().name("xrce-dds-gate".into()).spawn(move || Self::run(&shared)) {
                Ok(t) => self.thread = Some(t),
                Err(e) => tracing::warn!("no gate timer thread ({e}): held writes wait for the client's next message"),
            }
        }
    }

    /// No write is held any more.
    pub(super) fn disarm(&self) {
        let (m, _) = &*self.shared;
        m.lock().unwrap_or_else(PoisonError::into_inner).until = None;
    }

    fn run(shared: &(Mutex<TimerState>, Condvar)) {
        let (m, c) = shared;
        let mut st = m.lock().unwrap_or_else(PoisonError::into_inner);
        loop {
            if st.stop {
                return;
            }
            let Some(until) = st.until else {
                st = c.wait(st).unwrap_or_else(PoisonError::into_inner);
                continue;
            };
            st = c.wait_timeout(st, GATE_RECHECK).unwrap_or_else(PoisonError::into_inner).0;
            if Instant::now() >= until {
                st.until = None; // one last wake-up: the held write goes through on the deadline
            }
            if let Some(w) = st.waker.clone() {
                drop(st);
                w();
                st = m.lock().unwrap_or_else(PoisonError::into_inner);
            }
        }
    }
}

impl Drop for GateTimer {
    fn drop(&mut self) {
        let (m, c) = &*self.shared;
        m.lock().unwrap_or_else(PoisonError::into_inner).stop = true;
        c.notify_one();
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

/// Best-effort samples written to a datawriter at its first-contact gate (the core holds only reliable
/// ones), kept until the gate opens and then replayed at twice the rate they were written: a burst of
/// everything at once would overflow the history of a keep-last reader (a ROS node's depth 10 lost 5 to 7
/// of 18 samples so released), and twice the rate catches up with live writes after as long again as the
/// gate held. At most [`HELD_AT_GATE`] samples or [`HELD_AT_GATE_BYTES`], oldest dropped first.
#[derive(Debug, Default)]
pub(super) struct HeldSamples {
    samples: VecDeque<(Instant, Vec<u8>)>,
    bytes: usize,
    /// When the first held sample was written and when the gate opened.
    replay: Option<(Instant, Instant)>,
    dropped: u64,
}

impl HeldSamples {
    /// Samples held.
    pub(super) fn len(&self) -> usize {
        self.samples.len()
    }

    /// Keeps a sample written at `now` (also once the gate is open, while older ones wait: order is kept).
    pub(super) fn push(&mut self, now: Instant, data: &[u8]) {
        while !self.samples.is_empty()
            && (self.samples.len() >= HELD_AT_GATE || self.bytes + data.len() > HELD_AT_GATE_BYTES)
        {
            if let Some((_, old)) = self.samples.pop_front() {
                self.bytes -= old.len();
                self.dropped += 1;
            }
        }
        self.bytes += data.len();
        self.samples.push_back((now, data.to_vec()));
    }

    /// The gate is open: the next sample due by `now`, if any (the first call starts the replay).
    pub(super) fn pop_due(&mut self, now: Instant) -> Option<Vec<u8>> {
        let first = self.samples.front()?.0;
        let (origin, opened) = *self.replay.get_or_insert((first, now));
        let (written, _) = self.samples.front()?;
        let due = opened + written.saturating_duration_since(origin) / 2;
        if due > now {
            return None;
        }
        let (_, data) = self.samples.pop_front()?;
        self.bytes -= data.len();
        Some(data)
    }

    /// When the next held sample is due, once the replay started.
    pub(super) fn next_due(&self) -> Option<Instant> {
        let (origin, opened) = self.replay?;
        let (written, _) = self.samples.front()?;
        Some(opened + written.saturating_duration_since(origin) / 2)
    }

    pub(super) fn is_empty(&self) -> bool {
        self.samples.is_empty()
    }

    /// Samples dropped because the bounds were reached.
    pub(super) fn dropped(&self) -> u64 {
        self.dropped
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Duration;

    #[test]
    fn held_samples_replay_in_order_at_twice_the_rate() {
        let t0 = Instant::now();
        let ms = Duration::from_millis;
        let mut h = HeldSamples::default();
        for i in 0..10u8 {
            h.push(t0 + ms(u64::from(i) * 10), &[i]);
        }
        assert_eq!(h.next_due(), None, "no replay before the gate opens");
        let open = t0 + ms(200);
        assert_eq!(h.pop_due(open), Some(vec![0]));
        assert_eq!(h.pop_due(open), None, "the second one is due 5 ms later");
        assert_eq!(h.next_due(), Some(open + ms(5)));
        let got: Vec<u8> = std::iter::from_fn(|| h.pop_due(open + ms(20))).flatten().collect();
        assert_eq!(got, vec![1, 2, 3, 4]);
        // A live write while older ones wait goes behind them.
        h.push(open + ms(21), &[99]);
        let rest: Vec<u8> = std::iter::from_fn(|| h.pop_due(open + ms(1000))).flatten().collect();
        assert_eq!(rest, vec![5, 6, 7, 8, 9, 99]);
        assert!(h.is_empty());
    }

    #[test]
    fn held_samples_are_bounded_oldest_first() {
        let t0 = Instant::now();
        let mut h = HeldSamples::default();
        for i in 0..(HELD_AT_GATE + 3) {
            h.push(t0, &i.to_le_bytes());
        }
        assert_eq!(h.len(), HELD_AT_GATE);
        assert_eq!(h.dropped(), 3);
        assert_eq!(h.pop_due(t0), Some(3usize.to_le_bytes().to_vec()));
        let mut big = HeldSamples::default();
        big.push(t0, &vec![0; HELD_AT_GATE_BYTES - 10]);
        big.push(t0, &[1; 20]);
        assert_eq!(big.len(), 1, "the byte bound dropped the older sample");
        assert_eq!(big.pop_due(t0), Some(vec![1; 20]));
    }
}
