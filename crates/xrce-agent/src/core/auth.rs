//! Optional client authentication (ours; eProsima's agent has none): who may create a session.
//!
//! Off by default ([`AuthPolicy::default`]): every CREATE_CLIENT is served as eProsima's agent serves it.
//! When on (an allow-list, a pre-shared key, or both):
//! * an allow-list admits a client key (or any key) from an address, an address range, or anywhere;
//! * a pre-shared key requires the token of [`xrce_proto::auth`] in the CREATE_CLIENT property
//!   [`AUTH_PROPERTY`]; a token is good once per key (a replayed one is refused, except the repeat of the
//!   CREATE_CLIENT that created the current session, which a client resends when the reply was lost);
//! * a key whose session is bound to another address is not taken over: the CREATE_CLIENT is refused and the
//!   owner probed, so a client that rebooted onto a new port gets in once the old session is found dead;
//! * in-session messages from an address other than the session's are dropped.
//!
//! Refusals answer STATUS_AGENT with `STATUS_ERR_DENIED` and log the peer. See `docs/security.md` for the
//! threat model: nothing is encrypted, and an address is only as trustworthy as the network.

use std::collections::VecDeque;

use foldhash::{HashMap, HashMapExt, HashSet, HashSetExt};
use std::fmt::{self, Debug};
use std::hash::Hash;
use std::net::{IpAddr, SocketAddr};
use std::str::FromStr;
use std::time::Instant;

use xrce_proto::auth::{verify, AUTH_PROPERTY};
use xrce_proto::object::ClientRepresentation;
use xrce_proto::ClientKey;

use super::AgentCore;
use crate::middleware::Middleware;

/// Tokens remembered against replay (oldest forgotten first): 64 Ki × 12 bytes, about 1.5 MiB at most with
/// the set's overhead; only tokens that verified are stored, so only key holders fill it.
pub const MAX_REMEMBERED_TOKENS: usize = 65_536;

/// Who may create a session. Empty (the default): everybody.
#[derive(Clone, Default, PartialEq, Eq)]
pub struct AuthPolicy {
    /// When not empty, a CREATE_CLIENT must match one of these.
    pub allow: Vec<AllowRule>,
    /// When set, a CREATE_CLIENT must carry a token made with this key.
    pub psk: Option<Vec<u8>>,
}

impl Debug for AuthPolicy {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        // Never print the key.
        f.debug_struct("AuthPolicy")
            .field("allow", &self.allow)
            .field("psk", &self.psk.as_ref().map(|_| "set"))
            .finish()
    }
}

impl AuthPolicy {
    /// Whether any check is on.
    pub fn is_enabled(&self) -> bool {
        !self.allow.is_empty() || self.psk.is_some()
    }
}

/// One allow-list entry: `KEY[@ADDRESS]` on the command line (see [`FromStr`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct AllowRule {
    /// The client key it admits; `None`: any.
    pub key: Option<ClientKey>,
    /// Where from.
    pub from: AddressMatch,
}

/// The address part of an [`AllowRule`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AddressMatch {
    /// Any peer, addressed or not (serial lines have no address).
    Any,
    /// Exactly this IP address and port (a transport endpoint).
    Endpoint(SocketAddr),
    /// Any port of an address in this range (`ip/prefix`; a bare IP is a full-length prefix).
    Network(IpAddr, u8),
}

/// A malformed `--allow` value.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error(
    "`{value}`: {why} (expected KEY[@ADDRESS], KEY a hexadecimal client key or *, ADDRESS an IP, IP/PREFIX or IP:PORT)"
)]
pub struct AllowRuleError {
    value: String,
    why: &'static str,
}

impl FromStr for AllowRule {
    type Err = AllowRuleError;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let err = |why| AllowRuleError { value: s.to_owned(), why };
        let (key, addr) = match s.split_once('@') {
            Some((k, a)) => (k, Some(a)),
            None => (s, None),
        };
        let key = match key.trim() {
            "*" => None,
            k => {
                let hex = k.strip_prefix("0x").or_else(|| k.strip_prefix("0X")).unwrap_or(k);
                if hex.is_empty() || hex.len() > 8 {
                    return Err(err("the key has 1 to 8 hexadecimal digits"));
                }
                let raw = u32::from_str_radix(hex, 16).map_err(|_| err("the key is not hexadecimal"))?;
                Some(ClientKey::from_u32(raw))
            }
        };
        if key == Some(ClientKey::INVALID) {
            return Err(err("0 is not a valid client key"));
        }
        let from = match addr.map(str::trim) {
            None => AddressMatch::Any,
            Some(a) => parse_address(a).ok_or_else(|| err("bad address"))?,
        };
        Ok(Self { key, from })
    }
}

