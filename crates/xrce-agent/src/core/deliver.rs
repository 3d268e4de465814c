//! A connection's read tasks (spec §6.8, §10.3 READ_DATA): samples taken from the middleware through its
//! visitor within the task's delivery control. On a best-effort stream (or stream 0) the visitor copies the
//! sample once, straight into the outgoing message; on a reliable stream into a DATA submessage the stream
//! queues until the endpoint asks for the client's next message and the window lets it build one.

use std::fmt::Debug;
use std::hash::Hash;
use std::time::Instant;

use xrce_proto::layout::{submessage_offset, DataSubmessage};
use xrce_proto::{BaseObjectRequest, ClientKey, MessageHeader, ObjectId};

use super::connection::{Connection, Ctx};
use super::outbox::Control;
use super::stats::{add, bump, ClientTotals};
use crate::middleware::{EntityRef, Middleware, SampleRef};

/// Samples one read task may send per turn on a best-effort stream (reliable streams are bounded by their
/// window).
const MAX_SAMPLES_PER_PUMP: usize = 64;

impl<E: Copy + Eq + Hash + Debug> Connection<E> {
    /// Delivers samples for every active read task while its stream has room.
    pub(crate) fn pump_reads<M: Middleware>(&mut self, ctx: &mut Ctx<'_, E, M>, now: Instant) {
        let mut readers: [Option<ObjectId>; 8] = [None; 8];
        let mut rest: Vec<ObjectId> = Vec::new();
        for (i, id) in self.reads.keys().enumerate() {
            match readers.get_mut(i) {
                Some(slot) => *slot = Some(*id),
                None => rest.push(*id),
            }
        }
        for reader in readers.into_iter().flatten().chain(rest) {
            self.pump_reader(ctx, reader, now);
        }
    }

    /// Delivers the samples one read task may take now. On a reliable stream samples are queued while what
    /// waits fits the stream's window; the messages are built, several samples each when the client reads
    /// packed messages, when the endpoint asks for them.
    fn pump_reader<M: Middleware>(&mut self, ctx: &mut Ctx<'_, E, M>, reader: ObjectId, now: Instant) {
        let reliable = self.reads.get(&reader).map(|t| t.stream).filter(|s| s.is_reliable());
        let entity = EntityRef::new(self.key, reader);
        for _ in 0..MAX_SAMPLES_PER_PUMP {
            if let Some(stream) = reliable {
                let pack_mtu = self.pack_mtu();
                if self.streams.rel_out.get(&stream.0).is_some_and(|s| !s.can_take(pack_mtu)) {
                    return;
                }
            }
            let Some(task) = self.reads.get_mut(&reader) else { return };
            if task.finished(now) {
                self.reads.remove(&reader);
                ctx.middleware.stop_reading(entity);
                return;
            }
            task.expire_timers(now);
            let (stream, request) = (task.stream, task.request);
            let taken = if stream.is_reliable() {
                // Queued on the reliable stream, which builds its messages when its window allows.
                let mut sub = None;
                let pool = &mut *ctx.pool;
                let key = self.key;
                let counters = &mut self.counters;
                let taken = ctx.middleware.poll_sample(entity, &mut |sample| {
                    let size = sample.wire_size();
                    if task.ready(size, now).is_err() {
                        return false;
                    }
                    let mut buf = pool.get();
                    if append_data(&mut buf, key, request, &sample) {
                        sub = Some(buf);
                    } else {
                        pool.put(buf);
                    }
                    task.sent(size, now);
                    count_out(counters, size);
                    true
                });
                if let Some(sub) = sub {
                    self.send_on_stream(ctx, stream, sub, now);
                }
                taken
            } else {
                self.deliver_unreliable(ctx, entity, stream, request, now)
            };
            if taken != Some(true) {
                return;
            }
        }
    }

    /// Takes one sample for a read task on stream 0 or a best-effort stream, copied once: straight into the
    /// client's open best-effort message when it fits (packing), or into a new message.
    fn deliver_unreliable<M: Middleware>(
        &mut self,
        ctx: &mut Ctx<'_, E, M>,
        entity: EntityRef,
        stream: xrce_proto::StreamId,
        request: BaseObjectRequest,
        now: Instant,
    ) -> Option<bool> {
        let best_effort = stream.kind() == xrce_proto::StreamKind::BestEffort;
        let pack = self.pack_data && best_effort;
        let (key, mtu, header) = (self.key, self.mtu, self.header(stream, 0));
        let task = self.reads.get_mut(&entity.id)?;
        let (outbox, be_out, pool, stats, counters) =
            (&mut self.outbox, &mut self.streams.be_out, &mut *ctx.pool, &mut *ctx.stats, &mut self.counters);
        let mut new_message = None;
        let taken = ctx.middleware.poll_sample(entity, &mut |sample| {
            let size = sample.wire_size();
            if task.ready(size, now).is_err() {
                return false;
            }
            task.sent(size, now);
            count_out(counters, size);
            let sub_len = DataSubmessage::data(request, sample.body(request.object_id)).encoded_len();
            if let Some(last) = outbox.open_message(stream.0).filter(|_| pack) {
                let (len, at) = (last.len(), submessage_offset(last.len()));
                if at + sub_len <= mtu {
                    last.resize(at, 0);
                    if !append_data(last, key, request, &sample) {
                        last.truncate(len);
                    }
                    return true;
                }
            }
            if header.size() + sub_len > mtu {
                tracing::debug!(client = %key, stream = stream.0, len = sub_len, "message over the MTU on an unreliable stream dropped");
                stats.messages_dropped_out = stats.messages_dropped_out.saturating_add(1);
                return true;
            }
            let seq = if best_effort { be_out.get_or_insert_with(stream.0, Default::default).next_seq() } else { 0 };
            let mut msg = pool.get();
            msg.resize(header.size(), 0);
            if (MessageHeader { sequence_nr: seq, ..header }).encode(&mut msg).is_ok()
                && append_data(&mut msg, key, request, &sample)
            {
                new_message = Some(msg);
            } else {
                pool.put(msg);
            }
            true
        });
        if let Some(msg) = new_message {
            if best_effort {
                self.push_stream(ctx, msg);
                self.outbox.leave_open(stream.0);
            } else {
                self.push_control(ctx, Control::Message(msg));
            }
        }
        taken
    }
}

/// Counts a sample of `size` bytes taken for the client.
fn count_out(counters: &mut ClientTotals, size: usize) {
    bump(&mut counters.samples_out);
    add(&mut counters.bytes_out, size);
}

/// Appends a sample as one DATA submessage (spec §6.8), header included, to `buf`, written in place; false
/// (logged, nothing appended) when it is too large for one submessage.
fn append_data(buf: &mut Vec<u8>, key: ClientKey, request: BaseObjectRequest, sample: &SampleRef<'_>) -> bool {
    let sub = DataSubmessage::data(request, sample.body(request.object_id));
    if !sub.fits_one_submessage() {
        tracing::warn!(client = %key, size = sub.encoded_len(), "sample too large for one DATA submessage, dropped");
        return false;
    }
    let start = buf.len();
    buf.resize(start + sub.encoded_len(), 0);
    match buf.get_mut(start..).map(|out| sub.emit_into(out)) {
        Some(Ok(_)) => true,
        other => {
            tracing::warn!(client = %key, "cannot write a DATA submessage: {other:?}");
            buf.truncate(start);
            false
        }
    }
}
