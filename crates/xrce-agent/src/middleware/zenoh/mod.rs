//! The `zenoh` middleware (`-m zenoh`, cargo feature `zenoh`): XRCE entities join a ROS 2 graph that runs
//! on rmw_zenoh, with rmw_zenoh's own conventions (docs/zenoh.md).
//!
//! * **One Zenoh session** for the agent ([`session`]): rmw_zenoh's node defaults (a peer connecting to
//!   the router at `tcp/localhost:7447`), or `--zenoh-config` / `ZENOH_SESSION_CONFIG_URI`. No router:
//!   the agent serves its XRCE clients all the same, Zenoh retries, and the agent says once how to start one.
//! * **Named participants are nodes** (micro-ROS' rule for names, [`super::ros_graph::node_name`]); an
//!   unnamed one is node `xrce_<client key>`. Each node and each endpoint has its liveliness token
//!   ([`keys`]), withdrawn with the XRCE entity or its client: rmw_zenoh's graph sees them come and go.
//! * **Keys** carry the type's RIHS01 hash, from the type descriptions under `AMENT_PREFIX_PATH`
//!   ([`type_hash`]); a type without one is refused at creation (STATUS ERR_DDS_ERROR) with a message
//!   naming it and the fix, so nothing is ever sent under a wrong key.
//! * **Data** both ways with rmw_zenoh's attachment ([`attachment`]); QoS as rmw_zenoh maps it ([`qos`],
//!   [`declare`]): reliability, and transient local through zenoh-ext's AdvancedPublisher cache and
//!   AdvancedSubscriber history, which is what rmw_zenoh 0.2.x declares.
//! * **Services**: repliers are queryables, requesters send queries; requests and replies are matched by
//!   the attachment's sequence number and client GID, as rmw_zenoh matches them.
//! * **Never blocking**: Zenoh's threads queue into bounded per-reader [`inbox::Inbox`]es and call the
//!   [`Waker`]; puts use congestion control "drop"; declarations are local operations.

pub mod attachment;
mod declare;
mod diagnostics;
pub mod inbox;
pub mod keys;
pub mod qos;
pub mod session;
pub mod type_hash;

use std::collections::{HashMap, HashSet};
use std::path::Path;
use std::sync::Arc;
use std::time::Instant;

use xrce_proto::{ClientKey, ObjectKind, RequestId, SampleIdentity};
use zenoh::liveliness::LivelinessToken;

use super::dds::spec::{spec_of_creation, Spec, TopicSel};
use super::describe::ProfileSource;
use super::{
    Creation, EntityCounts, EntityRef, Middleware, MiddlewareError, MiddlewareStats, SampleVisitor, Waker, WriteOutcome,
};
use declare::{declare_token, source_time, At, Reader, Replier, Requester, Writer};
use inbox::{Inbox, WakerSlot};
use keys::{ros_service_name, ros_topic_name, service_type_name, EntityKind, NodeIdent, TopicIdent};
use qos::RosQos;
use session::{SessionError, Shell};
use type_hash::TypeHashes;

/// The QoS of service endpoints' tokens (rmw's services default: reliable, volatile, keep last 10).
const SERVICE_QOS: RosQos = RosQos {
    reliability: qos::Reliability::Reliable,
    durability: qos::Durability::Volatile,
    history: qos::History::KeepLast,
    depth: 10,
};

/// What each XRCE entity is on the Zenoh side.
enum Handle {
    Participant { node: NodeIdent, _token: LivelinessToken },
    Topic { name: String, type_name: String },
    Group,
    Writer(Writer),
    Reader(Reader),
    Requester(Requester),
    Replier(Replier),
}

impl Handle {
    fn inbox(&self) -> Option<&Inbox> {
        match self {
            Self::Reader(r) => Some(&r.inbox),
            Self::Requester(r) => Some(&r.inbox),
            Self::Replier(r) => Some(&r.inbox),
            _ => None,
        }
    }
}

struct Entity {
    parent: Option<EntityRef>,
    /// Digest of its spec, for REUSE.
    digest: u64,
    handle: Handle,
}

/// The `zenoh` middleware.
pub struct Zenoh {
    profiles: Arc<dyn ProfileSource>,
    shell: Shell,
    hashes: TypeHashes,
    /// `ROS_DOMAIN_ID`: the domain of participants created with XRCE's "default domain" (255).
    default_domain: u32,
    entities: HashMap<EntityRef, Entity>,
    owned: EntityCounts,
    names: HashMap<ClientKey, String>,
    waker: WakerSlot,
    /// rmw_zenoh numbers nodes and entities with one counter per session.
    next_id: u64,
    /// Types whose missing hash was already logged.
    reported: HashSet<String>,
    /// `--ros-diagnostics`: `/diagnostics` published from the core's snapshots.
    diagnostics: Option<diagnostics::RosDiagnostics>,
}

