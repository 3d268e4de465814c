//! `uxrUDPTransport` and `uxrTCPTransport`.

use core::ffi::c_char;
use core::ptr::addr_of_mut;

use xrce_client::transport::{IpProtocol, TcpTransport, UdpTransport};
use xrce_client::TransportError;

use super::{fits, install, uxrTCPTransport, uxrUDPTransport, Opened};
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
            // SAFETY: non-null, writable (contract); the opaque words fit (checked above) and are 8-aligned.
            unsafe {
                let storage = addr_of_mut!((*transport).opaque).cast::<Opened<$rust>>();
                install(storage, addr_of_mut!((*transport).comm), t);
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
