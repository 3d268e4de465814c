//! Common protocol types (spec §5): identifiers, status codes, time, sample identity, locators, properties.

use crate::cdr::{Decode, Encode, MinSize, Reader, Result, Writer};
use core::fmt;

/// `"XRCE"`, the cookie at the start of CLIENT and AGENT representations.
pub const XRCE_COOKIE: [u8; 4] = *b"XRCE";
/// Protocol version 1.0; peers check only the major byte.
pub const XRCE_VERSION: [u8; 2] = [0x01, 0x00];
/// eProsima's vendor id.
pub const VENDOR_EPROSIMA: [u8; 2] = [0x01, 0x0F];

/// The 4-byte client key, most significant byte first on the wire. `00000000` is invalid.
#[derive(Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Default)]
pub struct ClientKey(pub [u8; 4]);

impl ClientKey {
    /// The invalid all-zero key.
    pub const INVALID: Self = Self([0; 4]);

    /// Key from its numeric value (`0xAABBCCDD` → `AA BB CC DD`).
    pub const fn from_u32(v: u32) -> Self {
        Self(v.to_be_bytes())
    }

    /// Numeric value of the key.
    pub const fn to_u32(self) -> u32 {
        u32::from_be_bytes(self.0)
    }
}

impl fmt::Debug for ClientKey {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "ClientKey({:#010x})", self.to_u32())
    }
}

impl fmt::Display for ClientKey {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{:#010x}", self.to_u32())
    }
}

/// Session ids below this value carry the client key in the message header.
pub const SESSION_ID_WITHOUT_KEY: u8 = 0x80;
/// Out-of-session message with the client key in the header.
pub const SESSION_ID_NONE_WITH_KEY: u8 = 0x00;
/// Out-of-session message without client key.
pub const SESSION_ID_NONE_WITHOUT_KEY: u8 = 0x80;

/// Whether messages of this session id carry the client key in their header.
pub const fn session_has_key(session_id: u8) -> bool {
    session_id < SESSION_ID_WITHOUT_KEY
}

/// Whether a message with this session id travels outside any session (`SESSION_ID_NONE`, with or without
/// the client key).
pub const fn is_session_none(session_id: u8) -> bool {
    session_id & !SESSION_ID_WITHOUT_KEY == 0
}

/// The out-of-session id that carries the key exactly when `session_id` does: what CREATE_CLIENT travels
/// with (0x00 or 0x80).
pub const fn session_none_for(session_id: u8) -> u8 {
    session_id & SESSION_ID_WITHOUT_KEY
}

/// The kind of a stream, given by its id (spec §2).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum StreamKind {
    /// Stream 0: no order, no reliability.
    None,
    /// Ids 0x01–0x7F.
    BestEffort,
    /// Ids 0x80–0xFF.
    Reliable,
}

/// A stream id; per direction, so input 0x80 and output 0x80 are unrelated.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Default)]
pub struct StreamId(pub u8);

impl StreamId {
    /// Stream 0.
    pub const NONE: Self = Self(0x00);
    /// First best-effort stream, where the agent answers best-effort requests.
    pub const BUILTIN_BEST_EFFORT: Self = Self(0x01);
    /// First reliable stream, where the agent answers reliable requests.
    pub const BUILTIN_RELIABLE: Self = Self(0x80);

    /// The stream with index `index` of `kind` (index 0 of best effort is 0x01, of reliable 0x80).
    pub const fn from_index(index: u8, kind: StreamKind) -> Self {
        match kind {
            StreamKind::None => Self(0),
            StreamKind::BestEffort => Self(index.wrapping_add(1) & 0x7F),
            StreamKind::Reliable => Self(index | 0x80),
        }
    }

    /// Kind of the stream.
    pub const fn kind(self) -> StreamKind {
        match self.0 {
            0 => StreamKind::None,
            1..=0x7F => StreamKind::BestEffort,
            _ => StreamKind::Reliable,
        }
    }