impl std::fmt::Debug for Zenoh {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Zenoh").field("shell", &self.shell).field("entities", &self.entities.len()).finish()
    }
}

/// `ROS_DOMAIN_ID` as rcl reads it (unset or empty: 0).
pub fn ros_domain_id() -> Result<u32, String> {
    domain_from(std::env::var("ROS_DOMAIN_ID").ok().as_deref())
}

/// The domain a `ROS_DOMAIN_ID` value names.
fn domain_from(value: Option<&str>) -> Result<u32, String> {
    match value.map(str::trim) {
        Some(v) if !v.is_empty() => v.parse().map_err(|_| format!("ROS_DOMAIN_ID={v:?} is not a domain number")),
        _ => Ok(0),
    }
}

impl Zenoh {
    /// Opens the session (`config_file`: `--zenoh-config`; else `ZENOH_SESSION_CONFIG_URI`; else
    /// rmw_zenoh's node defaults) and reads `ROS_DOMAIN_ID` and `AMENT_PREFIX_PATH`.
    pub fn open(profiles: Arc<dyn ProfileSource>, config_file: Option<&Path>) -> Result<Self, SessionError> {
        Self::open_with(profiles, config_file, false)
    }

    /// As [`Self::open`]; `ros_diagnostics`: publish ROS 2 `/diagnostics` from the core's snapshots.
    pub fn open_with(
        profiles: Arc<dyn ProfileSource>,
        config_file: Option<&Path>,
        ros_diagnostics: bool,
    ) -> Result<Self, SessionError> {
        let file = session::config_file(config_file);
        let config = session::build_config(file.as_deref())?;
        let default_domain = ros_domain_id().map_err(SessionError::Setting)?;
        let shell = Shell::open(config, file.is_none())?;
        Ok(Self {
            profiles,
            shell,
            hashes: TypeHashes::from_env(),
            default_domain,
            entities: HashMap::new(),
            owned: EntityCounts::default(),
            names: HashMap::new(),
            waker: WakerSlot::default(),
            next_id: 0,
            reported: HashSet::new(),
            diagnostics: ros_diagnostics.then(diagnostics::RosDiagnostics::default),
        })
    }

    /// The session's Zenoh id, as tokens carry it.
    pub fn zid(&self) -> &str {
        &self.shell.zid
    }

    fn take_id(&mut self) -> u64 {
        let id = self.next_id;
        self.next_id += 1;
        id
    }

    fn entity(&self, e: EntityRef) -> Result<&Entity, MiddlewareError> {
        self.entities.get(&e).ok_or_else(|| MiddlewareError::UnknownReference(format!("{e:?}")))
    }

    /// The node of the participant at or above `at` (endpoint → publisher/subscriber → participant).
    fn node_above(&self, mut at: Option<EntityRef>) -> Result<NodeIdent, MiddlewareError> {
        for _ in 0..3 {
            let e = at.ok_or_else(|| MiddlewareError::InvalidDescription("missing parent".into()))?;
            let entity = self.entity(e)?;
            if let Handle::Participant { node, .. } = &entity.handle {
                return Ok(node.clone());
            }
            at = entity.parent;
        }
        Err(MiddlewareError::InvalidDescription("no participant above the entity".into()))
    }

    /// The hash of `type_name`, or the error that names the type and the fix (logged once per type).
    fn type_hash(&mut self, type_name: &str) -> Result<String, MiddlewareError> {
        self.hashes.lookup(type_name).map_err(|e| {
            if self.reported.insert(type_name.to_owned()) {
                tracing::error!("{e}");
            }
            MiddlewareError::InvalidDescription(e.to_string())
        })
    }

