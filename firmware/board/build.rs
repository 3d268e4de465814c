//! Puts the board's memory map where the linker looks: `memory.x` for cortex-m-rt's `link.x`, `riscv.ld` for the
//! RISC-V size builds.
use std::path::PathBuf;

fn main() {
    let out = PathBuf::from(std::env::var_os("OUT_DIR").unwrap_or_default());
    for file in ["memory.x", "riscv.ld"] {
        if let Err(e) = std::fs::copy(file, out.join(file)) {
            panic!("copying {file}: {e}");
        }
        println!("cargo:rerun-if-changed={file}");
    }
    println!("cargo:rustc-link-search={}", out.display());
}
