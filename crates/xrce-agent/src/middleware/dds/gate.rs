//! The first-contact gate's timer: while a write is held at a gate, a small thread wakes the core every
//! [`GATE_RECHECK`] so that it retries (see the parent module's documentation); it idles otherwise.

use std::sync::{Arc, Condvar, Mutex, PoisonError};
use std::time::Instant;

use super::GATE_RECHECK;
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
