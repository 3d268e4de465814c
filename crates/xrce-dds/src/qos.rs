//! Endpoint QoS as a plain struct, filled by the agent from XML profiles or the binary QoS bits (spec §7.4),
//! and its translation to RustDDS.

use std::time::Duration;

use rustdds::{policy, QosPolicies, QosPolicyBuilder};

/// Samples a KEEP_ALL endpoint may hold when the description gives no resource limits.
///
/// RustDDS' default topic cache holds only 64 samples and evicts the oldest beyond that whether or not a
/// reader has taken them, so a reliable burst is silently cut (measured: 12 % of 100k delivered). RustDDS
/// also keeps up to this many already-taken samples in memory per topic and participant, hence a bound and
/// not "unlimited": 32,768 × (payload + ~150 B).
pub const DEFAULT_KEEP_ALL_SAMPLES: i32 = 32_768;

/// Lower bound for a KEEP_LAST endpoint's cache: the dispatcher takes samples in batches, and the cache must
/// hold at least one batch so a burst does not overwrite samples before they are taken.
pub const MIN_KEEP_LAST_SAMPLES: i32 = 1_024;

/// Smallest bridge-side queue of a *reliable* reader, whatever its history depth.
///
/// The queue is a flow-control window between the dispatcher and the agent, not a history: with a
/// KEEP_LAST 1 reader a queue of one sample made the dispatcher pause after every sample and wait for a
/// resume round trip, while RustDDS' topic cache (1,024 samples, [`MIN_KEEP_LAST_SAMPLES`]) overflowed and
/// silently evicted samples nobody had taken (measured: 71 % loss XRCE → DDS → XRCE at 60k samples/s).
/// Best-effort readers keep their depth (a slow best-effort reader should not hold stale samples).
pub const MIN_RELIABLE_QUEUE: usize = 1_024;

/// Reliability kind.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Reliability {
    /// Samples may be lost.
    BestEffort,
    /// Samples are repaired; a write blocks at most `max_blocking_time` when the send window is full.
    Reliable,
}

/// Durability kind (TRANSIENT and PERSISTENT are accepted; RustDDS treats them like TRANSIENT_LOCAL).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Durability {
    /// No history for late joiners.
    Volatile,
    /// The writer keeps its history for late-joining readers.
    TransientLocal,
    /// As TRANSIENT_LOCAL in RustDDS.
    Transient,
    /// As TRANSIENT_LOCAL in RustDDS.
    Persistent,
}

/// History kind and depth.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum History {
    /// Keep the last `depth` samples (per instance in DDS; see `reader.rs` for keyed raw topics).
    KeepLast(u32),
    /// Keep everything, up to the resource limits.
    KeepAll,
}

/// DDS RESOURCE_LIMITS; counts are positive (no "unlimited": everything is bounded).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct ResourceLimits {
    /// Samples over all instances.
    pub max_samples: u32,
    /// Instances.
    pub max_instances: u32,
    /// Samples per instance.
    pub max_samples_per_instance: u32,
}

/// QoS of a raw datawriter or datareader (and of each half of a requester/replier).
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub struct EndpointQos {
    /// Reliability.
    pub reliability: Reliability,
    /// How long a reliable write may block on a full send window before failing with
    /// [`DdsError::Resources`](crate::DdsError::Resources). Fast DDS' default is 100 ms.
    pub max_blocking_time: Duration,
    /// Durability.
    pub durability: Durability,
    /// History.
    pub history: History,
    /// Resource limits; `None` picks bounds that avoid RustDDS' 64-sample default (see
    /// [`EndpointQos::effective_limits`]).
    pub resource_limits: Option<ResourceLimits>,
    /// DEADLINE period.
    pub deadline: Option<Duration>,
    /// LIFESPAN duration.
    pub lifespan: Option<Duration>,
    /// PARTITION names of the endpoint's publisher or subscriber (empty: the default partition). Applied by
    /// the Fast DDS engine; RustDDS 0.15.1 has no PARTITION policy and ignores them.
    pub partitions: Vec<String>,
}

impl Default for EndpointQos {
    /// Reliable, volatile, KEEP_ALL: the combination that never loses samples silently while the agent
    /// drains its readers, and matches every peer reader and writer (reliable writers match best-effort
    /// readers too).
    fn default() -> Self {
        Self {
            reliability: Reliability::Reliable,
            max_blocking_time: Duration::from_millis(100),
            durability: Durability::Volatile,
            history: History::KeepAll,
            resource_limits: None,
            deadline: None,
            lifespan: None,
            partitions: Vec::new(),
        }
    }
}

impl EndpointQos {
    /// Reliable, KEEP_ALL (the default).
    pub fn reliable() -> Self {
        Self::default()
    }

    /// Best effort, KEEP_LAST `depth`.
    pub fn best_effort(depth: u32) -> Self {
        Self { reliability: Reliability::BestEffort, history: History::KeepLast(depth), ..Self::default() }
    }

