//! The transports of seed 000: each C structure holds a Rust transport in its `_opaque` words and exposes it
//! to sessions through its `comm` function table.

#[cfg(all(feature = "can", target_os = "linux"))]
mod can;
mod custom;
#[cfg(feature = "std")]
mod discovery;
#[cfg(all(feature = "std", unix))]
mod serial;
#[cfg(feature = "std")]
mod sockets;

pub use custom::uxrCustomTransport;
use xrce_client::{Transport, TransportError};

use crate::comm::{fill, uxrCommunication};
use crate::layout::{CAN_WORDS, SERIAL_WORDS, TCP_WORDS, UDP_WORDS};

macro_rules! os_transport {
    ($(#[$m:meta])* $name:ident, $words:ident) => {
        $(#[$m])*
        /// Its functions need the `std` feature; the type exists without it so that the layout stays checked.
        #[repr(C)]
        #[allow(non_camel_case_types)]
        pub struct $name {
            opaque: [u64; $words],
            /// The function table sessions use.
            pub comm: uxrCommunication,
        }
    };
}

os_transport!(
    /// `uxrUDPTransport`.
    uxrUDPTransport, UDP_WORDS
);
os_transport!(
    /// `uxrTCPTransport`.
    uxrTCPTransport, TCP_WORDS
);
os_transport!(
    /// `uxrSerialTransport`.
    uxrSerialTransport, SERIAL_WORDS
);
os_transport!(
    /// `uxrCANTransport`.
    uxrCANTransport, CAN_WORDS
);

/// A transport that may have been closed (`uxr_close_*_transport`).
#[derive(Debug)]
pub struct Opened<T>(pub Option<T>);

impl<T: Transport> Transport for Opened<T> {
    fn mtu(&self) -> usize {
        self.0.as_ref().map_or(0, Transport::mtu)
    }

    fn send(&mut self, msg: &[u8]) -> Result<(), TransportError> {
        self.0.as_mut().ok_or(TransportError::NotOpen)?.send(msg)
    }

    fn recv(&mut self, buf: &mut [u8], timeout_ms: i32) -> Result<Option<usize>, TransportError> {
        self.0.as_mut().ok_or(TransportError::NotOpen)?.recv(buf, timeout_ms)
    }
}

/// `uxr_close_*_transport` for a structure whose opaque words hold an `Opened<$rust>`: drops the transport
/// (closing its socket or file); `false` for null or a transport already closed.
#[cfg(feature = "std")]
macro_rules! close_function {
    ($(#[$m:meta])* $name:ident, $c:ty, $rust:ty) => {
        $(#[$m])*
        ///
        /// # Safety
        /// `transport` null or initialised by its init function.
        #[no_mangle]
        pub unsafe extern "C" fn $name(transport: *mut $c) -> bool {
            if transport.is_null() {
                return false;
            }
            // SAFETY: contract.
            unsafe { $crate::transport::close(core::ptr::addr_of_mut!((*transport).opaque).cast::<$crate::transport::Opened<$rust>>()) }
        }
    };
}
#[cfg(feature = "std")]
pub(crate) use close_function;

/// Puts `transport` into the opaque words at `storage` and points `comm` at it.
///
/// # Safety
/// `storage` is writable, aligned for `Opened<T>` and large enough (each caller checks at compile time);
/// `comm` is writable; both stay where they are while sessions use them.
unsafe fn install<T: Transport>(storage: *mut Opened<T>, comm: *mut uxrCommunication, transport: T) {
    let mtu = transport.mtu();
    // SAFETY: contract; `write` does not drop whatever was there before (uninitialised memory, typically).
    unsafe { storage.write(Opened(Some(transport))) };
    // SAFETY: contract.
    if let Some(comm) = unsafe { comm.as_mut() } {
        fill(comm, storage, mtu);
    }
}

/// Closes the transport at `storage` (dropping it: sockets and files are closed); `false` if it was not open.
///
/// # Safety
/// `storage` was filled by [`install`].
unsafe fn close<T>(storage: *mut Opened<T>) -> bool {
    // SAFETY: contract.
    unsafe { storage.as_mut() }.and_then(|t| t.0.take()).is_some()
}

/// Compile-time check that `T` fits `words` opaque words.
const fn fits<T>(words: usize) -> bool {
    core::mem::size_of::<Opened<T>>() <= words * 8 && core::mem::align_of::<Opened<T>>() <= 8
}