    /// Index of the stream among those of its kind.
    pub const fn index(self) -> u8 {
        // Branch-free (firmware size): 0 stays 0, 1..=0x7F lose 1, 0x80.. lose 0x80.
        (self.0 & 0x7F).saturating_sub((self.0 < 0x80) as u8)
    }

    /// Whether the stream is reliable.
    pub const fn is_reliable(self) -> bool {
        self.0 >= 0x80
    }
}

/// Kind of an object: the low nibble of an [`ObjectId`] (spec §5.1).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
#[repr(u8)]
#[allow(missing_docs)]
pub enum ObjectKind {
    Invalid = 0x00,
    Participant = 0x01,
    Topic = 0x02,
    Publisher = 0x03,
    Subscriber = 0x04,
    DataWriter = 0x05,
    DataReader = 0x06,
    Requester = 0x07,
    Replier = 0x08,
    Unused9 = 0x09,
    Type = 0x0A,
    QosProfile = 0x0B,
    Application = 0x0C,
    Agent = 0x0D,
    Client = 0x0E,
    Other = 0x0F,
}

impl ObjectKind {
    /// Kind from the low nibble of `v` (every nibble names a kind).
    pub const fn from_nibble(v: u8) -> Self {
        match v & 0x0F {
            0x00 => Self::Invalid,
            0x01 => Self::Participant,
            0x02 => Self::Topic,
            0x03 => Self::Publisher,
            0x04 => Self::Subscriber,
            0x05 => Self::DataWriter,
            0x06 => Self::DataReader,
            0x07 => Self::Requester,
            0x08 => Self::Replier,
            0x09 => Self::Unused9,
            0x0A => Self::Type,
            0x0B => Self::QosProfile,
            0x0C => Self::Application,
            0x0D => Self::Agent,
            0x0E => Self::Client,
            _ => Self::Other,
        }
    }

    /// The kind's parent kind, for the 8 entity kinds the agent creates.
    pub const fn parent(self) -> Option<Self> {
        match self {
            Self::Topic | Self::Publisher | Self::Subscriber | Self::Requester | Self::Replier => {
                Some(Self::Participant)
            }
            Self::DataWriter => Some(Self::Publisher),
            Self::DataReader => Some(Self::Subscriber),
            _ => None,
        }
    }
}

/// An object id: 12-bit object number and 4-bit kind, `octet[2]` on the wire (spec §5.2).
#[derive(Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Default)]
pub struct ObjectId(pub [u8; 2]);

impl ObjectId {
    /// `00 00`.
    pub const INVALID: Self = Self([0x00, 0x00]);
    /// `FF FD`, the agent.
    pub const AGENT: Self = Self([0xFF, 0xFD]);
    /// `FF FE`, the client itself (DELETE of it ends the session).
    pub const CLIENT: Self = Self([0xFF, 0xFE]);
    /// `FF FF`, the session.
    pub const SESSION: Self = Self([0xFF, 0xFF]);

    /// Id of object number `number` (12 bits used) of `kind`.
    pub const fn new(number: u16, kind: ObjectKind) -> Self {
        Self::from_raw(((number & 0x0FFF) << 4) | kind as u16)
    }

    /// Id from its 16-bit value.
    pub const fn from_raw(raw: u16) -> Self {
        Self(raw.to_be_bytes())
    }

    /// The 16-bit value.
    pub const fn raw(self) -> u16 {
        u16::from_be_bytes(self.0)
    }

    /// The 12-bit object number.
    pub const fn number(self) -> u16 {
        self.raw() >> 4
    }

    /// The kind nibble.
    pub const fn kind(self) -> ObjectKind {
        ObjectKind::from_nibble(self.0[1])
    }

    /// The same number with another kind (how the agent rebuilds ids from prefixes).
    pub const fn with_kind(self, kind: ObjectKind) -> Self {
        Self::from_raw((self.raw() & 0xFFF0) | kind as u16)
    }
}

impl fmt::Debug for ObjectId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "ObjectId({:#06x} #{} {:?})", self.raw(), self.number(), self.kind())
    }
}

impl fmt::Display for ObjectId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{:02X}{:02X}", self.0[0], self.0[1])
    }
}