    /// The resource limits actually given to RustDDS: the explicit ones raised to the history depth, or
    /// [`DEFAULT_KEEP_ALL_SAMPLES`] for KEEP_ALL and `max(depth, MIN_KEEP_LAST_SAMPLES)` for KEEP_LAST.
    pub fn effective_limits(&self) -> ResourceLimits {
        let depth = match self.history {
            History::KeepLast(d) => d.max(1),
            History::KeepAll => 1,
        };
        match self.resource_limits {
            Some(rl) => ResourceLimits {
                max_samples: rl.max_samples.max(depth).max(1),
                max_instances: rl.max_instances.max(1),
                max_samples_per_instance: rl.max_samples_per_instance.max(depth).max(1),
            },
            None => {
                let n = match self.history {
                    History::KeepAll => DEFAULT_KEEP_ALL_SAMPLES.unsigned_abs(),
                    History::KeepLast(_) => depth.max(MIN_KEEP_LAST_SAMPLES.unsigned_abs()),
                };
                ResourceLimits { max_samples: n, max_instances: 1, max_samples_per_instance: n }
            }
        }
    }

    /// Capacity of the bridge-side queue of a reader with this QoS: how many received samples wait for the
    /// agent before the dispatcher stops taking from RustDDS. The history depth (KEEP_LAST) or the resource
    /// limit (KEEP_ALL); at least [`MIN_RELIABLE_QUEUE`] for a reliable KEEP_LAST reader.
    pub fn queue_capacity(&self) -> usize {
        match (self.history, self.reliability) {
            (History::KeepLast(d), Reliability::BestEffort) => usize::try_from(d.max(1)).unwrap_or(usize::MAX),
            (History::KeepLast(d), Reliability::Reliable) => {
                usize::try_from(d.max(1)).unwrap_or(usize::MAX).max(MIN_RELIABLE_QUEUE)
            }
            (History::KeepAll, _) => usize::try_from(self.effective_limits().max_samples).unwrap_or(usize::MAX),
        }
    }

    /// Translation to RustDDS. `force_keep_all` is used for keyed raw readers (all samples share one
    /// RustDDS instance, so KEEP_LAST would drop samples of distinct real instances).
    pub(crate) fn to_rustdds(&self, force_keep_all: bool) -> QosPolicies {
        let limits = self.effective_limits();
        let clamp = |v: u32| i32::try_from(v).unwrap_or(i32::MAX);
        let mut b = QosPolicyBuilder::new()
            .reliability(match self.reliability {
                Reliability::BestEffort => policy::Reliability::BestEffort,
                Reliability::Reliable => {
                    policy::Reliability::Reliable { max_blocking_time: rustdds::Duration::from(self.max_blocking_time) }
                }
            })
            .durability(match self.durability {
                Durability::Volatile => policy::Durability::Volatile,
                Durability::TransientLocal => policy::Durability::TransientLocal,
                Durability::Transient => policy::Durability::Transient,
                Durability::Persistent => policy::Durability::Persistent,
            })
            .history(match (self.history, force_keep_all) {
                (History::KeepLast(d), false) => policy::History::KeepLast { depth: clamp(d.max(1)) },
                _ => policy::History::KeepAll,
            })
            .resource_limits(policy::ResourceLimits {
                max_samples: clamp(limits.max_samples),
                max_instances: clamp(limits.max_instances),
                max_samples_per_instance: clamp(limits.max_samples_per_instance),
            });
        if let Some(d) = self.deadline {
            b = b.deadline(policy::Deadline(rustdds::Duration::from(d)));
        }
        if let Some(d) = self.lifespan {
            b = b.lifespan(policy::Lifespan { duration: rustdds::Duration::from(d) });
        }
        b.build()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_avoid_the_64_sample_cache() {
        let q = EndpointQos::default();
        assert_eq!(q.effective_limits().max_samples, 32_768);
        assert!(q.queue_capacity() >= 10_000);
        let be = EndpointQos::best_effort(10);
        assert_eq!(be.effective_limits().max_samples, 1_024);
        assert_eq!(be.queue_capacity(), 10);
        let rel = EndpointQos { history: History::KeepLast(1), ..EndpointQos::default() };
        assert_eq!(rel.queue_capacity(), MIN_RELIABLE_QUEUE, "a reliable reader's queue is a window, not a history");
    }

    #[test]
    fn explicit_limits_are_raised_to_depth() {
        let q = EndpointQos {
            history: History::KeepLast(100),
            resource_limits: Some(ResourceLimits { max_samples: 10, max_instances: 0, max_samples_per_instance: 5 }),
            ..EndpointQos::default()
        };
        let l = q.effective_limits();
        assert_eq!((l.max_samples, l.max_instances, l.max_samples_per_instance), (100, 1, 100));
    }

    #[test]
    fn translation_keeps_reliability_and_history() {
        let p = EndpointQos::best_effort(7).to_rustdds(false);
        assert_eq!(p.reliability(), Some(policy::Reliability::BestEffort));
        assert_eq!(p.history(), Some(policy::History::KeepLast { depth: 7 }));
        let p = EndpointQos::best_effort(7).to_rustdds(true);
        assert_eq!(p.history(), Some(policy::History::KeepAll));
    }
}
