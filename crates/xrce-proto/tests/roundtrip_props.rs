//! Property tests: every submessage and every object representation round-trips through encode and decode,
//! in both byte orders, with and without a client key in the header (which moves the alignment origin).

use proptest::prelude::*;
use xrce_proto::cdr::Seq;
use xrce_proto::message::{parse, MessageBuilder};
use xrce_proto::object::*;
use xrce_proto::submessage::*;
use xrce_proto::*;

/// Owned random material from which a borrowed submessage is built.
#[derive(Debug, Clone)]
struct Material {
    which: u8,
    strings: Vec<String>,
    bytes: Vec<u8>,
    nums: [u32; 8],
    flags: [bool; 8],
    little: bool,
    session: u8,
}

fn material() -> impl Strategy<Value = Material> {
    (
        0u8..40,
        proptest::collection::vec("[a-zA-Z0-9_<>/ ]{0,24}", 8),
        proptest::collection::vec(any::<u8>(), 0..64),
        any::<[u32; 8]>(),
        any::<[bool; 8]>(),
        any::<bool>(),
        prop_oneof![Just(0x01u8), Just(0x81u8), Just(0x00u8), Just(0x80u8)],
    )
        .prop_map(|(which, strings, bytes, nums, flags, little, session)| Material {
            which,
            strings,
            bytes,
            nums,
            flags,
            little,
            session,
        })
}

fn opt(m: &Material, i: usize) -> Option<&str> {
    m.flags[i % 8].then_some(m.strings[i % 8].as_str())
}

fn opt_num(m: &Material, i: usize) -> Option<u32> {
    m.flags[i % 8].then_some(m.nums[i % 8])
}

fn endpoint_qos(m: &Material) -> EndpointQos<'_> {
    EndpointQos {
        qos_flags: m.nums[0] as u16,
        history_depth: opt_num(m, 1).map(|n| n as u16),
        deadline_msec: opt_num(m, 2),
        lifespan_msec: opt_num(m, 3),
        user_data: m.flags[4].then_some(&m.bytes[..]),
    }
}

fn blob<'a>(m: &'a Material, kind: ObjectKind) -> BinaryObject<'a> {
    let s = |i: usize| m.strings[i].as_str();
    match kind {
        ObjectKind::Participant => BinaryObject::Participant(ParticipantBinary {
            domain_reference: opt(m, 0),
            qos_profile_reference: opt(m, 1),
        }),
        ObjectKind::Topic => {
            BinaryObject::Topic(TopicBinary { topic_name: s(0), type_reference: opt(m, 1), type_name: opt(m, 2) })
        }
        ObjectKind::Publisher | ObjectKind::Subscriber => {
            let b = PubSubBinary { name: opt(m, 0), qos: m.flags[1].then_some(&m.bytes[..]) };
            if kind == ObjectKind::Publisher {
                BinaryObject::Publisher(b)
            } else {
                BinaryObject::Subscriber(b)
            }
        }
        ObjectKind::DataWriter => BinaryObject::DataWriter(DataWriterBinary {
            topic_id: ObjectId::from_raw(m.nums[5] as u16),
            qos: m.flags[6].then(|| DataWriterQos { base: endpoint_qos(m), ownership_strength: opt_num(m, 7) }),
        }),
        ObjectKind::DataReader => BinaryObject::DataReader(DataReaderBinary {
            topic_id: ObjectId::from_raw(m.nums[5] as u16),
            qos: m.flags[6].then(|| DataReaderQos {
                base: endpoint_qos(m),
                timebasedfilter_msec: opt_num(m, 7),
                contentbased_filter: opt(m, 5),
            }),
        }),
        _ => {
            let b = RequesterBinary {
                service_name: s(0),
                request_type: s(1),
                reply_type: s(2),
                request_topic_name: opt(m, 3),
                reply_topic_name: opt(m, 4),
            };
            if kind == ObjectKind::Requester {
                BinaryObject::Requester(b)
            } else {
                BinaryObject::Replier(b)
            }
        }
    }
}

