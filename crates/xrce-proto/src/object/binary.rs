//! eProsima's binary object representations (spec §7.4).
//!
//! A blob is CDR with its own origin (the byte after the blob's length) in the byte order of the CREATE that
//! carries it. Where the C client and the C++ agent disagree on a layout, these types follow what is really
//! exchanged: the C client never sends publisher/subscriber QoS, nor `ownership_strength` or
//! `timebasedfilter_msec`; when present we read and write those as the agent does (`u32`), and keep
//! publisher/subscriber QoS as opaque bytes so any blob survives a decode/encode round trip.

use crate::cdr::{Decode, Encode, Endianness, Error, Reader, Result, Writer};
use crate::types::{ObjectId, ObjectKind};

/// A binary representation: raw as received, or typed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum BinaryObject<'a> {
    /// Bytes of the blob, as decoded from a CREATE.
    Raw(&'a [u8]),
    /// OBJK_DomainParticipant_Binary.
    Participant(ParticipantBinary<'a>),
    /// OBJK_Topic_Binary.
    Topic(TopicBinary<'a>),
    /// OBJK_Publisher_Binary.
    Publisher(PubSubBinary<'a>),
    /// OBJK_Subscriber_Binary.
    Subscriber(PubSubBinary<'a>),
    /// OBJK_DataWriter_Binary.
    DataWriter(DataWriterBinary<'a>),
    /// OBJK_DataReader_Binary.
    DataReader(DataReaderBinary<'a>),
    /// OBJK_Requester_Binary.
    Requester(RequesterBinary<'a>),
    /// OBJK_Replier_Binary (same layout as the requester's).
    Replier(RequesterBinary<'a>),
}

impl<'a> BinaryObject<'a> {
    /// Decodes a raw blob as the binary representation of `kind`; a typed object is returned as is.
    /// Bytes left after the known fields are ignored (the C client may leave none, eProsima ignores them).
    pub fn decode_as(self, kind: ObjectKind, endian: Endianness) -> Result<Self> {
        let BinaryObject::Raw(bytes) = self else { return Ok(self) };
        let mut r = Reader::new(bytes, endian);
        Ok(match kind {
            ObjectKind::Participant => Self::Participant(r.read()?),
            ObjectKind::Topic => Self::Topic(r.read()?),
            ObjectKind::Publisher => Self::Publisher(r.read()?),
            ObjectKind::Subscriber => Self::Subscriber(r.read()?),
            ObjectKind::DataWriter => Self::DataWriter(r.read()?),
            ObjectKind::DataReader => Self::DataReader(r.read()?),
            ObjectKind::Requester => Self::Requester(r.read()?),
            ObjectKind::Replier => Self::Replier(r.read()?),
            other => return Err(Error::InvalidDiscriminator(other as u8)),
        })
    }

    /// Writes the blob as `sequence<octet>`: its length, then the content with its own alignment origin.
    ///
    /// Public so a client can encode a blob straight into its output buffer: a [`Writer`] over an empty buffer
    /// measures the size first (its position, or [`Error::BufferTooSmall`]'s `needed`).
    pub fn encode_with_length(&self, w: &mut Writer<'_>) {
        if let Self::Raw(bytes) = self {
            w.write_octet_seq(bytes);
            return;
        }
        w.align(4);
        let length_at = w.position();
        w.write_u32(0);
        let start = w.position();
        let outer_origin = w.origin();
        w.set_origin(start);
        match self {
            Self::Raw(_) => {}
            Self::Participant(b) => b.encode(w),
            Self::Topic(b) => b.encode(w),
            Self::Publisher(b) | Self::Subscriber(b) => b.encode(w),
            Self::DataWriter(b) => b.encode(w),
            Self::DataReader(b) => b.encode(w),
            Self::Requester(b) | Self::Replier(b) => b.encode(w),
        }
        w.set_origin(outer_origin);
        let len = w.position() - start;
        match u32::try_from(len) {
            Ok(len) => w.patch_u32(length_at, len),
            Err(_) => w.fail(Error::TooLong(crate::cdr::LengthField::BinaryRepresentation)),
        }
    }
}

/// OBJK_DomainParticipant_Binary.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct ParticipantBinary<'a> {
    /// Domain reference (unused by eProsima).
    pub domain_reference: Option<&'a str>,
    /// The C client puts the participant name here; Fast DDS uses it as the participant name.
    pub qos_profile_reference: Option<&'a str>,
}

/// OBJK_Topic_Binary.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct TopicBinary<'a> {
    /// Topic name.
    pub topic_name: &'a str,
    /// Type reference (eProsima: "type_identifier", unused).
    pub type_reference: Option<&'a str>,
    /// Type name; the C client always sends it and the Fast DDS agent requires it.
    pub type_name: Option<&'a str>,
}

/// OBJK_Publisher_Binary / OBJK_Subscriber_Binary.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct PubSubBinary<'a> {
    /// Name.
    pub name: Option<&'a str>,
    /// QoS, kept as the opaque rest of the blob: client and agent disagree on its layout (spec §16 #3).
    pub qos: Option<&'a [u8]>,
}

/// Bits of `qos_flags` in [`EndpointQos`].
pub struct QosFlags;

impl QosFlags {
    /// RELIABLE, else BEST_EFFORT.
    pub const RELIABLE: u16 = 0x0001;
    /// KEEP_LAST, else KEEP_ALL.
    pub const HISTORY_KEEP_LAST: u16 = 0x0002;
    /// EXCLUSIVE ownership.
    pub const OWNERSHIP_EXCLUSIVE: u16 = 0x0004;
    /// TRANSIENT_LOCAL durability (checked first).
    pub const DURABILITY_TRANSIENT_LOCAL: u16 = 0x0008;
    /// TRANSIENT durability.
    pub const DURABILITY_TRANSIENT: u16 = 0x0010;
    /// PERSISTENT durability; none of the three means VOLATILE.
    pub const DURABILITY_PERSISTENT: u16 = 0x0020;
}

/// OBJK_Endpoint_QosBinary, the QoS common to writers and readers.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct EndpointQos<'a> {
    /// [`QosFlags`] bits.
    pub qos_flags: u16,
    /// History depth.
    pub history_depth: Option<u16>,
    /// Deadline in milliseconds.
    pub deadline_msec: Option<u32>,
    /// Lifespan in milliseconds.
    pub lifespan_msec: Option<u32>,
    /// User data.
    pub user_data: Option<&'a [u8]>,
}

/// Writer QoS.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct DataWriterQos<'a> {
    /// Common part.
    pub base: EndpointQos<'a>,
    /// Ownership strength, `u32` as the agent reads it.
    pub ownership_strength: Option<u32>,
}

/// OBJK_DataWriter_Binary.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct DataWriterBinary<'a> {
    /// Topic of the writer (an object of the same client).
    pub topic_id: ObjectId,
    /// QoS; the C client always sends it.
    pub qos: Option<DataWriterQos<'a>>,
}

/// Reader QoS.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct DataReaderQos<'a> {
    /// Common part.
    pub base: EndpointQos<'a>,
    /// Time-based filter in milliseconds, `u32` as the agent reads it.
    pub timebasedfilter_msec: Option<u32>,
    /// Content filter expression (ignored by eProsima).
    pub contentbased_filter: Option<&'a str>,
}

/// OBJK_DataReader_Binary.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct DataReaderBinary<'a> {
    /// Topic of the reader.
    pub topic_id: ObjectId,
    /// QoS; the C client always sends it.
    pub qos: Option<DataReaderQos<'a>>,
}

