use super::first_contact::{AfterMatch, GateWait};
use super::spec::{qos_from_binary, qos_from_profile, spec_from_profile};
use super::*;
use crate::profile;
use xrce_dds::{Durability, History, Reliability};
use xrce_proto::object::{EndpointQos as BinaryQos, QosFlags};

#[test]
fn expired_gates_of_endpoints_that_never_wrote_go_and_their_table_shrinks() {
    let profiles = Arc::new(crate::middleware::profiles::StoreProfiles::new());
    let mut dds = Dds::new(profiles);
    let start = Instant::now();
    let gate = |created| Gate { created, short: FIRST_CONTACT_GATE, acks: Acks::Unwatched };
    for id in 0..1_000u16 {
        let e = EntityRef {
            client: ClientKey(u32::from(id).to_be_bytes()),
            id: xrce_proto::types::ObjectId::new(id, ObjectKind::DataWriter),
        };
        dds.gates.insert(e, gate(start));
    }
    let young = EntityRef {
        client: ClientKey(7_000u32.to_be_bytes()),
        id: xrce_proto::types::ObjectId::new(1, ObjectKind::DataWriter),
    };
    let swept = start + GATE_EXPIRED + Duration::from_millis(1);
    dds.gates.insert(young, gate(swept - GATE_EXPIRED + Duration::from_millis(500)));
    let big = dds.gates.capacity();
    dds.sweep_gates(swept);
    assert_eq!(dds.gates.keys().copied().collect::<Vec<_>>(), vec![young], "only the young gate stays");
    assert!(dds.gates.capacity() < big / 4, "the table gave its room back ({} of {big})", dds.gates.capacity());
    // At most once per GATE_SWEEP.
    dds.sweep_gates(swept + Duration::from_millis(600));
    assert_eq!(dds.gates.len(), 1, "expired now, but swept only a second later");
    dds.sweep_gates(swept + GATE_SWEEP);
    assert!(dds.gates.is_empty());
}

#[test]
fn an_entity_node_stays_small() {
    // A node per entity, four or more per client, 10,000 idle clients: every byte here counts 40,000 times
    // (issue 22: ≤ 2 KiB per idle client). Large or rare parts are boxed in the handle.
    assert!(std::mem::size_of::<Handle>() <= 24, "handle: {} B", std::mem::size_of::<Handle>());
    assert!(std::mem::size_of::<Node>() <= 48, "node: {} B", std::mem::size_of::<Node>());
}

#[test]
fn after_the_match_a_gate_lets_depth_writes_go_then_waits_for_the_acknowledgements() {
    let created = Instant::now();
    let since = created + Duration::from_millis(100);
    let watching = |left| Gate { created, short: FIRST_CONTACT_GATE, acks: Acks::Watching { since, left, depth: 3 } };
    let never = || -> bool { panic!("nothing was written: acknowledgements are not asked") };
    // Nothing written since the match: go, whatever the acknowledgements (none is owed yet).
    assert_eq!(watching(3).after_match(never, since), AfterMatch::Write);
    // Written and acknowledged by every matched reader: the gate opens for good.
    assert_eq!(watching(2).after_match(|| true, since), AfterMatch::Open { timed_out: false });
    // Written, not acknowledged yet: go while the history still holds what was written...
    assert_eq!(watching(1).after_match(|| false, since), AfterMatch::Write);
    // ...then wait, until the discovery limit at most.
    let until = created + FIRST_CONTACT_DISCOVERY_LIMIT;
    assert_eq!(watching(0).after_match(|| false, since), AfterMatch::Hold(until));
    assert_eq!(watching(0).after_match(|| false, until), AfterMatch::Open { timed_out: true });
    assert_eq!(watching(0).after_match(|| true, since), AfterMatch::Open { timed_out: false });
}

#[test]
fn gate_holds_long_only_while_a_known_readers_participant_is_in_discovery() {
    let created = Instant::now();
    let gate = Gate { created, short: FIRST_CONTACT_GATE, acks: Acks::Unwatched };
    assert_eq!(gate.hold_until(GateWait::default()), None, "nothing to wait for: open");
    // A known reader unmatched although its participant's endpoints arrived (it will not match), or a
    // participant in discovery without a known reader: the short bound.
    let unmatched = GateWait { readers_in_discovery: 0, unmatched: 2 };
    assert_eq!(gate.hold_until(unmatched), Some(created + FIRST_CONTACT_GATE));
    // A known reader whose participant is still in discovery: up to the discovery limit.
    let discovering = GateWait { readers_in_discovery: 1, unmatched: 2 };
    assert_eq!(gate.hold_until(discovering), Some(created + FIRST_CONTACT_DISCOVERY_LIMIT));
    assert!(FIRST_CONTACT_DISCOVERY_LIMIT > Duration::from_secs(3), "covers Fast DDS' 3 s announcement period");
    assert!(FIRST_CONTACT_DISCOVERY_LIMIT < Duration::from_secs(4), "below 4 micro-ROS publishes of 1 s each");
}

