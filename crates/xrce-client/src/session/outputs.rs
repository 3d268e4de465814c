//! Writing into output streams: entity creation (XML, reference, binary), deletion, read requests, data.
//!
//! Every `buffer_*` function writes one submessage into a stream and returns its request id; nothing is sent
//! until the session flushes the streams. Submessages are written as lists of byte parts so that a large XML
//! string or sample is copied once, straight into the stream (and fragmented there when it does not fit one
//! message), without any intermediate buffer.

use crate::error::{Error, Result};
use crate::object::{QoS, REPLACE, REUSE};
use crate::stream::{OutputBestEffort, OutputReliable};
use xrce_proto::cdr::{Endianness, Writer};
use xrce_proto::object::{
    BinaryObject, DataReaderBinary, DataReaderQos, DataWriterBinary, DataWriterQos, EntityLink, EntityVariant,
    ParticipantBinary, PubSubBinary, RequesterBinary, TopicBinary,
};
use xrce_proto::submessage::DataDeliveryControl;
use xrce_proto::view::{self, RequestHead, StringCreate, SubmessageId};
use xrce_proto::{
    BaseObjectRequest, ObjectId, Representation, RequestId, SampleIdentity, StreamId, StreamKind, SubmessageHeader,
};

/// First request id the C client hands out (1–9 are reserved).
pub(crate) const FIRST_REQUEST_ID: u16 = 10;

/// The output side of a session, lent to callbacks so they can answer (e.g. a replier writing its reply from
/// `on_request`), and used by [`crate::WriteAccess`].
#[derive(Debug)]
pub struct Outputs<'s, 'a> {
    pub(crate) last_request_id: &'s mut u16,
    pub(crate) best_effort: &'s mut [Option<OutputBestEffort<'a>>],
    pub(crate) reliable: &'s mut [Option<OutputReliable<'a>>],
}

/// Space reserved in an output stream for a sample serialized in place (`uxr_prepare_output_stream`).
#[derive(Debug)]
pub struct Prepared<'s> {
    /// Request id of the WRITE_DATA.
    pub request_id: u16,
    buf: &'s mut [u8],
}

impl Prepared<'_> {
    /// The `data_size` bytes to serialize into, zero-filled; all of them are sent whatever is written.
    pub fn buffer(&mut self) -> &mut [u8] {
        self.buf
    }
}

fn mode_flags(mode: u8) -> u8 {
    mode & (REUSE | REPLACE)
}

/// The head of submessage `id` for `object`'s request `request_id`, with `body_len` payload bytes after it.
fn head(id: SubmessageId, flags: u8, request_id: u16, object: ObjectId, body_len: usize) -> Result<[u8; 8]> {
    let request = BaseObjectRequest { request_id: RequestId(request_id), object_id: object };
    RequestHead { id, flags, request, body_len }.to_bytes().ok_or(Error::TooLarge)
}

fn encode_sample_identity(s: &SampleIdentity) -> [u8; 24] {
    let mut out = [0u8; 24];
    let mut w = Writer::new(&mut out, Endianness::Little);
    w.write(s);
    out
}

impl<'s, 'a> Outputs<'s, 'a> {
    /// The same outputs for a shorter borrow, for the functions taking `self` by value
    /// ([`prepare_output_stream`](Self::prepare_output_stream)) when only `&mut Outputs` is at hand (a callback).
    pub fn reborrow(&mut self) -> Outputs<'_, 'a> {
        Outputs { last_request_id: self.last_request_id, best_effort: self.best_effort, reliable: self.reliable }
    }

    /// Hands out the next request id (10, 11, … 65535, 10, …).
    fn next_request_id(&mut self) -> u16 {
        let next = request_after(*self.last_request_id);
        *self.last_request_id = next;
        next
    }

    /// Runs `f` with a fresh request id; gives the id back when `f` fails so ids stay consecutive.
    fn with_request(&mut self, f: impl FnOnce(&mut Self, u16) -> Result<()>) -> Result<u16> {
        let previous = *self.last_request_id;
        let request = self.next_request_id();
        match f(self, request) {
            Ok(()) => Ok(request),
            Err(e) => {
                *self.last_request_id = previous;
                Err(e)
            }
        }
    }

