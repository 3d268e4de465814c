//! Samples larger than one message, serialized in place through a `ucdrBuffer` whose memory is a small window
//! in the session. Each time the window is full (the buffer's on-full callback) its bytes go into the reliable
//! stream as FRAGMENT submessages (`push_fragmented` of the Rust client). Two ways in:
//!
//! * `uxr_prepare_output_stream_fragmented` (eProsima's 7 arguments, or the seed's 6): a sample larger than
//!   the whole history; while the history has no room the program's flush callback runs the session;
//! * `uxr_prepare_output_stream` of a sample larger than a message on a reliable stream: it must fit the
//!   stream's free history whole (checked first, as eProsima's library does), so pushing never waits.
//!
//! The last window goes at the session's next call. Every announced byte is sent, zeros where nothing was
//! written, as the seed says.

use core::ffi::c_void;
use core::ptr::{addr_of, addr_of_mut};

use xrce_client::{StreamId, WriteAccess};

use super::public::{uxrContinuousArgs, OnBuffersFull};
use super::{set_field, slot, slot_at, uxrSession, with_session};
use crate::abi::{uxrObjectId, uxrStreamId, OUTPUT_STREAM};
use crate::ucdr::buffer::{ucdrBuffer, LITTLE};

/// Bytes serialized between two pushes into the stream.
const WINDOW: usize = 64;
/// Flush callbacks tried in a row without the history taking a byte before the write is given up.
const MAX_FLUSHES: usize = 64;

/// The seed's flush callback (`bool f(uxrSession*)`).
pub type OnBuffersFullSeed = Option<unsafe extern "C" fn(*mut uxrSession) -> bool>;

/// What runs the session when the history is full.
#[derive(Debug, Clone, Copy)]
enum Flush {
    /// Nothing: the write was checked to fit.
    Never,
    /// The seed's one-argument callback.
    Seed(unsafe extern "C" fn(*mut uxrSession) -> bool),
    /// eProsima's callback and its argument.
    WithArgs(unsafe extern "C" fn(*mut uxrSession, *mut c_void) -> bool, *mut c_void),
}

impl Flush {
    /// Calls the callback; `None` when there is none.
    ///
    /// # Safety
    /// `session` the session the callback was given with, not busy.
    unsafe fn call(self, session: *mut uxrSession) -> Option<bool> {
        match self {
            Self::Never => None,
            // SAFETY: the program's callback with its own session (contract).
            Self::Seed(f) => Some(unsafe { f(session) }),
            // SAFETY: as above, with the program's own argument.
            Self::WithArgs(f, args) => Some(unsafe { f(session, args) }),
        }
    }
}

/// A fragmented write in progress.
#[derive(Debug)]
pub struct Fragment {
    active: bool,
    stream: StreamId,
    flush: Flush,
    /// Bytes of the sample not yet pushed, the window's included.
    left: usize,
    /// Bytes of the sample in the window.
    window_len: usize,
    window: [u8; WINDOW],
}

impl Fragment {
    /// No write in progress.
    pub const fn idle() -> Self {
        Self { active: false, stream: StreamId::NONE, flush: Flush::Never, left: 0, window_len: 0, window: [0; WINDOW] }
    }

    /// Zeroes the window and sizes it for what is left. Out of line, one copy for its two callers (firmware
    /// size).
    #[inline(never)]
    fn clear_window(&mut self) {
        self.window = [0; WINDOW];
        self.window_len = self.left.min(WINDOW);
    }

    /// Opens the next window (zeroed) and points `ub` at it, its offset going on from where it was.
    fn next_window(&mut self, ub: &mut ucdrBuffer) {
        self.clear_window();
        let start = self.window.as_mut_ptr();
        ub.init = start;
        ub.iterator = start;
        ub.final_ = start.wrapping_add(self.window_len);
        ub.origin = ub.offset;
    }
}

/// Pushes the window of `session`'s fragmented write into its stream, calling the flush callback while the
/// history is full; whether all of it went. Called with the session not busy, so the callback may run it.
///
/// # Safety
/// `session` an initialised session; `fragment` its fragment, not otherwise borrowed.
unsafe fn push_window(session: *mut uxrSession, fragment: &mut Fragment) -> bool {
    let mut sent = 0;
    let mut flushes = 0;
    while sent < fragment.window_len {
        let bytes = fragment.window.get(sent..fragment.window_len).unwrap_or(&[]);
        let stream = fragment.stream;
        // SAFETY: contract.
        let taken = unsafe { with_session(session, 0, |s| s.outputs().push_fragmented(stream, bytes).unwrap_or(0)) };
        sent += taken;
        if sent < fragment.window_len {
            if flushes >= MAX_FLUSHES {
                return false;
            }
            flushes = if taken > 0 { 0 } else { flushes + 1 };
            // SAFETY: the session is not busy here (contract).
            if unsafe { fragment.flush.call(session) } != Some(true) {
                return false;
            }
        }
    }
    fragment.left -= fragment.window_len;
    fragment.window_len = 0;
    true
}

