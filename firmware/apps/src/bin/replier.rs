#![no_std]
#![no_main]
use xrce_firmware as fw;
#[export_name = "main"]
extern "C" fn main() -> ! {
    fw::finish(false)
}
