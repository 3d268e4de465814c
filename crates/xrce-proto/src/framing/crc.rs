//! CRC-16/ARC, the checksum eProsima's stream framing puts after every serial frame's payload.
//!
//! Parameters: reflected polynomial 0xA001 (0x8005 normal form), initial value 0, no final xor; the check
//! value over `b"123456789"` is `0xBB3D`. A 256-entry table is built at compile time, so updating costs
//! one lookup per byte and nothing at run time to set up.

/// Lookup table for the reflected polynomial 0xA001, computed by the compiler.
const TABLE: [u16; 256] = build_table();

/// Builds the byte-at-a-time table; runs only at compile time.
#[allow(
    clippy::indexing_slicing,
    reason = "const evaluation: `i < 256` bounds every index and an overrun would fail the build, not panic"
)]
const fn build_table() -> [u16; 256] {
    let mut table = [0u16; 256];
    let mut i = 0;
    while i < 256 {
        // `i < 256`, so the cast is lossless.
        let mut crc = i as u16;
        let mut bit = 0;
        while bit < 8 {
            crc = if crc & 1 != 0 { (crc >> 1) ^ 0xA001 } else { crc >> 1 };
            bit += 1;
        }
        table[i] = crc;
        i += 1;
    }
    table
}

/// Incremental CRC-16/ARC: feed the bytes in as many pieces as they arrive, then [`finish`](Self::finish).
///
/// The serial decoder uses this to checksum a payload while it unescapes it, without a second pass.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Crc16 {
    state: u16,
}

impl Crc16 {
    /// A fresh checksum (initial value 0).
    #[must_use]
    pub const fn new() -> Self {
        Self { state: 0 }
    }

    /// Adds one byte.
    pub fn update_byte(&mut self, byte: u8) -> &mut Self {
        let index = usize::from((self.state as u8) ^ byte);
        // `index` is a `u8`, so the lookup always succeeds.
        let entry = TABLE.get(index).copied().unwrap_or(0);
        self.state = (self.state >> 8) ^ entry;
        self
    }

    /// Adds a run of bytes; calling it on the pieces of a slice gives the same result as on the whole.
    pub fn update(&mut self, bytes: &[u8]) -> &mut Self {
        for &byte in bytes {
            self.update_byte(byte);
        }
        self
    }

    /// The checksum of everything added so far (the value is not consumed; more bytes may follow).
    #[must_use]
    pub const fn finish(&self) -> u16 {
        self.state
    }
}

/// One-shot CRC-16/ARC of `bytes`.
#[must_use]
pub fn crc16(bytes: &[u8]) -> u16 {
    Crc16::new().update(bytes).finish()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Bit-at-a-time reference implementation, to check the table.
    fn bitwise(bytes: &[u8]) -> u16 {
        let mut crc = 0u16;
        for &b in bytes {
            crc ^= u16::from(b);
            for _ in 0..8 {
                crc = if crc & 1 != 0 { (crc >> 1) ^ 0xA001 } else { crc >> 1 };
            }
        }
        crc
    }

    #[test]
    fn check_value() {
        assert_eq!(crc16(b"123456789"), 0xBB3D);
        assert_eq!(Crc16::new().update(b"123456789").finish(), 0xBB3D);
    }

    #[test]
    fn empty_is_zero() {
        assert_eq!(crc16(&[]), 0);
        assert_eq!(Crc16::default().finish(), 0);
    }

    #[test]
    fn incremental_equals_one_shot() {
        let data = b"The quick brown fox jumps over the lazy dog \x7e\x7d\x00\xff";
        for split in 0..=data.len() {
            let (a, b) = data.split_at(split);
            let mut crc = Crc16::new();
            crc.update(a);
            crc.update(b);
            assert_eq!(crc.finish(), crc16(data));
        }
    }

    #[test]
    fn table_matches_bitwise() {
        let mut data = [0u8; 300];
        for (i, b) in data.iter_mut().enumerate() {
            *b = (i as u8).wrapping_mul(37).wrapping_add(11);
        }
        for len in 0..data.len() {
            assert_eq!(crc16(&data[..len]), bitwise(&data[..len]));
        }
    }

    #[test]
    fn xrce_payloads() {
        // CREATE_CLIENT as in the serial test vector.
        let create_client = [
            0x80, 0x00, 0x00, 0x00, 0x00, 0x01, 0x10, 0x00, 0x58, 0x52, 0x43, 0x45, 0x01, 0x00, 0x01, 0x0F, 0xAA, 0xBB,
            0xCC, 0xDD, 0x81, 0x00, 0xFC, 0x01,
        ];
        assert_eq!(crc16(&create_client), 0x8F3E);
        assert_eq!(crc16(&[0x81, 0x00, 0x00, 0x00, 0x7E, 0x7D, 0x20, 0x00]), 0x5C58);
    }
}
