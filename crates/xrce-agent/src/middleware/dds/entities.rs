//! Building [`Dds`]'s entities from their XRCE descriptions: the participant of a parent, the topic, the
//! DDS endpoint with its QoS, and the ROS 2 graph entries of named participants.

use super::*;

impl Dds {
    /// The XRCE participant above `entity` (itself for a participant) and its DDS participant's GUID.
    /// `node` is `entity`'s, which may already be out of the table (deletion); its parents are still in.
    pub(super) fn graph_owner(&self, entity: EntityRef, node: &Node) -> Option<(EntityRef, [u8; 16])> {
        let (mut at, mut node) = (entity, node);
        // Participant ← publisher/subscriber ← endpoint: two steps up at most.
        for _ in 0..3 {
            if let Handle::Participant(p) = &node.handle {
                return Some((at, p.guid()));
            }
            at = node.parent?;
            node = self.entities.get(&at)?;
        }
        None
    }

    /// Tells the graph about a new entity: a participant named `name` becomes a node, an endpoint adds
    /// its DDS readers and writers to its participant's node.
    pub(super) fn graph_link(&self, entity: EntityRef, name: Option<&str>) {
        let (Some(g), Some(node)) = (&self.graph, self.entities.get(&entity)) else { return };
        if let Handle::Participant(p) = &node.handle {
            if let Some(name) = name {
                g.add_node(p, entity, name);
            }
        } else if let (Some((reader, writer)), Some((xrce, guid))) =
            (endpoint_gids(&node.handle), self.graph_owner(entity, node))
        {
            g.add_endpoint(guid, xrce, entity, reader, writer);
        }
    }

    /// Tells the graph an entity is gone.
    pub(super) fn graph_unlink(&self, entity: EntityRef, node: &Node) {
        let Some(g) = &self.graph else { return };
        match &node.handle {
            Handle::Participant(p) => g.remove_node(p.guid(), entity),
            h if endpoint_gids(h).is_some() => {
                if let Some((_, guid)) = self.graph_owner(entity, node) {
                    g.remove_endpoint(guid, entity);
                }
            }
            _ => {}
        }
    }

    pub(super) fn spec_of(&self, creation: &Creation<'_>) -> Result<Spec, MiddlewareError> {
        let mut spec = spec_of_creation(self.profiles.as_ref(), creation)?;
        if let Spec::Participant { domain, .. } = &mut spec {
            let xrce_domain = creation.variant.domain_id().unwrap_or(0);
            *domain = self.bridge.resolve_domain(i32::from(xrce_domain)).map_err(dds_error)?;
        }
        Ok(spec)
    }

    pub(super) fn node(&self, entity: EntityRef) -> Result<&Node, MiddlewareError> {
        self.entities.get(&entity).map(|n| &**n).ok_or_else(|| unknown(entity))
    }

    pub(super) fn participant_of(
        &self,
        parent: Option<EntityRef>,
    ) -> Result<(EntityRef, Participant), MiddlewareError> {
        let parent = parent.ok_or_else(|| invalid("missing parent"))?;
        match &self.node(parent)?.handle {
            Handle::Participant(p) => Ok((parent, p.clone())),
            _ => Err(invalid(format!("{parent:?} is not a participant"))),
        }
    }

    /// The participant above a publisher or subscriber.
    /// `qos` with the partitions of the publisher or subscriber `group` (when it has any).
    pub(super) fn with_group_partitions(&self, group: Option<EntityRef>, qos: &DdsQos) -> DdsQos {
        match group.and_then(|g| self.entities.get(&g)).map(|n| &n.handle) {
            Some(Handle::Group(parts)) if !parts.is_empty() => DdsQos { partitions: parts.to_vec(), ..qos.clone() },
            _ => qos.clone(),
        }
    }

    pub(super) fn group_participant(
        &self,
        parent: Option<EntityRef>,
    ) -> Result<(EntityRef, Participant), MiddlewareError> {
        let group = parent.ok_or_else(|| invalid("missing parent"))?;
        let node = self.node(group)?;
        match node.handle {
            Handle::Group(_) => self.participant_of(node.parent),
            _ => Err(invalid(format!("{group:?} is not a publisher or subscriber"))),
        }
    }

