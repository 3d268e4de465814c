//! Replays the client side of real eProsima captures into the core (no sockets) and checks the agent's
//! answers semantically.

mod common;

use std::time::Duration;

use common::{data_payload as payload, load_capture, Harness, Out, Packet};
use xrce_proto::layout::{DataSubmessage, SampleBody};
use xrce_proto::{BaseObjectRequest, ObjectKind, Submessage};

/// A replier's reply (a WRITE_DATA to a replier, first in its message): where the submessage starts, its
/// request and the reply after the sample identity.
fn replier_reply(msg: &[u8]) -> Option<(usize, BaseObjectRequest, &[u8])> {
    let raw = xrce_proto::message::parse(msg).ok()?.1.next()?.ok()?;
    let Submessage::WriteData(w) = raw.decode().ok()? else { return None };
    if w.request.object_id.kind() != ObjectKind::Replier {
        return None;
    }
    Some((raw.start - xrce_proto::SubmessageHeader::SIZE, w.request, w.split_sample_identity().ok()?.1))
}

/// Ports of clients whose messages contain submessage `id` (any position).
fn ports_sending(packets: &[Packet], id: u8) -> Vec<u16> {
    let mut ports: Vec<u16> = packets
        .iter()
        .filter(|p| p.to_agent)
        .filter(|p| {
            let Ok((h, subs)) = xrce_proto::message::parse(&p.data) else { return false };
            let _ = h;
            subs.filter_map(Result::ok).any(|s| s.header.id == id)
        })
        .map(|p| p.port)
        .collect();
    ports.sort_unstable();
    ports.dedup();
    ports
}

fn assert_all_ok(h: &Harness, port: u16) {
    let statuses = h.statuses(port);
    assert!(!statuses.is_empty(), "port {port} got no STATUS");
    for (req, status) in statuses {
        assert!(status <= 1, "port {port}: request {req} answered with status {status:#04x}");
    }
    assert!(h.outs(port).iter().any(|o| matches!(o, Out::StatusAgent { status: 0 })), "no STATUS_AGENT OK");
}

#[test]
fn reliable_pubsub_capture_delivers_hello_world() {
    let packets = load_capture("hello_world_pubsub_udp.all.txt");
    let readers = ports_sending(&packets, 8);
    let writers = ports_sending(&packets, 7);
    assert_eq!((readers.len(), writers.len()), (1, 1));
    let mut h = Harness::new();
    h.replay(&packets);
    assert_all_ok(&h, readers[0]);
    assert_all_ok(&h, writers[0]);
    let data = h.data(readers[0]);
    assert!(data.len() >= 5, "subscriber got {} samples", data.len());
    assert!(data.iter().all(|d| d.ends_with(b"Hello DDS world!\0")));
    // Samples arrive in publication order, without duplicates.
    let indexes: Vec<u32> = data.iter().map(|d| u32::from_le_bytes([d[0], d[1], d[2], d[3]])).collect();
    assert!(indexes.windows(2).all(|w| w[0] < w[1]), "{indexes:?}");
    // Every reliable message of the clients was acknowledged with an ACKNACK on stream 0.
    assert!(h.outs(writers[0]).iter().any(|o| matches!(o, Out::AckNack { stream: 0x80, .. })));
}

#[test]
fn best_effort_pubsub_capture_delivers() {
    let packets = load_capture("hello_world_besteffort_pubsub_udp.txt");
    let readers = ports_sending(&packets, 8);
    let writers = ports_sending(&packets, 7);
    let mut h = Harness::new();
    h.replay(&packets);
    assert_all_ok(&h, readers[0]);
    assert_all_ok(&h, writers[0]);
    let data = h.data(readers[0]);
    assert!(!data.is_empty());
    assert!(data.iter().all(|d| d.ends_with(b"Hello DDS world!\0")));
}

