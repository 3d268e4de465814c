//! RequestAdder: a requester sending `(n, n)` every second and printing the sums `reply_adder` sends back.
//! Usage, as eProsima's example: `request_adder <ip> <port> [<key>]`.

use xrce_client::prelude::*;

const STREAM_HISTORY: usize = 8;
const BUFFER_SIZE: usize = 512 * STREAM_HISTORY;

/// Prints the replies (`on_reply`): one little-endian `u64`.
struct Printer;

impl Callbacks for Printer {
    fn on_reply(&mut self, _: &mut Outputs<'_, '_>, _: ObjectId, _: u16, reply_id: u16, data: &[u8]) {
        if let Some(sum) = data.first_chunk::<8>().map(|b| u64::from_le_bytes(*b)) {
            println!("Reply received: {sum} [id: {reply_id}]");
        }
    }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    if args.len() < 3 || args[2].parse::<u16>().is_err() {
        println!("usage: program [-h | --help] | ip port [key]");
        return Ok(());
    }
    let key: u32 = args.get(3).and_then(|s| s.parse().ok()).unwrap_or(0xAAAA_BBBB);

    let transport = UdpTransport::new(IpProtocol::V4, &args[1], &args[2])?;
    let (mut out_buf, mut in_buf) = ([0u8; BUFFER_SIZE], [0u8; BUFFER_SIZE]);
    let mut session = Session::new(transport, key).with_callbacks(Printer);
    session.create_session()?;
    let reliable_out = session.create_output_reliable_stream(&mut out_buf, STREAM_HISTORY)?;
    let reliable_in = session.create_input_reliable_stream(&mut in_buf, STREAM_HISTORY)?;

    let participant_id = object_id(0x01, ObjectKind::Participant);
    let participant_xml = "<dds><participant><rtps><name>default_xrce_participant</name></rtps></participant></dds>";
    let participant_req =
        session.buffer_create_participant_xml(reliable_out, participant_id, 0, participant_xml, REPLACE)?;
    let requester_id = object_id(0x01, ObjectKind::Requester);
    let requester_xml = r#"<dds><requester profile_name="my_requester" service_name="service_name" request_type="request_type" reply_type="reply_type"></requester></dds>"#;
    let requester_req =
        session.buffer_create_requester_xml(reliable_out, requester_id, participant_id, requester_xml, REPLACE)?;

    let mut status = [0u8; 2];
    if !session.run_session_until_all_status(1000, &[participant_req, requester_req], &mut status)? {
        println!("Error at create entities: participant: {} requester: {}", status[0], status[1]);
        std::process::exit(1);
    }

    let control = DeliveryControl { max_samples: DeliveryControl::UNLIMITED, ..Default::default() };
    session.buffer_request_data(reliable_out, requester_id, reliable_in, Some(&control))?;

    let mut count = 0u32;
    let mut connected = true;
    while connected {
        let mut request = [0u8; 8];
        request[..4].copy_from_slice(&count.to_le_bytes());
        request[4..].copy_from_slice(&count.to_le_bytes());
        match session.buffer_request(reliable_out, requester_id, &request) {
            Ok(request_id) => println!("Request sent: ({count} + {count}) [id: {request_id}]"),
            Err(Error::WouldBlock) => println!("Request not sent: history full, retrying"),
            Err(e) => return Err(e.into()),
        }
        connected = session.run_session_time(1000)?;
        count += 1;
    }
    Ok(())
}
