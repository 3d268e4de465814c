//! Time for the engine: signed microseconds from an epoch the caller chooses, so the same code runs on a
//! microcontroller tick counter and under `std::time` (the agent converts).

use core::ops::{Add, Sub};

/// A point in time, in microseconds since the caller's epoch.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Default)]
pub struct Instant(pub i64);

/// A span of time in microseconds (never negative when produced by the engine).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Default)]
pub struct Duration(pub i64);

impl Instant {
    /// Later than any time: what an unarmed timer holds (a timer is a plain `Instant`, 8 bytes rather than an
    /// `Option`'s 16, which matters in a microcontroller's session).
    pub const NEVER: Self = Self(i64::MAX);

    /// `Some(self)` unless it is [`NEVER`](Self::NEVER).
    pub const fn armed(self) -> Option<Self> {
        if self.0 == i64::MAX {
            None
        } else {
            Some(self)
        }
    }

    /// From nanoseconds since the epoch (truncated to the microsecond).
    // Inlined: a call to `div_trunc_pow1000` directly, no wrapper (firmware size).
    #[inline(always)]
    pub const fn from_nanos(ns: i64) -> Self {
        Self(div_trunc_pow1000(ns, 1))
    }

    /// Nanoseconds since the epoch (wrapping past ±292 years: no check on a microcontroller's hot path).
    pub const fn as_nanos(self) -> i64 {
        self.0.wrapping_mul(1000)
    }

    /// Time from `earlier` to `self`, zero if `earlier` is later.
    pub const fn since(self, earlier: Self) -> Duration {
        let d = self.0.saturating_sub(earlier.0);
        Duration(if d < 0 { 0 } else { d })
    }
}

impl Duration {
    /// Zero.
    pub const ZERO: Self = Self(0);

    /// From milliseconds.
    pub const fn from_millis(ms: i64) -> Self {
        Self(ms.saturating_mul(1000))
    }

    /// From nanoseconds (truncated to the microsecond).
    pub const fn from_nanos(ns: i64) -> Self {
        Self(div_trunc_pow1000(ns, 1))
    }

    /// Nanoseconds (wrapping past ±292 years).
    pub const fn as_nanos(self) -> i64 {
        self.0.wrapping_mul(1000)
    }

    /// `self × 2^n`, saturating.
    #[must_use]
    pub const fn shl_saturating(self, n: u8) -> Self {
        // Past 30 doublings any span of a reliable stream is over its cap; shifting further only overflows.
        Self(self.0.saturating_mul(1 << if n > 30 { 30 } else { n }))
    }
}

/// `(n.div_euclid(1000^k), n.rem_euclid(1000^k))` for `k` in `0..=3`, with 32-bit divisions only.
///
/// A Cortex-M divides 32-bit numbers in one instruction but an `i64` by a constant through compiler-builtins'
/// 64-bit division (~1 KB of code); the engine only ever divides times by powers of 1000. The quotient is
/// exact: `k` long divisions by 1000 in 16-bit digits (each partial dividend is below `1000 × 2^16 < 2^32`),
/// and `⌊⌊n/a⌋/b⌋ = ⌊n/(ab)⌋`. A negative `n` is divided as `!n = -n - 1 ≥ 0`: `⌊n/d⌋ = !⌊!n/d⌋`.
#[inline(never)]
pub const fn div_floor_pow1000(n: i64, k: u32) -> (i64, u32) {
    let neg = n < 0;
    let q = (if neg { !n } else { n }) as u64;
    // In two 32-bit halves: no 64-bit shifts, which a Cortex-M4 makes library calls (firmware size).
    let (mut hi, mut lo) = ((q >> 32) as u32, q as u32);
    let mut rem = 0u32;
    let mut scale = 1u32;
    let mut round = 0;
    while round < k && round < 3 {
        let (a, r) = div1000_digit(0, hi >> 16);
        let (b, r) = div1000_digit(r, hi & 0xFFFF);
        let (c, r) = div1000_digit(r, lo >> 16);
        let (d, r) = div1000_digit(r, lo & 0xFFFF);
        hi = a << 16 | b;
        lo = c << 16 | d;
        rem += r * scale;
        scale *= 1000;
        round += 1;
    }
    let q = ((hi as u64) << 32 | lo as u64) as i64;
    if neg {
        (!q, scale - 1 - rem)
    } else {
        (q, rem)
    }
}

/// One step of a long division by 1000 in 16-bit digits: `(r × 2^16 + digit) / 1000` and its remainder, for
/// `r < 1000` and `digit < 2^16` (so below `2^26`, and the quotient below `2^16`).
#[inline(always)]
const fn div1000_digit(r: u32, digit: u32) -> (u32, u32) {
    let part = r << 16 | digit;
    (part / 1000, part % 1000)
}

/// `n / 1000^k` rounded toward zero (Rust's and C's `/`), `k` in `0..=3`, without a 64-bit division.
pub const fn div_trunc_pow1000(n: i64, k: u32) -> i64 {
    let (q, r) = div_floor_pow1000(n, k);
    if n < 0 && r != 0 {
        q + 1
    } else {
        q
    }
}

impl Add<Duration> for Instant {
    type Output = Self;
    #[inline(never)]
    fn add(self, d: Duration) -> Self {
        Self(self.0.saturating_add(d.0))
    }
}

impl Sub<Duration> for Instant {
    type Output = Self;
    fn sub(self, d: Duration) -> Self {
        Self(self.0.saturating_sub(d.0))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check(n: i64) {
        let mut d = 1i64;
        for k in 0..=3 {
            assert_eq!(div_floor_pow1000(n, k), (n.div_euclid(d), n.rem_euclid(d) as u32), "{n} / 1000^{k}");
            assert_eq!(div_trunc_pow1000(n, k), n / d, "{n} / 1000^{k}");
            d *= 1000;
        }
    }

    #[test]
    fn division_by_powers_of_1000_is_exact() {
        let edges: [i64; 11] =
            [0, 1, 999, 1000, 1001, 999_999, 1_000_000, 999_999_999, 1_000_000_000, 1 << 32, (1 << 48) - 1];
        for e in edges {
            for n in [e, -e, e.wrapping_add(1), e.wrapping_sub(1), -e - 1] {
                check(n);
            }
        }
        for n in [i64::MIN, i64::MIN + 1, i64::MAX, i64::MAX - 1, i64::MAX - 999] {
            check(n);
        }
        // A deterministic spread over the whole range and around multiples of 1000.
        let mut x: u64 = 0x9E37_79B9_7F4A_7C15;
        for _ in 0..100_000 {
            x = x.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
            let n = x as i64;
            check(n);
            check(n >> (x % 63));
            check((n >> 20) * 1000);
        }
    }
}
