//! QEMU's mps2-an386 (Cortex-M4) and mps2-an385 (Cortex-M3, runs thumbv6m code): CMSDK APB UART0, SysTick,
//! ARM semihosting.

use core::arch::asm;
use core::sync::atomic::{AtomicU32, Ordering};

use cortex_m::peripheral::syst::SystClkSource;
use cortex_m::peripheral::SYST;
use cortex_m_rt::{exception, ExceptionFrame};

/// CMSDK APB UART0.
const UART0: usize = 0x4000_4000;
const UART_DATA: *mut u32 = UART0 as *mut u32;
const UART_STATE: *mut u32 = (UART0 + 0x4) as *mut u32;
const UART_CTRL: *mut u32 = (UART0 + 0x8) as *mut u32;
const UART_INTCLEAR: *mut u32 = (UART0 + 0xC) as *mut u32;
const UART_BAUDDIV: *mut u32 = (UART0 + 0x10) as *mut u32;
const STATE_TX_FULL: u32 = 1;
const STATE_RX_FULL: u32 = 2;
const CTRL_TX_EN: u32 = 1;
const CTRL_RX_EN: u32 = 2;
const CTRL_RX_INT_EN: u32 = 4;
const INT_RX: u32 = 2;
/// NVIC interrupt clear-pending register 0 (UART0's receive interrupt is line 0 on the mps2 boards).
const NVIC_ICPR0: *mut u32 = 0xE000_E280 as *mut u32;
/// System control register: bit 4, SEVONPEND, makes a newly pending interrupt wake `wfe` even while it is
/// disabled in the NVIC.
const SCB_SCR: *mut u32 = 0xE000_ED10 as *mut u32;
const SCR_SEVONPEND: u32 = 1 << 4;

/// The core clock of the mps2 boards (SysTick counts it).
const CORE_HZ: u32 = 25_000_000;
/// One SysTick period: 1 ms.
const RELOAD: u32 = CORE_HZ / 1000 - 1;
/// Nanoseconds per core cycle.
const NS_PER_CYCLE: i64 = 1_000_000_000 / CORE_HZ as i64;

/// Milliseconds since reset, counted by the SysTick exception.
static TICKS: AtomicU32 = AtomicU32::new(0);

pub fn init() {
    // SAFETY: the UART's registers, at the address the board maps them; no other code touches them.
    unsafe {
        UART_BAUDDIV.write_volatile(16);
        // The receive interrupt is never taken (disabled in the NVIC): with SEVONPEND its pending state wakes
        // `idle` as soon as a byte arrives, rather than at the next tick.
        UART_CTRL.write_volatile(CTRL_TX_EN | CTRL_RX_EN | CTRL_RX_INT_EN);
        SCB_SCR.write_volatile(SCB_SCR.read_volatile() | SCR_SEVONPEND);
    }
    // SAFETY: the one place that configures SysTick, before anything reads it.
    let mut syst = unsafe { cortex_m::Peripherals::steal() }.SYST;
    syst.set_clock_source(SystClkSource::Core);
    syst.set_reload(RELOAD);
    syst.clear_current();
    syst.enable_interrupt();
    syst.enable_counter();
}

#[exception]
fn SysTick() {
    // The only writer (load and store: thumbv6m has no read-modify-write atomics).
    TICKS.store(TICKS.load(Ordering::Relaxed).wrapping_add(1), Ordering::Relaxed);
}

pub fn now_nanos() -> i64 {
    loop {
        let before = TICKS.load(Ordering::Relaxed);
        let cycles = RELOAD - SYST::get_current().min(RELOAD);
        if TICKS.load(Ordering::Relaxed) == before {
            return i64::from(before) * 1_000_000 + i64::from(cycles) * NS_PER_CYCLE;
        }
    }
}

/// Sleeps until a byte arrives or the next tick (a millisecond at most).
pub fn idle() {
    cortex_m::asm::wfe();
}

