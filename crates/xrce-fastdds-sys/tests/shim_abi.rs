//! The shim's C ABI is written three times: declared in `src/ffi.rs`, defined over Fast DDS in `shim/xfast.cpp`
//! and as a stub in `shim/stub.c` (built where Fast DDS is not installed). A function missing from the stub
//! links only on machines with Fast DDS, so these lists are compared here, whichever of the two was built.

use std::collections::BTreeSet;

/// Names `xf_…` that start a call or definition (`xf_name(`) on lines accepted by `keep`.
fn functions(source: &str, keep: impl Fn(&str) -> bool) -> BTreeSet<String> {
    let mut names = BTreeSet::new();
    for line in source.lines().filter(|l| keep(l)) {
        let mut rest = line;
        while let Some(at) = rest.find("xf_") {
            let tail = &rest[at..];
            let len = tail.find(|c: char| !(c.is_ascii_alphanumeric() || c == '_')).unwrap_or(tail.len());
            if tail[len..].starts_with('(') {
                names.insert(tail[..len].to_string());
            }
            rest = &tail[len..];
        }
    }
    names
}

fn read(path: &str) -> String {
    let full = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(path);
    std::fs::read_to_string(&full).unwrap_or_else(|e| panic!("{}: {e}", full.display()))
}

/// Definitions start at column 0 in both C files; calls inside bodies are indented.
fn defined_in(path: &str) -> BTreeSet<String> {
    functions(&read(path), |l| !l.starts_with(char::is_whitespace) && !l.starts_with("//") && !l.starts_with("/*"))
}

#[test]
fn stub_defines_every_shim_function() {
    let declared = functions(&read("src/ffi.rs"), |l| l.trim_start().starts_with("pub(crate) fn xf_"));
    assert!(declared.len() > 20, "ffi.rs parsed: {declared:?}");
    assert_eq!(declared, defined_in("shim/stub.c"), "src/ffi.rs against shim/stub.c");
    assert_eq!(declared, defined_in("shim/xfast.cpp"), "src/ffi.rs against shim/xfast.cpp");
}
