//! Compiles the C++ shim against Debian's Fast DDS 2.9 (`libfastrtps-dev`) and links it.
fn main() {
    println!("cargo:rerun-if-changed=shim/xfast.cpp");
    cc::Build::new()
        .cpp(true)
        .file("shim/xfast.cpp")
        .flag("-std=c++14")
        // Fast DDS 2.9's own headers use deprecated declarations; they are not ours to fix.
        .flag_if_supported("-Wno-deprecated-declarations")
        .opt_level(2)
        .compile("xfast_shim");
    println!("cargo:rustc-link-lib=dylib=fastrtps");
    println!("cargo:rustc-link-lib=dylib=fastcdr");
    println!("cargo:rustc-link-lib=dylib=stdc++");
}
