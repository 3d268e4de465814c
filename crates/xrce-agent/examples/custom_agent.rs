//! A custom agent transport (eProsima's `CustomAgent` example, seed 004): the agent serves over a UDP socket
//! owned by user code, and tells clients apart by an endpoint of two members, the peer's IPv4 address
//! (`u32`) and port (`u16`). With `--framing` the datagrams carry a byte stream in HDLC-like frames instead
//! of one message each (eProsima's `framing = true`). docs/agent-api.md walks through it.
//!
//! usage: cargo run -p xrce-agent --example custom_agent -- [port] [--framing]
//! then:  cargo run -p xrce-client --example custom_transport -- 127.0.0.1 <port> [--framing]

use std::io;
use std::net::{Ipv4Addr, SocketAddr, SocketAddrV4, UdpSocket};
use std::sync::{Arc, Mutex, PoisonError};
use std::time::Duration;

use xrce_agent::custom_agent::CustomAgent;
use xrce_agent::middleware::MiddlewareKind;
use xrce_agent::transport::custom::{CustomAgentIo, Endpoint, EndpointDesc, Mode};

/// The user's transport: open binds the socket, close drops it.
struct UdpIo {
    port: u16,
    /// Shared out of the lock, so a `read` waiting for input never holds up a `write`.
    socket: Mutex<Option<Arc<UdpSocket>>>,
}

impl UdpIo {
    fn socket(&self) -> io::Result<Arc<UdpSocket>> {
        let socket = self.socket.lock().unwrap_or_else(PoisonError::into_inner);
        socket.clone().ok_or_else(|| io::Error::new(io::ErrorKind::NotConnected, "transport closed"))
    }
}

fn invalid(e: impl std::error::Error + Send + Sync + 'static) -> io::Error {
    io::Error::new(io::ErrorKind::InvalidInput, e)
}

impl CustomAgentIo for UdpIo {
    fn open(&self) -> io::Result<()> {
        let socket = UdpSocket::bind(SocketAddrV4::new(Ipv4Addr::UNSPECIFIED, self.port))?;
        println!("custom agent listening on {}", socket.local_addr()?);
        *self.socket.lock().unwrap_or_else(PoisonError::into_inner) = Some(Arc::new(socket));
        Ok(())
    }

    fn close(&self) -> io::Result<()> {
        self.socket.lock().unwrap_or_else(PoisonError::into_inner).take();
        Ok(())
    }

    fn write(&self, to: &Endpoint, bytes: &[u8]) -> io::Result<usize> {
        let ip = Ipv4Addr::from(to.get::<u32>("ip").map_err(invalid)?);
        let port = to.get::<u16>("port").map_err(invalid)?;
        self.socket()?.send_to(bytes, SocketAddrV4::new(ip, port))
    }

    fn read(&self, from: &mut Endpoint, buf: &mut [u8], timeout: Duration) -> io::Result<usize> {
        let socket = self.socket()?;
        socket.set_read_timeout(Some(timeout.max(Duration::from_millis(1))))?;
        let (n, peer) = socket.recv_from(buf)?;
        let SocketAddr::V4(peer) = peer else { return Ok(0) };
        from.set("ip", u32::from(*peer.ip())).map_err(invalid)?;
        from.set("port", peer.port()).map_err(invalid)?;
        Ok(n)
    }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let framing = args.iter().any(|a| a == "--framing");
    let port = args.iter().find_map(|a| a.parse::<u16>().ok()).unwrap_or(8888);

    // eProsima: `CustomEndPoint endpoint; endpoint.add_member<uint32_t>("ip"); ...`
    let endpoint = EndpointDesc::new().member_u32("ip").member_u16("port");
    let io = UdpIo { port, socket: Mutex::new(None) };
    // `-m ced`: clients of this agent talk to each other without a DDS network.
    let mut agent = CustomAgent::new("udp-custom", endpoint, MiddlewareKind::Ced, Mode::from(framing), io)?;

    // The agent API of the built-in servers, before `start` as eProsima asks (here it may come later too).
    agent.agent().set_verbose_level(4);
    signal_hook::flag::register(signal_hook::consts::SIGINT, agent.stop_flag())?;
    signal_hook::flag::register(signal_hook::consts::SIGTERM, agent.stop_flag())?;

    agent.start()?;
    println!("framing {}; Ctrl-C stops", if framing { "on" } else { "off" });
    agent.run()?;
    Ok(())
}
