//! What the DDS middleware shows of itself in the agent's snapshot ([`MiddlewareStats`]).

use super::{Dds, Handle};
use crate::middleware::MiddlewareStats;

impl Dds {
    /// Its entities and what its first-contact gates hold, counted once per snapshot.
    pub(super) fn observed_stats(&self) -> MiddlewareStats {
        let mut stats = MiddlewareStats {
            // Gated, or a full backlog behind the agent's own slowest reliable reader, when the core last asked.
            writers_without_credit: self.without_credit.len() as u64,
            samples_at_gate: self.held.values().map(|h| h.len() as u64).sum(),
            ..MiddlewareStats::default()
        };
        for node in self.entities.values() {
            match node.handle {
                Handle::Participant(_) => stats.participants += 1,
                Handle::Topic(_) => stats.topics += 1,
                _ => {}
            }
        }
        stats
    }
}
