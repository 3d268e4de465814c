//! What the four firmware programs share: the session type over the board's serial link, the reconnection
//! bookkeeping their callbacks keep, the command line and the verdict.
#![no_std]

use xrce_board as board;
use xrce_client::{
    object_id, DeliveryControl, Error, ObjectId, ObjectKind, ServiceNames, Session, SessionState, StreamId,
    WriteAccessExt,
};

pub use board::MTU;

/// Client key of each program (two programs on one agent must differ).
pub mod keys {
    /// The publisher's.
    pub const PUBLISHER: u32 = 0xF1F1_0001;
    /// The subscriber's.
    pub const SUBSCRIBER: u32 = 0xF1F1_0002;
    /// The requester's.
    pub const REQUESTER: u32 = 0xF1F1_0003;
    /// The replier's.
    pub const REPLIER: u32 = 0xF1F1_0004;
}

/// A session over the framed UART: `OBE` best-effort output streams, one reliable output stream, `IBE`
/// best-effort input streams, one reliable input stream.
pub type Client<C, const OBE: usize, const IBE: usize> =
    Session<'static, board::Link, board::BoardClock, C, OBE, 1, IBE, 1, MTU>;

/// Reliable stream history (slots of one message each): 4 × 512 B per reliable stream.
pub const HISTORY: usize = 4;

/// What the session told the callbacks about the agent.
#[derive(Debug, Default)]
pub struct Liveness {
    /// Times the session was lost.
    pub lost: u32,
    /// Times it came back.
    pub restored: u32,
    /// It came back created again: the program must create its entities (and reads) again.
    pub recreate: bool,
}

impl Liveness {
    /// `Callbacks::on_session_lost`.
    pub fn lost(&mut self) {
        self.lost += 1;
        board::print(b"session lost, reconnecting\n");
    }

    /// `Callbacks::on_session_restored`.
    pub fn restored(&mut self, recreated: bool) {
        self.restored += 1;
        if recreated {
            // Without `std` the client does not replay its entities: the program does (as PX4 and micro-ROS do).
            self.recreate = true;
            board::print(b"session back (created again)\n");
        } else {
            board::print(b"session back (kept)\n");
        }
    }
}

/// Whether the mode word asks for best effort (`best-effort`); anything else is reliable.
pub fn best_effort(word: Option<&[u8]>) -> bool {
    word == Some(b"best-effort".as_slice())
}

/// Creates the session (10 attempts, one second apart); exits with 2 when no agent answers.
pub fn create_session<C: xrce_client::Callbacks, const OBE: usize, const IBE: usize>(
    session: &mut Client<C, OBE, IBE>,
) {
    match session.create_session() {
        Ok(()) => board::print(b"session created\n"),
        Err(_) => {
            board::print(b"FAIL: no session\n");
            board::exit(2)
        }
    }
}

/// Runs `request` (a `buffer_*` call), running the session while the reliable history is full (after a
/// re-creation it may still hold what was sent before), up to 5 s; its request id, or `None`.
pub fn buffer<C: xrce_client::Callbacks, const OBE: usize, const IBE: usize>(
    session: &mut Client<C, OBE, IBE>,
    mut request: impl FnMut(&mut Client<C, OBE, IBE>) -> Result<u16, Error>,
) -> Option<u16> {
    for _ in 0..500 {
        match request(session) {
            Ok(id) => return Some(id),
            Err(Error::WouldBlock) => {
                let _ = session.run_session_timeout(10);
            }
            Err(_) => return None,
        }
    }
    None
}

/// Waits for the statuses of `requests` (one second, at most `tries` times); whether all were OK.
pub fn created<C: xrce_client::Callbacks, const OBE: usize, const IBE: usize>(
    session: &mut Client<C, OBE, IBE>,
    requests: &[u16],
    tries: u32,
) -> bool {
    let mut status = [xrce_client::STATUS_NONE; 8];
    let Some(status) = status.get_mut(..requests.len()) else { return false };
    for _ in 0..tries {
        if session.run_session_until_all_status(1000, requests, status) == Ok(true) {
            return true;
        }
        if status.iter().all(|s| *s != xrce_client::STATUS_NONE) {
            // Every status came and one is an error.
            return false;
        }
    }
    false
}

/// Runs the session until `deadline_ms` (board milliseconds).
pub fn run_until<C: xrce_client::Callbacks, const OBE: usize, const IBE: usize>(
    session: &mut Client<C, OBE, IBE>,
    deadline_ms: i64,
) -> Result<(), Error> {
    loop {
        let left = deadline_ms - board::now_millis();
        if left <= 0 {
            return Ok(());
        }
        session.run_session_timeout(i32::try_from(left).unwrap_or(i32::MAX))?;
    }
}

/// Whether the session is up (not reconnecting).
pub fn established<C: xrce_client::Callbacks, const OBE: usize, const IBE: usize>(
    session: &mut Client<C, OBE, IBE>,
) -> bool {
    session.core().state() == SessionState::Established
}

/// The text of a `std_msgs/String` sample (CDR: length with its NUL, bytes, NUL), or `None`.
pub fn std_string(data: &[u8]) -> Option<&[u8]> {
    let len = u32::from_le_bytes(data.get(..4)?.try_into().ok()?) as usize;
    data.get(4..4 + len.checked_sub(1)?)
}

/// The second word of `text` as a number (`"m 12 …"`: the index micro_ros_node and px4_client write).
pub fn second_word_num(text: &[u8]) -> Option<u32> {
    board::words(text).nth(1).and_then(board::parse_num)
}

/// Prints the stack's high-water mark and the end of the run, and exits with 0 when `ok`, else 1.
pub fn finish(ok: bool) -> ! {
    board::report(b"peak stack: ", board::stack_used() as u64);
    board::print(if ok { b"PASS\n" } else { b"FAIL\n" });
    board::exit(if ok { 0 } else { 1 })
}

/// The adder service of eProsima's examples (what the host's `request_adder` and `reply_adder` use); the board's
/// requester and replier must name it alike.
pub const ADDER_SERVICE: ServiceNames<'static> = ServiceNames {
    service_name: "service_name",
    request_type: "request_type",
    reply_type: "reply_type",
    request_topic_name: "service_nameRequest",
    reply_topic_name: "service_nameReply",
};

/// Creates participant 1 named `name` and a service endpoint (`endpoint`, made by `create_endpoint` under that
/// participant), then asks for everything the endpoint receives on `input`; whether all of it went through.
pub fn create_service_endpoint<C: xrce_client::Callbacks, const OBE: usize, const IBE: usize>(
    session: &mut Client<C, OBE, IBE>,
    out: StreamId,
    input: StreamId,
    mode: u8,
    name: &str,
    endpoint: ObjectId,
    mut create_endpoint: impl FnMut(&mut Client<C, OBE, IBE>, ObjectId) -> Result<u16, Error>,
) -> bool {
    let participant = object_id(1, ObjectKind::Participant);
    let requests = [
        buffer(session, |s| s.buffer_create_participant_bin(out, participant, 0, Some(name), mode)),
        buffer(session, |s| create_endpoint(s, participant)),
    ];
    let [Some(a), Some(b)] = requests else { return false };
    if !created(session, &[a, b], 5) {
        return false;
    }
    let control = DeliveryControl { max_samples: DeliveryControl::UNLIMITED, ..Default::default() };
    buffer(session, |s| s.buffer_request_data(out, endpoint, input, Some(&control))).is_some()
}
