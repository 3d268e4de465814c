// Shared body of the publisher probes; each bin defines MTU, OUT_HISTORY, OUT_BUFFER, IN_HISTORY, IN_BUFFER
// and ONE_BY_ONE, then includes this file.

use core::mem::{size_of, MaybeUninit};
use core::ptr::addr_of_mut;

use xrce_client::transport::{Transport, TransportError};
use xrce_client::{object_id, Clock, ObjectKind, Session, WriteAccess, WriteAccessExt, REPLACE};
use xrce_client_footprint as rt;
use xrce_proto::cdr::{Endianness, Writer};

/// Stack painted and checked below the entry frame.
const PAINT: usize = 64 * 1024;

#[repr(C)]
struct SockAddrIn {
    family: u16,
    port: u16,
    addr: [u8; 4],
    zero: [u8; 8],
}

#[repr(C)]
struct PollFd {
    fd: i32,
    events: i16,
    revents: i16,
}

#[repr(C)]
struct TimeSpec {
    sec: i64,
    nsec: i64,
}

extern "C" {
    fn socket(domain: i32, kind: i32, protocol: i32) -> i32;
    fn connect(fd: i32, addr: *const SockAddrIn, len: u32) -> i32;
    fn send(fd: i32, buf: *const u8, len: usize, flags: i32) -> isize;
    fn recv(fd: i32, buf: *mut u8, len: usize, flags: i32) -> isize;
    fn poll(fds: *mut PollFd, n: u64, timeout: i32) -> i32;
    fn clock_gettime(clock: i32, ts: *mut TimeSpec) -> i32;
}

/// A connected UDP socket: what a board support package would provide.
struct Udp(i32);

impl Udp {
    fn connect(port: u16) -> Option<Self> {
        let addr = SockAddrIn { family: 2, port: port.to_be(), addr: [127, 0, 0, 1], zero: [0; 8] };
        // SAFETY: plain system calls on a socket this function owns; `addr` outlives the call.
        unsafe {
            let fd = socket(2, 2, 0);
            (fd >= 0 && connect(fd, &addr, size_of::<SockAddrIn>() as u32) == 0).then_some(Self(fd))
        }
    }
}

impl Transport for Udp {
    fn mtu(&self) -> usize {
        MTU
    }

    fn send(&mut self, msg: &[u8]) -> Result<(), TransportError> {
        // SAFETY: the pointer and length describe a live slice.
        match unsafe { send(self.0, msg.as_ptr(), msg.len(), 0) } {
            n if n == msg.len() as isize => Ok(()),
            _ => Err(TransportError::ShortWrite),
        }
    }

    fn recv(&mut self, buf: &mut [u8], timeout_ms: i32) -> Result<Option<usize>, TransportError> {
        let mut pfd = PollFd { fd: self.0, events: 1, revents: 0 };
        // SAFETY: `pfd` and `buf` are live for the calls.
        unsafe {
            if poll(&mut pfd, 1, timeout_ms) <= 0 {
                return Ok(None);
            }
            let n = recv(self.0, buf.as_mut_ptr(), buf.len(), 0);
            Ok((n > 0).then_some(n as usize))
        }
    }
}

/// CLOCK_REALTIME in nanoseconds.
struct Clk;

impl Clock for Clk {
    fn now_nanos(&mut self) -> i64 {
        let mut ts = TimeSpec { sec: 0, nsec: 0 };
        // SAFETY: `ts` is a valid out-parameter.
        unsafe { clock_gettime(0, &mut ts) };
        ts.sec * 1_000_000_000 + ts.nsec
    }
}

type Publisher = Session<'static, Udp, Clk, (), 0, 1, 0, 1, MTU>;

static mut OUTPUT: [u8; OUT_BUFFER] = [0; OUT_BUFFER];
static mut INPUT: [u8; IN_BUFFER] = [0; IN_BUFFER];
static mut SESSION: MaybeUninit<Publisher> = MaybeUninit::uninit();

/// Fills the stack below the caller with a pattern; returns the address the measurement starts from.
#[inline(never)]
fn paint() -> usize {
    let marker = 0u8;
    // 8-aligned: the pattern is written a word at a time (an unaligned wide store faults on Cortex-M).
    let top = core::hint::black_box(&marker) as *const u8 as usize & !7;
    for a in (top - PAINT..top - 64).step_by(8) {
        // SAFETY: unused stack below the live frames, inside the main thread's stack mapping.
        unsafe { core::ptr::write_volatile(a as *mut u64, 0xA5A5_A5A5_A5A5_A5A5) };
    }
    top
}

/// Bytes of painted stack that were overwritten.
fn used_stack(top: usize) -> usize {
    let mut a = top - PAINT;
    // SAFETY: the same region `paint` wrote.
    while a < top - 64 && unsafe { core::ptr::read_volatile(a as *const u64) } == 0xA5A5_A5A5_A5A5_A5A5 {
        a += 8;
    }
    top - a
}

fn report(top: usize) {
    rt::print(b"session object: ");
    rt::print_num(size_of::<Publisher>());
    rt::print(b" B\nstream buffers: ");
    rt::print_num(OUT_BUFFER + IN_BUFFER);
    rt::print(b" B\npeak stack while running (below main's frame): ");
    rt::print_num(used_stack(top));
    rt::print(b" B\n");
}

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
    let mut create = |session: &mut Publisher, i: usize| {
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
        ids[i] = r.unwrap_or(0);
        if ONE_BY_ONE {
            let _ = session.run_session_until_all_status(1000, &ids[i..=i], &mut status[i..=i]);
        }
    };
    for i in 0..4 {
        create(session, i);
    }
    // The statuses are not checked: an agent without DDS (eProsima's CED) refuses XML datawriters, and the
    // measurement wants the publishing path exercised anyway.
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

extern "C" fn main(sp: *const usize) -> ! {
    // SAFETY: at `_start`, `sp` points at argc, then the argv pointers, then NULL.
    let port = unsafe {
        let (argc, argv) = (*sp, sp.add(1) as *const *const u8);
        let mut port = 0u16;
        if argc > 1 {
            let mut p = *argv.add(1);
            while (*p).is_ascii_digit() {
                port = port.wrapping_mul(10).wrapping_add(u16::from(*p - b'0'));
                p = p.add(1);
            }
        }
        if port == 0 {
            8888
        } else {
            port
        }
    };
    let Some(udp) = Udp::connect(port) else { rt::exit(2) };
    // SAFETY: initialized once, before any use, and used from this thread only.
    let session = unsafe { (*addr_of_mut!(SESSION)).write(Session::with_clock(udp, Clk, 0xAAAA_BBBB)) };
    // Painted after the initialization: `Session::with_clock` builds its value on `main`'s frame before it is
    // moved into the static (a one-off `size_of::<Publisher>()` at start-up, reported apart).
    let top = paint();
    let ok = publish(session);
    rt::print(if ok { b"published 10 samples, session deleted\n" } else { b"no agent or refused\n" });
    report(top);
    rt::exit(if ok { 0 } else { 1 })
}

rt::entry!(main);
