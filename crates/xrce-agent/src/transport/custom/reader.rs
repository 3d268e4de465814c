//! The reader thread of a custom transport: calls the user's blocking `read` with a timeout, unframes the
//! bytes in stream mode (one decoder per endpoint), and hands each message to the event loop through a
//! bounded channel, waking the loop's poll.

use std::collections::HashMap;
use std::io::{self, Write};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{Receiver, SyncSender};
use std::sync::Arc;
use std::time::{Duration, Instant};

use xrce_proto::framing::serial::{AddressFilter, Event, FrameDecoder};

use super::endpoint::Endpoint;
use super::{CustomAgentIo, CustomOptions, Mode, AGENT_ADDRESS};
use crate::transport::{WakeFlag, MAX_BLOCK};

/// Bytes asked of a stream-mode `read` per call.
const READ_CHUNK: usize = 4096;

/// A message received, on its way to the loop.
#[derive(Debug)]
pub(super) struct Incoming {
    /// Where it came from.
    pub from: Endpoint,
    /// Its frame's source address, in stream mode.
    pub address: Option<u8>,
    /// The XRCE message (a recycled buffer).
    pub bytes: Vec<u8>,
}

/// How the reader wakes the loop: a flag, so many messages between two turns cost one wake-up, and a pipe
/// the loop polls (a `mio::Waker` cannot serve: a poll has one, the middleware's).
#[derive(Debug)]
pub(super) struct Wake {
    pub flag: WakeFlag,
    pub pipe: mio::unix::pipe::Sender,
}

impl Wake {
    fn raise(&self) {
        if self.flag.raise() {
            // A full pipe already holds a wake-up; a failed one only delays the message to the loop's next
            // turn (at most MAX_BLOCK).
            let _ = (&self.pipe).write(&[1]);
        }
    }
}

/// The reader thread's state.
pub(super) struct Reader {
    pub name: String,
    pub io: Arc<dyn CustomAgentIo>,
    pub blank: Endpoint,
    pub mode: Mode,
    pub options: CustomOptions,
    pub tx: SyncSender<Incoming>,
    /// Buffers the loop is done with.
    pub spare: Receiver<Vec<u8>>,
    pub wake: Arc<Wake>,
    pub stop: Arc<AtomicBool>,
}

impl Reader {
    /// Reads until `stop` is set or the loop is gone.
    pub fn run(self) {
        let size = match self.mode {
            Mode::Packet => self.options.max_message,
            Mode::Stream => READ_CHUNK,
        };
        let mut buf = vec![0u8; size.max(1)];
        let mut streams = Streams::new(self.options.max_streams, self.options.max_message);
        while !self.stop.load(Ordering::Relaxed) {
            let mut from = self.blank.clone();
            let n = match self.io.read(&mut from, &mut buf, self.options.read_timeout) {
                Ok(0) => continue,
                Ok(n) => n,
                Err(e) if matches!(e.kind(), io::ErrorKind::TimedOut | io::ErrorKind::WouldBlock) => continue,
                Err(e) if e.kind() == io::ErrorKind::Interrupted => continue,
                Err(e) => {
                    tracing::error!(transport = %self.name, "custom transport read failed, reopening it: {e}");
                    self.reopen();
                    streams.clear();
                    continue;
                }
            };
            // A `read` claiming more than the buffer is clamped to it.
            let data = buf.get(..n).unwrap_or(&buf);
            if let Err(e) = from.check_complete() {
                tracing::warn!(transport = %self.name, "message dropped, its endpoint is incomplete: {e}");
                continue;
            }
            let delivered = match self.mode {
                Mode::Packet => self.hand_over(from, None, data),
                Mode::Stream => {
                    let mut open = true;
                    streams.push(&from, data, &self.name, |src, payload| {
                        open = open && self.hand_over(from.clone(), Some(src), payload);
                    });
                    open
                }
            };
            if !delivered {
                break;
            }
        }
    }

    /// Sends one message to the loop; false when the loop is gone.
    fn hand_over(&self, from: Endpoint, address: Option<u8>, payload: &[u8]) -> bool {
        let mut bytes = self.spare.try_recv().unwrap_or_default();
        bytes.clear();
        bytes.extend_from_slice(payload);
        // Blocks while the loop's queue is full: the user's medium holds the rest meanwhile.
        if self.tx.send(Incoming { from, address, bytes }).is_err() {
            return false;
        }
        self.wake.raise();
        true
    }

