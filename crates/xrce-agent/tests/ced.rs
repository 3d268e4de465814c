//! Two clients talking through CED, driven through the core without sockets.

mod common;

use std::time::Duration;

use common::{create_client_msg, data_payload, unlimited, Client, Harness, Out};
use xrce_proto::layout::SampleBody;
use xrce_proto::submessage::DataDeliveryControl;
use xrce_proto::{ObjectId, ObjectKind, Submessage};

/// The first submessage of a client's message.
fn decode_client(msg: &[u8]) -> Submessage<'_> {
    let (_, mut subs) = xrce_proto::message::parse(msg).unwrap();
    subs.next().unwrap().unwrap().decode().unwrap()
}

const PUB: u16 = 1;
const SUB: u16 = 2;

/// The `u32` counters the subscriber received, in order.
fn counters(h: &Harness) -> Vec<u32> {
    h.data(SUB).iter().map(|d| u32::from_le_bytes([d[0], d[1], d[2], d[3]])).collect()
}

/// Writes `0..n` as one receive batch of the UDP shell (no delivery in between), then runs the exchange.
fn write_batch(h: &mut Harness, p: &mut Client, reliable: bool, n: u32) {
    let writer = ObjectId::new(1, ObjectKind::DataWriter);
    for i in 0..n {
        let m = p.write(reliable, writer, &i.to_le_bytes());
        h.core.handle_datagram(PUB, &m, h.now);
    }
    h.drain();
}

fn setup_pubsub(h: &mut Harness, topic_pub: &str, topic_sub: &str) -> (Client, Client) {
    let mut p = Client::new(0x1111_1111);
    let mut s = Client::new(0x2222_2222);
    h.send(PUB, &create_client_msg(p.key, 0x81));
    h.send(SUB, &create_client_msg(s.key, 0x81));
    for m in p.pubsub_entities(topic_pub) {
        h.send(PUB, &m);
    }
    for m in s.pubsub_entities(topic_sub) {
        h.send(SUB, &m);
    }
    assert_eq!(h.statuses(PUB).len(), 6);
    assert!(h.statuses(PUB).iter().chain(h.statuses(SUB).iter()).all(|(_, st)| *st == 0));
    (p, s)
}

#[test]
fn two_clients_pubsub_reliable_and_best_effort() {
    let mut h = Harness::new();
    let (mut p, mut s) = setup_pubsub(&mut h, "chatter", "chatter");
    let reader = ObjectId::new(1, ObjectKind::DataReader);
    let writer = ObjectId::new(1, ObjectKind::DataWriter);
    h.send(SUB, &s.read(reader, 0x80, unlimited()));
    for i in 0..40u32 {
        h.send(PUB, &p.write(i % 2 == 0, writer, &i.to_le_bytes()));
    }
    let got = counters(&h);
    assert_eq!(got, (0..40).collect::<Vec<_>>());
    // Best-effort delivery stream.
    h.send(SUB, &s.read(reader, 0x01, unlimited()));
    h.send(PUB, &p.write(false, writer, b"be!!"));
    assert_eq!(h.data(SUB).last().unwrap(), b"be!!");
    // Different topic: nothing crosses.
    let before = h.data(SUB).len();
    let mut other = Client::new(0x3333_3333);
    h.send(3, &create_client_msg(other.key, 0x81));
    for m in other.pubsub_entities("other") {
        h.send(3, &m);
    }
    h.send(3, &other.write(false, writer, b"xxxx"));
    assert_eq!(h.data(SUB).len(), before);
}