fn parse_address(a: &str) -> Option<AddressMatch> {
    if let Ok(ep) = a.parse::<SocketAddr>() {
        return Some(AddressMatch::Endpoint(ep));
    }
    let (ip, prefix) = match a.split_once('/') {
        Some((ip, p)) => (ip.parse::<IpAddr>().ok()?, Some(p.parse::<u8>().ok()?)),
        None => (a.parse::<IpAddr>().ok()?, None),
    };
    let max = if ip.is_ipv4() { 32 } else { 128 };
    let prefix = prefix.unwrap_or(max);
    (prefix <= max).then_some(AddressMatch::Network(ip, prefix))
}

impl AllowRule {
    /// Whether it admits `key` from `peer` (`None`: a peer without an IP address).
    pub fn admits(&self, key: ClientKey, peer: Option<SocketAddr>) -> bool {
        self.key.is_none_or(|k| k == key)
            && match (self.from, peer) {
                (AddressMatch::Any, _) => true,
                (AddressMatch::Endpoint(ep), Some(p)) => {
                    ep.ip().to_canonical() == p.ip().to_canonical() && ep.port() == p.port()
                }
                (AddressMatch::Network(net, prefix), Some(p)) => in_network(p.ip().to_canonical(), net, prefix),
                (_, None) => false,
            }
    }
}

fn in_network(ip: IpAddr, net: IpAddr, prefix: u8) -> bool {
    let mask = |bits: u32, prefix: u8| -> u128 {
        let prefix = u32::from(prefix).min(bits);
        if prefix == 0 {
            0
        } else {
            (u128::MAX << (128 - prefix)) >> (128 - bits)
        }
    };
    match (ip, net) {
        (IpAddr::V4(a), IpAddr::V4(n)) => {
            let m = mask(32, prefix);
            u128::from(u32::from(a)) & m == u128::from(u32::from(n)) & m
        }
        (IpAddr::V6(a), IpAddr::V6(n)) => {
            let m = mask(128, prefix);
            u128::from(a) & m == u128::from(n) & m
        }
        _ => false,
    }
}

/// Why a CREATE_CLIENT was refused.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum Denied {
    /// No allow-list entry matches.
    #[error("client key not allowed from this address")]
    NotAllowed,
    /// A pre-shared key is required and the property is absent (an eProsima client, say).
    #[error("no authentication token (property `xrce_rs_auth`): a pre-shared key is required")]
    NoToken,
    /// The token is malformed or made with another key.
    #[error("{0}")]
    BadToken(xrce_proto::auth::TokenError),
    /// The token was used before.
    #[error("authentication token replayed")]
    Replayed,
    /// The key's session belongs to another address, which is being probed.
    #[error("client key in use from another address")]
    KeyInUse,
}

/// The endpoint's authentication state: how to get a peer's address, and the tokens seen.
#[derive(Debug)]
pub(super) struct Gate<E> {
    /// A peer's IP address and port, if the transport has them.
    pub peer_address: fn(&E) -> Option<SocketAddr>,
    seen: HashSet<(ClientKey, u64)>,
    order: VecDeque<(ClientKey, u64)>,
    /// The nonce of the token that created each key's current session.
    current: HashMap<ClientKey, u64>,
}

impl<E> Default for Gate<E> {
    fn default() -> Self {
        Self { peer_address: |_| None, seen: HashSet::new(), order: VecDeque::new(), current: HashMap::new() }
    }
}

impl<E> Gate<E> {
    fn remember(&mut self, key: ClientKey, nonce: u64) {
        if self.seen.insert((key, nonce)) {
            self.order.push_back((key, nonce));
        }
        while self.order.len() > MAX_REMEMBERED_TOKENS {
            if let Some(old) = self.order.pop_front() {
                self.seen.remove(&old);
            }
        }
        self.current.insert(key, nonce);
    }
}