/// The fragment of an initialised session, `None` while its window is being pushed (a flush callback running
/// the session).
///
/// # Safety
/// `session` null or a `uxrSession`.
unsafe fn fragment<'f>(session: *mut uxrSession) -> Option<&'f mut Fragment> {
    // SAFETY: contract.
    let slot = unsafe { slot(session) }?;
    // SAFETY: an initialised slot; `pushing` is only reached through shared references.
    if unsafe { &*addr_of!((*slot).pushing) }.get() {
        return None;
    }
    // SAFETY: not being pushed, so no other reference to the fragment is live: the functions here take it
    // once per call and set `pushing` before anything that may call back into the program.
    Some(unsafe { &mut *addr_of_mut!((*slot).fragment) })
}

/// [`push_window`] with the `pushing` flag of `session` set around it.
///
/// # Safety
/// As [`push_window`].
unsafe fn push_window_guarded(session: *mut uxrSession, fragment: &mut Fragment) -> bool {
    // Not checked again: the caller found the fragment in this slot (firmware size).
    let slot = slot_at(session);
    // SAFETY: contract: an initialised session, so an initialised slot; `pushing` is only reached through
    // shared references.
    let pushing = unsafe { &*addr_of!((*slot).pushing) };
    pushing.set(true);
    // SAFETY: contract.
    let pushed = unsafe { push_window(session, fragment) };
    pushing.set(false);
    pushed
}

/// Ends the write of `session` (`continuous_args` cleared).
///
/// # Safety
/// `session` null or a `uxrSession`.
unsafe fn end(session: *mut uxrSession, fragment: &mut Fragment) {
    fragment.active = false;
    let idle = uxrContinuousArgs {
        flush_callback: None,
        flush_callback_args: core::ptr::null_mut(),
        stream_id: uxrStreamId::none(OUTPUT_STREAM),
        data_size: 0,
    };
    // SAFETY: contract; a named field.
    unsafe { set_field(session, |s| field!(s, continuous_args), idle) };
}

/// Sends the last window of a fragmented write (at the session's next call), then zeros for whatever the
/// program left unwritten.
///
/// # Safety
/// `session` null or a `uxrSession`, not busy.
pub unsafe fn finish_pending(session: *mut uxrSession) {
    // SAFETY: contract.
    let Some(fragment) = (unsafe { fragment(session) }) else { return };
    while fragment.active {
        // SAFETY: contract.
        if !unsafe { push_window_guarded(session, fragment) } || fragment.left == 0 {
            // SAFETY: contract.
            unsafe { end(session, fragment) };
        }
        fragment.clear_window();
    }
}

/// The `ucdrBuffer`'s on-full callback: pushes the window, opens the next.
///
/// # Safety
/// `ub` the buffer prepared by [`begin`], `args` its session.
unsafe extern "C" fn on_window_full(ub: *mut ucdrBuffer, args: *mut c_void) -> bool {
    let session = args.cast::<uxrSession>();
    // SAFETY: contract.
    let (Some(ub), Some(fragment)) = (unsafe { ub.as_mut() }, unsafe { fragment(session) }) else { return true };
    // SAFETY: contract.
    if !fragment.active || !unsafe { push_window_guarded(session, fragment) } {
        // SAFETY: contract.
        unsafe { end(session, fragment) };
        return true;
    }
    fragment.next_window(ub);
    fragment.window_len == 0
}

/// Starts a fragmented write of `data_size` bytes and points `ub` at its first window; the request id, 0 on
/// failure (best-effort stream, another write in progress, a bad session, no room when `flush` is `Never`).
///
/// # Safety
/// `session` null or a `uxrSession`, not busy; `ub` null or writable and used only for this sample.
unsafe fn begin(
    session: *mut uxrSession,
    stream_id: uxrStreamId,
    entity_id: uxrObjectId,
    ub: *mut ucdrBuffer,
    data_size: usize,
    flush: Flush,
) -> u16 {
    // SAFETY: contract.
    unsafe { finish_pending(session) };
    // The stream's lock is taken before the write starts and kept, if it starts, until the program's
    // UXR_UNLOCK_STREAM_ID (multithread profile): no other thread sends a window half-written.
    #[cfg(uxr_multithread)]
    // SAFETY: contract (a session, or null: no lock).
    unsafe {
        crate::lock::hold_stream(session, stream_id);
    }
    // SAFETY: contract.
    let request = unsafe { start(session, stream_id, entity_id, ub, data_size, flush) };
    #[cfg(uxr_multithread)]
    if request == 0 {
        // SAFETY: taken above by this thread.
        unsafe { crate::lock::release_stream(session, stream_id) };
    }
    request
}

