//! Adds the rpath of a Fast DDS found outside the system's library directories (xrce-fastdds-sys' build, handed
//! on by xrce-dds' as `DEP_XRCE_DDS_RPATH`) to the agent's binaries, tests and examples, so that they run
//! without `LD_LIBRARY_PATH`; and names that Fast DDS for `--version`.
fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    let built_with = std::env::var("DEP_XRCE_DDS_BUILT_WITH").unwrap_or_else(|_| "unknown".to_owned());
    println!("cargo:rustc-env=XRCE_AGENT_DDS_BUILT_WITH={built_with}");
    if let Ok(dir) = std::env::var("DEP_XRCE_DDS_RPATH") {
        println!("cargo:rustc-link-arg=-Wl,--disable-new-dtags,-rpath,{dir}");
    }
}
