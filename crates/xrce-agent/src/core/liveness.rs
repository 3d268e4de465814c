//! No ghost clients: a client that stops answering is probed, then removed with its entities, so DDS peers
//! and the ROS 2 graph lose its writers and readers.
//!
//! * Timeout `T`: the client's `uxr_hl` (eProsima's hard liveliness, milliseconds) plus
//!   [`max_liveliness_probes`](super::CoreConfig::max_liveliness_probes) heartbeat periods, probing from
//!   `uxr_hl` on every period (eProsima's agent: three GET_INFO, one per period, then removal); otherwise
//!   [`remove_silent_clients_after`](super::CoreConfig::remove_silent_clients_after) (`--client-timeout`,
//!   60 s by default), probing from `T/2` on, four times.
//! * A probe is a HEARTBEAT on each reliable output stream of the client (the C client answers with an
//!   ACKNACK whenever it runs its session, idle or not; an empty range when nothing is in flight), plus a
//!   GET_INFO (which eProsima's agent sends) for a client without reliable output streams, a `uxr_hl`
//!   client, or once a HEARTBEAT went unanswered: the C client answers GET_INFO with an INFO that lacks its
//!   submessage header, which still counts but is logged as undecodable, so it is not the first choice.
//!   Anything the client sends counts as an answer.
//! * Suspects: when a new session arrives from a client's endpoint with another key (a reboot), or, with
//!   authentication on, its key is claimed from another address, the client is probed at once and removed
//!   if it stays silent for [`suspect_grace`](super::CoreConfig::suspect_grace). A second session sharing
//!   the endpoint (the C client allows several per transport) answers and stays.
//!
//! * A client registered through the library API (eProsima's `create_client`, entities prepared ahead) is
//!   not timed out before its first message: it may connect much later.
//!
//! One timer per client, at `last heard + T/2` while it talks: a turn every `T/2` at most, not every
//! heartbeat period.

use foldhash::{HashMap, HashMapExt};
use smallvec::SmallVec;
use std::fmt::Debug;
use std::hash::Hash;
use std::time::{Duration, Instant};

use xrce_proto::submessage::{GetInfo, Heartbeat};
use xrce_proto::{BaseObjectRequest, ClientKey, ObjectId, RequestId, Submessage};

use super::connection::{Connection, Ctx, Liveness};
use super::timer::Timer;
use super::{AgentCore, CoreConfig};
use crate::middleware::Middleware;

/// Probes sent to a client without `uxr_hl` between `T/2` and `T`.
pub const PROBES_BEFORE_TIMEOUT: u32 = 4;

/// A client's liveness timer.
#[derive(Debug, Default, Clone)]
pub struct Watch {
    /// Probed at once (see the module documentation): since when, and removed at `until` unless heard.
    /// Boxed: rare, and 24 B less in each of thousands of idle connections.
    suspect: Option<Box<(Instant, Instant)>>,
    /// Registered through the API and not heard from yet: not timed out.
    unclaimed: bool,
}

/// When a client is probed and removed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Plan {
    probe_from: Duration,
    interval: Duration,
    timeout: Duration,
}

impl Plan {
    fn of(hard_liveliness: Option<Duration>, config: &CoreConfig) -> Option<Self> {
        let period = config.heartbeat_period;
        match hard_liveliness {
            Some(hl) => Some(Self {
                probe_from: hl,
                interval: period,
                timeout: hl.saturating_add(period.saturating_mul(u32::from(config.max_liveliness_probes))),
            }),
            None => config.remove_silent_clients_after.filter(|t| !t.is_zero()).map(|t| Self {
                probe_from: t / 2,
                interval: (t / 2 / PROBES_BEFORE_TIMEOUT).max(Duration::from_millis(10)),
                timeout: t,
            }),
        }
    }
}

impl<E: Copy + Eq + Hash + Debug> Connection<E> {
    /// Starts watching a new client (`from_api`: registered through the library API, with no endpoint yet).
    pub(super) fn start_watch(&mut self, config: &CoreConfig, now: Instant, from_api: bool) {
        self.watch.unclaimed = from_api;
        self.timers.set_opt(Timer::Liveness, Plan::of(self.hard_liveliness, config).map(|p| now + p.probe_from));
    }

    /// Probes the client at once; removed unless heard from within `grace`.
    pub(super) fn suspect(&mut self, now: Instant, grace: Duration) {
        if self.watch.suspect.is_none() {
            self.watch.suspect = Some(Box::new((now, now + grace)));
            self.timers.set(Timer::Liveness, now);
        }
    }

