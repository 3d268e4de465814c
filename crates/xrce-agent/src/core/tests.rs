//! Unit tests of the core's session and stream handling, driven with hand-built messages.

use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use xrce_proto::object::ClientRepresentation;
use xrce_proto::submessage::{AckNack, Heartbeat};
use xrce_proto::{message, ClientKey, Endianness, MessageHeader, StreamId, Submessage};

use super::{AgentCore, CoreConfig};
use crate::middleware::ced::Ced;
use crate::middleware::describe::FallbackProfiles;

pub(crate) type TestCore = AgentCore<u16, Ced>;

pub(crate) fn core_with(config: CoreConfig) -> TestCore {
    AgentCore::new(config, Ced::new(Arc::new(FallbackProfiles)))
}

pub(crate) fn encode(header: &MessageHeader, sub: &Submessage<'_>) -> Vec<u8> {
    let mut buf = vec![0u8; 70_000];
    let n = message::encode_single(&mut buf, header, sub, Endianness::Little).expect("encode");
    buf.truncate(n);
    buf
}

/// CREATE_CLIENT for `key` with session 0x81 (no key in headers), mtu 508.
pub(crate) fn create_client(key: u32) -> Vec<u8> {
    let header = MessageHeader::new(0x80, StreamId::NONE, 0, ClientKey::INVALID);
    let rep = ClientRepresentation::new(ClientKey::from_u32(key), 0x81, 508);
    encode(&header, &Submessage::CreateClient(rep))
}

/// Every ACKNACK among the queued transmits: (first, bitmap, stream).
pub(crate) fn acknacks(core: &mut TestCore) -> Vec<(u16, u16, u8)> {
    let mut out = Vec::new();
    while let Some(t) = core.next_transmit(Instant::now()) {
        let (_, subs) = message::parse(&t.data).expect("header");
        for raw in subs.flatten() {
            if let Ok(Submessage::AckNack(a)) = raw.decode() {
                out.push((a.first_unacked_seq_num, a.bitmap(), a.stream_id));
            }
        }
    }
    out
}

#[test]
fn heartbeat_before_any_message_of_a_reliable_stream_is_acknacked() {
    let mut core = core_with(CoreConfig::default());
    let now = Instant::now();
    core.handle_datagram(7, &create_client(0xAABB_CCDD), now);
    while core.next_transmit(Instant::now()).is_some() {}
    // The client's first reliable message (seq 0) was lost; its HEARTBEAT announces 0..=0.
    let header = MessageHeader::new(0x81, StreamId::NONE, 0, ClientKey::INVALID);
    let hb = Heartbeat { first_unacked_seq_nr: 0, last_unacked_seq_nr: 0, stream_id: 0x80 };
    core.handle_datagram(7, &encode(&header, &Submessage::Heartbeat(hb)), now);
    assert_eq!(acknacks(&mut core), vec![(0, 0b1, 0x80)], "the agent asks for message 0");
    // And a plain ACKNACK from a healthy stream is unaffected.
    let ack = AckNack { first_unacked_seq_num: 0, nack_bitmap: [0, 0], stream_id: 0x80 };
    core.handle_datagram(7, &encode(&header, &Submessage::AckNack(ack)), now);
    assert_eq!(acknacks(&mut core), vec![]);
}

#[test]
fn acknacks_can_be_taken_before_the_batch_is_delivered() {
    use xrce_proto::submessage::{DataFormat, DataPayload};
    use xrce_proto::{BaseObjectRequest, ObjectId, ObjectKind, RequestId};
    let mut core = core_with(CoreConfig::default());
    let now = Instant::now();
    core.handle_datagram(7, &create_client(0xAABB_CCDD), now);
    while core.next_transmit(Instant::now()).is_some() {}
    // A reliable WRITE_DATA to an unknown writer: it is acknowledged all the same (the stream advanced).
    let header = MessageHeader::new(0x81, StreamId(0x80), 0, ClientKey::INVALID);
    let request = BaseObjectRequest { request_id: RequestId(1), object_id: ObjectId::new(9, ObjectKind::DataWriter) };
    let write = Submessage::WriteData(DataPayload { request, format: DataFormat::DATA, data: &[1, 2, 3, 4] });
    core.handle_datagram(7, &encode(&header, &write), now);
    let mut early = Vec::new();
    assert_eq!(core.poll_acknack(&mut early), Some(7), "an ACKNACK is owed");
    let (_, subs) = message::parse(&early).expect("header");
    let kinds: Vec<_> = subs.flatten().map(|raw| raw.decode().map(|s| matches!(s, Submessage::AckNack(_)))).collect();
    assert_eq!(kinds, vec![Ok(true)]);
    assert!(core.poll_acknack(&mut early).is_none(), "one ACKNACK per stream");
    assert_eq!(acknacks(&mut core), vec![], "and it is not sent twice");
}

/// Counts the WARN events of the code it runs around.
struct CountWarnings(Arc<AtomicUsize>);

impl<S: tracing::Subscriber> tracing_subscriber::Layer<S> for CountWarnings {
    fn on_event(&self, e: &tracing::Event<'_>, _: tracing_subscriber::layer::Context<'_, S>) {
        if *e.metadata().level() == tracing::Level::WARN {
            self.0.fetch_add(1, Ordering::Relaxed);
        }
    }
}

