//! The plain data types of client.h, field for field (build.rs checks their sizes and alignments against the
//! header's), and their conversions to the Rust client's types.

#![allow(non_camel_case_types, non_snake_case)]

use xrce_client::{DeliveryControl, Durability, History, ObjectId, ObjectKind, QoS, Reliability, StreamId};

/// `uxrStreamId`.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct uxrStreamId {
    /// Id on the wire.
    pub raw: u8,
    /// Index among the streams of its type and direction.
    pub index: u8,
    /// `uxrStreamType`.
    pub type_: u8,
    /// `uxrStreamDirection`.
    pub direction: u8,
}

/// `UXR_NONE_STREAM`.
pub const NONE_STREAM: u8 = 0;
/// `UXR_BEST_EFFORT_STREAM`.
pub const BEST_EFFORT_STREAM: u8 = 1;
/// `UXR_RELIABLE_STREAM`.
pub const RELIABLE_STREAM: u8 = 2;
/// `UXR_INPUT_STREAM`.
pub const INPUT_STREAM: u32 = 0;
/// `UXR_OUTPUT_STREAM`.
pub const OUTPUT_STREAM: u32 = 1;

impl uxrStreamId {
    /// The C form of `id` used in `direction`.
    pub fn from_rust(id: StreamId, direction: u32) -> Self {
        let (index, type_) = match id.0 {
            0 => (0, NONE_STREAM),
            raw @ 1..=0x7F => (raw - 1, BEST_EFFORT_STREAM),
            raw => (raw - 0x80, RELIABLE_STREAM),
        };
        Self { raw: id.0, index, type_, direction: u8::try_from(direction).unwrap_or(0) }
    }

    /// The stream "none", returned when a stream cannot be created.
    pub fn none(direction: u32) -> Self {
        Self::from_rust(StreamId::NONE, direction)
    }

    /// The id on the wire.
    pub const fn rust(self) -> StreamId {
        StreamId(self.raw)
    }
}

/// `uxrObjectId`.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct uxrObjectId {
    /// Number of the object (12 bits on the wire).
    pub id: u16,
    /// `UXR_*_ID` kind.
    pub type_: u8,
}

impl uxrObjectId {
    /// The id on the wire.
    pub const fn rust(self) -> ObjectId {
        ObjectId::new(self.id, ObjectKind::from_nibble(self.type_))
    }

    /// The C form of a wire id.
    pub fn from_rust(id: ObjectId) -> Self {
        let [hi, lo] = id.0;
        Self { id: (u16::from(hi) << 4) | u16::from(lo >> 4), type_: lo & 0x0F }
    }
}

/// `uxrDeliveryControl`.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct uxrDeliveryControl {
    /// Samples to deliver (`UXR_MAX_SAMPLES_UNLIMITED`: no limit).
    pub max_samples: u16,
    /// Seconds the delivery lasts (0: no limit).
    pub max_elapsed_time: u16,
    /// Rate limit (0: none).
    pub max_bytes_per_second: u16,
    /// Minimum milliseconds between samples.
    pub min_pace_period: u16,
}

impl uxrDeliveryControl {
    /// The Rust client's form.
    pub const fn rust(self) -> DeliveryControl {
        DeliveryControl {
            max_samples: self.max_samples,
            max_elapsed_time: self.max_elapsed_time,
            max_bytes_per_second: self.max_bytes_per_second,
            min_pace_period: self.min_pace_period,
        }
    }
}

/// `uxrQoS_t` (three C enums, then the depth).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct uxrQoS_t {
    /// `uxrQoSDurability`.
    pub durability: u32,
    /// `uxrQoSReliability`.
    pub reliability: u32,
    /// `uxrQoSHistory`.
    pub history: u32,
    /// History depth.
    pub depth: u16,
}

impl uxrQoS_t {
    /// The Rust client's form; unknown enum values fall back to the defaults (volatile, best effort, keep last).
    pub const fn rust(self) -> QoS {
        QoS {
            durability: match self.durability {
                1 => Durability::TransientLocal,
                2 => Durability::Transient,
                3 => Durability::Persistent,
                _ => Durability::Volatile,
            },
            reliability: if self.reliability == 1 { Reliability::Reliable } else { Reliability::BestEffort },
            history: if self.history == 1 { History::KeepAll } else { History::KeepLast },
            depth: self.depth,
        }
    }
}