#[test]
fn delivery_control_limits_samples_and_cancel_stops() {
    let mut h = Harness::new();
    let (mut p, mut s) = setup_pubsub(&mut h, "t", "t");
    let reader = ObjectId::new(1, ObjectKind::DataReader);
    let writer = ObjectId::new(1, ObjectKind::DataWriter);
    // No control: exactly one sample.
    h.send(SUB, &s.read(reader, 0x80, None));
    for i in 0..3u8 {
        h.send(PUB, &p.write(true, writer, &[i]));
    }
    assert_eq!(h.data(SUB).len(), 1);
    // max_samples 3: the ring still holds samples 1 and 2, then one more.
    h.send(SUB, &s.read(reader, 0x80, Some(DataDeliveryControl { max_samples: 3, ..Default::default() })));
    for i in 3..10u8 {
        h.send(PUB, &p.write(true, writer, &[i]));
    }
    assert_eq!(h.data(SUB).len(), 4);
    // Unlimited, then cancel (stream 0, all-zero control).
    h.send(SUB, &s.read(reader, 0x80, unlimited()));
    let n = h.data(SUB).len();
    h.send(SUB, &s.read(reader, 0, Some(DataDeliveryControl::default())));
    h.send(PUB, &p.write(true, writer, &[99]));
    assert_eq!(h.data(SUB).len(), n);
}

#[test]
fn pace_and_rate_are_honoured() {
    let mut h = Harness::new();
    let (mut p, mut s) = setup_pubsub(&mut h, "t", "t");
    let reader = ObjectId::new(1, ObjectKind::DataReader);
    let writer = ObjectId::new(1, ObjectKind::DataWriter);
    let c = DataDeliveryControl { max_samples: 0xFFFF, min_pace_period: 100, ..Default::default() };
    h.send(SUB, &s.read(reader, 0x80, Some(c)));
    for i in 0..5u8 {
        h.send(PUB, &p.write(true, writer, &[i]));
    }
    assert_eq!(h.data(SUB).len(), 1, "pace: one now");
    h.advance(Duration::from_millis(250));
    assert_eq!(h.data(SUB).len(), 3, "pace: one per 100 ms");
    h.advance(Duration::from_secs(1));
    assert_eq!(h.data(SUB).len(), 5);
    // max_elapsed_time ends the task.
    let c = DataDeliveryControl { max_samples: 0xFFFF, max_elapsed_time: 1, ..Default::default() };
    h.send(SUB, &s.read(reader, 0x80, Some(c)));
    h.advance(Duration::from_millis(1500));
    h.send(PUB, &p.write(true, writer, &[42]));
    assert_eq!(h.data(SUB).len(), 5);
}

#[test]
fn request_reply_between_two_clients() {
    let mut h = Harness::new();
    let mut req = Client::new(0xA1);
    let mut rep = Client::new(0xA2);
    h.send(1, &create_client_msg(req.key, 0x81));
    h.send(2, &create_client_msg(rep.key, 0x81));
    for m in req.service_entities("adder", ObjectKind::Requester) {
        h.send(1, &m);
    }
    for m in rep.service_entities("adder", ObjectKind::Replier) {
        h.send(2, &m);
    }
    let requester = ObjectId::new(1, ObjectKind::Requester);
    let replier = ObjectId::new(1, ObjectKind::Replier);
    h.send(1, &req.read(requester, 0x80, unlimited()));
    h.send(2, &rep.read(replier, 0x80, unlimited()));
    let write = req.write(true, requester, &[1, 0, 0, 0, 2, 0, 0, 0]);
    let request_id = match decode_client(&write) {
        Submessage::WriteData(w) => w.request.request_id.0,
        other => panic!("{other:?}"),
    };
    h.send(1, &write);
    let got = h.data(2);
    assert_eq!(got.len(), 1);
    let (identity, request) = data_payload(&got[0]).split_sample_identity().unwrap();
    assert_eq!(request, &[1, 0, 0, 0, 2, 0, 0, 0]);
    let body = SampleBody::WithIdentity { identity, data: &3u32.to_le_bytes() };
    let mut reply = vec![0u8; body.encoded_len()];
    body.emit_into(&mut reply).unwrap();
    h.send(2, &rep.write(true, replier, &reply));
    let answers: Vec<(u16, Vec<u8>)> = h
        .outs(1)
        .into_iter()
        .filter_map(|o| match o {
            Out::Data { data, .. } => {
                let (related, reply) = data_payload(&data).split_base_request().unwrap();
                Some((related.request_id.0, reply.to_vec()))
            }
            _ => None,
        })
        .collect();
    assert_eq!(answers, vec![(request_id, 3u32.to_le_bytes().to_vec())]);
}

