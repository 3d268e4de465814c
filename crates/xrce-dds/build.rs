//! Hands on what xrce-fastdds-sys' build found (its `DEP_FASTRTPS_*` metadata): the rpath of a Fast DDS outside
//! the system's library directories, for this crate's tests and examples and for xrce-agent's binaries
//! (cargo passes a build script's metadata to direct dependents only), and which Fast DDS the build uses.
fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    let built_with = std::env::var("DEP_FASTRTPS_BUILT_WITH")
        .unwrap_or_else(|_| "no Fast DDS (cargo feature `fastdds` off): RustDDS only".to_owned());
    println!("cargo:built_with={built_with}");
    if let Ok(dir) = std::env::var("DEP_FASTRTPS_RPATH") {
        println!("cargo:rustc-link-arg=-Wl,--disable-new-dtags,-rpath,{dir}");
        println!("cargo:rpath={dir}");
    }
}
