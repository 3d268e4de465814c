//! `uxrCommunication`: the function table every transport fills in (eProsima's form: `recv_msg` points the
//! caller at a message the transport keeps), the Rust transport a session runs over, which calls through it,
//! and the functions that expose the library's own transports through such a table.

use core::ffi::c_void;
use core::sync::atomic::{AtomicU8, Ordering};

use xrce_client::{Transport, TransportError};

/// `send_msg_func`.
pub type SendMsg = Option<unsafe extern "C" fn(instance: *mut c_void, buf: *const u8, len: usize) -> bool>;
/// `recv_msg_func`: true with `*buf`/`*len` set to a message, false on timeout or error.
pub type RecvMsg =
    Option<unsafe extern "C" fn(instance: *mut c_void, buf: *mut *mut u8, len: *mut usize, timeout: i32) -> bool>;
/// `comm_error_func`.
pub type CommError = Option<extern "C" fn() -> u8>;

/// `uxrCommunication`.
#[repr(C)]
#[derive(Debug)]
#[allow(non_camel_case_types)]
pub struct uxrCommunication {
    /// The transport, handed back to the functions.
    pub instance: *mut c_void,
    /// Sends one message.
    pub send_msg: SendMsg,
    /// Receives one message.
    pub recv_msg: RecvMsg,
    /// The last error of the library's transports.
    pub comm_error: CommError,
    /// Largest message.
    pub mtu: u16,
    /// The transport's lock (multithread profile).
    #[cfg(uxr_multithread)]
    pub mutex: crate::lock::uxrMutex,
}

/// A session's transport: the C program's `uxrCommunication`, which must outlive the session (seed 000).
#[derive(Debug)]
pub struct Comm(pub *const uxrCommunication);

/// The functions of a `uxrCommunication`, read at each use (a program may change them).
#[derive(Debug, Clone, Copy)]
struct Table {
    instance: *mut c_void,
    send_msg: SendMsg,
    recv_msg: RecvMsg,
    mtu: u16,
}

impl Comm {
    fn table(&self) -> Option<Table> {
        // SAFETY: the pointer was non-null when the session was initialised and the seed requires the
        // communication to stay valid while the session uses it; it is only read.
        let c = unsafe { self.0.as_ref() }?;
        Some(Table { instance: c.instance, send_msg: c.send_msg, recv_msg: c.recv_msg, mtu: c.mtu })
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
        let (mut at, mut len) = (core::ptr::null_mut::<u8>(), 0usize);
        // SAFETY: a transport's own function with its own instance; `at` and `len` are writable.
        if !unsafe { recv(table.instance, &mut at, &mut len, timeout_ms) } || at.is_null() || len == 0 {
            return Ok(None);
        }
        let dst = buf.get_mut(..len).ok_or(TransportError::MessageTooLarge)?;
        // SAFETY: the transport promises `len` readable bytes at `at` until its next call.
        let src = unsafe { core::slice::from_raw_parts(at.cast_const(), len) };
        xrce_proto::bytes::copy(dst, src);
        Ok(Some(len))
    }
}

/// The last error code a library transport met (`comm_error`).
static LAST_ERROR: AtomicU8 = AtomicU8::new(0);

/// `comm_error` of the library's transports.
extern "C" fn last_error() -> u8 {
    LAST_ERROR.load(Ordering::Relaxed)
}

fn record(e: &TransportError) {
    let code = match e {
        TransportError::Custom(c) => *c,
        TransportError::Closed => 2,
        TransportError::NotOpen => 3,
        _ => 1,
    };
    LAST_ERROR.store(code, Ordering::Relaxed);
}

/// A C transport structure that holds a Rust transport and a buffer for the last message received.
pub trait Binding {
    /// The Rust transport.
    type Rust: Transport;

    /// The Rust transport inside `this`, and its receive buffer (pointer, capacity).
    ///
    /// # Safety
    /// `this` points to an initialised structure.
    unsafe fn parts(this: *mut Self) -> (*mut Self::Rust, *mut u8, usize);
}

/// Fills `comm` for the transport structure at `this`, messages up to `mtu`.
pub fn fill<B: Binding>(comm: &mut uxrCommunication, this: *mut B, mtu: usize) {
    comm.instance = this.cast();
    comm.send_msg = Some(send_through::<B>);
    comm.recv_msg = Some(recv_through::<B>);
    comm.comm_error = Some(last_error);
    comm.mtu = u16::try_from(mtu).unwrap_or(u16::MAX);
    // SAFETY: the transport's own lock, in memory being initialised with it and used by no thread yet.
    #[cfg(uxr_multithread)]
    unsafe {
        crate::lock::uxr_init_lock(&mut comm.mutex);
    }
}

/// `send_msg` of a library transport.
///
/// # Safety
/// `instance` is the structure given to [`fill`], still alive; `buf` holds `len` bytes.
unsafe extern "C" fn send_through<B: Binding>(instance: *mut c_void, buf: *const u8, len: usize) -> bool {
    if instance.is_null() || buf.is_null() {
        return false;
    }
    // SAFETY: contract.
    let (t, _, _) = unsafe { B::parts(instance.cast()) };
    // SAFETY: the Rust transport inside the live structure.
    let Some(t) = (unsafe { t.as_mut() }) else { return false };
    // SAFETY: non-null, `len` bytes (contract).
    let msg = unsafe { core::slice::from_raw_parts(buf, len) };
    t.send(msg).map_err(|e| record(&e)).is_ok()
}

/// `recv_msg` of a library transport: the message lands in the structure's buffer.
///
/// # Safety
/// `instance` is the structure given to [`fill`], still alive; `buf` and `len` writable.
unsafe extern "C" fn recv_through<B: Binding>(
    instance: *mut c_void,
    buf: *mut *mut u8,
    len: *mut usize,
    timeout_ms: i32,
) -> bool {
    if instance.is_null() || buf.is_null() || len.is_null() {
        return false;
    }
    // SAFETY: contract.
    let (t, data, capacity) = unsafe { B::parts(instance.cast()) };
    // SAFETY: the Rust transport inside the live structure.
    let Some(t) = (unsafe { t.as_mut() }) else { return false };
    // SAFETY: the structure's own buffer, `capacity` bytes, not otherwise borrowed during the call.
    let out = unsafe { core::slice::from_raw_parts_mut(data, capacity) };
    match t.recv(out, timeout_ms) {
        Ok(Some(n)) => {
            // SAFETY: writable (contract).
            unsafe {
                buf.write(data);
                len.write(n);
            }
            true
        }
        Ok(None) => false,
        Err(e) => {
            record(&e);
            false
        }
    }
}
