//! First contact (see the parent module's documentation): each new datawriter, requester and replier is
//! gated until its DDS writer has matched the readers its participant knows, then, for reliable keep-last
//! writers, until they acknowledge; the write credit the core asks for.

use super::*;

/// A first-contact gate: when it was set, its bound while no known reader's participant is in discovery,
/// and, once the writer matched the known readers, how many more writes may go before every matched reader
/// has acknowledged one ([`Acks`]).
#[derive(Debug, Clone, Copy)]
pub(super) struct Gate {
    pub(super) created: Instant,
    pub(super) short: Duration,
    /// For a reliable keep-last datawriter: its depth until the writer matched the known readers, then the
    /// watch of their first acknowledgements.
    pub(super) acks: Acks,
}

/// The second half of a reliable keep-last datawriter's gate. Our writer matching a remote reader does not
/// mean the reader has matched our writer: until it has (its endpoint discovery may still lose a message),
/// the writer keeps its samples for it, but only its last `depth`; a reader that matches after more writes
/// than that misses the first ones (seen in 1 of 30 boot storms of 10 nodes: samples 0–2 lost, the ROS reader
/// matched about 1.3 s late). So at most `depth` writes go until every matched reader has acknowledged
/// (which it does only once it has matched the writer), for [`FIRST_CONTACT_DISCOVERY_LIMIT`] at most.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Acks {
    /// Not watched (best effort, keep-all, requesters, repliers, RustDDS).
    Unwatched,
    /// Still matching the known readers; then up to `depth` writes before the acknowledgements.
    Pending { depth: usize },
    /// Matched: `left` of `depth` writes may still go before every matched reader has acknowledged, watched
    /// since `since`.
    Watching { since: Instant, left: usize, depth: usize },
}

/// What a gate still waits for.
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct GateWait {
    /// Known readers not matched yet whose participant is in discovery with the writer's.
    pub(super) readers_in_discovery: usize,
    /// Known readers not matched yet (those above included) and participants in discovery.
    pub(super) unmatched: usize,
}

/// What the second half of a gate ([`Acks::Watching`]) lets a write do.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum AfterMatch {
    /// Go; the gate stays.
    Write,
    /// Wait until then at most (every matched reader may acknowledge meanwhile).
    Hold(Instant),
    /// Go, and forget the gate: every matched reader acknowledged, or the wait timed out.
    Open { timed_out: bool },
}

impl Gate {
    /// The second half: a write may go while writes are left; once none is, when every matched reader has
    /// acknowledged (`acked`, asked only once something was written) or at the deadline.
    pub(super) fn after_match(self, acked: impl FnOnce() -> bool, now: Instant) -> AfterMatch {
        let Acks::Watching { since, left, depth } = self.acks else { return AfterMatch::Open { timed_out: false } };
        if left == depth {
            // Nothing written since the match: nothing to acknowledge yet.
            return AfterMatch::Write;
        }
        if acked() {
            return AfterMatch::Open { timed_out: false };
        }
        if left > 0 {
            return AfterMatch::Write;
        }
        let until = (self.created + FIRST_CONTACT_DISCOVERY_LIMIT).max(since + self.short);
        if now < until {
            AfterMatch::Hold(until)
        } else {
            AfterMatch::Open { timed_out: true }
        }
    }

    /// Until when writes wait for `wait`; `None`: nothing to wait for.
    pub(super) fn hold_until(self, wait: GateWait) -> Option<Instant> {
        if wait.readers_in_discovery > 0 {
            Some(self.created + FIRST_CONTACT_DISCOVERY_LIMIT.max(self.short))
        } else if wait.unmatched > 0 {
            Some(self.created + self.short)
        } else {
            None
        }
    }
}

impl Dds {
    /// Whether `entity` (a datawriter, requester or replier) may write as far as its first-contact gate goes;
    /// opens (forgets) the gate once its DDS writer matched every reader known on its topic, or at its
    /// deadline: [`FIRST_CONTACT_DISCOVERY_LIMIT`] while a known reader's participant is still in discovery
    /// with the writer's, the gate's own (short) one otherwise.
    pub(super) fn gate_open(&mut self, entity: EntityRef, now: Instant) -> bool {
        let Some(&gate) = self.gates.get(&entity) else { return true };
        if let Acks::Watching { .. } = gate.acks {
            return self.acks_open(entity, gate, now);
        }
        let wait = match self.entities.get(&entity).map(|n| &n.handle) {
            Some(Handle::Writer(w)) => GateWait {
                readers_in_discovery: w.writer.unmatched_readers_in_discovery(),
                unmatched: w.writer.unmatched_known_readers() + w.writer.participant_in_discovery(),
            },
            Some(Handle::Requester(r)) => GateWait {
                readers_in_discovery: r.repliers_in_discovery(),
                unmatched: r.unmatched_known_repliers() + usize::from(r.matched_repliers() == 0),
            },
            Some(Handle::Replier(r)) => GateWait {
                readers_in_discovery: r.requesters_in_discovery(),
                unmatched: r.unmatched_known_requesters(),
            },
            _ => GateWait::default(),
        };
        if let Some(until) = gate.hold_until(wait).filter(|until| now < *until) {
            self.gate_timer.arm(until, self.waker.as_ref());
            return false;
        }
        if wait.unmatched > 0 {
            tracing::info!(
                ?entity,
                unmatched = wait.unmatched,
                readers_in_discovery = wait.readers_in_discovery,
                held_ms = now.saturating_duration_since(gate.created).as_millis(),
                "first-contact gate timed out; writing before every known reader matched"
            );
        } else {
            let matched = match self.entities.get(&entity).map(|n| &n.handle) {
                Some(Handle::Writer(w)) => w.writer.matched_readers(),
                _ => 0,
            };
            tracing::debug!(
                ?entity,
                matched,
                held_ms = now.saturating_duration_since(gate.created).as_millis(),
                "first-contact gate open: every known reader matched"
            );
        }
        if let Acks::Pending { depth } = gate.acks {
            if let Some(g) = self.gates.get_mut(&entity) {
                g.acks = Acks::Watching { since: now, left: depth, depth };
                return true;
            }
        }
        self.close_gate(entity);
        true
    }

