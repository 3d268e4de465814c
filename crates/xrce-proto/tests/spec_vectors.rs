//! The test vectors of `shared/spec/xrce-wire.md` §17: each message is built from values with the encoder and
//! compared with the bytes of the spec (`??` = padding of unspecified content), then decoded back.

use xrce_proto::message::{encode_single, parse, MessageBuilder};
use xrce_proto::object::{
    BinaryObject, DataWriterBinary, DataWriterQos, EndpointQos, ParticipantBinary, QosFlags, TopicBinary,
};
use xrce_proto::submessage::*;
use xrce_proto::*;

const KEY: ClientKey = ClientKey::from_u32(0xAABBCCDD);

/// Expected bytes from hex text; `??` is a wildcard.
fn expected(text: &str) -> Vec<Option<u8>> {
    text.split_whitespace()
        .map(|t| if t == "??" { None } else { Some(u8::from_str_radix(t, 16).expect("hex")) })
        .collect()
}

fn assert_bytes(actual: &[u8], text: &str) {
    let exp = expected(text);
    assert_eq!(actual.len(), exp.len(), "length of {actual:02X?}");
    for (i, (a, e)) in actual.iter().zip(&exp).enumerate() {
        if let Some(e) = e {
            assert_eq!(a, e, "byte {i} of {actual:02X?}");
        }
    }
}

fn header(session: u8, stream: u8, seq: u16) -> MessageHeader {
    MessageHeader::new(session, StreamId(stream), seq, KEY)
}

/// Encodes, compares, then checks decoding gives the submessages back.
fn check(h: MessageHeader, subs: &[Submessage<'_>], text: &str) {
    let mut buf = [0u8; 512];
    let mut b = MessageBuilder::new(&mut buf, &h).expect("header");
    for s in subs {
        b.push(s, Endianness::Little).expect("fits");
    }
    let n = b.finish();
    assert_bytes(&buf[..n], text);
    let (decoded_header, raws) = parse(&buf[..n]).expect("parse");
    assert_eq!(decoded_header, h);
    let decoded: Vec<Submessage<'_>> = raws.map(|r| r.expect("raw").decode().expect("decode")).collect();
    let expected: Vec<Submessage<'_>> = subs
        .iter()
        .map(|s| match *s {
            // Typed blobs come back raw; compare them typed.
            Submessage::Create(c) => Submessage::Create(c),
            other => other,
        })
        .collect();
    assert_eq!(decoded.len(), expected.len());
    for (d, e) in decoded.iter().zip(&expected) {
        match (d, e) {
            (Submessage::Create(d), Submessage::Create(e)) => {
                let (ObjectVariant::Entity(de), ObjectVariant::Entity(ee)) = (d.variant, e.variant) else {
                    assert_eq!(d, e);
                    continue;
                };
                assert_eq!((d.request, d.mode, de.kind, de.link), (e.request, e.mode, ee.kind, ee.link));
                match (de.representation, ee.representation) {
                    (Representation::Binary(db), Representation::Binary(eb)) => {
                        assert_eq!(db.decode_as(de.kind, Endianness::Little).expect("blob"), eb)
                    }
                    (dr, er) => assert_eq!(dr, er),
                }
            }
            _ => assert_eq!(d, e),
        }
    }
}

fn create_client(session: u8) -> Submessage<'static> {
    Submessage::CreateClient(object::ClientRepresentation::new(KEY, session, 508))
}

fn status_agent() -> Submessage<'static> {
    Submessage::StatusAgent(StatusAgent {
        result: ResultStatus::new(StatusCode::OK),
        agent: object::AgentRepresentation::EPROSIMA,
    })
}

#[test]
fn v17_1_to_3_session_establishment() {
    check(
        header(0x80, 0, 0),
        &[create_client(0x81)],
        "80 00 00 00 00 01 10 00 58 52 43 45 01 00 01 0F AA BB CC DD 81 00 FC 01",
    );
    check(header(0x81, 0, 0), &[status_agent()], "81 00 00 00 04 01 0B 00 00 00 58 52 43 45 01 00 01 0F 00");
    check(
        header(0x00, 0, 0),
        &[create_client(0x01)],
        "00 00 00 00 AA BB CC DD 00 01 10 00 58 52 43 45 01 00 01 0F AA BB CC DD 01 00 FC 01",
    );
    check(
        header(0x01, 0, 0),
        &[status_agent()],
        "01 00 00 00 AA BB CC DD 04 01 0B 00 00 00 58 52 43 45 01 00 01 0F 00",
    );
}