/// The WARN events `f` emits (on this thread).
fn warnings_of(f: impl FnOnce()) -> usize {
    use tracing_subscriber::layer::SubscriberExt;
    let warnings = Arc::new(AtomicUsize::new(0));
    let subscriber = tracing_subscriber::registry().with(CountWarnings(warnings.clone()));
    tracing::subscriber::with_default(subscriber, f);
    warnings.load(Ordering::Relaxed)
}

/// 2,000 garbage datagrams from one peer give one warning, then one per second with the count held back;
/// another peer gets its own.
#[test]
fn garbage_from_one_peer_is_warned_about_once_per_second() {
    let mut core = core_with(CoreConfig::default());
    let t0 = Instant::now();
    let warnings = warnings_of(|| {
        for i in 0..2000u64 {
            core.handle_datagram(9, &[0xFF], t0 + Duration::from_micros(i * 100));
        }
        core.handle_datagram(9, &[0xFF], t0 + Duration::from_secs(1));
        core.handle_datagram(10, &[0xFF], t0);
    });
    assert_eq!(warnings, 3, "first, one a second later, and the other peer's");
    assert_eq!(core.stats().datagrams_dropped, 2002, "every datagram is still dropped and counted");
}

/// Hostile input inside a session, 2,000 datagrams of each kind from one client within 0.2 s: each kind gives
/// one warning, not one per datagram (every call site goes through the peer's `DropLog`).
#[test]
fn hostile_input_in_a_session_is_warned_about_once_per_second() {
    use xrce_proto::object::{EntityVariant, ObjectVariant, Representation};
    use xrce_proto::submessage::{Create, CreationMode};
    use xrce_proto::{BaseObjectRequest, ObjectId, ObjectKind, RequestId};

    const PEER: u16 = 7;
    let no_streams = CoreConfig { max_streams_per_client: 0, ..CoreConfig::default() };
    let small_reassembly = CoreConfig { max_reassembly_size: 64, ..CoreConfig::default() };
    let on = |stream: u8, seq: u16| MessageHeader::new(0x81, StreamId(stream), seq, ClientKey::INVALID);
    let heartbeat = |stream: u8| Heartbeat { first_unacked_seq_nr: 0, last_unacked_seq_nr: 0, stream_id: stream };
    let create = |i: u16, variant: EntityVariant<'_>| {
        let request = BaseObjectRequest {
            request_id: RequestId(i.wrapping_add(1)),
            object_id: ObjectId::new(i % 0x0FFF, variant.kind),
        };
        let create = Create { request, mode: CreationMode::default(), variant: ObjectVariant::Entity(variant) };
        encode(&on(0, 0), &Submessage::Create(create))
    };
    let participant = create(0x0FFE, EntityVariant::participant(Representation::Xml("<participant/>"), 0));
    let parent = ObjectId::new(0x0FFE, ObjectKind::Participant);
    // (what, config, a datagram sent first, the hostile datagram number i)
    #[allow(clippy::type_complexity)]
    let kinds: [(&str, CoreConfig, Option<Vec<u8>>, Box<dyn Fn(u16) -> Vec<u8>>); 6] = [
        (
            "best-effort message on one stream too many",
            no_streams.clone(),
            None,
            Box::new(move |i| encode(&on(1 + (i % 100) as u8, 0), &Submessage::Heartbeat(heartbeat(0x80)))),
        ),
        (
            "reliable message on one stream too many",
            no_streams.clone(),
            None,
            Box::new(move |i| encode(&on(0x80 + (i % 100) as u8, 0), &Submessage::Heartbeat(heartbeat(0x80)))),
        ),
        (
            "HEARTBEAT for one stream too many",
            no_streams,
            None,
            Box::new(move |i| encode(&on(0, 0), &Submessage::Heartbeat(heartbeat(0x80 + (i % 100) as u8)))),
        ),
        (
            "fragment past the reassembly limit",
            small_reassembly,
            None,
            Box::new(move |i| encode(&on(0x80, i), &Submessage::Fragment { last: false, data: &[0xAB; 100] })),
        ),
        (
            "CREATE the middleware refuses (a topic without a name)",
            CoreConfig::default(),
            Some(participant),
            Box::new(move |i| {
                create(i, EntityVariant::child(ObjectKind::Topic, Representation::Xml("<topic/>"), parent))
            }),
        ),
        (
            "CREATE_CLIENT refused (MTU too small)",
            CoreConfig::default(),
            None,
            Box::new(|i| {
                let header = MessageHeader::new(0x80, StreamId::NONE, 0, ClientKey::INVALID);
                let rep = ClientRepresentation::new(ClientKey::from_u32(0x1000 + u32::from(i)), 0x81, 1);
                encode(&header, &Submessage::CreateClient(rep))
            }),
        ),
    ];
    let mut counts = Vec::new();
    for (what, config, setup, datagram) in kinds {
        let mut core = core_with(config);
        let t0 = Instant::now();
        core.handle_datagram(PEER, &create_client(0xAABB_CCDD), t0);
        if let Some(setup) = setup {
            core.handle_datagram(PEER, &setup, t0);
        }
        while core.next_transmit(t0).is_some() {}
        let warnings = warnings_of(|| {
            for i in 0..2000u16 {
                core.handle_datagram(PEER, &datagram(i), t0 + Duration::from_micros(u64::from(i) * 100));
                while core.next_transmit(t0).is_some() {}
            }
        });
        counts.push((what, warnings));
    }
    let expected: Vec<_> = counts.iter().map(|(what, _)| (*what, 1)).collect();
    assert_eq!(counts, expected, "one warning per kind for 2,000 datagrams within a second");
}
