//! A deterministic lossy link: drop, duplicate, reorder, delay and corrupt datagrams, driven by a seed.
//!
//! [`LossyLink::send`] is a pure function of the datagram, the time and the link's state (its seeded PRNG): it
//! returns the copies to deliver and when. It never touches a socket or a clock, so it can sit between two
//! sans-IO cores in a test (feed it what one core's `poll_transmit` produced, hand what [`LinkQueue`] says is
//! due to the other core's `handle_input`) as well as inside the UDP proxy (`xrce-bench lossy-proxy`).
//!
//! Every datagram consumes the same number of random draws whatever the probabilities, so two links with the
//! same seed but, say, a different corruption rate drop the very same datagrams.

use std::cmp::Reverse;
use std::collections::BinaryHeap;

/// One millisecond in the link's time unit (nanoseconds).
pub const MILLIS: i64 = 1_000_000;

/// What the link does to datagrams. Probabilities are in `0.0..=1.0`; times in nanoseconds.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LinkConfig {
    /// Probability that a datagram is lost.
    pub drop: f64,
    /// Probability that a datagram that is not lost is delivered twice.
    pub duplicate: f64,
    /// Probability that a copy takes a detour of `reorder_min..=reorder_max` extra delay, so later datagrams
    /// overtake it.
    pub reorder: f64,
    /// Smallest detour of a reordered copy.
    pub reorder_min: i64,
    /// Largest detour of a reordered copy.
    pub reorder_max: i64,
    /// Delay every copy takes.
    pub delay: i64,
    /// Extra delay drawn uniformly in `0..=jitter` for every copy (jitter alone can also reorder).
    pub jitter: i64,
    /// Probability that a datagram has one bit flipped (the same bit in every copy).
    pub corrupt: f64,
    /// Seed of the PRNG.
    pub seed: u64,
}

impl Default for LinkConfig {
    /// A perfect link: no loss, no delay.
    fn default() -> Self {
        Self {
            drop: 0.0,
            duplicate: 0.0,
            reorder: 0.0,
            reorder_min: MILLIS,
            reorder_max: 20 * MILLIS,
            delay: 0,
            jitter: 0,
            corrupt: 0.0,
            seed: 1,
        }
    }
}

/// What happened on a link so far.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize)]
pub struct LinkStats {
    /// Datagrams handed to the link.
    pub sent: u64,
    /// Datagrams lost.
    pub dropped: u64,
    /// Datagrams delivered twice.
    pub duplicated: u64,
    /// Copies that took a detour.
    pub reordered: u64,
    /// Datagrams with a flipped bit.
    pub corrupted: u64,
    /// Copies the link will deliver (sent − dropped + duplicated).
    pub delivered: u64,
}

/// A copy of a datagram to deliver at time `at`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Delivery {
    /// When to deliver it (same clock as the `now` given to [`LossyLink::send`]).
    pub at: i64,
    /// The bytes (possibly corrupted).
    pub data: Vec<u8>,
}

/// SplitMix64: small, fast, good from any seed (0 included).
#[derive(Debug, Clone)]
pub struct Rng(u64);

impl Rng {
    /// A generator seeded with `seed`.
    pub const fn new(seed: u64) -> Self {
        Self(seed)
    }

    /// The next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in `[0, 1)`.
    pub fn unit(&mut self) -> f64 {
        // 53 random bits: exactly representable.
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Uniform in `lo..=hi` (`lo` when `hi <= lo`).
    pub fn range(&mut self, lo: i64, hi: i64) -> i64 {
        let r = self.next_u64();
        if hi <= lo {
            return lo;
        }
        let span = hi.abs_diff(lo).saturating_add(1);
        lo.saturating_add_unsigned(r % span)
    }
}

/// One direction of a lossy link.
#[derive(Debug, Clone)]
pub struct LossyLink {
    cfg: LinkConfig,
    rng: Rng,
    stats: LinkStats,
}

impl LossyLink {
    /// A link behaving as `cfg` says.
    pub const fn new(cfg: LinkConfig) -> Self {
        Self {
            rng: Rng::new(cfg.seed),
            cfg,
            stats: LinkStats { sent: 0, dropped: 0, duplicated: 0, reordered: 0, corrupted: 0, delivered: 0 },
        }
    }

    /// The configuration.
    pub const fn config(&self) -> &LinkConfig {
        &self.cfg
    }

