//! Keeps the Rust definitions of the C structures equal to the headers', field for field, on every target:
//!
//! * the opaque storage sizes (`#define UXR_*_OPAQUE_WORDS`) are read from the headers, so the headers are the
//!   one place they are written;
//! * a probe file (`$OUT_DIR/layout_probe.c`) is compiled for the target with the target's C compiler: for each
//!   structure it defines arrays whose sizes are the structure's size, alignment and field offsets (plus one).
//!   The sizes of those symbols are read back from the object file (the `object` crate) and become
//!   compile-time assertions against `size_of`, `align_of` and `offset_of!` of the Rust definitions
//!   (`$OUT_DIR/layout.rs`, included by src/layout.rs). A structure the target's headers do not have (no UDP
//!   on bare metal) is simply not checked there.
//!
//! Also writes an empty `libmicrocdr.a` beside the library: the `ucdr_*` functions live in
//! `libmicroxrcedds_client.a` (one Rust static library per program: two would each carry the Rust runtime), and
//! `-lmicrocdr` in existing link lines must still resolve.

#![allow(clippy::panic)] // a build script reports a broken header by failing

use std::collections::BTreeMap;
use std::env;
use std::fs;
use std::path::{Path, PathBuf};

use object::{Object, ObjectSymbol};

/// Headers holding opaque word counts, and the Rust constants they become.
const OPAQUE: [(&str, &str, &str); 6] = [
    ("include/uxr/client/core/session/session.h", "UXR_SESSION_OPAQUE_WORDS", "SESSION_WORDS"),
    ("include/uxr/client/profile/transport/ip/udp/udp_transport.h", "UXR_UDP_TRANSPORT_OPAQUE_WORDS", "UDP_WORDS"),
    ("include/uxr/client/profile/transport/ip/tcp/tcp_transport.h", "UXR_TCP_TRANSPORT_OPAQUE_WORDS", "TCP_WORDS"),
    (
        "include/uxr/client/profile/transport/serial/serial_transport.h",
        "UXR_SERIAL_TRANSPORT_OPAQUE_WORDS",
        "SERIAL_WORDS",
    ),
    (
        "include/uxr/client/profile/transport/custom/custom_transport.h",
        "UXR_CUSTOM_TRANSPORT_OPAQUE_WORDS",
        "CUSTOM_WORDS",
    ),
    ("include/uxr/client/profile/transport/can/can_transport.h", "UXR_CAN_TRANSPORT_OPAQUE_WORDS", "CAN_WORDS"),
];

/// A structure to check: its C name, the profile macro it needs (None: always there), its Rust path, and
/// (C member designator, Rust field path) pairs.
struct Probe {
    c: &'static str,
    needs: Option<&'static str>,
    rust: &'static str,
    fields: &'static [(&'static str, &'static str)],
}

const fn probe(c: &'static str, rust: &'static str, fields: &'static [(&'static str, &'static str)]) -> Probe {
    Probe { c, needs: None, rust, fields }
}

