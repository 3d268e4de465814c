//! Payload types of the submessages (spec §6).

use crate::cdr::{Decode, Encode, Endianness, Error, Reader, Result, Seq, Writer};
use crate::object::{AgentRepresentation, ObjectVariant};
use crate::types::{
    codec_struct, BaseObjectReply, BaseObjectRequest, ResultStatus, SampleIdentity, Time, TransportLocator,
};

/// STATUS_AGENT: the answer to CREATE_CLIENT.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StatusAgent<'a> {
    /// Outcome; the client reads only this.
    pub result: ResultStatus,
    /// The agent's representation.
    pub agent: AgentRepresentation<'a>,
}

impl<'a> Decode<'a> for StatusAgent<'a> {
    fn decode(r: &mut Reader<'a>) -> Result<Self> {
        Ok(Self { result: r.read()?, agent: r.read()? })
    }
}

impl Encode for StatusAgent<'_> {
    fn encode(&self, w: &mut Writer<'_>) {
        self.result.encode(w);
        self.agent.encode(w);
    }
}

/// Creation mode carried by the CREATE flags (spec §11).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct CreationMode {
    /// Keep an existing object that matches.
    pub reuse: bool,
    /// Replace an existing object.
    pub replace: bool,
}

impl CreationMode {
    /// REUSE flag bit.
    pub const REUSE_FLAG: u8 = 0x02;
    /// REPLACE flag bit.
    pub const REPLACE_FLAG: u8 = 0x04;

    /// Mode from submessage flags.
    pub const fn from_flags(flags: u8) -> Self {
        Self { reuse: flags & Self::REUSE_FLAG != 0, replace: flags & Self::REPLACE_FLAG != 0 }
    }

    /// Flag bits of the mode.
    pub const fn flags(self) -> u8 {
        (if self.reuse { Self::REUSE_FLAG } else { 0 }) | (if self.replace { Self::REPLACE_FLAG } else { 0 })
    }
}

/// CREATE: object to create and how.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Create<'a> {
    /// Request id and id of the object to create.
    pub request: BaseObjectRequest,
    /// REUSE / REPLACE (in the flags on the wire).
    pub mode: CreationMode,
    /// What to create.
    pub variant: ObjectVariant<'a>,
}

/// GET_INFO bits.
pub mod info_mask {
    /// INFO_CONFIGURATION.
    pub const CONFIGURATION: u32 = 0x01;
    /// INFO_ACTIVITY.
    pub const ACTIVITY: u32 = 0x02;
}

/// GET_INFO: ping, discovery, liveliness probe.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct GetInfo {
    /// Request id and object.
    pub request: BaseObjectRequest,
    /// [`info_mask`] bits (ignored by eProsima's agent).
    pub info_mask: u32,
}
codec_struct!(GetInfo { request: BaseObjectRequest, info_mask: u32 });

impl GetInfo {
    /// Its little-endian CDR bytes at a 4-aligned position.
    pub const fn to_le_bytes(&self) -> [u8; 8] {
        let [r0, r1, o0, o1] = self.request.to_bytes();
        let [m0, m1, m2, m3] = self.info_mask.to_le_bytes();
        [r0, r1, o0, o1, m0, m1, m2, m3]
    }
}

/// Activity part of an INFO.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ActivityInfo<'a> {
    /// The agent's activity: availability and where it listens.
    Agent {
        /// Greater than 0 when available.
        availability: i16,
        /// Locators (empty when answered on the normal transport).
        address_seq: Seq<'a, TransportLocator<'a>>,
    },
    /// A writer's activity (defined, never sent by eProsima).
    DataWriter {
        /// Stream sequence number.
        stream_seq_num: i16,
        /// Sample sequence number.
        sample_seq_num: u64,
    },
    /// A reader's activity (defined, never sent by eProsima).
    DataReader {
        /// Highest acknowledged number.
        highest_acked_num: i16,
    },
}

impl<'a> Decode<'a> for ActivityInfo<'a> {
    fn decode(r: &mut Reader<'a>) -> Result<Self> {
        match r.read_u8()? {
            0x0D => Ok(Self::Agent { availability: r.read_i16()?, address_seq: r.read()? }),
            0x05 => Ok(Self::DataWriter { stream_seq_num: r.read_i16()?, sample_seq_num: r.read_u64()? }),
            0x06 => Ok(Self::DataReader { highest_acked_num: r.read_i16()? }),
            other => Err(Error::InvalidDiscriminator(other)),
        }
    }
}

