use super::*;

const REFS: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../tests/data/vectors/agent.refs");

fn xml(kind: ObjectKind, text: &str) -> EntityProfile {
    match parse_entity_xml(kind, text) {
        Ok(p) => p,
        Err(e) => panic!("{kind:?} XML rejected: {e}\n{text}"),
    }
}

fn xml_err(kind: ObjectKind, text: &str) -> ProfileError {
    match parse_entity_xml(kind, text) {
        Ok(p) => panic!("{kind:?} XML accepted: {p:?}\n{text}"),
        Err(e) => e,
    }
}

fn hello_topic(keyed: bool) -> TopicProfile {
    TopicProfile::new("HelloWorldTopic", Some("HelloWorld".into()), keyed)
}

// ---- the forms seen on the wire (captures of eProsima's example clients) ----

#[test]
fn wire_participant() {
    let p = xml(
        ObjectKind::Participant,
        "<dds><participant><rtps><name>default_xrce_participant</name></rtps></participant></dds>",
    );
    assert_eq!(
        p,
        EntityProfile::Participant(ParticipantProfile {
            name: Some("default_xrce_participant".into()),
            domain_id: None
        })
    );
    assert_eq!(p.kind(), ObjectKind::Participant);
}

#[test]
fn wire_topic() {
    let p =
        xml(ObjectKind::Topic, "<dds><topic><name>HelloWorldTopic</name><dataType>HelloWorld</dataType></topic></dds>");
    assert_eq!(p, EntityProfile::Topic(hello_topic(false)));
    let EntityProfile::Topic(t) = p else { unreachable!() };
    assert_eq!(t.history, History::KeepLast(1));
    assert_eq!(
        t.resource_limits,
        ResourceLimits { max_samples: 5000, max_instances: 10, max_samples_per_instance: 400 }
    );
}

#[test]
fn wire_data_writer_gets_fast_dds_writer_defaults() {
    let p = xml(
        ObjectKind::DataWriter,
        "<dds><data_writer><topic><kind>NO_KEY</kind><name>HelloWorldTopic</name><dataType>HelloWorld</dataType>\
         </topic></data_writer></dds>",
    );
    let expected = DataWriterProfile {
        topic: hello_topic(false),
        qos: EndpointQos {
            reliability: Reliability::Reliable,
            durability: Durability::TransientLocal,
            history: History::KeepLast(1),
            resource_limits: ResourceLimits::default(),
        },
    };
    assert_eq!(p, EntityProfile::DataWriter(expected));
    assert_eq!(p.kind(), ObjectKind::DataWriter);
}

#[test]
fn wire_data_reader_gets_fast_dds_reader_defaults() {
    let p = xml(
        ObjectKind::DataReader,
        "<dds><data_reader><topic><kind>NO_KEY</kind><name>BigHelloWorldTopic</name><dataType>BigHelloWorld</dataType>\
         </topic></data_reader></dds>",
    );
    let expected = DataReaderProfile {
        topic: TopicProfile::new("BigHelloWorldTopic", Some("BigHelloWorld".into()), false),
        qos: EndpointQos::reader_default(),
    };
    assert_eq!(p, EntityProfile::DataReader(expected));
    let EntityProfile::DataReader(r) = p else { unreachable!() };
    assert_eq!(r.qos.reliability, Reliability::BestEffort);
    assert_eq!(r.qos.durability, Durability::Volatile);
}

/// Exactly the bytes of the RequestAdder / ReplyAdder capture: attributes with no separating spaces.
#[test]
fn wire_requester_and_replier_without_attribute_spaces() {
    let requester = r#"<dds><requester profile_name="my_requester"service_name="service_name"request_type="request_type"reply_type="reply_type"></requester></dds>"#;
    let expected = ServiceProfile {
        service_name: "service_name".into(),
        request_type: "request_type".into(),
        reply_type: "reply_type".into(),
        request_topic_name: "service_name_Request".into(),
        reply_topic_name: "service_name_Reply".into(),
    };
    assert_eq!(xml(ObjectKind::Requester, requester), EntityProfile::Requester(expected.clone()));
    let replier = r#"<dds><replier profile_name="my_requester"service_name="service_name"request_type="request_type"reply_type="reply_type"></replier></dds>"#;
    let p = xml(ObjectKind::Replier, replier);
    assert_eq!(p, EntityProfile::Replier(expected));
    assert_eq!(p.kind(), ObjectKind::Replier);
}

