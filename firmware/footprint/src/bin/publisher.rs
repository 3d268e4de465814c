//! The measured profile on the board: eProsima's PublishHelloWorld on the `no_std` core, as
//! crates/xrce-client/footprint's `footprint-publisher` but over the framed serial transport on the UART. One
//! session, MTU 512, one reliable output and one reliable input stream of history 4 (2 KiB each), entities by
//! XML, ten `HelloWorld` samples serialized in place, session deleted. Session and buffers are statics, so
//! `.bss` is the static RAM. Runs in QEMU against an agent on the UART's line; prints its RAM figures.
#![no_std]
#![no_main]

const MTU: usize = 512;
const OUT_HISTORY: usize = 4;
const OUT_BUFFER: usize = MTU * OUT_HISTORY;
const IN_HISTORY: usize = 4;
const IN_BUFFER: usize = MTU * IN_HISTORY;
/// The four creation requests fit the history together.
const ONE_BY_ONE: bool = false;

type Link = xrce_board::Link;

fn link() -> Option<Link> {
    xrce_board::link().ok()
}

include!("../probe.rs");
