//! Our client's custom transport (`uxrCustomTransport`) against our agent: packet-oriented over a UDP socket
//! the callbacks own, and framed (the HDLC-like serial framing) over a pseudoterminal whose other end the
//! agent's `serial` transport opens. A publisher and a subscriber on the same topic, with a sample large
//! enough to be fragmented on the reliable stream.

use std::fs::File;
use std::io::{Read, Write};
use std::net::{SocketAddr, UdpSocket};
use std::os::fd::AsFd;
use std::time::{Duration, Instant};

use xrce_agent::agent::AgentInstance;
use xrce_client::prelude::*;
use xrce_client::TransportError;

const HISTORY: usize = 8;
const BUF: usize = 512 * HISTORY;
/// Larger than the 512-byte MTU: travels as FRAGMENTs.
const BIG: usize = 1500;

/// Packet-oriented callbacks over a UDP socket towards the agent.
struct UdpIo {
    socket: UdpSocket,
    agent: SocketAddr,
}

impl CustomIo for UdpIo {
    fn write(&mut self, buf: &[u8]) -> Result<usize, TransportError> {
        self.socket.send_to(buf, self.agent).map_err(|_| TransportError::Custom(1))
    }

    fn read(&mut self, buf: &mut [u8], timeout_ms: i32) -> Result<usize, TransportError> {
        let timeout = Duration::from_millis(u64::try_from(timeout_ms.max(1)).unwrap_or(1));
        self.socket.set_read_timeout(Some(timeout)).map_err(|_| TransportError::Custom(2))?;
        Ok(self.socket.recv(buf).unwrap_or(0))
    }
}

/// Stream-oriented callbacks over a pseudoterminal's master side.
struct PtyIo {
    master: File,
}

impl CustomIo for PtyIo {
    fn write(&mut self, buf: &[u8]) -> Result<usize, TransportError> {
        self.master.write(buf).map_err(|_| TransportError::Custom(1))
    }

    fn read(&mut self, buf: &mut [u8], timeout_ms: i32) -> Result<usize, TransportError> {
        use nix::poll::{poll, PollFd, PollFlags, PollTimeout};
        let ms = u16::try_from(timeout_ms.clamp(1, 1000)).unwrap_or(1000);
        let mut fds = [PollFd::new(self.master.as_fd(), PollFlags::POLLIN)];
        match poll(&mut fds, PollTimeout::from(ms)) {
            Ok(n) if n > 0 => self.master.read(buf).map_err(|_| TransportError::Custom(2)),
            _ => Ok(0),
        }
    }
}

#[derive(Default)]
struct Samples(Vec<Vec<u8>>);

impl Callbacks for Samples {
    fn on_topic(&mut self, _: &mut Outputs<'_, '_>, _: ObjectId, _: u16, _: StreamId, data: &[u8]) {
        self.0.push(data.to_vec());
    }
}

