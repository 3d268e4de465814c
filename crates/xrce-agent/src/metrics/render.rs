//! The Prometheus text format of an [`AgentSnapshot`], encoded by `prometheus-client` through a collector
//! that reads the snapshot (no metric objects kept between scrapes: the snapshot is the state).

use std::fmt;
use std::sync::Arc;

use prometheus_client::collector::Collector;
use prometheus_client::encoding::{DescriptorEncoder, EncodeLabelSet, EncodeMetric};
use prometheus_client::metrics::counter::ConstCounter;
use prometheus_client::metrics::gauge::ConstGauge;
use prometheus_client::metrics::MetricType;
use prometheus_client::registry::Registry;

use crate::core::{AgentSnapshot, ClientCounters, ClientSnapshot, DropReason, RemoveReason};

/// Clients with their own series, at most (defined with the snapshot, which carries that many).
pub use crate::core::MAX_CLIENT_SERIES;

/// The snapshot as Prometheus text (format 0.0.4).
pub fn render(snapshot: Arc<AgentSnapshot>) -> String {
    let mut registry = Registry::default();
    registry.register_collector(Box::new(SnapshotCollector(snapshot)));
    let mut text = String::new();
    // Writing into a String does not fail; an encoder error leaves what was written.
    if let Err(e) = prometheus_client::encoding::prometheus_text::encode(&mut text, &registry) {
        tracing::warn!("metrics: encoding failed: {e}");
    }
    text
}

#[derive(Debug)]
struct SnapshotCollector(Arc<AgentSnapshot>);

/// A per-client counter: its name (without `_total`), help and value.
type ClientSeries = (&'static str, &'static str, fn(&ClientCounters) -> u64);

/// Per-client counters (`xrce_agent_client_NAME_total`), and the agent totals of the same name
/// (`xrce_agent_NAME_total`) but for those whose name starts with `client_` (the agent's own counter of that
/// name counts more).
const CLIENT_COUNTERS: [ClientSeries; 10] = [
    ("samples_received", "Samples (WRITE_DATA) the middleware took from clients", |c| c.samples_in),
    ("samples_sent", "Samples delivered to clients' read tasks", |c| c.samples_out),
    ("sample_bytes_received", "Payload bytes of the samples received", |c| c.bytes_in),
    ("sample_bytes_sent", "Bytes of the samples delivered", |c| c.bytes_out),
    ("retransmissions", "Reliable messages the agent sent again", |c| c.retransmissions),
    ("samples_dropped", "Best-effort samples the middleware could not take", |c| c.samples_dropped_in),
    ("client_datagrams_dropped", "Clients' datagrams dropped whole", |c| c.datagrams_dropped),
    ("liveness_probes", "Liveness probes sent to silent clients", |c| c.liveness_probes),
    ("stream_messages_received", "Messages received on clients' streams", |c| c.messages_in),
    ("stream_messages_sent", "New messages sent on clients' streams", |c| c.messages_out),
];

fn counter(e: &mut DescriptorEncoder, name: &str, help: &str, value: u64) -> fmt::Result {
    let c = ConstCounter::new(value);
    c.encode(e.encode_descriptor(name, help, None, c.metric_type())?)
}

fn gauge(e: &mut DescriptorEncoder, name: &str, help: &str, value: i64) -> fmt::Result {
    let g = ConstGauge::new(value);
    g.encode(e.encode_descriptor(name, help, None, g.metric_type())?)
}

/// One family with a series per `(labels, value)`.
fn family<L: EncodeLabelSet>(
    e: &mut DescriptorEncoder,
    name: &str,
    help: &str,
    kind: MetricType,
    series: impl Iterator<Item = (L, u64)>,
) -> fmt::Result {
    let mut f = e.encode_descriptor(name, help, None, kind)?;
    for (labels, value) in series {
        let m = f.encode_family(&labels)?;
        match kind {
            MetricType::Counter => ConstCounter::new(value).encode(m)?,
            _ => ConstGauge::new(i64::try_from(value).unwrap_or(i64::MAX)).encode(m)?,
        }
    }
    Ok(())
}

fn clamp(v: usize) -> i64 {
    i64::try_from(v).unwrap_or(i64::MAX)
}

