//! `xrce-agent --config FILE` (issue 24): one agent on several transports, from a TOML file read with serde
//! and the `toml` crate (the standard TOML parser, which keeps every key's and value's position, so errors
//! name the line).
//!
//! The common options sit at the top of the file under their long names (`middleware = "ced"`,
//! `verbose = 4`, `client-timeout = 30`, …), and each `[[transport]]` table has a `kind` (a transport
//! subcommand) and that transport's options under their long names (`port`, `dev`, `devs`, `file`,
//! `baudrate`, `flow-control`, `id`). Each value is checked by the command line's own parser (clap), as if
//! it had been typed after the transport, so the file and the command line cannot disagree on a name, a
//! range or a default. Beyond that: a port given twice (same protocol), a device given twice, and a serial
//! device or CAN interface that does not exist are refused. Every error names the file, the line and the
//! key, and nothing starts until the whole file is valid.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

use clap::error::ErrorKind;
use serde::Deserialize;
use toml::{Spanned, Value};

use crate::cli::{self, Config, Transport};

/// Largest configuration file read: a few dozen lines are expected.
pub const MAX_FILE_LEN: u64 = 1 << 20;

/// An agent's configuration from a file: the common options and every transport.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct FileConfig {
    /// The common options (`transport` and `flow_control` are the first transport's).
    pub options: Config,
    /// The transports, in the file's order.
    pub transports: Vec<TransportSpec>,
}

/// One `[[transport]]` table.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TransportSpec {
    /// The transport and its parameters.
    pub transport: Transport,
    /// RTS/CTS flow control (`flow-control`, serial and multiserial).
    pub flow_control: bool,
    /// Most connections served at once (`max-connections`, tcp4 and tcp6).
    pub max_connections: usize,
    /// The table's line in the file.
    pub line: usize,
}

/// A configuration file that cannot be used: where and why.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{}:{line}: {}{message}", file.display(), key.as_ref().map(|k| format!("`{k}`: ")).unwrap_or_default())]
pub struct ConfigFileError {
    /// The file.
    pub file: PathBuf,
    /// The line (from 1).
    pub line: usize,
    /// The key, when the error is about one.
    pub key: Option<String>,
    /// What is wrong.
    pub message: String,
}

/// A key with its value, both with their positions.
type Entries = BTreeMap<Spanned<String>, Spanned<Value>>;

/// The `[[transport]]` tables; the other top-level keys are read as [`Entries`].
#[derive(Deserialize)]
struct Transports {
    #[serde(default)]
    transport: Vec<Spanned<Entries>>,
}

/// Reads and checks `path`.
pub fn load(path: &Path) -> Result<FileConfig, ConfigFileError> {
    use std::io::Read;
    let fail = |message: String| ConfigFileError { file: path.to_path_buf(), line: 1, key: None, message };
    let mut text = String::new();
    std::fs::File::open(path)
        .and_then(|f| f.take(MAX_FILE_LEN + 1).read_to_string(&mut text))
        .map_err(|e| fail(format!("cannot read the file: {e}")))?;
    if text.len() as u64 > MAX_FILE_LEN {
        return Err(fail(format!("larger than {MAX_FILE_LEN} bytes")));
    }
    parse(&text, path)
}

/// Checks the text of a configuration file; `path` names it in errors.
pub fn parse(text: &str, path: &Path) -> Result<FileConfig, ConfigFileError> {
    Parser { text, path }.parse()
}

struct Parser<'a> {
    text: &'a str,
    path: &'a Path,
}

/// The long names clap knows: those every transport takes (the common options) and each transport's own.
struct Names {
    common: BTreeSet<String>,
    by_kind: BTreeMap<String, BTreeSet<String>>,
    /// Options that take no value (`flow-control`): `true` gives the bare option.
    flags: BTreeSet<String>,
}

impl Names {
    fn new() -> Self {
        let mut cmd = cli::command();
        cmd.build();
        let mut by_kind = BTreeMap::new();
        let mut flags = BTreeSet::new();
        for sub in cmd.get_subcommands() {
            let mut longs = BTreeSet::new();
            for arg in sub.get_arguments().filter(|a| !a.is_hide_set() || a.get_long() == Some("p2p")) {
                if let Some(long) = arg.get_long().filter(|l| *l != "help") {
                    if !arg.get_action().takes_values() {
                        flags.insert(long.to_owned());
                    }
                    longs.insert(long.to_owned());
                }
            }
            by_kind.insert(sub.get_name().to_owned(), longs);
        }
        let mut sets = by_kind.values();
        let first = sets.next().cloned().unwrap_or_default();
        let common = sets.fold(first, |acc, s| acc.intersection(s).cloned().collect());
        for own in by_kind.values_mut() {
            own.retain(|k| !common.contains(k));
        }
        Self { common, by_kind, flags }
    }
}

