//! Clients that create their entities exactly as micro-ROS (Jazzy `rmw_microxrcedds`, binary creation) and
//! PX4 (`uxrce_dds_client`) do, used by the `micro_ros_node` and `px4_client` examples and by the agent's ROS 2
//! suite (`crates/xrce-agent/tests/ros2.rs`, which includes this file with `#[path]`).
//!
//! Payloads are ROS 2 messages in CDR without encapsulation (the agent adds it): `std_msgs/String` samples carry
//! `"<tag> <index> <wall-clock ns>"` so that the other side can match and time them; services are
//! `std_srvs/srv/SetBool` (answer: `success = data`, `message = "xrce <data> <n>"`).
//!
//! Every step is reported as an [`Event`] (a name, wall-clock nanoseconds and a few fields), printed by the
//! examples as one JSON object per line.

#![allow(dead_code)]

use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use xrce_client::prelude::*;

/// Wall clock, nanoseconds since the Unix epoch (comparable across processes of one machine).
pub fn wall_ns() -> u64 {
    SystemTime::now().duration_since(UNIX_EPOCH).map_or(0, |d| u64::try_from(d.as_nanos()).unwrap_or(u64::MAX))
}

/// A value of an [`Event`] field.
#[derive(Debug, Clone, PartialEq)]
pub enum Val {
    U(u64),
    F(f64),
    S(String),
    B(bool),
}

/// One step of a client, with the wall-clock time it happened.
#[derive(Debug, Clone, PartialEq)]
pub struct Event {
    pub name: &'static str,
    pub wall_ns: u64,
    pub fields: Vec<(&'static str, Val)>,
}

impl Event {
    pub fn new(name: &'static str) -> Self {
        Self { name, wall_ns: wall_ns(), fields: Vec::new() }
    }

    pub fn with(mut self, key: &'static str, v: Val) -> Self {
        self.fields.push((key, v));
        self
    }

    pub fn get(&self, key: &str) -> Option<&Val> {
        self.fields.iter().find(|(k, _)| *k == key).map(|(_, v)| v)
    }

    pub fn u(&self, key: &str) -> Option<u64> {
        match self.get(key)? {
            Val::U(v) => Some(*v),
            _ => None,
        }
    }

    pub fn f(&self, key: &str) -> Option<f64> {
        match self.get(key)? {
            Val::F(v) => Some(*v),
            Val::U(v) => Some(*v as f64),
            _ => None,
        }
    }

    pub fn s(&self, key: &str) -> Option<&str> {
        match self.get(key)? {
            Val::S(v) => Some(v),
            _ => None,
        }
    }

    pub fn b(&self, key: &str) -> Option<bool> {
        match self.get(key)? {
            Val::B(v) => Some(*v),
            _ => None,
        }
    }

