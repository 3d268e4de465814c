//! Hostile input: the core never panics, answers with errors or drops, and keeps serving other clients.

mod common;

use common::{create_client_msg, unlimited, Client, Harness, Out};
use proptest::prelude::*;
use xrce_proto::{ObjectId, ObjectKind};

fn hex(s: &str) -> Vec<u8> {
    s.split_whitespace().map(|b| u8::from_str_radix(b, 16).unwrap()).collect()
}

/// A healthy pub/sub pair on ports 100/101 still works.
fn assert_still_serving(h: &mut Harness) {
    let mut p = Client::new(0x5151_5151);
    let mut s = Client::new(0x5252_5252);
    h.send(100, &create_client_msg(p.key, 0x81));
    h.send(101, &create_client_msg(s.key, 0x81));
    for m in p.pubsub_entities("healthy") {
        h.send(100, &m);
    }
    for m in s.pubsub_entities("healthy") {
        h.send(101, &m);
    }
    h.send(101, &s.read(ObjectId::new(1, ObjectKind::DataReader), 0x80, unlimited()));
    h.send(100, &p.write(true, ObjectId::new(1, ObjectKind::DataWriter), b"alive"));
    assert_eq!(h.data(101).last().map(Vec::as_slice), Some(&b"alive"[..]));
}

// The AOS_XRCEFUZZ crash packets are in tests/aos_xrcefuzz.rs.

#[test]
fn truncated_prefixes_of_real_messages_are_dropped() {
    let mut h = Harness::new();
    let mut c = Client::new(0x0909_0909);
    h.send(9, &create_client_msg(c.key, 0x81));
    let mut msgs = c.pubsub_entities("t");
    msgs.push(c.read(ObjectId::new(1, ObjectKind::DataReader), 0x80, unlimited()));
    for m in &msgs {
        for len in 0..m.len() {
            h.send(10, &m[..len]);
            h.send(9, &m[..len]);
        }
    }
    assert_still_serving(&mut h);
}

#[test]
fn malformed_fields_are_refused() {
    let mut h = Harness::new();
    // mtu 0.
    h.send(1, &hex("80 00 00 00 00 01 10 00 58 52 43 45 01 00 01 0f 01 02 03 04 81 00 00 00"));
    // Bool 2 as the properties flag.
    h.send(2, &hex("80 00 00 00 00 01 10 00 58 52 43 45 01 00 01 0f 01 02 03 05 81 02 fc 01"));
    // Huge property count.
    h.send(3, &hex("80 00 00 00 00 01 14 00 58 52 43 45 01 00 01 0f 01 02 03 06 81 01 00 00 ff ff ff ff fc 01"));
    // Wrong cookie, wrong major version, key 0.
    h.send(4, &hex("80 00 00 00 00 01 10 00 58 52 43 46 01 00 01 0f 01 02 03 07 81 00 fc 01"));
    h.send(5, &hex("80 00 00 00 00 01 10 00 58 52 43 45 02 00 01 0f 01 02 03 08 81 00 fc 01"));
    h.send(6, &hex("80 00 00 00 00 01 10 00 58 52 43 45 01 00 01 0f 00 00 00 00 81 00 fc 01"));
    assert_eq!(h.outs(1), vec![Out::StatusAgent { status: 0x85 }]);
    assert!(h.outs(2).is_empty() && h.outs(3).is_empty(), "undecodable CREATE_CLIENT is dropped");
    assert_eq!(h.outs(4), vec![Out::StatusAgent { status: 0x85 }]);
    assert_eq!(h.outs(5), vec![Out::StatusAgent { status: 0x86 }]);
    assert_eq!(h.outs(6), vec![Out::StatusAgent { status: 0x85 }]);
    assert!(h.core.client_keys().is_empty());

    let mut c = Client::new(0x0A0A_0A0A);
    h.send(11, &create_client_msg(c.key, 0x81));
    // Length past the end, unknown submessage id, STATUS from a client, huge reliable sequence numbers.
    h.send(11, &hex("81 01 00 00 07 01 ff 7f 00 0b 00 15 01 02"));
    h.send(11, &hex("81 01 01 00 63 01 04 00 00 00 00 00 01 01 00 00"));
    h.send(11, &hex("81 01 02 00 05 01 06 00 00 0a 00 11 00 00"));
    h.send(11, &hex("81 80 ff 7f 0d 01 04 00 01 02 03 04"));
    h.send(11, &hex("81 80 00 80 0d 01 04 00 01 02 03 04"));
    // CREATE whose XML length runs past the end: answered INVALID_DATA with the request id.
    let mut bad = c.create(
        ObjectId::new(1, ObjectKind::Participant),
        xrce_proto::EntityVariant::participant(xrce_proto::Representation::Xml("<dds/>"), 0),
    );
    bad[16] = 0xFF;
    h.send(11, &bad);
    assert!(h.statuses(11).iter().any(|(_, s)| *s == 0x85), "{:?}", h.outs(11));
    // A writer under a missing publisher, a reader on a missing topic.
    let w = c.create(
        ObjectId::new(1, ObjectKind::DataWriter),
        xrce_proto::EntityVariant::child(
            ObjectKind::DataWriter,
            xrce_proto::Representation::Reference("x"),
            ObjectId::new(9, ObjectKind::Publisher),
        ),
    );
    h.send(11, &w);
    assert_eq!(h.statuses(11).last().unwrap().1, 0x84);
    // READ_DATA on nothing → UNKNOWN_REFERENCE on 0x80.
    h.send(11, &c.read(ObjectId::new(5, ObjectKind::DataReader), 0x80, unlimited()));
    assert_eq!(h.statuses(11).last().unwrap().1, 0x84);
    assert_still_serving(&mut h);
}

