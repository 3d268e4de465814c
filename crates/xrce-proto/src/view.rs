//! Submessages as they sit in a buffer (the `Packet` half of smoltcp's `Packet` + `Repr`): the few fixed
//! layouts the agent and the client read or write in place, on the hot path, without decoding a whole
//! [`Submessage`](crate::Submessage). Every byte offset of these layouts lives here, so no other crate
//! needs to know one.
//!
//! * [`SubmessageId`]: the ids as an enum.
//! * [`RequestHead`]: the 8 bytes that start most submessages: header, request id, object id; before an
//!   object's data in WRITE_DATA (client → agent) and DATA (agent → client) (spec §6.7, §6.8, FORMAT_DATA).
//! * [`read_spec_bytes`], [`StringCreate`]: the rest of a READ_DATA, and a CREATE by XML or reference
//!   around its string.
//! * [`FragmentHead`]: the header of a FRAGMENT, whose length and last flag a writer fills in as the chunk
//!   grows (spec §6.10).
//! * [`write_data_object`]: the object a WRITE_DATA payload writes to; [`submessage_id`]: the id of an
//!   encoded submessage; [`mark_reuse`]: a CREATE made REUSE in place.

use crate::object::{format as object_format, EntityLink};
use crate::submessage::{flag, id, DataDeliveryControl, SubmessageHeader};
use crate::types::{BaseObjectRequest, ObjectId, RequestId};

/// Submessage ids (spec §3).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[repr(u8)]
pub enum SubmessageId {
    /// CREATE_CLIENT.
    CreateClient = id::CREATE_CLIENT,
    /// CREATE.
    Create = id::CREATE,
    /// GET_INFO.
    GetInfo = id::GET_INFO,
    /// DELETE.
    Delete = id::DELETE,
    /// STATUS_AGENT.
    StatusAgent = id::STATUS_AGENT,
    /// STATUS.
    Status = id::STATUS,
    /// INFO.
    Info = id::INFO,
    /// WRITE_DATA.
    WriteData = id::WRITE_DATA,
    /// READ_DATA.
    ReadData = id::READ_DATA,
    /// DATA.
    Data = id::DATA,
    /// ACKNACK.
    AckNack = id::ACKNACK,
    /// HEARTBEAT.
    Heartbeat = id::HEARTBEAT,
    /// RESET.
    Reset = id::RESET,
    /// FRAGMENT.
    Fragment = id::FRAGMENT,
    /// TIMESTAMP.
    Timestamp = id::TIMESTAMP,
    /// TIMESTAMP_REPLY.
    TimestampReply = id::TIMESTAMP_REPLY,
}

impl SubmessageId {
    /// The id of a wire value, if it is one.
    pub const fn from_u8(v: u8) -> Option<Self> {
        Some(match v {
            id::CREATE_CLIENT => Self::CreateClient,
            id::CREATE => Self::Create,
            id::GET_INFO => Self::GetInfo,
            id::DELETE => Self::Delete,
            id::STATUS_AGENT => Self::StatusAgent,
            id::STATUS => Self::Status,
            id::INFO => Self::Info,
            id::WRITE_DATA => Self::WriteData,
            id::READ_DATA => Self::ReadData,
            id::DATA => Self::Data,
            id::ACKNACK => Self::AckNack,
            id::HEARTBEAT => Self::Heartbeat,
            id::RESET => Self::Reset,
            id::FRAGMENT => Self::Fragment,
            id::TIMESTAMP => Self::Timestamp,
            id::TIMESTAMP_REPLY => Self::TimestampReply,
            _ => return None,
        })
    }

    /// The wire value.
    pub const fn as_u8(self) -> u8 {
        self as u8
    }
}

impl BaseObjectRequest {
    /// Encoded size: request id (big endian, as the spec's octet pair) and object id.
    pub const SIZE: usize = 4;

    /// The four bytes on the wire.
    pub const fn to_bytes(self) -> [u8; 4] {
        let r = self.request_id.0.to_be_bytes();
        [r[0], r[1], self.object_id.0[0], self.object_id.0[1]]
    }