fn req(request: u16, id: u16) -> BaseObjectRequest {
    BaseObjectRequest { request_id: RequestId(request), object_id: ObjectId::from_raw(id) }
}

#[test]
fn v17_4_create_participant_by_xml_and_replies() {
    let xml = "<dds><participant><rtps><name>default_xrce_participant</name></rtps></participant></dds>";
    let create = Submessage::Create(Create {
        request: req(10, 0x0011),
        mode: CreationMode { reuse: false, replace: true },
        variant: ObjectVariant::Entity(EntityVariant::participant(Representation::Xml(xml), 0)),
    });
    let mut text = String::from("81 80 00 00 01 05 68 00 00 0A 00 11 01 02 00 00 59 00 00 00");
    for b in xml.bytes() {
        text.push_str(&format!(" {b:02X}"));
    }
    text.push_str(" 00 00 00 00");
    check(header(0x81, 0x80, 0), &[create], &text);

    let status = Submessage::Status(BaseObjectReply {
        related_request: req(10, 0x0011),
        result: ResultStatus::new(StatusCode::OK),
    });
    check(header(0x81, 0x80, 0), &[status], "81 80 00 00 05 01 06 00 00 0A 00 11 00 00");
    let ack = Submessage::AckNack(AckNack { first_unacked_seq_num: 1, nack_bitmap: [0, 0], stream_id: 0x80 });
    check(header(0x81, 0, 0), &[ack], "81 00 00 00 0A 01 05 00 01 00 00 00 80");
}

const HELLO: &[u8] = b"\x01\x00\x00\x00\x11\x00\x00\x00Hello DDS world!\x00";

#[test]
fn v17_5_write_data_and_data() {
    let write = Submessage::WriteData(DataPayload { request: req(11, 0x0015), format: DataFormat::DATA, data: HELLO });
    // Our encoder adds no trailing padding: the C client's 3 padding bytes are not part of the message proper.
    let c_client = "81 01 00 00 07 01 1D 00 00 0B 00 15 01 00 00 00 11 00 00 00 \
                    48 65 6C 6C 6F 20 44 44 53 20 77 6F 72 6C 64 21 00";
    check(header(0x81, 0x01, 0), &[write], c_client);
    check(header(0x01, 0x01, 0), &[write], &format!("01 01 00 00 AA BB CC DD {}", &c_client[12..]));
    let data = Submessage::Data(DataPayload { request: req(15, 0x0016), format: DataFormat::DATA, data: HELLO });
    check(
        header(0x81, 0x80, 1),
        &[data],
        "81 80 01 00 09 01 1D 00 00 0F 00 16 01 00 00 00 11 00 00 00 \
         48 65 6C 6C 6F 20 44 44 53 20 77 6F 72 6C 64 21 00",
    );
    // The C client's padded form decodes to the same submessage.
    let padded = expected(&format!("{c_client} 00 00 00")).into_iter().map(|b| b.unwrap_or(0)).collect::<Vec<_>>();
    let (_, mut subs) = parse(&padded).expect("parse");
    assert_eq!(subs.next().expect("one").expect("ok").decode().expect("decode"), write);
    assert!(subs.next().is_none());
}

#[test]
fn v17_6_heartbeat_and_acknack() {
    let hb = Submessage::Heartbeat(Heartbeat { first_unacked_seq_nr: 0, last_unacked_seq_nr: 1, stream_id: 0x80 });
    check(header(0x81, 0, 0), &[hb], "81 00 00 00 0B 01 05 00 00 00 01 00 80");
    let ack = Submessage::AckNack(AckNack { first_unacked_seq_num: 0, nack_bitmap: [0x00, 0x03], stream_id: 0x80 });
    check(header(0x81, 0, 0), &[ack], "81 00 00 00 0A 01 05 00 00 00 00 03 80");
    check(header(0x01, 0, 0), &[ack], "01 00 00 00 AA BB CC DD 0A 01 05 00 00 00 00 03 80");
    if let Submessage::AckNack(a) = ack {
        assert_eq!(a.bitmap(), 0b11);
    }
}