/// A request id, `octet[2]` most significant byte first. 0 is invalid.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Default)]
pub struct RequestId(pub u16);

impl RequestId {
    /// Request id the C client uses to delete its session.
    pub const DELETE_SESSION: Self = Self(0x0002);
    /// Request id of the discovery GET_INFO.
    pub const DISCOVERY: Self = Self(0x0009);
    /// Request id of the ping GET_INFO.
    pub const PING: Self = Self(0x000A);
}

/// Status codes carried by [`ResultStatus`] (spec §5.4). Unknown values are kept as they are.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct StatusCode(pub u8);

impl StatusCode {
    /// Success.
    pub const OK: Self = Self(0x00);
    /// REUSE and the existing object matches.
    pub const OK_MATCHED: Self = Self(0x01);
    /// Middleware failure.
    pub const ERR_DDS_ERROR: Self = Self(0x80);
    /// REUSE without REPLACE and the existing object differs.
    pub const ERR_MISMATCH: Self = Self(0x81);
    /// Object exists and neither REUSE nor REPLACE was asked.
    pub const ERR_ALREADY_EXISTS: Self = Self(0x82);
    /// Denied.
    pub const ERR_DENIED: Self = Self(0x83);
    /// Unknown parent or object.
    pub const ERR_UNKNOWN_REFERENCE: Self = Self(0x84);
    /// Malformed request.
    pub const ERR_INVALID_DATA: Self = Self(0x85);
    /// Incompatible protocol version.
    pub const ERR_INCOMPATIBLE: Self = Self(0x86);
    /// Out of resources.
    pub const ERR_RESOURCES: Self = Self(0x87);
    /// Client-internal "no status yet"; never on the wire.
    pub const NONE: Self = Self(0xFF);

    /// Whether the code reports success (OK or OK_MATCHED).
    pub const fn is_ok(self) -> bool {
        self.0 < 0x80
    }

    /// Symbolic name of the code.
    pub const fn name(self) -> &'static str {
        match self.0 {
            0x00 => "OK",
            0x01 => "OK_MATCHED",
            0x80 => "ERR_DDS_ERROR",
            0x81 => "ERR_MISMATCH",
            0x82 => "ERR_ALREADY_EXISTS",
            0x83 => "ERR_DENIED",
            0x84 => "ERR_UNKNOWN_REFERENCE",
            0x85 => "ERR_INVALID_DATA",
            0x86 => "ERR_INCOMPATIBLE",
            0x87 => "ERR_RESOURCES",
            0xFF => "NONE",
            _ => "UNKNOWN",
        }
    }
}

impl fmt::Debug for StatusCode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}({:#04x})", self.name(), self.0)
    }
}

/// `u8 status ; u8 implementation_status`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct ResultStatus {
    /// The status code.
    pub status: StatusCode,
    /// 0, except in INFO where 1 means "the agent knows this session".
    pub implementation_status: u8,
}

impl ResultStatus {
    /// A result with implementation status 0.
    pub const fn new(status: StatusCode) -> Self {
        Self { status, implementation_status: 0 }
    }
}

/// `RequestId ; ObjectId`: the 4-byte prefix of most requests.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct BaseObjectRequest {
    /// The request id.
    pub request_id: RequestId,
    /// The object addressed.
    pub object_id: ObjectId,
}

/// `BaseObjectRequest related_request ; ResultStatus result`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct BaseObjectReply {
    /// Request being answered.
    pub related_request: BaseObjectRequest,
    /// Outcome.
    pub result: ResultStatus,
}

/// `i32 seconds ; u32 nanoseconds` since the Unix epoch.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Default)]
pub struct Time {
    /// Whole seconds.
    pub seconds: i32,
    /// Nanoseconds within the second.
    pub nanoseconds: u32,
}

impl Time {
    /// Time from nanoseconds since the epoch.
    pub const fn from_nanos(ns: i64) -> Self {
        let (seconds, nanoseconds) = crate::reliable::div_floor_pow1000(ns, 3);
        Self { seconds: seconds as i32, nanoseconds }
    }

