//! The empty probe: the board's start-up, UART and timer set-up, console, exit and fault handlers, nothing
//! else. Its sections are what the publishers' would be without the client.
#![no_std]
#![no_main]

use xrce_board as board;

#[export_name = "main"]
extern "C" fn main() -> ! {
    board::init();
    board::print(b"baseline\n");
    board::report(b"peak stack: ", board::stack_used() as u64);
    board::exit(0)
}