impl Parser<'_> {
    fn line_of(&self, offset: usize) -> usize {
        self.text.get(..offset).map_or(1, |before| before.matches('\n').count() + 1)
    }

    fn error(&self, offset: usize, key: Option<&str>, message: impl Into<String>) -> ConfigFileError {
        ConfigFileError {
            file: self.path.to_path_buf(),
            line: self.line_of(offset),
            key: key.map(str::to_owned),
            message: message.into(),
        }
    }

    /// toml's own error: a syntax error, or a key whose value has the wrong shape for the file's layout.
    fn toml_error(&self, e: &toml::de::Error) -> ConfigFileError {
        let offset = e.span().map_or(0, |s| s.start);
        self.error(offset, None, e.message().trim().to_owned())
    }

    fn parse(&self) -> Result<FileConfig, ConfigFileError> {
        let top: Entries = toml::from_str(self.text).map_err(|e| self.toml_error(&e))?;
        let tables: Transports = toml::from_str(self.text).map_err(|e| self.toml_error(&e))?;
        let names = Names::new();
        let mut common_args = Vec::new();
        for (key, value) in &top {
            if key.get_ref() == "transport" {
                continue;
            }
            if !names.common.contains(key.get_ref()) {
                let hint = if names.by_kind.values().any(|own| own.contains(key.get_ref())) {
                    ": a transport's option, it goes in its [[transport]] table"
                } else {
                    ""
                };
                return Err(self.error(key.span().start, Some(key.get_ref()), format!("unknown key{hint}")));
            }
            let args = self.arguments(key, value, &names)?;
            // Checked alone first, on a transport that needs nothing else, so the error names this key.
            self.check_alone(key, value, "pseudoterminal", &args)?;
            common_args.extend(args);
        }
        if tables.transport.is_empty() {
            let end = self.text.len();
            return Err(self.error(end, None, "no [[transport]] table: the file must name at least one transport"));
        }
        let mut transports = Vec::new();
        let mut options = None;
        for table in &tables.transport {
            let (config, spec) = self.transport(table, &names, &common_args)?;
            options.get_or_insert(config);
            transports.push(spec);
        }
        self.check_unique(&tables.transport, &transports)?;
        let options = options.ok_or_else(|| self.error(0, None, "no transport"))?;
        Ok(FileConfig { options, transports })
    }

    /// One `[[transport]]` table, checked key by key and then whole.
    fn transport(
        &self,
        table: &Spanned<Entries>,
        names: &Names,
        common_args: &[String],
    ) -> Result<(Config, TransportSpec), ConfigFileError> {
        let start = table.span().start;
        let line = self.line_of(start);
        let kind_key = table.get_ref().keys().find(|k| k.get_ref() == "kind");
        let Some((kind_key, kind)) = kind_key.and_then(|k| table.get_ref().get(k).map(|v| (k, v))) else {
            return Err(self.error(start, None, "this [[transport]] table has no `kind`"));
        };
        let kinds = names.by_kind.keys().cloned().collect::<Vec<_>>().join(", ");
        let Some(kind_name) = kind.get_ref().as_str().filter(|k| names.by_kind.contains_key(*k)) else {
            return Err(self.error(kind.span().start, Some(kind_key.get_ref()), format!("must be one of {kinds}")));
        };
        let own = names.by_kind.get(kind_name).cloned().unwrap_or_default();
        let mut args = vec![kind_name.to_owned()];
        for (key, value) in table.get_ref() {
            if key.get_ref() == "kind" {
                continue;
            }
            if !own.contains(key.get_ref()) {
                let hint = if names.common.contains(key.get_ref()) {
                    ": a common option, it goes at the top of the file".to_owned()
                } else {
                    let mut known: Vec<&str> = own.iter().map(String::as_str).collect();
                    known.insert(0, "kind");
                    format!(" for kind = \"{kind_name}\" (its keys: {})", known.join(", "))
                };
                return Err(self.error(key.span().start, Some(key.get_ref()), format!("unknown key{hint}")));
            }
            let value_args = self.arguments(key, value, names)?;
            self.check_alone(key, value, kind_name, &value_args)?;
            args.extend(value_args);
        }
        args.extend(common_args.iter().cloned());
        let config = cli::parse_from(std::iter::once("xrce-agent".to_owned()).chain(args))
            .map_err(|e| self.error(start, None, format!("[[transport]] {kind_name}: {}", clap_message(&e))))?;
        if let Some((key, missing)) = self.missing_device(&config.transport, table) {
            return Err(self.error(key.span().start, Some(key.get_ref()), format!("{missing} does not exist")));
        }
        let spec = TransportSpec {
            transport: config.transport.clone(),
            flow_control: config.flow_control,
            max_connections: config.max_connections,
            line,
        };
        Ok((config, spec))
    }

    /// The command-line arguments for one key: `--key value`, `--key` (a flag set to true), `--key a --key b`
    /// (an array; `devs` takes one space-separated value).
    fn arguments(
        &self,
        key: &Spanned<String>,
        value: &Spanned<Value>,
        names: &Names,
    ) -> Result<Vec<String>, ConfigFileError> {
        let name = key.get_ref();
        let option = format!("--{name}");
        let wrong = |what: &str| self.error(value.span().start, Some(name), format!("wrong type: {what}"));
        let scalar = |v: &Value| -> Result<String, ConfigFileError> {
            match v {
                Value::String(s) => Ok(s.clone()),
                Value::Integer(i) => Ok(i.to_string()),
                Value::Float(f) => Ok(f.to_string()),
                Value::Boolean(b) => Ok(if *b { "on" } else { "off" }.to_owned()),
                _ => Err(wrong("expected a string, a number or a boolean")),
            }
        };
        if names.flags.contains(name) {
            return match value.get_ref() {
                Value::Boolean(true) => Ok(vec![option]),
                Value::Boolean(false) => Ok(Vec::new()),
                _ => Err(wrong("expected true or false")),
            };
        }
        match value.get_ref() {
            Value::Array(items) if name == "devs" => {
                let devices = items.iter().map(scalar).collect::<Result<Vec<_>, _>>()?;
                Ok(vec![option, devices.join(" ")])
            }
            Value::Array(items) => {
                let mut args = Vec::new();
                for item in items {
                    args.push(option.clone());
                    args.push(scalar(item)?);
                }
                Ok(args)
            }
            Value::Table(_) | Value::Datetime(_) => Err(wrong("expected a string, a number or a boolean")),
            scalar_value => Ok(vec![option, scalar(scalar_value)?]),
        }
    }

    /// Parses `args` after `kind` as a command line; an error there is this key's (a missing other option,
    /// which the whole table may still give, is not).
    fn check_alone(
        &self,
        key: &Spanned<String>,
        value: &Spanned<Value>,
        kind: &str,
        args: &[String],
    ) -> Result<(), ConfigFileError> {
        let line = ["xrce-agent", kind].into_iter().map(str::to_owned).chain(args.iter().cloned());
        match cli::parse_from(line) {
            Err(e) if !matches!(e.kind(), ErrorKind::MissingRequiredArgument) => {
                let mut message = clap_message(&e);
                // A boolean went to the command line as on/off: name the value the file holds.
                if let Value::Boolean(b) = value.get_ref() {
                    let (given, file) = if *b { ("'on'", "'true'") } else { ("'off'", "'false'") };
                    message = message.replacen(given, file, 1);
                }
                Err(self.error(key.span().start, Some(key.get_ref()), message))
            }
            _ => Ok(()),
        }
    }

    /// A serial device or CAN interface of `transport` that does not exist, with the key that names it.
    fn missing_device<'t>(
        &self,
        transport: &Transport,
        table: &'t Spanned<Entries>,
    ) -> Option<(&'t Spanned<String>, String)> {
        let key = |names: &[&str]| table.get_ref().keys().find(|k| names.contains(&k.get_ref().as_str()));
        match transport {
            Transport::Serial { device, .. } if !Path::new(device).exists() => {
                Some((key(&["dev", "file"])?, format!("serial device {device}")))
            }
            Transport::MultiSerial { devices, .. } => {
                let gone = devices.iter().find(|d| !Path::new(d).exists())?;
                Some((key(&["devs", "file"])?, format!("serial device {gone}")))
            }
            Transport::CanFd { device, .. } if !Path::new("/sys/class/net").join(device).exists() => {
                Some((key(&["dev"])?, format!("CAN interface {device}")))
            }
            _ => None,
        }
    }

    /// A port (per protocol) or a device given twice.
    fn check_unique(&self, tables: &[Spanned<Entries>], specs: &[TransportSpec]) -> Result<(), ConfigFileError> {
        let mut seen: BTreeMap<String, usize> = BTreeMap::new();
        for (table, spec) in tables.iter().zip(specs) {
            let (key_name, taken): (&str, Vec<String>) = match &spec.transport {
                Transport::Udp4 { port } | Transport::Udp6 { port } if *port != 0 => {
                    ("port", vec![format!("UDP port {port}")])
                }
                Transport::Tcp4 { port } | Transport::Tcp6 { port } if *port != 0 => {
                    ("port", vec![format!("TCP port {port}")])
                }
                Transport::Serial { device, .. } => ("dev", vec![format!("device {device}")]),
                Transport::MultiSerial { devices, .. } => {
                    ("devs", devices.iter().map(|d| format!("device {d}")).collect())
                }
                Transport::CanFd { device, .. } => ("dev", vec![format!("CAN interface {device}")]),
                _ => continue,
            };
            let key = table.get_ref().keys().find(|k| k.get_ref() == key_name || k.get_ref() == "file");
            let offset = key.map_or(table.span().start, |k| k.span().start);
            for what in taken {
                if let Some(first) = seen.get(&what) {
                    let message = format!("{what} given twice (first at line {first})");
                    return Err(self.error(offset, key.map(|k| k.get_ref().as_str()), message));
                }
                // The line of the key that gave it (the table's line when a default port did).
                seen.insert(what, self.line_of(offset));
            }
        }
        Ok(())
    }
}

/// A clap error's first paragraph on one line (a missing argument's name is on its second line), without its
/// `error: ` prefix or the usage that follows.
fn clap_message(e: &clap::Error) -> String {
    let text = e.to_string();
    let first = text.split("\n\n").next().unwrap_or_default();
    let words = first.split_whitespace().collect::<Vec<_>>().join(" ");
    words.strip_prefix("error: ").unwrap_or(&words).to_owned()
}
