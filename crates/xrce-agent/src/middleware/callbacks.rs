//! User callbacks on entity creation and deletion (eProsima's `add_middleware_callback`), as a middleware
//! decorator. Unlike eProsima, where only the participant callbacks fire, every kind listed fires.

use std::sync::{Arc, RwLock};
use std::time::Instant;

use xrce_proto::{ClientKey, ObjectKind, RequestId, SampleIdentity};

use super::{Creation, EntityRef, Middleware, MiddlewareError, SampleVisitor, Waker, WriteOutcome};

/// When a callback fires (eProsima's `middleware::CallbackKind`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[allow(missing_docs)]
pub enum CallbackKind {
    CreateParticipant,
    CreateDataWriter,
    CreateDataReader,
    CreateRequester,
    CreateReplier,
    DeleteParticipant,
    DeleteDataWriter,
    DeleteDataReader,
    DeleteRequester,
    DeleteReplier,
}

impl CallbackKind {
    /// The kind for creating (`created`) or deleting an entity of `kind`, if callbacks exist for it.
    pub const fn for_entity(kind: ObjectKind, created: bool) -> Option<Self> {
        Some(match (kind, created) {
            (ObjectKind::Participant, true) => Self::CreateParticipant,
            (ObjectKind::DataWriter, true) => Self::CreateDataWriter,
            (ObjectKind::DataReader, true) => Self::CreateDataReader,
            (ObjectKind::Requester, true) => Self::CreateRequester,
            (ObjectKind::Replier, true) => Self::CreateReplier,
            (ObjectKind::Participant, false) => Self::DeleteParticipant,
            (ObjectKind::DataWriter, false) => Self::DeleteDataWriter,
            (ObjectKind::DataReader, false) => Self::DeleteDataReader,
            (ObjectKind::Requester, false) => Self::DeleteRequester,
            (ObjectKind::Replier, false) => Self::DeleteReplier,
            _ => return None,
        })
    }
}

/// A callback: gets the event kind and the entity.
pub type Callback = Arc<dyn Fn(CallbackKind, EntityRef) + Send + Sync>;

/// Callbacks shared between a [`WithCallbacks`] and whoever registers them (the library API), so they
/// can be added while the agent runs.
pub type CallbackRegistry = Arc<RwLock<Vec<(CallbackKind, Callback)>>>;

/// Wraps a middleware and calls the registered callbacks after each successful create/delete.
pub struct WithCallbacks<M> {
    inner: M,
    callbacks: CallbackRegistry,
}

impl<M> std::fmt::Debug for WithCallbacks<M> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("WithCallbacks").finish_non_exhaustive()
    }
}

impl<M: Middleware> WithCallbacks<M> {
    /// `inner` with no callbacks yet.
    pub fn new(inner: M) -> Self {
        Self { inner, callbacks: CallbackRegistry::default() }
    }

    /// `inner` calling the callbacks of `registry`.
    pub fn with_registry(inner: M, registry: CallbackRegistry) -> Self {
        Self { inner, callbacks: registry }
    }

    /// Adds a callback for `kind`.
    pub fn add(&self, kind: CallbackKind, callback: Callback) {
        self.callbacks.write().unwrap_or_else(std::sync::PoisonError::into_inner).push((kind, callback));
    }

    /// The wrapped middleware.
    pub fn inner(&self) -> &M {
        &self.inner
    }

    fn fire(&self, entity: EntityRef, created: bool) {
        let Some(kind) = CallbackKind::for_entity(entity.kind(), created) else { return };
        // Clone out of the lock so a callback may register another one.
        let matching: Vec<Callback> = self
            .callbacks
            .read()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
            .iter()
            .filter(|(k, _)| *k == kind)
            .map(|(_, cb)| cb.clone())
            .collect();
        for cb in matching {
            cb(kind, entity);
        }
    }
}

impl<M: Middleware> Middleware for WithCallbacks<M> {
    fn create(&mut self, creation: &Creation<'_>) -> Result<(), MiddlewareError> {
        self.inner.create(creation)?;
        self.fire(creation.entity, true);
        Ok(())
    }
    fn matches(&self, creation: &Creation<'_>) -> bool {
        self.inner.matches(creation)
    }
    fn delete(&mut self, entity: EntityRef) -> Result<(), MiddlewareError> {
        self.inner.delete(entity)?;
        self.fire(entity, false);
        Ok(())
    }
    fn delete_client(&mut self, client: ClientKey) {
        self.inner.delete_client(client);
    }
    fn write_data(&mut self, writer: EntityRef, data: &[u8], now: Instant) -> Result<WriteOutcome, MiddlewareError> {
        self.inner.write_data(writer, data, now)
    }
    fn write_request(
        &mut self,
        requester: EntityRef,
        id: RequestId,
        data: &[u8],
        now: Instant,
    ) -> Result<WriteOutcome, MiddlewareError> {
        self.inner.write_request(requester, id, data, now)
    }
    fn write_reply(
        &mut self,
        replier: EntityRef,
        identity: &SampleIdentity,
        data: &[u8],
        now: Instant,
    ) -> Result<WriteOutcome, MiddlewareError> {
        self.inner.write_reply(replier, identity, data, now)
    }
    fn start_reading(&mut self, reader: EntityRef) -> Result<(), MiddlewareError> {
        self.inner.start_reading(reader)
    }
    fn stop_reading(&mut self, reader: EntityRef) {
        self.inner.stop_reading(reader);
    }
    fn poll_sample(&mut self, reader: EntityRef, visit: &mut SampleVisitor<'_>) -> Option<bool> {
        self.inner.poll_sample(reader, visit)
    }
    fn poll(&mut self, now: Instant) {
        self.inner.poll(now);
    }
    fn flush(&mut self, now: Instant) {
        self.inner.flush(now);
    }
    fn flush_due(&self) -> Option<Instant> {
        self.inner.flush_due()
    }
    fn set_waker(&mut self, waker: Waker) {
        self.inner.set_waker(waker);
    }
    fn write_credit(&mut self, writer: EntityRef, now: Instant) -> u32 {
        self.inner.write_credit(writer, now)
    }
    fn set_reader_reliable(&mut self, reader: EntityRef, reliable: bool) {
        self.inner.set_reader_reliable(reader, reliable);
    }
    fn stats(&self) -> super::MiddlewareStats {
        self.inner.stats()
    }
    fn client_name(&self, client: xrce_proto::ClientKey) -> Option<String> {
        self.inner.client_name(client)
    }
    fn on_snapshot(&mut self, snapshot: &crate::core::AgentSnapshot, now: Instant) {
        self.inner.on_snapshot(snapshot, now);
    }
}
