//! CRC-16/ARC, the checksum eProsima's stream framing puts after every serial frame's payload.
//!
//! Parameters: reflected polynomial 0xA001 (0x8005 normal form), initial value 0, no final xor; the check
//! value over `b"123456789"` is `0xBB3D`. A 256-entry table built at compile time: one lookup per byte and
//! nothing to set up at run time. The state is the bare `u16` (no reference to an algorithm object), so an
//! update is a few instructions inline (firmware size).

/// The table of CRC-16/ARC, one entry per byte value.
static TABLE: [u16; 256] = table();

#[allow(clippy::indexing_slicing)] // only evaluated at compile time: a bad index fails the build
const fn table() -> [u16; 256] {
    let mut t = [0u16; 256];
    let mut i = 0;
    while i < 256 {
        // `i < 256` fits u16.
        let mut crc = i as u16;
        let mut bit = 0;
        while bit < 8 {
            crc = if crc & 1 != 0 { (crc >> 1) ^ 0xA001 } else { crc >> 1 };
            bit += 1;
        }
        t[i] = crc;
        i += 1;
    }
    t
}

/// Incremental CRC-16/ARC: feed the bytes in as many pieces as they arrive, then [`finish`](Self::finish).
///
/// The serial decoder uses this to checksum a payload while it unescapes it, without a second pass.
#[derive(Clone, Copy, PartialEq, Eq, Default)]
pub struct Crc16 {
    value: u16,
}

impl core::fmt::Debug for Crc16 {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("Crc16").field("value", &self.finish()).finish()
    }
}

impl Crc16 {
    /// A fresh checksum (initial value 0).
    #[must_use]
    pub const fn new() -> Self {
        Self { value: 0 }
    }

    /// Adds one byte.
    pub fn update_byte(&mut self, byte: u8) -> &mut Self {
        let [low, _] = self.value.to_le_bytes();
        // A `u8` index into 256 entries: always there.
        let entry = TABLE.get(usize::from(low ^ byte)).copied().unwrap_or(0);
        self.value = (self.value >> 8) ^ entry;
        self
    }

    /// Adds a run of bytes; calling it on the pieces of a slice gives the same result as on the whole.
    pub fn update(&mut self, bytes: &[u8]) -> &mut Self {
        for &b in bytes {
            self.update_byte(b);
        }
        self
    }

    /// The checksum of everything added so far (the value is not consumed; more bytes may follow).
    #[must_use]
    pub const fn finish(&self) -> u16 {
        self.value
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

    /// The `crc` crate's CRC-16/ARC, a second reference.
    static ARC: crc::Crc<u16> = crc::Crc::<u16>::new(&crc::CRC_16_ARC);

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
            assert_eq!(crc16(&data[..len]), ARC.checksum(&data[..len]));
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
