//! Reconnection in the sans-IO core, on a virtual clock: when a silent agent is probed and counted as lost, how
//! the attempts tell a surviving agent (the session resumes) from one that lost the session (it is created
//! again), and what the reliable output becomes in each case. The blocking session over a scripted transport
//! then shows the replay order after a re-creation: entity creations with REUSE, reads, then the data the agent
//! never acknowledged.

use std::cell::Cell;
use std::collections::VecDeque;
use std::rc::Rc;

use xrce_client::prelude::*;
use xrce_client::session::MILLIS;
use xrce_client::{Reconnect, SessionEvent, SessionState, TransportError};
use xrce_proto::cdr::{Endianness, Seq};
use xrce_proto::message::{encode_single, parse};
use xrce_proto::object::AgentRepresentation;
use xrce_proto::submessage::{id, ActivityInfo, Info, StatusAgent};
use xrce_proto::{
    BaseObjectReply, BaseObjectRequest, ClientKey, MessageHeader, ObjectVariant, RequestId, ResultStatus, StatusCode,
    Submessage,
};

const KEY: u32 = 0x1234_5678;
const SESSION: u8 = 0x81;
const MS: i64 = MILLIS;

fn status_agent() -> Vec<u8> {
    let header = MessageHeader::new(SESSION, StreamId::NONE, 0, ClientKey::from_u32(KEY));
    let sub = Submessage::StatusAgent(StatusAgent {
        result: ResultStatus::new(StatusCode::OK),
        agent: AgentRepresentation::EPROSIMA,
    });
    let mut buf = [0u8; 128];
    let n = encode_single(&mut buf, &header, &sub, Endianness::Little).unwrap();
    buf[..n].to_vec()
}

/// An INFO as an agent answers a GET_INFO: in the session (`SESSION`) or outside it (0x80); `known` is the
/// implementation status (1: the agent holds the session).
fn info(session_id: u8, known: u8) -> Vec<u8> {
    let header = MessageHeader::new(session_id, StreamId::NONE, 0, ClientKey::from_u32(KEY));
    let sub = Submessage::Info(Info {
        reply: BaseObjectReply {
            related_request: BaseObjectRequest { request_id: RequestId::PING, object_id: ObjectId::AGENT },
            result: ResultStatus { status: StatusCode::OK, implementation_status: known },
        },
        config: Some(ObjectVariant::Agent(AgentRepresentation::EPROSIMA)),
        activity: Some(ActivityInfo::Agent { availability: 1, address_seq: Seq::EMPTY }),
    });
    let mut buf = [0u8; 256];
    let n = encode_single(&mut buf, &header, &sub, Endianness::Little).unwrap();
    buf[..n].to_vec()
}

/// Every message the core wants to send now: (session id, stream, sequence number, first submessage id).
fn drain(core: &mut SessionCore<'_>, now: i64) -> Vec<(u8, u8, u16, u8)> {
    let mut out = Vec::new();
    let mut buf = [0u8; 512];
    while let Some(n) = core.poll_transmit(now, &mut buf) {
        let (header, mut subs) = parse(&buf[..n]).unwrap();
        let first = subs.next().unwrap().unwrap().header.id;
        out.push((header.session_id, header.stream_id.0, header.sequence_nr, first));
    }
    out
}

fn established<'a>() -> SessionCore<'a> {
    let mut core = SessionCore::new(SESSION, KEY, 512);
    core.set_reconnect(Some(Reconnect::default()));
    core.create_session(0);
    assert_eq!(drain(&mut core, 0), [(0x80, 0, 0, id::CREATE_CLIENT)]);
    core.handle_input(&status_agent(), 0, &mut ());
    assert_eq!(core.state(), SessionState::Established);
    core
}

#[test]
fn silence_is_probed_then_the_session_is_lost() {
    let mut core = established();
    assert!(drain(&mut core, 499 * MS).is_empty(), "no probe within 500 ms of the last answer");
    assert_eq!(drain(&mut core, 500 * MS), [(SESSION, 0, 0, id::GET_INFO)]);
    assert_eq!(drain(&mut core, 1000 * MS), [(SESSION, 0, 0, id::GET_INFO)]);
    assert_eq!(core.poll_event(), None);
    // Lost 1.5 s after the first unanswered probe; the first attempt goes at once, in and out of the session.
    assert_eq!(drain(&mut core, 2000 * MS), [(SESSION, 0, 0, id::GET_INFO), (0x80, 0, 0, id::GET_INFO)]);
    assert_eq!(core.state(), SessionState::Reconnecting);
    assert_eq!(core.poll_event(), Some(SessionEvent::Lost));
    // Attempts back off: 100 ms, then 200 ms.
    assert!(drain(&mut core, 2099 * MS).is_empty());
    assert_eq!(drain(&mut core, 2100 * MS).len(), 2);
    assert!(drain(&mut core, 2299 * MS).is_empty());
    assert_eq!(drain(&mut core, 2300 * MS).len(), 2);
}

