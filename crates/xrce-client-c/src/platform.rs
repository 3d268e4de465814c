//! What firmware gives the library (the `no_std` build): the time, and what happens on a panic. Both have
//! defaults that need nothing but the C library eProsima's client needs too (`clock_gettime`), and a setter
//! for boards that want something else (declared in `uxr/client/platform.h`).

use core::sync::atomic::{AtomicPtr, Ordering};

/// A time source: nanoseconds since an epoch (the Unix one for time synchronisation to mean something).
pub type TimeSource = unsafe extern "C" fn() -> i64;
/// What a panic calls before the library stops: it should not return (reset the board, log, halt).
pub type PanicHook = unsafe extern "C" fn();

static TIME_SOURCE: AtomicPtr<()> = AtomicPtr::new(core::ptr::null_mut());
static PANIC_HOOK: AtomicPtr<()> = AtomicPtr::new(core::ptr::null_mut());

/// `uxr_set_time_source`: the clock of `uxr_nanos`, `uxr_millis` and every session from now on; null goes
/// back to the platform's `clock_gettime(CLOCK_REALTIME)` (eProsima's POSIX and embedded ports take their time
/// there too, so a micro-ROS board's existing `clock_gettime` works unchanged).
#[no_mangle]
pub extern "C" fn uxr_set_time_source(source: Option<TimeSource>) {
    let raw = source.map_or(core::ptr::null_mut(), |f| f as *mut ());
    TIME_SOURCE.store(raw, Ordering::Release);
}

/// The program's time source, if it set one.
pub fn time_source() -> Option<TimeSource> {
    let raw = TIME_SOURCE.load(Ordering::Acquire);
    if raw.is_null() {
        return None;
    }
    // SAFETY: only `uxr_set_time_source` stores here, and only a `TimeSource` cast to a pointer.
    Some(unsafe { core::mem::transmute::<*mut (), TimeSource>(raw) })
}

/// `uxr_set_panic_hook`: what a panic inside the library calls (none is expected on any input: the library
/// has no panicking path on the data it is given). Without one, the `no_std` library halts in a loop; the
/// `std` library aborts the process (Rust's rule), the hook having been called first.
#[no_mangle]
pub extern "C" fn uxr_set_panic_hook(hook: Option<PanicHook>) {
    let raw = hook.map_or(core::ptr::null_mut(), |f| f as *mut ());
    PANIC_HOOK.store(raw, Ordering::Release);
    #[cfg(feature = "std")]
    if hook.is_some() {
        std::panic::set_hook(std::boxed::Box::new(|_| call_panic_hook()));
    }
}

/// Calls the program's panic hook, if any.
pub fn call_panic_hook() {
    let raw = PANIC_HOOK.load(Ordering::Acquire);
    if !raw.is_null() {
        // SAFETY: only `uxr_set_panic_hook` stores here, and only a `PanicHook` cast to a pointer.
        let hook = unsafe { core::mem::transmute::<*mut (), PanicHook>(raw) };
        // SAFETY: the program's own function, taking nothing.
        unsafe { hook() };
    }
}