#[test]
fn unknown_sessions_get_pongs_and_delete_replies_only() {
    let mut h = Harness::new();
    h.send(1, &hex("81 00 00 00 02 01 08 00 00 0a ff fd 02 00 00 00"));
    h.send(1, &hex("81 00 00 00 03 01 04 00 00 02 ff fe"));
    h.send(1, &hex("81 80 00 00 08 01 10 00 00 0f 00 16 80 00 00 01 ff ff 00 00 00 00 00 00"));
    let outs = h.outs(1);
    assert_eq!(outs.len(), 2, "{outs:?}");
    assert!(matches!(outs[0], Out::Info { implementation_status: 0, .. }));
    assert!(matches!(outs[1], Out::Status { request: 2, object: 0xFFFE, status: 0 }));
}

#[test]
fn fragment_floods_are_bounded() {
    let mut h = Harness::new();
    let mut c = Client::new(0x0B0B_0B0B);
    h.send(12, &create_client_msg(c.key, 0x81));
    h.auto_ack = false;
    let chunk = vec![0x41u8; 60_000];
    // 2 MiB of never-ending fragments: dropped past the reassembly bound, no growth beyond it.
    for seq in 0..40u16 {
        let mut m = vec![0x81, 0x80, (seq & 0xFF) as u8, (seq >> 8) as u8, 0x0D, 0x01];
        m.extend_from_slice(&(chunk.len() as u16).to_le_bytes());
        m.extend_from_slice(&chunk);
        h.send(12, &m);
    }
    let _ = c.next_request();
    assert_still_serving(&mut h);
}

#[test]
fn many_clients_are_bounded() {
    let config = xrce_agent::core::CoreConfig { max_clients: 8, ..Default::default() };
    let mut h = Harness::with_core(common::new_core_with(config));
    for i in 0..20u32 {
        h.send(1000 + i as u16, &create_client_msg(0x100 + i, 0x81));
    }
    assert_eq!(h.core.client_keys().len(), 8);
    assert_eq!(h.outs(1019), vec![Out::StatusAgent { status: 0x87 }]);
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, .. ProptestConfig::default() })]
    #[test]
    fn random_datagrams_never_panic(datagrams in proptest::collection::vec(proptest::collection::vec(any::<u8>(), 0..200), 1..20)) {
        let mut h = Harness::new();
        let mut c = Client::new(0x0C0C_0C0C);
        h.send(1, &create_client_msg(c.key, 0x81));
        for m in c.pubsub_entities("t") {
            h.send(1, &m);
        }
        for d in &datagrams {
            h.send(1, d);
            h.send(2, d);
            // Valid header + random payload.
            let mut framed = vec![0x81, 0x80, d.first().copied().unwrap_or(0), 0];
            framed.extend_from_slice(d);
            h.send(1, &framed);
        }
        h.advance(std::time::Duration::from_secs(1));
    }
}
