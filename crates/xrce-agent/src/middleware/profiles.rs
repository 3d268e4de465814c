//! The [`ProfileSource`] backed by the Fast DDS profile parser and the refs files ([`crate::profile`]).
//!
//! Strict parsing first; when it fails (eProsima's own examples send requester XML without spaces between
//! attributes, which no conforming parser accepts), the tolerant scan of [`FallbackProfiles`] gets a
//! chance. References the refs files do not know keep eProsima CED's meaning: the name itself, suffix
//! stripped.

use std::path::Path;
use std::sync::RwLock;

use xrce_proto::ObjectKind;

use super::describe::{Description, FallbackProfiles, ProfileSource, TopicRef};
use crate::profile::{parse_entity_xml, EntityProfile, ProfileError, ProfileStore};

/// Profiles from refs files (more can be loaded at run time) plus XML parsing.
#[derive(Debug, Default)]
pub struct StoreProfiles {
    store: RwLock<ProfileStore>,
}

impl StoreProfiles {
    /// No refs loaded yet.
    pub fn new() -> Self {
        Self::default()
    }

    /// Profiles of a store.
    pub fn with_store(store: ProfileStore) -> Self {
        Self { store: RwLock::new(store) }
    }

    /// Adds the profiles of a refs file (eProsima's `load_config_file`); returns how many were added.
    pub fn load_file(&self, path: impl AsRef<Path>) -> Result<usize, ProfileError> {
        let mut store = self.store.write().unwrap_or_else(std::sync::PoisonError::into_inner);
        store.merge_file(path)
    }

    /// Number of named profiles loaded.
    pub fn len(&self) -> usize {
        self.store.read().map(|s| s.len()).unwrap_or(0)
    }

    /// Whether no profile is loaded.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// The routing facts of a parsed profile.
pub fn description_of(profile: EntityProfile) -> Description {
    match profile {
        EntityProfile::Participant(p) => Description::Participant { domain_id: 0, name: p.name },
        EntityProfile::Topic(t) => Description::Topic { name: t.name, type_name: t.type_name },
        EntityProfile::Publisher(_) | EntityProfile::Subscriber(_) => Description::Group,
        EntityProfile::DataWriter(w) => {
            Description::Endpoint { topic: TopicRef::Name { name: w.topic.name, type_name: w.topic.type_name } }
        }
        EntityProfile::DataReader(r) => {
            Description::Endpoint { topic: TopicRef::Name { name: r.topic.name, type_name: r.topic.type_name } }
        }
        EntityProfile::Requester(s) | EntityProfile::Replier(s) => Description::Service {
            service_name: s.service_name,
            request_type: Some(s.request_type),
            reply_type: Some(s.reply_type),
        },
    }
}

impl ProfileSource for StoreProfiles {
    fn resolve_reference(&self, kind: ObjectKind, reference: &str) -> Option<Description> {
        let found = self.store.read().ok().and_then(|s| s.get(kind, reference).ok());
        match found {
            Some(profile) => Some(description_of(profile)),
            None => FallbackProfiles.resolve_reference(kind, reference),
        }
    }

    fn reference_profile(&self, kind: ObjectKind, reference: &str) -> Option<EntityProfile> {
        self.store.read().ok().and_then(|s| s.get(kind, reference).ok())
    }

    fn parse_xml(&self, kind: ObjectKind, xml: &str) -> Result<Description, String> {
        match parse_entity_xml(kind, xml) {
            Ok(profile) => Ok(description_of(profile)),
            Err(strict) => FallbackProfiles.parse_xml(kind, xml).map_err(|tolerant| format!("{strict}; {tolerant}")),
        }
    }
}