    // The lookup returns an `Option` (in a register, where a `Result` goes through memory), the error is made
    // at each caller (firmware size).
    #[inline(always)]
    fn reliable_mut(&mut self, stream: StreamId) -> Result<&mut OutputReliable<'a>> {
        self.reliable_opt(stream).ok_or(Error::UnknownStream)
    }

    fn reliable_opt(&mut self, stream: StreamId) -> Option<&mut OutputReliable<'a>> {
        match self.reliable.get_mut(usize::from(stream.index())) {
            Some(Some(s)) if stream.kind() == StreamKind::Reliable => Some(s),
            _ => None,
        }
    }

    /// Writes a submessage given as parts (its header first) into `stream`.
    pub(crate) fn write_parts(&mut self, stream: StreamId, parts: &[&[u8]]) -> Result<()> {
        match stream.kind() {
            StreamKind::BestEffort => match self.best_effort.get_mut(usize::from(stream.index())) {
                Some(Some(s)) => s.write_parts(parts),
                _ => Err(Error::UnknownStream),
            },
            StreamKind::Reliable => self.reliable_mut(stream)?.write_parts(parts),
            StreamKind::None => Err(Error::UnknownStream),
        }
    }

    /// Reserves `total` zero-filled bytes for one submessage in one message of `stream` (no fragmentation:
    /// [`Error::TooLarge`] when it cannot fit one message).
    fn reserve(&mut self, stream: StreamId, total: usize) -> Result<&mut [u8]> {
        reserve_in(self.best_effort, self.reliable, stream, total)
    }

    /// CREATE of `object` described by XML (`xml`) or by a reference. Text and binary creations are separate
    /// functions so a program creating only one way links only that encoder (~1 KB of firmware). The text is
    /// bytes: the agent parses it, and the C library then hands C strings over without a UTF-8 check.
    fn create_text(
        &mut self,
        stream: StreamId,
        object: ObjectId,
        link: EntityLink,
        text: &[u8],
        xml: bool,
        mode: u8,
    ) -> Result<u16> {
        self.with_request(|out, request| {
            let create = StringCreate {
                request: BaseObjectRequest { request_id: RequestId(request), object_id: object },
                mode: mode_flags(mode),
                xml,
                text_len: text.len(),
                link,
            };
            let (head, tail) = create.parts().ok_or(Error::TooLarge)?;
            out.write_parts(stream, &[&head, text, tail.as_bytes()])
        })
    }

    /// CREATE of `object` described by the binary representation `blob`.
    fn create_binary(
        &mut self,
        stream: StreamId,
        object: ObjectId,
        link: EntityLink,
        blob: BinaryObject<'_>,
        mode: u8,
    ) -> Result<u16> {
        let kind = object.kind();
        self.with_request(|out, request| {
            // Encoded in place, in two passes: a writer over no buffer measures the CREATE payload (CDR
            // alignment counted from the payload start, the variant after the 4-byte request), then the
            // same encoding goes straight into the reserved room of the stream. No scratch buffer.
            let variant = EntityVariant { kind, representation: Representation::Binary(blob), link };
            let mut measure = Writer::with_origin(&mut [], BaseObjectRequest::SIZE, 0, Endianness::Little);
            variant.encode_as_object(&mut measure);
            let payload = match measure.finish() {
                Ok(n) | Err(xrce_proto::cdr::Error::BufferTooSmall { needed: n }) => n,
                Err(e) => return Err(Error::Encode(e)),
            };
            let body_len = payload.saturating_sub(BaseObjectRequest::SIZE);
            let head = head(SubmessageId::Create, mode_flags(mode), request, object, body_len)?;
            let region = out.reserve(stream, RequestHead::SIZE + body_len)?;
            let Some((prefix, _)) = region.split_first_chunk_mut::<{ RequestHead::SIZE }>() else {
                return Err(Error::TooLarge);
            };
            *prefix = head;
            // CDR alignment counts from the payload, after the submessage header.
            let mut w = Writer::with_origin(region, RequestHead::SIZE, SubmessageHeader::SIZE, Endianness::Little);
            variant.encode_as_object(&mut w);
            w.finish().map(drop).map_err(Error::Encode)
        })
    }

    // ---- entities by XML -------------------------------------------------------------------------------

    /// `uxr_buffer_create_participant_xml`.
    pub fn buffer_create_participant_xml(
        &mut self,
        stream: StreamId,
        object: ObjectId,
        domain: u16,
        xml: &(impl AsRef<[u8]> + ?Sized),
        mode: u8,
    ) -> Result<u16> {
        self.create_text(stream, object, EntityLink::Domain(domain as i16), xml.as_ref(), true, mode)
    }

    /// `uxr_buffer_create_topic_xml`.
    pub fn buffer_create_topic_xml(
        &mut self,
        stream: StreamId,
        object: ObjectId,
        participant: ObjectId,
        xml: &(impl AsRef<[u8]> + ?Sized),
        mode: u8,
    ) -> Result<u16> {
        self.create_text(stream, object, EntityLink::Parent(participant), xml.as_ref(), true, mode)
    }

    /// `uxr_buffer_create_publisher_xml`.
    pub fn buffer_create_publisher_xml(
        &mut self,
        stream: StreamId,
        object: ObjectId,
        participant: ObjectId,
        xml: &(impl AsRef<[u8]> + ?Sized),
        mode: u8,
    ) -> Result<u16> {
        self.create_text(stream, object, EntityLink::Parent(participant), xml.as_ref(), true, mode)
    }

    /// `uxr_buffer_create_subscriber_xml`.
    pub fn buffer_create_subscriber_xml(
        &mut self,
        stream: StreamId,
        object: ObjectId,
        participant: ObjectId,
        xml: &(impl AsRef<[u8]> + ?Sized),
        mode: u8,
    ) -> Result<u16> {
        self.create_text(stream, object, EntityLink::Parent(participant), xml.as_ref(), true, mode)
    }

    /// `uxr_buffer_create_datawriter_xml`.
    pub fn buffer_create_datawriter_xml(
        &mut self,
        stream: StreamId,
        object: ObjectId,
        publisher: ObjectId,
        xml: &(impl AsRef<[u8]> + ?Sized),
        mode: u8,
    ) -> Result<u16> {
        self.create_text(stream, object, EntityLink::Parent(publisher), xml.as_ref(), true, mode)
    }

    /// `uxr_buffer_create_datareader_xml`.
    pub fn buffer_create_datareader_xml(
        &mut self,
        stream: StreamId,
        object: ObjectId,
        subscriber: ObjectId,
        xml: &(impl AsRef<[u8]> + ?Sized),
        mode: u8,
    ) -> Result<u16> {
        self.create_text(stream, object, EntityLink::Parent(subscriber), xml.as_ref(), true, mode)
    }

    /// `uxr_buffer_create_requester_xml`.
    pub fn buffer_create_requester_xml(
        &mut self,
        stream: StreamId,
        object: ObjectId,
        participant: ObjectId,
        xml: &(impl AsRef<[u8]> + ?Sized),
        mode: u8,
    ) -> Result<u16> {
        self.create_text(stream, object, EntityLink::Parent(participant), xml.as_ref(), true, mode)
    }

    /// `uxr_buffer_create_replier_xml`.
    pub fn buffer_create_replier_xml(
        &mut self,
        stream: StreamId,
        object: ObjectId,
        participant: ObjectId,
        xml: &(impl AsRef<[u8]> + ?Sized),
        mode: u8,
    ) -> Result<u16> {
        self.create_text(stream, object, EntityLink::Parent(participant), xml.as_ref(), true, mode)
    }

    // ---- entities by reference -------------------------------------------------------------------------

    /// `uxr_buffer_create_participant_ref`. The C function has no domain argument and sends domain 0.
    pub fn buffer_create_participant_ref(
        &mut self,
        stream: StreamId,
        object: ObjectId,
        domain: u16,
        reference: &(impl AsRef<[u8]> + ?Sized),
        mode: u8,
    ) -> Result<u16> {
        self.create_text(stream, object, EntityLink::Domain(domain as i16), reference.as_ref(), false, mode)
    }

    /// `uxr_buffer_create_topic_ref`.
    pub fn buffer_create_topic_ref(
        &mut self,
        stream: StreamId,
        object: ObjectId,
        participant: ObjectId,
        reference: &(impl AsRef<[u8]> + ?Sized),
        mode: u8,
    ) -> Result<u16> {
        self.create_text(stream, object, EntityLink::Parent(participant), reference.as_ref(), false, mode)
    }

    /// `uxr_buffer_create_datawriter_ref`.
    pub fn buffer_create_datawriter_ref(
        &mut self,
        stream: StreamId,
        object: ObjectId,
        publisher: ObjectId,
        reference: &(impl AsRef<[u8]> + ?Sized),
        mode: u8,
    ) -> Result<u16> {
        self.create_text(stream, object, EntityLink::Parent(publisher), reference.as_ref(), false, mode)
    }

    /// `uxr_buffer_create_datareader_ref`.
    pub fn buffer_create_datareader_ref(
        &mut self,
        stream: StreamId,
        object: ObjectId,
        subscriber: ObjectId,
        reference: &(impl AsRef<[u8]> + ?Sized),
        mode: u8,
    ) -> Result<u16> {
        self.create_text(stream, object, EntityLink::Parent(subscriber), reference.as_ref(), false, mode)
    }

    /// `uxr_buffer_create_requester_ref`.
    pub fn buffer_create_requester_ref(
        &mut self,
        stream: StreamId,
        object: ObjectId,
        participant: ObjectId,
        reference: &(impl AsRef<[u8]> + ?Sized),
        mode: u8,
    ) -> Result<u16> {
        self.create_text(stream, object, EntityLink::Parent(participant), reference.as_ref(), false, mode)
    }

    /// `uxr_buffer_create_replier_ref`.
    pub fn buffer_create_replier_ref(
        &mut self,
        stream: StreamId,
        object: ObjectId,
        participant: ObjectId,
        reference: &(impl AsRef<[u8]> + ?Sized),
        mode: u8,
    ) -> Result<u16> {
        self.create_text(stream, object, EntityLink::Parent(participant), reference.as_ref(), false, mode)
    }

    // ---- entities by binary ----------------------------------------------------------------------------

    /// `uxr_buffer_create_participant_bin`: the name travels as the QoS profile reference, as in the C client.
    pub fn buffer_create_participant_bin(
        &mut self,
        stream: StreamId,
        object: ObjectId,
        domain: u16,
        name: Option<&str>,
        mode: u8,
    ) -> Result<u16> {
        let blob = BinaryObject::Participant(ParticipantBinary { domain_reference: None, qos_profile_reference: name });
        self.create_binary(stream, object, EntityLink::Domain(domain as i16), blob, mode)
    }

    /// `uxr_buffer_create_topic_bin`.
    pub fn buffer_create_topic_bin(
        &mut self,
        stream: StreamId,
        object: ObjectId,
        participant: ObjectId,
        topic_name: &str,
        type_name: &str,
        mode: u8,
    ) -> Result<u16> {
        let blob = BinaryObject::Topic(TopicBinary { topic_name, type_reference: None, type_name: Some(type_name) });
        self.create_binary(stream, object, EntityLink::Parent(participant), blob, mode)
    }

    /// `uxr_buffer_create_publisher_bin`: no name, no QoS (the agent and the C client disagree on its layout).
    pub fn buffer_create_publisher_bin(
        &mut self,
        stream: StreamId,
        object: ObjectId,
        participant: ObjectId,
        mode: u8,
    ) -> Result<u16> {
        let blob = BinaryObject::Publisher(PubSubBinary::default());
        self.create_binary(stream, object, EntityLink::Parent(participant), blob, mode)
    }

    /// `uxr_buffer_create_subscriber_bin`: no name, no QoS, as the C client.
    pub fn buffer_create_subscriber_bin(
        &mut self,
        stream: StreamId,
        object: ObjectId,
        participant: ObjectId,
        mode: u8,
    ) -> Result<u16> {
        let blob = BinaryObject::Subscriber(PubSubBinary::default());
        self.create_binary(stream, object, EntityLink::Parent(participant), blob, mode)
    }

    /// `uxr_buffer_create_datawriter_bin`.
    pub fn buffer_create_datawriter_bin(
        &mut self,
        stream: StreamId,
        object: ObjectId,
        publisher: ObjectId,
        topic: ObjectId,
        qos: QoS,
        mode: u8,
    ) -> Result<u16> {
        let qos = Some(DataWriterQos { base: qos.endpoint(), ownership_strength: None });
        let blob = BinaryObject::DataWriter(DataWriterBinary { topic_id: topic, qos });
        self.create_binary(stream, object, EntityLink::Parent(publisher), blob, mode)
    }

    /// `uxr_buffer_create_datareader_bin`.
    pub fn buffer_create_datareader_bin(
        &mut self,
        stream: StreamId,
        object: ObjectId,
        subscriber: ObjectId,
        topic: ObjectId,
        qos: QoS,
        mode: u8,
    ) -> Result<u16> {
        let qos = Some(DataReaderQos { base: qos.endpoint(), timebasedfilter_msec: None, contentbased_filter: None });
        let blob = BinaryObject::DataReader(DataReaderBinary { topic_id: topic, qos });
        self.create_binary(stream, object, EntityLink::Parent(subscriber), blob, mode)
    }

    /// `uxr_buffer_create_requester_bin`. The blob has no QoS field; `qos` is accepted for parity and unused,
    /// as in the C client.
    #[allow(clippy::too_many_arguments)]
    pub fn buffer_create_requester_bin(
        &mut self,
        stream: StreamId,
        object: ObjectId,
        participant: ObjectId,
        service: &ServiceNames<'_>,
        _qos: QoS,
        mode: u8,
    ) -> Result<u16> {
        let blob = BinaryObject::Requester(service.binary());
        self.create_binary(stream, object, EntityLink::Parent(participant), blob, mode)
    }

    /// `uxr_buffer_create_replier_bin`; see [`buffer_create_requester_bin`](Self::buffer_create_requester_bin).
    pub fn buffer_create_replier_bin(
        &mut self,
        stream: StreamId,
        object: ObjectId,
        participant: ObjectId,
        service: &ServiceNames<'_>,
        _qos: QoS,
        mode: u8,
    ) -> Result<u16> {
        let blob = BinaryObject::Replier(service.binary());
        self.create_binary(stream, object, EntityLink::Parent(participant), blob, mode)
    }

    // ---- deletion, read access -------------------------------------------------------------------------

    /// `uxr_buffer_delete_entity`.
    pub fn buffer_delete_entity(&mut self, stream: StreamId, object: ObjectId) -> Result<u16> {
        self.with_request(|out, request| {
            out.write_parts(stream, &[&head(SubmessageId::Delete, 0, request, object, 0)?])
        })
    }

    /// `uxr_buffer_request_data`: ask `reader` (a datareader, requester or replier) to deliver on input stream
    /// `data_stream`; `control` `None` delivers one sample.
    pub fn buffer_request_data(
        &mut self,
        stream: StreamId,
        reader: ObjectId,
        data_stream: StreamId,
        control: Option<&DataDeliveryControl>,
    ) -> Result<u16> {
        self.read_data(stream, reader, data_stream.0, control)
    }

    /// `uxr_buffer_cancel_data`: a READ_DATA towards stream 0 with an all-zero delivery control.
    pub fn buffer_cancel_data(&mut self, stream: StreamId, reader: ObjectId) -> Result<u16> {
        self.read_data(stream, reader, 0, Some(&DataDeliveryControl::default()))
    }

    fn read_data(
        &mut self,
        stream: StreamId,
        reader: ObjectId,
        data_stream: u8,
        control: Option<&DataDeliveryControl>,
    ) -> Result<u16> {
        self.with_request(|out, request| {
            let (spec, len) = view::read_spec_bytes(data_stream, control);
            let head = head(SubmessageId::ReadData, 0, request, reader, len)?;
            out.write_parts(stream, &[&head, spec.get(..len).unwrap_or(&[])])
        })
    }

    // ---- write access ----------------------------------------------------------------------------------

    /// `uxr_buffer_topic`: a serialized sample for datawriter `writer`. Fragmented over several messages on a
    /// reliable stream when larger than one.
    pub fn buffer_topic(&mut self, stream: StreamId, writer: ObjectId, data: &[u8]) -> Result<u16> {
        self.with_request(|out, request| {
            out.write_parts(stream, &[&head(SubmessageId::WriteData, 0, request, writer, data.len())?, data])
        })
    }

    /// `uxr_buffer_request`: a serialized request for `requester`; the returned id comes back as `reply_id` in
    /// `on_reply`.
    pub fn buffer_request(&mut self, stream: StreamId, requester: ObjectId, data: &[u8]) -> Result<u16> {
        self.buffer_topic(stream, requester, data)
    }

    /// `uxr_buffer_reply`: a serialized reply from `replier` to the request identified by `sample_id` (as given
    /// to `on_request`).
    pub fn buffer_reply(
        &mut self,
        stream: StreamId,
        replier: ObjectId,
        sample_id: &SampleIdentity,
        data: &[u8],
    ) -> Result<u16> {
        let identity = encode_sample_identity(sample_id);
        self.with_request(|out, request| {
            let head = head(SubmessageId::WriteData, 0, request, replier, SampleIdentity::SIZE + data.len())?;
            out.write_parts(stream, &[&head, &identity, data])
        })
    }

    /// `uxr_prepare_output_stream`: reserves `size` bytes for a sample of `entity` to be serialized in place.
    /// The sample must fit one message: [`Error::TooLarge`] otherwise (use [`buffer_topic`](Self::buffer_topic)
    /// or `prepare_output_stream_fragmented`).
    pub fn prepare_output_stream(self, stream: StreamId, entity: ObjectId, size: usize) -> Result<Prepared<'s>> {
        let Outputs { last_request_id, best_effort, reliable } = self;
        let request = request_after(*last_request_id);
        let head = head(SubmessageId::WriteData, 0, request, entity, size)?;
        let region = reserve_in(best_effort, reliable, stream, RequestHead::SIZE + size)?;
        *last_request_id = request;
        let (h, data) = region.split_first_chunk_mut::<{ RequestHead::SIZE }>().ok_or(Error::TooLarge)?;
        *h = head;
        Ok(Prepared { request_id: request, buf: data })
    }

    /// Starts a continuous fragmented WRITE_DATA of `size` bytes for `entity` on reliable `stream`
    /// (`uxr_prepare_output_stream_fragmented`); feed it with [`push_fragmented`](Self::push_fragmented).
    /// A payload over 65535 bytes is announced with length 0, eProsima's write-limit convention.
    pub fn begin_fragmented(&mut self, stream: StreamId, entity: ObjectId, size: usize) -> Result<u16> {
        self.with_request(|out, request| {
            let request = BaseObjectRequest { request_id: RequestId(request), object_id: entity };
            let head = RequestHead::data(SubmessageId::WriteData, request, size);
            out.reliable_mut(stream)?.begin_chain(&head.to_bytes_fragmented(), head.encoded_len())
        })
    }

    /// [`begin_fragmented`](Self::begin_fragmented) for a sample that must fit the stream's free history
    /// whole (the C library's `uxr_prepare_output_stream` of a sample larger than a message): pushing its
    /// bytes never blocks. [`Error::WouldBlock`] when the history has no room for all of it now.
    pub fn begin_fragmented_whole(&mut self, stream: StreamId, entity: ObjectId, size: usize) -> Result<u16> {
        self.with_request(|out, request| {
            let request = BaseObjectRequest { request_id: RequestId(request), object_id: entity };
            let head = RequestHead::data(SubmessageId::WriteData, request, size);
            out.reliable_mut(stream)?.begin_chain_whole(&head.to_bytes_fragmented(), head.encoded_len())
        })
    }

    /// Appends bytes to the continuous fragmented write of `stream`; returns how many were taken (fewer when
    /// the history is full: flush, let the agent acknowledge, push the rest).
    pub fn push_fragmented(&mut self, stream: StreamId, data: &[u8]) -> Result<usize> {
        Ok(self.reliable_mut(stream)?.push(data))
    }

    /// Bytes the continuous fragmented write of `stream` still expects.
    pub fn fragmented_remaining(&mut self, stream: StreamId) -> Result<usize> {
        Ok(self.reliable_mut(stream)?.chain_remaining())
    }
}

