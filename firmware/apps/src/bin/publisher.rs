//! PublishHelloWorld on the board: participant, topic `HelloWorldTopic`, publisher and datawriter created by XML
//! on the reliable stream, then `COUNT` `HelloWorld` samples (index, "Hello DDS world!"), one every `PERIOD_MS`,
//! on the reliable stream (`reliable`, the default) or the best-effort one (`best-effort`).
//!
//! Command line (QEMU's `-append`): `[reliable|best-effort] [COUNT=10] [PERIOD_MS=100]`.
//!
//! Reconnection is on: if the agent goes away the session says so, comes back by itself, and the program
//! creates its entities again when the agent had lost them. A reliable sample is written only when the
//! history has room, so none is skipped; the run ends once every reliable sample is acknowledged. Verdict:
//! `PASS` (exit 0) when every sample was written (and, reliable, acknowledged), else `FAIL` (exit 1).
#![no_std]
#![no_main]

use core::mem::MaybeUninit;
use core::ptr::addr_of_mut;

use xrce_board as board;
use xrce_client::{object_id, Callbacks, Error, ObjectKind, StreamId, WriteAccess, WriteAccessExt, REPLACE, REUSE};
use xrce_firmware::{self as fw, Client, Liveness, HISTORY, MTU};
use xrce_proto::cdr::{Endianness, Writer};

#[derive(Default)]
struct Events(Liveness);

impl Callbacks for Events {
    fn on_session_lost(&mut self) {
        self.0.lost();
    }
    fn on_session_restored(&mut self, recreated: bool) {
        self.0.restored(recreated);
    }
}

type Publisher = Client<Events, 1, 0>;

static mut RELIABLE_OUT: [u8; MTU * HISTORY] = [0; MTU * HISTORY];
static mut RELIABLE_IN: [u8; MTU * HISTORY] = [0; MTU * HISTORY];
static mut BEST_EFFORT_OUT: [u8; MTU] = [0; MTU];
static mut SESSION: MaybeUninit<Publisher> = MaybeUninit::uninit();

const MESSAGE: &str = "Hello DDS world!";

/// Creates (or, `mode` REUSE, finds again) the four entities; whether the agent accepted them.
fn create_entities(session: &mut Publisher, out: StreamId, mode: u8) -> bool {
    let participant = object_id(1, ObjectKind::Participant);
    let topic = object_id(1, ObjectKind::Topic);
    let publisher = object_id(1, ObjectKind::Publisher);
    let writer = object_id(1, ObjectKind::DataWriter);
    let requests = [
        fw::buffer(session, |s| {
            s.buffer_create_participant_xml(
                out,
                participant,
                0,
                "<dds><participant><rtps><name>default_xrce_participant</name></rtps></participant></dds>",
                mode,
            )
        }),
        fw::buffer(session, |s| {
            s.buffer_create_topic_xml(
                out,
                topic,
                participant,
                "<dds><topic><name>HelloWorldTopic</name><dataType>HelloWorld</dataType></topic></dds>",
                mode,
            )
        }),
        fw::buffer(session, |s| s.buffer_create_publisher_xml(out, publisher, participant, "", mode)),
        fw::buffer(session, |s| {
            s.buffer_create_datawriter_xml(
                out,
                writer,
                publisher,
                "<dds><data_writer><topic><kind>NO_KEY</kind><name>HelloWorldTopic</name>\
                 <dataType>HelloWorld</dataType></topic></data_writer></dds>",
                mode,
            )
        }),
    ];
    let [Some(a), Some(b), Some(c), Some(d)] = requests else { return false };
    fw::created(session, &[a, b, c, d], 5)
}

/// Writes sample `index` on `stream`: `Ok(false)` when the history is full (run the session and retry).
fn write(session: &mut Publisher, stream: StreamId, index: u32) -> Result<bool, Error> {
    let writer = object_id(1, ObjectKind::DataWriter);
    let size = 4 + 4 + MESSAGE.len() + 1;
    match session.prepare_output_stream(stream, writer, size) {
        Ok(mut prepared) => {
            let mut w = Writer::new(prepared.buffer(), Endianness::Little);
            w.write_u32(index);
            w.write_string(MESSAGE);
            Ok(true)
        }
        Err(Error::WouldBlock) => Ok(false),
        Err(e) => Err(e),
    }
}

#[export_name = "main"]
extern "C" fn main() -> ! {
    board::init();
    let mut line = [0u8; 128];
    let mut args = board::words(board::cmdline(&mut line));
    let best_effort = fw::best_effort(args.next());
    let count = args.next().and_then(board::parse_num).unwrap_or(10);
    let period = i64::from(args.next().and_then(board::parse_num).unwrap_or(100));
    board::print(if best_effort { b"publisher, best effort\n" } else { b"publisher, reliable\n" });

    let Ok(link) = board::link() else { fw::finish(false) };
    // SAFETY: written once here, before any use; this program has one thread and no interrupt touches it.
    let session =
        unsafe { (*addr_of_mut!(SESSION)).write(Publisher::with_clock(link, board::BoardClock, fw::keys::PUBLISHER)) };
    fw::create_session(session);
    // SAFETY: the buffers are lent to the session once, for the rest of the program.
    let (reliable_out, reliable_in, best_effort_out) = unsafe {
        (&mut *addr_of_mut!(RELIABLE_OUT), &mut *addr_of_mut!(RELIABLE_IN), &mut *addr_of_mut!(BEST_EFFORT_OUT))
    };
    let (Ok(out), Ok(_), Ok(be_out)) = (
        session.create_output_reliable_stream(reliable_out, HISTORY),
        session.create_input_reliable_stream(reliable_in, HISTORY),
        session.create_output_best_effort_stream(best_effort_out),
    ) else {
        fw::finish(false)
    };
    if !create_entities(session, out, REPLACE) {
        board::print(b"FAIL: entities refused\n");
        fw::finish(false);
    }
    board::print(b"entities created\n");
    let stream = if best_effort { be_out } else { out };

    let mut written = 0u32;
    let mut next = board::now_millis();
    let mut index = 0;
    while index < count {
        if session.callbacks().0.recreate {
            session.callbacks().0.recreate = false;
            if !create_entities(session, out, REUSE | REPLACE) {
                board::print(b"entities not created again\n");
            }
        }
        if !fw::established(session) {
            // Reconnecting: a best-effort sample would go nowhere, a reliable one would wait in the history.
            let _ = session.run_session_timeout(10);
            continue;
        }
        match write(session, stream, index) {
            Ok(true) => {
                written += 1;
                index += 1;
                next += period;
                if fw::run_until(session, next).is_err() {
                    board::print(b"transport error\n");
                }
            }
            Ok(false) => {
                let _ = session.run_session_timeout(10);
            }
            Err(_) => {
                board::report(b"write failed, sample ", u64::from(index));
                index += 1;
            }
        }
    }
    let confirmed = best_effort || session.run_session_until_confirm_delivery(10_000) == Ok(true);
    board::report(b"samples written: ", u64::from(written));
    board::report(b"sessions lost: ", u64::from(session.callbacks().0.lost));
    board::report(b"sessions restored: ", u64::from(session.callbacks().0.restored));
    board::print(if confirmed { b"all acknowledged\n" } else { b"not all acknowledged\n" });
    let deleted = session.delete_session() == Ok(true);
    board::print(if deleted { b"session deleted\n" } else { b"session not deleted\n" });
    fw::finish(written == count && confirmed)
}
