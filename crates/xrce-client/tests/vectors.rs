//! The sans-IO core against the C client's verified bytes (spec §17) and the captured traffic.

mod common;

use common::{capture, hex, Collect};
use serde::{Deserialize, Serialize};
use xrce_client::prelude::*;
use xrce_client::session::{PingState, SessionState, MILLIS};
use xrce_proto::serde_cdr;

const KEY: u32 = 0xAABB_CCDD;
const T0: i64 = 1_700_000_000 * 1_000_000_000;

#[derive(Serialize, Deserialize, Debug, PartialEq)]
struct HelloWorld<'a> {
    index: u32,
    message: &'a str,
}

type Core<'a> = SessionCore<'a, 1, 1, 1, 1>;

/// Everything the core wants to send now.
fn drain(core: &mut Core<'_>, now: i64) -> Vec<Vec<u8>> {
    let mut out = Vec::new();
    let mut buf = [0u8; 512];
    while let Some(n) = core.poll_transmit(now, &mut buf) {
        out.push(buf[..n].to_vec());
    }
    out
}

/// A core with an established session (after the exchange of §17.1/§17.2).
fn established<'a>(session_id: u8) -> Core<'a> {
    let mut core = Core::new(session_id, KEY, 512);
    core.create_session(T0);
    let sent = drain(&mut core, T0);
    assert_eq!(sent.len(), 1);
    let reply = if session_id < 0x80 {
        hex("01 00 00 00 AA BB CC DD 04 01 0B 00 00 00 58 52 43 45 01 00 01 0F 00")
    } else {
        hex("81 00 00 00 04 01 0B 00 00 00 58 52 43 45 01 00 01 0F 00")
    };
    let mut reply = reply;
    reply[0] = session_id;
    core.handle_input(&reply, T0, &mut ());
    assert_eq!(core.state(), SessionState::Established);
    core
}

#[test]
fn create_client_17_1_and_status_agent_17_2() {
    let mut core = Core::new(0x81, KEY, 512);
    core.create_session(T0);
    let sent = drain(&mut core, T0);
    assert_eq!(sent, vec![hex("80 00 00 00 00 01 10 00 58 52 43 45 01 00 01 0F AA BB CC DD 81 00 FC 01")]);
    // Retried one second later, not before.
    assert!(drain(&mut core, T0 + 999 * MILLIS).is_empty());
    assert_eq!(drain(&mut core, T0 + 1000 * MILLIS).len(), 1);
    core.handle_input(&hex("81 00 00 00 04 01 0B 00 00 00 58 52 43 45 01 00 01 0F 00"), T0, &mut ());
    assert_eq!(core.state(), SessionState::Established);
}

#[test]
fn create_client_gives_up_after_the_attempts() {
    let mut core = Core::new(0x81, KEY, 512);
    core.create_session_retries(3, 0);
    let mut sent = 0;
    for ms in 0..5000 {
        sent += drain(&mut core, ms * MILLIS).len();
    }
    assert_eq!(sent, 3);
    assert_eq!(core.state(), SessionState::CreateTimedOut);
}

#[test]
fn refused_session_reports_the_status() {
    let mut core = Core::new(0x81, KEY, 512);
    core.create_session(0);
    drain(&mut core, 0);
    core.handle_input(&hex("81 00 00 00 04 01 0B 00 85 00 58 52 43 45 01 00 01 0F 00"), 0, &mut ());
    assert_eq!(core.state(), SessionState::Refused(0x85));
}

#[test]
fn packed_input_sends_the_pack_property_in_create_client() {
    let mut core = Core::new(0x81, KEY, 512);
    core.set_packed_input(true);
    core.create_session(T0);
    let sent = drain(&mut core, T0);
    assert_eq!(sent.len(), 1);
    let msg = &sent[0];
    let (_, start) = xrce_proto::MessageHeader::decode(msg).unwrap();
    let sub = xrce_proto::Submessages::new(msg, start).next().unwrap().unwrap().decode().unwrap();
    let xrce_proto::Submessage::CreateClient(rep) = sub else { panic!("not a CREATE_CLIENT: {sub:?}") };
    assert_eq!(rep.property(xrce_client::session::PACK_PROPERTY), Some("1"));
    assert_eq!(rep.mtu, 508);
    // Seen by eProsima's agent v3.0.1 (which ignores the property): …name "xrce_rs_pack", value "1", mtu.
    assert!(msg.ends_with(&hex("78 72 63 65 5F 72 73 5F 70 61 63 6B 00 00 00 00 02 00 00 00 31 00 FC 01")));
    // Without it the message is the C client's (§17.1).
    let mut plain = Core::new(0x81, KEY, 512);
    plain.create_session(T0);
    assert!(!plain.packed_input());
    assert_eq!(
        drain(&mut plain, T0),
        vec![hex("80 00 00 00 00 01 10 00 58 52 43 45 01 00 01 0F AA BB CC DD 81 00 FC 01")]
    );
}

