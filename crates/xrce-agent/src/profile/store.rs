//! Profiles loaded from a `-r` refs file, looked up by `profile_name` when a client creates an entity by
//! reference.

use std::collections::hash_map::Entry;
use std::collections::HashMap;
use std::io::Read;
use std::path::Path;

use xrce_proto::ObjectKind;

use super::parse::{self, ElementClass, EndpointElement};
use super::{
    element_name, EntityProfile, ParticipantProfile, ProfileError, ServiceProfile, TopicProfile, MAX_REFS_LEN,
    MAX_REFS_NODES,
};

/// Named profiles, one namespace per profile type as in Fast DDS (`publisher` and `data_writer` share one,
/// `subscriber` and `data_reader` another). Topics can also be found by their topic name.
#[derive(Debug, Clone, Default)]
pub struct ProfileStore {
    participants: HashMap<String, ParticipantProfile>,
    topics: HashMap<String, TopicProfile>,
    topics_by_name: HashMap<String, TopicProfile>,
    writers: HashMap<String, EndpointElement>,
    readers: HashMap<String, EndpointElement>,
    requesters: HashMap<String, ServiceProfile>,
    repliers: HashMap<String, ServiceProfile>,
}

/// Inserts unless the name is taken: Fast DDS refuses a second profile with the same name and keeps the
/// first, reporting it; so do we (with a warning).
fn insert_new<T>(map: &mut HashMap<String, T>, name: String, value: T, element: &str) {
    match map.entry(name) {
        Entry::Occupied(e) => {
            tracing::warn!(profile = %e.key(), element, "refs: duplicate profile_name, keeping the first");
        }
        Entry::Vacant(e) => {
            e.insert(value);
        }
    }
}

impl ProfileStore {
    /// An empty store (no refs file): every reference is unknown.
    pub fn new() -> Self {
        Self::default()
    }

    /// Loads a refs file (Fast DDS XML profile syntax, at most [`MAX_REFS_LEN`] bytes).
    pub fn load_refs(path: impl AsRef<Path>) -> Result<Self, ProfileError> {
        let mut store = Self::new();
        store.merge_file(path)?;
        Ok(store)
    }

    /// Parses refs-file text (at most [`MAX_REFS_LEN`] bytes).
    pub fn from_xml_str(xml: &str) -> Result<Self, ProfileError> {
        let mut store = Self::new();
        store.merge_xml_str(xml)?;
        Ok(store)
    }

    /// Adds the profiles of another refs file (eProsima's `load_config_file` may be called more than once).
    /// Returns how many profiles were added. On error nothing is added.
    pub fn merge_file(&mut self, path: impl AsRef<Path>) -> Result<usize, ProfileError> {
        let path = path.as_ref();
        let io = |source| ProfileError::Io { path: path.to_owned(), source };
        let file = std::fs::File::open(path).map_err(io)?;
        let mut bytes = Vec::new();
        file.take(MAX_REFS_LEN as u64 + 1).read_to_end(&mut bytes).map_err(io)?;
        // The agent may load several files: say which one is wrong.
        let in_file = |e| ProfileError::InFile { path: path.to_owned(), source: Box::new(e) };
        if bytes.len() > MAX_REFS_LEN {
            return Err(in_file(ProfileError::TooLarge { len: bytes.len(), max: MAX_REFS_LEN }));
        }
        let text = String::from_utf8(bytes).map_err(|_| in_file(ProfileError::NotUtf8))?;
        self.merge_xml_str(&text).map_err(in_file)
    }

