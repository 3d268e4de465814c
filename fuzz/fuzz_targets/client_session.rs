//! The client's session core fed arbitrary messages from "the agent", with time passing and the application
//! writing: it must never panic, and everything it sends must parse.
//!
//! Input layout: repeated `[op] [len_lo] [len_hi] [len bytes]`; `op & 4` advances time by `op` milliseconds
//! first; `op & 8` prefixes the bytes with the session's header (session 0x81, the stream and sequence taken
//! from the data) so the fuzzer reaches stream and submessage handling; `op & 16` writes a sample on the
//! reliable stream, `op & 32` on the best-effort one, `op & 64` a fragmented one (continuous API) first.
//! The session is established from the start, with one stream of each kind both ways.
#![no_main]

use libfuzzer_sys::fuzz_target;
use xrce_client::prelude::*;

const MS: i64 = 1_000_000;

fuzz_target!(|data: &[u8]| {
    let (mut rel_out, mut be_out, mut rel_in) = ([0u8; 2048], [0u8; 512], [0u8; 4096]);
    let mut core: SessionCore<'_, 1, 1, 1, 1> = SessionCore::new(0x81, 0xAABB_CCDD, 512);
    let mut now: i64 = 1_700_000_000_000_000_000;
    core.create_session(now);
    let mut out = [0u8; 512];
    while core.poll_transmit(now, &mut out).is_some() {}
    let status_agent = [0x81, 0, 0, 0, 0x04, 0x01, 0x0B, 0, 0, 0, 0x58, 0x52, 0x43, 0x45, 0x01, 0x00, 0x01, 0x0F, 0x00];
    core.handle_input(&status_agent, now, &mut ());
    let (Ok(rel), Ok(be)) =
        (core.create_output_reliable_stream(&mut rel_out, 8), core.create_output_best_effort_stream(&mut be_out))
    else {
        return;
    };
    if core.create_input_reliable_stream(&mut rel_in, 8).is_err() || core.create_input_best_effort_stream().is_err() {
        return;
    }
    let writer = object_id(1, ObjectKind::DataWriter);
    for (op, bytes) in xrce_fuzz::ops(data) {
        if op & 4 != 0 {
            now += i64::from(op) * MS;
        }
        if op & 64 != 0 && core.outputs().begin_fragmented(rel, writer, 1500).is_ok() {
            let _ = core.outputs().push_fragmented(rel, &[0x5A; 1500]);
        }
        if op & 16 != 0 {
            let _ = core.buffer_topic(rel, writer, bytes.get(..bytes.len().min(600)).unwrap_or(&[]));
        }
        if op & 32 != 0 {
            let _ = core.buffer_topic(be, writer, bytes.get(..bytes.len().min(100)).unwrap_or(&[]));
        }
        core.flash_output_streams();
        if op & 8 != 0 {
            core.handle_input(&xrce_fuzz::in_session(bytes), now, &mut ());
        } else {
            core.handle_input(bytes, now, &mut ());
        }
        while let Some(n) = core.poll_transmit(now, &mut out) {
            xrce_fuzz::assert_parses(&out[..n], "client");
        }
        let _ = core.poll_timeout();
    }
    now += 60_000 * MS;
    while let Some(n) = core.poll_transmit(now, &mut out) {
        xrce_fuzz::assert_parses(&out[..n], "client");
    }
});
