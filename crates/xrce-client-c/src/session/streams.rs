//! Creating the session's streams over memory the C program lends for the session's lifetime, and recording
//! them in the session's `streams` table.

use super::public::uxrReliableStream;
use super::{uxrSession, with_session};
use crate::abi::{uxrStreamId, INPUT_STREAM, OUTPUT_STREAM};

/// Records a new stream in `session->streams`: its memory in slot `index` of its kind, and the count.
///
/// # Safety
/// `session` an initialised `uxrSession`.
unsafe fn record(session: *mut uxrSession, id: uxrStreamId, buffer: *mut u8, size: usize, history: u16) {
    let index = usize::from(id.index);
    let base = uxrReliableStream { buffer, size, history };
    let streams = field!(session, streams);
    // SAFETY: contract; the table is a named field, plain data outside the Rust session's memory.
    let t = unsafe { &mut *streams };
    let count = u8::try_from(index + 1).unwrap_or(u8::MAX);
    match (id.type_, u32::from(id.direction)) {
        (crate::abi::BEST_EFFORT_STREAM, OUTPUT_STREAM) => {
            if let Some(s) = t.output_best_effort.get_mut(index) {
                s.buffer = buffer;
                s.size = size;
                t.output_best_effort_size = t.output_best_effort_size.max(count);
            }
        }
        (crate::abi::RELIABLE_STREAM, OUTPUT_STREAM) => {
            if let Some(s) = t.output_reliable.get_mut(index) {
                s.base = base;
                t.output_reliable_size = t.output_reliable_size.max(count);
            }
        }
        (crate::abi::BEST_EFFORT_STREAM, _) => t.input_best_effort_size = t.input_best_effort_size.max(count),
        (crate::abi::RELIABLE_STREAM, _) => {
            if let Some(s) = t.input_reliable.get_mut(index) {
                s.base = base;
                t.input_reliable_size = t.input_reliable_size.max(count);
            }
        }
        _ => {}
    }
}

/// The streams made over memory the program lends.
#[derive(Clone, Copy)]
enum Lent {
    OutputBestEffort,
    OutputReliable,
    InputReliable,
}

/// Lends `size` bytes at `buffer` to the session and creates a stream of `kind` over them; the "none" stream on
/// any failure (null memory, too many streams, a history that does not divide the buffer). One out-of-line
/// function for the three entry points (firmware size).
///
/// # Safety
/// `session` null or a `uxrSession`; `buffer` null or `size` writable bytes that outlive the session and that
/// the program no longer touches.
#[inline(never)]
unsafe fn lend(session: *mut uxrSession, buffer: *mut u8, size: usize, history: u16, kind: Lent) -> uxrStreamId {
    let direction = if matches!(kind, Lent::InputReliable) { INPUT_STREAM } else { OUTPUT_STREAM };
    let none = uxrStreamId::none(direction);
    if buffer.is_null() || size == 0 {
        return none;
    }
    // SAFETY: contract: the memory is the session's from now on.
    let memory = unsafe { core::slice::from_raw_parts_mut(buffer, size) };
    // SAFETY: contract.
    let id = unsafe {
        with_session(session, none, |s| {
            match kind {
                Lent::OutputBestEffort => s.create_output_best_effort_stream(memory),
                Lent::OutputReliable => s.create_output_reliable_stream(memory, history.into()),
                Lent::InputReliable => s.create_input_reliable_stream(memory, history.into()),
            }
            .map_or(none, |id| uxrStreamId::from_rust(id, direction))
        })
    };
    if id.raw != 0 {
        // SAFETY: contract: a session (the stream was created in it).
        unsafe { record(session, id, buffer, size, history) };
    }
    id
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
    unsafe { lend(session, buffer, size, 0, Lent::OutputBestEffort) }
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
    history: u16,
) -> uxrStreamId {
    // SAFETY: contract.
    unsafe { lend(session, buffer, size, history, Lent::OutputReliable) }
}

/// `uxr_create_input_best_effort_stream`.
///
/// # Safety
/// `session` null or a `uxrSession`.
#[no_mangle]
pub unsafe extern "C" fn uxr_create_input_best_effort_stream(session: *mut uxrSession) -> uxrStreamId {
    let none = uxrStreamId::none(INPUT_STREAM);
    // SAFETY: contract.
    let id = unsafe {
        with_session(session, none, |s| {
            s.create_input_best_effort_stream().map_or(none, |id| uxrStreamId::from_rust(id, INPUT_STREAM))
        })
    };
    if id.raw != 0 {
        // SAFETY: contract: a session (the stream was created in it).
        unsafe { record(session, id, core::ptr::null_mut(), 0, 0) };
    }
    id
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
    history: u16,
) -> uxrStreamId {
    // SAFETY: contract.
    unsafe { lend(session, buffer, size, history, Lent::InputReliable) }
}
