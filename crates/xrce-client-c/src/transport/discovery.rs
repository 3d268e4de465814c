//! Agent discovery (`uxr_discovery_agents*`) and the locator helpers.

use core::ffi::{c_char, c_void};
use std::net::{IpAddr, Ipv4Addr, Ipv6Addr, SocketAddr};

use xrce_client::transport::discovery;

use crate::entities::text;
use crate::types::{TransportLocator, ADDRESS_FORMAT_LARGE, ADDRESS_FORMAT_MEDIUM};

type OnAgentFound = Option<unsafe extern "C" fn(*const TransportLocator, *mut c_void) -> bool>;

fn locator(addr: SocketAddr) -> TransportLocator {
    match addr.ip() {
        IpAddr::V4(ip) => TransportLocator::medium(ip.octets(), addr.port()),
        IpAddr::V6(ip) => TransportLocator::large(ip.octets(), addr.port()),
    }
}

fn address(l: &TransportLocator) -> Option<SocketAddr> {
    match l.format {
        ADDRESS_FORMAT_MEDIUM => {
            // SAFETY: `format` says the medium member is the one written (the program's promise, as in C);
            // every bit pattern is a valid value of it.
            let m = unsafe { l._u.medium_locator };
            Some(SocketAddr::new(IpAddr::V4(Ipv4Addr::from(m.address)), m.locator_port))
        }
        ADDRESS_FORMAT_LARGE => {
            // SAFETY: as above, the large member.
            let m = unsafe { l._u.large_locator };
            let port = u16::try_from(m.locator_port).ok()?;
            Some(SocketAddr::new(IpAddr::V6(Ipv6Addr::from(m.address)), port))
        }
        _ => None,
    }
}

/// Runs discovery towards `agents` (the multicast group when empty), calling `on_agent` for each agent found.
fn discover(attempts: u32, period: i32, on_agent: OnAgentFound, args: *mut c_void, agents: &[SocketAddr]) -> bool {
    let Some(f) = on_agent else { return false };
    let period = u32::try_from(period).unwrap_or(0);
    let found = |addr: SocketAddr| {
        let l = locator(addr);
        // SAFETY: the program's callback with its own args; `l` lives for the call.
        unsafe { f(&l, args) }
    };
    let result = if agents.is_empty() {
        discovery::discovery_agents_default(attempts, period, found)
    } else {
        discovery::discovery_agents(attempts, period, found, agents)
    };
    result.unwrap_or(false)
}

/// `uxr_discovery_agents_default`: multicast to 239.255.0.2:7400; whether the callback stopped the search.
///
/// # Safety
/// `on_agent_func` null or a function taking `args`.
#[no_mangle]
pub unsafe extern "C" fn uxr_discovery_agents_default(
    attempts: u32,
    period: i32,
    on_agent_func: OnAgentFound,
    args: *mut c_void,
) -> bool {
    discover(attempts, period, on_agent_func, args, &[])
}

/// `uxr_discovery_agents`: towards each locator of `agent_list`.
///
/// # Safety
/// As [`uxr_discovery_agents_default`]; `agent_list` null or `agent_list_size` readable locators.
#[no_mangle]
pub unsafe extern "C" fn uxr_discovery_agents(
    attempts: u32,
    period: i32,
    on_agent_func: OnAgentFound,
    args: *mut c_void,
    agent_list: *const TransportLocator,
    agent_list_size: usize,
) -> bool {
    if agent_list.is_null() || agent_list_size == 0 {
        return false;
    }
    // SAFETY: contract.
    let list = unsafe { core::slice::from_raw_parts(agent_list, agent_list_size) };
    let agents: Vec<SocketAddr> = list.iter().filter_map(address).collect();
    !agents.is_empty() && discover(attempts, period, on_agent_func, args, &agents)
}

/// `uxr_ip_to_locator`.
///
/// # Safety
/// `ip` null or NUL-terminated; `locator` null or writable.
#[no_mangle]
pub unsafe extern "C" fn uxr_ip_to_locator(
    ip: *const c_char,
    port: u16,
    ip_protocol: u32,
    locator_out: *mut TransportLocator,
) -> bool {
    // SAFETY: contract.
    let (Some(ip), Some(out)) = (unsafe { (text(ip), locator_out.as_mut()) }) else { return false };
    let parsed: Option<IpAddr> = match ip_protocol {
        0 => ip.parse::<Ipv4Addr>().ok().map(IpAddr::V4),
        1 => ip.parse::<Ipv6Addr>().ok().map(IpAddr::V6),
        _ => None,
    };
    parsed.map(|ip| *out = locator(SocketAddr::new(ip, port))).is_some()
}

/// `uxr_locator_to_ip`: the address as text into `ip` (`size` bytes with the NUL), its port and protocol.
///
/// # Safety
/// `locator` null or readable; `ip` null or `size` writable bytes; `port` and `ip_protocol` null or writable.
#[no_mangle]
pub unsafe extern "C" fn uxr_locator_to_ip(
    locator_in: *const TransportLocator,
    ip: *mut c_char,
    size: usize,
    port: *mut u16,
    ip_protocol: *mut u32,
) -> bool {
    // SAFETY: contract.
    let Some(addr) = unsafe { locator_in.as_ref() }.and_then(address) else { return false };
    let text = addr.ip().to_string();
    if ip.is_null() || text.len() >= size {
        return false;
    }
    // SAFETY: `ip` has room for `size > text.len()` bytes (contract): the text and its NUL.
    unsafe {
        core::ptr::copy_nonoverlapping(text.as_ptr(), ip.cast::<u8>(), text.len());
        ip.add(text.len()).write(0);
    }
    // SAFETY: contract.
    if let Some(p) = unsafe { port.as_mut() } {
        *p = addr.port();
    }
    // SAFETY: contract.
    if let Some(p) = unsafe { ip_protocol.as_mut() } {
        *p = u32::from(addr.is_ipv6());
    }
    true
}
