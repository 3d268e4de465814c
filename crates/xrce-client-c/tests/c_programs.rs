//! The C tests (tests/c/*.c): each program is compiled against include/ and linked the way a user links
//! (`-lmicroxrcedds_client -lmicrocdr` and the system's libraries), once plainly and once under
//! `-fsanitize=address,undefined`, then run; those that talk to an agent get ours (`-m ced`, in this process,
//! on 127.0.0.1).

use std::io::{BufRead, BufReader, Read};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::OnceLock;

use xrce_agent::agent::AgentInstance;

/// A directory with the library as users link it: `libmicroxrcedds_client.a` and `libmicrocdr.a`.
///
/// The test binary is `<target>/<profile>/deps/<name>`; the static library cargo built for this test run is the
/// newest `deps/libmicroxrcedds_client-<hash>.a` (only `cargo build` copies it to `<profile>/`), and build.rs
/// wrote `libmicrocdr.a` into `<profile>/`.
fn library_dir() -> PathBuf {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let exe = std::env::current_exe().expect("test executable path");
        let deps = exe.parent().expect("deps directory");
        let profile = deps.parent().expect("profile directory");
        let newest = std::fs::read_dir(deps)
            .expect("deps directory readable")
            .filter_map(Result::ok)
            .map(|e| e.path())
            .filter(|p| {
                let name = p.file_name().and_then(|n| n.to_str()).unwrap_or("");
                name.starts_with("libmicroxrcedds_client-") && name.ends_with(".a")
            })
            .max_by_key(|p| p.metadata().and_then(|m| m.modified()).ok())
            .expect("the static library built for this test run");
        let dir = profile.join("c-tests");
        std::fs::create_dir_all(&dir).expect("c-tests directory");
        std::fs::copy(&newest, dir.join("libmicroxrcedds_client.a")).expect("library copied");
        std::fs::copy(profile.join("libmicrocdr.a"), dir.join("libmicrocdr.a")).expect("libmicrocdr.a copied");
        dir
    })
    .clone()
}

/// Whether the library was built with the multithread profile (`XRCE_C_MULTITHREAD=1`, build.rs).
const MULTITHREAD: bool = matches!(env!("XRCE_C_MULTITHREAD").as_bytes(), b"1");

/// The headers as the library was built: `include/`, or (multithread profile) a copy whose config.h turns the
/// profile on, as `scripts/c-install.sh` installs it.
fn include_dir() -> PathBuf {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let source = Path::new(env!("CARGO_MANIFEST_DIR")).join("include");
        if !MULTITHREAD {
            return source;
        }
        let dir = library_dir().join("include-multithread");
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).expect("include copy");
        let status = Command::new("cp").arg("-r").arg(source.join("uxr")).arg(source.join("ucdr")).arg(&dir).status();
        assert!(status.expect("cp runs").success());
        let config = dir.join("uxr/client/config.h");
        let text = std::fs::read_to_string(&config).expect("config.h");
        let on = text.replace("/* #define UCLIENT_PROFILE_MULTITHREAD */", "#define UCLIENT_PROFILE_MULTITHREAD");
        assert_ne!(on, text, "config.h has the multithread marker line");
        std::fs::write(&config, on).expect("config.h written");
        dir
    })
    .clone()
}

/// The C compiler the build found for this target, at `opt_level`.
fn c_compiler(opt_level: u32) -> cc::Tool {
    compiler(opt_level, false)
}

/// The C (or C++) compiler the build found for this target, at `opt_level`.
fn compiler(opt_level: u32, cpp: bool) -> cc::Tool {
    cc::Build::new()
        .cpp(cpp)
        .target(env!("XRCE_C_TARGET"))
        .host(env!("XRCE_C_HOST"))
        .opt_level(opt_level)
        .cargo_metadata(false)
        .warnings(true)
        .get_compiler()
}

