//! The C library's session API (`uxr_*`, called through its exported `extern "C"` functions on zeroed
//! `uxrSession` / `uxrCustomTransport` storage, as a C program's statics, under AddressSanitizer) in an
//! arbitrary order, over a custom transport whose `read` hands out arbitrary "agent" messages. Time is the
//! program's time source (`uxr_set_time_source`), advanced by every read that finds nothing, so the blocking
//! calls end without sleeping. The topic callback reads every sample through its `ucdrBuffer` to the announced
//! length: ASan catches a buffer shorter than announced. Nothing may panic or touch memory it does not own.
#![no_main]

use std::cell::RefCell;
use std::collections::VecDeque;
use std::ffi::{c_char, c_void};
use std::sync::atomic::{AtomicI64, Ordering};

use arbitrary::Arbitrary;
use libfuzzer_sys::fuzz_target;
use microxrcedds_client::abi::{uxrDeliveryControl, uxrObjectId, uxrStreamId};
use microxrcedds_client::access::*;
use microxrcedds_client::comm::uxrCommunication;
use microxrcedds_client::entities::*;
use microxrcedds_client::platform::uxr_set_time_source;
use microxrcedds_client::session::uxrSession;
use microxrcedds_client::transport::uxrCustomTransport;
use microxrcedds_client::ucdr::buffer::ucdrBuffer;
use microxrcedds_client::ucdr::primitives::{ucdr_deserialize_array_uint8_t, ucdr_serialize_array_uint8_t};

type OpenClose = unsafe extern "C" fn(*mut uxrCustomTransport) -> bool;
type Write = unsafe extern "C" fn(*mut uxrCustomTransport, *const u8, usize, *mut u8) -> usize;
type Read = unsafe extern "C" fn(*mut uxrCustomTransport, *mut u8, usize, i32, *mut u8) -> usize;
type OnTopic = unsafe extern "C" fn(*mut uxrSession, uxrObjectId, u16, uxrStreamId, *mut ucdrBuffer, u16, *mut c_void);
type OnStatus = unsafe extern "C" fn(*mut uxrSession, uxrObjectId, u16, u8, *mut c_void);
type OnBuffersFull = unsafe extern "C" fn(*mut uxrSession, *mut c_void) -> bool;

// The library's C symbols, declared as a C program's headers declare them (some live in private modules).
extern "C" {
    fn uxr_set_custom_transport_callbacks(
        t: *mut uxrCustomTransport,
        framing: bool,
        open: Option<OpenClose>,
        close: Option<OpenClose>,
        write: Option<Write>,
        read: Option<Read>,
    );
    fn uxr_init_custom_transport(t: *mut uxrCustomTransport, args: *mut c_void) -> bool;
    fn uxr_close_custom_transport(t: *mut uxrCustomTransport) -> bool;
    fn uxr_init_session(s: *mut uxrSession, comm: *mut uxrCommunication, key: u32);
    fn uxr_set_topic_callback(s: *mut uxrSession, f: Option<OnTopic>, args: *mut c_void);
    fn uxr_set_status_callback(s: *mut uxrSession, f: Option<OnStatus>, args: *mut c_void);
    fn uxr_create_session(s: *mut uxrSession) -> bool;
    fn uxr_create_session_retries(s: *mut uxrSession, retries: usize) -> bool;
    fn uxr_delete_session_retries(s: *mut uxrSession, retries: usize) -> bool;
    fn uxr_create_output_best_effort_stream(s: *mut uxrSession, buf: *mut u8, size: usize) -> uxrStreamId;
    fn uxr_create_output_reliable_stream(s: *mut uxrSession, buf: *mut u8, size: usize, history: u16) -> uxrStreamId;
    fn uxr_create_input_best_effort_stream(s: *mut uxrSession) -> uxrStreamId;
    fn uxr_create_input_reliable_stream(s: *mut uxrSession, buf: *mut u8, size: usize, history: u16) -> uxrStreamId;
    fn uxr_flash_output_streams(s: *mut uxrSession);
    fn uxr_run_session_time(s: *mut uxrSession, timeout_ms: i32) -> bool;
    fn uxr_run_session_until_data(s: *mut uxrSession, timeout_ms: i32) -> bool;
    fn uxr_run_session_until_all_status(s: *mut uxrSession, ms: i32, r: *const u16, st: *mut u8, n: usize) -> bool;
    fn uxr_run_session_until_one_status(s: *mut uxrSession, ms: i32, r: *const u16, st: *mut u8, n: usize) -> bool;
    fn uxr_sync_session(s: *mut uxrSession, timeout_ms: i32) -> bool;
    fn uxr_ping_agent_session(s: *mut uxrSession, timeout_ms: i32, attempts: u8) -> bool;
    fn uxr_prepare_output_stream_fragmented(
        s: *mut uxrSession,
        stream: uxrStreamId,
        entity: uxrObjectId,
        ub: *mut ucdrBuffer,
        size: usize,
        flush: Option<OnBuffersFull>,
        args: *mut c_void,
    ) -> u16;
}