const ENTITY_KINDS: [ObjectKind; 8] = [
    ObjectKind::Participant,
    ObjectKind::Topic,
    ObjectKind::Publisher,
    ObjectKind::Subscriber,
    ObjectKind::DataWriter,
    ObjectKind::DataReader,
    ObjectKind::Requester,
    ObjectKind::Replier,
];

fn representation<'a>(m: &'a Material, kind: ObjectKind, choice: u32) -> Representation<'a> {
    let pub_sub = matches!(kind, ObjectKind::Publisher | ObjectKind::Subscriber);
    match choice % 3 {
        0 if !pub_sub => Representation::Reference(&m.strings[6]),
        1 => Representation::Xml(&m.strings[7]),
        _ => Representation::Binary(blob(m, kind)),
    }
}

fn build<'a>(m: &'a Material, props: &'a [Property<'a>], locators: &'a [TransportLocator<'a>]) -> Submessage<'a> {
    let n = |i: usize| m.nums[i];
    let request = BaseObjectRequest { request_id: RequestId(n(0) as u16), object_id: ObjectId::from_raw(n(1) as u16) };
    let reply = BaseObjectReply {
        related_request: request,
        result: ResultStatus { status: StatusCode(n(2) as u8), implementation_status: n(3) as u8 },
    };
    let time = |i: usize| Time { seconds: n(i) as i32, nanoseconds: n(i + 1) };
    let client = ClientRepresentation {
        xrce_cookie: n(4).to_be_bytes(),
        xrce_version: [n(5) as u8, 0],
        xrce_vendor_id: [1, 15],
        client_key: ClientKey::from_u32(n(6)),
        session_id: n(7) as u8,
        properties: m.flags[0].then_some(Seq::Items(props)),
        mtu: n(3) as u16,
    };
    let agent =
        AgentRepresentation { properties: m.flags[1].then_some(Seq::Items(props)), ..AgentRepresentation::EPROSIMA };
    match m.which {
        0 => Submessage::CreateClient(client),
        1..=8 => {
            let kind = ENTITY_KINDS[usize::from(m.which - 1)];
            let representation = representation(m, kind, n(4));
            let entity = if kind == ObjectKind::Participant {
                EntityVariant::participant(representation, n(5) as i16)
            } else {
                EntityVariant::child(kind, representation, ObjectId::from_raw(n(5) as u16))
            };
            Submessage::Create(Create {
                request,
                mode: CreationMode { reuse: m.flags[2], replace: m.flags[3] },
                variant: ObjectVariant::Entity(entity),
            })
        }
        9..=11 => {
            let kind = [ObjectKind::Type, ObjectKind::QosProfile, ObjectKind::Application][usize::from(m.which - 9)];
            let representation =
                if m.flags[0] { Representation::Reference(&m.strings[0]) } else { Representation::Xml(&m.strings[1]) };
            Submessage::Create(Create {
                request,
                mode: CreationMode::default(),
                variant: ObjectVariant::Profile { kind, representation },
            })
        }
        12 => Submessage::Create(Create {
            request,
            mode: CreationMode::default(),
            variant: ObjectVariant::Client(client),
        }),
        13 => Submessage::GetInfo(GetInfo { request, info_mask: n(4) }),
        14 => Submessage::Delete(request),
        15 => Submessage::StatusAgent(StatusAgent { result: reply.result, agent }),
        16 => Submessage::Status(reply),
        17..=19 => {
            let activity = match m.which {
                17 => ActivityInfo::Agent { availability: n(4) as i16, address_seq: Seq::Items(locators) },
                18 => ActivityInfo::DataWriter {
                    stream_seq_num: n(4) as i16,
                    sample_seq_num: u64::from(n(5)) << 32 | u64::from(n(6)),
                },
                _ => ActivityInfo::DataReader { highest_acked_num: n(4) as i16 },
            };
            Submessage::Info(Info {
                reply,
                config: m.flags[2].then_some(ObjectVariant::Agent(agent)),
                activity: m.flags[3].then_some(activity),
            })
        }
        20 | 21 => {
            let p = DataPayload { request, format: DataFormat(n(4) as u8 & DataFormat::MASK), data: &m.bytes };
            if m.which == 20 {
                Submessage::WriteData(p)
            } else {
                Submessage::Data(p)
            }
        }
        22 => Submessage::ReadData(ReadData {
            request,
            spec: ReadSpecification {
                preferred_stream_id: n(4) as u8,
                data_format: n(5) as u8,
                content_filter_expression: opt(m, 0),
                delivery_control: m.flags[1].then_some(DataDeliveryControl {
                    max_samples: n(6) as u16,
                    max_elapsed_time: (n(6) >> 16) as u16,
                    max_bytes_per_second: n(7) as u16,
                    min_pace_period: (n(7) >> 16) as u16,
                }),
            },
        }),
        23 => Submessage::AckNack(AckNack {
            first_unacked_seq_num: n(4) as u16,
            nack_bitmap: [n(5) as u8, n(6) as u8],
            stream_id: n(7) as u8,
        }),
        24 => Submessage::Heartbeat(Heartbeat {
            first_unacked_seq_nr: n(4) as u16,
            last_unacked_seq_nr: n(5) as u16,
            stream_id: n(6) as u8,
        }),
        25 => Submessage::Reset,
        26 => Submessage::Fragment { last: m.flags[0], data: &m.bytes },
        27 => Submessage::Timestamp(time(0)),
        28 => Submessage::TimestampReply(TimestampReply {
            transmit_timestamp: time(0),
            receive_timestamp: time(2),
            originate_timestamp: time(4),
        }),
        _ => Submessage::Unknown {
            id: 16 + (n(4) as u8 % 200),
            flags: (n(5) as u8 & !1) | u8::from(m.little),
            payload: &m.bytes,
        },
    }
}

