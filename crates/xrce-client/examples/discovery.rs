//! Discovery: looks for agents, 10 rounds one second apart, and prints every one found. Without arguments it
//! asks the multicast group 239.255.0.2:7400; with `<ip> <port>` pairs (up to 10) it asks those addresses.
//! Usage, as eProsima's example: `discovery [ -h | --help | [<ip> <port> ...] ]`.

use std::net::{IpAddr, SocketAddr};

use xrce_client::prelude::*;

const MAX_AGENTS: usize = 10;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let help = args.first().is_some_and(|a| a == "-h" || a == "--help");
    if help || !args.len().is_multiple_of(2) || args.len() > 2 * MAX_AGENTS {
        println!("usage: program [ -h | --help | [<ip> <port> ...] ]");
        return Ok(());
    }
    let on_agent_found = |agent: SocketAddr| {
        println!("Agent found => ip: {}, port: {}", agent.ip(), agent.port());
        false // keep looking
    };
    if args.is_empty() {
        discovery::discovery_agents_default(10, 1000, on_agent_found)?;
    } else {
        let mut agents = Vec::new();
        for pair in args.chunks(2) {
            let (ip, port): (IpAddr, u16) = (pair[0].parse()?, pair[1].parse()?);
            agents.push(SocketAddr::new(ip, port));
        }
        discovery::discovery_agents(10, 1000, on_agent_found, &agents)?;
    }
    Ok(())
}
