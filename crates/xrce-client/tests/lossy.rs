//! Deterministic reliability test: a client core and a minimal agent-side peer (built from the client's stream
//! types, which run the same engine as the agent's, `xrce_proto::reliable`) exchange samples both ways over a link
//! that drops, duplicates and reorders 20 % of the packets each. Every sample must arrive exactly once, in
//! order, intact, including the fragmented ones.
//!
//! The agent side answers like eProsima's agent (spec §9.5): one ACKNACK per reliable message received,
//! accepted or not, and one per HEARTBEAT. Under reordering these ACKNACKs report the same gap many times; the
//! test counts every reliable message each side sends and bounds the retransmissions, which grew without
//! bound when the client resent its whole window on every NACK.

mod common;

use common::Collect;
use std::collections::{HashSet, VecDeque};
use xrce_client::prelude::*;
use xrce_client::session::MILLIS;
use xrce_client::stream::{InputReliable, OutputReliable, Ready, Received};
use xrce_proto::message::Submessages;
use xrce_proto::reliable::{AckNackBits, FaultRng as Rng};
use xrce_proto::{ClientKey, MessageHeader, Submessage};

/// One direction of the link: packets with their delivery time.
#[derive(Default)]
struct Link {
    queue: Vec<(i64, Vec<u8>)>,
    sent: usize,
    dropped: usize,
    duplicated: usize,
    /// Reliable messages (stream 0x80) handed to the link, and the distinct sequence numbers among them.
    reliable: usize,
    seqs: HashSet<u16>,
}

impl Link {
    /// Reliable messages sent more than once.
    fn retransmissions(&self) -> usize {
        self.reliable - self.seqs.len()
    }

    fn send(&mut self, rng: &mut Rng, now: i64, msg: &[u8]) {
        self.sent += 1;
        let (header, _) = MessageHeader::decode(msg).unwrap();
        if header.stream_id == STREAM {
            self.reliable += 1;
            self.seqs.insert(header.sequence_nr);
        }
        if rng.chance(20) {
            self.dropped += 1;
            return;
        }
        let copies = if rng.chance(20) {
            self.duplicated += 1;
            2
        } else {
            1
        };
        for _ in 0..copies {
            // 20 % take a detour of up to 40 ms, so they overtake and get overtaken.
            let delay = if rng.chance(20) { 1 + (rng.next_u64() % 40) as i64 } else { 1 };
            self.queue.push((now + delay * MILLIS, msg.to_vec()));
        }
    }

    fn due(&mut self, now: i64) -> Vec<Vec<u8>> {
        let mut out = Vec::new();
        let mut i = 0;
        while i < self.queue.len() {
            if self.queue[i].0 <= now {
                out.push(self.queue.remove(i).1);
            } else {
                i += 1;
            }
        }
        out
    }
}

fn sample(index: u32) -> Vec<u8> {
    // Every 7th sample is larger than a slot, so it travels fragmented.
    let len = if index.is_multiple_of(7) { 300 } else { 12 };
    let mut v = index.to_le_bytes().to_vec();
    v.extend((0..len).map(|i| (index as usize * 31 + i) as u8));
    v
}

fn check(samples: &[Vec<u8>], n: u32) {
    assert_eq!(samples.len(), n as usize, "every sample exactly once");
    for (i, s) in samples.iter().enumerate() {
        assert_eq!(s, &sample(i as u32), "sample {i} in order and intact");
    }
}

const SESSION: u8 = 0x81;
const KEY: ClientKey = ClientKey::from_u32(0xAABB_CCDD);
const STREAM: StreamId = StreamId(0x80);

/// The agent side: a reliable input stream for the client's WRITE_DATA, a reliable output stream for DATA.
struct AgentPeer<'a> {
    input: InputReliable<'a>,
    output: OutputReliable<'a>,
    received: Vec<Vec<u8>>,
    frag: Vec<u8>,
    /// ACKNACKs to send, one per reliable message or HEARTBEAT received, as eProsima's agent does.
    acks: VecDeque<AckNackBits>,
}

