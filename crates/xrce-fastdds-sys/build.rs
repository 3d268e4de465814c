//! Compiles the C++ shim against Fast DDS 2.x or 3.x where ROS 2 users have it, and links it. Searched in order (issue
//! 21): `XRCE_FASTDDS_PREFIX`, every prefix of `AMENT_PREFIX_PATH` (a sourced ROS 2 environment, or a venv of
//! the ROS 2 wheels), of `CMAKE_PREFIX_PATH`, `/opt/ros/$ROS_DISTRO`, then `/usr` (Debian's and Ubuntu's
//! `libfastrtps-dev`). `XRCE_FASTDDS_INCLUDE=DIR` instead names the include directory alone (a directory that
//! does not exist forces the stub). A library outside the system's directories is found at run time through
//! an rpath (handed on to xrce-dds and xrce-agent, whose build scripts add it to their binaries), so the agent
//! runs without `LD_LIBRARY_PATH`.
//!
//! Fast DDS 2.x is `libfastrtps` (Humble's 2.6 to Jazzy's 2.14, Debian's 2.9), 3.x is `libfastdds` (Kilted's
//! 3.2): the shim is compiled with `XF_FASTDDS_MAJOR` set, and `shim/compat.hpp` holds what differs.
//!
//! Without Fast DDS it compiles `shim/stub.c` instead (every constructor fails with `Error::Unavailable`),
//! so that the workspace and `--all-features` build on any machine; the build says so in a warning, and the
//! agent says how to get the engine when `-m dds` starts.
//!
//! Shared memory is on by default when Fast DDS came from a ROS 2 installation (anywhere but `/usr`): the ROS
//! nodes beside the agent then run the same Fast DDS, whose `/dev/shm` segments they share. Debian's 2.9
//! under `/usr` is not what ROS 2 nodes run (2.9 aborts on 2.14's segments), so UDPv4 only there.
use std::path::{Path, PathBuf};

const HEADER: &str = "fastdds/dds/domain/DomainParticipantFactory.hpp";

/// A Fast DDS installation.
struct FastDds {
    prefix: PathBuf,
    include: PathBuf,
    lib: PathBuf,
    version: String,
    /// 2 (`libfastrtps`) or 3 (`libfastdds`).
    major: u32,
    /// Directories the library's own dependencies are in, when its rpath does not find them: a venv of the
    /// ROS 2 wheels puts `libfastrtps.so` in `lib/` and its vendored libraries in
    /// `lib/python3.*/site-packages/ros_fastrtps.libs/` (`ros_fastdds.libs` for 3.x), which the wheel's
    /// `$ORIGIN` rpath misses from there.
    vendored: Vec<PathBuf>,
}

fn main() {
    println!("cargo:rerun-if-changed=shim/xfast.cpp");
    println!("cargo:rerun-if-changed=shim/compat.hpp");
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

/// The include directories looked at, and the first Fast DDS found.
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

/// Fast DDS in `prefix` (headers in `include`), or `None`.
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
    // 3.x has `fastdds/config.hpp` and `libfastdds`; 2.x `fastrtps/config.h` and `libfastrtps`.
    let (major, version, library, wheel_libs) = match version_in(include, "fastdds/config.hpp", "FASTDDS_VERSION_STR") {
        Some(v) => (3, Some(v), "libfastdds.so", "ros_fastdds.libs"),
        None => {
            (2, version_in(include, "fastrtps/config.h", "FASTRTPS_VERSION_STR"), "libfastrtps.so", "ros_fastrtps.libs")
        }
    };
    let Some(lib) = lib_dirs(prefix).into_iter().find(|d| d.join(library).exists()) else {
        println!("cargo:warning=Fast DDS headers in {} but no {library} beside them: not used", include.display());
        return None;
    };
    let vendored = std::fs::read_dir(prefix.join("lib"))
        .into_iter()
        .flatten()
        .flatten()
        .filter(|e| e.file_name().to_string_lossy().starts_with("python"))
        .map(|e| e.path().join("site-packages").join(wheel_libs))
        .filter(|d| d.is_dir())
        .collect();
    Some(FastDds {
        prefix: prefix.to_path_buf(),
        include: include.to_path_buf(),
        lib,
        version: version.unwrap_or_else(|| format!("{major}.x")),
        major,
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
        .define("XF_FASTDDS_MAJOR", fast.major.to_string().as_str())
        // 3.x headers use C++17 (std::optional, inline variables); 2.x builds with either.
        .flag(if fast.major >= 3 { "-std=c++17" } else { "-std=c++14" })
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
        // libfastrtps/libfastdds needs (libfastcdr), which a RUNPATH would not cover. This crate's own tests and
        // examples get it here; dependents through `DEP_FASTRTPS_RPATH`.
        println!("cargo:rustc-link-arg=-Wl,--disable-new-dtags,-rpath,{rpath}");
        println!("cargo:rpath={rpath}");
    }
    println!("cargo:rustc-link-lib=dylib={}", if fast.major >= 3 { "fastdds" } else { "fastrtps" });
    println!("cargo:rustc-link-lib=dylib=fastcdr");
    println!("cargo:rustc-link-lib=dylib=stdc++");
    let built_with = format!("Fast DDS {} ({})", fast.version, fast.prefix.display());
    println!("cargo:rustc-env=XRCE_FASTDDS_BUILT_WITH={built_with}");
    // The variable naming the user's profiles file that this version reads (3.x renamed it).
    let profiles_env = if fast.major >= 3 { "FASTDDS_DEFAULT_PROFILES_FILE" } else { "FASTRTPS_DEFAULT_PROFILES_FILE" };
    println!("cargo:rustc-env=XRCE_FASTDDS_PROFILES_ENV={profiles_env}");
    let shared_memory = !fast.prefix.starts_with("/usr");
    println!("cargo:rustc-env=XRCE_FASTDDS_SHARED_MEMORY_DEFAULT={shared_memory}");
    // For dependents' build scripts (`DEP_FASTRTPS_BUILT_WITH`): the agent's `--version` prints it.
    println!("cargo:built_with={built_with}");
}

fn build_stub(looked: &[PathBuf]) {
    let places: Vec<String> = looked.iter().map(|p| p.display().to_string()).collect();
    println!(
        "cargo:warning=Fast DDS not found (looked in {}): the fastdds engine is a stub and `-m dds` runs RustDDS; install libfastrtps-dev and g++, or source a ROS 2 environment, then rebuild",
        places.join(", ")
    );
    cc::Build::new().file("shim/stub.c").compile("xfast_shim");
    let built_with = "no Fast DDS (not found at build time): RustDDS only";
    println!("cargo:rustc-env=XRCE_FASTDDS_BUILT_WITH={built_with}");
    println!("cargo:rustc-env=XRCE_FASTDDS_SHARED_MEMORY_DEFAULT=false");
    println!("cargo:rustc-env=XRCE_FASTDDS_PROFILES_ENV=");
    println!("cargo:built_with={built_with}");
}
