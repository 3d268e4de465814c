//! A connection's entities: CREATE with its creation modes (spec §11) and DELETE of a subtree.

use std::fmt::Debug;
use std::hash::Hash;
use std::time::Instant;

use xrce_proto::submessage::CreationMode;
use xrce_proto::{Endianness, EntityVariant, ObjectId, StatusCode};

use super::connection::{Connection, Ctx};
use super::object::is_entity_kind;
use crate::middleware::{Creation, EntityRef, Middleware};

impl<E: Copy + Eq + Hash + Debug> Connection<E> {
    /// CREATE semantics with creation modes (spec §11), shared with the library API.
    pub(crate) fn create_object<M: Middleware>(
        &mut self,
        ctx: &mut Ctx<'_, E, M>,
        id: ObjectId,
        variant: &EntityVariant<'_>,
        mode: CreationMode,
        endian: Endianness,
        now: Instant,
    ) -> StatusCode {
        let kind = variant.kind;
        if !is_entity_kind(kind) {
            return StatusCode::ERR_DDS_ERROR;
        }
        let id = id.with_kind(kind);
        let parent = match (variant.parent(), kind.parent()) {
            (Some(p), Some(parent_kind)) => Some(p.with_kind(parent_kind)),
            _ => None,
        };
        if parent.is_some_and(|p| !self.objects.contains(p)) {
            return StatusCode::ERR_UNKNOWN_REFERENCE;
        }
        let exists = self.objects.contains(id);
        if !exists && self.objects.len() >= ctx.config.max_objects_per_client {
            return StatusCode::ERR_RESOURCES;
        }
        let key = self.key;
        let creation = Creation {
            entity: EntityRef::new(key, id),
            parent: parent.map(|p| EntityRef::new(key, p)),
            variant,
            endian,
            now,
        };
        if exists {
            match (mode.reuse, mode.replace) {
                (false, false) => return StatusCode::ERR_ALREADY_EXISTS,
                (true, replace) => {
                    if ctx.middleware.matches(&creation) {
                        return StatusCode::OK_MATCHED;
                    }
                    if !replace {
                        return StatusCode::ERR_MISMATCH;
                    }
                }
                (false, true) => {}
            }
            self.delete_object(ctx, id);
        }
        match ctx.middleware.create(&creation) {
            Ok(()) => {
                self.objects.insert(id, parent);
                tracing::debug!(client = %key, %id, ?kind, "entity created");
                StatusCode::OK
            }
            Err(e) => {
                // Every failure stays visible at debug level; warnings are rate-limited, as a client may
                // send CREATEs that fail in a loop.
                match ctx.admit_warning(self.endpoint, now) {
                    Some(held_back) => {
                        tracing::warn!(peer = ?self.endpoint, client = %key, %id, ?kind, held_back, "entity creation failed: {e}");
                    }
                    None => tracing::debug!(client = %key, %id, ?kind, "entity creation failed: {e}"),
                }
                e.status()
            }
        }
    }

    /// Deletes an object and everything below it.
    pub(crate) fn delete_object<M: Middleware>(&mut self, ctx: &mut Ctx<'_, E, M>, id: ObjectId) -> StatusCode {
        if !self.objects.contains(id) {
            return StatusCode::ERR_UNKNOWN_REFERENCE;
        }
        for victim in self.objects.subtree(id) {
            let entity = EntityRef::new(self.key, victim);
            if self.reads.remove(&victim).is_some() {
                ctx.middleware.stop_reading(entity);
            }
            if let Err(e) = ctx.middleware.delete(entity) {
                tracing::debug!(client = %self.key, id = %victim, "middleware delete failed: {e}");
            }
            self.objects.remove(victim);
        }
        StatusCode::OK
    }
}