impl Collector for SnapshotCollector {
    fn encode(&self, mut e: DescriptorEncoder) -> fmt::Result {
        let s = &*self.0;
        let t = &s.totals;
        gauge(&mut e, "xrce_agent_clients", "Clients (sessions) the agent holds", clamp(s.keys.len()))?;
        let totals = s.client_totals();
        for (name, help, get) in CLIENT_COUNTERS.iter().filter(|(name, ..)| !name.starts_with("client_")) {
            counter(&mut e, &format!("xrce_agent_{name}"), help, get(&totals))?;
        }
        counter(&mut e, "xrce_agent_datagrams_received", "Datagrams handed to the core", t.datagrams_in)?;
        counter(&mut e, "xrce_agent_messages_sent", "Messages queued for sending", t.messages_out)?;
        counter(&mut e, "xrce_agent_messages_dropped", "Outgoing messages dropped", t.messages_dropped_out)?;
        family(
            &mut e,
            "xrce_agent_datagrams_dropped",
            "Datagrams dropped whole, by reason",
            MetricType::Counter,
            DropReason::ALL.iter().map(|r| ([("reason", r.name())], t.dropped.get(*r))),
        )?;
        counter(&mut e, "xrce_agent_decode_errors", "Submessages that failed to decode", t.decode_errors)?;
        counter(&mut e, "xrce_agent_auth_refusals", "CREATE_CLIENTs refused by authentication", t.auth_refusals)?;
        counter(&mut e, "xrce_agent_tail_probes", "HEARTBEATs sent ahead of the period", t.tail_probes)?;
        counter(&mut e, "xrce_agent_clients_created", "Clients created", t.clients_created)?;
        family(
            &mut e,
            "xrce_agent_clients_removed",
            "Clients removed, by reason",
            MetricType::Counter,
            RemoveReason::ALL.iter().map(|r| ([("reason", r.name())], t.removed(*r))),
        )?;
        let m = &s.middleware;
        let mw = [
            (
                "writers_without_credit",
                "Writers that may not write now (reliable readers behind, or at their first-contact gate)",
                m.writers_without_credit,
            ),
            ("samples_at_gate", "Samples held at DDS writers' first-contact gates", m.samples_at_gate),
            ("participants", "Participants in the middleware", m.participants),
            ("topics", "Topics in the middleware", m.topics),
        ];
        for (name, help, v) in mw {
            gauge(&mut e, &format!("xrce_agent_middleware_{name}"), help, i64::try_from(v).unwrap_or(i64::MAX))?;
        }
        self.encode_clients(&mut e)
    }
}

/// A client's labels: key (8 hex digits) and transport.
type ClientLabels<'a> = [(&'static str, &'a str); 2];

impl SnapshotCollector {
    fn encode_clients(&self, e: &mut DescriptorEncoder) -> fmt::Result {
        let s = &*self.0;
        let mut shown: Vec<&ClientSnapshot> = s.clients.iter().collect();
        shown.sort_unstable_by_key(|c| c.key.to_u32());
        shown.truncate(MAX_CLIENT_SERIES);
        gauge(
            e,
            "xrce_agent_clients_not_shown",
            "Clients without their own series (past the cap of per-client series)",
            clamp(s.keys.len().saturating_sub(shown.len())),
        )?;
        let keys: Vec<String> = shown.iter().map(|c| format!("{:08x}", c.key.to_u32())).collect();
        let labelled = || keys.iter().zip(&shown).map(|(k, c)| ([("key", k.as_str()), ("transport", c.transport)], *c));
        let per = |e: &mut DescriptorEncoder, name: &str, help: &str, kind, get: &dyn Fn(&ClientSnapshot) -> u64| {
            family(e, name, help, kind, labelled().map(|(l, c): (ClientLabels<'_>, _)| (l, get(c))))
        };
        {
            let mut f = e.encode_descriptor(
                "xrce_agent_client_info",
                "A client's session: its node (named participant), peer as the logs print it, session id and MTU (value 1)",
                None,
                MetricType::Gauge,
            )?;
            for (labels, c) in labelled() {
                let session = format!("{:#04x}", c.session_id);
                let mtu = c.mtu.to_string();
                let extra = [
                    ("name", c.name.as_deref().unwrap_or("")),
                    ("peer", c.peer.as_deref().unwrap_or("")),
                    ("session", session.as_str()),
                    ("mtu", mtu.as_str()),
                ];
                ConstGauge::new(1i64).encode(f.encode_family(&(labels, extra))?)?;
            }
        }
        for (name, help, get) in CLIENT_COUNTERS {
            let name = format!("xrce_agent_client_{}", name.strip_prefix("client_").unwrap_or(name));
            per(e, &name, help, MetricType::Counter, &|c| get(&c.counters))?;
        }
        let at = s.taken_at;
        per(
            e,
            "xrce_agent_client_silent_seconds",
            "Seconds since the client was last heard from",
            MetricType::Gauge,
            &|c| at.saturating_duration_since(c.last_heard).as_secs(),
        )?;
        per(e, "xrce_agent_client_age_seconds", "Seconds since the client was created", MetricType::Gauge, &|c| {
            at.saturating_duration_since(c.created_at).as_secs()
        })?;
        per(
            e,
            "xrce_agent_client_probes_unanswered",
            "Liveness probes sent since the client went silent",
            MetricType::Gauge,
            &|c| u64::from(c.probes_unanswered),
        )?;
        per(
            e,
            "xrce_agent_client_window_used",
            "Reliable output messages the client has not acknowledged",
            MetricType::Gauge,
            &|c| c.streams.iter().filter(|st| !st.input).map(|st| st.window_used as u64).sum(),
        )?;
        let mut f = e.encode_descriptor(
            "xrce_agent_client_entities",
            "Entities a client holds, by kind",
            None,
            MetricType::Gauge,
        )?;
        for (labels, c) in labelled() {
            // Kinds it has none of are left out: most clients use 3 or 4 of the 8.
            for (kind, n) in c.entities.by_kind().into_iter().filter(|(_, n)| *n > 0) {
                ConstGauge::new(i64::from(n)).encode(f.encode_family(&(labels, [("kind", kind)]))?)?;
            }
        }
        Ok(())
    }
}