impl<E, M> AgentCore<E, M>
where
    E: Copy + Eq + Hash + Debug,
    M: Middleware,
{
    /// Tells the core how to read a peer's IP address and port, for the allow-list's address rules (the
    /// UDP and TCP shells set it; without it only rules without an address match).
    pub fn set_peer_address(&mut self, peer_address: fn(&E) -> Option<SocketAddr>) {
        self.auth.peer_address = peer_address;
    }

    /// Checks a CREATE_CLIENT against the policy; `Ok(Some(nonce))` when a token was checked (to remember
    /// once the session exists, with [`Self::accept_token`]).
    pub(super) fn authorize(
        &mut self,
        from: E,
        rep: &ClientRepresentation<'_>,
        now: Instant,
    ) -> Result<Option<u64>, Denied> {
        let policy = &self.config.auth;
        if !policy.is_enabled() {
            return Ok(None);
        }
        let key = rep.client_key;
        let peer = (self.auth.peer_address)(&from);
        if !policy.allow.is_empty() && !policy.allow.iter().any(|r| r.admits(key, peer)) {
            return Err(Denied::NotAllowed);
        }
        let nonce = match &policy.psk {
            None => None,
            Some(psk) => {
                let token = rep.property(AUTH_PROPERTY).ok_or(Denied::NoToken)?;
                let nonce = verify(psk, key, rep.session_id, token).map_err(Denied::BadToken)?;
                Some(nonce)
            }
        };
        let owner = self.clients.get(&key).map(|c| (c.endpoint, c.session_id));
        if let Some(nonce) = nonce {
            let repeat = self.auth.current.get(&key) == Some(&nonce) && owner == Some((Some(from), rep.session_id));
            if self.auth.seen.contains(&(key, nonce)) && !repeat {
                return Err(Denied::Replayed);
            }
        }
        if let Some((Some(owner_ep), _)) = owner {
            if owner_ep != from {
                self.suspect(key, now);
                return Err(Denied::KeyInUse);
            }
        }
        Ok(nonce)
    }

    /// Remembers the token of a session just created.
    pub(super) fn accept_token(&mut self, key: ClientKey, nonce: u64) {
        self.auth.remember(key, nonce);
        if self.auth.current.len() > 2 * self.clients.len() + 1024 {
            let clients = &self.clients;
            self.auth.current.retain(|k, _| clients.contains_key(k));
        }
    }

    /// Whether an in-session message from `from` for `key` is refused: with authentication on, only the
    /// session's own address speaks for it.
    pub(super) fn foreign_sender(&self, key: ClientKey, from: E) -> bool {
        self.config.auth.is_enabled() && self.clients.get(&key).and_then(|c| c.endpoint).is_some_and(|ep| ep != from)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rule(s: &str) -> AllowRule {
        s.parse().unwrap_or_else(|e| panic!("{e}"))
    }

    const KEY: ClientKey = ClientKey([0xAA, 0xBB, 0xCC, 0xDD]);

    fn at(s: &str) -> Option<SocketAddr> {
        Some(s.parse().expect("address"))
    }

    #[test]
    fn allow_rules_parse_and_match() {
        assert_eq!(rule("0xAABBCCDD"), AllowRule { key: Some(KEY), from: AddressMatch::Any });
        assert_eq!(rule("aabbccdd").key, Some(KEY));
        assert_eq!(rule("*@10.0.0.0/8").key, None);
        assert!(rule("aabbccdd@192.168.1.0/24").admits(KEY, at("192.168.1.77:5000")));
        assert!(!rule("aabbccdd@192.168.1.0/24").admits(KEY, at("192.168.2.77:5000")));
        assert!(!rule("aabbccdd@192.168.1.0/24").admits(ClientKey::from_u32(1), at("192.168.1.77:5000")));
        assert!(!rule("aabbccdd@192.168.1.0/24").admits(KEY, None), "a serial peer has no address");
        assert!(rule("aabbccdd").admits(KEY, None));
        assert!(rule("*@127.0.0.1:7000").admits(KEY, at("127.0.0.1:7000")));
        assert!(!rule("*@127.0.0.1:7000").admits(KEY, at("127.0.0.1:7001")));
        assert!(rule("*@127.0.0.1").admits(KEY, at("127.0.0.1:9")));
        assert!(rule("*@127.0.0.1").admits(KEY, at("[::ffff:127.0.0.1]:9")), "IPv4-mapped IPv6 peers");
        assert!(rule("*@fd00::/8").admits(KEY, at("[fd12::1]:9")));
        assert!(!rule("*@fd00::/8").admits(KEY, at("[fe80::1]:9")));
        assert!(rule("*@0.0.0.0/0").admits(KEY, at("8.8.8.8:1")));
        for bad in ["", "0x", "123456789", "zz", "0", "*@", "*@10.0.0.0/33", "*@host", "*@1.2.3.4/x"] {
            assert!(bad.parse::<AllowRule>().is_err(), "{bad}");
        }
    }

    #[test]
    fn the_policy_never_prints_its_key() {
        let p = AuthPolicy { allow: vec![], psk: Some(b"hunter2".to_vec()) };
        assert!(p.is_enabled());
        assert!(!format!("{p:?}").contains("hunter2"));
        assert!(!AuthPolicy::default().is_enabled());
    }
}