const PROBES: &[Probe] = &[
    probe(
        "ucdrBuffer",
        "crate::ucdr::buffer::ucdrBuffer",
        &[
            ("init", "init"),
            ("final", "final_"),
            ("iterator", "iterator"),
            ("origin", "origin"),
            ("offset", "offset"),
            ("endianness", "endianness"),
            ("last_data_size", "last_data_size"),
            ("error", "error"),
            ("on_full_buffer", "on_full_buffer"),
            ("args", "args"),
        ],
    ),
    probe(
        "uxrStreamId",
        "crate::abi::uxrStreamId",
        &[("raw", "raw"), ("index", "index"), ("type", "type_"), ("direction", "direction")],
    ),
    probe("uxrObjectId", "crate::abi::uxrObjectId", &[("id", "id"), ("type", "type_")]),
    probe(
        "uxrDeliveryControl",
        "crate::abi::uxrDeliveryControl",
        &[
            ("max_samples", "max_samples"),
            ("max_elapsed_time", "max_elapsed_time"),
            ("max_bytes_per_second", "max_bytes_per_second"),
            ("min_pace_period", "min_pace_period"),
        ],
    ),
    probe(
        "uxrQoS_t",
        "crate::abi::uxrQoS_t",
        &[("durability", "durability"), ("reliability", "reliability"), ("history", "history"), ("depth", "depth")],
    ),
    probe("Time_t", "crate::types::Time_t", &[("seconds", "seconds"), ("nanoseconds", "nanoseconds")]),
    probe("BinarySequence_t", "crate::types::BinarySequence_t", &[("size", "size"), ("data", "data")]),
    probe("StringSequence_t", "crate::types::StringSequence_t", &[("size", "size"), ("data", "data")]),
    probe("ClientKey", "crate::types::ClientKey", &[("data", "data")]),
    probe("ObjectId", "crate::types::ObjectId", &[("data", "data")]),
    probe(
        "TransportLocator",
        "crate::types::TransportLocator",
        &[
            ("format", "format"),
            ("_.small_locator.locator_port", "_u.small_locator.locator_port"),
            ("_.medium_locator.address", "_u.medium_locator.address"),
            ("_.medium_locator.locator_port", "_u.medium_locator.locator_port"),
            ("_.large_locator.locator_port", "_u.large_locator.locator_port"),
            ("_.string_locator.value", "_u.string_locator.value"),
        ],
    ),
    probe("TransportLocatorSeq", "crate::types::TransportLocatorSeq", &[("size", "size"), ("data", "data")]),
    probe(
        "SampleIdentity",
        "crate::types::SampleIdentity",
        &[
            ("writer_guid.guidPrefix", "writer_guid.guidPrefix"),
            ("writer_guid.entityId.entityKey", "writer_guid.entityId.entityKey"),
            ("writer_guid.entityId.entityKind", "writer_guid.entityId.entityKind"),
            ("sequence_number.high", "sequence_number.high"),
            ("sequence_number.low", "sequence_number.low"),
        ],
    ),
    probe(
        "uxrCommunication",
        "crate::comm::uxrCommunication",
        &[
            ("instance", "instance"),
            ("send_msg", "send_msg"),
            ("recv_msg", "recv_msg"),
            ("comm_error", "comm_error"),
            ("mtu", "mtu"),
        ],
    ),
    probe(
        "uxrSessionInfo",
        "crate::session::public::uxrSessionInfo",
        &[
            ("id", "id"),
            ("key", "key"),
            ("last_requested_status", "last_requested_status"),
            ("last_request_id", "last_request_id"),
        ],
    ),
    probe(
        "uxrOutputBestEffortStream",
        "crate::session::public::uxrOutputBestEffortStream",
        &[
            ("buffer", "buffer"),
            ("writer", "writer"),
            ("size", "size"),
            ("offset", "offset"),
            ("last_send", "last_send"),
        ],
    ),
    probe(
        "uxrOutputReliableStream",
        "crate::session::public::uxrOutputReliableStream",
        &[
            ("base.buffer", "base.buffer"),
            ("base.size", "base.size"),
            ("base.history", "base.history"),
            ("offset", "offset"),
            ("last_written", "last_written"),
            ("last_acknown", "last_acknown"),
            ("next_heartbeat_timestamp", "next_heartbeat_timestamp"),
            ("send_lost", "send_lost"),
        ],
    ),
    probe(
        "uxrInputBestEffortStream",
        "crate::session::public::uxrInputBestEffortStream",
        &[("last_handled", "last_handled")],
    ),
    probe(
        "uxrInputReliableStream",
        "crate::session::public::uxrInputReliableStream",
        &[
            ("base", "base"),
            ("last_handled", "last_handled"),
            ("last_announced", "last_announced"),
            ("on_get_fragmentation_info", "on_get_fragmentation_info"),
            ("cleanup_flag", "cleanup_flag"),
        ],
    ),
    probe(
        "uxrStreamStorage",
        "crate::session::public::uxrStreamStorage",
        &[
            ("output_best_effort", "output_best_effort"),
            ("output_best_effort_size", "output_best_effort_size"),
            ("output_reliable", "output_reliable"),
            ("output_reliable_size", "output_reliable_size"),
            ("input_best_effort", "input_best_effort"),
            ("input_best_effort_size", "input_best_effort_size"),
            ("input_reliable", "input_reliable"),
            ("input_reliable_size", "input_reliable_size"),
        ],
    ),
    probe(
        "uxrContinuousArgs",
        "crate::session::public::uxrContinuousArgs",
        &[
            ("flush_callback", "flush_callback"),
            ("flush_callback_args", "flush_callback_args"),
            ("stream_id", "stream_id"),
            ("data_size", "data_size"),
        ],
    ),
    probe(
        "uxrSession",
        "crate::session::uxrSession",
        &[
            ("info", "info"),
            ("streams", "streams"),
            ("comm", "comm"),
            ("request_list", "request_list"),
            ("status_list", "status_list"),
            ("request_status_list_size", "request_status_list_size"),
            ("on_status", "on_status"),
            ("on_status_args", "on_status_args"),
            ("on_topic", "on_topic"),
            ("on_topic_args", "on_topic_args"),
            ("on_time", "on_time"),
            ("on_time_args", "on_time_args"),
            ("time_offset", "time_offset"),
            ("synchronized", "synchronized"),
            ("on_request", "on_request"),
            ("on_request_args", "on_request_args"),
            ("on_reply", "on_reply"),
            ("on_reply_args", "on_reply_args"),
            ("on_data_flag", "on_data_flag"),
            ("on_pong_flag", "on_pong_flag"),
            ("continuous_args", "continuous_args"),
            ("_opaque", "_opaque"),
        ],
    ),
    probe(
        "uxrCustomTransport",
        "crate::transport::uxrCustomTransport",
        &[
            ("buffer", "buffer"),
            ("framing", "framing"),
            ("open", "open"),
            ("close", "close"),
            ("write", "write"),
            ("read", "read"),
            ("comm", "comm"),
            ("args", "args"),
            ("_opaque", "opaque"),
        ],
    ),
    Probe {
        c: "uxrUDPTransport",
        needs: Some("UCLIENT_PROFILE_UDP"),
        rust: "crate::transport::uxrUDPTransport",
        fields: &[
            ("buffer", "buffer"),
            ("comm", "comm"),
            ("platform.poll_fd.fd", "platform.poll_fd.fd"),
            ("platform.poll_fd.events", "platform.poll_fd.events"),
            ("_opaque", "opaque"),
        ],
    },
    Probe {
        c: "uxrTCPTransport",
        needs: Some("UCLIENT_PROFILE_TCP"),
        rust: "crate::transport::uxrTCPTransport",
        fields: &[
            ("input_buffer.buffer", "input_buffer.buffer"),
            ("input_buffer.position", "input_buffer.position"),
            ("input_buffer.state", "input_buffer.state"),
            ("input_buffer.msg_size", "input_buffer.msg_size"),
            ("comm", "comm"),
            ("platform.poll_fd.fd", "platform.poll_fd.fd"),
            ("_opaque", "opaque"),
        ],
    },
    Probe {
        c: "uxrSerialTransport",
        needs: Some("UCLIENT_PROFILE_SERIAL"),
        rust: "crate::transport::uxrSerialTransport",
        fields: &[
            ("buffer", "buffer"),
            ("remote_addr", "remote_addr"),
            ("comm", "comm"),
            ("platform.poll_fd.fd", "platform.poll_fd.fd"),
            ("_opaque", "opaque"),
        ],
    },
    Probe {
        c: "uxrCANTransport",
        needs: Some("UCLIENT_PROFILE_CAN"),
        rust: "crate::transport::uxrCANTransport",
        fields: &[
            ("buffer", "buffer"),
            ("comm", "comm"),
            ("platform.poll_fd.fd", "platform.poll_fd.fd"),
            ("platform.can_id", "platform.can_id"),
            ("_opaque", "opaque"),
        ],
    },
];

