//! `xrce-agent --config FILE` (issue 24): what a valid file gives, and each kind of error, which names the
//! file, the line and the key.

use std::path::Path;
use std::time::Duration;

use xrce_agent::cli::{self, Invocation, MiddlewareKind, Transport};
use xrce_agent::config_file::{parse, ConfigFileError};

const FILE: &str = "agent.toml";

fn error(text: &str) -> ConfigFileError {
    parse(text, Path::new(FILE)).expect_err("the file is refused")
}

/// The error is at `line`, about `key`, and says `words`; its text names the file, the line and the key.
fn assert_error(text: &str, line: usize, key: Option<&str>, words: &str) {
    let e = error(text);
    assert_eq!((e.line, e.key.as_deref()), (line, key), "{e}");
    assert!(e.message.contains(words), "`{words}` not in: {e}");
    let shown = e.to_string();
    assert!(shown.starts_with(&format!("{FILE}:{line}: ")), "{shown}");
    if let Some(key) = key {
        assert!(shown.contains(&format!("`{key}`")), "{shown}");
    }
}

#[test]
fn a_file_with_every_option_kind() {
    let refs = concat!(env!("CARGO_MANIFEST_DIR"), "/../../tests/data/vectors/agent.refs");
    let text = format!(
        r#"# the README's example, and more
middleware = "ced"
verbose = 5
refs = "{refs}"
client-timeout = 2.5
eager-participant = false
allow = ["0xAABBCCDD", "*@127.0.0.1"]

[[transport]]
kind = "udp4"
port = 8888

[[transport]]
kind = "tcp6"
port = 8888

[[transport]]
kind = "pseudoterminal"
baudrate = 921600

[[transport]]
kind = "multiserial"
devs = ["/dev/null", "/dev/zero"]
flow-control = true
"#
    );
    let file = parse(&text, Path::new(FILE)).expect("valid");
    assert_eq!(file.options.middleware, MiddlewareKind::Ced);
    assert_eq!(file.options.verbosity, 5);
    assert_eq!(file.options.refs.as_deref(), Some(Path::new(refs)));
    assert_eq!(file.options.client_timeout, Some(Duration::from_millis(2500)));
    assert!(!file.options.eager_participant);
    assert_eq!(file.options.auth.allow.len(), 2);
    let transports: Vec<_> = file.transports.iter().map(|t| (t.transport.clone(), t.flow_control, t.line)).collect();
    assert_eq!(
        transports,
        vec![
            (Transport::Udp4 { port: 8888 }, false, 9),
            (Transport::Tcp6 { port: 8888 }, false, 13),
            (Transport::PseudoTerminal { baudrate: 921_600 }, false, 17),
            (
                Transport::MultiSerial { devices: vec!["/dev/null".into(), "/dev/zero".into()], baudrate: 115_200 },
                true,
                21
            ),
        ]
    );
}

#[test]
fn defaults_are_the_command_line_s() {
    let file = parse("[[transport]]\nkind = \"udp4\"\nport = 1\n", Path::new(FILE)).expect("valid");
    let command = cli::parse_from(["xrce-agent", "udp4", "-p", "1"]).expect("valid");
    assert_eq!(file.options, command, "same options as `xrce-agent udp4 -p 1`");
}

#[test]
fn an_unknown_key() {
    assert_error("colour = 3\n[[transport]]\nkind = \"udp4\"\nport = 1\n", 1, Some("colour"), "unknown key");
    assert_error(
        "[[transport]]\nkind = \"udp4\"\nport = 1\ndev = \"x\"\n",
        4,
        Some("dev"),
        "unknown key for kind = \"udp4\"",
    );
    // Short names are the command line's only.
    assert_error("m = \"ced\"\n[[transport]]\nkind = \"udp4\"\nport = 1\n", 1, Some("m"), "unknown key");
    assert_error(
        "\n[[transport]]\nkind = \"udp4\"\nport = 1\nmiddleware = \"ced\"\n",
        5,
        Some("middleware"),
        "at the top",
    );
    assert_error("port = 1\n[[transport]]\nkind = \"udp4\"\nport = 1\n", 1, Some("port"), "[[transport]] table");
}

