//! The session: a sans-IO core ([`SessionCore`]) and, over a [`Transport`](crate::transport::Transport), the
//! blocking [`Session`] with the `run_session_*` family of the C API.
//!
//! The core never touches a socket or a clock. Bytes come in through [`SessionCore::handle_input`] with the
//! current time, bytes go out through [`SessionCore::poll_transmit`], timers are reported by
//! [`SessionCore::poll_timeout`], and what the agent says reaches a [`Callbacks`] implementation. Time is
//! nanoseconds since the Unix epoch (the value time synchronisation needs); only differences are used for timers.

mod blocking;
mod liveness;
mod outputs;
pub mod ping;
#[cfg(feature = "std")]
mod replay;

#[cfg(feature = "std")]
pub use blocking::StdClock;
pub use blocking::{Clock, Session};
pub use liveness::{Reconnect, SessionEvent};
pub use outputs::{Outputs, Prepared, ServiceNames};

use crate::error::{Error, Result};
use crate::stream::input_reliable_ready as ready;
use crate::stream::{InputBestEffort, InputReliable, OutputBestEffort, OutputReliable, Received};
use outputs::FIRST_REQUEST_ID;
use xrce_proto::message::{encode_single_bytes_opt, encode_single_kind, Submessages};
use xrce_proto::object::ClientRepresentation;
use xrce_proto::submessage::{id, info_mask, AckNack, DataFormat, FromAgent, GetInfo, Heartbeat};
use xrce_proto::{
    is_session_none, session_none_for, BaseObjectReply, BaseObjectRequest, ClientKey, MessageHeader, ObjectId,
    ObjectKind, RequestId, ResultStatus, SampleIdentity, StatusCode, StreamId, StreamKind, Time,
};

/// One millisecond in the core's time unit.
pub const MILLIS: i64 = 1_000_000;

/// `ns / MILLIS` (rounded toward zero) without a 64-bit division (see [`xrce_proto::reliable::div_trunc_pow1000`]).
pub(crate) const fn millis(ns: i64) -> i64 {
    xrce_proto::reliable::div_trunc_pow1000(ns, 2)
}
/// `UXR_CONFIG_MAX_SESSION_CONNECTION_ATTEMPTS`.
pub const CREATE_SESSION_ATTEMPTS: usize = 10;
/// `UXR_CONFIG_MIN_SESSION_CONNECTION_INTERVAL`, in milliseconds.
pub const SESSION_CONNECTION_INTERVAL_MS: i64 = 1000;
/// Default session id of the C client (no key in the header).
pub const DEFAULT_SESSION_ID: u8 = 0x81;
/// Default MTU of every C client transport but CAN.
pub const DEFAULT_MTU: usize = 512;

/// CREATE_CLIENT property asking our agent to pack several DATA per message (see
/// [`SessionCore::set_packed_input`]).
pub const PACK_PROPERTY: &str = "xrce_rs_pack";

const PACK_PROPERTIES: [xrce_proto::Property<'static>; 1] = [xrce_proto::Property { name: PACK_PROPERTY, value: "1" }];

/// CREATE_CLIENT property of a re-creation during reconnection: our agent, if it still holds the session,
/// keeps its streams and answers `STATUS_OK_MATCHED` (the session resumes, nothing is delivered twice);
/// others ignore it.
pub const RESUME_PROPERTY: &str = "xrce_rs_resume";

/// What the agent said, delivered while input is processed. Every method has a do-nothing default; `out`
/// lets a callback write into the output streams (a replier answering from `on_request`, say).
pub trait Callbacks {
    /// A STATUS for `request_id` (`uxrOnStatusFunc`); `status` is one of the `STATUS_*` values.
    fn on_status(&mut self, out: &mut Outputs<'_, '_>, object_id: ObjectId, request_id: u16, status: u8) {
        let _ = (out, object_id, request_id, status);
    }

    /// A sample for datareader `object_id`, from the READ_DATA `request_id` (`uxrOnTopicFunc`).
    fn on_topic(
        &mut self,
        out: &mut Outputs<'_, '_>,
        object_id: ObjectId,
        request_id: u16,
        stream_id: StreamId,
        data: &[u8],
    ) {
        let _ = (out, object_id, request_id, stream_id, data);
    }

    /// A request for replier `object_id` (`uxrOnRequestFunc`); answer with `out.buffer_reply(.., sample_id, ..)`.
    fn on_request(
        &mut self,
        out: &mut Outputs<'_, '_>,
        object_id: ObjectId,
        request_id: u16,
        sample_id: &SampleIdentity,
        data: &[u8],
    ) {
        let _ = (out, object_id, request_id, sample_id, data);
    }

    /// A reply for requester `object_id` to the request `reply_id` (`uxrOnReplyFunc`).
    fn on_reply(
        &mut self,
        out: &mut Outputs<'_, '_>,
        object_id: ObjectId,
        request_id: u16,
        reply_id: u16,
        data: &[u8],
    ) {
        let _ = (out, object_id, request_id, reply_id, data);
    }

    /// A time-synchronisation answer (`uxrOnTimeFunc`). Return `true` to take over the computation: the session
    /// then leaves its clock offset alone, as the C client does when a time callback is set.
    fn on_time(&mut self, sample: &TimeSample) -> bool {
        let _ = sample;
        false
    }

    /// The agent answered a ping and is available (an INFO with agent activity), whether or not this session
    /// asked; `in_session` when it knows this session (eProsima's `on_pong_flag`).
    fn on_pong(&mut self, in_session: bool) {
        let _ = in_session;
    }

    /// Bookkeeping hook: a request got a status (STATUS, or `STATUS_OK` for each DATA answering a READ_DATA).
    /// The blocking session uses it for `run_session_until_*_status`.
    fn on_request_status(&mut self, request_id: u16, status: u8) {
        let _ = (request_id, status);
    }

    /// The agent stopped answering (or lost the session); the blocking [`Session`] is reconnecting. Writes
    /// still go into the streams: reliable ones keep them (until their history is full), best-effort ones drop
    /// them.
    fn on_session_lost(&mut self) {}

    /// The session works again; `recreated` when the agent had lost it and the blocking [`Session`] created it
    /// again with its entities and reads (see [`SessionEvent::Restored`]).
    fn on_session_restored(&mut self, recreated: bool) {
        let _ = recreated;
    }
}

impl Callbacks for () {}

impl<T: Callbacks + ?Sized> Callbacks for &mut T {
    fn on_status(&mut self, out: &mut Outputs<'_, '_>, object_id: ObjectId, request_id: u16, status: u8) {
        (**self).on_status(out, object_id, request_id, status);
    }
    fn on_topic(
        &mut self,
        out: &mut Outputs<'_, '_>,
        object_id: ObjectId,
        request_id: u16,
        stream_id: StreamId,
        data: &[u8],
    ) {
        (**self).on_topic(out, object_id, request_id, stream_id, data);
    }
    fn on_request(
        &mut self,
        out: &mut Outputs<'_, '_>,
        object_id: ObjectId,
        request_id: u16,
        sample_id: &SampleIdentity,
        data: &[u8],
    ) {
        (**self).on_request(out, object_id, request_id, sample_id, data);
    }
    fn on_reply(
        &mut self,
        out: &mut Outputs<'_, '_>,
        object_id: ObjectId,
        request_id: u16,
        reply_id: u16,
        data: &[u8],
    ) {
        (**self).on_reply(out, object_id, request_id, reply_id, data);
    }
    fn on_time(&mut self, sample: &TimeSample) -> bool {
        (**self).on_time(sample)
    }
    fn on_pong(&mut self, in_session: bool) {
        (**self).on_pong(in_session);
    }
    fn on_request_status(&mut self, request_id: u16, status: u8) {
        (**self).on_request_status(request_id, status);
    }
    fn on_session_lost(&mut self) {
        (**self).on_session_lost();
    }
    fn on_session_restored(&mut self, recreated: bool) {
        (**self).on_session_restored(recreated);
    }
}

/// The four timestamps of a time-synchronisation exchange, nanoseconds since the epoch.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TimeSample {
    /// Client clock when the answer arrived.
    pub current: i64,
    /// Agent clock when it answered.
    pub transmit: i64,
    /// Agent clock when it received the request.
    pub received: i64,
    /// Client clock when the request left (echoed by the agent).
    pub originate: i64,
}

