//! Rate limit for the warnings about bad input. A peer that sends garbage gets its first warning at once,
//! then at most one per [`DROP_LOG_INTERVAL`], which counts what was held back since; so a flood cannot
//! fill the log (2,000 garbage datagrams gave 2,000 WARN lines before) and the counts still tell its size.

use foldhash::{HashMap, HashMapExt};
use std::hash::Hash;
use std::time::{Duration, Instant};

/// At most one warning per peer in this interval.
pub const DROP_LOG_INTERVAL: Duration = Duration::from_secs(1);

/// Peers remembered; past it the one logged longest ago is forgotten (it may get one warning more).
pub const DROP_LOG_PEERS: usize = 256;

/// When each peer was last warned about, and how many warnings were held back since.
#[derive(Debug)]
pub struct DropLog<E> {
    peers: HashMap<E, (Instant, u64)>,
}

impl<E> Default for DropLog<E> {
    fn default() -> Self {
        Self { peers: HashMap::new() }
    }
}

impl<E: Copy + Eq + Hash> DropLog<E> {
    /// Whether to warn about bad input from `peer` at `now`: `Some(held back since the last warning)` when
    /// so, `None` (and one more held back) when it was warned about less than [`DROP_LOG_INTERVAL`] ago.
    pub fn admit(&mut self, peer: E, now: Instant) -> Option<u64> {
        if let Some((at, held)) = self.peers.get_mut(&peer) {
            if now.saturating_duration_since(*at) < DROP_LOG_INTERVAL {
                *held = held.saturating_add(1);
                return None;
            }
            let n = *held;
            (*at, *held) = (now, 0);
            return Some(n);
        }
        if self.peers.len() >= DROP_LOG_PEERS {
            if let Some(stalest) = self.peers.iter().min_by_key(|(_, (at, _))| *at).map(|(p, _)| *p) {
                self.peers.remove(&stalest);
            }
        }
        self.peers.insert(peer, (now, 0));
        Some(0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_warning_per_interval_with_the_count_held_back() {
        let t0 = Instant::now();
        let mut log = DropLog::default();
        let admitted: Vec<u64> =
            (0..2000u32).filter_map(|i| log.admit(7u16, t0 + Duration::from_micros(u64::from(i) * 100))).collect();
        assert_eq!(admitted, vec![0], "2,000 drops in 0.2 s: one warning");
        assert_eq!(log.admit(7, t0 + DROP_LOG_INTERVAL), Some(1999));
        assert_eq!(log.admit(8, t0), Some(0), "another peer has its own budget");
    }

    #[test]
    fn the_table_is_bounded() {
        let t0 = Instant::now();
        let mut log = DropLog::default();
        for p in 0..(DROP_LOG_PEERS as u32 + 10) {
            assert_eq!(log.admit(p, t0 + Duration::from_millis(u64::from(p))), Some(0));
        }
        assert_eq!(log.peers.len(), DROP_LOG_PEERS);
    }
}
