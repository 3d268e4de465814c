//! A RISC-V board as QEMU's `virt` lays it out (16550 UART at 0x10000000, CLINT `mtime` at 10 MHz, the test
//! device to exit), for size measurements of riscv32imc builds: nothing here has been run. No console: the
//! output functions do nothing; the exit code goes to the test device.

use core::arch::global_asm;

const UART: usize = 0x1000_0000;
const UART_RBR_THR: *mut u8 = UART as *mut u8;
const UART_LSR: *const u8 = (UART + 5) as *const u8;
const LSR_DATA_READY: u8 = 1;
const LSR_THR_EMPTY: u8 = 0x20;
const MTIME: *const u32 = 0x0200_BFF8 as *const u32;
const MTIME_HI: *const u32 = 0x0200_BFFC as *const u32;
const TEST_DEVICE: *mut u32 = 0x0010_0000 as *mut u32;

global_asm!(
    ".section .text.start",
    ".globl _start",
    "_start:",
    "la sp, _stack_start",
    "call {start}",
    start = sym start,
);

extern "C" {
    static mut _sbss: u32;
    static mut _ebss: u32;
    static mut _sdata: u32;
    static mut _edata: u32;
    static _sidata: u32;
    fn main() -> !;
}

/// Zeroes `.bss`, copies `.data`, calls the program's `main`.
unsafe extern "C" fn start() -> ! {
    // SAFETY: the linker script's section bounds, word-aligned; nothing uses these sections yet.
    unsafe {
        let mut p = core::ptr::addr_of_mut!(_sbss);
        while p < core::ptr::addr_of_mut!(_ebss) {
            p.write_volatile(0);
            p = p.add(1);
        }
        let (mut d, mut s) = (core::ptr::addr_of_mut!(_sdata), core::ptr::addr_of!(_sidata));
        while d < core::ptr::addr_of_mut!(_edata) {
            d.write_volatile(s.read());
            d = d.add(1);
            s = s.add(1);
        }
        main()
    }
}

pub fn init() {}

pub fn now_nanos() -> i64 {
    loop {
        // SAFETY: the CLINT's timer registers, read-only here.
        let (hi, lo, hi2) = unsafe { (MTIME_HI.read_volatile(), MTIME.read_volatile(), MTIME_HI.read_volatile()) };
        if hi == hi2 {
            return ((i64::from(hi) << 32) | i64::from(lo)) * 100;
        }
    }
}

pub fn idle() {}

pub fn uart_write(b: u8) {
    // SAFETY: the UART's registers, at the address the board maps them.
    unsafe {
        while UART_LSR.read_volatile() & LSR_THR_EMPTY == 0 {}
        UART_RBR_THR.write_volatile(b);
    }
}

pub fn uart_read() -> Option<u8> {
    // SAFETY: the UART's registers (see `uart_write`).
    unsafe { (UART_LSR.read_volatile() & LSR_DATA_READY != 0).then(|| UART_RBR_THR.read_volatile()) }
}

pub fn print(_bytes: &[u8]) {}

pub fn exit(code: i32) -> ! {
    let word = if code == 0 { 0x5555 } else { ((code as u32) << 16) | 0x3333 };
    // SAFETY: the test device's register: a write ends the machine.
    unsafe { TEST_DEVICE.write_volatile(word) };
    loop {}
}

pub fn cmdline(_buf: &mut [u8]) -> usize {
    0
}

pub fn stack_used() -> usize {
    0
}

pub fn paint_below_here() -> usize {
    0
}

pub fn stack_used_below(_top: usize) -> usize {
    0
}