#[test]
fn an_answer_resets_the_probe_and_a_late_run_is_not_a_loss() {
    let mut core = established();
    assert_eq!(drain(&mut core, 600 * MS).len(), 1, "probe");
    core.handle_input(&info(SESSION, 1), 610 * MS, &mut ());
    assert!(drain(&mut core, 1100 * MS).is_empty(), "answered: next probe 500 ms after the answer");
    // The application did not run the session for 10 s: that alone is no loss, a probe goes first.
    assert_eq!(drain(&mut core, 11_000 * MS), [(SESSION, 0, 0, id::GET_INFO)]);
    assert_eq!(core.state(), SessionState::Established);
    drain(&mut core, 12_499 * MS);
    assert_eq!(core.state(), SessionState::Established);
    drain(&mut core, 12_500 * MS);
    assert_eq!(core.state(), SessionState::Reconnecting);
}

/// Writes three samples on a reliable stream and sends them (none acknowledged).
fn write_three(core: &mut SessionCore<'_>, stream: StreamId, now: i64) {
    let writer = object_id(1, ObjectKind::DataWriter);
    let mut sent = Vec::new();
    for i in 0u8..3 {
        core.outputs().buffer_topic(stream, writer, &[i; 8]).unwrap();
        core.flash_output_streams();
        sent.extend(drain(core, now));
    }
    assert_eq!(sent.iter().filter(|m| m.1 == 0x80).map(|m| m.2).collect::<Vec<_>>(), [0, 1, 2]);
}

#[test]
fn a_surviving_agent_resumes_the_session_as_it_was() {
    let mut buf = [0u8; 4 * 256];
    let mut core = established();
    let stream = core.create_output_reliable_stream(&mut buf, 4).unwrap();
    write_three(&mut core, stream, 10 * MS);
    core.reconnect(20 * MS);
    assert_eq!(core.poll_event(), Some(SessionEvent::Lost));
    assert_eq!(drain(&mut core, 20 * MS).len(), 2, "attempt");
    core.handle_input(&info(SESSION, 1), 25 * MS, &mut ());
    assert_eq!(core.state(), SessionState::Established);
    assert_eq!(core.poll_event(), Some(SessionEvent::Restored { recreated: false }));
    // No CREATE_CLIENT; the stream goes on with its own numbering (the agent kept it).
    let sent = drain(&mut core, 200 * MS);
    assert!(sent.iter().all(|m| m.3 != id::CREATE_CLIENT), "{sent:?}");
    assert!(sent.iter().any(|m| m.3 == id::HEARTBEAT), "the stream probes for its unacknowledged messages");
}

#[test]
fn an_agent_that_lost_the_session_gets_it_again_with_the_output_renumbered() {
    let mut buf = [0u8; 4 * 256];
    let mut core = established();
    let stream = core.create_output_reliable_stream(&mut buf, 4).unwrap();
    write_three(&mut core, stream, 10 * MS);
    // A probe answered "unknown session": lost and re-created at once.
    core.handle_input(&info(SESSION, 0), 30 * MS, &mut ());
    assert_eq!(core.poll_event(), Some(SessionEvent::Lost));
    assert_eq!(drain(&mut core, 30 * MS), [(0x80, 0, 0, id::CREATE_CLIENT)]);
    core.handle_input(&status_agent(), 40 * MS, &mut ());
    assert_eq!(core.poll_event(), Some(SessionEvent::Restored { recreated: true }));
    // The three unacknowledged messages go again, from sequence number 0.
    let sent: Vec<u16> = drain(&mut core, 40 * MS).iter().filter(|m| m.1 == 0x80).map(|m| m.2).collect();
    assert_eq!(sent, [0, 1, 2]);
}