impl TimeSample {
    /// NTP offset, client minus agent: `((t0 + t3) - (t1 + t2)) / 2`, truncated toward zero like C.
    pub const fn offset(&self) -> i64 {
        let twice = (self.originate + self.current) - (self.received + self.transmit);
        // `twice / 2` as a shift (1 added to a negative odd value): LLVM's `-Oz` calls the 64-bit division.
        (twice - (twice >> 63)) >> 1
    }
}

/// Where the session is in its life.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SessionState {
    /// Not created yet.
    Idle,
    /// CREATE_CLIENT sent, waiting for STATUS_AGENT.
    Creating,
    /// The agent accepted the session.
    Established,
    /// The agent refused the session with this status.
    Refused(u8),
    /// No STATUS_AGENT after every attempt.
    CreateTimedOut,
    /// DELETE of the client sent, waiting for its STATUS.
    Deleting,
    /// The agent confirmed the deletion (or every attempt went unanswered).
    Deleted,
    /// The agent stopped answering; reconnection attempts are under way (see [`Reconnect`]).
    Reconnecting,
}

/// Progress of an in-session ping.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PingState {
    /// No ping asked.
    Idle,
    /// Waiting for the pong.
    Pending,
    /// The agent answered and knows this session.
    Answered,
    /// No valid answer after every attempt.
    Failed,
}

#[derive(Debug, Clone, Copy)]
struct Retry {
    attempts_left: usize,
    next: i64,
    period: i64,
}

impl Retry {
    /// Whether to send now; `None` when attempts are exhausted and the last wait is over.
    // Always inlined at its two callers (firmware size).
    #[inline(always)]
    fn due(&mut self, now: i64) -> Option<bool> {
        if now < self.next {
            return Some(false);
        }
        if self.attempts_left == 0 {
            return None;
        }
        self.attempts_left -= 1;
        self.next = now + self.period;
        Some(true)
    }
}