    /// Counters so far.
    pub const fn stats(&self) -> LinkStats {
        self.stats
    }

    /// Hands `datagram` to the link at time `now`: the copies to deliver (none, one or two) and when.
    pub fn send(&mut self, datagram: &[u8], now: i64) -> Vec<Delivery> {
        let mut out = Vec::with_capacity(2);
        self.send_into(datagram, now, &mut out);
        out
    }

    /// As [`send`](Self::send), appending to `out`.
    pub fn send_into(&mut self, datagram: &[u8], now: i64, out: &mut impl Extend<Delivery>) {
        let c = self.cfg;
        // Fixed number of draws per datagram, whatever the outcome.
        let drop = self.rng.unit() < c.drop;
        let dup = self.rng.unit() < c.duplicate;
        let corrupt = self.rng.unit() < c.corrupt;
        let flip = self.rng.next_u64();
        let mut copies = [(false, 0i64, 0i64); 2];
        for copy in &mut copies {
            let reorder = self.rng.unit() < c.reorder;
            let detour = self.rng.range(c.reorder_min, c.reorder_max);
            let jitter = self.rng.range(0, c.jitter);
            *copy = (reorder, detour, jitter);
        }

        self.stats.sent += 1;
        if drop {
            self.stats.dropped += 1;
            return;
        }
        let mut data = datagram.to_vec();
        if corrupt && !data.is_empty() {
            self.stats.corrupted += 1;
            let len = data.len() as u64;
            let byte = usize::try_from(flip % len).unwrap_or(0);
            let bit = (flip / len) % 8;
            if let Some(b) = data.get_mut(byte) {
                *b ^= 1 << bit;
            }
        }
        let n = if dup {
            self.stats.duplicated += 1;
            2
        } else {
            1
        };
        for &(reorder, detour, jitter) in copies.iter().take(n) {
            let mut at = now.saturating_add(c.delay).saturating_add(jitter);
            if reorder {
                self.stats.reordered += 1;
                at = at.saturating_add(detour);
            }
            self.stats.delivered += 1;
            out.extend(core::iter::once(Delivery { at, data: data.clone() }));
        }
    }
}

/// Deliveries waiting for their time: earliest first, ties in the order they were pushed.
#[derive(Debug, Default)]
pub struct LinkQueue {
    heap: BinaryHeap<Reverse<(i64, u64, Vec<u8>)>>,
    seq: u64,
}

impl LinkQueue {
    /// An empty queue.
    pub fn new() -> Self {
        Self::default()
    }

    /// Queues deliveries.
    pub fn push(&mut self, deliveries: impl IntoIterator<Item = Delivery>) {
        for d in deliveries {
            self.heap.push(Reverse((d.at, self.seq, d.data)));
            self.seq += 1;
        }
    }

    /// The next delivery due at or before `now`, if any.
    pub fn pop_due(&mut self, now: i64) -> Option<Vec<u8>> {
        if self.heap.peek().is_some_and(|Reverse((at, _, _))| *at <= now) {
            self.heap.pop().map(|Reverse((_, _, d))| d)
        } else {
            None
        }
    }

    /// When the next delivery is due.
    pub fn next_at(&self) -> Option<i64> {
        self.heap.peek().map(|Reverse((at, _, _))| *at)
    }

    /// Deliveries waiting.
    pub fn len(&self) -> usize {
        self.heap.len()
    }

    /// Whether nothing waits.
    pub fn is_empty(&self) -> bool {
        self.heap.is_empty()
    }
}

/// A link and its queue: `send` datagrams in, `pop_due` them out.
#[derive(Debug)]
pub struct Pipe {
    /// The lossy link.
    pub link: LossyLink,
    /// What it will deliver.
    pub queue: LinkQueue,
}

impl Pipe {
    /// A pipe through a link configured as `cfg`.
    pub fn new(cfg: LinkConfig) -> Self {
        Self { link: LossyLink::new(cfg), queue: LinkQueue::new() }
    }

    /// Sends a datagram at `now`.
    pub fn send(&mut self, datagram: &[u8], now: i64) {
        let d = self.link.send(datagram, now);
        self.queue.push(d);
    }

    /// The next datagram due at `now`.
    pub fn pop_due(&mut self, now: i64) -> Option<Vec<u8>> {
        self.queue.pop_due(now)
    }
}
