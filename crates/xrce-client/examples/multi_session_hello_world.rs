//! MultiSessionHelloWorld: two sessions (keys 0x11111111 and 0x22222222) on two transports, each publishing
//! to the other on its own topic and printing what it receives.
//! Usage, as eProsima's example: `multi_session_hello_world <ip> <port> [<max_topics>]` (the third argument
//! is ours: eProsima's runs until the agent stops answering).

use serde::{Deserialize, Serialize};
use xrce_client::prelude::*;
use xrce_proto::serde_cdr;

#[derive(Serialize, Deserialize)]
struct HelloWorld<'a> {
    index: u32,
    message: &'a str,
}

const STREAM_HISTORY: usize = 8;
const BUFFER_SIZE: usize = 512 * STREAM_HISTORY;

/// Prints the samples a session receives, with its key (`on_topic`).
struct Printer {
    key: u32,
}

impl Callbacks for Printer {
    fn on_topic(&mut self, _: &mut Outputs<'_, '_>, _: ObjectId, _: u16, _: StreamId, data: &[u8]) {
        if let Ok(topic) = serde_cdr::from_slice::<HelloWorld<'_>>(data) {
            println!("Session {:#X}: {} ({})", self.key, topic.message, topic.index);
        }
    }
}

type HelloSession<'a> = Session<'a, UdpTransport, StdClock, Printer>;

/// Opens session `n` (1 or 2) and creates its participant, both topics, a writer on `HelloWorldTopic_n_to_m`
/// and a reader on `HelloWorldTopic_m_to_n`; returns the session, its output stream and its writer.
fn open<'a>(
    ip: &str,
    port: &str,
    n: u32,
    out_buf: &'a mut [u8],
    in_buf: &'a mut [u8],
) -> Result<(HelloSession<'a>, StreamId, ObjectId), Box<dyn std::error::Error>> {
    let key = 0x1111_1111 * n;
    let transport = UdpTransport::new(IpProtocol::V4, ip, port)?;
    let mut session = Session::new(transport, key).with_callbacks(Printer { key });
    session.create_session()?;
    let out = session.create_output_reliable_stream(out_buf, STREAM_HISTORY)?;
    let input = session.create_input_reliable_stream(in_buf, STREAM_HISTORY)?;

    let m = 3 - n;
    let participant = object_id(0x01, ObjectKind::Participant);
    let xml = format!("<dds><participant><rtps><name>default_xrce_participant_{n}</name></rtps></participant></dds>");
    let mut requests = vec![session.buffer_create_participant_xml(out, participant, 0, &xml, REPLACE)?];
    for (id, topic) in [(1, format!("HelloWorldTopic_{n}_to_{m}")), (2, format!("HelloWorldTopic_{m}_to_{n}"))] {
        let xml = format!("<dds><topic><name>{topic}</name><dataType>HelloWorld</dataType></topic></dds>");
        requests.push(session.buffer_create_topic_xml(
            out,
            object_id(id, ObjectKind::Topic),
            participant,
            &xml,
            REPLACE,
        )?);
    }
    let publisher = object_id(0x01, ObjectKind::Publisher);
    requests.push(session.buffer_create_publisher_xml(out, publisher, participant, "", REPLACE)?);
    let writer = object_id(0x01, ObjectKind::DataWriter);
    let xml = format!(
        "<dds><data_writer><topic><kind>NO_KEY</kind><name>HelloWorldTopic_{n}_to_{m}</name>\
         <dataType>HelloWorld</dataType></topic></data_writer></dds>"
    );
    requests.push(session.buffer_create_datawriter_xml(out, writer, publisher, &xml, REPLACE)?);
    let subscriber = object_id(0x01, ObjectKind::Subscriber);
    requests.push(session.buffer_create_subscriber_xml(out, subscriber, participant, "", REPLACE)?);
    let reader = object_id(0x01, ObjectKind::DataReader);
    let xml = format!(
        "<dds><data_reader><topic><kind>NO_KEY</kind><name>HelloWorldTopic_{m}_to_{n}</name>\
         <dataType>HelloWorld</dataType></topic></data_reader></dds>"
    );
    requests.push(session.buffer_create_datareader_xml(out, reader, subscriber, &xml, REPLACE)?);

    let mut status = vec![0u8; requests.len()];
    if !session.run_session_until_all_status(1000, &requests, &mut status)? {
        return Err(format!("Error at create entities session {n}: {status:?}").into());
    }
    let control = DeliveryControl { max_samples: DeliveryControl::UNLIMITED, ..Default::default() };
    session.buffer_request_data(out, reader, input, Some(&control))?;
    Ok((session, out, writer))
}

/// Serializes `topic` in place into the output stream of `session`.
fn publish(
    session: &mut HelloSession<'_>,
    out: StreamId,
    writer: ObjectId,
    topic: &HelloWorld<'_>,
) -> Result<(), Box<dyn std::error::Error>> {
    let size = serde_cdr::serialized_size(topic)?;
    match session.prepare_output_stream(out, writer, size) {
        Ok(mut prepared) => serde_cdr::to_slice(topic, prepared.buffer()).map(drop).map_err(Into::into),
        Err(Error::WouldBlock) => Ok(()), // history full: this sample is skipped
        Err(e) => Err(e.into()),
    }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    if args.len() < 3 || args[2].parse::<u16>().is_err() {
        println!("usage: program [-h | --help] | ip port");
        return Ok(());
    }
    let max_topics: u32 = args.get(3).and_then(|s| s.parse().ok()).unwrap_or(u32::MAX);

    let (mut out_1, mut in_1, mut out_2, mut in_2) =
        ([0u8; BUFFER_SIZE], [0u8; BUFFER_SIZE], [0u8; BUFFER_SIZE], [0u8; BUFFER_SIZE]);
    let (mut session_1, reliable_out_1, writer_1) = open(&args[1], &args[2], 1, &mut out_1, &mut in_1)?;
    let (mut session_2, reliable_out_2, writer_2) = open(&args[1], &args[2], 2, &mut out_2, &mut in_2)?;

    let mut count = 0u32;
    let mut connected = true;
    while connected && count < max_topics {
        publish(
            &mut session_1,
            reliable_out_1,
            writer_1,
            &HelloWorld { index: count, message: "Publisher 1 says hello" },
        )?;
        publish(
            &mut session_2,
            reliable_out_2,
            writer_2,
            &HelloWorld { index: count, message: "Publisher 2 says hello" },
        )?;
        connected = session_1.run_session_time(1000)?;
        connected &= session_2.run_session_time(1000)?;
        count += 1;
    }
    session_1.delete_session()?;
    session_2.delete_session()?;
    Ok(())
}
