//! The multithread profile (eProsima's `UCLIENT_PROFILE_MULTITHREAD`), built with `XRCE_C_MULTITHREAD=1` on
//! POSIX: a recursive pthread mutex in the session, each stream and each transport's `comm`, as eProsima's
//! library has them. One lock guards a session: its own. Every call on the session holds it, and the lock of
//! any of its streams (`uxr_get_stream_mutex_from_id`, so `UXR_LOCK_STREAM_ID`) *is* it, so a program still
//! serializing into a stream it prepared keeps other threads from sending it half-written, and two locks
//! can never be taken in opposite orders by two threads (a window of a large sample pushed while a program
//! holds its stream would otherwise wait on a thread that waits on the stream). `uxr_prepare_output_stream*`
//! return holding it. The streams' own `mutex` fields are initialised for programs that lock them directly
//! (`UXR_LOCK_ALL_INPUT_STREAMS`); the library does not use them. Without the profile this module is empty
//! and the headers' lock macros expand to nothing.

#![cfg(uxr_multithread)]
#![allow(non_camel_case_types)]

use crate::abi::{uxrStreamId, BEST_EFFORT_STREAM, INPUT_STREAM, OUTPUT_STREAM, RELIABLE_STREAM};
use crate::session::uxrSession;

/// `uxrMutex`.
#[repr(C)]
pub struct uxrMutex {
    /// `impl`: a recursive mutex.
    pub impl_: libc::pthread_mutex_t,
}

impl core::fmt::Debug for uxrMutex {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str("uxrMutex")
    }
}

/// `uxr_init_lock`: a recursive mutex.
///
/// # Safety
/// `mutex` null or writable, not locked by anyone.
#[no_mangle]
pub unsafe extern "C" fn uxr_init_lock(mutex: *mut uxrMutex) {
    if mutex.is_null() {
        return;
    }
    let mut attr = core::mem::MaybeUninit::<libc::pthread_mutexattr_t>::uninit();
    // SAFETY: `attr` is initialised by pthread_mutexattr_init before use and destroyed after; `mutex` is
    // writable (contract) and its `impl_` becomes an initialised mutex.
    unsafe {
        libc::pthread_mutexattr_init(attr.as_mut_ptr());
        libc::pthread_mutexattr_settype(attr.as_mut_ptr(), libc::PTHREAD_MUTEX_RECURSIVE);
        libc::pthread_mutex_init(core::ptr::addr_of_mut!((*mutex).impl_), attr.as_ptr());
        libc::pthread_mutexattr_destroy(attr.as_mut_ptr());
    }
}

/// `uxr_lock`.
///
/// # Safety
/// `mutex` null or initialised by `uxr_init_lock`.
#[no_mangle]
pub unsafe extern "C" fn uxr_lock(mutex: *mut uxrMutex) {
    if !mutex.is_null() {
        // SAFETY: an initialised mutex (contract).
        unsafe { libc::pthread_mutex_lock(core::ptr::addr_of_mut!((*mutex).impl_)) };
    }
}

/// `uxr_unlock`.
///
/// # Safety
/// `mutex` null or initialised by `uxr_init_lock` and locked by this thread.
#[no_mangle]
pub unsafe extern "C" fn uxr_unlock(mutex: *mut uxrMutex) {
    if !mutex.is_null() {
        // SAFETY: an initialised mutex this thread holds (contract).
        unsafe { libc::pthread_mutex_unlock(core::ptr::addr_of_mut!((*mutex).impl_)) };
    }
}

