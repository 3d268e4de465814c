//! Creating and deleting the session, the `uxr_run_session_*` family, time and ping.

use super::fragmented::finish_pending;
use super::public::{NO_PONG, PONG_NO_SESSION, STATUS_NONE};
use super::{get_field, set_field, uxrSession, with_session, Inner};
use crate::comm::{uxrCommunication, Comm};

/// [`with_session`] for the functions that send: the last window of a fragmented write goes first.
///
/// # Safety
/// `session` null or a `uxrSession`.
unsafe fn sending<R>(session: *mut uxrSession, fallback: R, f: impl FnOnce(&mut Inner) -> R) -> R {
    // SAFETY: contract.
    unsafe {
        finish_pending(session);
        with_session(session, fallback, f)
    }
}

macro_rules! run_fn {
    ($(#[$m:meta])* $name:ident => $method:ident) => {
        $(#[$m])*
        ///
        /// # Safety
        /// `session` null or a `uxrSession`.
        #[no_mangle]
        pub unsafe extern "C" fn $name(session: *mut uxrSession, timeout_ms: i32) -> bool {
            // SAFETY: contract.
            unsafe { sending(session, false, |s| s.$method(timeout_ms).unwrap_or(false)) }
        }
    };
}

/// `uxr_create_session`: whether the agent accepted the session.
///
/// # Safety
/// `session` null or a `uxrSession`.
#[no_mangle]
pub unsafe extern "C" fn uxr_create_session(session: *mut uxrSession) -> bool {
    // SAFETY: contract.
    unsafe { session_request(session, false, xrce_client::session::CREATE_SESSION_ATTEMPTS) }
}

/// Runs a create (`delete` false) or delete of the session with `attempts` sends and records its status in
/// `info.last_requested_status`, as eProsima's library does: `UXR_STATUS_OK`, the agent's refusal, or
/// `UXR_STATUS_NONE` without an answer. One function for the four entry points (firmware size).
///
/// # Safety
/// `session` null or a `uxrSession`.
#[inline(never)]
unsafe fn session_request(session: *mut uxrSession, delete: bool, attempts: usize) -> bool {
    // SAFETY: contract.
    let (ok, status) = unsafe {
        sending(session, (false, STATUS_NONE), |s| {
            match if delete {
                s.delete_session_retries(attempts)
            } else {
                s.create_session_retries(attempts).map(|()| true)
            } {
                Ok(done) => (done, if done { 0 } else { STATUS_NONE }),
                Err(xrce_client::Error::Refused(code)) => (false, code),
                Err(_) => (false, STATUS_NONE),
            }
        })
    };
    // SAFETY: contract; a named field.
    unsafe { set_field(session, |s| field!(s, info.last_requested_status), status) };
    ok
}

/// `uxr_create_session_retries`.
///
/// # Safety
/// `session` null or a `uxrSession`.
#[no_mangle]
pub unsafe extern "C" fn uxr_create_session_retries(session: *mut uxrSession, retries: usize) -> bool {
    // No attempt at all, as eProsima's (a program passing 0 means "do not try").
    if retries == 0 {
        return false;
    }
    // SAFETY: contract.
    unsafe { session_request(session, false, retries) }
}

/// `uxr_delete_session`: whether the agent confirmed.
///
/// # Safety
/// `session` null or a `uxrSession`.
#[no_mangle]
pub unsafe extern "C" fn uxr_delete_session(session: *mut uxrSession) -> bool {
    // SAFETY: contract.
    unsafe { session_request(session, true, xrce_client::session::CREATE_SESSION_ATTEMPTS) }
}

/// `uxr_delete_session_retries`.
///
/// # Safety
/// `session` null or a `uxrSession`.
#[no_mangle]
pub unsafe extern "C" fn uxr_delete_session_retries(session: *mut uxrSession, retries: usize) -> bool {
    // No attempt at all, as eProsima's: PX4 passes 0 when it gives a dead agent up.
    if retries == 0 {
        return false;
    }
    // SAFETY: contract.
    unsafe { session_request(session, true, retries) }
}

/// `uxr_flash_output_streams`.
///
/// # Safety
/// `session` null or a `uxrSession`.
#[no_mangle]
pub unsafe extern "C" fn uxr_flash_output_streams(session: *mut uxrSession) {
    // SAFETY: contract.
    unsafe {
        sending(session, (), |s| {
            let _ = s.flash_output_streams();
        })
    }
}

run_fn!(
    /// `uxr_run_session_time`: whether the output was confirmed.
    uxr_run_session_time => run_session_time
);
run_fn!(
    /// `uxr_run_session_timeout`: whether the output was confirmed.
    uxr_run_session_timeout => run_session_timeout
);
run_fn!(
    /// `uxr_run_session_until_timeout`: whether a message arrived.
    uxr_run_session_until_timeout => run_session_until_timeout
);
run_fn!(
    /// `uxr_run_session_until_confirm_delivery`.
    uxr_run_session_until_confirm_delivery => run_session_until_confirm_delivery
);
/// `uxr_run_session_until_data`: clears `on_data_flag`, which the next sample, request or reply sets.
///
/// # Safety
/// `session` null or a `uxrSession`.
#[no_mangle]
pub unsafe extern "C" fn uxr_run_session_until_data(session: *mut uxrSession, timeout_ms: i32) -> bool {
    // SAFETY: contract.
    unsafe {
        set_field(session, |s| field!(s, on_data_flag), false);
        sending(session, false, |s| s.run_session_until_data(timeout_ms).unwrap_or(false))
    }
}

/// `uxr_sync_session`: one TIMESTAMP, then waits up to `timeout_ms` for the reply; `synchronized` tells.
/// Without a time callback the library sets `time_offset`; with one, the callback does.
///
/// # Safety
/// `session` null or a `uxrSession`.
#[no_mangle]
pub unsafe extern "C" fn uxr_sync_session(session: *mut uxrSession, timeout_ms: i32) -> bool {
    // SAFETY: contract.
    unsafe {
        set_field(session, |s| field!(s, synchronized), false);
        sending(session, (), |s| {
            let _ = s.sync_session(timeout_ms);
        });
        get_field(session, false, |s| field!(s, synchronized))
    }
}

/// The request and status lists of the `until_*_status` functions; `None` when either is null (with a size).
///
/// # Safety
/// `requests` holds `n` ids and `statuses` `n` writable bytes, or either is null.
unsafe fn lists<'l>(requests: *const u16, statuses: *mut u8, n: usize) -> Option<(&'l [u16], &'l mut [u8])> {
    if n == 0 {
        return Some((&[], &mut []));
    }
    if requests.is_null() || statuses.is_null() {
        return None;
    }
    // SAFETY: non-null with `n` elements each (contract).
    unsafe { Some((core::slice::from_raw_parts(requests, n), core::slice::from_raw_parts_mut(statuses, n))) }
}

/// The Rust session's `run_session_until_all_status` or `_one_status`.
type StatusWait = fn(&mut Inner, i32, &[u16], &mut [u8]) -> xrce_client::Result<bool>;

/// Runs `wait` over the C lists.
///
/// # Safety
/// `session` null or a `uxrSession`; the lists as `lists` says.
unsafe fn until_status(
    session: *mut uxrSession,
    timeout_ms: i32,
    request_list: *const u16,
    status_list: *mut u8,
    list_size: usize,
    wait: StatusWait,
) -> bool {
    // SAFETY: contract.
    let Some((requests, statuses)) = (unsafe { lists(request_list, status_list, list_size) }) else { return false };
    // Null checked once here, not at each field (firmware size); a null session would fail below anyway.
    if session.is_null() {
        return false;
    }
    // The lists are visible in the session while the call runs, as in eProsima's library.
    // SAFETY: contract, non-null: a session; named fields.
    unsafe {
        field!(session, request_list).write(request_list);
        field!(session, status_list).write(status_list);
        field!(session, request_status_list_size).write(list_size);
    }
    // SAFETY: contract.
    let done = unsafe { sending(session, false, |s| wait(s, timeout_ms, requests, statuses).unwrap_or(false)) };
    // SAFETY: as above.
    unsafe {
        field!(session, request_list).write(core::ptr::null());
        field!(session, status_list).write(core::ptr::null_mut());
        field!(session, request_status_list_size).write(0);
    }
    done
}

/// `uxr_run_session_until_all_status`.
///
/// # Safety
/// `session` null or a `uxrSession`; the lists as `lists` says.
#[no_mangle]
pub unsafe extern "C" fn uxr_run_session_until_all_status(
    session: *mut uxrSession,
    timeout_ms: i32,
    request_list: *const u16,
    status_list: *mut u8,
    list_size: usize,
) -> bool {
    // SAFETY: contract.
    unsafe {
        until_status(session, timeout_ms, request_list, status_list, list_size, |s, t, r, st| {
            s.run_session_until_all_status(t, r, st)
        })
    }
}

/// `uxr_run_session_until_one_status`.
///
/// # Safety
/// As [`uxr_run_session_until_all_status`].
#[no_mangle]
pub unsafe extern "C" fn uxr_run_session_until_one_status(
    session: *mut uxrSession,
    timeout_ms: i32,
    request_list: *const u16,
    status_list: *mut u8,
    list_size: usize,
) -> bool {
    // SAFETY: contract.
    unsafe {
        until_status(session, timeout_ms, request_list, status_list, list_size, |s, t, r, st| {
            s.run_session_until_one_status(t, r, st)
        })
    }
}

/// `uxr_epoch_millis`: the agent's clock, milliseconds (the local one minus `time_offset`, which
/// `uxr_sync_session` or the program's time callback sets); 0 for a null session.
///
/// # Safety
/// `session` null or a `uxrSession`.
#[no_mangle]
pub unsafe extern "C" fn uxr_epoch_millis(session: *mut uxrSession) -> i64 {
    // SAFETY: contract.
    unsafe { uxr_epoch_nanos(session) / 1_000_000 }
}

/// `uxr_epoch_nanos`: the agent's clock, nanoseconds: `uxr_nanos() - session->time_offset`.
///
/// # Safety
/// `session` null or a `uxrSession`.
#[no_mangle]
pub unsafe extern "C" fn uxr_epoch_nanos(session: *mut uxrSession) -> i64 {
    if session.is_null() {
        return 0;
    }
    // SAFETY: contract; a named field.
    let offset = unsafe { get_field(session, 0, |s| field!(s, time_offset)) };
    crate::clock::uxr_nanos().saturating_sub(offset)
}

/// `uxr_ping_agent_session`: GET_INFO inside the session, `attempts` times, each waiting up to `timeout_ms`;
/// whether the agent answered knowing the session. `on_pong_flag` is cleared first and set by the answer,
/// also when it arrives after this call returns (a later run function processes it): PX4 pings with
/// `timeout_ms` 0 and reads the flag after its next run.
///
/// # Safety
/// `session` null or a `uxrSession`.
#[no_mangle]
pub unsafe extern "C" fn uxr_ping_agent_session(session: *mut uxrSession, timeout_ms: i32, attempts: u8) -> bool {
    // SAFETY: contract.
    unsafe {
        set_field(session, |s| field!(s, on_pong_flag), NO_PONG);
        let (answered, established) = with_session(session, (false, true), |s| {
            if s.core().state() == xrce_client::SessionState::Established {
                (s.ping_agent_session(timeout_ms, attempts).unwrap_or(false), true)
            } else {
                // Outside an established session eProsima's client still sends its GET_INFO and waits: an
                // agent answers without knowing the session, and the call returns false after the timeout, not
                // at once (a program retrying in a loop would spin).
                let pong = xrce_client::ping_agent_attempts(s.transport(), timeout_ms, attempts).unwrap_or(false);
                (pong, false)
            }
        });
        if !established {
            if answered {
                set_field(session, |s| field!(s, on_pong_flag), PONG_NO_SESSION);
            }
            return false;
        }
        answered
    }
}

/// `uxr_ping_agent`: one GET_INFO outside any session.
///
/// # Safety
/// `comm` null or an initialised transport's communication, not used by a running session meanwhile.
#[no_mangle]
pub unsafe extern "C" fn uxr_ping_agent(comm: *const uxrCommunication, timeout_ms: i32) -> bool {
    // SAFETY: contract.
    unsafe { uxr_ping_agent_attempts(comm, timeout_ms, 1) }
}

/// `uxr_ping_agent_attempts`.
///
/// # Safety
/// As [`uxr_ping_agent`].
#[no_mangle]
pub unsafe extern "C" fn uxr_ping_agent_attempts(comm: *const uxrCommunication, timeout_ms: i32, attempts: u8) -> bool {
    if comm.is_null() {
        return false;
    }
    xrce_client::ping_agent_attempts(&mut Comm(comm), timeout_ms, attempts).unwrap_or(false)
}
