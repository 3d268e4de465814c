//! Creating the session's streams over memory the C program lends for the session's lifetime, and recording
//! them in the session's `streams` table.

use super::public::uxrReliableStream;
use super::{uxrSession, with_session};
use crate::abi::{uxrStreamId, INPUT_STREAM, OUTPUT_STREAM};

/// Grows the count of a `streams` table to include the stream at `index`.
fn count(size: &mut u8, index: usize) {
    *size = (*size).max(u8::try_from(index + 1).unwrap_or(u8::MAX));
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
        // Recorded in `session->streams` by the kind known here, not decoded from the id (firmware size).
        let index = usize::from(id.index);
        let base = uxrReliableStream { buffer, size, history };
        // SAFETY: contract: a session (the stream was created in it); the table is a named field, plain data
        // outside the Rust session's memory.
        let t = unsafe { &mut *field!(session, streams) };
        match kind {
            Lent::OutputBestEffort => {
                if let Some(s) = t.output_best_effort.get_mut(index) {
                    s.buffer = buffer;
                    s.size = size;
                    count(&mut t.output_best_effort_size, index);
                }
            }
            Lent::OutputReliable => {
                if let Some(s) = t.output_reliable.get_mut(index) {
                    s.base = base;
                    count(&mut t.output_reliable_size, index);
                }
            }
            Lent::InputReliable => {
                if let Some(s) = t.input_reliable.get_mut(index) {
                    s.base = base;
                    count(&mut t.input_reliable_size, index);
                }
            }
        }
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
        // SAFETY: contract: a session (the stream was created in it); a named field.
        count(unsafe { &mut (*field!(session, streams)).input_best_effort_size }, usize::from(id.index));
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
