//! The ROS 2 graph of the `dds` middleware: XRCE participants appear as ROS 2 nodes.
//!
//! ROS 2 does not learn node names from DDS discovery: every rmw built on `rmw_dds_common` publishes, per
//! DDS participant, a `ParticipantEntitiesInfo` sample on the topic `ros_discovery_info` listing the nodes
//! living in that participant with the GIDs of their readers and writers. `ros2 node list`,
//! `get_node_names_and_namespaces()` and the `*_by_node` queries read nothing else. micro-ROS' own agent
//! publishes these samples for its clients; eProsima's plain agent does not, so micro-ROS nodes behind it
//! are invisible. This module does it for ours:
//!
//! * One node per *named* XRCE participant (binary: the `qos_profile_reference` string, which is where
//!   micro-ROS puts its node name; XML: `<rtps><name>`; references: the profile's participant name). The
//!   name is split as micro-ROS' agent splits it ([`node_name`]).
//! * Its readers' and writers' GIDs are those of the DDS endpoints created for the participant's
//!   datareaders, datawriters, requesters and repliers (both endpoints of the last two).
//! * Several XRCE participants share one DDS participant (see `xrce_dds::ParticipantKey`): one sample per
//!   DDS participant lists all their nodes, from one writer (reliable, transient-local, keep-last 1, as rmw
//!   creates it) on that participant.
//! * Changes are coalesced for [`COALESCE`] by a thread of its own, then published: the core thread never
//!   encodes a sample with thousands of nodes nor blocks on DDS for the graph. A deleted node is gone from
//!   the next sample, well within a second.
//! * GIDs are 16 bytes (the GUID) from Iron on and 24 bytes (the GUID then 8 zero bytes) in Humble:
//!   [`RosGraphMode`].

use std::collections::{BTreeMap, HashMap, HashSet};
use std::sync::{Arc, Condvar, Mutex, MutexGuard};
use std::thread::JoinHandle;
use std::time::Duration;

use xrce_dds::{Durability, EndpointQos, History, Participant, RawWriter, Reliability};

use super::EntityRef;

/// Topic on which rmw implementations publish their participants' nodes.
pub const DISCOVERY_TOPIC: &str = "ros_discovery_info";

/// DDS type name of [`DISCOVERY_TOPIC`] (rmw_dds_common's message, as rosidl names it for DDS).
pub const DISCOVERY_TYPE: &str = "rmw_dds_common::msg::dds_::ParticipantEntitiesInfo_";

/// Bound of `node_namespace` and `node_name` in rmw_dds_common's `NodeEntitiesInfo` (`string<=256`). A
/// longer string would make peers reject the whole sample, so such a node is left out (with a warning).
pub const MAX_NAME_LEN: usize = 256;

/// How long changes are gathered before a sample is published: a client creating its participant and
/// ten endpoints costs one sample, not eleven, and a deleted node still disappears at once for a human.
pub const COALESCE: Duration = Duration::from_millis(50);

/// How long the last sample of a DDS participant that no longer has nodes may take to be acknowledged
/// before its writer (and with it possibly the DDS participant) is dropped.
pub const RETIRE_ACK_WAIT: Duration = Duration::from_millis(300);

/// Whether and how the ROS 2 graph is published.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum RosGraphMode {
    /// Nothing is published on `ros_discovery_info`.
    Off,
    /// 16-byte GIDs: ROS 2 Iron, Jazzy and later (the default).
    #[default]
    Gid16,
    /// 24-byte GIDs: ROS 2 Humble (and earlier).
    Gid24,
}

impl RosGraphMode {
    /// Bytes of a GID on the wire, if the graph is on.
    pub const fn gid_len(self) -> Option<usize> {
        match self {
            Self::Off => None,
            Self::Gid16 => Some(16),
            Self::Gid24 => Some(24),
        }
    }
}

/// A node's namespace and name.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub struct NodeName {
    /// Namespace, starting with `/`.
    pub namespace: String,
    /// Name (micro-ROS' rule lets it contain `/` when the participant name has three segments or more).
    pub name: String,
}

