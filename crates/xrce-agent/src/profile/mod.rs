//! Fast DDS XML profiles: what eProsima clients send in CREATE (XML representation) and what `-r` refs
//! files hold (reference representation), turned into plain owned structs.
//!
//! The agent needs the same facts whatever the middleware: names, type names, the QoS it routes or
//! compares on, and the requester/replier topic names. Parsing here once, with eProsima's and Fast DDS's
//! defaults, lets CED create XML- and reference-described entities (eProsima's CED cannot) and gives REUSE
//! a comparison ([`EntityProfile::matches`]) that does not depend on the representation used.
//!
//! Hostile input: an entity XML is at most [`MAX_ENTITY_XML_LEN`] bytes, a refs file at most
//! [`MAX_REFS_LEN`]; elements nest at most [`MAX_XML_DEPTH`] deep; DTDs (and so entity expansion) are
//! refused. Every failure is a [`ProfileError`], never a panic. Unknown elements are skipped with a
//! `tracing` warning (Fast DDS would fail the whole profile), elements Fast DDS knows and the agent does not
//! use are skipped silently (debug level), and invalid values of modelled fields are errors.

mod parse;
mod qos;
mod store;

use std::path::PathBuf;

use xrce_proto::ObjectKind;

pub use qos::{Durability, EndpointQos, History, Reliability, ResourceLimits, LENGTH_UNLIMITED};
pub use store::ProfileStore;

/// Largest XML text accepted in a CREATE. eProsima's clients send a few hundred bytes; 64 KiB leaves room
/// for QoS-heavy profiles while bounding the parser's memory (a few times the input).
pub const MAX_ENTITY_XML_LEN: usize = 64 * 1024;
/// Largest refs file accepted. It is local operator input, so the bound only guards against mistakes
/// (pointing `-r` at a huge file).
pub const MAX_REFS_LEN: usize = 4 * 1024 * 1024;
/// Deepest element nesting accepted; the Fast DDS profile schema needs well under 16 levels.
pub const MAX_XML_DEPTH: usize = 32;
/// Most XML nodes (elements, texts, attributes...) in one entity XML, bounding memory independently of size.
const MAX_ENTITY_XML_NODES: u32 = 16 * 1024;
/// Most XML nodes in a refs file.
const MAX_REFS_NODES: u32 = 1024 * 1024;

