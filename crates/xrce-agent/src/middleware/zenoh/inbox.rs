//! A reader's bounded queue: Zenoh's threads push samples, requests and replies into it and wake the
//! transport shell; the core takes them on its own thread ([`super::Zenoh`]'s `poll_sample`).

use std::collections::VecDeque;
use std::sync::{Arc, Mutex, MutexGuard, PoisonError};

use crate::middleware::{Sample, Waker};

/// Samples a reader keeps for the core; past this the oldest goes (Zenoh has no back-pressure towards a
/// remote publisher; 1,024 samples are a second of a fast topic).
pub const INBOX_CAPACITY: usize = 1_024;

/// The waker every inbox calls, installed once the shell gives it ([`crate::middleware::Middleware::set_waker`]).
#[derive(Clone, Default)]
pub struct WakerSlot(Arc<Mutex<Option<Waker>>>);

impl WakerSlot {
    /// Installs `waker`.
    pub fn set(&self, waker: Waker) {
        *self.0.lock().unwrap_or_else(PoisonError::into_inner) = Some(waker);
    }

    fn wake(&self) {
        let waker = self.0.lock().unwrap_or_else(PoisonError::into_inner).clone();
        if let Some(w) = waker {
            w();
        }
    }
}

#[derive(Default)]
struct State {
    samples: VecDeque<Sample>,
    dropped: u64,
}

/// One reader's queue.
#[derive(Clone)]
pub struct Inbox {
    state: Arc<Mutex<State>>,
    waker: WakerSlot,
}

impl Inbox {
    /// An empty queue that wakes through `waker`.
    pub fn new(waker: WakerSlot) -> Self {
        Self { state: Arc::default(), waker }
    }

    fn lock(&self) -> MutexGuard<'_, State> {
        // Poisoning only means a panic elsewhere; the queue stays consistent.
        self.state.lock().unwrap_or_else(PoisonError::into_inner)
    }

    /// Queues `sample` (from Zenoh's threads), dropping the oldest when full; wakes the shell when the
    /// queue was empty (it will take everything queued meanwhile).
    pub fn push(&self, sample: Sample) {
        let was_empty = {
            let mut st = self.lock();
            if st.samples.len() >= INBOX_CAPACITY {
                st.samples.pop_front();
                st.dropped += 1;
            }
            st.samples.push_back(sample);
            st.samples.len() == 1
        };
        if was_empty {
            self.waker.wake();
        }
    }

    /// Lends the oldest sample to `visit`; removes it when taken. `None`: empty.
    pub fn visit_front(&self, visit: impl FnOnce(&Sample) -> bool) -> Option<bool> {
        let mut st = self.lock();
        let taken = visit(st.samples.front()?);
        if taken {
            st.samples.pop_front();
        }
        Some(taken)
    }

    /// Samples dropped because the core did not take them in time.
    pub fn dropped(&self) -> u64 {
        self.lock().dropped
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::atomic::{AtomicUsize, Ordering};

    #[test]
    fn wakes_once_per_empty_to_non_empty_and_drops_the_oldest_when_full() {
        let wakes = Arc::new(AtomicUsize::new(0));
        let slot = WakerSlot::default();
        let counter = Arc::clone(&wakes);
        slot.set(Arc::new(move || {
            counter.fetch_add(1, Ordering::Relaxed);
        }));
        let inbox = Inbox::new(slot);
        for i in 0..=INBOX_CAPACITY {
            inbox.push(Sample::Data(vec![(i % 256) as u8]));
        }
        assert_eq!(wakes.load(Ordering::Relaxed), 1);
        assert_eq!(inbox.dropped(), 1);
        assert_eq!(inbox.visit_front(|s| *s == Sample::Data(vec![1])), Some(true));
        assert_eq!(inbox.visit_front(|_| false), Some(false));
    }
}