/// Compiles `tests/c/<name>.c` (or `<name>.cpp`, as C++20) into an executable; `sanitize` adds ASan and UBSan.
fn compile(name: &str, sanitize: bool) -> PathBuf {
    let crate_dir = Path::new(env!("CARGO_MANIFEST_DIR"));
    let lib_dir = library_dir();
    let exe = lib_dir.join(format!("c-test-{name}{}", if sanitize { "-san" } else { "" }));
    let c_source = crate_dir.join("tests/c").join(format!("{name}.c"));
    let (source, cpp) = if c_source.exists() {
        (c_source, false)
    } else {
        (crate_dir.join("tests/c").join(format!("{name}.cpp")), true)
    };
    let mut cmd = compiler(1, cpp).to_command();
    cmd.arg(if cpp { "-std=c++20" } else { "-std=c11" }).arg("-Wall").arg("-Wextra").arg("-Werror");
    if sanitize {
        cmd.args(["-fsanitize=address,undefined", "-fno-sanitize-recover=all", "-fno-omit-frame-pointer"]);
    }
    cmd.arg(&source).arg("-I").arg(include_dir()).arg("-o").arg(&exe).arg("-L").arg(&lib_dir).args([
        "-lmicroxrcedds_client",
        "-lmicrocdr",
        "-lpthread",
        "-ldl",
        "-lm",
    ]);
    let out = cmd.output().expect("C compiler runs");
    assert!(
        out.status.success(),
        "compiling {name}.c failed:\n{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    exe
}

/// Runs `name` plainly and under the sanitizers with `args`; both must exit 0.
fn run(name: &str, args: &[&str]) {
    for sanitize in [false, true] {
        let exe = compile(name, sanitize);
        let out = Command::new(&exe)
            .args(args)
            .env("ASAN_OPTIONS", "abort_on_error=0:detect_leaks=1")
            .env("UBSAN_OPTIONS", "print_stacktrace=1:halt_on_error=1")
            .output()
            .expect("C test runs");
        println!("{name}{}: {}", if sanitize { " (sanitized)" } else { "" }, String::from_utf8_lossy(&out.stdout));
        assert!(
            out.status.success(),
            "{name}{} failed ({}):\n{}{}",
            if sanitize { " under the sanitizers" } else { "" },
            out.status,
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr)
        );
    }
}

/// Runs `serial` plainly and sanitized: it prints the two pseudoterminals it opened, our agent serves them
/// (`multiserial`), then it must exit 0.
fn run_over_serial_lines() {
    for sanitize in [false, true] {
        let exe = compile("serial", sanitize);
        let mut child =
            Command::new(&exe).stdout(Stdio::piped()).stderr(Stdio::piped()).spawn().expect("C test starts");
        let mut out = BufReader::new(child.stdout.take().expect("stdout"));
        let mut devs = String::new();
        out.read_line(&mut devs).expect("device names");
        let devs = devs.trim().to_string();
        let mut agent = AgentInstance::create(["xrce-agent", "multiserial", "--devs", &devs, "-m", "ced", "-v", "0"])
            .expect("agent");
        let mut rest = String::new();
        out.read_to_string(&mut rest).expect("output");
        let status = child.wait().expect("C test ends");
        let mut err = String::new();
        child.stderr.take().expect("stderr").read_to_string(&mut err).expect("stderr");
        agent.stop().expect("agent stops");
        println!("serial{}: {rest}", if sanitize { " (sanitized)" } else { "" });
        assert!(status.success(), "serial{} failed ({status}):\n{rest}{err}", if sanitize { " sanitized" } else { "" });
    }
}

/// Runs `name IP PORT` against our agent, or against the agent `XRCE_C_AGENT=IP:PORT` names (eProsima's, say:
/// a DDS agent wants `XRCE_C_SETTLE_MS`, the time its writers and readers take to match, 2000 for eProsima's).
fn run_with_agent(name: &str) {
    if let Ok(outside) = std::env::var("XRCE_C_AGENT") {
        let (ip, port) = outside.rsplit_once(':').expect("XRCE_C_AGENT=IP:PORT");
        let settle = std::env::var("XRCE_C_SETTLE_MS").unwrap_or_else(|_| "0".into());
        run(name, &[ip, port, &settle]);
        return;
    }
    let mut agent = AgentInstance::create(["xrce-agent", "udp4", "-p", "0", "-m", "ced", "-v", "0"]).expect("agent");
    let port = agent.local_addr().expect("agent bound").port().to_string();
    run(name, &["127.0.0.1", &port]);
    agent.stop().expect("agent stops");
}

