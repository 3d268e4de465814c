//! Pinging an agent outside any session (`uxr_ping_agent`, `uxr_ping_agent_attempts`, spec §14.2) and reading
//! INFO answers, which discovery also needs.

use crate::error::Result;
use crate::transport::Transport;
use xrce_proto::message::{encode_single_bytes_opt, parse};
use xrce_proto::submessage::{id, info_mask, FromAgent, GetInfo, Info};
use xrce_proto::{
    BaseObjectRequest, ClientKey, MessageHeader, ObjectId, RequestId, StreamId, Submessage, SESSION_ID_NONE_WITHOUT_KEY,
};

/// Size of a GET_INFO message without session.
pub const GET_INFO_LEN: usize = 16;

/// Writes the out-of-session GET_INFO with `request_id` and `mask` (ping: 10 and ACTIVITY; discovery: 9 and
/// CONFIGURATION | ACTIVITY) into `out`; its length.
pub fn encode_get_info(request_id: RequestId, mask: u32, out: &mut [u8]) -> Option<usize> {
    let header = MessageHeader::new(SESSION_ID_NONE_WITHOUT_KEY, StreamId::NONE, 0, ClientKey::INVALID);
    let get = GetInfo { request: BaseObjectRequest { request_id, object_id: ObjectId::AGENT }, info_mask: mask };
    encode_single_bytes_opt(out, &header, id::GET_INFO, &get.to_le_bytes())
}

/// The INFO carried first in `msg`, if it is one.
pub fn parse_info(msg: &[u8]) -> Option<Info<'_>> {
    let (_, mut subs) = parse(msg).ok()?;
    match subs.next()?.ok()?.decode().ok()? {
        Submessage::Info(info) => Some(info),
        _ => None,
    }
}

/// Whether `msg` is a pong: its first submessage an INFO whose activity says the agent is available (the
/// header is not checked, as in the C client). Read with the client's lean decoder ([`FromAgent`]), so a
/// firmware that pings carries no decoder of the agent's configuration or locators.
pub fn is_pong(msg: &[u8]) -> bool {
    let first = parse(msg).ok().and_then(|(_, mut subs)| subs.next()?.ok()?.decode_from_agent().ok());
    matches!(first, Some(FromAgent::Info { availability: Some(a), .. }) if a > 0)
}

/// `uxr_ping_agent`: one GET_INFO, then waits up to `timeout_ms` for the pong.
pub fn ping_agent<T: Transport + ?Sized>(transport: &mut T, timeout_ms: i32) -> Result<bool> {
    ping_agent_attempts(transport, timeout_ms, 1)
}

/// `uxr_ping_agent_attempts`: up to `attempts` GET_INFO, waiting up to `timeout_ms` after each. Anything else
/// that arrives meanwhile is dropped (as in the C client, the ping acts on the bare transport).
pub fn ping_agent_attempts<T: Transport + ?Sized>(transport: &mut T, timeout_ms: i32, attempts: u8) -> Result<bool> {
    let mut msg = [0u8; GET_INFO_LEN];
    let n = encode_get_info(RequestId::PING, info_mask::ACTIVITY, &mut msg).unwrap_or(0);
    let mut buf = [0u8; 512];
    for _ in 0..attempts {
        transport.send(msg.get(..n).unwrap_or(&[]))?;
        // A few unrelated messages may be in flight; each read waits the whole timeout at most.
        for _ in 0..8 {
            match transport.recv(&mut buf, timeout_ms)? {
                Some(len) if is_pong(buf.get(..len).unwrap_or(&[])) => return Ok(true),
                Some(_) => {}
                None => break,
            }
        }
    }
    Ok(false)
}