    /// One JSON object: `{"event": name, "wall_ns": …, fields…}`.
    pub fn to_json(&self) -> String {
        let mut s = format!("{{\"event\": \"{}\", \"wall_ns\": {}", self.name, self.wall_ns);
        for (k, v) in &self.fields {
            let v = match v {
                Val::U(n) => n.to_string(),
                Val::F(x) if x.is_finite() => format!("{x:.3}"),
                Val::F(_) => "null".into(),
                Val::B(b) => b.to_string(),
                Val::S(t) => json_string(t),
            };
            s.push_str(&format!(", \"{k}\": {v}"));
        }
        s.push('}');
        s
    }
}

fn json_string(t: &str) -> String {
    let mut s = String::with_capacity(t.len() + 2);
    s.push('"');
    for c in t.chars() {
        match c {
            '"' => s.push_str("\\\""),
            '\\' => s.push_str("\\\\"),
            c if (c as u32) < 0x20 => s.push_str(&format!("\\u{:04x}", c as u32)),
            c => s.push(c),
        }
    }
    s.push('"');
    s
}

// ---- CDR of the few ROS 2 messages used (no encapsulation: alignment from the payload start) ------------------

/// `std_msgs/String`.
pub fn string_msg(text: &str) -> Vec<u8> {
    let mut v = Vec::with_capacity(text.len() + 5);
    v.extend_from_slice(&(text.len() as u32 + 1).to_le_bytes());
    v.extend_from_slice(text.as_bytes());
    v.push(0);
    v
}

/// `std_msgs/String`, or `None` when truncated.
pub fn parse_string_msg(b: &[u8]) -> Option<String> {
    string_at(b, 0)
}

fn string_at(b: &[u8], at: usize) -> Option<String> {
    let len = u32::from_le_bytes(b.get(at..at + 4)?.try_into().ok()?) as usize;
    let s = b.get(at + 4..at + 4 + len.checked_sub(1)?)?;
    Some(String::from_utf8_lossy(s).into_owned())
}

/// `"<tag> <index> <wall ns>"`, the text of the samples both sides write.
pub fn parse_stamped(text: &str) -> Option<(String, u64, u64)> {
    let mut it = text.split_whitespace();
    let tag = it.next()?.to_string();
    let i = it.next()?.parse().ok()?;
    let t = it.next()?.parse().ok()?;
    Some((tag, i, t))
}

/// `std_srvs/srv/SetBool` request.
pub fn set_bool_request(data: bool) -> Vec<u8> {
    vec![u8::from(data)]
}

/// `std_srvs/srv/SetBool` response: `bool success`, then `string message` aligned to 4.
pub fn set_bool_response(success: bool, message: &str) -> Vec<u8> {
    let mut v = vec![u8::from(success), 0, 0, 0];
    v.extend_from_slice(&string_msg(message));
    v
}

pub fn parse_set_bool_response(b: &[u8]) -> Option<(bool, String)> {
    Some((*b.first()? != 0, string_at(b, 4)?))
}

// ---- what the clients do -------------------------------------------------------------------------------------

/// Shared with whoever drives a client: `go` lets the publisher start its counted samples (a test sets it once
/// the ROS node matched the writer; the examples start with it set), `stop` ends the client.
#[derive(Debug, Default)]
pub struct Control {
    pub go: AtomicBool,
    pub stop: AtomicBool,
}

impl Control {
    pub fn started() -> Self {
        Self { go: AtomicBool::new(true), stop: AtomicBool::new(false) }
    }
}

/// Gathers what the agent delivers and answers SetBool requests.
struct Handler<'e> {
    sink: &'e mut dyn FnMut(Event),
    out: Option<StreamId>,
    replier: Option<ObjectId>,
    requests: u64,
    replies: Vec<(u16, Instant, Vec<u8>)>,
    samples: u64,
}

impl Callbacks for Handler<'_> {
    fn on_topic(&mut self, _: &mut Outputs<'_, '_>, _: ObjectId, _: u16, _: StreamId, data: &[u8]) {
        let now = wall_ns();
        self.samples += 1;
        let text = parse_string_msg(data).unwrap_or_default();
        let mut e = Event::new("sample").with("n", Val::U(self.samples)).with("data", Val::S(text.clone()));
        if let Some((tag, i, t)) = parse_stamped(&text) {
            let latency_ms = now.saturating_sub(t) as f64 / 1e6;
            e = e.with("tag", Val::S(tag)).with("i", Val::U(i)).with("latency_ms", Val::F(latency_ms));
        }
        e.wall_ns = now;
        (self.sink)(e);
    }

    fn on_request(&mut self, out: &mut Outputs<'_, '_>, _: ObjectId, _: u16, sample_id: &SampleIdentity, data: &[u8]) {
        self.requests += 1;
        let value = data.first().is_some_and(|b| *b != 0);
        let message = format!("xrce {value} {}", self.requests);
        let answer = set_bool_response(value, &message);
        let sent = match (self.out, self.replier) {
            (Some(stream), Some(replier)) => out.buffer_reply(stream, replier, sample_id, &answer).is_ok(),
            _ => false,
        };
        (self.sink)(
            Event::new("request")
                .with("n", Val::U(self.requests))
                .with("data", Val::B(value))
                .with("replied", Val::B(sent)),
        );
    }

    fn on_reply(&mut self, _: &mut Outputs<'_, '_>, _: ObjectId, _: u16, reply_id: u16, data: &[u8]) {
        self.replies.push((reply_id, Instant::now(), data.to_vec()));
    }
}

type Udp<'a, 'e> = Session<'a, UdpTransport, StdClock, Handler<'e>>;

