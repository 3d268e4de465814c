//! ReplyAdder: a replier answering each `(a, b)` request of `request_adder` with `a + b`, from the request
//! callback. Usage, as eProsima's example: `reply_adder <ip> <port> [<key>]`.

use xrce_client::prelude::*;

const STREAM_HISTORY: usize = 8;
const BUFFER_SIZE: usize = 512 * STREAM_HISTORY;

/// Answers requests (`on_request`): two little-endian `u32` in, their sum as a `u64` out.
struct Adder {
    reliable_out: StreamId,
    replier_id: ObjectId,
}

impl Callbacks for Adder {
    fn on_request(&mut self, out: &mut Outputs<'_, '_>, _: ObjectId, _: u16, sample_id: &SampleIdentity, data: &[u8]) {
        let word = |i: usize| data.get(i..i + 4).and_then(|w| w.try_into().ok()).map(u32::from_le_bytes);
        let (Some(a), Some(b)) = (word(0), word(4)) else { return };
        println!("Request received: ({a} + {b})");
        let sum = u64::from(a) + u64::from(b);
        match out.buffer_reply(self.reliable_out, self.replier_id, sample_id, &sum.to_le_bytes()) {
            Ok(_) => println!("Reply send: {sum}"),
            Err(e) => println!("Reply not sent: {e}"),
        }
    }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    if args.len() < 3 || args[2].parse::<u16>().is_err() {
        println!("usage: program [-h | --help] | ip port [key]");
        return Ok(());
    }
    let key: u32 = args.get(3).and_then(|s| s.parse().ok()).unwrap_or(0xCCCC_DDDD);

    let transport = UdpTransport::new(IpProtocol::V4, &args[1], &args[2])?;
    let (mut out_buf, mut in_buf) = ([0u8; BUFFER_SIZE], [0u8; BUFFER_SIZE]);
    let mut session = Session::new(transport, key);
    session.create_session()?;
    let reliable_out = session.create_output_reliable_stream(&mut out_buf, STREAM_HISTORY)?;
    let reliable_in = session.create_input_reliable_stream(&mut in_buf, STREAM_HISTORY)?;

    let participant_id = object_id(0x01, ObjectKind::Participant);
    let participant_xml = "<dds><participant><rtps><name>default_xrce_participant</name></rtps></participant></dds>";
    let participant_req =
        session.buffer_create_participant_xml(reliable_out, participant_id, 0, participant_xml, REPLACE)?;
    let replier_id = object_id(0x01, ObjectKind::Replier);
    let replier_xml = r#"<dds><replier profile_name="my_replier" service_name="service_name" request_type="request_type" reply_type="reply_type"></replier></dds>"#;
    let replier_req =
        session.buffer_create_replier_xml(reliable_out, replier_id, participant_id, replier_xml, REPLACE)?;

    let mut status = [0u8; 2];
    if !session.run_session_until_all_status(1000, &[participant_req, replier_req], &mut status)? {
        println!("Error at create entities: participant: {} replier: {}", status[0], status[1]);
        std::process::exit(1);
    }

    let control = DeliveryControl { max_samples: DeliveryControl::UNLIMITED, ..Default::default() };
    session.buffer_request_data(reliable_out, replier_id, reliable_in, Some(&control))?;

    let mut session = session.with_callbacks(Adder { reliable_out, replier_id });
    while session.run_session_time(1000)? {}
    Ok(())
}
