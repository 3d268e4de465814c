//! BinaryEntityCreation: creates a participant, topic, publisher, datawriter, subscriber and datareader from
//! binary descriptions (no XML), then publishes an `i32` counter and reads it back through the same agent.
//! Usage, as eProsima's example: `binary_entity_creation <ip> <port> [<max_topics> [<key>]]` (the key argument
//! is ours, so this can run beside eProsima's example, whose key is fixed to 0xAAAABBBB).

use xrce_client::prelude::*;

const STREAM_HISTORY: usize = 8;
const BUFFER_SIZE: usize = 512 * STREAM_HISTORY;

/// Prints each `i32` sample (`on_topic`).
struct Printer;

impl Callbacks for Printer {
    fn on_topic(&mut self, _: &mut Outputs<'_, '_>, _: ObjectId, _: u16, _: StreamId, data: &[u8]) {
        if let Some(value) = data.first_chunk::<4>().map(|b| i32::from_le_bytes(*b)) {
            println!("Received topic: {value}");
        }
    }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    if args.len() < 3 || args[2].parse::<u16>().is_err() {
        println!("usage: program [-h | --help] | ip port [<max_topics> [<key>]]");
        return Ok(());
    }
    let max_topics: u32 = args.get(3).and_then(|s| s.parse().ok()).unwrap_or(u32::MAX);
    let key: u32 = args.get(4).and_then(|s| s.parse().ok()).unwrap_or(0xAAAA_BBBB);

    let transport = UdpTransport::new(IpProtocol::V4, &args[1], &args[2])?;
    let (mut out_buf, mut in_buf) = ([0u8; BUFFER_SIZE], [0u8; BUFFER_SIZE]);
    let mut session = Session::new(transport, key).with_callbacks(Printer);
    session.create_session()?;
    let reliable_out = session.create_output_reliable_stream(&mut out_buf, STREAM_HISTORY)?;
    let reliable_in = session.create_input_reliable_stream(&mut in_buf, STREAM_HISTORY)?;

    let participant_id = object_id(0x01, ObjectKind::Participant);
    let participant_req = session.buffer_create_participant_bin(reliable_out, participant_id, 0, None, REPLACE)?;
    let topic_id = object_id(0x01, ObjectKind::Topic);
    let topic_req = session.buffer_create_topic_bin(
        reliable_out,
        topic_id,
        participant_id,
        "ExampleTopic",
        "ExampleType",
        REPLACE,
    )?;
    let publisher_id = object_id(0x01, ObjectKind::Publisher);
    let publisher_req = session.buffer_create_publisher_bin(reliable_out, publisher_id, participant_id, REPLACE)?;
    let qos = QoS {
        reliability: Reliability::Reliable,
        durability: Durability::TransientLocal,
        history: History::KeepLast,
        depth: 0,
    };
    let datawriter_id = object_id(0x01, ObjectKind::DataWriter);
    let datawriter_req =
        session.buffer_create_datawriter_bin(reliable_out, datawriter_id, publisher_id, topic_id, qos, REPLACE)?;
    let subscriber_id = object_id(0x01, ObjectKind::Subscriber);
    let subscriber_req = session.buffer_create_subscriber_bin(reliable_out, subscriber_id, participant_id, REPLACE)?;
    let datareader_id = object_id(0x01, ObjectKind::DataReader);
    let datareader_req =
        session.buffer_create_datareader_bin(reliable_out, datareader_id, subscriber_id, topic_id, qos, REPLACE)?;

    let requests = [participant_req, topic_req, publisher_req, datawriter_req, subscriber_req, datareader_req];
    let mut status = [0u8; 6];
    if !session.run_session_until_all_status(1000, &requests, &mut status)? {
        println!("Error at create entities: {status:?}");
        std::process::exit(1);
    }

    let control = DeliveryControl { max_samples: DeliveryControl::UNLIMITED, ..Default::default() };
    session.buffer_request_data(reliable_out, datareader_id, reliable_in, Some(&control))?;

    let mut count = 0u32;
    let mut connected = true;
    while connected && count < max_topics {
        let value = count as i32;
        match session.prepare_output_stream(reliable_out, datawriter_id, 4) {
            Ok(mut prepared) => {
                prepared.buffer().copy_from_slice(&value.to_le_bytes());
                println!("Send topic: {value}");
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