/// Waits for the STATUS of one creation request (as micro-ROS's `run_xrce_session` and PX4 do); reports it.
fn create(
    session: &mut Udp<'_, '_>,
    request: u16,
    entity: &'static str,
    name: &str,
    timeout_ms: i32,
) -> Result<(), Box<dyn std::error::Error>> {
    let mut status = [0u8; 1];
    let ok = session.run_session_until_all_status(timeout_ms, &[request], &mut status)?;
    let e = Event::new("created")
        .with("entity", Val::S(entity.into()))
        .with("name", Val::S(name.into()))
        .with("status", Val::U(u64::from(status[0])))
        .with("ok", Val::B(ok));
    (session.callbacks().sink)(e);
    if ok {
        Ok(())
    } else {
        Err(format!("creating {entity} {name}: status {}", status[0]).into())
    }
}

/// How long micro-ROS waits for a reliable write to be acknowledged (`RMW_UXRCE_PUBLISH_RELIABLE_TIMEOUT`).
const CONFIRM_MS: i32 = 1000;

/// How a write went, as `rmw_publish` of micro-ROS reports it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Written {
    /// In the stream and acknowledged by the agent within [`CONFIRM_MS`].
    Confirmed,
    /// In the stream, not acknowledged in time (`rmw_publish` returns an error; the sample stays queued).
    Unconfirmed,
    /// Not written: the reliable history stayed full (`rmw_publish` returns an error; the sample is lost).
    Dropped,
}

/// Writes one sample as `rmw_publish` does on a reliable stream: into the stream, waiting up to [`CONFIRM_MS`]
/// for room when the history is full (its fragmented-write fallback flushes and waits so), then up to
/// [`CONFIRM_MS`] for the agent to acknowledge everything written (`uxr_run_session_until_confirm_delivery`).
fn write(session: &mut Udp<'_, '_>, stream: StreamId, writer: ObjectId, data: &[u8]) -> Result<Written, Error> {
    match session.buffer_topic(stream, writer, data) {
        Ok(_) => {}
        Err(Error::WouldBlock) => {
            session.run_session_until_confirm_delivery(CONFIRM_MS)?;
            match session.buffer_topic(stream, writer, data) {
                Ok(_) => {}
                Err(Error::WouldBlock) => return Ok(Written::Dropped),
                Err(e) => return Err(e),
            }
        }
        Err(e) => return Err(e),
    }
    Ok(if session.run_session_until_confirm_delivery(CONFIRM_MS)? { Written::Confirmed } else { Written::Unconfirmed })
}

/// A periodic publisher of stamped `std_msgs/String` samples: `warm-up` samples (tag `w`) while `go` is not
/// set, then `count` samples (tag `m`).
#[derive(Debug, Clone)]
pub struct PubPlan {
    pub topic: String,
    pub count: u64,
    pub period_ms: u64,
    /// At most this many warm-up samples (0: wait for `go` without writing).
    pub max_warmup: u64,
}

/// What a micro-ROS-like node does.
#[derive(Debug, Clone)]
pub struct MicroRosPlan {
    pub agent: String,
    pub port: u16,
    pub key: u32,
    /// The node name (the binary participant's name; `ns/name` with a namespace, as rmw_microxrcedds does).
    pub node: String,
    pub domain: u16,
    /// `rt/<topic>` publisher, std_msgs/String.
    pub publish: Option<PubPlan>,
    /// `rt/<topic>` subscription, std_msgs/String.
    pub subscribe: Option<String>,
    /// SetBool service served (replier).
    pub serve: Option<String>,
    /// SetBool service called (requester) this many times, the first right after creation.
    pub call: Option<(String, u32)>,
    /// How long to wait for one reply before calling again.
    pub call_timeout_ms: u64,
    /// Run at most this long after creating the entities.
    pub run_for: Duration,
}

/// micro-ROS' defaults: `RMW_UXRCE_STREAM_HISTORY` 4 slots of the UDP transport's 512-byte MTU per stream.
const HISTORY: usize = 4;
const BUF: usize = 512 * HISTORY;

fn ros_topic(name: &str) -> String {
    format!("rt/{}", name.trim_start_matches('/'))
}

/// `<pkg>::msg::dds_::<Msg>_`.
pub fn msg_type(pkg: &str, msg: &str) -> String {
    format!("{pkg}::msg::dds_::{msg}_")
}

