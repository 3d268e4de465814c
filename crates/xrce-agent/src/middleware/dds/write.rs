//! The write path of [`Dds`]: a sample written now, or handed ahead to the agent's own readers and
//! published once the shell has sent; held best-effort samples replayed; a full DDS history answered
//! [`WriteOutcome::WouldBlock`].

use super::*;

impl Dds {
    /// Publishes through the DDS writer, or hands the sample ahead to the agent's own readers and publishes
    /// it once the shell has sent ([`Self::write_after_send`]); a full history is [`WriteOutcome::WouldBlock`]
    /// (see [`WOULD_BLOCK_RETRY`]).
    pub(super) fn write_now(
        &mut self,
        writer: EntityRef,
        data: &[u8],
        now: Instant,
    ) -> Result<WriteOutcome, MiddlewareError> {
        if self.write_after_send(writer, data, now) {
            return Ok(WriteOutcome::Accepted);
        }
        // Samples waiting for the flush were written first.
        self.flush_writes(now);
        self.write_dds(writer, data, now)
    }

    /// The hop between two clients of the agent without the DDS write on its way: a sample of a datawriter
    /// whose DDS writer is matched with datareaders of the agent's own clients (reliable, with a reliable read
    /// task, that already received from it) is queued at those readers at once, and the DDS write, which Fast
    /// DDS would have made deliver it to them inside the write (some 5 µs hot, 10–15 µs in the agent between
    /// two datagrams), is made by [`Middleware::flush`] after the shell sent the turn's messages; the readers
    /// drop Fast DDS' copy ([`RawReader::deliver_ahead`]). Remote readers get it then, a turn's sends later.
    /// What DDS would deliver is unchanged: the same samples, per writer in the same order (a reader gets
    /// samples ahead only while its queue has room and is not paused, and only while every sample of the
    /// writer still waiting was queued ahead to it too), once each; the write cannot be refused (keep-last).
    /// False when nothing went ahead (the caller writes now).
    pub(super) fn write_after_send(&mut self, writer: EntityRef, data: &[u8], now: Instant) -> bool {
        if self.pinned.is_empty() || self.gates.contains_key(&writer) || self.held.contains_key(&writer) {
            return false;
        }
        let Some(Node { handle: Handle::Writer(state), .. }) = self.entities.get(&writer).map(|n| &**n) else {
            return false;
        };
        if !state.ahead {
            return false;
        }
        let guid = state.writer.guid();
        // Only samples that went ahead wait, so a DDS writer without an entry has none waiting.
        let earlier = self.ahead_to.get(&guid);
        let mut to = Vec::new();
        for r in &self.pinned {
            let Some(Node { handle: Handle::Reader(rs), .. }) = self.entities.get(r).map(|n| &**n) else { continue };
            if !rs.reliable || rs.topic != state.topic || earlier.is_some_and(|e| !e.contains(r)) {
                continue;
            }
            // A reader that has received from the writer is matched with it (neither was recreated since).
            if rs.reader.queue().progress_from(&guid).is_some() && rs.reader.deliver_ahead(&guid, data) {
                to.push(*r);
            }
        }
        if to.is_empty() {
            return false;
        }
        self.ahead_to.insert(guid, to);
        self.after_send.push_back((writer, data.to_vec()));
        self.after_send_since.get_or_insert(now);
        true
    }

    /// [`Self::flush_writes`] where no `now` is given (deletions): the samples are written as of when the
    /// oldest went ahead.
    pub(super) fn flush_pending(&mut self) {
        if let Some(since) = self.after_send_since {
            self.flush_writes(since);
        }
    }

    /// Makes the DDS writes of the samples that went ahead ([`Self::write_after_send`]), in order.
    pub(super) fn flush_writes(&mut self, now: Instant) {
        if self.after_send.is_empty() {
            return;
        }
        self.ahead_to.clear();
        self.after_send_since = None;
        while let Some((writer, data)) = self.after_send.pop_front() {
            match self.write_dds(writer, &data, now) {
                Ok(WriteOutcome::Accepted) => {}
                // Keep-last writers are never refused; if Fast DDS did, its own readers got the sample already.
                outcome => tracing::warn!(
                    ?writer,
                    ?outcome,
                    "DDS write after the agent's readers got the sample failed: DDS readers outside the agent miss it"
                ),
            }
        }
    }

    /// Publishes through the DDS writer now.
    pub(super) fn write_dds(
        &mut self,
        writer: EntityRef,
        data: &[u8],
        now: Instant,
    ) -> Result<WriteOutcome, MiddlewareError> {
        let node = self.entities.get_mut(&writer).ok_or_else(|| unknown(writer))?;
        let Handle::Writer(state) = &mut node.handle else {
            return Err(MiddlewareError::Unsupported(format!("{writer:?} is not a datawriter")));
        };
        let WriterState { writer: w, written, .. } = &mut **state;
        match w.write(data) {
            Ok(id) => {
                if let Some(Gate { acks: Acks::Watching { left, .. }, .. }) = self.gates.get_mut(&writer) {
                    *left = left.saturating_sub(1);
                }
                let seq = id.sequence_number;
                match written {
                    Some(wr) => wr.last_seq = wr.last_seq.max(seq),
                    None => *written = Some(Written { first_seq: seq, first_at: now, last_seq: seq }),
                }
                Ok(WriteOutcome::Accepted)
            }
            Err(e) => self.refused(writer, e, now),
        }
    }

    /// A write the engine refused: a full history asks the core to retry (and wakes it for that), anything
    /// else is an error.
    pub(super) fn refused(
        &mut self,
        entity: EntityRef,
        e: DdsError,
        now: Instant,
    ) -> Result<WriteOutcome, MiddlewareError> {
        match e {
            DdsError::Resources(m) => {
                tracing::debug!(?entity, "DDS write would block ({m}); the core retries");
                self.gate_timer.arm(now + WOULD_BLOCK_RETRY, self.waker.as_ref());
                Ok(WriteOutcome::WouldBlock)
            }
            e => {
                tracing::warn!(?entity, "DDS write failed, sample dropped: {e}");
                Err(dds_error(e))
            }
        }
    }

    /// Writes the best-effort samples held at `writer`'s (open) gate that are due by `now` (a failure is
    /// logged in [`Self::write_now`] and the rest still go); keeps the gate timer running for the others.
    pub(super) fn replay_held(&mut self, writer: EntityRef, now: Instant) {
        let Some(mut held) = self.held.remove(&writer) else { return };
        while let Some(sample) = held.pop_due(now) {
            // Best-effort samples: one the history cannot take now is dropped, as a best-effort write would be.
            let _ = self.write_now(writer, &sample, now);
        }
        if held.is_empty() {
            if held.dropped() > 0 {
                tracing::warn!(
                    ?writer,
                    dropped = held.dropped(),
                    "first-contact gate: best-effort samples dropped (bound reached)"
                );
            }
            return;
        }
        if let Some(due) = held.next_due() {
            self.gate_timer.arm(due, self.waker.as_ref());
        }
        self.held.insert(writer, held);
    }
}