#[test]
fn requester_explicit_topic_names() {
    let p = xml(
        ObjectKind::Requester,
        r#"<dds><requester profile_name="r" service_name="add" request_type="AddReq" reply_type="AddRep">
             <request_topic_name> rq/add </request_topic_name>
             <reply_topic_name>rr/add</reply_topic_name>
             <data_writer><qos><reliability><kind>RELIABLE</kind></reliability></qos></data_writer>
           </requester></dds>"#,
    );
    let EntityProfile::Requester(s) = p else { panic!("{p:?}") };
    assert_eq!(s.service_name, "add");
    assert_eq!(s.request_type, "AddReq");
    assert_eq!(s.reply_type, "AddRep");
    assert_eq!(s.request_topic_name, "rq/add");
    assert_eq!(s.reply_topic_name, "rr/add");
}

#[test]
fn requester_missing_attribute() {
    let e = xml_err(ObjectKind::Requester, r#"<dds><requester service_name="s" request_type="a"/></dds>"#);
    assert!(matches!(e, ProfileError::MissingField { element: "requester", field: "reply_type" }), "{e}");
    let e = xml_err(ObjectKind::Replier, r#"<dds><replier request_type="a" reply_type="b"/></dds>"#);
    assert!(matches!(e, ProfileError::MissingField { element: "replier", field: "service_name" }), "{e}");
    let e = xml_err(
        ObjectKind::Replier,
        r#"<dds><replier service_name="s" request_type="a" reply_type="b"><reply_topic_name/></replier></dds>"#,
    );
    assert!(matches!(e, ProfileError::EmptyElement { element: "reply_topic_name" }), "{e}");
}

// ---- QoS, publisher/subscriber, participant details ----

#[test]
fn writer_full_qos() {
    let p = xml(
        ObjectKind::DataWriter,
        r#"<?xml version="1.0" encoding="UTF-8"?>
        <dds xmlns="http://www.eprosima.com/XMLSchemas/fastRTPS_Profiles">
          <profiles>
            <data_writer profile_name="w">
              <!-- a comment -->
              <topic>
                <kind>WITH_KEY</kind>
                <name>Square</name>
                <dataType>ShapeType</dataType>
                <historyQos><kind>KEEP_LAST</kind><depth>20</depth></historyQos>
                <resourceLimitsQos>
                  <max_samples>100</max_samples><max_instances>-1</max_instances>
                  <max_samples_per_instance>20</max_samples_per_instance><allocated_samples>5</allocated_samples>
                </resourceLimitsQos>
              </topic>
              <qos>
                <reliability><kind>BEST_EFFORT</kind><max_blocking_time><sec>1</sec></max_blocking_time></reliability>
                <durability><kind>VOLATILE</kind></durability>
                <deadline><period><sec>1</sec></period></deadline>
                <partition><names><name>p1</name><name>p2</name></names></partition>
              </qos>
              <times><heartbeatPeriod><sec>1</sec></heartbeatPeriod></times>
              <historyMemoryPolicy>DYNAMIC</historyMemoryPolicy>
            </data_writer>
          </profiles>
        </dds>"#,
    );
    let EntityProfile::DataWriter(w) = p else { panic!("{p:?}") };
    assert_eq!(w.topic.name, "Square");
    assert_eq!(w.topic.type_name.as_deref(), Some("ShapeType"));
    assert!(w.topic.keyed);
    assert_eq!(w.qos.reliability, Reliability::BestEffort);
    assert_eq!(w.qos.durability, Durability::Volatile);
    assert_eq!(w.qos.history, History::KeepLast(20));
    assert_eq!(w.topic.history, History::KeepLast(20));
    assert_eq!(
        w.qos.resource_limits,
        ResourceLimits { max_samples: 100, max_instances: LENGTH_UNLIMITED, max_samples_per_instance: 20 }
    );
}

#[test]
fn reader_reliable_keep_all_and_every_durability() {
    for (text, durability) in [
        ("VOLATILE", Durability::Volatile),
        ("TRANSIENT_LOCAL", Durability::TransientLocal),
        ("TRANSIENT", Durability::Transient),
        ("PERSISTENT", Durability::Persistent),
    ] {
        let p = xml(
            ObjectKind::DataReader,
            &format!(
                "<dds><data_reader><topic><name>t</name><historyQos><kind>KEEP_ALL</kind></historyQos></topic>\
                 <qos><reliability><kind>RELIABLE</kind></reliability><durability><kind>{text}</kind></durability>\
                 </qos></data_reader></dds>"
            ),
        );
        let EntityProfile::DataReader(r) = p else { panic!("{p:?}") };
        assert_eq!(r.qos.reliability, Reliability::Reliable);
        assert_eq!(r.qos.durability, durability);
        assert_eq!(r.qos.history, History::KeepAll);
        assert_eq!(r.topic.type_name, None);
    }
}

#[test]
fn publisher_and_subscriber_partitions() {
    let p = xml(
        ObjectKind::Publisher,
        "<dds><publisher><qos><partition><names><name>a</name><name>b</name></names></partition></qos></publisher></dds>",
    );
    assert_eq!(p, EntityProfile::Publisher(PublisherProfile { partitions: vec!["a".into(), "b".into()] }));
    // A data_writer element serves a publisher too (one profile type in Fast DDS).
    let p = xml(
        ObjectKind::Publisher,
        "<dds><data_writer><qos><partition><names><name>x</name></names></partition></qos></data_writer></dds>",
    );
    assert_eq!(p, EntityProfile::Publisher(PublisherProfile { partitions: vec!["x".into()] }));
    let p = xml(
        ObjectKind::Subscriber,
        "<dds><subscriber><qos><partition><names><name>s</name></names></partition></qos></subscriber></dds>",
    );
    assert_eq!(p, EntityProfile::Subscriber(SubscriberProfile { partitions: vec!["s".into()] }));
    assert_eq!(
        xml(ObjectKind::Subscriber, "<dds><data_reader/></dds>"),
        EntityProfile::Subscriber(SubscriberProfile::default())
    );
}

#[test]
fn empty_xml_gives_defaults_where_eprosima_does() {
    assert_eq!(xml(ObjectKind::Participant, ""), EntityProfile::Participant(ParticipantProfile::default()));
    assert_eq!(xml(ObjectKind::Publisher, ""), EntityProfile::Publisher(PublisherProfile::default()));
    assert_eq!(xml(ObjectKind::Subscriber, " \0"), EntityProfile::Subscriber(SubscriberProfile::default()));
    for kind in
        [ObjectKind::Topic, ObjectKind::DataWriter, ObjectKind::DataReader, ObjectKind::Requester, ObjectKind::Replier]
    {
        assert!(matches!(xml_err(kind, ""), ProfileError::NoProfile { .. }), "{kind:?}");
    }
}

#[test]
fn participant_domain_and_other_roots() {
    let p = xml(
        ObjectKind::Participant,
        "<profiles><participant profile_name=\"p\"><domainId>42</domainId><rtps><name>n</name>\
         <builtin><discovery_config><leaseDuration><sec>DURATION_INFINITY</sec></leaseDuration></discovery_config>\
         </builtin></rtps></participant></profiles>",
    );
    assert_eq!(p, EntityProfile::Participant(ParticipantProfile { name: Some("n".into()), domain_id: Some(42) }));
    // Bare profile element as the root.
    let p = xml(ObjectKind::Participant, "<participant/>");
    assert_eq!(p, EntityProfile::Participant(ParticipantProfile::default()));
    let e = xml_err(ObjectKind::Participant, "<dds><participant><domainId>x</domainId></participant></dds>");
    assert!(matches!(e, ProfileError::InvalidValue { element: "domainId", .. }), "{e}");
}

#[test]
fn first_element_of_the_kind_is_used() {
    let text = "<dds><participant/><topic><name>first</name></topic><topic><name>second</name></topic></dds>";
    let EntityProfile::Topic(t) = xml(ObjectKind::Topic, text) else { panic!() };
    assert_eq!(t.name, "first");
}

#[test]
fn unknown_elements_are_ignored() {
    let p = xml(
        ObjectKind::DataWriter,
        "<dds><whatever/><data_writer><surprise>1</surprise><topic><name>t</name><colour>red</colour></topic>\
         <qos><frobnicate/></qos></data_writer></dds>",
    );
    let EntityProfile::DataWriter(w) = p else { panic!() };
    assert_eq!(w.topic.name, "t");
    assert_eq!(w.qos, EndpointQos::writer_default());
}

// ---- errors ----

#[test]
fn invalid_values_are_errors() {
    let cases = [
        (ObjectKind::Topic, "<dds><topic><name>t</name><kind>MAYBE_KEY</kind></topic></dds>", "kind"),
        (ObjectKind::DataWriter, "<dds><data_writer><topic><name>t</name></topic><qos><reliability><kind>SOMETIMES</kind></reliability></qos></data_writer></dds>", "reliability kind"),
        (ObjectKind::DataReader, "<dds><data_reader><topic><name>t</name></topic><qos><durability><kind>FOREVER</kind></durability></qos></data_reader></dds>", "durability kind"),
        (ObjectKind::DataReader, "<dds><data_reader><topic><name>t</name><historyQos><kind>KEEP_SOME</kind></historyQos></topic></data_reader></dds>", "historyQos kind"),
        (ObjectKind::DataReader, "<dds><data_reader><topic><name>t</name><historyQos><depth>0</depth></historyQos></topic></data_reader></dds>", "depth"),
        (ObjectKind::DataReader, "<dds><data_reader><topic><name>t</name><historyQos><depth>-3</depth></historyQos></topic></data_reader></dds>", "depth"),
        (ObjectKind::DataReader, "<dds><data_reader><topic><name>t</name><resourceLimitsQos><max_samples>lots</max_samples></resourceLimitsQos></topic></data_reader></dds>", "max_samples"),
        (ObjectKind::DataReader, "<dds><data_reader><topic><name>t</name><resourceLimitsQos><max_instances>99999999999</max_instances></resourceLimitsQos></topic></data_reader></dds>", "max_instances"),
    ];
    for (kind, text, field) in cases {
        match xml_err(kind, text) {
            ProfileError::InvalidValue { element, .. } => assert_eq!(element, field, "{text}"),
            e => panic!("{text}: {e}"),
        }
    }
}

#[test]
fn missing_and_empty_names() {
    let e = xml_err(ObjectKind::Topic, "<dds><topic><dataType>T</dataType></topic></dds>");
    assert!(matches!(e, ProfileError::MissingField { element: "topic", .. }), "{e}");
    let e = xml_err(ObjectKind::DataWriter, "<dds><data_writer/></dds>");
    assert!(matches!(e, ProfileError::MissingField { element: "data_writer", .. }), "{e}");
    let e = xml_err(ObjectKind::DataReader, "<dds><data_reader><topic><kind>NO_KEY</kind></topic></data_reader></dds>");
    assert!(matches!(e, ProfileError::MissingField { element: "data_reader", .. }), "{e}");
    let e = xml_err(ObjectKind::Topic, "<dds><topic><name>  </name></topic></dds>");
    assert!(matches!(e, ProfileError::EmptyElement { element: "name" }), "{e}");
}

#[test]
fn wrong_kind_and_unsupported_kinds() {
    let e = xml_err(ObjectKind::DataReader, "<dds><data_writer><topic><name>t</name></topic></data_writer></dds>");
    assert!(matches!(e, ProfileError::NoProfile { expected: "data_reader" }), "{e}");
    let e = xml_err(ObjectKind::Participant, "<dds><topic><name>t</name></topic></dds>");
    assert!(matches!(e, ProfileError::NoProfile { expected: "participant" }), "{e}");
    for kind in
        [ObjectKind::Type, ObjectKind::QosProfile, ObjectKind::Application, ObjectKind::Client, ObjectKind::Invalid]
    {
        assert!(matches!(xml_err(kind, "<dds/>"), ProfileError::UnsupportedKind(k) if k == kind));
    }
    let e = xml_err(ObjectKind::Topic, "<unknown_root><topic><name>t</name></topic></unknown_root>");
    assert!(matches!(e, ProfileError::NoProfile { .. }), "{e}");
}

#[test]
fn malformed_xml_is_an_error() {
    for text in [
        "<dds><topic><name>t</name></topic>",
        "<dds><topic><name>t</topic></name></dds>",
        "not xml at all",
        "<dds><topic name=\"a\" name=\"b\"/></dds>",
        "<dds><topic a=\"1></dds>",
        "<<<<>>>>",
        "<dds></dds><dds></dds>",
        "<dds>&unknown;</dds>",
    ] {
        assert!(matches!(xml_err(ObjectKind::Topic, text), ProfileError::Xml(_)), "{text}");
    }
}

#[test]
fn dtd_and_entity_expansion_refused() {
    let bomb = r#"<?xml version="1.0"?><!DOCTYPE lolz [<!ENTITY lol "lol"><!ENTITY lol2 "&lol;&lol;&lol;&lol;">]>
        <dds><topic><name>&lol2;</name></topic></dds>"#;
    assert!(matches!(xml_err(ObjectKind::Topic, bomb), ProfileError::Xml(_)));
}

#[test]
fn size_bound() {
    let filler = "x".repeat(MAX_ENTITY_XML_LEN);
    let text = format!("<dds><topic><name>{filler}</name></topic></dds>");
    match xml_err(ObjectKind::Topic, &text) {
        ProfileError::TooLarge { len, max } => {
            assert_eq!(len, text.len());
            assert_eq!(max, MAX_ENTITY_XML_LEN);
        }
        e => panic!("{e}"),
    }
    // Just under the limit is fine.
    let name = "y".repeat(MAX_ENTITY_XML_LEN - 64);
    let text = format!("<dds><topic><name>{name}</name></topic></dds>");
    let EntityProfile::Topic(t) = xml(ObjectKind::Topic, &text) else { panic!() };
    assert_eq!(t.name.len(), name.len());
}

#[test]
fn depth_bound() {
    let deep = format!("<dds>{}{}</dds>", "<a>".repeat(5_000), "</a>".repeat(5_000));
    assert!(deep.len() < MAX_ENTITY_XML_LEN);
    assert!(matches!(xml_err(ObjectKind::Topic, &deep), ProfileError::TooDeep { max: MAX_XML_DEPTH }));
    let unclosed = "<a>".repeat(10_000);
    assert!(matches!(xml_err(ObjectKind::Topic, &unclosed), ProfileError::TooDeep { .. }));
    // Self-closing and closed siblings do not add depth.
    let wide = format!("<dds>{}<topic><name>t</name></topic></dds>", "<x/><y></y>".repeat(2_000));
    assert!(parse_entity_xml(ObjectKind::Topic, &wide).is_ok());
    let ok_depth = format!("<dds>{}{}<topic><name>t</name></topic></dds>", "<a>".repeat(8), "</a>".repeat(8));
    assert!(parse_entity_xml(ObjectKind::Topic, &ok_depth).is_ok());
}

#[test]
fn node_bound() {
    // An element and a text node per 5 bytes: more nodes than the limit within the size bound.
    let many = format!("<dds>{}<topic><name>t</name></topic></dds>", "<x/>a".repeat(8_300));
    assert!(many.len() < MAX_ENTITY_XML_LEN);
    assert!(matches!(xml_err(ObjectKind::Topic, &many), ProfileError::Xml(_)));
}

#[test]
fn error_values_are_truncated() {
    let long = "Z".repeat(10_000);
    let e = xml_err(ObjectKind::Topic, &format!("<dds><topic><name>t</name><kind>{long}</kind></topic></dds>"));
    assert!(e.to_string().len() < 200, "{e}");
}

#[test]
fn attribute_spacing_repair_keeps_everything_else() {
    // Quotes inside comments, CDATA, text and values with '>' are left alone.
    let text = r#"<dds><!-- "a"b --><requester profile_name='p'service_name="s>x"request_type="a 'q'"reply_type="b">
        <request_topic_name><![CDATA["x"y]]></request_topic_name></requester></dds>"#;
    let EntityProfile::Requester(s) = xml(ObjectKind::Requester, text) else { panic!() };
    assert_eq!(s.service_name, "s>x");
    assert_eq!(s.request_type, "a 'q'");
    assert_eq!(s.reply_type, "b");
    assert_eq!(s.request_topic_name, "\"x\"y");
    assert_eq!(s.reply_topic_name, "s>x_Reply");
    assert!(matches!(parse::prepare("<a b=\"1\" c=\"2\"/>", 100), Ok(std::borrow::Cow::Borrowed(_))));
    let fixed = parse::prepare("<a b=\"1\"c='2'/>", 100).unwrap();
    assert_eq!(fixed, "<a b=\"1\" c='2'/>");
}

#[test]
fn hostile_fragments_never_panic() {
    let pieces = [
        "<",
        ">",
        "</",
        "/>",
        "<!--",
        "-->",
        "<![CDATA[",
        "]]>",
        "<?",
        "?>",
        "<!",
        "\"",
        "'",
        "=",
        "a",
        "dds",
        "topic",
        "name",
        " ",
        "&",
        "&amp;",
        "é",
        "\u{10FFFF}",
        "\0",
    ];
    // Deterministic pseudo-random concatenations.
    let mut state: u32 = 0x1234_5678;
    for _ in 0..3_000 {
        let mut text = String::new();
        for _ in 0..(state % 40) {
            state ^= state << 13;
            state ^= state >> 17;
            state ^= state << 5;
            text.push_str(pieces[(state as usize) % pieces.len()]);
        }
        for kind in [ObjectKind::Participant, ObjectKind::Topic, ObjectKind::DataWriter, ObjectKind::Requester] {
            let _ = parse_entity_xml(kind, &text);
        }
        let _ = ProfileStore::from_xml_str(&text);
        state = state.wrapping_add(0x9E37_79B9);
    }
}

// ---- matches (REUSE) ----

#[test]
fn matches_compares_names_types_and_qos() {
    let writer = |reliability: &str, topic: &str| {
        xml(
            ObjectKind::DataWriter,
            &format!(
                "<dds><data_writer><topic><name>{topic}</name><dataType>T</dataType></topic>\
                 <qos><reliability><kind>{reliability}</kind></reliability></qos></data_writer></dds>"
            ),
        )
    };
    assert!(writer("RELIABLE", "a").matches(&writer("RELIABLE", "a")));
    assert!(!writer("RELIABLE", "a").matches(&writer("BEST_EFFORT", "a")));
    assert!(!writer("RELIABLE", "a").matches(&writer("RELIABLE", "b")));
    // The default QoS equals the explicit default.
    assert!(writer("RELIABLE", "a").matches(&xml(
        ObjectKind::DataWriter,
        "<dds><data_writer><topic><name>a</name><dataType>T</dataType></topic></data_writer></dds>"
    )));
    // Different kinds never match, even with the same content.
    let w = xml(ObjectKind::DataWriter, "<dds><data_writer><topic><name>a</name></topic></data_writer></dds>");
    let r = xml(ObjectKind::DataReader, "<dds><data_reader><topic><name>a</name></topic></data_reader></dds>");
    assert!(!w.matches(&r));
    let t1 = xml(ObjectKind::Topic, "<dds><topic><name>a</name><dataType>T</dataType></topic></dds>");
    let t2 = xml(ObjectKind::Topic, "<dds><topic><name>a</name><dataType>U</dataType></topic></dds>");
    assert!(t1.matches(&t1.clone()));
    assert!(!t1.matches(&t2));
}

#[test]
fn participants_match_on_name_only() {
    let a = EntityProfile::Participant(ParticipantProfile { name: Some("p".into()), domain_id: Some(1) });
    let b = EntityProfile::Participant(ParticipantProfile { name: Some("p".into()), domain_id: None });
    let c = EntityProfile::Participant(ParticipantProfile { name: Some("q".into()), domain_id: Some(1) });
    assert!(a.matches(&b));
    assert!(!a.matches(&c));
}

#[test]
fn service_matches_on_all_fields() {
    let s = |reply_topic: &str| {
        EntityProfile::Requester(ServiceProfile {
            reply_topic_name: reply_topic.into(),
            ..ServiceProfile::new("s".into(), "a".into(), "b".into())
        })
    };
    assert!(s("s_Reply").matches(&s("s_Reply")));
    assert!(!s("s_Reply").matches(&s("other")));
    let replier = EntityProfile::Replier(ServiceProfile::new("s".into(), "a".into(), "b".into()));
    assert!(!s("s_Reply").matches(&replier));
}

// ---- refs files and the store ----

fn agent_refs() -> ProfileStore {
    match ProfileStore::load_refs(REFS) {
        Ok(s) => s,
        Err(e) => panic!("{REFS}: {e}"),
    }
}

#[test]
fn agent_refs_file() {
    let store = agent_refs();
    assert_eq!(store.len(), 6);
    assert!(!store.is_empty());
    let square = TopicProfile::new("Square", Some("ShapeType".into()), true);

    assert_eq!(
        store.get(ObjectKind::Participant, "default_xrce_participant").unwrap(),
        EntityProfile::Participant(ParticipantProfile {
            name: Some("default_xrce_participant".into()),
            domain_id: None
        })
    );
    assert_eq!(store.get(ObjectKind::Topic, "shapetype_topic").unwrap(), EntityProfile::Topic(square.clone()));
    // Topics are also found by topic name.
    assert_eq!(store.get(ObjectKind::Topic, "Square").unwrap(), EntityProfile::Topic(square.clone()));
    assert_eq!(
        store.get(ObjectKind::DataWriter, "shapetype_data_writer").unwrap(),
        EntityProfile::DataWriter(DataWriterProfile { topic: square.clone(), qos: EndpointQos::writer_default() })
    );
    assert_eq!(
        store.get(ObjectKind::DataReader, "shapetype_data_reader").unwrap(),
        EntityProfile::DataReader(DataReaderProfile { topic: square, qos: EndpointQos::reader_default() })
    );
    let service = ServiceProfile {
        service_name: "shapetype_service".into(),
        request_type: "request_type".into(),
        reply_type: "reply_type".into(),
        request_topic_name: "shapetype_service_Request".into(),
        reply_topic_name: "shapetype_service_Reply".into(),
    };
    assert_eq!(
        store.get(ObjectKind::Requester, "shapetype_requester").unwrap(),
        EntityProfile::Requester(service.clone())
    );
    assert_eq!(store.get(ObjectKind::Replier, "shapetype_replier").unwrap(), EntityProfile::Replier(service));
    // Writer/reader profiles serve publishers/subscribers (no partitions here).
    assert_eq!(
        store.get(ObjectKind::Publisher, "shapetype_data_writer").unwrap(),
        EntityProfile::Publisher(PublisherProfile::default())
    );
    assert_eq!(
        store.get(ObjectKind::Subscriber, "shapetype_data_reader").unwrap(),
        EntityProfile::Subscriber(SubscriberProfile::default())
    );
}

#[test]
fn store_lookup_errors() {
    let store = agent_refs();
    let e = store.get(ObjectKind::Participant, "nope").unwrap_err();
    assert!(matches!(&e, ProfileError::UnknownReference { kind: "participant", name } if name == "nope"), "{e}");
    // Namespaces are per profile type.
    assert!(matches!(
        store.get(ObjectKind::DataReader, "shapetype_data_writer"),
        Err(ProfileError::UnknownReference { .. })
    ));
    assert!(matches!(
        store.get(ObjectKind::Replier, "shapetype_requester"),
        Err(ProfileError::UnknownReference { .. })
    ));
    assert!(matches!(
        store.get(ObjectKind::Topic, "shapetype_data_writer"),
        Err(ProfileError::UnknownReference { .. })
    ));
    assert!(matches!(store.get(ObjectKind::Type, "x"), Err(ProfileError::UnsupportedKind(ObjectKind::Type))));
    assert!(matches!(ProfileStore::new().get(ObjectKind::Topic, "Square"), Err(ProfileError::UnknownReference { .. })));
}

#[test]
fn store_publisher_profile_without_topic() {
    let store = ProfileStore::from_xml_str(
        "<dds><profiles><publisher profile_name=\"pub\"><qos><partition><names><name>p</name></names></partition>\
         </qos></publisher></profiles></dds>",
    )
    .unwrap();
    assert_eq!(
        store.get(ObjectKind::Publisher, "pub").unwrap(),
        EntityProfile::Publisher(PublisherProfile { partitions: vec!["p".into()] })
    );
    // Used for a datawriter, it lacks a topic.
    assert!(matches!(store.get(ObjectKind::DataWriter, "pub"), Err(ProfileError::MissingField { .. })));
}

#[test]
fn store_skips_unnamed_and_duplicate_profiles() {
    let store = ProfileStore::from_xml_str(
        "<profiles>\
           <topic><name>unnamed</name></topic>\
           <topic profile_name=\"\"><name>empty</name></topic>\
           <topic profile_name=\"t\"><name>first</name></topic>\
           <topic profile_name=\"t\"><name>second</name></topic>\
           <transport_descriptors><transport_descriptor/></transport_descriptors>\
         </profiles>",
    )
    .unwrap();
    assert_eq!(store.len(), 1);
    let EntityProfile::Topic(t) = store.get(ObjectKind::Topic, "t").unwrap() else { panic!() };
    assert_eq!(t.name, "first");
    assert!(store.get(ObjectKind::Topic, "unnamed").is_err());
}

#[test]
fn store_malformed_profile_fails_whole_text() {
    let mut store = agent_refs();
    let e = store
        .merge_xml_str(
            "<profiles><topic profile_name=\"ok\"><name>x</name></topic>\
             <data_writer profile_name=\"bad\"><qos><reliability><kind>MAYBE</kind></reliability></qos></data_writer>\
             </profiles>",
        )
        .unwrap_err();
    assert!(matches!(e, ProfileError::InvalidValue { .. }), "{e}");
    assert_eq!(store.len(), 6);
    assert!(store.get(ObjectKind::Topic, "ok").is_err());
}

#[test]
fn store_merges_more_files() {
    let mut store = agent_refs();
    let added = store
        .merge_xml_str(
            "<dds><profiles><topic profile_name=\"shapetype_topic\"><name>Dup</name></topic>\
             <topic profile_name=\"circle\"><name>Circle</name><dataType>ShapeType</dataType></topic></profiles></dds>",
        )
        .unwrap();
    assert_eq!(added, 1);
    assert_eq!(store.len(), 7);
    let EntityProfile::Topic(t) = store.get(ObjectKind::Topic, "shapetype_topic").unwrap() else { panic!() };
    assert_eq!(t.name, "Square");
    assert!(store.get(ObjectKind::Topic, "Circle").is_ok());
}

/// The error of a refs file that cannot be used names the file.
fn file_error(path: &std::path::Path) -> ProfileError {
    let e = ProfileStore::load_refs(path).unwrap_err();
    let shown = e.to_string();
    assert!(shown.contains(&path.display().to_string()), "the error names {}: {shown}", path.display());
    match e {
        ProfileError::InFile { source, .. } => *source,
        other => other,
    }
}

#[test]
fn store_file_errors() {
    let e = file_error(std::path::Path::new("/nonexistent/agent.refs"));
    assert!(matches!(e, ProfileError::Io { .. }), "{e}");
    let dir = std::env::temp_dir().join(format!("xrce-agent-profile-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let bad = dir.join("latin1.refs");
    std::fs::write(&bad, b"<profiles><topic profile_name=\"\xe9\"><name>t</name></topic></profiles>").unwrap();
    assert!(matches!(file_error(&bad), ProfileError::NotUtf8));
    let big = dir.join("big.refs");
    std::fs::write(&big, vec![b' '; MAX_REFS_LEN + 1]).unwrap();
    assert!(matches!(file_error(&big), ProfileError::TooLarge { .. }));
    let malformed = dir.join("malformed.refs");
    std::fs::write(&malformed, "<dds><profiles><topic profile_name=\"t\"><name>t</name></profiles></dds>").unwrap();
    assert!(matches!(file_error(&malformed), ProfileError::Xml(_)));
    let invalid = dir.join("invalid.refs");
    std::fs::write(&invalid, "<profiles><topic profile_name=\"t\"><name></name></topic></profiles>").unwrap();
    assert!(matches!(file_error(&invalid), ProfileError::EmptyElement { .. }));
    assert!(matches!(ProfileStore::from_xml_str("<profiles>"), Err(ProfileError::Xml(_))));
    let empty = ProfileStore::from_xml_str("<profiles/>").unwrap();
    assert!(empty.is_empty());
}

#[test]
fn refs_and_xml_give_the_same_profile() {
    let store = agent_refs();
    let by_ref = store.get(ObjectKind::DataWriter, "shapetype_data_writer").unwrap();
    let by_xml = xml(
        ObjectKind::DataWriter,
        "<dds><data_writer><topic><kind>WITH_KEY</kind><name>Square</name><dataType>ShapeType</dataType></topic>\
         </data_writer></dds>",
    );
    assert!(by_ref.matches(&by_xml));
}

/// `-r FILE` on the command line (a malformed or a missing file) and the agent API's `load_config_file` fail
/// with an error naming the file.
#[test]
fn agent_refs_errors_name_the_file() {
    let dir = std::env::temp_dir().join(format!("xrce-agent-refs-errors-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let start = |refs: &std::path::Path| {
        let refs = refs.display().to_string();
        match crate::agent::AgentInstance::create([
            "xrce-agent",
            "udp4",
            "-p",
            "0",
            "-m",
            "ced",
            "-v",
            "0",
            "-r",
            &refs,
        ]) {
            Ok(mut agent) => {
                agent.stop().unwrap();
                panic!("the agent started with {refs}");
            }
            Err(e) => {
                let shown = e.to_string();
                assert!(shown.contains(&refs), "the error names {refs}: {shown}");
            }
        }
    };
    let malformed = dir.join("malformed.refs");
    std::fs::write(&malformed, "<dds><profiles><data_writer profile_name=\"w\"></profiles>").unwrap();
    start(&malformed);
    start(&dir.join("missing.refs"));
    // eProsima's `load_config_file` through the agent API.
    let agent = crate::agent::Agent::<u16>::new(crate::middleware::MiddlewareKind::Ced, Default::default()).unwrap();
    let missing = dir.join("missing.refs");
    let shown = agent.load_config_file(&missing).unwrap_err().to_string();
    assert!(shown.contains(&missing.display().to_string()), "{shown}");
    let shown = agent.load_config_file(&malformed).unwrap_err().to_string();
    assert!(shown.contains(&malformed.display().to_string()), "{shown}");
}