/// The names rmw_microxrcedds gives a service: `/name`, `rq/nameRequest`, `rr/nameReply` and the
/// `<pkg>::srv::dds_::<Srv>_Request_` / `_Response_` types.
pub fn service_names(service: &str, pkg: &str, srv: &str) -> [String; 5] {
    let bare = service.trim_start_matches('/');
    [
        format!("/{bare}"),
        format!("{pkg}::srv::dds_::{srv}_Request_"),
        format!("{pkg}::srv::dds_::{srv}_Response_"),
        format!("rq/{bare}Request"),
        format!("rr/{bare}Reply"),
    ]
}

fn names(n: &[String; 5]) -> ServiceNames<'_> {
    ServiceNames {
        service_name: &n[0],
        request_type: &n[1],
        reply_type: &n[2],
        request_topic_name: &n[3],
        reply_topic_name: &n[4],
    }
}

/// Runs a micro-ROS-like node: participant, then per rmw call a topic/publisher/datawriter,
/// topic/subscriber/datareader, replier or requester, each created in binary with REUSE|REPLACE on the reliable
/// stream and awaited one by one (QoS: reliable, volatile, keep-last 10).
pub fn run_micro_ros(
    plan: &MicroRosPlan,
    control: &Control,
    sink: &mut dyn FnMut(Event),
) -> Result<(), Box<dyn std::error::Error>> {
    let transport = UdpTransport::new(IpProtocol::V4, &plan.agent, &plan.port.to_string())?;
    let (mut out_buf, mut in_buf) = ([0u8; BUF], [0u8; BUF]);
    let handler = Handler { sink, out: None, replier: None, requests: 0, replies: Vec::new(), samples: 0 };
    let mut session: Udp<'_, '_> = Session::new(transport, plan.key).with_callbacks(handler);
    session.create_session()?;
    (session.callbacks().sink)(Event::new("session").with("key", Val::U(u64::from(plan.key))));
    let out = session.create_output_reliable_stream(&mut out_buf, HISTORY)?;
    let input = session.create_input_reliable_stream(&mut in_buf, HISTORY)?;
    session.callbacks().out = Some(out);
    let mode = REUSE | REPLACE;
    let qos = QoS {
        reliability: Reliability::Reliable,
        durability: Durability::Volatile,
        history: History::KeepLast,
        depth: 10,
    };
    let control_all = DeliveryControl { max_samples: DeliveryControl::UNLIMITED, ..Default::default() };
    let string_type = msg_type("std_msgs", "String");

    let participant = object_id(1, ObjectKind::Participant);
    let r = session.buffer_create_participant_bin(out, participant, plan.domain, Some(&plan.node), mode)?;
    create(&mut session, r, "participant", &plan.node, 1000)?;

    let mut writer = None;
    if let Some(p) = &plan.publish {
        let name = ros_topic(&p.topic);
        let topic = object_id(1, ObjectKind::Topic);
        let r = session.buffer_create_topic_bin(out, topic, participant, &name, &string_type, mode)?;
        create(&mut session, r, "topic", &name, 1000)?;
        let publisher = object_id(1, ObjectKind::Publisher);
        let r = session.buffer_create_publisher_bin(out, publisher, participant, mode)?;
        create(&mut session, r, "publisher", &name, 1000)?;
        let dw = object_id(1, ObjectKind::DataWriter);
        let r = session.buffer_create_datawriter_bin(out, dw, publisher, topic, qos, mode)?;
        create(&mut session, r, "datawriter", &name, 1000)?;
        writer = Some((dw, p.clone()));
    }
    if let Some(t) = &plan.subscribe {
        let name = ros_topic(t);
        let topic = object_id(2, ObjectKind::Topic);
        let r = session.buffer_create_topic_bin(out, topic, participant, &name, &string_type, mode)?;
        create(&mut session, r, "topic", &name, 1000)?;
        let subscriber = object_id(1, ObjectKind::Subscriber);
        let r = session.buffer_create_subscriber_bin(out, subscriber, participant, mode)?;
        create(&mut session, r, "subscriber", &name, 1000)?;
        let dr = object_id(1, ObjectKind::DataReader);
        let r = session.buffer_create_datareader_bin(out, dr, subscriber, topic, qos, mode)?;
        create(&mut session, r, "datareader", &name, 1000)?;
        session.buffer_request_data(out, dr, input, Some(&control_all))?;
    }
    if let Some(s) = &plan.serve {
        let n = service_names(s, "std_srvs", "SetBool");
        let replier = object_id(1, ObjectKind::Replier);
        let r = session.buffer_create_replier_bin(out, replier, participant, &names(&n), qos, mode)?;
        create(&mut session, r, "replier", &n[0], 1000)?;
        session.buffer_request_data(out, replier, input, Some(&control_all))?;
        session.callbacks().replier = Some(replier);
    }
    let mut requester = None;
    if let Some((s, calls)) = &plan.call {
        let n = service_names(s, "std_srvs", "SetBool");
        let id = object_id(1, ObjectKind::Requester);
        let r = session.buffer_create_requester_bin(out, id, participant, &names(&n), qos, mode)?;
        create(&mut session, r, "requester", &n[0], 1000)?;
        session.buffer_request_data(out, id, input, Some(&control_all))?;
        requester = Some((id, *calls));
    }

    let started = Instant::now();
    let mut pubber = writer.map(|(dw, p)| Publishing::new(dw, p));
    let mut caller = requester.map(|(id, calls)| Calling::new(id, calls, plan.call_timeout_ms));
    while !control.stop.load(Ordering::Relaxed) && started.elapsed() < plan.run_for {
        let mut busy = false;
        if let Some(p) = pubber.as_mut() {
            busy |= p.step(&mut session, out, control)?;
        }
        if let Some(c) = caller.as_mut() {
            busy |= c.step(&mut session, out)?;
        }
        if !busy && plan.serve.is_none() && plan.subscribe.is_none() {
            break;
        }
        let wait = pubber.as_ref().map_or(20, |p| p.wait_ms()).min(caller.as_ref().map_or(20, |c| c.wait_ms()));
        session.run_session_timeout(i32::try_from(wait).unwrap_or(20))?;
    }
    // What is written is delivered to the agent before the session goes.
    session.run_session_until_confirm_delivery(1000)?;
    let h = session.callbacks();
    let done = Event::new("done")
        .with("written", Val::U(pubber.as_ref().map_or(0, |p| p.counted)))
        .with("warmup", Val::U(pubber.as_ref().map_or(0, |p| p.warmup)))
        .with("received", Val::U(h.samples))
        .with("requests_served", Val::U(h.requests))
        .with("calls_ok", Val::U(caller.as_ref().map_or(0, |c| c.ok)));
    (h.sink)(done);
    let _ = session.delete_session();
    Ok(())
}