/// `uxr_get_stream_mutex_from_id`: the lock of `session`'s stream `stream_id` (the session's own, see the
/// module), null if the session has no such stream.
///
/// # Safety
/// `session` null or a `uxrSession`.
#[no_mangle]
pub unsafe extern "C" fn uxr_get_stream_mutex_from_id(
    session: *mut uxrSession,
    stream_id: uxrStreamId,
) -> *mut uxrMutex {
    if session.is_null() {
        return core::ptr::null_mut();
    }
    // SAFETY: a session (contract); the counts of its stream table are read, an address taken.
    let (t, own) = unsafe { (&*core::ptr::addr_of!((*session).streams), core::ptr::addr_of_mut!((*session).mutex)) };
    let count = match (stream_id.type_, u32::from(stream_id.direction)) {
        (BEST_EFFORT_STREAM, OUTPUT_STREAM) => t.output_best_effort_size,
        (RELIABLE_STREAM, OUTPUT_STREAM) => t.output_reliable_size,
        (BEST_EFFORT_STREAM, INPUT_STREAM) => t.input_best_effort_size,
        (RELIABLE_STREAM, INPUT_STREAM) => t.input_reliable_size,
        _ => 0,
    };
    if usize::from(stream_id.index) < usize::from(count) {
        own
    } else {
        core::ptr::null_mut()
    }
}

/// Every lock of `session`: its own, then its streams' (all slots, created or not: initialised with it).
fn locks(session: *mut uxrSession) -> impl Iterator<Item = *mut uxrMutex> {
    // SAFETY: only addresses inside the session are computed; callers pass a non-null `uxrSession`.
    let (own, t) = unsafe { (core::ptr::addr_of_mut!((*session).mutex), core::ptr::addr_of_mut!((*session).streams)) };
    // SAFETY: as above.
    let streams = unsafe {
        let obe = (*t).output_best_effort.iter_mut().map(|s| core::ptr::from_mut(&mut s.mutex));
        let ore = (*t).output_reliable.iter_mut().map(|s| core::ptr::from_mut(&mut s.mutex));
        let ibe = (*t).input_best_effort.iter_mut().map(|s| core::ptr::from_mut(&mut s.mutex));
        let ire = (*t).input_reliable.iter_mut().map(|s| core::ptr::from_mut(&mut s.mutex));
        obe.chain(ore).chain(ibe).chain(ire)
    };
    core::iter::once(own).chain(streams)
}

/// Initialises every lock of a session (`uxr_init_session`).
///
/// # Safety
/// `session` a writable `uxrSession` no thread uses.
pub unsafe fn init_session(session: *mut uxrSession) {
    for m in locks(session) {
        // SAFETY: contract.
        unsafe { uxr_init_lock(m) };
    }
}

/// Takes the session's lock (other threads wait; this one may hold it already: recursive); released by
/// [`release`].
///
/// # Safety
/// `session` an initialised `uxrSession`.
pub unsafe fn acquire(session: *mut uxrSession) {
    // SAFETY: contract: initialised by `init_session`; only the field's address is taken.
    unsafe { uxr_lock(core::ptr::addr_of_mut!((*session).mutex)) };
}

/// Releases what [`acquire`] took.
///
/// # Safety
/// `session` an initialised `uxrSession` whose lock this thread took with [`acquire`].
pub unsafe fn release(session: *mut uxrSession) {
    // SAFETY: contract.
    unsafe { uxr_unlock(core::ptr::addr_of_mut!((*session).mutex)) };
}

/// Takes the lock of one stream (`uxr_prepare_output_stream*`, before the bytes are reserved: on success the
/// program releases it with `UXR_UNLOCK_STREAM_ID`, on failure [`release_stream`] does).
///
/// # Safety
/// `session` an initialised `uxrSession`.
pub unsafe fn hold_stream(session: *mut uxrSession, stream_id: uxrStreamId) {
    // SAFETY: contract.
    unsafe { uxr_lock(uxr_get_stream_mutex_from_id(session, stream_id)) };
}

/// Gives back what [`hold_stream`] took.
///
/// # Safety
/// `session` an initialised `uxrSession`; this thread holds the stream's lock.
pub unsafe fn release_stream(session: *mut uxrSession, stream_id: uxrStreamId) {
    // SAFETY: contract.
    unsafe { uxr_unlock(uxr_get_stream_mutex_from_id(session, stream_id)) };
}
