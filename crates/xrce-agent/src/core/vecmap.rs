//! A map kept in a vector: the per-client tables (streams, objects, read tasks) hold a handful of entries,
//! where a `HashMap` costs more memory (a table allocated at 4+ buckets, 48 bytes inline) than a linear scan
//! costs time. An empty map allocates nothing; small maps grow one slot at a time.

/// A small map with linear lookup, in insertion order.
#[derive(Debug, Clone)]
pub struct VecMap<K, V> {
    entries: Vec<(K, V)>,
}

impl<K, V> Default for VecMap<K, V> {
    fn default() -> Self {
        Self { entries: Vec::new() }
    }
}

/// Below this many entries the map grows by exactly one slot (no spare capacity per idle client).
const EXACT_GROWTH_BELOW: usize = 8;

impl<K: Copy + Eq, V> VecMap<K, V> {
    /// Number of entries.
    pub fn len(&self) -> usize {
        self.entries.len()
    }

    /// Whether the map is empty.
    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }

    /// Whether `key` is present.
    pub fn contains_key(&self, key: &K) -> bool {
        self.entries.iter().any(|(k, _)| k == key)
    }

    /// The value of `key`.
    pub fn get(&self, key: &K) -> Option<&V> {
        self.entries.iter().find(|(k, _)| k == key).map(|(_, v)| v)
    }

    /// The value of `key`, mutably.
    pub fn get_mut(&mut self, key: &K) -> Option<&mut V> {
        self.entries.iter_mut().find(|(k, _)| k == key).map(|(_, v)| v)
    }

    // In bounds: the entry was just pushed.
    #[allow(clippy::indexing_slicing)]
    fn push(&mut self, key: K, value: V) -> &mut V {
        if self.entries.len() == self.entries.capacity() {
            if self.entries.len() < EXACT_GROWTH_BELOW {
                self.entries.reserve_exact(1);
            } else {
                self.entries.reserve(1);
            }
        }
        self.entries.push((key, value));
        let last = self.entries.len() - 1;
        // In bounds: an entry was just pushed.
        &mut self.entries[last].1
    }

    /// Inserts or replaces; returns the previous value.
    pub fn insert(&mut self, key: K, value: V) -> Option<V> {
        if let Some(v) = self.get_mut(&key) {
            return Some(std::mem::replace(v, value));
        }
        self.push(key, value);
        None
    }

    /// The value of `key`, inserted with `make` if absent.
    // In bounds: `position` found the entry (a `get_mut` match cannot fall through to the insert).
    #[allow(clippy::indexing_slicing)]
    pub fn get_or_insert_with(&mut self, key: K, make: impl FnOnce() -> V) -> &mut V {
        match self.entries.iter().position(|(k, _)| *k == key) {
            // In bounds: `position` found it.
            Some(i) => &mut self.entries[i].1,
            None => self.push(key, make()),
        }
    }

    /// Removes `key` (order of the others is not kept); frees the storage when the map becomes empty.
    pub fn remove(&mut self, key: &K) -> Option<V> {
        let i = self.entries.iter().position(|(k, _)| k == key)?;
        let (_, v) = self.entries.swap_remove(i);
        if self.entries.is_empty() {
            self.entries = Vec::new();
        }
        Some(v)
    }

    /// Keys.
    pub fn keys(&self) -> impl Iterator<Item = &K> {
        self.entries.iter().map(|(k, _)| k)
    }

    /// Values.
    pub fn values(&self) -> impl Iterator<Item = &V> {
        self.entries.iter().map(|(_, v)| v)
    }

    /// Entries.
    pub fn iter(&self) -> impl Iterator<Item = (&K, &V)> {
        self.entries.iter().map(|(k, v)| (k, v))
    }

    /// Entries, mutably.
    pub fn iter_mut(&mut self) -> impl Iterator<Item = (&K, &mut V)> {
        self.entries.iter_mut().map(|(k, v)| (&*k, v))
    }

    /// Takes every entry out.
    pub fn drain(&mut self) -> impl Iterator<Item = (K, V)> {
        std::mem::take(&mut self.entries).into_iter()
    }
}

impl<'a, K: Copy + Eq, V> IntoIterator for &'a VecMap<K, V> {
    type Item = (&'a K, &'a V);
    type IntoIter = std::iter::Map<std::slice::Iter<'a, (K, V)>, fn(&'a (K, V)) -> (&'a K, &'a V)>;

    fn into_iter(self) -> Self::IntoIter {
        self.entries.iter().map(|(k, v)| (k, v))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn behaves_as_a_map() {
        let mut m: VecMap<u8, u32> = VecMap::default();
        assert_eq!(m.insert(1, 10), None);
        assert_eq!(m.insert(1, 11), Some(10));
        *m.get_or_insert_with(2, || 20) += 1;
        assert_eq!(m.get(&2), Some(&21));
        assert_eq!(m.len(), 2);
        assert_eq!(m.remove(&1), Some(11));
        assert_eq!(m.remove(&1), None);
        assert_eq!(m.drain().collect::<Vec<_>>(), vec![(2, 21)]);
        assert!(m.is_empty());
    }
}
