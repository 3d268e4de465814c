//! What both probes share: the process entry, exit and panic handling, all minimal.
#![no_std]

extern "C" {
    fn _exit(code: i32) -> !;
    fn write(fd: i32, buf: *const u8, len: usize) -> isize;
}

/// Ends the process without running anything else.
pub fn exit(code: i32) -> ! {
    // SAFETY: `_exit` takes any status and never returns.
    unsafe { _exit(code) }
}

/// Writes `bytes` to standard output.
pub fn print(bytes: &[u8]) {
    // SAFETY: the pointer and length describe a live slice.
    unsafe { write(1, bytes.as_ptr(), bytes.len()) };
}

/// Writes `n` in decimal (no `core::fmt`: it would weigh more than the client).
pub fn print_num(mut n: usize) {
    let mut buf = [0u8; 20];
    let mut i = buf.len();
    loop {
        i -= 1;
        buf[i] = b'0' + (n % 10) as u8;
        n /= 10;
        if n == 0 {
            break;
        }
    }
    print(&buf[i..]);
}

#[panic_handler]
fn panic(_: &core::panic::PanicInfo<'_>) -> ! {
    exit(101)
}

/// Defines `_start`: aligns the stack as a call would and jumps to `$main(sp: *const usize) -> !`, `sp` pointing
/// at `argc`, then `argv`.
#[macro_export]
macro_rules! entry {
    ($main:path) => {
        core::arch::global_asm!(
            ".globl _start",
            "_start:",
            "xor ebp, ebp",
            "mov rdi, rsp",
            "and rsp, -16",
            "call {main}",
            "ud2",
            main = sym $main,
        );
    };
}