#[derive(Arbitrary, Debug)]
enum Call {
    /// The agent's next message: a session header (`stream`, `seq`) then any bytes, or any bytes.
    AgentSends {
        header: Option<(u8, u16)>,
        bytes: Vec<u8>,
    },
    /// The agent accepts the session (a valid STATUS_AGENT).
    AgentAccepts,
    CreateSession,
    DeleteSession,
    CreateXml {
        kind: u8,
        id: u8,
        parent: u8,
        text: u8,
        reliable: bool,
    },
    CreateRef {
        kind: u8,
        id: u8,
        parent: u8,
        reliable: bool,
    },
    RequestData {
        reader: u8,
        reliable_data: bool,
        max_samples: u16,
    },
    Write {
        writer: u8,
        reliable: bool,
        size: u16,
        bytes: Vec<u8>,
    },
    WriteFragmented {
        writer: u8,
        size: u16,
    },
    DeleteEntity {
        id: u8,
        kind: u8,
    },
    Run {
        ms: u8,
    },
    RunUntilData {
        ms: u8,
    },
    RunUntilStatus {
        ms: u8,
        requests: Vec<u16>,
        all: bool,
    },
    Sync {
        ms: u8,
    },
    Ping {
        ms: u8,
        attempts: u8,
    },
    Flash,
}

const TEXTS: [&[u8]; 4] = [
    b"<dds><participant><rtps><name>p</name></rtps></participant></dds>\0",
    b"<dds><topic><name>t</name><dataType>T</dataType></topic></dds>\0",
    b"<dds><data_writer><topic><kind>NO_KEY</kind><name>t</name><dataType>T</dataType></topic></data_writer></dds>\0",
    b"\0",
];

static NOW: AtomicI64 = AtomicI64::new(1_700_000_000_000_000_000);

thread_local! {
    static AGENT: RefCell<VecDeque<Vec<u8>>> = const { RefCell::new(VecDeque::new()) };
}

extern "C" fn now() -> i64 {
    NOW.load(Ordering::Relaxed)
}

unsafe extern "C" fn open_close(_: *mut uxrCustomTransport) -> bool {
    true
}

unsafe extern "C" fn write(_: *mut uxrCustomTransport, _: *const u8, len: usize, _: *mut u8) -> usize {
    len
}

unsafe extern "C" fn read(_: *mut uxrCustomTransport, buf: *mut u8, len: usize, timeout: i32, _: *mut u8) -> usize {
    match AGENT.with(|a| a.borrow_mut().pop_front()) {
        Some(m) => {
            let n = m.len().min(len);
            // SAFETY: the library gives a buffer writable for `len` bytes.
            unsafe { core::ptr::copy_nonoverlapping(m.as_ptr(), buf, n) };
            n
        }
        None => {
            NOW.fetch_add(i64::from(timeout.max(1)) * 1_000_000, Ordering::Relaxed);
            0
        }
    }
}

