//! The continuous fragmented API (`prepare_output_stream_fragmented`): a sample larger than the whole reliable
//! history, written through a `FragmentedWriter` whose flush callback runs the session until the agent
//! acknowledges. An in-memory agent acknowledges every message; the fragments are then reassembled by a
//! receiving core and compared with the CDR the writer was asked to produce.

mod common;

use common::Collect;
use std::collections::{BTreeMap, VecDeque};
use xrce_client::prelude::*;
use xrce_client::TransportError;

/// An agent in memory: accepts the session and acknowledges every reliable message; keeps them by sequence.
#[derive(Default)]
struct AckingAgent {
    replies: VecDeque<Vec<u8>>,
    reliable: BTreeMap<u16, Vec<u8>>,
    flushes: usize,
}

impl Transport for AckingAgent {
    fn send(&mut self, msg: &[u8]) -> Result<(), TransportError> {
        match (msg[1], msg[4]) {
            (0x00, 0x00) => {
                self.replies.push_back(common::hex("81 00 00 00 04 01 0B 00 00 00 58 52 43 45 01 00 01 0F 00"))
            }
            (0x80, _) => {
                let seq = u16::from_le_bytes([msg[2], msg[3]]);
                self.reliable.insert(seq, msg.to_vec());
                let [a, b] = seq.wrapping_add(1).to_le_bytes();
                self.replies.push_back(vec![0x81, 0, 0, 0, 0x0A, 1, 5, 0, a, b, 0, 0, 0x80]);
            }
            _ => {}
        }
        Ok(())
    }

    fn recv(&mut self, buf: &mut [u8], _timeout_ms: i32) -> Result<Option<usize>, TransportError> {
        match self.replies.pop_front() {
            Some(m) => {
                buf[..m.len()].copy_from_slice(&m);
                Ok(Some(m.len()))
            }
            None => {
                std::thread::sleep(std::time::Duration::from_millis(1));
                Ok(None)
            }
        }
    }
}

/// The CDR of `{ u32 7, string "x" * 2000, sequence<octet> 0..900 }`.
fn expected() -> Vec<u8> {
    let mut v = 7u32.to_le_bytes().to_vec();
    v.extend(2001u32.to_le_bytes());
    v.extend(std::iter::repeat_n(b'x', 2000));
    v.push(0);
    while !v.len().is_multiple_of(4) {
        v.push(0);
    }
    v.extend(900u32.to_le_bytes());
    v.extend((0..900u32).map(|i| (i % 251) as u8));
    v
}

#[test]
fn fragmented_sample_larger_than_the_history() {
    let expected = expected();
    let octets: Vec<u8> = (0..900u32).map(|i| (i % 251) as u8).collect();
    let mut out_buf = [0u8; 2048]; // 4 slots of 512: the 2.9 KB sample needs the history about twice over
    let mut session = Session::new(AckingAgent::default(), 0xAAAA_BBBB);
    session.create_session().unwrap();
    let out = session.create_output_reliable_stream(&mut out_buf, 4).unwrap();
    let writer = object_id(1, ObjectKind::DataWriter);
    let flush = |s: &mut Session<'_, AckingAgent, StdClock>| {
        s.transport().flushes += 1;
        s.run_session_until_confirm_delivery(1000).unwrap()
    };
    let mut w = session.prepare_output_stream_fragmented(out, writer, expected.len(), flush).unwrap();
    w.write_u32(7).unwrap();
    w.write_string(&"x".repeat(2000)).unwrap();
    w.write_octet_seq(&octets).unwrap();
    assert_eq!(w.position(), expected.len());
    assert_eq!(w.write_bytes(&[1]), Err(Error::TooLarge), "nothing beyond the announced size");
    w.finish().unwrap();
    assert!(session.run_session_until_confirm_delivery(1000).unwrap());
    let agent = session.into_transport();
    assert!(agent.flushes >= 1, "the history filled up and the callback ran");

    // Every message went out exactly once, in sequence; reassemble them as DATA in a receiving core.
    let msgs: Vec<Vec<u8>> = agent.reliable.into_values().collect();
    assert!(msgs.len() > 4, "{} messages", msgs.len());
    let mut receiver: SessionCore<'_> = SessionCore::new(0x81, 0xAAAA_BBBB, 512);
    receiver.create_session(0);
    let mut probe = [0u8; 512];
    receiver.poll_transmit(0, &mut probe);
    receiver.handle_input(&common::hex("81 00 00 00 04 01 0B 00 00 00 58 52 43 45 01 00 01 0F 00"), 0, &mut ());
    let mut in_buf = vec![0u8; 16 * 512];
    receiver.create_input_reliable_stream(&mut in_buf, 16).unwrap();
    let mut seen = Collect::default();
    for (i, m) in msgs.iter().enumerate() {
        let mut m = m.clone();
        if i == 0 {
            assert_eq!(m[4], 0x0D, "a FRAGMENT first");
            m[8] = 0x09; // the inner WRITE_DATA becomes the DATA an agent would deliver
        }
        receiver.handle_input(&m, 0, &mut seen);
    }
    assert_eq!(seen.topics.len(), 1);
    assert_eq!(seen.topics[0].3, expected);
}

#[test]
fn fragmented_write_stops_when_the_flush_callback_gives_up() {
    let mut out_buf = [0u8; 2048];
    let mut session = Session::new(AckingAgent::default(), 0xAAAA_BBBB);
    session.create_session().unwrap();
    let out = session.create_output_reliable_stream(&mut out_buf, 4).unwrap();
    let mut w =
        session.prepare_output_stream_fragmented(out, object_id(1, ObjectKind::DataWriter), 5000, |_| false).unwrap();
    assert_eq!(w.write_bytes(&[0u8; 5000]), Err(Error::WouldBlock));
    assert!(w.position() > 0 && w.position() < 5000);
}

#[test]
fn fragmented_write_on_a_best_effort_stream_is_refused() {
    let mut out_buf = [0u8; 512];
    let mut session = Session::new(AckingAgent::default(), 0xAAAA_BBBB);
    session.create_session().unwrap();
    let be = session.create_output_best_effort_stream(&mut out_buf).unwrap();
    let r = session.prepare_output_stream_fragmented(be, object_id(1, ObjectKind::DataWriter), 100, |_| true);
    assert_eq!(r.err(), Some(Error::UnknownStream));
}
