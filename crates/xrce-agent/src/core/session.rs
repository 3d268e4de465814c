//! Per-session state a [`Connection`](super::connection::Connection) is made of: its streams, why its
//! readers stopped holding writers back, where a held message resumes, and the CREATE_CLIENT properties
//! the agent reads.

use std::time::Duration;

use super::stream::{BestEffortIn, BestEffortOut, ReliableIn, ReliableOut};
use super::vecmap::VecMap;

/// Streams of a session, created on first use.
#[derive(Debug, Default)]
pub struct Streams {
    /// Best-effort input streams.
    pub be_in: VecMap<u8, BestEffortIn>,
    /// Reliable input streams.
    pub rel_in: VecMap<u8, ReliableIn>,
    /// Best-effort output streams.
    pub be_out: VecMap<u8, BestEffortOut>,
    /// Reliable output streams.
    pub rel_out: VecMap<u8, ReliableOut>,
}

impl Streams {
    /// Number of streams of all kinds.
    pub fn count(&self) -> usize {
        self.be_in.len() + self.rel_in.len() + self.be_out.len() + self.rel_out.len()
    }

    /// Bytes held in reliable input buffers.
    pub fn buffered(&self) -> usize {
        self.rel_in.values().map(ReliableIn::buffered).sum()
    }
}

/// Where the processing of a held reliable message resumes.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct Resume {
    /// Index of the submessage that could not run yet.
    pub at: usize,
    /// When that submessage was the last FRAGMENT of a message: the rebuilt message and where in it.
    pub inner: Option<(Vec<u8>, usize)>,
}

/// Why a client's reliable readers no longer hold writers back (back-pressure, see
/// [`Middleware::write_credit`](crate::middleware::Middleware::write_credit)).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Unpinned {
    /// Silent past its dead time; pinned again when heard from.
    Dead,
    /// Its reliable output made no progress for the dead time (it does not acknowledge); pinned again when
    /// an ACKNACK acknowledges something.
    Stalled,
}

/// CREATE_CLIENT property a client sets to `1` when it reads every submessage of a message (eProsima's C
/// client does not after a DATA): the agent then packs several samples per message.
pub const PACK_PROPERTY: &str = "xrce_rs_pack";

/// CREATE_CLIENT property our client sends when it re-creates a session it lost (reconnection): if this
/// agent still holds that session (same key and session id), it keeps its streams instead of resetting them
/// and answers `STATUS_OK_MATCHED`, so the client resumes where it was and nothing is delivered twice (a
/// TCP client's new connection cannot be matched to its session otherwise). eProsima's agent ignores it and
/// answers `OK`, as it does to any CREATE_CLIENT; a client that rebooted does not send it.
pub const RESUME_PROPERTY: &str = "xrce_rs_resume";

/// Parses the `uxr_hl` value: milliseconds as decimal digits.
pub fn parse_hard_liveliness(value: &str) -> Option<Duration> {
    let ms: u64 = value.trim().parse().ok()?;
    (ms > 0).then(|| Duration::from_millis(ms))
}
