//! Reading the Fast DDS XML profile syntax into the plain structs of [`super`].
//!
//! Structure accepted (Fast DDS accepts the same roots): `<dds>` holding profile elements directly or inside
//! `<profiles>`, a bare `<profiles>` root, and (leniently) a bare profile element as the root. Profile
//! elements are `participant`, `topic`, `publisher`/`data_writer`, `subscriber`/`data_reader`, `requester`
//! and `replier`; Fast DDS treats `publisher` and `data_writer` (and `subscriber`/`data_reader`) as the same
//! profile type, so we do too.
//!
//! Before the XML crate sees the text, [`prepare`] bounds its size and nesting depth and repairs the one
//! malformation eProsima's own clients produce: their C examples concatenate string literals so that
//! attributes follow each other with no separating space (`profile_name="a"service_name="b"`), which
//! tinyxml2 (used by Fast DDS) tolerates and a conforming parser rejects.

use std::borrow::Cow;

use roxmltree::{Document, Node, ParsingOptions};

use super::qos::{Durability, EndpointQos, History, Reliability, ResourceLimits};
use super::{
    DataReaderProfile, DataWriterProfile, ParticipantProfile, ProfileError, PublisherProfile, ServiceProfile,
    SubscriberProfile, TopicProfile, MAX_XML_DEPTH,
};

/// Longest value quoted back in an error message, so hostile input cannot make errors (and logs) huge.
const MAX_QUOTED_VALUE: usize = 64;

/// Checks size and depth and inserts the missing spaces between attributes (see the module docs).
///
/// Borrowed when nothing needs repairing, which is the common case.
pub(super) fn prepare(xml: &str, max_len: usize) -> Result<Cow<'_, str>, ProfileError> {
    if xml.len() > max_len {
        return Err(ProfileError::TooLarge { len: xml.len(), max: max_len });
    }
    let bytes = xml.as_bytes();
    let mut inserts: Vec<usize> = Vec::new();
    let mut depth = 0usize;
    let mut i = 0usize;
    while i < bytes.len() {
        if bytes.get(i) != Some(&b'<') {
            i += 1;
            continue;
        }
        // `i` is at an ASCII '<', hence on a char boundary.
        let rest = xml.get(i..).unwrap_or("");
        if rest.starts_with("<!--") {
            i = skip_past(xml, i + 4, "-->");
        } else if rest.starts_with("<![CDATA[") {
            i = skip_past(xml, i + 9, "]]>");
        } else if rest.starts_with("<?") {
            i = skip_past(xml, i + 2, "?>");
        } else if rest.starts_with("<!") {
            // DOCTYPE: left to the XML parser, which refuses DTDs.
            i += 2;
        } else if rest.starts_with("</") {
            depth = depth.saturating_sub(1);
            i = skip_past(xml, i + 2, ">");
        } else {
            let (end, self_closing) = scan_start_tag(bytes, i + 1, &mut inserts);
            if !self_closing {
                depth += 1;
                if depth > MAX_XML_DEPTH {
                    return Err(ProfileError::TooDeep { max: MAX_XML_DEPTH });
                }
            }
            i = end;
        }
    }
    if inserts.is_empty() {
        return Ok(Cow::Borrowed(xml));
    }
    let mut fixed = String::with_capacity(xml.len() + inserts.len());
    let mut from = 0usize;
    for at in inserts {
        fixed.push_str(xml.get(from..at).unwrap_or(""));
        fixed.push(' ');
        from = at;
    }
    fixed.push_str(xml.get(from..).unwrap_or(""));
    Ok(Cow::Owned(fixed))
}

/// Index just past the next `end` at or after `from` (or the end of the text).
fn skip_past(xml: &str, from: usize, end: &str) -> usize {
    match xml.get(from..).and_then(|rest| rest.find(end)) {
        Some(at) => from + at + end.len(),
        None => xml.len(),
    }
}

/// Scans a start tag from just after its `<`; records where a closing attribute quote is directly followed
/// by another attribute. Returns the index after the tag's `>` and whether it was self-closing.
fn scan_start_tag(bytes: &[u8], from: usize, inserts: &mut Vec<usize>) -> (usize, bool) {
    let mut quote: Option<u8> = None;
    let mut previous = 0u8;
    let mut j = from;
    while let Some(&b) = bytes.get(j) {
        match quote {
            Some(q) if b == q => {
                quote = None;
                if let Some(&next) = bytes.get(j + 1) {
                    if !(next.is_ascii_whitespace() || next == b'/' || next == b'>') {
                        inserts.push(j + 1);
                    }
                }
            }
            Some(_) => {}
            None => match b {
                b'"' | b'\'' => quote = Some(b),
                b'>' => return (j + 1, previous == b'/'),
                // A new tag before this one closed: malformed, let the XML parser report it.
                b'<' => return (j, false),
                _ => {}
            },
        }
        previous = b;
        j += 1;
    }
    (bytes.len(), false)
}

