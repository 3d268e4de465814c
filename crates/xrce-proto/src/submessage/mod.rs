//! Submessage header, ids and the decoded submessages (spec §3, §4, §6).

mod from_agent;
mod payload;

pub use from_agent::FromAgent;
pub use payload::*;

use crate::cdr::{Decode, Encode, Endianness, Error, Reader, Result, Writer};
use crate::object::{ClientRepresentation, ObjectVariant};
use crate::types::{BaseObjectReply, BaseObjectRequest, Time};

/// A reader of the payload `buf[start..end]` of a submessage with header `header`, its alignment origin the
/// first byte of the message `buf`.
fn payload_reader(header: SubmessageHeader, buf: &[u8], start: usize, end: usize) -> Result<Reader<'_>> {
    let bounded = buf.get(..end).ok_or(Error::Truncated)?;
    if start > end {
        return Err(Error::Truncated);
    }
    Ok(Reader::with_origin(bounded, start, 0, header.endianness()))
}

/// Submessage ids.
pub mod id {
    /// CREATE_CLIENT.
    pub const CREATE_CLIENT: u8 = 0;
    /// CREATE.
    pub const CREATE: u8 = 1;
    /// GET_INFO.
    pub const GET_INFO: u8 = 2;
    /// DELETE.
    pub const DELETE: u8 = 3;
    /// STATUS_AGENT.
    pub const STATUS_AGENT: u8 = 4;
    /// STATUS.
    pub const STATUS: u8 = 5;
    /// INFO.
    pub const INFO: u8 = 6;
    /// WRITE_DATA.
    pub const WRITE_DATA: u8 = 7;
    /// READ_DATA.
    pub const READ_DATA: u8 = 8;
    /// DATA.
    pub const DATA: u8 = 9;
    /// ACKNACK.
    pub const ACKNACK: u8 = 10;
    /// HEARTBEAT.
    pub const HEARTBEAT: u8 = 11;
    /// RESET.
    pub const RESET: u8 = 12;
    /// FRAGMENT.
    pub const FRAGMENT: u8 = 13;
    /// TIMESTAMP.
    pub const TIMESTAMP: u8 = 14;
    /// TIMESTAMP_REPLY.
    pub const TIMESTAMP_REPLY: u8 = 15;
}

/// Flag bits shared by several submessages.
pub mod flag {
    /// Payload little endian.
    pub const ENDIANNESS: u8 = 0x01;
    /// FRAGMENT: this slice completes the message.
    pub const LAST_FRAGMENT: u8 = 0x02;
}

/// `u8 id ; u8 flags ; u16 length (little endian)`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Hash)]
pub struct SubmessageHeader {
    /// Submessage id.
    pub id: u8,
    /// Flags; bit 0 is the payload byte order.
    pub flags: u8,
    /// Payload length without header and padding.
    pub length: u16,
}

impl SubmessageHeader {
    /// Encoded size.
    pub const SIZE: usize = 4;

    /// Byte order of the payload.
    pub const fn endianness(&self) -> Endianness {
        Endianness::from_flags(self.flags)
    }

    /// Decodes a header from four bytes.
    pub const fn from_bytes(b: [u8; 4]) -> Self {
        Self { id: b[0], flags: b[1], length: u16::from_le_bytes([b[2], b[3]]) }
    }

    /// The four bytes of the header.
    pub const fn to_bytes(self) -> [u8; 4] {
        let len = self.length.to_le_bytes();
        [self.id, self.flags, len[0], len[1]]
    }
}

