//! CAN FD framing of eProsima's CAN transport: one XRCE message per CAN FD frame, `data[0]` holding the
//! message length and `data[1..]` the message, so a message is at most 63 bytes (the session MTU must be
//! set accordingly). Frames use 29-bit extended identifiers.
//!
//! CAN FD only has the data lengths 0..=8, 12, 16, 20, 24, 32, 48 and 64; a controller pads a frame up to the
//! next one, which is why the message length travels in the first data byte. [`padded_len`], [`dlc`] and
//! [`dlc_to_len`] are there for drivers that fill the controller registers themselves.

use core::fmt;

/// Largest CAN FD data field.
pub const MAX_FRAME_LEN: usize = 64;
/// Largest XRCE message per frame: the data field minus the length byte.
pub const MAX_MESSAGE_LEN: usize = MAX_FRAME_LEN - 1;
/// Flag marking a 29-bit extended identifier in a Linux SocketCAN `can_id`.
pub const EFF_FLAG: u32 = 0x8000_0000;
/// The identifier bits of an extended `can_id`.
pub const EFF_MASK: u32 = 0x1FFF_FFFF;

/// Valid CAN FD data lengths, indexed by DLC.
const DLC_LENGTHS: [usize; 16] = [0, 1, 2, 3, 4, 5, 6, 7, 8, 12, 16, 20, 24, 32, 48, 64];

/// Errors of the CAN FD framing.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CanError {
    /// The message exceeds [`MAX_MESSAGE_LEN`].
    MessageTooLarge {
        /// Length of the rejected message.
        len: usize,
    },
    /// The output buffer is too small; `needed` is the frame length (length byte plus message).
    BufferTooSmall {
        /// Bytes the frame needs.
        needed: usize,
    },
    /// A received frame has no data at all, not even the length byte.
    EmptyFrame,
    /// An identifier does not fit 29 bits.
    IdTooLarge {
        /// The rejected identifier.
        id: u32,
    },
    /// A received frame's length byte announces more than the frame carries.
    BadLength {
        /// Length announced by `data[0]`.
        declared: u8,
        /// Message bytes actually present after it (capped at [`MAX_MESSAGE_LEN`]).
        available: usize,
    },
}

impl fmt::Display for CanError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Self::MessageTooLarge { len } => {
                write!(f, "message of {len} bytes exceeds the CAN FD framing maximum of {MAX_MESSAGE_LEN}")
            }
            Self::BufferTooSmall { needed } => write!(f, "output buffer too small: CAN FD frame needs {needed} bytes"),
            Self::EmptyFrame => f.write_str("CAN FD frame without a length byte"),
            Self::IdTooLarge { id } => write!(f, "CAN identifier {id:#x} does not fit 29 bits"),
            Self::BadLength { declared, available } => {
                write!(f, "CAN FD frame announces a {declared}-byte message but carries {available} bytes")
            }
        }
    }
}

impl core::error::Error for CanError {}

/// Writes the length byte and `msg` to the start of `out` (a `[u8; 64]` frame data field does) and returns
/// the frame length, `msg.len() + 1`. Bytes after it are left alone; controllers pad to [`padded_len`].
///
/// # Errors
/// * [`CanError::MessageTooLarge`] if `msg` exceeds [`MAX_MESSAGE_LEN`];
/// * [`CanError::BufferTooSmall`] if `out` is shorter than the frame (nothing is written then).
pub fn encode(msg: &[u8], out: &mut [u8]) -> Result<usize, CanError> {
    let len = u8::try_from(msg.len())
        .ok()
        .filter(|&len| usize::from(len) <= MAX_MESSAGE_LEN)
        .ok_or(CanError::MessageTooLarge { len: msg.len() })?;
    let needed = msg.len() + 1;
    let Some((head, body)) = out.get_mut(..needed).and_then(<[u8]>::split_first_mut) else {
        return Err(CanError::BufferTooSmall { needed });
    };
    *head = len;
    crate::bytes::copy(body, msg);
    Ok(needed)
}

/// Encodes `msg` into a fresh, zero-padded 64-byte data field and returns it with the padded frame length,
/// ready for a driver that wants the DLC-rounded length.
///
/// # Errors
/// [`CanError::MessageTooLarge`] if `msg` exceeds [`MAX_MESSAGE_LEN`].
pub fn encode_padded(msg: &[u8]) -> Result<([u8; MAX_FRAME_LEN], usize), CanError> {
    let mut data = [0u8; MAX_FRAME_LEN];
    let len = encode(msg, &mut data)?;
    // `len <= 64`, so a padded length always exists.
    Ok((data, padded_len(len).unwrap_or(MAX_FRAME_LEN)))
}

