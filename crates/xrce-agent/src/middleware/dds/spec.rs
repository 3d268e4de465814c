//! What an XRCE entity is created from, as the DDS middleware models it: a [`Spec`] from each object
//! representation (XML and reference profiles, the binary form), with the QoS mapped onto the bridge's.
//! REUSE compares specs through [`Spec::digest`].

use xrce_dds::{Durability, EndpointQos as DdsQos, History, Reliability, ResourceLimits, ServiceDescription};
use xrce_proto::object::{BinaryObject, EndpointQos as BinaryQos, QosFlags};
use xrce_proto::{ObjectId, ObjectKind};

use xrce_proto::object::Representation;

use super::{invalid, unknown};
use crate::middleware::describe::{Description, ProfileSource, TopicRef};
use crate::middleware::{Creation, MiddlewareError};
use crate::profile::{self, EntityProfile};

/// How a datawriter or datareader names its topic.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub(crate) enum TopicSel {
    /// A topic object of the same client (binary representation).
    Object(ObjectId),
    /// By name (XML and references), with what the description says of type and key.
    Name { name: String, type_name: Option<String>, keyed: bool },
}

/// Everything an entity is created from; REUSE compares it whole (through [`Spec::digest`]).
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub(crate) enum Spec {
    Participant { domain: u16, name: Option<String> },
    Topic { name: String, type_name: String, keyed: bool },
    Group { partitions: Vec<String> },
    Endpoint { topic: TopicSel, qos: DdsQos },
    Service { desc: Box<ServiceDescription>, qos: DdsQos },
}

impl Spec {
    /// A 64-bit digest, the same for equal specs within the process (`DefaultHasher::new` has fixed keys).
    pub(crate) fn digest(&self) -> u64 {
        use std::hash::{Hash, Hasher};
        let mut h = std::hash::DefaultHasher::new();
        self.hash(&mut h);
        h.finish()
    }
}

/// The spec of what `creation` describes (XML, reference or binary), the participant's domain left at 0 for
/// the middleware to resolve. Shared by the `dds` and `zenoh` middlewares.
pub(crate) fn spec_of_creation(profiles: &dyn ProfileSource, creation: &Creation<'_>) -> Result<Spec, MiddlewareError> {
    let kind = creation.variant.kind;
    Ok(match creation.variant.representation {
        Representation::Reference(r) => {
            let mut spec = match profiles.reference_profile(kind, r) {
                Some(p) => spec_from_profile(p)?,
                None => {
                    let d = profiles.resolve_reference(kind, r).ok_or_else(|| unknown(r))?;
                    spec_from_description(kind, d)?
                }
            };
            // A profile without `<rtps><name>` names its participant after itself (the ROS 2 node).
            if let Spec::Participant { name: name @ None, .. } = &mut spec {
                *name = Some(r.to_owned());
            }
            spec
        }
        Representation::Xml(x) => match profile::parse_entity_xml(kind, x) {
            Ok(p) => spec_from_profile(p)?,
            Err(strict) => {
                let d = profiles.parse_xml(kind, x).map_err(|e| invalid(format!("{strict}; {e}")))?;
                spec_from_description(kind, d)?
            }
        },
        Representation::Binary(blob) => {
            let typed = blob.decode_as(kind, creation.endian).map_err(|e| invalid(format!("binary {kind:?}: {e}")))?;
            spec_from_binary(typed)?
        }
    })
}

/// Converts the QoS of an XML profile or reference (Fast DDS defaults already applied).
pub(crate) fn qos_from_profile(q: &profile::EndpointQos) -> DdsQos {
    let reliability = match q.reliability {
        profile::Reliability::Reliable => Reliability::Reliable,
        profile::Reliability::BestEffort => Reliability::BestEffort,
    };
    let durability = match q.durability {
        profile::Durability::Volatile => Durability::Volatile,
        profile::Durability::TransientLocal => Durability::TransientLocal,
        profile::Durability::Transient => Durability::Transient,
        profile::Durability::Persistent => Durability::Persistent,
    };
    let history = match q.history {
        profile::History::KeepLast(d) => History::KeepLast(d.max(1)),
        profile::History::KeepAll => History::KeepAll,
    };
    // Raw samples of a topic are one instance on our side (keyed or not), so only `max_samples` bounds
    // anything. Fast DDS's defaults (5000/10/400) and "unlimited" leave the choice to the bridge, whose
    // bounds never cut a reliable burst short; explicit limits are honoured.
    let rl = q.resource_limits;
    let resource_limits = match u32::try_from(rl.max_samples) {
        Ok(m) if m > 0 && rl != profile::ResourceLimits::default() => {
            Some(ResourceLimits { max_samples: m, max_instances: 1, max_samples_per_instance: m })
        }
        _ => None,
    };
    DdsQos { reliability, durability, history, resource_limits, ..DdsQos::default() }
}

/// Converts the QoS bits of a binary datawriter/datareader (spec §7.4); `None` gives Fast DDS's defaults.
pub(crate) fn qos_from_binary(base: Option<&BinaryQos<'_>>, writer: bool) -> DdsQos {
    let Some(b) = base else {
        let defaults =
            if writer { profile::EndpointQos::writer_default() } else { profile::EndpointQos::reader_default() };
        return qos_from_profile(&defaults);
    };
    let flags = b.qos_flags;
    let reliability = if flags & QosFlags::RELIABLE != 0 { Reliability::Reliable } else { Reliability::BestEffort };
    let history = if flags & QosFlags::HISTORY_KEEP_LAST != 0 {
        History::KeepLast(u32::from(b.history_depth.unwrap_or(1).max(1)))
    } else {
        History::KeepAll
    };
    let durability = if flags & QosFlags::DURABILITY_TRANSIENT_LOCAL != 0 {
        Durability::TransientLocal
    } else if flags & QosFlags::DURABILITY_TRANSIENT != 0 {
        Durability::Transient
    } else if flags & QosFlags::DURABILITY_PERSISTENT != 0 {
        Durability::Persistent
    } else {
        Durability::Volatile
    };
    let ms = |v: u32| std::time::Duration::from_millis(u64::from(v));
    DdsQos {
        reliability,
        durability,
        history,
        deadline: b.deadline_msec.filter(|&d| d > 0).map(ms),
        lifespan: b.lifespan_msec.filter(|&d| d > 0).map(ms),
        ..DdsQos::default()
    }
}

