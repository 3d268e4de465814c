//! PublishHelloWorld: creates a participant, topic, publisher and datawriter by XML on a reliable stream and
//! publishes `HelloWorld` samples. Usage, as eProsima's example: `publish_hello_world <ip> <port> [<max_topics>]`.
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
    let mut session = Session::new(transport, 0xAAAA_BBBB);
    session.create_session()?;
    let reliable_out = session.create_output_reliable_stream(&mut out_buf, STREAM_HISTORY)?;
    session.create_input_reliable_stream(&mut in_buf, STREAM_HISTORY)?;

    let participant_id = object_id(0x01, ObjectKind::Participant);
    let topic_id = object_id(0x01, ObjectKind::Topic);
    let publisher_id = object_id(0x01, ObjectKind::Publisher);
    let datawriter_id = object_id(0x01, ObjectKind::DataWriter);
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
            session.buffer_create_publisher_bin(reliable_out, publisher_id, participant_id, REPLACE)?,
            session.buffer_create_datawriter_bin(
                reliable_out,
                datawriter_id,
                publisher_id,
                topic_id,
                QoS::default(),
                REPLACE,
            )?,
        ]
    } else {
        let participant_xml =
            "<dds><participant><rtps><name>default_xrce_participant</name></rtps></participant></dds>";
        let topic_xml = "<dds><topic><name>HelloWorldTopic</name><dataType>HelloWorld</dataType></topic></dds>";
        let datawriter_xml = "<dds><data_writer><topic><kind>NO_KEY</kind><name>HelloWorldTopic</name>\
                              <dataType>HelloWorld</dataType></topic></data_writer></dds>";
        [
            session.buffer_create_participant_xml(reliable_out, participant_id, 0, participant_xml, REPLACE)?,
            session.buffer_create_topic_xml(reliable_out, topic_id, participant_id, topic_xml, REPLACE)?,
            session.buffer_create_publisher_xml(reliable_out, publisher_id, participant_id, "", REPLACE)?,
            session.buffer_create_datawriter_xml(reliable_out, datawriter_id, publisher_id, datawriter_xml, REPLACE)?,
        ]
    };
    let mut status = [0u8; 4];
    if !session.run_session_until_all_status(1000, &requests, &mut status)? {
        println!(
            "Error at create entities: participant: {} topic: {} publisher: {} datawriter: {}",
            status[0], status[1], status[2], status[3]
        );
        std::process::exit(1);
    }

    let mut count = 0u32;
    while count < max_topics {
        let topic = HelloWorld { index: count, message: "Hello DDS world!" };
        let size = serde_cdr::serialized_size(&topic)?;
        match session.prepare_output_stream(reliable_out, datawriter_id, size) {
            Ok(mut prepared) => {
                serde_cdr::to_slice(&topic, prepared.buffer())?;
                count += 1;
            }
            // History full: the agent has not acknowledged yet; run the session and retry.
            Err(Error::WouldBlock) => {}
            Err(e) => return Err(e.into()),
        }
        let connected = session.run_session_time(1000)?;
        if connected {
            println!("Send topic: {}, id: {}", topic.message, topic.index);
        }
    }
    session.delete_session()?;
    Ok(())
}
