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

use xrce_dds::{Durability, EndpointQos, History, Participant, RawWriter, Reliability, ResourceLimits};
use xrce_proto::{ClientKey, ObjectId};

use super::EntityRef;

mod wire;
pub use wire::{node_name, split_node_name, Gid, InfoEncoder, NodeName, NodeNameRef, MAX_NAME_LEN};

/// Topic on which rmw implementations publish their participants' nodes.
pub const DISCOVERY_TOPIC: &str = "ros_discovery_info";

/// DDS type name of [`DISCOVERY_TOPIC`] (rmw_dds_common's message, as rosidl names it for DDS).
pub const DISCOVERY_TYPE: &str = "rmw_dds_common::msg::dds_::ParticipantEntitiesInfo_";

/// How long changes are gathered before a sample is published: a client creating its participant and
/// ten endpoints costs one sample, not eleven, and a deleted node still disappears at once for a human.
pub const COALESCE: Duration = Duration::from_millis(50);

/// Added to [`COALESCE`] per node listed: a sample is rewritten whole on every change, so with thousands
/// of nodes arriving at once (10,000 clients reconnecting) each publication is held longer and fewer,
/// larger samples are written. Every sample is a fresh allocation of ~56 bytes per node; at 50 ms for
/// 10,000 nodes the allocator kept ~460 bytes per node of them (measured in RSS), at
/// [`COALESCE_MAX`] about 4 times less.
pub const COALESCE_PER_NODE: Duration = Duration::from_micros(40);

/// Longest gathering time, so a deleted node disappears well within a second even among 100,000.
pub const COALESCE_MAX: Duration = Duration::from_millis(450);

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

/// The DDS endpoints behind one XRCE endpoint of a node.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Endpoint {
    /// The XRCE participant (of the same client) whose node lists it.
    participant: ObjectId,
    reader: Option<Gid>,
    writer: Option<Gid>,
}

/// The nodes of one DDS participant and its `ros_discovery_info` writer. Flat maps keyed by XRCE entity
/// keep a node small (thousands of clients, each a node): its participant name and one entry per
/// endpoint, nothing else; namespace and name are split when a sample is encoded.
struct DdsEntry {
    participant: Participant,
    writer: Option<Arc<RawWriter>>,
    nodes: BTreeMap<EntityRef, Box<str>>,
    endpoints: BTreeMap<EntityRef, Endpoint>,
}

impl DdsEntry {
    /// The endpoints of `client`, in object id order.
    fn client_endpoints(&self, client: ClientKey) -> impl Iterator<Item = (&EntityRef, &Endpoint)> {
        let lo = EntityRef::new(client, ObjectId::from_raw(0));
        let hi = EntityRef::new(client, ObjectId::from_raw(u16::MAX));
        self.endpoints.range(lo..=hi)
    }
}

