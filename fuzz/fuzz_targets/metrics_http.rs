//! The `--metrics` HTTP server's request parser on arbitrary bytes, arriving in arbitrary pieces as the server
//! reads them (accumulated up to its request limit): it must never panic, a request is routed as soon as its
//! head is complete, and a complete head keeps its route whatever follows it.
#![no_main]

use libfuzzer_sys::fuzz_target;
use xrce_agent::metrics::http::{route_name, MAX_REQUEST_BYTES};

fuzz_target!(|data: &[u8]| {
    let Some((&piece, rest)) = data.split_first() else { return };
    let piece = usize::from(piece).max(1);
    let mut request = Vec::new();
    for chunk in rest.chunks(piece) {
        let room = MAX_REQUEST_BYTES.saturating_sub(request.len());
        request.extend_from_slice(&chunk[..chunk.len().min(room)]);
        if let Some(route) = route_name(&request) {
            if route != "bad request" && route != "too large" {
                let mut longer = request.clone();
                longer.extend_from_slice(b"X-Trailing: 1\r\n\r\n");
                assert_eq!(route_name(&longer), Some(route), "bytes after a complete head changed its route");
            }
            return;
        }
    }
});
