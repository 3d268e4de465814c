//! rmw_zenoh's names, pure: the key expression a topic's data travels on, the liveliness token that
//! announces a node or an endpoint to the ROS graph, and the GID derived from that token
//! (docs/zenoh.md, "The mapping").

use super::qos::RosQos;

/// The liveliness admin space rmw_zenoh's graph listens to.
pub const ADMIN_SPACE: &str = "@ros2_lv";

/// What a liveliness token announces (the token's sixth part).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum EntityKind {
    /// A node.
    Node,
    /// A publisher.
    Publisher,
    /// A subscription.
    Subscription,
    /// A service server.
    Service,
    /// A service client.
    Client,
}

impl EntityKind {
    /// The token's code for it.
    pub const fn code(self) -> &'static str {
        match self {
            Self::Node => "NN",
            Self::Publisher => "MP",
            Self::Subscription => "MS",
            Self::Service => "SS",
            Self::Client => "SC",
        }
    }
}

/// The node an entity belongs to, as its token names it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct NodeIdent {
    /// `ROS_DOMAIN_ID`.
    pub domain: u32,
    /// The Zenoh session's id, as Zenoh prints it.
    pub zid: String,
    /// The node's id in this session (rmw_zenoh counts nodes and entities with one counter).
    pub node_id: u64,
    /// The security enclave (`/` when none).
    pub enclave: String,
    /// The namespace, starting with `/`.
    pub namespace: String,
    /// The node name.
    pub name: String,
}

/// A topic or service as its data key and its endpoints' tokens name it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TopicIdent {
    /// ROS name, starting with `/` (`/chatter`).
    pub name: String,
    /// DDS type name (`std_msgs::msg::dds_::String_`; a service's without `Request_`/`Response_`).
    pub type_name: String,
    /// `RIHS01_` and 64 hex digits.
    pub type_hash: String,
    /// The endpoint's QoS.
    pub qos: RosQos,
}

/// `/` inside a name becomes `%`, so that a name is one chunk of a key expression (an empty namespace,
/// `/`, becomes `%`).
pub fn mangle(name: &str) -> String {
    name.replace('/', "%")
}

/// The key expression of a topic's data: `<domain>/<name without its leading and trailing '/'>/<type>/<hash>`.
pub fn topic_keyexpr(domain: u32, topic: &TopicIdent) -> String {
    let name = topic.name.strip_prefix('/').unwrap_or(&topic.name);
    let name = name.strip_suffix('/').unwrap_or(name);
    format!("{domain}/{name}/{}/{}", topic.type_name, topic.type_hash)
}

/// The liveliness token of a node (`topic` `None`, `entity_id` the node's id) or of one of its endpoints.
pub fn liveliness_token(node: &NodeIdent, entity_id: u64, kind: EntityKind, topic: Option<&TopicIdent>) -> String {
    let mut token = format!(
        "{ADMIN_SPACE}/{}/{}/{}/{entity_id}/{}/{}/{}/{}",
        node.domain,
        node.zid,
        node.node_id,
        kind.code(),
        mangle(&node.enclave),
        mangle(&node.namespace),
        mangle(&node.name)
    );
    if let Some(t) = topic {
        token.push('/');
        token.push_str(&mangle(&t.name));
        token.push('/');
        token.push_str(&mangle(&t.type_name));
        token.push('/');
        token.push_str(&mangle(&t.type_hash));
        token.push('/');
        token.push_str(&t.qos.token_field());
    }
    token
}

/// The 16-byte GID rmw_zenoh gives an entity: XXH3-128 of its liveliness token, the low 64 bits then the
/// high 64 bits, each little endian. It travels in every sample's attachment.
pub fn gid(token: &str) -> [u8; 16] {
    let h = xxhash_rust::xxh3::xxh3_128(token.as_bytes());
    let mut out = [0u8; 16];
    let (low, high) = out.split_at_mut(8);
    low.copy_from_slice(&(h as u64).to_le_bytes());
    high.copy_from_slice(&((h >> 64) as u64).to_le_bytes());
    out
}

/// The ROS name of an XRCE topic: `rt/chatter` → `/chatter` (ROS 2's DDS prefix dropped); a name without
/// the prefix keeps its text, with a leading `/`.
pub fn ros_topic_name(dds_topic: &str) -> String {
    let bare = dds_topic.strip_prefix("rt/").unwrap_or(dds_topic);
    format!("/{}", bare.trim_start_matches('/'))
}

/// The ROS name of an XRCE service: from its request topic (`rq/add_two_intsRequest` → `/add_two_ints`)
/// when it has ROS 2's form, else from its service name.
pub fn ros_service_name(service_name: &str, request_topic: Option<&str>) -> String {
    let from_topic = request_topic.and_then(|t| t.strip_prefix("rq/")?.strip_suffix("Request"));
    let bare = from_topic.unwrap_or(service_name);
    format!("/{}", bare.trim_start_matches('/'))
}

