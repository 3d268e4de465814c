//! Compiles the C++ shim against Fast DDS 2.x where ROS 2 users have it, and links it. Searched in order (issue
//! 21): `XRCE_FASTDDS_PREFIX`, every prefix of `AMENT_PREFIX_PATH` (a sourced ROS 2 environment, or a venv of
//! the ROS 2 wheels), of `CMAKE_PREFIX_PATH`, `/opt/ros/$ROS_DISTRO`, then `/usr` (Debian's and Ubuntu's
//! `libfastrtps-dev`). `XRCE_FASTDDS_INCLUDE=DIR` instead names the include directory alone (a directory that
//! does not exist forces the stub). A library outside the system's directories is found at run time through
//! an rpath (handed on to xrce-dds and xrce-agent, whose build scripts add it to their binaries), so the agent
//! runs without `LD_LIBRARY_PATH`.
//!
//! Without Fast DDS 2.x it compiles `shim/stub.c` instead (every constructor fails with `Error::Unavailable`),
//! so that the workspace and `--all-features` build on any machine; the build says so in a warning, and the
//! agent says how to get the engine when `-m dds` starts. Fast DDS 3.x (ROS 2 Kilted and later, `libfastdds`)
//! is recognised and reported, not used yet: its API differs from 2.x.
use std::path::{Path, PathBuf};

const HEADER: &str = "fastdds/dds/domain/DomainParticipantFactory.hpp";

/// A Fast DDS 2.x installation.
struct FastDds {
    prefix: PathBuf,
    include: PathBuf,
    lib: PathBuf,
    version: String,
    /// Directories the library's own dependencies are in, when its rpath does not find them: a venv of the
    /// ROS 2 wheels puts `libfastrtps.so` in `lib/` and its vendored libraries in
    /// `lib/python3.*/site-packages/ros_fastrtps.libs/`, which the wheel's `$ORIGIN` rpath misses from there.
    vendored: Vec<PathBuf>,
}

fn main() {
    println!("cargo:rerun-if-changed=shim/xfast.cpp");
    println!("cargo:rerun-if-changed=shim/stub.c");
    for var in ["XRCE_FASTDDS_INCLUDE", "XRCE_FASTDDS_PREFIX", "AMENT_PREFIX_PATH", "CMAKE_PREFIX_PATH", "ROS_DISTRO"] {
        println!("cargo:rerun-if-env-changed={var}");
    }
    let (candidates, found) = search();
    match found {
        Some(fast) => build_shim(&fast),
        None => build_stub(&candidates),
    }
}

/// The include directories looked at, and the first Fast DDS 2.x found.
fn search() -> (Vec<PathBuf>, Option<FastDds>) {
    if let Some(include) = std::env::var_os("XRCE_FASTDDS_INCLUDE") {
        let include = PathBuf::from(include);
        let prefix = include.parent().map_or_else(|| PathBuf::from("/"), Path::to_path_buf);
        let found = probe(&prefix, &include);
        return (vec![include], found);
    }
    let mut prefixes: Vec<PathBuf> = Vec::new();
    if let Some(p) = std::env::var_os("XRCE_FASTDDS_PREFIX") {
        prefixes.push(p.into());
    }
    for var in ["AMENT_PREFIX_PATH", "CMAKE_PREFIX_PATH"] {
        if let Some(list) = std::env::var_os(var) {
            prefixes.extend(std::env::split_paths(&list).filter(|p| !p.as_os_str().is_empty()));
        }
    }
    if let Ok(distro) = std::env::var("ROS_DISTRO") {
        prefixes.push(Path::new("/opt/ros").join(distro.trim()));
    }
    prefixes.push("/usr".into());
    let mut looked = Vec::new();
    for prefix in prefixes {
        let include = prefix.join("include");
        if let Some(found) = probe(&prefix, &include) {
            return (looked, Some(found));
        }
        looked.push(include);
    }
    (looked, None)
}

/// Fast DDS 2.x in `prefix` (headers in `include`), or `None` (a 3.x there is reported in a warning).
fn probe(prefix: &Path, include: &Path) -> Option<FastDds> {
    let header = include.join(HEADER);
    if !header.exists() {
        // Packages keep their files' old mtimes, so a header that appears later is not "changed" to cargo: the
        // directory is watched (a recursive scan; a newly installed package's directories are newer).
        if include.is_dir() {
            println!("cargo:rerun-if-changed={}", include.display());
        }
        return None;
    }
    println!("cargo:rerun-if-changed={}", header.display());
    let lib = lib_dirs(prefix).into_iter().find(|d| d.join("libfastrtps.so").exists());
    let version = version_in(include, "fastrtps/config.h", "FASTRTPS_VERSION_STR");
    let Some(lib) = lib else {
        if let Some(v) = version_in(include, "fastdds/config.hpp", "FASTDDS_VERSION_STR") {
            println!(
                "cargo:warning=Fast DDS {v} found in {} (libfastdds, ROS 2 Kilted and later): not supported by this build yet, only Fast DDS 2.x (libfastrtps)",
                prefix.display()
            );
        }
        return None;
    };
    let vendored = std::fs::read_dir(prefix.join("lib"))
        .into_iter()
        .flatten()
        .flatten()
        .filter(|e| e.file_name().to_string_lossy().starts_with("python"))
        .map(|e| e.path().join("site-packages/ros_fastrtps.libs"))
        .filter(|d| d.is_dir())
        .collect();
    Some(FastDds {
        prefix: prefix.to_path_buf(),
        include: include.to_path_buf(),
        lib,
        version: version.unwrap_or_else(|| "2.x".into()),
        vendored,
    })
}

