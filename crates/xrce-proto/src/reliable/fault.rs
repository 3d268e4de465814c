//! A seeded pseudo-random source for fault injection: tests and tools that drop, duplicate and delay
//! packets with it see the same faults on every run (a test instrument kept in the library, as smoltcp does).

/// xorshift64*: small, fast, and good enough to pick which packets suffer.
#[derive(Debug, Clone)]
pub struct FaultRng(u64);

impl FaultRng {
    /// A source seeded with `seed` (0 is replaced: xorshift never leaves it).
    pub const fn new(seed: u64) -> Self {
        Self(if seed == 0 { 0x9E37_79B9_7F4A_7C15 } else { seed })
    }

    /// The next 64 pseudo-random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }

    /// True `percent` times in a hundred.
    pub fn chance(&mut self, percent: u64) -> bool {
        self.next_u64() % 100 < percent
    }
}

#[cfg(test)]
mod tests {
    use super::FaultRng;

    #[test]
    fn same_seed_same_faults() {
        let (mut a, mut b) = (FaultRng::new(42), FaultRng::new(42));
        assert!((0..100).all(|_| a.next_u64() == b.next_u64()));
        let hits = (0..10_000).filter(|_| a.chance(20)).count();
        assert!((1500..2500).contains(&hits), "{hits}");
        assert_ne!(FaultRng::new(0).next_u64(), 0);
    }
}
