//! `--ros-diagnostics` on Zenoh: each snapshot the core publishes becomes a ROS 2 `DiagnosticArray` on
//! `/diagnostics` ([`crate::middleware::diagnostics`] encodes it), published by the agent's own node
//! `/xrce_agent_<zid>` (its Zenoh id: every agent of a fleet has a node name of its own) with rmw_zenoh's key,
//! token and attachment, as rclcpp's diagnostic_updater publishes it
//! (reliable, volatile, keep last 10). The type hash comes from AMENT_PREFIX_PATH like any other: without
//! diagnostic_msgs there, no `/diagnostics` (said once).

use std::time::{Duration, Instant, UNIX_EPOCH};

use super::declare::{declare_token, At, Writer};
use super::keys::{liveliness_token, EntityKind, NodeIdent, TopicIdent};
use super::qos::RosQos;
use super::Zenoh;
use crate::core::AgentSnapshot;
use crate::middleware::diagnostics::{DiagnosticsState, TOPIC, TYPE};

/// The agent's node and its `/diagnostics` publisher, once declared.
pub(super) struct Publishing {
    writer: Writer,
    _node_token: zenoh::liveliness::LivelinessToken,
}

/// What `/diagnostics` needs between two snapshots.
#[derive(Default)]
pub(super) struct RosDiagnostics {
    state: DiagnosticsState,
    publishing: Option<Publishing>,
    /// The publisher could not be declared: no more attempts (said once).
    failed: bool,
}

/// The agent's node: `xrce_agent_<zid>`. One name for every agent would give a fleet's graph as many nodes of
/// that name as robots (`ros2 node list` warns of duplicates; tools keyed by node name mix them up).
fn node_name(zid: &str) -> String {
    format!("xrce_agent_{zid}")
}

impl Zenoh {
    /// Publishes `snapshot` on `/diagnostics`, declaring the agent's node and publisher on first use.
    pub(super) fn write_diagnostics(&mut self, snapshot: &AgentSnapshot, now: Instant) {
        let Some(mut d) = self.diagnostics.take() else { return };
        if d.publishing.is_none() && !d.failed {
            match self.declare_diagnostics() {
                Ok(p) => d.publishing = Some(p),
                Err(e) => {
                    tracing::warn!("no ROS 2 /diagnostics through Zenoh: {e}");
                    d.failed = true;
                }
            }
        }
        if let Some(p) = &mut d.publishing {
            let time = self.shell.clock.ns_at(now);
            let wall = UNIX_EPOCH + Duration::from_nanos(u64::try_from(time).unwrap_or(0));
            let body = d.state.encode(snapshot, wall);
            if let Err(e) = p.writer.write(&body, time) {
                tracing::debug!("/diagnostics sample not published: {e}");
            }
        }
        self.diagnostics = Some(d);
    }

    fn declare_diagnostics(&mut self) -> Result<Publishing, crate::middleware::MiddlewareError> {
        let type_hash = self.type_hash(TYPE)?;
        let node_id = self.take_id();
        let node = NodeIdent {
            domain: self.default_domain,
            zid: self.shell.zid.clone(),
            node_id,
            enclave: "/".into(),
            namespace: "/".into(),
            name: node_name(&self.shell.zid),
        };
        let node_token = declare_token(&self.shell, &liveliness_token(&node, node_id, EntityKind::Node, None))?;
        let topic = TopicIdent {
            name: super::keys::ros_topic_name(TOPIC),
            type_name: TYPE.to_owned(),
            type_hash,
            qos: RosQos { depth: 10, ..RosQos::default() },
        };
        let id = self.take_id();
        let writer = Writer::declare(At { shell: &self.shell, node: &node, id, topic: &topic })?;
        Ok(Publishing { writer, _node_token: node_token })
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn each_agent_has_a_node_name_of_its_own() {
        assert_eq!(super::node_name("1f2e"), "xrce_agent_1f2e");
        assert_ne!(super::node_name("1f2e"), super::node_name("a0"));
    }
}
