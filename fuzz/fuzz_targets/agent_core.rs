//! The agent core fed arbitrary sequences of datagrams from a few endpoints, with time passing: it must
//! never panic, and every message it emits must parse.
//!
//! Input layout: repeated `[op] [len_lo] [len_hi] [len bytes]`; `op & 3` picks the endpoint, `op & 4`
//! advances time by `op` milliseconds first, `op & 8` prefixes the bytes with a valid in-session header
//! (session 0x81, the stream and sequence taken from the data) so the fuzzer reaches submessage handling.
//! Two sessions with a participant, topic, publisher, subscriber, writer and reader exist from the start.
#![no_main]

use std::sync::Arc;
use std::time::{Duration, Instant};

use libfuzzer_sys::fuzz_target;
use xrce_agent::core::{AgentCore, CoreConfig};
use xrce_agent::middleware::ced::Ced;
use xrce_agent::middleware::describe::FallbackProfiles;

fn hex(s: &str) -> Vec<u8> {
    s.split_whitespace().filter_map(|b| u8::from_str_radix(b, 16).ok()).collect()
}

fn setup(core: &mut AgentCore<u8, Ced>, now: Instant) {
    for (ep, key) in [(0u8, "aa bb cc dd"), (1u8, "11 22 33 44")] {
        let create = hex(&format!("80 00 00 00 00 01 10 00 58 52 43 45 01 00 01 0f {key} 81 00 fc 01"));
        core.handle_datagram(ep, &create, now);
        // Binary participant, topic "t", publisher, subscriber, writer, reader on reliable stream 0x80.
        for (seq, body) in [
            "01 05 10 00 00 0b 00 11 01 03 00 00 02 00 00 00 00 00 00 00",
            "01 05 1c 00 00 0c 00 12 02 03 00 00 0e 00 00 00 02 00 00 00 74 00 00 01 02 00 00 00 54 00 00 11",
            "01 05 10 00 00 0d 00 13 03 03 00 00 02 00 00 00 00 00 00 11",
            "01 05 10 00 00 0e 00 14 04 03 00 00 02 00 00 00 00 00 00 11",
            "01 05 11 00 00 0f 00 15 05 03 00 00 03 00 00 00 00 12 00 00 13",
            "01 05 11 00 00 10 00 16 06 03 00 00 03 00 00 00 00 12 00 00 14",
        ]
        .iter()
        .enumerate()
        {
            let mut m = vec![0x81, 0x80, seq as u8, 0];
            m.extend(hex(body));
            core.handle_datagram(ep, &m, now);
        }
        debug_assert!(core.has_object(
            xrce_proto::ClientKey(hex(key).try_into().unwrap_or_default()),
            xrce_proto::ObjectId::from_raw(0x16)
        ));
        core.handle_datagram(ep, &hex("81 80 06 00 08 01 10 00 00 11 00 16 80 00 00 01 ff ff 00 00 00 00 00 00"), now);
    }
}

fuzz_target!(|data: &[u8]| {
    let mut now = Instant::now();
    let config = CoreConfig { max_clients: 16, max_reassembly_size: 1 << 16, ..CoreConfig::default() };
    let mut core = AgentCore::new(config, Ced::new(Arc::new(FallbackProfiles)));
    setup(&mut core, now);
    let mut out = Vec::new();
    for (op, bytes) in xrce_fuzz::ops(data) {
        if op & 4 != 0 {
            now += Duration::from_millis(u64::from(op));
            core.handle_timeout(now);
        }
        let ep = op & 3;
        if op & 8 != 0 {
            core.handle_datagram(ep, &xrce_fuzz::in_session(bytes), now);
        } else {
            core.handle_datagram(ep, bytes, now);
        }
        while core.poll_transmit(now, &mut out).is_some() {
            xrce_fuzz::assert_parses(&out, "agent");
        }
        if let Some(t) = core.poll_timeout() {
            assert!(t >= now || t + Duration::from_secs(1) >= now);
        }
    }
    core.handle_timeout(now + Duration::from_secs(60));
});
