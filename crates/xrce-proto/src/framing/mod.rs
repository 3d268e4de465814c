//! Byte-stream and datagram framings that carry XRCE messages.
//!
//! * [`crc`]: CRC-16/ARC, the checksum of the serial framing.
//! * [`serial`]: HDLC-like serial framing (flag, addresses, length, escaped payload, CRC-16) of eProsima's
//!   serial transport and of custom transports with framing.
//! * [`tcp`]: 2-byte little-endian length prefix of eProsima's TCP transport.
//! * [`can`]: one message per CAN FD frame, its length in the first data byte, as eProsima's CAN transport.
//!
//! Each encoder writes into a caller's buffer and reports the size it needed when that is too small; each
//! decoder borrows, so nothing allocates. Stream decoders take input in chunks of any size and resynchronise
//! after errors.

pub mod can;
pub mod crc;
pub mod serial;
pub mod tcp;

pub use can::CanError;
pub use crc::{crc16, Crc16};
pub use serial::{encode_frame, AddressFilter, FrameDecoder, FrameError, SerialStats};
pub use tcp::{TcpDecoder, TcpError, TcpEvent, TcpStats};