/// Everything but the reliable input streams, so a stored message can be processed while the rest changes.
#[derive(Debug)]
struct State<'a, const OBE: usize, const ORE: usize, const IBE: usize> {
    session_id: u8,
    key: ClientKey,
    /// Kept in 32 bits, room for the ping and sync hook on a 64-bit host (no MTU is larger).
    mtu: u32,
    state: SessionState,
    session_retry: Option<Retry>,
    last_request_id: u16,
    out_be: [Option<OutputBestEffort<'a>>; OBE],
    out_rel: [Option<OutputReliable<'a>>; ORE],
    in_be: [Option<InputBestEffort>; IBE],
    ping: PingState,
    ping_retry: Option<Retry>,
    sync_pending: bool,
    synced: bool,
    /// The ping and sync part of [`SessionCore::poll_transmit`], set by the calls that start them: reached
    /// only through them, it is left out of a program that never pings nor syncs (firmware size).
    timers: Option<PollTimers<'a, OBE, ORE, IBE>>,
    time_offset: i64,
    info_reply: Option<BaseObjectRequest>,
    packed_input: bool,
    live: liveness::Liveness,
    /// Pre-shared key and the nonce of the current session creation (the next one adds one).
    #[cfg(feature = "psk")]
    psk: Option<(&'a [u8], u64)>,
}

impl<'a, const OBE: usize, const ORE: usize, const IBE: usize> State<'a, OBE, ORE, IBE> {
    fn outputs(&mut self) -> Outputs<'_, 'a> {
        Outputs {
            last_request_id: &mut self.last_request_id,
            best_effort: &mut self.out_be,
            reliable: &mut self.out_rel,
        }
    }

    fn header(&self, stream: StreamId) -> MessageHeader {
        MessageHeader::new(self.session_id, stream, 0, self.key)
    }
}

/// The sans-IO session: streams, reliability, fragmentation, entity requests, session life, ping and time sync.
///
/// The const parameters bound the number of streams of each kind like `CONFIG_MAX_OUTPUT_BEST_EFFORT_STREAMS`,
/// `CONFIG_MAX_OUTPUT_RELIABLE_STREAMS`, `CONFIG_MAX_INPUT_BEST_EFFORT_STREAMS` and
/// `CONFIG_MAX_INPUT_RELIABLE_STREAMS`; stream buffers are lent by the caller for `'a`.
#[derive(Debug)]
pub struct SessionCore<'a, const OBE: usize = 1, const ORE: usize = 1, const IBE: usize = 1, const IRE: usize = 1> {
    st: State<'a, OBE, ORE, IBE>,
    in_rel: [Option<InputReliable<'a>>; IRE],
}

impl<'a, const OBE: usize, const ORE: usize, const IBE: usize, const IRE: usize> SessionCore<'a, OBE, ORE, IBE, IRE> {
    /// `uxr_init_session`: a session `session_id` (below 0x80 the key travels in every header) for client
    /// `key`, over a transport of `mtu` bytes.
    pub fn new(session_id: u8, key: u32, mtu: usize) -> Self {
        Self {
            st: State {
                session_id,
                key: ClientKey::from_u32(key),
                mtu: u32::try_from(mtu).unwrap_or(u32::MAX),
                state: SessionState::Idle,
                session_retry: None,
                last_request_id: FIRST_REQUEST_ID - 1,
                out_be: [const { None }; OBE],
                out_rel: [const { None }; ORE],
                in_be: [const { None }; IBE],
                ping: PingState::Idle,
                ping_retry: None,
                sync_pending: false,
                synced: false,
                timers: None,
                time_offset: 0,
                info_reply: None,
                packed_input: false,
                live: liveness::Liveness::new(),
                #[cfg(feature = "psk")]
                psk: None,
            },
            in_rel: [const { None }; IRE],
        }
    }

    /// The session id.
    pub const fn session_id(&self) -> u8 {
        self.st.session_id
    }

    /// The client key.
    pub const fn client_key(&self) -> ClientKey {
        self.st.key
    }

    /// The MTU messages are built for.
    pub const fn mtu(&self) -> usize {
        self.st.mtu as usize
    }

    /// Where the session is.
    pub const fn state(&self) -> SessionState {
        self.st.state
    }

    fn header_size(&self) -> usize {
        MessageHeader::size_for(self.st.session_id)
    }

    // ---- streams ---------------------------------------------------------------------------------------

    /// `uxr_create_output_best_effort_stream`: messages are built in `buffer` (at most the MTU is used).
    pub fn create_output_best_effort_stream(&mut self, buffer: &'a mut [u8]) -> Result<StreamId> {
        let hs = self.header_size();
        let mtu = self.mtu();
        let (index, slot) = free_slot(&mut self.st.out_be)?;
        *slot = Some(OutputBestEffort::new(buffer, mtu, hs));
        Ok(StreamId::from_index(index, StreamKind::BestEffort))
    }

    /// `uxr_create_output_reliable_stream`: `buffer` split into `history` slots (a power of two dividing it).
    pub fn create_output_reliable_stream(&mut self, buffer: &'a mut [u8], history: usize) -> Result<StreamId> {
        let hs = self.header_size();
        let stream = OutputReliable::new(buffer, history, hs)?;
        let (index, slot) = free_slot(&mut self.st.out_rel)?;
        *slot = Some(stream);
        Ok(StreamId::from_index(index, StreamKind::Reliable))
    }

    /// Sets the floor of the interval between two retransmissions of one message on reliable output stream
    /// `stream` (nanoseconds, default 20 ms; the round-trip estimate raises it on slow links). See
    /// [`OutputReliable::set_retransmit_floor`].
    pub fn set_retransmit_floor(&mut self, stream: StreamId, floor_ns: i64) -> Result<()> {
        match (stream.kind(), self.st.out_rel.get_mut(usize::from(stream.index()))) {
            (StreamKind::Reliable, Some(Some(s))) => {
                s.set_retransmit_floor(floor_ns);
                Ok(())
            }
            _ => Err(Error::UnknownStream),
        }
    }

    /// `uxr_create_input_best_effort_stream`.
    pub fn create_input_best_effort_stream(&mut self) -> Result<StreamId> {
        let (index, slot) = free_slot(&mut self.st.in_be)?;
        *slot = Some(InputBestEffort::new());
        Ok(StreamId::from_index(index, StreamKind::BestEffort))
    }

    /// `uxr_create_input_reliable_stream`: `buffer` split into `history` slots (a power of two dividing it).
    pub fn create_input_reliable_stream(&mut self, buffer: &'a mut [u8], history: usize) -> Result<StreamId> {
        let stream = InputReliable::new(buffer, history)?;
        let (index, slot) = free_slot(&mut self.in_rel)?;
        *slot = Some(stream);
        Ok(StreamId::from_index(index, StreamKind::Reliable))
    }

    /// The output side, to write entity requests and data (also reachable through [`crate::WriteAccess`]).
    pub fn outputs(&mut self) -> Outputs<'_, 'a> {
        self.st.outputs()
    }

    /// `uxr_flash_output_streams`: everything written so far becomes sendable through
    /// [`poll_transmit`](Self::poll_transmit).
    pub fn flash_output_streams(&mut self) {
        self.st.out_be.iter_mut().flatten().for_each(OutputBestEffort::flush);
        self.st.out_rel.iter_mut().flatten().for_each(OutputReliable::flush);
    }

    /// The last request id handed out (eProsima's `uxrSessionInfo.last_request_id`); it changes with every
    /// write into the output streams.
    pub const fn last_request_id(&self) -> u16 {
        self.st.last_request_id
    }

    /// Whether every reliable output stream had all its messages acknowledged.
    pub fn output_streams_confirmed(&self) -> bool {
        self.st.out_rel.iter().flatten().all(OutputReliable::confirmed)
    }

    /// Asks the agent, in the next CREATE_CLIENT, to pack several DATA submessages into one message when it
    /// can (property `xrce_rs_pack = "1"`): fewer datagrams towards this client. Only our agent honours it;
    /// eProsima's agent looks up the properties it knows (`uxr_sm`, `uxr_hl`) by name and ignores others, and
    /// the message format is unchanged (one message carries several submessages, as the protocol allows).
    /// This client always reads packed messages; the property only says so. Off by default, like the C client
    /// (which sends no properties). Takes effect at the next [`create_session`](Self::create_session).
    pub fn set_packed_input(&mut self, on: bool) {
        self.st.packed_input = on;
    }

    /// Whether [`set_packed_input`](Self::set_packed_input) is on.
    pub const fn packed_input(&self) -> bool {
        self.st.packed_input
    }

    /// Proves to an agent run with `--psk-file` (ours) that this client holds `psk`: every CREATE_CLIENT
    /// then carries the property `xrce_rs_auth`, a token made of a nonce and an HMAC-SHA256 with `psk` over
    /// the client key, the session id and the nonce ([`xrce_proto::auth`]). Each
    /// [`create_session`](Self::create_session) uses a new nonce, starting at `first_nonce`: the agent refuses
    /// a nonce it has seen for this key, so `first_nonce` must not repeat across reboots (a random number, a
    /// counter kept in flash, or the time). Without an agent that checks it the property is ignored
    /// (eProsima's agent looks up only the properties it knows). Takes effect at the next session creation.
    #[cfg(feature = "psk")]
    pub fn set_pre_shared_key(&mut self, psk: &'a [u8], first_nonce: u64) {
        self.st.psk = Some((psk, first_nonce.wrapping_sub(1)));
    }

    // ---- session life ----------------------------------------------------------------------------------

    /// `uxr_create_session`: starts sending CREATE_CLIENT, up to 10 times one second apart.
    pub fn create_session(&mut self, now: i64) {
        self.create_session_retries(CREATE_SESSION_ATTEMPTS, now);
    }

    /// `uxr_create_session_retries`: as [`create_session`](Self::create_session) with `attempts` sends.
    pub fn create_session_retries(&mut self, attempts: usize, now: i64) {
        #[cfg(feature = "psk")]
        if let Some((_, nonce)) = self.st.psk.as_mut() {
            // Retries of this creation resend the same token (the agent accepts a repeat of the token that
            // created the session); the next creation gets a fresh one.
            *nonce = nonce.wrapping_add(1);
        }
        reset_streams(&mut self.st, &mut self.in_rel, true);
        self.st.live.set_recreating(false);
        fail_pending_ping(&mut self.st);
        self.st.state = SessionState::Creating;
        self.st.session_retry =
            Some(Retry { attempts_left: attempts.max(1), next: now, period: SESSION_CONNECTION_INTERVAL_MS * MILLIS });
    }

    /// `uxr_delete_session`: starts sending DELETE of the client, up to 10 times one second apart.
    pub fn delete_session(&mut self, now: i64) {
        self.delete_session_retries(CREATE_SESSION_ATTEMPTS, now);
    }

    /// `uxr_delete_session_retries`.
    pub fn delete_session_retries(&mut self, attempts: usize, now: i64) {
        fail_pending_ping(&mut self.st);
        self.st.state = SessionState::Deleting;
        self.st.session_retry =
            Some(Retry { attempts_left: attempts.max(1), next: now, period: SESSION_CONNECTION_INTERVAL_MS * MILLIS });
    }

    // ---- reconnection ----------------------------------------------------------------------------------

    /// Turns automatic reconnection on (`Some`) or off (`None`, the default of the core; the blocking
    /// [`Session`] turns it on). See [`Reconnect`] for what it does and [`poll_event`](Self::poll_event) for
    /// what it reports.
    pub fn set_reconnect(&mut self, config: Option<Reconnect>) {
        self.st.live.set_config(config);
    }

    /// The reconnection settings, `None` when off.
    pub const fn reconnect_config(&self) -> Option<Reconnect> {
        self.st.live.config()
    }

    /// Counts the session as lost now (a transport error, say) and starts reconnection attempts; while already
    /// reconnecting, makes the next attempt now (the transport just came back, say). Does nothing otherwise, or
    /// with reconnection off.
    pub fn reconnect(&mut self, now: i64) {
        if self.st.live.config().is_none() {
            return;
        }
        match self.st.state {
            SessionState::Established => lose(&mut self.st, now),
            SessionState::Reconnecting => self.st.live.start_attempts(now),
            _ => {}
        }
    }

    /// Whether the session is lost and being brought back (attempts, or its re-creation under way).
    pub const fn is_reconnecting(&self) -> bool {
        matches!(self.st.state, SessionState::Reconnecting)
            || (matches!(self.st.state, SessionState::Creating) && self.st.live.recreating())
    }

    /// Whether the last input was only an agent's answer to a liveness probe (nothing for the application).
    pub const fn last_input_was_probe_answer(&self) -> bool {
        self.st.live.probe_answer()
    }

    /// The next thing that happened to the session ([`SessionEvent::Lost`], [`SessionEvent::Restored`]).
    pub fn poll_event(&mut self) -> Option<SessionEvent> {
        self.st.live.pop()
    }

    /// Hands the messages of reliable output stream `stream` not acknowledged yet to `visit`, in order (bytes
    /// after the message header, and whether the message ends with a FRAGMENT), and empties the stream, whose
    /// numbering restarts at 0 (so use it right after a re-creation, before anything is sent). After a
    /// re-creation ([`SessionEvent::Restored`] with `recreated`) they are already renumbered from 0 and would go
    /// out as they are; taking them out lets the caller send the entity creations first, then give them back
    /// with [`restore_reliable_output`](Self::restore_reliable_output).
    #[cfg(feature = "reconnect")]
    pub fn take_reliable_output(&mut self, stream: StreamId, visit: impl FnMut(&[u8], bool)) -> Result<()> {
        match (stream.kind(), self.st.out_rel.get_mut(usize::from(stream.index()))) {
            (StreamKind::Reliable, Some(Some(s))) => {
                s.take_messages(visit);
                Ok(())
            }
            _ => Err(Error::UnknownStream),
        }
    }

    /// Appends a message taken by [`take_reliable_output`](Self::take_reliable_output) to reliable output
    /// stream `stream`; [`Error::WouldBlock`] while its history is full.
    #[cfg(feature = "reconnect")]
    pub fn restore_reliable_output(&mut self, stream: StreamId, body: &[u8], ends_with_fragment: bool) -> Result<()> {
        match (stream.kind(), self.st.out_rel.get_mut(usize::from(stream.index()))) {
            (StreamKind::Reliable, Some(Some(s))) => s.restore_message(body, ends_with_fragment),
            _ => Err(Error::UnknownStream),
        }
    }

    /// The ids of the reliable output streams created.
    #[cfg(feature = "reconnect")]
    pub fn reliable_output_streams(&self) -> impl Iterator<Item = StreamId> + '_ {
        self.st
            .out_rel
            .iter()
            .enumerate()
            .filter(|(_, s)| s.is_some())
            .map(|(i, _)| StreamId::from_index(u8::try_from(i).unwrap_or(0), StreamKind::Reliable))
    }

    // ---- ping and time ---------------------------------------------------------------------------------

    /// Starts an in-session ping (`uxr_ping_agent_session`): GET_INFO up to `attempts` times, `timeout_ms`
    /// apart. Unlike the C client this works for every session id, with or without key.
    pub fn ping(&mut self, timeout_ms: i64, attempts: usize, now: i64) {
        if self.st.state != SessionState::Established {
            // Nothing is sent outside an established session (a creation that timed out, a deleted one): the
            // ping fails at once, rather than stay pending with a retry due forever (a blocking ping would spin).
            self.st.ping = PingState::Failed;
            self.st.ping_retry = None;
            return;
        }
        self.st.ping = PingState::Pending;
        self.st.timers = Some(poll_timers);
        self.st.ping_retry =
            Some(Retry { attempts_left: attempts.max(1), next: now, period: timeout_ms.max(1) * MILLIS });
    }

    /// Progress of the last ping.
    pub const fn ping_state(&self) -> PingState {
        self.st.ping
    }

    /// Starts a time synchronisation (`uxr_sync_session`): a TIMESTAMP goes out with the next transmit.
    pub fn sync(&mut self) {
        self.st.timers = Some(poll_timers);
        self.st.sync_pending = true;
        self.st.synced = false;
    }

    /// Whether a TIMESTAMP_REPLY arrived since the last [`sync`](Self::sync).
    pub const fn synced(&self) -> bool {
        self.st.synced
    }

    /// Offset of the local clock over the agent's, in nanoseconds (0 before any sync).
    pub const fn time_offset(&self) -> i64 {
        self.st.time_offset
    }

    /// `uxr_epoch_nanos`: the agent's time for local time `now`.
    pub const fn epoch_nanos(&self, now: i64) -> i64 {
        now - self.st.time_offset
    }

    /// `uxr_epoch_millis`.
    pub const fn epoch_millis(&self, now: i64) -> i64 {
        millis(self.epoch_nanos(now))
    }

    // ---- I/O -------------------------------------------------------------------------------------------

    /// Processes one received message, calling `cb` for what it carries.
    pub fn handle_input<C: Callbacks + ?Sized>(&mut self, msg: &[u8], now: i64, cb: &mut C) {
        self.st.live.set_probe_answer(false);
        let Ok((header, hs)) = MessageHeader::decode(msg) else { return };
        if RECONNECT && is_session_none(header.session_id) && self.st.state == SessionState::Reconnecting {
            // An answer outside the session: an agent is there; unless it answers in the session too, it lost us.
            if first_info(msg, hs).is_some() {
                self.st.live.agent_seen(now);
            }
            return;
        }
        if header.session_id != self.st.session_id || header.client_key.is_some_and(|k| k != self.st.key) {
            return;
        }
        if self.st.live.config().is_some() {
            if first_info(msg, hs) == Some(0) {
                // The agent answers our probe but does not know the session: it restarted, or dropped us.
                if self.st.state == SessionState::Established {
                    lose(&mut self.st, now);
                }
                if self.st.state == SessionState::Reconnecting {
                    recreate(&mut self.st, now);
                }
                return;
            }
            self.st.live.heard(now);
            let answer = self.st.state == SessionState::Established
                && self.st.ping != PingState::Pending
                && first_info(msg, hs).is_some();
            self.st.live.set_probe_answer(answer);
            if self.st.state == SessionState::Reconnecting {
                // The agent still holds the session: it goes on where it was, nothing to create again.
                self.st.state = SessionState::Established;
                self.st.live.push(SessionEvent::Restored { recreated: false });
            }
        }
        let stream = header.stream_id;
        let index = usize::from(stream.index());
        match stream.kind() {
            StreamKind::None => process(&mut self.st, &mut self.in_rel, msg, hs, stream, now, cb),
            _ if self.st.state != SessionState::Established => {}
            StreamKind::BestEffort => {
                if let Some(Some(s)) = self.st.in_be.get_mut(index) {
                    if s.accept(header.sequence_nr) {
                        process(&mut self.st, &mut self.in_rel, msg, hs, stream, now, cb);
                    }
                }
            }
            StreamKind::Reliable => {
                let verdict = match self.in_rel.get_mut(index) {
                    Some(Some(s)) => s.receive(header.sequence_nr, msg),
                    _ => return,
                };
                if verdict == Received::Now {
                    process(&mut self.st, &mut self.in_rel, msg, hs, stream, now, cb);
                    if let Some(Some(s)) = self.in_rel.get_mut(index) {
                        s.handled(header.sequence_nr);
                    }
                }
                self.drain(index, stream, now, cb);
            }
        }
    }

    /// Processes the stored messages of reliable input stream `index` that became consecutive.
    fn drain<C: Callbacks + ?Sized>(&mut self, index: usize, stream: StreamId, now: i64, cb: &mut C) {
        loop {
            let Some(Some(s)) = self.in_rel.get_mut(index) else { return };
            match s.next_ready() {
                None => return,
                Some(ready::Message(seq_nr)) => {
                    if let Some(msg) = s.message(seq_nr) {
                        let hs = MessageHeader::size_of_message(msg).unwrap_or(MessageHeader::MAX_SIZE);
                        process(&mut self.st, &mut [], msg, hs, stream, now, cb);
                    }
                    s.release(seq_nr, 1);
                }
                Some(ready::Fragments { first, count }) => {
                    let len = s.assemble(first, count);
                    process(&mut self.st, &mut [], s.assembled(len), 0, stream, now, cb);
                    s.finish_assembly(first, count);
                }
                Some(ready::Broken { first, count }) => s.release(first, count.max(1)),
            }
        }
    }

    /// The next message to send, written to `out`; its length. Call until `None` after every input, every
    /// write and every timeout. `out` should hold the MTU.
    // Out of line: 64 bytes less in the C library on a Cortex-M4 (40 more in the Rust publisher).
    #[inline(never)]
    pub fn poll_transmit(&mut self, now: i64, out: &mut [u8]) -> Option<usize> {
        let st = &mut self.st;
        // Built once for every message this sends outside a stream (firmware size).
        let header = st.header(StreamId::NONE);
        if st.state == SessionState::Reconnecting && st.live.recreate_due(now) {
            recreate(st, now);
        }
        // The fixed-size messages share one call to the encoder: their id, payload and its length (firmware size).
        let (sub_id, payload, len): (u8, [u8; 8], usize) = 'fixed: {
            // Session creation and deletion.
            if let Some(retry) = st.session_retry.as_mut() {
                match (st.state, retry.due(now)) {
                    (SessionState::Creating, Some(true)) => {
                        // Out of session: another id, with the key exactly when the session's carries it.
                        let header = MessageHeader { session_id: session_none_for(st.session_id), ..header };
                        let mtu = ClientRepresentation::mtu_for(st.mtu as usize);
                        let rep = ClientRepresentation::new(st.key, st.session_id, mtu);
                        #[cfg(feature = "psk")]
                        let token =
                            st.psk.map(|(psk, nonce)| xrce_proto::auth::Token::new(psk, st.key, st.session_id, nonce));
                        let none = xrce_proto::Property { name: "", value: "" };
                        // Room for the properties this build can send (firmware size: one without reconnection or PSK).
                        let mut props = [none; 1 + RECONNECT as usize + cfg!(feature = "psk") as usize];
                        let mut n = 0;
                        if st.packed_input {
                            add_property(&mut props, &mut n, PACK_PROPERTIES[0]);
                        }
                        if RECONNECT && st.live.recreating() {
                            add_property(
                                &mut props,
                                &mut n,
                                xrce_proto::Property { name: RESUME_PROPERTY, value: "1" },
                            );
                        }
                        #[cfg(feature = "psk")]
                        if let Some(token) = &token {
                            let auth =
                                xrce_proto::Property { name: xrce_proto::auth::AUTH_PROPERTY, value: token.as_str() };
                            add_property(&mut props, &mut n, auth);
                        }
                        let props = props.get(..n).unwrap_or(&[]);
                        return encode_single_kind(out, &header, id::CREATE_CLIENT, |w| {
                            rep.encode_with_properties(w, props)
                        })
                        .ok();
                    }
                    (SessionState::Deleting, Some(true)) => {
                        let req =
                            BaseObjectRequest { request_id: RequestId::DELETE_SESSION, object_id: ObjectId::CLIENT };
                        let [q0, q1, q2, q3] = req.to_bytes();
                        break 'fixed (id::DELETE, [q0, q1, q2, q3, 0, 0, 0, 0], 4);
                    }
                    (SessionState::Creating, None) if st.live.recreating() => {
                        // The agent went again before answering: back to the attempts.
                        st.session_retry = None;
                        st.state = SessionState::Reconnecting;
                        st.live.start_attempts(now);
                    }
                    (SessionState::Creating, None) => {
                        st.state = SessionState::CreateTimedOut;
                        st.session_retry = None;
                    }
                    (SessionState::Deleting, None) => {
                        st.state = SessionState::Deleted;
                        st.session_retry = None;
                    }
                    (SessionState::Creating | SessionState::Deleting, Some(false)) => {}
                    _ => st.session_retry = None,
                }
            }
            if st.state == SessionState::Established && st.live.lost(now) {
                lose(st, now);
            }
            if RECONNECT && st.state == SessionState::Reconnecting {
                return poll_reconnect(st, now, out);
            }
            if st.state != SessionState::Established {
                return None;
            }
            if st.live.probe_due(now) {
                break 'fixed (id::GET_INFO, liveness_probe().to_le_bytes(), 8);
            }
            if let Some(request) = st.info_reply.take() {
                let reply = BaseObjectReply {
                    related_request: request,
                    result: ResultStatus { status: StatusCode::OK, implementation_status: 1 },
                };
                // An INFO with neither configuration nor activity: the reply and two absent optionals.
                let [r0, r1, r2, r3, r4, r5] = reply.to_bytes();
                break 'fixed (id::INFO, [r0, r1, r2, r3, r4, r5, 0, 0], 8);
            }
            if let Some(n) = st.timers.and_then(|f| f(st, now, &header, out)) {
                return Some(n);
            }
            for (i, s) in self.in_rel.iter_mut().enumerate() {
                let Some(s) = s.as_mut().filter(|s| s.ack_pending()) else { continue };
                let stream_id = StreamId::from_index(u8::try_from(i).unwrap_or(0), StreamKind::Reliable).0;
                let [a0, a1, a2, a3, a4] = AckNack::from_bits(s.acknack(), stream_id).to_le_bytes();
                break 'fixed (id::ACKNACK, [a0, a1, a2, a3, a4, 0, 0, 0], 5);
            }
            for (i, s) in st.out_rel.iter_mut().enumerate() {
                let Some(s) = s.as_mut() else { continue };
                let stream = StreamId::from_index(u8::try_from(i).unwrap_or(0), StreamKind::Reliable);
                if let Some(n) = s.poll_transmit(st.session_id, st.key, stream, now, out) {
                    return Some(n);
                }
                if let Some((first, last)) = s.poll_heartbeat(now) {
                    let hb = Heartbeat { first_unacked_seq_nr: first, last_unacked_seq_nr: last, stream_id: stream.0 };
                    let [h0, h1, h2, h3, h4] = hb.to_le_bytes();
                    break 'fixed (id::HEARTBEAT, [h0, h1, h2, h3, h4, 0, 0, 0], 5);
                }
            }
            for (i, s) in st.out_be.iter_mut().enumerate() {
                let Some(s) = s.as_mut() else { continue };
                let stream = StreamId::from_index(u8::try_from(i).unwrap_or(0), StreamKind::BestEffort);
                if let Some(n) = s.poll_transmit(st.session_id, st.key, stream, out) {
                    return Some(n);
                }
            }
            return None;
        };
        encode_single_bytes_opt(out, &header, sub_id, payload.get(..len).unwrap_or(&payload))
    }

    /// The earliest time something will be due without new input (a retry, a heartbeat), if any.
    pub fn poll_timeout(&self) -> Option<i64> {
        let st = &self.st;
        // A plain fold, each candidate folded by one closure (firmware size: iterator chains cost ~200 bytes).
        let mut next = i64::MAX;
        let mut earlier = |t: Option<i64>| next = next.min(t.unwrap_or(i64::MAX));
        earlier(st.session_retry.map(|r| r.next));
        earlier(st.ping_retry.map(|r| r.next));
        let established = st.state == SessionState::Established;
        earlier(st.live.timeout(established, st.state == SessionState::Reconnecting));
        // Streams only send in an established session; their timers wait meanwhile.
        if established {
            st.out_rel.iter().flatten().for_each(|stream| earlier(stream.timeout()));
        }
        (next != i64::MAX).then_some(next)
    }

    /// Whether something is ready to be sent right now.
    pub fn has_pending_transmit(&self) -> bool {
        let st = &self.st;
        st.info_reply.is_some()
            || st.sync_pending
            || self.in_rel.iter().flatten().any(InputReliable::ack_pending)
            || st.out_rel.iter().flatten().any(OutputReliable::has_pending)
            || st.out_be.iter().flatten().any(|s| !s.is_empty())
    }
}

