//! The agent core's cost per delivered sample, without sockets: one publisher and one subscriber of a CED
//! topic driven through `AgentCore` by hand-built messages (reliable streams, batches of 8 writes, the
//! subscriber acknowledging each batch), so a figure does not depend on the kernel or the scheduler. Prints
//! ns per sample; run it under `valgrind --tool=callgrind` for an instruction count that the machine's
//! noise does not move.
//!
//! usage: cargo run --release -p xrce-agent --example core_cost -- [SAMPLES] [PAYLOAD] [--best-effort]
//!
//! PAYLOAD up to one message (484 B at the clients' MTU of 508); the count of fragmented deliveries is not
//! reliable yet.

use std::sync::Arc;
use std::time::{Duration, Instant};

use xrce_agent::core::{AgentCore, CoreConfig};
use xrce_agent::middleware::ced::Ced;
use xrce_agent::middleware::describe::FallbackProfiles;
use xrce_proto::submessage::AckNack;
use xrce_proto::{message, ClientKey, Endianness, MessageHeader, StreamId, Submessage};

const PUBLISHER: u8 = 0;
const SUBSCRIBER: u8 = 1;

fn hex(s: &str) -> Vec<u8> {
    s.split_whitespace().filter_map(|b| u8::from_str_radix(b, 16).ok()).collect()
}

/// CREATE_CLIENT (session 0x81, `xrce_rs_pack` not set), then a binary participant, topic "t", publisher,
/// subscriber, writer #1 and reader #1 on reliable stream 0x80; sequence numbers 0..=5.
fn setup(core: &mut AgentCore<u8, Ced>, ep: u8, key: &str, now: Instant) {
    let create = hex(&format!("80 00 00 00 00 01 10 00 58 52 43 45 01 00 01 0f {key} 81 00 fc 01"));
    core.handle_datagram(ep, &create, now);
    for (seq, body) in [
        "01 05 10 00 00 0b 00 11 01 03 00 00 02 00 00 00 00 00 00 00",
        "01 05 1c 00 00 0c 00 12 02 03 00 00 0e 00 00 00 02 00 00 00 74 00 00 01 02 00 00 00 54 00 00 11",
        "01 05 10 00 00 0d 00 13 03 03 00 00 02 00 00 00 00 00 00 11",
        "01 05 10 00 00 0e 00 14 04 03 00 00 02 00 00 00 00 00 00 11",
        "01 05 11 00 00 0f 00 15 05 03 00 00 03 00 00 00 00 12 00 00 13",
        "01 05 11 00 00 10 00 16 06 03 00 00 03 00 00 00 00 12 00 00 14",
    ]
    .iter()
    .enumerate()
    {
        let mut m = vec![0x81, 0x80, seq as u8, 0];
        m.extend(hex(body));
        core.handle_datagram(ep, &m, now);
    }
    let mut out = Vec::new();
    while core.poll_transmit(now, &mut out).is_some() {}
}

