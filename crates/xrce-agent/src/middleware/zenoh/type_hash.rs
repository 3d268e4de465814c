//! The RIHS01 type hash rmw_zenoh puts in every key, from the type description ROS installs with each
//! interface (`<prefix>/share/<package>/<msg|srv>/<Type>.json`, its `"type_hashes"`), found through
//! `AMENT_PREFIX_PATH` as a sourced ROS 2 (or a workspace with px4_msgs) sets it. Read once per type.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// Why a type has no hash; the message names the type and the fix.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum TypeHashError {
    /// Not of ROS 2's `<package>::<msg|srv>::dds_::<Type>_` form.
    #[error(
        "type `{0}` is not a ROS 2 interface type (`<package>::msg::dds_::<Type>_`): rmw_zenoh puts the type's \
         RIHS01 hash in every key and only ROS 2 interfaces have one; use a ROS 2 type, or `-m dds`"
    )]
    NotRos2(String),
    /// No prefix of `AMENT_PREFIX_PATH` has the description.
    #[error(
        "no type hash for `{type_name}`: share/{relative} is in none of AMENT_PREFIX_PATH ({searched}); nothing is \
         sent for it (rmw_zenoh's nodes would not match a wrong key). Fix: start the agent where the ROS 2 \
         installation with that package is sourced (`source /opt/ros/jazzy/setup.bash`, and your workspace's \
         `install/setup.bash` for px4_msgs or your own interfaces)"
    )]
    NotFound {
        /// The DDS type name.
        type_name: String,
        /// `<package>/<msg|srv>/<Type>.json`.
        relative: String,
        /// The prefixes looked in.
        searched: String,
    },
    /// The description exists but has no usable hash.
    #[error("type `{type_name}`: {file} has no RIHS01 hash for `{ros_name}` ({reason})")]
    Unreadable {
        /// The DDS type name.
        type_name: String,
        /// The file read.
        file: String,
        /// The ROS name looked for.
        ros_name: String,
        /// What was wrong.
        reason: String,
    },
}

/// A ROS 2 interface named by its DDS type name.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Interface<'a> {
    /// Package (`std_msgs`).
    pub package: &'a str,
    /// `msg` or `srv`.
    pub kind: &'a str,
    /// Type (`String`).
    pub name: &'a str,
}

impl Interface<'_> {
    /// `std_msgs::msg::dds_::String_` → std_msgs, msg, String; a service's base type
    /// (`example_interfaces::srv::dds_::AddTwoInts_`) likewise.
    pub fn parse(dds_type: &str) -> Option<Interface<'_>> {
        let mut parts = dds_type.split("::");
        let (package, kind, dds, last) = (parts.next()?, parts.next()?, parts.next()?, parts.next()?);
        let name = last.strip_suffix('_')?;
        let valid = !package.is_empty() && !name.is_empty() && matches!(kind, "msg" | "srv" | "action");
        (valid && dds == "dds_" && parts.next().is_none()).then_some(Interface { package, kind, name })
    }

    /// The ROS name the description lists the hash under (`std_msgs/msg/String`).
    pub fn ros_name(&self) -> String {
        format!("{}/{}/{}", self.package, self.kind, self.name)
    }

    /// The description's path under a prefix.
    pub fn relative_path(&self) -> String {
        format!("{}/{}/{}.json", self.package, self.kind, self.name)
    }
}

/// The hash `ros_name` has in a type description's JSON text.
pub fn hash_in_description(json: &str, ros_name: &str) -> Result<String, String> {
    let doc: serde_json::Value = serde_json::from_str(json).map_err(|e| format!("not JSON: {e}"))?;
    let hashes = doc.get("type_hashes").and_then(|h| h.as_array()).ok_or("no \"type_hashes\" array")?;
    let entry = hashes
        .iter()
        .find(|h| h.get("type_name").and_then(|n| n.as_str()) == Some(ros_name))
        .ok_or("not listed in \"type_hashes\"")?;
    let hash = entry.get("hash_string").and_then(|h| h.as_str()).ok_or("no \"hash_string\"")?;
    let hex = hash.strip_prefix("RIHS01_").ok_or("not an RIHS01 hash")?;
    if hex.len() != 64 || !hex.bytes().all(|b| b.is_ascii_hexdigit()) {
        return Err(format!("malformed hash {hash:?}"));
    }
    Ok(hash.to_owned())
}

/// Type hashes found through the install prefixes, cached per type (found or not).
#[derive(Debug, Default)]
pub struct TypeHashes {
    prefixes: Vec<PathBuf>,
    cache: HashMap<String, Result<String, TypeHashError>>,
}