    /// The second half of a datawriter's gate ([`Acks`]): see [`Gate::after_match`].
    pub(super) fn acks_open(&mut self, entity: EntityRef, gate: Gate, now: Instant) -> bool {
        let acked = || match self.entities.get(&entity).map(|n| &n.handle) {
            Some(Handle::Writer(w)) => w.writer.wait_for_acknowledgments(Duration::ZERO).unwrap_or(true),
            _ => true,
        };
        match gate.after_match(acked, now) {
            AfterMatch::Write => true,
            AfterMatch::Hold(until) => {
                self.gate_timer.arm(until, self.waker.as_ref());
                false
            }
            AfterMatch::Open { timed_out } => {
                if timed_out {
                    tracing::info!(
                        ?entity,
                        held_ms = now.saturating_duration_since(gate.created).as_millis(),
                        "first-contact gate timed out; writing before every matched reader acknowledged"
                    );
                } else {
                    tracing::debug!(?entity, "first-contact gate open: every matched reader acknowledged");
                }
                self.close_gate(entity);
                true
            }
        }
    }

    /// How a datawriter with `qos` is watched after its gate's first half: reliable keep-last writers on Fast
    /// DDS are (their history evicts unacknowledged samples), others not.
    pub(super) fn ack_watch_for(&self, qos: &DdsQos) -> Acks {
        match (qos.reliability, qos.history, self.bridge.engine()) {
            (xrce_dds::Reliability::Reliable, xrce_dds::History::KeepLast(depth), xrce_dds::Engine::FastDds) => {
                Acks::Pending { depth: usize::try_from(depth.max(1)).unwrap_or(usize::MAX) }
            }
            _ => Acks::Unwatched,
        }
    }

    /// The writer's credit now: 0 while its first-contact gate holds it, else the room left in the backlog of
    /// the agent's own slowest pinned reader of its topic (`u32::MAX`: nothing bounds it).
    pub(super) fn credit_now(&mut self, writer: EntityRef, now: Instant) -> u32 {
        if !self.gates.is_empty() && !self.gate_open(writer, now) {
            return 0;
        }
        if self.pinned.is_empty() {
            return u32::MAX;
        }
        let Some(Node { handle: Handle::Writer(state), .. }) = self.entities.get(&writer).map(|n| &**n) else {
            return u32::MAX;
        };
        let WriterState { writer: w, topic, written, .. } = &**state;
        let guid = w.guid();
        let room = self
            .pinned
            .iter()
            .filter_map(|r| self.entities.get(r))
            .filter_map(|node| match &node.handle {
                Handle::Reader(r) if r.topic == *topic => {
                    let bound = RELIABLE_BACKLOG.min(r.reader.queue().capacity() / 2).max(1);
                    Some(bound.saturating_sub(node.backlog_for(&guid, *written, now)))
                }
                _ => None,
            })
            .min();
        room.map_or(u32::MAX, |r| u32::try_from(r).unwrap_or(u32::MAX))
    }

    /// Drops the expired gates of endpoints without held samples, at most every [`GATE_SWEEP`], and gives the
    /// table's room back once it is mostly empty.
    pub(super) fn sweep_gates(&mut self, now: Instant) {
        if self.gates_swept_at.is_some_and(|at| now.saturating_duration_since(at) < GATE_SWEEP) {
            return;
        }
        self.gates_swept_at = Some(now);
        let held = &self.held;
        self.gates.retain(|e, g| now.saturating_duration_since(g.created) < GATE_EXPIRED || held.contains_key(e));
        if self.gates.len().saturating_mul(4) < self.gates.capacity() {
            self.gates.shrink_to_fit();
        }
        self.disarm_gate_timer_if_idle();
    }

    /// Forgets `entity`'s gate.
    pub(super) fn close_gate(&mut self, entity: EntityRef) {
        self.gates.remove(&entity);
        self.disarm_gate_timer_if_idle();
    }

    /// The gate timer runs only while a gate or a held sample waits.
    pub(super) fn disarm_gate_timer_if_idle(&mut self) {
        if self.gates.is_empty() && self.held.is_empty() {
            self.gate_timer.disarm();
        }
    }
}
