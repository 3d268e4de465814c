//! RequestAdder on the board: a requester for `service_name` (eProsima's example service, served by the host's
//! `reply_adder`), created in binary; sends `COUNT` requests `(i, i + 1)` one after the other, each a pair of
//! little-endian `u32`, and checks that the reply to each is their sum as a little-endian `u64`, matched by
//! request id.
//!
//! Command line (QEMU's `-append`): `[COUNT=5]`. Verdict: `PASS` (exit 0) when every reply came and was right.
#![no_std]
#![no_main]

use core::mem::MaybeUninit;
use core::ptr::addr_of_mut;

use xrce_board as board;
use xrce_client::{object_id, Callbacks, ObjectId, ObjectKind, Outputs, QoS, StreamId, WriteAccessExt, REPLACE, REUSE};
use xrce_firmware::{self as fw, Client, Liveness, HISTORY, MTU};

/// The reply awaited, and what came.
#[derive(Default)]
struct Replies {
    liveness: Liveness,
    /// Request id and expected sum of the request in flight.
    awaited: Option<(u16, u64)>,
    right: u32,
    wrong: u32,
}

impl Callbacks for Replies {
    fn on_reply(&mut self, _: &mut Outputs<'_, '_>, _: ObjectId, _: u16, reply_id: u16, data: &[u8]) {
        let sum = data.get(..8).and_then(|b| b.try_into().ok()).map(u64::from_le_bytes);
        match self.awaited {
            Some((id, expected)) if id == reply_id && sum == Some(expected) => {
                self.right += 1;
                self.awaited = None;
                board::report(b"reply: ", expected);
            }
            _ => self.wrong += 1,
        }
    }
    fn on_session_lost(&mut self) {
        self.liveness.lost();
    }
    fn on_session_restored(&mut self, recreated: bool) {
        self.liveness.restored(recreated);
    }
}

type Requester = Client<Replies, 0, 0>;

static mut RELIABLE_OUT: [u8; MTU * HISTORY] = [0; MTU * HISTORY];
static mut RELIABLE_IN: [u8; MTU * HISTORY] = [0; MTU * HISTORY];
static mut SESSION: MaybeUninit<Requester> = MaybeUninit::uninit();

/// Creates the participant and the requester, and asks for every reply on `input`.
fn create(session: &mut Requester, out: StreamId, input: StreamId, mode: u8) -> bool {
    let requester = object_id(1, ObjectKind::Requester);
    fw::create_service_endpoint(session, out, input, mode, "firmware_requester", requester, |s, participant| {
        s.buffer_create_requester_bin(out, requester, participant, &fw::ADDER_SERVICE, QoS::default(), mode)
    })
}

#[export_name = "main"]
extern "C" fn main() -> ! {
    board::init();
    let mut line = [0u8; 64];
    let count = board::words(board::cmdline(&mut line)).next().and_then(board::parse_num).unwrap_or(5);
    board::print(b"requester\n");

    let Ok(link) = board::link() else { fw::finish(false) };
    // SAFETY: written once here, before any use; this program has one thread and no interrupt touches it.
    let session =
        unsafe { (*addr_of_mut!(SESSION)).write(Requester::with_clock(link, board::BoardClock, fw::keys::REQUESTER)) };
    fw::create_session(session);
    // SAFETY: the buffers are lent to the session once, for the rest of the program.
    let (reliable_out, reliable_in) = unsafe { (&mut *addr_of_mut!(RELIABLE_OUT), &mut *addr_of_mut!(RELIABLE_IN)) };
    let (Ok(out), Ok(input)) = (
        session.create_output_reliable_stream(reliable_out, HISTORY),
        session.create_input_reliable_stream(reliable_in, HISTORY),
    ) else {
        fw::finish(false)
    };
    if !create(session, out, input, REPLACE) {
        board::print(b"FAIL: entities refused\n");
        fw::finish(false);
    }
    board::print(b"ready\n");
    let requester = object_id(1, ObjectKind::Requester);
    for i in 0..count {
        let mut request = [0u8; 8];
        let (a, b) = request.split_at_mut(4);
        a.copy_from_slice(&i.to_le_bytes());
        b.copy_from_slice(&(i + 1).to_le_bytes());
        // Each request waits up to 5 s for its reply, sent again after a lost session.
        let deadline = board::now_millis() + 5000;
        let mut sent = false;
        while session.callbacks().right <= i && board::now_millis() < deadline {
            if session.callbacks().liveness.recreate {
                session.callbacks().liveness.recreate = false;
                sent = !create(session, out, input, REUSE | REPLACE) && sent;
            }
            if !sent && fw::established(session) {
                if let Ok(id) = session.buffer_request(out, requester, &request) {
                    session.callbacks().awaited = Some((id, u64::from(i) * 2 + 1));
                    sent = true;
                }
            }
            let _ = session.run_session_until_data(100);
        }
    }
    let r = session.callbacks();
    board::report(b"replies right: ", u64::from(r.right));
    board::report(b"replies wrong or unexpected: ", u64::from(r.wrong));
    let ok = r.right == count && r.wrong == 0;
    let _ = session.delete_session();
    fw::finish(ok)
}
