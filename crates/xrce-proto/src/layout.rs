//! Where things sit in a message, for writers that build messages in their own buffers (the agent's
//! outgoing DATA, packed best-effort messages, STATUS bodies queued on a reliable stream): the 4-byte
//! alignment of submessages, the layouts of a DATA / WRITE_DATA payload (plain sample, sample identity
//! first, related request first) with an emit-in-place writer, and a submessage encoded apart from its
//! message. With [`view`](crate::view), this is the wire knowledge other crates would otherwise repeat.
//!
//! * [`submessage_offset`]: where a submessage appended to a message starts (after its padding).
//! * [`SampleBody`], [`DataSubmessage`]: a DATA or WRITE_DATA, [`DataSubmessage::encoded_len`] and
//!   [`DataSubmessage::emit_into`] a caller's buffer.
//! * [`encode_submessage`]: one submessage, header included, aligned for the offset it will have.
//! * [`FragmentHead::from_header`], [`Guid::from_bytes`] / [`Guid::to_bytes`].

use crate::cdr::{Endianness, Error, Result, Writer};
use crate::header::MessageHeader;
use crate::submessage::{id, Submessage, SubmessageHeader};
use crate::types::{BaseObjectRequest, Guid, SampleIdentity};
use crate::view::{FragmentHead, RequestHead, SubmessageId};

/// Alignment of every submessage from the start of its message (spec §8.3.2; eProsima pads with it).
pub const SUBMESSAGE_ALIGNMENT: usize = 4;

/// Largest submessage: its header and the most a 16-bit length announces.
pub const MAX_SUBMESSAGE_LEN: usize = SubmessageHeader::SIZE + u16::MAX as usize;

/// Largest message made of one submessage (header with client key).
pub const MAX_SINGLE_SUBMESSAGE_MESSAGE_LEN: usize = MessageHeader::MAX_SIZE + MAX_SUBMESSAGE_LEN;

/// Where a submessage appended to a message of `message_len` bytes starts: `message_len` rounded up to
/// [`SUBMESSAGE_ALIGNMENT`]; the bytes in between are padding. (A mask rather than `cdr::padding`'s modulo:
/// the client calls it on every write, and the mask is 59 B less code in the footprint build.)
pub const fn submessage_offset(message_len: usize) -> usize {
    (message_len + SUBMESSAGE_ALIGNMENT - 1) & !(SUBMESSAGE_ALIGNMENT - 1)
}

/// What a DATA (agent → client) or a WRITE_DATA (client → agent) in FORMAT_DATA carries after its
/// [`BaseObjectRequest`] (spec §6.8; the request/reply layouts are eProsima's).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SampleBody<'a> {
    /// A datawriter's or datareader's serialized sample, and a requester's request.
    Plain(&'a [u8]),
    /// The sample identity first: a request delivered to a replier (DATA), or a replier's reply carrying
    /// back the identity of the request it answers (WRITE_DATA).
    WithIdentity {
        /// Identity of the request.
        identity: SampleIdentity,
        /// The request or reply.
        data: &'a [u8],
    },
    /// The related request first: a reply delivered to a requester, after the request id of the
    /// WRITE_DATA that carried its request and the requester's object id.
    Reply {
        /// The request answered.
        related: BaseObjectRequest,
        /// The reply.
        data: &'a [u8],
    },
}

impl SampleBody<'_> {
    /// Bytes the body takes.
    pub const fn encoded_len(&self) -> usize {
        match self {
            Self::Plain(d) => d.len(),
            Self::WithIdentity { data, .. } => SampleIdentity::SIZE + data.len(),
            Self::Reply { data, .. } => BaseObjectRequest::SIZE + data.len(),
        }
    }

    /// Writes the body at the start of `out` (for a payload a caller frames itself); returns its length.
    ///
    /// # Errors
    /// [`Error::BufferTooSmall`] with the size needed.
    pub fn emit_into(&self, out: &mut [u8]) -> Result<usize> {
        let mut w = Writer::new(out, Endianness::Little);
        self.write(&mut w);
        w.finish()
    }

    /// Writes the body at the writer's position (little endian, as both eProsima sides write it).
    fn write(&self, w: &mut Writer<'_>) {
        match self {
            Self::Plain(d) => w.write_bytes(d),
            Self::WithIdentity { identity, data } => {
                w.write(identity);
                w.write_bytes(data);
            }
            Self::Reply { related, data } => {
                w.write_bytes(&related.to_bytes());
                w.write_bytes(data);
            }
        }
    }
}

