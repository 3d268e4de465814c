//! The empty probe: entry, exit, panic handler and nothing else. Its sections are what the publisher's would be
//! without the client.
#![no_std]
#![no_main]

use xrce_client_footprint as rt;

extern "C" fn main(_sp: *const usize) -> ! {
    rt::print(b"baseline\n");
    rt::exit(0)
}

rt::entry!(main);
