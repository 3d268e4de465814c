//! ROS 2 `/diagnostics` from the agent's snapshot (`--ros-diagnostics`): the CDR of a
//! `diagnostic_msgs/msg/DiagnosticArray` with one `DiagnosticStatus` for the agent and one per client, and
//! the levels. The pure part, unit-tested without DDS; the DDS middleware writes it (`dds/diagnostics.rs`).
//!
//! Levels, per client: OK; WARN when it had retransmissions or drops since the last array; ERROR while it
//! is silent and probed; STALE once, in the first array after it was removed.

use foldhash::{HashMap, HashMapExt};
use std::time::{Duration, SystemTime, UNIX_EPOCH};

use xrce_proto::ClientKey;

use crate::core::{AgentSnapshot, ClientSnapshot};

/// ROS 2 topic and DDS type of the array.
pub const TOPIC: &str = "rt/diagnostics";
/// The DDS type name rmw gives `diagnostic_msgs/msg/DiagnosticArray`.
pub const TYPE: &str = "diagnostic_msgs::msg::dds_::DiagnosticArray_";

/// Clients with a status of their own, at most (defined with the snapshot, which carries that many).
pub use crate::core::MAX_CLIENT_STATUSES;

/// `diagnostic_msgs/DiagnosticStatus` levels.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Level {
    /// Healthy.
    Ok = 0,
    /// Retransmissions or drops since the last array.
    Warn = 1,
    /// Silent and probed.
    Error = 2,
    /// Removed.
    Stale = 3,
}

/// What the last array showed of a client: its retransmissions and drops then, and its status name.
#[derive(Debug, Clone)]
struct Shown {
    troubles: u64,
    name: String,
}

/// The statuses of the last array, to tell WARN (troubles grew) and STALE (gone) in the next.
#[derive(Debug, Default)]
pub struct DiagnosticsState {
    shown: HashMap<ClientKey, Shown>,
}

/// Retransmissions and drops of a client, all kinds.
fn troubles(c: &ClientSnapshot) -> u64 {
    let n = &c.counters;
    n.retransmissions.saturating_add(n.samples_dropped_in).saturating_add(n.datagrams_dropped)
}

impl DiagnosticsState {
    /// The CDR body of the array for `snapshot`, a client named after its node when it has one; `wall`: the
    /// time stamped in the header.
    pub fn encode(&mut self, snapshot: &AgentSnapshot, wall: SystemTime) -> Vec<u8> {
        let mut rated: Vec<(Level, &ClientSnapshot)> = snapshot.clients.iter().map(|c| (self.level(c), c)).collect();
        rated.sort_unstable_by(|(la, a), (lb, b)| lb.cmp(la).then(a.key.to_u32().cmp(&b.key.to_u32())));
        rated.truncate(MAX_CLIENT_STATUSES);
        let stale: Vec<(ClientKey, Shown)> = {
            let present: HashMap<ClientKey, ()> = snapshot.keys.iter().map(|k| (*k, ())).collect();
            self.shown.iter().filter(|(k, _)| !present.contains_key(*k)).map(|(k, s)| (*k, s.clone())).collect()
        };
        let mut enc = Encoder::default();
        let stamp = wall.duration_since(UNIX_EPOCH).unwrap_or(Duration::ZERO);
        enc.u32(u32::try_from(stamp.as_secs()).unwrap_or(u32::MAX));
        enc.u32(stamp.subsec_nanos());
        enc.string("");
        enc.len(1 + rated.len() + stale.len());
        self.agent_status(&mut enc, snapshot, rated.len());
        let mut shown = HashMap::with_capacity(rated.len());
        for (level, c) in &rated {
            let name = match &c.name {
                Some(node) => format!("xrce_agent: {node}"),
                None => format!("xrce_agent: client {:08x}", c.key.to_u32()),
            };
            client_status(&mut enc, snapshot, c, *level, &name);
            shown.insert(c.key, Shown { troubles: troubles(c), name });
        }
        for (key, gone) in &stale {
            let none: &[(&str, &str)] = &[];
            enc.status(Level::Stale, &gone.name, "removed", &format!("{:08x}", key.to_u32()), none);
        }
        self.shown = shown;
        enc.buf
    }