/// The message inside a received frame's data field; trailing padding is ignored.
///
/// # Errors
/// * [`CanError::EmptyFrame`] if `data` is empty;
/// * [`CanError::BadLength`] if `data[0]` exceeds the bytes after it or [`MAX_MESSAGE_LEN`].
pub fn decode(data: &[u8]) -> Result<&[u8], CanError> {
    let (&declared, rest) = data.split_first().ok_or(CanError::EmptyFrame)?;
    let available = rest.len().min(MAX_MESSAGE_LEN);
    rest.get(..usize::from(declared))
        .filter(|msg| msg.len() <= MAX_MESSAGE_LEN)
        .ok_or(CanError::BadLength { declared, available })
}

/// One frame as the CAN transports move it between their sockets and the framing: the SocketCAN `can_id` word
/// (identifier and flags) and the data field. Plain data, so in-memory buses and tests need no SocketCAN.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Frame {
    /// SocketCAN identifier word: for XRCE traffic the 29-bit identifier with [`EFF_FLAG`] set.
    pub can_id: u32,
    /// Data length as sent or received, `0..=64`; bytes of `data` past it are padding.
    pub len: u8,
    /// The data field.
    pub data: [u8; MAX_FRAME_LEN],
}

impl Frame {
    /// The frame carrying `msg` under the 29-bit identifier `id` (EFF flag set), of length `msg.len() + 1`;
    /// the stack pads it to a valid CAN FD length.
    ///
    /// # Errors
    /// [`CanError::IdTooLarge`] if `id` does not fit 29 bits, [`CanError::MessageTooLarge`] above
    /// [`MAX_MESSAGE_LEN`].
    pub fn with_message(id: u32, msg: &[u8]) -> Result<Self, CanError> {
        let can_id = extended_id(id).ok_or(CanError::IdTooLarge { id })?;
        let mut data = [0u8; MAX_FRAME_LEN];
        let len = encode(msg, &mut data)?;
        // `encode` returns at most 64.
        Ok(Self { can_id, len: u8::try_from(len).unwrap_or(u8::MAX), data })
    }

    /// A frame from a received `can_id` word and data bytes (at most 64 are kept).
    #[must_use]
    pub fn from_parts(can_id: u32, bytes: &[u8]) -> Self {
        let mut data = [0u8; MAX_FRAME_LEN];
        for (slot, byte) in data.iter_mut().zip(bytes) {
            *slot = *byte;
        }
        let len = bytes.len().min(MAX_FRAME_LEN);
        Self { can_id, len: u8::try_from(len).unwrap_or(u8::MAX), data }
    }

    /// The data bytes the frame carries (`len` of them, at most 64).
    #[must_use]
    pub fn bytes(&self) -> &[u8] {
        self.data.get(..usize::from(self.len)).unwrap_or(&self.data)
    }

    /// The 29-bit identifier, or `None` for a standard (11-bit) frame, which carries no XRCE traffic.
    #[must_use]
    pub const fn id(&self) -> Option<u32> {
        raw_id(self.can_id)
    }

    /// The XRCE message of the frame: `data[0]` bytes after the length byte, read from the whole data
    /// field as eProsima's client and agent read it, whatever the frame length says. eProsima's agent sends
    /// frames one byte short (length = message length), so their last byte travels only as padding: intact
    /// on `vcan`, which moves the whole 64-byte field, and on a controller whenever rounding up to a DLC
    /// length covers it; a strict reader would refuse those frames. Bytes past what the sender wrote are
    /// zero (our frames, the stack's padding), so a short frame yields at worst a corrupt message, which the
    /// XRCE decoding rejects.
    ///
    /// # Errors
    /// [`CanError::BadLength`] if `data[0]` exceeds [`MAX_MESSAGE_LEN`]; [`CanError::EmptyFrame`] if the
    /// frame has no data.
    pub fn message(&self) -> Result<&[u8], CanError> {
        if self.len == 0 {
            return Err(CanError::EmptyFrame);
        }
        decode(&self.data)
    }
}

