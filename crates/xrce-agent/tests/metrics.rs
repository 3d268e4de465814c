//! `--metrics` over real HTTP (issue 22): the counters follow known traffic, parsed by a Prometheus text
//! parser other than the encoder; hostile HTTP clients get bounded treatment and never stop the agent.

use std::io::{Read, Write};
use std::net::{SocketAddr, TcpListener, TcpStream};
use std::time::{Duration, Instant};

use xrce_agent::agent::AgentInstance;
use xrce_client::prelude::*;

/// An agent on a free UDP port, `-m ced`, with `--metrics` on a free port and `extra` arguments.
fn agent(extra: &[&str]) -> AgentInstance {
    let mut args = vec!["xrce-agent", "udp4", "-p", "0", "-m", "ced", "-v", "0", "--metrics", "127.0.0.1:0"];
    args.extend_from_slice(extra);
    AgentInstance::create(args).expect("agent starts")
}

/// Sends `request` and returns the whole answer (the server closes after one).
fn http(addr: SocketAddr, request: &[u8]) -> String {
    let mut s = TcpStream::connect(addr).expect("connect");
    s.set_read_timeout(Some(Duration::from_secs(10))).unwrap();
    s.write_all(request).expect("send");
    let mut answer = Vec::new();
    s.read_to_end(&mut answer).expect("answer");
    String::from_utf8(answer).expect("text")
}

/// `GET /metrics`, parsed.
fn scrape(addr: SocketAddr) -> prometheus_parse::Scrape {
    let answer = http(addr, b"GET /metrics HTTP/1.1\r\nHost: test\r\n\r\n");
    let (head, body) = answer.split_once("\r\n\r\n").expect("head and body");
    assert!(head.starts_with("HTTP/1.1 200"), "{head}");
    assert!(head.contains("Content-Type: text/plain; version=0.0.4"), "{head}");
    prometheus_parse::Scrape::parse(body.lines().map(|l| Ok(l.to_owned()))).expect("Prometheus text")
}

/// The value of `name` with `labels` (all of them must match), if the scrape has it.
fn value(scrape: &prometheus_parse::Scrape, name: &str, labels: &[(&str, &str)]) -> Option<f64> {
    scrape.samples.iter().find(|s| s.metric == name && labels.iter().all(|(k, v)| s.labels.get(k) == Some(*v))).map(
        |s| match s.value {
            prometheus_parse::Value::Counter(v)
            | prometheus_parse::Value::Gauge(v)
            | prometheus_parse::Value::Untyped(v) => v,
            _ => f64::NAN,
        },
    )
}

/// Scrapes until `pred` holds (the loop publishes a snapshot every second); the last scrape.
fn scrape_until(
    addr: SocketAddr,
    what: &str,
    pred: impl Fn(&prometheus_parse::Scrape) -> bool,
) -> prometheus_parse::Scrape {
    let end = Instant::now() + Duration::from_secs(20);
    loop {
        let s = scrape(addr);
        if pred(&s) {
            return s;
        }
        assert!(Instant::now() < end, "never saw {what}: {:?}", s.samples);
        std::thread::sleep(Duration::from_millis(100));
    }
}

const KEY: u32 = 0x1122_3344;

/// A client that publishes `samples` reliable samples and waits until the agent acknowledged them all,
/// then returns its session (alive: dropping it stops its traffic without deleting it).
fn publish<'a>(
    agent: SocketAddr,
    samples: u32,
    out: &'a mut [u8],
    inp: &'a mut [u8],
) -> Session<'a, UdpTransport, StdClock> {
    let transport = UdpTransport::new(IpProtocol::V4, "127.0.0.1", &agent.port().to_string()).unwrap();
    let mut session = Session::new(transport, KEY);
    session.create_session().expect("session");
    let stream = session.create_output_reliable_stream(out, 8).unwrap();
    session.create_input_reliable_stream(inp, 8).unwrap();
    let participant = object_id(1, ObjectKind::Participant);
    let topic = object_id(1, ObjectKind::Topic);
    let publisher = object_id(1, ObjectKind::Publisher);
    let writer = object_id(1, ObjectKind::DataWriter);
    let requests = [
        session.buffer_create_participant_xml(stream, participant, 0, "<dds><participant/></dds>", REPLACE).unwrap(),
        session
            .buffer_create_topic_xml(
                stream,
                topic,
                participant,
                "<dds><topic><name>t</name><dataType>T</dataType></topic></dds>",
                REPLACE,
            )
            .unwrap(),
        session.buffer_create_publisher_xml(stream, publisher, participant, "", REPLACE).unwrap(),
        session
            .buffer_create_datawriter_xml(
                stream,
                writer,
                publisher,
                "<dds><data_writer><topic><name>t</name><dataType>T</dataType></topic></data_writer></dds>",
                REPLACE,
            )
            .unwrap(),
    ];
    let mut status = [0u8; 4];
    assert!(session.run_session_until_all_status(2000, &requests, &mut status).unwrap(), "entities: {status:?}");
    let mut sent = 0;
    while sent < samples {
        match session.buffer_topic(stream, writer, &sent.to_le_bytes()) {
            Ok(_) => sent += 1,
            Err(Error::WouldBlock) => {}
            Err(e) => panic!("write: {e}"),
        }
        session.run_session_time(0).unwrap();
    }
    assert!(session.run_session_until_confirm_delivery(5000).unwrap(), "all acknowledged");
    session
}

