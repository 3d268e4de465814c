//! `uxrCANTransport`: CAN FD over SocketCAN (Linux), the Rust client's `CanTransport` (docs/canfd.md).

use core::ffi::c_char;
use core::ptr::addr_of_mut;

use xrce_client::transport::{CanTransport, SocketCan};

use std::os::fd::AsRawFd;

use super::{binding, fits, install, uxrCANTransport, CanPlatform, Opened, PollFd};
use crate::entities::text;
use crate::layout::CAN_WORDS;

type Can = CanTransport<SocketCan>;

const _: () = assert!(fits::<Can>(CAN_WORDS), "UXR_CAN_TRANSPORT_OPAQUE_WORDS too small");

/// `uxr_init_can_transport`: a CAN FD raw socket on interface `dev` under the 29-bit identifier `can_id`.
///
/// # Safety
/// `transport` null or writable, not moved while in use; `dev` null or NUL-terminated.
#[no_mangle]
pub unsafe extern "C" fn uxr_init_can_transport(
    transport: *mut uxrCANTransport,
    dev: *const c_char,
    can_id: u32,
) -> bool {
    if transport.is_null() {
        return false;
    }
    // SAFETY: contract.
    let Some(dev) = (unsafe { text(dev) }) else { return false };
    let Ok(mut can) = Can::new(dev, can_id) else { return false };
    let platform = CanPlatform { poll_fd: PollFd::input(can.socket().as_raw_fd()), can_id };
    // SAFETY: non-null, writable (contract); the opaque words fit (checked above) and are 8-aligned.
    unsafe {
        addr_of_mut!((*transport).platform).write(platform);
        let storage = addr_of_mut!((*transport).opaque).cast::<Opened<Can>>();
        install(transport, storage, addr_of_mut!((*transport).comm), can);
    }
    true
}

binding!(uxrCANTransport, Can, buffer);

super::close_function!(
    /// `uxr_close_can_transport`: closes the socket.
    uxr_close_can_transport, uxrCANTransport, Can
);