/// The node an XRCE participant named `participant_name` is, by micro-ROS' agent's rule: one leading `/`
/// is dropped; with two segments or more the first is the namespace (`/` prepended) and the rest, joined
/// by `/`, the name; otherwise the whole is the name in namespace `/`. `None` for names that make no node:
/// empty, `/` (micro-ROS' agent skips its own root participant of that name) or longer than
/// [`MAX_NAME_LEN`].
pub fn node_name(participant_name: &str) -> Option<NodeName> {
    let s = participant_name.strip_prefix('/').unwrap_or(participant_name);
    // Segments as C++'s getline splits them: a trailing separator adds no empty last segment.
    let mut parts: Vec<&str> = s.split('/').collect();
    if parts.len() > 1 && parts.last() == Some(&"") {
        parts.pop();
    }
    let node = match parts.split_first() {
        Some((first, rest)) if !rest.is_empty() => NodeName { namespace: format!("/{first}"), name: rest.join("/") },
        _ => NodeName { namespace: "/".to_owned(), name: s.to_owned() },
    };
    if node.name.is_empty() || node.name.len() > MAX_NAME_LEN || node.namespace.len() > MAX_NAME_LEN {
        return None;
    }
    Some(node)
}

/// A DDS GUID: 12-byte prefix then 4-byte entity id.
pub type Gid = [u8; 16];

/// What one node lists: readers and writers.
#[derive(Debug, Clone, Copy)]
pub struct NodeEntities<'a> {
    /// Namespace and name.
    pub name: &'a NodeName,
    /// Reader GIDs.
    pub readers: &'a [Gid],
    /// Writer GIDs.
    pub writers: &'a [Gid],
}

/// XCDR1 little-endian writer for the body (alignment counted from the body start, after the 4-byte
/// encapsulation header the bridge adds).
struct Cdr(Vec<u8>);

impl Cdr {
    fn u32(&mut self, v: u32) {
        while !self.0.len().is_multiple_of(4) {
            self.0.push(0);
        }
        self.0.extend_from_slice(&v.to_le_bytes());
    }

    fn len(&mut self, n: usize) {
        self.u32(u32::try_from(n).unwrap_or(u32::MAX));
    }

    fn string(&mut self, s: &str) {
        self.len(s.len() + 1);
        self.0.extend_from_slice(s.as_bytes());
        self.0.push(0);
    }

    fn gid(&mut self, g: &Gid, gid_len: usize) {
        self.0.extend_from_slice(g);
        self.0.resize(self.0.len() + gid_len.saturating_sub(g.len()), 0);
    }

    fn gids(&mut self, gids: &[Gid], gid_len: usize) {
        self.len(gids.len());
        for g in gids {
            self.gid(g, gid_len);
        }
    }
}

/// CDR body of `ParticipantEntitiesInfo { Gid gid; NodeEntitiesInfo[] node_entities_info_seq; }` with
/// `NodeEntitiesInfo { string node_namespace; string node_name; Gid[] reader_gid_seq; Gid[] writer_gid_seq; }`
/// and `Gid { char data[gid_len]; }` (16 or 24, see [`RosGraphMode::gid_len`]).
pub fn encode_participant_info(participant: &Gid, nodes: &[NodeEntities<'_>], gid_len: usize) -> Vec<u8> {
    let mut w = Cdr(Vec::with_capacity(24 + nodes.len() * 64));
    w.gid(participant, gid_len);
    w.len(nodes.len());
    for n in nodes {
        w.string(&n.name.namespace);
        w.string(&n.name.name);
        w.gids(n.readers, gid_len);
        w.gids(n.writers, gid_len);
    }
    w.0
}

/// The DDS endpoints of one XRCE entity as the graph lists them.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct EndpointGid {
    entity: EntityRef,
    gid: Gid,
    writer: bool,
}

/// An XRCE participant that is a node. Small on purpose (thousands of clients): the name is shared by
/// every participant with the same one.
struct Node {
    name: Arc<NodeName>,
    endpoints: Vec<EndpointGid>,
}

/// The nodes of one DDS participant and its `ros_discovery_info` writer.
struct DdsEntry {
    participant: Participant,
    writer: Option<Arc<RawWriter>>,
    nodes: BTreeMap<EntityRef, Node>,
}

#[derive(Default)]
struct State {
    entries: HashMap<Gid, DdsEntry>,
    dirty: HashSet<Gid>,
    /// Node names in use, shared by the nodes that carry them.
    names: HashMap<String, Arc<NodeName>>,
    worker: Option<JoinHandle<()>>,
    shutdown: bool,
}

