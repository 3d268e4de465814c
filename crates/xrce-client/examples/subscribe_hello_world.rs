//! SubscribeHelloWorld: creates a participant, topic, subscriber and datareader by XML, asks for every sample on
//! reliable input stream 0x80 and prints them. Usage: `subscribe_hello_world <ip> <port> [<max_topics>]`.
//! With `XRCE_ENTITIES=binary` in the environment the entities are created with the binary representation
//! instead, for agents that cannot parse XML (eProsima's v3 agent with `-m ced`).

use serde::{Deserialize, Serialize};
use xrce_client::prelude::*;
use xrce_proto::serde_cdr;

#[derive(Serialize, Deserialize, Debug)]
struct HelloWorld<'a> {
    index: u32,
    message: &'a str,
}

const STREAM_HISTORY: usize = 8;
const BUFFER_SIZE: usize = 512 * STREAM_HISTORY;

/// Counts and prints samples (`on_topic`).
#[derive(Default)]
struct Printer {
    count: u32,
}

impl Callbacks for Printer {
    fn on_topic(&mut self, _: &mut Outputs<'_, '_>, _: ObjectId, _: u16, _: StreamId, data: &[u8]) {
        if let Ok(topic) = serde_cdr::from_slice::<HelloWorld<'_>>(data) {
            println!("Received topic: {}, id: {}", topic.message, topic.index);
            self.count += 1;
        }
    }

    // Reconnection is on by default: these only report it (eProsima's example has no counterpart).
    fn on_session_lost(&mut self) {
        println!("Agent lost, reconnecting");
    }

    fn on_session_restored(&mut self, recreated: bool) {
        println!("Agent back ({})", if recreated { "session and entities created again" } else { "session kept" });
    }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    if args.len() < 3 || args[2].parse::<u16>().is_err() {
        println!("usage: program [-h | --help] | ip port [<max_topics>]");
        return Ok(());
    }
    let max_topics: u32 = args.get(3).and_then(|s| s.parse().ok()).unwrap_or(u32::MAX);

    let transport = UdpTransport::new(IpProtocol::V4, &args[1], &args[2])?;
    let mut out_buf = [0u8; BUFFER_SIZE];
    let mut in_buf = [0u8; BUFFER_SIZE];
    let mut session = Session::new(transport, 0xCCCC_DDDD).with_callbacks(Printer::default());
    session.create_session()?;
    let reliable_out = session.create_output_reliable_stream(&mut out_buf, STREAM_HISTORY)?;
    let reliable_in = session.create_input_reliable_stream(&mut in_buf, STREAM_HISTORY)?;

    let participant_id = object_id(0x01, ObjectKind::Participant);
    let topic_id = object_id(0x01, ObjectKind::Topic);
    let subscriber_id = object_id(0x01, ObjectKind::Subscriber);
    let datareader_id = object_id(0x01, ObjectKind::DataReader);
    let requests = if std::env::var("XRCE_ENTITIES").is_ok_and(|v| v == "binary") {
        [
            session.buffer_create_participant_bin(reliable_out, participant_id, 0, None, REPLACE)?,
            session.buffer_create_topic_bin(
                reliable_out,
                topic_id,
                participant_id,
                "HelloWorldTopic",
                "HelloWorld",
                REPLACE,
            )?,
            session.buffer_create_subscriber_bin(reliable_out, subscriber_id, participant_id, REPLACE)?,
            session.buffer_create_datareader_bin(
                reliable_out,
                datareader_id,
                subscriber_id,
                topic_id,
                QoS::default(),
                REPLACE,
            )?,
        ]
    } else {
        let participant_xml =
            "<dds><participant><rtps><name>default_xrce_participant</name></rtps></participant></dds>";
        let topic_xml = "<dds><topic><name>HelloWorldTopic</name><dataType>HelloWorld</dataType></topic></dds>";
        let datareader_xml = "<dds><data_reader><topic><kind>NO_KEY</kind><name>HelloWorldTopic</name>\
                              <dataType>HelloWorld</dataType></topic></data_reader></dds>";
        [
            session.buffer_create_participant_xml(reliable_out, participant_id, 0, participant_xml, REPLACE)?,
            session.buffer_create_topic_xml(reliable_out, topic_id, participant_id, topic_xml, REPLACE)?,
            session.buffer_create_subscriber_xml(reliable_out, subscriber_id, participant_id, "", REPLACE)?,
            session.buffer_create_datareader_xml(
                reliable_out,
                datareader_id,
                subscriber_id,
                datareader_xml,
                REPLACE,
            )?,
        ]
    };
    let mut status = [0u8; 4];
    if !session.run_session_until_all_status(1000, &requests, &mut status)? {
        println!(
            "Error at create entities: participant: {} topic: {} subscriber: {} datareader: {}",
            status[0], status[1], status[2], status[3]
        );
        std::process::exit(1);
    }

    let control = DeliveryControl { max_samples: DeliveryControl::UNLIMITED, ..Default::default() };
    session.buffer_request_data(reliable_out, datareader_id, reliable_in, Some(&control))?;

    while session.callbacks().count < max_topics {
        session.run_session_until_data(1000)?;
    }
    session.delete_session()?;
    Ok(())
}
