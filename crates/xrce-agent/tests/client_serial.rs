//! Our client's serial transport (`SerialTransport`, `uxr_init_serial_transport`) against our agent's serial
//! servers on pseudoterminals: sessions, entities, a small and a fragmented sample on reliable streams; and a
//! device that goes away (its pseudoterminal closed, as a USB adapter unplugged) and comes back under the same
//! path, which the agent opens again while its other line goes on, and whose client goes on where it was.

use std::fs::File;
use std::io::Write;
use std::os::fd::OwnedFd;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, OnceLock};
use std::time::{Duration, Instant};

use xrce_agent::agent::{Agent, AgentInstance};
use xrce_agent::core::CoreConfig;
use xrce_agent::middleware::MiddlewareKind;
use xrce_agent::transport::serial::{Line, SerialEndpoint, SerialServer};
use xrce_client::prelude::*;

const HISTORY: usize = 8;
const BUF: usize = 512 * HISTORY;
/// Larger than the 512-byte MTU: travels as FRAGMENTs.
const BIG: usize = 1500;
const TOPIC: &str = "<dds><topic><name>SerialTopic</name><dataType>Blob</dataType></topic></dds>";

#[derive(Default)]
struct Samples(Vec<Vec<u8>>);

impl Callbacks for Samples {
    fn on_topic(&mut self, _: &mut Outputs<'_, '_>, _: ObjectId, _: u16, _: StreamId, data: &[u8]) {
        self.0.push(data.to_vec());
    }
}

type Sub<'a> = Session<'a, SerialTransport, StdClock, Samples>;
type Pub<'a> = Session<'a, SerialTransport, StdClock>;

/// A session on `transport` with a participant, the topic and a data reader reading from a reliable stream.
fn subscriber<'a>(transport: SerialTransport, key: u32, out: &'a mut [u8], input: &'a mut [u8]) -> Sub<'a> {
    let mut sub = Session::new(transport, key).with_callbacks(Samples::default());
    sub.create_session().expect("subscriber session");
    let o = sub.create_output_reliable_stream(out, HISTORY).expect("stream");
    let i = sub.create_input_reliable_stream(input, HISTORY * 2).expect("stream");
    let (p, t) = (object_id(1, ObjectKind::Participant), object_id(1, ObjectKind::Topic));
    let (s, dr) = (object_id(1, ObjectKind::Subscriber), object_id(1, ObjectKind::DataReader));
    let reader = "<dds><data_reader><topic><kind>NO_KEY</kind><name>SerialTopic</name><dataType>Blob</dataType>\
                  </topic></data_reader></dds>";
    let reqs = [
        sub.buffer_create_participant_xml(o, p, 0, "<dds><participant/></dds>", REPLACE).expect("p"),
        sub.buffer_create_topic_xml(o, t, p, TOPIC, REPLACE).expect("t"),
        sub.buffer_create_subscriber_xml(o, s, p, "", REPLACE).expect("s"),
        sub.buffer_create_datareader_xml(o, dr, s, reader, REPLACE).expect("dr"),
    ];
    let mut status = [0u8; 4];
    assert!(sub.run_session_until_all_status(3000, &reqs, &mut status).expect("run"), "{status:?}");
    let control = DeliveryControl { max_samples: DeliveryControl::UNLIMITED, ..Default::default() };
    sub.buffer_request_data(o, dr, i, Some(&control)).expect("read");
    sub.run_session_time(100).expect("run");
    sub
}

/// A session on `transport` with a participant, the topic and a data writer on a reliable stream; returns
/// the stream and the writer.
fn publisher<'a>(
    transport: SerialTransport,
    key: u32,
    out: &'a mut [u8],
    input: &'a mut [u8],
) -> (Pub<'a>, StreamId, ObjectId) {
    let mut publ = Session::new(transport, key);
    publ.create_session().expect("publisher session");
    let o = publ.create_output_reliable_stream(out, HISTORY).expect("stream");
    publ.create_input_reliable_stream(input, HISTORY).expect("stream");
    let (p, t) = (object_id(1, ObjectKind::Participant), object_id(1, ObjectKind::Topic));
    let (pb, dw) = (object_id(1, ObjectKind::Publisher), object_id(1, ObjectKind::DataWriter));
    let writer = "<dds><data_writer><topic><kind>NO_KEY</kind><name>SerialTopic</name><dataType>Blob</dataType>\
                  </topic></data_writer></dds>";
    let reqs = [
        publ.buffer_create_participant_xml(o, p, 0, "<dds><participant/></dds>", REPLACE).expect("p"),
        publ.buffer_create_topic_xml(o, t, p, TOPIC, REPLACE).expect("t"),
        publ.buffer_create_publisher_xml(o, pb, p, "", REPLACE).expect("pub"),
        publ.buffer_create_datawriter_xml(o, dw, pb, writer, REPLACE).expect("dw"),
    ];
    let mut status = [0u8; 4];
    assert!(publ.run_session_until_all_status(3000, &reqs, &mut status).expect("run"), "{status:?}");
    (publ, o, dw)
}