pub(crate) fn spec_from_profile(p: EntityProfile) -> Result<Spec, MiddlewareError> {
    Ok(match p {
        EntityProfile::Participant(p) => Spec::Participant { domain: 0, name: p.name },
        EntityProfile::Topic(t) => Spec::Topic {
            type_name: t.type_name.ok_or_else(|| invalid(format!("topic {:?} has no dataType", t.name)))?,
            name: t.name,
            keyed: t.keyed,
        },
        EntityProfile::Publisher(g) => Spec::Group { partitions: g.partitions },
        EntityProfile::Subscriber(g) => Spec::Group { partitions: g.partitions },
        EntityProfile::DataWriter(w) => Spec::Endpoint {
            qos: qos_from_profile(&w.qos),
            topic: TopicSel::Name { name: w.topic.name, type_name: w.topic.type_name, keyed: w.topic.keyed },
        },
        EntityProfile::DataReader(r) => Spec::Endpoint {
            qos: qos_from_profile(&r.qos),
            topic: TopicSel::Name { name: r.topic.name, type_name: r.topic.type_name, keyed: r.topic.keyed },
        },
        EntityProfile::Requester(s) | EntityProfile::Replier(s) => Spec::Service {
            desc: service(
                &s.service_name,
                &s.request_type,
                &s.reply_type,
                Some(&s.request_topic_name),
                Some(&s.reply_topic_name),
            ),
            qos: DdsQos::default(),
        },
    })
}

/// For descriptions without QoS (the tolerant XML scan, references resolved by name only).
pub(crate) fn spec_from_description(kind: ObjectKind, d: Description) -> Result<Spec, MiddlewareError> {
    Ok(match d {
        Description::Participant { name, .. } => Spec::Participant { domain: 0, name },
        Description::Topic { name, type_name } => Spec::Topic {
            type_name: type_name.ok_or_else(|| invalid(format!("topic {name:?} has no type name")))?,
            name,
            keyed: false,
        },
        Description::Group => Spec::Group { partitions: Vec::new() },
        Description::Endpoint { topic } => {
            let writer = kind == ObjectKind::DataWriter;
            let defaults =
                if writer { profile::EndpointQos::writer_default() } else { profile::EndpointQos::reader_default() };
            let topic = match topic {
                TopicRef::Name { name, type_name } => TopicSel::Name { name, type_name, keyed: false },
                TopicRef::Object(id) => TopicSel::Object(id),
            };
            Spec::Endpoint { topic, qos: qos_from_profile(&defaults) }
        }
        Description::Service { service_name, request_type, reply_type } => {
            let (Some(req), Some(rep)) = (request_type, reply_type) else {
                return Err(invalid(format!("service {service_name:?} lacks its request or reply type")));
            };
            Spec::Service { desc: service(&service_name, &req, &rep, None, None), qos: DdsQos::default() }
        }
    })
}

pub(crate) fn spec_from_binary(b: BinaryObject<'_>) -> Result<Spec, MiddlewareError> {
    Ok(match b {
        BinaryObject::Participant(p) => {
            Spec::Participant { domain: 0, name: p.qos_profile_reference.map(str::to_owned) }
        }
        BinaryObject::Topic(t) => Spec::Topic {
            name: t.topic_name.to_owned(),
            type_name: t
                .type_name
                .ok_or_else(|| invalid(format!("binary topic {:?} has no type name", t.topic_name)))?
                .to_owned(),
            keyed: false,
        },
        BinaryObject::Publisher(_) | BinaryObject::Subscriber(_) => Spec::Group { partitions: Vec::new() },
        BinaryObject::DataWriter(w) => Spec::Endpoint {
            topic: TopicSel::Object(w.topic_id),
            qos: qos_from_binary(w.qos.as_ref().map(|q| &q.base), true),
        },
        BinaryObject::DataReader(r) => Spec::Endpoint {
            topic: TopicSel::Object(r.topic_id),
            qos: qos_from_binary(r.qos.as_ref().map(|q| &q.base), false),
        },
        BinaryObject::Requester(s) | BinaryObject::Replier(s) => Spec::Service {
            desc: service(s.service_name, s.request_type, s.reply_type, s.request_topic_name, s.reply_topic_name),
            qos: DdsQos::default(),
        },
        BinaryObject::Raw(_) => return Err(invalid("undecodable binary representation")),
    })
}

/// A service description, empty topic names meaning the default ones.
fn service(
    service_name: &str,
    request_type: &str,
    reply_type: &str,
    request_topic: Option<&str>,
    reply_topic: Option<&str>,
) -> Box<ServiceDescription> {
    let non_empty = |s: Option<&str>| s.filter(|s| !s.is_empty()).map(str::to_owned);
    Box::new(ServiceDescription {
        service_name: service_name.to_owned(),
        request_type: request_type.to_owned(),
        reply_type: reply_type.to_owned(),
        request_topic_name: non_empty(request_topic),
        reply_topic_name: non_empty(reply_topic),
    })
}
