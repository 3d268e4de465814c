//! `uxrSession`: eProsima's named fields (`public.rs`) followed by the Rust blocking session, kept in the
//! structure's `_opaque` words, and the functions every other part uses to reach it safely from a C pointer.
//! The named fields are the C program's: the library reads the callbacks and `time_offset` from them when it
//! needs them and writes `info`, `synchronized`, the flags and the stream table as the session moves on.

/// The address of a named field of a `uxrSession` pointer (nothing is read).
macro_rules! field {
    ($s:expr, $($f:ident).+) => {{
        #[allow(unused_unsafe)] // also used inside callers' own unsafe blocks
        // SAFETY: only an address inside the structure is computed (`addr_of_mut!` reads nothing); every
        // caller passes a non-null pointer to a `uxrSession`.
        let at = unsafe { core::ptr::addr_of_mut!((*$s).$($f).+) };
        at
    }};
}

mod fragmented;
mod hooks;
pub mod public;
mod run;
mod streams;

use core::cell::Cell;
use core::mem::{align_of, size_of, MaybeUninit};
use core::ptr::{addr_of, addr_of_mut};

use xrce_client::{Outputs, Session, SessionState, WriteAccess};

use crate::clock::{clock, SysClock};
use crate::comm::{uxrCommunication, Comm};
pub use fragmented::prepare_whole;
pub use hooks::Hooks;
pub use public::uxrSession;

/// Streams of each kind (`UXR_CONFIG_MAX_*_STREAMS`) and the message size of the session.
pub const OBE: usize = 1;
/// As [`OBE`].
pub const ORE: usize = 1;
/// As [`OBE`].
pub const IBE: usize = 1;
/// As [`OBE`].
pub const IRE: usize = 1;
const MTU: usize = 512;

/// The Rust session behind a `uxrSession`.
pub type Inner = Session<'static, Comm, SysClock, Hooks, OBE, ORE, IBE, IRE, MTU>;

/// Outputs lent to a callback, seen from outside the callback.
type CallbackOutputs = Cell<*mut Outputs<'static, 'static>>;

/// Marks storage that `uxr_init_session` filled (with the storage's own address beside it).
const MAGIC: u64 = 0x7872_6365_2d72_7331;

/// What lives in a `uxrSession`.
struct Slot {
    magic: u64,
    this: *const uxrSession,
    /// While a callback runs: the outputs it may write to (a replier answering from `on_request`).
    in_callback: CallbackOutputs,
    /// While a call holds the Rust session: a callback calling back into a running function gets its error value.
    busy: Cell<bool>,
    /// The identity of the last request received (`uxr_buffer_reply` in the seed's form answers it).
    last_request: Cell<Option<crate::types::SampleIdentity>>,
    /// A `uxr_prepare_output_stream_fragmented` write in progress.
    fragment: fragmented::Fragment,
    /// While its window is pushed (the flush callback may run the session, which must not push it again).
    pushing: Cell<bool>,
    session: Inner,
}

const _: () = assert!(size_of::<Slot>() <= 8 * crate::layout::SESSION_WORDS, "UXR_SESSION_OPAQUE_WORDS too small");
const _: () = assert!(align_of::<Slot>() <= 8);

/// Where the slot of `session` lives: its `_opaque` words (no memory is read).
fn slot_at(session: *mut uxrSession) -> *mut Slot {
    // SAFETY: only an address inside the structure is computed (`addr_of_mut!` reads nothing); callers pass
    // non-null pointers to a `uxrSession`.
    unsafe { addr_of_mut!((*session)._opaque) }.cast::<Slot>()
}

/// The slot of an initialised session, `None` for null or storage `uxr_init_session` did not fill.
///
/// # Safety
/// `session` is null or points to a `uxrSession` (readable memory of its size).
unsafe fn slot(session: *mut uxrSession) -> Option<*mut Slot> {
    if session.is_null() {
        return None;
    }
    let slot = slot_at(session);
    // SAFETY: `slot` points to readable memory of the session's size (contract), which holds these fields.
    let (magic, this) = unsafe { (addr_of!((*slot).magic).read(), addr_of!((*slot).this).read()) };
    (magic == MAGIC && this == session.cast_const()).then_some(slot)
}

/// Runs `f` on the Rust session of `session`; `fallback` for a null, uninitialised or busy session (a callback
/// calling a `run_session` function, say).
///
/// # Safety
/// `session` is null or points to a `uxrSession`.
pub unsafe fn with_session<R>(session: *mut uxrSession, fallback: R, f: impl FnOnce(&mut Inner) -> R) -> R {
    // SAFETY: contract.
    let Some(inner) = (unsafe { enter(session) }) else { return fallback };
    let result = f(inner);
    // SAFETY: entered just above.
    unsafe { leave(session) };
    result
}