/// The publishing side of a client: one sample per period, warm-up (`w`) then counted (`m`).
struct Publishing {
    writer: ObjectId,
    plan: PubPlan,
    next: Instant,
    index: u64,
    warmup: u64,
    counted: u64,
}

impl Publishing {
    fn new(writer: ObjectId, plan: PubPlan) -> Self {
        Self { writer, plan, next: Instant::now(), index: 0, warmup: 0, counted: 0 }
    }

    fn wait_ms(&self) -> u64 {
        let left = self.next.saturating_duration_since(Instant::now());
        (left.as_millis() as u64).clamp(1, self.plan.period_ms.max(1))
    }

    /// Writes when due; whether there is more to write.
    fn step(&mut self, session: &mut Udp<'_, '_>, stream: StreamId, control: &Control) -> Result<bool, Error> {
        if self.counted >= self.plan.count {
            return Ok(false);
        }
        if Instant::now() < self.next {
            return Ok(true);
        }
        self.next += Duration::from_millis(self.plan.period_ms);
        let go = control.go.load(Ordering::Relaxed);
        if !go && self.warmup >= self.plan.max_warmup {
            return Ok(true);
        }
        let tag = if go { "m" } else { "w" };
        let t = wall_ns();
        let outcome = write(session, stream, self.writer, &string_msg(&format!("{tag} {} {t}", self.index)))?;
        let name = if outcome == Written::Dropped { "dropped" } else { "written" };
        (session.callbacks().sink)(
            Event::new(name)
                .with("tag", Val::S(tag.into()))
                .with("i", Val::U(self.index))
                .with("t", Val::U(t))
                .with("confirmed", Val::B(outcome == Written::Confirmed)),
        );
        self.index += 1;
        if go {
            self.counted += 1;
        } else {
            self.warmup += 1;
        }
        Ok(true)
    }
}