#[test]
fn v17_7_binary_creates() {
    let topic = Submessage::Create(Create {
        request: req(12, 0x0012),
        mode: CreationMode { reuse: false, replace: true },
        variant: ObjectVariant::Entity(EntityVariant::child(
            ObjectKind::Topic,
            Representation::Binary(BinaryObject::Topic(TopicBinary {
                topic_name: "HelloWorldTopic",
                type_reference: None,
                type_name: Some("HelloWorld"),
            })),
            ObjectId::from_raw(0x0011),
        )),
    });
    check(
        header(0x81, 0x01, 1),
        &[topic],
        "81 01 01 00 01 05 35 00 00 0C 00 12 02 03 00 00 27 00 00 00 \
         10 00 00 00 48 65 6C 6C 6F 57 6F 72 6C 64 54 6F 70 69 63 00 00 01 ?? ?? \
         0B 00 00 00 48 65 6C 6C 6F 57 6F 72 6C 64 00 00 11",
    );
    let participant = Submessage::Create(Create {
        request: req(13, 0x0011),
        mode: CreationMode { reuse: true, replace: true },
        variant: ObjectVariant::Entity(EntityVariant::participant(
            Representation::Binary(BinaryObject::Participant(ParticipantBinary::default())),
            0,
        )),
    });
    check(
        header(0x81, 0x01, 2),
        &[participant],
        "81 01 02 00 01 07 10 00 00 0D 00 11 01 03 00 00 02 00 00 00 00 00 00 00",
    );
    let writer = Submessage::Create(Create {
        request: req(14, 0x0015),
        mode: CreationMode { reuse: false, replace: true },
        variant: ObjectVariant::Entity(EntityVariant::child(
            ObjectKind::DataWriter,
            Representation::Binary(BinaryObject::DataWriter(DataWriterBinary {
                topic_id: ObjectId::from_raw(0x0012),
                qos: Some(DataWriterQos {
                    base: EndpointQos {
                        qos_flags: QosFlags::RELIABLE
                            | QosFlags::HISTORY_KEEP_LAST
                            | QosFlags::DURABILITY_TRANSIENT_LOCAL,
                        history_depth: Some(10),
                        ..Default::default()
                    },
                    ownership_strength: None,
                }),
            })),
            ObjectId::from_raw(0x0013),
        )),
    });
    check(
        header(0x81, 0x01, 3),
        &[writer],
        "81 01 03 00 01 05 1C 00 00 0E 00 15 05 03 00 00 0E 00 00 00 \
         00 12 01 ?? 0B 00 01 ?? 0A 00 00 00 00 00 00 13",
    );
}

#[test]
fn v17_8_read_data() {
    let read = Submessage::ReadData(ReadData {
        request: req(15, 0x0016),
        spec: ReadSpecification {
            preferred_stream_id: 0x80,
            data_format: 0,
            content_filter_expression: None,
            delivery_control: Some(DataDeliveryControl {
                max_samples: DataDeliveryControl::UNLIMITED,
                ..Default::default()
            }),
        },
    });
    check(header(0x81, 0x80, 1), &[read], "81 80 01 00 08 01 10 00 00 0F 00 16 80 00 00 01 FF FF 00 00 00 00 00 00");
}

#[test]
fn v17_9_discovery_and_ping() {
    let get_info = |request, mask| Submessage::GetInfo(GetInfo { request: req(request, 0xFFFD), info_mask: mask });
    check(header(0x80, 0, 0), &[get_info(9, 3)], "80 00 00 00 02 01 08 00 00 09 FF FD 03 00 00 00");
    check(header(0x80, 0, 0), &[get_info(10, 2)], "80 00 00 00 02 01 08 00 00 0A FF FD 02 00 00 00");
    check(header(0x81, 0, 0), &[get_info(10, 2)], "81 00 00 00 02 01 08 00 00 0A FF FD 02 00 00 00");

    let locators = [TransportLocator::Medium { address: [192, 168, 1, 10], port: 8888 }];
    let info = |request, implementation_status, locators| {
        Submessage::Info(Info {
            reply: BaseObjectReply {
                related_request: req(request, 0xFFFD),
                result: ResultStatus { status: StatusCode::OK, implementation_status },
            },
            config: Some(ObjectVariant::Agent(object::AgentRepresentation::EPROSIMA)),
            activity: Some(ActivityInfo::Agent { availability: 1, address_seq: cdr::Seq::Items(locators) }),
        })
    };
    check(
        header(0x80, 0, 0),
        &[info(9, 0, &locators)],
        "80 00 00 00 06 01 24 00 00 09 FF FD 00 00 01 0D 58 52 43 45 01 00 01 0F 00 \
         01 0D 00 01 00 00 00 01 00 00 00 01 C0 A8 01 0A 00 B8 22",
    );
    check(
        header(0x81, 0, 0),
        &[info(10, 1, &[])],
        "81 00 00 00 06 01 1C 00 00 0A FF FD 00 01 01 0D 58 52 43 45 01 00 01 0F 00 01 0D 00 01 00 00 00 00 00 00 00",
    );
}

