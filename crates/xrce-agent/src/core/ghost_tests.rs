//! Tests of liveness ([`super::liveness`]) and authentication ([`super::auth`]): no ghost clients, who may
//! create a session.

use std::net::SocketAddr;
use std::time::{Duration, Instant};

use xrce_proto::cdr::Seq;
use xrce_proto::object::{BinaryObject, ClientRepresentation};
use xrce_proto::submessage::{AckNack, CreationMode};
use xrce_proto::{
    message, ClientKey, EntityVariant, MessageHeader, ObjectId, ObjectKind, Property, Representation, StatusCode,
    StreamId, Submessage,
};

use super::auth::AuthPolicy;
use super::tests::{core_with, encode, TestCore};
use super::CoreConfig;

const A: u32 = 0xAAAA_0001;
const B: u32 = 0xBBBB_0002;
const PARTICIPANT: ObjectId = ObjectId::new(1, ObjectKind::Participant);
const SECOND: Duration = Duration::from_secs(1);

/// CREATE_CLIENT for `key` with `session` (below 0x80: the key rides in every header), with properties.
fn create(key: u32, session: u8, props: &[Property<'_>]) -> Vec<u8> {
    let k = ClientKey::from_u32(key);
    let header = MessageHeader::new(session & 0x80, StreamId::NONE, 0, k);
    let mut rep = ClientRepresentation::new(k, session, 508);
    if !props.is_empty() {
        rep.properties = Some(Seq::Items(props));
    }
    encode(&header, &Submessage::CreateClient(rep))
}

/// An ACKNACK of stream 0x80 from `key` in `session`: what a live client sends (an answer to a probe).
fn ack(key: u32, session: u8) -> Vec<u8> {
    ack_up_to(key, session, 0)
}

fn ack_up_to(key: u32, session: u8, first_unacked: u16) -> Vec<u8> {
    let header = MessageHeader::new(session, StreamId::NONE, 0, ClientKey::from_u32(key));
    let a = AckNack { first_unacked_seq_num: first_unacked, nack_bitmap: [0, 0], stream_id: 0x80 };
    encode(&header, &Submessage::AckNack(a))
}

/// What was sent, by kind: (destination, submessage id, STATUS_AGENT status if any).
fn sent(core: &mut TestCore) -> Vec<(u16, u8, Option<StatusCode>)> {
    let mut out = Vec::new();
    while let Some(t) = core.next_transmit(Instant::now()) {
        let (_, subs) = message::parse(&t.data).expect("header");
        for raw in subs.flatten() {
            let status = match raw.decode() {
                Ok(Submessage::StatusAgent(s)) => Some(s.result.status),
                _ => None,
            };
            out.push((t.to, raw.header.id, status));
        }
    }
    out
}

fn status_agent(core: &mut TestCore) -> Vec<(u16, StatusCode)> {
    sent(core).into_iter().filter_map(|(to, _, s)| Some((to, s?))).collect()
}

fn participant_variant() -> EntityVariant<'static> {
    EntityVariant::participant(Representation::Binary(BinaryObject::Raw(&[0, 0])), 0)
}

fn with_participant(core: &mut TestCore, key: u32, now: Instant) {
    let variant = participant_variant();
    let status = core.create_entity(ClientKey::from_u32(key), PARTICIPANT, &variant, CreationMode::default(), now);
    assert_eq!(status, StatusCode::OK);
}

/// The participant created as a client does, on reliable stream 0x80 (the agent answers on its own 0x80).
fn create_participant_reliably(core: &mut TestCore, port: u16, key: u32, session: u8, now: Instant) {
    let header = MessageHeader::new(session, StreamId(0x80), 0, ClientKey::from_u32(key));
    let create = xrce_proto::submessage::Create {
        request: xrce_proto::BaseObjectRequest { request_id: xrce_proto::RequestId(1), object_id: PARTICIPANT },
        mode: CreationMode::default(),
        variant: xrce_proto::ObjectVariant::Entity(participant_variant()),
    };
    core.handle_datagram(port, &encode(&header, &Submessage::Create(create)), now);
    assert!(has_participant(core, key));
}