pub fn uart_write(b: u8) {
    // SAFETY: the UART's registers (see `init`).
    unsafe {
        while UART_STATE.read_volatile() & STATE_TX_FULL != 0 {}
        UART_DATA.write_volatile(u32::from(b));
    }
}

pub fn uart_read() -> Option<u8> {
    // SAFETY: the UART's and the NVIC's registers (see `init`).
    unsafe {
        if UART_STATE.read_volatile() & STATE_RX_FULL == 0 {
            return None;
        }
        let b = UART_DATA.read_volatile() as u8;
        // Re-arm the wake-up: the next byte makes the interrupt pending again.
        UART_INTCLEAR.write_volatile(INT_RX);
        NVIC_ICPR0.write_volatile(u32::MAX);
        Some(b)
    }
}

// ---- semihosting --------------------------------------------------------------------------------------------

const SYS_OPEN: usize = 0x01;
const SYS_WRITE: usize = 0x05;
const SYS_GET_CMDLINE: usize = 0x15;
const SYS_EXIT_EXTENDED: usize = 0x20;
const ADP_STOPPED_APPLICATION_EXIT: usize = 0x2_0026;

/// One semihosting call: operation `op`, its parameter block (or value) `arg`.
///
/// # Safety
/// `arg` must be what `op` expects: the address of a parameter block valid for the call, or a value.
unsafe fn semihost(op: usize, arg: usize) -> usize {
    let mut r0 = op;
    // SAFETY: `bkpt 0xab` is the semihosting trap, served by QEMU (`-semihosting-config enable=on`); the
    // caller vouches for `arg`.
    unsafe { asm!("bkpt #0xab", inout("r0") r0, in("r1") arg, options(nostack)) };
    r0
}

/// The host's console, opened once (`:tt` for writing).
static CONSOLE: AtomicU32 = AtomicU32::new(u32::MAX);

pub fn print(bytes: &[u8]) {
    let mut handle = CONSOLE.load(Ordering::Relaxed);
    if handle == u32::MAX {
        let block = [c":tt".as_ptr() as usize, 4, 3];
        // SAFETY: SYS_OPEN's block: name, mode ("w"), name length; all live for the call.
        handle = unsafe { semihost(SYS_OPEN, block.as_ptr() as usize) } as u32;
        CONSOLE.store(handle, Ordering::Relaxed);
    }
    let block = [handle as usize, bytes.as_ptr() as usize, bytes.len()];
    // SAFETY: SYS_WRITE's block: handle, address and length of a live slice.
    unsafe { semihost(SYS_WRITE, block.as_ptr() as usize) };
}

pub fn exit(code: i32) -> ! {
    let block = [ADP_STOPPED_APPLICATION_EXIT, code as usize];
    // SAFETY: SYS_EXIT_EXTENDED's block: reason, exit code.
    unsafe { semihost(SYS_EXIT_EXTENDED, block.as_ptr() as usize) };
    // Without semihosting the call does not come back: halt.
    loop {
        cortex_m::asm::wfi();
    }
}

pub fn cmdline(buf: &mut [u8]) -> usize {
    let mut block = [buf.as_mut_ptr() as usize, buf.len()];
    // SAFETY: SYS_GET_CMDLINE's block: a writable buffer and its length, which the host updates.
    let failed = unsafe { semihost(SYS_GET_CMDLINE, block.as_mut_ptr() as usize) } != 0;
    if failed {
        return 0;
    }
    // The host wrote `len` bytes and a NUL.
    block[1].min(buf.len())
}

// ---- stack ----------------------------------------------------------------------------------------------------

extern "C" {
    static _stack_start: u32;
    static _stack_end: u32;
}