type PollTimers<'a, const OBE: usize, const ORE: usize, const IBE: usize> =
    fn(&mut State<'a, OBE, ORE, IBE>, i64, &MessageHeader, &mut [u8]) -> Option<usize>;

/// The ping's GET_INFO and the sync's TIMESTAMP when due (see `State::timers`).
fn poll_timers<const OBE: usize, const ORE: usize, const IBE: usize>(
    st: &mut State<'_, OBE, ORE, IBE>,
    now: i64,
    header: &MessageHeader,
    out: &mut [u8],
) -> Option<usize> {
    if let Some(retry) = st.ping_retry.as_mut() {
        match retry.due(now) {
            Some(true) => {
                let request = BaseObjectRequest { request_id: RequestId::PING, object_id: ObjectId::AGENT };
                let get = GetInfo { request, info_mask: info_mask::ACTIVITY };
                return encode_single_bytes_opt(out, header, id::GET_INFO, &get.to_le_bytes());
            }
            Some(false) => {}
            None => {
                st.ping_retry = None;
                st.ping = PingState::Failed;
            }
        }
    }
    if st.sync_pending {
        st.sync_pending = false;
        return encode_single_bytes_opt(out, header, id::TIMESTAMP, &Time::from_nanos(now).to_le_bytes());
    }
    None
}

/// Every stream back to its start, but the reliable output ones unless `reliable_output` (a session created).
/// One function for the two places that do it (firmware size).
fn reset_streams<const OBE: usize, const ORE: usize, const IBE: usize>(
    st: &mut State<'_, OBE, ORE, IBE>,
    in_rel: &mut [Option<InputReliable<'_>>],
    reliable_output: bool,
) {
    st.out_be.iter_mut().flatten().for_each(OutputBestEffort::reset);
    if reliable_output {
        st.out_rel.iter_mut().flatten().for_each(OutputReliable::reset);
    }
    st.in_be.iter_mut().flatten().for_each(InputBestEffort::reset);
    in_rel.iter_mut().flatten().for_each(InputReliable::reset);
}

/// Puts `p` in the next free slot of `props` (CREATE_CLIENT properties).
fn add_property<'p>(props: &mut [xrce_proto::Property<'p>], n: &mut usize, p: xrce_proto::Property<'p>) {
    if let Some(slot) = props.get_mut(*n) {
        *slot = p;
        *n += 1;
    }
}