    fn level(&self, c: &ClientSnapshot) -> Level {
        if c.probes_unanswered > 0 {
            Level::Error
        } else if self.shown.get(&c.key).is_some_and(|s| troubles(c) > s.troubles) {
            Level::Warn
        } else {
            Level::Ok
        }
    }

    fn agent_status(&self, enc: &mut Encoder, s: &AgentSnapshot, shown: usize) {
        let t = &s.totals;
        let all = s.client_totals();
        let values = [
            ("clients", s.keys.len().to_string()),
            ("clients not shown", s.keys.len().saturating_sub(shown).to_string()),
            ("transport", s.transport.to_owned()),
            ("samples received", all.samples_in.to_string()),
            ("samples sent", all.samples_out.to_string()),
            ("retransmissions", all.retransmissions.to_string()),
            ("datagrams received", t.datagrams_in.to_string()),
            ("datagrams dropped", t.datagrams_dropped.to_string()),
            ("clients created", t.clients_created.to_string()),
            ("writers without credit", s.middleware.writers_without_credit.to_string()),
            ("samples at first-contact gate", s.middleware.samples_at_gate.to_string()),
        ];
        let message = format!("{} clients", s.keys.len());
        enc.status(Level::Ok, "xrce_agent: agent", &message, "xrce-agent", &values);
    }
}

fn client_status(enc: &mut Encoder, s: &AgentSnapshot, c: &ClientSnapshot, level: Level, name: &str) {
    let n = &c.counters;
    let silent = s.taken_at.saturating_duration_since(c.last_heard);
    let message = match level {
        Level::Error => format!("silent {:.1} s, {} probes unanswered", silent.as_secs_f32(), c.probes_unanswered),
        Level::Warn => "retransmissions or drops".to_owned(),
        _ => "ok".to_owned(),
    };
    let values = [
        ("key", format!("{:08x}", c.key.to_u32())),
        ("session", format!("{:#04x}", c.session_id)),
        ("peer", c.peer.clone().unwrap_or_default()),
        ("transport", c.transport.to_owned()),
        ("silent seconds", format!("{:.1}", silent.as_secs_f32())),
        ("samples received", n.samples_in.to_string()),
        ("samples sent", n.samples_out.to_string()),
        ("retransmissions", n.retransmissions.to_string()),
        ("samples dropped", n.samples_dropped_in.to_string()),
        ("datagrams dropped", n.datagrams_dropped.to_string()),
        ("liveness probes", n.liveness_probes.to_string()),
        ("entities", c.entities.by_kind().iter().map(|(_, k)| u64::from(*k)).sum::<u64>().to_string()),
    ];
    enc.status(level, name, &message, &format!("{:08x}", c.key.to_u32()), &values);
}

/// XCDR1 little endian, aligned from the start of the body (the writer adds the encapsulation header).
#[derive(Default)]
struct Encoder {
    buf: Vec<u8>,
}

impl Encoder {
    fn u32(&mut self, v: u32) {
        while !self.buf.len().is_multiple_of(4) {
            self.buf.push(0);
        }
        self.buf.extend_from_slice(&v.to_le_bytes());
    }

    fn len(&mut self, n: usize) {
        self.u32(u32::try_from(n).unwrap_or(u32::MAX));
    }

    fn string(&mut self, s: &str) {
        self.len(s.len() + 1);
        self.buf.extend_from_slice(s.as_bytes());
        self.buf.push(0);
    }