/// A subscriber session on `sub_io` and a publisher session on `pub_io`, both through the agent: the
/// publisher writes a small and a fragmented sample, the subscriber must get both, whole and in order.
fn pubsub_through<IO: CustomIo>(sub_io: IO, pub_io: IO, framing: bool) {
    let p = object_id(1, ObjectKind::Participant);
    let t = object_id(1, ObjectKind::Topic);
    let topic = "<dds><topic><name>CustomTopic</name><dataType>Blob</dataType></topic></dds>";

    let (mut sub_out, mut sub_in) = ([0u8; BUF], [0u8; BUF * 2]);
    let transport = CustomTransport::<_, 512>::new(sub_io, framing).expect("subscriber transport opens");
    let mut sub = Session::new(transport, 0x0C05_0001).with_callbacks(Samples::default());
    sub.create_session().expect("subscriber session");
    let out = sub.create_output_reliable_stream(&mut sub_out, HISTORY).expect("stream");
    let input = sub.create_input_reliable_stream(&mut sub_in, HISTORY * 2).expect("stream");
    let (s, dr) = (object_id(1, ObjectKind::Subscriber), object_id(1, ObjectKind::DataReader));
    let reader = "<dds><data_reader><topic><kind>NO_KEY</kind><name>CustomTopic</name><dataType>Blob</dataType>\
                  </topic></data_reader></dds>";
    let reqs = [
        sub.buffer_create_participant_xml(out, p, 0, "<dds><participant/></dds>", REPLACE).expect("p"),
        sub.buffer_create_topic_xml(out, t, p, topic, REPLACE).expect("t"),
        sub.buffer_create_subscriber_xml(out, s, p, "", REPLACE).expect("s"),
        sub.buffer_create_datareader_xml(out, dr, s, reader, REPLACE).expect("dr"),
    ];
    let mut status = [0u8; 4];
    assert!(sub.run_session_until_all_status(3000, &reqs, &mut status).expect("run"), "{status:?}");
    let control = DeliveryControl { max_samples: DeliveryControl::UNLIMITED, ..Default::default() };
    sub.buffer_request_data(out, dr, input, Some(&control)).expect("read");
    sub.run_session_time(100).expect("run");

    let (mut pub_out, mut pub_in) = ([0u8; BUF], [0u8; BUF]);
    let transport = CustomTransport::<_, 512>::new(pub_io, framing).expect("publisher transport opens");
    let mut publ = Session::new(transport, 0x0C05_0002);
    publ.create_session().expect("publisher session");
    let out = publ.create_output_reliable_stream(&mut pub_out, HISTORY).expect("stream");
    // The agent's STATUS replies come on the matching input stream.
    publ.create_input_reliable_stream(&mut pub_in, HISTORY).expect("stream");
    let (pb, dw) = (object_id(1, ObjectKind::Publisher), object_id(1, ObjectKind::DataWriter));
    let writer = "<dds><data_writer><topic><kind>NO_KEY</kind><name>CustomTopic</name><dataType>Blob</dataType>\
                  </topic></data_writer></dds>";
    let reqs = [
        publ.buffer_create_participant_xml(out, p, 0, "<dds><participant/></dds>", REPLACE).expect("p"),
        publ.buffer_create_topic_xml(out, t, p, topic, REPLACE).expect("t"),
        publ.buffer_create_publisher_xml(out, pb, p, "", REPLACE).expect("pub"),
        publ.buffer_create_datawriter_xml(out, dw, pb, writer, REPLACE).expect("dw"),
    ];
    assert!(publ.run_session_until_all_status(3000, &reqs, &mut status).expect("run"), "{status:?}");
    let small = vec![7u8; 16];
    let big: Vec<u8> = (0..BIG).map(|i| (i % 251) as u8).collect();
    publ.buffer_topic(out, dw, &small).expect("small sample");
    publ.buffer_topic(out, dw, &big).expect("fragmented sample");
    assert!(publ.run_session_until_confirm_delivery(3000).expect("run"), "the agent acknowledged both");

    let t0 = Instant::now();
    while sub.callbacks().0.len() < 2 && t0.elapsed() < Duration::from_secs(5) {
        sub.run_session_until_data(200).expect("run");
    }
    assert_eq!(sub.callbacks().0, vec![small, big], "both samples, whole and in order");
    let _ = publ.delete_session();
    let _ = sub.delete_session();
}

#[test]
fn custom_transport_packet_mode_over_udp() {
    let mut agent = AgentInstance::create(["xrce-agent", "udp4", "-p", "0", "-m", "ced", "-v", "0"]).expect("agent");
    let port = agent.local_addr().expect("bound").port();
    let addr: SocketAddr = format!("127.0.0.1:{port}").parse().unwrap();
    let io = || UdpIo { socket: UdpSocket::bind("127.0.0.1:0").unwrap(), agent: addr };
    pubsub_through(io(), io(), false);
    agent.stop().expect("agent stops");
}

#[test]
fn custom_transport_framed_mode_over_a_pty() {
    // Two pseudoterminals: the agent's multiserial transport opens their slave sides, each client session
    // talks through a master.
    let ptys: Vec<nix::pty::OpenptyResult> = (0..2).map(|_| nix::pty::openpty(None, None).expect("pty")).collect();
    let names: Vec<String> =
        ptys.iter().map(|p| nix::unistd::ttyname(&p.slave).expect("tty name").display().to_string()).collect();
    let devs = names.join(" ");
    let mut agent =
        AgentInstance::create(["xrce-agent", "multiserial", "--devs", &devs, "-m", "ced", "-v", "0"]).expect("agent");
    let mut masters = ptys.into_iter().map(|p| PtyIo { master: File::from(p.master) });
    let (sub_io, pub_io) = (masters.next().unwrap(), masters.next().unwrap());
    pubsub_through(sub_io, pub_io, true);
    agent.stop().expect("agent stops");
}
