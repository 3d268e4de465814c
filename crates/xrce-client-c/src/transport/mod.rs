//! The transports of seed 000 in eProsima's structures: each has the receive `buffer`, the `comm` table
//! sessions use and (POSIX) the `platform` descriptor programs poll, then `_opaque` words holding the Rust
//! transport. build.rs checks every field against the headers.

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

use crate::comm::{fill, uxrCommunication, Binding};
use crate::layout::{CAN_WORDS, SERIAL_WORDS, TCP_WORDS, UDP_WORDS};

/// `UXR_CONFIG_*_TRANSPORT_MTU` (UDP, TCP, serial, custom).
pub const MTU: usize = 512;
/// `UXR_CAN_TRANSPORT_MTU`.
pub const CAN_MTU: usize = 63;

/// `struct pollfd` (POSIX).
#[repr(C)]
#[derive(Debug, Clone, Copy, Default)]
pub struct PollFd {
    /// The descriptor.
    pub fd: i32,
    /// `POLLIN`.
    pub events: i16,
    /// Left to the program's poll().
    pub revents: i16,
}

/// `POLLIN` (the same value on every POSIX system this library builds for).
const POLLIN: i16 = 1;

impl PollFd {
    /// Ready to poll `fd` for input.
    pub const fn input(fd: i32) -> Self {
        Self { fd, events: POLLIN, revents: 0 }
    }
}

/// `uxrUDPPlatform`, `uxrTCPPlatform`, `uxrSerialPlatform` (POSIX).
#[repr(C)]
#[derive(Debug, Clone, Copy, Default)]
pub struct Platform {
    /// The descriptor.
    pub poll_fd: PollFd,
}

/// `uxrCANPlatform` (SocketCAN).
#[repr(C)]
#[derive(Debug, Clone, Copy, Default)]
pub struct CanPlatform {
    /// The raw CAN socket.
    pub poll_fd: PollFd,
    /// The frame identifier.
    pub can_id: u32,
}

/// `uxrUDPTransport`. Its functions need the `std` feature; the type exists without it.
#[repr(C)]
#[allow(non_camel_case_types)]
pub struct uxrUDPTransport {
    /// The last message received.
    pub buffer: [u8; MTU],
    /// The function table sessions use.
    pub comm: uxrCommunication,
    /// The socket.
    pub platform: Platform,
    /// The Rust transport.
    pub(crate) opaque: [u64; UDP_WORDS],
}

/// `uxrTCPInputBuffer`: `buffer` holds the last message received (the stream is decoded in the Rust
/// transport, so the other fields stay 0).
#[repr(C)]
#[allow(non_camel_case_types)]
pub struct uxrTCPInputBuffer {
    /// The last message received.
    pub buffer: [u8; MTU],
    /// eProsima's decoding state (0).
    pub position: usize,
    /// As `position`.
    pub state: u32,
    /// As `position`.
    pub msg_size: usize,
}

/// `uxrTCPTransport`.
#[repr(C)]
#[allow(non_camel_case_types)]
pub struct uxrTCPTransport {
    /// Receive buffer.
    pub input_buffer: uxrTCPInputBuffer,
    /// The function table sessions use.
    pub comm: uxrCommunication,
    /// The connected socket (follows reconnections).
    pub platform: Platform,
    /// The Rust transport.
    pub(crate) opaque: [u64; TCP_WORDS],
}

/// `uxrSerialTransport`.
#[repr(C)]
#[allow(non_camel_case_types)]
pub struct uxrSerialTransport {
    /// The last message received.
    pub buffer: [u8; MTU],
    /// The agent's framing address.
    pub remote_addr: u8,
    /// The function table sessions use.
    pub comm: uxrCommunication,
    /// The line's descriptor.
    pub platform: Platform,
    /// The Rust transport.
    pub(crate) opaque: [u64; SERIAL_WORDS],
}

/// `uxrCANTransport`.
#[repr(C)]
#[allow(non_camel_case_types)]
pub struct uxrCANTransport {
    /// The last message received.
    pub buffer: [u8; CAN_MTU],
    /// The function table sessions use.
    pub comm: uxrCommunication,
    /// The raw CAN socket and frame id.
    pub platform: CanPlatform,
    /// The Rust transport.
    pub(crate) opaque: [u64; CAN_WORDS],
}

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

/// Implements [`Binding`] for a C transport structure whose `opaque` words hold an `Opened<$rust>` and whose
/// receive buffer is `$($buffer).+`.
macro_rules! binding {
    ($c:ty, $rust:ty, $($buffer:ident).+) => {
        impl $crate::comm::Binding for $c {
            type Rust = $crate::transport::Opened<$rust>;

            unsafe fn parts(this: *mut Self) -> (*mut Self::Rust, *mut u8, usize) {
                // SAFETY: only addresses inside the live structure are computed (contract).
                unsafe {
                    let buffer = core::ptr::addr_of_mut!((*this).$($buffer).+);
                    (
                        core::ptr::addr_of_mut!((*this).opaque).cast(),
                        buffer.cast::<u8>(),
                        core::mem::size_of_val(&*buffer),
                    )
                }
            }
        }
    };
}
pub(crate) use binding;

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

/// Puts `transport` into the opaque words of the structure at `this` and points its `comm` at it.
///
/// # Safety
/// `this` is writable and stays where it is while sessions use it; `storage` its opaque words, aligned for
/// `Opened<T>` and large enough (each caller checks at compile time); `comm` its `comm` field.
unsafe fn install<B: Binding<Rust = Opened<T>>, T: Transport>(
    this: *mut B,
    storage: *mut Opened<T>,
    comm: *mut uxrCommunication,
    transport: T,
) {
    let mtu = transport.mtu();
    // SAFETY: contract; `write` does not drop whatever was there before (uninitialised memory, typically).
    unsafe { storage.write(Opened(Some(transport))) };
    // SAFETY: contract.
    if let Some(comm) = unsafe { comm.as_mut() } {
        fill(comm, this, mtu);
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
