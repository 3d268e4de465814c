//! Turns an entity representation (XML, reference, binary) into the few facts a middleware routes on:
//! names, type names, domain, service. References and XML go through a [`ProfileSource`] (the Fast DDS
//! profile parser and the `-r` refs file); [`FallbackProfiles`] covers the case where none is loaded, with
//! eProsima CED's reference semantics and a tolerant scan of the XML.

use xrce_proto::object::{BinaryObject, Representation};
use xrce_proto::{Endianness, EntityVariant, ObjectId, ObjectKind};

/// How a datawriter/datareader names its topic.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum TopicRef {
    /// By name (XML and references), with the type name when known.
    Name {
        /// Topic name.
        name: String,
        /// Type name, if the description has one.
        type_name: Option<String>,
    },
    /// By a topic object of the same client (binary representation).
    Object(ObjectId),
}

/// What a middleware needs to know about an entity.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Description {
    /// A participant.
    Participant {
        /// Domain (255 already replaced by the agent's domain).
        domain_id: i16,
        /// Participant name, if any.
        name: Option<String>,
    },
    /// A topic.
    Topic {
        /// Topic name.
        name: String,
        /// Type name, if any.
        type_name: Option<String>,
    },
    /// A publisher or subscriber (content unused).
    Group,
    /// A datawriter or datareader.
    Endpoint {
        /// Its topic.
        topic: TopicRef,
    },
    /// A requester or replier.
    Service {
        /// Service name: requesters and repliers with the same one talk.
        service_name: String,
        /// Request type.
        request_type: Option<String>,
        /// Reply type.
        reply_type: Option<String>,
    },
}

/// Resolves references and XML texts into [`Description`]s.
pub trait ProfileSource: Send + Sync {
    /// The description of profile `reference` for an entity of `kind`, if known.
    fn resolve_reference(&self, kind: ObjectKind, reference: &str) -> Option<Description>;

    /// The description an XML text gives for an entity of `kind`.
    fn parse_xml(&self, kind: ObjectKind, xml: &str) -> Result<Description, String>;

    /// The full profile (with QoS) of reference `reference` for an entity of `kind`, when the source holds
    /// parsed profiles; the DDS middleware creates entities with it. `None` when unknown or not modelled.
    fn reference_profile(&self, _kind: ObjectKind, _reference: &str) -> Option<crate::profile::EntityProfile> {
        None
    }
}

/// Used when no profile parser or refs file is available: references are names with eProsima CED's
/// suffixes removed (`chatter__dw` → `chatter`), XML is scanned for `<name>`, `<dataType>` and the
/// requester/replier attributes. The scan is deliberately tolerant: eProsima's clients send XML that strict
/// parsers reject (attributes without separating spaces).
#[derive(Debug, Clone, Copy, Default)]
pub struct FallbackProfiles;

/// Suffix eProsima CED strips from a reference name, per kind (spec §15.1).
fn ced_suffix(kind: ObjectKind) -> Option<&'static str> {
    match kind {
        ObjectKind::Topic => Some("__t"),
        ObjectKind::DataWriter => Some("__dw"),
        ObjectKind::DataReader => Some("__dr"),
        _ => None,
    }
}

/// A reference name with CED's suffix removed (everything from the first occurrence of the suffix).
pub fn strip_ced_suffix(kind: ObjectKind, name: &str) -> &str {
    match ced_suffix(kind).and_then(|s| name.find(s)) {
        Some(at) => name.get(..at).unwrap_or(name),
        None => name,
    }
}

/// Text of the first `<tag>…</tag>` element.
fn element<'x>(xml: &'x str, tag: &str) -> Option<&'x str> {
    let open = format!("<{tag}>");
    let close = format!("</{tag}>");
    let start = xml.find(&open)? + open.len();
    let len = xml.get(start..)?.find(&close)?;
    xml.get(start..start + len).map(str::trim)
}

/// Value of the first `name="…"` attribute (single or double quotes).
fn attribute<'x>(xml: &'x str, name: &str) -> Option<&'x str> {
    let mut from = 0;
    while let Some(found) = xml.get(from..)?.find(name) {
        let at = from + found;
        from = at + name.len();
        // Must be a whole attribute name: preceded by whitespace or a quote, followed by `=`.
        let before_ok =
            at == 0 || matches!(xml.as_bytes().get(at - 1), Some(b' ' | b'\t' | b'\n' | b'\r' | b'"' | b'\''));
        let rest = xml.get(from..)?.trim_start();
        if !before_ok || !rest.starts_with('=') {
            continue;
        }
        let rest = rest.get(1..)?.trim_start();
        let quote = rest.chars().next()?;
        if quote != '"' && quote != '\'' {
            continue;
        }
        let body = rest.get(1..)?;
        let end = body.find(quote)?;
        return body.get(..end);
    }
    None
}

