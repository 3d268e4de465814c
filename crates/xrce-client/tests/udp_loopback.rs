//! The blocking session over a real UDP socket on 127.0.0.1, against a tiny scripted agent thread.

mod common;

use std::net::UdpSocket;
use xrce_client::prelude::*;

/// Answers CREATE_CLIENT, pings, DELETE, and acknowledges reliable messages with a STATUS per CREATE.
fn fake_agent() -> (std::net::SocketAddr, std::thread::JoinHandle<usize>) {
    let socket = UdpSocket::bind("127.0.0.1:0").unwrap();
    let addr = socket.local_addr().unwrap();
    let handle = std::thread::spawn(move || {
        let mut buf = [0u8; 1024];
        let mut status_seq = 0u16;
        let mut handled = 0;
        socket.set_read_timeout(Some(std::time::Duration::from_secs(5))).unwrap();
        while let Ok((n, from)) = socket.recv_from(&mut buf) {
            handled += 1;
            let msg = &buf[..n];
            match (msg[1], msg[4]) {
                (0, 0x00) => {
                    let reply = [0x81, 0, 0, 0, 4, 1, 11, 0, 0, 0, b'X', b'R', b'C', b'E', 1, 0, 1, 15, 0];
                    socket.send_to(&reply, from).unwrap();
                }
                (0, 0x02) => {
                    let mut pong = msg[..4].to_vec();
                    pong.extend(common::hex(
                        "06 01 1C 00 00 0A FF FD 00 01 01 0D 58 52 43 45 01 00 01 0F 00 01 0D 00 01 00 00 00 00 00 00 00",
                    ));
                    socket.send_to(&pong, from).unwrap();
                }
                (0, 0x03) => {
                    socket.send_to(&common::hex("81 00 00 00 05 01 06 00 00 02 FF FE 00 00"), from).unwrap();
                    break;
                }
                (0x80, _) => {
                    let seq = u16::from_le_bytes([msg[2], msg[3]]);
                    let [a, b] = seq.wrapping_add(1).to_le_bytes();
                    socket.send_to(&[0x81, 0, 0, 0, 0x0A, 1, 5, 0, a, b, 0, 0, 0x80], from).unwrap();
                    // A STATUS OK for every CREATE in the message.
                    let mut pos = 4;
                    while pos + 4 <= n {
                        let len = u16::from_le_bytes([msg[pos + 2], msg[pos + 3]]) as usize;
                        if msg[pos] == 0x01 {
                            let [s0, s1] = status_seq.to_le_bytes();
                            status_seq += 1;
                            let r = &msg[pos + 4..pos + 8];
                            let status = [0x81, 0x80, s0, s1, 5, 1, 6, 0, r[0], r[1], r[2], r[3], 0, 0];
                            socket.send_to(&status, from).unwrap();
                        }
                        pos = (pos + 4 + len + 3) & !3;
                    }
                }
                _ => {}
            }
        }
        handled
    });
    (addr, handle)
}

#[test]
fn blocking_session_over_udp_loopback() {
    let (addr, agent) = fake_agent();
    let mut transport = UdpTransport::connect(addr).unwrap();
    assert!(ping_agent_attempts(&mut transport, 500, 3).unwrap());
    let (mut out_buf, mut in_buf) = ([0u8; 2048], [0u8; 2048]);
    let mut session = Session::new(transport, 0xAAAA_BBBB);
    session.create_session().unwrap();
    assert!(session.ping_agent_session(500, 3).unwrap());
    let out = session.create_output_reliable_stream(&mut out_buf, 4).unwrap();
    session.create_input_reliable_stream(&mut in_buf, 4).unwrap();
    let participant = object_id(1, ObjectKind::Participant);
    let p = session.buffer_create_participant_ref(out, participant, 0, "participant", REPLACE).unwrap();
    let t =
        session.buffer_create_topic_ref(out, object_id(1, ObjectKind::Topic), participant, "topic", REPLACE).unwrap();
    let mut statuses = [0u8; 2];
    assert!(session.run_session_until_all_status(2000, &[p, t], &mut statuses).unwrap());
    assert_eq!(statuses, [STATUS_OK, STATUS_OK]);
    session.buffer_topic(out, object_id(1, ObjectKind::DataWriter), &[1, 2, 3, 4]).unwrap();
    assert!(session.run_session_until_confirm_delivery(2000).unwrap());
    assert!(session.delete_session().unwrap());
    assert!(agent.join().unwrap() >= 6);
}