/// The smallest valid CAN FD data length holding `len` bytes, or `None` above 64.
#[must_use]
pub const fn padded_len(len: usize) -> Option<usize> {
    match dlc(len) {
        Some(code) => dlc_to_len(code),
        None => None,
    }
}

/// The CAN FD data length code of the smallest frame holding `len` bytes, or `None` above 64.
#[must_use]
pub const fn dlc(len: usize) -> Option<u8> {
    match len {
        0..=8 => Some(len as u8),
        9..=12 => Some(9),
        13..=16 => Some(10),
        17..=20 => Some(11),
        21..=24 => Some(12),
        25..=32 => Some(13),
        33..=48 => Some(14),
        49..=64 => Some(15),
        _ => None,
    }
}

/// The data length a CAN FD data length code stands for, or `None` for codes above 15.
#[must_use]
pub const fn dlc_to_len(code: u8) -> Option<usize> {
    if code < 16 {
        // `code < 16` bounds the index; `const` rules out `get`.
        #[allow(clippy::indexing_slicing, reason = "bounded by the check above")]
        Some(DLC_LENGTHS[code as usize])
    } else {
        None
    }
}

/// The SocketCAN `can_id` of the 29-bit identifier `id`: the id with [`EFF_FLAG`] set, or `None` if `id` does
/// not fit 29 bits.
#[must_use]
pub const fn extended_id(id: u32) -> Option<u32> {
    if id & !EFF_MASK == 0 {
        Some(id | EFF_FLAG)
    } else {
        None
    }
}

/// Whether a SocketCAN `can_id` carries a 29-bit extended identifier (only those carry XRCE traffic).
#[must_use]
pub const fn is_extended(can_id: u32) -> bool {
    can_id & EFF_FLAG != 0
}

