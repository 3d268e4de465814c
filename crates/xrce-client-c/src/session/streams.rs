//! Creating the session's streams over memory the C program lends for the session's lifetime.

use super::{uxrSession, with_session, Inner};
use crate::abi::{uxrStreamId, INPUT_STREAM, OUTPUT_STREAM};
use xrce_client::{Result, StreamId};

/// Lends `size` bytes at `buffer` to the session and creates a stream over them with `create`; the "none"
/// stream on any failure (null memory, too many streams, a history that does not divide the buffer).
///
/// # Safety
/// `session` null or a `uxrSession`; `buffer` null or `size` writable bytes that outlive the session and that
/// the program no longer touches.
unsafe fn lend(
    session: *mut uxrSession,
    buffer: *mut u8,
    size: usize,
    direction: u32,
    create: impl FnOnce(&mut Inner, &'static mut [u8]) -> Result<StreamId>,
) -> uxrStreamId {
    let none = uxrStreamId::none(direction);
    if buffer.is_null() || size == 0 {
        return none;
    }
    // SAFETY: contract: the memory is the session's from now on.
    let memory = unsafe { core::slice::from_raw_parts_mut(buffer, size) };
    // SAFETY: contract.
    unsafe {
        with_session(session, none, |s| create(s, memory).map_or(none, |id| uxrStreamId::from_rust(id, direction)))
    }
}

/// `uxr_create_output_best_effort_stream`.
///
/// # Safety
/// As `lend`: the buffer belongs to the session from now on.
#[no_mangle]
pub unsafe extern "C" fn uxr_create_output_best_effort_stream(
    session: *mut uxrSession,
    buffer: *mut u8,
    size: usize,
) -> uxrStreamId {
    // SAFETY: contract.
    unsafe { lend(session, buffer, size, OUTPUT_STREAM, |s, m| s.create_output_best_effort_stream(m)) }
}

/// `uxr_create_output_reliable_stream`: `history` a power of two dividing `size`.
///
/// # Safety
/// As `lend`.
#[no_mangle]
pub unsafe extern "C" fn uxr_create_output_reliable_stream(
    session: *mut uxrSession,
    buffer: *mut u8,
    size: usize,
    history: usize,
) -> uxrStreamId {
    // SAFETY: contract.
    unsafe { lend(session, buffer, size, OUTPUT_STREAM, |s, m| s.create_output_reliable_stream(m, history)) }
}

/// `uxr_create_input_best_effort_stream`.
///
/// # Safety
/// `session` null or a `uxrSession`.
#[no_mangle]
pub unsafe extern "C" fn uxr_create_input_best_effort_stream(session: *mut uxrSession) -> uxrStreamId {
    let none = uxrStreamId::none(INPUT_STREAM);
    // SAFETY: contract.
    unsafe {
        with_session(session, none, |s| {
            s.create_input_best_effort_stream().map_or(none, |id| uxrStreamId::from_rust(id, INPUT_STREAM))
        })
    }
}

/// `uxr_create_input_reliable_stream`.
///
/// # Safety
/// As `lend`.
#[no_mangle]
pub unsafe extern "C" fn uxr_create_input_reliable_stream(
    session: *mut uxrSession,
    buffer: *mut u8,
    size: usize,
    history: usize,
) -> uxrStreamId {
    // SAFETY: contract.
    unsafe { lend(session, buffer, size, INPUT_STREAM, |s, m| s.create_input_reliable_stream(m, history)) }
}