impl AgentPeer<'_> {
    /// Takes the WRITE_DATA of a message processed in order. FRAGMENT payloads are joined as the eProsima agent
    /// does (a chain may start after other submessages, the C client's layout, spec §9.6).
    fn take_data(received: &mut Vec<Vec<u8>>, frag: &mut Vec<u8>, msg: &[u8], start: usize) {
        for raw in Submessages::new(msg, start) {
            match raw.unwrap().decode().unwrap() {
                Submessage::WriteData(d) => received.push(d.data.to_vec()),
                Submessage::Fragment { last, data } => {
                    frag.extend_from_slice(data);
                    if last {
                        let whole = std::mem::take(frag);
                        Self::take_data(received, frag, &whole, 0);
                    }
                }
                _ => {}
            }
        }
    }

    fn handle(&mut self, msg: &[u8], now: i64) {
        let (header, hs) = MessageHeader::decode(msg).unwrap();
        if header.stream_id == StreamId::NONE {
            for raw in Submessages::new(msg, hs) {
                match raw.unwrap().decode().unwrap() {
                    Submessage::AckNack(a) => self.output.on_acknack(a.first_unacked_seq_num, a.bitmap(), now),
                    Submessage::Heartbeat(h) => {
                        self.input.on_heartbeat(h.last_unacked_seq_nr);
                        self.acks.push_back(self.input.acknack());
                    }
                    _ => {}
                }
            }
            return;
        }
        if self.input.receive(header.sequence_nr, msg) == Received::Now {
            Self::take_data(&mut self.received, &mut self.frag, msg, hs);
            self.input.handled(header.sequence_nr);
        }
        while let Some(ready) = self.input.next_ready() {
            match ready {
                Ready::Message(s) => {
                    let m = self.input.message(s).unwrap();
                    Self::take_data(&mut self.received, &mut self.frag, m, MessageHeader::size_for(m[0]));
                    self.input.release(s, 1);
                }
                Ready::Fragments { first, count } => {
                    for i in 0..count {
                        let m = self.input.message(first.wrapping_add(i)).unwrap();
                        Self::take_data(&mut self.received, &mut self.frag, m, MessageHeader::size_for(m[0]));
                    }
                    self.input.release(first, count);
                }
                Ready::Broken { .. } => panic!("broken fragment run"),
            }
        }
        self.acks.push_back(self.input.acknack());
    }

    fn write(&mut self, data: &[u8]) -> Result<(), Error> {
        // DATA for datareader #1, from READ_DATA request 15.
        let len = (4 + data.len()) as u16;
        let head = [0x09, 0x01, len as u8, (len >> 8) as u8, 0x00, 0x0F, 0x00, 0x16];
        self.output.write_parts(&[&head, data])
    }

    fn poll(&mut self, now: i64, out: &mut [u8]) -> Option<usize> {
        let control = |out: &mut [u8], body: [u8; 9]| {
            out[..4].copy_from_slice(&[SESSION, 0, 0, 0]);
            out[4..13].copy_from_slice(&body);
            Some(13)
        };
        if let Some(ack) = self.acks.pop_front() {
            let [f0, f1] = ack.first_unacked.0.to_le_bytes();
            let [b0, b1] = ack.nack_bitmap();
            return control(out, [0x0A, 0x01, 0x05, 0x00, f0, f1, b0, b1, 0x80]);
        }
        if let Some(n) = self.output.poll_transmit(SESSION, KEY, STREAM, now, out) {
            return Some(n);
        }
        if let Some((first, last)) = self.output.poll_heartbeat(now) {
            let [f0, f1] = first.to_le_bytes();
            let [l0, l1] = last.to_le_bytes();
            return control(out, [0x0B, 0x01, 0x05, 0x00, f0, f1, l0, l1, 0x80]);
        }
        None
    }
}

/// What a run cost: reliable messages sent more than once, per direction.
#[derive(Debug)]
struct Cost {
    client_retransmissions: usize,
    agent_retransmissions: usize,
}