#[test]
fn xml_entities_work_on_ced() {
    let mut h = Harness::new();
    let packets = common::load_capture("hello_world_pubsub_udp.all.txt");
    // Only the entity creation parts of both clients, then one hand-made sample.
    h.replay(&packets[..packets.len().min(40)]);
    let ok = h.received.keys().all(|port| h.statuses(*port).iter().all(|(_, s)| *s == 0));
    assert!(ok);
}

#[test]
fn delete_removes_children_and_reuse_matches() {
    let mut h = Harness::new();
    let (mut p, _s) = setup_pubsub(&mut h, "t", "t");
    let participant = ObjectId::new(1, ObjectKind::Participant);
    let writer = ObjectId::new(1, ObjectKind::DataWriter);
    let key = xrce_proto::ClientKey::from_u32(p.key);
    assert!(h.core.has_object(key, writer));
    // REUSE of the same participant → OK_MATCHED.
    let mut m = p.create(
        participant,
        xrce_proto::EntityVariant::participant(
            xrce_proto::Representation::Binary(xrce_proto::object::BinaryObject::Raw(&[0, 0])),
            0,
        ),
    );
    m[5] = 0x03; // flags E|REUSE
    h.send(PUB, &m);
    assert_eq!(h.statuses(PUB).last().unwrap().1, 0x01);
    // Without REUSE/REPLACE → ALREADY_EXISTS.
    let mut m = p.create(
        participant,
        xrce_proto::EntityVariant::participant(
            xrce_proto::Representation::Binary(xrce_proto::object::BinaryObject::Raw(&[0, 0])),
            0,
        ),
    );
    m[5] = 0x01;
    h.send(PUB, &m);
    assert_eq!(h.statuses(PUB).last().unwrap().1, 0x82);
    // DELETE participant removes the writer too.
    let mut req = p.next_request();
    req.object_id = participant;
    h.send(PUB, &p.encode(true, &xrce_proto::Submessage::Delete(req)));
    assert_eq!(h.statuses(PUB).last().unwrap().1, 0x00);
    assert!(!h.core.has_object(key, writer));
    // Unknown object → UNKNOWN_REFERENCE.
    h.send(PUB, &p.encode(true, &xrce_proto::Submessage::Delete(req)));
    assert_eq!(h.statuses(PUB).last().unwrap().1, 0x84);
    // Writing to the deleted writer is silently dropped.
    h.send(PUB, &p.write(true, writer, b"x"));
}

#[test]
fn lost_messages_are_retransmitted_and_heartbeats_sent() {
    let mut h = Harness::new();
    let (mut p, mut s) = setup_pubsub(&mut h, "t", "t");
    let reader = ObjectId::new(1, ObjectKind::DataReader);
    let writer = ObjectId::new(1, ObjectKind::DataWriter);
    h.auto_ack = false;
    h.send(SUB, &s.read(reader, 0x80, unlimited()));
    for i in 0..20u8 {
        h.send(PUB, &p.write(false, writer, &[i]));
    }
    // Window of 16 without ACKs.
    assert_eq!(h.data(SUB).len(), 16);
    h.advance(Duration::from_millis(300));
    assert!(h.outs(SUB).iter().any(|o| matches!(o, Out::Heartbeat { stream: 0x80, .. })));
    // A NACK of the first DATA: it is sent again (the harness ignores the duplicate).
    let first_data_seq = 6u16; // 6 STATUS before the DATA on 0x80
    let ack =
        xrce_proto::submessage::AckNack { first_unacked_seq_num: first_data_seq, nack_bitmap: [0, 1], stream_id: 0x80 };
    let raw = s.encode(false, &xrce_proto::Submessage::AckNack(ack));
    // ACKNACK travels on stream 0: patch the header's stream.
    let mut raw = raw;
    raw[1] = 0;
    raw[2] = 0;
    let before = h.core.stats().messages_out;
    h.send(SUB, &raw);
    assert_eq!(h.core.stats().messages_out, before + 1, "exactly the NACKed message is resent");
    // Acknowledging everything lets the rest flow.
    h.auto_ack = true;
    h.advance(Duration::from_millis(300));
    assert_eq!(h.data(SUB).len(), 20);
}

