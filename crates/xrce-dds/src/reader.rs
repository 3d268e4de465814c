//! Delivery of received samples to the agent without polling loops.
//!
//! Each participant runs one dispatcher thread that waits on a `mio` poll in which every RustDDS reader of
//! the participant is registered. When RustDDS signals new data, the dispatcher takes it in batches (never
//! one `take_next_sample` at a time: RustDDS' sample cache scans all queued samples per call, which degrades
//! to tens of samples/s with 100k queued) and appends it to the reader's bounded [`SampleQueue`], then calls
//! the queue's waker. The agent drains queues from its own thread whenever it is woken; it never spins.
//!
//! Back-pressure: a queue holds at most its capacity (see [`EndpointQos::queue_capacity`]). When it is full
//! the dispatcher stops taking from that reader, so samples stay in RustDDS; once the agent has drained
//! half the queue, the dispatcher resumes. RustDDS' topic cache evicts its oldest samples past its resource
//! limit *whether or not they were taken*, and a RustDDS reliable reader acknowledges a sample as soon as
//! it is in that cache, so a stalled queue loses samples after all. The agent therefore holds local
//! writers back itself: each queue records, per writer GUID, the last sequence number it received
//! ([`SampleQueue::progress_from`]), from which the agent knows how many samples of its own writer are
//! still in flight towards a queue (see the agent's DDS middleware, `can_write`).
//!
//! [`EndpointQos::queue_capacity`]: crate::EndpointQos::queue_capacity

use std::collections::{HashMap, VecDeque};
use std::io;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::mpsc;
use std::sync::{Arc, Condvar, Mutex, MutexGuard};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use rustdds::mio1::{Events, Interest, Poll, Registry, Token, Waker as MioWaker};
use rustdds::{no_key, with_key, ReadCondition};

use crate::error::DdsError;
use crate::raw::{RawAdapter, RawSample};

/// How many samples the dispatcher moves from RustDDS to a queue per call. Large enough to amortize
/// RustDDS' per-call cache scan, small enough to interleave readers fairly.
const BATCH: usize = 512;

/// Token of the dispatcher's own command waker; reader tokens start above it.
const COMMAND_TOKEN: Token = Token(0);

/// Identity of a DDS sample: the GUID of the writer that wrote it and its sequence number. Requesters and
/// repliers correlate replies with it (DDS-RPC "related sample identity").
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct SampleIdentity {
    /// Writer GUID: 12-byte prefix then 4-byte entity id, as on the wire.
    pub writer_guid: [u8; 16],
    /// RTPS sequence number (64-bit; the XRCE encoding splits it in high `i32` and low `u32`).
    pub sequence_number: i64,
}

impl SampleIdentity {
    pub(crate) fn from_rustdds(id: rustdds::SampleIdentity) -> Self {
        Self { writer_guid: id.writer_guid.to_bytes(), sequence_number: i64::from(id.sequence_number) }
    }

    pub(crate) fn to_rustdds(self) -> rustdds::SampleIdentity {
        rustdds::SampleIdentity {
            writer_guid: rustdds::GUID::from_bytes(self.writer_guid),
            sequence_number: rustdds::SequenceNumber::from(self.sequence_number),
        }
    }

    /// Sequence number split as XRCE and Fast DDS carry it: `(high, low)`.
    pub fn sequence_parts(&self) -> (i32, u32) {
        let high = i32::try_from(self.sequence_number >> 32).unwrap_or(i32::MAX);
        let low = (self.sequence_number & 0xFFFF_FFFF) as u32;
        (high, low)
    }

    /// Builds the 64-bit sequence number from XRCE's `(high, low)`.
    pub fn from_parts(writer_guid: [u8; 16], high: i32, low: u32) -> Self {
        Self { writer_guid, sequence_number: (i64::from(high) << 32) | i64::from(low) }
    }
}

/// A sample received from DDS.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ReceivedSample {
    /// The CDR body, encapsulation header removed (what an XRCE DATA carries, spec §8.4).
    pub data: Vec<u8>,
    /// The encapsulation identifier that was removed (`[0, 1]` = CDR little endian, the usual case).
    pub encapsulation: [u8; 2],
    /// Who wrote it: writer GUID and sequence number (a replier answers with it).
    pub identity: SampleIdentity,
    /// The related sample identity the writer attached (replies carry the identity of their request).
    pub related_identity: Option<SampleIdentity>,
    /// For replies delivered to a [`Requester`](crate::Requester): the XRCE request id that was given to
    /// [`Requester::write_request`](crate::Requester::write_request) for the matching request.
    pub request_id: Option<u32>,
}