#[test]
fn ping_time_references_deletion_custom_and_tcp_transports() {
    let mut udp = AgentInstance::create(["xrce-agent", "udp4", "-p", "0", "-m", "ced", "-v", "0"]).expect("agent");
    let mut tcp = AgentInstance::create(["xrce-agent", "tcp4", "-p", "0", "-m", "ced", "-v", "0"]).expect("agent");
    let udp_port = udp.local_addr().expect("agent bound").port().to_string();
    let tcp_port = tcp.local_addr().expect("agent bound").port().to_string();
    run("misc", &["127.0.0.1", &udp_port, &tcp_port]);
    udp.stop().expect("agent stops");
    tcp.stop().expect("agent stops");
}

/// The two headers are C99 as eProsima's are (firmware toolchains build with `-std=c99 -pedantic`), and C11:
/// they compile cleanly in both, their layout checks included.
#[test]
fn the_headers_compile_as_c99_and_c11_with_pedantic_warnings_as_errors() {
    let probe = library_dir().join("headers.c");
    std::fs::write(
        &probe,
        "#include <uxr/client/client.h>\n#include <ucdr/microcdr.h>\nint main(void) { return 0; }\n",
    )
    .expect("probe written");
    for std in ["c99", "c11"] {
        let out = c_compiler(0)
            .to_command()
            .args([format!("-std={std}").as_str(), "-pedantic", "-Wall", "-Wextra", "-Werror", "-fsyntax-only", "-I"])
            .arg(include_dir())
            .arg(&probe)
            .output()
            .expect("C compiler runs");
        assert!(out.status.success(), "-std={std}:\n{}", String::from_utf8_lossy(&out.stderr));
    }
}

#[test]
fn serial_transport_and_framed_custom_transport_over_pseudoterminals() {
    run_over_serial_lines();
}

#[test]
fn ucdr_serializes_every_primitive_array_sequence_and_string() {
    run("ucdr", &[]);
}

#[test]
fn the_boundary_answers_bad_arguments_with_the_seeds_error_values() {
    run("boundary", &[]);
}

#[test]
fn hello_world_publisher_and_subscriber_through_our_agent() {
    run_with_agent("hello_pubsub");
}

#[test]
fn request_reply_with_binary_entities_and_a_reply_from_the_callback() {
    run_with_agent("services");
}

#[test]
fn a_sample_larger_than_the_history_goes_through_continuous_fragmentation() {
    run_with_agent("big");
}

#[test]
fn eprosimas_fields_forms_headers_and_serializers_behave_as_programs_use_them() {
    run_with_agent("eprosima_api");
}

/// PX4's `uxrce_dds_client` is C++: the same API from a C++ program (designated initializers in eProsima's
/// field order, the session's fields, the forms the C macros pick).
#[test]
fn the_api_from_cpp_as_px4_uses_it() {
    run_with_agent("eprosima_api_cpp");
}

/// Two threads on one session, as a micro-ROS executor and a timer thread use it: one publishes (prepare,
/// serialize, `UXR_UNLOCK_STREAM_ID`, as rmw_microxrcedds does), the other runs the session meanwhile; every
/// sample arrives, in order. With the profile off (the default build) the program checks that the lock macros
/// are empty and that a second thread entering a busy session gets the failure value, not a data race.
#[test]
fn two_threads_on_one_session_with_the_multithread_profile() {
    run_with_agent("multithread");
}

#[test]
fn a_49999_byte_sample_through_prepare_output_stream_is_fragmented_over_the_stream() {
    run_with_agent("big_prepare");
}

