//! Agent discovery server (`-d [port]`, spec §13.2): answers any GET_INFO with an INFO listing the agent's
//! local IPv4 interfaces as MEDIUM locators with the agent's service port. [`DiscoveryServer::bind_multicast`]
//! listens on the port and joins 239.255.0.2 (the agent's `-d`); [`DiscoveryServer::bind`] listens on one
//! address without multicast (tests, unicast discovery). The agent's UDP and TCP servers answer it from their
//! own event loop ([`DiscoveryServer::answer_queued`]); [`DiscoveryServer::run`] serves it alone.

use std::io;
use std::net::{IpAddr, Ipv4Addr, SocketAddr, UdpSocket};
use std::sync::atomic::{AtomicBool, Ordering};

use xrce_proto::message::parse;
use xrce_proto::object::AgentRepresentation;
use xrce_proto::submessage::{ActivityInfo, Info};
use xrce_proto::{BaseObjectReply, ObjectVariant, ResultStatus, StatusCode, Submessage, TransportLocator};

use super::MAX_BLOCK;

/// The discovery multicast group.
pub const DISCOVERY_GROUP: Ipv4Addr = Ipv4Addr::new(239, 255, 0, 2);
/// Locators in one answer (the C client keeps 4; more interfaces are rare).
pub const MAX_LOCATORS: usize = 16;

/// A discovery server for an agent serving on `service_port`.
#[derive(Debug)]
pub struct DiscoveryServer {
    socket: UdpSocket,
    service_port: u16,
    addresses: Vec<Ipv4Addr>,
}

/// The machine's IPv4 interface addresses, non-loopback first (a remote client takes the first ones).
pub fn local_ipv4_addresses() -> Vec<Ipv4Addr> {
    let mut v: Vec<Ipv4Addr> = Vec::new();
    #[cfg(target_os = "linux")]
    if let Ok(ifs) = nix::ifaddrs::getifaddrs() {
        for ifa in ifs {
            if let Some(sin) = ifa.address.as_ref().and_then(|a| a.as_sockaddr_in()) {
                let ip = sin.ip();
                if !v.contains(&ip) {
                    v.push(ip);
                }
            }
        }
    }
    if v.is_empty() {
        v.push(Ipv4Addr::LOCALHOST);
    }
    v.sort_by_key(Ipv4Addr::is_loopback);
    v.truncate(MAX_LOCATORS);
    v
}

/// The INFO answering every GET_INFO of `request` (header copied), or `None` if it holds none.
pub fn answer(request: &[u8], service_port: u16, addresses: &[Ipv4Addr]) -> Option<Vec<u8>> {
    let (header, subs) = parse(request).ok()?;
    let get = subs.map_while(Result::ok).find_map(|raw| match raw.decode() {
        Ok(Submessage::GetInfo(get)) => Some(get),
        _ => None,
    })?;
    let locators: Vec<TransportLocator<'static>> =
        addresses.iter().map(|ip| TransportLocator::Medium { address: ip.octets(), port: service_port }).collect();
    let info = Info {
        reply: BaseObjectReply {
            related_request: get.request,
            result: ResultStatus { status: StatusCode::OK, implementation_status: 0 },
        },
        config: Some(ObjectVariant::Agent(AgentRepresentation::EPROSIMA)),
        activity: Some(ActivityInfo::Agent { availability: 1, address_seq: xrce_proto::cdr::Seq::Items(&locators) }),
    };
    crate::core::encode_message(&header, &Submessage::Info(info))
}

impl DiscoveryServer {
    /// Listens on `0.0.0.0:port` and joins [`DISCOVERY_GROUP`] on the default interface (eProsima's `-d`).
    pub fn bind_multicast(port: u16, service_port: u16) -> io::Result<Self> {
        use socket2::{Domain, Protocol, Socket, Type};
        let socket = Socket::new(Domain::IPV4, Type::DGRAM, Some(Protocol::UDP))?;
        socket.set_reuse_address(true)?;
        socket.bind(&SocketAddr::from((Ipv4Addr::UNSPECIFIED, port)).into())?;
        socket.join_multicast_v4(&DISCOVERY_GROUP, &Ipv4Addr::UNSPECIFIED)?;
        Ok(Self { socket: socket.into(), service_port, addresses: local_ipv4_addresses() })
    }

    /// Listens on `addr` only (unicast), answering with `addresses` (default: the local interfaces).
    pub fn bind(addr: SocketAddr, service_port: u16, addresses: Option<Vec<Ipv4Addr>>) -> io::Result<Self> {
        let socket = UdpSocket::bind(addr)?;
        Ok(Self { socket, service_port, addresses: addresses.unwrap_or_else(local_ipv4_addresses) })
    }

    /// The bound address.
    pub fn local_addr(&self) -> io::Result<SocketAddr> {
        self.socket.local_addr()
    }

    /// Answers requests until `stop` is set. Answers go to the request's source, by unicast.
    pub fn run(&self, stop: &AtomicBool) -> io::Result<()> {
        self.socket.set_read_timeout(Some(MAX_BLOCK))?;
        let mut buf = vec![0u8; 1500];
        while !stop.load(Ordering::Relaxed) {
            self.answer_next(&mut buf)?;
        }
        Ok(())
    }

    /// The socket, for an event loop to register (after [`Self::set_nonblocking`]).
    pub fn socket(&self) -> &UdpSocket {
        &self.socket
    }