#[test]
fn v17_10_time_sync() {
    let base = 1_700_000_000i64 * 1_000_000_000;
    let ts = Submessage::Timestamp(Time::from_nanos(base + 100));
    check(header(0x81, 0, 0), &[ts], "81 00 00 00 0E 01 08 00 00 F1 53 65 64 00 00 00");
    let reply = Submessage::TimestampReply(TimestampReply {
        transmit_timestamp: Time::from_nanos(base + 600_000),
        receive_timestamp: Time::from_nanos(base + 500_000),
        originate_timestamp: Time::from_nanos(base + 100),
    });
    check(
        header(0x81, 0, 0),
        &[reply],
        "81 00 00 00 0F 01 18 00 00 F1 53 65 C0 27 09 00 00 F1 53 65 20 A1 07 00 00 F1 53 65 64 00 00 00",
    );
}

#[test]
fn v17_11_session_deletion() {
    check(header(0x81, 0, 0), &[Submessage::Delete(req(2, 0xFFFE))], "81 00 00 00 03 01 04 00 00 02 FF FE");
    let status =
        Submessage::Status(BaseObjectReply { related_request: req(2, 0xFFFE), result: ResultStatus::default() });
    check(header(0x81, 0, 0), &[status], "81 00 00 00 05 01 06 00 00 02 FF FE 00 00");
}

#[test]
fn v17_12_fragments_reassemble_into_the_write() {
    let payload: Vec<u8> = (0..100).collect();
    let inner = {
        let mut inner = vec![0x07, 0x01, 0x68, 0x00, 0x00, 0x0A, 0x00, 0x15];
        inner.extend_from_slice(&payload);
        inner
    };
    let chunks = [&inner[..52], &inner[52..104], &inner[104..]];
    let mut reassembled = vec![0x81, 0x80, 0x00, 0x00];
    for (seq, chunk) in chunks.iter().enumerate() {
        let last = seq == 2;
        let mut buf = [0u8; 64];
        let n = encode_single(
            &mut buf,
            &header(0x81, 0x80, seq as u16),
            &Submessage::Fragment { last, data: chunk },
            Endianness::Little,
        )
        .expect("fits");
        assert_eq!(n, 8 + chunk.len());
        assert_eq!(&buf[4..8], &[0x0D, if last { 0x03 } else { 0x01 }, chunk.len() as u8, 0]);
        reassembled.extend_from_slice(&buf[8..n]);
    }
    let (_, mut subs) = parse(&reassembled).expect("parse");
    let Submessage::WriteData(w) = subs.next().expect("one").expect("ok").decode().expect("decode") else {
        panic!("not a WRITE_DATA")
    };
    assert_eq!((w.request, w.data), (req(10, 0x0015), &payload[..]));
}

#[test]
fn v17_13_transport_framings() {
    let msg = expected("80 00 00 00 00 01 10 00 58 52 43 45 01 00 01 0F AA BB CC DD 81 00 FC 01")
        .into_iter()
        .map(|b| b.expect("byte"))
        .collect::<Vec<_>>();
    let mut out = [0u8; 64];
    let n = framing::tcp::encode(&msg, &mut out).expect("tcp");
    assert_eq!(&out[..2], &[0x18, 0x00]);
    assert_eq!(&out[2..n], &msg[..]);
    let n = framing::serial::encode_frame(0, 0, &msg, &mut out).expect("serial");
    assert_bytes(
        &out[..n],
        "7E 00 00 18 00 80 00 00 00 00 01 10 00 58 52 43 45 01 00 01 0F AA BB CC DD 81 00 FC 01 3E 8F",
    );
}
