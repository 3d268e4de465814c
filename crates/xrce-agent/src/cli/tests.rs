//! Tests of the command line: eProsima's MicroXRCEAgent arguments, and our own options.

use super::*;

const REFS: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../tests/data/vectors/agent.refs");

fn parse(line: &str) -> Result<Config, clap::Error> {
    parse_from(std::iter::once("xrce-agent").chain(line.split_whitespace()))
}

fn ok(line: &str) -> Config {
    match parse(line) {
        Ok(c) => c,
        Err(e) => panic!("`{line}` rejected: {e}"),
    }
}

fn rejected(line: &str) -> ErrorKind {
    match parse(line) {
        Ok(c) => panic!("`{line}` accepted: {c:?}"),
        Err(e) => e.kind(),
    }
}

fn temp_file(name: &str, content: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("xrce-agent-cli-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join(name);
    std::fs::write(&path, content).unwrap();
    path
}

#[test]
fn udp4_with_eprosima_defaults() {
    let c = ok("udp4 -p 8888");
    assert_eq!(
        c,
        Config {
            transport: Transport::Udp4 { port: 8888 },
            middleware: MiddlewareKind::Dds,
            refs: None,
            verbosity: 4,
            discovery: None,
            p2p: None,
            flow_control: false,
            max_connections: 100,
            ros_graph: RosGraph::On,
            dds_engine: None,
            eager_participant: true,
            participant_names: true,
            dds_shm: None,
            client_timeout: Some(std::time::Duration::from_secs(60)),
            auth: Default::default(),
            metrics: None,
            ros_diagnostics: true,
            zenoh_config: None,
        }
    );
    assert_eq!(c.log_level_filter(), LevelFilter::INFO);
    assert_eq!(c.transport.name(), "udp4");
    assert_eq!(c.transport.port(), Some(8888));
}

#[test]
fn every_ip_transport() {
    assert_eq!(ok("udp6 -p 1").transport, Transport::Udp6 { port: 1 });
    assert_eq!(ok("tcp4 --port 2").transport, Transport::Tcp4 { port: 2 });
    assert_eq!(ok("tcp6 -p 65535").transport, Transport::Tcp6 { port: 65535 });
    assert_eq!(ok("tcp6 --port=7").transport, Transport::Tcp6 { port: 7 });
}

#[test]
fn tcp_connections_are_capped() {
    assert_eq!(ok("tcp4 -p 1").max_connections, 100);
    assert_eq!(ok("tcp6 -p 1 --max-connections 5000").max_connections, 5000);
    assert_eq!(rejected("tcp4 -p 1 --max-connections 0"), ErrorKind::ValueValidation);
    assert_eq!(rejected("udp4 -p 1 --max-connections 5"), ErrorKind::UnknownArgument);
}

#[test]
fn attached_short_values() {
    let c = ok("udp4 -p8888 -v6 -mced -d7401 -P2019");
    assert_eq!(c.transport, Transport::Udp4 { port: 8888 });
    assert_eq!(c.verbosity, 6);
    assert_eq!(c.middleware, MiddlewareKind::Ced);
    assert_eq!(c.discovery, Some(7401));
    assert_eq!(c.p2p, Some(2019));
    assert_eq!(
        ok("serial -D/dev/ttyUSB0 -b9600").transport,
        Transport::Serial { device: "/dev/ttyUSB0".into(), baudrate: 9600 }
    );
}

#[test]
fn the_readme_command() {
    let c = ok("udp4 -p 8888 -m ced");
    assert_eq!(c.middleware, MiddlewareKind::Ced);
    assert_eq!(c.transport, Transport::Udp4 { port: 8888 });
}

#[test]
fn middleware_values() {
    assert_eq!(ok("udp4 -p 1 -m dds").middleware, MiddlewareKind::Dds);
    // Ours, long only: the ROS 2 graph of the DDS middleware.
    assert_eq!(ok("udp4 -p 1").ros_graph, RosGraph::On);
    assert_eq!(ok("udp4 -p 1 --ros-graph humble").ros_graph, RosGraph::Humble);
    assert_eq!(ok("serial -D /dev/null --ros-graph off").ros_graph, RosGraph::Off);
    assert!(parse("udp4 -p 1 --ros-graph iron").is_err());
    assert_eq!(ok("udp4 -p 1 --dds-engine fastdds").dds_engine, Some(DdsEngine::Fastdds));
    assert!(parse("udp4 -p 1 --dds-engine cyclone").is_err());
    assert!(ok("udp4 -p 1").eager_participant);
    assert!(!ok("udp4 -p 1 --eager-participant off").eager_participant);
    assert!(parse("udp4 -p 1 --eager-participant maybe").is_err());
    assert!(ok("udp4 -p 1").participant_names);
    let version = parse_from(["xrce-agent", "--version"]).unwrap_err();
    assert_eq!(version.kind(), clap::error::ErrorKind::DisplayVersion);
    assert!(version.to_string().contains(env!("CARGO_PKG_VERSION")), "{version}");
    assert!(!ok("udp4 -p 1 --participant-names off").participant_names);
    assert_eq!(ok("udp4 -p 1 --middleware rtps").middleware, MiddlewareKind::Rtps);
    assert_eq!(ok("udp4 -p 1 --middleware ced").middleware.as_str(), "ced");
    assert_eq!(ok("udp4 -p 1 -m zenoh").middleware, MiddlewareKind::Zenoh);
    assert_eq!(rejected("udp4 -p 1 -m fastdds"), ErrorKind::InvalidValue);
    assert_eq!(rejected("udp4 -p 1 -m CED"), ErrorKind::InvalidValue);
    assert_eq!(rejected("udp4 -p 1 -m"), ErrorKind::InvalidValue);
}

#[test]
fn verbosity_levels_and_bare_flag() {
    for level in 0..=6u8 {
        assert_eq!(ok(&format!("udp4 -p 1 -v {level}")).verbosity, level);
        assert_eq!(ok(&format!("udp4 -p 1 --verbose {level}")).verbosity, level);
        assert_eq!(ok(&format!("udp4 -p 1 -v{level}")).verbosity, level);
    }
    // Bare -v is eProsima's default level 4, whether last or followed by another option.
    assert_eq!(ok("udp4 -p 1 -v").verbosity, 4);
    assert_eq!(ok("udp4 -v -p 1").verbosity, 4);
    assert_eq!(ok("udp4 --verbose -p 1").verbosity, 4);
    assert_eq!(rejected("udp4 -p 1 -v 7"), ErrorKind::ValueValidation);
    assert_eq!(rejected("udp4 -p 1 -v7"), ErrorKind::ValueValidation);
    assert_eq!(rejected("udp4 -p 1 -v x"), ErrorKind::ValueValidation);
    assert_eq!(rejected("udp4 -p 1 -v -1"), ErrorKind::UnknownArgument);
}

#[test]
fn verbosity_maps_to_tracing_levels() {
    let expected = [
        LevelFilter::OFF,
        LevelFilter::ERROR,
        LevelFilter::ERROR,
        LevelFilter::WARN,
        LevelFilter::INFO,
        LevelFilter::DEBUG,
        LevelFilter::TRACE,
    ];
    for (level, filter) in expected.iter().enumerate() {
        assert_eq!(verbosity_to_filter(level as u8), *filter);
    }
    assert_eq!(verbosity_to_filter(200), LevelFilter::TRACE);
}

#[test]
fn discovery_optional_port() {
    assert_eq!(ok("udp4 -p 1").discovery, None);
    assert_eq!(ok("udp4 -p 1 -d").discovery, Some(7400));
    assert_eq!(ok("udp4 -d -p 1").discovery, Some(7400));
    assert_eq!(ok("udp4 -p 1 --discovery").discovery, Some(DEFAULT_DISCOVERY_PORT));
    assert_eq!(ok("udp4 -p 1 -d 7500").discovery, Some(7500));
    assert_eq!(ok("udp4 -p 1 --discovery 7600").discovery, Some(7600));
    assert_eq!(rejected("udp4 -p 1 -d 70000"), ErrorKind::ValueValidation);
}

#[test]
fn p2p_needs_a_port() {
    assert_eq!(ok("udp4 -p 1 -P 2019").p2p, Some(2019));
    assert_eq!(ok("udp4 -p 1 --p2p 2020").p2p, Some(2020));
    assert_eq!(rejected("udp4 -p 1 -P"), ErrorKind::InvalidValue);
    assert_eq!(rejected("udp4 -p 1 -P abc"), ErrorKind::ValueValidation);
}

#[test]
fn port_is_required_and_bounded() {
    assert_eq!(rejected("udp4"), ErrorKind::MissingRequiredArgument);
    assert_eq!(rejected("tcp4 -m ced"), ErrorKind::MissingRequiredArgument);
    assert_eq!(rejected("udp4 -p 65536"), ErrorKind::ValueValidation);
    assert_eq!(rejected("udp4 -p -5"), ErrorKind::UnknownArgument);
    assert_eq!(rejected("udp4 -p eighty"), ErrorKind::ValueValidation);
}

#[test]
fn refs_must_exist() {
    let c = ok(&format!("udp4 -p 1 -r {REFS}"));
    assert_eq!(c.refs.as_deref(), Some(Path::new(REFS)));
    let c = ok(&format!("tcp4 -p 1 --refs {REFS}"));
    assert_eq!(c.refs.as_deref(), Some(Path::new(REFS)));
    assert_eq!(rejected("udp4 -p 1 -r /nonexistent/agent.refs"), ErrorKind::ValueValidation);
}

#[test]
fn serial_device_or_file() {
    assert_eq!(
        ok("serial --dev /dev/ttyACM0").transport,
        Transport::Serial { device: "/dev/ttyACM0".into(), baudrate: 115_200 }
    );
    assert_eq!(
        ok("serial -D /dev/ttyACM0 -b 921600").transport,
        Transport::Serial { device: "/dev/ttyACM0".into(), baudrate: 921_600 }
    );
    // Non-standard rates are accepted, as eProsima does.
    assert_eq!(
        ok("serial -D /dev/x --baudrate 250000").transport,
        Transport::Serial { device: "/dev/x".into(), baudrate: 250_000 }
    );
    let file = temp_file("serial.dev", "/dev/ttyUSB3\n/dev/ttyUSB4\n");
    assert_eq!(
        ok(&format!("serial -f {}", file.display())).transport,
        Transport::Serial { device: "/dev/ttyUSB3".into(), baudrate: 115_200 }
    );
    assert_eq!(
        ok(&format!("serial --file {} -b 57600", file.display())).transport,
        Transport::Serial { device: "/dev/ttyUSB3".into(), baudrate: 57_600 }
    );
    assert_eq!(rejected("serial"), ErrorKind::MissingRequiredArgument);
    assert_eq!(rejected(&format!("serial -D /dev/x -f {}", file.display())), ErrorKind::ArgumentConflict);
    assert_eq!(rejected("serial -f /nonexistent/devs"), ErrorKind::Io);
    let empty = temp_file("empty.dev", "\n");
    assert_eq!(rejected(&format!("serial -f {}", empty.display())), ErrorKind::InvalidValue);
    assert_eq!(rejected("serial -D /dev/x -b fast"), ErrorKind::ValueValidation);
    assert_eq!(rejected("serial -D /dev/x -p 8888"), ErrorKind::UnknownArgument);
}

#[test]
fn multiserial_devs_in_one_argument_or_file() {
    let c = parse_from(["xrce-agent", "multiserial", "--devs", "/dev/ttyACM0 /dev/ttyACM1", "-b", "9600"]).unwrap();
    assert_eq!(
        c.transport,
        Transport::MultiSerial { devices: vec!["/dev/ttyACM0".into(), "/dev/ttyACM1".into()], baudrate: 9600 }
    );
    let c = parse_from(["xrce-agent", "multiserial", "-D", "/dev/a"]).unwrap();
    assert_eq!(c.transport, Transport::MultiSerial { devices: vec!["/dev/a".into()], baudrate: 115_200 });
    let file = temp_file("multi.dev", "/dev/a\n\n  /dev/b  \n");
    assert_eq!(
        ok(&format!("multiserial -f {}", file.display())).transport,
        Transport::MultiSerial { devices: vec!["/dev/a".into(), "/dev/b".into()], baudrate: 115_200 }
    );
    assert_eq!(rejected("multiserial"), ErrorKind::MissingRequiredArgument);
    let e = parse_from(["xrce-agent", "multiserial", "--devs", "  "]).unwrap_err();
    assert_eq!(e.kind(), ErrorKind::InvalidValue);
    assert_eq!(rejected("multiserial --dev /dev/a"), ErrorKind::UnknownArgument);
}

#[test]
fn pseudoterminal_baudrate_only() {
    assert_eq!(ok("pseudoterminal").transport, Transport::PseudoTerminal { baudrate: 115_200 });
    assert_eq!(ok("pseudoterminal -b 57600 -v5").transport, Transport::PseudoTerminal { baudrate: 57_600 });
    // eProsima's agent ignores arguments it does not know; scripts pass the serial subcommands' -D.
    assert_eq!(ok("pseudoterminal -D /dev/x").transport, Transport::PseudoTerminal { baudrate: 115_200 });
    assert_eq!(rejected("pseudoterminal --devs /dev/x"), ErrorKind::UnknownArgument);
}

#[test]
fn canfd_device_and_hex_id() {
    assert_eq!(ok("canfd -D can0").transport, Transport::CanFd { device: "can0".into(), can_id: 1 });
    assert_eq!(ok("canfd --dev vcan0 -I 0x123").transport, Transport::CanFd { device: "vcan0".into(), can_id: 0x123 });
    assert_eq!(
        ok("canfd --dev vcan0 --id 1ABCDEF").transport,
        Transport::CanFd { device: "vcan0".into(), can_id: 0x1AB_CDEF }
    );
    assert_eq!(
        ok("canfd -Dcan1 -I0X1fffffff").transport,
        Transport::CanFd { device: "can1".into(), can_id: MAX_CAN_ID }
    );
    assert_eq!(rejected("canfd"), ErrorKind::MissingRequiredArgument);
    assert_eq!(rejected("canfd -D can0 -I 0x20000000"), ErrorKind::ValueValidation);
    assert_eq!(rejected("canfd -D can0 -I xyz"), ErrorKind::ValueValidation);
    assert_eq!(rejected("canfd -D can0 -I +5"), ErrorKind::ValueValidation);
}

#[test]
fn common_options_on_every_transport() {
    let file = temp_file("common.dev", "/dev/z\n");
    for base in [
        "udp4 -p 1".to_owned(),
        "udp6 -p 1".to_owned(),
        "tcp4 -p 1".to_owned(),
        "tcp6 -p 1".to_owned(),
        "serial -D /dev/x".to_owned(),
        format!("serial -f {}", file.display()),
        "multiserial --devs /dev/x".to_owned(),
        "pseudoterminal".to_owned(),
        "canfd -D can0".to_owned(),
    ] {
        let c = ok(&format!("{base} -m ced -r {REFS} -v 2 -d 7401 -P 2018"));
        assert_eq!(c.middleware, MiddlewareKind::Ced, "{base}");
        assert_eq!(c.refs.as_deref(), Some(Path::new(REFS)), "{base}");
        assert_eq!(c.verbosity, 2, "{base}");
        assert_eq!(c.discovery, Some(7401), "{base}");
        assert_eq!(c.p2p, Some(2018), "{base}");
    }
}

#[test]
fn client_timeout_and_authentication_options() {
    use std::time::Duration;
    assert_eq!(ok("udp4 -p 1 --client-timeout 2.5").client_timeout, Some(Duration::from_millis(2500)));
    assert_eq!(ok("udp4 -p 1 --client-timeout 0").client_timeout, None);
    assert_eq!(ok("udp4 -p 1 --metrics 127.0.0.1:9464").metrics, Some("127.0.0.1:9464".parse().unwrap()));
    assert_eq!(rejected("udp4 -p 1 --metrics 9464"), ErrorKind::ValueValidation);
    assert!(!ok("udp4 -p 1 --ros-diagnostics off").ros_diagnostics);
    assert_eq!(rejected("udp4 -p 1 --client-timeout=-1"), ErrorKind::ValueValidation);
    assert_eq!(rejected("udp4 -p 1 --client-timeout soon"), ErrorKind::ValueValidation);
    let c = ok("serial -D /dev/x --allow 0xAABBCCDD --allow *@10.0.0.0/8");
    assert_eq!(c.auth.allow.len(), 2, "--allow accumulates");
    assert!(c.auth.is_enabled() && c.auth.psk.is_none());
    assert_eq!(rejected("udp4 -p 1 --allow 0xAABBCCDD@nowhere"), ErrorKind::ValueValidation);
    let key = temp_file("psk", "0123456789abcdef0123456789abcdef\n");
    let c = ok(&format!("udp4 -p 1 --psk-file {}", key.display()));
    assert_eq!(c.auth.psk.as_deref(), Some(&b"0123456789abcdef0123456789abcdef"[..]));
    let short = temp_file("psk-short", "secret\n");
    assert_eq!(rejected(&format!("udp4 -p 1 --psk-file {}", short.display())), ErrorKind::InvalidValue);
    assert_eq!(rejected("udp4 -p 1 --psk-file /nonexistent/psk"), ErrorKind::InvalidValue);
    assert!(!ok("udp4 -p 1").auth.is_enabled(), "off by default");
}

#[test]
fn repeated_option_keeps_last() {
    assert_eq!(ok("udp4 -p 1 -p 2").transport, Transport::Udp4 { port: 2 });
    assert_eq!(ok("udp4 -p 1 -v 2 -v 5").verbosity, 5);
}

#[test]
fn invalid_command_lines() {
    assert_eq!(rejected(""), ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand);
    assert_eq!(rejected("udp5 -p 1"), ErrorKind::InvalidSubcommand);
    assert_eq!(rejected("tpc6 -p 1"), ErrorKind::InvalidSubcommand);
    // No clap-style `help` subcommand: eProsima has none.
    assert_eq!(rejected("help udp4"), ErrorKind::InvalidSubcommand);
    assert_eq!(rejected("-p 8888 udp4"), ErrorKind::UnknownArgument);
    assert_eq!(rejected("udp4 -p 1 --bogus"), ErrorKind::UnknownArgument);
    assert_eq!(rejected("udp4 -p 1 extra"), ErrorKind::UnknownArgument);
    assert_eq!(rejected("udp4 -p 1 -b 9600"), ErrorKind::UnknownArgument);
}

#[test]
fn help_lists_everything() {
    for line in ["--help", "-h"] {
        let e = parse(line).unwrap_err();
        assert_eq!(e.kind(), ErrorKind::DisplayHelp);
        let help = e.to_string();
        for word in [
            "udp4",
            "udp6",
            "tcp4",
            "tcp6",
            "serial",
            "multiserial",
            "pseudoterminal",
            "canfd",
            "-m/--middleware",
            "ced|dds|rtps|zenoh",
            "--zenoh-config",
            "-r/--refs",
            "-v/--verbose",
            "-d/--discovery",
            "-p/--port",
            "-b/--baudrate",
            "-D/--dev",
            "-D/--devs",
            "-f/--file",
            "-I/--id",
            "7400",
            "115200",
            "0x00000001",
        ] {
            assert!(help.contains(word), "top-level help lacks `{word}`:\n{help}");
        }
    }
    let sub = |line: &str, words: &[&str]| {
        let e = parse(line).unwrap_err();
        assert_eq!(e.kind(), ErrorKind::DisplayHelp, "{line}");
        let help = e.to_string();
        for word in words {
            assert!(help.contains(word), "`{line}` help lacks `{word}`:\n{help}");
        }
    };
    let common = ["--middleware", "--refs", "--verbose", "--discovery", "[default: dds]", "[default: 4]"];
    for t in ["udp4", "udp6", "tcp4", "tcp6"] {
        sub(&format!("{t} --help"), &common);
        sub(&format!("{t} -h"), &["--port"]);
    }
    sub("serial --help", &common);
    sub("serial --help", &["--dev", "--file", "--baudrate", "[default: 115200]"]);
    sub("multiserial --help", &["--devs", "--file", "--baudrate"]);
    sub("pseudoterminal --help", &["--baudrate"]);
    sub("canfd --help", &["--dev", "--id", "[default: 0x00000001]"]);
}

#[test]
fn command_is_consistent() {
    command().debug_assert();
}