    /// Makes [`Self::answer_queued`] return at once when no request waits.
    pub fn set_nonblocking(&self) -> io::Result<()> {
        self.socket.set_nonblocking(true)
    }

    /// Answers every request queued on a non-blocking socket.
    pub fn answer_queued(&self) -> io::Result<()> {
        let mut buf = [0u8; 1500];
        while self.answer_next(&mut buf)? {}
        Ok(())
    }

    /// Waits for one request (as the socket allows) and answers it; false when none came.
    fn answer_next(&self, buf: &mut [u8]) -> io::Result<bool> {
        let (n, from) = match self.socket.recv_from(buf) {
            Ok(r) => r,
            Err(e) if matches!(e.kind(), io::ErrorKind::WouldBlock | io::ErrorKind::TimedOut) => return Ok(false),
            // A signal, or the ICMP error of an earlier answer (consumed by this call): requests may wait behind.
            Err(e) if matches!(e.kind(), io::ErrorKind::Interrupted | io::ErrorKind::ConnectionRefused) => {
                return Ok(true)
            }
            Err(e) => return Err(e),
        };
        if matches!(from.ip(), IpAddr::V4(ip) if ip.is_multicast()) {
            return Ok(true);
        }
        let Some(reply) = answer(buf.get(..n).unwrap_or(&[]), self.service_port, &self.addresses) else {
            tracing::debug!(peer = %from, "discovery: not a GET_INFO, ignored");
            return Ok(true);
        };
        tracing::debug!(peer = %from, "discovery: answering");
        if let Err(e) = self.socket.send_to(&reply, from) {
            tracing::debug!(peer = %from, "discovery answer failed: {e}");
        }
        Ok(true)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::Arc;

    #[test]
    fn answers_a_discovery_request_with_medium_locators() {
        // Spec §13.1: header 80 00 00 00 + GET_INFO {request 00 09, object FF FD, mask 0x03}.
        let request = [0x80, 0, 0, 0, 0x02, 0x01, 0x08, 0x00, 0x00, 0x09, 0xFF, 0xFD, 0x03, 0, 0, 0];
        let reply = answer(&request, 8888, &[Ipv4Addr::new(10, 1, 2, 3), Ipv4Addr::LOCALHOST]).unwrap();
        let (header, mut subs) = parse(&reply).unwrap();
        assert_eq!(header.session_id, 0x80);
        let Ok(Submessage::Info(info)) = subs.next().unwrap().unwrap().decode() else { panic!("not an INFO") };
        assert_eq!(info.reply.related_request.request_id.0, 9);
        let Some(ActivityInfo::Agent { availability, address_seq }) = info.activity else { panic!("no activity") };
        assert_eq!(availability, 1);
        let locators: Vec<_> = address_seq.iter().collect();
        assert_eq!(
            locators,
            vec![
                TransportLocator::Medium { address: [10, 1, 2, 3], port: 8888 },
                TransportLocator::Medium { address: [127, 0, 0, 1], port: 8888 },
            ]
        );
        assert!(answer(&[0x80, 0, 0, 0], 8888, &[]).is_none());
    }

    /// Our client's discovery towards `addr`, stopping at the first agent, while `serve` runs on a thread of
    /// its own until the search ends; what it found.
    fn discover_while(
        addr: SocketAddr,
        serve: impl FnOnce(&AtomicBool) -> io::Result<()> + Send + 'static,
    ) -> Vec<SocketAddr> {
        let stop = Arc::new(AtomicBool::new(false));
        let s2 = stop.clone();
        let t = std::thread::spawn(move || serve(&s2));
        let mut found = Vec::new();
        let stopped = xrce_client::transport::discovery::discovery_agents(
            3,
            500,
            |a| {
                found.push(a);
                true
            },
            &[addr],
        )
        .unwrap();
        stop.store(true, Ordering::Relaxed);
        t.join().unwrap().unwrap();
        assert!(stopped);
        found
    }

    /// Unicast on loopback only: our client's discovery finds the agent's service port.
    #[test]
    fn client_discovery_finds_the_agent_by_unicast() {
        let server =
            DiscoveryServer::bind("127.0.0.1:0".parse().unwrap(), 4242, Some(vec![Ipv4Addr::LOCALHOST])).unwrap();
        let addr = server.local_addr().unwrap();
        let found = discover_while(addr, move |stop| server.run(stop));
        assert_eq!(found, vec![SocketAddr::from(([127, 0, 0, 1], 4242))]);
    }

    /// A UDP server answers discovery from its own loop (the agent's `-d`, here by unicast on loopback).
    #[test]
    fn the_udp_server_answers_discovery_from_its_loop() {
        use crate::middleware::ced::Ced;
        use crate::middleware::describe::FallbackProfiles;
        let core = crate::core::AgentCore::new(
            crate::core::CoreConfig::default(),
            Box::new(Ced::new(Arc::new(FallbackProfiles))) as super::super::DynMiddleware,
        );
        let server =
            super::super::udp::UdpServer::bind("127.0.0.1:0".parse().unwrap(), crate::transport::SharedCore::new(core))
                .unwrap();
        let service = server.local_addr().unwrap();
        let discovery =
            DiscoveryServer::bind("127.0.0.1:0".parse().unwrap(), service.port(), Some(vec![Ipv4Addr::LOCALHOST]))
                .unwrap();
        let addr = discovery.local_addr().unwrap();
        let server = server.with_discovery(discovery);
        let found = discover_while(addr, move |stop| server.run(stop));
        assert_eq!(found, vec![service]);
    }
}