struct Shared {
    state: Mutex<State>,
    cond: Condvar,
    gid_len: usize,
}

fn lock(m: &Mutex<State>) -> MutexGuard<'_, State> {
    // Poisoning only means a panic elsewhere; every update below leaves the maps consistent.
    m.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
}

/// The graph publisher of a `dds` middleware. Calls are cheap map updates; the publishing happens on a
/// thread started with the first node.
pub struct RosGraph {
    shared: Arc<Shared>,
}

impl std::fmt::Debug for RosGraph {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("RosGraph").field("gid_len", &self.shared.gid_len).finish_non_exhaustive()
    }
}

impl RosGraph {
    /// A graph publisher, or `None` for [`RosGraphMode::Off`].
    pub fn new(mode: RosGraphMode) -> Option<Self> {
        let gid_len = mode.gid_len()?;
        Some(Self { shared: Arc::new(Shared { state: Mutex::new(State::default()), cond: Condvar::new(), gid_len }) })
    }

    /// XRCE participant `xrce`, named `name`, lives in `participant`: it becomes a node (if its name makes
    /// one, see [`node_name`]).
    pub fn add_node(&self, participant: &Participant, xrce: EntityRef, name: &str) {
        let Some(node) = node_name(name) else {
            if !name.is_empty() && name != "/" {
                tracing::warn!(?xrce, name, "participant name makes no ROS 2 node (longer than 256?)");
            }
            return;
        };
        let mut st = lock(&self.shared.state);
        let name = Arc::clone(st.names.entry(name_key(&node)).or_insert_with(|| Arc::new(node)));
        let guid = participant.guid();
        let entry = st.entries.entry(guid).or_insert_with(|| DdsEntry {
            participant: participant.clone(),
            writer: None,
            nodes: BTreeMap::new(),
        });
        entry.nodes.insert(xrce, Node { name, endpoints: Vec::new() });
        self.changed(st, guid);
    }

    /// XRCE participant `xrce` of DDS participant `guid` is gone.
    pub fn remove_node(&self, guid: Gid, xrce: EntityRef) {
        let mut st = lock(&self.shared.state);
        let removed = st.entries.get_mut(&guid).and_then(|e| e.nodes.remove(&xrce));
        if let Some(node) = removed {
            let key = name_key(&node.name);
            drop(node);
            // The last node with that name lets the shared name go.
            if st.names.get(&key).is_some_and(|n| Arc::strong_count(n) == 1) {
                st.names.remove(&key);
            }
            self.changed(st, guid);
        }
    }

    /// `entity` (an endpoint of XRCE participant `xrce`, in DDS participant `guid`) has these DDS readers
    /// and writers. Ignored when `xrce` is not a node.
    pub fn add_endpoint(&self, guid: Gid, xrce: EntityRef, entity: EntityRef, readers: &[Gid], writers: &[Gid]) {
        let mut st = lock(&self.shared.state);
        let Some(node) = st.entries.get_mut(&guid).and_then(|e| e.nodes.get_mut(&xrce)) else { return };
        node.endpoints.retain(|e| e.entity != entity);
        let tagged = |writer: bool| move |gid: &Gid| EndpointGid { entity, gid: *gid, writer };
        node.endpoints.extend(readers.iter().map(tagged(false)).chain(writers.iter().map(tagged(true))));
        self.changed(st, guid);
    }

    /// Endpoint `entity` of XRCE participant `xrce` (DDS participant `guid`) is gone.
    pub fn remove_endpoint(&self, guid: Gid, xrce: EntityRef, entity: EntityRef) {
        let mut st = lock(&self.shared.state);
        let Some(node) = st.entries.get_mut(&guid).and_then(|e| e.nodes.get_mut(&xrce)) else { return };
        let before = node.endpoints.len();
        node.endpoints.retain(|e| e.entity != entity);
        if node.endpoints.len() != before {
            self.changed(st, guid);
        }
    }

    /// Marks `guid` for publication and makes sure the publishing thread runs.
    fn changed(&self, mut st: MutexGuard<'_, State>, guid: Gid) {
        st.dirty.insert(guid);
        if st.worker.is_none() {
            let shared = Arc::clone(&self.shared);
            match std::thread::Builder::new().name("xrce-ros-graph".into()).spawn(move || run(&shared)) {
                Ok(h) => st.worker = Some(h),
                Err(e) => tracing::error!("cannot start the ROS 2 graph thread: {e}"),
            }
        }
        drop(st);
        self.shared.cond.notify_one();
    }
}