    /// Its little-endian CDR bytes at a 4-aligned position.
    pub const fn to_le_bytes(&self) -> [u8; 8] {
        let [s0, s1, s2, s3] = self.seconds.to_le_bytes();
        let [n0, n1, n2, n3] = self.nanoseconds.to_le_bytes();
        [s0, s1, s2, s3, n0, n1, n2, n3]
    }

    /// Nanoseconds since the epoch.
    pub const fn as_nanos(self) -> i64 {
        self.seconds as i64 * 1_000_000_000 + self.nanoseconds as i64
    }
}

/// DDS GUID: prefix, entity key, entity kind (16 bytes).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Default)]
pub struct Guid {
    /// Participant prefix.
    pub prefix: [u8; 12],
    /// Entity key.
    pub entity_key: [u8; 3],
    /// Entity kind.
    pub entity_kind: u8,
}

/// DDS sequence number, `i32 high ; u32 low`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Default)]
pub struct SequenceNumber {
    /// High 32 bits.
    pub high: i32,
    /// Low 32 bits.
    pub low: u32,
}

/// Identity of a DDS sample (24 bytes), which relates replies to requests.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Default)]
pub struct SampleIdentity {
    /// Writer of the sample.
    pub writer_guid: Guid,
    /// Its sequence number.
    pub sequence_number: SequenceNumber,
}

impl SampleIdentity {
    /// Encoded size.
    pub const SIZE: usize = 24;

    /// The identity in `bytes`, its little-endian CDR form (from a 4-aligned position).
    pub const fn from_le_bytes(bytes: &[u8; Self::SIZE]) -> Self {
        let [prefix @ .., k0, k1, k2, entity_kind, h0, h1, h2, h3, l0, l1, l2, l3] = *bytes;
        Self {
            writer_guid: Guid { prefix, entity_key: [k0, k1, k2], entity_kind },
            sequence_number: SequenceNumber {
                high: i32::from_le_bytes([h0, h1, h2, h3]),
                low: u32::from_le_bytes([l0, l1, l2, l3]),
            },
        }
    }
}

/// Where an agent can be reached (spec §5.6).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum TransportLocator<'a> {
    /// Format 0: 2-byte address, 1-byte port.
    Small {
        /// Address.
        address: [u8; 2],
        /// Port.
        port: u8,
    },
    /// Format 1: IPv4 address and port.
    Medium {
        /// IPv4 address, network order.
        address: [u8; 4],
        /// Port.
        port: u16,
    },
    /// Format 2: IPv6 address and port.
    Large {
        /// IPv6 address, network order.
        address: [u8; 16],
        /// Port.
        port: u32,
    },
    /// Format 3: free-form string.
    String(&'a str),
}

impl<'a> Decode<'a> for TransportLocator<'a> {
    fn decode(r: &mut Reader<'a>) -> Result<Self> {
        match r.read_u8()? {
            0 => Ok(Self::Small { address: r.read_array()?, port: r.read_u8()? }),
            1 => Ok(Self::Medium { address: r.read_array()?, port: r.read_u16()? }),
            2 => Ok(Self::Large { address: r.read_array()?, port: r.read_u32()? }),
            3 => Ok(Self::String(r.read_string()?)),
            other => Err(crate::cdr::Error::InvalidDiscriminator(other)),
        }
    }
}

impl Encode for TransportLocator<'_> {
    fn encode(&self, w: &mut Writer<'_>) {
        match self {
            Self::Small { address, port } => {
                w.write_u8(0);
                w.write_bytes(address);
                w.write_u8(*port);
            }
            Self::Medium { address, port } => {
                w.write_u8(1);
                w.write_bytes(address);
                w.write_u16(*port);
            }
            Self::Large { address, port } => {
                w.write_u8(2);
                w.write_bytes(address);
                w.write_u32(*port);
            }
            Self::String(s) => {
                w.write_u8(3);
                w.write_string(s);
            }
        }
    }
}

impl MinSize for TransportLocator<'_> {
    const MIN_SIZE: usize = 4;
}

