//! Endpoint QoS as the Fast DDS XML profile syntax expresses it, with Fast DDS's defaults.
//!
//! Only the policies the agent acts on or compares for REUSE are modelled; the rest of the Fast DDS QoS
//! schema is accepted and ignored by the parser.

/// Reliability kind (`<qos><reliability><kind>`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Reliability {
    /// `RELIABLE`: lost samples are repaired.
    Reliable,
    /// `BEST_EFFORT`: lost samples stay lost.
    BestEffort,
}

/// Durability kind (`<qos><durability><kind>`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Durability {
    /// `VOLATILE`: late joiners get nothing written before they matched.
    Volatile,
    /// `TRANSIENT_LOCAL`: the writer keeps its history for late joiners.
    TransientLocal,
    /// `TRANSIENT`: history kept beyond the writer's lifetime (in memory).
    Transient,
    /// `PERSISTENT`: history kept on permanent storage.
    Persistent,
}

/// History kind and depth (`<topic><historyQos>`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum History {
    /// `KEEP_LAST` with a depth of at least 1.
    KeepLast(u32),
    /// `KEEP_ALL`, bounded by the resource limits only.
    KeepAll,
}

/// Fast DDS's `LENGTH_UNLIMITED`: any value ≤ 0 in a resource limit means "no limit".
pub const LENGTH_UNLIMITED: i32 = -1;

/// Resource limits (`<topic><resourceLimitsQos>`); values ≤ 0 mean unlimited, as in DDS.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct ResourceLimits {
    /// Most samples kept in total.
    pub max_samples: i32,
    /// Most instances (keys) kept.
    pub max_instances: i32,
    /// Most samples kept per instance.
    pub max_samples_per_instance: i32,
}

impl Default for ResourceLimits {
    /// Fast DDS 2.x/3.x defaults (the versions eProsima's agents v2.x/v3.x build with): 5000 samples,
    /// 10 instances, 400 samples per instance.
    fn default() -> Self {
        Self { max_samples: 5000, max_instances: 10, max_samples_per_instance: 400 }
    }
}

/// QoS of a datawriter or datareader.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct EndpointQos {
    /// Reliability.
    pub reliability: Reliability,
    /// Durability.
    pub durability: Durability,
    /// History.
    pub history: History,
    /// Resource limits.
    pub resource_limits: ResourceLimits,
}

impl EndpointQos {
    /// Fast DDS's datawriter defaults: reliable, transient-local, keep-last 1.
    pub fn writer_default() -> Self {
        Self {
            reliability: Reliability::Reliable,
            durability: Durability::TransientLocal,
            history: History::KeepLast(1),
            resource_limits: ResourceLimits::default(),
        }
    }

    /// Fast DDS's datareader defaults: best-effort, volatile, keep-last 1.
    pub fn reader_default() -> Self {
        Self {
            reliability: Reliability::BestEffort,
            durability: Durability::Volatile,
            history: History::KeepLast(1),
            resource_limits: ResourceLimits::default(),
        }
    }
}