#[test]
fn a_wrong_type() {
    assert_error("[[transport]]\nkind = \"udp4\"\nport = \"eighty\"\n", 3, Some("port"), "invalid value 'eighty'");
    assert_error("[[transport]]\nkind = \"udp4\"\nport = 1.5\n", 3, Some("port"), "invalid value");
    // A boolean where a number goes: the message shows the file's value, not the on/off it stands for.
    assert_error("[[transport]]\nkind = \"udp4\"\nport = true\n", 3, Some("port"), "invalid value 'true'");
    assert_error(
        "verbose = { level = 4 }\n[[transport]]\nkind = \"udp4\"\nport = 1\n",
        1,
        Some("verbose"),
        "wrong type",
    );
    assert_error(
        "[[transport]]\nkind = \"serial\"\ndev = \"/dev/null\"\nflow-control = \"yes\"\n",
        4,
        Some("flow-control"),
        "expected true or false",
    );
    assert_error("\n\nverbose = 9\n[[transport]]\nkind = \"udp4\"\nport = 1\n", 3, Some("verbose"), "0..=6");
    assert_error(
        "middleware = \"fastdds\"\n[[transport]]\nkind = \"udp4\"\nport = 1\n",
        1,
        Some("middleware"),
        "fastdds",
    );
    assert_error("[[transport]]\nkind = 4\n", 2, Some("kind"), "must be one of");
    assert_error("[[transport]]\nkind = \"udp5\"\n", 2, Some("kind"), "must be one of");
}

#[test]
fn a_port_given_twice() {
    let text = "[[transport]]\nkind = \"udp4\"\nport = 8888\n[[transport]]\nkind = \"tcp4\"\nport = 8888\n\
                [[transport]]\nkind = \"udp6\"\nport = 8888\n";
    // The first is where its `port` key is, not its table.
    assert_error(text, 9, Some("port"), "UDP port 8888 given twice (first at line 3)");
    // The same device twice, once in a list.
    let text = "[[transport]]\nkind = \"serial\"\ndev = \"/dev/null\"\n[[transport]]\nkind = \"multiserial\"\n\
                devs = \"/dev/zero /dev/null\"\n";
    assert_error(text, 6, Some("devs"), "device /dev/null given twice");
}

#[test]
fn a_device_that_does_not_exist() {
    assert_error("[[transport]]\nkind = \"serial\"\ndev = \"/dev/xrce-none\"\n", 3, Some("dev"), "does not exist");
    let text = "[[transport]]\nkind = \"multiserial\"\ndevs = [\"/dev/null\", \"/dev/xrce-none\"]\n";
    assert_error(text, 3, Some("devs"), "serial device /dev/xrce-none does not exist");
    assert_error(
        "[[transport]]\nkind = \"canfd\"\ndev = \"xrce-nocan0\"\n",
        3,
        Some("dev"),
        "CAN interface xrce-nocan0",
    );
    assert_error(
        "refs = \"/nonexistent/agent.refs\"\n[[transport]]\nkind = \"udp4\"\nport = 1\n",
        1,
        Some("refs"),
        "does not exist",
    );
}

#[test]
fn a_table_incomplete_or_missing() {
    assert_error("middleware = \"ced\"\n", 2, None, "no [[transport]] table");
    assert_error("[[transport]]\nport = 1\n", 1, None, "no `kind`");
    assert_error("\n[[transport]]\nkind = \"tcp4\"\n", 2, None, "--port");
    assert_error("[[transport]]\nkind = \"udp4\"\nport = 1\nport = 2\n", 4, None, "duplicate key");
    assert_error("[[transport]\n", 1, None, "");
}

#[test]
fn config_takes_no_other_argument() {
    let file = cli::parse_invocation(["xrce-agent", "--config", "agent.toml"]).expect("valid");
    assert_eq!(file, Invocation::File("agent.toml".into()));
    for line in [
        &["xrce-agent", "--config", "a.toml", "udp4", "-p", "1"][..],
        &["xrce-agent", "udp4", "-p", "1", "--config", "a"],
    ] {
        assert!(cli::parse_invocation(line.iter().copied()).is_err(), "{line:?}");
    }
}

#[test]
fn the_zenoh_middleware_and_its_session_file() {
    let zenoh_file = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/zenoh/peer.py");
    let text =
        format!("middleware = \"zenoh\"\nzenoh-config = \"{zenoh_file}\"\n[[transport]]\nkind = \"udp4\"\nport = 1\n");
    let file = parse(&text, Path::new(FILE)).expect("valid");
    assert_eq!(file.options.middleware, MiddlewareKind::Zenoh);
    assert_eq!(file.options.zenoh_config.as_deref(), Some(Path::new(zenoh_file)));
    assert_error(
        "zenoh-config = \"/nonexistent.json5\"\n[[transport]]\nkind = \"udp4\"\nport = 1\n",
        1,
        Some("zenoh-config"),
        "",
    );
}