/// The first unacknowledged sequence number an ACKNACK in `msg` gives, if it has one.
fn acknowledged(msg: &[u8]) -> Option<u16> {
    let (_, subs) = message::parse(msg).ok()?;
    subs.flatten().find_map(|raw| match raw.decode() {
        Ok(Submessage::AckNack(a)) => Some(a.first_unacked_seq_num),
        _ => None,
    })
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let samples: u32 = args.first().and_then(|a| a.parse().ok()).unwrap_or(200_000);
    let payload: usize = args.get(1).and_then(|a| a.parse().ok()).unwrap_or(16);
    let best_effort = args.iter().any(|a| a == "--best-effort");
    let mut now = Instant::now();
    let mut core = AgentCore::new(CoreConfig::default(), Ced::new(Arc::new(FallbackProfiles)));
    setup(&mut core, PUBLISHER, "aa bb cc dd", now);
    setup(&mut core, SUBSCRIBER, "11 22 33 44", now);
    // READ_DATA on reader #1 (0x0016), unlimited, delivered on 0x80 or best-effort 0x01.
    let stream = if best_effort { "01" } else { "80" };
    core.handle_datagram(
        SUBSCRIBER,
        &hex(&format!("81 80 06 00 08 01 10 00 00 11 00 16 {stream} 00 00 01 ff ff 00 00 00 00 00 00")),
        now,
    );
    let mut out = Vec::new();
    while core.poll_transmit(now, &mut out).is_some() {}

    let mut pub_seq: u16 = 6;
    let mut sub_next: u16 = 0;
    let mut delivered: u64 = 0;
    let mut write = Vec::new();
    let started = Instant::now();
    let mut sent: u32 = 0;
    let mut pub_acked: u16 = 6;
    let mut idle_rounds = 0;
    // Writes until `samples` are written, then runs until the subscriber has them all (or nothing moves).
    while sent < samples || (delivered < u64::from(sent) && idle_rounds < 1000) {
        let before = delivered;
        // The publisher keeps at most 8 messages unacknowledged, as a client with a history of 8.
        while pub_seq.wrapping_sub(pub_acked) < 8 && sent < samples {
            // WRITE_DATA (0x07) to writer #1 (0x0015) on reliable stream 0x80, FORMAT_DATA.
            write.clear();
            write.extend_from_slice(&[0x81, 0x80]);
            write.extend_from_slice(&pub_seq.to_le_bytes());
            let len = u16::try_from(4 + payload).unwrap_or(u16::MAX);
            write.extend_from_slice(&[0x07, 0x01]);
            write.extend_from_slice(&len.to_le_bytes());
            write.extend_from_slice(&[0x00, 0x20, 0x00, 0x15]);
            write.extend(std::iter::repeat_n(0xAB, payload));
            core.handle_datagram(PUBLISHER, &write, now);
            pub_seq = pub_seq.wrapping_add(1);
            sent += 1;
        }
        while let Some(to) = core.poll_transmit(now, &mut out) {
            if to == PUBLISHER {
                pub_acked = acknowledged(&out).unwrap_or(pub_acked);
            } else if let Ok((header, subs)) = message::parse(&out) {
                {
                    // A DATA, or the last FRAGMENT of a sample the MTU made the agent cut.
                    let data = subs
                        .flatten()
                        .filter(|raw| {
                            raw.header.id == 0x09
                                || (raw.header.id == 0x0d
                                    && raw.header.flags & xrce_proto::submessage::flag::LAST_FRAGMENT != 0)
                        })
                        .count();
                    delivered += data as u64;
                    if header.stream_id.0 == 0x80 {
                        sub_next = header.sequence_nr.wrapping_add(1);
                    }
                }
            }
        }
        if !best_effort {
            // The subscriber acknowledges everything it received.
            let ack = AckNack { first_unacked_seq_num: sub_next, nack_bitmap: [0, 0], stream_id: 0x80 };
            let header = MessageHeader::new(0x81, StreamId::NONE, 0, ClientKey::INVALID);
            let mut buf = [0u8; 32];
            if let Ok(n) = message::encode_single(&mut buf, &header, &Submessage::AckNack(ack), Endianness::Little) {
                core.handle_datagram(SUBSCRIBER, &buf[..n], now);
            }
            while let Some(to) = core.poll_transmit(now, &mut out) {
                if to == PUBLISHER {
                    pub_acked = acknowledged(&out).unwrap_or(pub_acked);
                }
            }
        }
        idle_rounds = if delivered == before { idle_rounds + 1 } else { 0 };
        now += Duration::from_micros(50);
        if core.poll_timeout().is_some_and(|t| t <= now) {
            core.handle_timeout(now);
        }
    }
    let elapsed = started.elapsed();
    if std::env::var_os("CORE_COST_DEBUG").is_some() {
        eprintln!("{:?} sub_next {sub_next} pub_seq {pub_seq} pub_acked {pub_acked}", core.stats());
    }
    println!(
        "{} {payload} B: {sent} written, {delivered} delivered, {:.0} ns per delivered sample",
        if best_effort { "best-effort" } else { "reliable" },
        elapsed.as_nanos() as f64 / delivered.max(1) as f64
    );
}
