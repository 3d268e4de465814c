//! The measured profile: eProsima's PublishHelloWorld on the `no_std` core. One session over UDP/IPv4, MTU 512,
//! one reliable output and one reliable input stream of history 4 (2 KiB each), entities by XML, ten
//! `HelloWorld` samples serialized in place, session deleted. Session and buffers are statics, as on a
//! microcontroller, so `.bss` is the static RAM; the stack below `_start` is painted to measure its peak.
//!
//! Usage: `footprint-publisher [<agent port on 127.0.0.1>]` (default 8888). Prints the RAM figures at the end.
#![no_std]
#![no_main]

const MTU: usize = 512;
const OUT_HISTORY: usize = 4;
const OUT_BUFFER: usize = MTU * OUT_HISTORY;
const IN_HISTORY: usize = 4;
const IN_BUFFER: usize = MTU * IN_HISTORY;
/// The four creation requests fit the history together.
const ONE_BY_ONE: bool = false;

include!("../probe.rs");