    /// The liveness turn: probe, re-arm, or say the client is to be removed.
    pub(super) fn liveness_turn<M: Middleware>(&mut self, ctx: &mut Ctx<'_, E, M>, now: Instant) -> Liveness {
        self.timers.stop(Timer::Liveness);
        let plan = Plan::of(self.hard_liveliness, ctx.config);
        if let Some((since, until)) = self.watch.suspect.as_deref().copied() {
            if self.last_heard > since {
                self.watch.suspect = None;
            } else if now >= until {
                tracing::info!(client = %self.key, peer = ?self.endpoint, "client did not answer the probe sent when its endpoint started another session: removing");
                return Liveness::Remove;
            } else {
                self.probes = self.probes.saturating_add(1);
                super::stats::bump(&mut self.counters.rare().liveness_probes);
                self.probe(ctx);
                self.timers.set(Timer::Liveness, (now + ctx.config.heartbeat_period).min(until));
                return Liveness::Alive;
            }
        }
        let Some(plan) = plan else { return Liveness::Alive };
        if self.watch.unclaimed {
            if self.endpoint.is_none() {
                self.timers.set(Timer::Liveness, now + plan.probe_from);
                return Liveness::Alive;
            }
            self.watch.unclaimed = false;
        }
        let silent = now.saturating_duration_since(self.last_heard);
        if silent >= plan.timeout {
            tracing::info!(client = %self.key, peer = ?self.endpoint, silent_ms = silent.as_millis(), probes = self.probes, "client silent past its timeout: removing it and its entities");
            return Liveness::Remove;
        }
        if silent >= plan.probe_from {
            self.probes = self.probes.saturating_add(1);
            super::stats::bump(&mut self.counters.rare().liveness_probes);
            self.probe(ctx);
            self.timers.set(Timer::Liveness, (now + plan.interval).min(self.last_heard + plan.timeout));
        } else {
            self.timers.set(Timer::Liveness, self.last_heard + plan.probe_from);
        }
        Liveness::Alive
    }

    /// One probe: a HEARTBEAT per reliable output stream, and a GET_INFO when needed (see the module
    /// documentation). `self.probes` counts this one.
    fn probe<M: Middleware>(&mut self, ctx: &mut Ctx<'_, E, M>) {
        let get_info = self.streams.rel_out.is_empty() || self.hard_liveliness.is_some() || self.probes >= 2;
        let beats: Vec<Heartbeat> = self
            .streams
            .rel_out
            .iter()
            .map(|(sid, out)| {
                out.heartbeat(*sid).unwrap_or_else(|| {
                    // Nothing in flight: an empty range still asks for an ACKNACK.
                    let next = out.first_unacked();
                    Heartbeat { first_unacked_seq_nr: next, last_unacked_seq_nr: next.wrapping_sub(1), stream_id: *sid }
                })
            })
            .collect();
        for hb in beats {
            self.send_control(ctx, &Submessage::Heartbeat(hb));
        }
        if get_info {
            let get = GetInfo {
                request: BaseObjectRequest { request_id: RequestId(0), object_id: ObjectId::CLIENT },
                info_mask: 0,
            };
            self.send_control(ctx, &Submessage::GetInfo(get));
        }
    }
}

/// The keyed clients each endpoint created, so a new session from an endpoint finds its predecessors
/// without scanning the client table. Entries of clients gone or moved are pruned when met.
#[derive(Debug)]
pub(super) struct CreatedFrom<E>(HashMap<E, SmallVec<[ClientKey; 4]>>);

impl<E> CreatedFrom<E> {
    /// Endpoints with keyed clients recorded.
    #[cfg(test)]
    pub(super) fn len(&self) -> usize {
        self.0.len()
    }
}

impl<E> Default for CreatedFrom<E> {
    fn default() -> Self {
        Self(HashMap::new())
    }
}

impl<E, M> AgentCore<E, M>
where
    E: Copy + Eq + Hash + Debug,
    M: Middleware,
{
    /// Probes client `key` at once (see [`Connection::suspect`]).
    pub(super) fn suspect(&mut self, key: ClientKey, now: Instant) {
        let grace = self.config.suspect_grace;
        if let Some(client) = self.clients.get_mut(&key) {
            client.suspect(now, grace);
            self.schedule(key);
        }
    }

    /// A new session from `from` with `key`: other keyed clients bound to that endpoint may be what the
    /// client was before a reboot; each is probed at once. Only sessions with the key in their header
    /// (`session_has_key(session_id)`) are recorded: a keyless one (eProsima's default, so micro-ROS and
    /// PX4) is bound to its endpoint already, and a new session from there replaces it at once
    /// ([`Self::register_client`]), so recording it too would cost a table entry per client for nothing.
    pub(super) fn suspect_endpoint_peers(&mut self, from: E, key: ClientKey, session_id: u8, now: Instant) {
        let clients = &self.clients;
        let mut others: Vec<ClientKey> = Vec::new();
        if let Some(created) = self.created_from.0.get_mut(&from) {
            created.retain(|k| clients.get(&*k).is_some_and(|c| c.endpoint == Some(from)));
            others.extend(created.iter().copied().filter(|k| *k != key));
            if created.is_empty() {
                self.created_from.0.remove(&from);
            }
        }
        if xrce_proto::session_has_key(session_id) {
            let created = self.created_from.0.entry(from).or_default();
            if !created.contains(&key) {
                created.push(key);
            }
        }
        if self.created_from.0.len() > 2 * self.clients.len() + 1024 {
            let clients = &self.clients;
            self.created_from.0.retain(|ep, keys| {
                keys.retain(|k| clients.get(&*k).is_some_and(|c| c.endpoint == Some(*ep)));
                !keys.is_empty()
            });
        }
        for other in others {
            tracing::debug!(client = %other, peer = ?from, new_client = %key, "new session from this client's endpoint: probing it");
            self.suspect(other, now);
        }
    }
}