/// Called when a queue receives samples while it was empty; the agent uses it to wake its transport shell.
pub type QueueWaker = Arc<dyn Fn() + Send + Sync>;

/// Transforms or drops a sample before it is queued (requesters keep only replies to their own requests).
pub(crate) type Filter = Box<dyn FnMut(ReceivedSample) -> Option<ReceivedSample> + Send>;

struct QueueState {
    samples: VecDeque<ReceivedSample>,
    /// Set by the dispatcher when it stopped taking because the queue was full.
    paused: bool,
    waker: Option<QueueWaker>,
    /// Samples queued since creation (statistics, tests).
    received: u64,
    /// Per writer GUID: the highest sequence number taken from RustDDS and when it was taken.
    progress: HashMap<[u8; 16], (i64, Instant)>,
    /// Threads in [`SampleQueue::wait`]: the condition variable is notified only for them (a notification
    /// is a system call, paid per delivery otherwise).
    waiting: usize,
}

/// Writers whose progress a queue remembers; past it, entries not updated for [`PROGRESS_FORGET`] go.
const PROGRESS_ENTRIES: usize = 1024;
/// Age past which a writer's progress entry may be forgotten (see [`PROGRESS_ENTRIES`]).
const PROGRESS_FORGET: Duration = Duration::from_secs(60);

struct QueueShared {
    state: Mutex<QueueState>,
    cond: Condvar,
    capacity: usize,
    /// Asks the queue's engine to take again after a pause (called without the queue lock held).
    resume: Resume,
}

/// What un-pauses a queue: the rustdds dispatcher gets a command, the Fast DDS engine drains directly.
pub(crate) type Resume = Arc<dyn Fn() + Send + Sync>;

impl QueueShared {
    fn lock(&self) -> MutexGuard<'_, QueueState> {
        // A poisoned lock only means another thread panicked while holding it; the queue itself stays
        // consistent (every mutation is a single push/pop), so keep going.
        self.state.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
    }
}

/// The bounded queue of one reader, filled by the dispatcher thread and drained by the agent.
#[derive(Clone)]
pub struct SampleQueue {
    shared: Arc<QueueShared>,
}

impl std::fmt::Debug for SampleQueue {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SampleQueue").field("len", &self.len()).field("capacity", &self.shared.capacity).finish()
    }
}

impl SampleQueue {
    /// Samples waiting.
    pub fn len(&self) -> usize {
        self.shared.lock().samples.len()
    }

    /// Whether no sample waits.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Most samples the queue holds before the dispatcher stops taking from DDS.
    pub fn capacity(&self) -> usize {
        self.shared.capacity
    }

    /// Samples queued since the reader was created.
    pub fn received(&self) -> u64 {
        self.shared.lock().received
    }

    /// The highest sequence number of writer `writer_guid` that reached this queue (taken from RustDDS,
    /// whether or not the agent has popped it yet; requester filters included) and when it arrived.
    /// `None` before the first sample of that writer.
    pub fn progress_from(&self, writer_guid: &[u8; 16]) -> Option<(i64, Instant)> {
        self.shared.lock().progress.get(writer_guid).copied()
    }

    /// Samples waiting and the progress of `writer_guid` ([`SampleQueue::progress_from`]), read at once.
    pub fn backlog_of(&self, writer_guid: &[u8; 16]) -> (usize, Option<(i64, Instant)>) {
        let st = self.shared.lock();
        (st.samples.len(), st.progress.get(writer_guid).copied())
    }

    /// Length of the body of the next sample, without taking it (the agent checks it against its
    /// READ_DATA rate limit before taking).
    pub fn next_len(&self) -> Option<usize> {
        self.shared.lock().samples.front().map(|s| s.data.len())
    }

    /// Takes the next sample.
    pub fn pop(&self) -> Option<ReceivedSample> {
        let mut st = self.shared.lock();
        let s = st.samples.pop_front();
        let resume = self.maybe_resume(&mut st);
        drop(st);
        if resume {
            (self.shared.resume)();
        }
        s
    }