unsafe extern "C" fn on_topic(
    _: *mut uxrSession,
    _: uxrObjectId,
    _: u16,
    _: uxrStreamId,
    ub: *mut ucdrBuffer,
    length: u16,
    _: *mut c_void,
) {
    let mut sample = vec![0u8; usize::from(length)].into_boxed_slice();
    // SAFETY: the library's buffer; `sample` is writable for its length.
    unsafe { ucdr_deserialize_array_uint8_t(ub, sample.as_mut_ptr(), sample.len()) };
}

unsafe extern "C" fn on_status(_: *mut uxrSession, _: uxrObjectId, _: u16, _: u8, _: *mut c_void) {}

/// STATUS_AGENT accepting session 0x81.
const STATUS_AGENT: [u8; 19] =
    [0x81, 0, 0, 0, 0x04, 0x01, 0x0B, 0, 0, 0, 0x58, 0x52, 0x43, 0x45, 0x01, 0x00, 0x01, 0x0F, 0x00];

/// The C program's storage, zeroed as statics are, at fixed addresses.
struct Program {
    transport: Box<uxrCustomTransport>,
    session: Box<uxrSession>,
    reliable_out: Box<[u8]>,
    best_effort_out: Box<[u8]>,
    reliable_in: Box<[u8]>,
}

fuzz_target!(|calls: Vec<Call>| {
    uxr_set_time_source(Some(now));
    AGENT.with(|a| a.borrow_mut().clear());
    // SAFETY: both structures are plain C data for which all-zero is their static initial value.
    let mut p = unsafe {
        Program {
            transport: Box::new(core::mem::zeroed()),
            session: Box::new(core::mem::zeroed()),
            reliable_out: vec![0u8; 1024].into_boxed_slice(),
            best_effort_out: vec![0u8; 512].into_boxed_slice(),
            reliable_in: vec![0u8; 1024].into_boxed_slice(),
        }
    };
    let t: *mut uxrCustomTransport = &mut *p.transport;
    let s: *mut uxrSession = &mut *p.session;
    // SAFETY: `t` and `s` stay in place until the end of this run; buffers outlive the session.
    unsafe {
        uxr_set_custom_transport_callbacks(t, false, Some(open_close), Some(open_close), Some(write), Some(read));
        if !uxr_init_custom_transport(t, core::ptr::null_mut()) {
            return;
        }
        uxr_init_session(s, &mut (*t).comm, 0xAABB_CCDD);
        uxr_set_topic_callback(s, Some(on_topic), core::ptr::null_mut());
        uxr_set_status_callback(s, Some(on_status), core::ptr::null_mut());
        AGENT.with(|a| a.borrow_mut().push_back(STATUS_AGENT.to_vec()));
        uxr_create_session(s);
        let rel = uxr_create_output_reliable_stream(s, p.reliable_out.as_mut_ptr(), p.reliable_out.len(), 4);
        let be = uxr_create_output_best_effort_stream(s, p.best_effort_out.as_mut_ptr(), p.best_effort_out.len());
        let rel_in = uxr_create_input_reliable_stream(s, p.reliable_in.as_mut_ptr(), p.reliable_in.len(), 4);
        let be_in = uxr_create_input_best_effort_stream(s);
        for call in calls.iter().take(64) {
            perform(s, call, [rel, be, rel_in, be_in]);
        }
        uxr_delete_session_retries(s, 1);
        uxr_close_custom_transport(t);
    }
    drop(p);
});