/// The publisher's latest ACKNACK for its reliable stream 0x80: first unacknowledged sequence number.
fn publisher_first_unacked(h: &Harness) -> Option<u16> {
    h.outs(PUB).into_iter().rev().find_map(|o| match o {
        Out::AckNack { first, stream: 0x80, .. } => Some(first),
        _ => None,
    })
}

/// Back-pressure: a reliable reader that does not keep up holds the reliable writer back (its messages stay
/// unacknowledged, so a real client's history fills and its writes block) instead of the agent dropping
/// samples; once the reader acknowledges, every sample arrives, once, in order.
#[test]
fn slow_reliable_reader_holds_the_writer_back_without_loss() {
    let mut h = Harness::new();
    let (mut p, mut s) = setup_pubsub(&mut h, "backpressure", "backpressure");
    let reader = ObjectId::new(1, ObjectKind::DataReader);
    let writer = ObjectId::new(1, ObjectKind::DataWriter);
    h.send(SUB, &s.read(reader, 0x80, unlimited()));
    h.auto_ack = false;
    let base = p.seq_rel;
    let total = 300usize;
    let msgs: Vec<Vec<u8>> = (0..total as u32).map(|i| p.write(true, writer, &i.to_le_bytes())).collect();
    // A publisher with a history of 8: it sends while fewer than 8 messages are unacknowledged.
    let mut sent = 0usize;
    let run = |h: &mut Harness, sent: &mut usize| -> usize {
        loop {
            let acked = publisher_first_unacked(h).map_or(0, |f| usize::from(f.wrapping_sub(base)));
            if *sent >= total || *sent >= acked + 8 {
                return acked;
            }
            h.send(PUB, &msgs[*sent]);
            *sent += 1;
        }
    };
    let stalled_at = run(&mut h, &mut sent);
    assert!(stalled_at < total, "the writer is held back while the reader does not acknowledge");
    assert_eq!(h.data(SUB).len(), 16, "a reliable window in flight to the reader");
    // The reader catches up: everything flows, nothing was lost.
    h.auto_ack = true;
    for _ in 0..200 {
        h.advance(Duration::from_millis(250));
        if run(&mut h, &mut sent) >= total {
            break;
        }
    }
    let got = counters(&h);
    assert_eq!(got, (0..total as u32).collect::<Vec<_>>());
}

/// Samples waiting when a read starts: packed several per message only for clients that read packed
/// messages (`pack_data`), one DATA per message otherwise (eProsima's C client reads one DATA per message).
#[test]
fn data_is_packed_only_when_the_client_can_read_it() {
    for (pack, reliable) in [(false, true), (true, true), (false, false), (true, false)] {
        let config = xrce_agent::core::CoreConfig { pack_data: pack, ..Default::default() };
        let core = xrce_agent::core::AgentCore::new(
            config,
            xrce_agent::middleware::ced::Ced::new(std::sync::Arc::new(
                xrce_agent::middleware::describe::FallbackProfiles,
            )),
        );
        let mut h = Harness::with_core(core);
        let (mut p, mut s) = setup_pubsub(&mut h, "packed", "packed");
        let writer = ObjectId::new(1, ObjectKind::DataWriter);
        for i in 0..10u32 {
            h.send(PUB, &p.write(true, writer, &i.to_le_bytes()));
        }
        let stream = if reliable { 0x80 } else { 0x01 };
        h.send(SUB, &s.read(ObjectId::new(1, ObjectKind::DataReader), stream, unlimited()));
        let got = counters(&h);
        assert_eq!(got, (0..10).collect::<Vec<_>>(), "pack {pack} reliable {reliable}");
        let data_messages: Vec<usize> = h.received[&SUB]
            .iter()
            .map(|r| r.subs.iter().filter(|o| matches!(o, Out::Data { .. })).count())
            .filter(|n| *n > 0)
            .collect();
        if pack {
            assert!(data_messages.len() < 10 && data_messages.iter().sum::<usize>() == 10, "{data_messages:?}");
            assert!(h.received[&SUB].iter().all(|r| r.raw.len() <= 508));
        } else {
            assert_eq!(data_messages, vec![1; 10], "reliable {reliable}");
        }
    }
}

