//! `uxrCustomTransport` (seed 004): the program's four callbacks, packet-oriented or framed.

use core::ffi::c_void;
use core::ptr::addr_of_mut;

use xrce_client::{CustomIo, CustomTransport, TransportError};

use super::{binding, close, fits, install, Opened};
use crate::comm::uxrCommunication;
use crate::layout::CUSTOM_WORDS;

type OpenClose = Option<unsafe extern "C" fn(*mut uxrCustomTransport) -> bool>;
type Write = Option<unsafe extern "C" fn(*mut uxrCustomTransport, *const u8, usize, *mut u8) -> usize>;
type Read = Option<unsafe extern "C" fn(*mut uxrCustomTransport, *mut u8, usize, i32, *mut u8) -> usize>;

/// `uxrCustomTransport`.
#[repr(C)]
#[allow(non_camel_case_types)]
pub struct uxrCustomTransport {
    /// The last message received.
    pub buffer: [u8; super::MTU],
    /// Stream-oriented (HDLC-like framing) rather than packet-oriented.
    pub framing: bool,
    /// Opens the medium.
    pub open: OpenClose,
    /// Closes it.
    pub close: OpenClose,
    /// Writes bytes.
    pub write: Write,
    /// Reads bytes.
    pub read: Read,
    /// The function table sessions use.
    pub comm: uxrCommunication,
    /// What `uxr_init_custom_transport` was given.
    pub args: *mut c_void,
    /// The Rust transport.
    pub(crate) opaque: [u64; CUSTOM_WORDS],
}

/// The program's callbacks, called with its transport structure.
#[derive(Debug)]
pub struct Callbacks(*mut uxrCustomTransport);

pub type Transport = CustomTransport<Callbacks, 512>;

const _: () = assert!(fits::<Transport>(CUSTOM_WORDS), "UXR_CUSTOM_TRANSPORT_OPAQUE_WORDS too small");

impl Callbacks {
    fn open_close(&self, pick: fn(&uxrCustomTransport) -> OpenClose) -> bool {
        // SAFETY: the structure the program initialised and keeps in place; only its public fields are read.
        let Some(f) = (unsafe { self.0.as_ref() }).and_then(pick) else { return true };
        // SAFETY: the program's own callback with its own structure.
        unsafe { f(self.0) }
    }
}

impl CustomIo for Callbacks {
    fn open(&mut self) -> bool {
        self.open_close(|t| t.open)
    }

    fn close(&mut self) -> bool {
        self.open_close(|t| t.close)
    }

    // Inlined: its result then lives in registers, not in memory the caller reads back (firmware size).
    #[inline(always)]
    fn write(&mut self, buf: &[u8]) -> Result<usize, TransportError> {
        // SAFETY: as in `open_close`.
        let write = unsafe { self.0.as_ref() }.and_then(|t| t.write).ok_or(TransportError::NotOpen)?;
        let mut error = 0u8;
        // SAFETY: the program's callback; `buf` readable for its length, `error` writable.
        let n = unsafe { write(self.0, buf.as_ptr(), buf.len(), &mut error) };
        if error != 0 {
            return Err(TransportError::Custom(error));
        }
        Ok(n.min(buf.len()))
    }

    // As `write`.
    #[inline(always)]
    fn read(&mut self, buf: &mut [u8], timeout_ms: i32) -> Result<usize, TransportError> {
        // SAFETY: as in `open_close`.
        let read = unsafe { self.0.as_ref() }.and_then(|t| t.read).ok_or(TransportError::NotOpen)?;
        let mut error = 0u8;
        // SAFETY: the program's callback; `buf` writable for its length, `error` writable.
        let n = unsafe { read(self.0, buf.as_mut_ptr(), buf.len(), timeout_ms, &mut error) };
        if error != 0 {
            return Err(TransportError::Custom(error));
        }
        Ok(n.min(buf.len()))
    }
}

binding!(uxrCustomTransport, Transport, buffer);

/// `uxr_set_custom_transport_callbacks`: to call before `uxr_init_custom_transport`.
///
/// # Safety
/// `transport` null or writable.
#[no_mangle]
pub unsafe extern "C" fn uxr_set_custom_transport_callbacks(
    transport: *mut uxrCustomTransport,
    framing: bool,
    open: OpenClose,
    close: OpenClose,
    write: Write,
    read: Read,
) {
    if transport.is_null() {
        return;
    }
    // SAFETY: non-null and writable (contract); public fields only.
    unsafe {
        addr_of_mut!((*transport).framing).write(framing);
        addr_of_mut!((*transport).open).write(open);
        addr_of_mut!((*transport).close).write(close);
        addr_of_mut!((*transport).write).write(write);
        addr_of_mut!((*transport).read).write(read);
    }
}

/// `uxr_init_custom_transport`: calls `open`; `false` if it fails or no write/read callback was set.
///
/// # Safety
/// `transport` null or set up by `uxr_set_custom_transport_callbacks`, not moved while in use.
#[no_mangle]
pub unsafe extern "C" fn uxr_init_custom_transport(transport: *mut uxrCustomTransport, args: *mut c_void) -> bool {
    // SAFETY: contract.
    let Some(t) = (unsafe { transport.as_mut() }) else { return false };
    if t.write.is_none() || t.read.is_none() {
        return false;
    }
    t.args = args;
    let framing = t.framing;
    let Ok(custom) = Transport::new(Callbacks(transport), framing) else { return false };
    // SAFETY: the opaque words fit (checked above) and are 8-aligned; the structure stays in place (contract).
    unsafe {
        let storage = addr_of_mut!((*transport).opaque).cast::<Opened<Transport>>();
        install(transport, storage, addr_of_mut!((*transport).comm), custom);
    }
    true
}

/// `uxr_close_custom_transport`: calls `close`.
///
/// # Safety
/// `transport` null or initialised by `uxr_init_custom_transport`.
#[no_mangle]
pub unsafe extern "C" fn uxr_close_custom_transport(transport: *mut uxrCustomTransport) -> bool {
    if transport.is_null() {
        return false;
    }
    // SAFETY: contract.
    let storage = unsafe { addr_of_mut!((*transport).opaque) }.cast::<Opened<Transport>>();
    // SAFETY: contract.
    let closed = unsafe { storage.as_mut() }
        .and_then(|t| t.0.as_mut())
        .is_some_and(|t| xrce_client::Transport::close(t).is_ok());
    // SAFETY: contract.
    let dropped = unsafe { close(storage) };
    dropped && closed
}
