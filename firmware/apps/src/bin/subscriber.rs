//! A subscriber on the board, as micro-ROS creates one: participant, topic `TOPIC` of type
//! `std_msgs::msg::dds_::String_`, subscriber and datareader in binary (REUSE|REPLACE), then a READ_DATA for every
//! sample, delivered on the reliable input stream (`reliable`, the default) or the best-effort one
//! (`best-effort`). The samples are the ones `micro_ros_node --pub` and `px4_client --pub` write: text
//! `"<tag> <index> <time>"`, indices from 0.
//!
//! Command line (QEMU's `-append`): `[reliable|best-effort] [TOPIC=rt/chatter] [COUNT=20] [TIMEOUT_S=60]`;
//! prints `ready` once the reader is in place. Ends when index `COUNT - 1` arrived or after `TIMEOUT_S`.
//!
//! Reconnection is on: after the agent lost the session the program creates its entities and its read again;
//! from the first sample after that on, none may be missing. Verdict: `PASS` (exit 0) when, reliable, every
//! index arrived in order (a gap is allowed only across a lost session, duplicates only right after one) and the
//! last one is `COUNT - 1`; best effort, when the indices only grow and at least half arrived.
#![no_std]
#![no_main]

use core::mem::MaybeUninit;
use core::ptr::addr_of_mut;

use xrce_board as board;
use xrce_client::{
    object_id, Callbacks, DeliveryControl, ObjectId, ObjectKind, Outputs, QoS, Reliability, StreamId, WriteAccessExt,
    REPLACE, REUSE,
};
use xrce_firmware::{self as fw, Client, Liveness, HISTORY, MTU};

/// What arrived, in order.
#[derive(Default)]
struct Tally {
    liveness: Liveness,
    received: u32,
    first: Option<u32>,
    last: Option<u32>,
    /// Indices skipped while the session was up.
    gaps: u32,
    /// Indices skipped across a lost session (allowed).
    gaps_across_loss: u32,
    /// Indices at or below the last one.
    repeated: u32,
    /// A session was lost since the last sample.
    lost_since_last: bool,
}

impl Callbacks for Tally {
    fn on_topic(&mut self, _: &mut Outputs<'_, '_>, _: ObjectId, _: u16, _: StreamId, data: &[u8]) {
        let Some(index) = fw::std_string(data).and_then(fw::second_word_num) else { return };
        self.received += 1;
        match self.last {
            Some(last) if index <= last => self.repeated += 1,
            Some(last) => {
                let skipped = index - last - 1;
                if self.lost_since_last {
                    self.gaps_across_loss += skipped;
                } else {
                    self.gaps += skipped;
                }
                self.last = Some(index);
            }
            None => {
                self.first = Some(index);
                self.last = Some(index);
            }
        }
        if self.received <= 3 || index % 10 == 0 {
            board::report(b"received index ", u64::from(index));
        }
        self.lost_since_last = false;
    }
    fn on_session_lost(&mut self) {
        self.liveness.lost();
        self.lost_since_last = true;
    }
    fn on_session_restored(&mut self, recreated: bool) {
        self.liveness.restored(recreated);
    }
}

type Subscriber = Client<Tally, 0, 1>;

static mut RELIABLE_OUT: [u8; MTU * HISTORY] = [0; MTU * HISTORY];
static mut RELIABLE_IN: [u8; MTU * HISTORY] = [0; MTU * HISTORY];
static mut SESSION: MaybeUninit<Subscriber> = MaybeUninit::uninit();

/// Creates the entities (or finds them again) and asks for every sample on `data_stream`.
fn subscribe(session: &mut Subscriber, out: StreamId, data_stream: StreamId, topic_name: &str, qos: QoS) -> bool {
    let participant = object_id(1, ObjectKind::Participant);
    let topic = object_id(1, ObjectKind::Topic);
    let subscriber = object_id(1, ObjectKind::Subscriber);
    let reader = object_id(1, ObjectKind::DataReader);
    let mode = REUSE | REPLACE;
    let requests = [
        fw::buffer(session, |s| s.buffer_create_participant_bin(out, participant, 0, Some("firmware_listener"), mode)),
        fw::buffer(session, |s| {
            s.buffer_create_topic_bin(out, topic, participant, topic_name, "std_msgs::msg::dds_::String_", mode)
        }),
        fw::buffer(session, |s| s.buffer_create_subscriber_bin(out, subscriber, participant, mode)),
        fw::buffer(session, |s| s.buffer_create_datareader_bin(out, reader, subscriber, topic, qos, mode)),
    ];
    let [Some(a), Some(b), Some(c), Some(d)] = requests else { return false };
    if !fw::created(session, &[a, b, c, d], 5) {
        return false;
    }
    let control = DeliveryControl { max_samples: DeliveryControl::UNLIMITED, ..Default::default() };
    fw::buffer(session, |s| s.buffer_request_data(out, reader, data_stream, Some(&control))).is_some()
}

