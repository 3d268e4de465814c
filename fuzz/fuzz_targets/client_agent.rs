//! The client's session core against an arbitrary agent (structure-aware, `arbitrary`): the "agent" answers
//! with well-formed submessages whose fields are arbitrary (STATUS_AGENT, STATUS, DATA whole and in FRAGMENTs,
//! HEARTBEAT, ACKNACK, TIMESTAMP_REPLY), loses, repeats and reorders its reliable messages, or sends any bytes;
//! the application writes, fragments, reads, pings, syncs, deletes and re-creates the session while time
//! passes. It must never panic, and everything the client sends must parse.
#![no_main]

use arbitrary::Arbitrary;
use libfuzzer_sys::fuzz_target;
use xrce_client::prelude::*;
use xrce_proto::message::encode_single;
use xrce_proto::object::AgentRepresentation;
use xrce_proto::submessage::{AckNack, DataFormat, DataPayload, Heartbeat, StatusAgent, TimestampReply};
use xrce_proto::{
    BaseObjectReply, BaseObjectRequest, ClientKey, Endianness, MessageHeader, ObjectId as RawObjectId, RequestId,
    ResultStatus, StatusCode, StreamId as RawStreamId, Submessage, Time,
};

const MS: i64 = 1_000_000;

#[derive(Arbitrary, Debug)]
enum AgentSays {
    StatusAgent { status: u8, session: Option<u8> },
    Status { request: u16, object: u16, status: u8, reliable: bool },
    Data { reliable: bool, request: u16, object: u16, format: u8, sample: Vec<u8> },
    Fragmented { request: u16, sample: Vec<u8>, piece: u8 },
    Heartbeat { first: u16, last: u16, stream: u8 },
    AckNack { first: u16, bitmap: u16, stream: u8 },
    TimestampReply { transmit: (i32, u32), receive: (i32, u32), originate: (i32, u32) },
    Any { header: Option<(u8, u8, u16)>, bytes: Vec<u8> },
}

#[derive(Arbitrary, Debug)]
enum Step {
    Agent(AgentSays),
    /// The agent's reliable sequence jumps (its messages lost).
    AgentLoses(u8),
    /// The agent sends its `n`-th last reliable message again.
    AgentRepeats(u8),
    Write {
        reliable: bool,
        sample: Vec<u8>,
    },
    WriteFragmented {
        size: u16,
        pushes: Vec<u16>,
    },
    Request {
        reliable: bool,
        data_stream: u8,
    },
    DeleteEntity(u16),
    Ping {
        attempts: u8,
    },
    Sync,
    CreateSession,
    DeleteSession,
    Reconnect,
    Time(u16),
}

/// The agent's side: its reliable sequence number and last reliable messages.
struct Agent {
    reliable_seq: u16,
    best_effort_seq: u16,
    sent: Vec<Vec<u8>>,
}

impl Agent {
    fn message(&mut self, reliable: bool, sub: &Submessage<'_>) -> Option<Vec<u8>> {
        let (stream, seq) = if reliable {
            self.reliable_seq = self.reliable_seq.wrapping_add(1);
            (0x80, self.reliable_seq.wrapping_sub(1))
        } else {
            self.best_effort_seq = self.best_effort_seq.wrapping_add(1);
            (0x01, self.best_effort_seq)
        };
        let m = encode(&MessageHeader::new(0x81, RawStreamId(stream), seq, ClientKey::INVALID), sub)?;
        if reliable {
            if self.sent.len() >= 8 {
                self.sent.remove(0);
            }
            self.sent.push(m.clone());
        }
        Some(m)
    }

    fn says(&mut self, what: &AgentSays) -> Vec<Vec<u8>> {
        let reply = |request: u16, object: u16, status: u8| BaseObjectReply {
            related_request: BaseObjectRequest {
                request_id: RequestId(request),
                object_id: RawObjectId(object.to_be_bytes()),
            },
            result: ResultStatus::new(StatusCode(status)),
        };
        let control =
            |sub: &Submessage<'_>| encode(&MessageHeader::new(0x81, RawStreamId(0), 0, ClientKey::INVALID), sub);
        let time = |(seconds, nanoseconds): (i32, u32)| Time { seconds, nanoseconds };
        let mut out = Vec::new();
        match what {
            AgentSays::StatusAgent { status, session } => {
                let sub = Submessage::StatusAgent(StatusAgent {
                    result: ResultStatus::new(StatusCode(*status)),
                    agent: AgentRepresentation::EPROSIMA,
                });
                let header = MessageHeader::new(session.unwrap_or(0x81), RawStreamId(0), 0, ClientKey::INVALID);
                out.extend(encode(&header, &sub));
            }
            AgentSays::Status { request, object, status, reliable } => {
                let sub = Submessage::Status(reply(*request, *object, *status));
                out.extend(if *reliable { self.message(true, &sub) } else { control(&sub) });
            }
            AgentSays::Data { reliable, request, object, format, sample } => {
                let request =
                    BaseObjectRequest { request_id: RequestId(*request), object_id: RawObjectId(object.to_be_bytes()) };
                let sub = Submessage::Data(DataPayload { request, format: DataFormat(format & 0x0E), data: sample });
                out.extend(self.message(*reliable, &sub));
            }
            AgentSays::Fragmented { request, sample, piece } => {
                let request = BaseObjectRequest { request_id: RequestId(*request), object_id: RawObjectId([0, 0x16]) };
                let sub = Submessage::Data(DataPayload { request, format: DataFormat::DATA, data: sample });
                let Some(inner) = encode(&MessageHeader::new(0x81, RawStreamId(0x80), 0, ClientKey::INVALID), &sub)
                else {
                    return out;
                };
                let body = inner.get(4..).unwrap_or(&[]);
                let piece = usize::from(*piece).max(1);
                let count = body.len().div_ceil(piece);
                for (i, slice) in body.chunks(piece).enumerate() {
                    out.extend(self.message(true, &Submessage::Fragment { last: i + 1 == count, data: slice }));
                }
            }
            AgentSays::Heartbeat { first, last, stream } => {
                let hb = Heartbeat { first_unacked_seq_nr: *first, last_unacked_seq_nr: *last, stream_id: *stream };
                out.extend(control(&Submessage::Heartbeat(hb)));
            }
            AgentSays::AckNack { first, bitmap, stream } => {
                let ack =
                    AckNack { first_unacked_seq_num: *first, nack_bitmap: bitmap.to_be_bytes(), stream_id: *stream };
                out.extend(control(&Submessage::AckNack(ack)));
            }
            AgentSays::TimestampReply { transmit, receive, originate } => {
                let sub = Submessage::TimestampReply(TimestampReply {
                    transmit_timestamp: time(*transmit),
                    receive_timestamp: time(*receive),
                    originate_timestamp: time(*originate),
                });
                out.extend(control(&sub));
            }
            AgentSays::Any { header, bytes } => {
                let mut m = Vec::new();
                if let Some((session, stream, seq)) = header {
                    m.extend_from_slice(&[*session, *stream]);
                    m.extend_from_slice(&seq.to_le_bytes());
                }
                m.extend_from_slice(bytes);
                out.push(m);
            }
        }
        out
    }
}

