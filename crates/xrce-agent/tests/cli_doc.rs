//! docs/cli.md and `--help` list the same subcommands and options (issue 14 item 7).

use std::collections::BTreeSet;
use std::path::PathBuf;

/// Option spellings (`-p/--port`, `--ros-graph`, `-V/--version`) in `text`.
fn options(text: &str) -> BTreeSet<String> {
    let mut out = BTreeSet::new();
    for word in text.split(|c: char| c.is_whitespace() || c == '`' || c == '|' || c == ',') {
        let word = word.trim_end_matches(|c: char| !c.is_ascii_alphanumeric());
        let is_option = word.starts_with("--") && word.len() > 2
            || (word.starts_with('-') && word.get(2..3) == Some("/") && word.get(3..5) == Some("--"));
        if is_option && word.chars().all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '/') {
            out.insert(word.to_owned());
        }
    }
    out
}

fn help() -> String {
    xrce_agent::cli::parse_from(["xrce-agent", "--help"]).err().map(|e| e.to_string()).unwrap_or_default()
}

fn doc() -> String {
    std::fs::read_to_string(PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../docs/cli.md")).expect("docs/cli.md")
}

/// A section of the doc, from its heading to the next one.
fn section(heading: &str) -> String {
    let doc = doc();
    let start = doc.find(heading).unwrap_or_else(|| panic!("docs/cli.md has no {heading}"));
    let rest = &doc[start + heading.len()..];
    rest[..rest.find("\n## ").unwrap_or(rest.len())].to_owned()
}

#[test]
fn cli_doc_lists_every_option_of_the_help() {
    let help = help();
    // clap prints the top-level flags as "-h, --help" and "-V, --version"; the summary uses "-x/--long".
    let help = help.replace("-h, --help", "-h/--help").replace("-V, --version", "-V/--version");
    let in_help = options(&help);
    let in_doc = options(&section("## Options"));
    assert!(in_help.contains("-p/--port") && in_help.contains("--ros-graph"), "options parsed: {in_help:?}");
    assert_eq!(in_doc, in_help, "docs/cli.md (left) and --help (right) list different options");
    assert!(!help.contains("--p2p"), "-P is refused, so --help must not offer it");
}

#[test]
fn cli_doc_lists_every_subcommand_of_the_help() {
    let help = help();
    let doc = section("## Subcommands");
    for sub in ["udp4", "udp6", "tcp4", "tcp6", "serial", "multiserial", "pseudoterminal", "canfd"] {
        assert!(help.contains(&format!("  {sub} ")), "--help lacks {sub}");
        assert!(doc.contains(&format!("| `{sub}` |")), "docs/cli.md lacks {sub}");
    }
}