/// A DATA or WRITE_DATA submessage in FORMAT_DATA, little endian: the `Repr` of
/// [`RequestHead`] and its [`SampleBody`], written in place with [`Self::emit_into`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct DataSubmessage<'a> {
    /// [`SubmessageId::Data`] or [`SubmessageId::WriteData`].
    pub id: SubmessageId,
    /// DATA: the READ_DATA it answers; WRITE_DATA: the write itself.
    pub request: BaseObjectRequest,
    /// The sample.
    pub body: SampleBody<'a>,
}

impl<'a> DataSubmessage<'a> {
    /// A DATA (agent → client) answering the read `request`.
    pub const fn data(request: BaseObjectRequest, body: SampleBody<'a>) -> Self {
        Self { id: SubmessageId::Data, request, body }
    }

    /// A WRITE_DATA (client → agent).
    pub const fn write_data(request: BaseObjectRequest, body: SampleBody<'a>) -> Self {
        Self { id: SubmessageId::WriteData, request, body }
    }

    /// Its head: submessage header, request.
    pub const fn head(&self) -> RequestHead {
        RequestHead::data(self.id, self.request, self.body.encoded_len())
    }

    /// Whether the payload fits the header's 16-bit length (else it only travels fragmented, see
    /// [`RequestHead::to_bytes_fragmented`]).
    pub fn fits_one_submessage(&self) -> bool {
        self.head().payload_len().is_some()
    }

    /// Bytes of the whole submessage, header included.
    pub const fn encoded_len(&self) -> usize {
        self.head().encoded_len()
    }

    /// Writes the submessage at the start of `out`; returns its length ([`Self::encoded_len`]).
    ///
    /// # Errors
    /// [`Error::TooLong`] when the payload does not fit one submessage, [`Error::BufferTooSmall`]
    /// with the size needed when `out` is shorter. Bytes of `out` may have been written either way.
    pub fn emit_into(&self, out: &mut [u8]) -> Result<usize> {
        let head = self.head().to_bytes().ok_or(Error::TooLong(crate::cdr::LengthField::Submessage))?;
        let mut w = Writer::new(out, Endianness::Little);
        w.write_bytes(&head);
        self.body.write(&mut w);
        w.finish()
    }
}

/// Encodes `submessage`, header included, at the start of `out`, aligned as it will be once it sits at
/// byte `at` of its message (`at` 4-aligned: after the message header, or where
/// [`submessage_offset`] says); returns its length. The bytes are those a
/// [`MessageBuilder`](crate::MessageBuilder) would write there.
///
/// # Errors
/// As [`Submessage::encode`]: [`Error::BufferTooSmall`] with the size needed, or a value error.
pub fn encode_submessage(out: &mut [u8], at: usize, submessage: &Submessage<'_>, endian: Endianness) -> Result<usize> {
    // CDR alignment counts from the message start, `at` bytes before `out`'s first byte; the writer's
    // alignment is computed modulo 2^64, so a wrapped origin is exact.
    let mut w = Writer::with_origin(out, 0, 0usize.wrapping_sub(at), endian);
    submessage.encode(&mut w);
    w.finish()
}

impl FragmentHead {
    /// The FRAGMENT a submessage header announces; `None` for another submessage.
    pub const fn from_header(header: SubmessageHeader) -> Option<Self> {
        if header.id != id::FRAGMENT {
            return None;
        }
        Some(Self { last: header.flags & crate::submessage::flag::LAST_FRAGMENT != 0, chunk_len: header.length })
    }
}

impl Guid {
    /// Size of a GUID.
    pub const SIZE: usize = 16;

    /// A GUID from its 16 bytes: prefix (12), entity key (3), entity kind (1).
    pub const fn from_bytes(b: [u8; 16]) -> Self {
        let [p0, p1, p2, p3, p4, p5, p6, p7, p8, p9, p10, p11, k0, k1, k2, kind] = b;
        Self { prefix: [p0, p1, p2, p3, p4, p5, p6, p7, p8, p9, p10, p11], entity_key: [k0, k1, k2], entity_kind: kind }
    }