fn encode(header: &MessageHeader, sub: &Submessage<'_>) -> Option<Vec<u8>> {
    let mut buf = vec![0u8; 4096];
    let n = encode_single(&mut buf, header, sub, Endianness::Little).ok()?;
    buf.truncate(n);
    Some(buf)
}

fuzz_target!(|steps: Vec<Step>| {
    let (mut rel_out, mut be_out, mut rel_in) = ([0u8; 2048], [0u8; 512], [0u8; 2048]);
    let mut core: SessionCore<'_, 1, 1, 1, 1> = SessionCore::new(0x81, 0xAABB_CCDD, 512);
    let mut now: i64 = 1_700_000_000_000_000_000;
    let mut out = [0u8; 512];
    core.create_session(now);
    while core.poll_transmit(now, &mut out).is_some() {}
    let mut agent = Agent { reliable_seq: 0, best_effort_seq: 0, sent: Vec::new() };
    for m in agent.says(&AgentSays::StatusAgent { status: 0, session: None }) {
        core.handle_input(&m, now, &mut ());
    }
    let (Ok(rel), Ok(be)) =
        (core.create_output_reliable_stream(&mut rel_out, 4), core.create_output_best_effort_stream(&mut be_out))
    else {
        return;
    };
    let (Ok(rel_in), Ok(be_in)) =
        (core.create_input_reliable_stream(&mut rel_in, 4), core.create_input_best_effort_stream())
    else {
        return;
    };
    let writer = object_id(1, ObjectKind::DataWriter);
    let reader = object_id(1, ObjectKind::DataReader);
    for step in steps.iter().take(256) {
        let mut inbound = Vec::new();
        match step {
            Step::Agent(what) => inbound = agent.says(what),
            Step::AgentLoses(n) => agent.reliable_seq = agent.reliable_seq.wrapping_add(u16::from(*n)),
            Step::AgentRepeats(back) => {
                let n = agent.sent.len();
                if n > 0 {
                    inbound.extend(agent.sent.get(n - 1 - usize::from(*back) % n).cloned());
                }
            }
            Step::Write { reliable, sample } => {
                let _ = core.buffer_topic(if *reliable { rel } else { be }, writer, sample);
            }
            Step::WriteFragmented { size, pushes } => {
                if core.outputs().begin_fragmented(rel, writer, usize::from(*size)).is_ok() {
                    for &p in pushes.iter().take(8) {
                        let _ = core.outputs().push_fragmented(rel, &vec![0x5A; usize::from(p % 2048)]);
                    }
                }
            }
            Step::Request { reliable, data_stream } => {
                let data_stream = if *data_stream & 1 == 0 { rel_in } else { be_in };
                let stream = if *reliable { rel } else { be };
                let _ = core.outputs().buffer_request_data(stream, reader, data_stream, None);
            }
            Step::DeleteEntity(raw) => {
                let _ = core.outputs().buffer_delete_entity(rel, xrce_client::ObjectId::from_raw(*raw));
            }
            Step::Ping { attempts } => core.ping(100, usize::from(*attempts % 4), now),
            Step::Sync => core.sync(),
            Step::CreateSession => core.create_session(now),
            Step::DeleteSession => core.delete_session(now),
            Step::Reconnect => core.reconnect(now),
            Step::Time(ms) => now += i64::from(*ms) * MS,
        }
        core.flash_output_streams();
        for m in &inbound {
            core.handle_input(m, now, &mut ());
        }
        while let Some(n) = core.poll_transmit(now, &mut out) {
            xrce_fuzz::assert_parses(out.get(..n).unwrap_or(&[]), "client");
        }
        while core.poll_event().is_some() {}
        if let Some(t) = core.poll_timeout() {
            assert!(t >= now - 1_000 * MS, "a deadline more than a second in the past");
        }
    }
});