/// Parses prepared text with DTDs refused and the node count bounded.
pub(super) fn parse_document(text: &str, nodes_limit: u32) -> Result<Document<'_>, ProfileError> {
    let options = ParsingOptions { allow_dtd: false, nodes_limit };
    Ok(Document::parse_with_options(text, options)?)
}

/// What a profile element describes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum ElementClass {
    Participant,
    Topic,
    /// `publisher` or `data_writer`.
    Writer,
    /// `subscriber` or `data_reader`.
    Reader,
    Requester,
    Replier,
}

impl ElementClass {
    fn of(tag: &str) -> Option<Self> {
        Some(match tag {
            "participant" => Self::Participant,
            "topic" => Self::Topic,
            "publisher" | "data_writer" => Self::Writer,
            "subscriber" | "data_reader" => Self::Reader,
            "requester" => Self::Requester,
            "replier" => Self::Replier,
            _ => return None,
        })
    }
}

/// Fast DDS root-level elements that describe no entity (transports, types, logging...).
const NON_ENTITY_ELEMENTS: &[&str] =
    &["transport_descriptors", "types", "log", "library_settings", "domainparticipant_factory"];

/// The profile elements of a document, in document order, with their class.
pub(super) fn profile_elements<'a, 'i>(doc: &'a Document<'i>) -> Vec<(ElementClass, Node<'a, 'i>)> {
    let root = doc.root_element();
    let mut found = Vec::new();
    match root.tag_name().name() {
        "dds" | "profiles" => collect_profiles(root, &mut found),
        tag => match ElementClass::of(tag) {
            Some(class) => found.push((class, root)),
            None => tracing::warn!(element = tag, "XML profile: unknown root element, nothing loaded"),
        },
    }
    found
}

fn collect_profiles<'a, 'i>(container: Node<'a, 'i>, found: &mut Vec<(ElementClass, Node<'a, 'i>)>) {
    for child in elements(container) {
        let tag = child.tag_name().name();
        if let Some(class) = ElementClass::of(tag) {
            found.push((class, child));
        } else if tag == "profiles" && container.tag_name().name() == "dds" {
            collect_profiles(child, found);
        } else if NON_ENTITY_ELEMENTS.contains(&tag) {
            tracing::debug!(element = tag, "XML profile: skipping non-entity element");
        } else {
            unknown(child);
        }
    }
}

/// Element children only.
fn elements<'a, 'i>(node: Node<'a, 'i>) -> impl Iterator<Item = Node<'a, 'i>> {
    node.children().filter(Node::is_element)
}

fn unknown(node: Node<'_, '_>) {
    let parent = node.parent_element().map(|p| p.tag_name().name()).unwrap_or("");
    tracing::warn!(element = node.tag_name().name(), parent, "XML profile: ignoring unknown element");
}

fn unmodelled(node: Node<'_, '_>) {
    tracing::debug!(element = node.tag_name().name(), "XML profile: ignoring element the agent does not use");
}

/// Attribute value, exactly as written.
pub(super) fn attribute(node: Node<'_, '_>, name: &str) -> Option<String> {
    node.attribute(name).map(str::to_owned)
}

/// Trimmed text of a leaf element; empty text is an error, as in Fast DDS.
fn text<'a>(node: Node<'a, '_>, element: &'static str) -> Result<&'a str, ProfileError> {
    match node.text().map(str::trim) {
        Some(t) if !t.is_empty() => Ok(t),
        _ => Err(ProfileError::EmptyElement { element }),
    }
}

fn invalid(element: &'static str, value: &str) -> ProfileError {
    let mut quoted: String = value.chars().take(MAX_QUOTED_VALUE).collect();
    if quoted.len() < value.len() {
        quoted.push('…');
    }
    ProfileError::InvalidValue { element, value: quoted }
}

fn int<T: std::str::FromStr>(node: Node<'_, '_>, element: &'static str) -> Result<T, ProfileError> {
    let t = text(node, element)?;
    t.parse().map_err(|_| invalid(element, t))
}

/// `<participant>`: `<domainId>` and `<rtps><name>`; everything else in `<rtps>` is transport tuning.
pub(super) fn participant(node: Node<'_, '_>) -> Result<ParticipantProfile, ProfileError> {
    let mut profile = ParticipantProfile::default();
    for child in elements(node) {
        match child.tag_name().name() {
            "domainId" => profile.domain_id = Some(int(child, "domainId")?),
            "rtps" => {
                for item in elements(child) {
                    if item.tag_name().name() == "name" {
                        profile.name = Some(text(item, "name")?.to_owned());
                    } else {
                        unmodelled(item);
                    }
                }
            }
            _ => unknown(child),
        }
    }
    Ok(profile)
}

