//! The tables both engines keep the same way: participants and writers shared while someone holds them, and a
//! participant's topics (one type per name). Each engine supplies only how to create the DDS object.

use std::collections::HashMap;
use std::hash::Hash;
use std::sync::{Arc, Mutex, MutexGuard, PoisonError, Weak};

use crate::DdsError;

/// Locks `m`. Poisoning only means a panic elsewhere; every table here stays consistent (single inserts and
/// removes), so the data is used as it is.
pub(crate) fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(PoisonError::into_inner)
}

/// Values shared by key for as long as some caller holds one (the table keeps only weak references).
pub(crate) struct WeakMap<K, V>(Mutex<HashMap<K, Weak<V>>>);

impl<K: Eq + Hash, V> Default for WeakMap<K, V> {
    fn default() -> Self {
        Self(Mutex::new(HashMap::new()))
    }
}

impl<K: Eq + Hash, V> WeakMap<K, V> {
    /// The live value for `key`, or the one `make` creates (kept for the next caller). Dead entries are
    /// pruned whenever the table doubles: amortised O(1) per creation.
    pub(crate) fn get_or_try_insert<E>(&self, key: K, make: impl FnOnce() -> Result<Arc<V>, E>) -> Result<Arc<V>, E> {
        let mut map = lock(&self.0);
        if let Some(v) = map.get(&key).and_then(Weak::upgrade) {
            return Ok(v);
        }
        if map.len() >= 16 && map.len().is_power_of_two() {
            map.retain(|_, w| w.strong_count() > 0);
        }
        let v = make()?;
        map.insert(key, Arc::downgrade(&v));
        Ok(v)
    }

    /// The live value for `key`, if any.
    pub(crate) fn get(&self, key: &K) -> Option<Arc<V>> {
        lock(&self.0).get(key).and_then(Weak::upgrade)
    }

    /// The live values whose key `keep` accepts (taken out of the lock: dropping one never runs under it).
    #[cfg_attr(not(feature = "fastdds"), allow(dead_code))] // the Fast DDS engine's tables use it
    pub(crate) fn live_where(&self, keep: impl Fn(&K) -> bool) -> Vec<Arc<V>> {
        lock(&self.0).iter().filter(|(k, _)| keep(k)).filter_map(|(_, w)| w.upgrade()).collect()
    }

    /// Values alive now.
    pub(crate) fn live(&self) -> usize {
        lock(&self.0).values().filter(|w| w.strong_count() > 0).count()
    }
}

/// A topic of a participant as its table records it.
#[derive(Clone)]
pub(crate) struct TopicEntry<T> {
    pub(crate) topic: T,
    pub(crate) type_name: String,
    pub(crate) keyed: bool,
}

/// A participant's topics by name. DDS allows one type per topic name in a participant.
pub(crate) struct TopicTable<T>(Mutex<HashMap<String, TopicEntry<T>>>);

impl<T> Default for TopicTable<T> {
    fn default() -> Self {
        Self(Mutex::new(HashMap::new()))
    }
}

impl<T: Clone> TopicTable<T> {
    /// The topic `name`, created by `make` on first use; a request with another type name or key kind fails.
    pub(crate) fn get_or_try_create(
        &self,
        name: &str,
        type_name: &str,
        keyed: bool,
        make: impl FnOnce() -> Result<T, DdsError>,
    ) -> Result<T, DdsError> {
        let mut topics = lock(&self.0);
        if let Some(e) = topics.get(name) {
            if e.type_name != type_name || e.keyed != keyed {
                return Err(DdsError::TopicMismatch {
                    name: name.to_owned(),
                    existing_type: e.type_name.clone(),
                    existing_keyed: e.keyed,
                });
            }
            return Ok(e.topic.clone());
        }
        let topic = make()?;
        topics.insert(name.to_owned(), TopicEntry { topic: topic.clone(), type_name: type_name.to_owned(), keyed });
        Ok(topic)
    }

    /// The topic `name` if an earlier call created it (whatever its type).
    pub(crate) fn find(&self, name: &str) -> Option<TopicEntry<T>> {
        lock(&self.0).get(name).cloned()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn weak_map_shares_while_held_and_recreates_after() {
        let m: WeakMap<u8, u32> = WeakMap::default();
        let a = m.get_or_try_insert(1, || Ok::<_, ()>(Arc::new(7))).unwrap();
        let b = m.get_or_try_insert(1, || Ok::<_, ()>(Arc::new(8))).unwrap();
        assert!(Arc::ptr_eq(&a, &b));
        assert_eq!(m.live(), 1);
        drop((a, b));
        assert_eq!(m.live(), 0);
        assert_eq!(*m.get_or_try_insert(1, || Ok::<_, ()>(Arc::new(9))).unwrap(), 9);
    }

    #[test]
    fn topic_table_refuses_another_type_for_a_name() {
        let t: TopicTable<u8> = TopicTable::default();
        assert_eq!(t.get_or_try_create("a", "T", false, || Ok(1)).unwrap(), 1);
        assert_eq!(t.get_or_try_create("a", "T", false, || Ok(2)).unwrap(), 1, "created once");
        assert!(matches!(t.get_or_try_create("a", "U", false, || Ok(3)), Err(DdsError::TopicMismatch { .. })));
        assert!(t.get_or_try_create("a", "T", true, || Ok(4)).is_err());
        assert_eq!(t.find("a").map(|e| e.topic), Some(1));
        assert!(t.find("b").is_none());
    }
}
