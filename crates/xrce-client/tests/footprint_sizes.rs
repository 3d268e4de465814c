//! RAM of the hello-world publisher profile (docs/client-footprint.md): guards against the session object
//! growing unnoticed.

use std::mem::size_of;
use xrce_client::prelude::*;

#[test]
fn session_sizes_of_the_publisher_profile() {
    let core = size_of::<SessionCore<'static, 0, 1, 0, 1>>();
    let blocking = size_of::<Session<'static, UdpTransport, StdClock, (), 0, 1, 0, 1, 512>>();
    println!("SessionCore<0, 1, 0, 1>: {core} B, Session<UdpTransport, StdClock, 0, 1, 0, 1, 512>: {blocking} B");
    // 256 B without the `reconnect` feature (on with `std`: its timers, settings and pending events, 40 B).
    // The `psk` feature (default, off in the footprint build) adds the key's slice and a nonce: 24 B.
    let psk = if cfg!(feature = "psk") { 24 } else { 0 };
    assert!(core <= 296 + psk, "{core}");
    // One 512-byte message buffer serves both directions.
    assert!(blocking <= core + 512 + 64, "{blocking}");
}