    /// One `DiagnosticStatus`: level (octet), name, message, hardware_id, values (`KeyValue[]`).
    fn status<V: AsRef<str>>(
        &mut self,
        level: Level,
        name: &str,
        message: &str,
        hardware_id: &str,
        values: &[(&str, V)],
    ) {
        self.buf.push(level as u8);
        self.string(name);
        self.string(message);
        self.string(hardware_id);
        self.len(values.len());
        for (k, v) in values {
            self.string(k);
            self.string(v.as_ref());
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::core::{ClientCounters, CoreStats, EntityCounts};
    use crate::middleware::MiddlewareStats;
    use std::time::Instant;

    /// A status read back: level, name, message, values.
    type Status = (u8, String, String, Vec<(String, String)>);

    /// Reads the array back.
    fn decode(b: &[u8]) -> Vec<Status> {
        let mut at = 0;
        let u32_at = |at: &mut usize| {
            *at = at.next_multiple_of(4);
            let v = u32::from_le_bytes(b[*at..*at + 4].try_into().unwrap());
            *at += 4;
            v as usize
        };
        let string = |at: &mut usize| {
            let n = u32_at(at);
            let s = String::from_utf8(b[*at..*at + n - 1].to_vec()).unwrap();
            *at += n;
            s
        };
        u32_at(&mut at);
        u32_at(&mut at);
        assert_eq!(string(&mut at), "", "frame_id");
        let count = u32_at(&mut at);
        (0..count)
            .map(|_| {
                let level = b[at];
                at += 1;
                let (name, message, _hw) = (string(&mut at), string(&mut at), string(&mut at));
                let values = (0..u32_at(&mut at)).map(|_| (string(&mut at), string(&mut at))).collect();
                (level, name, message, values)
            })
            .collect()
    }

    fn client(key: u32, probes: u8, retransmissions: u64) -> ClientSnapshot {
        let now = Instant::now();
        ClientSnapshot {
            key: ClientKey::from_u32(key),
            session_id: 0x81,
            name: (key == 1).then(|| "talker".to_owned()),
            peer: Some("127.0.0.1:5000".into()),
            transport: "udp4",
            mtu: 512,
            created_at: now,
            last_heard: now,
            probes_unanswered: probes,
            entities: EntityCounts::default(),
            streams: Vec::new(),
            counters: ClientCounters { retransmissions, ..ClientCounters::default() },
        }
    }

    fn snapshot(clients: Vec<ClientSnapshot>) -> AgentSnapshot {
        AgentSnapshot {
            taken_at: Instant::now(),
            transport: "udp4",
            totals: CoreStats::default(),
            middleware: MiddlewareStats::default(),
            keys: clients.iter().map(|c| c.key).collect(),
            present_clients: clients.iter().fold(ClientCounters::default(), |mut all, c| {
                all.absorb(&c.counters);
                all
            }),
            clients,
        }
    }

    #[test]
    fn one_status_per_client_with_its_level() {
        let mut state = DiagnosticsState::default();
        let first = decode(&state.encode(&snapshot(vec![client(1, 0, 0), client(2, 0, 5)]), UNIX_EPOCH));
        let levels: Vec<(u8, &str)> = first.iter().map(|(l, n, ..)| (*l, n.as_str())).collect();
        assert_eq!(
            levels,
            [(0, "xrce_agent: agent"), (0, "xrce_agent: talker"), (0, "xrce_agent: client 00000002")],
            "first sight: no baseline for WARN yet"
        );
        assert!(first[2].3.contains(&("retransmissions".into(), "5".into())));
        // Client 2 retransmitted again; client 1 is silent and probed; then client 2 is gone.
        let second = decode(&state.encode(&snapshot(vec![client(1, 2, 0), client(2, 0, 6)]), UNIX_EPOCH));
        let levels: Vec<u8> = second.iter().map(|(l, ..)| *l).collect();
        assert_eq!(levels, [0, 2, 1], "agent OK, talker ERROR (first: worst first), client 2 WARN");
        let third = decode(&state.encode(&snapshot(vec![client(1, 0, 0)]), UNIX_EPOCH));
        let levels: Vec<(u8, &str)> = third.iter().map(|(l, n, ..)| (*l, n.as_str())).collect();
        assert_eq!(levels, [(0, "xrce_agent: agent"), (0, "xrce_agent: talker"), (3, "xrce_agent: client 00000002")]);
        let fourth = decode(&state.encode(&snapshot(vec![client(1, 0, 0)]), UNIX_EPOCH));
        assert_eq!(fourth.len(), 2, "STALE once");
    }
}
