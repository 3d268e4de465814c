//! `MicroXRCEAgent`: the same agent under eProsima's binary name, so scripts and launch files that start
//! `MicroXRCEAgent udp4 -p 8888` keep working unchanged.

fn main() -> std::process::ExitCode {
    xrce_agent::main_cli::run_command_line("MicroXRCEAgent")
}
