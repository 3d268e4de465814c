//! The clock of C sessions and `uxr_millis` / `uxr_nanos`: the program's time source if it set one
//! (`uxr_set_time_source`), else the system clock (`std`) or the platform's `clock_gettime` (`no_std`).

/// The clock of a C session.
#[derive(Debug, Default, Clone, Copy)]
pub struct SysClock {
    #[cfg(feature = "std")]
    system: xrce_client::StdClock,
}

/// With `std`: the system clock, read once and advanced monotonically (the Rust client's `StdClock`).
#[cfg(feature = "std")]
impl xrce_client::Clock for SysClock {
    fn now_nanos(&mut self) -> i64 {
        if let Some(source) = crate::platform::time_source() {
            // SAFETY: the program's own function, taking nothing.
            return unsafe { source() };
        }
        self.system.now_nanos()
    }
}

#[cfg(not(feature = "std"))]
mod posix {
    /// `struct timespec` with a 64-bit `time_t` (glibc on 64-bit targets, newlib 4).
    #[repr(C)]
    pub struct Timespec {
        pub tv_sec: i64,
        pub tv_nsec: core::ffi::c_long,
    }
    /// `CLOCK_REALTIME`: 0 on Linux, 1 in newlib (bare-metal toolchains).
    #[cfg(target_os = "linux")]
    pub const CLOCK_REALTIME: core::ffi::c_int = 0;
    #[cfg(not(target_os = "linux"))]
    pub const CLOCK_REALTIME: core::ffi::c_int = 1;
    extern "C" {
        pub fn clock_gettime(clock: core::ffi::c_int, ts: *mut Timespec) -> core::ffi::c_int;
    }
}

/// The platform's `clock_gettime(CLOCK_REALTIME)`, or the program's time source (`uxr_set_time_source`).
#[cfg(not(feature = "std"))]
impl xrce_client::Clock for SysClock {
    fn now_nanos(&mut self) -> i64 {
        if let Some(source) = crate::platform::time_source() {
            // SAFETY: the program's own function, taking nothing.
            return unsafe { source() };
        }
        let mut ts = posix::Timespec { tv_sec: 0, tv_nsec: 0 };
        // SAFETY: `ts` is a valid, writable timespec.
        if unsafe { posix::clock_gettime(posix::CLOCK_REALTIME, &mut ts) } != 0 {
            return 0;
        }
        // Wrapping: the product overflows only after the year 2262 (64-bit multiply without the overflow checks).
        ts.tv_sec.wrapping_mul(1_000_000_000).wrapping_add(i64::from(ts.tv_nsec))
    }
}

/// A fresh clock.
pub fn clock() -> SysClock {
    SysClock::default()
}

/// `uxr_nanos`: nanoseconds since the epoch on the local clock.
#[no_mangle]
pub extern "C" fn uxr_nanos() -> i64 {
    use xrce_client::Clock;
    clock().now_nanos()
}

/// `uxr_millis`: milliseconds since the epoch on the local clock.
#[no_mangle]
pub extern "C" fn uxr_millis() -> i64 {
    uxr_nanos() / 1_000_000
}