/// Whether reconnection is built in (feature `reconnect`): without it, the branches that only a lost
/// session takes are removed at compile time, so the footprint build carries none of them.
pub(crate) const RECONNECT: bool = cfg!(feature = "reconnect");

/// The in-session GET_INFO probing the agent (our own request id: the answer only counts as "heard").
const fn liveness_probe() -> GetInfo {
    GetInfo {
        request: BaseObjectRequest { request_id: RequestId::PING, object_id: ObjectId::AGENT },
        info_mask: info_mask::ACTIVITY,
    }
}

/// A ping only goes out in an established session: leaving it fails the pending one, whose retry would
/// otherwise stay due forever (a deadline in the past that makes an event loop spin; found by fuzzing).
fn fail_pending_ping<const OBE: usize, const ORE: usize, const IBE: usize>(st: &mut State<'_, OBE, ORE, IBE>) {
    st.ping_retry = None;
    if st.ping == PingState::Pending {
        st.ping = PingState::Failed;
    }
}

/// The session is lost: report it and start reconnection attempts.
fn lose<const OBE: usize, const ORE: usize, const IBE: usize>(st: &mut State<'_, OBE, ORE, IBE>, now: i64) {
    st.state = SessionState::Reconnecting;
    fail_pending_ping(st);
    st.live.start_attempts(now);
    st.live.push(SessionEvent::Lost);
}