    /// Moves up to `max` samples into `out` (a `Vec`, a `VecDeque`...); returns how many.
    pub fn take_batch(&self, max: usize, out: &mut impl Extend<ReceivedSample>) -> usize {
        let mut st = self.shared.lock();
        let n = max.min(st.samples.len());
        out.extend(st.samples.drain(..n));
        let resume = self.maybe_resume(&mut st);
        drop(st);
        if resume {
            (self.shared.resume)();
        }
        n
    }

    /// Blocks until a sample is queued or `timeout` passes; returns whether one is queued. For tests and
    /// simple consumers; the agent uses [`SampleQueue::set_waker`] instead.
    pub fn wait(&self, timeout: Duration) -> bool {
        let deadline = Instant::now() + timeout;
        let mut st = self.shared.lock();
        while st.samples.is_empty() {
            let now = Instant::now();
            if now >= deadline {
                return false;
            }
            st.waiting += 1;
            st = match self.shared.cond.wait_timeout(st, deadline - now) {
                Ok((g, _)) => g,
                Err(p) => p.into_inner().0,
            };
            st.waiting -= 1;
        }
        true
    }

    /// Installs (or removes) the callback run when samples arrive in an empty queue. If samples are already
    /// waiting, it is called at once so none is overlooked.
    pub fn set_waker(&self, waker: Option<QueueWaker>) {
        let call = {
            let mut st = self.shared.lock();
            st.waker = waker.clone();
            !st.samples.is_empty()
        };
        if let (true, Some(w)) = (call, waker) {
            w();
        }
    }

    fn maybe_resume(&self, st: &mut QueueState) -> bool {
        if st.paused && st.samples.len() <= self.shared.capacity / 2 {
            st.paused = false;
            return true;
        }
        false
    }

    /// A queue for an engine without the dispatcher; `resume` runs when a paused queue has room again.
    #[cfg_attr(not(feature = "fastdds"), allow(dead_code))]
    pub(crate) fn new_detached(capacity: usize, resume: Resume) -> Self {
        Self { shared: Arc::new(QueueShared::new(capacity, resume)) }
    }

    /// Room for more samples; 0 marks the queue paused (its engine stops taking until it is drained).
    pub(crate) fn room_or_pause(&self) -> usize {
        let mut st = self.shared.lock();
        let room = self.shared.capacity.saturating_sub(st.samples.len());
        if room == 0 {
            st.paused = true;
        }
        room
    }

    /// Queues a sample the agent's own writer is about to publish, ahead of the engine's copy (see
    /// [`RawReader::deliver_ahead`](crate::RawReader::deliver_ahead)): only when the queue is not paused (the
    /// engine then holds no older sample for it) and has room. `make` builds the sample only then.
    #[cfg_attr(not(feature = "fastdds"), allow(dead_code))]
    pub(crate) fn push_ahead(&self, make: impl FnOnce() -> ReceivedSample) -> bool {
        let waker = {
            let mut st = self.shared.lock();
            if st.paused || st.samples.len() >= self.shared.capacity {
                return false;
            }
            let was_empty = st.samples.is_empty();
            st.samples.push_back(make());
            st.received += 1;
            if st.waiting > 0 {
                self.shared.cond.notify_all();
            }
            if was_empty {
                st.waker.clone()
            } else {
                None
            }
        };
        if let Some(w) = waker {
            w();
        }
        true
    }

    /// Appends a batch taken from DDS (through `filter`), records writer progress and wakes the agent.
    pub(crate) fn deliver(&self, batch: &mut Vec<ReceivedSample>, filter: &mut Option<Filter>) {
        self.deliver_skipping(batch, filter, &mut HashMap::new());
    }