fn has_participant(core: &TestCore, key: u32) -> bool {
    core.has_object(ClientKey::from_u32(key), PARTICIPANT)
}

/// Runs the core's timers from `from` to `to`.
fn run(core: &mut TestCore, from: Instant, to: Instant) -> Vec<(u16, u8, Option<StatusCode>)> {
    let mut out = Vec::new();
    let mut now = from;
    while let Some(t) = core.poll_timeout().filter(|t| *t <= to) {
        now = t.max(now);
        core.handle_timeout(now);
        out.extend(sent(core));
    }
    core.handle_timeout(to);
    out.extend(sent(core));
    out
}

const GET_INFO: u8 = 2;
const HEARTBEAT: u8 = 11;

#[test]
fn a_silent_client_is_probed_from_half_its_timeout_then_removed_with_its_entities() {
    let config = CoreConfig { remove_silent_clients_after: Some(10 * SECOND), ..CoreConfig::default() };
    let mut core = core_with(config);
    let t0 = Instant::now();
    core.handle_datagram(7, &create(A, 0x01, &[]), t0);
    create_participant_reliably(&mut core, 7, A, 0x01, t0);
    // Its STATUS is acknowledged: nothing in flight, so the probe's HEARTBEAT has an empty range.
    sent(&mut core);
    core.handle_datagram(7, &ack_up_to(A, 0x01, 1), t0);
    let quiet = run(&mut core, t0, t0 + Duration::from_millis(4_900));
    assert!(quiet.is_empty(), "no probe before half the timeout: {quiet:?}");
    let probing = run(&mut core, t0 + Duration::from_millis(4_900), t0 + Duration::from_millis(9_900));
    let count = |kind| probing.iter().filter(|(to, id, _)| *to == 7 && *id == kind).count();
    // GET_INFO joins from the second probe on (the C client's INFO answer is malformed).
    assert_eq!((count(GET_INFO), count(HEARTBEAT)), (3, 4), "{probing:?}");
    assert!(has_participant(&core, A));
    run(&mut core, t0 + Duration::from_millis(9_900), t0 + 10 * SECOND);
    assert!(!core.has_client(ClientKey::from_u32(A)), "removed at the timeout");
    assert!(!has_participant(&core, A));
}

#[test]
fn a_client_answering_probes_is_never_removed() {
    let config = CoreConfig { remove_silent_clients_after: Some(10 * SECOND), ..CoreConfig::default() };
    let mut core = core_with(config);
    let t0 = Instant::now();
    core.handle_datagram(7, &create(A, 0x01, &[]), t0);
    with_participant(&mut core, A, t0);
    let mut now = t0;
    let end = t0 + Duration::from_secs(120);
    // An idle client that runs its session: it sends nothing of its own and answers what it gets.
    while now < end {
        let next = core.poll_timeout().unwrap_or(end).min(end);
        let out = run(&mut core, now, next);
        now = next;
        if out.iter().any(|(to, id, _)| *to == 7 && (*id == GET_INFO || *id == HEARTBEAT)) {
            core.handle_datagram(7, &ack(A, 0x01), now + Duration::from_millis(20));
        }
    }
    assert!(has_participant(&core, A), "alive after 12 timeouts of idleness");
}

#[test]
fn no_timeout_keeps_silent_clients_as_eprosima() {
    let config = CoreConfig { remove_silent_clients_after: None, ..CoreConfig::default() };
    let mut core = core_with(config);
    let t0 = Instant::now();
    core.handle_datagram(7, &create(A, 0x01, &[]), t0);
    run(&mut core, t0, t0 + Duration::from_secs(3600));
    assert!(core.has_client(ClientKey::from_u32(A)));
}

