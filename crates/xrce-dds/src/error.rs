//! Errors of the DDS bridge. They are coarse on purpose: the agent core only needs to pick a STATUS code
//! (unknown reference, resources, DDS error), and the text is logged.

/// Why a bridge operation failed.
#[derive(Debug, thiserror::Error)]
pub enum DdsError {
    /// RustDDS refused to create an entity (participant, topic, publisher, subscriber, endpoint).
    #[error("cannot create {what}: {reason}")]
    Create {
        /// Which entity.
        what: &'static str,
        /// RustDDS' reason.
        reason: String,
    },
    /// A topic of that name already exists on the participant with another type name or key kind; DDS
    /// allows one type per topic name and participant.
    #[error("topic {name:?} already exists with type {existing_type:?} (keyed: {existing_keyed})")]
    TopicMismatch {
        /// Topic name.
        name: String,
        /// Type name it was created with.
        existing_type: String,
        /// Whether it was created keyed.
        existing_keyed: bool,
    },
    /// The domain id cannot be used (RustDDS maps domains to UDP ports; ids above 232 overflow them).
    #[error("invalid domain id {0}")]
    InvalidDomain(i32),
    /// A reliable write waited `max_blocking_time` for room in the send window (back-pressure), or a
    /// bounded table is full.
    #[error("out of resources: {0}")]
    Resources(String),
    /// A write failed for another reason (serialization, I/O, RustDDS internal).
    #[error("write failed: {0}")]
    Write(String),
    /// The bridge's reader dispatcher thread is gone (it only stops when its participant is dropped).
    #[error("reader dispatcher stopped")]
    DispatcherStopped,
    /// An I/O error from the poll machinery.
    #[error("i/o: {0}")]
    Io(#[from] std::io::Error),
}
