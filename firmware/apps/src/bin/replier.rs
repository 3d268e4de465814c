//! ReplyAdder on the board: a replier for `service_name` (eProsima's example service, called by the host's
//! `request_adder`), created in binary; answers each request, a pair of little-endian `u32`, with their sum as a
//! little-endian `u64`, from the request callback.
//!
//! Command line (QEMU's `-append`): `[COUNT=3] [TIMEOUT_S=30]`; prints `ready` once the replier is in place.
//! Verdict: `PASS` (exit 0) when `COUNT` requests were answered within `TIMEOUT_S` and every answer was accepted
//! by the output stream.
#![no_std]
#![no_main]

use core::mem::MaybeUninit;
use core::ptr::addr_of_mut;

use xrce_board as board;
use xrce_client::{
    object_id, Callbacks, ObjectId, ObjectKind, Outputs, QoS, SampleIdentity, StreamId, WriteAccessExt, REPLACE, REUSE,
};
use xrce_firmware::{self as fw, Client, Liveness, HISTORY, MTU};

/// Answers requests on `out`.
#[derive(Default)]
struct Adder {
    liveness: Liveness,
    out: Option<StreamId>,
    answered: u32,
    not_answered: u32,
}

impl Callbacks for Adder {
    fn on_request(&mut self, out: &mut Outputs<'_, '_>, replier: ObjectId, _: u16, id: &SampleIdentity, data: &[u8]) {
        let word = |at: usize| data.get(at..at + 4).and_then(|b| b.try_into().ok()).map(u32::from_le_bytes);
        let (Some(a), Some(b)) = (word(0), word(4)) else {
            self.not_answered += 1;
            return;
        };
        let sum = u64::from(a) + u64::from(b);
        let Some(stream) = self.out else { return };
        if out.buffer_reply(stream, replier, id, &sum.to_le_bytes()).is_ok() {
            self.answered += 1;
            board::report(b"answered: ", sum);
        } else {
            self.not_answered += 1;
        }
    }
    fn on_session_lost(&mut self) {
        self.liveness.lost();
    }
    fn on_session_restored(&mut self, recreated: bool) {
        self.liveness.restored(recreated);
    }
}

type Replier = Client<Adder, 0, 0>;

static mut RELIABLE_OUT: [u8; MTU * HISTORY] = [0; MTU * HISTORY];
static mut RELIABLE_IN: [u8; MTU * HISTORY] = [0; MTU * HISTORY];
static mut SESSION: MaybeUninit<Replier> = MaybeUninit::uninit();

/// Creates the participant and the replier, and asks for every request on `input`.
fn create(session: &mut Replier, out: StreamId, input: StreamId, mode: u8) -> bool {
    let replier = object_id(1, ObjectKind::Replier);
    fw::create_service_endpoint(session, out, input, mode, "firmware_replier", replier, |s, participant| {
        s.buffer_create_replier_bin(out, replier, participant, &fw::ADDER_SERVICE, QoS::default(), mode)
    })
}

#[export_name = "main"]
extern "C" fn main() -> ! {
    board::init();
    let mut line = [0u8; 64];
    let mut args = board::words(board::cmdline(&mut line));
    let count = args.next().and_then(board::parse_num).unwrap_or(3);
    let timeout_ms = i64::from(args.next().and_then(board::parse_num).unwrap_or(30)) * 1000;
    board::print(b"replier\n");

    let Ok(link) = board::link() else { fw::finish(false) };
    // SAFETY: written once here, before any use; this program has one thread and no interrupt touches it.
    let session =
        unsafe { (*addr_of_mut!(SESSION)).write(Replier::with_clock(link, board::BoardClock, fw::keys::REPLIER)) };
    fw::create_session(session);
    // SAFETY: the buffers are lent to the session once, for the rest of the program.
    let (reliable_out, reliable_in) = unsafe { (&mut *addr_of_mut!(RELIABLE_OUT), &mut *addr_of_mut!(RELIABLE_IN)) };
    let (Ok(out), Ok(input)) = (
        session.create_output_reliable_stream(reliable_out, HISTORY),
        session.create_input_reliable_stream(reliable_in, HISTORY),
    ) else {
        fw::finish(false)
    };
    session.callbacks().out = Some(out);
    if !create(session, out, input, REPLACE) {
        board::print(b"FAIL: entities refused\n");
        fw::finish(false);
    }
    board::print(b"ready\n");
    let deadline = board::now_millis() + timeout_ms;
    while session.callbacks().answered < count && board::now_millis() < deadline {
        if session.callbacks().liveness.recreate {
            session.callbacks().liveness.recreate = false;
            if !create(session, out, input, REUSE | REPLACE) {
                board::print(b"entities not created again\n");
            }
        }
        let _ = session.run_session_until_data(100);
    }
    let delivered = session.run_session_until_confirm_delivery(5000) == Ok(true);
    let a = session.callbacks();
    board::report(b"requests answered: ", u64::from(a.answered));
    board::report(b"requests not answered: ", u64::from(a.not_answered));
    let ok = a.answered >= count && a.not_answered == 0 && delivered;
    let _ = session.delete_session();
    fw::finish(ok)
}