#[test]
fn the_default_timeout_is_a_minute() {
    let mut core = core_with(CoreConfig::default());
    let t0 = Instant::now();
    core.handle_datagram(7, &create(A, 0x01, &[]), t0);
    run(&mut core, t0, t0 + Duration::from_millis(59_900));
    assert!(core.has_client(ClientKey::from_u32(A)));
    run(&mut core, t0 + Duration::from_millis(59_900), t0 + Duration::from_secs(60));
    assert!(!core.has_client(ClientKey::from_u32(A)));
}

#[test]
fn a_client_registered_through_the_api_waits_for_its_first_message_then_is_watched() {
    let config = CoreConfig { remove_silent_clients_after: Some(10 * SECOND), ..CoreConfig::default() };
    let mut core = core_with(config);
    let t0 = Instant::now();
    assert_eq!(core.create_client(ClientKey::from_u32(A), 0x01, 512, t0), StatusCode::OK);
    with_participant(&mut core, A, t0);
    run(&mut core, t0, t0 + Duration::from_secs(100));
    assert!(has_participant(&core, A), "entities prepared for a client that connects later stay");
    let t1 = t0 + Duration::from_secs(100);
    core.handle_datagram(7, &create(A, 0x01, &[]), t1);
    run(&mut core, t1, t1 + Duration::from_millis(9_990));
    assert!(has_participant(&core, A));
    run(&mut core, t1 + Duration::from_millis(9_990), t1 + 10 * SECOND);
    assert!(!core.has_client(ClientKey::from_u32(A)), "once connected, a silent client times out");
}

#[test]
fn uxr_hl_sets_the_timeout_as_eprosima() {
    let config = CoreConfig { remove_silent_clients_after: None, ..CoreConfig::default() };
    let mut core = core_with(config);
    let t0 = Instant::now();
    core.handle_datagram(7, &create(A, 0x01, &[Property { name: "uxr_hl", value: "2000" }]), t0);
    sent(&mut core);
    let before = run(&mut core, t0, t0 + Duration::from_millis(1_990));
    assert!(before.is_empty());
    let probing = run(&mut core, t0 + Duration::from_millis(1_990), t0 + Duration::from_millis(2_590));
    assert_eq!(probing.iter().filter(|(_, id, _)| *id == GET_INFO).count(), 3, "{probing:?}");
    assert!(core.has_client(ClientKey::from_u32(A)));
    run(&mut core, t0 + Duration::from_millis(2_590), t0 + Duration::from_millis(2_600));
    assert!(!core.has_client(ClientKey::from_u32(A)), "removed after uxr_hl + 3 heartbeat periods");
}

#[test]
fn a_new_session_id_deletes_the_old_entities_at_once() {
    let mut core = core_with(CoreConfig::default());
    let t0 = Instant::now();
    core.handle_datagram(7, &create(A, 0x01, &[]), t0);
    with_participant(&mut core, A, t0);
    core.handle_datagram(9, &create(A, 0x02, &[]), t0);
    assert!(core.has_client(ClientKey::from_u32(A)));
    assert!(!has_participant(&core, A), "the old session's participant is gone");
}

#[test]
fn a_new_key_from_the_same_endpoint_removes_the_old_client_once_it_stays_silent() {
    for session in [0x01, 0x81] {
        let mut core = core_with(CoreConfig::default());
        let t0 = Instant::now();
        core.handle_datagram(7, &create(A, session, &[]), t0);
        with_participant(&mut core, A, t0);
        sent(&mut core);
        // The device rebooted with a new key: its old session will never answer again.
        core.handle_datagram(7, &create(B, session, &[]), t0 + SECOND);
        let probes = run(&mut core, t0 + SECOND, t0 + Duration::from_millis(1_990));
        if session == 0x01 {
            assert!(probes.iter().any(|(to, id, _)| *to == 7 && *id == GET_INFO), "{probes:?}");
        }
        run(&mut core, t0 + Duration::from_millis(1_990), t0 + 2 * SECOND);
        assert!(!core.has_client(ClientKey::from_u32(A)), "session {session:#x}: the ghost is gone");
        assert!(!has_participant(&core, A));
        assert!(core.has_client(ClientKey::from_u32(B)));
    }
}