#[test]
fn binary_qos_bits_map_to_dds_qos() {
    let b = BinaryQos {
        qos_flags: QosFlags::RELIABLE | QosFlags::HISTORY_KEEP_LAST | QosFlags::DURABILITY_TRANSIENT_LOCAL,
        history_depth: Some(10),
        deadline_msec: Some(1500),
        lifespan_msec: None,
        user_data: None,
    };
    let q = qos_from_binary(Some(&b), true);
    assert_eq!(q.reliability, Reliability::Reliable);
    assert_eq!(q.history, History::KeepLast(10));
    assert_eq!(q.durability, Durability::TransientLocal);
    assert_eq!(q.deadline, Some(std::time::Duration::from_millis(1500)));
    let be = qos_from_binary(Some(&BinaryQos { qos_flags: 0, ..b }), false);
    assert_eq!(
        (be.reliability, be.history, be.durability),
        (Reliability::BestEffort, History::KeepAll, Durability::Volatile)
    );
    // Without QoS: Fast DDS defaults.
    let w = qos_from_binary(None, true);
    assert_eq!(
        (w.reliability, w.durability, w.history),
        (Reliability::Reliable, Durability::TransientLocal, History::KeepLast(1))
    );
    let r = qos_from_binary(None, false);
    assert_eq!(r.reliability, Reliability::BestEffort);
    // Depth 0 (PX4) or left out (eProsima's client for 0): the DDS default, keep-last 1.
    for depth in [Some(0), None] {
        let q = qos_from_binary(Some(&BinaryQos { history_depth: depth, ..b }), true);
        assert_eq!(q.history, History::KeepLast(1));
    }
}

#[test]
fn profile_resource_limits_defaults_are_left_to_the_bridge() {
    let mut q = profile::EndpointQos::reader_default();
    assert_eq!(qos_from_profile(&q).resource_limits, None);
    q.resource_limits.max_samples = 200;
    let rl = qos_from_profile(&q).resource_limits.unwrap();
    assert_eq!((rl.max_samples, rl.max_samples_per_instance), (200, 200));
    q.resource_limits.max_samples = -1;
    assert_eq!(qos_from_profile(&q).resource_limits, None);
}

#[test]
fn sample_identity_round_trips() {
    let mut guid = [0u8; 16];
    for (i, b) in guid.iter_mut().enumerate() {
        *b = i as u8 + 1;
    }
    let id = xrce_dds::SampleIdentity::from_parts(guid, 2, 0xDEAD_BEEF);
    let x = identity_to_xrce(&id);
    assert_eq!(x.writer_guid.prefix, [1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12]);
    assert_eq!(x.writer_guid.entity_key, [13, 14, 15]);
    assert_eq!(x.writer_guid.entity_kind, 16);
    assert_eq!((x.sequence_number.high, x.sequence_number.low), (2, 0xDEAD_BEEF));
    assert_eq!(identity_to_dds(&x), id);
}

#[test]
fn xml_and_binary_specs_carry_names_types_and_keys() {
    let xml = "<dds><topic><name>T</name><dataType>Ty</dataType><kind>WITH_KEY</kind></topic></dds>";
    let p = profile::parse_entity_xml(ObjectKind::Topic, xml).unwrap();
    assert_eq!(spec_from_profile(p).unwrap(), Spec::Topic { name: "T".into(), type_name: "Ty".into(), keyed: true });
    let xml = r#"<dds><requester profile_name="r"service_name="s"request_type="a"reply_type="b"></requester></dds>"#;
    let p = profile::parse_entity_xml(ObjectKind::Requester, xml).unwrap();
    let Spec::Service { desc, .. } = spec_from_profile(p).unwrap() else { panic!("service") };
    assert_eq!((desc.request_topic(), desc.reply_topic()), ("s_Request".to_owned(), "s_Reply".to_owned()));
}
