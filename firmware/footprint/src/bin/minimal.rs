//! The minimal publisher on the board: `footprint-publisher` with the smallest streams that still carry it, as
//! crates/xrce-client/footprint's `footprint-minimal`: output history 4 in 256 B (the XML creations fragmented,
//! created one by one), input history 2 in 64 B. Framed serial transport on the UART.
#![no_std]
#![no_main]

const MTU: usize = 512;
const OUT_HISTORY: usize = 4;
const OUT_BUFFER: usize = 256;
const IN_HISTORY: usize = 2;
const IN_BUFFER: usize = 64;
/// The creation requests do not fit the history together: each waits for its status.
const ONE_BY_ONE: bool = true;

type Link = xrce_board::Link;

fn link() -> Option<Link> {
    xrce_board::link().ok()
}

include!("../probe.rs");
