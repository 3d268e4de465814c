//! What a client reads of the submessages an agent sends, and nothing more.
//!
//! [`Submessage::decode`](super::Submessage::decode) builds every field of every kind; a client acts on a few
//! of them. STATUS_AGENT's agent representation and an INFO's configuration and locators are never read by a
//! session, yet their decoders (representations, property sequences, strings checked as UTF-8, locators) were
//! ~3 KB of a C firmware's `.text` on a Cortex-M4. Here they are stepped over by their lengths: bounds are still
//! checked (a truncated message is an error), the contents are not.

use super::{flag, id, AckNack, DataPayload, GetInfo, Heartbeat, Submessage, SubmessageHeader, TimestampReply};
use crate::cdr::{Error, Reader, Result};
use crate::types::{BaseObjectReply, ObjectKind, ResultStatus};

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
            id::GET_INFO => Self::GetInfo(r.read()?),
            id::DATA => Self::Data(Submessage::data_payload(&mut r, flags)?),
            id::ACKNACK => Self::AckNack(r.read()?),
            id::HEARTBEAT => Self::Heartbeat(r.read()?),
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
    let kind_byte = r.read_u8()?;
    let kind = if kind_byte > 0x0F { None } else { Some(ObjectKind::from_nibble(kind_byte)) };
    match kind {
        // Cookie, version, vendor id; then the optional properties.
        Some(ObjectKind::Agent) => {
            r.skip(8)?;
            skip_properties(r)
        }
        // Cookie, version, vendor id, client key, session id; properties; the MTU.
        Some(ObjectKind::Client) => {
            r.skip(13)?;
            skip_properties(r)?;
            r.read_u16().map(drop)
        }
        _ => Err(Error::InvalidDiscriminator(kind_byte)),
    }
}

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