impl Encode for ActivityInfo<'_> {
    fn encode(&self, w: &mut Writer<'_>) {
        match self {
            Self::Agent { availability, address_seq } => {
                w.write_u8(0x0D);
                w.write_i16(*availability);
                address_seq.encode(w);
            }
            Self::DataWriter { stream_seq_num, sample_seq_num } => {
                w.write_u8(0x05);
                w.write_i16(*stream_seq_num);
                w.write_u64(*sample_seq_num);
            }
            Self::DataReader { highest_acked_num } => {
                w.write_u8(0x06);
                w.write_i16(*highest_acked_num);
            }
        }
    }
}

/// INFO: answer to GET_INFO.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Info<'a> {
    /// Related request and result (implementation status 1: the agent knows the session).
    pub reply: BaseObjectReply,
    /// Configuration (the agent's representation).
    pub config: Option<ObjectVariant<'a>>,
    /// Activity.
    pub activity: Option<ActivityInfo<'a>>,
}

impl<'a> Decode<'a> for Info<'a> {
    fn decode(r: &mut Reader<'a>) -> Result<Self> {
        Ok(Self { reply: r.read()?, config: r.read_optional(|r| r.read())?, activity: r.read_optional(|r| r.read())? })
    }
}

impl Encode for Info<'_> {
    fn encode(&self, w: &mut Writer<'_>) {
        self.reply.encode(w);
        w.write_optional(self.config.as_ref(), |w, c| c.encode(w));
        w.write_optional(self.activity.as_ref(), |w, a| a.encode(w));
    }
}

/// Data formats carried in WRITE_DATA/DATA flags (mask 0x0E).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct DataFormat(pub u8);

impl DataFormat {
    /// Raw sample bytes: the only format both eProsima sides implement.
    pub const DATA: Self = Self(0x00);
    /// FORMAT_SAMPLE.
    pub const SAMPLE: Self = Self(0x02);
    /// FORMAT_DATA_SEQ.
    pub const DATA_SEQ: Self = Self(0x08);
    /// FORMAT_SAMPLE_SEQ.
    pub const SAMPLE_SEQ: Self = Self(0x0A);
    /// FORMAT_PACKED_SAMPLES.
    pub const PACKED_SAMPLES: Self = Self(0x0E);
    /// Mask of the format bits in the flags.
    pub const MASK: u8 = 0x0E;

    /// Format from submessage flags.
    pub const fn from_flags(flags: u8) -> Self {
        Self(flags & Self::MASK)
    }
}

/// WRITE_DATA (client → agent) or DATA (agent → client) in any format; the data is kept raw.
///
/// FORMAT_DATA to a datawriter/datareader: the serialized sample. Requester reply DATA starts with a
/// `BaseObjectRequest`; replier DATA and replier WRITE_DATA start with a [`SampleIdentity`] (spec §6.8).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct DataPayload<'a> {
    /// Request id and object (writer/reader/requester/replier).
    pub request: BaseObjectRequest,
    /// Format bits.
    pub format: DataFormat,
    /// Bytes after the 4-byte prefix.
    pub data: &'a [u8],
}

impl<'a> DataPayload<'a> {
    /// Splits a leading [`SampleIdentity`] off the data (replier traffic).
    pub fn split_sample_identity(&self) -> Result<(SampleIdentity, &'a [u8])> {
        // A fixed layout read under one bounds check (firmware size).
        let (identity, rest) = self.data.split_first_chunk().ok_or(Error::Truncated)?;
        Ok((SampleIdentity::from_le_bytes(identity), rest))
    }

    /// Splits a leading [`BaseObjectRequest`] off the data (requester reply DATA).
    pub fn split_base_request(&self) -> Result<(BaseObjectRequest, &'a [u8])> {
        let (base, rest) = self.data.split_first_chunk().ok_or(Error::Truncated)?;
        Ok((BaseObjectRequest::from_bytes(*base), rest))
    }
}