#[test]
fn big_fragmented_samples_are_reassembled_and_fragmented_back() {
    let packets = load_capture("big_hello_world_pubsub_udp.txt");
    let readers = ports_sending(&packets, 8);
    let writers = ports_sending(&packets, 13);
    assert_eq!((readers.len(), writers.len()), (1, 1));
    let mut h = Harness::new();
    h.replay(&packets);
    assert_all_ok(&h, readers[0]);
    let data = h.data(readers[0]);
    assert!(!data.is_empty(), "no big sample delivered");
    for d in &data {
        // index (4) + string length (4) + 49,999 characters + NUL
        let len = u32::from_le_bytes([d[4], d[5], d[6], d[7]]) as usize;
        assert_eq!(d.len(), 8 + len);
        assert!(len >= 49_999, "len {len}");
    }
    // Every message to the reader respects its MTU (508).
    for r in h.received.get(&readers[0]).unwrap() {
        if r.header.stream_id.0 == 0 {
            assert!(r.raw.len() <= 508);
        }
    }
}

#[test]
fn binary_entity_creation_capture_is_all_ok() {
    for name in [
        "binary_entity_creation_udp.txt",
        "binary_entity_creation_ced_agentv2.3.0_udp.txt",
        "binary_entity_creation_ced_agentv3.0.1_udp.txt",
    ] {
        let packets = load_capture(name);
        let port = packets[0].port;
        let mut h = Harness::new();
        h.replay(&packets);
        assert_all_ok(&h, port);
        // The session ends with DELETE of the client: answered OK on stream 0.
        let last = h.received.get(&port).unwrap().last().unwrap().clone();
        assert_eq!(last.header.stream_id.0, 0);
        assert!(matches!(last.subs[0], Out::Status { request: 2, object: 0xFFFE, status: 0 }), "{name}: {last:?}");
        assert!(h.core.client_keys().is_empty());
        // The client wrote on its own writer and read it back through CED.
        assert!(!h.data(port).is_empty(), "{name}: no data");
    }
}

#[test]
fn request_reply_capture_routes_requests_and_replies() {
    let packets = load_capture("request_reply_adder_udp.txt");
    let replier_port = packets
        .iter()
        .find(|p| p.to_agent && p.data.windows(8).any(|w| w == b"<replier"))
        .map(|p| p.port)
        .expect("replier creation");
    let mut h = Harness::new();
    // The replier echoes the sample identity of the request it answers; the capture holds eProsima's
    // identities, so substitute ours, in order, as the C client would have.
    let mut replies = 0;
    let start = h.now;
    for p in packets.iter().filter(|p| p.to_agent) {
        let at = start + Duration::from_secs_f64(p.t);
        if at > h.now {
            let d = at - h.now;
            h.advance(d);
        }
        let mut data = p.data.clone();
        if p.port == replier_port {
            if let Some((at, request, reply)) = replier_reply(&p.data) {
                let requests = h.data(replier_port);
                let (identity, _) = payload(&requests[replies]).split_sample_identity().unwrap();
                let sub = DataSubmessage::write_data(request, SampleBody::WithIdentity { identity, data: reply });
                let n = sub.emit_into(&mut data[at..]).unwrap();
                assert_eq!(at + n, p.data.len(), "the same length, in place");
                replies += 1;
            }
        }
        h.send(p.port, &data);
    }
    assert!(replies > 0);
    let ports: Vec<u16> = {
        let mut p: Vec<u16> = packets.iter().filter(|p| p.to_agent).map(|p| p.port).collect();
        p.sort_unstable();
        p.dedup();
        p
    };
    for port in &ports {
        assert_all_ok(&h, *port);
    }
    // Replier gets DATA = identity (24) + request (two i32); requester gets DATA = BaseObjectRequest + sum.
    let mut replier_got = false;
    let mut requester_got = false;
    for port in &ports {
        for o in h.outs(*port) {
            if let Out::Data { object, data, .. } = o {
                match object & 0x0F {
                    8 => {
                        replier_got = true;
                        assert_eq!(payload(&data).split_sample_identity().unwrap().1.len(), 8);
                    }
                    7 => {
                        requester_got = true;
                        assert_eq!(payload(&data).split_base_request().unwrap().1.len(), 8);
                    }
                    k => panic!("unexpected DATA on kind {k}"),
                }
            }
        }
    }
    assert!(replier_got && requester_got, "replier {replier_got} requester {requester_got}");
}