#[test]
fn key_in_header_17_3() {
    let mut core = Core::new(0x01, KEY, 512);
    core.create_session(T0);
    assert_eq!(
        drain(&mut core, T0),
        vec![hex("00 00 00 00 AA BB CC DD 00 01 10 00 58 52 43 45 01 00 01 0F AA BB CC DD 01 00 FC 01")]
    );
    // A reply for another key is not ours.
    core.handle_input(&hex("01 00 00 00 AA BB CC DE 04 01 0B 00 00 00 58 52 43 45 01 00 01 0F 00"), T0, &mut ());
    assert_eq!(core.state(), SessionState::Creating);
    core.handle_input(&hex("01 00 00 00 AA BB CC DD 04 01 0B 00 00 00 58 52 43 45 01 00 01 0F 00"), T0, &mut ());
    assert_eq!(core.state(), SessionState::Established);
}

const PARTICIPANT_XML: &str =
    "<dds><participant><rtps><name>default_xrce_participant</name></rtps></participant></dds>";

#[test]
fn create_participant_xml_17_4_status_and_acknacks() {
    let mut out_buf = [0u8; 2048];
    let mut in_buf = [0u8; 2048];
    let mut core = established(0x81);
    let out = core.create_output_reliable_stream(&mut out_buf, 4).unwrap();
    let input = core.create_input_reliable_stream(&mut in_buf, 4).unwrap();
    assert_eq!((out.0, input.0), (0x80, 0x80));
    let participant = object_id(1, ObjectKind::Participant);
    let req = core.buffer_create_participant_xml(out, participant, 0, PARTICIPANT_XML, REPLACE).unwrap();
    assert_eq!(req, 10);
    assert!(drain(&mut core, T0).is_empty(), "nothing leaves before a flush");
    core.flash_output_streams();
    let sent = drain(&mut core, T0);
    let mut expected = hex("81 80 00 00 01 05 68 00 00 0A 00 11 01 02 00 00 59 00 00 00");
    expected.extend(PARTICIPANT_XML.as_bytes());
    expected.extend(hex("00 00 00 00"));
    assert_eq!(sent, vec![expected]);
    assert!(!core.output_streams_confirmed());

    // The agent's STATUS on reliable stream 0x80 reaches the callback and is acknowledged.
    let mut seen = Collect::default();
    core.handle_input(&hex("81 80 00 00 05 01 06 00 00 0A 00 11 00 00"), T0, &mut seen);
    assert_eq!(seen.statuses, vec![(participant, 10, STATUS_OK)]);
    assert_eq!(drain(&mut core, T0), vec![hex("81 00 00 00 0A 01 05 00 01 00 00 00 80")]);
    // The agent's ACKNACK for our seq 0 confirms delivery.
    core.handle_input(&hex("81 00 00 00 0A 01 05 00 01 00 00 00 80"), T0, &mut ());
    assert!(core.output_streams_confirmed());
}