/// DataDeliveryControl (spec §15.2).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Hash)]
pub struct DataDeliveryControl {
    /// Samples to deliver; `0xFFFF` is unlimited.
    pub max_samples: u16,
    /// Seconds the delivery lasts; 0 is unlimited.
    pub max_elapsed_time: u16,
    /// Rate limit; 0 is unlimited.
    pub max_bytes_per_second: u16,
    /// Minimum milliseconds between samples (ignored by eProsima; honoured by us).
    pub min_pace_period: u16,
}

impl DataDeliveryControl {
    /// `max_samples` meaning "no limit".
    pub const UNLIMITED: u16 = 0xFFFF;
}
codec_struct!(DataDeliveryControl {
    max_samples: u16,
    max_elapsed_time: u16,
    max_bytes_per_second: u16,
    min_pace_period: u16
});

/// ReadSpecification of a READ_DATA.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct ReadSpecification<'a> {
    /// Stream the DATA should travel on; 0 with an all-zero control means "cancel".
    pub preferred_stream_id: u8,
    /// Requested format (only FORMAT_DATA is honoured).
    pub data_format: u8,
    /// Content filter (parsed, ignored by eProsima).
    pub content_filter_expression: Option<&'a str>,
    /// Delivery control; absent means one sample.
    pub delivery_control: Option<DataDeliveryControl>,
}

impl<'a> Decode<'a> for ReadSpecification<'a> {
    fn decode(r: &mut Reader<'a>) -> Result<Self> {
        Ok(Self {
            preferred_stream_id: r.read_u8()?,
            data_format: r.read_u8()?,
            content_filter_expression: r.read_optional(|r| r.read_string())?,
            delivery_control: r.read_optional(|r| r.read())?,
        })
    }
}

impl Encode for ReadSpecification<'_> {
    fn encode(&self, w: &mut Writer<'_>) {
        w.write_u8(self.preferred_stream_id);
        w.write_u8(self.data_format);
        w.write_optional(self.content_filter_expression.as_ref(), |w, s| w.write_string(s));
        w.write_optional(self.delivery_control.as_ref(), |w, c| c.encode(w));
    }
}

/// READ_DATA.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ReadData<'a> {
    /// Request id and reader/requester/replier.
    pub request: BaseObjectRequest,
    /// What to read and how.
    pub spec: ReadSpecification<'a>,
}

impl<'a> Decode<'a> for ReadData<'a> {
    fn decode(r: &mut Reader<'a>) -> Result<Self> {
        Ok(Self { request: r.read()?, spec: r.read()? })
    }
}

impl Encode for ReadData<'_> {
    fn encode(&self, w: &mut Writer<'_>) {
        self.request.encode(w);
        self.spec.encode(w);
    }
}

/// ACKNACK for a reliable stream (5 bytes).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Hash)]
pub struct AckNack {
    /// First sequence number not received.
    pub first_unacked_seq_num: u16,
    /// Bit i of the big-endian u16 ↔ `first_unacked + i` missing.
    pub nack_bitmap: [u8; 2],
    /// The reliable stream acknowledged, as numbered by its sender.
    pub stream_id: u8,
}

// After the first `u16` the rest is read as one array (the second `u16` of a HEARTBEAT is aligned there).

impl<'a> Decode<'a> for AckNack {
    fn decode(r: &mut Reader<'a>) -> Result<Self> {
        let first_unacked_seq_num = r.read_u16()?;
        let [b0, b1, stream_id] = r.read_array()?;
        Ok(Self { first_unacked_seq_num, nack_bitmap: [b0, b1], stream_id })
    }
}

impl Encode for AckNack {
    fn encode(&self, w: &mut Writer<'_>) {
        w.write_u16(self.first_unacked_seq_num);
        w.write_bytes(&self.nack_bitmap);
        w.write_u8(self.stream_id);
    }
}

impl AckNack {
    /// Its little-endian CDR bytes at a 2-aligned position.
    pub const fn to_le_bytes(&self) -> [u8; 5] {
        let [f0, f1] = self.first_unacked_seq_num.to_le_bytes();
        let [b0, b1] = self.nack_bitmap;
        [f0, f1, b0, b1, self.stream_id]
    }

    /// The bitmap as a u16 whose bit i ↔ `first_unacked + i`.
    pub const fn bitmap(&self) -> u16 {
        u16::from_be_bytes(self.nack_bitmap)
    }
}

