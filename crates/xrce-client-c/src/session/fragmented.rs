//! `uxr_prepare_output_stream_fragmented`: a sample larger than the whole reliable history, serialized
//! through a `ucdrBuffer` whose memory is a small window in the session. Each time the window is full
//! (the buffer's on-full callback) its bytes go into the stream (`push_fragmented` of the Rust client) and,
//! while the history has no room, the program's flush callback runs the session. The last window goes at the
//! session's next call. Every announced byte is sent, zeros where nothing was written, as the seed says.

use core::ffi::c_void;
use core::ptr::{addr_of, addr_of_mut};

use xrce_client::{StreamId, WriteAccess};

use super::{slot, uxrSession, with_session};
use crate::abi::{uxrObjectId, uxrStreamId};
use crate::ucdr::buffer::{ucdrBuffer, LITTLE};

/// Bytes serialized between two pushes into the stream.
const WINDOW: usize = 64;
/// Flush callbacks tried in a row without the history taking a byte before the write is given up.
const MAX_FLUSHES: usize = 64;

/// `uxrOnBuffersFull`.
pub type OnBuffersFull = Option<unsafe extern "C" fn(*mut uxrSession) -> bool>;

/// A fragmented write in progress.
#[derive(Debug)]
pub struct Fragment {
    active: bool,
    stream: StreamId,
    flush: OnBuffersFull,
    /// Bytes of the sample not yet pushed, the window's included.
    left: usize,
    /// Bytes of the sample in the window.
    window_len: usize,
    window: [u8; WINDOW],
}

impl Fragment {
    /// No write in progress.
    pub const fn idle() -> Self {
        Self { active: false, stream: StreamId::NONE, flush: None, left: 0, window_len: 0, window: [0; WINDOW] }
    }

    /// Opens the next window (zeroed) and points `ub` at it, its offset going on from where it was.
    fn next_window(&mut self, ub: &mut ucdrBuffer) {
        self.window = [0; WINDOW];
        self.window_len = self.left.min(WINDOW);
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
            let Some(flush) = fragment.flush.filter(|_| flushes < MAX_FLUSHES) else { return false };
            flushes = if taken > 0 { 0 } else { flushes + 1 };
            // SAFETY: the program's callback with its own session, which is not busy here.
            if !unsafe { flush(session) } {
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
    // SAFETY: contract: an initialised session.
    let Some(slot) = (unsafe { slot(session) }) else { return false };
    // SAFETY: an initialised slot; `pushing` is only reached through shared references.
    let pushing = unsafe { &*addr_of!((*slot).pushing) };
    pushing.set(true);
    // SAFETY: contract.
    let pushed = unsafe { push_window(session, fragment) };
    pushing.set(false);
    pushed
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
            fragment.active = false;
        }
        fragment.window = [0; WINDOW];
        fragment.window_len = fragment.left.min(WINDOW);
    }
}

/// The `ucdrBuffer`'s on-full callback: pushes the window, opens the next.
///
/// # Safety
/// `ub` the buffer prepared by [`uxr_prepare_output_stream_fragmented`], `args` its session.
unsafe extern "C" fn on_window_full(ub: *mut ucdrBuffer, args: *mut c_void) -> bool {
    let session = args.cast::<uxrSession>();
    // SAFETY: contract.
    let (Some(ub), Some(fragment)) = (unsafe { ub.as_mut() }, unsafe { fragment(session) }) else { return true };
    // SAFETY: contract.
    if !fragment.active || !unsafe { push_window_guarded(session, fragment) } {
        fragment.active = false;
        return true;
    }
    fragment.next_window(ub);
    fragment.window_len == 0
}

/// `uxr_prepare_output_stream_fragmented`: the request id, 0 on failure (best-effort stream, another write
/// in progress, a bad session). Serialize into `ub`; `flush_callback` runs the session when the history is full.
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
) -> u16 {
    // SAFETY: contract.
    let (Some(ub), Some(fragment)) = (unsafe { ub.as_mut() }, unsafe { fragment(session) }) else { return 0 };
    *ub = ucdrBuffer::over(core::ptr::null_mut(), 0, 0, 0, LITTLE);
    if fragment.active {
        return 0;
    }
    let stream = stream_id.rust();
    // SAFETY: contract.
    let request = unsafe {
        with_session(session, 0, |s| s.outputs().begin_fragmented(stream, entity_id.rust(), data_size).unwrap_or(0))
    };
    if request == 0 {
        return 0;
    }
    *fragment = Fragment { active: true, stream, flush: flush_callback, left: data_size, ..Fragment::idle() };
    fragment.next_window(ub);
    ub.on_full_buffer = Some(on_window_full);
    ub.args = session.cast();
    request
}