#[test]
fn write_data_hello_world_17_5_in_place() {
    let mut be_buf = [0u8; 512];
    let mut core = established(0x81);
    let be = core.create_output_best_effort_stream(&mut be_buf).unwrap();
    let writer = object_id(1, ObjectKind::DataWriter);
    core.buffer_delete_entity(be, writer).unwrap(); // request 10
    core.flash_output_streams();
    drain(&mut core, T0);
    let topic = HelloWorld { index: 1, message: "Hello DDS world!" };
    let size = serde_cdr::serialized_size(&topic).unwrap();
    let mut prepared = core.prepare_output_stream(be, writer, size).unwrap();
    assert_eq!(prepared.request_id, 11);
    serde_cdr::to_slice(&topic, prepared.buffer()).unwrap();
    core.flash_output_streams();
    let sent = drain(&mut core, T0);
    let expected = hex("81 01 01 00 07 01 1D 00 00 0B 00 15 01 00 00 00 11 00 00 00
         48 65 6C 6C 6F 20 44 44 53 20 77 6F 72 6C 64 21 00 00 00 00");
    assert_eq!(sent, vec![expected]);
}

#[test]
fn write_data_with_key_in_header_17_5() {
    let mut be_buf = [0u8; 512];
    let mut core = established(0x01);
    let be = core.create_output_best_effort_stream(&mut be_buf).unwrap();
    let mut data = [0u8; 64];
    let n = serde_cdr::to_slice(&HelloWorld { index: 1, message: "Hello DDS world!" }, &mut data).unwrap();
    core.buffer_topic(be, object_id(1, ObjectKind::DataWriter), &data[..n]).unwrap();
    core.flash_output_streams();
    let sent = drain(&mut core, T0);
    assert_eq!(sent[0].len(), 44);
    assert_eq!(&sent[0][..8], &hex("01 01 00 00 AA BB CC DD")[..]);
}

#[test]
fn best_effort_larger_than_mtu_is_an_error() {
    let mut be_buf = [0u8; 4096];
    let mut core = established(0x81);
    let be = core.create_output_best_effort_stream(&mut be_buf).unwrap();
    let writer = object_id(1, ObjectKind::DataWriter);
    assert_eq!(core.buffer_topic(be, writer, &[0u8; 600]), Err(Error::TooLarge));
    core.buffer_topic(be, writer, &[0u8; 400]).unwrap();
    assert_eq!(core.buffer_topic(be, writer, &[0u8; 200]), Err(Error::WouldBlock));
}

#[test]
fn reliable_history_full_is_would_block() {
    let mut out_buf = [0u8; 256];
    let mut core = established(0x81);
    let out = core.create_output_reliable_stream(&mut out_buf, 2).unwrap();
    let writer = object_id(1, ObjectKind::DataWriter);
    core.buffer_topic(out, writer, &[1u8; 100]).unwrap();
    core.buffer_topic(out, writer, &[2u8; 100]).unwrap();
    assert_eq!(core.buffer_topic(out, writer, &[3u8; 100]), Err(Error::WouldBlock));
    core.flash_output_streams();
    assert_eq!(drain(&mut core, T0).len(), 2);
    assert_eq!(core.buffer_topic(out, writer, &[3u8; 100]), Err(Error::WouldBlock));
    // The agent acknowledges seq 0: one slot frees.
    core.handle_input(&hex("81 00 00 00 0A 01 05 00 01 00 00 00 80"), T0, &mut ());
    core.buffer_topic(out, writer, &[3u8; 100]).unwrap();
    // Larger than the whole history can never fit.
    assert_eq!(core.buffer_topic(out, writer, &[0u8; 400]), Err(Error::TooLarge));
}

#[test]
fn heartbeat_and_acknack_17_6() {
    let mut out_buf = [0u8; 2048];
    let mut in_buf = [0u8; 2048];
    let mut core = established(0x81);
    let out = core.create_output_reliable_stream(&mut out_buf, 4).unwrap();
    core.create_input_reliable_stream(&mut in_buf, 4).unwrap();
    let writer = object_id(1, ObjectKind::DataWriter);
    for _ in 0..2 {
        core.buffer_topic(out, writer, &[0u8; 8]).unwrap();
        core.flash_output_streams();
        assert_eq!(drain(&mut core, T0).len(), 1);
    }
    assert_eq!(core.poll_timeout(), Some(T0 + 100 * MILLIS));
    assert!(drain(&mut core, T0 + 99 * MILLIS).is_empty());
    assert_eq!(drain(&mut core, T0 + 100 * MILLIS), vec![hex("81 00 00 00 0B 01 05 00 00 00 01 00 80")]);
    // Every 100 ms while unacknowledged.
    assert_eq!(drain(&mut core, T0 + 200 * MILLIS).len(), 1);
    // Agent HEARTBEAT (0..1) with nothing received: both missing.
    core.handle_input(&hex("81 00 00 00 0B 01 05 00 00 00 01 00 80"), T0, &mut ());
    assert_eq!(drain(&mut core, T0 + 250 * MILLIS), vec![hex("81 00 00 00 0A 01 05 00 00 00 00 03 80")]);
    // A NACK of seq 0 resends seq 0 only (selective repeat, unlike the C client's go-back-N), byte-identical.
    core.handle_input(&hex("81 00 00 00 0A 01 05 00 00 00 00 01 80"), T0 + 260 * MILLIS, &mut ());
    let resent = drain(&mut core, T0 + 260 * MILLIS);
    assert_eq!(resent.len(), 1);
    assert_eq!(&resent[0][..4], &hex("81 80 00 00")[..]);
}

/// Once an acknowledgement has given a round trip, a tail loss is probed after `max(2 × min RTT, 2 ms)`, not
/// after the C client's 100 ms; unanswered probes back off to 100 ms; progress starts over.
#[test]
fn tail_losses_are_probed_after_two_round_trips_backing_off_to_the_period() {
    let mut out_buf = [0u8; 2048];
    let mut core = established(0x81);
    let out = core.create_output_reliable_stream(&mut out_buf, 8).unwrap();
    let writer = object_id(1, ObjectKind::DataWriter);
    let write = |core: &mut Core<'_>, ms: i64| {
        core.buffer_topic(out, writer, &[7u8; 8]).unwrap();
        core.flash_output_streams();
        assert_eq!(drain(core, T0 + ms * MILLIS).len(), 1);
    };
    let acknack = |core: &mut Core<'_>, first: u8, ms: i64| {
        let msg = [0x81, 0, 0, 0, 0x0A, 0x01, 0x05, 0x00, first, 0, 0, 0, 0x80];
        core.handle_input(&msg, T0 + ms * MILLIS, &mut ());
    };
    let is_heartbeat = |m: &Vec<u8>| m[1] == 0 && m[4] == 0x0B;
    // No round trip known yet: the C client's period.
    write(&mut core, 0);
    assert_eq!(core.poll_timeout(), Some(T0 + 100 * MILLIS));
    // Acknowledged 10 ms later: srtt 10 ms, so the next send is probed 20 ms after.
    acknack(&mut core, 1, 10);
    assert!(core.output_streams_confirmed());
    write(&mut core, 10);
    assert_eq!(core.poll_timeout(), Some(T0 + 30 * MILLIS));
    assert!(drain(&mut core, T0 + 29 * MILLIS).is_empty());
    let mut at = 30;
    for gap in [40, 80, 100, 100] {
        let probe = drain(&mut core, T0 + at * MILLIS);
        assert_eq!(probe.len(), 1, "probe at {at} ms");
        assert!(is_heartbeat(&probe[0]));
        at += gap;
        assert_eq!(core.poll_timeout(), Some(T0 + at * MILLIS), "backed off by {gap} ms");
    }
    // Progress ends the back-off. The late acknowledgement (a 335 ms sample, the wait for the lost one) does
    // not stretch the probe: its base is the smallest round trip seen.
    acknack(&mut core, 2, at - 5);
    write(&mut core, at);
    assert_eq!(core.poll_timeout(), Some(T0 + (at + 20) * MILLIS));
}