impl TypeHashes {
    /// Looks in `prefixes` (each holding `share/`).
    pub fn new(prefixes: Vec<PathBuf>) -> Self {
        Self { prefixes, cache: HashMap::new() }
    }

    /// Looks in the prefixes of `AMENT_PREFIX_PATH`.
    pub fn from_env() -> Self {
        let prefixes = std::env::var_os("AMENT_PREFIX_PATH")
            .map(|v| std::env::split_paths(&v).filter(|p| !p.as_os_str().is_empty()).collect())
            .unwrap_or_default();
        Self::new(prefixes)
    }

    /// The hash of DDS type `dds_type` (a message, or a service's base type).
    pub fn lookup(&mut self, dds_type: &str) -> Result<String, TypeHashError> {
        if let Some(known) = self.cache.get(dds_type) {
            return known.clone();
        }
        let found = self.find(dds_type);
        self.cache.insert(dds_type.to_owned(), found.clone());
        found
    }

    fn find(&self, dds_type: &str) -> Result<String, TypeHashError> {
        let iface = Interface::parse(dds_type).ok_or_else(|| TypeHashError::NotRos2(dds_type.to_owned()))?;
        let relative = iface.relative_path();
        let Some(file) = self.prefixes.iter().map(|p| p.join("share").join(&relative)).find(|f| f.is_file()) else {
            let searched = if self.prefixes.is_empty() {
                "unset or empty".to_owned()
            } else {
                self.prefixes.iter().map(|p| p.display().to_string()).collect::<Vec<_>>().join(":")
            };
            return Err(TypeHashError::NotFound { type_name: dds_type.to_owned(), relative, searched });
        };
        let unreadable = |reason: String| TypeHashError::Unreadable {
            type_name: dds_type.to_owned(),
            file: file.display().to_string(),
            ros_name: iface.ros_name(),
            reason,
        };
        let text = read(&file).map_err(unreadable)?;
        hash_in_description(&text, &iface.ros_name()).map_err(unreadable)
    }
}

fn read(file: &Path) -> Result<String, String> {
    std::fs::read_to_string(file).map_err(|e| e.to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    const STRING_JSON: &str = r#"{"type_hashes": [{"type_name": "std_msgs/msg/String",
        "hash_string": "RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18"}],
        "type_description_msg": {}}"#;

    #[test]
    fn dds_type_names_name_their_description() {
        let i = Interface::parse("std_msgs::msg::dds_::String_").unwrap();
        assert_eq!(
            (i.ros_name(), i.relative_path()),
            ("std_msgs/msg/String".into(), "std_msgs/msg/String.json".into())
        );
        let s = Interface::parse("example_interfaces::srv::dds_::AddTwoInts_").unwrap();
        assert_eq!(s.ros_name(), "example_interfaces/srv/AddTwoInts");
        assert_eq!(Interface::parse("HelloWorld"), None);
        assert_eq!(Interface::parse("std_msgs::msg::String"), None);
    }

    #[test]
    fn the_hash_comes_from_type_hashes_under_the_ros_name() {
        assert_eq!(
            hash_in_description(STRING_JSON, "std_msgs/msg/String").unwrap(),
            "RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18"
        );
        assert!(hash_in_description(STRING_JSON, "std_msgs/msg/Bool").is_err());
        assert!(hash_in_description(
            r#"{"type_hashes": [{"type_name": "a/msg/B", "hash_string": "RIHS01_12"}]}"#,
            "a/msg/B"
        )
        .is_err());
    }

    #[test]
    fn found_under_a_prefix_and_missing_types_name_the_type_and_the_fix() {
        let dir = std::env::temp_dir().join(format!("xrce-type-hash-{}", std::process::id()));
        let msg_dir = dir.join("share/std_msgs/msg");
        std::fs::create_dir_all(&msg_dir).unwrap();
        std::fs::write(msg_dir.join("String.json"), STRING_JSON).unwrap();
        let mut hashes = TypeHashes::new(vec![PathBuf::from("/nonexistent"), dir.clone()]);
        assert!(hashes.lookup("std_msgs::msg::dds_::String_").unwrap().starts_with("RIHS01_df66"));
        let err = hashes.lookup("px4_msgs::msg::dds_::VehicleStatus_").unwrap_err().to_string();
        assert!(err.contains("px4_msgs::msg::dds_::VehicleStatus_"), "{err}");
        assert!(err.contains("share/px4_msgs/msg/VehicleStatus.json"), "{err}");
        assert!(err.contains("install/setup.bash"), "{err}");
        assert!(matches!(TypeHashes::new(Vec::new()).lookup("HelloWorld"), Err(TypeHashError::NotRos2(_))));
        std::fs::remove_dir_all(dir).unwrap();
    }
}