/// [`begin`] without the lock.
///
/// # Safety
/// As [`begin`].
unsafe fn start(
    session: *mut uxrSession,
    stream_id: uxrStreamId,
    entity_id: uxrObjectId,
    ub: *mut ucdrBuffer,
    data_size: usize,
    flush: Flush,
) -> u16 {
    // SAFETY: contract.
    let (Some(ub), Some(fragment)) = (unsafe { ub.as_mut() }, unsafe { fragment(session) }) else { return 0 };
    *ub = ucdrBuffer::over(core::ptr::null_mut(), 0, 0, 0, LITTLE);
    if fragment.active {
        return 0;
    }
    let stream = stream_id.rust();
    let mut flushes = 0;
    let request = loop {
        // SAFETY: contract.
        let started = unsafe {
            with_session(session, Err(xrce_client::Error::Busy), |s| {
                let mut out = s.outputs();
                match flush {
                    Flush::Never => out.begin_fragmented_whole(stream, entity_id.rust(), data_size),
                    _ => out.begin_fragmented(stream, entity_id.rust(), data_size),
                }
            })
        };
        match started {
            Ok(request) => break request,
            // The history is full now: as eProsima's library, let the flush callback make room first (none for
            // a write checked to fit: matched here, so that path holds no flush loop).
            Err(xrce_client::Error::WouldBlock) if flushes < MAX_FLUSHES && !matches!(flush, Flush::Never) => {
                flushes += 1;
                // SAFETY: the session is not busy here (contract).
                if unsafe { flush.call(session) } != Some(true) {
                    return 0;
                }
            }
            Err(_) => return 0,
        }
    };
    // Field by field: `next_window` zeroes the window (one clear, not two).
    fragment.active = true;
    fragment.stream = stream;
    fragment.flush = flush;
    fragment.left = data_size;
    fragment.next_window(ub);
    ub.on_full_buffer = Some(on_window_full);
    ub.args = session.cast();
    let (flush_callback, flush_callback_args) = match flush {
        Flush::WithArgs(f, args) => (Some(f), args),
        _ => (None, core::ptr::null_mut()),
    };
    let args = uxrContinuousArgs { flush_callback, flush_callback_args, stream_id, data_size };
    // SAFETY: contract; a named field.
    unsafe { set_field(session, |s| field!(s, continuous_args), args) };
    request
}

/// `uxr_prepare_output_stream` of a sample larger than a message on a reliable stream: fragments over the
/// stream's slots, all of them free now (0 otherwise).
///
/// # Safety
/// As [`begin`].
pub unsafe fn prepare_whole(
    session: *mut uxrSession,
    stream_id: uxrStreamId,
    entity_id: uxrObjectId,
    ub: *mut ucdrBuffer,
    data_size: usize,
) -> u16 {
    // SAFETY: contract.
    unsafe { begin(session, stream_id, entity_id, ub, data_size, Flush::Never) }
}

/// `uxr_prepare_output_stream_fragmented` (eProsima's form): the request id, 0 on failure. Serialize into
/// `ub`; `flush_callback(session, flush_callback_args)` runs the session when the history is full.
///
/// # Safety
/// `session` null or a `uxrSession`; `ub` null or writable and used only for this sample.
#[no_mangle]
pub unsafe extern "C" fn uxr_prepare_output_stream_fragmented(
    session: *mut uxrSession,
    stream_id: uxrStreamId,
    entity_id: uxrObjectId,
    ub: *mut ucdrBuffer,
    data_size: usize,
    flush_callback: OnBuffersFull,
    flush_callback_args: *mut c_void,
) -> u16 {
    let flush = flush_callback.map_or(Flush::Never, |f| Flush::WithArgs(f, flush_callback_args));
    // SAFETY: contract.
    unsafe { begin(session, stream_id, entity_id, ub, data_size, flush) }
}

/// `uxr_prepare_output_stream_fragmented` as the seed's text writes it (a one-argument flush callback); the
/// header's macro picks it for a call with six arguments.
///
/// # Safety
/// As [`uxr_prepare_output_stream_fragmented`].
#[no_mangle]
pub unsafe extern "C" fn uxr_prepare_output_stream_fragmented_seed(
    session: *mut uxrSession,
    stream_id: uxrStreamId,
    entity_id: uxrObjectId,
    ub: *mut ucdrBuffer,
    data_size: usize,
    flush_callback: OnBuffersFullSeed,
) -> u16 {
    let flush = flush_callback.map_or(Flush::Never, Flush::Seed);
    // SAFETY: contract.
    unsafe { begin(session, stream_id, entity_id, ub, data_size, flush) }
}
