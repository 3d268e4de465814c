//! The endpoint's side of sessions: a datagram routed to its client by key or address, CREATE_CLIENT
//! (spec §10.2), GET_INFO outside a session, messages for unknown sessions (spec §10.3), the client table's
//! bound.

use std::fmt::Debug;
use std::hash::Hash;
use std::time::Instant;

use xrce_proto::object::{AgentRepresentation, ClientRepresentation};
use xrce_proto::submessage::StatusAgent;
use xrce_proto::{
    BaseObjectReply, ClientKey, MessageHeader, ObjectId, ResultStatus, StatusCode, StreamId, Submessage, XRCE_COOKIE,
};

use super::connection::Connection;
use super::input::{info_reply, parse_submessages};
use super::session::{parse_hard_liveliness, PACK_PROPERTY, RESUME_PROPERTY};
use super::stats::{self, DropReason, RemoveReason};
use super::{encode_message, AgentCore, Transmit};
use crate::middleware::Middleware;

impl<E, M> AgentCore<E, M>
where
    E: Copy + Eq + Hash + Debug,
    M: Middleware,
{
    fn drop_datagram(&mut self, reason: DropReason) {
        self.stats.drop_datagram(reason);
    }

    /// Queues a reply to a peer outside any session; beyond the transmit bound it is dropped.
    fn push_stateless(&mut self, to: E, data: Vec<u8>) {
        if self.stateless.len() >= self.config.max_transmit_queue {
            self.stats.messages_dropped_out = self.stats.messages_dropped_out.saturating_add(1);
            return;
        }
        self.stats.messages_out = self.stats.messages_out.saturating_add(1);
        self.stateless.push_back(Transmit { to, data });
    }

    /// Decodes the header and hands the message to its client (or answers outside a session).
    pub(super) fn route_datagram(&mut self, from: E, bytes: &[u8], now: Instant) {
        let header = match MessageHeader::decode(bytes) {
            Ok((h, _)) => h,
            Err(e) => {
                if let Some(held_back) = self.drop_log.admit(from, now) {
                    tracing::warn!(peer = ?from, len = bytes.len(), held_back, "dropping message: bad header: {e}");
                }
                self.drop_datagram(DropReason::BadHeader);
                return;
            }
        };
        if header.session_id == xrce_proto::SESSION_ID_NONE_WITH_KEY
            || header.session_id == xrce_proto::SESSION_ID_NONE_WITHOUT_KEY
        {
            self.out_of_session(from, &header, bytes, now);
            return;
        }
        let Some(key) = header.client_key.or_else(|| self.by_endpoint.get(&from).copied()) else {
            self.unknown_client(from, &header, bytes);
            return;
        };
        if self.foreign_sender(key, from) {
            if let Some(held_back) = self.drop_log.admit(from, now) {
                tracing::warn!(peer = ?from, client = %key, held_back, "dropping message: authentication is on and this session belongs to another address");
            }
            self.drop_datagram(DropReason::ForeignSender);
            return;
        }
        let (mut ctx, client) = self.ctx_for(key);
        let Some(client) = client else {
            self.unknown_client(from, &header, bytes);
            return;
        };
        client.handle_message(&mut ctx, from, &header, bytes, now);
        let (writes, retry) = (ctx.writes, ctx.retry);
        let delete = client.take_delete_request();
        // Readers are served at the end of the batch (or sooner past PUMP_AFTER_WRITES).
        self.unserved_writes = Some(self.unserved_writes.unwrap_or(0).saturating_add(writes));
        if let Some((request, header)) = delete {
            let to = self.clients.get(&key).and_then(|c| c.endpoint);
            let status = if self.remove_client(key, RemoveReason::Deleted) {
                StatusCode::OK
            } else {
                StatusCode::ERR_UNKNOWN_REFERENCE
            };
            // The client is gone: answer with its header, on stream 0, to where it was.
            let reply = BaseObjectReply { related_request: request, result: ResultStatus::new(status) };
            let h = MessageHeader { stream_id: StreamId::NONE, sequence_nr: 0, ..header };
            if let (Some(to), Some(m)) = (to, encode_message(&h, &Submessage::Status(reply))) {
                self.push_stateless(to, m);
            }
            return;
        }
        self.after_turn(key, retry);
    }

    /// CREATE_CLIENT and GET_INFO outside a session (header session id 0x00 or 0x80).
    fn out_of_session(&mut self, from: E, header: &MessageHeader, bytes: &[u8], now: Instant) {
        for raw in parse_submessages(bytes, header) {
            let decoded = match raw.decode() {
                Ok(d) => d,
                Err(e) => {
                    if let Some(held_back) = self.drop_log.admit(from, now) {
                        tracing::warn!(peer = ?from, id = raw.header.id, held_back, "dropping submessage: {e}");
                    }
                    self.stats.decode_errors = self.stats.decode_errors.saturating_add(1);
                    break;
                }
            };
            match decoded {
                Submessage::CreateClient(rep) => self.handle_create_client(from, header, &rep, now),
                Submessage::GetInfo(get) => {
                    let known = self.by_endpoint.contains_key(&from)
                        || header
                            .client_key
                            .and_then(|k| self.clients.get(&k))
                            .is_some_and(|c| c.endpoint == Some(from));
                    let reply = info_reply(&get, u8::from(known));
                    if let Some(msg) = encode_message(header, &Submessage::Info(reply)) {
                        self.push_stateless(from, msg);
                    }
                }
                other => {
                    tracing::debug!(peer = ?from, id = other.id(), "submessage outside a session ignored");
                    break;
                }
            }
        }
    }

    /// A message for a session the agent does not know (spec §10.3).
    fn unknown_client(&mut self, from: E, header: &MessageHeader, bytes: &[u8]) {
        let mut answered = false;
        for raw in parse_submessages(bytes, header) {
            let h = MessageHeader { stream_id: StreamId::NONE, sequence_nr: 0, ..*header };
            let reply = match raw.decode() {
                Ok(Submessage::Delete(req)) if req.object_id == ObjectId::CLIENT => {
                    Submessage::Status(BaseObjectReply {
                        related_request: req,
                        result: ResultStatus::new(StatusCode::OK),
                    })
                }
                Ok(Submessage::GetInfo(get)) => Submessage::Info(info_reply(&get, 0)),
                _ => break,
            };
            if let Some(msg) = encode_message(&h, &reply) {
                self.push_stateless(from, msg);
            }
            answered = true;
        }
        if !answered {
            tracing::debug!(peer = ?from, session = header.session_id, "message for an unknown session dropped");
            self.drop_datagram(DropReason::UnknownClient);
        }
    }

    fn handle_create_client(&mut self, from: E, header: &MessageHeader, rep: &ClientRepresentation<'_>, now: Instant) {
        let status = match self.authorize(from, rep, now) {
            Ok(token) => {
                let status = self.register_client(Some(from), rep.client_key, rep.session_id, rep.mtu, Some(rep), now);
                if status.is_ok() {
                    tracing::info!(peer = ?from, client = %rep.client_key, session = rep.session_id, mtu = rep.mtu, "session established");
                    if let Some(nonce) = token {
                        self.accept_token(rep.client_key, nonce);
                    }
                    self.suspect_endpoint_peers(from, rep.client_key, rep.session_id, now);
                } else {
                    if let Some(held_back) = self.drop_log.admit(from, now) {
                        tracing::warn!(peer = ?from, client = %rep.client_key, status = status.name(), held_back, "CREATE_CLIENT refused");
                    }
                }
                status
            }
            Err(why) => {
                stats::bump(&mut self.stats.auth_refusals);
                if let Some(held_back) = self.drop_log.admit(from, now) {
                    tracing::warn!(peer = ?from, client = %rep.client_key, held_back, "CREATE_CLIENT refused (STATUS_ERR_DENIED): {why}");
                }
                StatusCode::ERR_DENIED
            }
        };
        let key = header.client_key.unwrap_or(rep.client_key);
        let reply_header = MessageHeader::new(rep.session_id, StreamId::NONE, 0, key);
        let reply = StatusAgent { result: ResultStatus::new(status), agent: AgentRepresentation::EPROSIMA };
        if let Some(msg) = encode_message(&reply_header, &Submessage::StatusAgent(reply)) {
            self.push_stateless(from, msg);
        }
    }

    /// CREATE_CLIENT semantics (spec §10.2), shared with the library API (`from` = None).
    pub(super) fn register_client(
        &mut self,
        from: Option<E>,
        key: ClientKey,
        session_id: u8,
        mtu: u16,
        rep: Option<&ClientRepresentation<'_>>,
        now: Instant,
    ) -> StatusCode {
        // An endpoint speaks for one client: a new key from it replaces the old client.
        if let Some(ep) = from {
            if let Some(old) = self.by_endpoint.get(&ep).copied().filter(|old| *old != key) {
                self.remove_client(old, RemoveReason::Replaced);
            }
        }
        if key == ClientKey::INVALID {
            return StatusCode::ERR_INVALID_DATA;
        }
        if let Some(rep) = rep {
            if rep.xrce_cookie != XRCE_COOKIE {
                return StatusCode::ERR_INVALID_DATA;
            }
            if rep.xrce_version[0] != xrce_proto::XRCE_VERSION[0] {
                return StatusCode::ERR_INCOMPATIBLE;
            }
        }
        if mtu < self.config.min_mtu {
            return StatusCode::ERR_INVALID_DATA;
        }
        let mtu = usize::from(mtu.min(self.config.max_mtu));
        let resume = rep.is_some_and(|r| r.property(RESUME_PROPERTY) == Some("1"));
        let mut status = StatusCode::OK;
        match self.clients.get_mut(&key) {
            Some(client) if client.session_id == session_id => {
                if resume && client.mtu == mtu {
                    // Our client coming back after losing its link: same streams, from a new endpoint.
                    status = StatusCode::OK_MATCHED;
                } else {
                    client.reset_streams();
                }
                client.mtu = mtu;
                client.last_heard = now;
                client.probes = 0;
            }
            existing => {
                if existing.is_some() {
                    self.remove_client(key, RemoveReason::Replaced);
                } else if self.clients.len() >= self.config.max_clients && !self.evict_dead_client(now) {
                    return StatusCode::ERR_RESOURCES;
                }
                let mut client = Connection::new(key, session_id, mtu, from, now);
                client.pack_data = self.config.pack_data;
                if let Some(rep) = rep {
                    client.hard_liveliness = rep.property("uxr_hl").and_then(parse_hard_liveliness);
                    client.shared_memory = rep.property("uxr_sm") == Some("1");
                    client.pack_data |= rep.property(PACK_PROPERTY) == Some("1");
                }
                client.start_watch(&self.config, now, from.is_none());
                self.clients.insert(key, Box::new(client));
                stats::bump(&mut self.stats.clients_created);
                self.schedule(key);
            }
        }
        if let Some(ep) = from {
            if let Some(client) = self.clients.get_mut(&key) {
                if let Some(old) = client.endpoint.replace(ep) {
                    if old != ep && self.by_endpoint.get(&old) == Some(&key) {
                        self.by_endpoint.remove(&old);
                    }
                }
            }
            if !xrce_proto::session_has_key(session_id) {
                self.by_endpoint.insert(ep, key);
            }
        }
        status
    }

    /// Makes room in a full client table by removing the client silent the longest, if it is dead.
    fn evict_dead_client(&mut self, now: Instant) -> bool {
        let dead_time = self.config.client_dead_time;
        let victim =
            self.clients.values().filter(|c| c.is_dead(now, dead_time)).min_by_key(|c| c.last_heard).map(|c| c.key);
        victim.is_some_and(|k| self.remove_client(k, RemoveReason::Evicted))
    }
}
