//! `uxrCommunication`: the function table every transport fills in, and the Rust transport a session runs
//! over, which calls through it.

use core::ffi::c_void;

use xrce_client::{Transport, TransportError};

/// `uxrSendMsgFunc`.
pub type SendMsg = Option<unsafe extern "C" fn(instance: *mut c_void, buf: *const u8, len: usize) -> bool>;
/// `uxrRecvMsgFunc`: a message's length, 0 on timeout, negative on error.
pub type RecvMsg =
    Option<unsafe extern "C" fn(instance: *mut c_void, buf: *mut u8, capacity: usize, timeout_ms: i32) -> i32>;

/// `uxrCommunication`.
#[repr(C)]
#[derive(Debug, Clone, Copy)]
#[allow(non_camel_case_types)]
pub struct uxrCommunication {
    /// The transport, handed back to the functions.
    pub instance: *mut c_void,
    /// Sends one message.
    pub send_msg: SendMsg,
    /// Receives one message.
    pub recv_msg: RecvMsg,
    /// Largest message.
    pub mtu: u16,
}

/// A session's transport: the C program's `uxrCommunication`, which must outlive the session (seed 000).
#[derive(Debug)]
pub struct Comm(pub *const uxrCommunication);

impl Comm {
    fn table(&self) -> Option<uxrCommunication> {
        // SAFETY: the pointer was non-null when the session was initialised and the seed requires the
        // communication to stay valid while the session uses it; it is only read.
        unsafe { self.0.as_ref() }.copied()
    }
}

impl Transport for Comm {
    fn mtu(&self) -> usize {
        self.table().map_or(0, |t| usize::from(t.mtu))
    }

    fn send(&mut self, msg: &[u8]) -> Result<(), TransportError> {
        let table = self.table().ok_or(TransportError::NotOpen)?;
        let send = table.send_msg.ok_or(TransportError::NotOpen)?;
        // SAFETY: a transport's own function with its own instance; `msg` is valid for its length.
        if unsafe { send(table.instance, msg.as_ptr(), msg.len()) } {
            Ok(())
        } else {
            Err(TransportError::ShortWrite)
        }
    }

    fn recv(&mut self, buf: &mut [u8], timeout_ms: i32) -> Result<Option<usize>, TransportError> {
        let table = self.table().ok_or(TransportError::NotOpen)?;
        let recv = table.recv_msg.ok_or(TransportError::NotOpen)?;
        // SAFETY: a transport's own function with its own instance; `buf` is writable for its length.
        let n = unsafe { recv(table.instance, buf.as_mut_ptr(), buf.len(), timeout_ms) };
        match usize::try_from(n) {
            Ok(0) => Ok(None),
            Ok(n) if n <= buf.len() => Ok(Some(n)),
            Ok(_) => Err(TransportError::MessageTooLarge),
            Err(_) => Err(TransportError::Closed),
        }
    }
}

/// Fills `comm` for a Rust transport living at `instance` (inside the C transport structure).
pub fn fill<T: Transport>(comm: &mut uxrCommunication, instance: *mut T, mtu: usize) {
    *comm = uxrCommunication {
        instance: instance.cast(),
        send_msg: Some(send_through::<T>),
        recv_msg: Some(recv_through::<T>),
        mtu: u16::try_from(mtu).unwrap_or(u16::MAX),
    };
}

/// `send_msg` of a Rust transport.
///
/// # Safety
/// `instance` is the `T` given to [`fill`], still alive; `buf` holds `len` bytes.
unsafe extern "C" fn send_through<T: Transport>(instance: *mut c_void, buf: *const u8, len: usize) -> bool {
    // SAFETY: contract.
    let Some(t) = (unsafe { instance.cast::<T>().as_mut() }) else { return false };
    if buf.is_null() {
        return false;
    }
    // SAFETY: non-null, `len` bytes (contract).
    let msg = unsafe { core::slice::from_raw_parts(buf, len) };
    t.send(msg).is_ok()
}

/// `recv_msg` of a Rust transport.
///
/// # Safety
/// `instance` is the `T` given to [`fill`], still alive; `buf` has room for `capacity` bytes.
unsafe extern "C" fn recv_through<T: Transport>(
    instance: *mut c_void,
    buf: *mut u8,
    capacity: usize,
    timeout_ms: i32,
) -> i32 {
    // SAFETY: contract.
    let Some(t) = (unsafe { instance.cast::<T>().as_mut() }) else { return -1 };
    if buf.is_null() {
        return -1;
    }
    // SAFETY: non-null, room for `capacity` bytes (contract).
    let out = unsafe { core::slice::from_raw_parts_mut(buf, capacity) };
    match t.recv(out, timeout_ms) {
        Ok(Some(n)) => i32::try_from(n).unwrap_or(-1),
        Ok(None) => 0,
        Err(_) => -1,
    }
}
