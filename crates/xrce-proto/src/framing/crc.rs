//! CRC-16/ARC, the checksum eProsima's stream framing puts after every serial frame's payload.
//!
//! Parameters: reflected polynomial 0xA001 (0x8005 normal form), initial value 0, no final xor; the check
//! value over `b"123456789"` is `0xBB3D`. The arithmetic is the `crc` crate's (its 256-entry table is built
//! at compile time, so updating costs one lookup per byte and nothing at run time to set up).

use crc::{Crc, Digest, CRC_16_ARC};

/// The algorithm with its table; a `static` so digests can borrow it for `'static`.
static ARC: Crc<u16> = Crc::<u16>::new(&CRC_16_ARC);

/// Incremental CRC-16/ARC: feed the bytes in as many pieces as they arrive, then [`finish`](Self::finish).
///
/// The serial decoder uses this to checksum a payload while it unescapes it, without a second pass.
#[derive(Clone)]
pub struct Crc16 {
    digest: Digest<'static, u16>,
}

impl core::fmt::Debug for Crc16 {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("Crc16").field("value", &self.finish()).finish()
    }
}

impl Default for Crc16 {
    fn default() -> Self {
        Self::new()
    }
}

impl Crc16 {
    /// A fresh checksum (initial value 0).
    #[must_use]
    pub const fn new() -> Self {
        Self { digest: ARC.digest() }
    }

    /// Adds one byte.
    pub fn update_byte(&mut self, byte: u8) -> &mut Self {
        self.digest.update(&[byte]);
        self
    }

    /// Adds a run of bytes; calling it on the pieces of a slice gives the same result as on the whole.
    pub fn update(&mut self, bytes: &[u8]) -> &mut Self {
        self.digest.update(bytes);
        self
    }

    /// The checksum of everything added so far (the value is not consumed; more bytes may follow).
    #[must_use]
    pub fn finish(&self) -> u16 {
        self.digest.clone().finalize()
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

    /// Bit-at-a-time reference implementation, to check the crate's table against the hand-written
    /// arithmetic the framing used before.
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