/// Runs the subscriber until it holds `n` samples (or 5 s passed).
fn wait_for_samples(sub: &mut Sub<'_>, n: usize) {
    let t0 = Instant::now();
    while sub.callbacks().0.len() < n && t0.elapsed() < Duration::from_secs(5) {
        sub.run_session_until_data(200).expect("run");
    }
}

fn big_sample(seed: u8) -> Vec<u8> {
    (0..BIG).map(|i| (i % 251) as u8 ^ seed).collect()
}

/// A pseudoterminal: its master as a file (the client's end) and its slave (the agent's device).
fn pty() -> (File, OwnedFd, PathBuf) {
    let pty = nix::pty::openpty(None, None).expect("pty");
    let path = nix::unistd::ttyname(&pty.slave).expect("tty name");
    (File::from(pty.master), pty.slave, path)
}

/// One agent, two lines: a pseudoterminal the agent created (the client opens its path with
/// `SerialTransport::open_device`) and a device the agent opened (a pty slave; the client is on the master,
/// given to `SerialTransport::from_file`). The subscriber on one, the publisher on the other, a small and a
/// fragmented sample through the agent.
#[test]
fn serial_transport_publishes_and_subscribes_through_the_agent() {
    let agent = Agent::<SerialEndpoint>::new(MiddlewareKind::Ced, CoreConfig::default()).expect("ced");
    let created = Line::pseudoterminal(921_600).expect("agent's pseudoterminal");
    let created_path = created.path();
    let (master, slave, device) = pty();
    let opened = Line::open(&device, 921_600, false).expect("agent opens the pty slave");
    drop(slave);
    let server = SerialServer::new(vec![created, opened], agent.core());
    let stop = Arc::new(AtomicBool::new(false));
    let stop2 = stop.clone();
    let thread = std::thread::spawn(move || server.run(&stop2));

    let (mut sub_out, mut sub_in) = ([0u8; BUF], [0u8; BUF * 2]);
    let transport = SerialTransport::open_device(&created_path, SerialSettings::new(921_600), 0, 1).expect("opens");
    assert_eq!(transport.mtu(), 512, "eProsima's serial MTU");
    let mut sub = subscriber(transport, 0x5E21_0001, &mut sub_out, &mut sub_in);

    let (mut pub_out, mut pub_in) = ([0u8; BUF], [0u8; BUF]);
    let (mut publ, o, dw) = publisher(SerialTransport::from_file(master, 0, 9), 0x5E21_0002, &mut pub_out, &mut pub_in);
    let small = vec![7u8; 16];
    publ.buffer_topic(o, dw, &small).expect("small sample");
    publ.buffer_topic(o, dw, &big_sample(0)).expect("fragmented sample");
    assert!(publ.run_session_until_confirm_delivery(3000).expect("run"), "the agent acknowledged both");

    wait_for_samples(&mut sub, 2);
    assert_eq!(sub.callbacks().0, vec![small, big_sample(0)], "both samples, whole and in order");
    assert!(publ.delete_session().expect("run"));
    assert!(sub.delete_session().expect("run"));
    stop.store(true, Ordering::Relaxed);
    thread.join().expect("server thread").expect("server ran");
}

/// The agent's log lines, captured from every thread of this test binary.
fn log() -> &'static Arc<Mutex<Vec<u8>>> {
    static LOG: OnceLock<Arc<Mutex<Vec<u8>>>> = OnceLock::new();
    LOG.get_or_init(|| {
        let log = Arc::new(Mutex::new(Vec::new()));
        let sink = log.clone();
        let subscriber = tracing_subscriber::fmt()
            .with_max_level(tracing::Level::INFO)
            .with_ansi(false)
            .with_writer(move || Sink(sink.clone()))
            .finish();
        tracing::subscriber::set_global_default(subscriber).expect("the only global subscriber");
        log
    })
}

