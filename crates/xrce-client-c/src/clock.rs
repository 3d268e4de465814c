//! The clock of C sessions and `uxr_millis` / `uxr_nanos`.

#[cfg(feature = "std")]
pub use xrce_client::StdClock as SysClock;

/// Without `std`: the POSIX `clock_gettime(CLOCK_REALTIME)` of the platform's C library.
#[cfg(not(feature = "std"))]
#[derive(Debug, Default, Clone, Copy)]
pub struct SysClock;

#[cfg(not(feature = "std"))]
mod posix {
    #[repr(C)]
    pub struct Timespec {
        pub tv_sec: i64,
        pub tv_nsec: core::ffi::c_long,
    }
    extern "C" {
        pub fn clock_gettime(clock: core::ffi::c_int, ts: *mut Timespec) -> core::ffi::c_int;
    }
}

#[cfg(not(feature = "std"))]
impl xrce_client::Clock for SysClock {
    fn now_nanos(&mut self) -> i64 {
        let mut ts = posix::Timespec { tv_sec: 0, tv_nsec: 0 };
        // SAFETY: `ts` is a valid, writable timespec; CLOCK_REALTIME (0) exists on every POSIX system.
        if unsafe { posix::clock_gettime(0, &mut ts) } != 0 {
            return 0;
        }
        ts.tv_sec.saturating_mul(1_000_000_000).saturating_add(i64::from(ts.tv_nsec))
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