#[test]
fn a_second_session_sharing_the_endpoint_answers_and_stays() {
    let mut core = core_with(CoreConfig::default());
    let t0 = Instant::now();
    core.handle_datagram(7, &create(A, 0x01, &[]), t0);
    with_participant(&mut core, A, t0);
    core.handle_datagram(7, &create(B, 0x01, &[]), t0);
    sent(&mut core);
    core.handle_timeout(t0);
    assert!(sent(&mut core).iter().any(|(_, id, _)| *id == GET_INFO), "A is probed");
    core.handle_datagram(7, &ack(A, 0x01), t0 + Duration::from_millis(5));
    run(&mut core, t0 + Duration::from_millis(5), t0 + 5 * SECOND);
    assert!(has_participant(&core, A) && core.has_client(ClientKey::from_u32(B)));
}

// ---- authentication ----

fn localhost(port: &u16) -> Option<SocketAddr> {
    Some(SocketAddr::from(([127, 0, 0, 1], *port)))
}

fn auth_core(policy: AuthPolicy) -> TestCore {
    let mut core = core_with(CoreConfig { auth: policy, ..CoreConfig::default() });
    core.set_peer_address(localhost);
    core
}

#[test]
fn authentication_is_off_by_default() {
    let mut core = core_with(CoreConfig::default());
    let t0 = Instant::now();
    core.handle_datagram(7, &create(A, 0x81, &[]), t0);
    assert_eq!(status_agent(&mut core), vec![(7, StatusCode::OK)]);
    // Without authentication a key moves with its client (eProsima's behaviour).
    core.handle_datagram(8, &create(A, 0x01, &[]), t0);
    assert_eq!(status_agent(&mut core), vec![(8, StatusCode::OK)]);
}

#[test]
fn the_allow_list_admits_keys_from_their_addresses() {
    let allow = vec!["aaaa0001@127.0.0.1:7".parse().expect("rule"), "*@10.0.0.0/8".parse().expect("rule")];
    let mut core = auth_core(AuthPolicy { allow, psk: None });
    let t0 = Instant::now();
    core.handle_datagram(7, &create(A, 0x81, &[]), t0);
    core.handle_datagram(8, &create(A, 0x81, &[]), t0);
    core.handle_datagram(9, &create(B, 0x81, &[]), t0);
    assert_eq!(
        status_agent(&mut core),
        vec![(7, StatusCode::OK), (8, StatusCode::ERR_DENIED), (9, StatusCode::ERR_DENIED)]
    );
    assert!(!core.has_client(ClientKey::from_u32(B)));
}

#[test]
fn a_pre_shared_key_is_required_and_its_tokens_are_not_replayed() {
    let psk = b"correct horse battery staple".to_vec();
    let mut core = auth_core(AuthPolicy { allow: vec![], psk: Some(psk.clone()) });
    let t0 = Instant::now();
    let token = |nonce| xrce_proto::auth::Token::new(&psk, ClientKey::from_u32(A), 0x01, nonce);
    let t1 = token(1);
    let good = create(A, 0x01, &[Property { name: xrce_proto::auth::AUTH_PROPERTY, value: t1.as_str() }]);
    // An eProsima client, which sends no token.
    core.handle_datagram(7, &create(A, 0x01, &[]), t0);
    // A token made with another key.
    let forged = xrce_proto::auth::Token::new(b"guess", ClientKey::from_u32(A), 0x01, 2);
    core.handle_datagram(7, &create(A, 0x01, &[Property { name: "xrce_rs_auth", value: forged.as_str() }]), t0);
    assert_eq!(status_agent(&mut core), vec![(7, StatusCode::ERR_DENIED), (7, StatusCode::ERR_DENIED)]);
    core.handle_datagram(7, &good, t0);
    // The client resends it when the reply is lost: same session, same address, still fine.
    core.handle_datagram(7, &good, t0);
    assert_eq!(status_agent(&mut core), vec![(7, StatusCode::OK), (7, StatusCode::OK)]);
    // Once the session is gone, the captured message is worth nothing.
    assert_eq!(core.delete_client(ClientKey::from_u32(A)), StatusCode::OK);
    core.handle_datagram(7, &good, t0);
    assert_eq!(status_agent(&mut core), vec![(7, StatusCode::ERR_DENIED)]);
    let t3 = token(3);
    core.handle_datagram(7, &create(A, 0x01, &[Property { name: "xrce_rs_auth", value: t3.as_str() }]), t0);
    assert_eq!(status_agent(&mut core), vec![(7, StatusCode::OK)]);
}