/// Takes `session` for a call: its Rust session, `None` for a null, uninitialised or busy session. Out of line,
/// as [`leave`], so the many `with_session` instances share one copy (firmware size).
///
/// # Safety
/// `session` is null or points to a `uxrSession`; a `Some` is followed by [`leave`] once the call is done.
#[inline(never)]
unsafe fn enter<'s>(session: *mut uxrSession) -> Option<&'s mut Inner> {
    // SAFETY: contract.
    let slot = unsafe { self::slot(session) }?;
    // Other threads wait here (multithread profile); this one may already hold the locks (recursive).
    // SAFETY: contract: an initialised session.
    #[cfg(uxr_multithread)]
    unsafe {
        crate::lock::acquire(session);
    }
    // SAFETY: an initialised slot; `busy` is only ever reached through shared references.
    let busy = unsafe { &*addr_of!((*slot).busy) };
    if busy.replace(true) {
        // SAFETY: taken just above.
        #[cfg(uxr_multithread)]
        unsafe {
            crate::lock::release(session);
        }
        return None;
    }
    // The hooks already point at `session`: the slot check found it where it was initialised (firmware size).
    // SAFETY: not busy, so no other reference to the session exists; callbacks reach only `in_callback` and
    // `busy` (other fields) while this one is live.
    Some(unsafe { &mut *addr_of_mut!((*slot).session) })
}

/// Ends a call [`enter`] began: publishes `info`, clears `busy`, releases the lock.
///
/// # Safety
/// `session` entered by [`enter`], the reference it gave no longer used.
#[inline(never)]
unsafe fn leave(session: *mut uxrSession) {
    let slot = slot_at(session);
    // SAFETY: entered, so an initialised slot no other reference to the session points into.
    let inner = unsafe { &mut *addr_of_mut!((*slot).session) };
    // SAFETY: an initialised session; the named fields lie outside the Rust session's memory.
    unsafe { publish(session, inner) };
    // SAFETY: an initialised slot; `busy` is only ever reached through shared references.
    unsafe { &*addr_of!((*slot).busy) }.set(false);
    // SAFETY: taken by `enter`.
    #[cfg(uxr_multithread)]
    unsafe {
        crate::lock::release(session);
    }
}

/// Brings `info` up to date after a call: the session id, the key and the last request id, as the Rust
/// session has them.
///
/// # Safety
/// `session` an initialised `uxrSession` whose Rust session is `inner`.
#[inline(always)] // its one caller, `leave`, is out of line (firmware size)
unsafe fn publish(session: *mut uxrSession, inner: &mut Inner) {
    let core = inner.core();
    let (id, key, last) = (core.session_id(), core.client_key(), core.last_request_id());
    // SAFETY: contract; named fields only.
    unsafe {
        let info = addr_of_mut!((*session).info);
        addr_of_mut!((*info).id).write(id);
        addr_of_mut!((*info).key).write(key.0);
        addr_of_mut!((*info).last_request_id).write(last);
    }
}

/// Runs `f` on the output streams of `session`: inside a callback those lent to it, otherwise the session's
/// (`fallback` once the session is deleted).
///
/// # Safety
/// `session` is null or points to a `uxrSession`.
pub unsafe fn with_outputs<R>(
    session: *mut uxrSession,
    fallback: R,
    f: impl for<'x> FnOnce(Outputs<'x, 'static>) -> R,
) -> R {
    // `f` is called at one place only and the outputs are found out of line, so each instance holds one copy
    // of `f` and little else (firmware size).
    let mut out = MaybeUninit::uninit();
    // SAFETY: contract.
    let Some(entered) = (unsafe { outputs_of(session, &mut out) }) else { return fallback };
    // SAFETY: `outputs_of` wrote the outputs when it returned `Some`.
    let result = f(unsafe { out.assume_init() });
    if entered {
        // SAFETY: entered by `outputs_of`; the outputs borrowed from the session were consumed by `f`.
        unsafe { leave(session) };
    }
    result
}

/// Writes into `out` the outputs [`with_outputs`] runs on and tells whether the session was entered for them
/// (then [`leave`] follows); `None`, `out` untouched, when there are none. Out of line: one copy for every
/// `with_outputs` instance; the outputs written in place and an `Option<bool>` returned in a register, not a
/// 6-word `Option` through memory then copied (firmware size).
///
/// # Safety
/// `session` is null or points to a `uxrSession`; the outputs are used only until [`leave`] or, lent ones, while
/// the callback that lent them runs.
#[inline(never)]
unsafe fn outputs_of<'s>(session: *mut uxrSession, out: &mut MaybeUninit<Outputs<'s, 'static>>) -> Option<bool> {
    // SAFETY: contract.
    let slot = unsafe { self::slot(session) }?;
    // SAFETY: an initialised slot; `in_callback` is only reached through shared references.
    let lent = unsafe { &*addr_of!((*slot).in_callback) }.get();
    // SAFETY: non-null only while a callback runs, during which the outputs it points to are borrowed for the
    // callback and reached by nothing else.
    match unsafe { lent.as_mut() } {
        Some(lent) => {
            out.write(lent.reborrow());
            Some(false)
        }
        None => {
            // SAFETY: contract.
            let inner = unsafe { open_outputs(session) }?;
            out.write(inner.outputs());
            Some(true)
        }
    }
}

