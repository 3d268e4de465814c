//! The pure part of the ROS 2 graph: node names from participant names (micro-ROS' agent's rule) and the
//! CDR of rmw_dds_common's `ParticipantEntitiesInfo`, unit-tested without DDS.

/// Bound of `node_namespace` and `node_name` in rmw_dds_common's `NodeEntitiesInfo` (`string<=256`). A
/// longer string would make peers reject the whole sample, so such a node is left out (with a warning).
pub const MAX_NAME_LEN: usize = 256;

/// A node's namespace and name.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub struct NodeName {
    /// Namespace, starting with `/`.
    pub namespace: String,
    /// Name (micro-ROS' rule lets it contain `/` when the participant name has three segments or more).
    pub name: String,
}

/// A node's namespace and name as parts of the participant name (no allocation: samples listing
/// thousands of nodes are encoded straight from the participant names).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct NodeNameRef<'a> {
    /// The namespace without its leading `/` (empty: the root namespace `/`).
    pub namespace_tail: &'a str,
    /// The name.
    pub name: &'a str,
}

impl NodeNameRef<'_> {
    /// Owned form.
    pub fn to_owned(self) -> NodeName {
        NodeName { namespace: format!("/{}", self.namespace_tail), name: self.name.to_owned() }
    }
}

/// The node an XRCE participant named `participant_name` is, by micro-ROS' agent's rule: one leading `/`
/// is dropped; with two segments or more the first is the namespace (`/` prepended) and the rest, joined
/// by `/`, the name; otherwise the whole is the name in namespace `/`. Segments are cut as C++'s getline
/// cuts them, so one trailing `/` adds no empty segment. `None` for names that make no node: empty, `/`
/// (micro-ROS' agent skips its own root participant of that name) or longer than [`MAX_NAME_LEN`].
pub fn split_node_name(participant_name: &str) -> Option<NodeNameRef<'_>> {
    let s = participant_name.strip_prefix('/').unwrap_or(participant_name);
    let node = match s.split_once('/') {
        Some((first, rest)) if !rest.is_empty() => {
            NodeNameRef { namespace_tail: first, name: rest.strip_suffix('/').unwrap_or(rest) }
        }
        _ => NodeNameRef { namespace_tail: "", name: s },
    };
    if node.name.is_empty() || node.name.len() > MAX_NAME_LEN || node.namespace_tail.len() + 1 > MAX_NAME_LEN {
        return None;
    }
    Some(node)
}

/// [`split_node_name`], owned.
pub fn node_name(participant_name: &str) -> Option<NodeName> {
    split_node_name(participant_name).map(NodeNameRef::to_owned)
}

/// A DDS GUID: 12-byte prefix then 4-byte entity id.
pub type Gid = [u8; 16];

/// XCDR1 little-endian writer of a `ParticipantEntitiesInfo` body (alignment counted from the body
/// start, after the 4-byte encapsulation header the bridge adds):
/// `ParticipantEntitiesInfo { Gid gid; NodeEntitiesInfo[] node_entities_info_seq; }`,
/// `NodeEntitiesInfo { string node_namespace; string node_name; Gid[] reader_gid_seq; Gid[] writer_gid_seq; }`,
/// `Gid { char data[gid_len]; }` (16 or 24, see [`super::RosGraphMode::gid_len`]).
pub struct InfoEncoder {
    buf: Vec<u8>,
    gid_len: usize,
    /// Where the node count goes, written last.
    count_at: usize,
    count: u32,
}

impl InfoEncoder {
    /// Starts the sample of DDS participant `participant`, about `nodes` nodes long.
    pub fn new(participant: &Gid, gid_len: usize, nodes: usize) -> Self {
        let mut e = Self { buf: Vec::with_capacity(24 + nodes * 56), gid_len, count_at: 0, count: 0 };
        e.gid(participant);
        e.align4();
        e.count_at = e.buf.len();
        e.u32(0);
        e
    }

    /// Adds a node with its readers and writers.
    pub fn node(&mut self, name: NodeNameRef<'_>, readers: &[Gid], writers: &[Gid]) {
        self.string(&["/", name.namespace_tail]);
        self.string(&[name.name]);
        self.gids(readers);
        self.gids(writers);
        self.count = self.count.saturating_add(1);
    }

    /// The body.
    pub fn finish(mut self) -> Vec<u8> {
        if let Some(slot) = self.buf.get_mut(self.count_at..self.count_at + 4) {
            slot.copy_from_slice(&self.count.to_le_bytes());
        }
        self.buf
    }

    fn align4(&mut self) {
        while !self.buf.len().is_multiple_of(4) {
            self.buf.push(0);
        }
    }

    fn u32(&mut self, v: u32) {
        self.align4();
        self.buf.extend_from_slice(&v.to_le_bytes());
    }

    fn len(&mut self, n: usize) {
        self.u32(u32::try_from(n).unwrap_or(u32::MAX));
    }

    /// A string made of `parts`, NUL-terminated.
    fn string(&mut self, parts: &[&str]) {
        self.len(parts.iter().map(|p| p.len()).sum::<usize>() + 1);
        for p in parts {
            self.buf.extend_from_slice(p.as_bytes());
        }
        self.buf.push(0);
    }

    fn gid(&mut self, g: &Gid) {
        self.buf.extend_from_slice(g);
        self.buf.resize(self.buf.len() + self.gid_len.saturating_sub(g.len()), 0);
    }

    fn gids(&mut self, gids: &[Gid]) {
        self.len(gids.len());
        for g in gids {
            self.gid(g);
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
        assert_eq!(node_name("a/"), nn("/", "a/"), "one segment: the whole, as micro-ROS");
        assert_eq!(node_name("a//"), None, "an empty name");
        assert_eq!(node_name("//x"), nn("/", "x"));
        assert_eq!(node_name("a/b//"), nn("/a", "b/"));
    }

    fn gid(b: u8) -> Gid {
        let mut g = [b; 16];
        g[12..].copy_from_slice(&[0, 0, 1, 0xc1]);
        g
    }

    #[test]
    fn participant_info_encodes_as_rmw_dds_common() {
        let mut enc = InfoEncoder::new(&gid(1), 16, 1);
        enc.node(split_node_name("talker").unwrap(), &[], &[gid(7)]);
        let body = enc.finish();
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
        let mut enc = InfoEncoder::new(&gid(1), 24, 1);
        enc.node(split_node_name("/ns/n").unwrap(), &[gid(2)], &[]);
        let body = enc.finish();
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
        let body = InfoEncoder::new(&gid(3), 16, 0).finish();
        assert_eq!(body.len(), 20);
        assert_eq!(&body[16..], &[0; 4]);
    }
}