#[export_name = "main"]
extern "C" fn main() -> ! {
    board::init();
    let mut line = [0u8; 128];
    let mut args = board::words(board::cmdline(&mut line));
    let best_effort = fw::best_effort(args.next());
    let topic_name = args.next().and_then(|w| core::str::from_utf8(w).ok()).unwrap_or("rt/chatter");
    let count = args.next().and_then(board::parse_num).unwrap_or(20).max(1);
    let timeout_ms = i64::from(args.next().and_then(board::parse_num).unwrap_or(60)) * 1000;
    board::print(if best_effort { b"subscriber, best effort, " } else { b"subscriber, reliable, " });
    board::print(topic_name.as_bytes());
    board::print(b"\n");

    let Ok(link) = board::link() else { fw::finish(false) };
    // SAFETY: written once here, before any use; this program has one thread and no interrupt touches it.
    let session = unsafe {
        (*addr_of_mut!(SESSION)).write(Subscriber::with_clock(link, board::BoardClock, fw::keys::SUBSCRIBER))
    };
    fw::create_session(session);
    // SAFETY: the buffers are lent to the session once, for the rest of the program.
    let (reliable_out, reliable_in) = unsafe { (&mut *addr_of_mut!(RELIABLE_OUT), &mut *addr_of_mut!(RELIABLE_IN)) };
    let (Ok(out), Ok(rel_in), Ok(be_in)) = (
        session.create_output_reliable_stream(reliable_out, HISTORY),
        session.create_input_reliable_stream(reliable_in, HISTORY),
        session.create_input_best_effort_stream(),
    ) else {
        fw::finish(false)
    };
    let (data_stream, reliability) =
        if best_effort { (be_in, Reliability::BestEffort) } else { (rel_in, Reliability::Reliable) };
    let qos = QoS { reliability, depth: 10, ..QoS::default() };
    if !subscribe(session, out, data_stream, topic_name, qos) {
        board::print(b"FAIL: entities refused\n");
        fw::finish(false);
    }
    board::print(b"ready\n");

    let deadline = board::now_millis() + timeout_ms;
    while session.callbacks().last.is_none_or(|last| last.saturating_add(1) < count) && board::now_millis() < deadline {
        if session.callbacks().liveness.recreate {
            session.callbacks().liveness.recreate = false;
            if !subscribe(session, out, data_stream, topic_name, qos) {
                board::print(b"entities not created again\n");
            }
        }
        let _ = session.run_session_until_data(100);
    }
    let t = session.callbacks();
    board::report(b"samples received: ", u64::from(t.received));
    board::report(b"first index: ", t.first.map_or(0, u64::from));
    board::report(b"last index: ", t.last.map_or(0, u64::from));
    board::report(b"indices missing: ", u64::from(t.gaps));
    board::report(b"indices missing across a lost session: ", u64::from(t.gaps_across_loss));
    board::report(b"repeated or late: ", u64::from(t.repeated));
    board::report(b"sessions lost: ", u64::from(t.liveness.lost));
    board::report(b"sessions restored: ", u64::from(t.liveness.restored));
    let ok = if best_effort {
        t.repeated == 0 && t.received.saturating_mul(2) >= count
    } else {
        // Duplicates may follow a re-creation (the publisher sends again what the old agent had not
        // acknowledged); with no session lost, there must be none.
        t.first == Some(0) && t.gaps == 0 && t.last == Some(count - 1) && (t.repeated == 0 || t.liveness.lost > 0)
    };
    let _ = session.delete_session();
    fw::finish(ok)
}
