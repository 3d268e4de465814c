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
    pub const fn from_nanos(ns: i64) -> Self {
        Self(ns / 1000)
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
        Self(ns / 1000)
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

impl Add<Duration> for Instant {
    type Output = Self;
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