/// The calling side of a client: one SetBool call at a time, again after `timeout_ms` without reply.
struct Calling {
    requester: ObjectId,
    calls: u32,
    timeout: Duration,
    sent: u32,
    ok: u64,
    pending: Option<(u16, bool, Instant)>,
}

impl Calling {
    fn new(requester: ObjectId, calls: u32, timeout_ms: u64) -> Self {
        Self { requester, calls, timeout: Duration::from_millis(timeout_ms), sent: 0, ok: 0, pending: None }
    }

    fn wait_ms(&self) -> u64 {
        if self.pending.is_some() {
            5
        } else {
            20
        }
    }

    fn step(&mut self, session: &mut Udp<'_, '_>, stream: StreamId) -> Result<bool, Error> {
        if let Some((id, value, at)) = self.pending {
            let replies = std::mem::take(&mut session.callbacks().replies);
            for (reply_id, when, data) in replies {
                let parsed = parse_set_bool_response(&data);
                let matches = reply_id == id;
                let rtt_ms = when.saturating_duration_since(at).as_secs_f64() * 1e3;
                let (success, message) = parsed.unwrap_or((false, String::new()));
                // Both ends answer `success = data` and `"<who> <data> <n>"`.
                let correct = matches
                    && success == value
                    && message.split(' ').nth(1) == Some(if value { "true" } else { "false" });
                if matches {
                    self.pending = None;
                    self.ok += u64::from(correct);
                }
                (session.callbacks().sink)(
                    Event::new("reply")
                        .with("call", Val::U(u64::from(self.sent.saturating_sub(1))))
                        .with("request", Val::B(value))
                        .with("rtt_ms", Val::F(rtt_ms))
                        .with("success", Val::B(success))
                        .with("message", Val::S(message))
                        .with("for_pending", Val::B(matches))
                        .with("correct", Val::B(correct)),
                );
            }
            if let Some((_, _, at)) = self.pending {
                if at.elapsed() < self.timeout {
                    return Ok(true);
                }
                (session.callbacks().sink)(
                    Event::new("call_timeout").with("call", Val::U(u64::from(self.sent.saturating_sub(1)))),
                );
                self.pending = None;
            }
        }
        if self.sent >= self.calls {
            return Ok(false);
        }
        let value = self.sent.is_multiple_of(2);
        let id = session.buffer_request(stream, self.requester, &set_bool_request(value))?;
        let at = Instant::now();
        // As rmw_send_request: the request is confirmed before the call returns.
        session.run_session_until_confirm_delivery(CONFIRM_MS)?;
        self.pending = Some((id, value, at));
        (session.callbacks().sink)(
            Event::new("call").with("call", Val::U(u64::from(self.sent))).with("request", Val::B(value)),
        );
        self.sent += 1;
        Ok(true)
    }
}

/// What a PX4-like client does.
#[derive(Debug, Clone)]
pub struct Px4Plan {
    pub agent: String,
    pub port: u16,
    pub key: u32,
    pub domain: u16,
    /// `rt/fmu/out/<topic>`, best effort, std_msgs/String, on the best-effort output stream.
    pub publish: Option<PubPlan>,
    /// `rt/fmu/in/<topic>`, best effort, std_msgs/String, delivered on the best-effort input stream.
    pub subscribe: Option<String>,
    /// `rq/fmu/<name>Request` / `rr/fmu/<name>Reply` SetBool replier (reliable).
    pub serve: Option<String>,
    pub run_for: Duration,
}

/// The participant PX4 creates (without a namespace).
pub const PX4_PARTICIPANT_XML: &str =
    "<dds><participant><rtps><name>px4_micro_xrce_dds</name></rtps></participant></dds>";