/// A reliable reader whose client went silent (past the 30 s dead time) stops holding its writers back.
#[test]
fn a_silent_reliable_reader_stops_holding_writers_after_the_dead_time() {
    let mut h = Harness::new();
    let (mut p, mut s) = setup_pubsub(&mut h, "vanished", "vanished");
    h.send(SUB, &s.read(ObjectId::new(1, ObjectKind::DataReader), 0x80, unlimited()));
    h.auto_ack = false;
    let writer = ObjectId::new(1, ObjectKind::DataWriter);
    let base = p.seq_rel;
    let total = 200usize;
    let msgs: Vec<Vec<u8>> = (0..total as u32).map(|i| p.write(true, writer, &i.to_le_bytes())).collect();
    let mut sent = 0usize;
    let run = |h: &mut Harness, sent: &mut usize| -> usize {
        loop {
            let acked = publisher_first_unacked(h).map_or(0, |f| usize::from(f.wrapping_sub(base)));
            if *sent >= total || *sent >= acked + 8 {
                return acked;
            }
            h.send(PUB, &msgs[*sent]);
            *sent += 1;
        }
    };
    assert!(run(&mut h, &mut sent) < total, "held back while the reader is alive");
    h.advance(Duration::from_secs(29));
    assert!(run(&mut h, &mut sent) < total, "still held back within the dead time");
    h.advance(Duration::from_secs(2));
    assert!(run(&mut h, &mut sent) >= total, "released once the reader's client is dead");
}

/// A reliable reader whose client keeps talking but acknowledges nothing stops holding writers back after the
/// dead time too, and holds them again once it acknowledges.
#[test]
fn a_reliable_reader_that_never_acknowledges_stops_holding_writers() {
    use xrce_proto::{message, ClientKey, MessageHeader, StreamId, Submessage};
    let mut h = Harness::new();
    let (mut p, mut s) = setup_pubsub(&mut h, "deaf", "deaf");
    h.send(SUB, &s.read(ObjectId::new(1, ObjectKind::DataReader), 0x80, unlimited()));
    h.auto_ack = false;
    let writer = ObjectId::new(1, ObjectKind::DataWriter);
    let base = p.seq_rel;
    let total = 200usize;
    let msgs: Vec<Vec<u8>> = (0..total as u32).map(|i| p.write(true, writer, &i.to_le_bytes())).collect();
    let mut sent = 0usize;
    let run = |h: &mut Harness, sent: &mut usize| -> usize {
        loop {
            let acked = publisher_first_unacked(h).map_or(0, |f| usize::from(f.wrapping_sub(base)));
            if *sent >= total || *sent >= acked + 8 {
                return acked;
            }
            h.send(PUB, &msgs[*sent]);
            *sent += 1;
        }
    };
    assert!(run(&mut h, &mut sent) < total);
    // The subscriber stays alive (a ping every second) but never acknowledges its DATA.
    let ping = {
        let header = MessageHeader::new(0x81, StreamId::NONE, 0, ClientKey::from_u32(s.key));
        let get = xrce_proto::submessage::GetInfo { request: Default::default(), info_mask: 0 };
        let mut buf = [0u8; 64];
        let n = message::encode_single(&mut buf, &header, &Submessage::GetInfo(get), xrce_proto::Endianness::Little)
            .unwrap();
        buf[..n].to_vec()
    };
    for _ in 0..29 {
        h.advance(Duration::from_secs(1));
        h.send(SUB, &ping);
    }
    assert!(run(&mut h, &mut sent) < total, "still held back within the dead time");
    for _ in 0..3 {
        h.advance(Duration::from_secs(1));
        h.send(SUB, &ping);
    }
    assert!(run(&mut h, &mut sent) >= total, "released: the reader made no progress for the dead time");
}

