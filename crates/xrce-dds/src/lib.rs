//! The DDS side of the XRCE agent: an untyped bridge from XRCE entities to a real DDS domain, built on the
//! pure-Rust `rustdds` 0.15.1 or, with the `fastdds` feature and [`Engine::FastDds`], on Fast DDS 2.x or 3.x
//! (see `engine.rs` for the dispatch).
//!
//! * [`DdsBridge`] shares DDS participants per (domain, profile) among XRCE participants, so thousands of
//!   clients fit where eProsima's one-participant-per-client design dies at ~210 (issue 5 item 6).
//! * Topics are raw: name and type name are runtime strings; samples are the XRCE client's CDR bodies,
//!   with the `00 01 00 00` encapsulation added on publish and removed on receive by RustDDS itself
//!   (spec §8.4; see `raw.rs`).
//! * Readers deliver into bounded [`SampleQueue`]s from one dispatcher thread per participant, in batches,
//!   with a waker for the agent: no polling loop anywhere.
//! * [`Requester`] and [`Replier`] bridge eProsima's request/reply entities with the related sample
//!   identity Fast DDS uses.
//!
//! Every DDS participant must run inside a loopback-only network namespace in tests (see
//! `shared/dds-peers/netns.sh`); the DDS tests of this crate are `#[ignore]`d and refuse to run elsewhere.
#![forbid(unsafe_code)]
#![warn(missing_docs)]

mod bridge;
mod engine;
mod error;
#[cfg(feature = "fastdds")]
mod fast;
mod qos;
mod raw;
mod reader;
pub mod ros_env;
mod service;
mod shared;

pub use bridge::{BridgeConfig, ParticipantKey, AGENT_DOMAIN, DOMAIN_OVERRIDE_ENV, MAX_DOMAIN_ID};
pub use engine::{DdsBridge, Engine, Participant, RawReader, RawTopic, RawWriter, ENGINE_ENV};
pub use error::DdsError;
pub use qos::{
    Durability, EndpointQos, History, Reliability, ResourceLimits, DEFAULT_KEEP_ALL_SAMPLES, MIN_KEEP_LAST_SAMPLES,
    MIN_RELIABLE_QUEUE,
};
pub use reader::{QueueWaker, ReceivedSample, SampleIdentity, SampleQueue};
pub use ros_env::{DiscoverySettings, Range as DiscoveryRange, SettingsError};
pub use service::{Replier, Requester, ServiceDescription, MAX_PENDING_REQUESTS};