#[test]
fn an_answer_outside_the_session_recreates_only_after_a_grace() {
    let mut core = established();
    core.reconnect(0);
    drain(&mut core, 0);
    core.handle_input(&info(0x80, 0), 10 * MS, &mut ());
    assert!(drain(&mut core, 209 * MS).iter().all(|m| m.3 != id::CREATE_CLIENT));
    assert_eq!(drain(&mut core, 210 * MS).last(), Some(&(0x80, 0, 0, id::CREATE_CLIENT)));

    // Same, but the answer in the session follows within the grace: resumed, never re-created.
    let mut core = established();
    core.reconnect(0);
    drain(&mut core, 0);
    core.handle_input(&info(0x80, 0), 10 * MS, &mut ());
    core.handle_input(&info(SESSION, 1), 50 * MS, &mut ());
    assert_eq!(core.state(), SessionState::Established);
    assert!(drain(&mut core, 400 * MS).iter().all(|m| m.3 != id::CREATE_CLIENT));
}

#[test]
fn reconnection_off_never_probes() {
    let mut core = SessionCore::<'_>::new(SESSION, KEY, 512);
    core.create_session(0);
    drain(&mut core, 0);
    core.handle_input(&status_agent(), 0, &mut ());
    assert!(drain(&mut core, 60_000 * MS).is_empty());
    core.reconnect(60_000 * MS);
    assert_eq!(core.state(), SessionState::Established);
}

/// A transport scripted by the test: what the client sent, what it will receive, and a shared virtual clock
/// that every `recv` advances by its timeout.
#[derive(Clone, Default)]
struct Script {
    now: Rc<Cell<i64>>,
    sent: Rc<std::cell::RefCell<Vec<Vec<u8>>>>,
    inbox: Rc<std::cell::RefCell<VecDeque<Vec<u8>>>>,
    /// Answer every in-session GET_INFO as an agent holding the session does.
    answer_probes: bool,
}

impl Transport for Script {
    fn send(&mut self, msg: &[u8]) -> Result<(), TransportError> {
        self.sent.borrow_mut().push(msg.to_vec());
        let (header, mut subs) = parse(msg).unwrap();
        let probe = header.session_id == SESSION && subs.next().unwrap().unwrap().header.id == id::GET_INFO;
        // No answer after 40 messages sent, so that a loop that never stops by itself still ends (and fails).
        if self.answer_probes && probe && self.sent.borrow().len() < 40 {
            self.inbox.borrow_mut().push_back(info(SESSION, 1));
        }
        Ok(())
    }
    fn recv(&mut self, buf: &mut [u8], timeout_ms: i32) -> Result<Option<usize>, TransportError> {
        if let Some(m) = self.inbox.borrow_mut().pop_front() {
            buf[..m.len()].copy_from_slice(&m);
            return Ok(Some(m.len()));
        }
        self.now.set(self.now.get() + i64::from(timeout_ms.max(1)) * MS);
        Ok(None)
    }
}

/// The submessages (id, flags) of the reliable messages sent, in order, from the first with `seq` 0 after
/// the message at `from`.
fn reliable_after(sent: &[Vec<u8>], from: usize) -> Vec<(u16, u8, u8)> {
    let mut out = Vec::new();
    for m in &sent[from..] {
        let (header, subs) = parse(m).unwrap();
        if header.stream_id.0 != 0x80 {
            continue;
        }
        for s in subs {
            let s = s.unwrap();
            out.push((header.sequence_nr, s.header.id, s.header.flags));
        }
    }
    out
}

