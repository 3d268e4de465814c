//! Agent discovery over UDP (`uxr_discovery_agents_default`, `uxr_discovery_agents`, spec §13.1): a GET_INFO
//! to the multicast group 239.255.0.2:7400 or to a list of addresses, repeated `attempts` times, listening
//! `period` milliseconds after each round; every agent locator found goes to a callback that may stop the search.

use std::net::{Ipv4Addr, Ipv6Addr, SocketAddr, UdpSocket};
use std::time::{Duration, Instant};

use xrce_proto::submessage::{info_mask, ActivityInfo};
use xrce_proto::{ObjectVariant, RequestId, TransportLocator, XRCE_VERSION};

use super::TransportError;
use crate::session::ping::{encode_get_info, parse_info, GET_INFO_LEN};

/// Default discovery group.
pub const MULTICAST_GROUP: Ipv4Addr = Ipv4Addr::new(239, 255, 0, 2);
/// Default discovery port.
pub const DISCOVERY_PORT: u16 = 7400;
/// How long one socket is listened to before the other, when discovery uses an IPv4 and an IPv6 socket.
const LISTEN_TURN: Duration = Duration::from_millis(10);
/// The C client keeps only the first locators of an answer.
const MAX_LOCATORS: usize = 4;

/// `uxr_discovery_agents_default`: multicast to 239.255.0.2:7400. `on_agent` gets each agent found and returns
/// `true` to stop. Whether the callback stopped the search.
pub fn discovery_agents_default(
    attempts: u32,
    period_ms: u32,
    on_agent: impl FnMut(SocketAddr) -> bool,
) -> Result<bool, TransportError> {
    discovery_agents(attempts, period_ms, on_agent, &[SocketAddr::from((MULTICAST_GROUP, DISCOVERY_PORT))])
}

/// `uxr_discovery_agents`: as [`discovery_agents_default`] towards every address of `agents`.
pub fn discovery_agents(
    attempts: u32,
    period_ms: u32,
    mut on_agent: impl FnMut(SocketAddr) -> bool,
    agents: &[SocketAddr],
) -> Result<bool, TransportError> {
    let socket = UdpSocket::bind((Ipv4Addr::UNSPECIFIED, 0))?;
    let socket6 =
        agents.iter().any(SocketAddr::is_ipv6).then(|| UdpSocket::bind((Ipv6Addr::UNSPECIFIED, 0))).transpose()?;
    let mut request = [0u8; GET_INFO_LEN];
    let n = encode_get_info(RequestId::DISCOVERY, info_mask::CONFIGURATION | info_mask::ACTIVITY, &mut request)
        .unwrap_or(0);
    let request = request.get(..n).unwrap_or(&[]);
    let period = Duration::from_millis(u64::from(period_ms));
    let mut buf = [0u8; 1024];
    for _ in 0..attempts {
        for agent in agents {
            let s = if agent.is_ipv6() { socket6.as_ref().unwrap_or(&socket) } else { &socket };
            // An unreachable address must not end the search for the others.
            let _ = s.send_to(request, agent);
        }
        let deadline = Instant::now() + period;
        // With both sockets, each is listened to in turns of LISTEN_TURN, so answers to either arrive while
        // the period lasts (the IPv4 socket used to be read until the deadline, the IPv6 one never).
        let turn = if socket6.is_some() { LISTEN_TURN } else { period };
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            if left.is_zero() {
                break;
            }
            for s in [Some(&socket), socket6.as_ref()].into_iter().flatten() {
                s.set_read_timeout(Some(left.min(turn).max(Duration::from_millis(1))))?;
                while let Ok((len, from)) = s.recv_from(&mut buf) {
                    if found(buf.get(..len).unwrap_or(&[]), from, &mut on_agent) {
                        return Ok(true);
                    }
                    if Instant::now() >= deadline {
                        break;
                    }
                }
            }
        }
    }
    Ok(false)
}

/// Reports the agent locators of an INFO answer; whether the callback asked to stop.
fn found(msg: &[u8], from: SocketAddr, on_agent: &mut impl FnMut(SocketAddr) -> bool) -> bool {
    let Some(info) = parse_info(msg) else { return false };
    if let Some(ObjectVariant::Agent(agent)) = info.config {
        if agent.xrce_version != XRCE_VERSION {
            return false;
        }
    }
    let Some(ActivityInfo::Agent { address_seq, .. }) = info.activity else { return false };
    if address_seq.is_empty() {
        // An agent answering on its service port lists no locator: it is where the answer came from.
        return on_agent(from);
    }
    for locator in address_seq.iter().take(MAX_LOCATORS) {
        let addr = match locator {
            TransportLocator::Medium { address, port } => SocketAddr::from((address, port)),
            TransportLocator::Large { address, port } => SocketAddr::from((address, u16::try_from(port).unwrap_or(0))),
            _ => continue,
        };
        if on_agent(addr) {
            return true;
        }
    }
    false
}
