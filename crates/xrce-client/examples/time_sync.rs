//! TimeSync: synchronises the session clock with the agent's and prints both. Usage: `time_sync <ip> <port>`.

use xrce_client::prelude::*;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    if args.len() < 3 || args[2].parse::<u16>().is_err() {
        println!("usage: program [-h | --help] | ip port");
        return Ok(());
    }
    let transport = UdpTransport::new(IpProtocol::V4, &args[1], &args[2])?;
    let mut session = Session::new(transport, 0xAAAA_BBBB);
    session.create_session()?;
    for _ in 0..10 {
        if session.sync_session(1000)? {
            println!(
                "synchronized: agent epoch {} ms, offset {} ns",
                session.epoch_millis(),
                session.core().time_offset()
            );
        } else {
            println!("no answer to the time synchronisation");
        }
        std::thread::sleep(std::time::Duration::from_secs(1));
    }
    session.delete_session()?;
    Ok(())
}