    pub(super) fn resolve_topic(
        &self,
        client: ClientKey,
        participant_ref: EntityRef,
        participant: &Participant,
        sel: &TopicSel,
    ) -> Result<RawTopic, MiddlewareError> {
        match sel {
            TopicSel::Object(id) => {
                let topic_ref = EntityRef::new(client, id.with_kind(ObjectKind::Topic));
                let node = self.node(topic_ref)?;
                match &node.handle {
                    Handle::Topic(t) if node.parent == Some(participant_ref) => Ok(t.clone()),
                    Handle::Topic(_) => Err(invalid(format!("topic {topic_ref:?} belongs to another participant"))),
                    _ => Err(unknown(topic_ref)),
                }
            }
            TopicSel::Name { name, type_name, keyed } => {
                // As eProsima: the endpoint's topic is the participant's topic of that name. It may have been
                // created by another XRCE participant sharing the DDS participant.
                if let Some(t) = participant.find_topic(name) {
                    if type_name.as_ref().is_some_and(|ty| *ty != t.type_name()) {
                        tracing::warn!(topic = %name, "endpoint names another type than its topic; the topic's is used");
                    }
                    return Ok(t);
                }
                match type_name {
                    Some(ty) => participant.topic(name, ty, *keyed).map_err(dds_error),
                    None => Err(MiddlewareError::UnknownReference(format!("topic {name:?}"))),
                }
            }
        }
    }

    pub(super) fn build(&self, creation: &Creation<'_>, spec: &Spec) -> Result<Handle, MiddlewareError> {
        let entity = creation.entity;
        let parent = creation.parent;
        Ok(match (entity.kind(), spec) {
            (ObjectKind::Participant, Spec::Participant { domain, name }) => {
                let domain = i32::from(*domain);
                let mut name = match name {
                    Some(n) if !self.share_participants => n.as_str(),
                    _ => "",
                };
                if !name.is_empty()
                    && self.bridge.participant_count() >= self.named_limit
                    && self.bridge.existing_participant(domain, name).is_none()
                {
                    tracing::warn!(
                        participant = name,
                        limit = self.named_limit,
                        "DDS participant limit reached: this XRCE participant shares the default DDS participant \
                         (--participant-names off shares them all)"
                    );
                    name = "";
                }
                Handle::Participant(self.bridge.participant(domain, name).map_err(dds_error)?)
            }
            (ObjectKind::Topic, Spec::Topic { name, type_name, keyed }) => {
                let (_, p) = self.participant_of(parent)?;
                Handle::Topic(p.topic(name, type_name, *keyed).map_err(dds_error)?)
            }
            (ObjectKind::Publisher | ObjectKind::Subscriber, Spec::Group { partitions }) => {
                let (_, p) = self.participant_of(parent)?;
                if !partitions.is_empty() && matches!(p, Participant::Rust(_)) {
                    // RustDDS 0.15.1 has no PARTITION policy (its QoS builder has none, its SEDP data
                    // carries none): endpoints below this group match as if in the default partition.
                    tracing::warn!(
                        ?entity,
                        ?partitions,
                        "DDS middleware: partitions cannot be applied (RustDDS has no PARTITION QoS)"
                    );
                }
                // Fast DDS: the group's partitions go to every endpoint created below it.
                Handle::Group(partitions.clone().into_boxed_slice())
            }
            (ObjectKind::DataWriter, Spec::Endpoint { topic, qos }) => {
                let (pref, p) = self.group_participant(parent)?;
                let t = self.resolve_topic(entity.client, pref, &p, topic)?;
                let qos = &non_blocking(&self.with_group_partitions(parent, qos));
                let topic = (p.key().domain_id, t.shared_name());
                let ahead = self.bridge.engine() == xrce_dds::Engine::FastDds
                    && qos.reliability == xrce_dds::Reliability::Reliable
                    && matches!(qos.history, xrce_dds::History::KeepLast(_))
                    && qos.lifespan.is_none()
                    && !t.is_keyed();
                Handle::Writer(Box::new(WriterState {
                    writer: p.shared_writer(&t, qos).map_err(dds_error)?,
                    topic,
                    written: None,
                    ahead,
                }))
            }
            (ObjectKind::DataReader, Spec::Endpoint { topic, qos }) => {
                let (pref, p) = self.group_participant(parent)?;
                let t = self.resolve_topic(entity.client, pref, &p, topic)?;
                let qos = &self.with_group_partitions(parent, qos);
                let topic = (p.key().domain_id, t.shared_name());
                let reliable = qos.reliability == xrce_dds::Reliability::Reliable;
                let reader = p.create_reader(&t, qos).map_err(dds_error)?;
                Handle::Reader(Box::new(ReaderState { reader, topic, reliable, local: VecDeque::new() }))
            }
            (ObjectKind::Requester, Spec::Service { desc, qos }) => {
                let (_, p) = self.participant_of(parent)?;
                Handle::Requester(Queued::new(Requester::new(&p, desc, &non_blocking(qos)).map_err(dds_error)?))
            }
            (ObjectKind::Replier, Spec::Service { desc, qos }) => {
                let (_, p) = self.participant_of(parent)?;
                Handle::Replier(Queued::new(Replier::new(&p, desc, &non_blocking(qos)).map_err(dds_error)?))
            }
            (kind, s) => return Err(invalid(format!("{kind:?} cannot be described as {s:?}"))),
        })
    }
}