/// OBJK_Requester_Binary and OBJK_Replier_Binary.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct RequesterBinary<'a> {
    /// Service name.
    pub service_name: &'a str,
    /// Request type name.
    pub request_type: &'a str,
    /// Reply type name.
    pub reply_type: &'a str,
    /// Request topic name (the C client always sets it).
    pub request_topic_name: Option<&'a str>,
    /// Reply topic name (the C client always sets it).
    pub reply_topic_name: Option<&'a str>,
}

fn read_opt_str<'a>(r: &mut Reader<'a>) -> Result<Option<&'a str>> {
    r.read_optional(|r| r.read_string())
}

fn write_opt_str(w: &mut Writer<'_>, v: Option<&str>) {
    w.write_optional(v.as_ref(), |w, s| w.write_string(s));
}

impl<'a> Decode<'a> for ParticipantBinary<'a> {
    fn decode(r: &mut Reader<'a>) -> Result<Self> {
        Ok(Self { domain_reference: read_opt_str(r)?, qos_profile_reference: read_opt_str(r)? })
    }
}

impl Encode for ParticipantBinary<'_> {
    fn encode(&self, w: &mut Writer<'_>) {
        write_opt_str(w, self.domain_reference);
        write_opt_str(w, self.qos_profile_reference);
    }
}

