//! PublishHelloWorld over CAN FD: `can_publisher <interface> [<can_id hex>] [<max_topics>]`, against an agent
//! started with `xrce-agent canfd --dev <interface>` (or eProsima's `MicroXRCEAgent canfd --dev <interface>`).
//! Entities are created in the binary representation, a few frames each; every message is at most 63 bytes,
//! so the stream buffers are sized `CAN_MTU * history`, as eProsima's CAN examples do.

#[cfg(all(target_os = "linux", feature = "can"))]
fn main() -> Result<(), Box<dyn std::error::Error>> {
    use serde::Serialize;
    use xrce_client::prelude::*;
    use xrce_client::transport::can::CAN_MTU;
    use xrce_proto::serde_cdr;

    #[derive(Serialize)]
    struct HelloWorld<'a> {
        index: u32,
        message: &'a str,
    }

    const STREAM_HISTORY: usize = 8;
    const OUT_SIZE: usize = CAN_MTU * STREAM_HISTORY;
    const IN_SIZE: usize = 64 * STREAM_HISTORY;

    let args: Vec<String> = std::env::args().collect();
    let Some(interface) = args.get(1) else {
        println!("usage: can_publisher [-h | --help] | <interface> [<can_id hex>] [<max_topics>]");
        return Ok(());
    };
    let can_id = match args.get(2) {
        Some(id) => u32::from_str_radix(id.trim_start_matches("0x"), 16)?,
        None => 0x0000_0001,
    };
    let max_topics: u32 = args.get(3).and_then(|s| s.parse().ok()).unwrap_or(u32::MAX);

    let transport = CanTransport::new(interface, can_id)?;
    let (mut out_buf, mut in_buf) = ([0u8; OUT_SIZE], [0u8; IN_SIZE]);
    let mut session = Session::new(transport, 0xAAAA_BBBB);
    session.create_session()?;
    let out = session.create_output_reliable_stream(&mut out_buf, STREAM_HISTORY)?;
    session.create_input_reliable_stream(&mut in_buf, STREAM_HISTORY)?;

    let participant = object_id(0x01, ObjectKind::Participant);
    let topic = object_id(0x01, ObjectKind::Topic);
    let publisher = object_id(0x01, ObjectKind::Publisher);
    let writer = object_id(0x01, ObjectKind::DataWriter);
    let requests = [
        session.buffer_create_participant_bin(out, participant, 0, None, REPLACE)?,
        session.buffer_create_topic_bin(out, topic, participant, "HelloWorldTopic", "HelloWorld", REPLACE)?,
        session.buffer_create_publisher_bin(out, publisher, participant, REPLACE)?,
        session.buffer_create_datawriter_bin(out, writer, publisher, topic, QoS::default(), REPLACE)?,
    ];
    let mut status = [0u8; 4];
    if !session.run_session_until_all_status(3000, &requests, &mut status)? {
        println!("Error at create entities: {status:?}");
        std::process::exit(1);
    }

    let mut count = 0u32;
    while count < max_topics {
        let sample = HelloWorld { index: count, message: "Hello DDS world!" };
        let size = serde_cdr::serialized_size(&sample)?;
        match session.prepare_output_stream(out, writer, size) {
            Ok(mut prepared) => {
                serde_cdr::to_slice(&sample, prepared.buffer())?;
                count += 1;
            }
            // History full: the agent has not acknowledged yet; run the session and retry.
            Err(Error::WouldBlock) => {}
            Err(e) => return Err(e.into()),
        }
        if session.run_session_time(1000)? {
            println!("Send topic: {}, id: {}", sample.message, sample.index);
        }
    }
    session.delete_session()?;
    Ok(())
}

#[cfg(not(all(target_os = "linux", feature = "can")))]
fn main() {
    println!("CAN FD needs Linux SocketCAN and the `can` feature");
}
