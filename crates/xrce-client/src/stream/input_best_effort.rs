//! Best-effort input stream (spec §9.2): newer messages are processed, older and duplicate ones dropped.

use super::seq;

/// A best-effort input stream: only its last handled sequence number.
#[derive(Debug, Clone, Copy)]
pub struct InputBestEffort {
    last_handled: u16,
}

impl Default for InputBestEffort {
    fn default() -> Self {
        Self::new()
    }
}

impl InputBestEffort {
    /// A fresh stream.
    pub const fn new() -> Self {
        Self { last_handled: seq::INIT }
    }

    /// Restarts numbering (session (re)creation).
    pub fn reset(&mut self) {
        self.last_handled = seq::INIT;
    }

    /// Whether message `seq_nr` is newer than the last one handled; if so it becomes the last handled.
    pub fn accept(&mut self, seq_nr: u16) -> bool {
        if seq::lt(self.last_handled, seq_nr) {
            self.last_handled = seq_nr;
            true
        } else {
            false
        }
    }
}