#[test]
fn ping_capture_gets_info_in_and_out_of_session() {
    let packets = load_capture("ping_agent_udp.txt");
    let port = packets[0].port;
    let mut h = Harness::new();
    h.replay(&packets);
    let infos: Vec<(u8, u8)> = h
        .received
        .get(&port)
        .unwrap()
        .iter()
        .filter_map(|r| match r.subs.first() {
            Some(Out::Info { implementation_status, .. }) => Some((r.header.session_id, *implementation_status)),
            _ => None,
        })
        .collect();
    assert_eq!(infos.len(), 2, "{infos:?}");
    assert!(infos.contains(&(0x81, 1)), "in-session pong with implementation status 1: {infos:?}");
}

#[test]
fn ping_reply_matches_spec_bytes() {
    let mut h = Harness::new();
    h.send(9, &[0x80, 0x00, 0x00, 0x00, 0x02, 0x01, 0x08, 0x00, 0x00, 0x0A, 0xFF, 0xFD, 0x02, 0x00, 0x00, 0x00]);
    let r = &h.received[&9][0];
    assert_eq!(
        r.raw,
        [
            0x80, 0, 0, 0, 0x06, 0x01, 0x1C, 0x00, 0x00, 0x0A, 0xFF, 0xFD, 0x00, 0x00, 0x01, 0x0D, 0x58, 0x52, 0x43,
            0x45, 0x01, 0x00, 0x01, 0x0F, 0x00, 0x01, 0x0D, 0x00, 0x01, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00
        ]
    );
}

#[test]
fn timesync_capture_echoes_originate() {
    let packets = load_capture("timesync_udp.txt");
    let port = packets[0].port;
    let mut h = Harness::new();
    h.replay(&packets);
    let replies: Vec<(i32, u32)> = h
        .outs(port)
        .into_iter()
        .filter_map(|o| match o {
            Out::TimestampReply { originate } => Some(originate),
            _ => None,
        })
        .collect();
    assert_eq!(replies.len(), 3);
    let sent: Vec<(i32, u32)> = packets
        .iter()
        .filter(|p| p.to_agent)
        .filter_map(|p| match xrce_proto::message::parse(&p.data).ok()?.1.next()?.ok()?.decode().ok()? {
            Submessage::Timestamp(t) => Some((t.seconds, t.nanoseconds)),
            _ => None,
        })
        .collect();
    assert_eq!(replies, sent);
}

