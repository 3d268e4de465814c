//! Regression tests for the crashes the AOS_XRCEFUZZ project (Politecnico di Milano, 2025) found in eProsima's
//! agent with AFLNet. Each packet is rebuilt here from its description; the agent must survive it, answer
//! sensibly, and keep serving a well-behaved client on another endpoint.

mod common;

use common::{create_client_msg, Harness, Out};

/// CREATE_CLIENT (key in header, session 0x81 in the payload, no properties) announcing an MTU of 0: eProsima's
/// agent sized buffers from it and crashed ("alloc crash 1"). We refuse the client with INVALID_DATA or fall
/// back to a usable MTU; either way no crash and an answer.
fn create_client_mtu_zero() -> Vec<u8> {
    let mut m = vec![0x00, 0x00, 0x00, 0x00, 0xAA, 0xBB, 0xCC, 0xDD]; // header: session 0, stream 0, seq 0, key
    m.extend_from_slice(&[0x00, 0x01, 0x10, 0x00]); // CREATE_CLIENT, E, length 16
    m.extend_from_slice(b"XRCE");
    m.extend_from_slice(&[0x01, 0x00, 0x01, 0x0F]); // version 1.0, vendor eProsima
    m.extend_from_slice(&[0xAA, 0xBB, 0xCC, 0xDD, 0x81, 0x00]); // key, session 0x81, no properties
    m.extend_from_slice(&[0x00, 0x00]); // mtu 0
    m
}

/// A HEARTBEAT (first 0, last 0, stream 0x80) in a message of session 0x81 on stream 0 with sequence number
/// 256, from an endpoint that never created a session ("alloc crash 2").
fn heartbeat_without_session() -> Vec<u8> {
    vec![0x81, 0x00, 0x00, 0x01, 0x0B, 0x01, 0x05, 0x00, 0x00, 0x00, 0x00, 0x00, 0x80]
}

/// CREATE_CLIENT with key "aaaa" whose submessage claims 80 bytes, zeroed cookie and key, and a property
/// presence boolean of 0xFF: Fast-CDR threw an exception eProsima did not catch ("bool crash").
fn create_client_bad_bool() -> Vec<u8> {
    let mut m = vec![0x00, 0x00, 0x00, 0x00, b'a', b'a', b'a', b'a'];
    m.extend_from_slice(&[0x00, 0x01, 0x00, 0x50]); // CREATE_CLIENT, E, length 0x5000 (little endian)
    m.extend_from_slice(&[0u8; 13]); // cookie, version, vendor, key, session: all zero
    m.push(0xFF); // properties "present" flag: not a boolean
    m.resize(m.len() + 102, 0);
    m
}

fn assert_agent_still_serves(h: &mut Harness) {
    h.send(2, &create_client_msg(0x0102_0304, 0x81));
    assert!(
        h.outs(2).contains(&Out::StatusAgent { status: 0 }),
        "a good client is still served after the hostile packet: {:?}",
        h.outs(2)
    );
}

#[test]
fn every_crash_packet_inside_an_established_session_is_harmless() {
    let mut h = Harness::new();
    h.send(8, &create_client_msg(0x0808_0808, 0x81));
    for packet in [create_client_mtu_zero(), heartbeat_without_session(), create_client_bad_bool()] {
        h.send(8, &packet);
    }
    assert_agent_still_serves(&mut h);
}

#[test]
fn create_client_with_mtu_zero_is_answered_and_harmless() {
    let mut h = Harness::new();
    h.send(1, &create_client_mtu_zero());
    let outs = h.outs(1);
    assert_eq!(outs.first(), Some(&Out::StatusAgent { status: 0x85 }), "refused with INVALID_DATA: {outs:?}");
    assert!(!h.core.has_client(xrce_proto::ClientKey::from_u32(0xAABBCCDD)));
    assert_agent_still_serves(&mut h);
}

#[test]
fn heartbeat_from_unknown_session_is_dropped() {
    let mut h = Harness::new();
    h.send(1, &heartbeat_without_session());
    assert!(h.outs(1).is_empty(), "no answer to an unknown session: {:?}", h.outs(1));
    assert_agent_still_serves(&mut h);
}

#[test]
fn create_client_with_invalid_boolean_is_rejected() {
    let mut h = Harness::new();
    let packet = create_client_bad_bool();
    h.send(1, &packet);
    // The submessage length runs past the end of the datagram and the boolean is invalid: nothing is created.
    assert!(h.outs(1).iter().all(|o| !matches!(o, Out::StatusAgent { status: 0 })), "{:?}", h.outs(1));
    // Trimmed so the length fits, it still must not create a client.
    let mut fitted = packet.clone();
    fitted[10] = 16;
    fitted[11] = 0;
    h.send(3, &fitted[..8 + 4 + 16]);
    assert!(h.outs(3).iter().all(|o| !matches!(o, Out::StatusAgent { status: 0 })), "{:?}", h.outs(3));
    assert_agent_still_serves(&mut h);
}
