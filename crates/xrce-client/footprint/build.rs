//! Links the probes without crt1/crti (they bring their own `_start`), against the shared libc only for the
//! `mem*` functions and a few system calls, as a firmware links against its vendor's C library.
fn main() {
    println!("cargo:rustc-link-arg-bins=-nostartfiles");
    println!("cargo:rustc-link-arg-bins=-lc");
}