/// Names of a binary requester or replier (`uxr_buffer_create_requester_bin` arguments).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ServiceNames<'n> {
    /// Service name.
    pub service_name: &'n str,
    /// Request type name.
    pub request_type: &'n str,
    /// Reply type name.
    pub reply_type: &'n str,
    /// Request topic name.
    pub request_topic_name: &'n str,
    /// Reply topic name.
    pub reply_topic_name: &'n str,
}

impl<'n> ServiceNames<'n> {
    fn binary(&self) -> RequesterBinary<'n> {
        RequesterBinary {
            service_name: self.service_name,
            request_type: self.request_type,
            reply_type: self.reply_type,
            request_topic_name: Some(self.request_topic_name),
            reply_topic_name: Some(self.reply_topic_name),
        }
    }
}

/// The request id after `id`: 10, 11, … 65535, then 10 again.
const fn request_after(id: u16) -> u16 {
    match id.checked_add(1) {
        Some(n) if n >= FIRST_REQUEST_ID => n,
        _ => FIRST_REQUEST_ID,
    }
}

/// Reserves `total` bytes for one submessage in one message of `stream`.
fn reserve_in<'s, 'a>(
    best_effort: &'s mut [Option<OutputBestEffort<'a>>],
    reliable: &'s mut [Option<OutputReliable<'a>>],
    stream: StreamId,
    total: usize,
) -> Result<&'s mut [u8]> {
    match stream.kind() {
        StreamKind::BestEffort => match best_effort.get_mut(usize::from(stream.index())) {
            Some(Some(s)) => s.reserve(total),
            _ => Err(Error::UnknownStream),
        },
        StreamKind::Reliable => match reliable.get_mut(usize::from(stream.index())) {
            Some(Some(s)) => s.reserve(total)?.ok_or(Error::TooLarge),
            _ => Err(Error::UnknownStream),
        },
        StreamKind::None => Err(Error::UnknownStream),
    }
}