/// The 29-bit identifier of an extended SocketCAN `can_id`, or `None` for a standard (11-bit) one.
#[must_use]
pub const fn raw_id(can_id: u32) -> Option<u32> {
    if is_extended(can_id) {
        Some(can_id & EFF_MASK)
    } else {
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const CREATE_CLIENT: [u8; 24] = [
        0x80, 0x00, 0x00, 0x00, 0x00, 0x01, 0x10, 0x00, 0x58, 0x52, 0x43, 0x45, 0x01, 0x00, 0x01, 0x0F, 0xAA, 0xBB,
        0xCC, 0xDD, 0x81, 0x00, 0xFC, 0x01,
    ];

    #[test]
    fn create_client_frame() {
        let mut data = [0u8; MAX_FRAME_LEN];
        let len = encode(&CREATE_CLIENT, &mut data).unwrap();
        assert_eq!(len, 25);
        assert_eq!(data[0], 0x18);
        assert_eq!(&data[1..25], &CREATE_CLIENT);
        assert_eq!(padded_len(len), Some(32));
        assert_eq!(decode(&data[..32]), Ok(&CREATE_CLIENT[..]));
        assert_eq!(decode(&data[..25]), Ok(&CREATE_CLIENT[..]));
        let (padded, plen) = encode_padded(&CREATE_CLIENT).unwrap();
        assert_eq!(plen, 32);
        assert_eq!(&padded[..25], &data[..25]);
        assert!(padded[25..].iter().all(|&b| b == 0));
    }

    #[test]
    fn encode_limits() {
        let msg = [0x5Au8; 64];
        let mut data = [0u8; 64];
        assert_eq!(encode(&msg[..63], &mut data), Ok(64));
        assert_eq!(data[0], 63);
        assert_eq!(decode(&data), Ok(&msg[..63]));
        assert_eq!(encode(&msg, &mut data), Err(CanError::MessageTooLarge { len: 64 }));
        assert_eq!(encode_padded(&msg), Err(CanError::MessageTooLarge { len: 64 }));
        static HUGE: [u8; 300] = [0; 300];
        assert_eq!(encode(&HUGE, &mut data), Err(CanError::MessageTooLarge { len: 300 }));
        let mut small = [0u8; 4];
        assert_eq!(encode(&msg[..4], &mut small), Err(CanError::BufferTooSmall { needed: 5 }));
        assert_eq!(small, [0; 4]);
        assert_eq!(encode(&[], &mut small), Ok(1));
        assert_eq!(decode(&small[..1]), Ok(&[][..]));
    }

    #[test]
    fn decode_errors() {
        assert_eq!(decode(&[]), Err(CanError::EmptyFrame));
        assert_eq!(decode(&[3, 1, 2]), Err(CanError::BadLength { declared: 3, available: 2 }));
        let mut long = [0u8; 80];
        long[0] = 70;
        assert_eq!(decode(&long), Err(CanError::BadLength { declared: 70, available: 63 }));
    }

    #[test]
    fn padded_lengths() {
        let expect = [
            (0, 0),
            (1, 1),
            (8, 8),
            (9, 12),
            (12, 12),
            (13, 16),
            (17, 20),
            (21, 24),
            (24, 24),
            (25, 32),
            (33, 48),
            (48, 48),
            (49, 64),
            (64, 64),
        ];
        for (len, padded) in expect {
            assert_eq!(padded_len(len), Some(padded), "{len}");
        }
        assert_eq!(padded_len(65), None);
        for code in 0..16u8 {
            let len = dlc_to_len(code).unwrap();
            assert_eq!(dlc(len), Some(code));
        }
        assert_eq!(dlc_to_len(16), None);
        assert_eq!(dlc(65), None);
    }

    #[test]
    fn extended_ids() {
        assert_eq!(extended_id(0x1FFF_FFFF), Some(0x9FFF_FFFF));
        assert_eq!(extended_id(0x123), Some(0x8000_0123));
        assert_eq!(extended_id(0x2000_0000), None);
        assert!(is_extended(0x8000_0001));
        assert!(!is_extended(0x123));
        assert_eq!(raw_id(0x8000_0123), Some(0x123));
        assert_eq!(raw_id(0x123), None);
        assert_eq!(raw_id(extended_id(0x0ABC_DEF0).unwrap()), Some(0x0ABC_DEF0));
    }

    #[test]
    fn frame_of_the_create_client_vector() {
        // Spec §17.13: extended id = client id | EFF, data = 0x18 + the 24 bytes, length 25.
        let frame = Frame::with_message(0x0000_0123, &CREATE_CLIENT).unwrap();
        assert_eq!(frame.can_id, 0x8000_0123);
        assert_eq!(frame.len, 25);
        assert_eq!(frame.bytes()[0], 0x18);
        assert_eq!(&frame.bytes()[1..], &CREATE_CLIENT);
        assert_eq!(frame.id(), Some(0x123));
        assert_eq!(frame.message(), Ok(&CREATE_CLIENT[..]));
        assert_eq!(Frame::from_parts(frame.can_id, frame.bytes()), frame);
        assert_eq!(Frame::with_message(0x2000_0000, &CREATE_CLIENT), Err(CanError::IdTooLarge { id: 0x2000_0000 }));
        assert_eq!(Frame::with_message(1, &[0; 64]), Err(CanError::MessageTooLarge { len: 64 }));
    }

    #[test]
    fn frame_message_reads_the_whole_field() {
        // eProsima's agent: frame length = message length, the last byte in the padding.
        let mut short = Frame::with_message(7, &CREATE_CLIENT).unwrap();
        short.len = 24;
        assert_eq!(short.message(), Ok(&CREATE_CLIENT[..]));
        let standard = Frame::from_parts(0x123, &[1, 0xAA]);
        assert_eq!(standard.id(), None);
        assert_eq!(standard.message(), Ok(&[0xAA][..]));
        assert_eq!(Frame::from_parts(0x8000_0001, &[]).message(), Err(CanError::EmptyFrame));
        let mut bad = [0u8; 64];
        bad[0] = 64;
        assert_eq!(
            Frame::from_parts(0x8000_0001, &bad).message(),
            Err(CanError::BadLength { declared: 64, available: 63 })
        );
        // More than 64 bytes: the rest is cut.
        assert_eq!(Frame::from_parts(0x8000_0001, &[5u8; 80]).len, 64);
    }

    #[test]
    fn display_is_nonempty() {
        use core::fmt::Write;
        struct Len(usize);
        impl Write for Len {
            fn write_str(&mut self, s: &str) -> fmt::Result {
                self.0 += s.len();
                Ok(())
            }
        }
        for e in [
            CanError::MessageTooLarge { len: 64 },
            CanError::BufferTooSmall { needed: 5 },
            CanError::EmptyFrame,
            CanError::IdTooLarge { id: 0x2000_0000 },
            CanError::BadLength { declared: 3, available: 2 },
        ] {
            let mut l = Len(0);
            write!(l, "{e}").unwrap();
            assert!(l.0 > 20);
        }
    }
}
