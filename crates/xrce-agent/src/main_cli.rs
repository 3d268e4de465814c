//! The process entry point shared by the `xrce-agent` and `MicroXRCEAgent` binaries.

use std::process::ExitCode;

use crate::agent::AgentInstance;

/// Parses the command line, installs SIGINT/SIGTERM handlers that stop the agent cleanly, and runs it.
/// `name` prefixes error messages (the binary's name).
pub fn run_command_line(name: &str) -> ExitCode {
    let config = match crate::cli::parse_from(std::env::args_os()) {
        Ok(c) => c,
        Err(e) => e.exit(),
    };
    crate::logging::set_verbose_level(config.verbosity);
    let mut instance = match AgentInstance::from_config(config) {
        Ok(i) => i,
        Err(e) => {
            eprintln!("{name}: {e}");
            return ExitCode::FAILURE;
        }
    };
    let stop = instance.stop_flag();
    for signal in [signal_hook::consts::SIGINT, signal_hook::consts::SIGTERM] {
        if let Err(e) = signal_hook::flag::register(signal, stop.clone()) {
            eprintln!("{name}: cannot install signal handler: {e}");
            return ExitCode::FAILURE;
        }
    }
    match instance.run() {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("{name}: {e}");
            ExitCode::FAILURE
        }
    }
}
