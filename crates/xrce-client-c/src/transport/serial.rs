//! `uxrSerialTransport`: an open serial line's file descriptor, framed as eProsima's serial transport.

use core::ptr::addr_of_mut;
use std::fs::File;
use std::os::fd::FromRawFd;

use xrce_client::transport::SerialTransport;

use super::{binding, fits, install, uxrSerialTransport, Opened, Platform, PollFd};
use crate::layout::SERIAL_WORDS;

const _: () = assert!(fits::<SerialTransport>(SERIAL_WORDS), "UXR_SERIAL_TRANSPORT_OPAQUE_WORDS too small");

/// `uxr_init_serial_transport`: the transport owns `fd` from now on (closed by `uxr_close_serial_transport`);
/// the terminal is used as the program set it up.
///
/// # Safety
/// `transport` null or writable, not moved while in use; `fd` an open file descriptor the program hands over.
#[no_mangle]
pub unsafe extern "C" fn uxr_init_serial_transport(
    transport: *mut uxrSerialTransport,
    fd: i32,
    remote_addr: u8,
    local_addr: u8,
) -> bool {
    if transport.is_null() || fd < 0 {
        return false;
    }
    // SAFETY: an open descriptor whose ownership the program hands over (contract).
    let file = unsafe { File::from_raw_fd(fd) };
    let serial = SerialTransport::from_file(file, remote_addr, local_addr);
    // SAFETY: the opaque words fit (checked above) and are 8-aligned; the structure stays in place (contract).
    unsafe {
        addr_of_mut!((*transport).remote_addr).write(remote_addr);
        addr_of_mut!((*transport).platform).write(Platform { poll_fd: PollFd::input(fd) });
        let storage = addr_of_mut!((*transport).opaque).cast::<Opened<SerialTransport>>();
        install(transport, storage, addr_of_mut!((*transport).comm), serial);
    }
    true
}

binding!(uxrSerialTransport, SerialTransport, buffer);

super::close_function!(
    /// `uxr_close_serial_transport`: closes the descriptor.
    uxr_close_serial_transport, uxrSerialTransport, SerialTransport
);
