//! DDS-XRCE agent library: a drop-in replacement for eProsima's `MicroXRCEAgent`.
//!
//! * [`core`]: the sans-IO agent core (sessions, streams, objects, read tasks).
//! * [`middleware`]: the `Middleware` trait and the CED middleware.
//! * [`transport`]: UDP and TCP shells around the core.
//! * [`agent`]: the library API of eProsima's agent (`Agent`, `AgentInstance`).
//! * [`custom_agent`]: eProsima's `CustomAgent`, an agent over the user's own transport.
//! * [`metrics`]: `--metrics`, the agent's snapshot as Prometheus metrics over HTTP.
#![cfg_attr(not(test), deny(clippy::unwrap_used, clippy::expect_used, clippy::indexing_slicing, clippy::panic))]

pub mod agent;
/// Recycled byte buffers, shared by the core and the CED middleware (internal).
mod bufpool;
pub mod cli;
pub mod config_file;
pub mod core;
pub mod custom_agent;
pub mod logging;
pub mod main_cli;
pub mod metrics;
pub mod middleware;
pub mod profile;
pub mod transport;

/// docs/agent-api.md: its code blocks are doctests, so the page cannot drift from the API.
#[cfg(doctest)]
#[doc = include_str!("../../../docs/agent-api.md")]
pub struct AgentApiDoc;
