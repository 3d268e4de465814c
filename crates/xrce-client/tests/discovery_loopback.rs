//! Agent discovery with a unicast list on 127.0.0.1 (never multicast): scripted agents answer the discovery
//! GET_INFO with their locators, or with none; unreachable entries do not stop the search; the callback can.

mod common;

use std::net::{SocketAddr, UdpSocket};
use std::time::Duration;
use xrce_client::prelude::*;

/// INFO answering request `request` (big-endian id), agent available, with `locators` (IPv4, port).
fn info(request: [u8; 2], locators: &[([u8; 4], u16)]) -> Vec<u8> {
    let mut payload = vec![request[0], request[1], 0xFF, 0xFD, 0x00, 0x01];
    payload.extend(common::hex("01 0D 58 52 43 45 01 00 01 0F 00 01 0D 00 01 00 00 00"));
    payload.extend(u32::try_from(locators.len()).unwrap().to_le_bytes());
    for (address, port) in locators {
        payload.push(0x01); // medium locator
        payload.extend(address);
        payload.push(0); // port alignment
        payload.extend(port.to_le_bytes());
        while payload.len() % 4 != 0 {
            payload.push(0);
        }
    }
    let mut msg = vec![0x80, 0, 0, 0, 0x06, 0x01];
    msg.extend(u16::try_from(payload.len()).unwrap().to_le_bytes());
    msg.extend(payload);
    msg
}

/// An agent answering every GET_INFO with `locators`; returns its address.
fn agent(locators: Vec<([u8; 4], u16)>) -> SocketAddr {
    agent_on("127.0.0.1:0", locators)
}

/// The same, bound to `bind`.
fn agent_on(bind: &str, locators: Vec<([u8; 4], u16)>) -> SocketAddr {
    let socket = UdpSocket::bind(bind).unwrap();
    let addr = socket.local_addr().unwrap();
    socket.set_read_timeout(Some(Duration::from_secs(5))).unwrap();
    std::thread::spawn(move || {
        let mut buf = [0u8; 256];
        while let Ok((n, from)) = socket.recv_from(&mut buf) {
            if n >= 8 && buf[4] == 0x02 {
                let _ = socket.send_to(&info([buf[8], buf[9]], &locators), from);
            }
        }
    });
    addr
}

#[test]
fn discovery_reports_locators_of_every_listed_agent() {
    let a = agent(vec![([127, 0, 0, 1], 8888), ([10, 1, 2, 3], 8889)]);
    let b = agent(vec![]); // answered on its service port: reported at the address it answered from
    let unreachable = UdpSocket::bind("127.0.0.1:0").unwrap().local_addr().unwrap(); // closed at once
    let mut found = Vec::new();
    let stopped = discovery::discovery_agents(
        2,
        200,
        |agent| {
            found.push(agent);
            false
        },
        &[unreachable, a, b],
    )
    .unwrap();
    assert!(!stopped);
    found.sort();
    found.dedup();
    let mut expected: Vec<SocketAddr> = vec!["127.0.0.1:8888".parse().unwrap(), "10.1.2.3:8889".parse().unwrap(), b];
    expected.sort();
    assert_eq!(found, expected);
}

#[test]
fn discovery_callback_stops_the_search() {
    let a = agent(vec![([127, 0, 0, 1], 7777)]);
    let mut calls = 0;
    let start = std::time::Instant::now();
    let stopped = discovery::discovery_agents(
        10,
        1000,
        |_| {
            calls += 1;
            true
        },
        &[a],
    )
    .unwrap();
    assert!(stopped);
    assert_eq!(calls, 1);
    assert!(start.elapsed() < Duration::from_secs(2), "stopped at the first answer, not after 10 rounds");
}

#[test]
fn discovery_without_answers_runs_every_round() {
    let silent = UdpSocket::bind("127.0.0.1:0").unwrap();
    let start = std::time::Instant::now();
    let stopped = discovery::discovery_agents(3, 100, |_| true, &[silent.local_addr().unwrap()]).unwrap();
    assert!(!stopped);
    assert!(start.elapsed() >= Duration::from_millis(290));
    let mut buf = [0u8; 64];
    silent.set_read_timeout(Some(Duration::from_millis(100))).unwrap();
    let (n, _) = silent.recv_from(&mut buf).unwrap();
    assert_eq!(&buf[4..6], &[0x02, 0x01], "a GET_INFO");
    assert_eq!(&buf[8..10], &[0x00, 0x09], "with the discovery request id");
    assert_eq!(n, 16);
}

/// An IPv6 agent listed after an IPv4 address that never answers is found: both sockets are listened to
/// during the period (the IPv4 one used to be read until the deadline, the IPv6 one never).
#[test]
fn discovery_finds_an_ipv6_agent_beside_a_silent_ipv4_one() {
    if UdpSocket::bind("[::1]:0").is_err() {
        eprintln!("no IPv6 loopback here: skipped");
        return;
    }
    let silent = UdpSocket::bind("127.0.0.1:0").unwrap();
    let v6 = agent_on("[::1]:0", vec![]);
    let mut found = Vec::new();
    let stopped = discovery::discovery_agents(
        1,
        300,
        |agent| {
            found.push(agent);
            true
        },
        &[silent.local_addr().unwrap(), v6],
    )
    .unwrap();
    assert!(stopped, "the IPv6 agent answered within the period");
    assert_eq!(found, vec![v6]);
}