impl FallbackProfiles {
    fn describe_by_name(kind: ObjectKind, name: &str, type_name: Option<&str>) -> Description {
        let owned = |s: Option<&str>| s.map(str::to_owned);
        match kind {
            ObjectKind::Participant => Description::Participant { domain_id: 0, name: Some(name.to_owned()) },
            ObjectKind::Topic => Description::Topic { name: name.to_owned(), type_name: owned(type_name) },
            ObjectKind::DataWriter | ObjectKind::DataReader => {
                Description::Endpoint { topic: TopicRef::Name { name: name.to_owned(), type_name: owned(type_name) } }
            }
            ObjectKind::Requester | ObjectKind::Replier => {
                Description::Service { service_name: name.to_owned(), request_type: None, reply_type: None }
            }
            _ => Description::Group,
        }
    }
}

impl ProfileSource for FallbackProfiles {
    fn resolve_reference(&self, kind: ObjectKind, reference: &str) -> Option<Description> {
        Some(Self::describe_by_name(kind, strip_ced_suffix(kind, reference), None))
    }

    fn parse_xml(&self, kind: ObjectKind, xml: &str) -> Result<Description, String> {
        match kind {
            ObjectKind::Participant => {
                Ok(Description::Participant { domain_id: 0, name: element(xml, "name").map(str::to_owned) })
            }
            ObjectKind::Topic | ObjectKind::DataWriter | ObjectKind::DataReader => {
                let name = element(xml, "name").ok_or("no <name> in topic XML")?;
                Ok(Self::describe_by_name(kind, name, element(xml, "dataType")))
            }
            ObjectKind::Requester | ObjectKind::Replier => Ok(Description::Service {
                service_name: attribute(xml, "service_name").ok_or("no service_name attribute")?.to_owned(),
                request_type: attribute(xml, "request_type").map(str::to_owned),
                reply_type: attribute(xml, "reply_type").map(str::to_owned),
            }),
            _ => Ok(Description::Group),
        }
    }
}

/// Describes an entity variant. The participant's domain comes from the variant's link (with 255 replaced by
/// `default_domain`), never from the profile.
pub fn describe(
    profiles: &dyn ProfileSource,
    variant: &EntityVariant<'_>,
    endian: Endianness,
    default_domain: i16,
) -> Result<Description, String> {
    let kind = variant.kind;
    let mut description = match variant.representation {
        Representation::Reference(r) => {
            profiles.resolve_reference(kind, r).ok_or_else(|| format!("unknown reference `{r}`"))?
        }
        Representation::Xml(x) => profiles.parse_xml(kind, x)?,
        Representation::Binary(blob) => describe_binary(blob, kind, endian)?,
    };
    if let Description::Participant { domain_id, .. } = &mut description {
        let d = variant.domain_id().unwrap_or(0);
        *domain_id = if d == 255 { default_domain } else { d };
    }
    Ok(description)
}

fn describe_binary(blob: BinaryObject<'_>, kind: ObjectKind, endian: Endianness) -> Result<Description, String> {
    let typed = blob.decode_as(kind, endian).map_err(|e| format!("binary {kind:?}: {e}"))?;
    Ok(match typed {
        BinaryObject::Participant(p) => {
            Description::Participant { domain_id: 0, name: p.qos_profile_reference.map(str::to_owned) }
        }
        BinaryObject::Topic(t) => {
            Description::Topic { name: t.topic_name.to_owned(), type_name: t.type_name.map(str::to_owned) }
        }
        BinaryObject::Publisher(_) | BinaryObject::Subscriber(_) => Description::Group,
        BinaryObject::DataWriter(w) => Description::Endpoint { topic: TopicRef::Object(w.topic_id) },
        BinaryObject::DataReader(r) => Description::Endpoint { topic: TopicRef::Object(r.topic_id) },
        BinaryObject::Requester(r) | BinaryObject::Replier(r) => Description::Service {
            service_name: r.service_name.to_owned(),
            request_type: Some(r.request_type.to_owned()),
            reply_type: Some(r.reply_type.to_owned()),
        },
        BinaryObject::Raw(_) => return Err(format!("binary {kind:?}: not decodable")),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tolerant_xml_scan_reads_eprosima_requester_xml() {
        let xml = r#"<dds><replier profile_name="my_requester"service_name="service_name"request_type="request_type"reply_type="reply_type"></replier></dds>"#;
        let d = FallbackProfiles.parse_xml(ObjectKind::Replier, xml).unwrap();
        assert_eq!(
            d,
            Description::Service {
                service_name: "service_name".into(),
                request_type: Some("request_type".into()),
                reply_type: Some("reply_type".into())
            }
        );
    }

    #[test]
    fn writer_xml_names_its_topic() {
        let xml = "<dds><data_writer><topic><kind>NO_KEY</kind><name>HelloWorldTopic</name><dataType>HelloWorld</dataType></topic></data_writer></dds>";
        let d = FallbackProfiles.parse_xml(ObjectKind::DataWriter, xml).unwrap();
        assert_eq!(
            d,
            Description::Endpoint {
                topic: TopicRef::Name { name: "HelloWorldTopic".into(), type_name: Some("HelloWorld".into()) }
            }
        );
    }

    #[test]
    fn references_lose_ced_suffixes() {
        assert_eq!(strip_ced_suffix(ObjectKind::DataWriter, "chatter__dw"), "chatter");
        assert_eq!(strip_ced_suffix(ObjectKind::Topic, "chatter__t__x"), "chatter");
        assert_eq!(strip_ced_suffix(ObjectKind::Participant, "p__t"), "p__t");
    }
}