/// A decoded submessage, borrowing from the message buffer.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Submessage<'a> {
    /// CREATE_CLIENT.
    CreateClient(ClientRepresentation<'a>),
    /// CREATE.
    Create(Create<'a>),
    /// GET_INFO.
    GetInfo(GetInfo),
    /// DELETE.
    Delete(BaseObjectRequest),
    /// STATUS_AGENT.
    StatusAgent(StatusAgent<'a>),
    /// STATUS.
    Status(BaseObjectReply),
    /// INFO.
    Info(Info<'a>),
    /// WRITE_DATA.
    WriteData(DataPayload<'a>),
    /// READ_DATA.
    ReadData(ReadData<'a>),
    /// DATA.
    Data(DataPayload<'a>),
    /// ACKNACK.
    AckNack(AckNack),
    /// HEARTBEAT.
    Heartbeat(Heartbeat),
    /// RESET.
    Reset,
    /// FRAGMENT: a slice of an inner message.
    Fragment {
        /// Whether this slice completes the inner message.
        last: bool,
        /// The slice.
        data: &'a [u8],
    },
    /// TIMESTAMP.
    Timestamp(Time),
    /// TIMESTAMP_REPLY.
    TimestampReply(TimestampReply),
    /// Any other id, kept raw.
    Unknown {
        /// Submessage id.
        id: u8,
        /// Flags.
        flags: u8,
        /// Payload.
        payload: &'a [u8],
    },
}

impl<'a> Submessage<'a> {
    /// Submessage id.
    pub const fn id(&self) -> u8 {
        match self {
            Self::CreateClient(_) => id::CREATE_CLIENT,
            Self::Create(_) => id::CREATE,
            Self::GetInfo(_) => id::GET_INFO,
            Self::Delete(_) => id::DELETE,
            Self::StatusAgent(_) => id::STATUS_AGENT,
            Self::Status(_) => id::STATUS,
            Self::Info(_) => id::INFO,
            Self::WriteData(_) => id::WRITE_DATA,
            Self::ReadData(_) => id::READ_DATA,
            Self::Data(_) => id::DATA,
            Self::AckNack(_) => id::ACKNACK,
            Self::Heartbeat(_) => id::HEARTBEAT,
            Self::Reset => id::RESET,
            Self::Fragment { .. } => id::FRAGMENT,
            Self::Timestamp(_) => id::TIMESTAMP,
            Self::TimestampReply(_) => id::TIMESTAMP_REPLY,
            Self::Unknown { id, .. } => *id,
        }
    }

    /// Flags besides the endianness bit.
    pub const fn extra_flags(&self) -> u8 {
        match self {
            Self::Create(c) => c.mode.flags(),
            Self::WriteData(d) | Self::Data(d) => d.format.0 & DataFormat::MASK,
            Self::Fragment { last: true, .. } => flag::LAST_FRAGMENT,
            Self::Unknown { flags, .. } => *flags & !flag::ENDIANNESS,
            _ => 0,
        }
    }

    /// Decodes the payload `buf[start..end]` of a submessage with header `header`.
    ///
    /// `buf` is the whole message: CDR alignment is relative to its first byte (spec §1.2).
    /// Bytes after what the submessage's type consumes are ignored.
    pub fn decode(header: SubmessageHeader, buf: &'a [u8], start: usize, end: usize) -> Result<Self> {
        let mut r = payload_reader(header, buf, start, end)?;
        let flags = header.flags;
        Ok(match header.id {
            id::CREATE_CLIENT => Self::CreateClient(r.read()?),
            id::CREATE => Self::Create(Create {
                request: r.read()?,
                mode: CreationMode::from_flags(flags),
                variant: ObjectVariant::decode(&mut r)?,
            }),
            id::GET_INFO => Self::GetInfo(r.read()?),
            id::DELETE => Self::Delete(r.read()?),
            id::STATUS_AGENT => Self::StatusAgent(r.read()?),
            id::STATUS => Self::Status(r.read()?),
            id::INFO => Self::Info(r.read()?),
            id::DATA => Self::Data(Self::data_payload(&mut r, flags)?),
            id::WRITE_DATA => Self::WriteData(Self::data_payload(&mut r, flags)?),
            id::READ_DATA => Self::ReadData(r.read()?),
            id::ACKNACK => Self::AckNack(r.read()?),
            id::HEARTBEAT => Self::Heartbeat(r.read()?),
            id::RESET => Self::Reset,
            id::FRAGMENT => Self::Fragment { last: flags & flag::LAST_FRAGMENT != 0, data: r.take_rest() },
            id::TIMESTAMP => Self::Timestamp(r.read()?),
            id::TIMESTAMP_REPLY => Self::TimestampReply(r.read()?),
            other => Self::Unknown { id: other, flags, payload: r.take_rest() },
        })
    }

    /// The payload of a DATA or WRITE_DATA submessage with `flags`, read from `r`.
    pub(super) fn data_payload(r: &mut Reader<'a>, flags: u8) -> Result<DataPayload<'a>> {
        Ok(DataPayload { request: r.read()?, format: DataFormat::from_flags(flags), data: r.take_rest() })
    }

    /// Writes the payload (not the header) at the writer's position.
    pub fn encode_payload(&self, w: &mut Writer<'_>) {
        match self {
            Self::CreateClient(c) => c.encode(w),
            Self::Create(c) => {
                c.request.encode(w);
                c.variant.encode(w);
            }
            Self::GetInfo(g) => g.encode(w),
            Self::Delete(d) => d.encode(w),
            Self::StatusAgent(s) => s.encode(w),
            Self::Status(s) => s.encode(w),
            Self::Info(i) => i.encode(w),
            Self::WriteData(d) | Self::Data(d) => {
                d.request.encode(w);
                w.write_bytes(d.data);
            }
            Self::ReadData(r) => r.encode(w),
            Self::AckNack(a) => a.encode(w),
            Self::Heartbeat(h) => h.encode(w),
            Self::Reset => {}
            Self::Fragment { data, .. } => w.write_bytes(data),
            Self::Timestamp(t) => t.encode(w),
            Self::TimestampReply(t) => t.encode(w),
            Self::Unknown { payload, .. } => w.write_bytes(payload),
        }
    }

    /// Writes header and payload at the writer's position, which must be 4-aligned from the message start.
    /// The payload byte order is the writer's.
    pub fn encode(&self, w: &mut Writer<'_>) {
        write_submessage(w, self.id(), self.extra_flags(), |w| self.encode_payload(w));
    }
}

/// Writes a submessage `id` with `flags` (the byte order added) whose payload `payload` writes, at the writer's
/// position (4-aligned by the caller). Writing one kind this way links only that kind's encoder, where
/// [`Submessage::encode`] links every kind's: a client sends a handful of kinds.
pub fn write_submessage(w: &mut Writer<'_>, id: u8, flags: u8, payload: impl FnOnce(&mut Writer<'_>)) {
    let header_at = w.position();
    let flags = flags | w.endianness().flag();
    w.write_bytes(&SubmessageHeader { id, flags, length: 0 }.to_bytes());
    let start = w.position();
    payload(w);
    match u16::try_from(w.position() - start) {
        Ok(len) => w.patch_u16_le(header_at + 2, len),
        Err(_) => w.fail(Error::TooLong(crate::cdr::LengthField::Submessage)),
    }
}