/// Brings typed binary blobs of the original to the form decoding gives back (raw), by decoding both typed.
/// What [`FromAgent`] must give for a submessage the whole decoder gives as `s`: `None` where the client's
/// decoder refuses it (an INFO configuring an entity, which no agent reports to a client).
fn what_a_client_reads(s: Submessage<'_>) -> Option<FromAgent<'_>> {
    Some(match s {
        Submessage::StatusAgent(s) => FromAgent::StatusAgent(s.result),
        Submessage::Status(s) => FromAgent::Status(s),
        Submessage::Info(i) => {
            if matches!(i.config, Some(c) if !matches!(c, ObjectVariant::Agent(_) | ObjectVariant::Client(_))) {
                return None;
            }
            let availability = match i.activity {
                Some(ActivityInfo::Agent { availability, .. }) => Some(availability),
                _ => None,
            };
            FromAgent::Info { reply: i.reply, availability }
        }
        Submessage::GetInfo(g) => FromAgent::GetInfo(g),
        Submessage::Data(d) => FromAgent::Data(d),
        Submessage::AckNack(a) => FromAgent::AckNack(a),
        Submessage::Heartbeat(h) => FromAgent::Heartbeat(h),
        Submessage::Fragment { last, data } => FromAgent::Fragment { last, data },
        Submessage::TimestampReply(t) => FromAgent::TimestampReply(t),
        _ => FromAgent::Other,
    })
}

fn normalise(s: Submessage<'_>, endian: Endianness) -> Submessage<'_> {
    let Submessage::Create(mut c) = s else { return s };
    if let ObjectVariant::Entity(mut e) = c.variant {
        if let Representation::Binary(b) = e.representation {
            e.representation = Representation::Binary(b.decode_as(e.kind, endian).expect("blob decodes"));
            c.variant = ObjectVariant::Entity(e);
        }
    }
    Submessage::Create(c)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2000))]

    #[test]
    fn submessages_round_trip(m in material()) {
        let props = [
            Property { name: &m.strings[2], value: &m.strings[3] },
            Property { name: &m.strings[4], value: &m.strings[5] },
        ];
        let mut address6 = [0u8; 16];
        address6[..8].copy_from_slice(&(u64::from(m.nums[0]) << 32 | u64::from(m.nums[1])).to_be_bytes());
        let locators = [
            TransportLocator::Small { address: [m.nums[0] as u8, 1], port: m.nums[1] as u8 },
            TransportLocator::Medium { address: m.nums[2].to_be_bytes(), port: m.nums[3] as u16 },
            TransportLocator::Large { address: address6, port: m.nums[4] },
            TransportLocator::String(&m.strings[0]),
        ];
        let sub = build(&m, &props, &locators);
        let endian = if m.little { Endianness::Little } else { Endianness::Big };
        let header = MessageHeader::new(m.session, StreamId(m.nums[0] as u8), m.nums[1] as u16, ClientKey::from_u32(m.nums[2]));

        let mut buf = [0u8; 1024];
        let mut b = MessageBuilder::new(&mut buf, &header).expect("header");
        b.push(&sub, endian).expect("fits");
        let n = b.finish();

        let (h, mut raws) = parse(&buf[..n]).expect("parse");
        prop_assert_eq!(h, header);
        let raw = raws.next().expect("one submessage").expect("in bounds");
        prop_assert_eq!(raw.header.endianness(), endian);
        // A client's decoder: what it reads of what an agent sends is what the whole decoder reads.
        let decoded = raw.decode().expect("decodes");
        prop_assert_eq!(raw.decode_from_agent().ok(), what_a_client_reads(decoded));
        prop_assert!(raws.next().is_none());
        prop_assert_eq!(normalise(decoded, endian), normalise(sub, endian));

        // The size the builder reports for a too-small buffer is the real size.
        if n > header.size() + 4 {
            let mut small = vec![0u8; n - 1];
            let mut b = MessageBuilder::new(&mut small, &header).expect("header");
            prop_assert_eq!(b.push(&sub, endian), Err(cdr::Error::BufferTooSmall { needed: n }));
        }
    }

    #[test]
    fn decoding_arbitrary_bytes_never_panics(bytes in proptest::collection::vec(any::<u8>(), 0..256)) {
        if let Ok((_, raws)) = parse(&bytes) {
            for raw in raws.flatten() {
                let _ = raw.decode_from_agent();
                if let Ok(Submessage::Create(c)) = raw.decode() {
                    if let ObjectVariant::Entity(e) = c.variant {
                        let _ = e.binary(Endianness::Little);
                    }
                }
            }
        }
    }
}

