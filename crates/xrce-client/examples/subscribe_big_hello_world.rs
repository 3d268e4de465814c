//! SubscribeBigHelloWorld: receives the 49,999-character samples of `publish_big_hello_world`, reassembled from
//! their fragments in a 128-slot reliable input stream.
//! Usage, as eProsima's example: `subscribe_big_hello_world <ip> <port> [<max_topics>]`.

use serde::Deserialize;
use xrce_client::prelude::*;
use xrce_proto::serde_cdr;

#[derive(Deserialize)]
struct BigHelloWorld<'a> {
    index: u32,
    message: &'a str,
}

const STREAM_HISTORY: usize = 128;
const BUFFER_SIZE: usize = 512 * STREAM_HISTORY;

/// Counts and prints samples (`on_topic`).
#[derive(Default)]
struct Printer {
    count: u32,
}

impl Callbacks for Printer {
    fn on_topic(&mut self, _: &mut Outputs<'_, '_>, _: ObjectId, _: u16, _: StreamId, data: &[u8]) {
        if let Ok(topic) = serde_cdr::from_slice::<BigHelloWorld<'_>>(data) {
            println!("Received topic with size {}, id: {}", topic.message.len(), topic.index);
            println!("\tMessage: {}...", topic.message.get(..30).unwrap_or(topic.message));
            self.count += 1;
        }
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
    let (mut out_buf, mut in_buf) = (vec![0u8; BUFFER_SIZE], vec![0u8; BUFFER_SIZE]);
    let mut session = Session::new(transport, 0xCCCC_DDDD).with_callbacks(Printer::default());
    session.create_session()?;
    let reliable_out = session.create_output_reliable_stream(&mut out_buf, STREAM_HISTORY)?;
    let reliable_in = session.create_input_reliable_stream(&mut in_buf, STREAM_HISTORY)?;

    let participant_id = object_id(0x01, ObjectKind::Participant);
    let participant_xml = "<dds><participant><rtps><name>default_xrce_participant</name></rtps></participant></dds>";
    let participant_req =
        session.buffer_create_participant_xml(reliable_out, participant_id, 0, participant_xml, REPLACE)?;
    let topic_id = object_id(0x01, ObjectKind::Topic);
    let topic_xml = "<dds><topic><name>BigHelloWorldTopic</name><dataType>BigHelloWorld</dataType></topic></dds>";
    let topic_req = session.buffer_create_topic_xml(reliable_out, topic_id, participant_id, topic_xml, REPLACE)?;
    let subscriber_id = object_id(0x01, ObjectKind::Subscriber);
    let subscriber_req =
        session.buffer_create_subscriber_xml(reliable_out, subscriber_id, participant_id, "", REPLACE)?;
    let datareader_id = object_id(0x01, ObjectKind::DataReader);
    let datareader_xml = "<dds><data_reader><topic><kind>NO_KEY</kind><name>BigHelloWorldTopic</name>\
                          <dataType>BigHelloWorld</dataType></topic></data_reader></dds>";
    let datareader_req =
        session.buffer_create_datareader_xml(reliable_out, datareader_id, subscriber_id, datareader_xml, REPLACE)?;

    let requests = [participant_req, topic_req, subscriber_req, datareader_req];
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
        session.run_session_time(1000)?;
    }
    session.delete_session()?;
    Ok(())
}
