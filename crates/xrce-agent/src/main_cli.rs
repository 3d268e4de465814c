//! The process entry point shared by the `xrce-agent` and `MicroXRCEAgent` binaries.

use std::process::ExitCode;

use crate::agent::{AgentError, AgentInstance};
use crate::cli::Invocation;

/// Parses the command line, installs SIGINT/SIGTERM handlers that stop the agent cleanly, and runs it.
/// `name` prefixes error messages (the binary's name).
pub fn run_command_line(name: &str) -> ExitCode {
    let invocation = match crate::cli::parse_invocation(std::env::args_os()) {
        Ok(i) => i,
        Err(e) => e.exit(),
    };
    let started = match invocation {
        Invocation::Command(config) => {
            crate::logging::set_verbose_level(config.verbosity);
            AgentInstance::from_config(config)
        }
        // Nothing starts until the whole file is valid.
        Invocation::File(path) => crate::config_file::load(&path).map_err(AgentError::from).and_then(|file| {
            crate::logging::set_verbose_level(file.options.verbosity);
            AgentInstance::from_file(file)
        }),
    };
    let mut instance = match started {
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