/// An agent that never answers: the probes settle at the period, however many go unanswered (the doubling
/// must not overflow into a negative or tiny timeout).
#[test]
fn unanswered_probes_stay_at_the_period_forever() {
    let mut out_buf = [0u8; 2048];
    let mut core = established(0x81);
    let out = core.create_output_reliable_stream(&mut out_buf, 8).unwrap();
    let writer = object_id(1, ObjectKind::DataWriter);
    core.buffer_topic(out, writer, &[1u8; 8]).unwrap();
    core.flash_output_streams();
    assert_eq!(drain(&mut core, T0).len(), 1);
    core.handle_input(&[0x81, 0, 0, 0, 0x0A, 0x01, 0x05, 0x00, 1, 0, 0, 0, 0x80], T0 + MILLIS, &mut ());
    core.buffer_topic(out, writer, &[2u8; 8]).unwrap();
    core.flash_output_streams();
    assert_eq!(drain(&mut core, T0 + MILLIS).len(), 1);
    let mut at = core.poll_timeout().unwrap();
    for i in 0..100 {
        assert_eq!(drain(&mut core, at).len(), 1, "probe {i}");
        let next = core.poll_timeout().unwrap();
        assert!(next > at && next - at <= 100 * MILLIS, "probe {i}: next in {} ns", next - at);
        if i > 10 {
            assert_eq!(next - at, 100 * MILLIS, "probe {i}");
        }
        at = next;
    }
}