/// Bytes of stack used since reset: cortex-m-rt's `paint-stack` filled `_stack_end.._stack_start` with
/// 0xCCCCCCCC; the lowest word no longer holding it is the high-water mark.
pub fn stack_used() -> usize {
    let (end, start) = (core::ptr::addr_of!(_stack_end) as usize, core::ptr::addr_of!(_stack_start) as usize);
    let mut a = end;
    // SAFETY: word-aligned addresses inside the stack region the linker script placed in RAM.
    while a < start && unsafe { (a as *const u32).read_volatile() } == 0xCCCC_CCCC {
        a += 4;
    }
    start - a
}

/// Paints the stack again below the caller's frame (what start-up code already used there, a session built on
/// the stack before it moved to its static, is forgotten); returns the address [`stack_used_below`] counts from.
/// Word writes at word-aligned addresses: a wide store at an unaligned address faults on Cortex-M.
#[inline(never)]
pub fn paint_below_here() -> usize {
    let marker = 0u8;
    let top = core::hint::black_box(&marker) as *const u8 as usize & !7;
    let end = core::ptr::addr_of!(_stack_end) as usize;
    // This function's own frame lies within the 64 bytes under `top`.
    let mut a = end;
    while a + 4 <= top.saturating_sub(64) {
        // SAFETY: word-aligned, unused stack between the end of RAM's data and this function's frame.
        unsafe { (a as *mut u32).write_volatile(0xCCCC_CCCC) };
        a += 4;
    }
    top
}

/// Bytes of stack used below `top` (from [`paint_below_here`]) since it was painted.
pub fn stack_used_below(top: usize) -> usize {
    let mut a = core::ptr::addr_of!(_stack_end) as usize;
    // SAFETY: word-aligned addresses inside the stack region.
    while a < top && unsafe { (a as *const u32).read_volatile() } == 0xCCCC_CCCC {
        a += 4;
    }
    top.saturating_sub(a)
}

#[exception]
unsafe fn HardFault(frame: &ExceptionFrame) -> ! {
    crate::print(b"hard fault at pc ");
    crate::print_num(u64::from(frame.pc()));
    crate::print(b"\n");
    exit(102)
}

// ---- memory routines ----------------------------------------------------------------------------------------
//
// The board's memcpy/memmove/memset family, in byte loops: compiler-builtins' (word-at-a-time, one copy per
// alignment variant) take 1.7 KB of a Cortex-M firmware's code, these ~200 B, as a C firmware links newlib-nano's
// size-optimised ones. compiler-builtins defines its own as weak symbols, so these replace them. Volatile
// accesses keep LLVM from turning the loops back into calls to the functions they implement.

mod mem {
    /// Copies `n` bytes upwards.
    ///
    /// # Safety
    /// `d` writable and `s` readable for `n` bytes; if they overlap, `d` is not above `s`.
    unsafe fn forward(d: *mut u8, s: *const u8, n: usize) {
        for i in 0..n {
            // SAFETY: the caller's ranges.
            unsafe { d.add(i).write_volatile(s.add(i).read_volatile()) };
        }
    }

    /// Copies `n` bytes downwards.
    ///
    /// # Safety
    /// `d` writable and `s` readable for `n` bytes.
    unsafe fn backward(d: *mut u8, s: *const u8, n: usize) {
        for i in (0..n).rev() {
            // SAFETY: the caller's ranges.
            unsafe { d.add(i).write_volatile(s.add(i).read_volatile()) };
        }
    }

    /// # Safety
    /// `d` writable for `n` bytes.
    unsafe fn fill(d: *mut u8, n: usize, c: u8) {
        for i in 0..n {
            // SAFETY: the caller's range.
            unsafe { d.add(i).write_volatile(c) };
        }
    }

    /// # Safety
    /// As C's `memmove`.
    unsafe fn move_(d: *mut u8, s: *const u8, n: usize) {
        if (d as usize) <= (s as usize) {
            // SAFETY: the caller's ranges; moving down, each byte is read before it is overwritten.
            unsafe { forward(d, s, n) }
        } else {
            // SAFETY: the caller's ranges; moving up, from the end.
            unsafe { backward(d, s, n) }
        }
    }