    /// Reads the first four bytes of `b`, if there are four.
    pub fn from_prefix(b: &[u8]) -> Option<Self> {
        match *b {
            [r0, r1, o0, o1, ..] => {
                Some(Self { request_id: RequestId(u16::from_be_bytes([r0, r1])), object_id: ObjectId([o0, o1]) })
            }
            _ => None,
        }
    }
}

/// The head of a submessage whose payload starts with a [`BaseObjectRequest`] (CREATE, DELETE, WRITE_DATA,
/// READ_DATA, DATA, ...) and goes on for `body_len` more bytes, little endian as both eProsima sides send it.
/// For WRITE_DATA and DATA the body is the object's data (FORMAT_DATA).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RequestHead {
    /// The submessage.
    pub id: SubmessageId,
    /// Flags besides the byte order (CREATE: the REUSE / REPLACE mode; data: the format, 0).
    pub flags: u8,
    /// WRITE_DATA, CREATE, ...: the request itself; DATA: the READ_DATA it answers.
    pub request: BaseObjectRequest,
    /// Payload bytes after the request.
    pub body_len: usize,
}

impl RequestHead {
    /// Encoded size of the head.
    pub const SIZE: usize = SubmessageHeader::SIZE + BaseObjectRequest::SIZE;

    /// A WRITE_DATA (client) or DATA (agent) head for `body_len` bytes of data.
    pub const fn data(id: SubmessageId, request: BaseObjectRequest, body_len: usize) -> Self {
        Self { id, flags: 0, request, body_len }
    }

    /// Head and body.
    pub const fn encoded_len(&self) -> usize {
        Self::SIZE + self.body_len
    }

    /// The submessage's payload length, if it fits the header's 16 bits.
    pub fn payload_len(&self) -> Option<u16> {
        u16::try_from(BaseObjectRequest::SIZE + self.body_len).ok()
    }

    /// The head's bytes; `None` when the payload is too long for one submessage.
    pub fn to_bytes(&self) -> Option<[u8; Self::SIZE]> {
        Some(self.with_length(self.payload_len()?))
    }

    /// The head's bytes with length 0 when the payload is too long for the header: eProsima's convention for
    /// a WRITE_DATA that only travels fragmented (its reassembled length is known from the fragments).
    pub fn to_bytes_fragmented(&self) -> [u8; Self::SIZE] {
        self.with_length(self.payload_len().unwrap_or(0))
    }

    /// The head's bytes with the submessage length `length` as given.
    const fn with_length(&self, length: u16) -> [u8; Self::SIZE] {
        let [l0, l1] = length.to_le_bytes();
        let [r0, r1, o0, o1] = self.request.to_bytes();
        [self.id.as_u8(), self.flags | flag::ENDIANNESS, l0, l1, r0, r1, o0, o1]
    }
}

/// The READ_DATA body after its request (`ReadSpecification`, spec §6.6): the stream to deliver on, format
/// FORMAT_DATA, no content filter, and the delivery control if any.
pub fn read_spec_bytes(data_stream: u8, control: Option<&DataDeliveryControl>) -> ([u8; 12], usize) {
    let head = [data_stream, 0, 0, u8::from(control.is_some())];
    let Some(c) = control else { return ([head[0], head[1], head[2], head[3], 0, 0, 0, 0, 0, 0, 0, 0], 4) };
    let [a0, a1] = c.max_samples.to_le_bytes();
    let [b0, b1] = c.max_elapsed_time.to_le_bytes();
    let [c0, c1] = c.max_bytes_per_second.to_le_bytes();
    let [d0, d1] = c.min_pace_period.to_le_bytes();
    ([head[0], head[1], head[2], head[3], a0, a1, b0, b1, c0, c1, d0, d1], 12)
}

/// A CREATE of an entity given as an XML string or a reference (spec §7.7.3), laid out around the string so
/// that a writer sends the string from where it is: [`Self::head`] (submessage header, request, kind,
/// representation, string length), the string's bytes, then [`Self::tail`] (its NUL, padding and the link).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct StringCreate {
    /// Request id and the object to create.
    pub request: BaseObjectRequest,
    /// REUSE / REPLACE flags.
    pub mode: u8,
    /// XML (`true`) or reference.
    pub xml: bool,
    /// Bytes of the string, without a NUL.
    pub text_len: usize,
    /// The participant's domain or the parent.
    pub link: EntityLink,
}

