//! A middleware that cannot take a write now (a full DDS history) answers `WouldBlock` instead of blocking
//! the core: the core holds the client's reliable message unacknowledged and resumes it where it stopped
//! once the middleware polls, so every sample is written once, in order. Driven through the core with CED
//! behind a middleware that refuses writes past a budget.

mod common;

use std::cell::Cell;
use std::rc::Rc;
use std::sync::Arc;
use std::time::Instant;

use common::{create_client_msg, unlimited, Client, Harness, Out};
use xrce_agent::core::{AgentCore, CoreConfig};
use xrce_agent::middleware::ced::Ced;
use xrce_agent::middleware::describe::FallbackProfiles;
use xrce_agent::middleware::{Creation, EntityRef, Middleware, MiddlewareError, SampleVisitor, WriteOutcome};
use xrce_proto::submessage::{DataFormat, DataPayload};
use xrce_proto::{BaseObjectRequest, ObjectId, ObjectKind, RequestId, SampleIdentity, Submessage};

const PUB: u16 = 1;
const SUB: u16 = 2;

/// CED that accepts `budget` more writes, then answers `WouldBlock`.
struct Refusing {
    inner: Ced,
    budget: Rc<Cell<u32>>,
}

impl Refusing {
    fn admit(&self) -> bool {
        let left = self.budget.get();
        self.budget.set(left.saturating_sub(1));
        left > 0
    }
}

impl Middleware for Refusing {
    fn create(&mut self, c: &Creation<'_>) -> Result<(), MiddlewareError> {
        self.inner.create(c)
    }
    fn matches(&self, c: &Creation<'_>) -> bool {
        self.inner.matches(c)
    }
    fn delete(&mut self, e: EntityRef) -> Result<(), MiddlewareError> {
        self.inner.delete(e)
    }
    fn write_data(&mut self, w: EntityRef, d: &[u8], now: Instant) -> Result<WriteOutcome, MiddlewareError> {
        if !self.admit() {
            return Ok(WriteOutcome::WouldBlock);
        }
        self.inner.write_data(w, d, now)
    }
    fn write_request(
        &mut self,
        r: EntityRef,
        id: RequestId,
        d: &[u8],
        now: Instant,
    ) -> Result<WriteOutcome, MiddlewareError> {
        self.inner.write_request(r, id, d, now)
    }
    fn write_reply(
        &mut self,
        r: EntityRef,
        i: &SampleIdentity,
        d: &[u8],
        now: Instant,
    ) -> Result<WriteOutcome, MiddlewareError> {
        self.inner.write_reply(r, i, d, now)
    }
    fn start_reading(&mut self, r: EntityRef) -> Result<(), MiddlewareError> {
        self.inner.start_reading(r)
    }
    fn poll_sample(&mut self, r: EntityRef, visit: &mut SampleVisitor<'_>) -> Option<bool> {
        self.inner.poll_sample(r, visit)
    }
}

fn setup() -> (Harness<Refusing>, Rc<Cell<u32>>, Client) {
    let budget = Rc::new(Cell::new(u32::MAX));
    let middleware = Refusing { inner: Ced::new(Arc::new(FallbackProfiles)), budget: budget.clone() };
    let mut h = Harness::with_core(AgentCore::new(CoreConfig::default(), middleware));
    let mut p = Client::new(0x1111_1111);
    let mut s = Client::new(0x2222_2222);
    for (port, c) in [(PUB, &mut p), (SUB, &mut s)] {
        h.send(port, &create_client_msg(c.key, 0x81));
        for m in c.pubsub_entities("t") {
            h.send(port, &m);
        }
    }
    h.send(SUB, &s.read(ObjectId::new(1, ObjectKind::DataReader), 0x80, unlimited()));
    (h, budget, p)
}

fn write(p: &mut Client, data: &[u8]) -> Submessage<'static> {
    let mut request: BaseObjectRequest = p.next_request();
    request.object_id = ObjectId::new(1, ObjectKind::DataWriter);
    let data: &'static [u8] = Box::leak(data.to_vec().into_boxed_slice());
    Submessage::WriteData(DataPayload { request, format: DataFormat::DATA, data })
}

/// The first unacknowledged sequence number of the publisher's reliable stream 0x80, from the latest
/// ACKNACK it received.
fn acked_up_to(h: &Harness<Refusing>) -> Option<u16> {
    h.received.get(&PUB)?.iter().flat_map(|r| r.subs.iter()).rev().find_map(|o| match o {
        Out::AckNack { first, stream: 0x80, .. } => Some(*first),
        _ => None,
    })
}

#[test]
fn a_message_blocked_part_way_resumes_after_its_last_write_and_is_acknowledged_only_then() {
    let (mut h, budget, mut p) = setup();
    let before = acked_up_to(&h).expect("the entities were acknowledged");
    // One message, three samples; the middleware takes the first only.
    budget.set(1);
    let subs = [write(&mut p, b"one"), write(&mut p, b"two"), write(&mut p, b"three")];
    h.send(PUB, &p.encode_many(true, &subs));
    assert_eq!(h.data(SUB), vec![b"one".to_vec()], "the first write went through");
    assert_eq!(acked_up_to(&h), Some(before), "the held message is not acknowledged");
    // Still no room: a retry takes nothing and repeats nothing.
    h.core.poll_middleware(h.now);
    h.drain();
    assert_eq!(h.data(SUB).len(), 1);
    // Room again: the middleware's poll resumes the message at its second write.
    budget.set(u32::MAX);
    h.core.poll_middleware(h.now);
    h.drain();
    assert_eq!(h.data(SUB), vec![b"one".to_vec(), b"two".to_vec(), b"three".to_vec()], "each once, in order");
    assert_eq!(acked_up_to(&h), Some(before.wrapping_add(1)), "acknowledged once processed");
    // The stream goes on.
    let four = write(&mut p, b"four");
    h.send(PUB, &p.encode_many(true, &[four]));
    assert_eq!(h.data(SUB).last().map(Vec::as_slice), Some(&b"four"[..]));
}

#[test]
fn a_fragmented_write_that_would_block_is_written_once_when_room_comes() {
    let (mut h, budget, mut p) = setup();
    let sample: Vec<u8> = (0..1500u32).map(|i| i as u8).collect();
    budget.set(0);
    for m in p.write_fragmented(ObjectId::new(1, ObjectKind::DataWriter), &sample, 3) {
        h.send(PUB, &m);
    }
    // A later message on the same stream waits behind the held one.
    let after = write(&mut p, b"after");
    h.send(PUB, &p.encode_many(true, &[after]));
    assert!(h.data(SUB).is_empty(), "nothing written while there is no room");
    budget.set(u32::MAX);
    h.core.poll_middleware(h.now);
    h.drain();
    assert_eq!(h.data(SUB), vec![sample, b"after".to_vec()], "the reassembled sample once, then the next");
}
