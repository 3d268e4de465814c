//! 16-bit sequence numbers in serial arithmetic (spec §9.1).

/// A message sequence number. Ordering wraps: `a < b` when `b` is 1..=32767 ahead of `a`, so it is not `Ord`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct SeqNum(pub u16);

impl SeqNum {
    /// Initial value of every "last" counter: the first number used is therefore 0.
    pub const INIT: Self = Self(0xFFFF);

    /// `self < other` in serial arithmetic.
    pub const fn lt(self, other: Self) -> bool {
        let d = other.0.wrapping_sub(self.0);
        d != 0 && d < 0x8000
    }

    /// `self <= other` in serial arithmetic.
    pub const fn le(self, other: Self) -> bool {
        self.0 == other.0 || self.lt(other)
    }

    /// The later of the two.
    pub const fn max(self, other: Self) -> Self {
        if self.lt(other) {
            other
        } else {
            self
        }
    }

    /// `n` numbers later.
    #[must_use]
    pub const fn add(self, n: u16) -> Self {
        Self(self.0.wrapping_add(n))
    }

    /// `n` numbers earlier.
    #[must_use]
    pub const fn sub(self, n: u16) -> Self {
        Self(self.0.wrapping_sub(n))
    }

    /// The next number.
    #[must_use]
    pub const fn next(self) -> Self {
        self.add(1)
    }

    /// How many numbers `later` is ahead of `self` (modulo 2^16: meaningful when `self <= later`).
    pub const fn distance(self, later: Self) -> u16 {
        later.0.wrapping_sub(self.0)
    }

    /// Whether `self` is in `(after, after + depth]`: the window of a stream whose last handled (or
    /// acknowledged) number is `after` and that holds `depth` messages.
    pub const fn in_window(self, after: Self, depth: u16) -> bool {
        let d = after.distance(self);
        d != 0 && d <= depth
    }
}

impl From<u16> for SeqNum {
    fn from(v: u16) -> Self {
        Self(v)
    }
}

impl From<SeqNum> for u16 {
    fn from(s: SeqNum) -> Self {
        s.0
    }
}

#[cfg(test)]
mod tests {
    use super::SeqNum;

    #[test]
    fn serial_arithmetic_wraps() {
        let s = SeqNum;
        assert!(s(0xFFFF).lt(s(0)));
        assert!(s(10).lt(s(11)) && !s(11).lt(s(10)));
        assert!(s(0xFFF0).lt(s(0x0010)));
        assert!(!s(5).lt(s(5)) && s(5).le(s(5)));
        assert_eq!(s(0xFFFF).max(s(3)), s(3));
        assert_eq!(s(0xFFFF).add(2), s(1));
        assert_eq!(s(1).sub(2), s(0xFFFF));
        assert_eq!(s(0xFFFE).distance(s(2)), 4);
        assert!(s(2).in_window(s(0xFFFE), 4) && !s(3).in_window(s(0xFFFE), 4) && !s(0xFFFE).in_window(s(0xFFFE), 4));
    }
}
