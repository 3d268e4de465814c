//! The `--config` file parser (TOML, then every value through the command line's own parser) on arbitrary
//! text: it must never panic, an error names a line inside the file, and a valid file has a transport.
#![no_main]

use std::path::Path;

use libfuzzer_sys::fuzz_target;
use xrce_agent::config_file::parse;

fuzz_target!(|text: &str| {
    match parse(text, Path::new("fuzz.toml")) {
        Ok(config) => assert!(!config.transports.is_empty(), "a configuration without a transport was accepted"),
        Err(e) => {
            let lines = text.split('\n').count().max(1);
            assert!(e.line >= 1 && e.line <= lines, "error on line {} of a {lines}-line file", e.line);
        }
    }
});
