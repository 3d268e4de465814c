//! A connection's read tasks (spec §6.8, §10.3 READ_DATA): samples taken from the middleware through its
//! visitor, copied once into a DATA submessage, sent on the task's stream within its delivery control.

use std::fmt::Debug;
use std::hash::Hash;
use std::time::Instant;

use xrce_proto::view::{RequestHead, SubmessageId};
use xrce_proto::{BaseObjectRequest, ClientKey, Endianness, ObjectId};

use super::connection::{Connection, Ctx};
use crate::bufpool::BufPool;
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

    /// Delivers the samples one read task may take now. On a reliable stream samples are queued and packed
    /// several per message (a message's worth at a time) while the window has room.
    fn pump_reader<M: Middleware>(&mut self, ctx: &mut Ctx<'_, E, M>, reader: ObjectId, now: Instant) {
        let reliable = self.reads.get(&reader).map(|t| t.stream).filter(|s| s.is_reliable());
        self.pumping = true;
        self.pump_reader_inner(ctx, reader, reliable, now);
        self.pumping = false;
        if let Some(stream) = reliable {
            self.flush_stream(ctx, stream, now);
        }
    }

    fn pump_reader_inner<M: Middleware>(
        &mut self,
        ctx: &mut Ctx<'_, E, M>,
        reader: ObjectId,
        reliable: Option<xrce_proto::StreamId>,
        now: Instant,
    ) {
        let entity = EntityRef::new(self.key, reader);
        for _ in 0..MAX_SAMPLES_PER_PUMP {
            if let Some(stream) = reliable {
                let pack_mtu = self.pack_mtu();
                let state = self.streams.rel_out.get(&stream.0);
                if state.is_some_and(|s| s.pending_bytes() >= pack_mtu && s.has_window_room()) {
                    self.flush_stream(ctx, stream, now);
                }
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
            // The sample is copied once, from the middleware into the DATA submessage; left in place when the
            // read's pace does not allow it yet.
            let mut sub = None;
            let pool = &mut *ctx.pool;
            let key = self.key;
            let taken = ctx.middleware.poll_sample(entity, &mut |sample| {
                let size = sample.wire_size();
                if task.ready(size, now).is_err() {
                    return false;
                }
                sub = data_submessage(key, request, &sample, pool);
                task.sent(size, now);
                true
            });
            if taken != Some(true) {
                return;
            }
            if let Some(sub) = sub {
                self.send_on_stream(ctx, stream, sub, now);
            }
        }
    }
}

/// A sample as one DATA submessage (spec §6.8), header included, in a buffer of `pool`; `None` (logged)
/// when it is too large for one submessage.
fn data_submessage(
    key: ClientKey,
    request: BaseObjectRequest,
    sample: &SampleRef<'_>,
    pool: &mut BufPool,
) -> Option<Vec<u8>> {
    let head = RequestHead::data(SubmessageId::Data, request, sample.wire_size());
    let Some(head_bytes) = head.to_bytes() else {
        tracing::warn!(client = %key, size = head.encoded_len(), "sample too large for one DATA submessage, dropped");
        return None;
    };
    let mut sub = pool.get();
    sub.extend_from_slice(&head_bytes);
    match *sample {
        SampleRef::Data(d) => sub.extend_from_slice(d),
        SampleRef::Request { identity, data } => {
            let mut id_buf = [0u8; xrce_proto::SampleIdentity::SIZE];
            let mut w = xrce_proto::cdr::Writer::new(&mut id_buf, Endianness::Little);
            w.write(&identity);
            sub.extend_from_slice(&id_buf);
            sub.extend_from_slice(data);
        }
        SampleRef::Reply { request_id, data } => {
            // A reply starts with the request it answers (eProsima's requester format).
            let related = BaseObjectRequest { request_id, object_id: request.object_id };
            sub.extend_from_slice(&related.to_bytes());
            sub.extend_from_slice(data);
        }
    }
    Some(sub)
}
