//! Creating and deleting the session, the `uxr_run_session_*` family, time and ping.

use super::fragmented::finish_pending;
use super::{uxrSession, with_session, Inner};
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
    unsafe { with_session(session, false, |s| s.create_session().is_ok()) }
}

/// `uxr_create_session_retries`.
///
/// # Safety
/// `session` null or a `uxrSession`.
#[no_mangle]
pub unsafe extern "C" fn uxr_create_session_retries(session: *mut uxrSession, retries: usize) -> bool {
    // SAFETY: contract.
    unsafe { with_session(session, false, |s| s.create_session_retries(retries).is_ok()) }
}

/// `uxr_delete_session`: whether the agent confirmed.
///
/// # Safety
/// `session` null or a `uxrSession`.
#[no_mangle]
pub unsafe extern "C" fn uxr_delete_session(session: *mut uxrSession) -> bool {
    // SAFETY: contract.
    unsafe { sending(session, false, |s| s.delete_session().unwrap_or(false)) }
}

/// `uxr_delete_session_retries`.
///
/// # Safety
/// `session` null or a `uxrSession`.
#[no_mangle]
pub unsafe extern "C" fn uxr_delete_session_retries(session: *mut uxrSession, retries: usize) -> bool {
    // SAFETY: contract.
    unsafe { with_session(session, false, |s| s.delete_session_retries(retries).unwrap_or(false)) }
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
run_fn!(
    /// `uxr_run_session_until_data`.
    uxr_run_session_until_data => run_session_until_data
);
run_fn!(
    /// `uxr_sync_session`: whether the agent answered.
    uxr_sync_session => sync_session
);

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
    // SAFETY: contract.
    unsafe { sending(session, false, |s| wait(s, timeout_ms, requests, statuses).unwrap_or(false)) }
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

/// `uxr_epoch_millis`: the agent's clock after `uxr_sync_session` (the local one before); 0 for a bad session.
///
/// # Safety
/// `session` null or a `uxrSession`.
#[no_mangle]
pub unsafe extern "C" fn uxr_epoch_millis(session: *mut uxrSession) -> i64 {
    // SAFETY: contract.
    unsafe { with_session(session, 0, |s| s.epoch_millis()) }
}

/// `uxr_epoch_nanos`.
///
/// # Safety
/// `session` null or a `uxrSession`.
#[no_mangle]
pub unsafe extern "C" fn uxr_epoch_nanos(session: *mut uxrSession) -> i64 {
    // SAFETY: contract.
    unsafe { with_session(session, 0, |s| s.epoch_nanos()) }
}

/// `uxr_ping_agent_session`.
///
/// # Safety
/// `session` null or a `uxrSession`.
#[no_mangle]
pub unsafe extern "C" fn uxr_ping_agent_session(session: *mut uxrSession, timeout_ms: i32, attempts: u8) -> bool {
    // SAFETY: contract.
    unsafe { with_session(session, false, |s| s.ping_agent_session(timeout_ms, attempts).unwrap_or(false)) }
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
