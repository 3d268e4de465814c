//! What a client reads of the submessages an agent sends, and nothing more.
//!
//! [`Submessage::decode`](super::Submessage::decode) builds every field of every kind; a client acts on a few
//! of them. STATUS_AGENT's agent representation and an INFO's configuration and locators are never read by a
//! session, yet their decoders (representations, property sequences, strings checked as UTF-8, locators) were
//! ~3 KB of a C firmware's `.text` on a Cortex-M4. Here they are stepped over by their lengths: bounds are still
//! checked (a truncated message is an error), the contents are not.

use super::{flag, id, AckNack, DataPayload, GetInfo, Heartbeat, Submessage, SubmessageHeader, TimestampReply};
use crate::cdr::{Endianness, Error, Reader, Result};
use crate::types::{BaseObjectReply, BaseObjectRequest, ResultStatus};

/// A submessage from an agent as a client sees it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum FromAgent<'a> {
    /// STATUS_AGENT: the outcome of CREATE_CLIENT (the agent's representation is stepped over).
    StatusAgent(ResultStatus),
    /// STATUS: the outcome of a request.
    Status(BaseObjectReply),
    /// INFO: the request it answers, and the agent's availability when its activity is the agent's.
    Info {
        /// Related request and result (implementation status 1: the agent knows the session).
        reply: BaseObjectReply,
        /// `ActivityInfo::Agent`'s availability (greater than 0: available), if the INFO carries it.
        availability: Option<i16>,
    },
    /// GET_INFO: the agent probing whether this session is still alive.
    GetInfo(GetInfo),
    /// DATA.
    Data(DataPayload<'a>),
    /// ACKNACK.
    AckNack(AckNack),
    /// HEARTBEAT.
    Heartbeat(Heartbeat),
    /// FRAGMENT.
    Fragment {
        /// LAST_FRAGMENT flag.
        last: bool,
        /// This piece of the fragmented message.
        data: &'a [u8],
    },
    /// TIMESTAMP_REPLY.
    TimestampReply(TimestampReply),
    /// RESET, requests only a client sends, and ids this decoder does not know: nothing for a client to do.
    Other,
}

impl<'a> FromAgent<'a> {
    /// Decodes the payload `buf[start..end]` of a submessage with header `header`; `buf` is the whole message
    /// (CDR alignment is relative to its first byte). Bytes after what the kind consumes are ignored.
    pub fn decode(header: SubmessageHeader, buf: &'a [u8], start: usize, end: usize) -> Result<Self> {
        let mut r = super::payload_reader(header, buf, start, end)?;
        let flags = header.flags;
        Ok(match header.id {
            id::STATUS_AGENT => Self::StatusAgent(r.read()?),
            id::STATUS => Self::Status(r.read()?),
            id::INFO => {
                let reply = r.read()?;
                if r.read_bool()? {
                    skip_configuration(&mut r)?;
                }
                let availability =
                    if r.read_bool()? && r.read_u8()? == ACTIVITY_AGENT { Some(r.read_i16()?) } else { None };
                Self::Info { reply, availability }
            }
            id::GET_INFO => {
                // The request and the mask, 4-aligned (no padding), in one read (firmware size).
                let [r0, r1, o0, o1, m0, m1, m2, m3] = r.read_array_opt().ok_or(Error::Truncated)?;
                let m = [m0, m1, m2, m3];
                let info_mask =
                    if r.endianness() == Endianness::Big { u32::from_be_bytes(m) } else { u32::from_le_bytes(m) };
                Self::GetInfo(GetInfo { request: BaseObjectRequest::from_bytes([r0, r1, o0, o1]), info_mask })
            }
            id::DATA => Self::Data(Submessage::data_payload(&mut r, flags)?),
            id::ACKNACK | id::HEARTBEAT => {
                // One read for the two 5-byte kinds, a u16 (4-aligned: no padding), two bytes and the stream id
                // (firmware size).
                let [a0, a1, b0, b1, stream_id] = r.read_array_opt().ok_or(Error::Truncated)?;
                let big = r.endianness() == Endianness::Big;
                let u16_of = |b: [u8; 2]| if big { u16::from_be_bytes(b) } else { u16::from_le_bytes(b) };
                if header.id == id::ACKNACK {
                    Self::AckNack(AckNack { first_unacked_seq_num: u16_of([a0, a1]), nack_bitmap: [b0, b1], stream_id })
                } else {
                    Self::Heartbeat(Heartbeat {
                        first_unacked_seq_nr: u16_of([a0, a1]),
                        last_unacked_seq_nr: u16_of([b0, b1]),
                        stream_id,
                    })
                }
            }
            id::FRAGMENT => Self::Fragment { last: flags & flag::LAST_FRAGMENT != 0, data: r.take_rest() },
            id::TIMESTAMP_REPLY => Self::TimestampReply(r.read()?),
            _ => Self::Other,
        })
    }
}