impl AckNack {
    /// The ACKNACK of reliable stream `stream_id` saying what `bits` says (the bitmap goes big endian).
    pub const fn from_bits(bits: crate::reliable::AckNackBits, stream_id: u8) -> Self {
        Self { first_unacked_seq_num: bits.first_unacked.0, nack_bitmap: bits.nack_bitmap(), stream_id }
    }

    /// What it says, as the reliable engine reads it.
    pub const fn bits(&self) -> crate::reliable::AckNackBits {
        crate::reliable::AckNackBits::from_wire(self.first_unacked_seq_num, self.nack_bitmap)
    }
}

/// HEARTBEAT for a reliable stream (5 bytes).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Hash)]
pub struct Heartbeat {
    /// Oldest sequence number still held.
    pub first_unacked_seq_nr: u16,
    /// Newest sequence number sent.
    pub last_unacked_seq_nr: u16,
    /// The sender's reliable output stream.
    pub stream_id: u8,
}

impl<'a> Decode<'a> for Heartbeat {
    fn decode(r: &mut Reader<'a>) -> Result<Self> {
        let first_unacked_seq_nr = r.read_u16()?;
        let [l0, l1, stream_id] = r.read_array()?;
        let last_unacked_seq_nr = match r.endianness() {
            Endianness::Little => u16::from_le_bytes([l0, l1]),
            Endianness::Big => u16::from_be_bytes([l0, l1]),
        };
        Ok(Self { first_unacked_seq_nr, last_unacked_seq_nr, stream_id })
    }
}

impl Encode for Heartbeat {
    fn encode(&self, w: &mut Writer<'_>) {
        w.write_u16(self.first_unacked_seq_nr);
        w.write_u16(self.last_unacked_seq_nr);
        w.write_u8(self.stream_id);
    }
}

impl Heartbeat {
    /// Its little-endian CDR bytes at a 2-aligned position.
    pub const fn to_le_bytes(&self) -> [u8; 5] {
        let [f0, f1] = self.first_unacked_seq_nr.to_le_bytes();
        let [l0, l1] = self.last_unacked_seq_nr.to_le_bytes();
        [f0, f1, l0, l1, self.stream_id]
    }
}

/// TIMESTAMP_REPLY (24 bytes, in this order).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Hash)]
pub struct TimestampReply {
    /// Agent clock when replying.
    pub transmit_timestamp: Time,
    /// Agent clock when the TIMESTAMP was processed.
    pub receive_timestamp: Time,
    /// The client's transmit timestamp, echoed.
    pub originate_timestamp: Time,
}
// Only truncation can fail: read as an `Option` (firmware size, see `Reader::read_array_opt`).
impl<'a> Decode<'a> for TimestampReply {
    #[inline(always)]
    fn decode(r: &mut Reader<'a>) -> Result<Self> {
        Self::read_opt(r).ok_or(Error::Truncated)
    }
}

impl TimestampReply {
    fn read_opt(r: &mut Reader<'_>) -> Option<Self> {
        Some(Self {
            transmit_timestamp: Time::read_opt(r)?,
            receive_timestamp: Time::read_opt(r)?,
            originate_timestamp: Time::read_opt(r)?,
        })
    }
}

impl Encode for TimestampReply {
    fn encode(&self, w: &mut Writer<'_>) {
        self.transmit_timestamp.encode(w);
        self.receive_timestamp.encode(w);
        self.originate_timestamp.encode(w);
    }
}

#[cfg(test)]
mod acknack_tests {
    use super::AckNack;
    use crate::reliable::{AckNackBits, SeqNum};

    #[test]
    fn acknack_carries_the_bitmap_big_endian() {
        let bits = AckNackBits { first_unacked: SeqNum(0x0102), bitmap: 0b1000_0000_0000_0101 };
        let ack = AckNack::from_bits(bits, 0x80);
        assert_eq!(ack, AckNack { first_unacked_seq_num: 0x0102, nack_bitmap: [0x80, 0x05], stream_id: 0x80 });
        assert_eq!(ack.bits(), bits);
        assert_eq!(ack.bitmap(), bits.bitmap);
    }
}

#[cfg(test)]
mod le_bytes_tests {
    use super::{AckNack, GetInfo, Heartbeat};
    use crate::cdr::{Encode, Endianness, Writer};
    use crate::types::{BaseObjectReply, BaseObjectRequest, ObjectId, RequestId, ResultStatus, StatusCode, Time};

