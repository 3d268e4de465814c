//! The core's counters: agent totals ([`CoreStats`]) and each client's ([`ClientCounters`]), plain integers
//! bumped on the loop's thread (no lock, no allocation per sample); [`snapshot`](super::snapshot) copies them
//! out. All saturate.

/// Why a whole datagram was dropped.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DropReason {
    /// The message header did not decode.
    BadHeader,
    /// No session matches it (and nothing answered it).
    UnknownClient,
    /// Authentication is on and the session belongs to another address.
    ForeignSender,
    /// The client opened more streams than [`CoreConfig::max_streams_per_client`](super::CoreConfig).
    TooManyStreams,
    /// A best-effort message older than the last one, or a reliable one outside the window or the buffer.
    OutOfOrder,
}

impl DropReason {
    /// Every reason, in the order of [`DatagramDrops::by_reason`].
    pub const ALL: [DropReason; 5] = [
        DropReason::BadHeader,
        DropReason::UnknownClient,
        DropReason::ForeignSender,
        DropReason::TooManyStreams,
        DropReason::OutOfOrder,
    ];

    /// Its name as a metric label.
    pub fn name(self) -> &'static str {
        match self {
            DropReason::BadHeader => "bad_header",
            DropReason::UnknownClient => "unknown_client",
            DropReason::ForeignSender => "foreign_sender",
            DropReason::TooManyStreams => "too_many_streams",
            DropReason::OutOfOrder => "out_of_order",
        }
    }
}

/// Why a client was removed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RemoveReason {
    /// A DELETE of the client, the library API's `delete_client` or `reset`.
    Deleted,
    /// Silent past its timeout (or its liveliness probes went unanswered).
    Timeout,
    /// A CREATE_CLIENT replaced it: the same key with another session, or another key from its endpoint.
    Replaced,
    /// Dead, and removed to make room in a full client table.
    Evicted,
}

impl RemoveReason {
    /// Every reason, in the order of [`CoreStats::clients_removed`].
    pub const ALL: [RemoveReason; 4] =
        [RemoveReason::Deleted, RemoveReason::Timeout, RemoveReason::Replaced, RemoveReason::Evicted];

    /// Its name as a metric label.
    pub fn name(self) -> &'static str {
        match self {
            RemoveReason::Deleted => "deleted",
            RemoveReason::Timeout => "timeout",
            RemoveReason::Replaced => "replaced",
            RemoveReason::Evicted => "evicted",
        }
    }

    fn index(self) -> usize {
        match self {
            RemoveReason::Deleted => 0,
            RemoveReason::Timeout => 1,
            RemoveReason::Replaced => 2,
            RemoveReason::Evicted => 3,
        }
    }
}

/// Datagrams dropped whole, by reason.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct DatagramDrops {
    /// Counts in the order of [`DropReason::ALL`].
    pub by_reason: [u64; DropReason::ALL.len()],
}

impl DatagramDrops {
    /// Dropped for `reason`.
    pub fn get(&self, reason: DropReason) -> u64 {
        self.by_reason.get(reason as usize).copied().unwrap_or(0)
    }
}

/// Agent totals; all saturate.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct CoreStats {
    /// Datagrams handed to the core.
    pub datagrams_in: u64,
    /// Datagrams dropped whole, all reasons together ([`Self::dropped`] splits them).
    pub datagrams_dropped: u64,
    /// Datagrams dropped whole, by reason.
    pub dropped: DatagramDrops,
    /// Submessages that failed to decode.
    pub decode_errors: u64,
    /// Messages queued for sending.
    pub messages_out: u64,
    /// Outgoing messages dropped (outbox full, too large for the MTU on a best-effort stream).
    pub messages_dropped_out: u64,
    /// Times the shell polled the middleware after its waker fired ([`AgentCore::poll_middleware`](super::AgentCore::poll_middleware)).
    pub middleware_polls: u64,
    /// Tail-loss probes sent: HEARTBEATs ahead of the period.
    pub tail_probes: u64,
    /// Samples from best-effort streams the middleware could not take (a full DDS history), dropped.
    pub samples_dropped_in: u64,
    /// CREATE_CLIENTs refused by client authentication (`--allow`, `--psk-file`).
    pub auth_refusals: u64,
    /// Clients created (a CREATE_CLIENT or the library API made a new one).
    pub clients_created: u64,
    /// Clients removed, in the order of [`RemoveReason::ALL`].
    pub clients_removed: [u64; RemoveReason::ALL.len()],
    /// The totals of the clients removed so far: added to the present clients' they give the agent's
    /// counters, which never go down (and cost nothing per sample).
    pub removed_clients: ClientCounters,
}

impl CoreStats {
    /// Counts a datagram dropped for `reason`.
    pub(crate) fn drop_datagram(&mut self, reason: DropReason) {
        self.datagrams_dropped = self.datagrams_dropped.saturating_add(1);
        if let Some(n) = self.dropped.by_reason.get_mut(reason as usize) {
            *n = n.saturating_add(1);
        }
    }

