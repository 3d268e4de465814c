//! The reliable-stream engine both the client and the agent run (spec §9): sequence numbers, ACKNACK and
//! HEARTBEAT, the retransmission and tail-loss probe policy, fragmentation and reassembly.
//!
//! No storage here: each side keeps its messages its own way (the client in eProsima's slot layout inside
//! caller buffers, the agent in owned buffers) and lends the engine what it needs through [`SendLog`] (when
//! each message last left) and [`FragmentSink`] (where fragments are joined), or through closures.
//!
//! * [`SeqNum`]: 16-bit serial arithmetic.
//! * [`InputWindow`], [`AckNackBits`]: the receiving side's counters and the ACKNACK it answers with.
//! * [`Sender`]: the sending side's counters, selective and deferred retransmission, HEARTBEATs.
//! * [`Probe`], [`Rtt`]: round-trip estimate and tail-loss probes.
//! * [`FragmentPlan`], [`Reassembler`]: cutting a submessage into FRAGMENTs and joining them.
//! * [`InPlaceJoin`], [`StoredFragment`], [`FragmentPlan::continuing`]: the same for messages kept in
//!   eProsima's slot layout, joined inside the buffer that holds them.
//! * [`Instant`], [`Duration`]: microseconds, from whatever clock the caller has.
//! * [`FaultRng`]: seeded faults for tests of all this over a lossy link.

mod fault;
mod fragment;
mod input;
mod output;
mod probe;
mod seq;
mod slots;
mod time;

pub use fault::FaultRng;
pub use fragment::{Chunk, Chunks, FragmentPlan, FragmentSink, Reassembler, Reassembly, SliceSink};
pub use input::{AckNackBits, InputWindow, Nacked};
pub use output::{SendLog, Sender, DEFAULT_RETRANSMIT_FLOOR, MAX_RETRANSMIT_INTERVAL};
pub use probe::{Probe, Rtt, PROBE_FLOOR};
pub use seq::SeqNum;
pub use slots::{InPlaceJoin, StoredFragment};
pub use time::{div_floor_pow1000, div_trunc_pow1000, Duration, Instant};

/// Size of a FRAGMENT submessage header.
pub const FRAGMENT_HEADER: usize = crate::SubmessageHeader::SIZE;