fn run(seed: u64, n: u32) -> (i64, Cost) {
    let mut rng = Rng::new(seed);
    let (mut c_out, mut c_in, mut a_in, mut a_out) = ([0u8; 1024], [0u8; 2048], [0u8; 2048], [0u8; 1024]);
    let mut client: SessionCore<'_, 1, 1, 1, 1> = SessionCore::new(SESSION, KEY.to_u32(), 512);
    let out = client.create_output_reliable_stream(&mut c_out, 8).unwrap();
    client.create_input_reliable_stream(&mut c_in, 16).unwrap();
    client.create_session(0);
    let mut buf = [0u8; 512];
    assert!(client.poll_transmit(0, &mut buf).is_some());
    client.handle_input(&[0x81, 0, 0, 0, 4, 1, 11, 0, 0, 0, b'X', b'R', b'C', b'E', 1, 0, 1, 15, 0], 0, &mut ());
    let mut agent = AgentPeer {
        input: InputReliable::new(&mut a_in, 16).unwrap(),
        output: OutputReliable::new(&mut a_out, 8, 4).unwrap(),
        received: Vec::new(),
        frag: Vec::new(),
        acks: VecDeque::new(),
    };
    let (mut to_agent, mut to_client) = (Link::default(), Link::default());
    let mut seen = Collect::default();
    let writer = object_id(1, ObjectKind::DataWriter);
    let (mut c_next, mut a_next) = (0u32, 0u32);
    let mut would_block = 0;
    let mut pending: VecDeque<Vec<u8>> = VecDeque::new();
    let mut now = 0i64;
    while now < 600_000 * MILLIS {
        now += MILLIS;
        // Writers push as fast as the histories allow; a full history says WouldBlock, never stalls.
        while c_next < n {
            match client.buffer_topic(out, writer, &sample(c_next)) {
                Ok(_) => c_next += 1,
                Err(Error::WouldBlock) => {
                    would_block += 1;
                    break;
                }
                Err(e) => panic!("{e}"),
            }
        }
        // Like the eProsima agent, one submessage per message: each sample is sealed and sent at once.
        while a_next < n {
            match agent.write(&sample(a_next)) {
                Ok(()) => a_next += 1,
                Err(Error::WouldBlock) => break,
                Err(e) => panic!("{e}"),
            }
            agent.output.flush();
            while let Some(len) = agent.poll(now, &mut buf) {
                to_client.send(&mut rng, now, &buf[..len]);
            }
        }
        client.flash_output_streams();
        agent.output.flush();
        for msg in to_agent.due(now) {
            agent.handle(&msg, now);
        }
        for msg in to_client.due(now) {
            client.handle_input(&msg, now, &mut seen);
        }
        while let Some(len) = client.poll_transmit(now, &mut buf) {
            pending.push_back(buf[..len].to_vec());
        }
        while let Some(m) = pending.pop_front() {
            to_agent.send(&mut rng, now, &m);
        }
        while let Some(len) = agent.poll(now, &mut buf) {
            to_client.send(&mut rng, now, &buf[..len]);
        }
        if agent.received.len() == n as usize && seen.topics.len() == n as usize && client.output_streams_confirmed() {
            break;
        }
    }
    assert!(to_agent.dropped > 0 && to_agent.duplicated > 0 && to_client.dropped > 0, "the link was lossy");
    assert!(would_block > 0, "back-pressure was exercised");
    check(&agent.received, n);
    let topics: Vec<Vec<u8>> = seen.topics.iter().map(|t| t.3.clone()).collect();
    check(&topics, n);
    assert!(client.output_streams_confirmed());
    eprintln!(
        "seed {seed:#x}: {} ms, client→agent {} sent {} dropped {} duplicated ({} reliable, {} retransmitted), \
         agent→client {} sent {} dropped ({} reliable, {} retransmitted)",
        now / MILLIS,
        to_agent.sent,
        to_agent.dropped,
        to_agent.duplicated,
        to_agent.reliable,
        to_agent.retransmissions(),
        to_client.sent,
        to_client.dropped,
        to_client.reliable,
        to_client.retransmissions(),
    );
    (
        now / MILLIS,
        Cost { client_retransmissions: to_agent.retransmissions(), agent_retransmissions: to_client.retransmissions() },
    )
}

#[test]
fn reliable_streams_survive_20_percent_loss_duplication_and_reordering() {
    for seed in [0x5EED_u64, 0xC0FFEE, 0xDEAD_BEEF, 42] {
        let n = 200;
        let (_, cost) = run(seed, n);
        // 20 % loss needs about 0.25 retransmissions per message; reordering adds a few spurious ones (a first
        // NACK goes at once). Go-back-N on every NACK cost tens of thousands here. Bound: one per sample.
        let bound = n as usize;
        assert!(cost.client_retransmissions <= bound, "seed {seed:#x}: client {cost:?}");
        assert!(cost.agent_retransmissions <= bound, "seed {seed:#x}: agent {cost:?}");
    }
}