/// An INFO whose configuration is not the agent's or a client's: decoded whole by `decode`, refused by a client's
/// decoder (which steps over the agent's or a client's representation only); the agent's own is stepped over, and
/// the availability after it read.
#[test]
fn a_clients_decoder_steps_over_only_the_agents_or_a_clients_configuration() {
    let reply = BaseObjectReply::default();
    let profile =
        ObjectVariant::Profile { kind: ObjectKind::QosProfile, representation: Representation::Reference("qos") };
    let agent = ObjectVariant::Agent(AgentRepresentation::EPROSIMA);
    let activity = Some(ActivityInfo::Agent { availability: 7, address_seq: Seq::Items(&[]) });
    for (config, client_decodes) in [(profile, false), (agent, true)] {
        let info = Submessage::Info(Info { reply, config: Some(config), activity });
        let header = MessageHeader::new(0x81, StreamId::NONE, 0, ClientKey::from_u32(1));
        let mut buf = [0u8; 256];
        let mut b = MessageBuilder::new(&mut buf, &header).expect("header");
        b.push(&info, Endianness::Little).expect("fits");
        let n = b.finish();
        let (_, mut raws) = parse(&buf[..n]).expect("parse");
        let raw = raws.next().expect("one submessage").expect("in bounds");
        assert_eq!(raw.decode().expect("decodes"), info);
        let lean = FromAgent::Info { reply, availability: Some(7) };
        assert_eq!(raw.decode_from_agent().ok(), client_decodes.then_some(lean));
    }
}