    /// [`SampleQueue::deliver`], dropping per writer GUID as many samples as `ahead` counts (the engine's
    /// copies of samples queued ahead by [`SampleQueue::push_ahead`]); their progress is recorded.
    pub(crate) fn deliver_skipping(
        &self,
        batch: &mut Vec<ReceivedSample>,
        filter: &mut Option<Filter>,
        ahead: &mut HashMap<[u8; 16], u32>,
    ) {
        let now = Instant::now();
        let waker = {
            let mut st = self.shared.lock();
            let was_empty = st.samples.is_empty();
            for s in batch.iter() {
                let p = st.progress.entry(s.identity.writer_guid).or_insert((s.identity.sequence_number, now));
                *p = (p.0.max(s.identity.sequence_number), now);
            }
            if st.progress.len() > PROGRESS_ENTRIES {
                st.progress.retain(|_, (_, at)| now.duration_since(*at) < PROGRESS_FORGET);
            }
            for s in batch.drain(..) {
                if !ahead.is_empty() {
                    if let Some(n) = ahead.get_mut(&s.identity.writer_guid) {
                        *n -= 1;
                        if *n == 0 {
                            ahead.remove(&s.identity.writer_guid);
                        }
                        continue;
                    }
                }
                let s = match filter.as_mut() {
                    Some(f) => match f(s) {
                        Some(s) => s,
                        None => continue,
                    },
                    None => s,
                };
                st.samples.push_back(s);
                st.received += 1;
            }
            if st.waiting > 0 {
                self.shared.cond.notify_all();
            }
            if was_empty && !st.samples.is_empty() {
                st.waker.clone()
            } else {
                None
            }
        };
        if let Some(w) = waker {
            w();
        }
    }
}

impl QueueShared {
    fn new(capacity: usize, resume: Resume) -> Self {
        QueueShared {
            state: Mutex::new(QueueState {
                samples: VecDeque::new(),
                paused: false,
                waker: None,
                received: 0,
                progress: HashMap::new(),
                waiting: 0,
            }),
            cond: Condvar::new(),
            capacity: capacity.max(1),
            resume,
        }
    }
}

/// A RustDDS reader the dispatcher can register and drain.
pub(crate) trait RawSource: Send {
    fn register(&mut self, registry: &Registry, token: Token) -> io::Result<()>;
    fn deregister(&mut self, registry: &Registry);
    /// Appends up to `max` samples to `out`.
    fn take(&mut self, max: usize, out: &mut Vec<ReceivedSample>);
}

fn to_received(
    sample: RawSample,
    identity: rustdds::SampleIdentity,
    related: Option<rustdds::SampleIdentity>,
) -> ReceivedSample {
    ReceivedSample {
        data: Vec::from(sample.body),
        encapsulation: sample.encapsulation,
        identity: SampleIdentity::from_rustdds(identity),
        related_identity: related.map(SampleIdentity::from_rustdds),
        request_id: None,
    }
}

/// Unkeyed topics use RustDDS' `SimpleDataReader`: no second sample cache, constant cost per sample, and
/// it exposes writer GUID, sequence number and write options (related sample identity) directly.
impl RawSource for no_key::SimpleDataReader<RawSample, RawAdapter> {
    fn register(&mut self, registry: &Registry, token: Token) -> io::Result<()> {
        rustdds::mio1::event::Source::register(self, registry, token, Interest::READABLE)
    }

    fn deregister(&mut self, registry: &Registry) {
        if let Err(e) = rustdds::mio1::event::Source::deregister(self, registry) {
            tracing::debug!("deregistering reader: {e}");
        }
    }

    fn take(&mut self, max: usize, out: &mut Vec<ReceivedSample>) {
        // Must precede the takes, or a notification for data that arrives meanwhile could be lost.
        self.drain_read_notifications();
        for _ in 0..max {
            match self.try_take_one() {
                Ok(Some(dcc)) => {
                    let identity =
                        rustdds::SampleIdentity { writer_guid: dcc.writer_guid, sequence_number: dcc.sequence_number };
                    let related = dcc.write_options.related_sample_identity();
                    out.push(to_received(dcc.sample, identity, related));
                }
                Ok(None) => break,
                Err(e) => {
                    tracing::warn!("dropping undecodable sample: {e}");
                }
            }
        }
    }
}

/// Keyed topics need RustDDS' full `DataReader` (the simple one is not public for keyed topics); it is
/// drained with `take(batch)`.
impl RawSource for with_key::DataReader<RawSample, RawAdapter> {
    fn register(&mut self, registry: &Registry, token: Token) -> io::Result<()> {
        rustdds::mio1::event::Source::register(self, registry, token, Interest::READABLE)
    }

    fn deregister(&mut self, registry: &Registry) {
        if let Err(e) = rustdds::mio1::event::Source::deregister(self, registry) {
            tracing::debug!("deregistering reader: {e}");
        }
    }