impl<'a> Decode<'a> for TopicBinary<'a> {
    fn decode(r: &mut Reader<'a>) -> Result<Self> {
        Ok(Self { topic_name: r.read_string()?, type_reference: read_opt_str(r)?, type_name: read_opt_str(r)? })
    }
}

impl Encode for TopicBinary<'_> {
    fn encode(&self, w: &mut Writer<'_>) {
        w.write_string(self.topic_name);
        write_opt_str(w, self.type_reference);
        write_opt_str(w, self.type_name);
    }
}

impl<'a> Decode<'a> for PubSubBinary<'a> {
    fn decode(r: &mut Reader<'a>) -> Result<Self> {
        let name = read_opt_str(r)?;
        let qos = r.read_optional(|r| Ok(r.take_rest()))?;
        Ok(Self { name, qos })
    }
}

impl Encode for PubSubBinary<'_> {
    fn encode(&self, w: &mut Writer<'_>) {
        write_opt_str(w, self.name);
        w.write_optional(self.qos.as_ref(), |w, q| w.write_bytes(q));
    }
}

impl<'a> Decode<'a> for EndpointQos<'a> {
    fn decode(r: &mut Reader<'a>) -> Result<Self> {
        Ok(Self {
            qos_flags: r.read_u16()?,
            history_depth: r.read_optional(|r| r.read_u16())?,
            deadline_msec: r.read_optional(|r| r.read_u32())?,
            lifespan_msec: r.read_optional(|r| r.read_u32())?,
            user_data: r.read_optional(|r| r.read_octet_seq())?,
        })
    }
}

impl Encode for EndpointQos<'_> {
    fn encode(&self, w: &mut Writer<'_>) {
        w.write_u16(self.qos_flags);
        w.write_optional(self.history_depth.as_ref(), |w, v| w.write_u16(*v));
        w.write_optional(self.deadline_msec.as_ref(), |w, v| w.write_u32(*v));
        w.write_optional(self.lifespan_msec.as_ref(), |w, v| w.write_u32(*v));
        w.write_optional(self.user_data.as_ref(), |w, v| w.write_octet_seq(v));
    }
}

impl<'a> Decode<'a> for DataWriterBinary<'a> {
    fn decode(r: &mut Reader<'a>) -> Result<Self> {
        let topic_id = r.read()?;
        let qos = r.read_optional(|r| {
            Ok(DataWriterQos { base: r.read()?, ownership_strength: r.read_optional(|r| r.read_u32())? })
        })?;
        Ok(Self { topic_id, qos })
    }
}

impl Encode for DataWriterBinary<'_> {
    fn encode(&self, w: &mut Writer<'_>) {
        self.topic_id.encode(w);
        w.write_optional(self.qos.as_ref(), |w, q| {
            q.base.encode(w);
            w.write_optional(q.ownership_strength.as_ref(), |w, v| w.write_u32(*v));
        });
    }
}

impl<'a> Decode<'a> for DataReaderBinary<'a> {
    fn decode(r: &mut Reader<'a>) -> Result<Self> {
        let topic_id = r.read()?;
        let qos = r.read_optional(|r| {
            Ok(DataReaderQos {
                base: r.read()?,
                timebasedfilter_msec: r.read_optional(|r| r.read_u32())?,
                contentbased_filter: read_opt_str(r)?,
            })
        })?;
        Ok(Self { topic_id, qos })
    }
}

impl Encode for DataReaderBinary<'_> {
    fn encode(&self, w: &mut Writer<'_>) {
        self.topic_id.encode(w);
        w.write_optional(self.qos.as_ref(), |w, q| {
            q.base.encode(w);
            w.write_optional(q.timebasedfilter_msec.as_ref(), |w, v| w.write_u32(*v));
            write_opt_str(w, q.contentbased_filter);
        });
    }
}

impl<'a> Decode<'a> for RequesterBinary<'a> {
    fn decode(r: &mut Reader<'a>) -> Result<Self> {
        Ok(Self {
            service_name: r.read_string()?,
            request_type: r.read_string()?,
            reply_type: r.read_string()?,
            request_topic_name: read_opt_str(r)?,
            reply_topic_name: read_opt_str(r)?,
        })
    }
}

impl Encode for RequesterBinary<'_> {
    fn encode(&self, w: &mut Writer<'_>) {
        w.write_string(self.service_name);
        w.write_string(self.request_type);
        w.write_string(self.reply_type);
        write_opt_str(w, self.request_topic_name);
        write_opt_str(w, self.reply_topic_name);
    }
}