/// The bytes after a [`StringCreate`]'s string.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct StringCreateTail {
    bytes: [u8; 4],
    len: usize,
}

impl StringCreateTail {
    /// The bytes to send.
    pub fn as_bytes(&self) -> &[u8] {
        self.bytes.get(..self.len).unwrap_or(&[])
    }
}

impl StringCreate {
    /// Head bytes: submessage header, request, kind, representation (2 bytes of padding), string length.
    pub const HEAD: usize = RequestHead::SIZE + 8;

    /// Payload offset right after the string's NUL.
    const fn after_string(&self) -> usize {
        BaseObjectRequest::SIZE + 8 + self.text_len + 1
    }

    /// What follows the string: its NUL, then the link (a domain id is 2-aligned).
    pub fn tail(&self) -> StringCreateTail {
        // bytes[0] is the string's NUL.
        let (bytes, len) = match self.link {
            EntityLink::Domain(d) => {
                let [lo, hi] = d.to_le_bytes();
                if self.after_string() % 2 == 1 {
                    ([0, 0, lo, hi], 4)
                } else {
                    ([0, lo, hi, 0], 3)
                }
            }
            EntityLink::Parent(p) => ([0, p.0[0], p.0[1], 0], 3),
        };
        StringCreateTail { bytes, len }
    }

    /// Bytes of [`Self::tail`].
    const fn tail_len(&self) -> usize {
        match self.link {
            EntityLink::Domain(_) => 3 + self.after_string() % 2,
            EntityLink::Parent(_) => 3,
        }
    }

    /// The whole submessage's size.
    pub const fn encoded_len(&self) -> usize {
        Self::HEAD + self.text_len + self.tail_len()
    }

    /// The head; `None` when the payload does not fit a submessage length or the string a CDR length.
    pub fn head(&self) -> Option<[u8; Self::HEAD]> {
        self.head_with_tail(&self.tail())
    }

    /// [`head`](Self::head) and [`tail`](Self::tail), the tail worked out once (firmware size).
    pub fn parts(&self) -> Option<([u8; Self::HEAD], StringCreateTail)> {
        let tail = self.tail();
        Some((self.head_with_tail(&tail)?, tail))
    }

    fn head_with_tail(&self, tail: &StringCreateTail) -> Option<[u8; Self::HEAD]> {
        let body_len = Self::HEAD + self.text_len + tail.len - RequestHead::SIZE;
        let h = RequestHead { id: SubmessageId::Create, flags: self.mode, request: self.request, body_len };
        let [h0, h1, h2, h3, h4, h5, h6, h7] = h.to_bytes()?;
        let format = if self.xml { object_format::AS_XML_STRING } else { object_format::BY_REFERENCE };
        let kind = self.request.object_id.kind() as u8;
        let [n0, n1, n2, n3] = u32::try_from(self.text_len + 1).ok()?.to_le_bytes();
        Some([h0, h1, h2, h3, h4, h5, h6, h7, kind, format, 0, 0, n0, n1, n2, n3])
    }
}

/// The id of the submessage `submessage` starts with (header included), if known.
pub fn submessage_id(submessage: &[u8]) -> Option<SubmessageId> {
    submessage.first().copied().and_then(SubmessageId::from_u8)
}

/// The object a WRITE_DATA writes to, from its submessage id and payload (or from a reassembled fragmented
/// message, which starts with the WRITE_DATA's header: use [`write_data_object_in_message`]).
pub fn write_data_object(submessage_id: u8, payload: &[u8]) -> Option<ObjectId> {
    if submessage_id != id::WRITE_DATA {
        return None;
    }
    BaseObjectRequest::from_prefix(payload).map(|r| r.object_id)
}

/// The object of the WRITE_DATA a (reassembled) message body starts with: submessage header, then payload.
pub fn write_data_object_in_message(message: &[u8]) -> Option<ObjectId> {
    let (&sub_id, _) = message.split_first()?;
    write_data_object(sub_id, message.get(SubmessageHeader::SIZE..)?)
}