/// Runs a PX4-like client: time sync, participant by XML (REPLACE), then per topic a topic, a publisher and a
/// datawriter in binary (best effort, transient local, keep-last depth 0) awaited together, readers likewise
/// (best effort, volatile) and a replier (reliable); data on the best-effort output stream.
pub fn run_px4(
    plan: &Px4Plan,
    control: &Control,
    sink: &mut dyn FnMut(Event),
) -> Result<(), Box<dyn std::error::Error>> {
    let transport = UdpTransport::new(IpProtocol::V4, &plan.agent, &plan.port.to_string())?;
    let (mut rel_out_buf, mut be_out_buf, mut in_buf) = ([0u8; BUF], [0u8; 512], [0u8; BUF]);
    let handler = Handler { sink, out: None, replier: None, requests: 0, replies: Vec::new(), samples: 0 };
    let mut session: Udp<'_, '_> = Session::new(transport, plan.key).with_callbacks(handler);
    session.create_session()?;
    (session.callbacks().sink)(Event::new("session").with("key", Val::U(u64::from(plan.key))));
    let be_out = session.create_output_best_effort_stream(&mut be_out_buf)?;
    let rel_out = session.create_output_reliable_stream(&mut rel_out_buf, HISTORY)?;
    let be_in = session.create_input_best_effort_stream()?;
    let rel_in = session.create_input_reliable_stream(&mut in_buf, HISTORY)?;
    session.callbacks().out = Some(rel_out);
    let synced = session.sync_session(1000)?;
    (session.callbacks().sink)(Event::new("time_sync").with("ok", Val::B(synced)));
    let control_all = DeliveryControl { max_samples: DeliveryControl::UNLIMITED, ..Default::default() };
    let string_type = msg_type("std_msgs", "String");

    let participant = object_id(1, ObjectKind::Participant);
    let r = session.buffer_create_participant_xml(rel_out, participant, plan.domain, PX4_PARTICIPANT_XML, REPLACE)?;
    create(&mut session, r, "participant", "px4_micro_xrce_dds", 1000)?;

    let mut writer = None;
    if let Some(p) = &plan.publish {
        let name = format!("rt/fmu/out/{}", p.topic);
        let topic = object_id(1, ObjectKind::Topic);
        let publisher = object_id(1, ObjectKind::Publisher);
        let dw = object_id(1, ObjectKind::DataWriter);
        let qos = QoS {
            reliability: Reliability::BestEffort,
            durability: Durability::TransientLocal,
            history: History::KeepLast,
            depth: 0,
        };
        let reqs = [
            session.buffer_create_topic_bin(rel_out, topic, participant, &name, &string_type, REPLACE)?,
            session.buffer_create_publisher_bin(rel_out, publisher, participant, REPLACE)?,
            session.buffer_create_datawriter_bin(rel_out, dw, publisher, topic, qos, REPLACE)?,
        ];
        let mut status = [0u8; 3];
        let ok = session.run_session_until_all_status(1000, &reqs, &mut status)?;
        (session.callbacks().sink)(
            Event::new("created")
                .with("entity", Val::S("datawriter".into()))
                .with("name", Val::S(name.clone()))
                .with("ok", Val::B(ok)),
        );
        if !ok {
            return Err(format!("creating the writer of {name}: {status:?}").into());
        }
        writer = Some((dw, p.clone()));
    }
    if let Some(t) = &plan.subscribe {
        let name = format!("rt/fmu/in/{t}");
        // PX4 numbers its readers from the middle of the id space.
        let id = 0x800;
        let topic = object_id(id, ObjectKind::Topic);
        let subscriber = object_id(id, ObjectKind::Subscriber);
        let dr = object_id(id, ObjectKind::DataReader);
        let qos = QoS {
            reliability: Reliability::BestEffort,
            durability: Durability::Volatile,
            history: History::KeepLast,
            depth: 5,
        };
        let reqs = [
            session.buffer_create_topic_bin(rel_out, topic, participant, &name, &string_type, REPLACE)?,
            session.buffer_create_subscriber_bin(rel_out, subscriber, participant, REPLACE)?,
            session.buffer_create_datareader_bin(rel_out, dr, subscriber, topic, qos, REPLACE)?,
        ];
        let mut status = [0u8; 3];
        let ok = session.run_session_until_all_status(1000, &reqs, &mut status)?;
        (session.callbacks().sink)(
            Event::new("created")
                .with("entity", Val::S("datareader".into()))
                .with("name", Val::S(name.clone()))
                .with("ok", Val::B(ok)),
        );
        if !ok {
            return Err(format!("creating the reader of {name}: {status:?}").into());
        }
        session.buffer_request_data(rel_out, dr, be_in, Some(&control_all))?;
    }
    if let Some(s) = &plan.serve {
        let bare = s.trim_start_matches('/');
        let n = [
            bare.to_string(),
            "std_srvs::srv::dds_::SetBool_Request_".to_string(),
            "std_srvs::srv::dds_::SetBool_Response_".to_string(),
            format!("rq/fmu/{bare}Request"),
            format!("rr/fmu/{bare}Reply"),
        ];
        let replier = object_id(0x800, ObjectKind::Replier);
        let qos = QoS {
            reliability: Reliability::Reliable,
            durability: Durability::Persistent,
            history: History::KeepLast,
            depth: 1,
        };
        let r = session.buffer_create_replier_bin(rel_out, replier, participant, &names(&n), qos, REPLACE)?;
        create(&mut session, r, "replier", &n[3], 1000)?;
        session.buffer_request_data(rel_out, replier, rel_in, Some(&control_all))?;
        session.callbacks().replier = Some(replier);
    }

    let started = Instant::now();
    let mut pubber = writer.map(|(dw, p)| Publishing::new(dw, p));
    while !control.stop.load(Ordering::Relaxed) && started.elapsed() < plan.run_for {
        let busy = match pubber.as_mut() {
            Some(p) => p.step(&mut session, be_out, control)?,
            None => false,
        };
        if !busy && plan.serve.is_none() && plan.subscribe.is_none() {
            break;
        }
        let wait = pubber.as_ref().map_or(20, |p| p.wait_ms());
        session.run_session_timeout(i32::try_from(wait).unwrap_or(20))?;
    }
    // Best effort: nothing to confirm; give the last datagrams a moment on the way.
    session.run_session_timeout(50)?;
    let h = session.callbacks();
    let done = Event::new("done")
        .with("written", Val::U(pubber.as_ref().map_or(0, |p| p.counted)))
        .with("warmup", Val::U(pubber.as_ref().map_or(0, |p| p.warmup)))
        .with("received", Val::U(h.samples))
        .with("requests_served", Val::U(h.requests));
    (h.sink)(done);
    let _ = session.delete_session();
    Ok(())
}