/// One call; `streams` are the output reliable and best-effort, input reliable and best-effort ones.
///
/// # Safety
/// `s` an initialised session.
unsafe fn perform(s: *mut uxrSession, call: &Call, streams: [uxrStreamId; 4]) {
    let [rel, be, rel_in, be_in] = streams;
    let out = |reliable: bool| if reliable { rel } else { be };
    let kind = |k: u8| 1 + k % 8;
    // SAFETY (every call below): `s` is initialised (contract); pointers passed are valid for their sizes.
    unsafe {
        match call {
            Call::AgentSends { header, bytes } => {
                let mut m = Vec::new();
                if let Some((stream, seq)) = header {
                    m.extend_from_slice(&[0x81, *stream]);
                    m.extend_from_slice(&seq.to_le_bytes());
                }
                m.extend_from_slice(bytes);
                AGENT.with(|a| a.borrow_mut().push_back(m));
            }
            Call::AgentAccepts => AGENT.with(|a| a.borrow_mut().push_back(STATUS_AGENT.to_vec())),
            Call::CreateSession => {
                uxr_create_session_retries(s, 1);
            }
            Call::DeleteSession => {
                uxr_delete_session_retries(s, 1);
            }
            Call::CreateXml { kind: k, id, parent, text, reliable } => {
                let text = TEXTS[usize::from(*text) % TEXTS.len()].as_ptr().cast::<c_char>();
                let object = uxr_object_id(u16::from(*id), kind(*k));
                let parent = uxr_object_id(u16::from(*parent), 1);
                match k % 3 {
                    0 => uxr_buffer_create_participant_xml(s, out(*reliable), object, 0, text, 2),
                    1 => uxr_buffer_create_topic_xml(s, out(*reliable), object, parent, text, 2),
                    _ => uxr_buffer_create_datawriter_xml(s, out(*reliable), object, parent, text, 3),
                };
            }
            Call::CreateRef { kind: k, id, parent, reliable } => {
                let object = uxr_object_id(u16::from(*id), kind(*k));
                let parent = uxr_object_id(u16::from(*parent), 1);
                let name = c"t".as_ptr();
                uxr_buffer_create_topic_ref(s, out(*reliable), object, parent, name, 1);
            }
            Call::RequestData { reader, reliable_data, max_samples } => {
                let control = uxrDeliveryControl {
                    max_samples: *max_samples,
                    max_elapsed_time: 0,
                    max_bytes_per_second: 0,
                    min_pace_period: 0,
                };
                let data_stream = if *reliable_data { rel_in } else { be_in };
                uxr_buffer_request_data(s, rel, uxr_object_id(u16::from(*reader), 6), data_stream, &control);
            }
            Call::Write { writer, reliable, size, bytes } => {
                let mut ub: ucdrBuffer = core::mem::zeroed();
                let writer = uxr_object_id(u16::from(*writer), 5);
                if uxr_prepare_output_stream(s, out(*reliable), writer, &mut ub, u32::from(*size)) != 0 {
                    ucdr_serialize_array_uint8_t(&mut ub, bytes.as_ptr(), bytes.len());
                }
            }
            Call::WriteFragmented { writer, size } => {
                let mut ub: ucdrBuffer = core::mem::zeroed();
                let writer = uxr_object_id(u16::from(*writer), 5);
                let size = usize::from(*size % 4096);
                let data = vec![0x5Au8; size];
                if uxr_prepare_output_stream_fragmented(s, rel, writer, &mut ub, size, None, core::ptr::null_mut()) != 0
                {
                    ucdr_serialize_array_uint8_t(&mut ub, data.as_ptr(), data.len());
                }
            }
            Call::DeleteEntity { id, kind: k } => {
                uxr_buffer_delete_entity(s, rel, uxr_object_id(u16::from(*id), kind(*k)));
            }
            Call::Run { ms } => {
                uxr_run_session_time(s, i32::from(*ms));
            }
            Call::RunUntilData { ms } => {
                uxr_run_session_until_data(s, i32::from(*ms));
            }
            Call::RunUntilStatus { ms, requests, all } => {
                let requests: Box<[u16]> = requests.iter().take(8).copied().collect();
                let mut status = vec![0u8; requests.len()].into_boxed_slice();
                let f = if *all { uxr_run_session_until_all_status } else { uxr_run_session_until_one_status };
                f(s, i32::from(*ms), requests.as_ptr(), status.as_mut_ptr(), requests.len());
            }
            Call::Sync { ms } => {
                uxr_sync_session(s, i32::from(*ms));
            }
            Call::Ping { ms, attempts } => {
                uxr_ping_agent_session(s, i32::from(*ms), attempts % 3);
            }
            Call::Flash => uxr_flash_output_streams(s),
        }
    }
}