    /// Adds the profiles of refs-file text. Returns how many profiles were added. A malformed profile fails
    /// the whole text, as in Fast DDS, and then nothing is added; profiles without `profile_name` or with a
    /// name already taken are skipped with a warning.
    pub fn merge_xml_str(&mut self, xml: &str) -> Result<usize, ProfileError> {
        let text = parse::prepare(xml, MAX_REFS_LEN)?;
        let doc = parse::parse_document(&text, MAX_REFS_NODES)?;
        let mut parsed = Self::new();
        for (class, node) in parse::profile_elements(&doc) {
            let element = node.tag_name().name();
            let Some(name) = parse::attribute(node, "profile_name").filter(|n| !n.is_empty()) else {
                tracing::warn!(element, "refs: profile without profile_name skipped");
                continue;
            };
            match class {
                ElementClass::Participant => {
                    insert_new(&mut parsed.participants, name, parse::participant(node)?, element);
                }
                ElementClass::Topic => insert_new(&mut parsed.topics, name, parse::topic(node)?, element),
                ElementClass::Writer => insert_new(&mut parsed.writers, name, parse::endpoint(node, true)?, element),
                ElementClass::Reader => insert_new(&mut parsed.readers, name, parse::endpoint(node, false)?, element),
                ElementClass::Requester => insert_new(&mut parsed.requesters, name, parse::service(node)?, element),
                ElementClass::Replier => insert_new(&mut parsed.repliers, name, parse::service(node)?, element),
            }
        }
        Ok(self.absorb(parsed))
    }

    fn absorb(&mut self, other: Self) -> usize {
        let before = self.len();
        for (name, p) in other.participants {
            insert_new(&mut self.participants, name, p, "participant");
        }
        for (name, t) in other.topics {
            insert_new(&mut self.topics, name, t, "topic");
        }
        for (name, w) in other.writers {
            insert_new(&mut self.writers, name, w, "data_writer");
        }
        for (name, r) in other.readers {
            insert_new(&mut self.readers, name, r, "data_reader");
        }
        for (name, s) in other.requesters {
            insert_new(&mut self.requesters, name, s, "requester");
        }
        for (name, s) in other.repliers {
            insert_new(&mut self.repliers, name, s, "replier");
        }
        // Several topic profiles may share a topic name: the one with the smallest profile_name wins, so
        // the choice does not depend on hash order.
        self.topics_by_name.clear();
        let mut names: Vec<&String> = self.topics.keys().collect();
        names.sort();
        for name in names {
            if let Some(topic) = self.topics.get(name) {
                self.topics_by_name.entry(topic.name.clone()).or_insert_with(|| topic.clone());
            }
        }
        self.len() - before
    }

    /// The profile of `kind` named `name`: its `profile_name`, or for topics also its topic name.
    ///
    /// A `publisher`/`data_writer` profile serves publishers and datawriters alike (likewise for readers);
    /// used for a datawriter or datareader it must name a topic.
    pub fn get(&self, kind: ObjectKind, name: &str) -> Result<EntityProfile, ProfileError> {
        let Some(element) = element_name(kind) else {
            return Err(ProfileError::UnsupportedKind(kind));
        };
        let unknown = || ProfileError::UnknownReference { kind: element, name: name.to_owned() };
        let found = match kind {
            ObjectKind::Participant => self.participants.get(name).cloned().map(EntityProfile::Participant),
            ObjectKind::Topic => {
                self.topics.get(name).or_else(|| self.topics_by_name.get(name)).cloned().map(EntityProfile::Topic)
            }
            ObjectKind::Publisher => self.writers.get(name).cloned().map(|w| EntityProfile::Publisher(w.publisher())),
            ObjectKind::Subscriber => {
                self.readers.get(name).cloned().map(|r| EntityProfile::Subscriber(r.subscriber()))
            }
            ObjectKind::DataWriter => match self.writers.get(name) {
                Some(w) => Some(EntityProfile::DataWriter(w.clone().writer()?)),
                None => None,
            },
            ObjectKind::DataReader => match self.readers.get(name) {
                Some(r) => Some(EntityProfile::DataReader(r.clone().reader()?)),
                None => None,
            },
            ObjectKind::Requester => self.requesters.get(name).cloned().map(EntityProfile::Requester),
            ObjectKind::Replier => self.repliers.get(name).cloned().map(EntityProfile::Replier),
            _ => return Err(ProfileError::UnsupportedKind(kind)),
        };
        found.ok_or_else(unknown)
    }

    /// Number of named profiles (all kinds; a topic counts once).
    pub fn len(&self) -> usize {
        self.participants.len()
            + self.topics.len()
            + self.writers.len()
            + self.readers.len()
            + self.requesters.len()
            + self.repliers.len()
    }

    /// Whether no profile is loaded.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}