#[test]
fn acknack_resends_only_nacked_and_not_twice_within_the_interval() {
    let mut out_buf = [0u8; 2048];
    let mut core = established(0x81);
    let out = core.create_output_reliable_stream(&mut out_buf, 8).unwrap();
    core.set_retransmit_floor(out, 30 * MILLIS).unwrap();
    let writer = object_id(1, ObjectKind::DataWriter);
    let mut originals = Vec::new();
    for i in 0..6u8 {
        core.buffer_topic(out, writer, &[i; 8]).unwrap();
        core.flash_output_streams();
        originals.extend(drain(&mut core, T0));
    }
    assert_eq!(originals.len(), 6);
    let seqs = |msgs: &[Vec<u8>]| msgs.iter().map(|m| m[2]).collect::<Vec<u8>>();
    // Resends only: the probe HEARTBEATs (session stream 0) are another test's business.
    let resends = |msgs: Vec<Vec<u8>>| msgs.into_iter().filter(|m| m[1] == 0x80).collect::<Vec<_>>();
    let acknack = |core: &mut Core<'_>, first: u8, bitmap: u16, ms: i64| {
        let [b0, b1] = bitmap.to_be_bytes();
        let msg = [0x81, 0, 0, 0, 0x0A, 0x01, 0x05, 0x00, first, 0, b0, b1, 0x80];
        core.handle_input(&msg, T0 + ms * MILLIS, &mut ());
        resends(drain(core, T0 + ms * MILLIS))
    };
    // first_unacked 1, bits for 1 and 3: seq 0 is released, only 1 and 3 go again, byte-identical.
    assert_eq!(acknack(&mut core, 1, 0b101, 1), vec![originals[1].clone(), originals[3].clone()]);
    // The same gaps reported again (the agent sends one ACKNACK per message it receives): nothing within the
    // interval.
    assert!(acknack(&mut core, 1, 0b101, 2).is_empty());
    assert!(acknack(&mut core, 1, 0b101, 10).is_empty());
    // A gap reported for the first time goes at once, while the others wait.
    assert_eq!(seqs(&acknack(&mut core, 1, 0b111, 20)), vec![2]);
    // Nothing acknowledged them meanwhile: the waiting ones go when their interval ends.
    assert!(resends(drain(&mut core, T0 + 30 * MILLIS)).is_empty());
    assert_eq!(core.poll_timeout(), Some(T0 + 31 * MILLIS));
    assert_eq!(seqs(&resends(drain(&mut core, T0 + 31 * MILLIS))), vec![1, 3]);
    // An ACKNACK that only acknowledges never resends.
    assert!(acknack(&mut core, 2, 0, 32).is_empty());
    // A stale ACKNACK (older first_unacked) names acknowledged messages: skipped; 3 just went: it waits.
    assert!(acknack(&mut core, 0, 0b1011, 41).is_empty());
    // Acknowledged before its interval ended: it never goes.
    assert!(acknack(&mut core, 4, 0, 45).is_empty());
    assert!(resends(drain(&mut core, T0 + 70 * MILLIS)).is_empty());
    // Messages sent once go at once when NACKed.
    assert_eq!(seqs(&acknack(&mut core, 4, 0b11, 71)), vec![4, 5]);
    // The floor is configurable.
    core.set_retransmit_floor(out, 5 * MILLIS).unwrap();
    assert_eq!(seqs(&acknack(&mut core, 4, 0b1, 77)), vec![4]);
    // Everything acknowledged: nothing left, no heartbeat.
    assert!(acknack(&mut core, 6, 0, 80).is_empty());
    assert!(core.output_streams_confirmed());
    assert!(drain(&mut core, T0 + 500 * MILLIS).is_empty());
}

#[test]
fn heartbeat_with_key_in_header_17_6() {
    let mut out_buf = [0u8; 2048];
    let mut core = established(0x01);
    let out = core.create_output_reliable_stream(&mut out_buf, 4).unwrap();
    core.buffer_topic(out, object_id(1, ObjectKind::DataWriter), &[0u8; 8]).unwrap();
    core.flash_output_streams();
    drain(&mut core, T0);
    assert_eq!(drain(&mut core, T0 + 100 * MILLIS), vec![hex("01 00 00 00 AA BB CC DD 0B 01 05 00 00 00 00 00 80")]);
}

#[test]
fn binary_creates_17_7() {
    let mut be_buf = [0u8; 512];
    let mut core = established(0x81);
    let be = core.create_output_best_effort_stream(&mut be_buf).unwrap();
    let participant = object_id(1, ObjectKind::Participant);
    let topic = object_id(1, ObjectKind::Topic);
    let publisher = object_id(1, ObjectKind::Publisher);
    let send = |core: &mut Core<'_>| {
        core.flash_output_streams();
        drain(core, T0).pop().unwrap()
    };
    core.buffer_delete_entity(be, participant).unwrap(); // request 10, seq 0
    send(&mut core);
    core.buffer_delete_entity(be, participant).unwrap(); // request 11
    core.buffer_create_topic_bin(be, topic, participant, "HelloWorldTopic", "HelloWorld", REPLACE).unwrap();
    let msg = send(&mut core);
    let expected = hex("01 05 35 00 00 0C 00 12 02 03 00 00 27 00 00 00
         10 00 00 00 48 65 6C 6C 6F 57 6F 72 6C 64 54 6F 70 69 63 00
         00 01 00 00 0B 00 00 00 48 65 6C 6C 6F 57 6F 72 6C 64 00 00 11 00 00 00");
    // Message = header, DELETE (8 bytes), then the topic CREATE; padding bytes may differ from C's.
    let create = &msg[12..];
    let pad = [42usize, 43];
    for (i, (a, b)) in create.iter().zip(&expected).enumerate() {
        if !pad.contains(&i) {
            assert_eq!(a, b, "byte {i}");
        }
    }
    assert_eq!(create.len(), expected.len());

    core.buffer_create_participant_bin(be, participant, 0, None, REUSE | REPLACE).unwrap(); // 13
    let msg = send(&mut core);
    assert_eq!(&msg[4..], &hex("01 07 10 00 00 0D 00 11 01 03 00 00 02 00 00 00 00 00 00 00")[..]);

    let qos = QoS {
        durability: Durability::TransientLocal,
        reliability: Reliability::Reliable,
        history: History::KeepLast,
        depth: 10,
    };
    core.buffer_create_datawriter_bin(be, object_id(1, ObjectKind::DataWriter), publisher, topic, qos, REPLACE)
        .unwrap(); // 14
    let msg = send(&mut core);
    let expected =
        hex("01 05 1C 00 00 0E 00 15 05 03 00 00 0E 00 00 00 00 12 01 00 0B 00 01 00 0A 00 00 00 00 00 00 13");
    assert_eq!(&msg[4..], &expected[..]);
}