/// A service's type in keys and tokens: its request (or reply) type without the suffix
/// (`example_interfaces::srv::dds_::AddTwoInts_Request_` → `example_interfaces::srv::dds_::AddTwoInts_`).
pub fn service_type_name(request_or_reply_type: &str) -> String {
    for suffix in ["Request_", "Response_"] {
        if let Some(at) = request_or_reply_type.rfind(suffix) {
            return request_or_reply_type.get(..at).unwrap_or(request_or_reply_type).to_owned();
        }
    }
    request_or_reply_type.to_owned()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::middleware::zenoh::qos::{Durability, History, Reliability};

    const STRING_HASH: &str = "RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18";

    fn talker() -> NodeIdent {
        NodeIdent {
            domain: 0,
            zid: "7a1f2c3d4e5f60718293a4b5c6d7e8f9".into(),
            node_id: 0,
            enclave: "/".into(),
            namespace: "/".into(),
            name: "talker".into(),
        }
    }

    fn chatter(qos: RosQos) -> TopicIdent {
        TopicIdent {
            name: "/chatter".into(),
            type_name: "std_msgs::msg::dds_::String_".into(),
            type_hash: STRING_HASH.into(),
            qos,
        }
    }

    fn default_talker_qos() -> RosQos {
        RosQos {
            reliability: Reliability::Reliable,
            durability: Durability::Volatile,
            history: History::KeepLast,
            depth: 10,
        }
    }

    #[test]
    fn data_travels_on_domain_name_type_and_hash() {
        // As observed with rmw_zenoh 0.2.10 on domain 0.
        assert_eq!(
            topic_keyexpr(0, &chatter(default_talker_qos())),
            format!("0/chatter/std_msgs::msg::dds_::String_/{STRING_HASH}")
        );
        let mut nested = chatter(default_talker_qos());
        nested.name = "/fmu/out/vehicle_status/".into();
        assert!(topic_keyexpr(7, &nested).starts_with("7/fmu/out/vehicle_status/std_msgs"));
    }

    #[test]
    fn publisher_token_mangles_slashes_and_ends_with_the_full_qos_field() {
        let token = liveliness_token(&talker(), 10, EntityKind::Publisher, Some(&chatter(default_talker_qos())));
        assert_eq!(
            token,
            format!(
                "@ros2_lv/0/7a1f2c3d4e5f60718293a4b5c6d7e8f9/0/10/MP/%/%/talker/%chatter/\
                 std_msgs::msg::dds_::String_/{STRING_HASH}/::,10:,:,:,,"
            )
        );
    }

    #[test]
    fn node_token_stops_after_the_node_name_and_keeps_namespaces_in_one_chunk() {
        let mut node = talker();
        node.namespace = "/robot1/arm".into();
        node.node_id = 3;
        assert_eq!(
            liveliness_token(&node, 3, EntityKind::Node, None),
            "@ros2_lv/0/7a1f2c3d4e5f60718293a4b5c6d7e8f9/3/3/NN/%/%robot1%arm/talker"
        );
    }

    #[test]
    fn gid_is_xxh3_128_of_the_token_low_half_first_little_endian() {
        let token = "@ros2_lv/0/1/0/10/MP/%/%/talker";
        let h = xxhash_rust::xxh3::xxh3_128(token.as_bytes());
        let g = gid(token);
        assert_eq!(u64::from_le_bytes(g[..8].try_into().unwrap()), h as u64);
        assert_eq!(u64::from_le_bytes(g[8..].try_into().unwrap()), (h >> 64) as u64);
        // Known value of XXH3-128 (the empty input, from xxHash's own test vectors).
        assert_eq!(gid(""), {
            let mut e = [0u8; 16];
            e[..8].copy_from_slice(&0x6001_C324_468D_497Fu64.to_le_bytes());
            e[8..].copy_from_slice(&0x99AA_06D3_0147_98D8u64.to_le_bytes());
            e
        });
    }

    #[test]
    fn xrce_names_become_ros_names() {
        assert_eq!(ros_topic_name("rt/chatter"), "/chatter");
        assert_eq!(ros_topic_name("rt/fmu/out/vehicle_status"), "/fmu/out/vehicle_status");
        assert_eq!(ros_topic_name("HelloWorldTopic"), "/HelloWorldTopic");
        assert_eq!(ros_service_name("robot1/set_flag", Some("rq/robot1/set_flagRequest")), "/robot1/set_flag");
        assert_eq!(ros_service_name("add_two_ints", None), "/add_two_ints");
        assert_eq!(
            service_type_name("example_interfaces::srv::dds_::AddTwoInts_Request_"),
            "example_interfaces::srv::dds_::AddTwoInts_"
        );
        assert_eq!(service_type_name("std_srvs::srv::dds_::SetBool_Response_"), "std_srvs::srv::dds_::SetBool_");
    }
}
