//! QoS as rmw_zenoh carries it: in the liveliness token's last field (empty parts are rmw_zenoh's defaults,
//! and receivers drop a token whose field lacks a part) and in what the Zenoh entities are declared with.

pub use xrce_dds::{Durability, Reliability};
use xrce_dds::{EndpointQos, History as DdsHistory};

/// rmw_zenoh's depth when none is given (and the default left out of tokens).
pub const DEFAULT_DEPTH: u32 = 42;

/// History kind (rmw's enum values: keep last 1, keep all 2).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum History {
    /// Keep last `depth`, rmw_zenoh's default.
    KeepLast,
    /// Keep all.
    KeepAll,
}

/// The QoS of a ROS 2 endpoint that rmw_zenoh models (deadline, lifespan and liveliness stay at their
/// defaults: XRCE entities do not carry them in a form ROS reads).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct RosQos {
    /// Reliability (rmw's values: reliable 1, best effort 2).
    pub reliability: Reliability,
    /// Durability, volatile or transient local (rmw's values: transient local 1, volatile 2).
    pub durability: Durability,
    /// History kind.
    pub history: History,
    /// History depth (never 0: 0 means [`DEFAULT_DEPTH`]).
    pub depth: u32,
}

impl Default for RosQos {
    fn default() -> Self {
        Self {
            reliability: Reliability::Reliable,
            durability: Durability::Volatile,
            history: History::KeepLast,
            depth: DEFAULT_DEPTH,
        }
    }
}

impl RosQos {
    /// From the QoS the XRCE entity was described with. Transient and persistent count as transient local
    /// (what a ROS node can ask for); a depth of 0 is rmw_zenoh's default depth.
    pub fn from_endpoint(q: &EndpointQos) -> Self {
        let (history, depth) = match q.history {
            DdsHistory::KeepLast(d) => (History::KeepLast, d),
            DdsHistory::KeepAll => (History::KeepAll, 0),
        };
        Self {
            reliability: q.reliability,
            // What a ROS node can ask for: transient and persistent are served as transient local.
            durability: match q.durability {
                Durability::Volatile => Durability::Volatile,
                _ => Durability::TransientLocal,
            },
            history,
            depth: if depth == 0 { DEFAULT_DEPTH } else { depth },
        }
    }

    /// The token's QoS field: `reliability:durability:history,depth:deadline_s,deadline_ns:lifespan_s,lifespan_ns:liveliness,lease_s,lease_ns`,
    /// each part empty when it is rmw_zenoh's default.
    pub fn token_field(&self) -> String {
        let reliability = match self.reliability {
            Reliability::Reliable => "",
            Reliability::BestEffort => "2",
        };
        let durability = match self.durability {
            Durability::Volatile => "",
            _ => "1",
        };
        let history = match self.history {
            History::KeepLast => "",
            History::KeepAll => "2",
        };
        let depth = if self.depth == DEFAULT_DEPTH { String::new() } else { self.depth.to_string() };
        format!("{reliability}:{durability}:{history},{depth}:,:,:,,")
    }

    /// Parses a token's QoS field (a remote endpoint's), `None` when it lacks a part or has an unknown value.
    #[cfg(test)]
    pub fn parse_token_field(field: &str) -> Option<Self> {
        let parts: Vec<&str> = field.split(':').collect();
        let [reliability, durability, history, ..] = parts.as_slice() else { return None };
        if parts.len() < 6 {
            return None;
        }
        let (kind, depth) = history.split_once(',')?;
        Some(Self {
            reliability: match *reliability {
                "" | "0" | "1" => Reliability::Reliable,
                "2" => Reliability::BestEffort,
                _ => return None,
            },
            durability: match *durability {
                "" | "0" | "2" => Durability::Volatile,
                "1" => Durability::TransientLocal,
                _ => return None,
            },
            history: match kind {
                "" | "0" | "1" => History::KeepLast,
                "2" => History::KeepAll,
                _ => return None,
            },
            depth: if depth.is_empty() { DEFAULT_DEPTH } else { depth.parse().ok()? },
        })
    }

    /// How many samples a transient local publisher keeps for late joiners, and a subscriber asks for.
    pub fn cache_depth(&self) -> usize {
        usize::try_from(self.depth).unwrap_or(usize::MAX)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn token_field_has_every_part_and_leaves_defaults_empty() {
        let talker = RosQos { depth: 10, ..RosQos::default() };
        assert_eq!(talker.token_field(), "::,10:,:,:,,");
        assert_eq!(RosQos::default().token_field(), "::,:,:,:,,");
        let px4 = RosQos {
            reliability: Reliability::BestEffort,
            durability: Durability::TransientLocal,
            history: History::KeepLast,
            depth: 1,
        };
        assert_eq!(px4.token_field(), "2:1:,1:,:,:,,");
        let all = RosQos { history: History::KeepAll, ..RosQos::default() };
        assert_eq!(all.token_field(), "::2,:,:,:,,");
    }

    #[test]
    fn token_field_round_trips_and_short_fields_are_refused() {
        for q in [
            RosQos::default(),
            RosQos { depth: 10, ..RosQos::default() },
            RosQos {
                reliability: Reliability::BestEffort,
                durability: Durability::TransientLocal,
                ..RosQos::default()
            },
        ] {
            assert_eq!(RosQos::parse_token_field(&q.token_field()), Some(q));
        }
        assert_eq!(RosQos::parse_token_field("::,10"), None);
        assert_eq!(RosQos::parse_token_field("7::,:,:,:,,"), None);
    }

    #[test]
    fn xrce_qos_maps_onto_ros_qos() {
        let q = EndpointQos {
            reliability: Reliability::BestEffort,
            durability: Durability::Persistent,
            history: DdsHistory::KeepLast(5),
            ..EndpointQos::default()
        };
        let ros = RosQos::from_endpoint(&q);
        assert_eq!(ros.reliability, Reliability::BestEffort);
        assert_eq!(ros.durability, Durability::TransientLocal);
        assert_eq!(ros.depth, 5);
        let all = RosQos::from_endpoint(&EndpointQos { history: DdsHistory::KeepAll, ..EndpointQos::default() });
        assert_eq!((all.history, all.depth), (History::KeepAll, DEFAULT_DEPTH));
    }
}
