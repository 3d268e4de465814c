//! `--ros-diagnostics`: the DDS middleware writes each snapshot the core publishes as a ROS 2
//! `DiagnosticArray` on `rt/diagnostics` ([`crate::middleware::diagnostics`] encodes it), from the agent's
//! default DDS participant.
//!
//! The writer is created only once one of the agent's participants knows a remote `/diagnostics` reader
//! (`rqt_robot_monitor`, `diagnostic_aggregator`, `ros2 topic echo`): nobody reads it otherwise, and an
//! endpoint the default participant has before a peer appears costs that peer's first contact. A DDS peer that
//! discovers a participant with endpoints must fetch their announcements (SEDP) first; Cyclone DDS asked Fast
//! DDS 2.9 for the missing one as soon as it matched, Fast DDS answered only at its next heartbeat, 1 s later,
//! and the announcement of a client's writer created meanwhile waited behind it: a burst the client wrote right
//! after STATUS OK was lost whole (tests/dds_interop.rs, 6 runs in 6 with the writer created at start).

use std::time::SystemTime;

use xrce_dds::{Durability, EndpointQos, History, Participant, RawWriter, Reliability, AGENT_DOMAIN};

use super::Dds;
use crate::core::AgentSnapshot;
use crate::middleware::diagnostics::{DiagnosticsState, TOPIC, TYPE};

/// The diagnostics writer and what the arrays need between two snapshots.
#[derive(Default)]
pub(super) struct RosDiagnostics {
    state: DiagnosticsState,
    /// The participant and writer, once created.
    writer: Option<(Participant, RawWriter)>,
    /// The writer could not be created: no more attempts (warned once).
    failed: bool,
}

impl std::fmt::Debug for RosDiagnostics {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("RosDiagnostics").field("writer", &self.writer.is_some()).finish_non_exhaustive()
    }
}

impl Dds {
    /// Writes `snapshot` on `/diagnostics`, creating the writer on first use.
    pub(super) fn write_diagnostics(&mut self, snapshot: &AgentSnapshot) {
        let Some(d) = &mut self.diagnostics else { return };
        if d.failed {
            return;
        }
        if d.writer.is_none() {
            if self.bridge.domain_knows_reader(AGENT_DOMAIN, TOPIC) != Some(true) {
                return;
            }
            let created = self.bridge.participant(AGENT_DOMAIN, "").and_then(|p| {
                let topic = p.topic(TOPIC, TYPE, false)?;
                // rclcpp's default publisher QoS (diagnostic_updater's): reliable, volatile, keep last 10.
                let qos = EndpointQos {
                    reliability: Reliability::Reliable,
                    durability: Durability::Volatile,
                    history: History::KeepLast(10),
                    ..EndpointQos::default()
                };
                let w = p.create_writer(&topic, &qos)?;
                Ok((p, w))
            });
            match created {
                Ok(pw) => d.writer = Some(pw),
                Err(e) => {
                    tracing::warn!("no ROS 2 /diagnostics: cannot create its writer: {e}");
                    d.failed = true;
                    return;
                }
            }
        }
        let body = d.state.encode(snapshot, SystemTime::now());
        if let Some((_, w)) = &d.writer {
            if let Err(e) = w.write(&body) {
                tracing::debug!("/diagnostics sample not written: {e}");
            }
        }
    }
}
