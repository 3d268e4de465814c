//! The Client API of seed 000 as a C library (`libmicroxrcedds_client.a`, headers in `include/`): eProsima's
//! function names, signatures and types over the Rust client (`xrce-client`), plus the Micro-CDR functions
//! the callbacks and generated topic types use. docs/c-api.md lists every function and what differs.
//!
//! Every exported function is `extern "C"`: a panic inside one aborts the process instead of unwinding into
//! C (Rust's rule for non-unwinding ABIs), and the library has no panicking path on the data it is given
//! (clippy denies unwrap, expect, indexing and panic). Pointers from C are checked for null; a session or
//! transport that was not initialised is recognised and refused with the seed's error values.
#![cfg_attr(not(feature = "std"), no_std)]
#![deny(clippy::unwrap_used, clippy::expect_used, clippy::indexing_slicing, clippy::panic)]

pub mod abi;
pub mod access;
pub mod clock;
pub mod comm;
pub mod entities;
pub mod layout;
pub mod lock;
pub mod platform;
pub mod session;
pub mod transport;
pub mod types;
pub mod ucdr;

/// Without `std` (firmware), a panic calls the program's hook (`uxr_set_panic_hook`) and halts: no `abort`,
/// which newlib implements with signals and `malloc`. None is expected on any input.
#[cfg(all(not(feature = "std"), not(test)))]
#[panic_handler]
fn panic(_: &core::panic::PanicInfo<'_>) -> ! {
    platform::call_panic_hook();
    loop {
        core::hint::spin_loop();
    }
}