/// An agent answers but does not hold the session: create it again, same key and id.
fn recreate<const OBE: usize, const ORE: usize, const IBE: usize>(st: &mut State<'_, OBE, ORE, IBE>, now: i64) {
    #[cfg(feature = "psk")]
    if let Some((_, nonce)) = st.psk.as_mut() {
        // A fresh token: an agent that still remembers the last one (it dropped the session but did not
        // restart) refuses a replay.
        *nonce = nonce.wrapping_add(1);
    }
    st.state = SessionState::Creating;
    st.live.start_attempts(now);
    st.live.set_recreating(true);
    let period = i64::from(st.live.config().map_or(1000, |c| c.retry_max_ms.max(1))) * MILLIS;
    st.session_retry = Some(Retry { attempts_left: 3, next: now, period });
}

/// While reconnecting: the two GET_INFO of an attempt (in the session, then outside it), and best-effort
/// output dropped (nobody would receive it).
fn poll_reconnect<const OBE: usize, const ORE: usize, const IBE: usize>(
    st: &mut State<'_, OBE, ORE, IBE>,
    now: i64,
    out: &mut [u8],
) -> Option<usize> {
    for (i, s) in st.out_be.iter_mut().enumerate() {
        let Some(s) = s.as_mut() else { continue };
        let stream = StreamId::from_index(u8::try_from(i).unwrap_or(0), StreamKind::BestEffort);
        while s.poll_transmit(st.session_id, st.key, stream, out).is_some() {}
    }
    if st.live.attempt_due(now) {
        let header = st.header(StreamId::NONE);
        return encode_single_bytes_opt(out, &header, id::GET_INFO, &liveness_probe().to_le_bytes());
    }
    if st.live.take_second_ping() {
        return ping::encode_get_info(RequestId::PING, info_mask::ACTIVITY, out);
    }
    None
}