/// Contents of a `<topic>` element, where only the name may be missing (writers and readers).
#[derive(Debug, Clone, PartialEq, Eq)]
struct TopicAttributes {
    name: Option<String>,
    type_name: Option<String>,
    keyed: bool,
    history: History,
    resource_limits: ResourceLimits,
}

impl Default for TopicAttributes {
    fn default() -> Self {
        Self {
            name: None,
            type_name: None,
            keyed: false,
            history: History::KeepLast(1),
            resource_limits: ResourceLimits::default(),
        }
    }
}

impl TopicAttributes {
    fn into_profile(self, element: &'static str) -> Result<TopicProfile, ProfileError> {
        let name = self.name.ok_or(ProfileError::MissingField { element, field: "topic name" })?;
        Ok(TopicProfile {
            name,
            type_name: self.type_name,
            keyed: self.keyed,
            history: self.history,
            resource_limits: self.resource_limits,
        })
    }
}

fn topic_attributes(node: Node<'_, '_>) -> Result<TopicAttributes, ProfileError> {
    let mut attrs = TopicAttributes::default();
    for child in elements(node) {
        match child.tag_name().name() {
            "name" => attrs.name = Some(text(child, "name")?.to_owned()),
            "dataType" => attrs.type_name = Some(text(child, "dataType")?.to_owned()),
            "kind" => {
                attrs.keyed = match text(child, "kind")? {
                    "NO_KEY" => false,
                    "WITH_KEY" => true,
                    other => return Err(invalid("kind", other)),
                }
            }
            "historyQos" => attrs.history = history(child)?,
            "resourceLimitsQos" => attrs.resource_limits = resource_limits(child)?,
            _ => unknown(child),
        }
    }
    Ok(attrs)
}

/// `<topic>` profile (standalone or in a CREATE): the topic name is required.
pub(super) fn topic(node: Node<'_, '_>) -> Result<TopicProfile, ProfileError> {
    topic_attributes(node)?.into_profile("topic")
}

fn history(node: Node<'_, '_>) -> Result<History, ProfileError> {
    let mut keep_all = false;
    let mut depth: i32 = 1;
    for child in elements(node) {
        match child.tag_name().name() {
            "kind" => {
                keep_all = match text(child, "kind")? {
                    "KEEP_LAST" => false,
                    "KEEP_ALL" => true,
                    other => return Err(invalid("historyQos kind", other)),
                }
            }
            "depth" => depth = int(child, "depth")?,
            _ => unknown(child),
        }
    }
    if keep_all {
        return Ok(History::KeepAll);
    }
    // Fast DDS refuses KEEP_LAST with a depth below 1 as inconsistent.
    match u32::try_from(depth) {
        Ok(d) if d >= 1 => Ok(History::KeepLast(d)),
        _ => Err(invalid("depth", &depth.to_string())),
    }
}

fn resource_limits(node: Node<'_, '_>) -> Result<ResourceLimits, ProfileError> {
    let mut limits = ResourceLimits::default();
    for child in elements(node) {
        match child.tag_name().name() {
            "max_samples" => limits.max_samples = int(child, "max_samples")?,
            "max_instances" => limits.max_instances = int(child, "max_instances")?,
            "max_samples_per_instance" => limits.max_samples_per_instance = int(child, "max_samples_per_instance")?,
            "allocated_samples" | "extra_samples" => unmodelled(child),
            _ => unknown(child),
        }
    }
    Ok(limits)
}

/// Children of a `publisher`/`data_writer`/`subscriber`/`data_reader` element Fast DDS knows and the agent
/// does not use.
const ENDPOINT_UNMODELLED: &[&str] = &[
    "times",
    "external_unicast_locators",
    "ignore_non_matching_locators",
    "unicastLocatorList",
    "multicastLocatorList",
    "remoteLocatorList",
    "expects_inline_qos",
    "historyMemoryPolicy",
    "propertiesPolicy",
    "userDefinedID",
    "entityID",
    "matchedSubscribersAllocation",
    "matchedPublishersAllocation",
];

/// QoS policies Fast DDS knows and the agent does not use.
const QOS_UNMODELLED: &[&str] = &[
    "durabilityService",
    "deadline",
    "latencyBudget",
    "liveliness",
    "lifespan",
    "userData",
    "timeBasedFilter",
    "ownership",
    "ownershipStrength",
    "destinationOrder",
    "presentation",
    "topicData",
    "groupData",
    "publishMode",
    "data_sharing",
    "disablePositiveAcks",
    "disable_heartbeat_piggyback",
    "transport_priority",
];

/// A writer-side or reader-side element: its topic (if any), endpoint QoS and the partitions that apply to
/// its publisher/subscriber.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(super) struct EndpointElement {
    topic: Option<TopicAttributes>,
    qos: EndpointQos,
    partitions: Vec<String>,
}

