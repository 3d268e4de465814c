//! Board support for the firmware: what a DDS-XRCE client needs from a microcontroller and nothing more.
//!
//! * [`Uart`]: the client's custom transport callbacks ([`CustomIo`]) over the board's UART registers; [`link`]
//!   wraps them in the framed (HDLC-like) custom transport that the agent's `serial`/`pseudoterminal`
//!   transports speak.
//! * [`BoardClock`]: the client's [`Clock`], from the core's timer (SysTick on Cortex-M).
//! * [`print`], [`print_num`], [`exit`], [`cmdline`]: the run's output, verdict and arguments, through
//!   semihosting (QEMU: `-semihosting-config enable=on,target=native`).
//! * [`stack_used`]: the stack's high-water mark since reset.
//!
//! Cortex-M (`arm.rs`): QEMU's mps2-an386 (Cortex-M4) and mps2-an385, CMSDK APB UART0 at 0x40004000. RISC-V
//! (`riscv.rs`): a 16550 UART at 0x10000000 and the CLINT timer, for size measurements.
#![no_std]

use xrce_client::transport::{CustomIo, CustomTransport, TransportError};
use xrce_client::Clock;

#[cfg(target_arch = "arm")]
mod arm;
#[cfg(target_arch = "arm")]
use arm as hw;

#[cfg(target_arch = "riscv32")]
mod riscv;
#[cfg(target_arch = "riscv32")]
use riscv as hw;

pub use hw::{exit, paint_below_here, stack_used, stack_used_below};

/// The client's message size on the serial line (eProsima's `UXR_CONFIG_SERIAL_TRANSPORT_MTU`).
pub const MTU: usize = 512;

/// The framed custom transport over the UART.
pub type Link = CustomTransport<Uart, MTU>;

/// Sets the board up (UART, timer); call once, first.
pub fn init() {
    hw::init();
}

/// The UART as the four callbacks of an eProsima custom transport, stream-oriented (framing on).
#[derive(Debug, Default)]
pub struct Uart;

impl CustomIo for Uart {
    fn write(&mut self, buf: &[u8]) -> Result<usize, TransportError> {
        for &b in buf {
            hw::uart_write(b);
        }
        Ok(buf.len())
    }

    /// Waits up to `timeout_ms` for a first byte (sleeping between timer ticks), then takes what is there.
    fn read(&mut self, buf: &mut [u8], timeout_ms: i32) -> Result<usize, TransportError> {
        let deadline = (timeout_ms >= 0).then(|| hw::now_nanos() + i64::from(timeout_ms) * 1_000_000);
        let mut n = 0;
        loop {
            while let Some(slot) = buf.get_mut(n) {
                match hw::uart_read() {
                    Some(b) => {
                        *slot = b;
                        n += 1;
                    }
                    None => break,
                }
            }
            if n > 0 || deadline.is_some_and(|d| hw::now_nanos() >= d) || buf.is_empty() {
                return Ok(n);
            }
            hw::idle();
        }
    }
}

/// The framed custom transport over the UART, frames from address 0 to address 0 (eProsima's custom
/// transport's, which the agent's serial transports expect).
pub fn link() -> Result<Link, TransportError> {
    CustomTransport::new(Uart, true)
}

/// Nanoseconds since reset, from the core's timer.
#[derive(Debug, Default, Clone, Copy)]
pub struct BoardClock;

impl Clock for BoardClock {
    fn now_nanos(&mut self) -> i64 {
        hw::now_nanos()
    }
}

/// Nanoseconds since reset.
pub fn now_nanos() -> i64 {
    hw::now_nanos()
}

/// Milliseconds since reset.
pub fn now_millis() -> i64 {
    hw::now_nanos() / 1_000_000
}

/// Writes `bytes` to the host's console (semihosting).
pub fn print(bytes: &[u8]) {
    hw::print(bytes);
}

/// Writes `n` in decimal (without `core::fmt`, which would weigh more than the client's wire code).
pub fn print_num(n: u64) {
    let mut buf = [0u8; 20];
    let digits = format_num(n, &mut buf);
    print(digits);
}

/// `n` in decimal, in the tail of `buf`.
pub fn format_num(mut n: u64, buf: &mut [u8; 20]) -> &[u8] {
    let mut i = buf.len();
    for slot in buf.iter_mut().rev() {
        *slot = b'0' + (n % 10) as u8;
        i -= 1;
        n /= 10;
        if n == 0 {
            break;
        }
    }
    buf.get(i..).unwrap_or(&[])
}

/// Writes `label`, `n` and a new line.
pub fn report(label: &[u8], n: u64) {
    print(label);
    print_num(n);
    print(b"\n");
}

/// The command line QEMU was given (`-append`, after the program's name), copied into `buf`.
pub fn cmdline(buf: &mut [u8]) -> &[u8] {
    let n = hw::cmdline(buf);
    let line = buf.get(..n).unwrap_or(&[]);
    // QEMU passes "<kernel file> <-append text>": skip the file name.
    match line.iter().position(|&b| b == b' ') {
        Some(space) => line.get(space + 1..).unwrap_or(&[]),
        None => &[],
    }
}

/// The arguments of a command line: words separated by spaces.
pub fn words(line: &[u8]) -> impl Iterator<Item = &[u8]> {
    line.split(|&b| b == b' ').filter(|w| !w.is_empty())
}

/// A decimal number, or `None`.
pub fn parse_num(word: &[u8]) -> Option<u32> {
    if word.is_empty() {
        return None;
    }
    word.iter().try_fold(0u32, |acc, &b| {
        let digit = b.checked_sub(b'0').filter(|d| *d < 10)?;
        acc.checked_mul(10)?.checked_add(u32::from(digit))
    })
}

#[panic_handler]
fn panic(_: &core::panic::PanicInfo<'_>) -> ! {
    print(b"panic\n");
    exit(101)
}
