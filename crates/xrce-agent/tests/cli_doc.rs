//! docs/cli.md and `--help` list the subcommands and options clap really defines (issue 14 item 7),
//! docs/agent-api.md's code uses every API name its tables give, and every example has a command in the
//! README or docs/.

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

/// `-p/--port`, `--ros-graph` or `-x`, as the docs spell an argument.
fn spelling(arg: &clap::Arg) -> Option<String> {
    match (arg.get_short(), arg.get_long()) {
        (Some(s), Some(l)) => Some(format!("-{s}/--{l}")),
        (None, Some(l)) => Some(format!("--{l}")),
        (Some(s), None) => Some(format!("-{s}")),
        (None, None) => None, // positional
    }
}

/// What clap defines, hidden ones left out: the subcommands, and each visible option with the subcommands
/// that take it (`""` for the top level).
fn clap_definitions() -> (Vec<String>, Vec<(String, String)>) {
    let mut cmd = xrce_agent::cli::command();
    cmd.build(); // adds clap's own -h/--help and -V/--version
    let mut options: Vec<(String, String)> =
        cmd.get_arguments().filter(|a| !a.is_hide_set()).filter_map(spelling).map(|o| (o, String::new())).collect();
    let mut subcommands = Vec::new();
    for sub in cmd.get_subcommands().filter(|s| !s.is_hide_set()) {
        subcommands.push(sub.get_name().to_owned());
        for arg in sub.get_arguments().filter(|a| !a.is_hide_set()) {
            if let Some(o) = spelling(arg) {
                options.push((o, sub.get_name().to_owned()));
            }
        }
    }
    (subcommands, options)
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

/// Every option clap defines is a row of docs/cli.md's table that applies to the subcommands taking it, the
/// table has no other, and `--help` (whose per-transport list is written by hand) lists the same.
#[test]
fn cli_doc_lists_every_option_clap_defines() {
    let (_, defined) = clap_definitions();
    let spellings: BTreeSet<String> = defined.iter().map(|(o, _)| o.clone()).collect();
    assert!(spellings.contains("-p/--port") && spellings.contains("--ros-graph"), "read from clap: {spellings:?}");
    assert!(!spellings.iter().any(|o| o.contains("p2p")), "-P is refused, so it is hidden");
    let table = section("## Options");
    // Rows: | `-p/--port <PORT>` | same | udp4 udp6 tcp4 tcp6 | ...
    let rows: Vec<(String, String)> = table
        .lines()
        .filter_map(|l| {
            let mut cells = l.split(" | ");
            let option = cells.next()?.strip_prefix("| `")?;
            let applies = cells.nth(1)?;
            Some((option.split([' ', '`']).next()?.to_owned(), applies.to_owned()))
        })
        .collect();
    for (option, sub) in &defined {
        let covered = rows.iter().any(|(o, applies)| {
            o == option && (applies.starts_with("all") || applies == "top level" || applies.contains(sub.as_str()))
        });
        assert!(
            covered,
            "docs/cli.md has no row for {option} applying to {}",
            if sub.is_empty() { "the top level" } else { sub }
        );
    }
    let in_doc: BTreeSet<String> = rows.iter().map(|(o, _)| o.clone()).collect();
    assert_eq!(in_doc, spellings, "docs/cli.md (left) and clap (right) have different options");
    assert_eq!(options(&table), spellings, "the Options section names no other option");

    // clap prints the top-level flags as "-h, --help" and "-V, --version"; the summary uses "-x/--long".
    let help = help().replace("-h, --help", "-h/--help").replace("-V, --version", "-V/--version");
    assert_eq!(options(&help), spellings, "--help (left) and clap (right) list different options");
}

/// Every subcommand clap defines is in docs/cli.md's table and `--help`, and the table has no other.
#[test]
fn cli_doc_lists_every_subcommand_clap_defines() {
    let (defined, _) = clap_definitions();
    assert!(defined.len() >= 8 && defined.iter().any(|s| s == "canfd"), "read from clap: {defined:?}");
    let help = help();
    let table = section("## Subcommands");
    for sub in &defined {
        assert!(help.contains(&format!("  {sub} ")), "--help lacks {sub}");
    }
    let in_doc: Vec<String> =
        table.lines().filter_map(|l| l.strip_prefix("| `")?.split('`').next().map(str::to_owned)).collect();
    assert_eq!(in_doc, defined, "docs/cli.md (left) and clap (right) list different subcommands");
}

/// docs/agent-api.md's text, with escaped table pipes (`\|`) made plain characters.
fn agent_api_doc() -> String {
    std::fs::read_to_string(PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../docs/agent-api.md"))
        .expect("docs/agent-api.md")
        .replace("\\|", "¦")
}

/// Identifiers of `text`, with what precedes and follows each.
fn identifiers(text: &str) -> Vec<(&str, &str, &str)> {
    let mut out = Vec::new();
    let mut rest = text;
    let mut before = "";
    while let Some(start) = rest.find(|c: char| c.is_ascii_alphabetic() || c == '_') {
        let (head, tail) = rest.split_at(start);
        let end = tail.find(|c: char| !(c.is_ascii_alphanumeric() || c == '_')).unwrap_or(tail.len());
        let (word, after) = tail.split_at(end);
        // A word inside a number or a path (`0x04`, `a.b`) keeps its neighbours all the same.
        let before_word = if head.is_empty() { before } else { head };
        out.push((before_word, word, after));
        before = word;
        rest = after;
    }
    out
}

/// The API names in the "here" column of the doc's mapping tables: calls (`name(`), paths (`A::b`), methods
/// (`.name`), and identifiers standing alone in backticks (`create_publisher_by_xml`).
fn mapped_names(doc: &str) -> BTreeSet<String> {
    // Rust's own words, and eProsima's name for what a row describes.
    const NOT_API: [&str; 7] = ["Ok", "Err", "Some", "io", "Result", "fn", "handle_error"];
    let mut names = BTreeSet::new();
    for row in doc.lines().filter(|l| l.starts_with('|') && !l.starts_with("|---") && !l.contains("| here |")) {
        let Some(here) = row.split('|').nth(2) else { continue };
        for span in here.split('`').skip(1).step_by(2) {
            let words = identifiers(span);
            // Prose words in backticks (`bool`, `args[0]`) are not API names: those have a `_` or a capital.
            let alone =
                words.len() == 1 && words.iter().any(|(_, w, _)| w.contains('_') || w.starts_with(char::is_uppercase));
            for (before, word, after) in words {
                let api = alone
                    || after.starts_with('(')
                    || after.starts_with("::")
                    || before.ends_with('.')
                    || before.ends_with("::");
                if api && !NOT_API.contains(&word) && !word.chars().all(|c| c.is_ascii_digit()) {
                    names.insert(word.to_owned());
                }
            }
        }
    }
    names
}

/// The words of the doc's Rust code blocks (compiled, and run unless `no_run`, as doctests of the crate: see
/// `AgentApiDoc` in lib.rs), comments left out.
fn code_words(doc: &str) -> BTreeSet<String> {
    let mut words = BTreeSet::new();
    let mut in_rust = false;
    for line in doc.lines() {
        if let Some(fence) = line.trim_start().strip_prefix("```") {
            in_rust = !in_rust && fence.starts_with("rust");
            continue;
        }
        if in_rust {
            let code = line.split("//").next().unwrap_or("");
            words.extend(identifiers(code).into_iter().map(|(_, w, _)| w.to_owned()));
        }
    }
    words
}

/// Every name the mapping tables of docs/agent-api.md give is used in its code blocks, which compile as
/// doctests: a renamed or removed API fails the doctests, a name added to a table without code fails here.
#[test]
fn agent_api_doc_code_uses_every_mapped_name() {
    let doc = agent_api_doc();
    let names = mapped_names(&doc);
    for name in ["AgentInstance", "create_client", "create_replier_by_xml", "EndpointDesc", "member_u64"] {
        assert!(names.contains(name), "the tables were read: {name} missing from {names:?}");
    }
    let code = code_words(&doc);
    let missing: Vec<&String> = names.iter().filter(|n| !code.contains(*n)).collect();
    assert!(missing.is_empty(), "docs/agent-api.md maps these but its code blocks never use them: {missing:?}");
}

/// Every example of the workspace has a command (`--example NAME`) in the README or docs/.
#[test]
fn every_example_has_a_command_in_the_docs() {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..");
    let mut docs = std::fs::read_to_string(root.join("README.md")).expect("README.md");
    for entry in std::fs::read_dir(root.join("docs")).expect("docs/") {
        docs += &std::fs::read_to_string(entry.expect("entry").path()).expect("a doc");
    }
    let mut examples = Vec::new();
    for krate in std::fs::read_dir(root.join("crates")).expect("crates/") {
        let Ok(dir) = std::fs::read_dir(krate.expect("entry").path().join("examples")) else { continue };
        for file in dir {
            let path = file.expect("entry").path();
            if path.extension().is_some_and(|e| e == "rs") {
                examples.push(path.file_stem().expect("a name").to_string_lossy().into_owned());
            }
        }
    }
    assert!(examples.len() >= 20 && examples.iter().any(|e| e == "throughput"), "examples found: {examples:?}");
    let has_command = |name: &str| {
        let needle = format!("--example {name}");
        docs.match_indices(&needle)
            .any(|(at, _)| !docs[at + needle.len()..].starts_with(|c: char| c.is_ascii_alphanumeric() || c == '_'))
    };
    let missing: Vec<&String> = examples.iter().filter(|e| !has_command(e)).collect();
    assert!(missing.is_empty(), "no `--example NAME` command in README.md or docs/ for {missing:?}");
}