#[test]
fn with_authentication_a_known_key_is_not_taken_over_from_another_address() {
    let allow = vec!["*@127.0.0.0/8".parse().expect("rule")];
    let mut core = auth_core(AuthPolicy { allow, psk: None });
    let t0 = Instant::now();
    core.handle_datagram(7, &create(A, 0x01, &[]), t0);
    with_participant(&mut core, A, t0);
    sent(&mut core);
    core.handle_datagram(8, &create(A, 0x01, &[]), t0);
    let out = sent(&mut core);
    assert!(out.contains(&(8, 0x04, Some(StatusCode::ERR_DENIED))), "{out:?}");
    // In-session messages from the intruder are dropped; the owner is probed and answers.
    let dropped = core.stats().datagrams_dropped;
    core.handle_datagram(8, &ack(A, 0x01), t0);
    assert_eq!(core.stats().datagrams_dropped, dropped + 1);
    core.handle_timeout(t0);
    assert!(sent(&mut core).iter().any(|(to, id, _)| *to == 7 && *id == GET_INFO), "the owner is probed");
    core.handle_datagram(7, &ack(A, 0x01), t0 + Duration::from_millis(5));
    run(&mut core, t0, t0 + 3 * SECOND);
    assert!(has_participant(&core, A), "the owner keeps its session");
    // A client that really moved (its old address is silent) gets in once the old session is found dead.
    let t1 = t0 + 3 * SECOND;
    core.handle_datagram(9, &create(A, 0x01, &[]), t1);
    assert_eq!(status_agent(&mut core), vec![(9, StatusCode::ERR_DENIED)]);
    run(&mut core, t1, t1 + 2 * SECOND);
    assert!(!core.has_client(ClientKey::from_u32(A)));
    core.handle_datagram(9, &create(A, 0x01, &[]), t1 + 2 * SECOND);
    assert_eq!(status_agent(&mut core), vec![(9, StatusCode::OK)]);
}

/// What a client costs the core's tables: keyless sessions (eProsima's default) are not recorded per
/// endpoint twice, and the timer queue stays within 1.5 entries per client however often timers move.
#[test]
fn the_core_tables_hold_no_more_than_a_client_needs() {
    let mut core = core_with(CoreConfig::default());
    let t0 = Instant::now();
    for port in 0..200u16 {
        core.handle_datagram(port, &create(0x1000_0000 + u32::from(port), 0x81, &[]), t0);
    }
    assert_eq!(core.created_from.len(), 0, "keyless sessions are found through their endpoint");
    for port in 200..210u16 {
        core.handle_datagram(port, &create(0x1000_0000 + u32::from(port), 0x01, &[]), t0);
    }
    assert_eq!(core.created_from.len(), 10, "keyed sessions are recorded");
    // Every client's timer moves earlier many times: each reliable reply arms a probe before the heartbeat
    // already queued, leaving a stale entry behind.
    for step in 1..40u32 {
        let now = t0 + Duration::from_millis(u64::from(step) * 10);
        for port in 0..200u16 {
            create_participant_reliably(&mut core, port, 0x1000_0000 + u32::from(port), 0x81, now);
        }
        core.handle_timeout(now);
        sent(&mut core);
        let clients = core.clients.len();
        assert!(core.timers.len() <= clients + clients / 2 + 64, "{} entries, {clients} clients", core.timers.len());
    }
}
