//! `uxrUDPTransport` and `uxrTCPTransport`.

use core::ffi::c_char;
use core::ptr::addr_of_mut;
use std::os::fd::AsRawFd;

use xrce_client::transport::{IpProtocol, TcpTransport, UdpTransport};
use xrce_client::TransportError;

use super::{binding, fits, install, uxrTCPTransport, uxrUDPTransport, Opened, Platform, PollFd};
use crate::entities::text;
use crate::layout::{TCP_WORDS, UDP_WORDS};

const _: () = assert!(fits::<UdpTransport>(UDP_WORDS), "UXR_UDP_TRANSPORT_OPAQUE_WORDS too small");
const _: () = assert!(fits::<TcpTransport>(TCP_WORDS), "UXR_TCP_TRANSPORT_OPAQUE_WORDS too small");

/// Resolves the C arguments and opens a transport with `open`.
///
/// # Safety
/// `ip` and `port` null or NUL-terminated.
unsafe fn open_with<T>(
    protocol: u32,
    ip: *const c_char,
    port: *const c_char,
    open: impl FnOnce(IpProtocol, &str, &str) -> Result<T, TransportError>,
) -> Option<T> {
    let protocol = if protocol == 1 { IpProtocol::V6 } else { IpProtocol::V4 };
    // SAFETY: contract.
    let (ip, port) = unsafe { (text(ip)?, text(port)?) };
    open(protocol, ip, port).ok()
}

macro_rules! socket_transport {
    ($c:ident, $rust:ty, $init:ident, $close:ident) => {
        #[doc = concat!("`", stringify!($init), "`: `ip_protocol` `UXR_IPv4` or `UXR_IPv6`, address and port as text.")]
        ///
        /// # Safety
        /// `transport` null or writable, not moved while in use; `ip`, `port` null or NUL-terminated.
        #[no_mangle]
        pub unsafe extern "C" fn $init(
            transport: *mut $c,
            ip_protocol: u32,
            ip: *const c_char,
            port: *const c_char,
        ) -> bool {
            if transport.is_null() {
                return false;
            }
            // SAFETY: contract.
            let Some(t) = (unsafe { open_with(ip_protocol, ip, port, <$rust>::new) }) else { return false };
            let platform = Platform { poll_fd: PollFd::input(t.as_raw_fd()) };
            // SAFETY: non-null, writable (contract); the opaque words fit (checked above) and are 8-aligned.
            unsafe {
                addr_of_mut!((*transport).platform).write(platform);
                let storage = addr_of_mut!((*transport).opaque).cast::<Opened<$rust>>();
                install(transport, storage, addr_of_mut!((*transport).comm), t);
            }
            true
        }

        super::close_function!(
            #[doc = concat!("`", stringify!($close), "`: closes the socket.")]
            $close,
            $c,
            $rust
        );
    };
}

socket_transport!(uxrUDPTransport, UdpTransport, uxr_init_udp_transport, uxr_close_udp_transport);
socket_transport!(uxrTCPTransport, TcpTransport, uxr_init_tcp_transport, uxr_close_tcp_transport);

binding!(uxrUDPTransport, UdpTransport, buffer);

impl crate::comm::Binding for uxrTCPTransport {
    type Rust = Opened<TcpTransport>;

    /// Also keeps `platform.poll_fd.fd` on the connected socket: the transport reconnects on a new one when
    /// the agent goes away.
    unsafe fn parts(this: *mut Self) -> (*mut Self::Rust, *mut u8, usize) {
        // SAFETY: the live structure (contract): addresses inside it, and its Rust transport, which no other
        // reference reaches during this call.
        unsafe {
            let rust = addr_of_mut!((*this).opaque).cast::<Opened<TcpTransport>>();
            if let Some(t) = (*rust).0.as_ref() {
                addr_of_mut!((*this).platform.poll_fd.fd).write(t.as_raw_fd());
            }
            let buffer = addr_of_mut!((*this).input_buffer.buffer);
            (rust, buffer.cast::<u8>(), core::mem::size_of_val(&*buffer))
        }
    }
}
