//! PublishBigHelloWorld: publishes 49,999-character `BigHelloWorld` samples on a reliable stream with a
//! 128-slot history; each sample travels in about a hundred FRAGMENT submessages.
//! Usage, as eProsima's example: `publish_big_hello_world <ip> <port> [<max_topics>]`.

use serde::Serialize;
use xrce_client::prelude::*;
use xrce_proto::serde_cdr;

/// `BigHelloWorld` of eProsima's example: `char message[50000]` holds 49,999 characters and the NUL.
#[derive(Serialize)]
struct BigHelloWorld<'a> {
    index: u32,
    message: &'a str,
}

const STREAM_HISTORY: usize = 128;
const BUFFER_SIZE: usize = 512 * STREAM_HISTORY;
const MESSAGE_LEN: usize = 49_999;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    if args.len() < 3 || args[2].parse::<u16>().is_err() {
        println!("usage: program [-h | --help] | ip port [<max_topics>]");
        return Ok(());
    }
    let max_topics: u32 = args.get(3).and_then(|s| s.parse().ok()).unwrap_or(u32::MAX);

    let transport = UdpTransport::new(IpProtocol::V4, &args[1], &args[2])?;
    // 64 KiB each: on the heap, the main thread's stack is not the place for them.
    let (mut out_buf, mut in_buf) = (vec![0u8; BUFFER_SIZE], vec![0u8; BUFFER_SIZE]);
    let mut session = Session::new(transport, 0xAAAA_BBBB);
    session.create_session()?;
    let reliable_out = session.create_output_reliable_stream(&mut out_buf, STREAM_HISTORY)?;
    session.create_input_reliable_stream(&mut in_buf, STREAM_HISTORY)?;

    let participant_id = object_id(0x01, ObjectKind::Participant);
    let participant_xml = "<dds><participant><rtps><name>default_xrce_participant</name></rtps></participant></dds>";
    let participant_req =
        session.buffer_create_participant_xml(reliable_out, participant_id, 0, participant_xml, REPLACE)?;
    let topic_id = object_id(0x01, ObjectKind::Topic);
    let topic_xml = "<dds><topic><name>BigHelloWorldTopic</name><dataType>BigHelloWorld</dataType></topic></dds>";
    let topic_req = session.buffer_create_topic_xml(reliable_out, topic_id, participant_id, topic_xml, REPLACE)?;
    let publisher_id = object_id(0x01, ObjectKind::Publisher);
    let publisher_req = session.buffer_create_publisher_xml(reliable_out, publisher_id, participant_id, "", REPLACE)?;
    let datawriter_id = object_id(0x01, ObjectKind::DataWriter);
    let datawriter_xml = "<dds><data_writer><topic><kind>NO_KEY</kind><name>BigHelloWorldTopic</name>\
                          <dataType>BigHelloWorld</dataType></topic></data_writer></dds>";
    let datawriter_req =
        session.buffer_create_datawriter_xml(reliable_out, datawriter_id, publisher_id, datawriter_xml, REPLACE)?;

    let requests = [participant_req, topic_req, publisher_req, datawriter_req];
    let mut status = [0u8; 4];
    if !session.run_session_until_all_status(1000, &requests, &mut status)? {
        println!(
            "Error at create entities: participant: {} topic: {} publisher: {} datawriter: {}",
            status[0], status[1], status[2], status[3]
        );
        std::process::exit(1);
    }

    let message = "A".repeat(MESSAGE_LEN);
    let mut sample = Vec::new();
    let mut count = 0u32;
    let mut connected = true;
    while connected && count < max_topics {
        let topic = BigHelloWorld { index: count, message: &message };
        sample.resize(serde_cdr::serialized_size(&topic)?, 0);
        serde_cdr::to_slice(&topic, &mut sample)?;
        // Fragmented over the reliable stream; all or nothing, so a history still holding the previous sample
        // says WouldBlock: run the session until the agent acknowledges, then retry.
        match session.buffer_topic(reliable_out, datawriter_id, &sample) {
            Ok(_) => {
                println!("Send topic with size {}, id: {}", topic.message.len(), topic.index);
                count += 1;
            }
            Err(Error::WouldBlock) => {}
            Err(e) => return Err(e.into()),
        }
        connected = session.run_session_time(1000)?;
    }
    session.delete_session()?;
    Ok(())
}
