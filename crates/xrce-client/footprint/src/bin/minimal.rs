//! The minimal publisher: the same PublishHelloWorld as `footprint-publisher`, with the smallest streams that
//! still carry it. MTU 512; one reliable output stream of history 4 in 256 B (64 B slots: a `HelloWorld` sample
//! travels whole, the XML creation requests travel fragmented over up to 3 slots, so they are created one by one);
//! one reliable input stream of history 2 in 64 B (32 B slots: a STATUS message is 14 B). Session and buffers
//! are statics, so `.bss` is the static RAM; the stack below `_start` is painted to measure its peak.
//!
//! Usage: `footprint-minimal [<agent port on 127.0.0.1>]` (default 8888). Prints the RAM figures at the end.
#![no_std]
#![no_main]

const MTU: usize = 512;
const OUT_HISTORY: usize = 4;
const OUT_BUFFER: usize = 256;
const IN_HISTORY: usize = 2;
const IN_BUFFER: usize = 64;
/// The creation requests do not fit the history together: each waits for its status.
const ONE_BY_ONE: bool = true;

include!("../probe.rs");