/// The fields the multithread profile adds (`XRCE_C_MULTITHREAD=1`).
const MULTITHREAD_PROBES: &[Probe] = &[
    probe("uxrSession", "crate::session::uxrSession", &[("mutex", "mutex"), ("_opaque", "_opaque")]),
    probe("uxrCommunication", "crate::comm::uxrCommunication", &[("mutex", "mutex")]),
    probe("uxrOutputBestEffortStream", "crate::session::public::uxrOutputBestEffortStream", &[("mutex", "mutex")]),
    probe("uxrOutputReliableStream", "crate::session::public::uxrOutputReliableStream", &[("mutex", "mutex")]),
    probe("uxrInputBestEffortStream", "crate::session::public::uxrInputBestEffortStream", &[("mutex", "mutex")]),
    probe("uxrInputReliableStream", "crate::session::public::uxrInputReliableStream", &[("mutex", "mutex")]),
];

fn main() {
    println!("cargo:rerun-if-changed=include");
    println!("cargo:rerun-if-env-changed=XRCE_C_MULTITHREAD");
    println!("cargo::rustc-check-cfg=cfg(uxr_multithread)");
    let out = PathBuf::from(env::var("OUT_DIR").unwrap_or_else(|e| panic!("OUT_DIR: {e}")));
    // The multithread profile (eProsima's UCLIENT_PROFILE_MULTITHREAD): POSIX targets with `std` only.
    let unix = env::var("CARGO_CFG_UNIX").is_ok();
    let std = env::var("CARGO_FEATURE_STD").is_ok();
    let multithread = env::var("XRCE_C_MULTITHREAD").is_ok_and(|v| v == "1");
    if multithread && !(unix && std) {
        panic!("XRCE_C_MULTITHREAD=1 needs a POSIX target and the `std` feature (POSIX threads)");
    }
    if multithread {
        println!("cargo:rustc-cfg=uxr_multithread");
    }
    // The C tests compile their programs with the profile the library was built with.
    println!("cargo:rustc-env=XRCE_C_MULTITHREAD={}", u8::from(multithread));

    let mut rust = String::new();
    for (header, c_name, rust_name) in OPAQUE {
        let text = fs::read_to_string(header).unwrap_or_else(|e| panic!("{header}: {e}"));
        let value = define(&text, c_name).unwrap_or_else(|| panic!("{header} lacks #define {c_name}"));
        rust.push_str(&format!("/// `{c_name}`.\npub const {rust_name}: usize = {value};\n"));
    }
    rust.push_str(&layout_assertions(&out, multithread));
    fs::write(out.join("layout.rs"), rust).unwrap_or_else(|e| panic!("layout.rs: {e}"));

    empty_microcdr(&out);

    // The C tests (tests/c_programs.rs) compile for the same target with the `cc` crate, which asks for these.
    for var in ["TARGET", "HOST"] {
        if let Ok(value) = env::var(var) {
            println!("cargo:rustc-env=XRCE_C_{var}={value}");
        }
    }
}