struct Sink(Arc<Mutex<Vec<u8>>>);

impl Write for Sink {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.0.lock().unwrap_or_else(std::sync::PoisonError::into_inner).extend_from_slice(buf);
        Ok(buf.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

/// Waits up to 5 s for a log line holding all of `words`.
fn wait_for_log(words: &[&str]) -> bool {
    let t0 = Instant::now();
    while t0.elapsed() < Duration::from_secs(5) {
        let text = String::from_utf8_lossy(&log().lock().unwrap()).into_owned();
        if text.lines().any(|l| words.iter().all(|w| l.contains(w))) {
            return true;
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    false
}

/// Points the symlink `link` at `target`, atomically (as udev does for /dev/serial/by-id).
fn point(link: &Path, target: &Path) {
    let tmp = link.with_extension("new");
    let _ = std::fs::remove_file(&tmp);
    std::os::unix::fs::symlink(target, &tmp).expect("symlink");
    std::fs::rename(&tmp, link).expect("rename");
}

/// `multiserial` on a symlink to a pty slave (the device) and on a second pty. The device's pty is closed (the
/// agent reads a hang-up, as from an unplugged USB adapter): the agent logs it, the other line keeps working,
/// and once the symlink points at a new pty the agent logs that the device is back and has set it as before
/// (250000 baud, RTS/CTS). The publisher, given the new pty, goes on: the sample it wrote while the device was
/// gone and one written after reach the subscriber on the other line, and it creates its session again.
#[test]
fn an_unplugged_device_is_reopened_and_its_client_goes_on() {
    use nix::sys::termios::{tcgetattr, ControlFlags};
    log();
    let dir = std::env::temp_dir().join(format!("xrce-serial-replug-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let link = dir.join("ttyXRCE0");
    let (master, slave, device) = pty();
    point(&link, &device);
    let (other_master, other_slave, other) = pty();
    let devs = format!("{} {}", link.display(), other.display());
    let mut agent = AgentInstance::create([
        "xrce-agent",
        "multiserial",
        "--devs",
        &devs,
        "-b",
        "250000",
        "--flow-control",
        "-m",
        "ced",
    ])
    .expect("agent");
    drop((slave, other_slave));

    let (mut sub_out, mut sub_in) = ([0u8; BUF], [0u8; BUF * 2]);
    let mut sub = subscriber(SerialTransport::from_file(other_master, 0, 1), 0x5E21_0011, &mut sub_out, &mut sub_in);
    let (mut pub_out, mut pub_in) = ([0u8; BUF], [0u8; BUF]);
    let (mut publ, o, dw) = publisher(SerialTransport::from_file(master, 0, 1), 0x5E21_0012, &mut pub_out, &mut pub_in);
    publ.buffer_topic(o, dw, &big_sample(1)).expect("before");
    assert!(publ.run_session_until_confirm_delivery(3000).expect("run"));
    wait_for_samples(&mut sub, 1);

    // Unplugged.
    publ.transport().close().expect("close");
    let name = link.display().to_string();
    assert!(wait_for_log(&["WARN", &name, "is gone"]), "the agent logs the device gone");
    assert!(sub.ping_agent_session(1000, 3).expect("ping"), "the other line still answers");
    publ.buffer_topic(o, dw, &big_sample(2)).expect("while gone");

    // Plugged back under the same name.
    let (master, slave, device) = pty();
    point(&link, &device);
    assert!(wait_for_log(&["INFO", &name, "is back"]), "the agent logs the device back");
    let attrs = tcgetattr(&slave).expect("termios");
    assert!(attrs.control_flags.contains(ControlFlags::CRTSCTS), "--flow-control again");
    assert_eq!(attrs.control_flags.bits() & nix::libc::CBAUD, nix::libc::BOTHER, "250000 baud again");
    publ.transport().reattach(master);
    publ.buffer_topic(o, dw, &big_sample(3)).expect("after");
    assert!(publ.run_session_until_confirm_delivery(5000).expect("run"), "the agent acknowledged all");
    wait_for_samples(&mut sub, 3);
    assert_eq!(sub.callbacks().0, vec![big_sample(1), big_sample(2), big_sample(3)], "whole, in order, none lost");
    publ.create_session().expect("a session again on the reopened device");

    drop(slave);
    agent.stop().expect("agent stops");
    let _ = std::fs::remove_dir_all(&dir);
}