impl Drop for RosGraph {
    fn drop(&mut self) {
        let worker = {
            let mut st = lock(&self.shared.state);
            st.shutdown = true;
            st.worker.take()
        };
        self.shared.cond.notify_one();
        if let Some(h) = worker {
            if h.join().is_err() {
                tracing::error!("the ROS 2 graph thread panicked");
            }
        }
    }
}

fn name_key(n: &NodeName) -> String {
    if n.namespace == "/" {
        n.name.clone()
    } else {
        format!("{}/{}", n.namespace, n.name)
    }
}

/// One publication the thread has to make, gathered under the lock and carried out without it.
struct Job {
    guid: Gid,
    participant: Participant,
    writer: Option<Arc<RawWriter>>,
    body: Vec<u8>,
    /// No node left: after this (empty) sample the writer goes.
    retire: bool,
}

fn gather(st: &mut State, gid_len: usize) -> Vec<Job> {
    let dirty: Vec<Gid> = st.dirty.drain().collect();
    let mut jobs = Vec::with_capacity(dirty.len());
    for guid in dirty {
        let Some(entry) = st.entries.get(&guid) else { continue };
        let mut lists: Vec<(Vec<Gid>, Vec<Gid>)> = Vec::with_capacity(entry.nodes.len());
        for node in entry.nodes.values() {
            let mut readers: Vec<Gid> = node.endpoints.iter().filter(|e| !e.writer).map(|e| e.gid).collect();
            let mut writers: Vec<Gid> = node.endpoints.iter().filter(|e| e.writer).map(|e| e.gid).collect();
            // XRCE datawriters of one participant may share a DDS writer: list it once.
            readers.sort_unstable();
            readers.dedup();
            writers.sort_unstable();
            writers.dedup();
            lists.push((readers, writers));
        }
        let nodes: Vec<NodeEntities<'_>> = entry
            .nodes
            .values()
            .zip(&lists)
            .map(|(n, (r, w))| NodeEntities { name: &n.name, readers: r, writers: w })
            .collect();
        jobs.push(Job {
            guid,
            participant: entry.participant.clone(),
            writer: entry.writer.clone(),
            body: encode_participant_info(&guid, &nodes, gid_len),
            retire: entry.nodes.is_empty(),
        });
    }
    jobs
}

fn discovery_writer(p: &Participant) -> Result<RawWriter, xrce_dds::DdsError> {
    let topic = p.topic(DISCOVERY_TOPIC, DISCOVERY_TYPE, false)?;
    // What rmw gives its own ros_discovery_info writer, so late-joining ROS nodes get the last sample.
    let qos = EndpointQos {
        reliability: Reliability::Reliable,
        durability: Durability::TransientLocal,
        history: History::KeepLast(1),
        ..EndpointQos::default()
    };
    p.create_writer(&topic, &qos)
}

fn publish(job: &Job) -> Option<Arc<RawWriter>> {
    let writer = match &job.writer {
        Some(w) => Arc::clone(w),
        None => match discovery_writer(&job.participant) {
            Ok(w) => Arc::new(w),
            Err(e) => {
                tracing::warn!("cannot create the {DISCOVERY_TOPIC} writer: {e}");
                return None;
            }
        },
    };
    if let Err(e) = writer.write(&job.body) {
        tracing::warn!("{DISCOVERY_TOPIC} sample not published: {e}");
    }
    Some(writer)
}