impl EndpointElement {
    pub(super) fn writer(self) -> Result<DataWriterProfile, ProfileError> {
        let topic = self.topic.unwrap_or_default().into_profile("data_writer")?;
        Ok(DataWriterProfile { topic, qos: self.qos })
    }

    pub(super) fn reader(self) -> Result<DataReaderProfile, ProfileError> {
        let topic = self.topic.unwrap_or_default().into_profile("data_reader")?;
        Ok(DataReaderProfile { topic, qos: self.qos })
    }

    pub(super) fn publisher(self) -> PublisherProfile {
        PublisherProfile { partitions: self.partitions }
    }

    pub(super) fn subscriber(self) -> SubscriberProfile {
        SubscriberProfile { partitions: self.partitions }
    }
}

/// Parses a writer-side (`writer == true`) or reader-side element, starting from Fast DDS's defaults.
pub(super) fn endpoint(node: Node<'_, '_>, writer: bool) -> Result<EndpointElement, ProfileError> {
    let mut element = EndpointElement {
        topic: None,
        qos: if writer { EndpointQos::writer_default() } else { EndpointQos::reader_default() },
        partitions: Vec::new(),
    };
    for child in elements(node) {
        let tag = child.tag_name().name();
        match tag {
            "topic" => {
                let attrs = topic_attributes(child)?;
                // Fast DDS takes the endpoint's history and resource limits from its <topic>.
                element.qos.history = attrs.history;
                element.qos.resource_limits = attrs.resource_limits;
                element.topic = Some(attrs);
            }
            "qos" => endpoint_qos(child, &mut element)?,
            _ if ENDPOINT_UNMODELLED.contains(&tag) => unmodelled(child),
            _ => unknown(child),
        }
    }
    Ok(element)
}

fn endpoint_qos(node: Node<'_, '_>, element: &mut EndpointElement) -> Result<(), ProfileError> {
    for child in elements(node) {
        let tag = child.tag_name().name();
        match tag {
            "reliability" => {
                for item in elements(child) {
                    match item.tag_name().name() {
                        "kind" => {
                            element.qos.reliability = match text(item, "reliability kind")? {
                                "RELIABLE" => Reliability::Reliable,
                                "BEST_EFFORT" => Reliability::BestEffort,
                                other => return Err(invalid("reliability kind", other)),
                            }
                        }
                        "max_blocking_time" => unmodelled(item),
                        _ => unknown(item),
                    }
                }
            }
            "durability" => {
                for item in elements(child) {
                    match item.tag_name().name() {
                        "kind" => {
                            element.qos.durability = match text(item, "durability kind")? {
                                "VOLATILE" => Durability::Volatile,
                                "TRANSIENT_LOCAL" => Durability::TransientLocal,
                                "TRANSIENT" => Durability::Transient,
                                "PERSISTENT" => Durability::Persistent,
                                other => return Err(invalid("durability kind", other)),
                            }
                        }
                        _ => unknown(item),
                    }
                }
            }
            "partition" => element.partitions = partitions(child)?,
            _ if QOS_UNMODELLED.contains(&tag) => unmodelled(child),
            _ => unknown(child),
        }
    }
    Ok(())
}

/// `<partition><names><name>…</name>…</names></partition>`.
fn partitions(node: Node<'_, '_>) -> Result<Vec<String>, ProfileError> {
    let mut names = Vec::new();
    for child in elements(node) {
        if child.tag_name().name() == "names" {
            for item in elements(child) {
                if item.tag_name().name() == "name" {
                    names.push(text(item, "partition name")?.to_owned());
                } else {
                    unknown(item);
                }
            }
        } else {
            unknown(child);
        }
    }
    Ok(names)
}

/// `<requester>`/`<replier>`: the three attributes are required (as in Fast DDS); topic names default to
/// `<service_name>_Request` and `<service_name>_Reply`, Fast DDS's derivation.
pub(super) fn service(node: Node<'_, '_>) -> Result<ServiceProfile, ProfileError> {
    let element = if node.tag_name().name() == "replier" { "replier" } else { "requester" };
    let required = |field: &'static str| attribute(node, field).ok_or(ProfileError::MissingField { element, field });
    let mut profile =
        ServiceProfile::new(required("service_name")?, required("request_type")?, required("reply_type")?);
    for child in elements(node) {
        match child.tag_name().name() {
            "request_topic_name" => profile.request_topic_name = text(child, "request_topic_name")?.to_owned(),
            "reply_topic_name" => profile.reply_topic_name = text(child, "reply_topic_name")?.to_owned(),
            "publisher" | "data_writer" | "subscriber" | "data_reader" => unmodelled(child),
            _ => unknown(child),
        }
    }
    Ok(profile)
}