/// Compiles the probe for the target and turns the sizes it records into Rust assertions.
fn layout_assertions(out: &Path, multithread: bool) -> String {
    let mut probe = String::from("#include <stddef.h>\n#include <uxr/client/client.h>\n");
    let extra: &[Probe] = if multithread { MULTITHREAD_PROBES } else { &[] };
    for (n, p) in PROBES.iter().chain(extra).enumerate() {
        let c = format!("{}{}", p.c, if n >= PROBES.len() { "__mt" } else { "" });
        let mut body = format!(
            "char uxr_layout__{c}__size[sizeof({t}) + 1];\nchar uxr_layout__{c}__align[_Alignof({t}) + 1];\n",
            t = p.c
        );
        for (i, (member, _)) in p.fields.iter().enumerate() {
            body.push_str(&format!("char uxr_layout__{c}__field{i}[offsetof({t}, {member}) + 1];\n", t = p.c));
        }
        match p.needs {
            Some(profile) => probe.push_str(&format!("#ifdef {profile}\n{body}#endif\n")),
            None => probe.push_str(&body),
        }
    }
    let file = out.join("layout_probe.c");
    fs::write(&file, probe).unwrap_or_else(|e| panic!("layout_probe.c: {e}"));
    let mut build = cc::Build::new();
    if multithread {
        build.define("UCLIENT_PROFILE_MULTITHREAD", None);
    }
    let objects = build
        .file(&file)
        .include("include")
        .std("c11")
        .flag_if_supported("-fno-common")
        .cargo_metadata(false)
        .warnings(true)
        .compile_intermediates();
    let mut sizes = BTreeMap::new();
    for path in objects {
        let data = fs::read(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        let obj = object::File::parse(&*data).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        for sym in obj.symbols() {
            if let Ok(name) = sym.name() {
                let name = name.trim_start_matches('_');
                if let Some(rest) = name.strip_prefix("uxr_layout__") {
                    sizes.insert(rest.to_string(), sym.size().saturating_sub(1));
                }
            }
        }
    }
    if sizes.is_empty() {
        panic!("no layout symbols in the probe object: this object format does not record symbol sizes");
    }
    let mut rust = String::new();
    for (n, p) in PROBES.iter().chain(extra).enumerate() {
        let c = format!("{}{}", p.c, if n >= PROBES.len() { "__mt" } else { "" });
        let Some(size) = sizes.get(&format!("{c}__size")) else { continue };
        let align = sizes.get(&format!("{c}__align")).copied().unwrap_or(0);
        rust.push_str(&format!(
            "const _: () = assert!(core::mem::size_of::<{r}>() == {size} && core::mem::align_of::<{r}>() == {align}, \
             \"size or alignment of {c} differs from the C header\");\n",
            r = p.rust,
            c = p.c
        ));
        for (i, (member, field)) in p.fields.iter().enumerate() {
            let Some(offset) = sizes.get(&format!("{c}__field{i}")) else { continue };
            rust.push_str(&format!(
                "const _: () = assert!(core::mem::offset_of!({r}, {field}) == {offset}, \
                 \"offset of {t}.{member} differs from the C header\");\n",
                r = p.rust,
                t = p.c
            ));
        }
    }
    rust
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