    /// The ROS topic a datawriter or datareader names.
    fn topic_of(&mut self, client: ClientKey, sel: &TopicSel, qos: RosQos) -> Result<TopicIdent, MiddlewareError> {
        let (name, type_name) = match sel {
            TopicSel::Object(id) => match &self.entity(EntityRef::new(client, id.with_kind(ObjectKind::Topic)))?.handle
            {
                Handle::Topic { name, type_name } => (name.clone(), type_name.clone()),
                _ => return Err(MiddlewareError::UnknownReference(format!("topic {id:?}"))),
            },
            TopicSel::Name { name, type_name: Some(t), .. } => (name.clone(), t.clone()),
            TopicSel::Name { name, type_name: None, .. } => {
                let known = self.entities.iter().find_map(|(e, ent)| match &ent.handle {
                    Handle::Topic { name: n, type_name } if e.client == client && n == name => Some(type_name.clone()),
                    _ => None,
                });
                (name.clone(), known.ok_or_else(|| MiddlewareError::UnknownReference(format!("topic {name:?}")))?)
            }
        };
        let type_hash = self.type_hash(&type_name)?;
        Ok(TopicIdent { name: ros_topic_name(&name), type_name, type_hash, qos })
    }

    fn build(&mut self, creation: &Creation<'_>, spec: &Spec) -> Result<Handle, MiddlewareError> {
        let client = creation.entity.client;
        Ok(match (creation.entity.kind(), spec) {
            (ObjectKind::Participant, Spec::Participant { name, .. }) => {
                let xrce_domain = creation.variant.domain_id().unwrap_or(0);
                let domain = match u32::try_from(xrce_domain) {
                    Ok(d) if d != 255 => d,
                    _ => self.default_domain,
                };
                let (namespace, name) = match name.as_deref().and_then(super::ros_graph::node_name) {
                    Some(n) => (n.namespace, n.name),
                    None => ("/".to_owned(), format!("xrce_{:08x}", client.to_u32())),
                };
                let node_id = self.take_id();
                let node =
                    NodeIdent { domain, zid: self.shell.zid.clone(), node_id, enclave: "/".into(), namespace, name };
                let token = keys::liveliness_token(&node, node_id, EntityKind::Node, None);
                Handle::Participant { _token: declare_token(&self.shell, &token)?, node }
            }
            (ObjectKind::Topic, Spec::Topic { name, type_name, .. }) => {
                // Checked now, so a client learns at once that its type cannot travel.
                self.type_hash(type_name)?;
                Handle::Topic { name: name.clone(), type_name: type_name.clone() }
            }
            (ObjectKind::Publisher | ObjectKind::Subscriber, Spec::Group { .. }) => Handle::Group,
            (ObjectKind::DataWriter | ObjectKind::DataReader, Spec::Endpoint { topic, qos }) => {
                let node = self.node_above(creation.parent)?;
                let topic = self.topic_of(client, topic, RosQos::from_endpoint(qos))?;
                let id = self.take_id();
                let at = At { shell: &self.shell, node: &node, id, topic: &topic };
                if creation.entity.kind() == ObjectKind::DataWriter {
                    Handle::Writer(Writer::declare(at)?)
                } else {
                    Handle::Reader(Reader::declare(at, Inbox::new(self.waker.clone()))?)
                }
            }
            (ObjectKind::Requester | ObjectKind::Replier, Spec::Service { desc, .. }) => {
                let node = self.node_above(creation.parent)?;
                let type_name = service_type_name(&desc.request_type);
                let service = TopicIdent {
                    name: ros_service_name(&desc.service_name, desc.request_topic_name.as_deref()),
                    type_hash: self.type_hash(&type_name)?,
                    type_name,
                    qos: SERVICE_QOS,
                };
                let id = self.take_id();
                let inbox = Inbox::new(self.waker.clone());
                let at = At { shell: &self.shell, node: &node, id, topic: &service };
                if creation.entity.kind() == ObjectKind::Requester {
                    Handle::Requester(Requester::declare(at, inbox)?)
                } else {
                    Handle::Replier(Replier::declare(at, inbox)?)
                }
            }
            (kind, _) => return Err(MiddlewareError::Unsupported(format!("{kind:?} in the zenoh middleware"))),
        })
    }
}

impl Middleware for Zenoh {
    fn create(&mut self, creation: &Creation<'_>) -> Result<(), MiddlewareError> {
        let spec = spec_of_creation(self.profiles.as_ref(), creation)?;
        let handle = self.build(creation, &spec)?;
        if let (Handle::Participant { node, .. }, Some(name)) = (&handle, spec_participant_name(&spec)) {
            tracing::debug!(node = %node.name, namespace = %node.namespace, "XRCE participant {name:?} is a ROS node");
            self.names.insert(creation.entity.client, name.to_owned());
        }
        let entity = Entity { parent: creation.parent, digest: spec.digest(), handle };
        if self.entities.insert(creation.entity, entity).is_none() {
            self.owned.added(creation.entity.client);
        }
        Ok(())
    }