/// Why an XML profile or a refs file could not be used.
#[derive(Debug, thiserror::Error)]
pub enum ProfileError {
    /// The text exceeds the documented size bound.
    #[error("XML text of {len} bytes exceeds the {max}-byte limit")]
    TooLarge {
        /// Size of the input.
        len: usize,
        /// Limit that applied.
        max: usize,
    },
    /// Elements nest deeper than [`MAX_XML_DEPTH`].
    #[error("XML elements nest deeper than {max} levels")]
    TooDeep {
        /// Limit that applied.
        max: usize,
    },
    /// Not well-formed XML (or a DTD, which is refused).
    #[error("malformed XML: {0}")]
    Xml(#[from] roxmltree::Error),
    /// A refs file is not UTF-8.
    #[error("XML text is not valid UTF-8")]
    NotUtf8,
    /// No element describing an entity of the requested kind.
    #[error("no <{expected}> element in the XML")]
    NoProfile {
        /// Element looked for.
        expected: &'static str,
    },
    /// A required attribute or child element is absent.
    #[error("<{element}> lacks its {field}")]
    MissingField {
        /// Element concerned.
        element: &'static str,
        /// What is missing.
        field: &'static str,
    },
    /// A leaf element that must carry text is empty.
    #[error("<{element}> is empty")]
    EmptyElement {
        /// Element concerned.
        element: &'static str,
    },
    /// A value outside the element's allowed set or range (quoted value truncated to 64 characters).
    #[error("invalid value `{value}` for {element}")]
    InvalidValue {
        /// Element concerned.
        element: &'static str,
        /// The offending value.
        value: String,
    },
    /// The object kind has no XML profile (types, QoS profiles, applications...).
    #[error("object kind {0:?} has no XML profile")]
    UnsupportedKind(ObjectKind),
    /// No profile of that kind with that name in the store.
    #[error("no {kind} profile named `{name}`")]
    UnknownReference {
        /// Kind looked up (element name).
        kind: &'static str,
        /// Name looked up.
        name: String,
    },
    /// The refs file could not be read.
    #[error("cannot read refs file {}: {source}", path.display())]
    Io {
        /// File concerned.
        path: PathBuf,
        /// Underlying error.
        source: std::io::Error,
    },
    /// The refs file was read but is not usable (too large, not UTF-8, malformed): the message names it.
    #[error("refs file {}: {source}", path.display())]
    InFile {
        /// File concerned.
        path: PathBuf,
        /// What is wrong with its content.
        source: Box<ProfileError>,
    },
}

/// A participant (`<participant>`). eProsima's agent takes the domain from the CREATE, not from here.
#[derive(Debug, Clone, Default, PartialEq, Eq, Hash)]
pub struct ParticipantProfile {
    /// `<rtps><name>`; Fast DDS names unnamed participants "RTPSParticipant".
    pub name: Option<String>,
    /// `<domainId>`, if given.
    pub domain_id: Option<u32>,
}

/// A topic (`<topic>`, standalone or inside a writer/reader profile).
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub struct TopicProfile {
    /// Topic name.
    pub name: String,
    /// `<dataType>`; absent in some writer/reader profiles (eProsima only uses the topic name there).
    pub type_name: Option<String>,
    /// `<kind>WITH_KEY</kind>`.
    pub keyed: bool,
    /// `<historyQos>` (Fast DDS default keep-last 1).
    pub history: History,
    /// `<resourceLimitsQos>`.
    pub resource_limits: ResourceLimits,
}

impl TopicProfile {
    /// A topic with Fast DDS's default topic QoS, e.g. for topics described in binary.
    pub fn new(name: impl Into<String>, type_name: Option<String>, keyed: bool) -> Self {
        Self {
            name: name.into(),
            type_name,
            keyed,
            history: History::KeepLast(1),
            resource_limits: ResourceLimits::default(),
        }
    }
}

/// A publisher (`<publisher>`/`<data_writer>` used for a publisher): its partitions.
#[derive(Debug, Clone, Default, PartialEq, Eq, Hash)]
pub struct PublisherProfile {
    /// `<qos><partition><names><name>`, in order.
    pub partitions: Vec<String>,
}

/// A subscriber (`<subscriber>`/`<data_reader>` used for a subscriber): its partitions.
#[derive(Debug, Clone, Default, PartialEq, Eq, Hash)]
pub struct SubscriberProfile {
    /// `<qos><partition><names><name>`, in order.
    pub partitions: Vec<String>,
}

/// A datawriter: its topic and QoS (Fast DDS writer defaults for what the XML leaves out).
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub struct DataWriterProfile {
    /// Topic written (matched by name).
    pub topic: TopicProfile,
    /// QoS; history and resource limits come from the `<topic>` element, as in Fast DDS.
    pub qos: EndpointQos,
}

/// A datareader: its topic and QoS (Fast DDS reader defaults for what the XML leaves out).
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub struct DataReaderProfile {
    /// Topic read (matched by name).
    pub topic: TopicProfile,
    /// QoS; history and resource limits come from the `<topic>` element, as in Fast DDS.
    pub qos: EndpointQos,
}

/// A requester or replier (`<requester>`/`<replier>`): the service and its two topics.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub struct ServiceProfile {
    /// Service name.
    pub service_name: String,
    /// Type of requests.
    pub request_type: String,
    /// Type of replies.
    pub reply_type: String,
    /// Topic carrying requests (default `<service_name>_Request`).
    pub request_topic_name: String,
    /// Topic carrying replies (default `<service_name>_Reply`).
    pub reply_topic_name: String,
}

/// A requester's profile.
pub type RequesterProfile = ServiceProfile;
/// A replier's profile.
pub type ReplierProfile = ServiceProfile;

impl ServiceProfile {
    /// A service with Fast DDS's derived topic names `<service_name>_Request` and `<service_name>_Reply`.
    pub fn new(service_name: String, request_type: String, reply_type: String) -> Self {
        let request_topic_name = format!("{service_name}_Request");
        let reply_topic_name = format!("{service_name}_Reply");
        Self { service_name, request_type, reply_type, request_topic_name, reply_topic_name }
    }
}

/// A parsed profile of any entity kind.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub enum EntityProfile {
    /// A participant.
    Participant(ParticipantProfile),
    /// A topic.
    Topic(TopicProfile),
    /// A publisher.
    Publisher(PublisherProfile),
    /// A subscriber.
    Subscriber(SubscriberProfile),
    /// A datawriter.
    DataWriter(DataWriterProfile),
    /// A datareader.
    DataReader(DataReaderProfile),
    /// A requester.
    Requester(RequesterProfile),
    /// A replier.
    Replier(ReplierProfile),
}

impl EntityProfile {
    /// The object kind this profile creates.
    pub fn kind(&self) -> ObjectKind {
        match self {
            Self::Participant(_) => ObjectKind::Participant,
            Self::Topic(_) => ObjectKind::Topic,
            Self::Publisher(_) => ObjectKind::Publisher,
            Self::Subscriber(_) => ObjectKind::Subscriber,
            Self::DataWriter(_) => ObjectKind::DataWriter,
            Self::DataReader(_) => ObjectKind::DataReader,
            Self::Requester(_) => ObjectKind::Requester,
            Self::Replier(_) => ObjectKind::Replier,
        }
    }