    /// C's `memcpy`.
    ///
    /// # Safety
    /// As C's.
    #[no_mangle]
    pub unsafe extern "C" fn memcpy(d: *mut u8, s: *const u8, n: usize) -> *mut u8 {
        // SAFETY: C's contract.
        unsafe { forward(d, s, n) };
        d
    }

    /// C's `memmove`.
    ///
    /// # Safety
    /// As C's.
    #[no_mangle]
    pub unsafe extern "C" fn memmove(d: *mut u8, s: *const u8, n: usize) -> *mut u8 {
        // SAFETY: C's contract.
        unsafe { move_(d, s, n) };
        d
    }

    /// C's `memset`.
    ///
    /// # Safety
    /// As C's.
    #[no_mangle]
    pub unsafe extern "C" fn memset(d: *mut u8, c: i32, n: usize) -> *mut u8 {
        // SAFETY: C's contract.
        unsafe { fill(d, n, c as u8) };
        d
    }

    /// C's `memcmp` (and `bcmp`, its equality-only form).
    ///
    /// # Safety
    /// As C's.
    #[no_mangle]
    pub unsafe extern "C" fn memcmp(a: *const u8, b: *const u8, n: usize) -> i32 {
        for i in 0..n {
            // SAFETY: C's contract: both readable for `n` bytes.
            let (x, y) = unsafe { (a.add(i).read_volatile(), b.add(i).read_volatile()) };
            if x != y {
                return i32::from(x) - i32::from(y);
            }
        }
        0
    }

    /// C's `bcmp`.
    ///
    /// # Safety
    /// As C's.
    #[no_mangle]
    pub unsafe extern "C" fn bcmp(a: *const u8, b: *const u8, n: usize) -> i32 {
        // SAFETY: C's contract.
        unsafe { memcmp(a, b, n) }
    }

    // The ARM run-time ABI's forms (what LLVM calls on ARM); the 4/8 variants only promise alignment.
    macro_rules! aeabi {
        ($($copy:ident),* ; $($move:ident),* ; $($set:ident),* ; $($clr:ident),*) => {
            $(
                /// ARM run-time ABI copy.
                ///
                /// # Safety
                /// As C's `memcpy`.
                #[no_mangle]
                pub unsafe extern "C" fn $copy(d: *mut u8, s: *const u8, n: usize) {
                    // SAFETY: the ABI's contract.
                    unsafe { forward(d, s, n) }
                }
            )*
            $(
                /// ARM run-time ABI move.
                ///
                /// # Safety
                /// As C's `memmove`.
                #[no_mangle]
                pub unsafe extern "C" fn $move(d: *mut u8, s: *const u8, n: usize) {
                    // SAFETY: the ABI's contract.
                    unsafe { move_(d, s, n) }
                }
            )*
            $(
                /// ARM run-time ABI set (note the argument order: length, then value).
                ///
                /// # Safety
                /// As C's `memset`.
                #[no_mangle]
                pub unsafe extern "C" fn $set(d: *mut u8, n: usize, c: i32) {
                    // SAFETY: the ABI's contract.
                    unsafe { fill(d, n, c as u8) }
                }
            )*
            $(
                /// ARM run-time ABI clear.
                ///
                /// # Safety
                /// As C's `memset` with 0.
                #[no_mangle]
                pub unsafe extern "C" fn $clr(d: *mut u8, n: usize) {
                    // SAFETY: the ABI's contract.
                    unsafe { fill(d, n, 0) }
                }
            )*
        };
    }

    aeabi!(__aeabi_memcpy, __aeabi_memcpy4, __aeabi_memcpy8;
           __aeabi_memmove, __aeabi_memmove4, __aeabi_memmove8;
           __aeabi_memset, __aeabi_memset4, __aeabi_memset8;
           __aeabi_memclr, __aeabi_memclr4, __aeabi_memclr8);
}