#[test]
fn blocking_session_replays_entities_and_reads_before_the_unacknowledged_data() {
    let script = Script::default();
    let clock = {
        let now = script.now.clone();
        move || now.get()
    };
    let mut out_buf = [0u8; 4 * 256];
    let mut in_buf = [0u8; 4 * 256];
    let mut s: Session<'_, Script, _> = Session::with_clock(script.clone(), clock, KEY);
    script.inbox.borrow_mut().push_back(status_agent());
    s.create_session().unwrap();
    let out = s.create_output_reliable_stream(&mut out_buf, 4).unwrap();
    let inp = s.create_input_reliable_stream(&mut in_buf, 4).unwrap();
    let (p, t, pb, w, sb, r) = (
        object_id(1, ObjectKind::Participant),
        object_id(1, ObjectKind::Topic),
        object_id(1, ObjectKind::Publisher),
        object_id(1, ObjectKind::DataWriter),
        object_id(1, ObjectKind::Subscriber),
        object_id(1, ObjectKind::DataReader),
    );
    s.buffer_create_participant_ref(out, p, 0, "participant", REPLACE).unwrap();
    s.buffer_create_topic_ref(out, t, p, "topic", REPLACE).unwrap();
    s.buffer_create_publisher_bin(out, pb, p, REPLACE).unwrap();
    s.buffer_create_datawriter_ref(out, w, pb, "writer", REPLACE).unwrap();
    s.buffer_create_subscriber_bin(out, sb, p, REPLACE).unwrap();
    s.buffer_create_datareader_ref(out, r, sb, "reader", REPLACE).unwrap();
    s.flash_output_streams().unwrap();
    // A subscriber deleted again: it and its reader are not created again.
    s.buffer_delete_entity(out, sb).unwrap();
    let control = DeliveryControl { max_samples: DeliveryControl::UNLIMITED, ..Default::default() };
    s.buffer_request_data(out, w, inp, Some(&control)).unwrap(); // a continuous read (object kind aside)
    s.buffer_topic(out, w, &[7; 8]).unwrap();
    s.run_session_timeout(0).unwrap();
    assert_eq!(s.recorded_entities(), 4);

    // The agent restarted: its answer to a probe says it does not know the session.
    let mark = script.sent.borrow().len();
    script.inbox.borrow_mut().push_back(info(SESSION, 0));
    script.inbox.borrow_mut().push_back(status_agent());
    s.run_session_timeout(50).unwrap();
    let sent = script.sent.borrow().clone();
    let replayed = reliable_after(&sent, mark);
    let ids: Vec<u8> = replayed.iter().map(|r| r.1).collect();
    // The four creations still standing (REUSE set, REPLACE kept), the read, then what the agent never
    // acknowledged except the creations and reads already replayed: the DELETE and the sample.
    let expected = [id::CREATE, id::CREATE, id::CREATE, id::CREATE, id::READ_DATA, id::DELETE, id::WRITE_DATA];
    assert_eq!(ids, expected, "{replayed:?}");
    assert!(replayed[..4].iter().all(|r| r.2 & (REUSE | REPLACE) == REUSE | REPLACE));
    assert_eq!(replayed[0].0, 0, "the new session's stream starts at 0");
    let seqs: Vec<u16> = replayed.iter().map(|r| r.0).collect();
    assert!(seqs.windows(2).all(|w| w[0] <= w[1]), "in order: {seqs:?}");
}

#[test]
fn taken_output_can_be_given_back_in_order() {
    let mut buf = [0u8; 4 * 256];
    let mut core = established();
    let stream = core.create_output_reliable_stream(&mut buf, 4).unwrap();
    write_three(&mut core, stream, 10 * MS);
    let mut taken = Vec::new();
    core.take_reliable_output(stream, |body, frag| taken.push((body.to_vec(), frag))).unwrap();
    assert_eq!(taken.len(), 3);
    assert!(drain(&mut core, 20 * MS).iter().all(|m| m.1 != 0x80), "the stream is empty");
    for (body, frag) in &taken {
        core.restore_reliable_output(stream, body, *frag).unwrap();
    }
    let mut out = [0u8; 512];
    let mut payloads = Vec::new();
    while let Some(n) = core.poll_transmit(30 * MS, &mut out) {
        let (header, subs) = parse(&out[..n]).unwrap();
        if header.stream_id.0 == 0x80 {
            for sub in subs {
                let sub = sub.unwrap();
                payloads.push((header.sequence_nr, sub.payload()[4]));
            }
        }
    }
    // Taking restarts the numbering (it is meant for a re-created session, whose streams restart at 0).
    assert_eq!(payloads, [(0, 0), (1, 1), (2, 2)], "given back in order");
}

/// Answered probes are no messages for the application: `run_session_time`, which returns after a silence of
/// its timeout, still returns although the agent answers a probe every 300 ms.
#[test]
fn answered_probes_do_not_keep_run_session_time_running() {
    let script = Script { answer_probes: true, ..Script::default() };
    let clock = {
        let now = script.now.clone();
        move || now.get()
    };
    let config = Reconnect { probe_after_ms: 300, ..Reconnect::default() };
    let mut s: Session<'_, Script, _> = Session::with_clock(script.clone(), clock, KEY).with_reconnect(Some(config));
    script.inbox.borrow_mut().push_back(status_agent());
    s.create_session().unwrap();
    let start = script.now.get();
    s.run_session_time(1000).unwrap();
    let probes = script.sent.borrow().iter().filter(|m| parse(m).unwrap().0.session_id == SESSION).count();
    assert!(probes >= 3, "probes sent and answered meanwhile: {probes}");
    assert!(script.now.get() - start < 2000 * MS, "returned after its 1 s of silence");
}