/// A name/value pair (CREATE_CLIENT properties such as `uxr_hl`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Property<'a> {
    /// Name.
    pub name: &'a str,
    /// Value.
    pub value: &'a str,
}

impl<'a> Decode<'a> for Property<'a> {
    fn decode(r: &mut Reader<'a>) -> Result<Self> {
        Ok(Self { name: r.read_string()?, value: r.read_string()? })
    }
}

impl Encode for Property<'_> {
    fn encode(&self, w: &mut Writer<'_>) {
        w.write_string(self.name);
        w.write_string(self.value);
    }
}

impl MinSize for Property<'_> {
    const MIN_SIZE: usize = 8;
}

macro_rules! codec_struct {
    ($t:ty { $($field:ident : $ft:ty),* $(,)? }) => {
        impl<'a> Decode<'a> for $t {
            fn decode(r: &mut Reader<'a>) -> Result<Self> {
                Ok(Self { $($field: <$ft as Decode>::decode(r)?),* })
            }
        }
        impl Encode for $t {
            fn encode(&self, w: &mut Writer<'_>) {
                $(self.$field.encode(w);)*
            }
        }
    };
}
pub(crate) use codec_struct;

macro_rules! codec_newtype {
    ($t:ident, $inner:ty) => {
        impl<'a> Decode<'a> for $t {
            fn decode(r: &mut Reader<'a>) -> Result<Self> {
                Ok(Self(<$inner as Decode>::decode(r)?))
            }
        }
        impl Encode for $t {
            fn encode(&self, w: &mut Writer<'_>) {
                self.0.encode(w)
            }
        }
    };
}

codec_newtype!(ClientKey, [u8; 4]);
codec_newtype!(ObjectId, [u8; 2]);
codec_newtype!(StatusCode, u8);

impl<'a> Decode<'a> for RequestId {
    fn decode(r: &mut Reader<'a>) -> Result<Self> {
        Ok(Self(u16::from_be_bytes(r.read_array()?)))
    }
}

impl Encode for RequestId {
    fn encode(&self, w: &mut Writer<'_>) {
        w.write_bytes(&self.0.to_be_bytes())
    }
}

// Bytes without alignment: each of these is read as one array (one bounds check rather than one per field).

impl BaseObjectRequest {
    pub(crate) const fn from_bytes([r0, r1, o0, o1]: [u8; 4]) -> Self {
        Self { request_id: RequestId(u16::from_be_bytes([r0, r1])), object_id: ObjectId([o0, o1]) }
    }
}

impl BaseObjectReply {
    /// Its CDR bytes (no alignment, no byte order).
    pub const fn to_bytes(&self) -> [u8; 6] {
        let [r0, r1, o0, o1] = self.related_request.to_bytes();
        [r0, r1, o0, o1, self.result.status.0, self.result.implementation_status]
    }
}

impl<'a> Decode<'a> for ResultStatus {
    fn decode(r: &mut Reader<'a>) -> Result<Self> {
        let [status, implementation_status] = r.read_array()?;
        Ok(Self { status: StatusCode(status), implementation_status })
    }
}

impl Encode for ResultStatus {
    fn encode(&self, w: &mut Writer<'_>) {
        self.status.encode(w);
        self.implementation_status.encode(w);
    }
}

// These decoders can only fail on truncation: the work is done returning an `Option` (firmware size, see
// `Reader::read_array_opt`).
impl<'a> Decode<'a> for BaseObjectRequest {
    #[inline(always)]
    fn decode(r: &mut Reader<'a>) -> Result<Self> {
        Self::read_opt(r).ok_or(crate::cdr::Error::Truncated)
    }
}

impl BaseObjectRequest {
    #[inline(never)]
    fn read_opt(r: &mut Reader<'_>) -> Option<Self> {
        r.read_array_opt().map(Self::from_bytes)
    }
}

impl Encode for BaseObjectRequest {
    fn encode(&self, w: &mut Writer<'_>) {
        self.request_id.encode(w);
        self.object_id.encode(w);
    }
}

