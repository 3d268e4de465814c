//! PingAgent (UDP): pings an agent outside any session. Usage: `ping_agent <ip> <port>`.

use xrce_client::prelude::*;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    if args.len() < 3 || args[2].parse::<u16>().is_err() {
        println!("usage: program [-h | --help] | ip port");
        return Ok(());
    }
    let mut transport = UdpTransport::new(IpProtocol::V4, &args[1], &args[2])?;
    if ping_agent_attempts(&mut transport, 1000, 10)? {
        println!("Success! Agent is up on port {}.", args[2]);
    } else {
        println!("Sorry, no agent available at port {}.", args[2]);
    }
    Ok(())
}