/// `--name value` pairs of the examples' command lines.
#[derive(Debug, Default)]
pub struct Args(Vec<(String, String)>);

impl Args {
    /// Parses `std::env::args()`; every option takes a value; `--help` prints the known names and exits.
    pub fn parse(known: &[&str]) -> Result<Self, String> {
        let mut out = Vec::new();
        let mut it = std::env::args().skip(1);
        while let Some(a) = it.next() {
            let Some(name) = a.strip_prefix("--") else { return Err(format!("unexpected argument {a:?}")) };
            if name == "help" || name == "h" {
                println!("options: {}", known.iter().map(|k| format!("--{k} V")).collect::<Vec<_>>().join(" "));
                std::process::exit(0);
            }
            if !known.contains(&name) {
                return Err(format!("unknown option --{name} (known: {known:?})"));
            }
            let value = it.next().ok_or_else(|| format!("--{name} needs a value"))?;
            out.push((name.to_string(), value));
        }
        Ok(Self(out))
    }

    pub fn get(&self, name: &str) -> Option<&str> {
        self.0.iter().rev().find(|(k, _)| k == name).map(|(_, v)| v.as_str())
    }

    pub fn num<N: std::str::FromStr>(&self, name: &str, default: N) -> Result<N, String> {
        match self.get(name) {
            None => Ok(default),
            Some(v) => v.parse().map_err(|_| format!("--{name}: not a number: {v:?}")),
        }
    }

    /// `--pub TOPIC [--count N] [--period-ms MS]`, with these defaults; `None` without `--pub`.
    pub fn pub_plan(&self, count: u64, period_ms: u64) -> Result<Option<PubPlan>, String> {
        let Some(topic) = self.get("pub") else { return Ok(None) };
        Ok(Some(PubPlan {
            topic: topic.to_string(),
            count: self.num("count", count)?,
            period_ms: self.num("period-ms", period_ms)?,
            max_warmup: 0,
        }))
    }
}
