//! `xrce-agent`: the `MicroXRCEAgent`-compatible command line.

fn main() -> std::process::ExitCode {
    xrce_agent::main_cli::run_command_line("xrce-agent")
}