#[derive(Default)]
struct State {
    entries: HashMap<Gid, DdsEntry>,
    dirty: HashSet<Gid>,
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
        if split_node_name(name).is_none() {
            if !name.is_empty() && name != "/" {
                tracing::warn!(?xrce, name, "participant name makes no ROS 2 node (longer than 256?)");
            }
            return;
        }
        let mut st = lock(&self.shared.state);
        let guid = participant.guid();
        let entry = st.entries.entry(guid).or_insert_with(|| DdsEntry {
            participant: participant.clone(),
            writer: None,
            nodes: BTreeMap::new(),
            endpoints: BTreeMap::new(),
        });
        entry.nodes.insert(xrce, name.into());
        self.changed(st, guid);
    }

    /// XRCE participant `xrce` of DDS participant `guid` is gone, with its endpoints.
    pub fn remove_node(&self, guid: Gid, xrce: EntityRef) {
        let mut st = lock(&self.shared.state);
        let Some(entry) = st.entries.get_mut(&guid) else { return };
        if entry.nodes.remove(&xrce).is_none() {
            return;
        }
        let gone: Vec<EntityRef> =
            entry.client_endpoints(xrce.client).filter(|(_, e)| e.participant == xrce.id).map(|(k, _)| *k).collect();
        for e in gone {
            entry.endpoints.remove(&e);
        }
        self.changed(st, guid);
    }

    /// `entity` (an endpoint of XRCE participant `xrce`, in DDS participant `guid`) has this DDS reader
    /// and writer. Ignored when `xrce` is not a node.
    pub fn add_endpoint(
        &self,
        guid: Gid,
        xrce: EntityRef,
        entity: EntityRef,
        reader: Option<Gid>,
        writer: Option<Gid>,
    ) {
        let mut st = lock(&self.shared.state);
        let Some(entry) = st.entries.get_mut(&guid) else { return };
        if !entry.nodes.contains_key(&xrce) {
            return;
        }
        entry.endpoints.insert(entity, Endpoint { participant: xrce.id, reader, writer });
        self.changed(st, guid);
    }

    /// Endpoint `entity` of DDS participant `guid` is gone.
    pub fn remove_endpoint(&self, guid: Gid, entity: EntityRef) {
        let mut st = lock(&self.shared.state);
        if st.entries.get_mut(&guid).and_then(|e| e.endpoints.remove(&entity)).is_some() {
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
    // Reused for every node: no allocation per node, however many there are.
    let (mut readers, mut writers) = (Vec::<Gid>::new(), Vec::<Gid>::new());
    for guid in dirty {
        let Some(entry) = st.entries.get(&guid) else { continue };
        let mut enc = InfoEncoder::new(&guid, gid_len, entry.nodes.len());
        for (xrce, name) in &entry.nodes {
            // Checked when the node was added.
            let Some(name) = split_node_name(name) else { continue };
            readers.clear();
            writers.clear();
            for (_, e) in entry.client_endpoints(xrce.client).filter(|(_, e)| e.participant == xrce.id) {
                readers.extend(e.reader);
                writers.extend(e.writer);
            }
            // XRCE datawriters of one participant may share a DDS writer: list it once.
            readers.sort_unstable();
            readers.dedup();
            writers.sort_unstable();
            writers.dedup();
            enc.node(name, &readers, &writers);
        }
        jobs.push(Job {
            guid,
            participant: entry.participant.clone(),
            writer: entry.writer.clone(),
            body: enc.finish(),
            retire: entry.nodes.is_empty(),
        });
    }
    jobs
}

fn discovery_writer(p: &Participant) -> Result<RawWriter, xrce_dds::DdsError> {
    let topic = p.topic(DISCOVERY_TOPIC, DISCOVERY_TYPE, false)?;
    // What rmw gives its own ros_discovery_info writer, so late-joining ROS nodes get the last sample. The
    // explicit limit matters: a durable RustDDS writer without matched readers keeps every sample up to it
    // (1,024 by default, each listing every node). RustDDS also makes it the send window: with one, a
    // sample waits for the acknowledgment of the previous one, which a newly matched Fast DDS reader
    // gives only ~1 s late (measured: a node took 0.86 s to disappear); two let the next change through.
    let qos = EndpointQos {
        reliability: Reliability::Reliable,
        durability: Durability::TransientLocal,
        history: History::KeepLast(1),
        resource_limits: Some(ResourceLimits { max_samples: 2, max_instances: 1, max_samples_per_instance: 2 }),
        ..EndpointQos::default()
    };
    p.create_writer(&topic, &qos)
}

/// Publishes `job`'s sample; the writer, and whether the sample went out.
fn publish(job: &Job) -> (Option<Arc<RawWriter>>, bool) {
    let writer = match &job.writer {
        Some(w) => Arc::clone(w),
        None => match discovery_writer(&job.participant) {
            Ok(w) => Arc::new(w),
            Err(e) => {
                tracing::warn!("cannot create the {DISCOVERY_TOPIC} writer: {e}");
                return (None, false);
            }
        },
    };
    // With one sample of room, a write waits for the previous sample's acknowledgments (100 ms at most);
    // a sample that did not go out is tried again with the next round.
    let sent = match writer.write(&job.body) {
        Ok(_) => true,
        Err(e) => {
            tracing::debug!("{DISCOVERY_TOPIC} sample not published yet: {e}");
            false
        }
    };
    (Some(writer), sent)
}

/// The agent stops: every DDS participant says it has no node left. Without this a ROS 2 node would list
/// the clients until the participant's lease ran out, as RustDDS' last SPDP dispose does not always get
/// out before its threads stop.
fn farewell(writers: &[(Gid, Arc<RawWriter>)], gid_len: usize) {
    for (guid, w) in writers {
        if let Err(e) = w.write(&InfoEncoder::new(guid, gid_len, 0).finish()) {
            tracing::debug!("last {DISCOVERY_TOPIC} sample not published: {e}");
        }
    }
    for (_, w) in writers {
        let _acked = w.wait_for_acknowledgments(RETIRE_ACK_WAIT);
    }
}

fn run(shared: &Shared) {
    loop {
        {
            let mut st = lock(&shared.state);
            while st.dirty.is_empty() && !st.shutdown {
                st = shared.cond.wait(st).unwrap_or_else(std::sync::PoisonError::into_inner);
            }
            if st.shutdown {
                let writers: Vec<(Gid, Arc<RawWriter>)> =
                    st.entries.iter().filter_map(|(g, e)| e.writer.clone().map(|w| (*g, w))).collect();
                drop(st);
                farewell(&writers, shared.gid_len);
                return;
            }
        }
        let nodes: usize = lock(&shared.state).entries.values().map(|e| e.nodes.len()).sum();
        let per_node = COALESCE_PER_NODE.saturating_mul(u32::try_from(nodes).unwrap_or(u32::MAX));
        std::thread::sleep(COALESCE.saturating_add(per_node).min(COALESCE_MAX));
        let jobs = gather(&mut lock(&shared.state), shared.gid_len);
        for job in jobs {
            let (writer, sent) = publish(&job);
            if !sent {
                lock(&shared.state).dirty.insert(job.guid);
            }
            if job.retire && sent {
                if let Some(w) = &writer {
                    // Best effort: the DDS participant may go right after, taking its nodes with it anyway.
                    let _acked = w.wait_for_acknowledgments(RETIRE_ACK_WAIT);
                }
            }
            let gone = {
                let mut st = lock(&shared.state);
                let pending = st.dirty.contains(&job.guid);
                match st.entries.get_mut(&job.guid) {
                    Some(e) if job.retire && sent && e.nodes.is_empty() && !pending => st.entries.remove(&job.guid),
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

    #[test]
    fn modes_give_the_gid_size_or_no_graph() {
        assert_eq!(RosGraphMode::default().gid_len(), Some(16));
        assert_eq!(RosGraphMode::Gid24.gid_len(), Some(24));
        assert!(RosGraph::new(RosGraphMode::Off).is_none());
    }
}