/// `prefix/lib` and its multiarch subdirectories (`/usr/lib/x86_64-linux-gnu`).
fn lib_dirs(prefix: &Path) -> Vec<PathBuf> {
    let lib = prefix.join("lib");
    let mut dirs = vec![lib.clone()];
    if let Ok(entries) = std::fs::read_dir(&lib) {
        dirs.extend(
            entries
                .flatten()
                .map(|e| e.path())
                .filter(|p| p.is_dir() && p.file_name().is_some_and(|n| n.to_string_lossy().ends_with("-linux-gnu"))),
        );
    }
    dirs
}

/// The string value of `#define NAME "…"` in `include/file` or its multiarch copy (`include/<triple>/file`).
fn version_in(include: &Path, file: &str, name: &str) -> Option<String> {
    let mut paths = vec![include.join(file)];
    if let Ok(entries) = std::fs::read_dir(include) {
        paths.extend(entries.flatten().map(|e| e.path().join(file)));
    }
    paths.iter().filter_map(|p| std::fs::read_to_string(p).ok()).find_map(|text| {
        text.lines().find_map(|l| {
            let rest = l.trim().strip_prefix("#define")?.trim().strip_prefix(name)?;
            Some(rest.trim().trim_matches('"').to_owned())
        })
    })
}

/// Whether the dynamic loader finds libraries in `dir` without help.
fn is_system_dir(dir: &Path) -> bool {
    dir.starts_with("/usr/lib") || dir.starts_with("/lib")
}

fn build_shim(fast: &FastDds) {
    cc::Build::new()
        .cpp(true)
        .file("shim/xfast.cpp")
        .include(&fast.include)
        .flag("-std=c++14")
        // Fast DDS' own headers use deprecated declarations; they are not ours to fix.
        .flag_if_supported("-Wno-deprecated-declarations")
        .opt_level(2)
        .compile("xfast_shim");
    if !is_system_dir(&fast.lib) {
        println!("cargo:rustc-link-search=native={}", fast.lib.display());
        let dirs: Vec<String> =
            std::iter::once(&fast.lib).chain(&fast.vendored).map(|d| d.display().to_string()).collect();
        let rpath = dirs.join(":");
        // An RPATH, not a RUNPATH (`--disable-new-dtags`): the loader then also uses it for the libraries
        // libfastrtps needs (libfastcdr), which a RUNPATH would not cover. This crate's own tests and
        // examples get it here; dependents through `DEP_FASTRTPS_RPATH`.
        println!("cargo:rustc-link-arg=-Wl,--disable-new-dtags,-rpath,{rpath}");
        println!("cargo:rpath={rpath}");
    }
    println!("cargo:rustc-link-lib=dylib=fastrtps");
    println!("cargo:rustc-link-lib=dylib=fastcdr");
    println!("cargo:rustc-link-lib=dylib=stdc++");
    let built_with = format!("Fast DDS {} ({})", fast.version, fast.prefix.display());
    println!("cargo:rustc-env=XRCE_FASTDDS_BUILT_WITH={built_with}");
    // For dependents' build scripts (`DEP_FASTRTPS_BUILT_WITH`): the agent's `--version` prints it.
    println!("cargo:built_with={built_with}");
}

fn build_stub(looked: &[PathBuf]) {
    let places: Vec<String> = looked.iter().map(|p| p.display().to_string()).collect();
    println!(
        "cargo:warning=Fast DDS 2.x not found (looked in {}): the fastdds engine is a stub and `-m dds` runs RustDDS; install libfastrtps-dev and g++, or source a ROS 2 environment, then rebuild",
        places.join(", ")
    );
    cc::Build::new().file("shim/stub.c").compile("xfast_shim");
    let built_with = "no Fast DDS (not found at build time): RustDDS only";
    println!("cargo:rustc-env=XRCE_FASTDDS_BUILT_WITH={built_with}");
    println!("cargo:built_with={built_with}");
}
