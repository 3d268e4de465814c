//! The DDS-XRCE wire format exactly as eProsima Micro XRCE-DDS (client 2.4/3.x, agent 2.x/3.x) puts it on the wire.
//!
//! * [`cdr`]: XCDR v1 reader and writer over byte slices, both byte orders, alignment from a chosen origin.
//! * [`header`], [`submessage`], [`message`]: message header, every submessage, a message builder and a
//!   submessage iterator.
//! * [`types`], [`object`]: common types and the object representations (XML, reference, binary) of the 8 kinds.
//! * [`framing`]: HDLC-like serial framing with CRC-16, TCP length framing, CAN FD framing.
//! * `serde` feature: CDR serialization of user topic types.
//!
//! Decoding borrows from the input and never panics; encoding writes into a caller's buffer and reports the size
//! it needed when the buffer is too small. No heap, no `unsafe`.
#![no_std]
#![forbid(unsafe_code)]
#![cfg_attr(not(test), deny(clippy::unwrap_used, clippy::expect_used, clippy::indexing_slicing, clippy::panic))]

#[cfg(feature = "psk")]
pub mod auth;
pub mod bytes;
pub mod cdr;
pub mod framing;
pub mod header;
pub mod layout;
pub mod message;
pub mod object;
pub mod reliable;
pub mod submessage;
pub mod types;
pub mod view;

pub use cdr::Endianness;
pub use header::MessageHeader;
pub use message::{MessageBuilder, RawSubmessage, Submessages};
pub use object::{EntityVariant, ObjectVariant, Representation};
pub use submessage::{Submessage, SubmessageHeader};
pub use types::*;
#[cfg(feature = "serde")]
pub mod serde_cdr;
