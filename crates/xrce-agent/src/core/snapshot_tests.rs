//! The snapshot counts what happened: clients created and removed by reason, drops by reason, totals
//! that do not go down when a client leaves, and publication on the core's own timer.

use std::sync::Arc;
use std::time::{Duration, Instant};

use xrce_proto::{ClientKey, MessageHeader, StreamId, Submessage};

use super::stats::{DropReason, RemoveReason};
use super::tests::{core_with, create_client, encode};
use super::{CoreConfig, SnapshotBoard};

#[test]
fn clients_are_counted_in_and_out_by_reason() {
    let mut core = core_with(CoreConfig::default());
    let now = Instant::now();
    core.handle_datagram(7, &create_client(0x0A), now);
    core.handle_datagram(8, &create_client(0x0B), now);
    // Another key from endpoint 8 replaces 0x0B.
    core.handle_datagram(8, &create_client(0x0C), now);
    assert_eq!(core.delete_client(ClientKey::from_u32(0x0A)), xrce_proto::StatusCode::OK);
    let s = core.snapshot(now);
    assert_eq!(s.totals.clients_created, 3);
    assert_eq!(s.totals.removed(RemoveReason::Replaced), 1);
    assert_eq!(s.totals.removed(RemoveReason::Deleted), 1);
    assert_eq!(s.totals.removed(RemoveReason::Timeout), 0);
    assert_eq!(s.clients.len(), 1);
    let c = &s.clients[0];
    assert_eq!((c.key, c.session_id, c.mtu), (ClientKey::from_u32(0x0C), 0x81, 508));
    assert_eq!(c.peer.as_deref(), Some("8"), "the endpoint as the logs print it");
}

#[test]
fn drops_are_counted_by_reason_and_client() {
    let mut core = core_with(CoreConfig::default());
    let now = Instant::now();
    core.handle_datagram(7, &[0xFF], now);
    core.handle_datagram(7, &create_client(0x0A), now);
    // Best-effort stream 1: message 5, then 4 (older: dropped).
    for seq in [5, 4] {
        let header = MessageHeader::new(0x81, StreamId(1), seq, ClientKey::INVALID);
        let hb = xrce_proto::submessage::Heartbeat { first_unacked_seq_nr: 0, last_unacked_seq_nr: 0, stream_id: 0x80 };
        core.handle_datagram(7, &encode(&header, &Submessage::Heartbeat(hb)), now);
    }
    let s = core.snapshot(now);
    assert_eq!(s.totals.dropped.get(DropReason::BadHeader), 1);
    assert_eq!(s.totals.dropped.get(DropReason::OutOfOrder), 1);
    assert_eq!(s.totals.datagrams_dropped, 2);
    let c = &s.clients[0];
    assert_eq!(c.counters.datagrams_dropped, 1);
    assert_eq!(c.counters.messages_in, 1, "the best-effort message taken");
    assert!(c.streams.iter().any(|st| st.id == 1 && st.input && st.messages == 1));
    // Removed, its counts stay in the agent's totals.
    core.delete_client(ClientKey::from_u32(0x0A));
    let s = core.snapshot(now);
    assert_eq!(s.client_totals().messages_in, 1);
    assert_eq!(s.client_totals().datagrams_dropped, 1);
}

#[test]
fn snapshots_are_published_on_the_cores_timer() {
    let mut core = core_with(CoreConfig::default());
    let board = Arc::new(SnapshotBoard::default());
    let stored = Arc::new(std::sync::atomic::AtomicUsize::new(0));
    let count = stored.clone();
    // What the `--metrics` server does: it is woken by each new snapshot.
    board.watch(move || {
        count.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    });
    let t0 = Instant::now();
    assert!(board.latest().is_none());
    core.publish_snapshots(Some(board.clone()), Duration::from_secs(1), t0);
    let first = board.latest().expect("published at once");
    assert_eq!(first.taken_at, t0);
    assert_eq!(core.poll_timeout(), Some(t0 + Duration::from_secs(1)));
    core.handle_datagram(7, &create_client(0x0A), t0);
    core.handle_timeout(t0 + Duration::from_millis(500));
    assert!(Arc::ptr_eq(&first, &board.latest().expect("kept")), "not due yet");
    core.handle_timeout(t0 + Duration::from_secs(1));
    assert_eq!(board.latest().expect("published").clients.len(), 1);
    assert_eq!(stored.load(std::sync::atomic::Ordering::Relaxed), 2, "the watcher heard of both snapshots");
}

#[test]
fn a_limited_snapshot_keeps_the_probed_then_the_lowest_keys_and_knows_every_key() {
    let mut core = core_with(CoreConfig::default());
    let now = Instant::now();
    for (port, key) in [(7, 0x30), (8, 0x10), (9, 0x20), (10, 0x40)] {
        core.handle_datagram(port, &create_client(key), now);
    }
    if let Some(c) = core.clients.get_mut(&ClientKey::from_u32(0x40)) {
        c.probes = 1;
    }
    let s = core.snapshot_of(now, 2);
    let mut shown: Vec<u32> = s.clients.iter().map(|c| c.key.to_u32()).collect();
    shown.sort_unstable();
    assert_eq!(shown, [0x10, 0x40], "the probed one, then the lowest key");
    assert_eq!(s.keys.len(), 4);
    assert_eq!(core.snapshot(now).clients.len(), 4);
}

/// A snapshot of a few clients (what `/metrics` and `/diagnostics` get each second) still totals every client.
#[test]
fn a_snapshot_of_a_few_clients_totals_them_all() {
    let mut core = core_with(CoreConfig::default());
    let now = Instant::now();
    for port in 0..5u16 {
        core.handle_datagram(port, &create_client(0x0100 + u32::from(port)), now);
        // A best-effort message each, counted as a message in.
        let header = MessageHeader::new(0x81, StreamId(1), 1, ClientKey::INVALID);
        let hb = xrce_proto::submessage::Heartbeat { first_unacked_seq_nr: 0, last_unacked_seq_nr: 0, stream_id: 0x80 };
        core.handle_datagram(port, &encode(&header, &Submessage::Heartbeat(hb)), now);
    }
    let all = core.snapshot(now);
    let few = core.snapshot_of(now, 2);
    assert_eq!((all.clients.len(), few.clients.len(), few.keys.len()), (5, 2, 5));
    assert_eq!(all.client_totals().messages_in, 5);
    assert_eq!(few.client_totals().messages_in, 5, "the clients left out are still counted");
}