/// Marks the CREATE whose bytes (header included) `submessage` holds REUSE, in place (an entity created again
/// after the agent lost the session, kept if it still has it); false, nothing changed, for anything else.
pub fn mark_reuse(submessage: &mut [u8]) -> bool {
    match submessage {
        [sub_id, flags, _, _, ..] if *sub_id == id::CREATE => {
            *flags |= crate::submessage::CreationMode::REUSE_FLAG;
            true
        }
        _ => false,
    }
}

/// The header of a FRAGMENT submessage. A writer that fills a fragment chunk by chunk writes it with the
/// length known so far and patches it in place ([`FragmentHead::set_in`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FragmentHead {
    /// The fragment completes the message.
    pub last: bool,
    /// Bytes of the message in this fragment.
    pub chunk_len: u16,
}

impl FragmentHead {
    /// Encoded size.
    pub const SIZE: usize = SubmessageHeader::SIZE;

    /// The header's bytes (little endian).
    pub const fn to_bytes(self) -> [u8; Self::SIZE] {
        let flags = if self.last { flag::ENDIANNESS | flag::LAST_FRAGMENT } else { flag::ENDIANNESS };
        SubmessageHeader { id: id::FRAGMENT, flags, length: self.chunk_len }.to_bytes()
    }

    /// The FRAGMENT header `submessage` starts with; `None` for another submessage or too few bytes.
    pub fn parse(submessage: &[u8]) -> Option<Self> {
        let (&b, _) = submessage.split_first_chunk::<{ Self::SIZE }>()?;
        let h = SubmessageHeader::from_bytes(b);
        (h.id == id::FRAGMENT).then_some(Self { last: h.flags & flag::LAST_FRAGMENT != 0, chunk_len: h.length })
    }

    /// Writes the header at the start of `buf`; false (nothing written) when `buf` is shorter than it.
    pub fn set_in(self, buf: &mut [u8]) -> bool {
        match buf.first_chunk_mut::<{ Self::SIZE }>() {
            Some(dst) => {
                *dst = self.to_bytes();
                true
            }
            None => false,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::submessage::Submessage;
    use crate::{message, MessageHeader, ObjectKind, StreamId};

    #[test]
    fn ids_round_trip_and_unknown_ids_are_none() {
        for v in 0..=15u8 {
            assert_eq!(SubmessageId::from_u8(v).map(SubmessageId::as_u8), Some(v));
        }
        assert_eq!(SubmessageId::from_u8(16), None);
        assert_eq!(SubmessageId::from_u8(0xff), None);
    }

    #[test]
    fn data_head_is_what_the_decoder_reads() {
        let request = BaseObjectRequest { request_id: RequestId(0x0102), object_id: ObjectId([0x00, 0x15]) };
        let head = RequestHead::data(SubmessageId::WriteData, request, 3);
        let mut msg = [0u8; 64];
        let mh = MessageHeader { session_id: 0x81, stream_id: StreamId(1), sequence_nr: 0, client_key: None };
        let n = mh.encode(&mut msg).unwrap();
        let end = n + head.encoded_len();
        msg[n..n + RequestHead::SIZE].copy_from_slice(&head.to_bytes().unwrap());
        msg[n + RequestHead::SIZE..end].copy_from_slice(&[7, 8, 9]);
        let (_, mut subs) = message::parse(&msg[..end]).unwrap();
        match subs.next().unwrap().unwrap().decode().unwrap() {
            Submessage::WriteData(w) => {
                assert_eq!(w.request, request);
                assert_eq!(w.data, &[7, 8, 9]);
            }
            other => panic!("{other:?}"),
        }
        assert_eq!(write_data_object_in_message(&msg[n..end]), Some(ObjectId([0x00, 0x15])));
        assert_eq!(write_data_object(id::DATA, &msg[n + 4..end]), None);
    }

    #[test]
    fn data_head_refuses_or_zeroes_an_oversized_length() {
        let head = RequestHead::data(SubmessageId::Data, BaseObjectRequest::default(), 70_000);
        assert_eq!(head.to_bytes(), None);
        assert_eq!(&head.to_bytes_fragmented()[2..4], &[0, 0]);
    }

    /// Encodes `parts` as one submessage after a message header and decodes it back.
    fn decode_one<'b>(buf: &'b mut [u8], parts: &[&[u8]]) -> Submessage<'b> {
        let mh = MessageHeader { session_id: 0x81, stream_id: StreamId(1), sequence_nr: 0, client_key: None };
        let mut n = mh.encode(buf).unwrap();
        for p in parts {
            buf[n..n + p.len()].copy_from_slice(p);
            n += p.len();
        }
        let (_, mut subs) = message::parse(&buf[..n]).unwrap();
        subs.next().unwrap().unwrap().decode().unwrap()
    }