/// The session's own outputs for [`with_outputs`]: a sample still being serialized through a window goes into
/// the stream first, then the session is entered; `None` (not entered) when it cannot be, or once the session
/// is deleted. Inlined into its one caller, [`outputs_of`], itself out of line (firmware size).
///
/// # Safety
/// `session` is null or points to a `uxrSession`; a `Some` is followed by [`leave`] once the call is done.
#[inline(always)]
unsafe fn open_outputs<'s>(session: *mut uxrSession) -> Option<&'s mut Inner> {
    // SAFETY: contract.
    unsafe { fragmented::finish_pending(session) };
    // SAFETY: contract.
    let inner = unsafe { enter(session) }?;
    if matches!(inner.core().state(), SessionState::Deleted | SessionState::Deleting) {
        // SAFETY: entered just above; `inner` is not used again.
        unsafe { leave(session) };
        return None;
    }
    Some(inner)
}

/// The identity of the last request `session` received.
///
/// # Safety
/// `session` null or a `uxrSession`.
pub unsafe fn last_request(session: *mut uxrSession) -> Option<crate::types::SampleIdentity> {
    // SAFETY: contract.
    let slot = unsafe { slot(session) }?;
    // SAFETY: an initialised slot; the field is only reached through shared references.
    unsafe { &*addr_of!((*slot).last_request) }.get()
}

/// `uxr_init_session`: a session for client `key` over `comm`, which must outlive it. Reconnection is off, as
/// in eProsima's client (programs carry their own ping-and-recreate logic). The named fields start as
/// eProsima's do: no callbacks, offset 0, not synchronised, `info` with session id 0x81 and the key.
///
/// # Safety
/// `session` null or writable storage of a `uxrSession`; `comm` null or a communication that outlives the session.
#[no_mangle]
pub unsafe extern "C" fn uxr_init_session(session: *mut uxrSession, comm: *mut uxrCommunication, key: u32) {
    if session.is_null() || comm.is_null() {
        return;
    }
    // SAFETY: contract.
    if let Some(old) = unsafe { slot(session) } {
        // SAFETY: an initialised slot; `busy` is only reached through shared references.
        if unsafe { &*addr_of!((*old).busy) }.get() {
            return;
        }
        // SAFETY: the storage holds a session initialised here and not in use: drop it (its heap bookkeeping).
        unsafe { core::ptr::drop_in_place(old) };
    }
    let slot = slot_at(session);
    let hooks = Hooks::new(session);
    let inner = Session::<Comm, SysClock, (), OBE, ORE, IBE, IRE, MTU>::with_clock(Comm(comm), clock(), key)
        .with_reconnect(None)
        .with_callbacks(hooks);
    let value = Slot {
        magic: MAGIC,
        this: session,
        in_callback: Cell::new(core::ptr::null_mut()),
        busy: Cell::new(false),
        last_request: Cell::new(None),
        fragment: fragmented::Fragment::idle(),
        pushing: Cell::new(false),
        session: inner,
    };
    // SAFETY: `session` is writable (contract). Its named fields are plain data: all zero is eProsima's
    // initial state (null callbacks, offset 0, flags clear, empty stream table) but for what is set after.
    unsafe {
        core::ptr::write_bytes(session.cast::<u8>(), 0, core::mem::offset_of!(uxrSession, _opaque));
        addr_of_mut!((*session).comm).write(comm);
        addr_of_mut!((*session).info).write(public::uxrSessionInfo {
            id: 0x81,
            key: key.to_be_bytes(),
            last_requested_status: public::STATUS_NONE,
            last_request_id: 9,
        });
        #[cfg(uxr_multithread)]
        crate::lock::init_session(session);
    }
    // SAFETY: `slot` is writable storage large and aligned enough (checked above at compile time); `write`
    // does not drop what was there.
    unsafe { slot.write(value) };
}

/// Writes one named field of an initialised or null session.
///
/// # Safety
/// `session` null or a `uxrSession`.
pub unsafe fn set_field<T>(session: *mut uxrSession, field: impl FnOnce(*mut uxrSession) -> *mut T, value: T) {
    if !session.is_null() {
        // SAFETY: contract; named fields lie outside the Rust session's memory.
        unsafe { field(session).write(value) };
    }
}

/// Reads one named field (`fallback` for null).
///
/// # Safety
/// `session` null or a `uxrSession`.
pub unsafe fn get_field<T: Copy>(
    session: *mut uxrSession,
    fallback: T,
    field: impl FnOnce(*mut uxrSession) -> *mut T,
) -> T {
    if session.is_null() {
        return fallback;
    }
    // SAFETY: contract.
    unsafe { field(session).read() }
}