#[test]
fn read_data_17_8() {
    let mut out_buf = [0u8; 2048];
    let mut core = established(0x81);
    let out = core.create_output_reliable_stream(&mut out_buf, 4).unwrap();
    let reader = object_id(1, ObjectKind::DataReader);
    for _ in 0..5 {
        core.buffer_delete_entity(out, reader).unwrap(); // requests 10..14, seq 0
    }
    core.flash_output_streams();
    drain(&mut core, T0);
    let control = DeliveryControl { max_samples: 0xFFFF, ..Default::default() };
    let req = core.buffer_request_data(out, reader, StreamId(0x80), Some(&control)).unwrap();
    assert_eq!(req, 15);
    core.flash_output_streams();
    assert_eq!(
        drain(&mut core, T0),
        vec![hex("81 80 01 00 08 01 10 00 00 0F 00 16 80 00 00 01 FF FF 00 00 00 00 00 00")]
    );
    core.buffer_cancel_data(out, reader).unwrap();
    core.flash_output_streams();
    assert_eq!(
        drain(&mut core, T0),
        vec![hex("81 80 02 00 08 01 10 00 00 10 00 16 00 00 00 01 00 00 00 00 00 00 00 00")]
    );
}

#[test]
fn data_17_5_reaches_the_topic_callback() {
    let mut in_buf = [0u8; 2048];
    let mut core = established(0x81);
    core.create_input_reliable_stream(&mut in_buf, 4).unwrap();
    let data = hex("81 80 01 00 09 01 1D 00 00 0F 00 16 01 00 00 00 11 00 00 00
         48 65 6C 6C 6F 20 44 44 53 20 77 6F 72 6C 64 21 00");
    let mut seen = Collect::default();
    // seq 1 before seq 0: stored, acknowledged with seq 0 missing.
    core.handle_input(&data, T0, &mut seen);
    assert!(seen.topics.is_empty());
    assert_eq!(drain(&mut core, T0), vec![hex("81 00 00 00 0A 01 05 00 00 00 00 01 80")]);
    core.handle_input(&hex("81 80 00 00 05 01 06 00 00 0A 00 11 00 00"), T0, &mut seen);
    assert_eq!(seen.statuses.len(), 1);
    assert_eq!(seen.topics.len(), 1);
    let (object, request, stream, bytes) = &seen.topics[0];
    assert_eq!((*object, *request, *stream), (object_id(1, ObjectKind::DataReader), 15, StreamId(0x80)));
    let sample: HelloWorld<'_> = serde_cdr::from_slice(bytes).unwrap();
    assert_eq!(sample, HelloWorld { index: 1, message: "Hello DDS world!" });
    assert_eq!(drain(&mut core, T0), vec![hex("81 00 00 00 0A 01 05 00 02 00 00 00 80")]);
}

#[test]
fn ping_17_9_in_session_with_and_without_key() {
    for session_id in [0x81u8, 0x01] {
        let mut core = established(session_id);
        core.ping(100, 3, T0);
        let sent = drain(&mut core, T0);
        let mut expected = if session_id < 0x80 { hex("01 00 00 00 AA BB CC DD") } else { hex("81 00 00 00") };
        expected.extend(hex("02 01 08 00 00 0A FF FD 02 00 00 00"));
        assert_eq!(sent, vec![expected.clone()]);
        let mut pong = expected[..expected.len() - 12].to_vec();
        pong.extend(hex(
            "06 01 1C 00 00 0A FF FD 00 01 01 0D 58 52 43 45 01 00 01 0F 00 01 0D 00 01 00 00 00 00 00 00 00",
        ));
        core.handle_input(&pong, T0, &mut ());
        assert_eq!(core.ping_state(), PingState::Answered);
    }
    // No answer: three attempts, then failure.
    let mut core = established(0x81);
    core.ping(100, 3, 0);
    let sent: usize = (0..400).map(|ms| drain(&mut core, ms * MILLIS).len()).sum();
    assert_eq!((sent, core.ping_state()), (3, PingState::Failed));
}

#[test]
fn a_ping_outside_an_established_session_fails_at_once() {
    // A micro-ROS-like firmware pings, finds the agent gone, tries to create the session again (which times
    // out), then pings again: that ping must fail, not stay pending with a retry due forever.
    let mut core = SessionCore::<1, 1, 1, 1>::new(0x81, 0xAABB_CCDD, 512);
    core.create_session_retries(1, 0);
    let sent: usize = (0..1500).map(|ms| drain(&mut core, ms * MILLIS).len()).sum();
    assert_eq!((sent, core.state()), (1, SessionState::CreateTimedOut));
    core.ping(100, 3, 2000 * MILLIS);
    assert_eq!(core.ping_state(), PingState::Failed);
    assert_eq!(drain(&mut core, 2000 * MILLIS), Vec::<Vec<u8>>::new());
    assert_eq!(core.poll_timeout(), None);
}

#[test]
fn out_of_session_ping_bytes_17_9() {
    let mut buf = [0u8; 16];
    let n = xrce_client::session::ping::encode_get_info(xrce_proto::RequestId::PING, 0x02, &mut buf).unwrap();
    assert_eq!(&buf[..n], &hex("80 00 00 00 02 01 08 00 00 0A FF FD 02 00 00 00")[..]);
    let info = hex("80 00 00 00 06 01 24 00 00 09 FF FD 00 00 01 0D 58 52 43 45 01 00 01 0F 00 01 0D 00
         01 00 00 00 01 00 00 00 01 C0 A8 01 0A 00 B8 22");
    assert!(xrce_client::session::ping::is_pong(&info));
}

#[test]
fn time_sync_17_10() {
    let mut core = established(0x81);
    core.sync();
    let t = T0 + 100;
    assert_eq!(drain(&mut core, t), vec![hex("81 00 00 00 0E 01 08 00 00 F1 53 65 64 00 00 00")]);
    let reply = hex("81 00 00 00 0F 01 18 00 00 F1 53 65 C0 27 09 00 00 F1 53 65 20 A1 07 00 00 F1 53 65 64 00 00 00");
    core.handle_input(&reply, T0 + 1_000_100, &mut ());
    assert!(core.synced());
    assert_eq!(core.time_offset(), -49_900);
    assert_eq!(core.epoch_nanos(T0), T0 + 49_900);
}

#[test]
fn delete_session_17_11() {
    let mut core = established(0x81);
    core.delete_session(T0);
    assert_eq!(drain(&mut core, T0), vec![hex("81 00 00 00 03 01 04 00 00 02 FF FE")]);
    core.handle_input(&hex("81 00 00 00 05 01 06 00 00 02 FF FE 00 00"), T0, &mut ());
    assert_eq!(core.state(), SessionState::Deleted);
}

#[test]
fn fragmentation_17_12() {
    let mut out_buf = [0u8; 256];
    let mut core = established(0x81);
    let out = core.create_output_reliable_stream(&mut out_buf, 4).unwrap();
    let data: Vec<u8> = (0..100).collect();
    assert_eq!(core.buffer_topic(out, object_id(1, ObjectKind::DataWriter), &data).unwrap(), 10);
    core.flash_output_streams();
    let sent = drain(&mut core, T0);
    let mut inner = hex("07 01 68 00 00 0A 00 15");
    inner.extend(&data);
    let mut m0 = hex("81 80 00 00 0D 01 34 00");
    m0.extend(&inner[..52]);
    let mut m1 = hex("81 80 01 00 0D 01 34 00");
    m1.extend(&inner[52..104]);
    let mut m2 = hex("81 80 02 00 0D 03 04 00");
    m2.extend(&inner[104..]);
    assert_eq!(sent, vec![m0, m1, m2]);
}

#[test]
fn our_fragments_reassemble_in_our_input_stream() {
    // Loop the fragments of a 1000-byte sample back into an input stream, out of order.
    let mut out_buf = [0u8; 2048];
    let mut in_buf = [0u8; 4096];
    let mut sender = established(0x81);
    let out = sender.create_output_reliable_stream(&mut out_buf, 16).unwrap();
    let data: Vec<u8> = (0..1000u32).map(|i| (i * 7) as u8).collect();
    sender.buffer_topic(out, object_id(1, ObjectKind::DataReader), &data).unwrap();
    sender.flash_output_streams();
    let mut sent = drain(&mut sender, T0);
    assert!(sent.len() > 5);
    // Turn the inner WRITE_DATA (first byte after the first FRAGMENT header) into a DATA.
    sent[0][8] = 0x09;
    let mut receiver = established(0x81);
    receiver.create_input_reliable_stream(&mut in_buf, 32).unwrap(); // 128-byte slots
    let mut seen = Collect::default();
    let order: Vec<usize> = (0..sent.len()).rev().collect();
    for i in order {
        receiver.handle_input(&sent[i], T0, &mut seen);
    }
    assert_eq!(seen.topics.len(), 1);
    assert_eq!(seen.topics[0].3, data);
}

/// Replays the agent's side of a capture into a fresh core for the client on `port`; returns what it saw.
fn replay(name: &str, pick: impl Fn(&common::Packet) -> bool) -> Collect {
    let packets = capture(name);
    let port = packets.iter().find(|p| pick(p)).map(|p| p.client_port).expect("client in capture");
    let create =
        packets.iter().find(|p| p.client_port == port && p.to_agent && p.annotation.contains("CREATE_CLIENT")).unwrap();
    let key = u32::from_be_bytes(create.bytes[create.bytes.len() - 8..create.bytes.len() - 4].try_into().unwrap());
    let session_id = create.bytes[create.bytes.len() - 4];
    // Big samples arrive as ~100 fragments: a history that holds them all, as SubscribeBigHelloWorld uses.
    let mut in_rel = vec![0u8; 128 * 520];
    let mut out_rel = vec![0u8; 8 * 512];
    let mut out_be = vec![0u8; 512];
    let mut core = Core::new(session_id, key, 512);
    core.create_output_reliable_stream(&mut out_rel, 8).unwrap();
    core.create_output_best_effort_stream(&mut out_be).unwrap();
    core.create_input_reliable_stream(&mut in_rel, 128).unwrap();
    core.create_input_best_effort_stream().unwrap();
    core.create_session(0);
    let mut seen = Collect::default();
    for p in packets.iter().filter(|p| p.client_port == port) {
        let now = (p.time * 1e9) as i64;
        drain(&mut core, now);
        if !p.to_agent {
            core.handle_input(&p.bytes, now, &mut seen);
        }
    }
    seen
}

#[test]
fn capture_subscribe_hello_world_reaches_topic_callback() {
    let seen = replay("subscribe_hello_world_udp.txt", |_| true);
    assert_eq!(seen.statuses.len(), 4, "{:?}", seen.statuses);
    assert!(seen.statuses.iter().all(|s| s.2 == STATUS_OK));
    assert!(seen.topics.len() >= 6, "{} topics", seen.topics.len());
    let mut last = None;
    for (object, _, stream, data) in &seen.topics {
        assert_eq!((*object, *stream), (object_id(1, ObjectKind::DataReader), StreamId(0x80)));
        let s: HelloWorld<'_> = serde_cdr::from_slice(data).unwrap();
        assert_eq!(s.message, "Hello DDS world!");
        if let Some(l) = last {
            assert_eq!(s.index, l + 1, "in order, once");
        }
        last = Some(s.index);
    }
}

#[test]
fn capture_best_effort_subscriber_reaches_topic_callback() {
    let seen = replay("hello_world_besteffort_pubsub_udp.txt", |p| p.to_agent && p.annotation.contains("READ_DATA"));
    assert!(!seen.topics.is_empty());
    for (_, _, _, data) in &seen.topics {
        let s: HelloWorld<'_> = serde_cdr::from_slice(data).unwrap();
        assert_eq!(s.message, "Hello DDS world!");
    }
}

#[test]
fn capture_big_hello_world_reassembles_fragments() {
    let seen = replay("big_hello_world_pubsub_udp.txt", |p| p.to_agent && p.annotation.contains("READ_DATA"));
    assert!(!seen.topics.is_empty(), "no sample reassembled");
    for (_, _, _, data) in &seen.topics {
        assert!(data.len() > 512, "sample of {} bytes", data.len());
        let (index, message): (u32, &str) = serde_cdr::from_slice(data).unwrap();
        assert!(message.len() > 500, "index {index}");
    }
}

#[test]
fn capture_request_reply_adder() {
    let packets = capture("request_reply_adder_udp.txt");
    let ports: std::collections::BTreeSet<u16> = packets.iter().map(|p| p.client_port).collect();
    let mut replies = 0;
    let mut requests = 0;
    for port in ports {
        let seen = replay("request_reply_adder_udp.txt", |p| p.client_port == port);
        replies += seen.replies.len();
        requests += seen.requests.len();
    }
    assert!(replies > 0 && requests > 0, "replies {replies}, requests {requests}");
}