    #[test]
    fn string_creates_decode_with_both_links_and_every_padding() {
        use crate::object::{ObjectVariant, Representation};
        use crate::ObjectKind;
        for text in ["<dds/>", "<dds/>x", "ref"] {
            for (kind, link) in [
                (ObjectKind::Participant, EntityLink::Domain(42)),
                (ObjectKind::Topic, EntityLink::Parent(ObjectId::new(1, ObjectKind::Participant))),
            ] {
                let request = BaseObjectRequest { request_id: RequestId(9), object_id: ObjectId::new(3, kind) };
                let c = StringCreate { request, mode: 0x02, xml: text.starts_with('<'), text_len: text.len(), link };
                let mut buf = [0u8; 96];
                let head = c.head().unwrap();
                let sub = decode_one(&mut buf, &[&head, text.as_bytes(), c.tail().as_bytes()]);
                let Submessage::Create(create) = sub else { panic!("{sub:?}") };
                assert_eq!(create.request, request);
                let ObjectVariant::Entity(e) = create.variant else { panic!("{create:?}") };
                assert_eq!((e.kind, e.link), (kind, link), "{text}");
                let got = match e.representation {
                    Representation::Xml(s) | Representation::Reference(s) => s,
                    other => panic!("{other:?}"),
                };
                assert_eq!(got, text);
                assert_eq!(c.encoded_len(), head.len() + text.len() + c.tail().as_bytes().len());
            }
        }
    }

    #[test]
    fn read_spec_decodes_with_and_without_control() {
        let request =
            BaseObjectRequest { request_id: RequestId(5), object_id: ObjectId::new(1, ObjectKind::DataReader) };
        let control =
            DataDeliveryControl { max_samples: 7, max_elapsed_time: 1, max_bytes_per_second: 2, min_pace_period: 3 };
        for ctl in [None, Some(&control)] {
            let (spec, n) = read_spec_bytes(0x80, ctl);
            let head = RequestHead { id: SubmessageId::ReadData, flags: 0, request, body_len: n }.to_bytes().unwrap();
            let mut buf = [0u8; 64];
            let sub = decode_one(&mut buf, &[&head, &spec[..n]]);
            let Submessage::ReadData(r) = sub else { panic!("{sub:?}") };
            assert_eq!(r.request, request);
            assert_eq!(r.spec.preferred_stream_id, 0x80);
            assert_eq!(r.spec.delivery_control, ctl.copied());
        }
    }

    #[test]
    fn mark_reuse_sets_the_create_flag_only() {
        let mut create = [id::CREATE, flag::ENDIANNESS, 0, 0, 1, 2];
        assert!(mark_reuse(&mut create));
        assert_eq!(create, [id::CREATE, 0x03, 0, 0, 1, 2]);
        let mut data = [id::WRITE_DATA, flag::ENDIANNESS, 0, 0];
        assert!(!mark_reuse(&mut data));
        assert_eq!(data[1], flag::ENDIANNESS);
        assert!(!mark_reuse(&mut [id::CREATE, 1]));
    }

    #[test]
    fn fragment_head_sets_last_and_length() {
        let mut b = [0u8; 4];
        assert!(FragmentHead { last: false, chunk_len: 0x0203 }.set_in(&mut b));
        assert_eq!(b, [id::FRAGMENT, 0x01, 0x03, 0x02]);
        assert!(FragmentHead { last: true, chunk_len: 5 }.set_in(&mut b));
        assert_eq!(b, [id::FRAGMENT, 0x03, 5, 0]);
        assert!(!FragmentHead { last: true, chunk_len: 5 }.set_in(&mut b[..3]));
        assert_eq!(FragmentHead::parse(&b), Some(FragmentHead { last: true, chunk_len: 5 }));
        assert_eq!(FragmentHead::parse(&b[..3]), None);
        assert_eq!(FragmentHead::parse(&[id::DATA, 1, 0, 0]), None);
    }
}