/// `ActivityInfo`'s discriminator for the agent's activity.
const ACTIVITY_AGENT: u8 = 0x0D;

/// Steps over an INFO's configuration: the agent's or a client's representation, the only ones an agent
/// reports to a client; any other kind is [`Error::InvalidDiscriminator`], as the whole decoder says.
fn skip_configuration(r: &mut Reader<'_>) -> Result<()> {
    // One path for both kinds (firmware size). The agent's: cookie, version, vendor id; then the optional
    // properties. A client's: cookie, version, vendor id, client key, session id; properties; the MTU.
    let kind = r.read_u8()?;
    let fixed = match kind {
        KIND_AGENT => 8,
        KIND_CLIENT => 13,
        _ => return Err(Error::InvalidDiscriminator(kind)),
    };
    r.skip(fixed)?;
    skip_properties(r)?;
    if kind == KIND_CLIENT {
        r.read_u16()?;
    }
    Ok(())
}

/// The object kinds of the agent's and a client's representations ([`ObjectKind`](crate::types::ObjectKind)).
const KIND_AGENT: u8 = 0x0D;
const KIND_CLIENT: u8 = 0x0E;

/// Steps over an optional sequence of (name, value) string pairs.
fn skip_properties(r: &mut Reader<'_>) -> Result<()> {
    if !r.read_bool()? {
        return Ok(());
    }
    // Two string lengths at least per property.
    let count = r.read_seq_len(8)?;
    for _ in 0..count.saturating_mul(2) {
        let len = r.read_u32()?;
        r.skip(usize::try_from(len).map_err(|_| Error::Truncated)?)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cdr::Error;

    /// What an INFO with a configuration of kind `kind` followed by `rest` decodes to: its availability.
    fn info_with_configuration(kind: u8, rest: &[u8]) -> Result<Option<i16>> {
        let mut msg = [0u8; 64];
        let head = [0, 1, 0xFF, 0xFE, 0, 1, 1, kind];
        msg[8..16].copy_from_slice(&head);
        msg[16..16 + rest.len()].copy_from_slice(rest);
        let len = head.len() + rest.len();
        let header = SubmessageHeader { id: id::INFO, flags: 1, length: len as u16 };
        match FromAgent::decode(header, &msg, 8, 8 + len)? {
            FromAgent::Info { availability, .. } => Ok(availability),
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn configurations_of_other_kinds_are_refused() {
        for kind in [0x00, 0x01, 0x0C, 0x0F, 0x10, 0x1D, 0xFE] {
            assert_eq!(info_with_configuration(kind, &[0; 24]), Err(Error::InvalidDiscriminator(kind)), "{kind:#x}");
        }
    }

    #[test]
    fn configurations_are_stepped_over() {
        // The agent's: 8 fixed bytes, no properties; then an agent activity, availability 1.
        let agent = [0u8, 0, 0, 0, 0, 0, 0, 0, 0, 1, 0x0D, 0, 1, 0];
        assert_eq!(info_with_configuration(0x0D, &agent), Ok(Some(1)));
        // A client's: 13 fixed bytes, no properties, the MTU (2-aligned already); then no activity.
        let client = [0u8, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 2, 0];
        assert_eq!(info_with_configuration(0x0E, &client), Ok(None));
        assert_eq!(info_with_configuration(0x0E, &client[..14]), Err(Error::Truncated));
        assert_eq!(info_with_configuration(0x0D, &[0; 8]), Err(Error::Truncated));
    }

    #[test]
    fn fixed_size_kinds_read_as_the_full_decoder_does() {
        let payload = [0x12, 0x34, 0x56, 0x78, 0x80];
        for flags in [0, 1] {
            for (kind, len) in [
                (id::ACKNACK, 5),
                (id::HEARTBEAT, 5),
                (id::ACKNACK, 4),
                (id::HEARTBEAT, 3),
                (id::GET_INFO, 8),
                (id::GET_INFO, 7),
            ] {
                let mut msg = [0u8; 16];
                msg[8..13].copy_from_slice(&payload);
                msg[13..16].copy_from_slice(&[0x9A, 0xBC, 0xDE]);
                let header = SubmessageHeader { id: kind, flags, length: len };
                let end = 8 + usize::from(len);
                let full = Submessage::decode(header, &msg, 8, end);
                match (FromAgent::decode(header, &msg, 8, end), full) {
                    (Ok(FromAgent::AckNack(a)), Ok(Submessage::AckNack(b))) => assert_eq!(a, b),
                    (Ok(FromAgent::Heartbeat(a)), Ok(Submessage::Heartbeat(b))) => assert_eq!(a, b),
                    (Ok(FromAgent::GetInfo(a)), Ok(Submessage::GetInfo(b))) => assert_eq!(a, b),
                    (Err(a), Err(b)) => assert_eq!(a, b),
                    other => panic!("{other:?}"),
                }
            }
        }
    }
}