    /// What the CDR writer makes of `v`, little endian from a 4-aligned position.
    fn cdr<T: Encode>(v: &T) -> ([u8; 16], usize) {
        let mut buf = [0u8; 16];
        let mut w = Writer::new(&mut buf, Endianness::Little);
        v.encode(&mut w);
        let n = w.finish().unwrap();
        (buf, n)
    }

    fn same<T: Encode>(v: &T, bytes: &[u8]) {
        let (buf, n) = cdr(v);
        assert_eq!(&buf[..n], bytes);
    }

    #[test]
    fn times_read_as_fields_would() {
        use super::TimestampReply;
        use crate::cdr::{Decode, Error, Reader};
        let bytes: [u8; 29] = core::array::from_fn(|i| (i as u8).wrapping_mul(37));
        for endian in [Endianness::Little, Endianness::Big] {
            for pos in 0..6 {
                let by_fields = |r: &mut Reader<'_>| -> Result<[Time; 3], Error> {
                    let mut t = [Time::default(); 3];
                    for x in &mut t {
                        *x = Time { seconds: r.read_i32()?, nanoseconds: r.read_u32()? };
                    }
                    Ok(t)
                };
                let mut a = Reader::with_origin(&bytes, pos, 0, endian);
                let mut b = a;
                let expected = by_fields(&mut a);
                let got = TimestampReply::decode(&mut b)
                    .map(|t| [t.transmit_timestamp, t.receive_timestamp, t.originate_timestamp]);
                assert_eq!(got, expected, "{endian:?} {pos}");
                if got.is_ok() {
                    assert_eq!(a.position(), b.position());
                }
                let mut c = Reader::with_origin(&bytes[..pos + 9], pos, 0, endian);
                let mut d = c;
                let one = (|| Ok::<_, Error>(Time { seconds: d.read_i32()?, nanoseconds: d.read_u32()? }))();
                assert_eq!(Time::decode(&mut c), one, "{endian:?} {pos}");
            }
        }
    }

    #[test]
    fn data_splits_read_as_the_decoders_would() {
        use super::DataPayload;
        use crate::cdr::{Decode, Reader};
        use crate::types::SampleIdentity;
        let bytes: [u8; 27] = core::array::from_fn(|i| (i as u8).wrapping_mul(53).wrapping_add(7));
        for len in [0, 3, 4, 23, 24, 27] {
            let data = &bytes[..len];
            let d = DataPayload { request: BaseObjectRequest::default(), format: super::DataFormat::DATA, data };
            let mut r = Reader::new(data, Endianness::Little);
            let expected = SampleIdentity::decode(&mut r).map(|i| (i, r.rest()));
            assert_eq!(d.split_sample_identity(), expected);
            let mut r = Reader::new(data, Endianness::Little);
            let expected = BaseObjectRequest::decode(&mut r).map(|b| (b, r.rest()));
            assert_eq!(d.split_base_request(), expected);
            assert_eq!(expected.is_err(), len < 4);
        }
    }

    #[test]
    fn fixed_payloads_are_what_the_writer_makes() {
        let request = BaseObjectRequest { request_id: RequestId(0x1234), object_id: ObjectId([0x56, 0x78]) };
        same(&request, &request.to_bytes());
        let get = GetInfo { request, info_mask: 0x0A0B_0C0D };
        same(&get, &get.to_le_bytes());
        let reply = BaseObjectReply {
            related_request: request,
            result: ResultStatus { status: StatusCode(0x80), implementation_status: 1 },
        };
        same(&reply, &reply.to_bytes());
        for t in [Time { seconds: -2, nanoseconds: 999_999_999 }, Time { seconds: 0x0102_0304, nanoseconds: 5 }] {
            same(&t, &t.to_le_bytes());
        }
        let ack = AckNack { first_unacked_seq_num: 0xFFFE, nack_bitmap: [0x80, 0x01], stream_id: 0x80 };
        same(&ack, &ack.to_le_bytes());
        let hb = Heartbeat { first_unacked_seq_nr: 0x0102, last_unacked_seq_nr: 0xFF00, stream_id: 0x81 };
        same(&hb, &hb.to_le_bytes());
    }
}
