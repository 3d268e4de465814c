//! Reads the opaque storage sizes and the layout table (`UXR_ABI` lines) from client.h, so that the header is
//! the one place they are written: the Rust side gets them as constants and compile-time assertions
//! (`$OUT_DIR/layout.rs`), the C side is checked by compiling the header. Also writes an empty `libmicrocdr.a`
//! beside the library: the `ucdr_*` functions live in `libmicroxrcedds_client.a` (one Rust static library per
//! program: two would each carry the Rust runtime), and `-lmicrocdr` in existing link lines must still resolve.

#![allow(clippy::panic)] // a build script reports a broken header by failing

use std::env;
use std::fs;
use std::path::{Path, PathBuf};

const HEADER: &str = "include/uxr/client/client.h";
const OPAQUE: [(&str, &str); 6] = [
    ("UXR_SESSION_OPAQUE_WORDS", "SESSION_WORDS"),
    ("UXR_UDP_TRANSPORT_OPAQUE_WORDS", "UDP_WORDS"),
    ("UXR_TCP_TRANSPORT_OPAQUE_WORDS", "TCP_WORDS"),
    ("UXR_SERIAL_TRANSPORT_OPAQUE_WORDS", "SERIAL_WORDS"),
    ("UXR_CUSTOM_TRANSPORT_OPAQUE_WORDS", "CUSTOM_WORDS"),
    ("UXR_CAN_TRANSPORT_OPAQUE_WORDS", "CAN_WORDS"),
];

fn main() {
    println!("cargo:rerun-if-changed={HEADER}");
    println!("cargo:rerun-if-changed=include/ucdr/microcdr.h");
    let header = fs::read_to_string(HEADER).unwrap_or_else(|e| panic!("{HEADER}: {e}"));
    let out = PathBuf::from(env::var("OUT_DIR").unwrap_or_else(|e| panic!("OUT_DIR: {e}")));

    let mut rust = String::new();
    for (c_name, rust_name) in OPAQUE {
        let value = define(&header, c_name).unwrap_or_else(|| panic!("{HEADER} lacks #define {c_name}"));
        rust.push_str(&format!("/// `{c_name}`.\npub const {rust_name}: usize = {value};\n"));
    }
    for line in header.lines().filter(|l| l.starts_with("UXR_ABI(")) {
        let args = line.trim_start_matches("UXR_ABI(").trim_end_matches(')');
        let parts: Vec<&str> = args.splitn(3, ", ").collect();
        let [ty, size, align] = parts.as_slice() else { panic!("bad layout line: {line}") };
        let rust_expr = |e: &str| {
            let mut e = e.replace("UXR_PTR", "core::mem::size_of::<usize>()");
            for (c_name, rust_name) in OPAQUE {
                e = e.replace(c_name, rust_name);
            }
            e
        };
        rust.push_str(&format!(
            "const _: () = assert!(core::mem::size_of::<{ty}>() == {} && core::mem::align_of::<{ty}>() == {}, \
             \"layout of {ty} differs from client.h\");\n",
            rust_expr(size),
            rust_expr(align)
        ));
    }
    fs::write(out.join("layout.rs"), rust).unwrap_or_else(|e| panic!("layout.rs: {e}"));

    // The C side of the same table: compiling the header evaluates its static assertions.
    let check = out.join("layout_check.c");
    fs::write(&check, "#include <uxr/client/client.h>\n").unwrap_or_else(|e| panic!("layout_check.c: {e}"));
    cc::Build::new().file(&check).include("include").cargo_metadata(false).warnings(true).compile("layout_check");

    empty_microcdr(&out);

    // The C tests (tests/c_programs.rs) compile for the same target with the `cc` crate, which asks for these.
    for var in ["TARGET", "HOST"] {
        if let Ok(value) = env::var(var) {
            println!("cargo:rustc-env=XRCE_C_{var}={value}");
        }
    }
}

/// The value of `#define NAME value` in `text`.
fn define(text: &str, name: &str) -> Option<usize> {
    text.lines().find_map(|l| {
        let rest = l.strip_prefix("#define ")?.strip_prefix(name)?;
        rest.trim().parse().ok()
    })
}

/// `libmicrocdr.a` (an empty archive) in the profile directory, beside `libmicroxrcedds_client.a`.
fn empty_microcdr(out: &Path) {
    // OUT_DIR is <target>/<profile>/build/<crate>-<hash>/out.
    let Some(profile_dir) = out.ancestors().nth(3) else { return };
    let _ = fs::write(profile_dir.join("libmicrocdr.a"), b"!<arch>\n");
}