#[test]
fn counters_follow_known_traffic_and_a_timed_out_client_leaves() {
    let instance = agent(&["--client-timeout", "1"]);
    let metrics = instance.metrics_addr().expect("metrics server");
    let udp = instance.local_addr().unwrap();
    let before = scrape(metrics);
    assert_eq!(value(&before, "xrce_agent_clients", &[]), Some(0.0));
    assert_eq!(value(&before, "xrce_agent_samples_received_total", &[]), Some(0.0));

    let (mut out, mut inp) = (vec![0u8; 8 * 512], vec![0u8; 8 * 512]);
    let session = publish(udp, 1000, &mut out, &mut inp);
    let client = [("key", "11223344"), ("transport", "udp4")];
    let s =
        scrape_until(metrics, "1,000 samples", |s| value(s, "xrce_agent_samples_received_total", &[]) == Some(1000.0));
    assert_eq!(value(&s, "xrce_agent_clients", &[]), Some(1.0));
    assert_eq!(value(&s, "xrce_agent_client_samples_received_total", &client), Some(1000.0));
    assert_eq!(value(&s, "xrce_agent_sample_bytes_received_total", &[]), Some(4000.0));
    assert_eq!(value(&s, "xrce_agent_client_entities", &[("key", "11223344"), ("kind", "datawriter")]), Some(1.0));
    assert_eq!(value(&s, "xrce_agent_clients_created_total", &[]), Some(1.0));
    assert!(value(&s, "xrce_agent_stream_messages_received_total", &[]).unwrap() >= 1000.0);
    assert_eq!(value(&s, "xrce_agent_clients_removed_total", &[("reason", "timeout")]), Some(0.0));

    // Silent from now on: probed, then removed after --client-timeout.
    drop(session);
    let s = scrape_until(metrics, "the client removed", |s| value(s, "xrce_agent_clients", &[]) == Some(0.0));
    assert_eq!(value(&s, "xrce_agent_clients_removed_total", &[("reason", "timeout")]), Some(1.0));
    assert_eq!(value(&s, "xrce_agent_client_samples_received_total", &client), None, "its series vanish");
    assert_eq!(value(&s, "xrce_agent_samples_received_total", &[]), Some(1000.0), "the agent's total stays");
    assert!(value(&s, "xrce_agent_liveness_probes_total", &[]).unwrap() >= 1.0, "it was probed first");
}

#[test]
fn anything_but_get_metrics_is_refused() {
    let instance = agent(&[]);
    let metrics = instance.metrics_addr().unwrap();
    let post = http(metrics, b"POST /metrics HTTP/1.1\r\nContent-Length: 0\r\n\r\n");
    assert!(post.starts_with("HTTP/1.1 405") && post.contains("Allow: GET"), "{post}");
    assert!(http(metrics, b"GET / HTTP/1.1\r\n\r\n").starts_with("HTTP/1.1 404"));
    assert!(http(metrics, b"GET /metricsx HTTP/1.1\r\n\r\n").starts_with("HTTP/1.1 404"));
    assert!(http(metrics, b"\x16\x03\x01 not http\r\n\r\n").starts_with("HTTP/1.1 400"));
}

#[test]
fn a_metrics_port_taken_is_an_error_naming_it() {
    let taken = TcpListener::bind("127.0.0.1:0").unwrap();
    let addr = taken.local_addr().unwrap().to_string();
    let args = ["xrce-agent", "udp4", "-p", "0", "-m", "ced", "-v", "0", "--metrics", addr.as_str()];
    let err = AgentInstance::create(args).expect_err("the port is taken").to_string();
    assert!(err.contains(&format!("metrics port {addr}")), "{err}");
}