    fn take(&mut self, max: usize, out: &mut Vec<ReceivedSample>) {
        match with_key::DataReader::take(self, max, ReadCondition::not_read()) {
            Ok(samples) => {
                for ds in samples {
                    let info = ds.sample_info();
                    let identity = info.sample_identity();
                    let related = info.related_sample_identity();
                    // Dispose/unregister notifications carry no data for an XRCE client.
                    if let Some(sample) = ds.into_value().value() {
                        out.push(to_received(sample, identity, related));
                    }
                }
            }
            Err(e) => tracing::warn!("taking from keyed reader: {e}"),
        }
    }
}

enum Command {
    Add { token: Token, source: Box<dyn RawSource>, queue: SampleQueue, filter: Option<Filter> },
    Remove(Token),
    Resume(Token),
    Stop,
}

/// Sending side of the dispatcher: commands plus the `mio` waker that interrupts its poll.
pub(crate) struct Control {
    tx: mpsc::Sender<Command>,
    waker: MioWaker,
    next_token: AtomicUsize,
}

impl Control {
    fn send(&self, cmd: Command) -> bool {
        if self.tx.send(cmd).is_err() {
            return false;
        }
        if let Err(e) = self.waker.wake() {
            tracing::warn!("waking dispatcher: {e}");
        }
        true
    }
}

/// The dispatcher thread of one participant. Dropping it stops the thread and drops its RustDDS readers.
pub(crate) struct Dispatcher {
    control: Arc<Control>,
    thread: Option<JoinHandle<()>>,
}

impl Dispatcher {
    pub(crate) fn start(name: String) -> Result<Self, DdsError> {
        let poll = Poll::new()?;
        let waker = MioWaker::new(poll.registry(), COMMAND_TOKEN)?;
        let (tx, rx) = mpsc::channel();
        let control = Arc::new(Control { tx, waker, next_token: AtomicUsize::new(1) });
        let thread = std::thread::Builder::new().name(name).spawn(move || run(poll, rx))?;
        Ok(Self { control, thread: Some(thread) })
    }

    /// Hands a RustDDS reader to the dispatcher and returns the queue the agent drains.
    pub(crate) fn add(
        &self,
        source: Box<dyn RawSource>,
        capacity: usize,
        filter: Option<Filter>,
    ) -> Result<(SampleQueue, Token), DdsError> {
        let token = Token(self.control.next_token.fetch_add(1, Ordering::Relaxed));
        let control = Arc::clone(&self.control);
        let resume: Resume = Arc::new(move || {
            control.send(Command::Resume(token));
        });
        let shared = Arc::new(QueueShared::new(capacity, resume));
        if !self.control.send(Command::Add {
            token,
            source,
            queue: SampleQueue { shared: Arc::clone(&shared) },
            filter,
        }) {
            return Err(DdsError::DispatcherStopped);
        }
        Ok((SampleQueue { shared }, token))
    }

    /// Removes a reader; its RustDDS reader is dropped on the dispatcher thread.
    pub(crate) fn remove(&self, token: Token) {
        self.control.send(Command::Remove(token));
    }
}

impl Drop for Dispatcher {
    fn drop(&mut self) {
        self.control.send(Command::Stop);
        if let Some(t) = self.thread.take() {
            if t.join().is_err() {
                tracing::error!("reader dispatcher thread panicked");
            }
        }
    }
}

struct Entry {
    source: Box<dyn RawSource>,
    queue: SampleQueue,
    filter: Option<Filter>,
}

fn run(mut poll: Poll, rx: mpsc::Receiver<Command>) {
    let mut events = Events::with_capacity(256);
    let mut readers: HashMap<Token, Entry> = HashMap::new();
    let mut batch = Vec::with_capacity(BATCH);
    loop {
        if let Err(e) = poll.poll(&mut events, None) {
            if e.kind() == io::ErrorKind::Interrupted {
                continue;
            }
            tracing::error!("reader dispatcher poll failed, stopping: {e}");
            return;
        }
        let mut ready: Vec<Token> = Vec::new();
        for ev in events.iter() {
            if ev.token() == COMMAND_TOKEN {
                while let Ok(cmd) = rx.try_recv() {
                    match cmd {
                        Command::Add { token, mut source, queue, filter } => {
                            if let Err(e) = source.register(poll.registry(), token) {
                                tracing::error!("registering reader: {e}");
                            }
                            readers.insert(token, Entry { source, queue, filter });
                            // Data may have arrived between creation and registration.
                            ready.push(token);
                        }
                        Command::Remove(token) => {
                            if let Some(mut e) = readers.remove(&token) {
                                e.source.deregister(poll.registry());
                            }
                        }
                        Command::Resume(token) => ready.push(token),
                        Command::Stop => {
                            for (_, mut e) in readers.drain() {
                                e.source.deregister(poll.registry());
                            }
                            return;
                        }
                    }
                }
            } else {
                ready.push(ev.token());
            }
        }
        for token in ready {
            if let Some(entry) = readers.get_mut(&token) {
                drain(entry, &mut batch);
            }
        }
    }
}