    /// The 16 bytes of the GUID.
    pub const fn to_bytes(&self) -> [u8; 16] {
        let [p0, p1, p2, p3, p4, p5, p6, p7, p8, p9, p10, p11] = self.prefix;
        let [k0, k1, k2] = self.entity_key;
        [p0, p1, p2, p3, p4, p5, p6, p7, p8, p9, p10, p11, k0, k1, k2, self.entity_kind]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::message::{self, MessageBuilder};
    use crate::submessage::{flag, ActivityInfo, Info};
    use crate::types::{BaseObjectReply, ObjectId, RequestId, ResultStatus, SequenceNumber, StatusCode, StreamId};
    use crate::{ClientKey, ObjectVariant};

    #[test]
    fn submessages_start_4_aligned() {
        let offsets: [usize; 9] = core::array::from_fn(submessage_offset);
        assert_eq!(offsets, [0, 4, 4, 4, 4, 8, 8, 8, 8]);
        assert_eq!(MAX_SUBMESSAGE_LEN, 65_539);
        assert_eq!(MAX_SINGLE_SUBMESSAGE_MESSAGE_LEN, 65_547);
    }

    /// Packet 25 of `request_reply_adder_udp.txt` (eProsima's agent): a request delivered to a replier.
    const REPLIER_DATA: [u8; 40] = [
        0x09, 0x01, 0x24, 0x00, 0x00, 0x0c, 0x00, 0x18, 0x01, 0x0f, 0x78, 0xfd, 0xb2, 0x56, 0xa0, 0x5d, 0x01, 0x00,
        0x00, 0x00, 0x00, 0x00, 0x01, 0x03, 0x00, 0x00, 0x00, 0x00, 0x03, 0x00, 0x00, 0x00, 0x02, 0x00, 0x00, 0x00,
        0x02, 0x00, 0x00, 0x00,
    ];
    /// Packet 33 of the same capture: a reply delivered to a requester.
    const REQUESTER_DATA: [u8; 20] =
        [0x09, 0x01, 0x10, 0x00, 0x00, 0x0c, 0x00, 0x17, 0x00, 0x0f, 0x00, 0x17, 0x04, 0x00, 0x00, 0x00, 0, 0, 0, 0];

    fn decode_data(sub: &[u8]) -> crate::submessage::DataPayload<'_> {
        let header = SubmessageHeader::from_bytes(*sub.first_chunk().unwrap());
        match Submessage::decode(header, sub, SubmessageHeader::SIZE, sub.len()).unwrap() {
            Submessage::Data(d) | Submessage::WriteData(d) => d,
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn replier_data_emits_the_capture_bytes() {
        let payload = decode_data(&REPLIER_DATA);
        let (identity, data) = payload.split_sample_identity().unwrap();
        assert_eq!(identity.sequence_number, SequenceNumber { high: 0, low: 3 });
        let body = SampleBody::WithIdentity { identity, data };
        let mut alone = [0u8; 32];
        assert_eq!(body.emit_into(&mut alone), Ok(32));
        assert_eq!(alone, REPLIER_DATA[8..]);
        let sub = DataSubmessage::data(payload.request, body);
        assert_eq!(sub.encoded_len(), REPLIER_DATA.len());
        let mut out = [0xEE; 48];
        assert_eq!(sub.emit_into(&mut out), Ok(REPLIER_DATA.len()));
        assert_eq!(out[..REPLIER_DATA.len()], REPLIER_DATA);
    }

    #[test]
    fn requester_data_emits_the_capture_bytes() {
        let payload = decode_data(&REQUESTER_DATA);
        let (related, data) = payload.split_base_request().unwrap();
        assert_eq!(related, BaseObjectRequest { request_id: RequestId(0x0f), object_id: ObjectId([0x00, 0x17]) });
        let sub = DataSubmessage::data(payload.request, SampleBody::Reply { related, data });
        let mut out = [0xEE; 20];
        assert_eq!(sub.emit_into(&mut out), Ok(20));
        assert_eq!(out, REQUESTER_DATA);
    }

    #[test]
    fn plain_write_data_decodes_back_and_short_buffers_say_what_they_need() {
        let request = BaseObjectRequest { request_id: RequestId(0x0e), object_id: ObjectId([0x00, 0x17]) };
        let body = SampleBody::Plain(&[1, 0, 0, 0, 1, 0, 0, 0]);
        assert_eq!(body.emit_into(&mut [0u8; 7]), Err(Error::BufferTooSmall { needed: 8 }));
        let sub = DataSubmessage::write_data(request, body);
        let mut out = [0u8; 16];
        assert_eq!(sub.emit_into(&mut out), Ok(16));
        // Packet 21 of the capture, after its message header.
        assert_eq!(out, [0x07, 0x01, 0x0c, 0x00, 0x00, 0x0e, 0x00, 0x17, 1, 0, 0, 0, 1, 0, 0, 0]);
        assert_eq!(decode_data(&out).data, &[1, 0, 0, 0, 1, 0, 0, 0]);
        assert_eq!(sub.emit_into(&mut out[..15]), Err(Error::BufferTooSmall { needed: 16 }));
    }

    #[test]
    fn oversized_data_is_refused() {
        static BIG: [u8; 65_532] = [0; 65_532];
        let fits = DataSubmessage::data(BaseObjectRequest::default(), SampleBody::Plain(&BIG[..65_531]));
        assert!(fits.fits_one_submessage());
        let big = DataSubmessage::data(BaseObjectRequest::default(), SampleBody::Plain(&BIG));
        assert!(!big.fits_one_submessage());
        assert_eq!(big.emit_into(&mut [0u8; 8]), Err(Error::TooLong(crate::cdr::LengthField::Submessage)));
    }

    /// An INFO with a datawriter's activity has a u64: its alignment depends on where the submessage sits.
    #[test]
    fn a_submessage_alone_has_the_bytes_it_has_in_its_message() {
        let info = Submessage::Info(Info {
            reply: BaseObjectReply {
                related_request: BaseObjectRequest::default(),
                result: ResultStatus::new(StatusCode::OK),
            },
            config: None::<ObjectVariant<'_>>,
            activity: Some(ActivityInfo::DataWriter { stream_seq_num: 1, sample_seq_num: 0x0102_0304_0506_0708 }),
        });
        for session_id in [0x01, 0x81] {
            let header = MessageHeader::new(session_id, StreamId::NONE, 0, ClientKey::INVALID);
            let mut msg = [0u8; 64];
            let mut b = MessageBuilder::new(&mut msg, &header).unwrap();
            b.push(&info, Endianness::Little).unwrap();
            let n = b.finish();
            let mut alone = [0u8; 64];
            let m = encode_submessage(&mut alone, header.size(), &info, Endianness::Little).unwrap();
            assert_eq!(alone[..m], msg[header.size()..n], "session {session_id:#x}");
            assert_eq!(
                encode_submessage(&mut alone[..m - 1], header.size(), &info, Endianness::Little),
                Err(Error::BufferTooSmall { needed: m })
            );
        }
        let (_, mut subs) =
            message::parse(&[0x81, 0, 0, 0, id::FRAGMENT, flag::ENDIANNESS | flag::LAST_FRAGMENT, 1, 0, 9]).unwrap();
        let raw = subs.next().unwrap().unwrap();
        assert_eq!(FragmentHead::from_header(raw.header), Some(FragmentHead { last: true, chunk_len: 1 }));
        assert_eq!(FragmentHead::from_header(SubmessageHeader { id: id::DATA, flags: 3, length: 1 }), None);
    }

    #[test]
    fn guid_bytes_round_trip_in_wire_order() {
        let bytes: [u8; 16] = core::array::from_fn(|i| i as u8);
        let g = Guid::from_bytes(bytes);
        assert_eq!((g.prefix[11], g.entity_key, g.entity_kind), (11, [12, 13, 14], 15));
        assert_eq!(g.to_bytes(), bytes);
        let identity = SampleIdentity { writer_guid: g, sequence_number: SequenceNumber { high: 0, low: 7 } };
        let mut cdr = [0u8; SampleIdentity::SIZE];
        Writer::new(&mut cdr, Endianness::Little).write(&identity);
        assert_eq!(cdr[..Guid::SIZE], bytes);
    }
}