/// The implementation status of the INFO `msg` starts with, if it does.
fn first_info(msg: &[u8], hs: usize) -> Option<u8> {
    match Submessages::new(msg, hs).next()?.ok()?.decode_from_agent().ok()? {
        FromAgent::Info { reply, .. } => Some(reply.result.implementation_status),
        _ => None,
    }
}

fn free_slot<T>(slots: &mut [Option<T>]) -> Result<(u8, &mut Option<T>)> {
    let (index, slot) = slots.iter_mut().enumerate().find(|(_, s)| s.is_none()).ok_or(Error::TooManyStreams)?;
    Ok((u8::try_from(index).map_err(|_| Error::TooManyStreams)?, slot))
}

/// Processes the submessages of `msg` from `start` (after the header, or 0 for a reassembled message).
/// `in_rel` is empty when the message itself comes from a reliable input stream's storage.
#[allow(clippy::too_many_arguments)]
fn process<'a, C: Callbacks + ?Sized, const OBE: usize, const ORE: usize, const IBE: usize>(
    st: &mut State<'a, OBE, ORE, IBE>,
    in_rel: &mut [Option<InputReliable<'a>>],
    msg: &[u8],
    start: usize,
    stream: StreamId,
    now: i64,
    cb: &mut C,
) {
    for raw in Submessages::new(msg, start) {
        let Ok(raw) = raw else { return };
        let Ok(sub) = raw.decode_from_agent() else { return };
        match sub {
            FromAgent::StatusAgent(result) if stream == StreamId::NONE && st.state == SessionState::Creating => {
                st.session_retry = None;
                let recreated = st.live.take_recreating();
                if RECONNECT && recreated && result.status == StatusCode::OK_MATCHED {
                    // Our agent still held the session and kept its streams: go on where we were.
                    st.state = SessionState::Established;
                    st.live.heard(now);
                    st.live.push(SessionEvent::Restored { recreated: false });
                } else if result.status == StatusCode::OK {
                    st.state = SessionState::Established;
                    st.live.heard(now);
                    if RECONNECT && recreated {
                        // The agent restarted its streams; what it did not acknowledge goes again, renumbered.
                        st.out_rel.iter_mut().flatten().for_each(OutputReliable::rebase);
                        st.live.push(SessionEvent::Restored { recreated: true });
                        reset_streams(st, in_rel, false);
                    } else {
                        reset_streams(st, in_rel, true);
                    }
                } else if RECONNECT && recreated {
                    // Refused for now (the agent is full, say): keep trying.
                    st.state = SessionState::Reconnecting;
                    st.live.start_attempts(now);
                } else {
                    st.state = SessionState::Refused(result.status.0);
                }
            }
            FromAgent::Status(reply) if stream == StreamId::NONE => {
                let deleted = reply.related_request.request_id == RequestId::DELETE_SESSION;
                if deleted && st.state == SessionState::Deleting {
                    st.state = SessionState::Deleted;
                    st.session_retry = None;
                }
            }
            FromAgent::Status(reply) => {
                let request = reply.related_request.request_id.0;
                let status = reply.result.status.0;
                cb.on_status(&mut st.outputs(), reply.related_request.object_id, request, status);
                cb.on_request_status(request, status);
            }
            FromAgent::Info { reply, availability } => {
                let available = availability.is_some_and(|a| a > 0);
                let in_session = reply.result.implementation_status != 0;
                if available {
                    cb.on_pong(in_session);
                }
                if available && in_session && st.ping == PingState::Pending {
                    st.ping = PingState::Answered;
                    st.ping_retry = None;
                }
            }
            FromAgent::GetInfo(get) => st.info_reply = Some(get.request),
            FromAgent::Data(d) => {
                let request = d.request.request_id.0;
                let object = d.request.object_id;
                if d.format == DataFormat::DATA {
                    let out = &mut st.outputs();
                    match object.kind() {
                        ObjectKind::Requester => {
                            if let Ok((base, data)) = d.split_base_request() {
                                cb.on_reply(out, object, request, base.request_id.0, data);
                            }
                        }
                        ObjectKind::Replier => {
                            if let Ok((identity, data)) = d.split_sample_identity() {
                                cb.on_request(out, object, request, &identity, data);
                            }
                        }
                        _ => cb.on_topic(out, object, request, stream, d.data),
                    }
                }
                cb.on_request_status(request, StatusCode::OK.0);
            }
            FromAgent::AckNack(a) => {
                let s = StreamId(a.stream_id);
                if let (StreamKind::Reliable, Some(Some(out))) = (s.kind(), st.out_rel.get_mut(usize::from(s.index())))
                {
                    out.on_acknack(a.first_unacked_seq_num, a.bitmap(), now);
                }
            }
            FromAgent::Heartbeat(h) => {
                let s = StreamId(h.stream_id);
                if let (StreamKind::Reliable, Some(Some(inp))) = (s.kind(), in_rel.get_mut(usize::from(s.index()))) {
                    inp.on_heartbeat(h.last_unacked_seq_nr);
                }
            }
            FromAgent::TimestampReply(t) => {
                let sample = TimeSample {
                    current: now,
                    transmit: t.transmit_timestamp.as_nanos(),
                    received: t.receive_timestamp.as_nanos(),
                    originate: t.originate_timestamp.as_nanos(),
                };
                if !cb.on_time(&sample) {
                    st.time_offset = sample.offset();
                }
                st.synced = true;
            }
            _ => {}
        }
    }
}

#[cfg(test)]
mod tests {
    use super::{millis, TimeSample};

    #[test]
    fn time_offset_truncates_toward_zero() {
        for twice in [0, 1, -1, 2, -2, 3, -3, 99_801, -99_801, i64::MAX, i64::MIN, i64::MIN + 1] {
            let s = TimeSample { current: twice, originate: 0, received: 0, transmit: 0 };
            assert_eq!(s.offset(), twice / 2, "{twice}");
        }
    }

    #[test]
    fn millis_truncates_toward_zero() {
        for ns in [0, 1, 999_999, 1_000_000, -1, -999_999, -1_000_000, -1_000_001, i64::MAX, i64::MIN] {
            assert_eq!(millis(ns), ns / 1_000_000, "{ns}");
        }
    }
}