#[test]
fn spec_vectors_create_client_and_status_agent() {
    let mut h = Harness::new();
    let create = [
        0x80, 0x00, 0x00, 0x00, 0x00, 0x01, 0x10, 0x00, 0x58, 0x52, 0x43, 0x45, 0x01, 0x00, 0x01, 0x0F, 0xAA, 0xBB,
        0xCC, 0xDD, 0x81, 0x00, 0xFC, 0x01,
    ];
    h.send(1, &create);
    assert_eq!(
        h.received[&1][0].raw,
        [0x81, 0, 0, 0, 0x04, 0x01, 0x0B, 0x00, 0x00, 0x00, 0x58, 0x52, 0x43, 0x45, 0x01, 0x00, 0x01, 0x0F, 0x00]
    );
    // Keyed session 0x01.
    let keyed = [
        0x00, 0, 0, 0, 0xAA, 0xBB, 0xCC, 0xDE, 0x00, 0x01, 0x10, 0x00, 0x58, 0x52, 0x43, 0x45, 0x01, 0x00, 0x01, 0x0F,
        0xAA, 0xBB, 0xCC, 0xDE, 0x01, 0x00, 0xFC, 0x01,
    ];
    h.send(2, &keyed);
    assert_eq!(
        h.received[&2][0].raw,
        [
            0x01, 0, 0, 0, 0xAA, 0xBB, 0xCC, 0xDE, 0x04, 0x01, 0x0B, 0x00, 0x00, 0x00, 0x58, 0x52, 0x43, 0x45, 0x01,
            0x00, 0x01, 0x0F, 0x00
        ]
    );
    // Participant by XML on reliable stream 0x80 (spec §17.4): STATUS on 0x80 seq 0, ACKNACK first_unacked 1.
    let xml = b"<dds><participant><rtps><name>default_xrce_participant</name></rtps></participant></dds>";
    let mut msg =
        vec![0x81, 0x80, 0x00, 0x00, 0x01, 0x05, 0x68, 0x00, 0x00, 0x0A, 0x00, 0x11, 0x01, 0x02, 0, 0, 0x59, 0, 0, 0];
    msg.extend_from_slice(xml);
    msg.extend_from_slice(&[0x00, 0x00, 0x00, 0x00]);
    assert_eq!(msg.len(), 112);
    h.auto_ack = false;
    h.send(1, &msg);
    let raws: Vec<Vec<u8>> = h.received[&1].iter().skip(1).map(|r| r.raw.clone()).collect();
    assert!(raws.contains(&vec![0x81, 0x80, 0x00, 0x00, 0x05, 0x01, 0x06, 0x00, 0x00, 0x0A, 0x00, 0x11, 0x00, 0x00]));
    assert!(raws.contains(&vec![0x81, 0, 0, 0, 0x0A, 0x01, 0x05, 0x00, 0x01, 0x00, 0x00, 0x00, 0x80]));
    // Unacknowledged: the agent heartbeats its stream 0x80 (first 0, last 0).
    h.advance(Duration::from_millis(250));
    assert!(h.outs(1).contains(&Out::Heartbeat { first: 0, last: 0, stream: 0x80 }));
    // Delete the session (spec §17.11).
    h.send(1, &[0x81, 0x00, 0x00, 0x00, 0x03, 0x01, 0x04, 0x00, 0x00, 0x02, 0xFF, 0xFE]);
    assert_eq!(
        h.received[&1].last().unwrap().raw,
        [0x81, 0x00, 0x00, 0x00, 0x05, 0x01, 0x06, 0x00, 0x00, 0x02, 0xFF, 0xFE, 0x00, 0x00]
    );
}

#[test]
fn tcp_capture_with_references_is_all_ok() {
    use xrce_proto::framing::tcp::{TcpDecoder, TcpEvent};
    let packets = load_capture("tcp_ping_and_shapes.txt");
    let mut h = Harness::with_core(common::new_core_with_refs());
    // Interleave connections packet by packet, decoding each connection's byte stream.
    let mut decoders: std::collections::HashMap<u16, TcpDecoder<Vec<u8>>> = Default::default();
    let mut messages = 0;
    for p in packets.iter().filter(|p| p.to_agent) {
        let dec = decoders.entry(p.port).or_insert_with(|| TcpDecoder::new(vec![0u8; 65535]));
        let mut msgs = Vec::new();
        dec.push(&p.data, |e| {
            if let TcpEvent::Message(m) = e {
                msgs.push(m.to_vec());
            }
        });
        for m in msgs {
            messages += 1;
            h.send(p.port, &m);
        }
    }
    assert!(messages > 10);
    let ports: Vec<u16> = common::tcp_streams(&packets).into_iter().map(|(p, _)| p).collect();
    let mut statuses = 0;
    for port in &ports {
        for (req, status) in h.statuses(*port) {
            statuses += 1;
            assert!(status <= 1, "port {port}: request {req} → {status:#04x}");
        }
    }
    assert!(statuses >= 8, "only {statuses} STATUS");
    // The ShapesDemo publisher's squares reach the subscriber through CED, by reference.
    let got: usize = ports.iter().map(|p| h.data(*p).len()).sum();
    assert!(got > 0, "no shape delivered");
}