fn run(shared: &Shared) {
    loop {
        {
            let mut st = lock(&shared.state);
            while st.dirty.is_empty() && !st.shutdown {
                st = shared.cond.wait(st).unwrap_or_else(std::sync::PoisonError::into_inner);
            }
            if st.shutdown {
                return;
            }
        }
        std::thread::sleep(COALESCE);
        let jobs = gather(&mut lock(&shared.state), shared.gid_len);
        for job in jobs {
            let writer = publish(&job);
            if job.retire {
                if let Some(w) = &writer {
                    // Best effort: the DDS participant may go right after, taking its nodes with it anyway.
                    let _acked = w.wait_for_acknowledgments(RETIRE_ACK_WAIT);
                }
            }
            let gone = {
                let mut st = lock(&shared.state);
                let pending = st.dirty.contains(&job.guid);
                match st.entries.get_mut(&job.guid) {
                    Some(e) if job.retire && e.nodes.is_empty() && !pending => st.entries.remove(&job.guid),
                    // Nodes came back meanwhile, or another sample follows: keep the writer.
                    Some(e) => {
                        e.writer = writer;
                        None
                    }
                    None => None,
                }
            };
            // Dropped outside the lock: the last handle on a DDS participant stops its threads.
            drop(gone);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn nn(ns: &str, name: &str) -> Option<NodeName> {
        Some(NodeName { namespace: ns.to_owned(), name: name.to_owned() })
    }

    #[test]
    fn node_names_follow_micro_ros() {
        assert_eq!(node_name("talker"), nn("/", "talker"));
        assert_eq!(node_name("/talker"), nn("/", "talker"));
        assert_eq!(node_name("/ns/talker"), nn("/ns", "talker"));
        assert_eq!(node_name("ns/talker"), nn("/ns", "talker"));
        assert_eq!(node_name("/a/b/c"), nn("/a", "b/c"));
        assert_eq!(node_name("px4_micro_xrce_dds"), nn("/", "px4_micro_xrce_dds"));
        assert_eq!(node_name("ns/talker/"), nn("/ns", "talker"));
        assert_eq!(node_name("/"), None);
        assert_eq!(node_name(""), None);
        assert_eq!(node_name(&"x".repeat(257)), None);
        assert_eq!(node_name(&"x".repeat(256)), nn("/", &"x".repeat(256)));
    }

    fn gid(b: u8) -> Gid {
        let mut g = [b; 16];
        g[12..].copy_from_slice(&[0, 0, 1, 0xc1]);
        g
    }

    #[test]
    fn participant_info_encodes_as_rmw_dds_common() {
        let talker = NodeName { namespace: "/".into(), name: "talker".into() };
        let nodes = [NodeEntities { name: &talker, readers: &[], writers: &[gid(7)] }];
        let body = encode_participant_info(&gid(1), &nodes, 16);
        let mut expected = gid(1).to_vec();
        expected.extend_from_slice(&1u32.to_le_bytes()); // one node
        expected.extend_from_slice(&2u32.to_le_bytes()); // "/" and its NUL
        expected.extend_from_slice(b"/\0\0\0"); // padded to 4 for the next length
        expected.extend_from_slice(&7u32.to_le_bytes());
        expected.extend_from_slice(b"talker\0\0");
        expected.extend_from_slice(&0u32.to_le_bytes()); // no reader
        expected.extend_from_slice(&1u32.to_le_bytes()); // one writer
        expected.extend_from_slice(&gid(7));
        assert_eq!(body, expected);
    }

    #[test]
    fn humble_gids_are_24_bytes_zero_padded() {
        let ns = NodeName { namespace: "/ns".into(), name: "n".into() };
        let nodes = [NodeEntities { name: &ns, readers: &[gid(2)], writers: &[] }];
        let body = encode_participant_info(&gid(1), &nodes, 24);
        assert_eq!(&body[..16], &gid(1));
        assert_eq!(&body[16..24], &[0; 8]);
        assert_eq!(&body[24..28], &1u32.to_le_bytes());
        // "/ns" (len 4) at 28, "n" (len 2) at 36, padded to 44: one reader GID of 24 bytes.
        assert_eq!(&body[28..32], &4u32.to_le_bytes());
        assert_eq!(&body[32..36], b"/ns\0");
        assert_eq!(&body[36..40], &2u32.to_le_bytes());
        assert_eq!(&body[40..44], b"n\0\0\0");
        assert_eq!(&body[44..48], &1u32.to_le_bytes());
        assert_eq!(&body[48..64], &gid(2));
        assert_eq!(&body[64..72], &[0; 8]);
        assert_eq!(&body[72..76], &0u32.to_le_bytes());
        assert_eq!(body.len(), 76);
    }

    #[test]
    fn empty_participant_lists_no_node() {
        let body = encode_participant_info(&gid(3), &[], 16);
        assert_eq!(body.len(), 20);
        assert_eq!(&body[16..], &[0; 4]);
        assert_eq!(RosGraphMode::default().gid_len(), Some(16));
        assert!(RosGraph::new(RosGraphMode::Off).is_none());
    }
}