    fn matches(&self, creation: &Creation<'_>) -> bool {
        let Some(entity) = self.entities.get(&creation.entity) else { return false };
        spec_of_creation(self.profiles.as_ref(), creation)
            .is_ok_and(|spec| entity.parent == creation.parent && entity.digest == spec.digest())
    }

    fn delete(&mut self, entity: EntityRef) -> Result<(), MiddlewareError> {
        // Dropping the handle undeclares its Zenoh entities and withdraws its token.
        self.entities.remove(&entity).ok_or_else(|| MiddlewareError::UnknownReference(format!("{entity:?}")))?;
        self.owned.removed(entity.client);
        Ok(())
    }

    fn delete_client(&mut self, client: ClientKey) {
        self.names.remove(&client);
        if self.owned.forget(client) {
            self.entities.retain(|e, _| e.client != client);
        }
    }

    fn write_data(&mut self, writer: EntityRef, data: &[u8], now: Instant) -> Result<WriteOutcome, MiddlewareError> {
        let time = source_time(&self.shell, now);
        match self.entities.get_mut(&writer).map(|e| &mut e.handle) {
            Some(Handle::Writer(w)) => w.write(data, time).map(|()| WriteOutcome::Accepted),
            Some(_) => Err(MiddlewareError::Unsupported(format!("{writer:?} is not a datawriter"))),
            None => Err(MiddlewareError::UnknownReference(format!("{writer:?}"))),
        }
    }

    fn write_request(
        &mut self,
        requester: EntityRef,
        request_id: RequestId,
        data: &[u8],
        now: Instant,
    ) -> Result<WriteOutcome, MiddlewareError> {
        let time = source_time(&self.shell, now);
        match self.entities.get_mut(&requester).map(|e| &mut e.handle) {
            Some(Handle::Requester(r)) => {
                r.request(&self.shell, request_id, data, time).map(|()| WriteOutcome::Accepted)
            }
            Some(_) => Err(MiddlewareError::Unsupported(format!("{requester:?} is not a requester"))),
            None => Err(MiddlewareError::UnknownReference(format!("{requester:?}"))),
        }
    }

    fn write_reply(
        &mut self,
        replier: EntityRef,
        identity: &SampleIdentity,
        data: &[u8],
        now: Instant,
    ) -> Result<WriteOutcome, MiddlewareError> {
        let time = source_time(&self.shell, now);
        match self.entities.get(&replier).map(|e| &e.handle) {
            Some(Handle::Replier(r)) => r.reply(identity, data, time).map(|()| WriteOutcome::Accepted),
            Some(_) => Err(MiddlewareError::Unsupported(format!("{replier:?} is not a replier"))),
            None => Err(MiddlewareError::UnknownReference(format!("{replier:?}"))),
        }
    }

    fn start_reading(&mut self, reader: EntityRef) -> Result<(), MiddlewareError> {
        match self.entity(reader)?.handle.inbox() {
            Some(_) => Ok(()),
            None => Err(MiddlewareError::Unsupported(format!("{reader:?} cannot read"))),
        }
    }

    fn poll_sample(&mut self, reader: EntityRef, visit: &mut SampleVisitor<'_>) -> Option<bool> {
        self.entities.get(&reader)?.handle.inbox()?.visit_front(|s| visit(s.as_ref()))
    }

    fn set_waker(&mut self, waker: Waker) {
        self.waker.set(waker);
    }

    fn stats(&self) -> MiddlewareStats {
        let count = |f: fn(&Handle) -> bool| self.entities.values().filter(|e| f(&e.handle)).count() as u64;
        MiddlewareStats {
            participants: count(|h| matches!(h, Handle::Participant { .. })),
            topics: count(|h| matches!(h, Handle::Topic { .. })),
            ..MiddlewareStats::default()
        }
    }

    fn client_name(&self, client: ClientKey) -> Option<String> {
        self.names.get(&client).cloned()
    }

    fn on_snapshot(&mut self, snapshot: &crate::core::AgentSnapshot, now: Instant) {
        self.write_diagnostics(snapshot, now);
    }
}

fn spec_participant_name(spec: &Spec) -> Option<&str> {
    match spec {
        Spec::Participant { name, .. } => name.as_deref(),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ros_domain_id_as_rcl_reads_it() {
        assert_eq!(domain_from(None), Ok(0));
        assert_eq!(domain_from(Some(" ")), Ok(0));
        assert_eq!(domain_from(Some("42")), Ok(42));
        assert!(domain_from(Some("robot")).unwrap_err().contains("ROS_DOMAIN_ID"));
    }
}