impl<'a> Decode<'a> for BaseObjectReply {
    #[inline(always)]
    fn decode(r: &mut Reader<'a>) -> Result<Self> {
        Self::read_opt(r).ok_or(crate::cdr::Error::Truncated)
    }
}

impl BaseObjectReply {
    #[inline(never)]
    fn read_opt(r: &mut Reader<'_>) -> Option<Self> {
        let [r0, r1, o0, o1, status, implementation_status] = r.read_array_opt()?;
        Some(Self {
            related_request: BaseObjectRequest::from_bytes([r0, r1, o0, o1]),
            result: ResultStatus { status: StatusCode(status), implementation_status },
        })
    }
}

impl Encode for BaseObjectReply {
    fn encode(&self, w: &mut Writer<'_>) {
        self.related_request.encode(w);
        self.result.encode(w);
    }
}
// Only truncation can fail: read as an `Option` (firmware size, see `Reader::read_array_opt`).
impl<'a> Decode<'a> for Time {
    #[inline(always)]
    fn decode(r: &mut Reader<'a>) -> Result<Self> {
        Self::read_opt(r).ok_or(crate::cdr::Error::Truncated)
    }
}

impl Time {
    // Always inlined into TIMESTAMP_REPLY's three reads (firmware size: 72 bytes less than calls).
    #[inline(always)]
    pub(crate) fn read_opt(r: &mut Reader<'_>) -> Option<Self> {
        Some(Self { seconds: r.read_u32_opt()? as i32, nanoseconds: r.read_u32_opt()? })
    }
}

impl Encode for Time {
    fn encode(&self, w: &mut Writer<'_>) {
        self.seconds.encode(w);
        self.nanoseconds.encode(w);
    }
}
codec_struct!(Guid { prefix: [u8; 12], entity_key: [u8; 3], entity_kind: u8 });
codec_struct!(SequenceNumber { high: i32, low: u32 });
codec_struct!(SampleIdentity { writer_guid: Guid, sequence_number: SequenceNumber });

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stream_index_of_every_id() {
        for id in 0..=u8::MAX {
            let expected = match StreamId(id).kind() {
                StreamKind::None => 0,
                StreamKind::BestEffort => id - 1,
                StreamKind::Reliable => id - 0x80,
            };
            assert_eq!(StreamId(id).index(), expected, "{id:#x}");
        }
    }

    #[test]
    fn object_ids_follow_the_spec_examples() {
        assert_eq!(ObjectId::new(1, ObjectKind::Participant).0, [0x00, 0x11]);
        assert_eq!(ObjectId::new(1, ObjectKind::DataWriter).0, [0x00, 0x15]);
        assert_eq!(ObjectId::new(0x123, ObjectKind::DataWriter).0, [0x12, 0x35]);
        assert_eq!(ObjectId([0x12, 0x35]).number(), 0x123);
        assert_eq!(ObjectId([0x00, 0x13]).with_kind(ObjectKind::Participant), ObjectId([0x00, 0x11]));
    }

    #[test]
    fn session_none_keeps_the_key_choice() {
        assert_eq!(session_none_for(0x81), SESSION_ID_NONE_WITHOUT_KEY);
        assert_eq!(session_none_for(0x01), SESSION_ID_NONE_WITH_KEY);
        assert!(is_session_none(0x00) && is_session_none(0x80));
        assert!(!is_session_none(0x01) && !is_session_none(0x81) && !is_session_none(0xFF));
    }

    #[test]
    fn stream_ids_map_indices() {
        assert_eq!(StreamId::from_index(0, StreamKind::BestEffort), StreamId(1));
        assert_eq!(StreamId::from_index(2, StreamKind::Reliable), StreamId(0x82));
        assert_eq!(StreamId(0x82).index(), 2);
        assert_eq!(StreamId(0).kind(), StreamKind::None);
    }

    #[test]
    fn time_converts_negative_nanos() {
        let t = Time::from_nanos(-1);
        assert_eq!(t, Time { seconds: -1, nanoseconds: 999_999_999 });
        assert_eq!(t.as_nanos(), -1);
    }
}
