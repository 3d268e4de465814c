//! A client's object table: which entities exist and what hangs from what (spec §5.2, §11).

use xrce_proto::{ObjectId, ObjectKind};

use super::vecmap::VecMap;

/// Entry of the object table.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ObjectEntry {
    /// Parent object (participant, publisher, subscriber), for all kinds but participants.
    pub parent: Option<ObjectId>,
}

/// The objects of one client, keyed by full object id (number and kind).
#[derive(Debug, Clone, Default)]
pub struct ObjectTable {
    objects: VecMap<ObjectId, ObjectEntry>,
}

/// Whether `kind` is one of the 8 kinds an agent creates.
pub const fn is_entity_kind(kind: ObjectKind) -> bool {
    matches!(
        kind,
        ObjectKind::Participant
            | ObjectKind::Topic
            | ObjectKind::Publisher
            | ObjectKind::Subscriber
            | ObjectKind::DataWriter
            | ObjectKind::DataReader
            | ObjectKind::Requester
            | ObjectKind::Replier
    )
}

impl ObjectTable {
    /// Number of objects.
    pub fn len(&self) -> usize {
        self.objects.len()
    }

    /// Every object's id.
    pub fn ids(&self) -> impl Iterator<Item = ObjectId> + '_ {
        self.objects.keys().copied()
    }

    /// Whether `id` exists.
    pub fn contains(&self, id: ObjectId) -> bool {
        self.objects.contains_key(&id)
    }

    /// Records `id`.
    pub fn insert(&mut self, id: ObjectId, parent: Option<ObjectId>) {
        self.objects.insert(id, ObjectEntry { parent });
    }

    /// Forgets `id` (children stay; use [`Self::subtree`] first).
    pub fn remove(&mut self, id: ObjectId) -> bool {
        self.objects.remove(&id).is_some()
    }

    /// `id` and everything below it, deepest first, so deleting in this order never orphans a middleware
    /// entity. Topics under a participant come after the writers and readers that may use them.
    pub fn subtree(&self, id: ObjectId) -> Vec<ObjectId> {
        let mut order = Vec::new();
        self.collect(id, &mut order, 0);
        order
    }

    fn collect(&self, id: ObjectId, order: &mut Vec<ObjectId>, depth: u8) {
        // The graph is at most 3 levels deep; the bound protects against a corrupted table.
        if depth < 4 {
            let mut children: Vec<ObjectId> =
                self.objects.iter().filter(|(_, e)| e.parent == Some(id)).map(|(c, _)| *c).collect();
            // Groups (publisher/subscriber) before topics, so endpoints go before the topics they use.
            children.sort_by_key(|c| match c.kind() {
                ObjectKind::Topic => 1,
                _ => 0,
            });
            for child in children {
                self.collect(child, order, depth + 1);
            }
        }
        order.push(id);
    }

    /// All root objects (participants), for deleting a whole client in order.
    pub fn roots(&self) -> Vec<ObjectId> {
        self.objects.iter().filter(|(_, e)| e.parent.is_none()).map(|(id, _)| *id).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn subtree_is_deepest_first() {
        let mut t = ObjectTable::default();
        let p = ObjectId::new(1, ObjectKind::Participant);
        let topic = ObjectId::new(1, ObjectKind::Topic);
        let publisher = ObjectId::new(1, ObjectKind::Publisher);
        let w = ObjectId::new(1, ObjectKind::DataWriter);
        t.insert(p, None);
        t.insert(topic, Some(p));
        t.insert(publisher, Some(p));
        t.insert(w, Some(publisher));
        assert_eq!(t.subtree(p), vec![w, publisher, topic, p]);
        assert_eq!(t.roots(), vec![p]);
    }
}
