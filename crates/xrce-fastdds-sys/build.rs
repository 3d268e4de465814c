//! Compiles the C++ shim against the system's Fast DDS 2.x (Debian's `libfastrtps-dev`) and links it. Without
//! Fast DDS' headers it compiles `shim/stub.c` instead (every constructor fails with `Error::Unavailable`), so
//! that the workspace and `--all-features` build on a machine without the package; the agent then says how to
//! get the engine when `--dds-engine fastdds` is asked for.
use std::path::Path;

fn main() {
    println!("cargo:rerun-if-changed=shim/xfast.cpp");
    println!("cargo:rerun-if-changed=shim/stub.c");
    println!("cargo:rerun-if-env-changed=XRCE_FASTDDS_INCLUDE");
    let include = std::env::var("XRCE_FASTDDS_INCLUDE").unwrap_or_else(|_| "/usr/include".into());
    let header = Path::new(&include).join("fastdds/dds/domain/DomainParticipantFactory.hpp");
    println!("cargo:rerun-if-changed={}", header.display());
    if !header.exists() {
        // Packages keep their files' old mtimes, so a header that appears later is not "changed" to cargo:
        // watch the whole include directory (a recursive scan, only in this case), which a newly installed
        // package's new directories make newer than this build.
        println!("cargo:rerun-if-changed={include}");
        println!("cargo:warning=Fast DDS headers not found ({}): the fastdds engine is a stub; install libfastrtps-dev and g++ to build it", header.display());
        cc::Build::new().file("shim/stub.c").compile("xfast_shim");
        return;
    }
    cc::Build::new()
        .cpp(true)
        .file("shim/xfast.cpp")
        .include(&include)
        .flag("-std=c++14")
        // Fast DDS 2.9's own headers use deprecated declarations; they are not ours to fix.
        .flag_if_supported("-Wno-deprecated-declarations")
        .opt_level(2)
        .compile("xfast_shim");
    println!("cargo:rustc-link-lib=dylib=fastrtps");
    println!("cargo:rustc-link-lib=dylib=fastcdr");
    println!("cargo:rustc-link-lib=dylib=stdc++");
}
