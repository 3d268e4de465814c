//! The TCP transport on 127.0.0.1 against a scripted agent thread: 2-byte little-endian length framing both
//! ways, messages split over several reads, out-of-session ping, session creation, deletion, and a closed
//! connection reported as such.

mod common;

use std::io::{Read, Write};
use std::net::{TcpListener, TcpStream};
use std::time::Duration;
use xrce_client::prelude::*;
use xrce_client::TransportError;

const STATUS_AGENT: &str = "81 00 00 00 04 01 0B 00 00 00 58 52 43 45 01 00 01 0F 00";
const PONG: &str = "80 00 00 00 06 01 1C 00 00 0A FF FD 00 01 01 0D 58 52 43 45 01 00 01 0F 00 01 0D 00 01 00 00 00 \
                    00 00 00 00";
const DELETE_STATUS: &str = "81 00 00 00 05 01 06 00 00 02 FF FE 00 00";

fn read_message(s: &mut TcpStream) -> Option<Vec<u8>> {
    let mut len = [0u8; 2];
    s.read_exact(&mut len).ok()?;
    let mut msg = vec![0u8; usize::from(u16::from_le_bytes(len))];
    s.read_exact(&mut msg).ok()?;
    Some(msg)
}

/// Writes one framed message a byte at a time, so the client's decoder sees it in pieces.
fn write_message(s: &mut TcpStream, msg: &[u8]) {
    let len = u16::try_from(msg.len()).unwrap().to_le_bytes();
    for b in len.iter().chain(msg) {
        s.write_all(&[*b]).unwrap();
        s.flush().unwrap();
    }
}

#[test]
fn tcp_session_over_loopback() {
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let port = listener.local_addr().unwrap().port();
    let agent = std::thread::spawn(move || {
        let (mut s, _) = listener.accept().unwrap();
        s.set_nodelay(true).unwrap();
        s.set_read_timeout(Some(Duration::from_secs(10))).unwrap();
        let mut kinds = Vec::new();
        while let Some(msg) = read_message(&mut s) {
            kinds.push(msg[4]);
            match msg[4] {
                0x00 => write_message(&mut s, &common::hex(STATUS_AGENT)),
                0x02 => write_message(&mut s, &common::hex(PONG)),
                0x03 => {
                    write_message(&mut s, &common::hex(DELETE_STATUS));
                    break;
                }
                _ => {}
            }
        }
        kinds
    });

    let mut transport = TcpTransport::new(IpProtocol::V4, "127.0.0.1", &port.to_string()).unwrap();
    assert!(ping_agent_attempts(&mut transport, 1000, 3).unwrap());
    let mut session = Session::new(transport, 0xAAAA_BBBB);
    session.create_session().unwrap();
    assert!(session.delete_session().unwrap());
    let mut transport = session.into_transport();
    let kinds = agent.join().unwrap();
    assert_eq!(kinds, vec![0x02, 0x00, 0x03], "GET_INFO, CREATE_CLIENT, DELETE");
    // The agent hung up: the transport says so instead of reporting silence.
    let mut buf = [0u8; 64];
    assert_eq!(transport.recv(&mut buf, 1000), Err(TransportError::Closed));
}

#[test]
fn tcp_connect_to_nobody_fails() {
    let port = TcpListener::bind("127.0.0.1:0").unwrap().local_addr().unwrap().port(); // closed again at once
    assert!(TcpTransport::new(IpProtocol::V4, "127.0.0.1", &port.to_string()).is_err());
}

#[test]
fn tcp_recv_times_out_without_data() {
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let mut transport = TcpTransport::connect(listener.local_addr().unwrap()).unwrap();
    let _peer = listener.accept().unwrap();
    let mut buf = [0u8; 64];
    let start = std::time::Instant::now();
    assert_eq!(transport.recv(&mut buf, 100), Ok(None));
    assert!(start.elapsed() >= Duration::from_millis(90));
}