/// Samples handled in one batch (one `recvmmsg`) reach a packing reader in one message; without packing
/// (eProsima's C client) each sample still gets its own message.
#[test]
fn a_batch_of_writes_reaches_a_packing_reader_in_one_message() {
    for pack in [true, false] {
        let config = xrce_agent::core::CoreConfig { pack_data: pack, ..Default::default() };
        let mut h = Harness::with_core(common::new_core_with(config));
        let (mut p, mut s) = setup_pubsub(&mut h, "batch", "batch");
        let reader = ObjectId::new(1, ObjectKind::DataReader);
        h.send(SUB, &s.read(reader, 0x80, unlimited()));
        let before = h.received.get(&SUB).map_or(0, Vec::len);
        write_batch(&mut h, &mut p, true, 8);
        let got = counters(&h);
        assert_eq!(got, (0..8).collect::<Vec<_>>(), "pack {pack}");
        let with_data =
            h.received[&SUB][before..].iter().filter(|r| r.subs.iter().any(|o| matches!(o, Out::Data { .. }))).count();
        assert_eq!(with_data, if pack { 1 } else { 8 }, "messages carrying the 8 samples, pack {pack}");
    }
}

/// A receive batch longer than a CED topic's 16 samples loses nothing for a best-effort reader: the core
/// serves readers every few writes within the batch (a regression of batch delivery, seen at 150k/s).
#[test]
fn a_long_batch_of_writes_loses_nothing_for_a_best_effort_reader() {
    let mut h = Harness::new();
    let (mut p, mut s) = setup_pubsub(&mut h, "long", "long");
    let reader = ObjectId::new(1, ObjectKind::DataReader);
    h.send(SUB, &s.read(reader, 0x01, unlimited()));
    // 32 best-effort writes: one full `recvmmsg` batch of the UDP shell.
    write_batch(&mut h, &mut p, false, 32);
    let got = counters(&h);
    assert_eq!(got, (0..32).collect::<Vec<_>>());
}

/// Once a subscriber has acknowledged something (a round trip is known), a DATA whose acknowledgement
/// does not come is probed after `max(2 × min RTT, 2 ms)`, doubling while unanswered, instead of waiting for
/// the 200 ms HEARTBEAT period.
#[test]
fn a_lost_tail_is_probed_within_milliseconds_once_a_round_trip_is_known() {
    let mut h = Harness::new();
    let (mut p, mut s) = setup_pubsub(&mut h, "t", "t");
    let reader = ObjectId::new(1, ObjectKind::DataReader);
    let writer = ObjectId::new(1, ObjectKind::DataWriter);
    h.send(SUB, &s.read(reader, 0x80, unlimited()));
    h.auto_ack = false;
    h.send(PUB, &p.write(false, writer, b"x"));
    assert_eq!(h.data(SUB).len(), 1);
    let beats = |h: &Harness| h.outs(SUB).iter().filter(|o| matches!(o, Out::Heartbeat { stream: 0x80, .. })).count();
    let mut seen = Vec::new();
    for _ in 0..14 {
        h.advance(Duration::from_millis(1));
        seen.push(beats(&h));
    }
    // Probes at 2, 6 (2 + 4) and 14 ms (6 + 8).
    assert_eq!(seen, [0, 1, 1, 1, 1, 2, 2, 2, 2, 2, 2, 2, 2, 3]);
    assert_eq!(h.core.stats().tail_probes, 3);
    // The subscriber answers: the DATA is released and probing stops.
    h.auto_ack = true;
    h.advance(Duration::from_millis(20));
    h.auto_ack = false;
    let settled = beats(&h);
    h.advance(Duration::from_millis(150));
    assert_eq!(beats(&h), settled, "nothing in flight, nothing probed");
}