/// The CMake packages `microxrcedds_client` and `microcdr` (cmake/, installed by scripts/c-install.sh): a
/// project written for eProsima's client finds them with find_package and links its targets. Lays the
/// library out as the script installs it, configures and builds a small project, runs it. Needs `cmake`
/// (.ci/run installs it); without it the test says so and passes.
#[test]
fn find_package_finds_the_installed_library_and_its_targets() {
    if Command::new("cmake").arg("--version").output().is_err() {
        println!("cmake not found: find_package not checked");
        return;
    }
    let crate_dir = Path::new(env!("CARGO_MANIFEST_DIR"));
    let lib = library_dir();
    let prefix = lib.join("cmake-prefix");
    let _ = std::fs::remove_dir_all(&prefix);
    for dir in ["lib/cmake/microxrcedds_client", "lib/cmake/microcdr", "include"] {
        std::fs::create_dir_all(prefix.join(dir)).expect("prefix directories");
    }
    let copy_tree = |from: &Path, to: &Path| {
        let status = Command::new("cp").arg("-r").arg(from).arg(to).status().expect("cp runs");
        assert!(status.success());
    };
    copy_tree(&include_dir().join("uxr"), &prefix.join("include"));
    copy_tree(&include_dir().join("ucdr"), &prefix.join("include"));
    std::fs::copy(lib.join("libmicroxrcedds_client.a"), prefix.join("lib/libmicroxrcedds_client.a")).expect("lib");
    std::fs::copy(lib.join("libmicroxrcedds_client.a"), prefix.join("lib/libmicrocdr.a")).expect("lib");
    for entry in std::fs::read_dir(crate_dir.join("cmake")).expect("cmake dir").filter_map(Result::ok) {
        let name = entry.file_name().to_string_lossy().into_owned();
        let package = if name.starts_with("microcdr") { "microcdr" } else { "microxrcedds_client" };
        std::fs::copy(entry.path(), prefix.join("lib/cmake").join(package).join(&name)).expect("cmake file");
    }
    let project = lib.join("cmake-project");
    let _ = std::fs::remove_dir_all(&project);
    std::fs::create_dir_all(&project).expect("project dir");
    std::fs::write(
        project.join("CMakeLists.txt"),
        "cmake_minimum_required(VERSION 3.16)\nproject(uses_the_client C)\n\
         find_package(microcdr REQUIRED)\nfind_package(microxrcedds_client 2.4 REQUIRED)\n\
         add_executable(uses main.c)\ntarget_link_libraries(uses microxrcedds_client microcdr)\n",
    )
    .expect("CMakeLists.txt");
    std::fs::write(
        project.join("main.c"),
        "#include <uxr/client/client.h>\n#include <stdio.h>\nint main(void) {\n\
         uint8_t b[8]; ucdrBuffer ub; ucdr_init_buffer(&ub, b, sizeof b);\n\
         return ucdr_serialize_uint32_t(&ub, 7) && uxr_millis() > 0 && UXR_CLIENT_VERSION_MAJOR == 3 ? 0 : 1; }\n",
    )
    .expect("main.c");
    let build = project.join("build");
    let configure = Command::new("cmake")
        .arg("-S")
        .arg(&project)
        .arg("-B")
        .arg(&build)
        .arg(format!("-DCMAKE_PREFIX_PATH={}", prefix.display()))
        .output()
        .expect("cmake runs");
    assert!(configure.status.success(), "configure:\n{}", String::from_utf8_lossy(&configure.stderr));
    let built = Command::new("cmake").arg("--build").arg(&build).output().expect("cmake --build runs");
    assert!(
        built.status.success(),
        "build:\n{}{}",
        String::from_utf8_lossy(&built.stdout),
        String::from_utf8_lossy(&built.stderr)
    );
    let ran = Command::new(build.join("uses")).status().expect("program runs");
    assert!(ran.success(), "the program built with find_package failed");
}