    /// Counts a client removed for `reason`.
    pub(crate) fn client_removed(&mut self, reason: RemoveReason) {
        if let Some(n) = self.clients_removed.get_mut(reason.index()) {
            *n = n.saturating_add(1);
        }
    }

    /// Clients removed for `reason`.
    pub fn removed(&self, reason: RemoveReason) -> u64 {
        self.clients_removed.get(reason.index()).copied().unwrap_or(0)
    }
}

/// One client's totals, kept in its connection; all saturate.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ClientCounters {
    /// Samples (WRITE_DATA) the middleware took from it.
    pub samples_in: u64,
    /// Their payload bytes.
    pub bytes_in: u64,
    /// Samples delivered to it (DATA for its read tasks).
    pub samples_out: u64,
    /// Their bytes as the middleware handed them.
    pub bytes_out: u64,
    /// Its best-effort samples the middleware could not take, dropped.
    pub samples_dropped_in: u64,
    /// Its datagrams dropped whole (out of order, too many streams, from a foreign address).
    pub datagrams_dropped: u64,
    /// Liveness probes sent to it while it was silent.
    pub liveness_probes: u64,
    /// Messages it sent on its streams (counted by each stream; here those of streams since reset).
    pub messages_in: u64,
    /// Messages the agent sent it on its streams, retransmissions apart (same).
    pub messages_out: u64,
    /// Messages the agent sent it again (same).
    pub retransmissions: u64,
}

impl ClientCounters {
    /// Adds `other`'s counts to these.
    pub fn absorb(&mut self, other: &ClientCounters) {
        let pairs = [
            (&mut self.samples_in, other.samples_in),
            (&mut self.bytes_in, other.bytes_in),
            (&mut self.samples_out, other.samples_out),
            (&mut self.bytes_out, other.bytes_out),
            (&mut self.samples_dropped_in, other.samples_dropped_in),
            (&mut self.datagrams_dropped, other.datagrams_dropped),
            (&mut self.liveness_probes, other.liveness_probes),
            (&mut self.messages_in, other.messages_in),
            (&mut self.messages_out, other.messages_out),
            (&mut self.retransmissions, other.retransmissions),
        ];
        for (n, by) in pairs {
            *n = n.saturating_add(by);
        }
    }
}

/// A client's totals as its connection keeps them: the per-sample ones inline, the rare ones (drops, probes,
/// and the counts its streams left when they were reset) in a box allocated on first use, so each of 10,000
/// idle clients carries 40 bytes of counters instead of 80. [`ClientTotals::counters`] gives the model's view.
#[derive(Debug, Default, Clone, PartialEq, Eq)]
pub struct ClientTotals {
    /// Samples (WRITE_DATA) the middleware took from it.
    pub samples_in: u64,
    /// Their payload bytes.
    pub bytes_in: u64,
    /// Samples delivered to it.
    pub samples_out: u64,
    /// Their bytes.
    pub bytes_out: u64,
    /// The rare counters; its four per-sample fields stay zero (the inline ones above count).
    rare: Option<Box<ClientCounters>>,
}

impl ClientTotals {
    /// The rare counters, allocated on first use (once per client: bounded).
    pub fn rare(&mut self) -> &mut ClientCounters {
        self.rare.get_or_insert_with(Box::default)
    }

    /// The totals as the model shows them.
    pub fn counters(&self) -> ClientCounters {
        let rare = self.rare.as_deref().copied().unwrap_or_default();
        ClientCounters {
            samples_in: self.samples_in,
            bytes_in: self.bytes_in,
            samples_out: self.samples_out,
            bytes_out: self.bytes_out,
            ..rare
        }
    }
}

impl From<ClientCounters> for ClientTotals {
    fn from(c: ClientCounters) -> Self {
        let rare = ClientCounters { samples_in: 0, bytes_in: 0, samples_out: 0, bytes_out: 0, ..c };
        Self {
            samples_in: c.samples_in,
            bytes_in: c.bytes_in,
            samples_out: c.samples_out,
            bytes_out: c.bytes_out,
            rare: (rare != ClientCounters::default()).then(|| Box::new(rare)),
        }
    }
}

/// Adds one to a saturating counter.
pub(crate) fn bump(n: &mut u64) {
    *n = n.saturating_add(1);
}

/// Adds `by` to a saturating counter.
pub(crate) fn add(n: &mut u64, by: usize) {
    *n = n.saturating_add(u64::try_from(by).unwrap_or(u64::MAX));
}

#[cfg(test)]
mod totals_tests {
    use super::*;

    #[test]
    fn totals_box_only_rare_counts_and_keep_every_count() {
        let idle = ClientTotals::from(ClientCounters { samples_in: 3, bytes_out: 9, ..ClientCounters::default() });
        assert!(idle.rare.is_none(), "per-sample counts alone allocate nothing");
        let mut t = idle.clone();
        bump(&mut t.rare().liveness_probes);
        let all = ClientCounters { liveness_probes: 1, ..idle.counters() };
        assert_eq!(t.counters(), all);
        assert_eq!(ClientTotals::from(all), t, "a round trip keeps the rare counts");
    }
}
