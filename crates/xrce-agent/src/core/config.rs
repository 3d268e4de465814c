//! Tunables of the agent core. Every queue, table and buffer the core keeps is bounded by one of these; the
//! defaults follow eProsima's agent where it has a value (spec §9.7) and are generous but finite elsewhere.

use std::time::Duration;

/// eProsima's reliable window: 16 messages in flight per stream, 16 stored out of order per input stream.
pub const DEFAULT_RELIABLE_WINDOW: u16 = 16;
/// Default client limit: 65,536 sessions. eProsima's agent has none; an idle session (participant, topic,
/// publisher, datawriter) costs about 2 KiB on CED, so a full table stays near 128 MiB, while every stream,
/// buffer and table of a client is bounded by the other limits below.
pub const DEFAULT_MAX_CLIENTS: usize = 65_536;
/// eProsima's `UAGENT_CONFIG_HEARTBEAT_PERIOD`.
pub const DEFAULT_HEARTBEAT_PERIOD: Duration = Duration::from_millis(200);
/// eProsima's `CLIENT_DEAD_TIME`.
pub const DEFAULT_CLIENT_DEAD_TIME: Duration = Duration::from_secs(30);
/// Unanswered liveliness probes (clients with `uxr_hl`) before the client is removed, as eProsima.
pub const DEFAULT_MAX_LIVELINESS_PROBES: u8 = 3;
/// Silence after which a client without `uxr_hl` is removed with its entities (ours; eProsima keeps such a
/// client forever). Probes start at half of it, so a client is only removed when it neither sent anything
/// nor ran its session for 30 s (eProsima's [`DEFAULT_CLIENT_DEAD_TIME`]), then ignored four probes; an
/// idle client that still runs its session (a micro-ROS executor spinning) answers them. See
/// [`liveness`](super::liveness).
pub const DEFAULT_CLIENT_TIMEOUT: Duration = Duration::from_secs(60);
/// How long a client gets to answer the probe sent when a new session arrives from its endpoint (a reboot
/// with a new key) or, with authentication on, when its key is claimed from another address.
pub const DEFAULT_SUSPECT_GRACE: Duration = Duration::from_secs(1);

/// Limits and timings of an [`AgentCore`](super::AgentCore).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CoreConfig {
    /// Most clients registered at once; a CREATE_CLIENT beyond it evicts the longest-dead client or is
    /// refused with `STATUS_ERR_RESOURCES`. Default [`DEFAULT_MAX_CLIENTS`].
    pub max_clients: usize,
    /// Most objects (all kinds) one client may own.
    pub max_objects_per_client: usize,
    /// Most active read tasks per client.
    pub max_read_tasks_per_client: usize,
    /// Most streams (each direction counted apart) a client may open.
    pub max_streams_per_client: usize,
    /// Reliable window (messages in flight out, stored out of order in); at most 16 fits the 16-bit
    /// ACKNACK bitmap.
    pub reliable_window: u16,
    /// Messages queued behind a full reliable output window (STATUS, DATA fragments), per stream.
    pub max_pending_per_stream: usize,
    /// Largest message rebuilt from FRAGMENTs.
    pub max_reassembly_size: usize,
    /// Bytes a client may keep in out-of-order input buffers and reassembly buffers together.
    pub max_buffered_bytes_per_client: usize,
    /// Stream messages one client may have waiting for the shell (its outbox); beyond it the oldest are
    /// dropped (reliable ones are retransmitted later). Control messages are bounded apart
    /// (256 per client) and never dropped for stream messages; also bounds replies outside a session.
    pub max_transmit_queue: usize,
    /// Heartbeat period of reliable output streams (and liveliness probes).
    pub heartbeat_period: Duration,
    /// Silence after which a client counts as dead (overridden per client by `uxr_hl`).
    pub client_dead_time: Duration,
    /// Probes sent to a dead `uxr_hl` client before it is removed.
    pub max_liveliness_probes: u8,
    /// Remove a client (without `uxr_hl`) silent this long, probing it from half of it on; `None` keeps
    /// silent clients, as eProsima does, until the client table is full. Default
    /// [`DEFAULT_CLIENT_TIMEOUT`]. A client with `uxr_hl` is removed after that time and
    /// [`Self::max_liveliness_probes`] unanswered probes instead.
    pub remove_silent_clients_after: Option<Duration>,
    /// Time a client has to answer the probe sent when a new session comes from its endpoint with another
    /// key (or claims its key from elsewhere, with authentication on); silent, it is removed.
    pub suspect_grace: Duration,
    /// Who may create a session (off by default: everybody, as eProsima).
    pub auth: super::auth::AuthPolicy,
    /// Largest MTU the agent honours from CREATE_CLIENT; also the size used when the client says 0.
    pub max_mtu: u16,
    /// Smallest usable MTU: below it the agent could not even send a FRAGMENT (CREATE_CLIENT is refused).
    pub min_mtu: u16,
    /// Port reported in INFO locators (0: none).
    pub info_port: u16,
    /// Pack several DATA submessages per message for every client (default false: only for clients that
    /// set the `xrce_rs_pack` property; eProsima's C client cannot read packed messages).
    pub pack_data: bool,
}

impl Default for CoreConfig {
    fn default() -> Self {
        Self {
            max_clients: DEFAULT_MAX_CLIENTS,
            max_objects_per_client: 1024,
            max_read_tasks_per_client: 256,
            max_streams_per_client: 64,
            reliable_window: DEFAULT_RELIABLE_WINDOW,
            max_pending_per_stream: 4096,
            max_reassembly_size: 1 << 20,
            max_buffered_bytes_per_client: 4 << 20,
            max_transmit_queue: 65_536,
            heartbeat_period: DEFAULT_HEARTBEAT_PERIOD,
            client_dead_time: DEFAULT_CLIENT_DEAD_TIME,
            max_liveliness_probes: DEFAULT_MAX_LIVELINESS_PROBES,
            remove_silent_clients_after: Some(DEFAULT_CLIENT_TIMEOUT),
            suspect_grace: DEFAULT_SUSPECT_GRACE,
            auth: super::auth::AuthPolicy::default(),
            max_mtu: 65_535,
            min_mtu: 24,
            info_port: 0,
            pack_data: false,
        }
    }
}