#[test]
fn hostile_http_clients_neither_grow_the_server_nor_stop_scrapes_or_xrce() {
    let instance = agent(&[]);
    let metrics = instance.metrics_addr().unwrap();
    // 1,000 idle connections: the oldest are closed to let new ones in, and a scrape still answers.
    let idle: Vec<TcpStream> = (0..1000).map(|_| TcpStream::connect(metrics).expect("connect")).collect();
    // A request trickled a byte at a time, never finished.
    let mut trickle = TcpStream::connect(metrics).unwrap();
    for b in b"GET /met" {
        trickle.write_all(&[*b]).unwrap();
        std::thread::sleep(Duration::from_millis(20));
    }
    assert!(value(&scrape(metrics), "xrce_agent_clients", &[]).is_some(), "a scrape answers beside them");
    // A 1 MiB request line: refused once the bound is reached, without reading the rest.
    let mut huge = TcpStream::connect(metrics).unwrap();
    huge.set_read_timeout(Some(Duration::from_secs(10))).unwrap();
    let mut line = b"GET /".to_vec();
    line.resize(1 << 20, b'a');
    // The server may close before all is written: a failed write is the point.
    let _ = huge.write_all(&line);
    let mut answer = Vec::new();
    let _ = huge.read_to_end(&mut answer);
    assert!(String::from_utf8_lossy(&answer).starts_with("HTTP/1.1 431"), "{:?}", String::from_utf8_lossy(&answer));
    // The XRCE side never noticed: a client publishes and is counted.
    let (mut out, mut inp) = (vec![0u8; 8 * 512], vec![0u8; 8 * 512]);
    let _session = publish(instance.local_addr().unwrap(), 10, &mut out, &mut inp);
    scrape_until(metrics, "10 samples", |s| value(s, "xrce_agent_samples_received_total", &[]) == Some(10.0));
    drop(idle);
}

#[test]
fn a_trickled_request_is_closed_at_the_connection_timeout() {
    use std::sync::Arc;
    use xrce_agent::core::SnapshotBoard;
    use xrce_agent::metrics::{http::Limits, MetricsServer};
    let limits = Limits { connection_timeout: Duration::from_millis(300), ..Limits::default() };
    let server =
        MetricsServer::start_with("127.0.0.1:0".parse().unwrap(), Arc::new(SnapshotBoard::default()), limits).unwrap();
    let mut slow = TcpStream::connect(server.local_addr()).unwrap();
    slow.set_read_timeout(Some(Duration::from_secs(10))).unwrap();
    slow.write_all(b"GET /metr").unwrap();
    let mut buf = [0u8; 64];
    // Closed without an answer (0 bytes: end of stream), well before the read timeout.
    assert_eq!(slow.read(&mut buf).unwrap_or(0), 0);
    // No snapshot published on this board: the server says so.
    assert!(http(server.local_addr(), b"GET /metrics HTTP/1.1\r\n\r\n").starts_with("HTTP/1.1 503"));
}

/// A free loopback port for UDP and TCP both (bound and released).
fn free_port() -> u16 {
    loop {
        let tcp = TcpListener::bind("127.0.0.1:0").unwrap();
        let port = tcp.local_addr().unwrap().port();
        if std::net::UdpSocket::bind(("127.0.0.1", port)).is_ok() {
            return port;
        }
    }
}

#[test]
fn an_agent_from_a_config_file_labels_each_client_with_its_own_transport() {
    let (udp_port, tcp_port) = (free_port(), free_port());
    let text = format!(
        "middleware = \"ced\"\nverbose = 0\nmetrics = \"127.0.0.1:0\"\n\
         [[transport]]\nkind = \"udp4\"\nport = {udp_port}\n\
         [[transport]]\nkind = \"tcp4\"\nport = {tcp_port}\n"
    );
    let file = xrce_agent::config_file::parse(&text, std::path::Path::new("agent.toml")).expect("a valid file");
    let instance = AgentInstance::from_file(file).expect("agent starts");
    let metrics = instance.metrics_addr().expect("the config file's metrics key starts the server");

    let udp = UdpTransport::connect(([127, 0, 0, 1], udp_port).into()).expect("udp");
    let mut udp_client = Session::new(udp, 0x0000_0a01);
    udp_client.create_session().expect("UDP session");
    let tcp = TcpTransport::connect(([127, 0, 0, 1], tcp_port).into()).expect("tcp");
    let mut tcp_client = Session::new(tcp, 0x0000_0a02);
    tcp_client.create_session().expect("TCP session");

    let s = scrape_until(metrics, "both clients", |s| value(s, "xrce_agent_clients", &[]) == Some(2.0));
    let info = |key, transport| value(&s, "xrce_agent_client_info", &[("key", key), ("transport", transport)]);
    assert_eq!(info("00000a01", "udp4"), Some(1.0), "{:?}", s.samples);
    assert_eq!(info("00000a02", "tcp4"), Some(1.0), "{:?}", s.samples);
    assert_eq!(info("00000a01", "tcp4"), None, "one transport label per client");
    assert_eq!(info("00000a02", "udp4"), None, "one transport label per client");
}