/// Moves everything RustDDS holds for one reader into its queue, as far as the queue has room.
fn drain(entry: &mut Entry, batch: &mut Vec<ReceivedSample>) {
    loop {
        let room = entry.queue.room_or_pause();
        if room == 0 {
            return;
        }
        batch.clear();
        entry.source.take(room.min(BATCH), batch);
        if batch.is_empty() {
            return;
        }
        let took = batch.len();
        entry.queue.deliver(batch, &mut entry.filter);
        if took < room.min(BATCH) {
            return;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample(writer: u8, seq: i64) -> ReceivedSample {
        let mut writer_guid = [0; 16];
        writer_guid[0] = writer;
        ReceivedSample {
            data: vec![writer, seq as u8],
            encapsulation: [0, 1],
            identity: SampleIdentity { writer_guid, sequence_number: seq },
            related_identity: None,
            request_id: None,
        }
    }

    fn bodies(q: &SampleQueue) -> Vec<Vec<u8>> {
        let mut out: Vec<ReceivedSample> = Vec::new();
        q.take_batch(usize::MAX, &mut out);
        out.into_iter().map(|s| s.data).collect()
    }

    #[test]
    fn samples_queued_ahead_replace_the_engines_copies_which_still_count_as_progress() {
        let q = SampleQueue::new_detached(4, Arc::new(|| {}));
        let wakes = Arc::new(std::sync::atomic::AtomicUsize::new(0));
        let w = Arc::clone(&wakes);
        q.set_waker(Some(Arc::new(move || {
            w.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        })));
        let mut ahead = HashMap::new();
        // Writer 1's samples 1 and 2 go ahead (as the agent does before the DDS write).
        for seq in 1..=2 {
            assert!(q.push_ahead(|| ReceivedSample {
                identity: SampleIdentity { sequence_number: -1, ..sample(1, seq).identity },
                ..sample(1, seq)
            }));
            *ahead.entry(sample(1, seq).identity.writer_guid).or_insert(0) += 1;
        }
        assert_eq!(
            wakes.load(std::sync::atomic::Ordering::Relaxed),
            1,
            "woken once, when the queue got its first sample"
        );
        // The engine then delivers its copies, with writer 2's sample between them: the copies go, the
        // other stays, and writer 1's progress is the copies' sequence numbers.
        let mut batch = vec![sample(1, 1), sample(2, 7), sample(1, 2)];
        q.deliver_skipping(&mut batch, &mut None, &mut ahead);
        assert!(ahead.is_empty(), "every copy was dropped: {ahead:?}");
        assert_eq!(q.progress_from(&sample(1, 0).identity.writer_guid).map(|p| p.0), Some(2));
        assert_eq!(q.received(), 3);
        assert_eq!(bodies(&q), vec![vec![1, 1], vec![1, 2], vec![2, 7]]);
        // A later sample of writer 1 that did not go ahead is delivered.
        q.deliver_skipping(&mut vec![sample(1, 3)], &mut None, &mut ahead);
        assert_eq!(bodies(&q), vec![vec![1, 3]]);
    }

    #[test]
    fn nothing_goes_ahead_into_a_full_or_paused_queue() {
        let q = SampleQueue::new_detached(4, Arc::new(|| {}));
        for seq in 1..=4 {
            assert!(q.push_ahead(|| sample(1, seq)));
        }
        assert!(!q.push_ahead(|| unreachable!("full: the sample is not even built")), "full");
        assert_eq!(q.room_or_pause(), 0, "the engine finds it full and pauses it");
        let mut out: Vec<ReceivedSample> = Vec::new();
        q.take_batch(1, &mut out);
        assert!(!q.push_ahead(|| sample(1, 5)), "paused: the engine may hold older samples, which come first");
        q.take_batch(1, &mut out);
        assert!(q.push_ahead(|| sample(1, 5)), "resumed once half empty");
    }
}
