//! `xrce-agent`: the `MicroXRCEAgent`-compatible command line.

use std::process::ExitCode;

use xrce_agent::agent::{AgentError, AgentInstance};

fn main() -> ExitCode {
    let config = match xrce_agent::cli::parse_from(std::env::args_os()) {
        Ok(c) => c,
        Err(e) => e.exit(),
    };
    xrce_agent::logging::set_verbose_level(config.verbosity);
    let mut instance = match AgentInstance::from_config(config) {
        Ok(i) => i,
        Err(e) => {
            eprintln!("xrce-agent: {e}");
            return ExitCode::FAILURE;
        }
    };
    let stop = instance.stop_flag();
    for signal in [signal_hook::consts::SIGINT, signal_hook::consts::SIGTERM] {
        if let Err(e) = signal_hook::flag::register(signal, stop.clone()) {
            eprintln!("xrce-agent: cannot install signal handler: {e}");
            return ExitCode::FAILURE;
        }
    }
    match instance.run() {
        Ok(()) => ExitCode::SUCCESS,
        Err(AgentError::Io(e)) => {
            eprintln!("xrce-agent: {e}");
            ExitCode::FAILURE
        }
        Err(e) => {
            eprintln!("xrce-agent: {e}");
            ExitCode::FAILURE
        }
    }
}