    /// eProsima's `handle_error`: close and open the medium again, at most every [`MAX_BLOCK`] so a medium
    /// that stays broken is not spun on.
    fn reopen(&self) {
        if let Err(e) = self.io.close() {
            tracing::debug!(transport = %self.name, "close before reopening failed: {e}");
        }
        let until = Instant::now() + MAX_BLOCK;
        while Instant::now() < until && !self.stop.load(Ordering::Relaxed) {
            std::thread::sleep(Duration::from_millis(10));
        }
        match self.io.open() {
            Ok(()) => tracing::info!(transport = %self.name, "custom transport reopened"),
            Err(e) => tracing::warn!(transport = %self.name, "custom transport cannot be reopened: {e}"),
        }
    }
}

/// Stream mode: one frame decoder per endpoint, so byte runs of different peers never mix, at most
/// `max` of them; a new endpoint beyond that takes over the least recently used one's decoder (a frame
/// in progress there is lost, and reliable streams recover it).
struct Streams {
    decoders: HashMap<Endpoint, (FrameDecoder<Vec<u8>>, u64)>,
    max: usize,
    payload: usize,
    clock: u64,
}

impl Streams {
    fn new(max: usize, payload: usize) -> Self {
        Self { decoders: HashMap::new(), max: max.max(1), payload, clock: 0 }
    }

    fn clear(&mut self) {
        self.decoders.clear();
    }

    /// Feeds `data` from `from` to its decoder; `on_frame(src, payload)` for each whole frame.
    fn push(&mut self, from: &Endpoint, data: &[u8], name: &str, mut on_frame: impl FnMut(u8, &[u8])) {
        self.clock = self.clock.wrapping_add(1);
        let clock = self.clock;
        if !self.decoders.contains_key(from) {
            let decoder = self
                .recycle()
                .unwrap_or_else(|| FrameDecoder::new(vec![0u8; self.payload], AddressFilter::Only(AGENT_ADDRESS)));
            self.decoders.insert(from.clone(), (decoder, clock));
        }
        let Some((decoder, used)) = self.decoders.get_mut(from) else { return };
        *used = clock;
        decoder.push(data, |event| match event {
            Event::Frame { src, payload, .. } => on_frame(src, payload),
            Event::Error(e) => tracing::debug!(transport = %name, endpoint = %from, "frame dropped: {e}"),
        });
    }

    /// The least recently used decoder, reset, when the table is full.
    fn recycle(&mut self) -> Option<FrameDecoder<Vec<u8>>> {
        if self.decoders.len() < self.max {
            return None;
        }
        let oldest = self.decoders.iter().min_by_key(|(_, (_, used))| *used).map(|(e, _)| e.clone())?;
        let (mut decoder, _) = self.decoders.remove(&oldest)?;
        decoder.reset();
        Some(decoder)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::transport::custom::EndpointDesc;
    use xrce_proto::framing::serial::{encode_frame, max_encoded_len};

    fn frame(src: u8, payload: &[u8]) -> Vec<u8> {
        let mut out = vec![0u8; max_encoded_len(payload.len())];
        let n = encode_frame(src, AGENT_ADDRESS, payload, &mut out).unwrap();
        out.truncate(n);
        out
    }

    /// Two peers' byte runs interleaved byte by byte still make two whole frames each: every endpoint has
    /// its own decoder.
    #[test]
    fn interleaved_streams_are_unframed_apart() {
        let desc = EndpointDesc::new().member_u8("peer");
        let (mut a, mut b) = (desc.endpoint(), desc.endpoint());
        a.set("peer", 1u8).unwrap();
        b.set("peer", 2u8).unwrap();
        let (fa, fb) =
            ([frame(5, b"alpha"), frame(5, b"ALPHA")].concat(), [frame(6, b"beta"), frame(6, b"BETA")].concat());
        let mut streams = Streams::new(4, 64);
        let mut got = Vec::new();
        for i in 0..fa.len().max(fb.len()) {
            for (e, f) in [(&a, &fa), (&b, &fb)] {
                if let Some(byte) = f.get(i) {
                    streams.push(e, &[*byte], "t", |src, p| got.push((e.get::<u8>("peer").unwrap(), src, p.to_vec())));
                }
            }
        }
        got.sort();
        assert_eq!(
            got,
            [(1, 5, b"ALPHA".to_vec()), (1, 5, b"alpha".to_vec()), (2, 6, b"BETA".to_vec()), (2, 6, b"beta".to_vec())]
        );
    }

    /// Past `max` endpoints the least recently used decoder is taken over: the table never grows beyond it.
    #[test]
    fn decoders_are_bounded() {
        let desc = EndpointDesc::new().member_u32("peer");
        let mut streams = Streams::new(3, 64);
        for peer in 0..100u32 {
            let mut e = desc.endpoint();
            e.set("peer", peer).unwrap();
            // Half a frame each: every decoder holds a frame in progress.
            let f = frame(1, b"0123456789");
            streams.push(&e, f.get(..6).unwrap(), "t", |_, _| panic!("no whole frame"));
        }
        assert_eq!(streams.decoders.len(), 3);
    }
}
