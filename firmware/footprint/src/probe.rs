// Shared body of the board's publisher probes (crates/xrce-client/footprint/src/probe.rs on the board): each bin
// defines MTU, OUT_HISTORY, OUT_BUFFER, IN_HISTORY, IN_BUFFER, ONE_BY_ONE and the `Link` type with `fn link()`,
// then includes this file.

use core::mem::{size_of, MaybeUninit};
use core::ptr::addr_of_mut;

use xrce_board as board;
use xrce_client::{object_id, ObjectKind, Session, WriteAccess, WriteAccessExt, REPLACE};
use xrce_proto::cdr::{Endianness, Writer};

type Publisher = Session<'static, Link, board::BoardClock, (), 0, 1, 0, 1, MTU>;

static mut OUTPUT: [u8; OUT_BUFFER] = [0; OUT_BUFFER];
static mut INPUT: [u8; IN_BUFFER] = [0; IN_BUFFER];
static mut SESSION: MaybeUninit<Publisher> = MaybeUninit::uninit();

fn publish(session: &mut Publisher) -> bool {
    // SAFETY: the buffers are only ever borrowed here, once.
    let (output, input) = unsafe { (&mut *addr_of_mut!(OUTPUT), &mut *addr_of_mut!(INPUT)) };
    if session.create_session().is_err() {
        return false;
    }
    let (Ok(out), Ok(_)) = (
        session.create_output_reliable_stream(output, OUT_HISTORY),
        session.create_input_reliable_stream(input, IN_HISTORY),
    ) else {
        return false;
    };
    let participant = object_id(1, ObjectKind::Participant);
    let topic = object_id(1, ObjectKind::Topic);
    let publisher = object_id(1, ObjectKind::Publisher);
    let writer = object_id(1, ObjectKind::DataWriter);
    // Buffered all at once when the history holds them, else created one by one (each waits for its status).
    let mut ids = [0u16; 4];
    let mut status = [0u8; 4];
    for i in 0..4 {
        let r = match i {
            0 => session.buffer_create_participant_xml(
                out,
                participant,
                0,
                "<dds><participant><rtps><name>default_xrce_participant</name></rtps></participant></dds>",
                REPLACE,
            ),
            1 => session.buffer_create_topic_xml(
                out,
                topic,
                participant,
                "<dds><topic><name>HelloWorldTopic</name><dataType>HelloWorld</dataType></topic></dds>",
                REPLACE,
            ),
            2 => session.buffer_create_publisher_xml(out, publisher, participant, "", REPLACE),
            _ => session.buffer_create_datawriter_xml(
                out,
                writer,
                publisher,
                "<dds><data_writer><topic><kind>NO_KEY</kind><name>HelloWorldTopic</name>\
             <dataType>HelloWorld</dataType></topic></data_writer></dds>",
                REPLACE,
            ),
        };
        if let (Some(id), Some(st)) = (ids.get_mut(i), status.get_mut(i)) {
            *id = r.unwrap_or(0);
            if ONE_BY_ONE {
                let _ = session.run_session_until_all_status(1000, &[*id], core::slice::from_mut(st));
            }
        }
    }
    if !ONE_BY_ONE {
        let _ = session.run_session_until_all_status(1000, &ids, &mut status);
    }
    let message = "Hello DDS world!";
    for index in 0..10u32 {
        let size = 4 + 4 + message.len() + 1;
        if let Ok(mut prepared) = session.prepare_output_stream(out, writer, size) {
            let mut w = Writer::new(prepared.buffer(), Endianness::Little);
            w.write_u32(index);
            w.write_string(message);
        }
        let _ = session.run_session_time(100);
    }
    matches!(session.delete_session(), Ok(true))
}

#[export_name = "main"]
extern "C" fn main() -> ! {
    board::init();
    let Some(link) = link() else { board::exit(2) };
    // SAFETY: initialized once, before any use, and used from this thread only.
    let session = unsafe { (*addr_of_mut!(SESSION)).write(Session::with_clock(link, board::BoardClock, 0xAAAA_BBBB)) };
    // Painted again after the initialization, as the host probe does: `Session::with_clock` builds its value on
    // `main`'s frame before it moves to the static (a one-off at start-up, in the figure since reset).
    let top = board::paint_below_here();
    let ok = publish(session);
    let running = board::stack_used_below(top);
    board::print(if ok { b"published 10 samples, session deleted\n" } else { b"no agent or refused\n" });
    board::report(b"session object: ", size_of::<Publisher>() as u64);
    board::report(b"stream buffers: ", (OUT_BUFFER + IN_BUFFER) as u64);
    board::report(b"peak stack while running (below main's frame): ", running as u64);
    board::report(b"peak stack since reset: ", board::stack_used() as u64);
    board::exit(if ok { 0 } else { 1 })
}
