//! A client on a custom transport (eProsima's `uxrCustomTransport`, seed 004): the four callbacks over a UDP
//! socket of the example's own, packet-oriented, or stream-oriented with `--framing` (the session's messages
//! then travel in HDLC-like frames, cut into datagrams of up to 64 bytes). Creates a session and a
//! datawriter, and publishes a few samples, one larger than the MTU (sent in fragments).
//!
//! usage: custom_transport <ip> <port> [--framing]
//! with the custom agent example: cargo run -p xrce-agent --example custom_agent -- <port> [--framing]

use std::net::UdpSocket;
use std::time::Duration;

use xrce_client::prelude::*;
use xrce_client::TransportError;

const STREAM_HISTORY: usize = 8;
const BUFFER_SIZE: usize = 512 * STREAM_HISTORY;

/// The callbacks' state (eProsima's `transport->args`).
struct UdpCallbacks {
    socket: UdpSocket,
}

impl CustomIo for UdpCallbacks {
    fn write(&mut self, buf: &[u8]) -> Result<usize, TransportError> {
        self.socket.send(buf).map_err(|_| TransportError::Custom(1))
    }

    fn read(&mut self, buf: &mut [u8], timeout_ms: i32) -> Result<usize, TransportError> {
        let ms = u64::try_from(timeout_ms.max(1)).unwrap_or(1);
        self.socket.set_read_timeout(Some(Duration::from_millis(ms))).map_err(|_| TransportError::Custom(2))?;
        // A timeout reads nothing.
        Ok(self.socket.recv(buf).unwrap_or(0))
    }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let (Some(ip), Some(port)) = (args.get(1), args.get(2).and_then(|p| p.parse::<u16>().ok())) else {
        println!("usage: custom_transport <ip> <port> [--framing]");
        return Ok(());
    };
    let framing = args.iter().any(|a| a == "--framing");

    let socket = UdpSocket::bind("0.0.0.0:0")?;
    socket.connect((ip.as_str(), port))?;
    // eProsima: uxr_set_custom_transport_callbacks(&transport, framing, open, close, write, read) and
    // uxr_init_custom_transport(&transport, &args).
    let transport = CustomTransport::<_, 512>::new(UdpCallbacks { socket }, framing)?;

    let (mut out_buf, mut in_buf) = ([0u8; BUFFER_SIZE], [0u8; BUFFER_SIZE]);
    let mut session = Session::new(transport, 0xCC05_7001);
    session.create_session()?;
    let out = session.create_output_reliable_stream(&mut out_buf, STREAM_HISTORY)?;
    session.create_input_reliable_stream(&mut in_buf, STREAM_HISTORY)?;

    let participant = object_id(1, ObjectKind::Participant);
    let topic = object_id(1, ObjectKind::Topic);
    let publisher = object_id(1, ObjectKind::Publisher);
    let writer = object_id(1, ObjectKind::DataWriter);
    let topic_xml = "<dds><topic><name>CustomTopic</name><dataType>Blob</dataType></topic></dds>";
    let writer_xml = "<dds><data_writer><topic><kind>NO_KEY</kind><name>CustomTopic</name>\
                      <dataType>Blob</dataType></topic></data_writer></dds>";
    let requests = [
        session.buffer_create_participant_xml(out, participant, 0, "<dds><participant/></dds>", REPLACE)?,
        session.buffer_create_topic_xml(out, topic, participant, topic_xml, REPLACE)?,
        session.buffer_create_publisher_xml(out, publisher, participant, "", REPLACE)?,
        session.buffer_create_datawriter_xml(out, writer, publisher, writer_xml, REPLACE)?,
    ];
    let mut status = [0u8; 4];
    if !session.run_session_until_all_status(1000, &requests, &mut status)? {
        println!("entities not created: {status:?}");
        std::process::exit(1);
    }

    for i in 0..5u8 {
        // The last one is larger than the 512-byte MTU: it goes in fragments.
        let sample = vec![i; if i == 4 { 2000 } else { 32 }];
        session.buffer_topic(out, writer, &sample)?;
        let delivered = session.run_session_until_confirm_delivery(1000)?;
        println!("sample {i} ({} bytes) {}", sample.len(), if delivered { "acknowledged" } else { "not acknowledged" });
    }
    session.delete_session()?;
    Ok(())
}
