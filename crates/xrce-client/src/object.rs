//! Object identifiers, creation modes and the binary QoS of `uxrQoS_t` (spec §5, §7.4, §11).

use xrce_proto::object::{EndpointQos, QosFlags};
pub use xrce_proto::submessage::DataDeliveryControl as DeliveryControl;
pub use xrce_proto::{ObjectId, ObjectKind};

/// CREATE flag: keep an existing object that matches (`UXR_REUSE`).
pub const REUSE: u8 = xrce_proto::submessage::CreationMode::REUSE_FLAG;
/// CREATE flag: replace an existing object (`UXR_REPLACE`).
pub const REPLACE: u8 = xrce_proto::submessage::CreationMode::REPLACE_FLAG;

/// `uxr_object_id`: the id of object number `id` (12 bits) of `kind`.
pub const fn object_id(id: u16, kind: ObjectKind) -> ObjectId {
    ObjectId::new(id, kind)
}

/// Durability of a binary-created writer or reader (`uxrQoSDurability`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Durability {
    /// `UXR_DURABILITY_VOLATILE`.
    #[default]
    Volatile,
    /// `UXR_DURABILITY_TRANSIENT_LOCAL`.
    TransientLocal,
    /// `UXR_DURABILITY_TRANSIENT`.
    Transient,
    /// `UXR_DURABILITY_PERSISTENT`.
    Persistent,
}

/// Reliability of a binary-created writer or reader (`uxrQoSReliability`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Reliability {
    /// `UXR_RELIABILITY_BEST_EFFORT`.
    BestEffort,
    /// `UXR_RELIABILITY_RELIABLE`.
    #[default]
    Reliable,
}

/// History kind of a binary-created writer or reader (`uxrQoSHistory`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum History {
    /// `UXR_HISTORY_KEEP_LAST`.
    #[default]
    KeepLast,
    /// `UXR_HISTORY_KEEP_ALL`.
    KeepAll,
}

/// `uxrQoS_t`: the QoS the binary creation functions carry.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct QoS {
    /// Durability.
    pub durability: Durability,
    /// Reliability.
    pub reliability: Reliability,
    /// History kind.
    pub history: History,
    /// History depth; 0 leaves it out of the blob, as the C client does.
    pub depth: u16,
}

impl QoS {
    /// The `qos_flags` bits of this QoS.
    pub const fn flags(&self) -> u16 {
        let mut f = 0;
        if matches!(self.reliability, Reliability::Reliable) {
            f |= QosFlags::RELIABLE;
        }
        if matches!(self.history, History::KeepLast) {
            f |= QosFlags::HISTORY_KEEP_LAST;
        }
        f |= match self.durability {
            Durability::Volatile => 0,
            Durability::TransientLocal => QosFlags::DURABILITY_TRANSIENT_LOCAL,
            Durability::Transient => QosFlags::DURABILITY_TRANSIENT,
            Durability::Persistent => QosFlags::DURABILITY_PERSISTENT,
        };
        f
    }

    /// The endpoint QoS blob part the C client sends: flags, and the depth when not 0.
    pub const fn endpoint(&self) -> EndpointQos<'static> {
        EndpointQos {
            qos_flags: self.flags(),
            history_depth: if self.depth != 0 { Some(self.depth) } else { None },
            deadline_msec: None,
            lifespan_msec: None,
            user_data: None,
        }
    }
}