    /// Whether an existing entity created from `self` satisfies a CREATE with REUSE described by `other`
    /// (STATUS_OK_MATCHED). As eProsima's Fast DDS middleware: participants compare their names only (the
    /// domain comes from the CREATE and is compared by the caller); every other kind compares names, types
    /// and QoS. Different kinds never match.
    pub fn matches(&self, other: &EntityProfile) -> bool {
        match (self, other) {
            (Self::Participant(a), Self::Participant(b)) => a.name == b.name,
            _ => self == other,
        }
    }
}

/// The element name Fast DDS uses for a kind (for error messages), if the kind has a profile.
fn element_name(kind: ObjectKind) -> Option<&'static str> {
    Some(match kind {
        ObjectKind::Participant => "participant",
        ObjectKind::Topic => "topic",
        ObjectKind::Publisher => "publisher",
        ObjectKind::Subscriber => "subscriber",
        ObjectKind::DataWriter => "data_writer",
        ObjectKind::DataReader => "data_reader",
        ObjectKind::Requester => "requester",
        ObjectKind::Replier => "replier",
        _ => return None,
    })
}

fn wanted_class(kind: ObjectKind) -> Option<parse::ElementClass> {
    use parse::ElementClass as C;
    Some(match kind {
        ObjectKind::Participant => C::Participant,
        ObjectKind::Topic => C::Topic,
        ObjectKind::Publisher | ObjectKind::DataWriter => C::Writer,
        ObjectKind::Subscriber | ObjectKind::DataReader => C::Reader,
        ObjectKind::Requester => C::Requester,
        ObjectKind::Replier => C::Replier,
        _ => return None,
    })
}

/// Builds the profile of `kind` from a profile element of the matching class.
fn build(kind: ObjectKind, node: roxmltree::Node<'_, '_>) -> Result<EntityProfile, ProfileError> {
    Ok(match kind {
        ObjectKind::Participant => EntityProfile::Participant(parse::participant(node)?),
        ObjectKind::Topic => EntityProfile::Topic(parse::topic(node)?),
        ObjectKind::Publisher => EntityProfile::Publisher(parse::endpoint(node, true)?.publisher()),
        ObjectKind::Subscriber => EntityProfile::Subscriber(parse::endpoint(node, false)?.subscriber()),
        ObjectKind::DataWriter => EntityProfile::DataWriter(parse::endpoint(node, true)?.writer()?),
        ObjectKind::DataReader => EntityProfile::DataReader(parse::endpoint(node, false)?.reader()?),
        ObjectKind::Requester => EntityProfile::Requester(parse::service(node)?),
        ObjectKind::Replier => EntityProfile::Replier(parse::service(node)?),
        other => return Err(ProfileError::UnsupportedKind(other)),
    })
}

/// Parses the XML representation of a CREATE for an entity of `kind`.
///
/// The first element describing that kind is used (`<data_writer>` or `<publisher>` for datawriters and
/// publishers alike, as Fast DDS). An empty text gives the default participant, publisher or subscriber, as
/// eProsima's agent does for these kinds (its clients create publishers and subscribers with `""`); for the
/// other kinds it is an error.
pub fn parse_entity_xml(kind: ObjectKind, xml: &str) -> Result<EntityProfile, ProfileError> {
    let (Some(expected), Some(class)) = (element_name(kind), wanted_class(kind)) else {
        return Err(ProfileError::UnsupportedKind(kind));
    };
    if xml.trim_matches(|c: char| c.is_whitespace() || c == '\0').is_empty() {
        return match kind {
            ObjectKind::Participant => Ok(EntityProfile::Participant(ParticipantProfile::default())),
            ObjectKind::Publisher => Ok(EntityProfile::Publisher(PublisherProfile::default())),
            ObjectKind::Subscriber => Ok(EntityProfile::Subscriber(SubscriberProfile::default())),
            _ => Err(ProfileError::NoProfile { expected }),
        };
    }
    let text = parse::prepare(xml, MAX_ENTITY_XML_LEN)?;
    let doc = parse::parse_document(&text, MAX_ENTITY_XML_NODES)?;
    let node = parse::profile_elements(&doc)
        .into_iter()
        .find(|(c, _)| *c == class)
        .map(|(_, node)| node)
        .ok_or(ProfileError::NoProfile { expected })?;
    build(kind, node)
}

#[cfg(test)]
mod tests;
